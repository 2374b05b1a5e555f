//! The Gauss–Newton normal equations ([`Strip::normal`]) with their per-sample work in AVX2
//! instructions: [`LANES`] samples placed, read (the 3×3 pixel block of
//! [`Image::bilinear_grad`](crate::track::pixels::Image::bilinear_grad) as nine 32-bit words per
//! sample, the clean plate's cell as four) and turned into their normal-equation terms side by
//! side, each with the operations of the portable build in the same order; the terms are then
//! added into the `f64` sums one sample at a time, in sample order, so the result is the
//! portable build's to the bit (the test `avx2_builds_give_the_portable_bits`).

use super::simd::{bilinear, cells, chan, floor};
use super::{Normal, Shape, Strip, View, LANES};
use crate::geom::Point;
use crate::track::pixels::Image;
use std::arch::x86_64::*;

/// The nine 32-bit words of the 3×3 blocks whose top-left pixels are at byte offsets `at` of
/// `img`: per row, bytes 0–3, 3–6 and 5–8 (pixel 0 in the first word's bytes 0–2, pixel 1 in the
/// second's 0–2, pixel 2 in the third's 1–3).
///
/// # Safety
/// The CPU must have AVX2 (inlined into [`Strip::normal_avx2`] only); every block must lie
/// within the image.
#[inline(always)]
unsafe fn blocks(img: &Image, at: &[u32; LANES]) -> [[__m256i; 3]; 3] {
    let row = 3 * img.width();
    let mut words = [[[0i32; LANES]; 3]; 3];
    let word = |b: &[u8; 6], k: usize| std::ptr::read_unaligned(b.as_ptr().add(k) as *const i32);
    for l in 0..LANES {
        let i = at[l] as usize;
        let (a01, b01) = (img.pairs_at(i), img.pairs_at(i + 3));
        let (a12, b12) = (img.pairs_at(i + row), img.pairs_at(i + row + 3));
        for (j, (a, b)) in [(a01.0, b01.0), (a01.1, b01.1), (a12.1, b12.1)]
            .into_iter()
            .enumerate()
        {
            words[j][0][l] = word(a, 0);
            words[j][1][l] = word(b, 0);
            words[j][2][l] = word(b, 2);
        }
    }
    let v = |w: &[i32; LANES]| _mm256_loadu_si256(w.as_ptr() as *const __m256i);
    [
        [v(&words[0][0]), v(&words[0][1]), v(&words[0][2])],
        [v(&words[1][0]), v(&words[1][1]), v(&words[1][2])],
        [v(&words[2][0]), v(&words[2][1]), v(&words[2][2])],
    ]
}

/// `split` of `pixels.rs`, lane by lane: whether `a ≥ 1` (then the second pixel pair) and the
/// fraction.
#[inline(always)]
unsafe fn split(a: __m256) -> (__m256, __m256) {
    let one = _mm256_set1_ps(1.0);
    // `a < 1.0` false (NaN too): the second pair.
    let second = _mm256_cmp_ps::<_CMP_NLT_UQ>(a, one);
    (second, _mm256_blendv_ps(a, _mm256_sub_ps(a, one), second))
}

