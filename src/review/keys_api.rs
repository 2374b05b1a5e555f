//! The correction page's keys on any frame (`RUN/keys.toml`, [`crate::run::keys`]):
//!
//! - `GET /api/frames/N`: the tracked joints of frame N (from `tracks.csv`, read again whenever
//!   it changes, so a resume shows) and which of them `keys.toml` keys there, with their keys;
//!   409 saying so while a resume (from the page or a terminal) replaces `tracks.csv`.
//! - `GET /api/frames/N/frame.png`: frame N of the clip. The clip is decoded from its start, or
//!   onward from the last frame asked for, so stepping forward is cheap; the last few frames are
//!   kept.
//! - `POST /api/keys` with `{"frame": N, "joints": {"name": [x, y], …}}`: sets those joints'
//!   key on frame N, keeping every other key (and that frame's other keyed joints); an empty
//!   `joints` removes frame N's key. Checked as `keys::read` checks the file (joint names,
//!   inside the frame, frame within the clip) → 400. Written while holding the run folder's lock
//!   (409 at once while `track` or `resume`, from a terminal or the page, holds it), atomically,
//!   and only when the keys change. Only
//!   that key's lines change ([`crate::run::keys::set_key`]): the user's comments, blank lines,
//!   the order and the writing of every other key and joint stay as they were.

use super::api::Api;
use super::reply::{json_body, Reply};
use crate::error::Error;
use crate::geom::Point;
use crate::run::keys::{self, Key};
use crate::run::TrackRow;
use serde::Deserialize;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::sync::Arc;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyBody {
    frame: u64,
    joints: BTreeMap<String, [f64; 2]>,
}

impl Api {
    pub(super) fn names(&self) -> Vec<String> {
        self.data
            .seeds
            .joints
            .iter()
            .map(|j| j.name.clone())
            .collect()
    }

    /// Frames in the clip, when the run knows.
    pub(super) fn clip_frames(&self) -> Option<u64> {
        Some(self.data.manifest.frames).filter(|&n| n > 0)
    }

    /// The segment (as `resume --segment K` counts them) holding frame `f`; the clip's last
    /// frame, when it opens a file of its own, belongs to the segment it closes.
    fn segment_number(&self, f: u64) -> Option<u64> {
        let m = &self.data.manifest;
        let plan = crate::run::segments::Plan {
            seed_frame: m.seed_frame,
            len: m.segment_len,
        };
        let k = (m.segment_len > 0).then(|| plan.segment_of(f))?;
        Some(match self.clip_frames() {
            Some(n) => k.min(plan.count(n).saturating_sub(1)),
            None => k,
        })
    }

    /// The segment to resume from for a key on frame `f`: the one before the segment holding it
    /// ([`crate::run::segments::Plan::resume_for_key`]).
    fn resume_number(&self, f: u64) -> Option<u64> {
        self.segment_number(f).map(|k| k.saturating_sub(1))
    }

    /// `tracks.csv` now (read again when its time or size has changed).
    pub(super) fn tracks(&self) -> crate::error::Result<Arc<Vec<TrackRow>>> {
        let path = self.data.dir.join("tracks.csv");
        let meta = std::fs::metadata(&path).map_err(|e| Error::io(&path, e))?;
        let stamp = (meta.modified().ok(), meta.len());
        let mut cache = self
            .any_frame
            .tracks
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        if let Some((t, n, rows)) = cache.as_ref() {
            if (*t, *n) == stamp {
                return Ok(rows.clone());
            }
        }
        let rows = Arc::new(crate::run::tracks::read_tracks(&path)?);
        *cache = Some((stamp.0, stamp.1, rows.clone()));
        Ok(rows)
    }

