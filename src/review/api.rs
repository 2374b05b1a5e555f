//! What the correction page asks of the run folder, as plain functions from a request to a
//! [`Reply`]: the segment list with flags, one segment's joints, its first frame as PNG, and
//! saving edited rectangles into `segments/NNN.toml` — atomically, the previous version kept in
//! `segments/history/NNN.K.toml`, the file written in the seed-file format exactly as a hand
//! edit would leave it (it reads back with [`crate::seed::read_seeds`]). The HTTP side is
//! [`super::serve`].

use super::boxes::{apply_boxes, BoxEdit};
use super::data::{is_segment_name, RunData, SEGMENTS_DIR};
use super::draw::png_bytes;
use super::reply::json_body;
pub use super::reply::Reply;
use crate::error::{Error, Result};
use crate::seed::{parse_seeds, to_toml};
use serde::Deserialize;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

/// Folder under `segments/` keeping every replaced version of a segment file.
pub const HISTORY_DIR: &str = "history";

/// A segment file that does not parse: its id and the message.
type Broken = (String, String);

/// Runs the resume of segment number `k` of the run folder and refreshes the review outputs,
/// returning a message for the page; stops at its next checkpoint (with
/// [`Error::Interrupted`]) once the flag is set. Supplied by the app (`app::serve`); without it
/// the page's button answers 501.
pub type ResumeFn = dyn Fn(&Path, u32, &AtomicBool) -> Result<String> + Send + Sync;

/// The run being corrected, and the first frames decoded so far (PNG bytes by frame).
pub struct Api {
    pub(super) data: RunData,
    pub(super) clip: PathBuf,
    frames: Mutex<BTreeMap<u64, Arc<Vec<u8>>>>,
    resume: Option<Box<ResumeFn>>,
    /// Any frame for the key editor: see [`super::keys_api`].
    pub(super) any_frame: super::frame_cache::FrameCache,
    /// The pose engine of the Detect button: see [`super::detect_api`].
    pub(super) detector: super::detect_api::Detector,
    /// What the page is writing now.
    writes: Writes,
}

/// The page's writes to the run folder. Saves (segment files, keys) wait for each other, as
/// they are short; a resume started from the page refuses them at once (409) while it runs, and
/// waits for those under way before it starts. (A `track` or `resume` of another process holds
/// the run folder's lock, which makes a save answer 409 too.)
#[derive(Default)]
struct Writes {
    saving: Mutex<()>,
    resuming: AtomicBool,
    /// Set when the server stops: a resume under way stops at its next checkpoint.
    stopping: AtomicBool,
}

/// Clears a flag when dropped.
struct Clear<'a>(&'a AtomicBool);

