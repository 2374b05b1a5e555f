//! Background model: a clean plate (per-pixel temporal median over frames sampled across the
//! clip, or a user-supplied plate) and the foreground test used to keep background pixels out of
//! the template cost (docs/method.md §1).

use crate::error::{Error, Result};
use crate::geom::Point;
use image::RgbImage;
use std::path::Path;

pub mod camera;
mod choice;
mod median;
mod setting;

pub use choice::{median_background, BackgroundChoice, Built, BACKGROUND_SAMPLES};
pub(crate) use setting::deserialize_either;
pub use setting::BackgroundSetting;

/// A clean plate and the colour distance above which a pixel counts as foreground.
#[derive(Debug, Clone)]
pub struct Background {
    /// The background alone, same size as the frames.
    pub plate: RgbImage,
    /// Foreground threshold on the L1 colour distance `|ΔR|+|ΔG|+|ΔB|` (0–765) of a frame from
    /// the plate's levels as they are: the sampled frames' exposure drift included.
    pub threshold: u32,
    /// The same measured with each sampled frame in its own light (the plate times the frame's
    /// gain): the sensor's noise alone, for comparisons made at the frame's gain, as the
    /// tracker's are ([`Background::noise_sigma`]).
    pub lit_threshold: u32,
}

/// A plate level `v` in a frame of brightness `gain` (see [`Background::gain`]).
#[inline]
fn lit(v: u8, gain: f32) -> u8 {
    (gain * v as f32).round().min(255.0) as u8
}

/// `gain` where it is further from 1 than `step` ([`Background::gain_step`]), else exactly 1.
fn told(gain: f32, step: f32) -> f32 {
    if (gain - 1.0).abs() > step {
        gain
    } else {
        1.0
    }
}

