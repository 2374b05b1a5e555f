//! Constant-acceleration Kalman filters (docs/method.md §2.1, eq. 2–3).
//!
//! [`Ca`] filters one scalar signal with state `(s, s', s'')` per frame (Δt = 1 frame): a root
//! joint's x or y (px, px/frame, px/frame²), or a bone's direction (rad) or log length. [`Kalman`]
//! pairs two of them for a position. The process noise is a random jerk of `jerk_sigma` units
//! per frame³.

use crate::geom::{Point, Vector};
use nalgebra::{Matrix3, Vector3};

/// Transition matrix F = [[1, Δt, Δt²/2], [0, 1, Δt], [0, 0, 1]] with Δt = 1 frame
/// (docs/method.md eq. 2).
fn transition() -> Matrix3<f32> {
    Matrix3::new(1.0, 1.0, 0.5, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0)
}

/// Process noise Q = σ_j² G Gᵀ with G = (Δt³/6, Δt²/2, Δt): a random jerk of σ_j per frame³.
fn process_noise(jerk_sigma: f32) -> Matrix3<f32> {
    let g = Vector3::new(1.0 / 6.0, 0.5, 1.0);
    g * g.transpose() * (jerk_sigma * jerk_sigma)
}

/// A constant-acceleration filter of one scalar signal.
#[derive(Debug, Clone, PartialEq)]
pub struct Ca {
    /// State: value, rate (per frame), acceleration (per frame²).
    pub s: Vector3<f32>,
    /// State covariance.
    pub cov: Matrix3<f32>,
    q: Matrix3<f32>,
}

impl Ca {
    /// Starts at `value`, at rest, with standard deviations `value_sigma`, `rate_sigma`
    /// (per frame) and `accel_sigma` (per frame²), and a random jerk of `jerk_sigma` per frame³.
    pub fn new(
        value: f32,
        value_sigma: f32,
        rate_sigma: f32,
        accel_sigma: f32,
        jerk_sigma: f32,
    ) -> Self {
        Ca {
            s: Vector3::new(value, 0.0, 0.0),
            cov: Matrix3::from_diagonal(&Vector3::new(
                value_sigma * value_sigma,
                rate_sigma * rate_sigma,
                accel_sigma * accel_sigma,
            )),
            q: process_noise(jerk_sigma),
        }
    }

    /// The current value.
    pub fn value(&self) -> f32 {
        self.s[0]
    }

    /// The current rate (per frame).
    pub fn rate(&self) -> f32 {
        self.s[1]
    }

    /// Standard deviation of the current value.
    pub fn sigma(&self) -> f32 {
        self.cov[(0, 0)].max(0.0).sqrt()
    }

    /// Predict step: S ← F S, P ← F P Fᵀ + Q (docs/method.md eq. 2). Returns the predicted value.
    pub fn predict(&mut self) -> f32 {
        let f = transition();
        self.s = f * self.s;
        self.cov = f * self.cov * f.transpose() + self.q;
        self.s[0]
    }

    /// Update step with a measured value `z` of variance `var` (docs/method.md eq. 3).
    pub fn update(&mut self, z: f32, var: f32) {
        let k = self.cov.column(0) / (self.cov[(0, 0)] + var);
        self.s += k * (z - self.s[0]);
        let kh = Matrix3::from_columns(&[k, Vector3::zeros(), Vector3::zeros()]);
        self.cov = (Matrix3::identity() - kh) * self.cov;
        self.cov = (self.cov + self.cov.transpose()) * 0.5;
    }

    /// Keeps the value, scales the rate by `rate_keep` and the acceleration by `accel_keep`
    /// (while a signal is unobserved, so the prediction does not run off on a stale rate).
    pub fn damp(&mut self, rate_keep: f32, accel_keep: f32) {
        self.s[1] *= rate_keep;
        self.s[2] *= accel_keep;
    }

    /// Keeps the value within `[lo, hi]`; a clamped value stops (rate and acceleration 0).
    pub fn clamp(&mut self, lo: f32, hi: f32) {
        if self.s[0] < lo || self.s[0] > hi {
            self.s[0] = self.s[0].clamp(lo, hi);
            self.s[1] = 0.0;
            self.s[2] = 0.0;
        }
    }