impl Drop for Clear<'_> {
    fn drop(&mut self) {
        self.0.store(false, Ordering::SeqCst);
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SaveBody {
    joints: Vec<BoxEdit>,
}

impl Api {
    /// Reads the run folder (and finds its clip: `clip`, else where run.toml says).
    pub fn open(run: &Path, clip: Option<&Path>, resume: Option<Box<ResumeFn>>) -> Result<Api> {
        let data = RunData::read(run)?;
        let clip = data.clip(clip)?;
        Ok(Api {
            data,
            clip,
            frames: Mutex::new(BTreeMap::new()),
            resume,
            any_frame: Default::default(),
            detector: Default::default(),
            writes: Writes::default(),
        })
    }

    /// The server is stopping: a resume under way stops at its next checkpoint, and no other
    /// starts.
    pub(super) fn stop_work(&self) {
        self.writes.stopping.store(true, Ordering::SeqCst);
    }

    /// True while a resume started from the page runs.
    pub(super) fn resuming(&self) -> bool {
        self.writes.resuming.load(Ordering::SeqCst)
    }

    /// The page's turn to save `what` (`edit`, `key`): at once 409 while a resume started from
    /// the page runs, else after the saves under way.
    pub(super) fn save_turn(&self, what: &str) -> std::result::Result<MutexGuard<'_, ()>, Reply> {
        let busy = || {
            Reply::error(
                409,
                format!(
                    "a resume started from this page is writing the run folder; your {what} is \
                     not saved: save it again once the resume is done"
                ),
            )
        };
        if self.resuming() {
            return Err(busy());
        }
        let turn = self.writes.saving.lock().unwrap_or_else(|e| e.into_inner());
        if self.resuming() {
            return Err(busy());
        }
        Ok(turn)
    }

    fn seg_dir(&self) -> PathBuf {
        self.data.dir.join(SEGMENTS_DIR)
    }

    /// The segment file of id `id` (digits only, and present), or a 404 reply.
    fn segment_path(&self, id: &str) -> std::result::Result<PathBuf, Reply> {
        let name = format!("{id}.toml");
        if !is_segment_name(&name) {
            return Err(Reply::error(
                404,
                format!("no segment {id:?}: ids are digits"),
            ));
        }
        let p = self.seg_dir().join(name);
        if !p.is_file() {
            return Err(Reply::error(
                404,
                format!("no segment {id}: {} does not exist", rel(&p)),
            ));
        }
        Ok(p)
    }

    /// Segment ids and first frames present now (files that parse), in number order, with the
    /// unreadable ones' messages.
    fn listing(&self) -> (Vec<(String, u64)>, Vec<Broken>) {
        let mut ok = Vec::new();
        let mut bad = Vec::new();
        let Ok(rd) = std::fs::read_dir(self.seg_dir()) else {
            return (ok, bad);
        };
        let mut names: Vec<String> = rd
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| is_segment_name(n))
            .collect();
        names.sort_by_key(|n| {
            (
                n.trim_end_matches(".toml").parse::<u64>().unwrap_or(0),
                n.clone(),
            )
        });
        for n in names {
            let id = n.trim_end_matches(".toml").to_owned();
            match crate::seed::read_seeds(&self.seg_dir().join(&n)) {
                Ok((s, _)) => ok.push((id, s.frame)),
                Err(e) => bad.push((id, e.to_string())),
            }
        }
        (ok, bad)
    }

    /// The frames worth keying next, as `report.md` names them (none while the run is not
    /// complete or its report cannot be made).
    fn suggested(&self) -> Vec<u64> {
        crate::run::report::for_run(
            &self.data.dir,
            &self.data.manifest,
            &self.data.seeds,
            crate::run::report::SUGGESTED,
        )
        .map(|(_, r)| r.suggested)
        .unwrap_or_default()
    }

    /// `GET /api/run`: frame size, joints, the segments with their flags, and the frames worth
    /// keying next.
    pub fn run_info(&self) -> Reply {
        let (segs, bad) = self.listing();
        let list: Vec<Value> = segs
            .iter()
            .enumerate()
            .map(|(k, (id, frame))| {
                let end = segs.get(k + 1).map_or(self.data.end(), |s| s.1).max(*frame);
                let f = self.data.flags(*frame, end);
                json!({
                    "id": id, "frame": frame, "end": end, "flagged": f.flagged(),
                    "flags": f.describe(), "low": f.low, "occluded": f.occluded, "lost": f.lost,
                    "min_score": f.min_score,
                })
            })
            .collect();
        let m = &self.data.manifest;
        let joints: Vec<Value> = self
            .data
            .seeds
            .joints
            .iter()
            .map(|j| json!({ "name": j.name, "parent": j.parent }))
            .collect();
        Reply::json(
            200,
            &json!({
                "run": self.data.dir.display().to_string(),
                "width": m.width, "height": m.height, "fps": m.fps, "frames": m.frames,
                "joints": joints, "segments": list,
                "broken": bad.iter().map(|(id, e)| json!({"id": id, "error": e})).collect::<Vec<_>>(),
                "resume": self.resume.is_some(),
                "seed_frame": m.seed_frame, "segment_len": m.segment_len,
                "first": self.data.first, "end": self.data.end(),
                "suggested": self.suggested(),
                "no_detect": self.no_detect(),
            }),
        )
    }

    /// `GET /api/segments/ID`: the segment file's frame, joints and text.
    pub fn segment(&self, id: &str) -> Reply {
        let path = match self.segment_path(id) {
            Ok(p) => p,
            Err(r) => return r,
        };
        let (seeds, text) = match crate::seed::read_seeds(&path) {
            Ok(s) => s,
            Err(e) => return Reply::error(409, format!("{e}; fix the file by hand first")),
        };
        let joints: Vec<Value> = seeds
            .joints
            .iter()
            .map(|j| {
                json!({
                    "name": j.name, "x": j.bbox.cx, "y": j.bbox.cy, "w": j.bbox.w, "h": j.bbox.h,
                    "angle": j.bbox.angle_rad, "parent": j.parent, "score": j.score,
                    "status": j.status,
                })
            })
            .collect();
        Reply::json(
            200,
            &json!({
                "id": id, "frame": seeds.frame, "file": rel(&path), "text": text,
                "width": self.data.manifest.width, "height": self.data.manifest.height,
                "joints": joints,
            }),
        )
    }

    /// `GET /api/segments/ID/frame.png`: the segment's first frame. The first request decodes
    /// the clip once up to the last segment, keeping every segment's first frame.
    pub fn frame_png(&self, id: &str) -> Reply {
        let path = match self.segment_path(id) {
            Ok(p) => p,
            Err(r) => return r,
        };
        let frame = match crate::seed::read_seeds(&path) {
            Ok((s, _)) => s.frame,
            Err(e) => return Reply::error(409, e.to_string()),
        };
        let mut cache = self.frames.lock().unwrap_or_else(|e| e.into_inner());
        if !cache.contains_key(&frame) {
            let mut want: Vec<u64> = self.listing().0.iter().map(|s| s.1).collect();
            want.push(frame);
            if let Err(e) = decode_frames(&self.clip, self.data.manifest.fps, &want, &mut cache) {
                return Reply::error(500, e.to_string());
            }
        }
        match cache.get(&frame) {
            Some(png) => Reply {
                status: 200,
                content_type: "image/png",
                body: png.as_ref().clone(),
            },
            None => Reply::error(
                404,
                format!(
                    "frame {frame} of segment {id} is beyond the clip {}",
                    self.clip.display()
                ),
            ),
        }
    }

    /// `POST /api/segments/ID` with `{"joints":[{"name","x","y","w","h","angle"}, …]}`: checks
    /// every rectangle, then writes the segment file (see the module doc).
    pub fn save(&self, id: &str, body: &[u8]) -> Reply {
        let path = match self.segment_path(id) {
            Ok(p) => p,
            Err(r) => return r,
        };
        let edit: SaveBody = match json_body(
            body,
            r#"{"joints": [{"name", "x", "y", "w", "h", "angle"}, …]}"#,
        ) {
            Ok(b) => b,
            Err(r) => return r,
        };
        // One writer at a time: while `track` or `resume` writes the run folder, a save could
        // be overwritten by it, so it is refused (the page keeps the edit to save again).
        let _turn = match self.save_turn("edit") {
            Ok(t) => t,
            Err(r) => return r,
        };
        let _lock = match crate::run::lock::RunLock::acquire(&self.data.dir, "serve (a save)") {
            Ok(l) => l,
            Err(e @ Error::RunFolder { .. }) => {
                return Reply::error(
                    409,
                    format!("{e}; your edit is not saved: save it again once that is done"),
                )
            }
            Err(e) => return Reply::error(500, format!("{e}; your edit is not saved")),
        };
        let (seeds, old_text) = match crate::seed::read_seeds(&path) {
            Ok(s) => s,
            Err(e) => return Reply::error(409, format!("{e}; fix the file by hand first")),
        };
        let mut joints = seeds.joints.clone();
        if let Err(r) = apply_boxes(&mut joints, &edit.joints, &rel(&path)) {
            return r;
        }
        let text = to_toml(seeds.frame, &joints, &leading_comment(&old_text));
        let (w, h) = (self.data.manifest.width, self.data.manifest.height);
        let check = parse_seeds(&text, &path)
            .and_then(|s| s.check_against_clip(&path, w, h, None).map(|_| s));
        if let Err(e) = check {
            return Reply::error(400, e.to_string());
        }
        if text == old_text {
            return Reply::json(
                200,
                &json!({ "saved": false, "file": rel(&path), "message": "unchanged" }),
            );
        }
        match write_with_history(&path, &old_text, &text) {
            Ok(prev) => Reply::json(
                200,
                &json!({ "saved": true, "file": rel(&path), "previous": rel(&prev) }),
            ),
            Err(e) => Reply::error(500, e.to_string()),
        }
    }

    /// `POST /api/segments/ID/resume`: resumes tracking from this segment, when the app supplies
    /// a resume; 501 otherwise. 409 while another resume from the page runs; 503 once the
    /// server is stopping (a resume under way then stops at its next checkpoint).
    pub fn resume(&self, id: &str) -> Reply {
        if let Err(r) = self.segment_path(id) {
            return r;
        }
        let Some(resume) = &self.resume else {
            return Reply::error(
                501,
                "this page cannot resume tracking: save your edits, then run \
                 `mocap2d resume RUN --segment K` from a terminal.",
            );
        };
        let k: u32 = id.parse().unwrap_or(0);
        let stopping = &self.writes.stopping;
        let stopped = || {
            Reply::error(
                503,
                format!(
                    "serve is stopping (Ctrl-C); the resume stopped at a checkpoint: carry on \
                     with `mocap2d resume {}`",
                    self.data.dir.display()
                ),
            )
        };
        if stopping.load(Ordering::SeqCst) {
            return Reply::error(503, "serve is stopping (Ctrl-C); no resume starts now");
        }
        if self.writes.resuming.swap(true, Ordering::SeqCst) {
            return Reply::error(
                409,
                "a resume started from this page is already running; wait for it to finish",
            );
        }
        let _done = Clear(&self.writes.resuming);
        // Saves under way finish first; later ones are refused until the resume is done.
        drop(self.writes.saving.lock().unwrap_or_else(|e| e.into_inner()));
        match resume(&self.data.dir, k, stopping) {
            Ok(msg) => Reply::json(200, &json!({ "resumed": true, "message": msg })),
            Err(Error::Interrupted) => stopped(),
            Err(e) if e.is_user_error() => Reply::error(400, e.to_string()),
            Err(e) => Reply::error(500, e.to_string()),
        }
    }
}

