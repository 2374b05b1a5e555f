//! Whether the camera holds still over the clip (docs/method.md §1, "A camera that moves"): a
//! temporal median is a plate only when the background stays put. Each pair of consecutive
//! sampled frames is aligned by the shift of their coarse grey gradients that fits best; the
//! camera holds still when, for at least half of the pairs, no shift fits better than none.
//! A subject moving in front of a still background does not move the best shift: most of the
//! frame is background.

use image::RgbImage;
use rayon::prelude::*;

/// Largest shift tried, in cells (see [`cell_px`]): ±48 px on a 640-wide clip.
const RADIUS: usize = 6;

/// A cell's gradient difference counts at most this much (grey levels): a subject that moved,
/// or a light switched on, weighs like any other misfit instead of deciding the shift.
const TRUNCATE: f32 = 20.0;

/// What [`check`] found: of `pairs` pairs of consecutive samples, `still` fitted best unshifted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CameraCheck {
    pub pairs: usize,
    pub still: usize,
}

impl CameraCheck {
    /// The camera moves: fewer than half of the pairs fit best unshifted.
    pub fn moves(&self) -> bool {
        2 * self.still < self.pairs
    }

    /// What the check saw, for messages: `the camera moves (the background shifts between …)`.
    pub fn describe(&self) -> String {
        format!(
            "the camera moves (the background shifts between {} of {} pairs of frames sampled \
             across the clip)",
            self.pairs - self.still,
            self.pairs
        )
    }
}

/// The side (px) of the cells the frames are averaged into: the smallest power of two, at least
/// 8, that leaves at most 100 cells across (`width` px).
pub fn cell_px(width: u32) -> u32 {
    let mut k = 8;
    while width / k > 100 {
        k *= 2;
    }
    k
}

/// Checks `samples` (in clip order, all one size). Frames too small for the shifts tried count
/// as still.
pub fn check(samples: &[RgbImage]) -> CameraCheck {
    let Some(first) = samples.first() else {
        return CameraCheck { pairs: 0, still: 0 };
    };
    let k = cell_px(first.width());
    let grads: Vec<Gradients> = samples.par_iter().map(|s| Gradients::of(s, k)).collect();
    let still = grads
        .par_windows(2)
        .map(|w| usize::from(unshifted_fits_best(&w[0], &w[1])))
        .sum();
    CameraCheck {
        pairs: samples.len().saturating_sub(1),
        still,
    }
}

/// A frame's grey level averaged over `k`×`k` cells, and its central differences across and
/// down (0 on the border cells).
struct Gradients {
    w: usize,
    h: usize,
    gx: Vec<f32>,
    gy: Vec<f32>,
}

impl Gradients {
    fn of(img: &RgbImage, k: u32) -> Gradients {
        let (w, h) = ((img.width() / k) as usize, (img.height() / k) as usize);
        let mut grey = vec![0.0f32; w * h];
        let raw = img.as_raw();
        let stride = img.width() as usize * 3;
        let k = k as usize;
        for (cy, row) in grey.chunks_mut(w.max(1)).enumerate().take(h) {
            for y in cy * k..(cy + 1) * k {
                let line = &raw[y * stride..y * stride + w * k * 3];
                for (cx, cell) in row.iter_mut().enumerate() {
                    *cell += line[cx * k * 3..(cx + 1) * k * 3]
                        .iter()
                        .map(|&v| v as u32)
                        .sum::<u32>() as f32;
                }
            }
        }
        let norm = 1.0 / (3 * k * k) as f32;
        grey.iter_mut().for_each(|g| *g *= norm);
        let (mut gx, mut gy) = (vec![0.0f32; w * h], vec![0.0f32; w * h]);
        for y in 1..h.saturating_sub(1) {
            for x in 1..w.saturating_sub(1) {
                gx[y * w + x] = grey[y * w + x + 1] - grey[y * w + x - 1];
                gy[y * w + x] = grey[(y + 1) * w + x] - grey[(y - 1) * w + x];
            }
        }
        Gradients { w, h, gx, gy }
    }

