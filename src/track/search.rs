//! Exhaustive search of a window around the predicted centre for the position that minimises
//! the mixed cost D = W_c·D_c + W_g·D_g (METHOD.md eq. 4.5–4.6), then sub-pixel refinement by a
//! parabola through the cost at the best position and its 4 neighbours.
//!
//! `D_c` is the masked RGB sum of squared differences, normalised to [0, 1] by the number of
//! counted channel values and 255²; `D_g` is the squared distance to the prediction in units of
//! the search radius, so `W_g` is dimensionless.

use super::template::Template;
use crate::geom::Point;
use image::RgbImage;

/// Result of one search.
#[derive(Debug, Clone, Copy)]
pub struct Match {
    /// Best centre (px), sub-pixel.
    pub pos: Point,
    /// Normalised colour cost at the best integer position (mean squared difference / 255²).
    pub colour_cost: f32,
}

/// Raw masked SSD of `t` placed with its top-left pixel at `(x0, y0)` in `frame`, giving up
/// (returning a value > `limit`) once the partial sum exceeds `limit`. This is the hot loop.
#[inline]
pub fn ssd(frame: &RgbImage, t: &Template, x0: usize, y0: usize, limit: u64) -> u64 {
    let stride = frame.width() as usize * 3;
    let raw = frame.as_raw();
    let row_len = t.w * 3;
    let mut acc: u64 = 0;
    for j in 0..t.h {
        let start = (y0 + j) * stride + x0 * 3;
        let img = &raw[start..start + row_len];
        let tr = &t.rgb[j * row_len..(j + 1) * row_len];
        let mr = &t.mask[j * row_len..(j + 1) * row_len];
        let mut row: i32 = 0;
        for ((&a, &b), &m) in img.iter().zip(tr).zip(mr) {
            let d = (a as i16 - b) & m;
            row += d as i32 * d as i32;
        }
        acc += row as u64;
        if acc > limit {
            return acc;
        }
    }
    acc
}

