//! Points, angles and joint boxes.
//!
//! # Conventions
//! Stated once here and kept everywhere in the crate:
//! - **Image space**: pixels as `f32`; origin at the top-left corner of the frame; x to the right,
//!   y down; pixel centres lie on integer coordinates (pixel (3, 4) covers [2.5, 3.5] × [3.5, 4.5]).
//! - **Angles**: radians, measured from +x toward +y (clockwise on screen), as `atan2(dy, dx)`.
//!   Angle series are unwrapped (see [`unwrap_angle`]) so they never jump by 2π.
//! - **Joint boxes** are centre + size, as in the seed file; [`JointBox::corner`] converts to the
//!   top-left corner.
//! - **Time**: `frame` is the 0-based decoded index; Δt is one frame, so the Kalman filter works in
//!   px, px/frame and px/frame². Seconds exist only in exports (`frame / fps`).
//! - **Colour**: `u8`, 0–255 per channel, RGB order.

/// A position in image space (px, y down).
pub type Point = nalgebra::Point2<f32>;
/// An offset in image space (px, y down).
pub type Vector = nalgebra::Vector2<f32>;

/// A joint's rectangle: centre `(cx, cy)` in px, size `w × h` in whole px, rotated by `angle_rad`
/// about its centre (clockwise on screen, see the module conventions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointBox {
    pub cx: f32,
    pub cy: f32,
    pub w: u32,
    pub h: u32,
    pub angle_rad: f32,
}

impl JointBox {
    /// An axis-aligned box from its centre (px) and size (px).
    pub fn centred(cx: f32, cy: f32, w: u32, h: u32) -> Self {
        JointBox {
            cx,
            cy,
            w,
            h,
            angle_rad: 0.0,
        }
    }

    /// The centre as a point (px).
    pub fn centre(&self) -> Point {
        Point::new(self.cx, self.cy)
    }

    /// Top-left corner (px) of the unrotated box, in pixel-edge coordinates: a box of width `w`
    /// centred on `cx` covers `[cx - w/2, cx + w/2]`.
    pub fn corner(&self) -> (f32, f32) {
        (self.cx - self.w as f32 / 2.0, self.cy - self.h as f32 / 2.0)
    }

    /// Whether the unrotated box lies fully inside a `width × height` frame, pixel edges included
    /// (the frame covers `[-0.5, width - 0.5]` in x, see the module conventions).
    pub fn inside(&self, width: u32, height: u32) -> bool {
        let (x0, y0) = self.corner();
        let x1 = x0 + self.w as f32;
        let y1 = y0 + self.h as f32;
        x0 >= -0.5 && y0 >= -0.5 && x1 <= width as f32 - 0.5 && y1 <= height as f32 - 0.5
    }
}

/// Direction of the vector `to - from` in radians (clockwise on screen, see the conventions).
pub fn direction(from: Point, to: Point) -> f32 {
    let d = to - from;
    d.y.atan2(d.x)
}

/// Wraps an angle (radians) into `(-π, π]`.
pub fn wrap_angle(a: f32) -> f32 {
    let tau = std::f32::consts::TAU;
    let mut r = a.rem_euclid(tau);
    if r > std::f32::consts::PI {
        r -= tau;
    }
    r
}

/// Unwraps `a` (radians) so it is the representative of `a mod 2π` nearest to `prev`: an angle
/// series built with it never jumps by 2π.
pub fn unwrap_angle(prev: f32, a: f32) -> f32 {
    prev + wrap_angle(a - prev)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    #[test]
    fn wrap_stays_in_half_open_range() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-5);
        assert!((wrap_angle(-PI / 2.0) + PI / 2.0).abs() < 1e-6);
        assert!((wrap_angle(2.0 * PI + 0.25) - 0.25).abs() < 1e-5);
    }

    #[test]
    fn unwrap_crosses_pi_without_jump() {
        let prev = PI - 0.1;
        let next = -PI + 0.1; // 0.2 rad further counter-clockwise through ±π
        let u = unwrap_angle(prev, next);
        assert!((u - (PI + 0.1)).abs() < 1e-5, "{u}");
    }

    #[test]
    fn box_inside_uses_pixel_edges() {
        // A 5-px box centred on pixel 2 covers [-0.5, 4.5]: exactly inside a 5-px frame.
        assert!(JointBox::centred(2.0, 2.0, 5, 5).inside(5, 5));
        assert!(!JointBox::centred(1.9, 2.0, 5, 5).inside(5, 5));
        assert!(!JointBox::centred(2.0, 2.0, 5, 5).inside(4, 5));
    }

    #[test]
    fn direction_is_clockwise_on_screen() {
        // Straight down on screen is +π/2.
        let a = direction(Point::new(0.0, 0.0), Point::new(0.0, 10.0));
        assert!((a - PI / 2.0).abs() < 1e-6);
    }
}
