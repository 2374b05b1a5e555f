//! Paths between two keys (docs/method.md, "Motion between keys").
//!
//! Between a key on frame `a` and a key on frame `b` (a user's correction, or the seed), every
//! joint is followed three ways once the frames in between are at hand: by Lucas–Kanade forward
//! from the key on `a`, by Lucas–Kanade backward from the key on `b`
//! ([`crate::track::flow`]), and by the appearance tracker (the guide, which starts on `a`).
//! Each way's position on frame `t` carries the variance accumulated since its key: a
//! Lucas–Kanade step adds `(e + floor)²`, `e` its forward–backward error, a step it could not
//! follow (too flat, off the frame, `e` over the limit) adds 100 px² and holds the point; a
//! guide step adds `σ²` where the tracker called the joint `ok` on both frames, else (8 px)².
//! The guide is bent onto the key on `b` (its miss shared out as its variance grew) and counts
//! from both ends. The positions are averaged with weights `(1 − λ) / V` for Lucas–Kanade from
//! `a`, `λ / V` for Lucas–Kanade from `b` and `1 / V` for the bent guide, `λ = (t − a) /
//! (b − a)`: a way counts for less the further it is from its key and the more doubtful its
//! steps were. On a key the key wins. [`Between::lk_miss`] says how far Lucas–Kanade's ways
//! land from the keys; [`keep_tracker`] judges them against the tracker's own passes.
//!
//! The doubt of the result is its standard deviation, raised to the two passes' disagreement
//! times `2 min(λ, 1 − λ)` between two keys: where forward and backward end up apart, one of
//! them lost the joint, and the frame is worth a look.
//!
//! With no key on `b` (the clip's end) the ways from `a` alone decide. Joints are independent,
//! so they are solved in parallel with the same result as in sequence.

use crate::geom::Point;
use crate::track::flow::{track_checked_again, FlowParams, GreyPyramid};
use crate::track::Status;
use rayon::prelude::*;

/// How the steps between keys are weighed.
#[derive(Debug, Clone, Copy)]
pub struct KeyedParams {
    pub flow: FlowParams,
    /// A Lucas–Kanade step whose forward–backward error exceeds this (px) is taken as failed.
    pub max_fb_px: f32,
    /// Added to a step's forward–backward error before weighing it (px): LK's own noise.
    pub floor_px: f32,
    /// The appearance tracker's step noise (px).
    pub guide_sigma_px: f32,
}

impl Default for KeyedParams {
    fn default() -> Self {
        KeyedParams {
            flow: FlowParams::default(),
            max_fb_px: 3.0,
            floor_px: 0.5,
            guide_sigma_px: 4.0,
        }
    }
}

/// A joint's solved position on a frame and its doubt: the standard deviation (px) of the
/// fused position, raised where the passes disagree (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solved {
    pub pos: Point,
    pub sigma_px: f32,
}

/// What [`solve`] finds between two keys.
#[derive(Debug, Clone)]
pub struct Between {
    /// `[t][j]`: every joint on every frame, the keys' frames included.
    pub rows: Vec<Vec<Solved>>,
    /// Per joint, how far Lucas–Kanade's two ways land from the keys they run toward (px,
    /// forward's miss plus backward's; infinite without a key at both ends).
    pub lk_miss: Vec<f32>,
    /// Per joint, how far Lucas–Kanade forward lands from the far key (px; infinite without).
    pub lk_fwd_miss: Vec<f32>,
}

/// Where the appearance tracker also ran both ways between two keys, its blend is kept for a
/// joint unless Lucas–Kanade's ways land nearer the keys than this share of the tracker's
/// ways' miss (see docs/method.md, "Motion between keys").
pub const LK_MARGIN: f32 = 0.5;

/// A tracker whose ways land within this distance (px) of the keys was right between them: it
/// stands whatever Lucas–Kanade's miss (which is then noise of the same size).
pub const TRACKER_HIT_PX: f32 = 2.0;

/// A span where the tracker called fewer than this share of its joint-frames `ok` is in doubt
/// (see [`Lead::Doubt`]).
pub const FLOW_LEADS_OK_SHARE: f32 = 0.5;

/// A span in doubt whose blend the tracker called `ok` (its body fitting as well, docs/method.md
/// §2.5) on fewer than this share of the joint-frames lost the body: Lucas–Kanade leads it
/// ([`settle`]).
pub const BODY_LOST_OK_SHARE: f32 = 0.2;

