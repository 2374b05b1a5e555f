//! Evidence of tracking errors, per joint and frame, for the correction report
//! ([`super::report`]).
//!
//! Evidence, per joint and frame ([`evidence`]), each with the weight it carries: the share of
//! joint-frames showing it that were more than 10 px off, measured on the synth scenarios
//! (walk, occlude, fast, squash, noisy in segments of 30 and 150, a mixed clip in segments of
//! 40), so that a segment's weights add up to about how many of its joint-frames are that far off:
//! - **hidden** (0.35): status `occluded` or `lost`;
//! - **low** (0.08): seen poorly (status `low`, or a score under [`Thresholds::score_min`]);
//! - **jump** (0.2): moved further from the previous frame than [`Thresholds::jump`] rectangle
//!   sides;
//! - **off its motion** (0.25; 0.45 at twice the distance): further from the constant-velocity
//!   prediction of the two previous frames than [`Thresholds::residual`] rectangle sides;
//! - **bone length** (0.3; 0.33 and 0.46 outside the seed ranges): its bone's length left the
//!   range it had over the last [`Thresholds::bone_window`] frames by more than
//!   [`Thresholds::bone_tolerance`], or is outside [`Thresholds::bone_range`] (or the wider
//!   [`Thresholds::bone_range_wide`]) times its seed length.
//!
//! A joint-frame weighs the most of the evidence it shows (see [`evidence`]).

use crate::geom::Point;
use crate::skeleton::Skeleton;
use crate::track::Status;
use std::collections::VecDeque;

/// Kinds of evidence, as bits of a joint-frame's doubt mask.
pub const LOW: u8 = 1;
pub const HIDDEN: u8 = 2;
pub const JUMP: u8 = 4;
pub const RESIDUAL: u8 = 8;
pub const BONE: u8 = 16;
/// Set on the frames a doubt spreads to.
pub const NEAR: u8 = 64;

/// When evidence counts, and when a segment is flagged.
#[derive(Debug, Clone, PartialEq)]
pub struct Thresholds {
    /// A seen joint scoring under this (0–1) is doubtful.
    pub score_min: f32,
    /// Largest move between frames, in rectangle sides (the mean of `w` and `h`).
    pub jump: f32,
    /// Largest distance from the constant-velocity prediction, in rectangle sides.
    pub residual: f32,
    /// Frames over which a bone's recent length range is taken.
    pub bone_window: usize,
    /// Share a bone's length may leave its recent range by.
    pub bone_tolerance: f32,
    /// Range of a bone's length, as multiples of its seed length, and a wider one.
    pub bone_range: (f32, f32),
    pub bone_range_wide: (f32, f32),
    /// Frames a doubt spreads to, either side, in the listing.
    pub spread: u64,
    /// Need (about how many joint-frames are far off) that flags a segment.
    pub min_need: f32,
    /// Share of a segment's joint-frames its need must also reach (0–1), for long segments.
    pub min_share: f32,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            score_min: 0.5,
            jump: 1.0,
            residual: 0.25,
            bone_window: 30,
            bone_tolerance: 0.15,
            bone_range: (0.75, 1.33),
            bone_range_wide: (0.6, 1.6),
            spread: 5,
            min_need: 3.0,
            min_share: 0.005,
        }
    }
}

/// Tracks as a dense table: `frames[i]` and its joints' rows (seed-file order), for judging a
/// whole clip at once ([`evidence`]); a run's report streams instead ([`Stream`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    pub frames: Vec<u64>,
    pub pos: Vec<Vec<Point>>,
    pub score: Vec<Vec<f32>>,
    pub status: Vec<Vec<Status>>,
}

/// Evidence on every joint-frame of a table: which kinds show (bits [`LOW`] … [`BONE`], or
/// [`NEAR`] within [`Thresholds::spread`] frames of some) and what the joint-frame weighs.
#[derive(Debug, Clone, PartialEq)]
pub struct Evidence {
    pub mask: Vec<Vec<u8>>,
    pub weight: Vec<Vec<f32>>,
}

/// The evidence on every joint of every frame of `t`. `sides` is each joint's rectangle side
/// (px), `seed_len` each bone's length on the seed frame (px, by child joint; roots unused).
/// The whole table at once; [`Stream`] gives the same frame by frame.
pub fn evidence(
    t: &Table,
    sk: &Skeleton,
    sides: &[f32],
    seed_len: &[f32],
    th: &Thresholds,
) -> Evidence {
    let mut stream = Stream::new(sk, sides, seed_len, th);
    let mut judged = Vec::with_capacity(t.frames.len());
    for i in 0..t.frames.len() {
        judged.extend(stream.push(t.frames[i], &t.pos[i], &t.score[i], &t.status[i]));
    }
    judged.extend(stream.finish());
    let (mask, weight) = judged.into_iter().map(|j| (j.mask, j.weight)).unzip();
    Evidence { mask, weight }
}

/// One frame's evidence, per joint (see [`Evidence`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Judged {
    pub frame: u64,
    pub mask: Vec<u8>,
    pub weight: Vec<f32>,
}