    /// `GET /api/frames/N`.
    pub fn frame_info(&self, n: &str) -> Reply {
        let Ok(f) = n.parse::<u64>() else {
            return Reply::error(404, format!("no frame {n:?}: frames are numbers"));
        };
        if self.resuming() {
            return Reply::json(
                409,
                &json!({
                    "error": "a resume started from this page is tracking the run again; the \
                              frame shows once it is done",
                    "resuming": true,
                }),
            );
        }
        let rows = match self.tracks() {
            Ok(r) => r,
            Err(e) => return self.no_tracks(e),
        };
        let joints: Vec<Value> = rows
            .iter()
            .filter(|r| r.frame == f)
            .map(|r| json!({ "name": r.joint, "x": r.x, "y": r.y, "status": r.status }))
            .collect();
        if joints.is_empty() {
            return Reply::error(
                404,
                format!("frame {f} has no tracked joints in tracks.csv"),
            );
        }
        let names = self.names();
        let m = &self.data.manifest;
        let (mut keyed, mut keys_at, mut keys_error) = (Vec::new(), json!({}), Value::Null);
        match keys::read(&self.data.dir, &names, m.width, m.height, None) {
            Ok(all) => {
                if let Some(k) = all.iter().find(|k| k.frame == f) {
                    for (name, p) in names.iter().zip(&k.joints) {
                        if let Some(p) = p {
                            keyed.push(name.clone());
                            keys_at[name] = json!([p.x, p.y]);
                        }
                    }
                }
            }
            Err(e) => keys_error = json!(e.to_string()),
        }
        Reply::json(
            200,
            &json!({
                "frame": f, "joints": joints, "keyed": keyed, "keys": keys_at,
                "keys_error": keys_error, "segment": self.segment_number(f),
                "resume_from": self.resume_number(f),
            }),
        )
    }

    /// The reply when `tracks.csv` cannot be read (`e`): 409 while another process writes the
    /// run folder (a `resume` from a terminal replaces `tracks.csv`), naming it, or when it is
    /// missing (saying how to track it again); else 500.
    pub(super) fn no_tracks(&self, e: Error) -> Reply {
        let lock = self.data.dir.join(crate::run::lock::LOCK_FILE);
        let holder = std::fs::read_to_string(&lock).unwrap_or_default();
        let holder = holder.trim();
        if holder.is_empty() {
            let missing = matches!(&e, Error::Io { error, .. }
                if error.kind() == std::io::ErrorKind::NotFound);
            if missing {
                return Reply::error(
                    409,
                    format!(
                        "{e}; the run has no tracks now (a resume stopped before writing them?): \
                         `mocap2d resume {}` tracks it again",
                        self.data.dir.display()
                    ),
                );
            }
            return Reply::error(500, e.to_string());
        }
        Reply::json(
            409,
            &json!({
                "error": format!(
                    "{holder} is writing this run folder (tracks.csv is being replaced); the \
                     frame shows once it is done. If no mocap2d is running any more, `mocap2d \
                     resume {}` finishes the run",
                    self.data.dir.display()
                ),
                "resuming": true,
            }),
        )
    }

    /// `GET /api/frames/N/frame.png`.
    pub fn any_frame_png(&self, n: &str) -> Reply {
        self.any_frame
            .png(&self.clip, Some(self.data.manifest.fps), n)
    }

