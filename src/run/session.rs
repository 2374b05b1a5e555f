//! The tracking loop, shared by `track` and `resume`: from segment K on, each segment is
//! tracked from its first frame and checkpointed when done (its rows in `segments/NNN.csv`, the
//! next segment's file and tracker state, `run.toml`). Resuming from any checkpoint repeats
//! exactly what an uninterrupted run does (docs/method.md §3).
//!
//! How a segment's tracker starts:
//! - on segment 0, it is built from that file on the seed frame (appearance included);
//! - on a file the tool wrote, the previous segment's tracker goes on: its whole state
//!   ([`Tracker::state`], kept in `segments/NNN.state` for resume) is restored on a tracker
//!   built from the seed frame, so an uncorrected boundary changes nothing but gap filling.
//!   Restarting there would forget that the character turned round (mirrored strips), what it
//!   learnt, and that the body was lost;
//! - on a corrected file (a keyframe the user vouches for), the previous segment's tracker goes
//!   on too, moved to the file's rectangles (its motion filters keep their rates: a correction
//!   says where the joints are, not how they move), and passes start from trackers built on the
//!   correction itself ([`pass`]). Only the first is carried on to the next segment: a tracker
//!   built on a poor place to learn an appearance (a crouch after a turn, limbs over each
//!   other) would otherwise cost whole segments after it.
//!
//! Up to the next key (a corrected segment file, or a key of `keys.toml`), the segment's frames
//! are held, and every joint's path between its own keys is solved through both ends
//! ([`segment`], [`spans`], [`crate::run::keyed`]), past the segment's end too: the frames up to
//! each joint's next key are read ahead and given back ([`ahead`]). After the last key, the
//! carried tracker's pass and
//! one built on the correction are blended ([`super::blend`]). An appearance built on a
//! correction keeps the seed frame's for the bones hidden there
//! ([`Tracker::adopt_hidden_from`]): a far arm behind the body would otherwise be sampled off
//! the near arm and followed there. The figures behind these choices are in docs/NOTES.md
//! ("Segments: carrying the tracker on").
use crate::background::Background;
use crate::decode::{self, FrameSource, Recycler};
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::run::keys::{self, Key};
use crate::run::report::{Report, Tally};
use crate::run::segments::{self, Plan, Start};
use crate::run::Manifest;
use crate::seed::Seeds;
use crate::track::scale::{Frame, WorkScale};
use crate::track::{JointEstimate, TrackParams, Tracker};
use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::mpsc::Receiver;

mod ahead;
mod between;
mod checkpoint;
mod flow;
mod pass;
mod segment;
mod spans;

