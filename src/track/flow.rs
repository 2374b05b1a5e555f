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

mod build;
mod window;

use build::{halve_row, luma_into};
use window::{template, window_sums, Work};

/// One level of a grey pyramid: luma 0–255 as `f32`, row-major.
#[derive(Debug, Clone)]
pub struct GreyLevel {
    pub width: usize,
    pub height: usize,
    pub data: Vec<f32>,
}

impl GreyLevel {
    /// This level's buffer resized to `width` × `height` (its values to be overwritten).
    fn reshape(mut self, width: usize, height: usize) -> GreyLevel {
        if self.data.len() != width * height {
            self.data.clear();
            self.data.resize(width * height, 0.0);
        }
        GreyLevel {
            width,
            height,
            data: self.data,
        }
    }

    /// `next` (reshaped to half this level's size) filled with this level halved by 2×2 box
    /// averages (an odd last row or column is dropped).
    fn halve_into(&self, next: GreyLevel) -> GreyLevel {
        let (w, h) = (self.width / 2, self.height / 2);
        let mut next = next.reshape(w, h);
        if w > 0 {
            for (y, out) in next.data.chunks_exact_mut(w).enumerate() {
                let r0 = &self.data[2 * y * self.width..][..2 * w];
                let r1 = &self.data[(2 * y + 1) * self.width..][..2 * w];
                halve_row(r0, r1, out);
            }
        }
        next
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
        let mut p = GreyPyramid { levels: Vec::new() };
        p.rebuild(img, levels);
        p
    }

    /// [`GreyPyramid::new`] into this pyramid's buffers: a pyramid a frame, segment after
    /// segment, then costs no fresh memory (on 1024 × 1024 frames, paging it in took as long
    /// as filling it).
    pub fn rebuild(&mut self, img: &RgbImage, levels: usize) {
        let (w, h) = (img.width() as usize, img.height() as usize);
        let mut spare = std::mem::take(&mut self.levels).into_iter();
        let mut buffer = || {
            spare.next().unwrap_or(GreyLevel {
                width: 0,
                height: 0,
                data: Vec::new(),
            })
        };
        let mut first = buffer().reshape(w, h);
        luma_into(&img.as_raw()[..w * h * 3], &mut first.data);
        let mut out = vec![first];
        while out.len() < levels.max(1) {
            let last = out.last().expect("one level");
            if last.width < 32 || last.height < 32 {
                break;
            }
            let next = last.halve_into(buffer());
            out.push(next);
        }
        self.levels = out;
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

/// One level's template of a window on frame a: its values, gradients and the sums Σ gx²,
/// Σ gx gy, Σ gy²; `None` where the window leaves the level.
type LevelTemplate = Option<(Vec<f32>, Vec<f32>, Vec<f32>, [f32; 3])>;

/// A window's templates around point `p` on a frame's levels, found as Lucas–Kanade reaches
/// them. A step checked back from frame b finds the templates on b around the point it
/// reached, which the next step from b (from that point) takes again rather than finding them
/// anew: they depend on nothing else.
pub struct Template {
    p: Point,
    half: usize,
    levels: Vec<Option<LevelTemplate>>,
}

impl Template {
    fn new(p: Point, half: usize) -> Template {
        Template {
            p,
            half,
            levels: Vec::new(),
        }
    }

    /// Whether these are the templates around `p` (to the bit) for windows of half side `half`.
    fn fits(&self, p: Point, half: usize) -> bool {
        (self.p.x.to_bits(), self.p.y.to_bits(), self.half) == (p.x.to_bits(), p.y.to_bits(), half)
    }
}

/// Follows `p` (px on frame `a`) to frame `b`. `None` when the window leaves the frame or is
/// too flat on some level.
pub fn track_point(a: &GreyPyramid, b: &GreyPyramid, p: Point, prm: &FlowParams) -> Option<Point> {
    track_point_with(a, b, &mut Template::new(p, prm.half), prm)
}

/// [`track_point`] from `tpl.p`, with the templates on `a` found so far.
fn track_point_with(
    a: &GreyPyramid,
    b: &GreyPyramid,
    tpl: &mut Template,
    prm: &FlowParams,
) -> Option<Point> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2.
        return unsafe { track_point_avx2(a, b, tpl, prm) };
    }
    track_point_any(a, b, tpl, prm)
}

