//! Locating the joints on a frame: the coarse search (docs/method.md §2.3, eq. 7–8, an exhaustive
//! search over windows sized by the motion model) and the joint Gauss–Newton refinement.

use super::model::End;
use super::motion::Prediction;
use super::search::{grid_min_bounded, Window};
use super::solve::{self, LengthPrior, PositionPrior, Problem};
use super::strip::{Fit, Shape, Strip, View};
use super::tracker::Tracker;
use crate::geom::{Point, Vector};
use rayon::prelude::*;

impl Tracker {
    /// The coarse search, parents first; each joint starts where its parent's move carries its
    /// prediction. `views` are the frame's pyramid levels (finest first).
    pub(super) fn search(&self, views: &[View], pred: &[Prediction]) -> Vec<Point> {
        let p = &self.params;
        let n = self.joints.len();
        let coarse = &views[views.len() - 1];
        let middle = &views[1.min(views.len() - 1)];
        let mut x: Vec<Point> = pred.iter().map(|q| q.pos).collect();
        let mut shift = vec![Vector::zeros(); n];
        // Joints at the same depth depend only on their parents: each depth is searched in
        // parallel, and the results are written back in order (the same on any thread count).
        for depth in &self.depths {
            let found: Vec<Point> = depth
                .par_iter()
                .map(|&j| match self.parents[j] {
                    None => {
                        let radius = (p.search_sigmas * pred[j].sigma)
                            .clamp(p.search_min_px, p.search_max_px);
                        x[j] + self.search_root(coarse, j, &x, radius)
                    }
                    Some(par) => {
                        let guess = pred[j].pos + shift[par];
                        let Some(si) = self.model.strip_of[j] else {
                            return guess;
                        };
                        // The bones below, where the parent's move carries their prediction.
                        let below: Vec<(usize, Point)> = self.children[j]
                            .iter()
                            .filter_map(|&c| {
                                Some((self.model.strip_of[c]?, pred[c].pos + shift[par]))
                            })
                            .collect();
                        self.search_bone(middle, si, x[par], guess, &below, &pred[j])
                    }
                })
                .collect();
            for (&j, q) in depth.iter().zip(found) {
                x[j] = q;
                shift[j] = q - pred[j].pos;
            }
        }
        x
    }

    /// Best translation (px) of root `r` and everything below it within `radius` px, on a
    /// coarse pyramid level: every bone of the subtree at its predicted place relative to the
    /// root, so the whole body's shape anchors the search.
    fn search_root(&self, v: &View, r: usize, x: &[Point], radius: f32) -> Vector {
        let p = &self.params;
        let strips: Vec<&Strip> = self
            .descendants_and_self(r)
            .into_iter()
            .filter_map(|j| self.model.strip_of[j])
            .map(|si| &self.model.strips[si])
            .collect();
        if strips.is_empty() {
            return Vector::zeros();
        }
        let step = (p.search_step_px * v.img.scale / 2.0).min(radius.max(1.0));
        let w = Window {
            centre: [0.0, 0.0],
            half: [radius, radius],
            step: [step, step],
        };
        let colour = |d: Vector| {
            strips
                .iter()
                .map(|s| s.coarse_cost(v, x[s.parent] + d, x[s.child] + d))
                .sum::<f32>()
                / strips.len() as f32
        };
        let typical =
            strips.iter().map(|s| s.typical_cost[v.img.k]).sum::<f32>() / strips.len() as f32;
        if colour(Vector::zeros()) < typical + p.search_skip_cost {
            return Vector::zeros();
        }
        let count = strips.len() as f32;
        // `colour(d)` plus the geometric term, given up (infinite) once it cannot be below
        // `limit`: the strips' costs summed so far plus a lower bound of the next one (see
        // [`Strip::coarse_cost_until`]), through the same operations.
        let (best, _) = grid_min_bounded(&w, p.search_max_steps, |q, limit| {
            let d = Vector::new(q[0], q[1]);
            let geo = p.geo_weight * d.norm_squared() / (radius * radius);
            let mut sum = 0.0;
            for s in &strips {
                let reached = |m: f32| (sum + m) / count + geo >= limit;
                match s.coarse_cost_until(v, x[s.parent] + d, x[s.child] + d, s.mirrored, reached) {
                    Some(c) => sum += c,
                    None => return f32::INFINITY,
                }
            }
            sum / count + geo
        });
        Vector::new(best[0], best[1])
    }

