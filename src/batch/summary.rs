//! What a batch did, clip by clip: the table printed at the end and `batch-summary.csv`.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// How one clip ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    /// Its stages ran (some may have been up to date already).
    Done,
    /// Everything was up to date: nothing ran.
    Skipped,
    /// A stage failed; `message` is the error on one line, `user_error` whether the user can fix
    /// it (bad seeds, an undecodable clip: exit code 2) or not (exit code 1).
    Failed { message: String, user_error: bool },
    /// Stopped part-way by Ctrl-C (or SIGTERM): its run folder holds a checkpoint (or, in
    /// `render`, no video), and a re-run of the batch carries it on.
    Interrupted,
}

impl Status {
    /// The status word of the table and the CSV.
    pub fn word(&self) -> &'static str {
        match self {
            Status::Done => "done",
            Status::Skipped => "skipped",
            Status::Failed { .. } => "failed",
            Status::Interrupted => "interrupted",
        }
    }
}

/// One clip's line of the summary.
#[derive(Debug, Clone, PartialEq)]
pub struct ClipOutcome {
    pub clip: PathBuf,
    pub run_dir: PathBuf,
    /// Frames tracked (from the seed frame on), when known.
    pub frames: Option<u64>,
    /// Wall time of the tracking stage, seconds; `None` when it did not run.
    pub track_seconds: Option<f64>,
    /// Flagged segments of the run, from [`flagged_segments_hook`].
    pub flagged_segments: Option<usize>,
    /// What `track` told the user about the clip (a camera that moves, frames tracked halved),
    /// or empty.
    pub note: String,
    pub status: Status,
}

impl ClipOutcome {
    /// Tracking speed, frames per second, when tracking ran.
    pub fn frames_per_second(&self) -> Option<f64> {
        match (self.frames, self.track_seconds) {
            (Some(n), Some(s)) if s > 0.0 => Some(n as f64 / s),
            _ => None,
        }
    }
}

/// The number of segments the run's correction report flags (see [`crate::app::report`]), or
/// `None` when `run_dir` has no complete run to report on; while every clip gives `None` the
/// summary has no `flagged segments` column.
pub fn flagged_segments_hook(run_dir: &Path) -> Option<usize> {
    crate::app::report(run_dir, crate::run::report::SUGGESTED)
        .ok()
        .map(|r| r.ranked().len())
}

/// The exit code a batch ends with: 130 if it was interrupted, 0 if no clip failed, 2 if every
/// failure is one the user can fix (see [`Error::is_user_error`]), else 1.
pub fn exit_code(outcomes: &[ClipOutcome]) -> u8 {
    if outcomes.iter().any(|o| o.status == Status::Interrupted) {
        return crate::error::EXIT_INTERRUPTED;
    }
    let failures: Vec<bool> = outcomes
        .iter()
        .filter_map(|o| match &o.status {
            Status::Failed { user_error, .. } => Some(*user_error),
            _ => None,
        })
        .collect();
    match failures.is_empty() {
        true => 0,
        false if failures.iter().all(|&u| u) => 2,
        false => 1,
    }
}

/// When Ctrl-C stopped the batch (a clip was interrupted, or fewer than the `planned` clips
/// ran): one line saying how far it got and how to finish it.
pub fn interrupted(outcomes: &[ClipOutcome], planned: usize) -> Option<String> {
    let count = |w: &str| outcomes.iter().filter(|o| o.status.word() == w).count();
    let stopped: Vec<String> = outcomes
        .iter()
        .filter(|o| o.status == Status::Interrupted)
        .map(|o| o.clip.display().to_string())
        .collect();
    let not_started = planned.saturating_sub(outcomes.len());
    if stopped.is_empty() && not_started == 0 {
        return None;
    }
    let done = count("done") + count("skipped");
    let mut parts = vec![format!("{done} of {planned} clips done")];
    match count("failed") {
        0 => {}
        n => parts.push(format!("{n} failed")),
    }
    if !stopped.is_empty() {
        parts.push(format!("stopped part-way: {}", stopped.join(", ")));
    }
    if not_started > 0 {
        parts.push(format!("{not_started} not started"));
    }
    Some(format!(
        "batch interrupted: {}; no file was left half-written; run the same command again to \
         finish (done clips are skipped, stopped ones resume from their last checkpoint)",
        parts.join(", ")
    ))
}

fn has_segments(outcomes: &[ClipOutcome]) -> bool {
    outcomes.iter().any(|o| o.flagged_segments.is_some())
}

fn cell<T: ToString>(v: Option<T>) -> String {
    v.map(|v| v.to_string()).unwrap_or_default()
}

/// The summary table (columns clip, frames, frames/s, [flagged segments,] status), a line per
/// clip with a note (`note: CLIP: …`), and a last line with the counts, as text.
pub fn table(outcomes: &[ClipOutcome]) -> String {
    let segments = has_segments(outcomes);
    let mut rows: Vec<Vec<String>> = vec![["clip", "frames", "frames/s"]
        .iter()
        .map(|s| s.to_string())
        .collect()];
    if segments {
        rows[0].push("flagged segments".into());
    }
    rows[0].push("status".into());
    for o in outcomes {
        let mut r = vec![
            o.clip.display().to_string(),
            cell(o.frames),
            cell(o.frames_per_second().map(|f| format!("{f:.1}"))),
        ];
        if segments {
            r.push(cell(o.flagged_segments));
        }
        r.push(o.status.word().into());
        rows.push(r);
    }
    let widths: Vec<usize> = (0..rows[0].len())
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    let mut out = String::new();
    for r in &rows {
        let cells: Vec<String> = r
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(c, (v, &w))| match c {
                0 => format!("{v:<w$}"),
                _ if c + 1 == r.len() => v.clone(),
                _ => format!("{v:>w$}"),
            })
            .collect();
        out.push_str(cells.join("  ").trim_end());
        out.push('\n');
    }
    for o in outcomes.iter().filter(|o| !o.note.is_empty()) {
        out.push_str(&format!("note: {}: {}\n", o.clip.display(), o.note));
    }
    let count = |w: &str| outcomes.iter().filter(|o| o.status.word() == w).count();
    out.push_str(&format!(
        "{} clip{}: {} done, {} skipped, {} failed\n",
        outcomes.len(),
        if outcomes.len() == 1 { "" } else { "s" },
        count("done"),
        count("skipped"),
        count("failed")
    ));
    out
}