/// Searches integer centres within `radius_px` of `pred` (clipped so the template stays inside
/// the frame) and returns the best sub-pixel centre. `geo_weight` is W_g in units where the
/// colour term is in [0, 1] and the distance is divided by the radius.
pub fn search(
    frame: &RgbImage,
    t: &Template,
    pred: Point,
    radius_px: f32,
    geo_weight: f32,
) -> Match {
    let (fw, fh) = (frame.width() as i64, frame.height() as i64);
    let (tw, th) = (t.w as i64, t.h as i64);
    let hx = (t.w as f32 - 1.0) / 2.0;
    let hy = (t.h as f32 - 1.0) / 2.0;
    // Top-left corner of the template for the predicted centre, rounded.
    let px = (pred.x - hx).round() as i64;
    let py = (pred.y - hy).round() as i64;
    let r = radius_px.ceil().max(1.0) as i64;
    let xmin = (px - r).clamp(0, fw - tw);
    let xmax = (px + r).clamp(0, fw - tw);
    let ymin = (py - r).clamp(0, fh - th);
    let ymax = (py + r).clamp(0, fh - th);
    let norm = t.cost_norm();
    let r2 = (radius_px * radius_px).max(1.0) as f64;
    let geo = |x: i64, y: i64| -> f64 {
        let dx = (x as f64 + hx as f64) - pred.x as f64;
        let dy = (y as f64 + hy as f64) - pred.y as f64;
        geo_weight as f64 * (dx * dx + dy * dy) / r2
    };
    let mut best = (f64::INFINITY, xmin, ymin, 0u64);
    // Visit candidates in order of distance from the prediction so early exit bites sooner;
    // ties keep the first visited, which makes the result independent of anything but inputs.
    let mut cands: Vec<(i64, i64, i64)> =
        Vec::with_capacity(((xmax - xmin + 1) * (ymax - ymin + 1)) as usize);
    for y in ymin..=ymax {
        for x in xmin..=xmax {
            let d2 = (x - px) * (x - px) + (y - py) * (y - py);
            if d2 <= r * r + r {
                cands.push((d2, x, y));
            }
        }
    }
    if cands.is_empty() {
        cands.push((0, xmin, ymin));
    }
    cands.sort_unstable();
    for &(_, x, y) in &cands {
        let g = geo(x, y);
        if g >= best.0 {
            continue;
        }
        let limit = ((best.0 - g) * norm).min(u64::MAX as f64 / 2.0) as u64;
        let raw = ssd(frame, t, x as usize, y as usize, limit);
        let total = raw as f64 / norm + g;
        if total < best.0 {
            best = (total, x, y, raw);
        }
    }
    let (_, bx, by, braw) = best;
    // Sub-pixel: parabola through the full cost at the best corner and its neighbours.
    let full = |x: i64, y: i64| -> Option<f64> {
        if x < 0 || y < 0 || x > fw - tw || y > fh - th {
            return None;
        }
        Some(ssd(frame, t, x as usize, y as usize, u64::MAX) as f64 / norm + geo(x, y))
    };
    let c0 = braw as f64 / norm + geo(bx, by);
    let refine = |cm: Option<f64>, cp: Option<f64>| -> f64 {
        match (cm, cp) {
            (Some(a), Some(b)) => {
                let den = a - 2.0 * c0 + b;
                if den > 1e-12 {
                    (0.5 * (a - b) / den).clamp(-0.5, 0.5)
                } else {
                    0.0
                }
            }
            _ => 0.0,
        }
    };
    let dx = refine(full(bx - 1, by), full(bx + 1, by));
    let dy = refine(full(bx, by - 1), full(bx, by + 1));
    Match {
        pos: Point::new(bx as f32 + hx + dx as f32, by as f32 + hy + dy as f32),
        colour_cost: (braw as f64 / norm) as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track::template::{Patch, Template};
    use image::Rgb;

    /// A 5×5 template cut from a textured image is found at its true place.
    #[test]
    fn finds_a_5x5_template() {
        let img = RgbImage::from_fn(30, 30, |x, y| {
            Rgb([
                ((x * 37 + y * 11) % 251) as u8,
                ((x * x + 3 * y) % 199) as u8,
                ((x * y) % 97) as u8,
            ])
        });
        let patch = Patch::extract(&img, None, Point::new(17.0, 12.0), 0.0, 5, 5);
        let t = Template::from_patch(&patch, 0.0, 5, 5);
        let m = search(&img, &t, Point::new(14.0, 14.0), 6.0, 0.0);
        assert!(
            (m.pos.x - 17.0).abs() < 0.5 && (m.pos.y - 12.0).abs() < 0.5,
            "{:?}",
            m.pos
        );
        assert_eq!(m.colour_cost, 0.0);
    }

    #[test]
    fn early_exit_never_changes_an_accepted_sum() {
        let img = RgbImage::from_fn(12, 12, |x, y| Rgb([(x * 20) as u8, (y * 20) as u8, 5]));
        let patch = Patch::extract(&img, None, Point::new(5.0, 5.0), 0.0, 5, 5);
        let t = Template::from_patch(&patch, 0.0, 5, 5);
        let full = ssd(&img, &t, 4, 3, u64::MAX);
        assert_eq!(ssd(&img, &t, 4, 3, full), full);
        assert!(ssd(&img, &t, 4, 3, 0) > 0);
    }

    /// A smooth blob moved by a sub-pixel amount is located to within 0.2 px.
    #[test]
    fn subpixel_refinement_recovers_fractional_shift() {
        let blob = |cx: f32, cy: f32| {
            RgbImage::from_fn(40, 40, |x, y| {
                let d2 = (x as f32 - cx).powi(2) + (y as f32 - cy).powi(2);
                let v = (255.0 * (-d2 / 18.0).exp()) as u8;
                Rgb([v, 255 - v, v / 2])
            })
        };
        let a = blob(20.0, 20.0);
        let b = blob(21.3, 19.6);
        let patch = Patch::extract(&a, None, Point::new(20.0, 20.0), 0.0, 11, 11);
        let t = Template::from_patch(&patch, 0.0, 11, 11);
        let m = search(&b, &t, Point::new(20.0, 20.0), 4.0, 0.0);
        assert!(
            (m.pos.x - 21.3).abs() < 0.2 && (m.pos.y - 19.6).abs() < 0.2,
            "{:?}",
            m.pos
        );
    }
}
