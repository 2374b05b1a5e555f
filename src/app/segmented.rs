//! Segmented tracking, shared by `track` and `resume`: from segment K on, each segment is
//! tracked by a fresh [`Tracker`] built on its first frame from `segments/NNN.toml`, and
//! checkpointed when done (its rows in `segments/NNN.csv`, the next segment's file, `run.toml`).
//! A segment depends only on its file, its frames and (when the next file is a correction) the
//! next file, so resuming from any checkpoint repeats exactly what an uninterrupted run does.
//!
//! When the next segment's file is a correction, the segment is also tracked backward from it
//! (its frames are held in memory for that) and the two passes are blended ([`super::blend`]).

use crate::background::Background;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::run::report::{doubts, Report, Table, Thresholds};
use crate::run::segments::{self, file_text, Plan, Start};
use crate::run::tracks::read_tracks;
use crate::run::{Manifest, SegmentRecord};
use crate::seed::Seeds;
use crate::track::{JointEstimate, TrackParams, Tracker};
use image::RgbImage;
use std::path::PathBuf;

/// Everything a segmented run needs besides the frames.
pub struct Session {
    pub run_dir: PathBuf,
    /// The run's seed file (`seeds.toml`).
    pub base: Seeds,
    pub names: Vec<String>,
    pub params: TrackParams,
    pub background: Option<Background>,
    pub width: u32,
    pub height: u32,
    /// The manifest, rewritten at every checkpoint.
    pub manifest: Manifest,
}

/// What a finished segmented run reports.
pub struct Finished {
    /// Frames the clip has.
    pub frames: u64,
    pub table: Table,
    pub report: Report,
}

/// Frames, one at a time, with progress and interruption.
struct Frames<'p, I> {
    inner: I,
    progress: &'p dyn Progress,
    count: u64,
}

impl<I: Iterator<Item = Result<(u64, RgbImage)>>> Frames<'_, I> {
    fn next(&mut self) -> Result<Option<(u64, RgbImage)>> {
        match self.inner.next() {
            None => Ok(None),
            Some(item) => {
                let (idx, frame) = item?;
                self.count = idx + 1;
                if !self.progress.advance(1) {
                    return Err(Error::Interrupted);
                }
                Ok(Some((idx, frame)))
            }
        }
    }
}

impl Session {
    /// Segment boundaries of this run.
    pub fn plan(&self) -> Plan {
        Plan {
            seed_frame: self.manifest.seed_frame,
            len: self.manifest.segment_len,
        }
    }

    /// Hashes the tool wrote for segment `k`'s file.
    fn written(&self, k: u64) -> &[String] {
        self.manifest
            .segment
            .get(k as usize)
            .map_or(&[], |r| r.written.as_slice())
    }

    /// Reads segment `k`'s file.
    pub fn start(&self, k: u64) -> Result<Start> {
        Start::read(
            &segments::file_path(&self.run_dir, k),
            self.plan().first_frame(k),
            &self.base,
            self.width,
            self.height,
            self.params.rotate_roots,
            self.written(k),
        )
    }

    /// Segment `k`'s file when it exists and is a correction.
    pub fn correction(&self, k: u64) -> Result<Option<Start>> {
        let p = segments::file_path(&self.run_dir, k);
        match segments::hash_file(&p)? {
            Some(h) if !self.written(k).contains(&h) => Ok(Some(self.start(k)?)),
            _ => Ok(None),
        }
    }

    fn tracker(&self, seeds: &Seeds, frame: &RgbImage) -> Tracker {
        Tracker::new(self.params.clone(), seeds, frame, self.background.clone())
    }

