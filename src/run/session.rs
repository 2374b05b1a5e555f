//! Segmented tracking, shared by `track` and `resume`: from segment K on, each segment is
//! tracked on from its first frame and checkpointed when done (its rows in
//! `segments/NNN.csv`, the next segment's file and tracker state, `run.toml`). Resuming from
//! any checkpoint repeats exactly what an uninterrupted run does.
//!
//! How a segment's tracker starts:
//! - on segment 0, it is built from that file on the seed frame (appearance included);
//! - on a file the tool wrote, the previous segment's tracker goes on: its whole state
//!   ([`Tracker::state`], kept in `segments/NNN.state` for resume) is restored on a tracker
//!   built from the seed frame, so an uncorrected boundary changes nothing but gap filling (a
//!   joint hidden across a boundary is not interpolated over it). Restarting there instead
//!   forgets that the character turned round (mirrored strips), what it learnt, and that the
//!   body was lost: measured on `long` (900 frames, 640×360, segments of 150, PCK@5) over
//!   seeds 1–3, going on gives 79.8 / 74.0 / 83.9 %, restarting at the file's rectangles with
//!   the seed frame's appearance 54.0 / 46.4 / 61.0 %, with the learnt appearance but the
//!   motion at rest 80.6 / 47.2 / 75.2 % (a lost body restarted as if seen stays lost). On
//!   450-frame clips the restart did better by 2–5 points (walk, occlude, fast, noisy): it
//!   cuts a drift short by chance rather than by evidence, and costs a whole body on long;
//! - on a corrected file (a keyframe the user vouches for), the previous segment's tracker goes
//!   on too, moved to the file's rectangles (its motion filters keep their rates: a correction
//!   says where the joints are, not how they move), and a second pass starts from a tracker
//!   built on the correction itself. Only the first is carried on to the next segment.
//!   Carrying on the tracker built on the correction instead (until the fifth session) cost
//!   whole segments wherever the corrected frame was a poor place to learn an appearance (a
//!   crouch after a turn, limbs over each other): correcting the report's first segment and
//!   the one after on `long` seeds 1–5 (640×360, segments of 150) gave 81.6 / 83.4 / 83.0 /
//!   78.7 / 85.4 % against 91.0 / 93.2 / 93.5 / 94.1 / 92.1 % uncorrected; now 93.3 / 93.2 /
//!   94.4 / 94.2 / 93.8 %. Moving the filters to rest instead of keeping their rates lost 13
//!   points on one segment of seed 3. On flies the tracker built on a correction did better
//!   once the flies walk: one file corrected (frame 1050), 77.1 % then, 74.9 % now (74.4 %
//!   uncorrected); with every file from there on corrected, the same as then.
//!
//! Up to the next key (segment file `k + 1` a correction, on the next segment's first frame or
//! the clip's last), the segment's frames are held, and every joint's path between the two keys
//! is solved through both ([`crate::run::keyed`]: Lucas–Kanade forward from one key and backward
//! from the other, the carried tracker as a guide, each step weighed by its doubt). Measured on
//! the real dance clip with keys every 50 frames (`scripts/accuracy --dance`), this gives PCK@20
//! 75.2 % where the earlier blend of tracker passes gave 54.6 % and interpolating the keys
//! 62.1 %, in a third of the time. After the last key, the carried tracker's pass and one built
//! on the correction are blended ([`super::blend`]). An appearance built on a correction keeps
//! the seed frame's for the bones hidden there ([`Tracker::adopt_hidden_from`]): a far arm
//! behind the body would otherwise be sampled off the near arm and followed there.