    /// Best position of the child end of strip `si` with its parent at `parent`, in an angle ×
    /// length window around `guess`. The bones below (`below`: strip and far end when the child
    /// is at `guess`) move rigidly with the child and add their cost, so a bone partly hidden
    /// is still placed by the next one down. The bone moves off `guess` only on real evidence:
    /// a hidden bone costs nearly 1 everywhere, and its noise must not pull it off its path.
    fn search_bone(
        &self,
        v: &View,
        si: usize,
        parent: Point,
        guess: Point,
        below: &[(usize, Point)],
        pred: &Prediction,
    ) -> Point {
        let p = &self.params;
        let s = &self.model.strips[si];
        let d = guess - parent;
        let len = d.norm().max(1.0);
        let (a0, l0) = (d.y.atan2(d.x), len.ln());
        let half_a = (p.search_sigmas * pred.sigma)
            .max(p.search_min_px / len)
            .max(p.angle_min_deg.to_radians())
            .min(p.angle_max_deg.to_radians());
        let half_l = (p.search_sigmas * pred.len_sigma).clamp(p.stretch_min, p.stretch_max);
        let w = Window {
            centre: [a0, l0],
            half: [half_a, half_l],
            step: [
                (p.search_step_px / len).min(half_a.max(1e-3)),
                (p.search_step_px / len).min(half_l),
            ],
        };
        let at = |q: [f32; 2]| parent + Vector::new(q[0].cos(), q[0].sin()) * q[1].exp();
        let n = (1 + below.len()) as f32;
        let colour = |c: Point| {
            let d = c - guess;
            let mut sum = s.coarse_cost(v, parent, c);
            for &(bi, end) in below {
                sum += self.model.strips[bi].coarse_cost(v, c, end + d);
            }
            sum / n
        };
        let here = colour(guess);
        let mut typical = s.typical_cost[v.img.k];
        for &(bi, _) in below {
            typical += self.model.strips[bi].typical_cost[v.img.k];
        }
        if here < typical / n + p.search_skip_cost {
            // As good as it gets: the refinement does the rest.
            return guess;
        }
        // `colour(at(q))` plus the geometric term, given up (infinite) once it cannot be below
        // `limit` (as in `search_root`).
        let (best, _) = grid_min_bounded(&w, p.search_max_steps, |q, limit| {
            let geo = ((q[0] - a0) / half_a).powi(2) + ((q[1] - l0) / half_l).powi(2);
            let extra = p.geo_weight * geo;
            let c = at(q);
            let d = c - guess;
            let reached = |sum: f32| sum / n + extra >= limit;
            let Some(mut sum) = s.coarse_cost_until(v, parent, c, s.mirrored, reached) else {
                return f32::INFINITY;
            };
            for &(bi, end) in below {
                let b = &self.model.strips[bi];
                let more = b.coarse_cost_until(v, c, end + d, b.mirrored, |m| reached(sum + m));
                match more {
                    Some(m) => sum += m,
                    None => return f32::INFINITY,
                }
            }
            sum / n + extra
        });
        if colour(at(best)) < here - p.move_evidence {
            at(best)
        } else {
            guess
        }
    }

    /// Gauss–Newton refinement of every joint, from the coarsest view down to
    /// `finest_level`, with the motion prior relative to each parent and the bone-length prior
    /// from the predictions.
    pub(super) fn refine(&self, views: &[View], pred: &[Prediction], x: &mut [Point]) {
        let p = &self.params;
        let strips = &self.model.strips;
        let weights = vec![p.colour_weight; strips.len()];
        let lengths: Vec<LengthPrior> = strips
            .iter()
            .zip(self.length_centres(pred))
            .map(|(s, centre)| {
                let len = (pred[s.child].pos - pred[s.parent].pos).norm().max(1.0);
                let sigma = len * pred[s.child].len_sigma.max(p.length_sigma);
                LengthPrior {
                    len: centre,
                    weight: if s.shape == Shape::Bone {
                        1.0 / (sigma * sigma)
                    } else {
                        0.0
                    },
                }
            })
            .collect();
        let positions: Vec<PositionPrior> = (0..x.len())
            .map(|j| {
                let q = &pred[j];
                let (parent, offset, s) = match self.parents[j] {
                    None => (None, q.pos.coords, q.sigma.max(3.0 * p.prior_sigma_px)),
                    Some(par) => {
                        let off = q.pos - pred[par].pos;
                        let s = (off.norm() * q.sigma.hypot(q.len_sigma)).max(p.prior_sigma_px);
                        (Some(par), off, s)
                    }
                };
                PositionPrior {
                    parent,
                    offset,
                    weight: p.prior_weight / (s * s),
                }
            })
            .collect();
        let problem = Problem {
            strips,
            strip_weight: &weights,
            lengths: &lengths,
            positions: &positions,
        };
        for v in views.iter().skip(p.finest_level).rev() {
            solve::refine(&problem, v, x, p.iterations, 2.0 * v.img.scale);
        }
    }

