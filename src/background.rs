//! Background model: a clean plate (per-pixel temporal median over frames sampled across the
//! clip, or a user-supplied plate) and the foreground test used to keep background pixels out of
//! the template cost (METHOD.md §1, "Background subtraction").

use crate::error::{Error, Result};
use image::RgbImage;
use std::path::Path;

/// A clean plate and the colour distance above which a pixel counts as foreground.
#[derive(Debug, Clone)]
pub struct Background {
    /// The background alone, same size as the frames.
    pub plate: RgbImage,
    /// Foreground threshold on the L1 colour distance `|ΔR|+|ΔG|+|ΔB|` (0–765).
    pub threshold: u32,
}

/// Lowest foreground threshold (L1 colour distance), whatever the measured noise.
pub const MIN_THRESHOLD: u32 = 30;

impl Background {
    /// Per-pixel temporal median of `samples` (all the same size; at least one), with the
    /// foreground threshold set from the measured noise: 4× the median absolute L1 deviation
    /// of the samples from the plate, at least [`MIN_THRESHOLD`].
    pub fn fit(samples: &[RgbImage]) -> Result<Background> {
        let first = samples.first().ok_or_else(|| {
            Error::Usage("background: no frames to build a clean plate from".into())
        })?;
        let (w, h) = first.dimensions();
        if samples.iter().any(|s| s.dimensions() != (w, h)) {
            return Err(Error::Usage(
                "background: sampled frames differ in size".into(),
            ));
        }
        let n = samples.len();
        let mut plate = RgbImage::new(w, h);
        let raw: Vec<&[u8]> = samples.iter().map(|s| s.as_raw().as_slice()).collect();
        let mut vals = vec![0u8; n];
        for (k, out) in plate.iter_mut().enumerate() {
            for (v, r) in vals.iter_mut().zip(&raw) {
                *v = r[k];
            }
            let mid = n / 2;
            let (_, m, _) = vals.select_nth_unstable(mid);
            *out = *m;
        }
        // Noise estimate: median L1 distance to the plate over a sparse pixel grid of all samples.
        let mut dists: Vec<u32> = Vec::new();
        let step = ((w as usize * h as usize) / 20_000).max(1);
        for s in samples {
            for (i, (p, q)) in s.pixels().zip(plate.pixels()).enumerate() {
                if i % step == 0 {
                    dists.push(l1(p.0, q.0));
                }
            }
        }
        let mid = dists.len() / 2;
        let noise = if dists.is_empty() {
            0
        } else {
            *dists.select_nth_unstable(mid).1
        };
        Ok(Background {
            plate,
            threshold: (4 * noise).max(MIN_THRESHOLD),
        })
    }

    /// Per-channel noise standard deviation (levels) implied by the foreground threshold: the
    /// threshold is 4× the median L1 deviation over three channels, and for Gaussian noise of
    /// σ per channel that median is about 2.2 σ.
    pub fn noise_sigma(&self) -> f32 {
        self.threshold as f32 / (4.0 * 2.2)
    }

    /// A background from a user-supplied clean plate (PNG/JPEG) of the clip's frame size.
    pub fn from_plate_file(path: &Path, width: u32, height: u32) -> Result<Background> {
        let img = image::open(path)
            .map_err(|e| {
                Error::Usage(format!(
                    "{}: cannot read the clean plate: {e}",
                    path.display()
                ))
            })?
            .to_rgb8();
        if img.dimensions() != (width, height) {
            return Err(Error::Usage(format!(
                "{}: the clean plate is {}x{} but the clip is {width}x{height}; give a plate of the clip's size",
                path.display(),
                img.width(),
                img.height()
            )));
        }
        Ok(Background {
            plate: img,
            threshold: MIN_THRESHOLD,
        })
    }

    /// Global brightness gain of `frame` relative to the plate (1 = same exposure): the median,
    /// over a sparse grid of pixels, of the frame's channel sum over the plate's. Foreground
    /// pixels are a minority, so the median reflects the background (flicker, exposure drift).
    pub fn gain(&self, frame: &RgbImage) -> f32 {
        let (w, h) = frame.dimensions();
        if (w, h) != self.plate.dimensions() {
            return 1.0;
        }
        let step = (((w as u64 * h as u64) / 4000) as f64).sqrt().max(1.0) as u32;
        let mut ratios = Vec::with_capacity(4200);
        for y in (step / 2..h).step_by(step as usize) {
            for x in (step / 2..w).step_by(step as usize) {
                let p: u32 = self.plate.get_pixel(x, y).0.iter().map(|&v| v as u32).sum();
                if p >= 60 {
                    let f: u32 = frame.get_pixel(x, y).0.iter().map(|&v| v as u32).sum();
                    ratios.push(f as f32 / p as f32);
                }
            }
        }
        if ratios.is_empty() {
            return 1.0;
        }
        let mid = ratios.len() / 2;
        *ratios.select_nth_unstable_by(mid, f32::total_cmp).1
    }

    /// L1 colour distance between `frame` and the plate at pixel `(x, y)`.
    #[inline]
    pub fn distance(&self, frame: &RgbImage, x: u32, y: u32) -> u32 {
        l1(frame.get_pixel(x, y).0, self.plate.get_pixel(x, y).0)
    }

    /// Whether pixel `(x, y)` of `frame` differs from the plate by more than the threshold.
    #[inline]
    pub fn is_foreground(&self, frame: &RgbImage, x: u32, y: u32) -> bool {
        self.distance(frame, x, y) > self.threshold
    }
}

#[inline]
fn l1(a: [u8; 3], b: [u8; 3]) -> u32 {
    (0..3)
        .map(|c| (a[c] as i32 - b[c] as i32).unsigned_abs())
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    #[test]
    fn median_removes_a_moving_square() {
        // A grey plate with a red square at a different place in each of 5 frames.
        let frames: Vec<RgbImage> = (0..5)
            .map(|i| {
                let mut f = RgbImage::from_pixel(20, 10, Rgb([100, 110, 120]));
                for y in 2..6 {
                    for x in (i * 4)..(i * 4 + 3) {
                        f.put_pixel(x, y, Rgb([250, 0, 0]));
                    }
                }
                f
            })
            .collect();
        let bg = Background::fit(&frames).unwrap();
        assert!(bg.plate.pixels().all(|p| p.0 == [100, 110, 120]));
        assert_eq!(bg.threshold, MIN_THRESHOLD);
        assert!(bg.is_foreground(&frames[0], 1, 3));
        assert!(!bg.is_foreground(&frames[0], 10, 3));
        // A frame 10 % brighter everywhere has gain 1.1.
        let bright = RgbImage::from_pixel(20, 10, Rgb([110, 121, 132]));
        assert!(
            (bg.gain(&bright) - 1.1).abs() < 0.01,
            "{}",
            bg.gain(&bright)
        );
    }
}