/// The `#` comment lines (and blank lines) a file starts with.
fn leading_comment(text: &str) -> String {
    text.lines()
        .take_while(|l| l.trim().is_empty() || l.trim_start().starts_with('#'))
        .filter(|l| !l.trim().is_empty())
        .collect::<Vec<_>>()
        .join("\n")
}

/// Keeps `old` as the next `segments/history/NNN.K.toml` and writes `new` over `path`, both
/// atomically. Returns the history file.
fn write_with_history(path: &Path, old: &str, new: &str) -> Result<PathBuf> {
    let dir = path
        .parent()
        .expect("a segment file is in segments/")
        .join(HISTORY_DIR);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let prev = (1..)
        .map(|k| dir.join(format!("{stem}.{k:03}.toml")))
        .find(|p| !p.exists())
        .expect("some number is free");
    crate::atomic::write(&prev, old.as_bytes())?;
    crate::atomic::write(path, new.as_bytes())?;
    Ok(prev)
}

/// A path as shown to the page: from the `segments` folder on.
fn rel(p: &Path) -> String {
    let parts: Vec<String> = p
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    match parts.iter().rposition(|c| c == SEGMENTS_DIR) {
        Some(i) => parts[i..].join("/"),
        None => p.display().to_string(),
    }
}

/// Decodes `clip` once up to the last of `want`, putting those frames into `cache` as PNG.
fn decode_frames(
    clip: &Path,
    fps: f64,
    want: &[u64],
    cache: &mut BTreeMap<u64, Arc<Vec<u8>>>,
) -> Result<()> {
    let last = want.iter().copied().max().unwrap_or(0);
    let mut source = crate::decode::open(clip, Some(fps))?;
    let mut f = 0u64;
    while f <= last {
        let Some(img) = source.next_frame()? else {
            break;
        };
        if want.contains(&f) && !cache.contains_key(&f) {
            cache.insert(f, Arc::new(png_bytes(&img)));
        }
        f += 1;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leading_comment_keeps_only_the_header() {
        let t = "# segment 3\n#\n# frames 10..20\n\nframe = 10\n# not this\n";
        assert_eq!(leading_comment(t), "# segment 3\n#\n# frames 10..20");
        assert_eq!(leading_comment("frame = 1\n"), "");
    }

    #[test]
    fn rel_starts_at_segments() {
        assert_eq!(
            rel(Path::new("/a/r.mocap/segments/history/003.001.toml")),
            "segments/history/003.001.toml"
        );
    }
}
