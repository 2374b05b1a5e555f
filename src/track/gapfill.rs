//! Filling hidden stretches after the fact. While a joint is hidden the tracker can only guess
//! (it rides on its parent); once the joint is seen again, its bone's direction and length on
//! both sides of the gap are known, and the hidden frames are filled by interpolating them
//! between the two (a batch tool can afford to wait). Frames are held back while any joint is
//! hidden, at most `max_gap` frames; when they are handed out then (or the input ends), each
//! joint's gaps that closed within them are filled, and a gap still open is left as tracked.
//!
//! Interpolation is relative to the parent (angle unwrapped, length linear), so a hidden forearm
//! follows its upper arm; roots are interpolated in position. Where at least two frames on each
//! side of a gap see the bone, its direction follows a cubic fitted to up to five of them a side
//! (least squares), so a limb that was speeding up or turning back keeps doing so through the
//! gap; with fewer, the direction is interpolated linearly. Statuses and scores are kept: the
//! filled positions are inferences, and `tracks.csv` still says the joint was not seen.

use super::{JointEstimate, Status};
use crate::geom::{direction, unwrap_angle, Point, Vector};
use nalgebra::{DMatrix, DVector};
use std::collections::VecDeque;

/// Whether an estimate was seen (a measurement) rather than inferred.
fn seen(s: Status) -> bool {
    matches!(s, Status::Seed | Status::Ok | Status::Low)
}

/// Holds frames back until hidden gaps close, then fills them.
pub struct GapFiller {
    parents: Vec<Option<usize>>,
    order: Vec<usize>,
    max_gap: usize,
    /// The last frame handed out (the left context of any gap), if any.
    last: Option<Vec<JointEstimate>>,
    pending: VecDeque<(u64, Vec<JointEstimate>)>,
}

impl GapFiller {
    /// `order` lists joints with parents before children.
    pub fn new(parents: Vec<Option<usize>>, order: Vec<usize>, max_gap: usize) -> Self {
        GapFiller {
            parents,
            order,
            max_gap,
            last: None,
            pending: VecDeque::new(),
        }
    }

    /// Adds frame `idx`; returns the frames that are final now, in order.
    pub fn push(&mut self, idx: u64, est: Vec<JointEstimate>) -> Vec<(u64, Vec<JointEstimate>)> {
        let all_seen = est.iter().all(|e| seen(e.status));
        self.pending.push_back((idx, est));
        if all_seen || self.pending.len() > self.max_gap {
            self.fill();
            return self.drain();
        }
        Vec::new()
    }

    /// Hands out everything still held, gaps closed within it filled (gaps open at the end stay
    /// as tracked).
    pub fn finish(&mut self) -> Vec<(u64, Vec<JointEstimate>)> {
        self.fill();
        self.drain()
    }

    /// Fills every closed gap of `rows` at once, with the frames on both sides of each gap at
    /// hand (a whole segment after its passes are blended), and hands them back.
    pub fn fill_all(
        &mut self,
        rows: Vec<(u64, Vec<JointEstimate>)>,
    ) -> Vec<(u64, Vec<JointEstimate>)> {
        self.pending.extend(rows);
        self.fill();
        self.drain()
    }

    fn drain(&mut self) -> Vec<(u64, Vec<JointEstimate>)> {
        let out: Vec<_> = self.pending.drain(..).collect();
        if let Some((_, e)) = out.last() {
            self.last = Some(e.clone());
        }
        out
    }

    /// Fills every gap in `pending` whose joint is seen again within it. When the newest frame
    /// has every joint seen, that is every gap; when frames are handed out because the limit
    /// is reached or the input ends, a joint still hidden on the newest frame keeps its last
    /// gap as tracked, while the others' gaps are filled. A gap at the very start (nothing
    /// handed out yet) has no left side and stays as tracked.
    fn fill(&mut self) {
        let n = self.pending.len();
        for &j in &self.order.clone() {
            let mut k = 0;
            while k < n {
                if seen(self.pending[k].1[j].status) {
                    k += 1;
                    continue;
                }
                // Hidden from k to e-1; seen at e.
                let mut e = k;
                while e < n && !seen(self.pending[e].1[j].status) {
                    e += 1;
                }
                if e == n {
                    break; // still hidden on the newest frame
                }
                let before = match (k, &self.last) {
                    (0, None) => {
                        k = e + 1;
                        continue;
                    }
                    (0, Some(left)) => left.clone(),
                    _ => self.pending[k - 1].1.clone(),
                };
                let after = self.pending[e].1.clone();
                let span = (e - k + 1) as f32;
                let curve = self.parents[j].and_then(|p| self.angle_curve(j, p, k, e));
                for (step, f) in (k..e).enumerate() {
                    let w = (step + 1) as f32 / span;
                    let pos = match self.parents[j] {
                        None => before[j].pos + (after[j].pos - before[j].pos) * w,
                        Some(p) => {
                            let (a0, l0) = polar(before[p].pos, before[j].pos);
                            let (a1, l1) = polar(after[p].pos, after[j].pos);
                            let a1 = unwrap_angle(a0, a1);
                            let a = match &curve {
                                Some(c) => c.at(f as f64 - k as f64) as f32,
                                None => a0 + (a1 - a0) * w,
                            };
                            let l = l0 + (l1 - l0) * w;
                            let par: Point = self.pending[f].1[p].pos;
                            par + Vector::new(a.cos(), a.sin()) * l
                        }
                    };
                    self.pending[f].1[j].pos = pos;
                }
                k = e + 1;
            }
        }
    }