    /// Tracks from segment `first_segment` (whose file must exist) to the end of the clip,
    /// checkpointing after every segment, then joins `tracks.csv`, writes `report.md` and marks
    /// the manifest complete. `frames` is the whole clip from frame 0.
    pub fn run(
        &mut self,
        frames: impl Iterator<Item = Result<(u64, RgbImage)>>,
        first_segment: u64,
        progress: &dyn Progress,
    ) -> Result<Finished> {
        let plan = self.plan();
        let mut frames = Frames {
            inner: frames,
            progress,
            count: 0,
        };
        let start_frame = plan.first_frame(first_segment);
        let mut cur = loop {
            match frames.next()? {
                Some((idx, f)) if idx == start_frame => break f,
                Some(_) => continue,
                None => {
                    return Err(Error::RunFolder {
                        path: self.run_dir.clone(),
                        msg: format!(
                            "segment {first_segment} starts on frame {start_frame}, beyond the \
                             clip's {} frames",
                            frames.count
                        ),
                    })
                }
            }
        };
        let mut k = first_segment;
        loop {
            let (rows, boundary) = self.track_segment(k, &cur, &mut frames)?;
            let next = boundary.map(|(est, frame)| {
                cur = frame;
                est
            });
            self.checkpoint(k, &rows, next.as_deref())?;
            if next.is_none() {
                break;
            }
            k += 1;
        }
        self.finish(k + 1, frames.count)
    }

    /// Tracks segment `k` from its first frame `first` (already decoded) on. Returns its rows
    /// and, unless the clip ends within it, the estimate on the next segment's first frame with
    /// that frame.
    #[allow(clippy::type_complexity)]
    fn track_segment<I: Iterator<Item = Result<(u64, RgbImage)>>>(
        &self,
        k: u64,
        first: &RgbImage,
        frames: &mut Frames<'_, I>,
    ) -> Result<(
        Vec<(u64, Vec<JointEstimate>)>,
        Option<(Vec<JointEstimate>, RgbImage)>,
    )> {
        let plan = self.plan();
        let (s, next) = (plan.first_frame(k), plan.first_frame(k + 1));
        let start = self.start(k)?;
        let end = self.correction(k + 1)?;
        let mut t = self.tracker(&start.seeds, first);
        let mut g = t.gap_filler();
        let mut out = g.push(s, t.current());
        let mut held: Vec<RgbImage> = Vec::new();
        let mut boundary: Option<RgbImage> = None;
        while let Some((idx, frame)) = frames.next()? {
            out.extend(g.push(idx, t.step(&frame)));
            if idx == next {
                boundary = Some(frame);
                break;
            }
            if end.is_some() {
                held.push(frame);
            }
        }
        drop(t);
        out.extend(g.finish());
        for (_, est) in &mut out {
            for (e, off) in est.iter_mut().zip(&start.angle_offsets) {
                e.angle_rad += off;
            }
        }
        out[0].1 = start.row.clone();
        let at_next = boundary.as_ref().map(|_| out.pop().expect("pushed").1);
        if let (Some(end), Some(bf)) = (&end, &boundary) {
            let back = self.track_backward(end, bf, &held, s + 1);
            let fwd: Vec<Vec<JointEstimate>> = out[1..].iter().map(|(_, e)| e.clone()).collect();
            for (row, b) in out[1..].iter_mut().zip(super::blend::blend(&fwd, &back)) {
                row.1 = b;
            }
        }
        Ok((out, at_next.zip(boundary)))
    }

    /// Tracks `held` (frames `first..`, in time order) backward from the correction `end` on
    /// frame `bf` (the frame after the last held one). Returns estimates in time order.
    fn track_backward(
        &self,
        end: &Start,
        bf: &RgbImage,
        held: &[RgbImage],
        first: u64,
    ) -> Vec<Vec<JointEstimate>> {
        let mut t = self.tracker(&end.seeds, bf);
        let mut g = t.gap_filler();
        let mut out = g.push(end.seeds.frame, t.current());
        for (i, f) in held.iter().enumerate().rev() {
            out.extend(g.push(first + i as u64, t.step(f)));
        }
        out.extend(g.finish());
        let mut back: Vec<Vec<JointEstimate>> = out
            .into_iter()
            .skip(1)
            .map(|(_, mut est)| {
                for (e, off) in est.iter_mut().zip(&end.angle_offsets) {
                    e.angle_rad += off;
                }
                est
            })
            .collect();
        back.reverse();
        back
    }

