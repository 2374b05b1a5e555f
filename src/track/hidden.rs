//! Hidden joints: where a joint goes when its colour evidence has collapsed (docs/method.md §2.5:
//! the motion model keeps it on its path), and how it is found again.

use super::motion::Prediction;
use super::search::{grid_min_bounded, grid_min_bounded_serial, Window};
use super::strip::{Fit, View};
use super::tracker::Tracker;
use crate::geom::{Point, Vector};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Where the middle joint of a two-bone chain goes: at distance `l1` (px) from `a` and `l2`
/// from `c`, of the two such points the one nearer `guess` (two-bone inverse kinematics). When
/// `a` and `c` are too far apart or too close for both lengths, it lies on the line through them,
/// splitting the gap in the ratio of the lengths.
pub(super) fn two_bone(a: Point, c: Point, l1: f32, l2: f32, guess: Point) -> Point {
    let d = c - a;
    let dist = d.norm();
    if dist < 1e-3 {
        return guess;
    }
    let u = d / dist;
    // Distance from `a` along the line to the chord, and half the chord.
    let along = (dist * dist + l1 * l1 - l2 * l2) / (2.0 * dist);
    let h2 = l1 * l1 - along * along;
    if h2 <= 0.0 {
        return a + u * (dist * l1 / (l1 + l2).max(1e-3));
    }
    let n = Vector::new(-u.y, u.x);
    let base = a + u * along;
    let (p1, p2) = (base + n * h2.sqrt(), base - n * h2.sqrt());
    if (p1 - guess).norm() <= (p2 - guess).norm() {
        p1
    } else {
        p2
    }
}

impl Tracker {
    /// A hidden joint's colour evidence is not to be trusted: it keeps its predicted place
    /// relative to its parent (a hidden root: where its seen children put it), or, when one of
    /// its children is seen, the place that keeps both of its bones at their predicted lengths
    /// nearest to that (an elbow behind the torso sits where the shoulder and the seen wrist put
    /// it). Joints in `keep` (re-acquired this frame) stay where they are.
    pub(super) fn place_hidden(
        &self,
        pred: &[Prediction],
        evidence: &[f32],
        keep: &[bool],
        x: &mut [Point],
    ) {
        let seen = |j: usize| evidence[j] >= self.params.seen_share || keep[j];
        for &j in &self.order {
            if seen(j) {
                continue;
            }
            let Some(par) = self.parents[j] else {
                let from: Vec<Point> = self.children[j]
                    .iter()
                    .filter(|&&c| seen(c))
                    .map(|&c| x[c] - (pred[c].pos - pred[j].pos))
                    .collect();
                if !from.is_empty() {
                    let sum = from.iter().fold(Vector::zeros(), |a, q| a + q.coords);
                    x[j] = Point::from(sum / from.len() as f32);
                }
                continue;
            };
            let guess = x[par] + (pred[j].pos - pred[par].pos);
            x[j] = match self.children[j].iter().copied().find(|&c| seen(c)) {
                Some(c) => {
                    let l1 = (pred[j].pos - pred[par].pos).norm();
                    let l2 = (pred[c].pos - pred[j].pos).norm();
                    two_bone(x[par], x[c], l1, l2, guess)
                }
                None => guess,
            };
        }
    }

