//! Whole-body re-detection: a body the tracker has lost (the character turned, crossed the
//! frame while hidden, or the tracker slid off it) is looked for over the whole frame, so a lost
//! track comes back instead of staying where it was lost (docs/method.md §2.6: the search widened
//! to the whole frame).
//!
//! A body is looked for when its root has gone unseen for a while, or when its joints are on the
//! whole unseen (a root can fit where the rest of the body does not). It is searched rigidly, in
//! the pose it had when it was lost and in its seed pose, each as it is and mirrored left to
//! right (a character that turned round), at the coarsest pyramid level; each placement is then
//! tracked into place like a frame (bone search and refinement with wide windows). Judged on the
//! judging level, the placement whose whole body fits best is taken, if the root's strips fit at
//! least `redetect_share` there and the body fits better than where the tracker has it: judged
//! by the root alone, a root hidden behind the hands on the seed frame took a left–right
//! mirrored body over one that was tracking well. The motion models of the body are then
//! restarted at rest there.

use super::motion::Prediction;
use super::search::{grid_min_bounded, Window};
use super::strip::View;
use super::Tracker;
use crate::geom::{Point, Vector};
use rayon::prelude::*;

impl Tracker {
    /// Looks for every body whose root has been unseen for
    /// [`super::TrackParams::redetect_after`] frames (then every `redetect_every` frames while it
    /// stays unseen), or whose joints are on the whole unseen (every `redetect_every` frames),
    /// with the joints at `x` and this frame's `evidence`. Moves what is found (the root and
    /// everything below it) and returns which joints moved.
    pub(super) fn redetect(
        &mut self,
        views: &[View],
        judge: &View,
        evidence: &[f32],
        x: &mut [Point],
    ) -> Vec<bool> {
        let p = self.params.clone();
        let mut found = vec![false; x.len()];
        if p.redetect_after == 0 {
            return found;
        }
        let coarse = &views[views.len() - 1];
        // Frames stepped before this one (kept in the tracker's state): the clock of the
        // looks for a body lost as a whole.
        let clock = self.timings.frames;
        let every = p.redetect_every.max(1);
        for r in 0..x.len() {
            if self.parents[r].is_some() {
                continue;
            }
            let body = self.descendants_and_self(r);
            // Looked for when its root has been hidden for a while, or when the body as a
            // whole is not seen (its joints' mean evidence under `seen_share`) though the
            // root fits: a root that fits where the rest of the body does not is no sign
            // that the body is in place, and the root is only the user's choice.
            let body_fit =
                |ev: &[f32]| body.iter().map(|&k| ev[k]).sum::<f32>() / body.len() as f32;
            let now = body_fit(evidence);
            let run = self.joints[r].hidden_run + 1;
            let root_hidden = evidence[r] < p.seen_share
                && run >= p.redetect_after
                && (run - p.redetect_after).is_multiple_of(every);
            let body_lost = now < p.seen_share && clock.is_multiple_of(every as u64);
            if !root_hidden && !body_lost {
                continue;
            }
            // Each rigid candidate is then tracked into place as a frame would be, and the
            // one whose body fits best is taken, if its root fits as on a frame where it is
            // seen and the body fits better than where it is now.
            let candidates = self.redetect_candidates(coarse, r, x, evidence);
            // Each candidate tracked into place: its evidence and joints. Those laid as they
            // are, side by side, then those mirrored (the body's strips turned over meanwhile).
            let mut tracked: Vec<Option<(Vec<f32>, Vec<Point>)>> = vec![None; candidates.len()];
            for turned in [false, true] {
                self.flip_strips(&body, turned);
                let this = &*self;
                let done: Vec<(usize, (Vec<f32>, Vec<Point>))> = candidates
                    .par_iter()
                    .enumerate()
                    .filter(|(_, (_, flip))| *flip == turned)
                    .map(|(i, (placed, _))| {
                        let mut trial = x.to_vec();
                        for (&k, &q) in body.iter().zip(placed) {
                            trial[k] = q;
                        }
                        let pred = this.wide_prediction(&trial, coarse.img.scale);
                        let mut y = this.search(views, &pred);
                        this.refine(views, &pred, &mut y);
                        (i, (this.evidence(&this.fits(judge, &y)), y))
                    })
                    .collect();
                self.flip_strips(&body, turned);
                for (i, t) in done {
                    tracked[i] = Some(t);
                }
            }
            let mut best: Option<(f32, Vec<Point>, bool)> = None;
            for ((_, flip), t) in candidates.iter().zip(tracked) {
                let (ev, y) = t.expect("every candidate tracked");
                if ev[r] < p.redetect_share || self.on_another_body(r, y[r], x, evidence) {
                    continue;
                }
                let fit = body_fit(&ev);
                if fit > now && best.as_ref().is_none_or(|b| fit > b.0) {
                    best = Some((fit, body.iter().map(|&k| y[k]).collect(), *flip));
                }
            }
            if let Some((_, placed, flip)) = best {
                for (&k, &q) in body.iter().zip(&placed) {
                    x[k] = q;
                    found[k] = true;
                }
                self.flip_strips(&body, flip);
                self.restart_motion(&body, x);
            }
        }
        found
    }