/// Writes `batch-summary.csv` atomically: `clip,run,frames,frames_per_s,status,error` (and
/// `flagged_segments` when there is segment data, `note` when a clip has one), one row per
/// clip in the batch's order.
pub fn write_csv(path: &Path, outcomes: &[ClipOutcome]) -> Result<()> {
    let segments = has_segments(outcomes);
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["clip", "run", "frames", "frames_per_s", "status", "error"];
    if segments {
        header.push("flagged_segments");
    }
    let notes = outcomes.iter().any(|o| !o.note.is_empty());
    if notes {
        header.push("note");
    }
    let io = |e: csv::Error| Error::io(path, std::io::Error::other(e));
    w.write_record(&header).map_err(io)?;
    for o in outcomes {
        let error = match &o.status {
            Status::Failed { message, .. } => message.clone(),
            _ => String::new(),
        };
        let mut r = vec![
            o.clip.display().to_string(),
            o.run_dir.display().to_string(),
            cell(o.frames),
            cell(o.frames_per_second().map(|f| format!("{f:.2}"))),
            o.status.word().to_string(),
            error,
        ];
        if segments {
            r.push(cell(o.flagged_segments));
        }
        if notes {
            r.push(o.note.clone());
        }
        w.write_record(&r).map_err(io)?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| Error::io(path, std::io::Error::other(e.to_string())))?;
    crate::atomic::write(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn outcome(clip: &str, status: Status) -> ClipOutcome {
        ClipOutcome {
            clip: clip.into(),
            run_dir: format!("{clip}.mocap").into(),
            frames: Some(30),
            track_seconds: Some(2.0),
            flagged_segments: None,
            note: String::new(),
            status,
        }
    }

    fn failed(user_error: bool) -> Status {
        Status::Failed {
            message: "x".into(),
            user_error,
        }
    }

    #[test]
    fn exit_code_follows_the_worst_failure() {
        let ok = outcome("a", Status::Done);
        assert_eq!(exit_code(&[ok.clone(), outcome("b", Status::Skipped)]), 0);
        assert_eq!(exit_code(&[ok.clone(), outcome("b", failed(true))]), 2);
        let both = [outcome("b", failed(true)), outcome("c", failed(false))];
        assert_eq!(exit_code(&both), 1);
        let cut = [
            outcome("b", failed(false)),
            outcome("c", Status::Interrupted),
        ];
        assert_eq!(exit_code(&cut), 130);
    }

    #[test]
    fn an_interrupted_batch_says_how_far_it_got() {
        let all = [outcome("a", Status::Done), outcome("b", Status::Skipped)];
        assert_eq!(interrupted(&all, 2), None);
        let msg = interrupted(&all, 4).unwrap();
        assert!(msg.starts_with("batch interrupted: 2 of 4 clips done, 2 not started;"));
        let cut = [
            outcome("a", failed(true)),
            outcome("b", Status::Interrupted),
        ];
        let msg = interrupted(&cut, 2).unwrap();
        assert!(msg.contains("0 of 2 clips done, 1 failed, stopped part-way: b;"));
        assert!(msg.contains("run the same command again"));
    }

    #[test]
    fn segment_column_only_with_segment_data() {
        let mut rows = vec![outcome("a.mp4", Status::Done)];
        let t = table(&rows);
        assert!(t.starts_with("clip   frames  frames/s  status\n"), "{t}");
        assert!(t.contains("a.mp4      30      15.0  done\n"), "{t}");
        rows[0].flagged_segments = Some(3);
        assert!(table(&rows).contains("flagged segments"));
    }

    #[test]
    fn what_track_said_of_a_clip_is_in_the_table_and_the_csv() {
        let mut rows = vec![
            outcome("a.mp4", Status::Done),
            outcome("b.mp4", Status::Done),
        ];
        let dir = tempfile::tempdir().unwrap();
        let csv_path = dir.path().join("batch-summary.csv");
        write_csv(&csv_path, &rows).unwrap();
        let text = std::fs::read_to_string(&csv_path).unwrap();
        assert!(
            !text.contains("note") && !table(&rows).contains("note"),
            "{text}"
        );
        rows[1].note = "the camera moves, so no clean plate".into();
        let t = table(&rows);
        assert!(
            t.contains("\nnote: b.mp4: the camera moves, so no clean plate\n"),
            "{t}"
        );
        write_csv(&csv_path, &rows).unwrap();
        let mut r = csv::Reader::from_path(&csv_path).unwrap();
        let header = r.headers().unwrap().clone();
        assert_eq!(header.iter().last(), Some("note"));
        let notes: Vec<String> = r.records().map(|x| x.unwrap()[6].to_string()).collect();
        assert_eq!(notes, ["", "the camera moves, so no clean plate"]);
    }
}