use pass::{Appearance, Frames, Pass};
use segment::keyed_row;

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
    pub seed_image: Option<Frame>,
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
    fn tracker(&self, seeds: &Seeds, frame: &Frame) -> Tracker {
        Tracker::new_at(
            self.params.clone(),
            seeds,
            frame,
            self.background.clone(),
            self.work_scale(),
        )
    }

    /// The resolution the run's trackers work at (from its seed file): what a decode thread
    /// makes each frame's working image at ([`WorkScale::frame`]).
    pub fn work_scale(&self) -> WorkScale {
        WorkScale::for_seeds(&self.params, &self.base)
    }

    /// `source`'s frames for [`Session::run`], decoded on their own thread (a channel of 8),
    /// each with its working image made there and its buffers handed back for later frames
    /// (`decode::Recycler`). With `keep_full` false, the frames at full resolution are let go
    /// once halved: for a run with no keys and no corrections, where Lucas–Kanade between keys,
    /// the only reader of them, does not run.
    pub fn frames_from(
        &self,
        mut source: Box<dyn FrameSource>,
        keep_full: bool,
    ) -> Receiver<Result<(u64, Frame)>> {
        let work = self.work_scale();
        let recycler = Recycler::new();
        source.recycle_from(recycler.clone());
        decode::spawn_reader_with(source, 8, move |f| {
            work.frame(f, Some(&recycler), keep_full)
        })
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
    fn tracker_at(&self, start: &Start, frame: &Frame, appearance: Appearance) -> Result<Pass> {
        let t = match appearance {
            Appearance::Here => self.built_here(start, frame)?,
            Appearance::SeedFrame => {
                let mut t = self.seed_tracker()?;
                let centres: Vec<_> = start.seeds.boxes().iter().map(|b| b.centre()).collect();
                t.restart_at(&centres);
                t
            }
            Appearance::Learnt(k, bytes) | Appearance::LearntMoved(k, bytes) => {
                let mut t = self.restored(k, bytes)?;
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

    /// The tracker that learnt `state` ([`Tracker::state`]), which segment `k` carries on with
    /// (built on the seed frame, then given the state).
    fn restored(&self, k: u64, state: &[u8]) -> Result<Tracker> {
        let mut t = self.seed_tracker()?;
        if !t.restore_state(state) {
            return Err(self.state_error(k, "does not fit this run"));
        }
        Ok(t)
    }

    /// A tracker built on segment file `start`'s frame `frame` from its rectangles; off the seed
    /// frame, bones hidden there keep the seed frame's appearance.
    fn built_here(&self, start: &Start, frame: &Frame) -> Result<Tracker> {
        let mut t = self.tracker(&start.seeds, frame);
        if start.seeds.frame != self.plan().seed_frame {
            t.adopt_hidden_from(&self.seed_tracker()?, frame);
        }
        Ok(t)
    }

    /// Tracks from segment `first_segment` (whose file must exist) to the end of the clip,
    /// checkpointing after every segment, then joins `tracks.csv`, writes `report.md` and marks
    /// the manifest complete. `frames` is the whole clip from frame 0.
    ///
    /// Frames come as images, or as [`Frame`]s whose working image the decode thread has made
    /// ([`WorkScale::frame`]); the rows are the same either way.
    pub fn run<F: Into<Frame>>(
        &mut self,
        frames: impl Iterator<Item = Result<(u64, F)>>,
        first_segment: u64,
        progress: &dyn Progress,
    ) -> Result<Finished> {
        let plan = self.plan();
        let mut frames = Frames::new(
            frames.map(|item| item.map(|(i, f)| (i, f.into()))),
            progress,
        );
        let start_frame = plan.first_frame(first_segment);
        // From segment 0, the frames before the seed frame are held, to be tracked backward
        // from it (at most `BEFORE_SEED_BYTES` of them: the latest).
        let mut before: VecDeque<(u64, Frame)> = VecDeque::new();
        let mut before_bytes = 0usize;
        let mut cur = loop {
            match frames.next()? {
                Some((idx, f)) => {
                    if idx == plan.seed_frame {
                        self.seed_image = Some(f.clone());
                    }
                    if idx == start_frame {
                        break f;
                    }
                    if first_segment == 0 && idx < plan.seed_frame {
                        before_bytes += f.bytes();
                        before.push_back((idx, f));
                        while before_bytes > BEFORE_SEED_BYTES {
                            let (_, old) = before.pop_front().expect("over the limit");
                            before_bytes -= old.bytes();
                        }
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
        // `track` keeps frames at full resolution (Lucas–Kanade between keys reads them) only
        // when keys.toml was there as it started: a file written since is left for `resume`.
        let keys = if cur.has_full() {
            keys::read(&self.run_dir, &self.names, self.width, self.height, None)?
        } else {
            Vec::new()
        };
        let mut k = first_segment;
        let mut pre = if before.is_empty() {
            Vec::new()
        } else {
            self.track_before_seed(&cur, before, &keys)?
        };
        loop {
            let (mut rows, boundary) = self.track_segment(k, &cur, &mut frames, &keys)?;
            if !pre.is_empty() {
                pre.append(&mut rows);
                rows = std::mem::take(&mut pre);
            }
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

    /// The frames before the seed frame (`before`, in order, ending just before it), tracked
    /// backward from the seed frame `seed` by a tracker built there, moved onto the keys of
    /// `keys.toml` it passes. Their rows, in frame order.
    fn track_before_seed(
        &self,
        seed: &Frame,
        before: VecDeque<(u64, Frame)>,
        keys: &[Key],
    ) -> Result<Vec<(u64, Vec<JointEstimate>)>> {
        let start = self.start(0)?;
        let seed_frame = start.seeds.frame;
        let mut pass = self.tracker_at(&start, seed, Appearance::Here)?;
        // The tracker and its gap filler see time run forward: frame `seed_frame − i` is fed
        // as `seed_frame + i`.
        let mirror = |f: u64| 2 * seed_frame - f;
        for (idx, frame) in before.iter().rev() {
            // A key of `keys.toml` giving every joint, on this frame or before it, lies ahead
            // of the pass.
            let key_ahead = keys
                .iter()
                .any(|x| x.frame <= *idx && x.gives_every_joint());
            pass.step(mirror(*idx), frame, key_ahead);
            if let Some(key) = keys.iter().find(|x| x.frame == *idx) {
                pass.move_to(key);
            }
        }
        let mut rows: Vec<(u64, Vec<JointEstimate>)> = pass
            .finish()
            .into_iter()
            .filter(|(f, _)| *f > seed_frame)
            .map(|(f, est)| (mirror(f), est))
            .collect();
        for (f, row) in &mut rows {
            if let Some(key) = keys.iter().find(|x| x.frame == *f) {
                keyed_row(row, key);
            }
        }
        rows.reverse();
        Ok(rows)
    }
}

/// Most bytes of frames held before the seed frame to be tracked backward (about 380 frames of
/// 1280×720): a seed frame later than that leaves the earliest frames untracked.
const BEFORE_SEED_BYTES: usize = 1 << 30;