    /// The best rigid placement over the whole frame of root `r`'s body (joints in
    /// [`Tracker::descendants_and_self`] order) in each of its poses (as at `x`, as on the seed
    /// frame) laid as it is and mirrored, on the coarse view `v`; never on another body seen
    /// there (`evidence`, see [`Tracker::on_another_body`]).
    fn redetect_candidates(
        &self,
        v: &View,
        r: usize,
        x: &[Point],
        evidence: &[f32],
    ) -> Vec<(Vec<Point>, bool)> {
        let body = self.descendants_and_self(r);
        let strips: Vec<usize> = body
            .iter()
            .filter_map(|&k| self.model.strip_of[k])
            .collect();
        if strips.is_empty() {
            return Vec::new();
        }
        let slot = |j: usize| body.iter().position(|&k| k == j).unwrap_or(0);
        let step = 2.0 * v.img.scale;
        let w = Window {
            centre: [0.5 * self.frame_max.x, 0.5 * self.frame_max.y],
            half: [0.5 * self.frame_max.x, 0.5 * self.frame_max.y],
            step: [step, step],
        };
        // The four searches are independent: side by side, kept in this order.
        let tries: Vec<(&[Point], bool)> = [x, &self.seed_pos[..]]
            .into_iter()
            .flat_map(|pose| [(pose, false), (pose, true)])
            .collect();
        tries
            .par_iter()
            .map(|&(pose, flip)| {
                // The body relative to its root, mirrored left to right when `flip`.
                let rel: Vec<Vector> = body
                    .iter()
                    .map(|&k| {
                        let d = pose[k] - pose[r];
                        Vector::new(if flip { -d.x } else { d.x }, d.y)
                    })
                    .collect();
                // The mean coarse cost of the body's strips with the root at `q`, given up
                // (infinite) once it cannot be below `limit` (see `Strip::coarse_cost_until`).
                let count = strips.len() as f32;
                let cost = |q: [f32; 2], limit: f32| {
                    if self.on_another_body(r, Point::new(q[0], q[1]), x, evidence) {
                        return f32::INFINITY;
                    }
                    let at = |j: usize| Point::new(q[0], q[1]) + rel[slot(j)];
                    let mut sum = 0.0;
                    for &si in &strips {
                        let s = &self.model.strips[si];
                        let reached = |m: f32| (sum + m) / count >= limit;
                        let (a, b, m) = (at(s.parent), at(s.child), s.mirrored ^ flip);
                        match s.coarse_cost_until(v, a, b, m, reached) {
                            Some(c) => sum += c,
                            None => return f32::INFINITY,
                        }
                    }
                    sum / count
                };
                let (q, _) = grid_min_bounded(&w, self.params.search_max_steps, cost);
                let at = Point::new(q[0], q[1]);
                (rel.iter().map(|&d| at + d).collect(), flip)
            })
            .collect()
    }

    /// Predictions centred on `x` with windows wide enough to pull a rigidly placed body onto
    /// its limbs: a root within two coarse steps (`scale` px each), bones within the widest
    /// angle window.
    fn wide_prediction(&self, x: &[Point], scale: f32) -> Vec<Prediction> {
        let p = &self.params;
        (0..x.len())
            .map(|k| Prediction {
                pos: x[k],
                sigma: match self.parents[k] {
                    None => 2.0 * scale / p.search_sigmas.max(1e-3),
                    Some(_) => p.angle_max_deg.to_radians() / p.search_sigmas.max(1e-3),
                },
                len_sigma: p.stretch_max / p.search_sigmas.max(1e-3),
            })
            .collect()
    }

    /// Turns the strips of `body` over when `flip`.
    fn flip_strips(&mut self, body: &[usize], flip: bool) {
        if !flip {
            return;
        }
        for &k in body {
            if let Some(si) = self.model.strip_of[k] {
                let s = &mut self.model.strips[si];
                s.mirrored = !s.mirrored;
            }
        }
    }

    /// Restarts the motion models of `body` (a root first) at rest at `x`.
    fn restart_motion(&mut self, body: &[usize], x: &[Point]) {
        for &k in body {
            self.joints[k].motion = self.motion_at_rest(k, x);
        }
    }
}