    /// Looks for hidden joint `j`'s bone all around its parent (lengths within 15 % of its
    /// current one, and any it has been seen at:
    /// [`seen_lengths`](super::strip::Strip::seen_lengths)), as it was laid and mirrored, on the
    /// search view `v`, judged on `judge`. Returns the child position and whether the bone is
    /// mirrored when enough of it fits.
    pub(super) fn reacquire(
        &self,
        v: &View,
        judge: &View,
        j: usize,
        x: &[Point],
    ) -> Option<(Point, bool)> {
        let p = &self.params;
        let s = &self.model.strips[self.model.strip_of[j]?];
        let par = self.parents[j]?;
        let d = x[j] - x[par];
        let len = d.norm().max(1.0);
        let step = (p.search_step_px / len).clamp(0.5f32.to_radians(), 5f32.to_radians());
        // Lengths within 15 % of the current one, and any it has been seen at.
        let (lo, hi) = s.seen_lengths();
        let (lo, hi) = (lo.min(len / 1.15).ln(), hi.max(len * 1.15).ln());
        let w = Window {
            centre: [d.y.atan2(d.x), 0.5 * (lo + hi)],
            half: [PI, 0.5 * (hi - lo)],
            step: [step, 0.15],
        };
        let at = |q: [f32; 2]| x[par] + Vector::new(q[0].cos(), q[0].sin()) * q[1].exp();
        // The bone as it was laid and mirrored: two independent searches, side by side, then
        // judged in this order.
        let search = |m: bool| {
            let (best, _) = grid_min_bounded(&w, p.search_max_steps, |q, limit| {
                s.coarse_cost_below(v, x[par], at(q), m, limit)
            });
            let c = at(best);
            (c, m, s.fit_as(judge, x[par], c, m))
        };
        let (laid, turned) = rayon::join(|| search(s.mirrored), || search(!s.mirrored));
        let mut found: Option<(Point, bool, f32)> = None;
        for (c, m, fit) in [laid, turned] {
            if s.found(&fit, p.reacquire_share, false)
                && found.is_none_or(|f| fit.child_end > f.2 + 0.1)
            {
                found = Some((c, m, fit.child_end));
            }
        }
        found.map(|(c, m, _)| (c, m))
    }

    /// Looks for hidden joint `j` whose parent is hidden too, with the grandparent placed: the
    /// parent on the circle around the grandparent (its bone's current length), `j` on the
    /// circle around the parent, scored by the bone between them on `v` (a coarse level: the
    /// grid is the square of a circle) and judged on `judge`. The circles' radii are the bones'
    /// current lengths and the shortest and longest each has been seen at.
    /// Returns the parent's and `j`'s positions and whether the bone is mirrored when enough
    /// of that bone fits (tried as it was laid and mirrored).
    pub(super) fn reacquire_chain(
        &self,
        v: &View,
        judge: &View,
        j: usize,
        x: &[Point],
    ) -> Option<(Point, Point, bool)> {
        let p = &self.params;
        let s = &self.model.strips[self.model.strip_of[j]?];
        let par = self.parents[j]?;
        let grand = self.parents[par]?;
        let d1 = x[par] - x[grand];
        let d2 = x[j] - x[par];
        // Both bones are hidden, so their lengths are unknown: tried at their current lengths and
        // at the shortest and longest they have been seen (a squashed cartoon arm).
        let lengths = |k: usize, now: f32| {
            let mut l = vec![now.max(1.0)];
            if let Some(si) = self.model.strip_of[k] {
                let (lo, hi) = self.model.strips[si].seen_lengths();
                l.extend(
                    [lo, hi]
                        .into_iter()
                        .filter(|&q| (q / now.max(1.0)).ln().abs() > 0.1),
                );
            }
            l
        };
        let (l1s, l2s) = (lengths(par, d1.norm()), lengths(j, d2.norm()));
        let centre = [d1.y.atan2(d1.x), d2.y.atan2(d2.x)];
        let step = |l: f32| {
            (p.search_step_px * v.img.scale / l).clamp(2f32.to_radians(), 10f32.to_radians())
        };
        // Every pair of lengths, laid as it was and mirrored: independent searches, run side by
        // side (each on one thread), then judged in this order.
        let tries: Vec<(f32, f32, bool)> = l1s
            .iter()
            .flat_map(|&a| l2s.iter().map(move |&b| (a, b)))
            .flat_map(|(a, b)| [(a, b, s.mirrored), (a, b, !s.mirrored)])
            .collect();
        let placed: Vec<(Point, Point, bool, Fit)> = tries
            .par_iter()
            .map(|&(l1, l2, m)| {
                let w = Window {
                    centre,
                    half: [PI, PI],
                    step: [step(l1), step(l2)],
                };
                let at = |q: [f32; 2]| {
                    let b = x[grand] + Vector::new(q[0].cos(), q[0].sin()) * l1;
                    (b, b + Vector::new(q[1].cos(), q[1].sin()) * l2)
                };
                let (best, _) = grid_min_bounded_serial(&w, p.search_max_steps, |q, limit| {
                    let (b, c) = at(q);
                    s.coarse_cost_below(v, b, c, m, limit)
                });
                let (b, c) = at(best);
                (b, c, m, s.fit_as(judge, b, c, m))
            })
            .collect();
        let mut found: Option<(Point, Point, bool, f32)> = None;
        for (b, c, m, fit) in placed {
            if s.found(&fit, p.reacquire_share, true)
                && found.is_none_or(|f| fit.child_end > f.3 + 0.1)
            {
                found = Some((b, c, m, fit.child_end));
            }
        }
        found.map(|(b, c, m, _)| (b, c, m))
    }

