//! One tracking pass over a segment, where its tracker's appearance is built, and the frames
//! as they arrive (with progress and interruption).

use super::Key;
use crate::error::{Error, Result};
use crate::geom::Point;
use crate::progress::Progress;
use crate::track::scale::Frame;
use crate::track::{gapfill::GapFiller, JointEstimate, Tracker};
use std::collections::VecDeque;

/// Where a segment tracker's appearance model is built.
#[derive(Debug, Clone, Copy)]
pub(super) enum Appearance<'a> {
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
pub(super) struct Pass {
    tracker: Tracker,
    filler: GapFiller,
    offsets: Vec<f32>,
    out: Vec<(u64, Vec<JointEstimate>)>,
}

impl Pass {
    /// Moves the tracker onto a key's joints (the others stay where it has them), its motion
    /// filters keeping their rates, as for a corrected segment file.
    pub(super) fn move_to(&mut self, key: &Key) {
        let current = self.tracker.current();
        // A key the tracker already sits on (every keyed joint within
        // `keyed::TRACKER_HIT_PX`) leaves it as it is: restarting would only forget what it
        // knows of the joints' hiding and motion.
        let off = current
            .iter()
            .zip(&key.joints)
            .filter_map(|(e, k)| k.map(|k| (k - e.pos).norm()))
            .fold(0.0f32, f32::max);
        if off <= crate::run::keyed::TRACKER_HIT_PX {
            return;
        }
        let centres: Vec<Point> = current
            .iter()
            .zip(&key.joints)
            .map(|(e, k)| k.unwrap_or(e.pos))
            .collect();
        let keyed: Vec<bool> = key.joints.iter().map(Option::is_some).collect();
        self.tracker.restart_moving_keyed(&centres, &keyed);
    }

    /// Starts a pass of `tracker`, just built or restarted on frame `frame`, where the joints'
    /// angles from the run's seed pose are `angles`.
    pub(super) fn new(tracker: Tracker, angles: &[f32], frame: u64) -> Pass {
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

    /// Tracks frame `idx`; `key_ahead`: a key of every joint lies on or beyond it in the pass's
    /// direction ([`Tracker::set_key_ahead`]).
    pub(super) fn step(&mut self, idx: u64, frame: &Frame, key_ahead: bool) {
        self.tracker.set_key_ahead(key_ahead);
        let est = self.tracker.step(frame);
        self.out.extend(self.filler.push(idx, est));
    }

    /// Every frame's estimates, in the order they were tracked, angles from the seed pose.
    pub(super) fn finish(self) -> Vec<(u64, Vec<JointEstimate>)> {
        self.finish_keep().0
    }

    /// [`Pass::finish`], giving the tracker back too.
    pub(super) fn finish_keep(mut self) -> (Vec<(u64, Vec<JointEstimate>)>, Tracker) {
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
pub(super) struct Frames<'p, I> {
    pub(super) inner: I,
    pub(super) progress: &'p dyn Progress,
    /// One past the index of the last frame handed out.
    pub(super) count: u64,
    /// Frames read ahead and given back ([`Frames::unread`]), handed out again first.
    pub(super) pending: VecDeque<(u64, Frame)>,
}

impl<'p, I: Iterator<Item = Result<(u64, Frame)>>> Frames<'p, I> {
    pub(super) fn new(inner: I, progress: &'p dyn Progress) -> Self {
        Frames {
            inner,
            progress,
            count: 0,
            pending: VecDeque::new(),
        }
    }

    pub(super) fn next(&mut self) -> Result<Option<(u64, Frame)>> {
        if let Some((idx, frame)) = self.pending.pop_front() {
            self.count = idx + 1;
            return Ok(Some((idx, frame)));
        }
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

    /// Gives back `frames` (read in order, the last ones read): they are handed out again, in
    /// that order, before any new frame (progress counts them once).
    pub(super) fn unread(&mut self, frames: Vec<(u64, Frame)>) {
        if let Some((idx, _)) = frames.first() {
            self.count = *idx;
        }
        for f in frames.into_iter().rev() {
            self.pending.push_front(f);
        }
    }
}