    /// The direction of bone `p -> j` over the gap `k..e` of `pending`, as a cubic fitted by
    /// least squares to the frames on either side where both joints are seen (up to `CONTEXT`
    /// a side, contiguous); `None` (interpolate linearly) with fewer than two on either side.
    /// A limb seldom swings at a steady rate: the frames around a gap tell how it was turning
    /// into it and out of it, which a straight line between its two ends ignores.
    fn angle_curve(&self, j: usize, p: usize, k: usize, e: usize) -> Option<Cubic> {
        let both = |f: usize| {
            let row = &self.pending[f].1;
            seen(row[j].status) && seen(row[p].status)
        };
        let left: Vec<usize> = (0..k)
            .rev()
            .take(CONTEXT)
            .take_while(|&f| both(f))
            .collect();
        let right: Vec<usize> = (e..self.pending.len())
            .take(CONTEXT)
            .take_while(|&f| both(f))
            .collect();
        if left.len() < 2 || right.len() < 2 {
            return None;
        }
        let angle = |f: usize| direction(self.pending[f].1[p].pos, self.pending[f].1[j].pos);
        // Unwrapped outward from each end, the right end from the left one.
        let a0 = angle(left[0]);
        let a1 = unwrap_angle(a0, angle(right[0]));
        let mut samples = Vec::with_capacity(left.len() + right.len());
        let mut prev = a0;
        for &f in &left {
            prev = unwrap_angle(prev, angle(f));
            samples.push((f as f64 - k as f64, prev as f64));
        }
        prev = a1;
        for &f in &right {
            prev = unwrap_angle(prev, angle(f));
            samples.push((f as f64 - k as f64, prev as f64));
        }
        Cubic::fit(&samples)
    }
}

/// Seen frames used on each side of a gap to fit the bone's direction through it.
const CONTEXT: usize = 5;

/// `c0 + c1 t + c2 t² + c3 t³`.
struct Cubic([f64; 4]);

impl Cubic {
    /// Least squares through `(t, value)` samples (at least four).
    fn fit(samples: &[(f64, f64)]) -> Option<Cubic> {
        let a = DMatrix::from_fn(samples.len(), 4, |r, c| samples[r].0.powi(c as i32));
        let b = DVector::from_iterator(samples.len(), samples.iter().map(|s| s.1));
        let x = a.svd(true, true).solve(&b, 1e-9).ok()?;
        Some(Cubic([x[0], x[1], x[2], x[3]]))
    }

    fn at(&self, t: f64) -> f64 {
        let c = &self.0;
        c[0] + t * (c[1] + t * (c[2] + t * c[3]))
    }
}

