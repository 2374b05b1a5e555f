//! Is a clip's work already done for the same inputs? A re-run of a batch (after a crash, or
//! with more clips) skips what its run folders show finished.
//!
//! `track` writes `seeds.toml` and `run.toml` first, then checkpoints every segment, and
//! joins `tracks.csv` and marks `run.toml` complete last, each file atomically: a complete
//! `run.toml` beside a `tracks.csv` means the run finished, an incomplete one is a checkpoint
//! that `resume` carries on from (a batch interrupted by Ctrl-C, or killed); `run.toml` says
//! with what inputs. `retarget` writes `retarget.toml` last, recording the target file's and
//! the tracks' hashes.

use crate::app::{TrackOptions, RETARGET_DIR};
use crate::run::{hash_clip, Manifest};
use std::path::Path;

/// The finished run in `run_dir`: complete, with its `tracks.csv`, for the same inputs (see
/// [`same_inputs`]).
pub fn finished_track(run_dir: &Path, opts: &TrackOptions) -> Option<Manifest> {
    if !run_dir.join("tracks.csv").is_file() {
        return None;
    }
    same_inputs(run_dir, opts).filter(|m| m.complete)
}

/// The first segment file of the run in `run_dir` (manifest `m`) edited since it was tracked
/// (its hash is not the one tracking last started from): an edit `resume` has not applied yet.
pub fn unapplied_edit(run_dir: &Path, m: &Manifest) -> Option<u64> {
    m.segment
        .iter()
        .enumerate()
        .take(m.tracked_segments as usize + 1)
        .find(|(k, rec)| {
            crate::run::segments::hash_file(&crate::run::segments::file_path(run_dir, *k as u64))
                .ok()
                .flatten()
                .is_some_and(|h| h != rec.tracked_from)
        })
        .map(|(k, _)| k as u64)
}

/// The unfinished run in `run_dir` (stopped by Ctrl-C, a kill or a crash) for the same inputs
/// (see [`same_inputs`]): `resume` carries it on from its last checkpoint.
pub fn unfinished_track(run_dir: &Path, opts: &TrackOptions) -> Option<Manifest> {
    same_inputs(run_dir, opts).filter(|m| !m.complete)
}

/// The manifest of the run in `run_dir`, when it was tracked by this version of mocap2d from a
/// clip with the same content (size and blake3), a seed file with the same bytes, the same
/// parameters, the same kind of background model (median or none) and the same frame rate.
/// `None` whenever any of that differs or cannot be read (the clip is then tracked again, which
/// reports any real problem).
fn same_inputs(run_dir: &Path, opts: &TrackOptions) -> Option<Manifest> {
    let m = Manifest::read(&run_dir.join("run.toml")).ok()?;
    let background_same = m.background.answers(&opts.background);
    let seeds = std::fs::read(&opts.seeds).ok()?;
    let same = m.tool == "mocap2d"
        && m.version == env!("CARGO_PKG_VERSION")
        && opts.dlc.is_none()
        && background_same
        && m.params == opts.params
        && m.seeds_blake3 == blake3::hash(&seeds).to_hex().to_string();
    if !same {
        return None;
    }
    let (bytes, blake3) = hash_clip(&opts.clip).ok()?;
    if bytes != m.clip.bytes || blake3 != m.clip.blake3 {
        return None;
    }
    let fps = match opts.fps {
        Some(f) => f,
        None => crate::decode::open(&opts.clip, None).ok()?.info().fps,
    };
    (fps == m.fps).then_some(m)
}

/// True when `run_dir/retarget/` holds a finished retarget, by this version, onto a target
/// file whose text hashes to `target_blake3`, from the run's current `tracks.csv`, with the
/// default options (no smoothing, no cartoon filter), as a batch makes it.
pub fn finished_retarget(run_dir: &Path, target_blake3: &str) -> bool {
    let dir = run_dir.join(RETARGET_DIR);
    if !dir.join("pose.csv").is_file() || !dir.join("bones.csv").is_file() {
        return false;
    }
    let Ok(m) = crate::retarget::files::read_manifest(&dir.join("retarget.toml")) else {
        return false;
    };
    let Ok(tracks) = std::fs::read(run_dir.join("tracks.csv")) else {
        return false;
    };
    m.version == env!("CARGO_PKG_VERSION")
        && m.target_blake3 == target_blake3
        && m.tracks_blake3 == blake3::hash(&tracks).to_hex().to_string()
        && m.smooth == "none"
        && m.cartoon_strength == 0.0
}
