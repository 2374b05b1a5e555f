//! Filling a grey pyramid: luma from RGB and levels halved, with AVX2 where the CPU has it
//! (the same arithmetic in the same order, so the same values on every CPU).

/// One row of a halved level: `out[x]` the average of `r0[2x..2x + 2]` and `r1[2x..2x + 2]`.
pub(super) fn halve_row(r0: &[f32], r1: &[f32], out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2.
        return unsafe { halve_row_avx2(r0, r1, out) };
    }
    halve_row_any(r0, r1, out)
}

/// [`halve_row`] compiled for AVX2 (the same arithmetic, so the same values).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn halve_row_avx2(r0: &[f32], r1: &[f32], out: &mut [f32]) {
    halve_row_any(r0, r1, out)
}

#[inline(always)]
fn halve_row_any(r0: &[f32], r1: &[f32], out: &mut [f32]) {
    for ((o, a), b) in out
        .iter_mut()
        .zip(r0.chunks_exact(2))
        .zip(r1.chunks_exact(2))
    {
        *o = 0.25 * (a[0] + a[1] + b[0] + b[1]);
    }
}

/// Rec. 601 luma of RGB pixels `rgb` into `out` (one value a pixel).
pub(super) fn luma_into(rgb: &[u8], out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2.
        return unsafe { luma_avx2(rgb, out) };
    }
    luma_any(rgb, out)
}

/// [`luma_into`] with AVX2: eight pixels at a time, their red, green and blue bytes picked out
/// by byte shuffles, then the same products and sums as [`luma_any`] (so the same values).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn luma_avx2(rgb: &[u8], out: &mut [f32]) {
    use std::arch::x86_64::*;
    // Byte `i` of the 16 loaded first, or (`hi`) of the 8 after: -1 leaves a zero.
    const fn pick(channel: usize, hi: bool) -> [i8; 16] {
        let mut m = [-1i8; 16];
        let mut k = 0;
        while k < 8 {
            let b = 3 * k + channel;
            if hi && b >= 16 {
                m[k] = (b - 16) as i8;
            } else if !hi && b < 16 {
                m[k] = b as i8;
            }
            k += 1;
        }
        m
    }
    let masks = |c: usize| {
        let (lo, hi) = (pick(c, false), pick(c, true));
        (
            _mm_loadu_si128(lo.as_ptr() as *const __m128i),
            _mm_loadu_si128(hi.as_ptr() as *const __m128i),
        )
    };
    let (r_lo, r_hi) = masks(0);
    let (g_lo, g_hi) = masks(1);
    let (b_lo, b_hi) = masks(2);
    let (wr, wg, wb) = (
        _mm256_set1_ps(0.299),
        _mm256_set1_ps(0.587),
        _mm256_set1_ps(0.114),
    );
    let mut outs = out.chunks_exact_mut(8);
    let mut pixels = rgb.chunks_exact(24);
    for (o, p) in (&mut outs).zip(&mut pixels) {
        let lo = _mm_loadu_si128(p.as_ptr() as *const __m128i);
        let hi = _mm_loadl_epi64(p[16..].as_ptr() as *const __m128i);
        let channel = |ml: __m128i, mh: __m128i| {
            let bytes = _mm_or_si128(_mm_shuffle_epi8(lo, ml), _mm_shuffle_epi8(hi, mh));
            _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(bytes))
        };
        let (r, g, b) = (
            channel(r_lo, r_hi),
            channel(g_lo, g_hi),
            channel(b_lo, b_hi),
        );
        let y = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(wr, r), _mm256_mul_ps(wg, g)),
            _mm256_mul_ps(wb, b),
        );
        _mm256_storeu_ps(o.as_mut_ptr(), y);
    }
    luma_any(pixels.remainder(), outs.into_remainder());
}

#[inline(always)]
pub(super) fn luma_any(rgb: &[u8], out: &mut [f32]) {
    for (o, p) in out.iter_mut().zip(rgb.chunks_exact(3)) {
        *o = 0.299 * p[0] as f32 + 0.587 * p[1] as f32 + 0.114 * p[2] as f32;
    }
}
