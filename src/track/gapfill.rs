//! Filling hidden stretches after the fact. While a joint is hidden the tracker can only guess
//! (it rides on its parent); once the joint is seen again, its bone's direction and length on
//! both sides of the gap are known, and the hidden frames are filled by interpolating them
//! between the two (a batch tool can afford to wait). Frames are held back while any joint is
//! hidden, at most `max_gap` frames; a gap still open then is left as tracked.
//!
//! Interpolation is relative to the parent (angle unwrapped, length linear), so a hidden forearm
//! follows its upper arm; roots are interpolated in position. Statuses and scores are kept: the
//! filled positions are inferences, and `tracks.csv` still says the joint was not seen.

use super::{JointEstimate, Status};
use crate::geom::{direction, unwrap_angle, Point, Vector};
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
            if all_seen {
                self.fill();
            }
            return self.drain();
        }
        Vec::new()
    }

    /// Hands out everything still held (gaps open at the end stay as tracked).
    pub fn finish(&mut self) -> Vec<(u64, Vec<JointEstimate>)> {
        self.drain()
    }

    fn drain(&mut self) -> Vec<(u64, Vec<JointEstimate>)> {
        let out: Vec<_> = self.pending.drain(..).collect();
        if let Some((_, e)) = out.last() {
            self.last = Some(e.clone());
        }
        out
    }

    /// Fills every closed gap in `pending` (the newest frame has every joint seen).
    fn fill(&mut self) {
        let Some(left) = self.last.clone() else {
            return;
        };
        let n = self.pending.len();
        for &j in &self.order.clone() {
            let mut k = 0;
            while k < n {
                if seen(self.pending[k].1[j].status) {
                    k += 1;
                    continue;
                }
                // Hidden from k to e-1; seen at e (exists: the newest frame is all seen).
                let mut e = k;
                while !seen(self.pending[e].1[j].status) {
                    e += 1;
                }
                let before = if k == 0 {
                    left.clone()
                } else {
                    self.pending[k - 1].1.clone()
                };
                let after = self.pending[e].1.clone();
                let span = (e - k + 1) as f32;
                for (step, f) in (k..e).enumerate() {
                    let w = (step + 1) as f32 / span;
                    let pos = match self.parents[j] {
                        None => before[j].pos + (after[j].pos - before[j].pos) * w,
                        Some(p) => {
                            let (a0, l0) = polar(before[p].pos, before[j].pos);
                            let (a1, l1) = polar(after[p].pos, after[j].pos);
                            let a1 = unwrap_angle(a0, a1);
                            let a = a0 + (a1 - a0) * w;
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
}
