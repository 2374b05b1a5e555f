//! The coarse cost ([`Strip::coarse_cost_until`]) written out in AVX2 instructions: a block of
//! [`LANES`] samples placed, read and costed in one register per quantity, with the pixels of
//! each sample's cell read as four 32-bit words (the top and the bottom pair, each as its first
//! and its last four bytes) and split into channels by shifts, instead of twelve bytes stored
//! one by one and read back as vectors (a store-to-load forwarding stall on every block).
//!
//! Every lane goes through the operations of the portable kernel, in the same order (no fused
//! multiply-adds), and the terms are added one by one in sample order, so the cost, the lower
//! bounds handed to `stop` and the early stop are the portable kernel's to the bit (the test
//! `avx2_builds_give_the_portable_bits`).

use super::{Strip, View, LANES, PLATE_CHECK_E};
use crate::geom::Point;
use crate::track::pixels::Image;
use std::arch::x86_64::*;

/// The four 32-bit words of the cells at byte offsets `at` (one per lane) of `img`: the top
/// pair's bytes 0–3 and 2–5, the bottom pair's bytes 0–3 and 2–5.
///
/// # Safety
/// The CPU must have AVX2 (inlined into [`Strip::coarse_cost_until_avx2`] only).
#[inline(always)]
pub(super) unsafe fn cells(img: &Image, at: __m256i) -> [__m256i; 4] {
    // Each word is loaded straight into its lane (no bytes stored and read back as a vector),
    // written out lane by lane: the intrinsics need constant lane numbers.
    macro_rules! pair {
        ($l:literal) => {
            img.pairs_at(_mm256_extract_epi32::<$l>(at) as usize)
        };
    }
    // SAFETY (of the reads): bytes 0–3 and 2–5 of a 6-byte array.
    let word = |b: &[u8; 6], k: usize| std::ptr::read_unaligned(b.as_ptr().add(k) as *const i32);
    let (t0, u0) = pair!(0);
    let (t1, u1) = pair!(1);
    let (t2, u2) = pair!(2);
    let (t3, u3) = pair!(3);
    let (t4, u4) = pair!(4);
    let (t5, u5) = pair!(5);
    let (t6, u6) = pair!(6);
    let (t7, u7) = pair!(7);
    macro_rules! gather {
        ($k:literal, $a:ident, $b:ident, $c:ident, $d:ident, $e:ident, $f:ident, $g:ident, $h:ident) => {{
            let lo = _mm_cvtsi32_si128(word($a, $k));
            let lo = _mm_insert_epi32::<1>(lo, word($b, $k));
            let lo = _mm_insert_epi32::<2>(lo, word($c, $k));
            let lo = _mm_insert_epi32::<3>(lo, word($d, $k));
            let hi = _mm_cvtsi32_si128(word($e, $k));
            let hi = _mm_insert_epi32::<1>(hi, word($f, $k));
            let hi = _mm_insert_epi32::<2>(hi, word($g, $k));
            let hi = _mm_insert_epi32::<3>(hi, word($h, $k));
            _mm256_set_m128i(hi, lo)
        }};
    }
    [
        gather!(0, t0, t1, t2, t3, t4, t5, t6, t7),
        gather!(2, t0, t1, t2, t3, t4, t5, t6, t7),
        gather!(0, u0, u1, u2, u3, u4, u5, u6, u7),
        gather!(2, u0, u1, u2, u3, u4, u5, u6, u7),
    ]
}

/// Bilinear colours (channel by channel) of the cells read by [`cells`], as
/// [`Image::bilinear_at`] computes them: `a b` on top, `c d` below.
///
/// The byte of every lane of `w` that starts `shift` bits up (0, 8, 16 or 24), as floats.
///
/// # Safety
/// The CPU must have AVX2 (inlined into the AVX2 builds only).
#[inline(always)]
pub(super) unsafe fn chan(w: __m256i, shift: i32) -> __m256 {
    let s = match shift {
        0 => w,
        8 => _mm256_srli_epi32::<8>(w),
        16 => _mm256_srli_epi32::<16>(w),
        _ => _mm256_srli_epi32::<24>(w),
    };
    _mm256_cvtepi32_ps(_mm256_and_si256(s, _mm256_set1_epi32(0xff)))
}