    /// Looks for hidden joints (parents first; each every `reacquire_every` frames), moving
    /// what is found and everything below it, and turning its strip over if it was found
    /// mirrored. Returns which joints were re-acquired.
    pub(super) fn reacquire_hidden(
        &mut self,
        views: &[View],
        judge: &View,
        evidence: &[f32],
        x: &mut [Point],
    ) -> Vec<bool> {
        let seen_share = self.params.seen_share;
        let every = self.params.reacquire_every.max(1) as usize;
        let v = &views[1.min(views.len() - 1)];
        let mut found = vec![false; x.len()];
        for j in self.order.clone() {
            let Some(par) = self.parents[j] else {
                continue;
            };
            // Hidden joints take turns: each is looked for every `every` frames.
            if evidence[j] >= seen_share || !(self.frame_count() + j).is_multiple_of(every) {
                continue;
            }
            if evidence[par] >= seen_share || found[par] {
                if let Some((c, m)) = self.reacquire(v, judge, j, x) {
                    self.set_mirrored(j, m);
                    let d = c - x[j];
                    for k in self.descendants_and_self(j) {
                        x[k] += d;
                    }
                    found[j] = true;
                }
            } else if let Some((b, c, m)) = self.reacquire_chain(v, judge, j, x) {
                self.set_mirrored(j, m);
                // The parent is hidden too (an elbow behind the torso): both are placed by the
                // bone between them, as far as it shows; the parent's other children follow it.
                let (db, dc) = (b - x[par], c - x[j]);
                x[par] += db;
                for &sib in &self.children[par] {
                    let d = if sib == j { dc } else { db };
                    for k in self.descendants_and_self(sib) {
                        x[k] += d;
                    }
                }
                found[par] = true;
                found[j] = true;
            }
        }
        found
    }
}

impl Tracker {
    /// Lays the strip of the bone ending at joint `j` mirrored or not.
    fn set_mirrored(&mut self, j: usize, mirrored: bool) {
        if let Some(si) = self.model.strip_of[j] {
            self.model.strips[si].mirrored = mirrored;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_bone_keeps_both_lengths_on_the_side_of_the_guess() {
        let (a, c) = (Point::new(0.0, 0.0), Point::new(8.0, 0.0));
        let up = two_bone(a, c, 5.0, 5.0, Point::new(4.0, -10.0));
        assert!((up - Point::new(4.0, -3.0)).norm() < 1e-4, "{up:?}");
        let down = two_bone(a, c, 5.0, 5.0, Point::new(4.0, 10.0));
        assert!((down - Point::new(4.0, 3.0)).norm() < 1e-4, "{down:?}");
        // Out of reach: on the line, split in the ratio of the lengths.
        let far = two_bone(a, Point::new(30.0, 0.0), 10.0, 5.0, Point::new(0.0, 5.0));
        assert!((far - Point::new(20.0, 0.0)).norm() < 1e-4, "{far:?}");
    }
}
