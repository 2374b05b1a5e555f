//! Point motion between two frames by pyramidal Lucas–Kanade with a forward–backward check
//! (docs/method.md, "Motion between keys").
//!
//! A frame becomes a [`GreyPyramid`] (luma as `f32`, each level the previous one halved by 2×2
//! box averages). [`track_point`] follows one point from frame A to frame B: on every level, from
//! the coarsest down, Gauss–Newton steps on the sum of squared differences of a square window
//! around the point, with the window's gradient matrix fixed on frame A (the inverse-compositional
//! shortcut OpenCV's `calcOpticalFlowPyrLK` also takes). [`track_checked`] then follows the
//! result back from B to A: the distance between where it lands and where it started (the
//! forward–backward error, px) is the step's doubt. A window with too little texture (its
//! gradient matrix nearly singular) is refused rather than guessed.
//!
//! Conventions (px, pixel centres on integer coordinates) are [`crate::geom`]'s.

use crate::geom::Point;
use image::RgbImage;

/// One level of a grey pyramid: luma 0–255 as `f32`, row-major.
#[derive(Debug, Clone)]
pub struct GreyLevel {
    pub width: usize,
    pub height: usize,
    pub data: Vec<f32>,
}

impl GreyLevel {
    /// Bilinear sample at `(x, y)` (level px); `None` outside the level (one pixel margin).
    #[inline]
    fn sample(&self, x: f32, y: f32) -> Option<f32> {
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        let (x0, y0) = (x as usize, y as usize);
        if x0 + 1 >= self.width || y0 + 1 >= self.height {
            return None;
        }
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let i = y0 * self.width + x0;
        let d = &self.data;
        let top = d[i] + fx * (d[i + 1] - d[i]);
        let bot = d[i + self.width] + fx * (d[i + self.width + 1] - d[i + self.width]);
        Some(top + fy * (bot - top))
    }

    /// The level halved by 2×2 box averages (an odd last row or column is dropped).
    fn halved(&self) -> GreyLevel {
        let (w, h) = (self.width / 2, self.height / 2);
        let mut data = Vec::with_capacity(w * h);
        for y in 0..h {
            let r0 = &self.data[2 * y * self.width..];
            let r1 = &self.data[(2 * y + 1) * self.width..];
            for x in 0..w {
                data.push(0.25 * (r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1]));
            }
        }
        GreyLevel {
            width: w,
            height: h,
            data,
        }
    }
}

/// A frame's luma at full resolution and halved `levels - 1` times.
#[derive(Debug, Clone)]
pub struct GreyPyramid {
    pub levels: Vec<GreyLevel>,
}

impl GreyPyramid {
    /// Builds `levels` levels (at least one) from an RGB frame; luma is Rec. 601
    /// (0.299 R + 0.587 G + 0.114 B). Levels stop early once a side would fall below 16 px.
    pub fn new(img: &RgbImage, levels: usize) -> GreyPyramid {
        let (w, h) = (img.width() as usize, img.height() as usize);
        let data = img
            .pixels()
            .map(|p| 0.299 * p[0] as f32 + 0.587 * p[1] as f32 + 0.114 * p[2] as f32)
            .collect();
        let mut out = vec![GreyLevel {
            width: w,
            height: h,
            data,
        }];
        while out.len() < levels.max(1) {
            let last = out.last().expect("one level");
            if last.width < 32 || last.height < 32 {
                break;
            }
            out.push(last.halved());
        }
        GreyPyramid { levels: out }
    }
}

/// Lucas–Kanade settings. The defaults follow OpenCV's usual choice for body points: a 31 px
/// window, five levels, up to 30 steps a level, stop below 0.01 px.
#[derive(Debug, Clone, Copy)]
pub struct FlowParams {
    /// Half the window's side (px): the window is `2 * half + 1` square.
    pub half: usize,
    pub iterations: usize,
    pub epsilon: f32,
    /// Smallest eigenvalue of the window's gradient matrix, per pixel of the window, below which
    /// the window is too flat to track (gradients in grey levels per px).
    pub min_eigen: f32,
}

impl Default for FlowParams {
    fn default() -> Self {
        FlowParams {
            half: 15,
            iterations: 30,
            epsilon: 0.01,
            min_eigen: 0.05,
        }
    }
}

