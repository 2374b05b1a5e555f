//! Motion models (docs/method.md §2.1, eq. 2–3): a constant-acceleration Kalman filter of a root's
//! position, and of every other joint's bone direction and log length relative to its parent,
//! so that a swinging limb is predicted along its arc.

use super::kalman::{Ca, Kalman};
use super::TrackParams;
use crate::geom::{unwrap_angle, Point, Vector};

/// Motion model of one joint.
#[derive(Debug, Clone)]
pub(super) enum Motion {
    /// A root: its position (px).
    Root(Kalman),
    /// Any other joint: the direction (rad, unwrapped) and log length of its bone, and the log
    /// length range it is kept in (a quarter to four times its seed length).
    Bone {
        angle: Ca,
        log_len: Ca,
        log_len_range: (f32, f32),
    },
}

/// Per-frame prediction of one joint.
#[derive(Debug, Clone, Copy)]
pub(super) struct Prediction {
    /// Predicted position (px).
    pub pos: Point,
    /// Root: position sigma (px). Bone: direction sigma (rad).
    pub sigma: f32,
    /// Bone: log-length sigma.
    pub len_sigma: f32,
}

impl Motion {
    /// A root at `at` (px), at rest with `speed_sigma` px/frame of prior uncertainty.
    pub fn root(at: Point, p: &TrackParams) -> Motion {
        Motion::Root(Kalman::new(at, p.speed_sigma, 1.0, p.jerk_sigma))
    }

    /// The bone from `parent` to `child` (px), at rest with `turn_sigma` rad/frame of prior
    /// uncertainty in its turn rate.
    pub fn bone(parent: Point, child: Point, p: &TrackParams) -> Motion {
        let d = child - parent;
        let dir = d.y.atan2(d.x);
        let ln = d.norm().max(1.0).ln();
        let spread = 4f32.ln();
        Motion::Bone {
            angle: Ca::new(
                dir,
                0.01,
                p.turn_sigma,
                0.5 * p.turn_sigma,
                p.turn_jerk_sigma,
            ),
            log_len: Ca::new(
                ln,
                0.01,
                0.3 * p.turn_sigma,
                0.15 * p.turn_sigma,
                p.stretch_jerk_sigma,
            ),
            log_len_range: (ln - spread, ln + spread),
        }
    }

    /// Predict step (docs/method.md eq. 2). `parent` is the parent's predicted position (ignored
    /// for a root); a root is kept within `[0, frame_max]`.
    pub fn predict(&mut self, parent: Option<Point>, frame_max: Point) -> Prediction {
        match self {
            Motion::Root(k) => {
                k.predict();
                k.clamp(Point::origin(), frame_max);
                Prediction {
                    pos: k.position(),
                    sigma: k.position_sigma(),
                    len_sigma: 0.0,
                }
            }
            Motion::Bone {
                angle,
                log_len,
                log_len_range: (lo, hi),
            } => {
                let a = angle.predict();
                log_len.predict();
                log_len.clamp(*lo, *hi);
                let len = log_len.value().exp();
                Prediction {
                    pos: parent.unwrap_or(Point::origin()) + Vector::new(a.cos(), a.sin()) * len,
                    sigma: angle.sigma(),
                    len_sigma: log_len.sigma(),
                }
            }
        }
    }

    /// Update step (docs/method.md eq. 3) with the joint at `at` and its parent at `parent` (px),
    /// measured to within `sigma_px` (px).
    pub fn update(&mut self, at: Point, parent: Option<Point>, sigma_px: f32) {
        match self {
            Motion::Root(k) => k.update(at, sigma_px * sigma_px),
            Motion::Bone { angle, log_len, .. } => {
                let d = at - parent.unwrap_or(Point::origin());
                let len = d.norm().max(1.0);
                let var = (sigma_px / len).powi(2);
                angle.update(unwrap_angle(angle.value(), d.y.atan2(d.x)), var);
                log_len.update(len.ln(), var);
            }
        }
    }

    /// Moves the joint to `at` (its parent at `parent`, px) without touching its rates or
    /// uncertainty: a correction of where it is, not of how it moves.
    pub fn moved_to(&mut self, at: Point, parent: Option<Point>) {
        match self {
            Motion::Root(k) => {
                k.x.s[0] = at.x;
                k.y.s[0] = at.y;
            }
            Motion::Bone { angle, log_len, .. } => {
                let d = at - parent.unwrap_or(Point::origin());
                angle.s[0] = unwrap_angle(angle.value(), d.y.atan2(d.x));
                log_len.s[0] = d.norm().max(1.0).ln();
            }
        }
    }

    /// Unobserved: the speed decays so the prediction does not run off on a stale rate.
    pub fn coast(&mut self) {
        match self {
            Motion::Root(k) => k.damp(0.9, 0.0),
            Motion::Bone { angle, log_len, .. } => {
                angle.damp(0.8, 0.0);
                log_len.damp(0.5, 0.0);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_moved_joint_keeps_how_it_moves() {
        let p = TrackParams::default();
        // A bone turning 0.1 rad and a root moving 2 px a frame.
        let mut bone = Motion::bone(Point::origin(), Point::new(10.0, 0.0), &p);
        let mut root = Motion::root(Point::origin(), &p);
        for t in 1..=20 {
            let a = 0.1 * t as f32;
            bone.predict(Some(Point::origin()), Point::new(1e3, 1e3));
            bone.update(Point::new(10.0 * a.cos(), 10.0 * a.sin()), None, 0.5);
            root.predict(None, Point::new(1e3, 1e3));
            root.update(Point::new(2.0 * t as f32, 0.0), None, 0.5);
        }
        bone.moved_to(Point::new(0.0, 20.0), Some(Point::origin()));
        root.moved_to(Point::new(100.0, 50.0), None);
        let next = bone
            .predict(Some(Point::origin()), Point::new(1e3, 1e3))
            .pos;
        // From straight down (pi/2), 20 px long, it goes on turning by about 0.1 rad.
        let a = next.y.atan2(next.x);
        assert!(
            (a - (std::f32::consts::FRAC_PI_2 + 0.1)).abs() < 0.02,
            "{a}"
        );
        assert!((next.coords.norm() - 20.0).abs() < 0.5, "{next:?}");
        let next = root.predict(None, Point::new(1e3, 1e3)).pos;
        assert!((next - Point::new(102.0, 50.0)).norm() < 0.2, "{next:?}");
    }
}
