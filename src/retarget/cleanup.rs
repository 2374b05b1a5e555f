//! The clean-up of the tracks before retargeting (docs/method.md §4.5): points that make a jump
//! a limb cannot make are dropped and filled from their neighbours, then every joint's x and y
//! go through a Savitzky–Golay filter (a least-squares polynomial over a sliding window: it
//! smooths jitter without the lag of a running mean, and keeps peaks).
//!
//! One number sets the strength: the filter's half-window in frames ([`Cleanup::strength`]; 0
//! turns the whole clean-up off). Points the user placed (status `seed`: seed files, corrected
//! segment files and keys) are never dropped, and the filtered track is pulled back onto them
//! so they stay exact.

use super::{Motion, P64};
use crate::skeleton::Skeleton;
use nalgebra::{DMatrix, DVector};
use std::collections::BTreeMap;

/// The clean-up's setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cleanup {
    /// Half-window of the Savitzky–Golay filter, frames (window `2·strength + 1`); 0 is off.
    pub strength: usize,
}

/// The default strength: a 7-frame window.
pub const DEFAULT_STRENGTH: usize = 3;
/// The largest strength accepted (a 41-frame window).
pub const MAX_STRENGTH: usize = 20;
/// Degree of the Savitzky–Golay polynomial.
const DEGREE: usize = 2;
/// Neighbours each side that a point is compared with for the outlier test.
const NEIGHBOURS: usize = 2;
/// A point further than this fraction of its bone's median length from the median of its
/// neighbours (each side [`NEIGHBOURS`] frames) made a jump its limb cannot make: out and back
/// within a frame or two, against the motion around it.
pub const JUMP_BONE_FRACTION: f64 = 0.4;
/// The status a dropped-and-filled point is given in `retarget/clean.csv`.
pub const FILLED: &str = "filled";

impl Default for Cleanup {
    fn default() -> Self {
        Cleanup {
            strength: DEFAULT_STRENGTH,
        }
    }
}

/// A cleaned motion.
#[derive(Debug, Clone, PartialEq)]
pub struct Cleaned {
    pub motion: Motion,
    /// `[t][joint]`: true where the point was dropped as a jump and filled.
    pub dropped: Vec<Vec<bool>>,
}

impl Cleaned {
    /// Number of dropped points.
    pub fn dropped_count(&self) -> usize {
        self.dropped.iter().flatten().filter(|&&d| d).count()
    }
}

/// Cleans `motion` (joints of `skeleton`); `fixed[t][j]` marks points the user placed, which are
/// kept exactly.
pub fn clean(motion: &Motion, skeleton: &Skeleton, fixed: &[Vec<bool>], c: Cleanup) -> Cleaned {
    let frames = motion.joints.len();
    let n = skeleton.len();
    let mut dropped = vec![vec![false; n]; frames];
    if c.strength == 0 || frames < 3 {
        return Cleaned {
            motion: motion.clone(),
            dropped,
        };
    }
    let limits = jump_limits(motion, skeleton);
    let mut joints = motion.joints.clone();
    let mut coeffs = Coefficients::default();
    for j in 0..n {
        let track: Vec<P64> = motion.joints.iter().map(|f| f[j]).collect();
        let keep: Vec<bool> = (0..frames)
            .map(|t| fixed[t][j] || !is_jump(&track, t, limits[j]))
            .collect();
        for t in 0..frames {
            dropped[t][j] = !keep[t];
        }
        let filled = fill(&track, &keep);
        for axis in 0..2 {
            let x: Vec<f64> = filled.iter().map(|p| p[axis]).collect();
            let mut y = coeffs.filter(&x, c.strength);
            pin(
                &mut y,
                &x,
                &(0..frames).map(|t| fixed[t][j]).collect::<Vec<_>>(),
                c.strength,
            );
            for (f, v) in joints.iter_mut().zip(y) {
                f[j][axis] = v;
            }
        }
    }
    Cleaned {
        motion: Motion {
            frames: motion.frames.clone(),
            joints,
        },
        dropped,
    }
}