/// Follows `p` (px on frame `a`) to frame `b`. `None` when the window leaves the frame or is
/// too flat on some level.
pub fn track_point(a: &GreyPyramid, b: &GreyPyramid, p: Point, prm: &FlowParams) -> Option<Point> {
    let levels = a.levels.len().min(b.levels.len());
    let half = prm.half as i32;
    let n = (2 * half + 1) as usize;
    let mut tmpl = vec![0.0f32; n * n];
    let mut gx = vec![0.0f32; n * n];
    let mut gy = vec![0.0f32; n * n];
    // Displacement guess, in the current level's px.
    let (mut dx, mut dy) = (0.0f32, 0.0f32);
    for lvl in (0..levels).rev() {
        let la = &a.levels[lvl];
        let lb = &b.levels[lvl];
        let s = 1.0 / (1u32 << lvl) as f32;
        let (px, py) = (p.x * s, p.y * s);
        // Template, its gradients and their matrix on frame a.
        let (mut gxx, mut gxy, mut gyy) = (0.0f32, 0.0f32, 0.0f32);
        let mut inside = true;
        'win: for j in -half..=half {
            for i in -half..=half {
                let (x, y) = (px + i as f32, py + j as f32);
                let (Some(c), Some(l), Some(r), Some(u), Some(d)) = (
                    la.sample(x, y),
                    la.sample(x - 1.0, y),
                    la.sample(x + 1.0, y),
                    la.sample(x, y - 1.0),
                    la.sample(x, y + 1.0),
                ) else {
                    inside = false;
                    break 'win;
                };
                let k = ((j + half) as usize) * n + (i + half) as usize;
                tmpl[k] = c;
                gx[k] = 0.5 * (r - l);
                gy[k] = 0.5 * (d - u);
                gxx += gx[k] * gx[k];
                gxy += gx[k] * gy[k];
                gyy += gy[k] * gy[k];
            }
        }
        if !inside {
            // The window leaves a coarse level near the border: go on at the next finer one.
            if lvl == 0 {
                return None;
            }
            dx *= 2.0;
            dy *= 2.0;
            continue;
        }
        let area = (n * n) as f32;
        let tr = gxx + gyy;
        let det = gxx * gyy - gxy * gxy;
        let min_eig = 0.5 * (tr - ((gxx - gyy).powi(2) + 4.0 * gxy * gxy).sqrt());
        if min_eig / area < prm.min_eigen || det <= f32::EPSILON {
            return None;
        }
        for _ in 0..prm.iterations {
            let (mut bx, mut by) = (0.0f32, 0.0f32);
            for j in -half..=half {
                for i in -half..=half {
                    let k = ((j + half) as usize) * n + (i + half) as usize;
                    let v = lb.sample(px + dx + i as f32, py + dy + j as f32)?;
                    let diff = tmpl[k] - v;
                    bx += diff * gx[k];
                    by += diff * gy[k];
                }
            }
            let sx = (gyy * bx - gxy * by) / det;
            let sy = (gxx * by - gxy * bx) / det;
            dx += sx;
            dy += sy;
            if sx * sx + sy * sy < prm.epsilon * prm.epsilon {
                break;
            }
        }
        if lvl > 0 {
            dx *= 2.0;
            dy *= 2.0;
        }
    }
    let q = Point::new(p.x + dx, p.y + dy);
    (q.x.is_finite() && q.y.is_finite()).then_some(q)
}

/// Follows `p` from `a` to `b` and back: the point on `b` and the forward–backward error (px),
/// or `None` when either way fails.
pub fn track_checked(
    a: &GreyPyramid,
    b: &GreyPyramid,
    p: Point,
    prm: &FlowParams,
) -> Option<(Point, f32)> {
    let q = track_point(a, b, p, prm)?;
    let r = track_point(b, a, q, prm)?;
    Some((q, (r - p).norm()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth textured frame, shifted by `(sx, sy)` px.
    fn frame(sx: f32, sy: f32) -> RgbImage {
        RgbImage::from_fn(160, 120, |x, y| {
            let (u, v) = (x as f32 - sx, y as f32 - sy);
            let g =
                128.0 + 60.0 * (u * 0.21).sin() * (v * 0.17).cos() + 40.0 * ((u + v) * 0.09).sin();
            image::Rgb([g as u8, g as u8, g as u8])
        })
    }

    #[test]
    fn follows_a_shift_to_a_tenth_of_a_pixel() {
        let a = GreyPyramid::new(&frame(0.0, 0.0), 4);
        let b = GreyPyramid::new(&frame(7.3, -4.6), 4);
        let prm = FlowParams::default();
        let (q, fb) = track_checked(&a, &b, Point::new(80.0, 60.0), &prm).expect("tracked");
        assert!(
            (q.x - 87.3).abs() < 0.1 && (q.y - 55.4).abs() < 0.1,
            "{q:?}"
        );
        assert!(fb < 0.1, "forward–backward error {fb}");
    }

    #[test]
    fn refuses_a_flat_window() {
        let flat = RgbImage::from_pixel(160, 120, image::Rgb([90, 90, 90]));
        let a = GreyPyramid::new(&flat, 4);
        assert!(track_point(&a, &a, Point::new(80.0, 60.0), &FlowParams::default()).is_none());
    }
}
