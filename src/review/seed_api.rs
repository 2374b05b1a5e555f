//! The seeding page of a bare clip, `mocap2d serve CLIP --skeleton SKELETON.toml --seeds-out
//! SEEDS.toml` (docs/guide.md, "serve"): the joints of a skeleton file are placed by hand on any
//! frame and saved as the clip's first seed file.
//!
//! - `GET /api/run`: the clip (size, frames when stated), the joints to place with their
//!   rectangles (as last saved, else the skeleton's), the seed file to write and whether this
//!   page has saved it.
//! - `GET /api/frames/N/frame.png`: frame N of the clip (as on the correction page).
//! - `POST /api/seeds` with `{"frame": N, "joints": [{"name", "x", "y", "w", "h"}, …]}`: every
//!   joint of the skeleton, once. Checked as `track --seeds` checks a seed file (rectangles
//!   inside the frame, sizes at least 5 px, frame within the clip) → 400; then written
//!   atomically in the seed-file format with `frame = N` and the skeleton's parents. The file is
//!   never overwritten unless it holds what this page last wrote there: the first save refuses
//!   (409) when the file has appeared since the start, and a later one when it was changed by
//!   hand.
//! - `POST /api/frames/N/detect`: the pose network's proposal of the joints on frame N, written
//!   nowhere (see [`detect`]); `GET /api/run` says in `no_detect` why a skeleton gets none.
//! - `POST /api/seeds/track`: runs `mocap2d track CLIP --seeds SEEDS.toml` when the app supplies
//!   it (501 otherwise), once the seeds are saved (409 before).

mod detect;

use super::boxes::{apply_boxes, BoxEdit};
use super::detect_api::Detector;
use super::frame_cache::FrameCache;
use super::reply::{json_body, Reply};
use super::serve::{page_asset, path_parts, Pages};
use crate::error::{Error, Result};
use crate::seed::{parse_seeds, read_seeds, to_toml, Seeds, MIN_BOX_PX};
use serde::Deserialize;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// Tracks the clip (first path) from the seed file (second path), returning a message for the
/// page; stops at its next checkpoint (with [`Error::Interrupted`]) once the flag is set.
/// Supplied by the app (`app::serve`); without it the page's button answers 501.
pub type TrackFn = dyn Fn(&Path, &Path, &AtomicBool) -> Result<String> + Send + Sync;

/// A clip to seed: the joints to place, where to save them, and the text saved so far.
pub struct SeedApi {
    clip: PathBuf,
    skeleton: PathBuf,
    out: PathBuf,
    /// The skeleton's joints, their rectangles fitted into the frame.
    seeds: Seeds,
    width: u32,
    height: u32,
    /// Frames in the clip, when its file states it.
    frames: Option<u64>,
    /// The frame the page opens on: the skeleton file's `frame`, when in the clip.
    first: u64,
    cache: FrameCache,
    /// What this page last wrote to `out`.
    written: Mutex<Option<String>>,
    track: Option<Box<TrackFn>>,
    /// True while the page's track runs: saves are refused (409) meanwhile.
    tracking: AtomicBool,
    /// Set when the server stops: a track under way stops at its next checkpoint.
    stopping: AtomicBool,
    /// The pose engine of the page's Detect.
    detector: Detector,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SeedBody {
    frame: u64,
    joints: Vec<BoxEdit>,
}

impl SeedApi {
    /// Checks the start: `out` must not exist (and its folder must), `skeleton` must be a seed
    /// file, `clip` a clip. Joints outside this clip's frame (a seed file of another clip) are
    /// scaled and moved, together, into it.
    pub fn open(
        clip: &Path,
        skeleton: &Path,
        out: &Path,
        track: Option<Box<TrackFn>>,
    ) -> Result<SeedApi> {
        if out.exists() {
            return Err(Error::Usage(format!(
                "--seeds-out {}: the file exists and may hold your work; serve never overwrites \
                 a seed file: choose another name, or give this one as --skeleton to start from \
                 its rectangles",
                out.display()
            )));
        }
        let dir = out.parent().filter(|d| !d.as_os_str().is_empty());
        if dir.is_some_and(|d| !d.is_dir()) {
            return Err(Error::Usage(format!(
                "--seeds-out {}: the folder {} does not exist; create it or choose another path",
                out.display(),
                dir.map(Path::display).expect("checked above")
            )));
        }
        if clip.join("run.toml").is_file() {
            return Err(Error::Usage(format!(
                "{}: this is a run folder; --seeds-out places the first seeds on a clip: give \
                 the clip (or drop --seeds-out and --skeleton to correct this run)",
                clip.display()
            )));
        }
        let (mut seeds, _) = read_seeds(skeleton)?;
        let source = crate::decode::open(clip, None)?;
        let info = source.info();
        let (width, height, frames) = (info.width, info.height, info.stated_frames);
        fit_into(&mut seeds, width, height);
        seeds.check_against_clip(skeleton, width, height, None)?;
        let first = Some(seeds.frame)
            .filter(|&f| frames.is_none_or(|n| f < n))
            .unwrap_or(0);
        Ok(SeedApi {
            clip: clip.to_owned(),
            skeleton: skeleton.to_owned(),
            out: out.to_owned(),
            seeds,
            width,
            height,
            frames,
            first,
            cache: FrameCache::default(),
            written: Mutex::new(None),
            track,
            tracking: AtomicBool::new(false),
            stopping: AtomicBool::new(false),
            detector: Detector::default(),
        })
    }