/// `[joint]`: the largest distance (px) from the median of its neighbours a point may lie:
/// [`JUMP_BONE_FRACTION`] of the median length of the bone ending at the joint (a root: of its
/// first child's bone), or of the skeleton's median bone when that is longer (a toe's short
/// bone swings as fast as the leg).
fn jump_limits(motion: &Motion, skeleton: &Skeleton) -> Vec<f64> {
    let lengths: Vec<f64> = (0..skeleton.len())
        .map(|j| {
            let other = skeleton
                .parent(j)
                .or_else(|| skeleton.children(j).first().copied());
            let len = other.map_or(0.0, |o| {
                let l: Vec<f64> = motion
                    .joints
                    .iter()
                    .map(|f| super::dist(f[j], f[o]))
                    .collect();
                super::median(&l)
            });
            len
        })
        .collect();
    let typical = super::median(&lengths);
    lengths
        .iter()
        .map(|&l| (JUMP_BONE_FRACTION * l.max(typical)).max(2.0))
        .collect()
}

/// Whether point `t` of `track` lies further than `limit` px from the per-axis median of its
/// neighbours.
fn is_jump(track: &[P64], t: usize, limit: f64) -> bool {
    let lo = t.saturating_sub(NEIGHBOURS);
    let hi = (t + NEIGHBOURS).min(track.len() - 1);
    let around: Vec<P64> = (lo..=hi).filter(|&k| k != t).map(|k| track[k]).collect();
    let m = [0, 1].map(|a| super::median(&around.iter().map(|p| p[a]).collect::<Vec<_>>()));
    super::dist(track[t], m) > limit
}

/// `track` with every point not kept replaced by the straight line between the nearest kept
/// points before and after it (the nearest one at an end).
fn fill(track: &[P64], keep: &[bool]) -> Vec<P64> {
    let kept: Vec<usize> = (0..track.len()).filter(|&t| keep[t]).collect();
    if kept.is_empty() {
        return track.to_vec();
    }
    (0..track.len())
        .map(|t| {
            if keep[t] {
                return track[t];
            }
            let after = kept.partition_point(|&k| k < t);
            match (after.checked_sub(1).map(|i| kept[i]), kept.get(after)) {
                (Some(a), Some(&b)) => {
                    let w = (t - a) as f64 / (b - a) as f64;
                    [0, 1].map(|i| track[a][i] + w * (track[b][i] - track[a][i]))
                }
                (Some(a), None) => track[a],
                (None, Some(&b)) => track[b],
                (None, None) => track[t],
            }
        })
        .collect()
}

/// Moves the filtered `y` back onto the original `x` at every fixed frame, the difference spread
/// over `strength + 1` frames each side (a tent), so a user's point stays exact without a step.
fn pin(y: &mut [f64], x: &[f64], fixed: &[bool], strength: usize) {
    let reach = (strength + 1) as f64;
    let errors: Vec<(usize, f64)> = (0..x.len())
        .filter(|&t| fixed[t])
        .map(|t| (t, x[t] - y[t]))
        .collect();
    for (t, v) in y.iter_mut().enumerate() {
        for &(k, e) in &errors {
            let w = 1.0 - (t as f64 - k as f64).abs() / reach;
            if w > 0.0 {
                *v += w * e;
            }
        }
    }
}

/// Savitzky–Golay weights, by window placement, computed once each.
#[derive(Default)]
struct Coefficients {
    /// `(first offset, last offset)` of the window relative to the frame filtered → weights.
    cache: BTreeMap<(isize, isize), Vec<f64>>,
}

impl Coefficients {
    /// The Savitzky–Golay filter of `x` with half-window `r`: each sample is the value at its
    /// frame of the degree-[`DEGREE`] least-squares polynomial over the `2r + 1` frames around
    /// it; near the ends the window slides inside the signal (the polynomial is evaluated off
    /// its centre), so the ends are neither held nor mirrored.
    fn filter(&mut self, x: &[f64], r: usize) -> Vec<f64> {
        let n = x.len() as isize;
        let r = (r as isize).min((n - 1) / 2);
        if r < 1 {
            return x.to_vec();
        }
        (0..n)
            .map(|t| {
                let lo = (t - r).clamp(0, n - 1 - 2 * r);
                let (a, b) = (lo - t, lo + 2 * r - t);
                let w = self
                    .cache
                    .entry((a, b))
                    .or_insert_with(|| weights(a, b, DEGREE));
                w.iter()
                    .enumerate()
                    .map(|(k, w)| w * x[(lo + k as isize) as usize])
                    .sum()
            })
            .collect()
    }
}