/// The foreground threshold from distances counted by value: 4× their median, at least
/// [`MIN_THRESHOLD`].
fn threshold_of(counts: &[u64]) -> u32 {
    let mid = counts.iter().sum::<u64>() / 2;
    let mut below = 0;
    let noise = counts
        .iter()
        .position(|&c| {
            below += c;
            below > mid
        })
        .unwrap_or(0) as u32;
    (4 * noise).max(MIN_THRESHOLD)
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
        let raw: Vec<&[u8]> = samples.iter().map(|s| s.as_raw().as_slice()).collect();
        let plate = RgbImage::from_raw(w, h, median::median_bytes(&raw))
            .expect("the median has the samples' size");
        // Noise estimate: median L1 distance to the plate over a sparse pixel grid of all samples
        // (the distance at index len / 2 of their sorted list), counted by value: a distance is
        // at most 3 × 255. Once against the plate's levels as they are, once with each sample
        // in its own light (the plate times the sample's gain): an exposure that swings over
        // the clip is not the sensor's noise, and counted as noise where the tracker compares
        // at the frame's gain it made a limb near the wall's colour look like the wall
        // (docs/method.md §1).
        let mut fitted = Background {
            plate,
            threshold: MIN_THRESHOLD,
            lit_threshold: MIN_THRESHOLD,
        };
        let step = ((w as usize * h as usize) / 20_000).max(1);
        let (mut raw, mut lit_counts) = (vec![0u64; 3 * 255 + 1], vec![0u64; 3 * 255 + 1]);
        let px = |raw: &[u8], i: usize| [raw[3 * i], raw[3 * i + 1], raw[3 * i + 2]];
        let gain_step = fitted.gain_step();
        for s in samples {
            let gain = told(fitted.gain(s), gain_step);
            for i in (0..w as usize * h as usize).step_by(step) {
                let (f, b) = (px(s.as_raw(), i), px(fitted.plate.as_raw(), i));
                raw[l1(f, b) as usize] += 1;
                lit_counts[l1(f, b.map(|v| lit(v, gain))) as usize] += 1;
            }
        }
        fitted.threshold = threshold_of(&raw);
        fitted.lit_threshold = threshold_of(&lit_counts);
        Ok(fitted)
    }

    /// Per-channel noise standard deviation (levels) implied by the foreground threshold measured
    /// in each frame's own light ([`Background::lit_threshold`]): the threshold is 4× the median
    /// L1 deviation over three channels, and for Gaussian noise of σ per channel that median is
    /// about 2.2 σ.
    pub fn noise_sigma(&self) -> f32 {
        self.lit_threshold as f32 / (4.0 * 2.2)
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
            lit_threshold: MIN_THRESHOLD,
        })
    }

    /// Global brightness gain of `frame` relative to the plate (1 = same exposure): the median,
    /// over a sparse grid of pixels, of the frame's channel sum over the plate's. Foreground
    /// pixels are a minority, so the median reflects the background (flicker, exposure drift).
    pub fn gain(&self, frame: &RgbImage) -> f32 {
        if frame.dimensions() != self.plate.dimensions() {
            return 1.0;
        }
        let mut ratios: Vec<f32> = self
            .gain_pixels()
            .into_iter()
            .map(|(x, y, p)| {
                let f: u32 = frame.get_pixel(x, y).0.iter().map(|&v| v as u32).sum();
                f as f32 / p as f32
            })
            .collect();
        if ratios.is_empty() {
            return 1.0;
        }
        let mid = ratios.len() / 2;
        *ratios.select_nth_unstable_by(mid, f32::total_cmp).1
    }

    /// How finely [`Background::gain`] can tell a gain (docs/method.md §1): one level on every
    /// channel of its median pixel, over that pixel's channel sum. The frame's background moves
    /// from level to level together as the exposure changes, so on a dark plate (the flies', at
    /// about 22 levels: 4.5 %) the gain comes in steps of this size. 0 when it has no pixels.
    pub fn gain_step(&self) -> f32 {
        let mut sums: Vec<u32> = self.gain_pixels().into_iter().map(|(_, _, p)| p).collect();
        if sums.is_empty() {
            return 0.0;
        }
        let mid = sums.len() / 2;
        3.0 / *sums.select_nth_unstable(mid).1 as f32
    }

    /// The pixels [`Background::gain`] reads: a sparse grid of about 4000, those whose plate
    /// channel sum (the third value) is at least 60. (Plain loops into a list: read through a
    /// flattened iterator, the grid cost about 2 % of a 1280x720 track.)
    fn gain_pixels(&self) -> Vec<(u32, u32, u32)> {
        let (w, h) = self.plate.dimensions();
        let step = (((w as u64 * h as u64) / 4000) as f64).sqrt().max(1.0) as u32;
        let mut out = Vec::with_capacity(4200);
        for y in (step / 2..h).step_by(step as usize) {
            for x in (step / 2..w).step_by(step as usize) {
                let p: u32 = self.plate.get_pixel(x, y).0.iter().map(|&v| v as u32).sum();
                if p >= 60 {
                    out.push((x, y, p));
                }
            }
        }
        out
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

/// One limb of a subject on the seed frame, as [`Background::clear_resting_subject`] sees it: a
/// segment from `a` to `b` (px; `a == b` for a lone joint) and how far the limb reaches around
/// it (px).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limb {
    pub a: Point,
    pub b: Point,
    pub radius: f32,
}