    /// Checkpoint after segment `k`: its rows, the next segment's file from `next` (unless that
    /// file is a correction), then the manifest. The manifest learns a file's hash before the
    /// file is written, so a crash in between never makes a tool-written file look edited.
    fn checkpoint(
        &mut self,
        k: u64,
        rows: &[(u64, Vec<JointEstimate>)],
        next: Option<&[JointEstimate]>,
    ) -> Result<()> {
        let plan = self.plan();
        segments::write_rows(&self.run_dir, k, &self.names, rows)?;
        let used = self.start(k)?.hash;
        self.manifest.segment[k as usize].tracked_from = used;
        if let Some(est) = next {
            let k1 = k + 1;
            let first = plan.first_frame(k1);
            if self.manifest.segment.len() <= k1 as usize {
                self.manifest.segment.push(SegmentRecord {
                    first_frame: first,
                    written: Vec::new(),
                    tracked_from: String::new(),
                });
            }
            if self.correction(k1)?.is_none() {
                let text = file_text(k1, first, &self.base, est, self.width, self.height);
                let h = segments::hash_bytes(text.as_bytes());
                let rec = &mut self.manifest.segment[k1 as usize];
                if !rec.written.contains(&h) {
                    rec.written.push(h.clone());
                    self.manifest.write(&self.run_dir)?;
                }
                crate::atomic::write(&segments::file_path(&self.run_dir, k1), text.as_bytes())?;
                self.manifest.segment[k1 as usize].written = vec![h];
            }
        }
        self.manifest.tracked_segments = k + 1;
        self.manifest.write(&self.run_dir)
    }

    /// The run is tracked through segment `count - 1`: joins `tracks.csv`, writes `report.md`,
    /// and marks the manifest complete with the clip's `frames`.
    fn finish(&mut self, count: u64, frames: u64) -> Result<Finished> {
        segments::assemble_tracks(&self.run_dir, count)?;
        let (table, report) = self.report()?;
        let name = self
            .run_dir
            .file_name()
            .map_or("run".into(), |n| n.to_string_lossy().into_owned());
        crate::atomic::write(
            &self.run_dir.join("report.md"),
            report.to_markdown(&name).as_bytes(),
        )?;
        self.manifest.segment.truncate(count as usize);
        self.manifest.frames = frames;
        self.manifest.complete = true;
        self.manifest.write(&self.run_dir)?;
        Ok(Finished {
            frames,
            table,
            report,
        })
    }

    /// The report on the run's `tracks.csv`.
    pub fn report(&self) -> Result<(Table, Report)> {
        let rows = read_tracks(&self.run_dir.join("tracks.csv"))?;
        let table = Table::from_rows(&rows, self.names.len());
        let plan = self.plan();
        let sk = &self.base.skeleton;
        let boxes = self.base.boxes();
        let sides: Vec<f32> = boxes.iter().map(|b| 0.5 * (b.w + b.h) as f32).collect();
        let seed_len: Vec<f32> = (0..sk.len())
            .map(|j| sk.parents[j].map_or(0.0, |p| (boxes[j].centre() - boxes[p].centre()).norm()))
            .collect();
        let mut corrected = Vec::new();
        let mut starts = Vec::new();
        for (k, rec) in self.manifest.segment.iter().enumerate() {
            let h = segments::hash_file(&segments::file_path(&self.run_dir, k as u64))?;
            let c = h.is_some_and(|h| !rec.written.contains(&h));
            corrected.push(c);
            if k > 0 && !c {
                if let Ok(i) = table.frames.binary_search(&rec.first_frame) {
                    starts.push(i);
                }
            }
        }
        let th = Thresholds::default();
        let m = doubts(&table, sk, &sides, &seed_len, &starts, &th);
        let report = Report::build(&table, &m, &self.names, &plan, &corrected, &th);
        Ok((table, report))
    }
}