/// The weights over offsets `a..=b` whose sum with the samples is the value at offset 0 of the
/// least-squares polynomial of `degree` through them: `w = A (AᵀA)⁻¹ e₀` with `A[k][i] = kⁱ`.
fn weights(a: isize, b: isize, degree: usize) -> Vec<f64> {
    let m = (b - a + 1) as usize;
    let d = degree.min(m - 1) + 1;
    let design = DMatrix::from_fn(m, d, |k, i| ((a + k as isize) as f64).powi(i as i32));
    let normal = design.transpose() * &design;
    let mut e0 = DVector::zeros(d);
    e0[0] = 1.0;
    // Cannot fail: distinct offsets make the normal matrix of a Vandermonde design positive
    // definite when d ≤ m.
    let z = normal.cholesky().expect("positive definite").solve(&e0);
    (design * z).iter().copied().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(frames: usize) -> Motion {
        Motion {
            frames: (0..frames as u64).collect(),
            joints: (0..frames)
                .map(|t| {
                    let x = 100.0 + 3.0 * t as f64 + 0.05 * (t * t) as f64;
                    vec![[x, 50.0], [x, 150.0]]
                })
                .collect(),
        }
    }

    fn two() -> Skeleton {
        Skeleton::new(vec!["a".into(), "b".into()], vec![None, Some(0)])
    }

    #[test]
    fn a_quadratic_passes_unchanged_and_a_jump_is_dropped_and_filled() {
        let m = line(30);
        let fixed = vec![vec![false; 2]; 30];
        let c = clean(&m, &two(), &fixed, Cleanup::default());
        assert_eq!(c.dropped_count(), 0);
        for (a, b) in c
            .motion
            .joints
            .iter()
            .flatten()
            .zip(m.joints.iter().flatten())
        {
            assert!(super::super::dist(*a, *b) < 1e-9, "{a:?} {b:?}");
        }
        // Frame 12's b jumps 60 px (the bone is 100 px long): out, then back.
        let mut bad = m.clone();
        bad.joints[12][1][1] += 60.0;
        let c = clean(&bad, &two(), &fixed, Cleanup::default());
        assert_eq!(c.dropped_count(), 1);
        assert!(c.dropped[12][1]);
        assert!((c.motion.joints[12][1][1] - 150.0).abs() < 1e-9);
        // Unless the user put it there.
        let mut mine = fixed.clone();
        mine[12][1] = true;
        let c = clean(&bad, &two(), &mine, Cleanup::default());
        assert_eq!(c.dropped_count(), 0);
        assert_eq!(c.motion.joints[12][1], bad.joints[12][1]);
        // Strength 0: untouched.
        let c = clean(&bad, &two(), &fixed, Cleanup { strength: 0 });
        assert_eq!(c.motion, bad);
    }

    #[test]
    fn the_filter_cuts_jitter_without_lag() {
        // A sine with ±1.5 px alternating jitter.
        let x: Vec<f64> = (0..120)
            .map(|t| 40.0 * (t as f64 * 0.08).sin() + if t % 2 == 0 { 1.5 } else { -1.5 })
            .collect();
        let y = Coefficients::default().filter(&x, 3);
        let err = |t: usize| (y[t] - 40.0 * (t as f64 * 0.08).sin()).abs();
        // Inside, the 1.5 px jitter drops below 0.6 px; at the ends (off-centre windows) it
        // does not grow.
        let worst = (3..117).map(err).fold(0.0, f64::max);
        assert!(worst < 0.6, "worst {worst}");
        let ends = (0..120).map(err).fold(0.0, f64::max);
        assert!(ends < 1.5, "ends {ends}");
        // The first peak stays where it is (no lag): the largest value of the first half within
        // a frame of the sine's.
        let peak = (0..60).max_by(|&a, &b| y[a].total_cmp(&y[b])).unwrap();
        let true_peak = (std::f64::consts::FRAC_PI_2 / 0.08).round() as usize;
        assert!(peak.abs_diff(true_peak) <= 1, "{peak} vs {true_peak}");
    }
}