use crate::background::Background;
use crate::error::{Error, Result};
use crate::geom::Point;
use crate::progress::Progress;
use crate::run::keyed;
use crate::run::keys::{self, Key};
use crate::run::report::{Report, Tally};
use crate::run::segments::{self, file_text, Plan, Start};
use crate::run::{Manifest, SegmentRecord};
use crate::seed::Seeds;
use crate::track::flow::GreyPyramid;
use crate::track::scale::WorkScale;
use crate::track::Status;
use crate::track::{gapfill::GapFiller, JointEstimate, TrackParams, Tracker};
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
    /// The seed frame, once decoded: the appearance of restarted segments is built on it.
    pub seed_image: Option<RgbImage>,
    /// Angles (radians) of the last row written, as `tracks.csv` holds them: a corrected file
    /// counts turns from them.
    pub last_angles: Option<Vec<f32>>,
    /// What the previous segment's tracker learnt ([`Tracker::state`]), when this
    /// run tracked it: the next segment starts from it (else from its `segments/NNN.state`).
    pub carried: Option<Vec<u8>>,
}

/// What a finished segmented run reports.
pub struct Finished {
    /// Frames the clip has.
    pub frames: u64,
    /// What `tracks.csv` holds (frames, statuses).
    pub tally: Tally,
    pub report: Report,
}

