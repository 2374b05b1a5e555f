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
use crate::run::segments::parse_status;
use crate::run::tracks::TrackRow;
use crate::skeleton::Skeleton;
use crate::track::Status;

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

/// Tracks as a dense table: `frames[i]` and its joints' rows `est[i]` (seed-file order).
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    pub frames: Vec<u64>,
    pub pos: Vec<Vec<Point>>,
    pub score: Vec<Vec<f32>>,
    pub status: Vec<Vec<Status>>,
}

impl Table {
    /// The table of `tracks.csv` rows (by frame, then joint; `joints` per frame). Unknown status
    /// words count as `lost`.
    pub fn from_rows(rows: &[TrackRow], joints: usize) -> Table {
        let mut t = Table {
            frames: Vec::new(),
            pos: Vec::new(),
            score: Vec::new(),
            status: Vec::new(),
        };
        for chunk in rows.chunks(joints.max(1)) {
            t.frames.push(chunk[0].frame);
            t.pos
                .push(chunk.iter().map(|r| Point::new(r.x, r.y)).collect());
            t.score.push(chunk.iter().map(|r| r.score).collect());
            t.status.push(
                chunk
                    .iter()
                    .map(|r| parse_status(&r.status).unwrap_or(Status::Lost))
                    .collect(),
            );
        }
        t
    }
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
pub fn evidence(
    t: &Table,
    sk: &Skeleton,
    sides: &[f32],
    seed_len: &[f32],
    th: &Thresholds,
) -> Evidence {
    let n = t.frames.len();
    let nj = sk.len();
    let mut m = vec![vec![0u8; nj]; n];
    let mut w = vec![vec![0f32; nj]; n];
    let outside = |v: f32, (lo, hi): (f32, f32)| v < lo || v > hi;
    for i in 0..n {
        for j in 0..nj {
            let st = t.status[i][j];
            let (mut b, mut wt) = (0u8, 0f32);
            let mut add = |bit: u8, weight: f32| {
                b |= bit;
                wt = wt.max(weight);
            };
            if st == Status::Low || (st.seen() && t.score[i][j] < th.score_min) {
                add(LOW, 0.08);
            }
            if !st.seen() {
                add(HIDDEN, 0.35);
            }
            if i >= 1 && (t.pos[i][j] - t.pos[i - 1][j]).norm() > th.jump * sides[j] {
                add(JUMP, 0.2);
            }
            if i >= 2 {
                let pred = t.pos[i - 1][j] + (t.pos[i - 1][j] - t.pos[i - 2][j]);
                let r = (t.pos[i][j] - pred).norm() / (th.residual * sides[j]);
                if r > 2.0 {
                    add(RESIDUAL, 0.45);
                } else if r > 1.0 {
                    add(RESIDUAL, 0.25);
                }
            }
            if let Some(p) = sk.parents[j] {
                let len = |k: usize| (t.pos[k][j] - t.pos[k][p]).norm();
                let l = len(i);
                if seed_len[j] > 0.0 {
                    let ratio = l / seed_len[j];
                    if outside(ratio, th.bone_range_wide) {
                        add(BONE, 0.46);
                    } else if outside(ratio, th.bone_range) {
                        add(BONE, 0.33);
                    }
                }
                if i >= 1 {
                    let from = i.saturating_sub(th.bone_window);
                    let (mut a, mut z) = (f32::MAX, 0f32);
                    for k in from..i {
                        a = a.min(len(k));
                        z = z.max(len(k));
                    }
                    let tol = th.bone_tolerance;
                    if l < a * (1.0 - tol) - 1.0 || l > z * (1.0 + tol) + 1.0 {
                        add(BONE, 0.3);
                    }
                }
            }
            m[i][j] = b;
            w[i][j] = wt;
        }
    }
    // Spread, for the listing.
    let raw: Vec<Vec<bool>> = m
        .iter()
        .map(|r| r.iter().map(|&b| b != 0).collect())
        .collect();
    let sp = th.spread as usize;
    for j in 0..nj {
        let mut last: Option<usize> = None;
        for i in 0..n {
            if raw[i][j] {
                last = Some(i);
            }
            if last.is_some_and(|l| i - l <= sp) && m[i][j] == 0 {
                m[i][j] = NEAR;
            }
        }
        let mut next: Option<usize> = None;
        for i in (0..n).rev() {
            if raw[i][j] {
                next = Some(i);
            }
            if next.is_some_and(|l| l - i <= sp) && m[i][j] == 0 {
                m[i][j] = NEAR;
            }
        }
    }
    Evidence { mask: m, weight: w }
}
