//! Reading a frame at sub-pixel positions: bilinear colour and its gradient (docs/method.md
//! §2.2), the only way the tracker looks at pixels.
//!
//! Positions follow [`crate::geom`]'s conventions: px, origin top-left, pixel centres on integer
//! coordinates. A position whose 2×2 neighbourhood leaves the frame reads as `None`.

use image::RgbImage;
use std::borrow::Cow;

/// An RGB colour or colour derivative, 0–255 per channel, as `f32`.
pub type Rgb = [f32; 3];

/// Most pyramid levels the tracker uses (full resolution, half, quarter, eighth); how many it
/// does use depends on the size of the joints' rectangles.
pub const MAX_LEVELS: usize = 4;

/// A borrowed RGB frame.
#[derive(Clone, Copy)]
pub struct Image<'a> {
    raw: &'a [u8],
    w: usize,
    h: usize,
}

impl<'a> Image<'a> {
    /// Borrows `img`.
    pub fn new(img: &'a RgbImage) -> Self {
        Image {
            raw: img.as_raw(),
            w: img.width() as usize,
            h: img.height() as usize,
        }
    }

    /// Frame width (px).
    pub fn width(&self) -> usize {
        self.w
    }

    /// Frame height (px).
    pub fn height(&self) -> usize {
        self.h
    }

    /// Index of the top-left pixel of the 2×2 neighbourhood of `(x, y)` and the fractions
    /// `(fx, fy)`, or `None` outside the frame.
    #[inline(always)]
    pub fn cell(&self, x: f32, y: f32) -> Option<(usize, f32, f32)> {
        // Also rejects NaN: every comparison with NaN is false.
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        let (x0, y0) = (x as usize, y as usize);
        if x0 + 1 >= self.w || y0 + 1 >= self.h {
            return None;
        }
        Some(((y0 * self.w + x0) * 3, x - x0 as f32, y - y0 as f32))
    }

    /// Bilinear colour at `(x, y)` px.
    #[inline(always)]
    pub fn bilinear(&self, x: f32, y: f32) -> Option<Rgb> {
        let (i, fx, fy) = self.cell(x, y)?;
        Some(self.bilinear_at(i, fx, fy))
    }

    /// Whether `other` has this image's size: then a [`Image::cell`] of one is a cell of the
    /// other.
    #[inline(always)]
    pub fn same_size(&self, other: &Image) -> bool {
        self.w == other.w && self.h == other.h
    }

    /// The 2×2 pixels of a cell found by [`Image::cell`]: the top pair and the bottom pair,
    /// 3 bytes (RGB) each.
    #[inline(always)]
    pub fn pairs_at(&self, i: usize) -> (&[u8; 6], &[u8; 6]) {
        // One bounds check for both pairs: the block from the top pair to the end of the bottom.
        let row = 3 * self.w;
        let block = &self.raw[i..i + row + 6];
        let t = block[..6].try_into().expect("6 bytes");
        let u = block[row..row + 6].try_into().expect("6 bytes");
        (t, u)
    }

    /// [`Image::bilinear`] at a cell found by [`Image::cell`] (of an image of the same size).
    #[inline(always)]
    pub fn bilinear_at(&self, i: usize, fx: f32, fy: f32) -> Rgb {
        // The two pixel pairs as slices: two bounds checks instead of twelve.
        let (t, u) = self.pairs_at(i);
        let mut out = [0.0; 3];
        for (k, o) in out.iter_mut().enumerate() {
            let (a, b) = (t[k] as f32, t[3 + k] as f32);
            let (c, d) = (u[k] as f32, u[3 + k] as f32);
            let top = a + (b - a) * fx;
            let bot = c + (d - c) * fx;
            *o = top + (bot - top) * fy;
        }
        out
    }