/// Where a segment tracker's appearance model is built.
#[derive(Debug, Clone, Copy)]
enum Appearance<'a> {
    /// On the segment file's own frame, from its rectangles.
    Here,
    /// On the seed frame, from segment 0's file; the tracker then restarts at the rectangles.
    SeedFrame,
    /// As `SeedFrame`, then given what the previous segment's tracker learnt
    /// ([`Tracker::state`]), for segment `.0`.
    Learnt(u64, &'a [u8]),
    /// As `Learnt`, then moved to the segment file's rectangles (a correction), the motion
    /// filters keeping their rates.
    LearntMoved(u64, &'a [u8]),
}

/// One tracking pass: a tracker, its gap filler, what it has output, and the angle to add to
/// each joint's (the tracker measures from its own seed pose).
struct Pass {
    tracker: Tracker,
    filler: GapFiller,
    offsets: Vec<f32>,
    out: Vec<(u64, Vec<JointEstimate>)>,
}

impl Pass {
    /// Moves the tracker onto a key's joints (the others stay where it has them), its motion
    /// filters keeping their rates, as for a corrected segment file.
    fn move_to(&mut self, key: &Key) {
        let centres: Vec<Point> = self
            .tracker
            .current()
            .iter()
            .zip(&key.joints)
            .map(|(e, k)| k.unwrap_or(e.pos))
            .collect();
        self.tracker.restart_moving(&centres);
    }

    /// Starts a pass of `tracker`, just built or restarted on frame `frame`, where the joints'
    /// angles from the run's seed pose are `angles`.
    fn new(tracker: Tracker, angles: &[f32], frame: u64) -> Pass {
        let current = tracker.current();
        let offsets = angles
            .iter()
            .zip(&current)
            .map(|(a, e)| a - e.angle_rad)
            .collect();
        let mut filler = tracker.gap_filler();
        let out = filler.push(frame, current);
        Pass {
            tracker,
            filler,
            offsets,
            out,
        }
    }

    /// Tracks frame `idx`.
    fn step(&mut self, idx: u64, frame: &RgbImage) {
        let est = self.tracker.step(frame);
        self.out.extend(self.filler.push(idx, est));
    }

    /// Every frame's estimates, in the order they were tracked, angles from the seed pose.
    fn finish(self) -> Vec<(u64, Vec<JointEstimate>)> {
        self.finish_keep().0
    }

    /// [`Pass::finish`], giving the tracker back too.
    fn finish_keep(mut self) -> (Vec<(u64, Vec<JointEstimate>)>, Tracker) {
        self.out.extend(self.filler.finish());
        for (_, est) in &mut self.out {
            for (e, off) in est.iter_mut().zip(&self.offsets) {
                e.angle_rad += off;
            }
        }
        (self.out, self.tracker)
    }
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

    /// The frame of segment file `k`: its segment's first frame, or for the file after the
    /// last segment, the clip's last frame (as recorded).
    fn frame_of(&self, k: u64) -> u64 {
        self.manifest
            .segment
            .get(k as usize)
            .map_or(self.plan().first_frame(k), |r| r.first_frame)
    }

    /// Reads segment file `k`.
    pub fn start(&self, k: u64) -> Result<Start> {
        Start::read(
            &segments::file_path(&self.run_dir, k),
            self.frame_of(k),
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

    /// Checks that tracking can start at segment `k`: unless it is segment 0 or its file is a
    /// correction, its state file must be there as written, in this version's layout (see
    /// [`Session::run`]).
    pub fn check_state(&self, k: u64) -> Result<()> {
        if k == 0 || self.correction(k)?.is_some() {
            return Ok(());
        }
        if crate::track::state::is_current(&self.read_state(k)?) {
            Ok(())
        } else {
            Err(self.state_error(k, "was written by another version of mocap2d"))
        }
    }

    /// `segments/NNN.state` of segment `k`, checked against the hash `run.toml` records.
    fn read_state(&self, k: u64) -> Result<Vec<u8>> {
        let path = segments::state_path(&self.run_dir, k);
        let recorded = self
            .manifest
            .segment
            .get(k as usize)
            .map(|r| r.state.as_str());
        match std::fs::read(&path) {
            Ok(b) if recorded == Some(segments::hash_bytes(&b).as_str()) => Ok(b),
            Ok(_) => Err(self.state_error(k, "was changed since it was written")),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                Err(self.state_error(k, "is missing"))
            }
            Err(e) => Err(Error::io(&path, e)),
        }
    }

    /// Segment `k`'s state file cannot be used: the message says how to get on.
    fn state_error(&self, k: u64, what: &str) -> Error {
        Error::RunFolder {
            path: segments::state_path(&self.run_dir, k),
            msg: format!(
                "{what} (it holds what tracking learnt up to segment {k}, written by the tool); \
                 resume from an earlier segment (`--segment 0` always works) to rebuild it"
            ),
        }
    }

    /// A tracker built from `seeds` on `frame`, at the run's working resolution (its seed
    /// file's, whatever the rectangles of a corrected file: the run's trackers exchange states).
    fn tracker(&self, seeds: &Seeds, frame: &RgbImage) -> Tracker {
        let work = WorkScale::for_seeds(&self.params, &self.base);
        Tracker::new_at(
            self.params.clone(),
            seeds,
            frame,
            self.background.clone(),
            work,
        )
    }

    /// A tracker built on the seed frame from segment 0's file.
    fn seed_tracker(&self) -> Result<Tracker> {
        let first = self.start(0)?;
        let image = self
            .seed_image
            .as_ref()
            .expect("the seed frame is decoded before any segment");
        Ok(self.tracker(&first.seeds, image))
    }

    /// A tracker starting from `start` (a segment file) on its frame `frame`, with the
    /// appearance built there or on the seed frame (see the module docs).
    fn tracker_at(&self, start: &Start, frame: &RgbImage, appearance: Appearance) -> Result<Pass> {
        let t = match appearance {
            Appearance::Here => self.built_here(start, frame)?,
            Appearance::SeedFrame => {
                let mut t = self.seed_tracker()?;
                let centres: Vec<_> = start.seeds.boxes().iter().map(|b| b.centre()).collect();
                t.restart_at(&centres);
                t
            }
            Appearance::Learnt(k, bytes) | Appearance::LearntMoved(k, bytes) => {
                let mut t = self.seed_tracker()?;
                if !t.restore_state(bytes) {
                    return Err(self.state_error(k, "does not fit this run"));
                }
                if let Appearance::LearntMoved(..) = appearance {
                    let centres: Vec<_> = start.seeds.boxes().iter().map(|b| b.centre()).collect();
                    t.restart_moving(&centres);
                }
                t
            }
        };
        // A tracker carried on measures its angles from the run's seed pose already.
        let angles: Vec<f32> = match appearance {
            Appearance::Learnt(..) => t.current().iter().map(|e| e.angle_rad).collect(),
            _ => start.angles.clone(),
        };
        Ok(Pass::new(t, &angles, start.seeds.frame))
    }

    /// A tracker built on segment file `start`'s frame `frame` from its rectangles; off the seed
    /// frame, bones hidden there keep the seed frame's appearance.
    fn built_here(&self, start: &Start, frame: &RgbImage) -> Result<Tracker> {
        let mut t = self.tracker(&start.seeds, frame);
        if start.seeds.frame != self.plan().seed_frame {
            t.adopt_hidden_from(&self.seed_tracker()?, frame);
        }
        Ok(t)
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
                Some((idx, f)) => {
                    if idx == plan.seed_frame {
                        self.seed_image = Some(f.clone());
                    }
                    if idx == start_frame {
                        break f;
                    }
                }
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
        self.last_angles = match first_segment {
            0 => None,
            k => Some(segments::last_angles(&self.run_dir, k - 1)?),
        };
        let keys = keys::read(&self.run_dir, &self.names, self.width, self.height, None)?;
        let mut k = first_segment;
        loop {
            let (rows, boundary) = self.track_segment(k, &cur, &mut frames, &keys)?;
            match boundary {
                Some((est, frame)) => {
                    cur = frame;
                    self.checkpoint(k, &rows, Some((plan.first_frame(k + 1), &est, false)))?;
                    k += 1;
                }
                None => {
                    // The clip ends in segment k: its last frame is a keyframe file of its own.
                    let (f, est) = rows.last().expect("a segment has its first frame");
                    let end = (*f > plan.first_frame(k)).then_some((*f, est.as_slice(), true));
                    self.checkpoint(k, &rows, end)?;
                    break;
                }
            }
        }
        self.finish(k + 1, frames.count)
    }

    /// Tracks segment `k` from its first frame `first` (already decoded) on. Returns its rows
    /// and, unless the clip ends within it, the estimate on the next segment's first frame with
    /// that frame. When segment file `k + 1` is a correction (the next segment's first frame,
    /// or the clip's last frame), the segment's frames are held and tracked backward from it
    /// too, and the passes blended ([`super::blend`]).
    #[allow(clippy::type_complexity)]
    fn track_segment<I: Iterator<Item = Result<(u64, RgbImage)>>>(
        &mut self,
        k: u64,
        first: &RgbImage,
        frames: &mut Frames<'_, I>,
        keys: &[Key],
    ) -> Result<(
        Vec<(u64, Vec<JointEstimate>)>,
        Option<(Vec<JointEstimate>, RgbImage)>,
    )> {
        let plan = self.plan();
        let next = plan.first_frame(k + 1);
        let mut start = self.start(k)?;
        if let (true, Some(r)) = (start.corrected, &self.last_angles) {
            start.align_turns(r);
        }
        let mut end = self.correction(k + 1)?;
        let keyframe = k == 0 || start.corrected;
        let corrected = k > 0 && start.corrected;
        let learnt = match (k, self.carried.take()) {
            (0, _) => None,
            (_, Some(b)) => Some(b),
            (_, None) => Some(self.read_state(k)?),
        };
        let mut forward = vec![self.tracker_at(
            &start,
            first,
            match &learnt {
                None => Appearance::Here,
                Some(b) if corrected => Appearance::LearntMoved(k, b),
                Some(b) => Appearance::Learnt(k, b),
            },
        )?];
        if corrected {
            forward.push(self.tracker_at(&start, first, Appearance::Here)?);
            if end.is_some() {
                forward.push(self.tracker_at(&start, first, Appearance::SeedFrame)?);
            }
        }
        // Keys of `keys.toml` on this segment's first frame, inside it, and on the next one's
        // first frame ([`crate::run::keys`]).
        let first_frame = plan.first_frame(k);
        let key_here = keys.iter().find(|x| x.frame == first_frame);
        let inner: Vec<&Key> = keys
            .iter()
            .filter(|x| x.frame > first_frame && x.frame < next)
            .collect();
        let key_next = keys.iter().find(|x| x.frame == next);
        if let Some(key) = key_here {
            for p in &mut forward {
                p.move_to(key);
            }
        }
        let hold = end.is_some() || !inner.is_empty() || key_next.is_some();
        let mut held: Vec<RgbImage> = Vec::new();
        let mut boundary: Option<RgbImage> = None;
        while let Some((idx, frame)) = frames.next()? {
            for p in &mut forward {
                p.step(idx, &frame);
            }
            if idx == next {
                boundary = Some(frame);
                break;
            }
            if let Some(key) = inner.iter().find(|x| x.frame == idx) {
                for p in &mut forward {
                    p.move_to(key);
                }
            }
            if hold {
                held.push(frame);
            }
        }
        let mut passes = forward.into_iter();
        let (mut out, tracker) = passes.next().expect("one forward pass").finish_keep();
        let forward: Vec<Vec<(u64, Vec<JointEstimate>)>> = passes.map(Pass::finish).collect();
        self.carried = Some(tracker.state());
        if keyframe {
            out[0].1 = start.row.clone();
        }
        if let Some(key) = key_here {
            keyed_row(&mut out[0].1, key);
        }
        let mut at_next = boundary.as_ref().map(|_| out.pop().expect("pushed").1);
        // Where the carried tracker got to on the next key's frame.
        let mut carried_end: Option<Vec<Point>> =
            at_next.as_ref().map(|r| r.iter().map(|x| x.pos).collect());
        // A correction on the clip's last frame, inside this segment: the last frame held.
        let tail = match (&mut end, &boundary) {
            (Some(e), None) if !held.is_empty() && e.seeds.frame + 1 == frames.count => {
                let last = &mut out.last_mut().expect("held frames were tracked").1;
                carried_end = Some(last.iter().map(|x| x.pos).collect());
                e.align_turns(&last.iter().map(|x| x.angle_rad).collect::<Vec<_>>());
                *last = e.row.clone();
                held.pop()
            }
            (Some(e), Some(_)) => {
                let at = at_next.as_ref().expect("a boundary");
                e.align_turns(&at.iter().map(|x| x.angle_rad).collect::<Vec<_>>());
                None
            }
            _ => None,
        };
        // Each pass's estimates on the frames between the first and the next keyframe (`n`).
        let between = |p: &[(u64, Vec<JointEstimate>)], n: usize| -> Vec<Vec<JointEstimate>> {
            p[1..=n].iter().map(|(_, e)| e.clone()).collect()
        };
        // The tracker built on the next correction, run backward to this segment's start.
        let mut back_here: Option<Vec<Vec<Point>>> = None;
        let passes = if let (Some(end), Some(bf)) = (&end, boundary.as_ref().or(tail.as_ref())) {
            let n = held.len();
            let mut passes = Vec::new();
            // Between two corrections, the passes that start on them decide: the carried tracker
            // adds nothing there (on flies, 12 files corrected, it cost 1.5 points).
            if !corrected {
                passes.push(between(&out, n));
            }
            passes.extend(forward.iter().map(|p| between(p, n)));
            for appearance in [Appearance::Here, Appearance::SeedFrame] {
                let mut p = self.tracker_at(end, bf, appearance)?;
                for (i, f) in held.iter().enumerate().rev() {
                    p.step(plan.first_frame(k) + 1 + i as u64, f);
                }
                let mut back = p.finish();
                back.reverse();
                if back_here.is_none() {
                    back_here = Some(
                        back[..n]
                            .iter()
                            .map(|(_, r)| r.iter().map(|x| x.pos).collect())
                            .collect(),
                    );
                }
                passes.push(back[..n].iter().map(|(_, e)| e.clone()).collect());
            }
            passes
        } else if corrected {
            // After the last correction: the carried tracker and the one built on the
            // correction.
            let n = out.len() - 1;
            let mut passes = vec![between(&out, n)];
            passes.extend(forward.iter().map(|p| between(p, n)));
            passes
        } else {
            Vec::new()
        };
        if !passes.is_empty() {
            for (row, b) in out[1..].iter_mut().zip(super::blend::blend(&passes)) {
                row.1 = b;
            }
        }
        // Between two keys, the path through both ([`crate::run::keyed`]): from the segment's
        // first frame through every key inside it to the next segment's file when that is a
        // correction (or the clip's last frame is), or to a key on the next segment's first frame.
        let last = boundary.as_ref().or(tail.as_ref());
        let n = held.len();
        let mut anchors: Vec<(usize, Vec<Option<Point>>)> =
            vec![(0, out[0].1.iter().map(|e| Some(e.pos)).collect())];
        anchors.extend(
            inner
                .iter()
                .map(|key| ((key.frame - first_frame) as usize, key.joints.clone())),
        );
        match (&end, key_next, last) {
            (Some(end), _, Some(_)) => {
                anchors.push((n + 1, end.row.iter().map(|e| Some(e.pos)).collect()))
            }
            (None, Some(key), Some(_)) if boundary.is_some() => {
                anchors.push((n + 1, key.joints.clone()))
            }
            _ => {}
        }
        if anchors.len() > 1 {
            let images: Vec<&RgbImage> = std::iter::once(first)
                .chain(held.iter())
                .chain(last)
                .collect();
            let mut track_pos: Vec<Vec<Point>> = out
                .iter()
                .map(|(_, r)| r.iter().map(|e| e.pos).collect())
                .chain(at_next.iter().map(|r| r.iter().map(|e| e.pos).collect()))
                .collect();
            let track_ok: Vec<Vec<bool>> = out
                .iter()
                .map(|(_, r)| r.as_slice())
                .chain(at_next.as_deref())
                .map(|r| {
                    r.iter()
                        .map(|e| matches!(e.status, Status::Ok | Status::Seed))
                        .collect()
                })
                .collect();
            let top = anchors.last().expect("two anchors").0;
            let pyramids: Vec<GreyPyramid> = images[..=top]
                .iter()
                .map(|f| GreyPyramid::new(f, KEYED_LEVELS))
                .collect();
            let prm = keyed::KeyedParams::default();
            let boxes: Vec<u32> = start
                .seeds
                .joints
                .iter()
                .map(|j| j.bbox.w.min(j.bbox.h))
                .collect();
            let mut doubt: Vec<Vec<f32>> = vec![vec![0.0; self.names.len()]; top + 1];
            for pair in anchors.windows(2) {
                let ((ia, ka), (ib, kb)) = (&pair[0], &pair[1]);
                let start_pos: Vec<Point> = ka
                    .iter()
                    .zip(&track_pos[*ia])
                    .map(|(k, p)| k.unwrap_or(*p))
                    .collect();
                let solved = keyed::solve(
                    &pyramids[*ia..=*ib],
                    &start_pos,
                    Some(kb),
                    &track_pos[*ia..=*ib],
                    &track_ok[*ia..=*ib],
                    &boxes,
                    &prm,
                );
                // Up to a corrected segment file, the blend of the tracker's passes stands for a
                // joint unless Lucas–Kanade's two ways land decisively nearer the keys than the
                // tracker's (see docs/method.md).
                let keep_blend: Vec<bool> = match (&back_here, &carried_end) {
                    (Some(bh), Some(ce)) if *ib == top && end.is_some() => (0..self.names.len())
                        .map(|j| {
                            let (Some(xa), Some(xb)) = (start_pos.get(j), kb[j]) else {
                                return true;
                            };
                            let back_a = bh.get(*ia).map_or(*xa, |r| r[j]);
                            let miss_t = (ce[j] - xb).norm() + (back_a - *xa).norm();
                            solved.lk_miss[j] >= keyed::LK_MARGIN * miss_t
                        })
                        .collect(),
                    // Between keys of keys.toml the tracker ran forward only: it stands for a
                    // joint, bent onto the far key, unless Lucas–Kanade forward lands there at
                    // under half its miss.
                    _ => (0..self.names.len())
                        .map(|j| match kb[j] {
                            Some(xb) => {
                                let miss_t = (track_pos[*ib][j] - xb).norm();
                                solved.lk_fwd_miss[j] >= keyed::LK_MARGIN * miss_t
                            }
                            None => true,
                        })
                        .collect(),
                };
                let blend_kept = *ib == top && end.is_some() && back_here.is_some();
                let len = (ib - ia) as f32;
                for (t, row) in solved.rows.iter().enumerate().skip(1) {
                    for (j, s) in row.iter().enumerate() {
                        match (keep_blend[j], blend_kept, kb[j]) {
                            (true, true, _) => doubt[ia + t][j] = f32::NAN,
                            (true, false, Some(xb)) => {
                                let lam = t as f32 / len;
                                let miss = xb - track_pos[*ib][j];
                                track_pos[ia + t][j] += miss * lam;
                                doubt[ia + t][j] = miss.norm() * 2.0 * lam.min(1.0 - lam);
                            }
                            (true, false, None) => doubt[ia + t][j] = f32::NAN,
                            (false, ..) => {
                                track_pos[ia + t][j] = s.pos;
                                doubt[ia + t][j] = s.sigma_px;
                            }
                        }
                    }
                }
            }
            for (i, (_, row)) in out.iter_mut().enumerate().take(top + 1).skip(1) {
                for (j, e) in row.iter_mut().enumerate() {
                    if doubt[i][j].is_nan() {
                        continue;
                    }
                    e.pos = track_pos[i][j];
                    e.score = keyed::score(doubt[i][j]);
                    e.status = keyed::status(doubt[i][j]);
                }
            }
            for key in &inner {
                keyed_row(&mut out[(key.frame - first_frame) as usize].1, key);
            }
            if let (None, Some(key), Some(row)) = (&end, key_next, at_next.as_mut()) {
                keyed_row(row, key);
            }
        }
        // Hidden stretches are filled again over the whole segment at once, between where the
        // joint was seen on either side and with the frames around each gap at hand (the pass's
        // filler hands frames out after `fill_gaps_max`, and a pass that lost a joint up to a
        // keyframe coasted), up to the next keyframe if any.
        if self.params.fill_gaps_max > 0 {
            let end_row = match (&end, &boundary) {
                (Some(e), Some(_)) => Some((next, e.row.clone())),
                _ => None,
            };
            let rows = out.iter().cloned().chain(end_row).collect();
            let filled = tracker.gap_filler().fill_all(rows);
            for (row, (_, f)) in out.iter_mut().zip(filled) {
                row.1 = f;
            }
        }
        // Rows from several passes, or a pass and its keyframe, may count turns differently.
        for i in 1..out.len() {
            let (done, rest) = out.split_at_mut(i);
            for (e, p) in rest[0].1.iter_mut().zip(&done[i - 1].1) {
                e.angle_rad = segments::turns_near(p.angle_rad, e.angle_rad);
            }
        }
        Ok((out, at_next.zip(boundary)))
    }

    /// Checkpoint after segment `k`: its rows, segment file `k + 1` from `next` (its frame, the
    /// estimates there, and whether it is the clip's last frame rather than a segment's first)
    /// unless that file is a correction, then the manifest. The manifest learns a file's hash before the
    /// file is written, so a crash in between never makes a tool-written file look edited.
    fn checkpoint(
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
    fn finish(&mut self, count: u64, frames: u64) -> Result<Finished> {
        segments::assemble_tracks(&self.run_dir, count)?;
        let (tally, report) = self.report()?;
        crate::atomic::write(
            &self.run_dir.join("report.md"),
            report.to_markdown().as_bytes(),
        )?;
        self.manifest.frames = frames;
        self.manifest.complete = true;
        self.manifest.write(&self.run_dir)?;
        Ok(Finished {
            frames,
            tally,
            report,
        })
    }

    /// The report on the run's `tracks.csv`.
    pub fn report(&self) -> Result<(Tally, Report)> {
        crate::run::report::for_run(&self.run_dir, &self.manifest, &self.base)
    }
}

/// Angles (radians) of a row as `tracks.csv` writes them (4 decimals).
/// Levels of the grey pyramids Lucas–Kanade works on between keys (a 31 px window on the
/// fifth level covers ±240 px of motion at full resolution).
const KEYED_LEVELS: usize = 5;

/// Puts a key's joints into a row: their positions, status `seed`, score 1.
fn keyed_row(row: &mut [JointEstimate], key: &Key) {
    for (e, k) in row.iter_mut().zip(&key.joints) {
        if let Some(p) = k {
            e.pos = *p;
            e.status = Status::Seed;
            e.score = 1.0;
        }
    }
}

fn written_angles(est: &[JointEstimate]) -> Vec<f32> {
    est.iter()
        .map(|e| format!("{:.4}", e.angle_rad).parse().unwrap_or(e.angle_rad))
        .collect()
}
