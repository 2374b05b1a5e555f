//! Joint appearance: patches sampled in the joint's own (rotating) frame, and the rotated,
//! masked template built from them for matching (METHOD.md eq. 4.2, rotation resampling).
//!
//! A patch stores the appearance at local offsets `o` (px, joint frame, origin at the joint
//! centre); the image position of `o` is `c + R(θ)·o` for a joint at `c` rotated by `θ`.

use crate::background::Background;
use crate::geom::Point;
use image::RgbImage;

/// Appearance of one joint in its own frame: `w × h` pixels, RGB as `f32` (0–255), and a
/// foreground weight per pixel in [0, 1] (1 where the pixel differs from the clean plate).
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    pub w: usize,
    pub h: usize,
    pub rgb: Vec<f32>,
    pub mask: Vec<f32>,
}

/// Bilinear sample of `img` at `(x, y)` px (pixel centres on integers), clamped to the border.
#[inline]
pub fn sample(img: &RgbImage, x: f32, y: f32) -> [f32; 3] {
    let (w, h) = (img.width() as i32, img.height() as i32);
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let x0 = x.floor() as i32;
    let y0 = y.floor() as i32;
    let x1 = (x0 + 1).min(w - 1);
    let y1 = (y0 + 1).min(h - 1);
    let fx = x - x0 as f32;
    let fy = y - y0 as f32;
    let raw = img.as_raw();
    let at = |xx: i32, yy: i32| ((yy * w + xx) * 3) as usize;
    let (a, b, c, d) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let top = raw[a + k] as f32 * (1.0 - fx) + raw[b + k] as f32 * fx;
        let bot = raw[c + k] as f32 * (1.0 - fx) + raw[d + k] as f32 * fx;
        *o = top * (1.0 - fy) + bot * fy;
    }
    out
}

/// Local offset (px) of patch pixel `(i, j)` from the patch centre.
#[inline]
fn offset(i: usize, j: usize, w: usize, h: usize) -> (f32, f32) {
    (
        i as f32 - (w as f32 - 1.0) / 2.0,
        j as f32 - (h as f32 - 1.0) / 2.0,
    )
}

impl Patch {
    /// Samples a `w × h` patch of `frame` in the frame of a joint at `c` rotated by `angle_rad`
    /// (bilinear). Foreground weights come from `bg` (all 1 without a background model).
    pub fn extract(
        frame: &RgbImage,
        bg: Option<&Background>,
        c: Point,
        angle_rad: f32,
        w: usize,
        h: usize,
    ) -> Patch {
        let (s, co) = angle_rad.sin_cos();
        let mut rgb = Vec::with_capacity(w * h * 3);
        let mut mask = Vec::with_capacity(w * h);
        for j in 0..h {
            for i in 0..w {
                let (ox, oy) = offset(i, j, w, h);
                let x = c.x + co * ox - s * oy;
                let y = c.y + s * ox + co * oy;
                let p = sample(frame, x, y);
                rgb.extend_from_slice(&p);
                let m = match bg {
                    Some(bg) => {
                        let q = sample(&bg.plate, x, y);
                        let d: f32 = (0..3).map(|k| (p[k] - q[k]).abs()).sum();
                        if d > bg.threshold as f32 {
                            1.0
                        } else {
                            0.0
                        }
                    }
                    None => 1.0,
                };
                mask.push(m);
            }
        }
        Patch { w, h, rgb, mask }
    }

    /// Blends `other` into `self`: `self ← (1−rate)·self + rate·other`, colour and mask alike.
    pub fn blend(&mut self, other: &Patch, rate: f32) {
        for (a, b) in self.rgb.iter_mut().zip(&other.rgb) {
            *a += rate * (b - *a);
        }
        for (a, b) in self.mask.iter_mut().zip(&other.mask) {
            *a += rate * (b - *a);
        }
    }

    /// Bilinear sample of the patch at local offset `(ox, oy)`; `None` outside it.
    #[inline]
    fn sample_local(&self, ox: f32, oy: f32) -> Option<([f32; 3], f32)> {
        let x = ox + (self.w as f32 - 1.0) / 2.0;
        let y = oy + (self.h as f32 - 1.0) / 2.0;
        if x < 0.0 || y < 0.0 || x > (self.w - 1) as f32 || y > (self.h - 1) as f32 {
            return None;
        }
        let x0 = (x.floor() as usize).min(self.w - 1);
        let y0 = (y.floor() as usize).min(self.h - 1);
        let x1 = (x0 + 1).min(self.w - 1);
        let y1 = (y0 + 1).min(self.h - 1);
        let fx = x - x0 as f32;
        let fy = y - y0 as f32;
        let wts = [
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        ];
        let idx = [
            y0 * self.w + x0,
            y0 * self.w + x1,
            y1 * self.w + x0,
            y1 * self.w + x1,
        ];
        let mut c = [0.0f32; 3];
        let mut m = 0.0f32;
        for (wt, ix) in wts.iter().zip(idx) {
            for (ck, v) in c.iter_mut().zip(&self.rgb[ix * 3..ix * 3 + 3]) {
                *ck += wt * v;
            }
            m += wt * self.mask[ix];
        }
        Some((c, m))
    }
}