    /// Where each strip's bone-length prior in the refinement is centred (px): the predicted
    /// length `L̂` and the seed length `L₀` scaled with its body, blended as
    /// `L̂^(1−a) · (s·L₀)^a` with `a` = `length_anchor`. The body's scale `s` is the median of
    /// `L̂ / L₀` over its bones, so a body that comes nearer the camera grows as a whole, while
    /// one bone that creeps shorter (a uniform limb matches anywhere along itself, a shoe the
    /// colour of the floor) is held to its share of the body. Centred on `L̂` alone, a creep
    /// became the prediction and then the prior: on `fast`, toes 5–8 px short for 40 frames.
    fn length_centres(&self, pred: &[Prediction]) -> Vec<f32> {
        let strips = &self.model.strips;
        let predicted: Vec<f32> = strips
            .iter()
            .map(|s| (pred[s.child].pos - pred[s.parent].pos).norm().max(1.0))
            .collect();
        let a = self.params.length_anchor;
        if a <= 0.0 {
            return predicted;
        }
        let root = |mut j: usize| {
            while let Some(q) = self.parents[j] {
                j = q;
            }
            j
        };
        let mut ratios = vec![Vec::new(); self.joints.len()];
        for (s, &len) in strips.iter().zip(&predicted) {
            if s.shape == Shape::Bone {
                ratios[root(s.child)].push(len / s.seed_len().max(1.0));
            }
        }
        let scale: Vec<f32> = ratios
            .into_iter()
            .map(|mut r| {
                r.sort_by(f32::total_cmp);
                r.get(r.len() / 2).copied().unwrap_or(1.0)
            })
            .collect();
        strips
            .iter()
            .zip(predicted)
            .map(|(s, len)| {
                let anchored = scale[root(s.child)] * s.seed_len().max(1.0);
                len.powf(1.0 - a) * anchored.powf(a)
            })
            .collect()
    }

    /// Turns over every bone strip that fits clearly better mirrored across its axis (the
    /// character turned round), on view `v` with the joints at `x`; `fits` are the strips' fits
    /// there and are updated. Returns whether any strip turned.
    pub(super) fn flip_mirrored(&mut self, v: &View, x: &[Point], fits: &mut [Fit]) -> bool {
        let ok = self.params.ok_share;
        let mut turned = false;
        for (s, f) in self.model.strips.iter_mut().zip(fits.iter_mut()) {
            if s.shape != Shape::Bone || f.inliers >= ok {
                continue;
            }
            s.mirrored = !s.mirrored;
            let g = s.fit(v, x[s.parent], x[s.child]);
            if g.inliers > f.inliers + 0.15 {
                *f = g;
                turned = true;
            } else {
                s.mirrored = !s.mirrored;
            }
        }
        turned
    }

    /// Every strip's fit with the joints at `x`, on view `v`.
    pub(super) fn fits(&self, v: &View, x: &[Point]) -> Vec<Fit> {
        let strips = &self.model.strips;
        strips
            .par_iter()
            .map(|s| s.fit(v, x[s.parent], x[s.child]))
            .collect()
    }

    /// Evidence for each joint: the share of fitting samples in the halves of its strips nearest
    /// to it, averaged over its strips by how many samples each has there.
    pub(super) fn evidence(&self, fits: &[Fit]) -> Vec<f32> {
        self.model
            .touching
            .iter()
            .map(|t| {
                let (mut sum, mut mass) = (0.0, 0.0);
                for &(si, end) in t {
                    let f = &fits[si];
                    let (share, m) = match end {
                        End::Parent => (f.parent_end, f.parent_mass),
                        End::Child => (f.child_end, f.child_mass),
                        End::Patch => (f.inliers, 1.0),
                    };
                    sum += share * m;
                    mass += m;
                }
                if mass > 0.0 {
                    (sum / mass).min(1.0)
                } else {
                    0.0
                }
            })
            .collect()
    }
}