    /// The command that tracks from the saved seeds.
    fn command(&self) -> String {
        format!(
            "mocap2d track {} --seeds {}",
            shell_arg(&self.clip),
            shell_arg(&self.out)
        )
    }

    fn saved(&self) -> bool {
        self.written
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .is_some()
    }

    /// `GET /api/run`: the joints and frame as last saved from the page, else the skeleton's.
    fn run_info(&self) -> Reply {
        let saved = self
            .written
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_deref()
            .and_then(|t| parse_seeds(t, &self.out).ok());
        let (seeds, frame) = match &saved {
            Some(s) => (s, s.frame),
            None => (&self.seeds, self.first),
        };
        let joints: Vec<Value> = seeds
            .joints
            .iter()
            .map(|j| {
                let b = &j.bbox;
                json!({
                    "name": j.name, "parent": j.parent, "x": b.cx, "y": b.cy, "w": b.w, "h": b.h,
                    "angle": b.angle_rad,
                })
            })
            .collect();
        Reply::json(
            200,
            &json!({
                "mode": "seed", "run": self.clip.display().to_string(),
                "file": self.out.display().to_string(),
                "skeleton": self.skeleton.display().to_string(),
                "width": self.width, "height": self.height, "frames": self.frames,
                "frame": frame, "joints": joints, "segments": [], "broken": [],
                "resume": false, "track": self.track.is_some(), "saved": saved.is_some(),
                "command": self.command(), "no_detect": self.no_detect(),
            }),
        )
    }

    /// `POST /api/seeds` (see the module doc).
    fn save(&self, body: &[u8]) -> Reply {
        let shape = r#"{"frame": N, "joints": [{"name", "x", "y", "w", "h"}, …]}"#;
        let edit: SeedBody = match json_body(body, shape) {
            Ok(b) => b,
            Err(r) => return r,
        };
        let mut joints = self.seeds.joints.clone();
        if let Err(r) = apply_boxes(
            &mut joints,
            &edit.joints,
            &self.skeleton.display().to_string(),
        ) {
            return r;
        }
        for j in &mut joints {
            (j.score, j.status) = (None, None);
        }
        let header = format!(
            "Seeds placed with `mocap2d serve` on frame {} of {}; joints and parents from {}.\n\
             Track with: {}",
            edit.frame,
            self.clip.display(),
            self.skeleton.display(),
            self.command()
        );
        let text = to_toml(edit.frame, &joints, &header);
        let check = parse_seeds(&text, &self.out)
            .and_then(|s| s.check_against_clip(&self.out, self.width, self.height, self.frames));
        if let Err(e) = check {
            return Reply::error(400, e.to_string());
        }
        let mut written = self.written.lock().unwrap_or_else(|e| e.into_inner());
        // (Checked under the lock, which the track takes once, as it starts.)
        if self.tracking.load(Ordering::SeqCst) {
            return Reply::error(
                409,
                "tracking from the saved seeds is running; your seeds are not saved: save them \
                 again once it is done",
            );
        }
        let answer = |saved: bool| {
            json!({
                "saved": saved, "file": self.out.display().to_string(), "frame": edit.frame,
                "command": self.command(),
            })
        };
        if written.as_deref() == Some(text.as_str()) {
            return Reply::json(200, &answer(false));
        }
        // Never over a file this page did not write: one that appeared since the start, or a
        // hand edit of what it wrote.
        let keep_old = || {
            Ok(match written.as_deref() {
                None => self.out.exists(),
                Some(mine) => std::fs::read_to_string(&self.out).ok().as_deref() != Some(mine),
            })
        };
        match crate::atomic::write_unless(&self.out, text.as_bytes(), keep_old) {
            Ok(true) => {
                *written = Some(text);
                Reply::json(200, &answer(true))
            }
            Ok(false) => Reply::error(
                409,
                format!(
                    "{} was written by something else since this page started or saved it; it \
                     is not overwritten and your seeds are not saved: move it away and save \
                     again, or restart serve with another --seeds-out",
                    self.out.display()
                ),
            ),
            Err(e) => Reply::error(500, e.to_string()),
        }
    }