impl Limb {
    /// Distance (px) from `q` to the segment.
    fn distance(&self, q: Point) -> f32 {
        let d = self.b - self.a;
        let len2 = d.norm_squared();
        let t = if len2 > 1e-9 {
            ((q - self.a).dot(&d) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (q - (self.a + d * t)).norm()
    }
}

impl Background {
    /// Clears from the plate a subject that sat still (docs/method.md §1): a temporal median keeps
    /// whatever stays put over most of the sampled frames, so two flies resting for 1000 of 1500
    /// frames are in it, and then nothing of them counts as foreground (their limbs are measured
    /// 1 px wide, and a limb laid on the floor looks as good as one laid on the limb).
    ///
    /// `bodies` are the subjects on `seed_frame`, each a list of limbs. A body is at rest in the
    /// plate when most of its limbs' axes match the plate on the seed frame. Within such a body's
    /// limbs, a pixel that matches the plate on the seed frame takes instead the median of the
    /// samples that differ from the seed frame there, when at least `max(3, n/8)` of the `n`
    /// samples do (the subject left) and at least half of those agree with their median (the
    /// floor it uncovered, not another subject passing). Returns the number of pixels changed.
    pub fn clear_resting_subject(
        &mut self,
        samples: &[RgbImage],
        seed_frame: &RgbImage,
        bodies: &[Vec<Limb>],
    ) -> usize {
        let (w, h) = self.plate.dimensions();
        if seed_frame.dimensions() != (w, h) || samples.iter().any(|s| s.dimensions() != (w, h)) {
            return 0;
        }
        let thr = self.threshold;
        let matches_plate = |x: u32, y: u32| self.distance(seed_frame, x, y) <= thr;
        let inside = |q: Point| q.x >= 0.0 && q.y >= 0.0 && q.x < w as f32 && q.y < h as f32;
        let need = (samples.len() / 8).max(3);
        let mut changed = Vec::new();
        let mut seen = vec![false; w as usize * h as usize];
        for body in bodies {
            // Most of the body's axes look like the plate: the plate holds the body.
            let (mut on_plate, mut axis) = (0usize, 0usize);
            for l in body {
                let steps = (l.b - l.a).norm().ceil().max(1.0) as usize;
                for i in 0..=steps {
                    let q = l.a + (l.b - l.a) * (i as f32 / steps as f32);
                    if inside(q) {
                        axis += 1;
                        on_plate += usize::from(matches_plate(q.x as u32, q.y as u32));
                    }
                }
            }
            if axis == 0 || 2 * on_plate <= axis {
                continue;
            }
            let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
            for l in body {
                for e in [l.a, l.b] {
                    x0 = x0.min(e.x - l.radius);
                    y0 = y0.min(e.y - l.radius);
                    x1 = x1.max(e.x + l.radius);
                    y1 = y1.max(e.y + l.radius);
                }
            }
            let xs = (x0.floor().max(0.0) as u32)..(x1.ceil().max(0.0) as u32 + 1).min(w);
            let ys = (y0.floor().max(0.0) as u32)..(y1.ceil().max(0.0) as u32 + 1).min(h);
            for y in ys {
                for x in xs.clone() {
                    let q = Point::new(x as f32, y as f32);
                    let k = y as usize * w as usize + x as usize;
                    if seen[k]
                        || !body.iter().any(|l| l.distance(q) <= l.radius)
                        || !matches_plate(x, y)
                    {
                        continue;
                    }
                    seen[k] = true;
                    let seed = seed_frame.get_pixel(x, y).0;
                    let away: Vec<[u8; 3]> = samples
                        .iter()
                        .map(|s| s.get_pixel(x, y).0)
                        .filter(|&c| l1(c, seed) > thr)
                        .collect();
                    if away.len() < need {
                        continue;
                    }
                    let m: [u8; 3] = std::array::from_fn(|c| {
                        let mut v: Vec<u8> = away.iter().map(|p| p[c]).collect();
                        let mid = v.len() / 2;
                        *v.select_nth_unstable(mid).1
                    });
                    if 2 * away.iter().filter(|&&c| l1(c, m) <= thr).count() >= away.len() {
                        changed.push((x, y, m));
                    }
                }
            }
        }
        for &(x, y, m) in &changed {
            self.plate.put_pixel(x, y, image::Rgb(m));
        }
        changed.len()
    }
}

/// L1 colour distance `|ΔR| + |ΔG| + |ΔB|` between two pixels (0–765).
#[inline]
pub(crate) fn l1(a: [u8; 3], b: [u8; 3]) -> u32 {
    (0..3)
        .map(|c| (a[c] as i32 - b[c] as i32).unsigned_abs())
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    #[test]
    fn a_subject_at_rest_is_cleared_from_the_plate_once_it_leaves() {
        // A bright bar sits still on frames 0-5 and is gone on frames 6-8: the median keeps it.
        let floor = Rgb([20, 20, 20]);
        let frames: Vec<RgbImage> = (0..9)
            .map(|i| {
                let mut f = RgbImage::from_pixel(40, 20, floor);
                if i < 6 {
                    for x in 10..30 {
                        for y in 8..12 {
                            f.put_pixel(x, y, Rgb([200, 200, 200]));
                        }
                    }
                }
                f
            })
            .collect();
        let mut bg = Background::fit(&frames).unwrap();
        assert_eq!(bg.plate.get_pixel(20, 10), &Rgb([200, 200, 200]));
        let limb = Limb {
            a: Point::new(12.0, 10.0),
            b: Point::new(28.0, 10.0),
            radius: 4.0,
        };
        // Too few frames without the subject: left as it is.
        assert_eq!(
            bg.clear_resting_subject(&frames[..8], &frames[0], &[vec![limb]]),
            0
        );
        let n = bg.clear_resting_subject(&frames, &frames[0], &[vec![limb]]);
        assert_eq!(n, 20 * 4);
        assert!(bg.plate.pixels().all(|p| *p == floor));
        assert!(bg.is_foreground(&frames[0], 20, 10));
        // A body that moves is not in the plate: nothing to clear.
        let moving = Limb {
            a: Point::new(2.0, 2.0),
            b: Point::new(8.0, 2.0),
            radius: 2.0,
        };
        let mut seed = frames[7].clone();
        for x in 2..9 {
            seed.put_pixel(x, 2, Rgb([255, 0, 0]));
        }
        assert_eq!(bg.clear_resting_subject(&frames, &seed, &[vec![moving]]), 0);
    }

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

    #[test]
    fn an_exposure_that_swings_is_not_noise() {
        // A textured wall filmed through a ±15 % brightness swing, with a pixel of grain in
        // every 16: measured in each frame's own light the noise stays at the floor; against
        // the plate's levels the swing makes a threshold of over 100.
        let wall = |x: u32, y: u32| [120 + (x * 7 % 40) as u8, 100 + (y * 5 % 30) as u8, 90];
        let frames: Vec<RgbImage> = (0..25)
            .map(|i| {
                let g = 1.0 + 0.15 * (2.0 * std::f32::consts::PI * i as f32 / 25.0).sin();
                RgbImage::from_fn(64, 48, |x, y| {
                    let grain = if (x + 3 * y + i) % 16 == 0 { 6.0 } else { 0.0 };
                    Rgb(wall(x, y).map(|v| (g * v as f32 + grain).round().min(255.0) as u8))
                })
            })
            .collect();
        let bg = Background::fit(&frames).unwrap();
        assert_eq!(bg.lit_threshold, MIN_THRESHOLD);
        assert!(
            (bg.noise_sigma() - 30.0 / 8.8).abs() < 1e-4,
            "{}",
            bg.noise_sigma()
        );
        assert!(bg.threshold > 100, "{}", bg.threshold);
        let g = told(bg.gain(&frames[6]), bg.gain_step());
        assert!((g - 1.149).abs() < 0.02, "{g}");
    }

    #[test]
    fn a_dark_plate_tells_the_gain_in_coarse_steps() {
        let plate = |v: u8| Background {
            plate: RgbImage::from_pixel(40, 30, Rgb([v, v, v])),
            threshold: MIN_THRESHOLD,
            lit_threshold: MIN_THRESHOLD,
        };
        // One level over 22: 4.5 %; over 200: 0.5 %; a plate too dark to read: none.
        assert!((plate(22).gain_step() - 1.0 / 22.0).abs() < 1e-6);
        assert!((plate(200).gain_step() - 1.0 / 200.0).abs() < 1e-6);
        assert_eq!(plate(10).gain_step(), 0.0);
        // Exposed 4 % darker, the dark plate's frame rounds back to the plate (gain 1) or to one
        // level below it (21/22): a step about as large as `gain_step`.
        let dark = plate(22);
        let g = dark.gain(&RgbImage::from_pixel(40, 30, Rgb([21, 21, 21])));
        assert!((1.0 - g - dark.gain_step()).abs() < 1e-6, "{g}");
    }
}