/// Which cue leads the span between two keys (docs/method.md, "Motion between keys").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lead {
    /// Lucas–Kanade landed nearer the keys than the tracker for the median joint
    /// (`ln((m_LK + 1) / (m_T + 1)) < 0`), or the span was in doubt and the tracker lost the
    /// body ([`settle`]): every joint the tracker missed follows Lucas–Kanade.
    Flow,
    /// The tracker landed nearer for the median joint but called fewer than
    /// [`FLOW_LEADS_OK_SHARE`] of the span's joint-frames `ok`: a joint follows Lucas–Kanade
    /// where Lucas–Kanade landed nearer the keys than the tracker, at any margin.
    Doubt,
    /// Neither: a joint follows Lucas–Kanade only where it landed at under [`LK_MARGIN`] of
    /// the tracker's miss.
    Tracker,
}

/// Which cue leads the span between two keys, from `misses[j]` = how far the tracker's ways and
/// Lucas–Kanade's landed from the keys (px; `None` without a key at the far end) and
/// `ok_share`, the share of the span's joint-frames where the joint's own strips fit as an `ok`
/// joint's do ([`crate::track::JointEstimate::fits_alone`]).
///
/// Which cue follows the joints depends on the footage: on flat-coloured drawings the tracker
/// lands on the keys and Lucas–Kanade slides along uniform limbs; on real video the tracker
/// loses limbs that Lucas–Kanade follows. The keys at both ends say which this span is. A
/// tracker that lost most of the span but still landed nearer the keys (a drawn character
/// turning edge-on; the dancer turning her back) does not hand every joint to Lucas–Kanade:
/// each joint goes to whichever landed nearer. Handing them all over made correcting two
/// segment files of the synth `long` clip lower its PCK@5 from 92.9 to 89.0 %. Once the span's
/// passes are blended, [`settle`] says whether such a span lost the body after all.
pub fn lead(misses: &[Option<(f32, f32)>], ok_share: f32) -> Lead {
    let mut ratios: Vec<f32> = misses
        .iter()
        .flatten()
        .map(|&(t, lk)| ((lk + 1.0) / (t + 1.0)).ln())
        .collect();
    ratios.sort_by(f32::total_cmp);
    if ratios.get(ratios.len() / 2).is_some_and(|&r| r < 0.0) {
        Lead::Flow
    } else if ok_share < FLOW_LEADS_OK_SHARE {
        Lead::Doubt
    } else {
        Lead::Tracker
    }
}

/// The lead of a span once its passes are blended: a span in doubt whose blend the tracker
/// called `ok` on fewer than [`BODY_LOST_OK_SHARE`] of its joint-frames (`body_share`) lost the
/// body, and its landing near the keys was luck: Lucas–Kanade leads it. On the dance, where she
/// turns her back (her blend `ok` on 0–11 % of such a span's joint-frames), keeping the joints
/// the tracker landed nearer scored 60.7 and 65.1 % PCK@20 over two spans of 25 frames,
/// Lucas–Kanade 79.1 and 79.4 %; the synth `long` clip turning edge-on, where the tracker is
/// right between the keys it missed, has its blend `ok` on 43 % (docs/NOTES.md).
pub fn settle(lead: Lead, body_share: f32) -> Lead {
    match lead {
        Lead::Doubt if body_share < BODY_LOST_OK_SHARE => Lead::Flow,
        l => l,
    }
}

/// Which joints keep the appearance tracker's path between two keys (the rest take
/// [`solve`]'s), `misses` as for [`lead`]: a joint without a key at the far end, or whose
/// tracker landed within [`TRACKER_HIT_PX`] of the keys, is kept; the others as [`Lead`] says.
pub fn keep_tracker(misses: &[Option<(f32, f32)>], lead: Lead) -> Vec<bool> {
    misses
        .iter()
        .map(|m| match *m {
            None => true,
            Some((t, _)) if t <= TRACKER_HIT_PX => true,
            Some((t, lk)) => match lead {
                Lead::Flow => false,
                Lead::Doubt => lk >= t,
                Lead::Tracker => lk >= LK_MARGIN * t,
            },
        })
        .collect()
}

/// Variance (px²) given to a step no Lucas–Kanade pass could follow.
const FAILED_STEP_VAR: f64 = 100.0;

/// Variance of every step of a joint [`ways_of`] leaves unfollowed (held where it starts).
const HELD_VAR: f64 = 1e12;

/// Variance (px²) of a step of the appearance tracker where it did not call the joint `ok`.
const GUESSED_STEP_VAR: f64 = 64.0;

/// One Lucas–Kanade pass of one joint over `frames` (in the order given) from `p0`: the
/// position on every frame and the variance accumulated since `p0` (px², 0 on the first).
fn pass(
    frames: &[&GreyPyramid],
    p0: Point,
    prm: &FlowParams,
    max_fb: f32,
    floor: f32,
) -> (Vec<Point>, Vec<f64>) {
    let mut pos = Vec::with_capacity(frames.len());
    let mut var = Vec::with_capacity(frames.len());
    pos.push(p0);
    var.push(0.0);
    let (mut p, mut v) = (p0, 0.0f64);
    // The window's templates around `p` on the frame the next step starts from, when known.
    let mut known = None;
    for w in frames.windows(2) {
        let (step, there) = track_checked_again(w[0], w[1], p, prm, known.take());
        match step {
            Some((q, e)) if e <= max_fb => {
                p = q;
                v += ((e + floor) as f64).powi(2);
                known = there;
            }
            _ => v += FAILED_STEP_VAR,
        }
        pos.push(p);
        var.push(v);
    }
    (pos, var)
}