    /// Appends the filter (state, covariance, process noise) to `w` ([`super::state`]).
    pub fn save(&self, w: &mut super::state::bytes::Writer) {
        for v in self.s.iter().chain(self.cov.iter()).chain(self.q.iter()) {
            w.f32(*v);
        }
    }

    /// Reads back what [`Ca::save`] wrote.
    pub fn load(r: &mut super::state::bytes::Reader) -> Option<Ca> {
        let mut v = [0f32; 21];
        for x in &mut v {
            *x = r.f32()?;
        }
        Some(Ca {
            s: Vector3::from_column_slice(&v[..3]),
            cov: Matrix3::from_column_slice(&v[3..12]),
            q: Matrix3::from_column_slice(&v[12..]),
        })
    }

    /// Restarts at `value` with rate `rate`, no acceleration, and standard deviations
    /// `value_sigma` and `rate_sigma`.
    pub fn reset(&mut self, value: f32, rate: f32, value_sigma: f32, rate_sigma: f32) {
        self.s = Vector3::new(value, rate, 0.0);
        self.cov = Matrix3::from_diagonal(&Vector3::new(
            value_sigma * value_sigma,
            rate_sigma * rate_sigma,
            0.25 * rate_sigma * rate_sigma,
        ));
    }
}

/// A constant-acceleration filter of a position (px): one [`Ca`] per axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Kalman {
    pub x: Ca,
    pub y: Ca,
}

impl Kalman {
    /// Starts at `p` at rest, with `speed_sigma` px/frame and `accel_sigma` px/frame² of prior
    /// uncertainty and a random jerk of `jerk_sigma` px/frame³.
    pub fn new(p: Point, speed_sigma: f32, accel_sigma: f32, jerk_sigma: f32) -> Self {
        Kalman {
            x: Ca::new(p.x, 0.5, speed_sigma, accel_sigma, jerk_sigma),
            y: Ca::new(p.y, 0.5, speed_sigma, accel_sigma, jerk_sigma),
        }
    }

    /// The current position estimate (px).
    pub fn position(&self) -> Point {
        Point::new(self.x.value(), self.y.value())
    }

    /// The current velocity estimate (px/frame).
    pub fn velocity(&self) -> Vector {
        Vector::new(self.x.rate(), self.y.rate())
    }

    /// Predict step (docs/method.md eq. 2). Returns the predicted position.
    pub fn predict(&mut self) -> Point {
        Point::new(self.x.predict(), self.y.predict())
    }

    /// Positional standard deviation (px): the larger of the two axes.
    pub fn position_sigma(&self) -> f32 {
        self.x.sigma().max(self.y.sigma())
    }

    /// Update step with a measured position `z` of variance `var` px² per axis
    /// (docs/method.md eq. 3).
    pub fn update(&mut self, z: Point, var: f32) {
        self.x.update(z.x, var);
        self.y.update(z.y, var);
    }

    /// See [`Ca::damp`].
    pub fn damp(&mut self, rate_keep: f32, accel_keep: f32) {
        self.x.damp(rate_keep, accel_keep);
        self.y.damp(rate_keep, accel_keep);
    }

    /// Keeps the position within `[lo, hi]` per axis (see [`Ca::clamp`]).
    pub fn clamp(&mut self, lo: Point, hi: Point) {
        self.x.clamp(lo.x, hi.x);
        self.y.clamp(lo.y, hi.y);
    }

    /// Restarts at `p` moving at `v` px/frame (see [`Ca::reset`]).
    pub fn reset(&mut self, p: Point, v: Vector, pos_sigma: f32, speed_sigma: f32) {
        self.x.reset(p.x, v.x, pos_sigma, speed_sigma);
        self.y.reset(p.y, v.y, pos_sigma, speed_sigma);
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

    #[test]
    fn damping_stops_a_coasting_signal() {
        let mut c = Ca::new(0.0, 0.1, 1.0, 1.0, 0.01);
        for t in 1..10 {
            c.predict();
            c.update(t as f32, 1e-4);
        }
        assert!((c.rate() - 1.0).abs() < 0.05, "{}", c.rate());
        c.damp(0.0, 0.0);
        let v = c.value();
        assert!((c.predict() - v).abs() < 1e-6);
    }
}