/// An image-aligned template ready for the integer-shift search: `w × h` pixels, RGB as `i16`
/// interleaved, and a per-channel mask (`-1` = counts, `0` = ignored) so the inner loop is
/// `((img − t) & m)²`.
#[derive(Debug, Clone)]
pub struct Template {
    pub w: usize,
    pub h: usize,
    pub rgb: Vec<i16>,
    pub mask: Vec<i16>,
    /// Number of counted channel values (3 per counted pixel).
    pub active: usize,
}

/// Mask weight above which a template pixel counts in the cost.
const MASK_ON: f32 = 0.5;

impl Template {
    /// The template for matching a joint whose rotation is `angle_rad` (the angle the patch was
    /// extracted at is the reference): pixel `u` (image offset from the centre) takes the patch
    /// value at `R(−θ)·u` (eq. 4.2, bilinear resampling).
    /// `w × h` is the joint rectangle; the patch must be large enough to cover its rotation.
    /// Pixels whose mask is off (background at seed time) do not count; if fewer than a quarter
    /// of the pixels count, all count (a joint seen against a plate-less or similar background).
    pub fn from_patch(patch: &Patch, angle_rad: f32, w: usize, h: usize) -> Template {
        Template::from_patch_gain(patch, angle_rad, w, h, 1.0)
    }

    /// As [`Template::from_patch`], with colours scaled by `gain` (the frame's brightness
    /// relative to the patch's, see [`crate::background::Background::gain`]).
    pub fn from_patch_gain(
        patch: &Patch,
        angle_rad: f32,
        w: usize,
        h: usize,
        gain: f32,
    ) -> Template {
        let (s, c) = angle_rad.sin_cos();
        let mut rgb = vec![0i16; w * h * 3];
        let mut mask = vec![0i16; w * h * 3];
        let mut active = 0;
        for j in 0..h {
            for i in 0..w {
                let (ux, uy) = offset(i, j, w, h);
                // R(−θ)·u
                let ox = c * ux + s * uy;
                let oy = -s * ux + c * uy;
                let k = (j * w + i) * 3;
                if let Some((col, m)) = patch.sample_local(ox, oy) {
                    for ch in 0..3 {
                        rgb[k + ch] = (col[ch] * gain).round().min(255.0) as i16;
                    }
                    if m > MASK_ON {
                        mask[k..k + 3].fill(-1);
                        active += 3;
                    }
                }
            }
        }
        if active < w * h * 3 / 4 {
            mask.fill(-1);
            active = w * h * 3;
        }
        Template {
            w,
            h,
            rgb,
            mask,
            active,
        }
    }
}

impl Template {
    /// Divisor that turns a raw masked SSD into the normalised colour cost in [0, 1]
    /// (counted channel values × 255²).
    pub fn cost_norm(&self) -> f64 {
        (self.active.max(1) as f64) * 255.0 * 255.0
    }
}

/// Side (px) of the square patch that covers a `w × h` rectangle at any rotation, plus a margin.
pub fn patch_side(w: u32, h: u32) -> usize {
    ((w as f32).hypot(h as f32).ceil() as usize + 3) | 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    fn ramp() -> RgbImage {
        RgbImage::from_fn(40, 40, |x, y| Rgb([(x * 6) as u8, (y * 6) as u8, 77]))
    }

    #[test]
    fn bilinear_sample_interpolates() {
        let img = ramp();
        let p = sample(&img, 10.5, 20.25);
        assert!((p[0] - 63.0).abs() < 1e-4 && (p[1] - 121.5).abs() < 1e-4);
    }

    #[test]
    fn rotate_then_unrotate_is_identity_at_the_centre_region() {
        let img = ramp();
        let c = Point::new(20.0, 20.0);
        let side = patch_side(9, 9);
        // Appearance sampled in a frame rotated by 0.7 rad; the template for a joint at that same
        // rotation is the image itself, unrotated.
        let patch = Patch::extract(&img, None, c, 0.7, side, side);
        let t = Template::from_patch(&patch, 0.7, 9, 9);
        for j in 0..9 {
            for i in 0..9 {
                let want = img.get_pixel(16 + i as u32, 16 + j as u32).0;
                for ch in 0..3 {
                    let got = t.rgb[(j * 9 + i) * 3 + ch];
                    assert!(
                        (got - want[ch] as i16).abs() <= 1,
                        "{i},{j}: {got} vs {want:?}"
                    );
                }
            }
        }
    }
}