    /// `POST /api/seeds/track` (see the module doc).
    fn track(&self) -> Reply {
        let Some(track) = &self.track else {
            return Reply::error(
                501,
                format!(
                    "this page cannot track: run `{}` from a terminal",
                    self.command()
                ),
            );
        };
        if self.stopping.load(Ordering::SeqCst) {
            return Reply::error(503, "serve is stopping (Ctrl-C); no track starts now");
        }
        if self.tracking.swap(true, Ordering::SeqCst) {
            return Reply::error(
                409,
                "tracking is already running from this page; wait for it",
            );
        }
        struct Clear<'a>(&'a AtomicBool);
        impl Drop for Clear<'_> {
            fn drop(&mut self) {
                self.0.store(false, Ordering::SeqCst);
            }
        }
        let _done = Clear(&self.tracking);
        // Waits for a save under way.
        if !self.saved() {
            return Reply::error(
                409,
                "save the seeds first: tracking starts from the saved file",
            );
        }
        match track(&self.clip, &self.out, &self.stopping) {
            Ok(msg) => Reply::json(200, &json!({ "tracked": true, "message": msg })),
            Err(Error::Interrupted) => Reply::error(
                503,
                "serve is stopping (Ctrl-C); tracking stopped at a checkpoint: carry on with \
                 `mocap2d resume RUN`",
            ),
            Err(e) if e.is_user_error() => Reply::error(400, e.to_string()),
            Err(e) => Reply::error(500, e.to_string()),
        }
    }
}

impl Pages for SeedApi {
    fn stopping(&self) {
        self.stopping.store(true, Ordering::SeqCst);
    }

    fn answer(&self, method: &str, url: &str, body: &[u8]) -> Reply {
        let (path, parts) = path_parts(url);
        if let Some(r) = page_asset(method, path) {
            return r;
        }
        let get = method == "GET" || method == "HEAD";
        let post = method == "POST";
        match parts.as_slice() {
            ["", "api", "run"] if get => self.run_info(),
            ["", "api", "frames", n, "frame.png"] if get => self.cache.png(&self.clip, None, n),
            ["", "api", "seeds"] if post => self.save(body),
            ["", "api", "seeds", "track"] if post => self.track(),
            ["", "api", "frames", n, "detect"] if post => self.detect(n, body),
            ["", "api", "run"]
            | ["", "api", "frames", _, "frame.png" | "detect"]
            | ["", "api", "seeds"]
            | ["", "api", "seeds", "track"] => {
                Reply::error(405, format!("{method} is not allowed on {path}"))
            }
            _ => Reply::error(
                404,
                format!("no such page: {path} (this page seeds a clip; it has no run folder)"),
            ),
        }
    }
}

/// Scales and moves every rectangle of `seeds` together so that all lie inside a `width ×
/// height` frame, when one does not: the skeleton's extent is fitted into the middle 80 % of
/// the frame (never enlarged).
fn fit_into(seeds: &mut Seeds, width: u32, height: u32) {
    if seeds.joints.iter().all(|j| j.bbox.inside(width, height)) {
        return;
    }
    let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    for j in &seeds.joints {
        let b = &j.bbox;
        let (hw, hh) = (b.w as f32 / 2.0, b.h as f32 / 2.0);
        (x0, x1) = (x0.min(b.cx - hw), x1.max(b.cx + hw));
        (y0, y1) = (y0.min(b.cy - hh), y1.max(b.cy + hh));
    }
    let (w, h) = (width as f32, height as f32);
    let s = (0.8 * w / (x1 - x0).max(1.0))
        .min(0.8 * h / (y1 - y0).max(1.0))
        .min(1.0);
    let (mx, my) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let side = |v: u32, room: u32| {
        ((v as f32 * s).round() as u32)
            .max(MIN_BOX_PX)
            .min(room.saturating_sub(1).max(MIN_BOX_PX))
    };
    for j in &mut seeds.joints {
        let b = &mut j.bbox;
        b.cx = (w - 1.0) / 2.0 + (b.cx - mx) * s;
        b.cy = (h - 1.0) / 2.0 + (b.cy - my) * s;
        (b.w, b.h) = (side(b.w, width), side(b.h, height));
    }
}

/// A path as one shell word: as is when plain, else in single quotes.
fn shell_arg(p: &Path) -> String {
    let s = p.display().to_string();
    let plain = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+,:=@".contains(c));
    if plain {
        s
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_skeleton_larger_than_the_frame_is_fitted_inside() {
        let text = "frame = 3\n[[joint]]\nname = \"a\"\nx = 100\ny = 50\nw = 21\nh = 21\n\
                    [[joint]]\nname = \"b\"\nx = 900\ny = 650\nw = 21\nh = 21\nparent = \"a\"\n";
        let mut s = parse_seeds(text, Path::new("s.toml")).unwrap();
        fit_into(&mut s, 320, 240);
        assert!(s.joints.iter().all(|j| j.bbox.inside(320, 240)), "{s:?}");
        let (a, b) = (&s.joints[0].bbox, &s.joints[1].bbox);
        // Shape kept: b stays right of and below a, by the same ratio.
        assert!(((b.cx - a.cx) / (b.cy - a.cy) - 800.0 / 600.0).abs() < 1e-3);
        let mut t = s.clone();
        fit_into(&mut t, 320, 240);
        assert_eq!(s, t, "a skeleton that fits is left alone");
    }

    #[test]
    fn paths_are_quoted_for_the_shell_when_needed() {
        assert_eq!(shell_arg(Path::new("clips/a.mp4")), "clips/a.mp4");
        assert_eq!(shell_arg(Path::new("my clip.mp4")), "'my clip.mp4'");
        assert_eq!(shell_arg(Path::new("it's.mp4")), r"'it'\''s.mp4'");
    }
}