    /// The misfit of `b` shifted by `(dx, dy)` cells against `self` over the cells both cover
    /// at every shift tried, stopping once it reaches `stop`.
    fn misfit(&self, b: &Gradients, dx: isize, dy: isize, stop: f64) -> f64 {
        let mut sum = 0.0f64;
        for y in RADIUS..self.h - RADIUS {
            let yb = (y as isize + dy) as usize;
            let mut row = 0.0f32;
            for x in RADIUS..self.w - RADIUS {
                let (i, j) = (y * self.w + x, yb * b.w + (x as isize + dx) as usize);
                let d = (self.gx[i] - b.gx[j]).abs() + (self.gy[i] - b.gy[j]).abs();
                row += d.min(TRUNCATE);
            }
            sum += row as f64;
            if sum >= stop {
                break;
            }
        }
        sum
    }
}

/// Whether no shift of `b` fits `a` better than none (ties count as still).
fn unshifted_fits_best(a: &Gradients, b: &Gradients) -> bool {
    if a.w < 2 * RADIUS + 3 || a.h < 2 * RADIUS + 3 || (a.w, a.h) != (b.w, b.h) {
        return true;
    }
    let none = a.misfit(b, 0, 0, f64::INFINITY);
    let r = RADIUS as isize;
    (-r..=r)
        .flat_map(|dy| (-r..=r).map(move |dx| (dx, dy)))
        .filter(|&d| d != (0, 0))
        .all(|(dx, dy)| a.misfit(b, dx, dy, none) >= none)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A textured scene (smooth random blobs) seen through a `w`×`h` window at `(ox, oy)`, with
    /// a bright square (a subject) at `(sx, sy)`.
    fn view(w: u32, h: u32, ox: u32, oy: u32, sx: u32, sy: u32) -> RgbImage {
        let tex = |x: u32, y: u32| -> u8 {
            let (x, y) = (x as f32, y as f32);
            let v = 128.0
                + 50.0 * (x * 0.11).sin() * (y * 0.07).cos()
                + 40.0 * ((x + 2.0 * y) * 0.05).sin()
                + 25.0 * ((x * 0.31 + y * 0.23).sin() * (y * 0.17 - x * 0.05).cos());
            v.clamp(0.0, 255.0) as u8
        };
        RgbImage::from_fn(w, h, |x, y| {
            if (sx..sx + 60).contains(&x) && (sy..sy + 60).contains(&y) {
                image::Rgb([250, 240, 230])
            } else {
                let v = tex(x + ox, y + oy);
                image::Rgb([v, v / 2 + 60, 255 - v])
            }
        })
    }

    #[test]
    fn a_subject_moving_before_a_still_camera_is_told_from_a_camera_that_pans() {
        // Ten samples; the subject crosses the frame.
        let still: Vec<RgbImage> = (0..10)
            .map(|i| view(320, 240, 0, 0, 20 + 25 * i, 90))
            .collect();
        let c = check(&still);
        assert_eq!(c, CameraCheck { pairs: 9, still: 9 });
        assert!(!c.moves());
        // The same with the camera panning 3 to 30 px between samples (the subject with it).
        let panning: Vec<RgbImage> = (0..10)
            .map(|i| view(320, 240, 3 * i * i / 2 + 3 * i, 2 * i, 130, 90))
            .collect();
        let c = check(&panning);
        assert!(c.moves(), "{c:?}");
        assert!(c.still <= 1, "{c:?}");
        // Nothing to compare, or frames too small to shift: still.
        assert!(!check(&still[..1]).moves());
        assert!(!check(&[view(40, 40, 0, 0, 0, 0), view(40, 40, 9, 9, 0, 0)]).moves());
    }

    #[test]
    fn cells_leave_at_most_a_hundred_across() {
        assert_eq!(cell_px(406), 8);
        assert_eq!(cell_px(640), 8);
        assert_eq!(cell_px(1024), 16);
        assert_eq!(cell_px(1280), 16);
        assert_eq!(cell_px(3840), 64);
    }
}