    /// Bilinear colour at `(x, y)` px and its derivatives along x and y (levels/px), as central
    /// differences of bilinear reads half a pixel either side: continuous in the position, unlike
    /// the gradient of the bilinear interpolant itself, which jumps at every pixel boundary.
    /// The five reads share one 3×3 block of pixels, read once.
    #[inline(always)]
    pub fn bilinear_grad(&self, x: f32, y: f32) -> Option<(Rgb, Rgb, Rgb)> {
        let (xs, ys) = (x - 0.5, y - 0.5);
        if !(xs >= 0.0 && ys >= 0.0) {
            return None;
        }
        let (x0, y0) = (xs as usize, ys as usize);
        if x0 + 2 >= self.w || y0 + 2 >= self.h {
            return None;
        }
        // Block offsets: a = fx + (0, 0.5, 1), b = fy + (0, 0.5, 1) within the 3×3 block.
        let (fx, fy) = (xs - x0 as f32, ys - y0 as f32);
        // The block, read once: row j, column i, channel k at [j][3 i + k].
        let row = |j: usize| -> [f32; 9] {
            let start = ((y0 + j) * self.w + x0) * 3;
            let px = &self.raw[start..start + 9];
            std::array::from_fn(|i| px[i] as f32)
        };
        let block = [row(0), row(1), row(2)];
        let (cl, cm, cr) = (split(fx), split(fx + 0.5), split(fx + 1.0));
        let (ru, rm, rd) = (split(fy), split(fy + 0.5), split(fy + 1.0));
        let (mut v, mut gx, mut gy) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        for k in 0..3 {
            v[k] = block_read(&block, cm, rm, k);
            gx[k] = block_read(&block, cr, rm, k) - block_read(&block, cl, rm, k);
            gy[k] = block_read(&block, cm, rd, k) - block_read(&block, cm, ru, k);
        }
        Some((v, gx, gy))
    }
}

/// Where an offset `a ∈ [0, 2)` within a 3×3 block falls: the first pixel of its pair (0 or 1)
/// and the fraction past it.
#[inline(always)]
fn split(a: f32) -> (usize, f32) {
    if a < 1.0 {
        (0, a)
    } else {
        (1, a - 1.0)
    }
}

/// Bilinear value of channel `k` within a 3×3 `block` (see [`Image::bilinear_grad`]) at the
/// column pair and fraction `(i, fa)` and the row pair and fraction `(j, fb)` ([`split`]).
#[inline(always)]
fn block_read(
    block: &[[f32; 9]; 3],
    (i, fa): (usize, f32),
    (j, fb): (usize, f32),
    k: usize,
) -> f32 {
    let p = |jj: usize, ii: usize| block[jj][3 * ii + k];
    let top = p(j, i) + (p(j, i + 1) - p(j, i)) * fa;
    let bot = p(j + 1, i) + (p(j + 1, i + 1) - p(j + 1, i)) * fa;
    top + (bot - top) * fb
}

/// An image pyramid of a frame: level 0 is the frame, each next level halves both sides by
/// averaging 2×2 blocks (a box blur, so coarse levels see the shape of a limb rather than its
/// fine texture, and a match there tolerates misplacement by several pixels).
///
/// Level `k` pixel `x_k` covers full-resolution pixels `2^k·x_k … 2^k·x_k + 2^k − 1`, so a
/// full-resolution position `x` (px) is `x_k = (x − (2^k − 1)/2) / 2^k` there ([`Level`]).
pub struct Pyramid<'a> {
    base: Image<'a>,
    coarse: Cow<'a, [image::RgbImage]>,
}

/// Halves an RGB buffer `w × h` by averaging 2×2 blocks (odd edges dropped). Output rows are
/// made in parallel.
fn halve(raw: &[u8], w: usize, h: usize) -> image::RgbImage {
    use rayon::prelude::*;
    let (w2, h2) = ((w / 2).max(1), (h / 2).max(1));
    let mut out = vec![0u8; w2 * h2 * 3];
    if w >= 2 && h >= 2 {
        out.par_chunks_mut(w2 * 3)
            .enumerate()
            .with_min_len(16)
            .for_each_init(
                || halve_scratch(w),
                |(down, across), (y, o)| {
                    halve_row(&raw[2 * y * w * 3..(2 * y + 2) * w * 3], down, across, o);
                },
            );
    }
    image::RgbImage::from_raw(w2 as u32, h2 as u32, out).expect("buffer sized to the image")
}

