//! Joint refinement: all joints of a frame placed at once by Gauss–Newton (damped) on
//!
//! ```text
//! E(X) = Σ_bones K·mean_s ρ(e_s)                     colour, docs/method.md eq. 5
//!      + Σ_joints w_j |x_j − x_parent − r̂_j|²          motion prior (eq. 9)
//!      + Σ_bones w_b (|C − P| − L̂_b)²                  bones change length slowly
//! ```
//!
//! so a joint is placed by every bone that touches it: an elbow by its upper arm and forearm.
//! A bone whose samples stop fitting (hidden) loses its pull through the robust weights, and the
//! priors hold its joints where the motion model expects them.

use super::strip::{Shape, Strip, View};
use crate::geom::{Point, Vector};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// The prior on one joint: where the motion model expects it, as an offset (px) from its parent
/// (a root: from the origin), and the weight of the squared distance to it (per px²). Relative to
/// the parent, so a hidden forearm keeps following its upper arm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionPrior {
    pub parent: Option<usize>,
    pub offset: Vector,
    pub weight: f32,
}

/// The prior on the length of the bone of a strip: expected length (px) and the weight of the
/// squared difference (per px²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LengthPrior {
    pub len: f32,
    pub weight: f32,
}

/// What one refinement uses.
pub struct Problem<'a> {
    pub strips: &'a [Strip],
    /// Weight `K` of each strip's mean robust colour cost (0 leaves a strip out).
    pub strip_weight: &'a [f32],
    /// One per strip (ignored for patches).
    pub lengths: &'a [LengthPrior],
    /// One per joint.
    pub positions: &'a [PositionPrior],
}

/// Colour-scale schedule of the refinement (graduated non-convexity): a wide scale first, so
/// samples on a misplaced sharp edge still pull, then the strips' own.
const WIDEN: [f32; 3] = [4.0, 2.0, 1.0];

/// Refines `x` (px, one point a joint) by damped Gauss–Newton steps of at most `max_step` px per
/// joint: `iterations` in all, spread over the [`WIDEN`] stages; a stage ends early once no joint
/// moves by more than 0.01 px.
pub fn refine(p: &Problem, img: &View, x: &mut [Point], iterations: usize, max_step: f32) {
    let per_stage = iterations.div_ceil(WIDEN.len()).max(1);
    for widen in WIDEN {
        for _ in 0..per_stage {
            if !step(p, img, x, max_step, widen) {
                break;
            }
        }
    }
}

/// One damped Gauss–Newton step; returns whether some joint moved by more than 0.01 px.
fn step(p: &Problem, img: &View, x: &mut [Point], max_step: f32, widen: f32) -> bool {
    let n = x.len();
    {
        let mut h = DMatrix::<f64>::zeros(2 * n, 2 * n);
        let mut g = DVector::<f64>::zeros(2 * n);
        // The strips' normal equations are independent: computed in parallel, summed in order
        // (so the sum, and the result, do not depend on the threads).
        let normals: Vec<_> = p
            .strips
            .par_iter()
            .enumerate()
            .map(|(si, s)| {
                let w = p.strip_weight[si];
                (w > 0.0).then(|| s.normal(img, x[s.parent], x[s.child], w, widen))
            })
            .collect();
        for ((si, s), ne) in p.strips.iter().enumerate().zip(normals) {
            let Some(ne) = ne else {
                continue;
            };
            let idx = match s.shape {
                Shape::Bone => [2 * s.parent, 2 * s.parent + 1, 2 * s.child, 2 * s.child + 1],
                Shape::Patch => [2 * s.parent, 2 * s.parent + 1, usize::MAX, usize::MAX],
            };
            for a in 0..4 {
                if idx[a] == usize::MAX {
                    continue;
                }
                g[idx[a]] += ne.g[a];
                for b in 0..4 {
                    if idx[b] != usize::MAX {
                        h[(idx[a], idx[b])] += ne.h[a][b];
                    }
                }
            }
            if s.shape == Shape::Bone {
                let lp = p.lengths[si];
                if lp.weight > 0.0 {
                    let d = x[s.child] - x[s.parent];
                    let len = d.norm().max(1e-3);
                    let u = d / len;
                    let r = (len - lp.len) as f64;
                    let jac = [-u.x, -u.y, u.x, u.y];
                    let w = lp.weight as f64;
                    for a in 0..4 {
                        g[idx[a]] += w * jac[a] as f64 * r;
                        for b in 0..4 {
                            h[(idx[a], idx[b])] += w * (jac[a] * jac[b]) as f64;
                        }
                    }
                }
            }
        }
        for (j, pr) in p.positions.iter().enumerate() {
            if pr.weight <= 0.0 {
                continue;
            }
            let w = pr.weight as f64;
            let base = pr.parent.map_or(Vector::zeros(), |q| x[q].coords);
            let d = x[j].coords - base - pr.offset;
            for (axis, r) in [(0, d.x as f64), (1, d.y as f64)] {
                let a = 2 * j + axis;
                g[a] += w * r;
                h[(a, a)] += w;
                if let Some(q) = pr.parent {
                    let b = 2 * q + axis;
                    g[b] -= w * r;
                    h[(b, b)] += w;
                    h[(a, b)] -= w;
                    h[(b, a)] -= w;
                }
            }
        }
        // Levenberg–Marquardt damping: a little on the diagonal keeps every step defined.
        for i in 0..2 * n {
            let d = h[(i, i)];
            h[(i, i)] = d * 1.05 + 1e-6;
        }
        let Some(chol) = h.cholesky() else {
            return false;
        };
        let step = chol.solve(&(-g));
        let mut biggest = 0.0f32;
        for (j, xj) in x.iter_mut().enumerate() {
            let mut d = Vector::new(step[2 * j] as f32, step[2 * j + 1] as f32);
            if !(d.x.is_finite() && d.y.is_finite()) {
                continue;
            }
            let norm = d.norm();
            if norm > max_step {
                d *= max_step / norm;
            }
            biggest = biggest.max(d.norm());
            *xj += d;
        }
        biggest >= 0.01
    }
}