impl Strip {
    /// [`Strip::normal`] with its per-sample work in AVX2 instructions (see the module doc).
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn normal_avx2(
        &self,
        v: &View,
        p: Point,
        c: Point,
        weight: f32,
        widen: f32,
    ) -> Normal {
        let (lvl, gain) = (&v.img, v.gain);
        let img = &lvl.img;
        let plate = v.plate.as_ref().filter(|_| self.trust_plate);
        let small = |i: &Image| {
            i.width() < 3 || i.height() < 3 || i.width() * i.height() * 3 > i32::MAX as usize
        };
        if small(img) || plate.is_some_and(|p| small(&p.img)) {
            return self.normal_any(v, p, c, weight, widen);
        }
        let place = self.placement(p, c);
        let inv = self.inv_scale() / (widen * widen);
        let mut out = Normal::default();
        let stride = 1usize << lvl.k;
        let scale = (weight * stride as f32 / self.weight_sum()) as f64;
        let (u, n, len, omega, gamma) = (place.u, place.n, place.len, place.w, self.width_exponent);
        let lv = lvl.k;
        let s = _mm256_set1_ps;
        let (zero, one, half) = (s(0.0), s(1.0), s(0.5));
        let sign = s(-0.0);
        let neg = |x: __m256| _mm256_xor_ps(x, sign);
        let (pw, ox, oy) = (s(place.w), s(place.o.x), s(place.o.y));
        let (ax, ay, ux, uy) = (s(place.a.x), s(place.a.y), s(u.x), s(u.y));
        let (nx, ny) = (s(n.x), s(n.y));
        let (m1f, m2f) = (s(omega / len), s(gamma * omega / len));
        let (gain_v, inv_v, inv2) = (s(gain), s(inv), s(2.0 * inv));
        // The samples this level reads, in blocks of `LANES`.
        let mut picked = self
            .samples
            .iter()
            .enumerate()
            .step_by(stride)
            // (As the portable build skips `sw <= 0`.)
            .filter(|&(k, _)| !(self.weight(k) <= 0.0))
            .peekable();
        while picked.peek().is_some() {
            let mut count = 0;
            let (mut t, mut e, mut vv, mut sw) =
                ([0f32; LANES], [0f32; LANES], [0f32; LANES], [0f32; LANES]);
            let mut tm = [[0f32; LANES]; 3];
            for (k, smp) in picked.by_ref().take(LANES) {
                (t[count], e[count], vv[count]) = (smp.t, smp.e, smp.v);
                sw[count] = self.weight(k);
                for ch in 0..3 {
                    tm[ch][count] = self.template[k][lv][ch];
                }
                count += 1;
            }
            let ld = |a: &[f32; LANES]| _mm256_loadu_ps(a.as_ptr());
            let (tv, ev, vvv) = (ld(&t), ld(&e), ld(&vv));
            // `Placement::at`.
            let (es, vs) = (_mm256_mul_ps(ev, pw), _mm256_mul_ps(vvv, pw));
            let along = |o, a, u, n| {
                let x = _mm256_add_ps(o, _mm256_mul_ps(tv, a));
                let x = _mm256_add_ps(x, _mm256_mul_ps(es, u));
                _mm256_add_ps(x, _mm256_mul_ps(vs, n))
            };
            let (x, y) = (along(ox, ax, ux, nx), along(oy, ay, uy, ny));
            // `Level::bilinear_grad`: the 3×3 block around the half-pixel-shifted position.
            let (loff, lsc) = (s(lvl.offset), s(lvl.inv_scale));
            let xs = _mm256_sub_ps(_mm256_mul_ps(_mm256_sub_ps(x, loff), lsc), half);
            let ys = _mm256_sub_ps(_mm256_mul_ps(_mm256_sub_ps(y, loff), lsc), half);
            let inside = _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(xs, zero),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(ys, zero),
                ),
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_LT_OQ>(xs, s(img.width().saturating_sub(2) as f32)),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(ys, s(img.height().saturating_sub(2) as f32)),
                ),
            );
            let (cx, cy) = (_mm256_and_ps(xs, inside), _mm256_and_ps(ys, inside));
            let ((x0, flx), (y0, fly)) = (floor(cx), floor(cy));
            let (fx, fy) = (_mm256_sub_ps(cx, flx), _mm256_sub_ps(cy, fly));
            let mut at = [0u32; LANES];
            let at_v = _mm256_mullo_epi32(
                _mm256_add_epi32(
                    _mm256_mullo_epi32(y0, _mm256_set1_epi32(img.width() as i32)),
                    x0,
                ),
                _mm256_set1_epi32(3),
            );
            _mm256_storeu_si256(at.as_mut_ptr() as *mut __m256i, at_v);
            let words = blocks(img, &at);
            let (cl, cm, cr) = (
                split(fx),
                split(_mm256_add_ps(fx, half)),
                split(_mm256_add_ps(fx, one)),
            );
            let (ru, rm, rd) = (
                split(fy),
                split(_mm256_add_ps(fy, half)),
                split(_mm256_add_ps(fy, one)),
            );
            let sel = |m: __m256, a: __m256, b: __m256| _mm256_blendv_ps(a, b, m);
            let (mut col, mut gx, mut gy) = ([zero; 3], [zero; 3], [zero; 3]);
            for ch in 0..3 {
                let lo = 8 * ch as i32;
                // Pixel `i` of row `j`, channel `ch`.
                let px = |j: usize| {
                    [
                        chan(words[j][0], lo),
                        chan(words[j][1], lo),
                        chan(words[j][2], lo + 8),
                    ]
                };
                let rows = [px(0), px(1), px(2)];
                let read = |(ci, fa): (__m256, __m256), (rj, fb): (__m256, __m256)| {
                    // Columns (i, i + 1) and rows (j, j + 1), i and j 0 or 1 per lane.
                    let pair = |r: &[__m256; 3]| (sel(ci, r[0], r[1]), sel(ci, r[1], r[2]));
                    let (r0, r1) = (pair(&rows[0]), pair(&rows[1]));
                    let r2 = pair(&rows[2]);
                    let (tp, bt) = (
                        (sel(rj, r0.0, r1.0), sel(rj, r0.1, r1.1)),
                        (sel(rj, r1.0, r2.0), sel(rj, r1.1, r2.1)),
                    );
                    let top = _mm256_add_ps(tp.0, _mm256_mul_ps(_mm256_sub_ps(tp.1, tp.0), fa));
                    let bot = _mm256_add_ps(bt.0, _mm256_mul_ps(_mm256_sub_ps(bt.1, bt.0), fa));
                    _mm256_add_ps(top, _mm256_mul_ps(_mm256_sub_ps(bot, top), fb))
                };
                col[ch] = read(cm, rm);
                gx[ch] = _mm256_mul_ps(_mm256_sub_ps(read(cr, rm), read(cl, rm)), lsc);
                gy[ch] = _mm256_mul_ps(_mm256_sub_ps(read(cm, rd), read(cm, ru)), lsc);
            }
            // `View::looks_background` where the block is inside.
            let mut valid = inside;
            if let Some(pl) = plate {
                let (poff, psc) = (s(pl.offset), s(pl.inv_scale));
                let px = _mm256_mul_ps(_mm256_sub_ps(x, poff), psc);
                let py = _mm256_mul_ps(_mm256_sub_ps(y, poff), psc);
                let pin = _mm256_and_ps(
                    _mm256_and_ps(
                        _mm256_cmp_ps::<_CMP_GE_OQ>(px, zero),
                        _mm256_cmp_ps::<_CMP_GE_OQ>(py, zero),
                    ),
                    _mm256_and_ps(
                        _mm256_cmp_ps::<_CMP_LT_OQ>(px, s(pl.img.width().saturating_sub(1) as f32)),
                        _mm256_cmp_ps::<_CMP_LT_OQ>(
                            py,
                            s(pl.img.height().saturating_sub(1) as f32),
                        ),
                    ),
                );
                let (qx, qy) = (_mm256_and_ps(px, pin), _mm256_and_ps(py, pin));
                let ((qx0, qfx), (qy0, qfy)) = (floor(qx), floor(qy));
                let pat = _mm256_mullo_epi32(
                    _mm256_add_epi32(
                        _mm256_mullo_epi32(qy0, _mm256_set1_epi32(pl.img.width() as i32)),
                        qx0,
                    ),
                    _mm256_set1_epi32(3),
                );
                let b = bilinear(
                    &cells(&pl.img, pat),
                    _mm256_sub_ps(qx, qfx),
                    _mm256_sub_ps(qy, qfy),
                );
                let q = |ch: usize| {
                    let d = _mm256_sub_ps(col[ch], _mm256_mul_ps(gain_v, b[ch]));
                    _mm256_mul_ps(d, d)
                };
                let dd = _mm256_add_ps(_mm256_add_ps(q(0), q(1)), q(2));
                let bg = _mm256_and_ps(
                    pin,
                    _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_mul_ps(dd, s(v.bg_inv)), one),
                );
                valid = _mm256_andnot_ps(bg, inside);
            }
            // The residual and the terms of the normal equations.
            let r: [__m256; 3] = std::array::from_fn(|ch| {
                _mm256_sub_ps(col[ch], _mm256_mul_ps(gain_v, ld(&tm[ch])))
            });
            let sq = |a: __m256, b: __m256| _mm256_mul_ps(a, b);
            let e = _mm256_mul_ps(
                _mm256_add_ps(
                    _mm256_add_ps(sq(r[0], r[0]), sq(r[1], r[1])),
                    sq(r[2], r[2]),
                ),
                inv_v,
            );
            let swv = ld(&sw);
            let ope = _mm256_add_ps(one, e);
            let wv = _mm256_div_ps(swv, _mm256_mul_ps(ope, ope));
            let cost_t = _mm256_div_ps(_mm256_mul_ps(swv, e), ope);
            let dot = |a: &[__m256; 3], b: &[__m256; 3]| {
                let mut acc = zero;
                for ch in 0..3 {
                    acc = _mm256_add_ps(acc, _mm256_mul_ps(a[ch], b[ch]));
                }
                acc
            };
            let (a00, a01, a11) = (dot(&gx, &gx), dot(&gx, &gy), dot(&gy, &gy));
            let (b0, b1) = (dot(&gx, &r), dot(&gy, &r));
            let cols: [[__m256; 2]; 4] = match self.shape {
                Shape::Patch => [[one, zero], [zero, one], [zero, zero], [zero, zero]],
                Shape::Bone => {
                    let m1x = _mm256_mul_ps(
                        _mm256_sub_ps(_mm256_mul_ps(nx, ev), _mm256_mul_ps(ux, vvv)),
                        m1f,
                    );
                    let m1y = _mm256_mul_ps(
                        _mm256_sub_ps(_mm256_mul_ps(ny, ev), _mm256_mul_ps(uy, vvv)),
                        m1f,
                    );
                    let m2x = _mm256_mul_ps(
                        _mm256_add_ps(_mm256_mul_ps(ux, ev), _mm256_mul_ps(nx, vvv)),
                        m2f,
                    );
                    let m2y = _mm256_mul_ps(
                        _mm256_add_ps(_mm256_mul_ps(uy, ev), _mm256_mul_ps(ny, vvv)),
                        m2f,
                    );
                    let cx = [
                        _mm256_sub_ps(
                            _mm256_add_ps(tv, _mm256_mul_ps(nx, m1x)),
                            _mm256_mul_ps(ux, m2x),
                        ),
                        _mm256_sub_ps(_mm256_mul_ps(nx, m1y), _mm256_mul_ps(ux, m2y)),
                    ];
                    let cy = [
                        _mm256_sub_ps(_mm256_mul_ps(ny, m1x), _mm256_mul_ps(uy, m2x)),
                        _mm256_sub_ps(
                            _mm256_add_ps(tv, _mm256_mul_ps(ny, m1y)),
                            _mm256_mul_ps(uy, m2y),
                        ),
                    ];
                    [
                        [_mm256_sub_ps(one, cx[0]), neg(cx[1])],
                        [neg(cy[0]), _mm256_sub_ps(one, cy[1])],
                        cx,
                        cy,
                    ]
                }
            };
            let lin = |a: __m256, b: __m256, ca: __m256, cb: __m256| {
                _mm256_add_ps(_mm256_mul_ps(a, ca), _mm256_mul_ps(b, cb))
            };
            let ab: [[__m256; 2]; 4] = std::array::from_fn(|i| {
                [
                    lin(a00, a01, cols[i][0], cols[i][1]),
                    lin(a01, a11, cols[i][0], cols[i][1]),
                ]
            });
            // Per lane: cost term, f's f32 factor, 4 gradient and 10 Hessian terms.
            let mut terms = [[0f32; LANES]; 16];
            let st = |o: &mut [f32; LANES], x: __m256| _mm256_storeu_ps(o.as_mut_ptr(), x);
            st(&mut terms[0], cost_t);
            st(&mut terms[1], _mm256_mul_ps(inv2, wv));
            for i in 0..4 {
                st(&mut terms[2 + i], lin(b0, b1, cols[i][0], cols[i][1]));
            }
            let mut slot = 6;
            for i in 0..4 {
                for j in i..4 {
                    st(
                        &mut terms[slot],
                        lin(cols[i][0], cols[i][1], ab[j][0], ab[j][1]),
                    );
                    slot += 1;
                }
            }
            let valid = _mm256_movemask_ps(valid);
            for l in 0..count {
                if valid & (1 << l) == 0 {
                    out.cost += scale * sw[l] as f64;
                    continue;
                }
                out.cost += scale * terms[0][l] as f64;
                let f = terms[1][l] as f64 * scale;
                for i in 0..4 {
                    out.g[i] += f * terms[2 + i][l] as f64;
                }
                let mut slot = 6;
                for i in 0..4 {
                    for j in i..4 {
                        out.h[i][j] += f * terms[slot][l] as f64;
                        slot += 1;
                    }
                }
            }
        }
        for i in 0..4 {
            for j in 0..i {
                out.h[i][j] = out.h[j][i];
            }
        }
        out
    }
}