    /// `POST /api/keys` (see the module doc).
    pub fn save_key(&self, body: &[u8]) -> Reply {
        let edit: KeyBody = match json_body(body, r#"{"frame": N, "joints": {"name": [x, y], …}}"#)
        {
            Ok(b) => b,
            Err(r) => return r,
        };
        let names = self.names();
        let m = &self.data.manifest;
        let (w, h) = (m.width, m.height);
        if let Some(n) = self.clip_frames().filter(|&n| edit.frame >= n) {
            return Reply::error(
                400,
                format!(
                    "frame {}, but the clip has {n} frames (0 to {})",
                    edit.frame,
                    n - 1
                ),
            );
        }
        let mut given = vec![None; names.len()];
        for (name, &[x, y]) in &edit.joints {
            let Some(j) = names.iter().position(|n| n == name) else {
                return Reply::error(
                    400,
                    format!(
                        "joint {name:?}: no such joint in this run; its joints are {}",
                        names.join(", ")
                    ),
                );
            };
            let inside = x.is_finite()
                && y.is_finite()
                && x >= -0.5
                && y >= -0.5
                && x <= w as f64 - 0.5
                && y <= h as f64 - 0.5;
            if !inside {
                return Reply::error(
                    400,
                    format!("joint {name:?}: ({x}, {y}) lies outside the {w}×{h} frame"),
                );
            }
            given[j] = Some(Point::new(x as f32, y as f32));
        }
        // One writer at a time, as for segment files: refused while `track` or `resume` writes.
        let _turn = match self.save_turn("key") {
            Ok(t) => t,
            Err(r) => return r,
        };
        let _lock = match crate::run::lock::RunLock::acquire(&self.data.dir, "serve (a key)") {
            Ok(l) => l,
            Err(e @ Error::RunFolder { .. }) => {
                return Reply::error(
                    409,
                    format!("{e}; your key is not saved: save it again once that is done"),
                )
            }
            Err(e) => return Reply::error(500, format!("{e}; your key is not saved")),
        };
        let path = keys::path(&self.data.dir);
        let old_text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
            Err(e) => return Reply::error(500, Error::io(&path, e).to_string()),
        };
        let frames = self.clip_frames();
        let mut all = match keys::parse(&old_text, &path, &names, w, h, frames) {
            Ok(k) => k,
            Err(e) => return Reply::error(409, format!("{e}; fix keys.toml by hand first")),
        };
        let before = all.clone();
        let at = all.iter().position(|k| k.frame == edit.frame);
        if edit.joints.is_empty() {
            if let Some(i) = at {
                all.remove(i);
            }
        } else {
            let i = at.unwrap_or_else(|| {
                all.push(Key {
                    frame: edit.frame,
                    joints: vec![None; names.len()],
                });
                all.len() - 1
            });
            for (slot, p) in all[i].joints.iter_mut().zip(&given) {
                if p.is_some() {
                    *slot = *p;
                }
            }
            all.sort_by_key(|k| k.frame);
        }
        // The file's own text with only this key changed: its comments and layout stay.
        let text = if all == before {
            old_text.clone()
        } else {
            match keys::set_key(&old_text, &path, &names, edit.frame, &given) {
                Ok(t) => t,
                Err(e) => return Reply::error(409, format!("{e}; your key is not saved")),
            }
        };
        match keys::parse(&text, &path, &names, w, h, frames) {
            Ok(back) if back == all => {}
            Ok(_) => {
                return Reply::error(
                    500,
                    "keys.toml as edited does not read back to the keys meant; your key is not \
                     saved",
                )
            }
            Err(e) => return Reply::error(400, e.to_string()),
        }
        let keyed: Vec<&String> = all
            .iter()
            .find(|k| k.frame == edit.frame)
            .map(|k| {
                names
                    .iter()
                    .zip(&k.joints)
                    .filter(|(_, p)| p.is_some())
                    .map(|(n, _)| n)
                    .collect()
            })
            .unwrap_or_default();
        let segment = self.segment_number(edit.frame);
        let resume_from = self.resume_number(edit.frame);
        let command = resume_from
            .map(|k| format!("mocap2d resume {} --segment {k}", self.data.dir.display()));
        let answer = |saved: bool| {
            json!({
                "saved": saved, "file": "keys.toml", "frame": edit.frame, "keyed": keyed,
                "segment": segment, "resume_from": resume_from, "command": command,
            })
        };
        if text == old_text {
            return Reply::json(200, &answer(false));
        }
        // The file is read under the lock; a hand edit landing since then is kept, not lost.
        let changed = || Ok(std::fs::read_to_string(&path).unwrap_or_default() != old_text);
        match crate::atomic::write_unless(&path, text.as_bytes(), changed) {
            Ok(true) => Reply::json(200, &answer(true)),
            Ok(false) => Reply::error(
                409,
                "keys.toml changed while saving; your key is not saved: reload and save again",
            ),
            Err(e) => Reply::error(500, e.to_string()),
        }
    }
}