/// Direction (radians) and length (px) of the bone from `p` to `c`.
fn polar(p: Point, c: Point) -> (f32, f32) {
    (direction(p, c), (c - p).norm())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn est(x: f32, y: f32, status: Status) -> JointEstimate {
        JointEstimate {
            pos: Point::new(x, y),
            angle_rad: 0.0,
            score: 1.0,
            status,
        }
    }

    #[test]
    fn a_hidden_child_swings_between_its_seen_ends() {
        // Parent fixed at the origin; the child at 10 px, seen at 0°, hidden twice, seen at 90°.
        let mut g = GapFiller::new(vec![None, Some(0)], vec![0, 1], 100);
        let root = est(0.0, 0.0, Status::Ok);
        assert_eq!(g.push(0, vec![root, est(10.0, 0.0, Status::Seed)]).len(), 1);
        assert!(g
            .push(1, vec![root, est(9.0, 0.0, Status::Occluded)])
            .is_empty());
        assert!(g
            .push(2, vec![root, est(9.0, 0.0, Status::Occluded)])
            .is_empty());
        let out = g.push(3, vec![root, est(0.0, 10.0, Status::Ok)]);
        assert_eq!(out.len(), 3);
        let p1 = out[0].1[1].pos;
        let a = 30f32.to_radians();
        assert!(
            (p1 - Point::new(10.0 * a.cos(), 10.0 * a.sin())).norm() < 1e-3,
            "{p1:?}"
        );
        assert_eq!(out[0].1[1].status, Status::Occluded);
    }

    #[test]
    fn a_gap_longer_than_the_limit_is_left_as_tracked() {
        let mut g = GapFiller::new(vec![None], vec![0], 2);
        g.push(0, vec![est(0.0, 0.0, Status::Seed)]);
        assert!(g.push(1, vec![est(5.0, 0.0, Status::Occluded)]).is_empty());
        assert!(g.push(2, vec![est(5.0, 0.0, Status::Occluded)]).is_empty());
        let out = g.push(3, vec![est(5.0, 0.0, Status::Occluded)]);
        assert_eq!(out.len(), 3);
        assert!(out.iter().all(|(_, e)| e[0].pos.x == 5.0));
        assert_eq!(g.finish().len(), 0);
    }

    #[test]
    fn a_closed_gap_is_filled_while_another_joint_stays_hidden() {
        // Two roots: joint 0 hidden on frames 1-2 and seen on 3; joint 1 hidden from frame 1 on,
        // so no frame is all seen and the limit (4 frames) hands frames out.
        let mut g = GapFiller::new(vec![None, None], vec![0, 1], 4);
        g.push(
            0,
            vec![est(0.0, 0.0, Status::Seed), est(0.0, 0.0, Status::Seed)],
        );
        let hid = Status::Occluded;
        assert!(g
            .push(1, vec![est(9.0, 9.0, hid), est(1.0, 0.0, hid)])
            .is_empty());
        assert!(g
            .push(2, vec![est(9.0, 9.0, hid), est(2.0, 0.0, hid)])
            .is_empty());
        assert!(g
            .push(3, vec![est(3.0, 0.0, Status::Ok), est(3.0, 0.0, hid)])
            .is_empty());
        assert!(g
            .push(4, vec![est(4.0, 0.0, Status::Ok), est(4.0, 0.0, hid)])
            .is_empty());
        let out = g.push(5, vec![est(5.0, 0.0, Status::Ok), est(5.0, 0.0, hid)]);
        assert_eq!(out.len(), 5);
        assert!((out[0].1[0].pos - Point::new(1.0, 0.0)).norm() < 1e-4);
        assert!((out[1].1[0].pos - Point::new(2.0, 0.0)).norm() < 1e-4);
        // Joint 1 is still hidden: left as tracked.
        assert_eq!(out[1].1[1].pos, Point::new(2.0, 0.0));
    }

    #[test]
    fn a_gap_at_the_very_start_has_no_left_side_and_stays() {
        let mut g = GapFiller::new(vec![None, None], vec![0, 1], 100);
        let hid = Status::Occluded;
        g.push(0, vec![est(7.0, 7.0, hid), est(0.0, 0.0, Status::Ok)]);
        g.push(1, vec![est(2.0, 0.0, Status::Ok), est(1.0, 0.0, hid)]);
        g.push(2, vec![est(2.0, 0.0, Status::Ok), est(9.0, 9.0, hid)]);
        let out = g.finish();
        assert_eq!(out.len(), 3);
        assert_eq!(out[0].1[0].pos, Point::new(7.0, 7.0));
        // Joint 1's gap (frames 1-2) is open at the end: as tracked.
        assert_eq!(out[2].1[1].pos, Point::new(9.0, 9.0));
    }

    #[test]
    fn a_gap_follows_the_turn_seen_around_it() {
        // The child turns ever faster (0.01 t² rad); hidden on frames 5-9.
        let at = |t: f32, status| {
            let a = 0.01 * t * t;
            est(10.0 * a.cos(), 10.0 * a.sin(), status)
        };
        let root = est(0.0, 0.0, Status::Ok);
        let rows: Vec<_> = (0..15u64)
            .map(|t| {
                let hidden = (5..10).contains(&t);
                let s = if hidden { Status::Occluded } else { Status::Ok };
                let child = if hidden {
                    est(10.0, 0.0, s)
                } else {
                    at(t as f32, s)
                };
                (t, vec![root, child])
            })
            .collect();
        let mut g = GapFiller::new(vec![None, Some(0)], vec![0, 1], 100);
        let out = g.fill_all(rows);
        let p = out[7].1[1].pos;
        let truth = at(7.0, Status::Ok).pos;
        assert!((p - truth).norm() < 0.01, "{p:?} against {truth:?}");
        // A straight line between the ends (0.16 rad on frame 4, 1.0 on 10) gives 0.58 rad there
        // against 0.49: 0.9 px off.
        assert_eq!(out[7].1[1].status, Status::Occluded);
    }
}
