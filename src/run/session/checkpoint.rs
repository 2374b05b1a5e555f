//! The end of each segment and of the run: the checkpoint that writes a segment's rows, the next
//! segment's file and state and the manifest, then `tracks.csv` and `report.md`.

use super::{Finished, Session};
use crate::error::Result;
use crate::run::report::{Report, Tally};
use crate::run::segments::{self, file_text};
use crate::run::SegmentRecord;
use crate::track::JointEstimate;

impl Session {
    /// Checkpoint after segment `k`: its rows, segment file `k + 1` from `next` (its frame, the
    /// estimates there, and whether it is the clip's last frame rather than a segment's first)
    /// unless that file is a correction, then the manifest. The manifest learns a file's hash before the
    /// file is written, so a crash in between never makes a tool-written file look edited.
    pub(super) fn checkpoint(
        &mut self,
        k: u64,
        rows: &[(u64, Vec<JointEstimate>)],
        next: Option<(u64, &[JointEstimate], bool)>,
    ) -> Result<()> {
        segments::write_rows(&self.run_dir, k, &self.names, rows)?;
        self.last_angles = rows.last().map(|(_, est)| written_angles(est));
        let used = self.start(k)?.hash;
        self.manifest.segment[k as usize].tracked_from = used;
        if next.is_none_or(|n| n.2) {
            // The last segment: no file after the clip's end.
            self.manifest
                .segment
                .truncate(k as usize + 1 + next.is_some() as usize);
        }
        if let (Some((_, _, false)), Some(state)) = (next, &self.carried) {
            // What the next segment's tracker starts from: written before the manifest
            // records it, so a crash in between only makes resume track segment k again.
            crate::atomic::write(&segments::state_path(&self.run_dir, k + 1), state)?;
        }
        if let Some((first, est, last)) = next {
            let k1 = k + 1;
            match self.manifest.segment.get_mut(k1 as usize) {
                Some(rec) if rec.first_frame == first => {}
                Some(rec) => {
                    *rec = SegmentRecord {
                        first_frame: first,
                        ..SegmentRecord::default()
                    }
                }
                None => self.manifest.segment.push(SegmentRecord {
                    first_frame: first,
                    ..SegmentRecord::default()
                }),
            }
            self.manifest.segment[k1 as usize].state = match (last, &self.carried) {
                (false, Some(state)) => segments::hash_bytes(state),
                _ => String::new(),
            };
            match self.correction(k1)? {
                Some(c) if last => self.manifest.segment[k1 as usize].tracked_from = c.hash,
                Some(_) => {}
                None => {
                    let text = file_text(k1, first, last, &self.base, est, self.width, self.height);
                    let h = segments::hash_bytes(text.as_bytes());
                    let rec = &mut self.manifest.segment[k1 as usize];
                    if !rec.written.contains(&h) {
                        rec.written.push(h.clone());
                        self.manifest.write(&self.run_dir)?;
                    }
                    let path = segments::file_path(&self.run_dir, k1);
                    // A file that became a correction since `correction` looked is kept.
                    let written = &self.manifest.segment[k1 as usize].written;
                    crate::run::folder::write_segment_unless_corrected(&path, &text, written)?;
                    let rec = &mut self.manifest.segment[k1 as usize];
                    rec.written = vec![h.clone()];
                    if last {
                        rec.tracked_from = h;
                    }
                }
            }
        }
        self.manifest.tracked_segments = k + 1;
        self.manifest.write(&self.run_dir)
    }

    /// The run is tracked through segment `count - 1`: joins `tracks.csv`, writes `report.md`,
    /// and marks the manifest complete with the clip's `frames`.
    pub(super) fn finish(&mut self, count: u64, frames: u64) -> Result<Finished> {
        segments::assemble_tracks(&self.run_dir, count)?;
        let finished = self.rereport(frames)?;
        self.manifest.frames = frames;
        self.manifest.complete = true;
        self.manifest.write(&self.run_dir)?;
        Ok(finished)
    }

    /// Rewrites `report.md` from `tracks.csv` as it is now (after the pose cue's fusion).
    pub fn rereport(&self, frames: u64) -> Result<Finished> {
        let (tally, report) = self.report()?;
        crate::atomic::write(
            &self.run_dir.join("report.md"),
            report.to_markdown().as_bytes(),
        )?;
        Ok(Finished {
            frames,
            tally,
            report,
        })
    }

    /// The report on the run's `tracks.csv`.
    pub fn report(&self) -> Result<(Tally, Report)> {
        crate::run::report::for_run(
            &self.run_dir,
            &self.manifest,
            &self.base,
            crate::run::report::SUGGESTED,
        )
    }
}

/// Angles (radians) of a row as `tracks.csv` writes them (4 decimals).
fn written_angles(est: &[JointEstimate]) -> Vec<f32> {
    est.iter()
        .map(|e| format!("{:.4}", e.angle_rad).parse().unwrap_or(e.angle_rad))
        .collect()
}