/// # Safety
/// The CPU must have AVX2 (inlined into [`Strip::coarse_cost_until_avx2`] only).
#[inline(always)]
pub(super) unsafe fn bilinear(words: &[__m256i; 4], fx: __m256, fy: __m256) -> [__m256; 3] {
    // Channel `ch` of the first pixel of a pair is byte `ch` of its first word; of the second
    // pixel, byte `ch + 1` of its last word (bytes 2–5: a₂ b₀ b₁ b₂).
    let mut out = [_mm256_setzero_ps(); 3];
    for (ch, o) in out.iter_mut().enumerate() {
        let lo = 8 * ch as i32;
        let (a, b) = (chan(words[0], lo), chan(words[1], lo + 8));
        let (c, d) = (chan(words[2], lo), chan(words[3], lo + 8));
        let top = _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), fx));
        let bot = _mm256_add_ps(c, _mm256_mul_ps(_mm256_sub_ps(d, c), fx));
        *o = _mm256_add_ps(top, _mm256_mul_ps(_mm256_sub_ps(bot, top), fy));
    }
    out
}

/// `floor_small` of `cost.rs`, lane by lane: `⌊x⌋` as an integer and as a float, for
/// `0 ≤ x < 2²³`.
///
/// # Safety
/// The CPU must have AVX2 (inlined into AVX2 builds only).
#[inline(always)]
pub(super) unsafe fn floor(x: __m256) -> (__m256i, __m256) {
    let big = _mm256_set1_ps(8_388_608.0);
    let r = _mm256_sub_ps(_mm256_add_ps(x, big), big);
    let f = _mm256_blendv_ps(
        r,
        _mm256_sub_ps(r, _mm256_set1_ps(1.0)),
        _mm256_cmp_ps::<_CMP_GT_OQ>(r, x),
    );
    let i = _mm256_sub_epi32(
        _mm256_castps_si256(_mm256_add_ps(f, big)),
        _mm256_castps_si256(big),
    );
    (i, f)
}