/// Solves every joint's path over `frames` (frame `a` first, frame `b` last). `start` holds the
/// joints' positions on `a`, `end` on `b` when `b` is a key (`None` per joint not keyed there),
/// `guide[t][j]` the appearance tracker's position of joint `j` on the `t`-th frame (empty to
/// go without), `boxes[j]` the smaller side (px) of joint `j`'s rectangle: Lucas–Kanade's
/// window is sized to it ([`window_half`]). Returns `[t][j]`.
pub fn solve(
    frames: &[GreyPyramid],
    start: &[Point],
    end: Option<&[Option<Point>]>,
    guide: &[Vec<Point>],
    guide_ok: &[Vec<bool>],
    boxes: &[u32],
    prm: &KeyedParams,
) -> Between {
    solve_with(
        &ways(frames, start, end, boxes, prm),
        start,
        end,
        guide,
        guide_ok,
        prm,
    )
}

/// Lucas–Kanade's ways between two keys, per joint: forward from `start` and, where `end` has
/// a key, backward from it, each as positions on every frame and the variance accumulated
/// since its key (arguments as for [`solve`]).
pub struct Ways {
    per_joint: Vec<Way>,
}

/// One joint's ways: forward `(positions, variances)` and backward, in frame order.
type Way = ((Vec<Point>, Vec<f64>), Option<(Vec<Point>, Vec<f64>)>);

impl Ways {
    /// Per joint, how far the two ways land from the keys they run toward (px, forward's miss
    /// plus backward's; infinite without a key at both ends).
    pub fn misses(&self, start: &[Point], end: Option<&[Option<Point>]>) -> Vec<f32> {
        self.per_joint
            .iter()
            .enumerate()
            .map(
                |(j, ((pf, _), back))| match (end.and_then(|e| e[j]), back) {
                    (Some(kb), Some((pb, _))) => {
                        (pf[pf.len() - 1] - kb).norm() + (pb[0] - start[j]).norm()
                    }
                    _ => f32::INFINITY,
                },
            )
            .collect()
    }
}

/// Follows every joint both ways between two keys (see [`Ways`]).
pub fn ways(
    frames: &[GreyPyramid],
    start: &[Point],
    end: Option<&[Option<Point>]>,
    boxes: &[u32],
    prm: &KeyedParams,
) -> Ways {
    ways_of(frames, start, end, boxes, prm, &vec![true; start.len()])
}

/// [`ways`] for the joints where `only` holds; the others are held at `start` (every step
/// unfollowed), for a caller that keeps none of their results.
pub fn ways_of(
    frames: &[GreyPyramid],
    start: &[Point],
    end: Option<&[Option<Point>]>,
    boxes: &[u32],
    prm: &KeyedParams,
    only: &[bool],
) -> Ways {
    let fwd: Vec<&GreyPyramid> = frames.iter().collect();
    let bwd: Vec<&GreyPyramid> = frames.iter().rev().collect();
    let per_joint = (0..start.len())
        .into_par_iter()
        .map(|j| {
            if !only[j] {
                let held = (vec![start[j]; frames.len()], vec![HELD_VAR; frames.len()]);
                return (held, None);
            }
            let flow = FlowParams {
                half: window_half(boxes[j], prm.flow.half),
                ..prm.flow
            };
            let f = pass(&fwd, start[j], &flow, prm.max_fb_px, prm.floor_px);
            let b = end.and_then(|e| e[j]).map(|kb| {
                let (mut pb, mut vb) = pass(&bwd, kb, &flow, prm.max_fb_px, prm.floor_px);
                pb.reverse();
                vb.reverse();
                (pb, vb)
            });
            (f, b)
        })
        .collect();
    Ways { per_joint }
}