/// [`halve`] on the calling thread alone, into `out` (emptied first): the same bytes, for a
/// thread outside rayon's pool (the decode thread) that should not hand its work to the pool's
/// threads.
fn halve_here(raw: &[u8], w: usize, h: usize, mut out: Vec<u8>) -> image::RgbImage {
    let (w2, h2) = ((w / 2).max(1), (h / 2).max(1));
    out.clear();
    out.resize(w2 * h2 * 3, 0);
    if w >= 2 && h >= 2 {
        let (mut down, mut across) = halve_scratch(w);
        for (y, o) in out.chunks_mut(w2 * 3).enumerate() {
            halve_row(
                &raw[2 * y * w * 3..(2 * y + 2) * w * 3],
                &mut down,
                &mut across,
                o,
            );
        }
    }
    image::RgbImage::from_raw(w2 as u32, h2 as u32, out).expect("buffer sized to the image")
}

/// Scratch rows for [`halve_row`] over rows `w` px wide: the row pair summed down, and each of
/// those sums plus the next pixel's.
fn halve_scratch(w: usize) -> (Vec<u16>, Vec<u16>) {
    (vec![0u16; w * 3], vec![0u16; w * 3])
}

/// One output row of [`halve`] from the two input rows `rows`, through `down` and `across`
/// (scratch, as long as an input row). Summed down first, then across, each a plain loop over
/// bytes that the compiler runs wide; integer sums, so the order does not matter.
fn halve_row(rows: &[u8], down: &mut [u16], across: &mut [u16], o: &mut [u8]) {
    let (r0, r1) = rows.split_at(rows.len() / 2);
    for ((d, &a), &b) in down.iter_mut().zip(r0).zip(r1) {
        *d = a as u16 + b as u16;
    }
    // (The last pixel's entry is left as it is: no pair starts there.)
    for (a, (&p, &q)) in across.iter_mut().zip(down.iter().zip(&down[3..])) {
        *a = (p + q + 2) / 4;
    }
    // Every other pixel of `across` is an output pixel.
    for (px, a) in o.chunks_exact_mut(3).zip(across.chunks_exact(6)) {
        px.copy_from_slice(&[a[0] as u8, a[1] as u8, a[2] as u8]);
    }
}

/// `img` halved: 2×2 blocks averaged (rounded), odd edges dropped.
pub fn halve_image(img: &RgbImage) -> RgbImage {
    halve(img.as_raw(), img.width() as usize, img.height() as usize)
}

/// [`halve_image`] on the calling thread alone, written into `buf`'s memory (same bytes).
pub fn halve_image_into(img: &RgbImage, buf: Vec<u8>) -> RgbImage {
    halve_here(
        img.as_raw(),
        img.width() as usize,
        img.height() as usize,
        buf,
    )
}

/// The levels of `img`'s pyramid of `levels` levels after the first: `img` halved, halved
/// again, and so on (none for 1 level).
pub fn coarse_levels(img: &RgbImage, levels: usize) -> Vec<RgbImage> {
    let mut coarse: Vec<RgbImage> = Vec::with_capacity(levels.saturating_sub(1));
    for _ in 1..levels.max(1) {
        let prev = coarse.last().unwrap_or(img);
        let next = halve(prev.as_raw(), prev.width() as usize, prev.height() as usize);
        coarse.push(next);
    }
    coarse
}

/// Every pyramid level of `img` as owned images, level 0 (a copy of `img`) first.
pub fn halve_all(img: &RgbImage, levels: usize) -> Vec<RgbImage> {
    std::iter::once(img.clone())
        .chain(coarse_levels(img, levels))
        .collect()
}

