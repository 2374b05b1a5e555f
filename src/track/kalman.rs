//! Constant-acceleration Kalman filter for one joint centre (METHOD.md eq. 4.3–4.4, with the
//! update step). State per axis `(p, p', p'')` in px, px/frame, px/frame²; Δt = 1 frame.
//! Both axes share one model, so they share one 3×3 covariance.

use crate::geom::Point;
use nalgebra::{Matrix3, Vector3};

/// Transition matrix F = [[1, Δt, Δt²/2], [0, 1, Δt], [0, 0, 1]] with Δt = 1 frame (eq. 4.3).
fn transition() -> Matrix3<f32> {
    Matrix3::new(1.0, 1.0, 0.5, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0)
}

/// Process noise Q = σ_j² G Gᵀ with G = (Δt³/6, Δt²/2, Δt): a random jerk of σ_j px/frame³.
fn process_noise(jerk_sigma: f32) -> Matrix3<f32> {
    let g = Vector3::new(1.0 / 6.0, 0.5, 1.0);
    g * g.transpose() * (jerk_sigma * jerk_sigma)
}

/// Filter state of one joint.
#[derive(Debug, Clone)]
pub struct Kalman {
    /// x-axis state (px, px/frame, px/frame²).
    pub sx: Vector3<f32>,
    /// y-axis state.
    pub sy: Vector3<f32>,
    /// Covariance, shared by both axes.
    pub cov: Matrix3<f32>,
    q: Matrix3<f32>,
}

impl Kalman {
    /// Starts at `p` at rest, with `speed_sigma` px/frame and `accel_sigma` px/frame² of prior
    /// uncertainty, and a random jerk of `jerk_sigma` px/frame³ per frame.
    pub fn new(p: Point, speed_sigma: f32, accel_sigma: f32, jerk_sigma: f32) -> Self {
        Kalman {
            sx: Vector3::new(p.x, 0.0, 0.0),
            sy: Vector3::new(p.y, 0.0, 0.0),
            cov: Matrix3::from_diagonal(&Vector3::new(
                0.25,
                speed_sigma * speed_sigma,
                accel_sigma * accel_sigma,
            )),
            q: process_noise(jerk_sigma),
        }
    }

    /// The current position estimate (px).
    pub fn position(&self) -> Point {
        Point::new(self.sx[0], self.sy[0])
    }

    /// The current velocity estimate (px/frame).
    pub fn velocity(&self) -> crate::geom::Vector {
        crate::geom::Vector::new(self.sx[1], self.sy[1])
    }

    /// Predict step: S ← F S, P ← F P Fᵀ + Q (eq. 4.3). Returns the predicted position.
    pub fn predict(&mut self) -> Point {
        let f = transition();
        self.sx = f * self.sx;
        self.sy = f * self.sy;
        self.cov = f * self.cov * f.transpose() + self.q;
        self.position()
    }

    /// Positional standard deviation (px) of the current estimate, per axis.
    pub fn position_sigma(&self) -> f32 {
        self.cov[(0, 0)].max(0.0).sqrt()
    }

    /// Update step with a measured position `z` of variance `meas_var` px² per axis (eq. 4.4).
    pub fn update(&mut self, z: Point, meas_var: f32) {
        let s = self.cov[(0, 0)] + meas_var;
        let k = self.cov.column(0) / s;
        self.sx += k * (z.x - self.sx[0]);
        self.sy += k * (z.y - self.sy[0]);
        // Joseph-free form is fine here: P ← (I − K H) P, kept symmetric.
        let kh = Matrix3::from_columns(&[k, Vector3::zeros(), Vector3::zeros()]);
        self.cov = (Matrix3::identity() - kh) * self.cov;
        self.cov = (self.cov + self.cov.transpose()) * 0.5;
    }

    /// Restarts the filter at `p` moving at `v` (px/frame) with no acceleration, with positional
    /// and speed standard deviations `pos_sigma` (px) and `speed_sigma` (px/frame). Used when a
    /// hidden joint is placed from the skeleton rather than measured.
    pub fn reset(&mut self, p: Point, v: crate::geom::Vector, pos_sigma: f32, speed_sigma: f32) {
        self.sx = Vector3::new(p.x, v.x, 0.0);
        self.sy = Vector3::new(p.y, v.y, 0.0);
        let a = speed_sigma / 2.0;
        self.cov = Matrix3::from_diagonal(&Vector3::new(
            pos_sigma * pos_sigma,
            speed_sigma * speed_sigma,
            a * a,
        ));
    }

    /// Keeps the position inside `[lo, hi]` per axis (px), stopping motion along a clamped axis.
    pub fn clamp_to(&mut self, lo: Point, hi: Point) {
        for (s, l, h) in [(&mut self.sx, lo.x, hi.x), (&mut self.sy, lo.y, hi.y)] {
            if s[0] < l || s[0] > h {
                s[0] = s[0].clamp(l, h);
                s[1] = 0.0;
                s[2] = 0.0;
            }
        }
    }

    /// Damps velocity and acceleration (used while a joint is hidden so the prediction does not
    /// fly off along a stale velocity).
    pub fn damp(&mut self, velocity_keep: f32, accel_keep: f32) {
        self.sx[1] *= velocity_keep;
        self.sy[1] *= velocity_keep;
        self.sx[2] *= accel_keep;
        self.sy[2] *= accel_keep;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follows_exact_constant_acceleration_track() {
        // x(t) = 10 + 2t + 0.25 t², y(t) = 50 - t: after a few exact measurements the
        // prediction of the next frame is exact to within a small fraction of a pixel.
        let pos = |t: f32| Point::new(10.0 + 2.0 * t + 0.25 * t * t, 50.0 - t);
        let mut k = Kalman::new(pos(0.0), 10.0, 5.0, 0.01);
        for t in 1..40 {
            k.predict();
            k.update(pos(t as f32), 0.01);
        }
        let p = k.predict();
        let truth = pos(40.0);
        assert!((p - truth).norm() < 0.05, "{p:?} vs {truth:?}");
    }

    #[test]
    fn covariance_grows_without_updates() {
        let mut k = Kalman::new(Point::new(0.0, 0.0), 2.0, 1.0, 0.5);
        k.predict();
        let s1 = k.position_sigma();
        k.predict();
        k.predict();
        assert!(k.position_sigma() > s1);
    }
}