/// [`solve`] with Lucas–Kanade's ways already followed (by [`ways`], over the same frames and
/// keys).
pub fn solve_with(
    ways: &Ways,
    start: &[Point],
    end: Option<&[Option<Point>]>,
    guide: &[Vec<Point>],
    guide_ok: &[Vec<bool>],
    prm: &KeyedParams,
) -> Between {
    let n = ways.per_joint.first().map_or(0, |w| w.0 .0.len());
    let gvar = (prm.guide_sigma_px as f64).powi(2);
    let per_joint: Vec<(Vec<Solved>, f32)> = (0..start.len())
        .into_par_iter()
        .map(|j| {
            let ((pf, vf), back) = &ways.per_joint[j];
            let key_b = end.and_then(|e| e[j]);
            // The guide's steps weigh by what the tracker said of them: `ok` on both frames, its
            // own noise; else a step it may have guessed.
            let mut vg: Vec<f64> = vec![0.0; n];
            for t in 1..n.min(guide_ok.len()) {
                let sure = guide_ok[t - 1][j] && guide_ok[t][j];
                vg[t] = vg[t - 1] + if sure { gvar } else { GUESSED_STEP_VAR };
            }
            let pg: Vec<Point> = guide.iter().map(|g| g[j]).collect();
            // Between two keys the guide is bent onto the far one (its miss shared out as its
            // doubt grew) and counts from both ends: its doubt on a frame is what its steps
            // gathered since the nearer key.
            let mut pg = pg;
            if let (Some(kb), false) = (key_b, pg.is_empty()) {
                let total = vg[n - 1];
                let miss = kb - pg[n - 1];
                for t in 0..n {
                    let share = if total > 0.0 {
                        vg[t] / total
                    } else {
                        t as f64 / (n - 1).max(1) as f64
                    };
                    pg[t] += miss * share as f32;
                    vg[t] = vg[t].min(total - vg[t]);
                }
            }
            let fwd_miss = key_b.map_or(f32::INFINITY, |kb| (pf[n - 1] - kb).norm());
            let rows: Vec<Solved> = (0..n)
                .map(|t| {
                    // Time weights: each side counts for less the further from its key.
                    let lam = if n > 1 {
                        t as f64 / (n - 1) as f64
                    } else {
                        0.0
                    };
                    let mut sides: Vec<(Point, f64, f64)> = Vec::with_capacity(3);
                    sides.push((pf[t], vf[t], 1.0 - lam));
                    if !guide.is_empty() {
                        sides.push((pg[t], vg[t], 1.0));
                    }
                    if let Some((pb, vb)) = back {
                        sides.push((pb[t], vb[t], lam));
                    }
                    fuse(&sides, back.is_some(), lam)
                })
                .collect();
            (rows, fwd_miss)
        })
        .collect();
    Between {
        rows: (0..n)
            .map(|t| per_joint.iter().map(|p| p.0[t]).collect())
            .collect(),
        lk_miss: ways.misses(start, end),
        lk_fwd_miss: per_joint.iter().map(|p| p.1).collect(),
    }
}

/// Half the Lucas–Kanade window's side for a joint whose rectangle's smaller side is `side`
/// px: the window spans about 1.2 rectangles, so that it follows the part the user framed
/// rather than its neighbours, within 4 and `max` px.
pub fn window_half(side: u32, max: usize) -> usize {
    ((side as f32 * 0.6).round() as usize).clamp(4, max)
}

/// The `score` column for a joint solved with doubt `sigma_px`: 1 on a key, ½ at 10 px.
pub fn score(sigma_px: f32) -> f32 {
    10.0 / (10.0 + sigma_px)
}

/// A solved joint is `ok` while its doubt stays under 10 px, else `low` (worth a look). How
/// often `ok` is wrong on the dance is measured with `scripts/ok-precision` (docs/benchmarks.md).
pub fn status(sigma_px: f32) -> Status {
    if sigma_px < 10.0 {
        Status::Ok
    } else {
        Status::Low
    }
}

/// Fuses the sides' positions `(position, accumulated variance, time weight)`: weights are the
/// time weight over the variance; a side on its own key (variance 0) wins outright. The doubt
/// is the fused standard deviation, or, between two keys, the passes' disagreement scaled by
/// how far the frame is from the nearer key, whichever is larger.
fn fuse(sides: &[(Point, f64, f64)], two_keys: bool, lam: f64) -> Solved {
    if let Some(&(p, _, _)) = sides.iter().find(|s| s.1 == 0.0 && s.2 > 0.0) {
        return Solved {
            pos: p,
            sigma_px: 0.0,
        };
    }
    let (mut sw, mut sx, mut sy, mut info) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for &(p, v, tw) in sides {
        let w = tw / v;
        sw += w;
        sx += w * p.x as f64;
        sy += w * p.y as f64;
        info += 1.0 / v;
    }
    let pos = Point::new((sx / sw) as f32, (sy / sw) as f32);
    let mut sigma = (1.0 / info).sqrt();
    if two_keys {
        let (f, b) = (sides[0].0, sides[sides.len() - 1].0);
        sigma = sigma.max((f - b).norm() as f64 * 2.0 * lam.min(1.0 - lam));
    }
    Solved {
        pos,
        sigma_px: sigma as f32,
    }
}

mod spans;
pub use spans::joint_spans;

#[cfg(test)]
mod tests;
