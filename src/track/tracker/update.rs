//! After a frame is located: each joint's motion model, status and estimate (docs/method.md
//! §2.5), and which bones were seen clearly enough to learn from.

use super::super::motion::Prediction;
use super::super::strip::Placement;
use super::super::{JointEstimate, Status};
use super::Tracker;
use crate::geom::{direction, unwrap_angle, Point};

impl Tracker {
    /// Motion models and statuses from the frame's final positions `x` and `evidence`. A bone
    /// is measured only when both its ends are seen. An `anchored` joint (hidden, but placed by
    /// a child's bone found whole) is `low`, not hidden, and its filters still coast. Returns
    /// the placement of every strip whose bone was clearly seen, for [`Tracker::learn`].
    pub(super) fn update(
        &mut self,
        pred: &[Prediction],
        x: &[Point],
        evidence: &[f32],
        anchored: &[bool],
    ) -> Vec<Option<Placement>> {
        let body_fit = Self::body_fit(&self.parents, evidence);
        let p = &self.params;
        let seen = |j: usize| evidence[j] >= p.seen_share;
        for &j in &self.order {
            let e = evidence[j];
            let par = self.parents[j];
            let state = &mut self.joints[j];
            let measured = seen(j) && par.is_none_or(seen);
            if measured {
                let sigma = p.meas_sigma_px / e.max(0.1);
                state.motion.update(x[j], par.map(|q| x[q]), sigma);
            } else {
                state.motion.coast();
            }
            let stretched = par.is_some_and(|q| {
                let expected = (pred[j].pos - pred[q].pos).norm().max(1.0);
                ((x[j] - x[q]).norm() / expected - 1.0).abs() > p.bone_tolerance
            });
            let status = if seen(j) || anchored[j] {
                state.hidden_run = 0;
                if e >= p.ok_share && body_fit[j] >= p.ok_share && !(measured && stretched) {
                    Status::Ok
                } else {
                    Status::Low
                }
            } else {
                state.hidden_run += 1;
                if state.hidden_run > p.lost_after_frames {
                    Status::Lost
                } else {
                    Status::Occluded
                }
            };
            let dir = match par {
                Some(q) => Some(direction(x[q], x[j])),
                None if p.rotate_roots => self.children[j].first().map(|&c| direction(x[j], x[c])),
                None => None,
            };
            let angle_rad = dir.map_or(0.0, |d| {
                unwrap_angle(state.last.angle_rad, d - state.seed_dir)
            });
            state.last = JointEstimate {
                pos: x[j],
                angle_rad,
                score: e.clamp(0.0, 1.0),
                status,
            };
        }
        self.model
            .strips
            .iter()
            .map(|s| {
                (seen(s.parent) && seen(s.child)).then(|| s.placement(x[s.parent], x[s.child]))
            })
            .collect()
    }
}