impl<'a> Pyramid<'a> {
    /// The pyramid of `img` with `levels` levels (at least 1; level 0 is `img` itself).
    pub fn new(img: &'a RgbImage, levels: usize) -> Self {
        Pyramid {
            base: Image::new(img),
            coarse: Cow::Owned(coarse_levels(img, levels)),
        }
    }

    /// The pyramid of `img` over its levels below the first, `coarse`, made beforehand
    /// ([`coarse_levels`]) and shared by every pass that steps over the frame.
    pub fn over(img: &'a RgbImage, coarse: &'a [RgbImage]) -> Self {
        Pyramid {
            base: Image::new(img),
            coarse: Cow::Borrowed(coarse),
        }
    }

    /// Number of levels.
    pub fn levels(&self) -> usize {
        1 + self.coarse.len()
    }

    /// Level `k` (0 is the frame), clamped to the coarsest.
    pub fn level(&self, k: usize) -> Level<'_> {
        let k = k.min(self.coarse.len());
        let img = if k == 0 {
            self.base
        } else {
            Image::new(&self.coarse[k - 1])
        };
        Level::new(img, k)
    }
}

/// One pyramid level, read with full-resolution positions (px).
#[derive(Clone, Copy)]
pub struct Level<'a> {
    pub img: Image<'a>,
    /// Level index `k` (0: full resolution).
    pub k: usize,
    /// `2^k`.
    pub scale: f32,
    /// `2^-k`.
    pub inv_scale: f32,
    /// `(2^k − 1) / 2`.
    pub offset: f32,
}

impl<'a> Level<'a> {
    /// Level `k` made of `img`.
    pub fn new(img: Image<'a>, k: usize) -> Self {
        let scale = (1u32 << k) as f32;
        Level {
            img,
            k,
            scale,
            inv_scale: 1.0 / scale,
            offset: 0.5 * (scale - 1.0),
        }
    }

    /// The level's own coordinates of the full-resolution position `(x, y)`.
    #[inline(always)]
    pub fn to_level(&self, x: f32, y: f32) -> (f32, f32) {
        (
            (x - self.offset) * self.inv_scale,
            (y - self.offset) * self.inv_scale,
        )
    }

    /// Bilinear colour at the full-resolution position `(x, y)`.
    #[inline(always)]
    pub fn bilinear(&self, x: f32, y: f32) -> Option<Rgb> {
        let (lx, ly) = self.to_level(x, y);
        self.img.bilinear(lx, ly)
    }