/// [`evidence`] frame by frame, holding only the frames it looks back and ahead over (the
/// last [`Thresholds::bone_window`] bone lengths, and twice [`Thresholds::spread`] frames
/// waiting to be spread to), so that a report on a long clip takes no more memory than on a
/// short one. A frame comes out [`Thresholds::spread`] frames after it goes in; the last ones
/// at [`Stream::finish`].
pub struct Stream<'a> {
    sk: &'a Skeleton,
    sides: &'a [f32],
    seed_len: &'a [f32],
    th: &'a Thresholds,
    /// Positions on the last two frames pushed, the newest last.
    recent: VecDeque<Vec<Point>>,
    /// Each joint's bone length (0 for roots) on the last `bone_window` frames, newest last.
    lens: VecDeque<Vec<f32>>,
    /// Frames judged, with which of their joints showed evidence themselves; the oldest ones
    /// are already out and are kept only to spread to the frames after them.
    held: VecDeque<(Judged, Vec<bool>)>,
    /// Frames pushed, and frames handed out.
    pushed: usize,
    out: usize,
}

impl<'a> Stream<'a> {
    /// A stream over a clip whose joints are `sk`'s (see [`evidence`] for the rest).
    pub fn new(
        sk: &'a Skeleton,
        sides: &'a [f32],
        seed_len: &'a [f32],
        th: &'a Thresholds,
    ) -> Self {
        Stream {
            sk,
            sides,
            seed_len,
            th,
            recent: VecDeque::new(),
            lens: VecDeque::new(),
            held: VecDeque::new(),
            pushed: 0,
            out: 0,
        }
    }

    /// Judges the next frame (joints in seed-file order); returns the frame now final, if any.
    pub fn push(
        &mut self,
        frame: u64,
        pos: &[Point],
        score: &[f32],
        status: &[Status],
    ) -> Option<Judged> {
        let th = self.th;
        let nj = self.sk.len();
        let outside = |v: f32, (lo, hi): (f32, f32)| v < lo || v > hi;
        let mut mask = vec![0u8; nj];
        let mut weight = vec![0f32; nj];
        let mut len_now = vec![0f32; nj];
        for j in 0..nj {
            let st = status[j];
            let (mut b, mut wt) = (0u8, 0f32);
            let mut add = |bit: u8, weight: f32| {
                b |= bit;
                wt = wt.max(weight);
            };
            if st == Status::Low || (st.seen() && score[j] < th.score_min) {
                add(LOW, 0.08);
            }
            if !st.seen() {
                add(HIDDEN, 0.35);
            }
            let back = |k: usize| &self.recent[self.recent.len() - k];
            if !self.recent.is_empty() && (pos[j] - back(1)[j]).norm() > th.jump * self.sides[j] {
                add(JUMP, 0.2);
            }
            if self.recent.len() >= 2 {
                let pred = back(1)[j] + (back(1)[j] - back(2)[j]);
                let r = (pos[j] - pred).norm() / (th.residual * self.sides[j]);
                if r > 2.0 {
                    add(RESIDUAL, 0.45);
                } else if r > 1.0 {
                    add(RESIDUAL, 0.25);
                }
            }
            if let Some(p) = self.sk.parents[j] {
                let l = (pos[j] - pos[p]).norm();
                len_now[j] = l;
                if self.seed_len[j] > 0.0 {
                    let ratio = l / self.seed_len[j];
                    if outside(ratio, th.bone_range_wide) {
                        add(BONE, 0.46);
                    } else if outside(ratio, th.bone_range) {
                        add(BONE, 0.33);
                    }
                }
                if !self.lens.is_empty() {
                    let (mut a, mut z) = (f32::MAX, 0f32);
                    for ls in &self.lens {
                        a = a.min(ls[j]);
                        z = z.max(ls[j]);
                    }
                    let tol = th.bone_tolerance;
                    if l < a * (1.0 - tol) - 1.0 || l > z * (1.0 + tol) + 1.0 {
                        add(BONE, 0.3);
                    }
                }
            }
            mask[j] = b;
            weight[j] = wt;
        }
        self.recent.push_back(pos.to_vec());
        if self.recent.len() > 2 {
            self.recent.pop_front();
        }
        self.lens.push_back(len_now);
        if self.lens.len() > th.bone_window {
            self.lens.pop_front();
        }
        let raw = mask.iter().map(|&b| b != 0).collect();
        self.held.push_back((
            Judged {
                frame,
                mask,
                weight,
            },
            raw,
        ));
        self.pushed += 1;
        let sp = th.spread as usize;
        (self.pushed > sp).then(|| self.release())
    }

    /// The frames still held, now final (the clip has ended).
    pub fn finish(&mut self) -> Vec<Judged> {
        let mut rest = Vec::new();
        while self.out < self.pushed {
            rest.push(self.release());
        }
        rest
    }

    /// Frames held now (for tests: at most twice [`Thresholds::spread`] and one).
    pub fn held_frames(&self) -> usize {
        self.held.len()
    }

    /// Hands out the next frame: a joint with no evidence of its own there is [`NEAR`] when
    /// some frame within [`Thresholds::spread`] of it, either side, has (of those pushed).
    fn release(&mut self) -> Judged {
        let sp = self.th.spread as usize;
        // `held[0]` is frame `first` (counted from the first pushed).
        let first = self.pushed - self.held.len();
        let at = self.out - first;
        let lo = at.saturating_sub(sp);
        let hi = (at + sp).min(self.held.len() - 1);
        let mut judged = self.held[at].0.clone();
        for (j, b) in judged.mask.iter_mut().enumerate() {
            if *b == 0 && (lo..=hi).any(|k| self.held[k].1[j]) {
                *b = NEAR;
            }
        }
        self.out += 1;
        // Frames more than `spread` before the next one to go out are no longer looked at.
        while self.pushed - self.held.len() + sp < self.out {
            self.held.pop_front();
        }
        judged
    }
}
