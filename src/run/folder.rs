//! Housekeeping of a run folder around a (re)run: earlier results into `history/`, stale segment
//! files and temp files away, and the one rule that trumps the rest: a user's corrections are
//! never overwritten.

use crate::error::{Error, Result};
use crate::run::manifest::{Manifest, RUN_TOML};
use crate::run::segments::{hash_file, SEGMENTS_DIR};
use std::path::{Path, PathBuf};

/// The folder earlier `tracks.csv` (and `report.md`) are moved to before a rerun.
pub const HISTORY_DIR: &str = "history";

/// Segment files in `run_dir/segments` (`NNN.toml` and `NNN.csv`), as (index, extension, path),
/// sorted.
pub fn segment_files(run_dir: &Path) -> Result<Vec<(u64, String, PathBuf)>> {
    let dir = run_dir.join(SEGMENTS_DIR);
    let entries = match std::fs::read_dir(&dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::io(&dir, e)),
    };
    let mut out = Vec::new();
    for e in entries {
        let p = e.map_err(|e| Error::io(&dir, e))?.path();
        let (Some(stem), Some(ext)) = (
            p.file_stem().and_then(|s| s.to_str()),
            p.extension().and_then(|s| s.to_str()),
        ) else {
            continue;
        };
        if (ext == "toml" || ext == "csv") && stem.bytes().all(|b| b.is_ascii_digit()) {
            if let Ok(k) = stem.parse::<u64>() {
                out.push((k, ext.to_owned(), p));
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Fails if `run_dir` holds a segment file the user edited (its hash is not one `run.toml`
/// recorded), naming it: `track` would overwrite it.
pub fn check_no_corrections(run_dir: &Path) -> Result<()> {
    let files = segment_files(run_dir)?;
    if !files.iter().any(|(_, ext, _)| ext == "toml") {
        return Ok(());
    }
    let manifest = Manifest::read(&run_dir.join(RUN_TOML)).ok();
    for (k, ext, p) in files {
        if ext != "toml" {
            continue;
        }
        let written = manifest
            .as_ref()
            .and_then(|m| m.segment.get(k as usize))
            .map_or(&[][..], |r| r.written.as_slice());
        let h = hash_file(&p)?.unwrap_or_default();
        if !written.contains(&h) {
            return Err(Error::RunFolder {
                path: p,
                msg: format!(
                    "a correction (edited since mocap2d wrote it), which `track` would overwrite; \
                     apply it with `mocap2d resume {} --segment {k}`, or track into another --out",
                    run_dir.display()
                ),
            });
        }
    }
    Ok(())
}

/// Writes a tool-made segment file `path` (the next segment's, at a checkpoint) unless the file
/// there became a correction meanwhile: its hash is none of `written`, the hashes mocap2d
/// recorded writing it. A file the user saved (by hand, or from a page before the run-folder
/// lock existed) between the checkpoint's look and its write is then kept, never replaced.
/// Returns whether `path` was written.
pub fn write_segment_unless_corrected(path: &Path, text: &str, written: &[String]) -> Result<bool> {
    crate::atomic::write_unless(path, text.as_bytes(), || {
        Ok(hash_file(path)?.is_some_and(|h| !written.contains(&h)))
    })
}

/// Removes every segment file (`segments/NNN.toml`, `NNN.csv`): a new run starts afresh.
/// Call [`check_no_corrections`] first.
pub fn clear_segments(run_dir: &Path) -> Result<()> {
    for (_, _, p) in segment_files(run_dir)? {
        std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
    }
    Ok(())
}

/// Removes temp files a killed run left (`*.tmp` in the run folder and `segments/`).
pub fn remove_temp_files(run_dir: &Path) -> Result<()> {
    for dir in [run_dir.to_owned(), run_dir.join(SEGMENTS_DIR)] {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.extension().is_some_and(|x| x == "tmp") && p.is_file() {
                std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
            }
        }
    }
    Ok(())
}

/// Moves `tracks.csv` and `report.md` (when there) to `history/NNN-tracks.csv` and
/// `history/NNN-report.md`, NNN one more than the highest there. Returns the new path of
/// `tracks.csv`, if it was there.
pub fn archive_previous(run_dir: &Path) -> Result<Option<PathBuf>> {
    let tracks = run_dir.join("tracks.csv");
    if !tracks.is_file() {
        return Ok(None);
    }
    let hist = run_dir.join(HISTORY_DIR);
    std::fs::create_dir_all(&hist).map_err(|e| Error::io(&hist, e))?;
    let mut n = 0u32;
    for e in std::fs::read_dir(&hist)
        .map_err(|e| Error::io(&hist, e))?
        .flatten()
    {
        let name = e.file_name();
        let name = name.to_string_lossy();
        if let Some(v) = name.split('-').next().and_then(|d| d.parse::<u32>().ok()) {
            n = n.max(v);
        }
    }
    let n = n + 1;
    let dst = hist.join(format!("{n:03}-tracks.csv"));
    std::fs::rename(&tracks, &dst).map_err(|e| Error::io(&tracks, e))?;
    let report = run_dir.join("report.md");
    if report.is_file() {
        let r = hist.join(format!("{n:03}-report.md"));
        std::fs::rename(&report, &r).map_err(|e| Error::io(&report, e))?;
    }
    Ok(Some(dst))
}

/// Copies `run.toml` and `seeds.toml` (when there) beside `archived`, the `history/NNN-tracks.csv`
/// [`archive_previous`] returned, as `NNN-run.toml` and `NNN-seeds.toml`: the archived tracks
/// then still trace to their clip and seeds when a run of another clip replaces them. With no
/// tracks archived (an unfinished run), they go to the next free NNN.
pub fn archive_inputs(run_dir: &Path, archived: Option<&Path>) -> Result<()> {
    let hist = run_dir.join(HISTORY_DIR);
    std::fs::create_dir_all(&hist).map_err(|e| Error::io(&hist, e))?;
    let prefix = match archived
        .and_then(|p| p.file_name())
        .and_then(|n| n.to_str())
        .and_then(|n| n.strip_suffix("-tracks.csv"))
    {
        Some(p) => p.to_owned(),
        None => {
            let used = |n: u32| {
                std::fs::read_dir(&hist)
                    .into_iter()
                    .flatten()
                    .flatten()
                    .any(|e| {
                        e.file_name()
                            .to_string_lossy()
                            .starts_with(&format!("{n:03}-"))
                    })
            };
            format!("{:03}", (1..).find(|&n| !used(n)).unwrap_or(1))
        }
    };
    for name in [RUN_TOML, "seeds.toml"] {
        let src = run_dir.join(name);
        if src.is_file() {
            let bytes = std::fs::read(&src).map_err(|e| Error::io(&src, e))?;
            crate::atomic::write(&hist.join(format!("{prefix}-{name}")), &bytes)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn archive_numbers_on_and_moves_the_report_along() {
        let d = tempfile::tempdir().unwrap();
        let r = d.path();
        assert_eq!(archive_previous(r).unwrap(), None);
        std::fs::write(r.join("tracks.csv"), "a").unwrap();
        std::fs::write(r.join("report.md"), "ra").unwrap();
        assert_eq!(
            archive_previous(r).unwrap(),
            Some(r.join("history/001-tracks.csv"))
        );
        std::fs::write(r.join("tracks.csv"), "b").unwrap();
        archive_previous(r).unwrap();
        assert_eq!(
            std::fs::read_to_string(r.join("history/002-tracks.csv")).unwrap(),
            "b"
        );
        assert_eq!(
            std::fs::read_to_string(r.join("history/001-report.md")).unwrap(),
            "ra"
        );
        assert!(!r.join("tracks.csv").exists());
    }

    #[test]
    fn a_segment_file_edited_before_the_checkpoint_writes_it_is_kept() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("002.toml");
        let tool = crate::run::segments::hash_bytes(b"frame = 3 # tool");
        // Missing, or as mocap2d wrote it: written.
        assert!(write_segment_unless_corrected(
            &p,
            "frame = 3 # tool",
            std::slice::from_ref(&tool)
        )
        .unwrap());
        assert!(
            write_segment_unless_corrected(&p, "frame = 3 # new", std::slice::from_ref(&tool))
                .unwrap()
        );
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "frame = 3 # new");
        // Edited by the user since: kept.
        std::fs::write(&p, "frame = 3 # user").unwrap();
        let new = crate::run::segments::hash_bytes(b"frame = 3 # new");
        assert!(!write_segment_unless_corrected(&p, "frame = 3 # again", &[tool, new]).unwrap());
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "frame = 3 # user");
    }

    #[test]
    fn an_unrecorded_segment_file_is_a_correction() {
        let d = tempfile::tempdir().unwrap();
        let r = d.path();
        std::fs::create_dir_all(r.join(SEGMENTS_DIR)).unwrap();
        std::fs::write(r.join("segments/000.csv"), "x").unwrap();
        check_no_corrections(r).unwrap();
        std::fs::write(r.join("segments/002.toml"), "frame = 3").unwrap();
        let m = check_no_corrections(r).unwrap_err().to_string();
        assert!(m.contains("002.toml") && m.contains("--segment 2"), "{m}");
        clear_segments(r).unwrap();
        assert!(segment_files(r).unwrap().is_empty());
    }
}