    /// Bilinear colour at the full-resolution position `(x, y)` and its derivatives per
    /// full-resolution px (see [`Image::bilinear_grad`]).
    #[inline(always)]
    pub fn bilinear_grad(&self, x: f32, y: f32) -> Option<(Rgb, Rgb, Rgb)> {
        let (lx, ly) = self.to_level(x, y);
        let (v, gx, gy) = self.img.bilinear_grad(lx, ly)?;
        let s = self.inv_scale;
        Some((v, gx.map(|g| g * s), gy.map(|g| g * s)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halve_is_the_rounded_mean_of_each_block() {
        for (w, h) in [(2, 2), (3, 3), (4, 2), (5, 7), (8, 6), (33, 40)] {
            let raw: Vec<u8> = (0..w * h * 3)
                .map(|i| ((i * 97 + i / 7) % 256) as u8)
                .collect();
            let out = halve(&raw, w, h);
            assert_eq!(
                (out.width() as usize, out.height() as usize),
                (w / 2, h / 2)
            );
            assert_eq!(
                out,
                halve_here(&raw, w, h, vec![9; 5]),
                "{w}x{h}: one thread, other bytes"
            );
            for y in 0..h / 2 {
                for x in 0..w / 2 {
                    for k in 0..3 {
                        let at = |xx: usize, yy: usize| raw[(yy * w + xx) * 3 + k] as u16;
                        let sum = at(2 * x, 2 * y)
                            + at(2 * x + 1, 2 * y)
                            + at(2 * x, 2 * y + 1)
                            + at(2 * x + 1, 2 * y + 1);
                        let got = out.get_pixel(x as u32, y as u32).0[k];
                        assert_eq!(got, ((sum + 2) / 4) as u8, "{w}x{h} at ({x}, {y}) {k}");
                    }
                }
            }
        }
    }

    fn ramp() -> RgbImage {
        // R = 10 x, G = 5 y, B = x + y: a linear image, so bilinear reads are exact.
        RgbImage::from_fn(8, 6, |x, y| {
            image::Rgb([(10 * x) as u8, (5 * y) as u8, (x + y) as u8])
        })
    }

    #[test]
    fn bilinear_is_exact_on_a_linear_image() {
        let img = ramp();
        let im = Image::new(&img);
        let c = im.bilinear(2.25, 3.5).unwrap();
        assert!(
            (c[0] - 22.5).abs() < 1e-4 && (c[1] - 17.5).abs() < 1e-4 && (c[2] - 5.75).abs() < 1e-4
        );
        let (v, gx, gy) = im.bilinear_grad(2.25, 3.5).unwrap();
        assert_eq!(v, c);
        assert_eq!(gx, [10.0, 0.0, 1.0]);
        assert_eq!(gy, [0.0, 5.0, 1.0]);
    }

    #[test]
    fn pyramid_levels_read_the_same_linear_image_at_full_resolution_positions() {
        // A linear image stays linear under 2×2 averaging, so every level reads the same
        // colour at the same full-resolution position (away from rounding).
        let img = RgbImage::from_fn(64, 48, |x, y| image::Rgb([(2 * x) as u8, (3 * y) as u8, 7]));
        let pyr = Pyramid::new(&img, 3);
        assert_eq!(pyr.levels(), 3);
        for k in 0..3 {
            let c = pyr.level(k).bilinear(20.3, 17.6).unwrap();
            assert!(
                (c[0] - 40.6).abs() < 0.6 && (c[1] - 52.8).abs() < 0.6,
                "level {k}: {c:?}"
            );
            let (_, gx, gy) = pyr.level(k).bilinear_grad(20.3, 17.6).unwrap();
            assert!(
                (gx[0] - 2.0).abs() < 0.05 && (gy[1] - 3.0).abs() < 0.05,
                "{gx:?} {gy:?}"
            );
        }
    }

    #[test]
    fn gradient_is_the_central_difference_of_bilinear_reads() {
        let img = RgbImage::from_fn(9, 7, |x, y| {
            image::Rgb([
                (x * x * 3 + y) as u8,
                (50 + 7 * x * y) as u8,
                (200 - 5 * y * y) as u8,
            ])
        });
        let im = Image::new(&img);
        for &(x, y) in &[(2.3f32, 3.7f32), (4.5, 2.5), (1.0, 1.0), (6.9, 4.2)] {
            let (v, gx, gy) = im.bilinear_grad(x, y).unwrap();
            let b = |x, y| im.bilinear(x, y).unwrap();
            for k in 0..3 {
                assert!((v[k] - b(x, y)[k]).abs() < 1e-3);
                assert!((gx[k] - (b(x + 0.5, y)[k] - b(x - 0.5, y)[k])).abs() < 1e-3);
                assert!((gy[k] - (b(x, y + 0.5)[k] - b(x, y - 0.5)[k])).abs() < 1e-3);
            }
        }
        assert!(im.bilinear_grad(0.4, 3.0).is_none());
        assert!(im.bilinear_grad(7.6, 3.0).is_none());
    }

    #[test]
    fn outside_reads_none() {
        let img = ramp();
        let im = Image::new(&img);
        assert!(im.bilinear(-0.1, 1.0).is_none());
        assert!(im.bilinear(6.99, 1.0).is_some());
        assert!(im.bilinear(7.0, 1.0).is_none());
        assert!(im.bilinear(1.0, 5.0).is_none());
        assert!(im.bilinear(f32::NAN, 1.0).is_none());
    }
}