impl Strip {
    /// [`Strip::coarse_cost_until`] in AVX2 instructions (see the module doc): the portable
    /// kernel's result to the bit.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn coarse_cost_until_avx2(
        &self,
        v: &View,
        p: Point,
        c: Point,
        mirrored: bool,
        stop: impl Fn(f32) -> bool,
    ) -> Option<f32> {
        let img = &v.img.img;
        // Byte offsets of cells as 32-bit lanes.
        // (A frame narrower or lower than a cell has no sample inside: the portable kernel
        // reads nothing there.)
        if img.width() * img.height() * 3 > i32::MAX as usize || img.width() < 2 || img.height() < 2
        {
            return self.coarse_cost_until_any(v, p, c, mirrored, stop);
        }
        let place = self.placement_as(p, c, mirrored);
        let inv = self.inv_scale();
        let lv = v.img.k;
        let plate = v
            .plate
            .as_ref()
            .filter(|p| self.trust_plate && p.k == lv && p.img.same_size(img));
        // A plate of another size is read sample by sample, as the portable kernel does.
        let general_plate = plate.is_none() && self.trust_plate && v.plate.is_some();
        let xmax = _mm256_set1_ps(img.width().saturating_sub(1) as f32);
        let ymax = _mm256_set1_ps(img.height().saturating_sub(1) as f32);
        let width = _mm256_set1_epi32(img.width() as i32);
        let s = _mm256_set1_ps;
        let (pw, ox, oy) = (s(place.w), s(place.o.x), s(place.o.y));
        let (ax, ay, ux, uy) = (s(place.a.x), s(place.a.y), s(place.u.x), s(place.u.y));
        let (nx, ny) = (s(place.n.x), s(place.n.y));
        let (offset, scale) = (s(v.img.offset), s(v.img.inv_scale));
        let (zero, one, gain, inv_v) = (s(0.0), s(1.0), s(v.gain), s(inv));
        let check_e = s(PLATE_CHECK_E);
        let (bg_inv, infinity) = (s(v.bg_inv), s(f32::INFINITY));
        let abs = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff));
        let mut sum = 0.0f32;
        for (b, blk) in self.coarse.iter().enumerate() {
            let count = (self.coarse_len - b * LANES).min(LANES);
            let ld = |a: &[f32; LANES]| _mm256_loadu_ps(a.as_ptr());
            // `Placement::at`.
            let (e, w) = (_mm256_mul_ps(ld(&blk.e), pw), _mm256_mul_ps(ld(&blk.v), pw));
            let t = ld(&blk.t);
            let along = |o, a, u, n| {
                let x = _mm256_add_ps(o, _mm256_mul_ps(t, a));
                let x = _mm256_add_ps(x, _mm256_mul_ps(e, u));
                _mm256_add_ps(x, _mm256_mul_ps(w, n))
            };
            let (x, y) = (along(ox, ax, ux, nx), along(oy, ay, uy, ny));
            // `Level::to_level`, the frame test and `floor_small`.
            let lx = _mm256_mul_ps(_mm256_sub_ps(x, offset), scale);
            let ly = _mm256_mul_ps(_mm256_sub_ps(y, offset), scale);
            let inside = _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(lx, zero),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(ly, zero),
                ),
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_LT_OQ>(lx, xmax),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(ly, ymax),
                ),
            );
            let (cx, cy) = (_mm256_and_ps(lx, inside), _mm256_and_ps(ly, inside));
            let ((x0, flx), (y0, fly)) = (floor(cx), floor(cy));
            let (fx, fy) = (_mm256_sub_ps(cx, flx), _mm256_sub_ps(cy, fly));
            let at_v = _mm256_mullo_epi32(
                _mm256_add_epi32(_mm256_mullo_epi32(y0, width), x0),
                _mm256_set1_epi32(3),
            );
            let col = bilinear(&cells(img, at_v), fx, fy);
            // `residual`.
            let tm = &blk.template[lv];
            let d = |ch: usize| _mm256_sub_ps(col[ch], _mm256_mul_ps(gain, ld(&tm[ch])));
            let (d0, d1, d2) = (d(0), d(1), d(2));
            let e = _mm256_mul_ps(
                _mm256_add_ps(
                    _mm256_add_ps(_mm256_mul_ps(d0, d0), _mm256_mul_ps(d1, d1)),
                    _mm256_mul_ps(d2, d2),
                ),
                inv_v,
            );
            // The plate, where a sample fits.
            let checked = _mm256_and_ps(inside, _mm256_cmp_ps::<_CMP_LT_OQ>(e, check_e));
            let mut fits = inside;
            if let Some(pl) = plate {
                if _mm256_movemask_ps(checked) & ((1 << count) - 1) != 0 {
                    let bgc = bilinear(&cells(&pl.img, at_v), fx, fy);
                    let q = |ch: usize| {
                        let d = _mm256_sub_ps(col[ch], _mm256_mul_ps(gain, bgc[ch]));
                        _mm256_mul_ps(d, d)
                    };
                    let dd = _mm256_add_ps(_mm256_add_ps(q(0), q(1)), q(2));
                    let background = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_mul_ps(dd, bg_inv), one);
                    fits = _mm256_andnot_ps(_mm256_and_ps(background, checked), inside);
                }
            } else if general_plate {
                let mask = _mm256_movemask_ps(checked);
                if mask & ((1 << count) - 1) != 0 {
                    let mut xs = [0.0f32; LANES];
                    let mut ys = [0.0f32; LANES];
                    let mut cs = [[0.0f32; LANES]; 3];
                    _mm256_storeu_ps(xs.as_mut_ptr(), x);
                    _mm256_storeu_ps(ys.as_mut_ptr(), y);
                    for (ch, out) in cs.iter_mut().enumerate() {
                        _mm256_storeu_ps(out.as_mut_ptr(), col[ch]);
                    }
                    let mut bg = [0i32; LANES];
                    for l in 0..count {
                        if mask & (1 << l) != 0 {
                            let rgb = [cs[0][l], cs[1][l], cs[2][l]];
                            bg[l] = -(v.looks_background(xs[l], ys[l], rgb) as i32);
                        }
                    }
                    let bg = _mm256_castsi256_ps(_mm256_loadu_si256(bg.as_ptr() as *const __m256i));
                    fits = _mm256_andnot_ps(bg, inside);
                }
            }
            // The robust terms.
            let finite = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_and_ps(e, abs), infinity);
            let rho = _mm256_div_ps(e, _mm256_add_ps(one, e));
            let r = _mm256_blendv_ps(one, rho, _mm256_and_ps(fits, finite));
            let mut term = [0.0f32; LANES];
            _mm256_storeu_ps(term.as_mut_ptr(), _mm256_mul_ps(ld(&blk.w), r));
            for &t in &term[..count] {
                sum += t;
            }
            if count == LANES && stop(sum / self.coarse_weight) {
                return None;
            }
        }
        let n = self.coarse_weight;
        Some(if n > 0.0 { sum / n } else { 1.0 })
    }
}