/// [`track_point`] compiled for AVX2 (the same arithmetic in the same order, so the same
/// values).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn track_point_avx2(
    a: &GreyPyramid,
    b: &GreyPyramid,
    tpl: &mut Template,
    prm: &FlowParams,
) -> Option<Point> {
    track_point_any(a, b, tpl, prm)
}

#[inline(always)]
fn track_point_any(
    a: &GreyPyramid,
    b: &GreyPyramid,
    tpl: &mut Template,
    prm: &FlowParams,
) -> Option<Point> {
    let p = tpl.p;
    let levels = a.levels.len().min(b.levels.len());
    let half = prm.half as i32;
    let n = (2 * half + 1) as usize;
    let mut work = Work::default();
    if tpl.levels.len() < levels {
        tpl.levels.resize_with(levels, || None);
    }
    // Displacement guess, in the current level's px.
    let (mut dx, mut dy) = (0.0f32, 0.0f32);
    for lvl in (0..levels).rev() {
        let la = &a.levels[lvl];
        let lb = &b.levels[lvl];
        let s = 1.0 / (1u32 << lvl) as f32;
        let (px, py) = (p.x * s, p.y * s);
        // Template, its gradients and their matrix on frame a: per column its centre, left
        // and right neighbours' axes, per row its centre, upper and lower ones.
        if tpl.levels[lvl].is_none() {
            let inside = work.cols.set(px, half, la.width) && work.rows.set(py, half, la.height);
            let mut found = None;
            if inside {
                let (mut tmpl, mut gx, mut gy) =
                    (vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]);
                let (gxx, gxy, gyy) = template(la, &mut tmpl, &mut gx, &mut gy, &mut work);
                found = Some((tmpl, gx, gy, [gxx, gxy, gyy]));
            }
            tpl.levels[lvl] = Some(found);
        }
        let Some(Some((tmpl, gx, gy, [gxx, gxy, gyy]))) = tpl.levels[lvl].as_ref() else {
            // The window leaves a coarse level near the border: go on at the next finer one.
            if lvl == 0 {
                return None;
            }
            dx *= 2.0;
            dy *= 2.0;
            continue;
        };
        let (gxx, gxy, gyy) = (*gxx, *gxy, *gyy);
        let area = (n * n) as f32;
        let tr = gxx + gyy;
        let det = gxx * gyy - gxy * gxy;
        let min_eig = 0.5 * (tr - ((gxx - gyy).powi(2) + 4.0 * gxy * gxy).sqrt());
        if min_eig / area < prm.min_eigen || det <= f32::EPSILON {
            return None;
        }
        for _ in 0..prm.iterations {
            let (bxp, byp) = (px + dx, py + dy);
            if !work.wcols.set(bxp, half, lb.width) || !work.wrows.set(byp, half, lb.height) {
                return None;
            }
            let (bx, by) = window_sums(lb, tmpl, gx, gy, &mut work);
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
    track_checked_again(a, b, p, prm, None).0
}

/// [`track_checked`], taking the templates around `p` on `a` from `known` where they are those
/// (the last step's, from its way back), and giving those around the point reached on `b`
/// for the next step.
pub fn track_checked_again(
    a: &GreyPyramid,
    b: &GreyPyramid,
    p: Point,
    prm: &FlowParams,
    known: Option<Template>,
) -> (Option<(Point, f32)>, Option<Template>) {
    let mut ta = known
        .filter(|t| t.fits(p, prm.half))
        .unwrap_or_else(|| Template::new(p, prm.half));
    let Some(q) = track_point_with(a, b, &mut ta, prm) else {
        return (None, None);
    };
    let mut tb = Template::new(q, prm.half);
    match track_point_with(b, a, &mut tb, prm) {
        Some(r) => (Some((q, (r - p).norm())), Some(tb)),
        None => (None, None),
    }
}

#[cfg(test)]
mod tests;
