//! What a strip costs laid at a pose (docs/method.md eq. 5, see the module doc of
//! [`super`]): per-sample residuals, the coarse search cost (with its early stop), the fit
//! statistics, and the Gauss–Newton normal equations of the refinement.

use super::{Fit, Normal, Shape, Strip, View, INLIER_E, LANES, PLATE_CHECK_E};
use crate::geom::Point;
use crate::track::pixels::Rgb;

/// Squared normalised residual `e` of the colour `col` against the template colour `t`.
#[inline(always)]
fn residual(t: &Rgb, col: Rgb, gain: f32, inv: f32) -> f32 {
    let (d0, d1, d2) = (
        col[0] - gain * t[0],
        col[1] - gain * t[1],
        col[2] - gain * t[2],
    );
    (d0 * d0 + d1 * d1 + d2 * d2) * inv
}

/// `⌊x⌋` as an integer and as a float, for `0 ≤ x < 2²³` (`x as u32` and its `f32`), by float
/// adds and integer bit operations only, which run side by side over lanes (a conversion
/// instruction with Rust's saturating semantics does not).
#[inline(always)]
fn floor_small(x: f32) -> (u32, f32) {
    // From 2²³ on, the f32 are the integers: adding it rounds to the nearest one, exactly.
    const BIG: f32 = 8_388_608.0;
    let r = (x + BIG) - BIG;
    let f = if r > x { r - 1.0 } else { r };
    ((f + BIG).to_bits() - BIG.to_bits(), f)
}

impl Strip {
    /// Diagnostics: every sample's image position (px) at the pose `(p, c)`, its squared
    /// normalised residual `e` (infinite outside the frame) and its weight.
    pub fn probe(&self, v: &View, p: Point, c: Point) -> Vec<(f32, f32, f32, f32)> {
        let place = self.placement(p, c);
        let inv = self.inv_scale();
        (0..self.samples.len())
            .map(|k| {
                let s = &self.samples[k];
                let (x, y) = place.at(s.t, s.e, s.v);
                let e = self.residual_at(v, k, x, y, inv).unwrap_or(f32::INFINITY);
                (x, y, e, self.weight(k))
            })
            .collect()
    }

    /// Whether `fit` looks like this bone found: at least `share` of what fits on a frame where
    /// it is seen (its [`Strip::typical`] shares), at its child end and, unless `parent_hidden`,
    /// overall.
    pub fn found(&self, fit: &Fit, share: f32, parent_hidden: bool) -> bool {
        let typical = 0.5 * (self.typical.0 + self.typical.1);
        (parent_hidden || fit.inliers >= share * typical) && fit.child_end >= share * self.typical.1
    }

    /// Squared normalised residual `e` of sample `k` against colour `col` at level `lv`.
    #[inline(always)]
    pub(super) fn residual(&self, k: usize, lv: usize, col: Rgb, gain: f32, inv: f32) -> f32 {
        residual(&self.template[k][lv], col, gain, inv)
    }

    /// Squared normalised residual of sample `k` at `(x, y)` on view `v`: `None` outside the
    /// frame, infinite where the pixel looks like the clean plate.
    #[inline(always)]
    fn residual_at(&self, v: &View, k: usize, x: f32, y: f32, inv: f32) -> Option<f32> {
        let col = v.img.bilinear(x, y)?;
        let e = self.residual(k, v.img.k, col, v.gain, inv);
        // The plate matters only where the sample fits (a poor fit costs nearly 1 anyway):
        // reading it only there halves the work of a search.
        if e < PLATE_CHECK_E && self.trust_plate && v.looks_background(x, y, col) {
            return Some(f32::INFINITY);
        }
        Some(e)
    }

    /// Mean robust cost (0–1) over the coarse samples for the pose `(p, c)` on view `v`: the
    /// search cost.
    pub fn coarse_cost(&self, v: &View, p: Point, c: Point) -> f32 {
        self.coarse_cost_as(v, p, c, self.mirrored)
    }

    /// [`Strip::coarse_cost`] laid mirrored or not as asked.
    pub fn coarse_cost_as(&self, v: &View, p: Point, c: Point, mirrored: bool) -> f32 {
        self.coarse_cost_until(v, p, c, mirrored, |_| false)
            .unwrap_or(1.0)
    }

    /// [`Strip::coarse_cost_as`] for a bounded grid search
    /// ([`grid_min_bounded`](crate::track::search::grid_min_bounded)): the cost exactly when it
    /// is below `limit`, otherwise infinity or the cost (given up once a lower bound reaches
    /// `limit`, see [`Strip::coarse_cost_until`]).
    pub fn coarse_cost_below(
        &self,
        v: &View,
        p: Point,
        c: Point,
        mirrored: bool,
        limit: f32,
    ) -> f32 {
        self.coarse_cost_until(v, p, c, mirrored, |m| m >= limit)
            .unwrap_or(f32::INFINITY)
    }

    /// [`Strip::coarse_cost_as`], given up once it is sure to be too high: after every block of
    /// [`LANES`] samples, `stop(m)` is asked with `m` a lower bound of the cost (the running sum
    /// over the total weight; every term is at least 0, and rounding is monotonic, so the cost
    /// is at least `m` to the bit), and `None` is returned when it says so. Otherwise the cost,
    /// exactly as [`Strip::coarse_cost_as`] computes it.
    ///
    /// Per sample: its robust cost `ρ(e)` (1 outside the frame or on a pixel that looks like
    /// the clean plate) times its weight. A block's samples are placed, read and costed side
    /// by side, each with the same operations as one at a time, and the terms are added in
    /// sample order, so the sum does not depend on the blocking.
    ///
    /// On a CPU with AVX2 the same operations run in AVX2 instructions (eight lanes in one
    /// register; no fused multiply-adds, so the same bits: see `simd.rs`).
    pub fn coarse_cost_until(
        &self,
        v: &View,
        p: Point,
        c: Point,
        mirrored: bool,
        stop: impl Fn(f32) -> bool,
    ) -> Option<f32> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            return unsafe { self.coarse_cost_until_avx2(v, p, c, mirrored, stop) };
        }
        self.coarse_cost_until_any(v, p, c, mirrored, stop)
    }

    /// [`Strip::coarse_cost_until`] for any CPU (inlined into each compiled version).
    #[inline(always)]
    pub(super) fn coarse_cost_until_any(
        &self,
        v: &View,
        p: Point,
        c: Point,
        mirrored: bool,
        stop: impl Fn(f32) -> bool,
    ) -> Option<f32> {
        let place = self.placement_as(p, c, mirrored);
        let inv = self.inv_scale();
        let lv = v.img.k;
        let img = &v.img.img;
        // A plate of the frame's size is read at the frame's cell (the same position and
        // fractions as its own `bilinear` would find).
        let plate = v
            .plate
            .as_ref()
            .filter(|p| self.trust_plate && p.k == lv && p.img.same_size(img));
        // `Image::cell`'s test `x0 + 1 < w` on `x0 = ⌊x⌋` for `x ≥ 0` is `x < w − 1` (exact in f32).
        let xmax = img.width().saturating_sub(1) as f32;
        let ymax = img.height().saturating_sub(1) as f32;
        let mut sum = 0.0f32;
        for (b, blk) in self.coarse.iter().enumerate() {
            let count = (self.coarse_len - b * LANES).min(LANES);
            let (mut x, mut y) = ([0.0f32; LANES], [0.0f32; LANES]);
            let (mut fx, mut fy) = ([0.0f32; LANES], [0.0f32; LANES]);
            let (mut x0, mut y0) = ([0u32; LANES], [0u32; LANES]);
            let mut inside = [false; LANES];
            for l in 0..LANES {
                (x[l], y[l]) = place.at(blk.t[l], blk.e[l], blk.v[l]);
                let (lx, ly) = v.img.to_level(x[l], y[l]);
                // Also rejects NaN: every comparison with NaN is false. (`&`, not `&&`: no
                // branches, so that the lanes run side by side.)
                inside[l] = (lx >= 0.0) & (ly >= 0.0) & (lx < xmax) & (ly < ymax);
                let (cx, cy) = if inside[l] { (lx, ly) } else { (0.0, 0.0) };
                let ((ix, flx), (iy, fly)) = (floor_small(cx), floor_small(cy));
                (x0[l], y0[l]) = (ix, iy);
                (fx[l], fy[l]) = (cx - flx, cy - fly);
            }
            // The four pixels of each sample's cell, channel by channel: a b on top, c d below
            // (as bytes, turned into floats side by side).
            let mut at = [0usize; LANES];
            let mut q8 = [[[0u8; LANES]; 4]; 3];
            for l in 0..count {
                if !inside[l] {
                    continue;
                }
                at[l] = (y0[l] as usize * img.width() + x0[l] as usize) * 3;
                let (t, u) = img.pairs_at(at[l]);
                for ch in 0..3 {
                    q8[ch][0][l] = t[ch];
                    q8[ch][1][l] = t[3 + ch];
                    q8[ch][2][l] = u[ch];
                    q8[ch][3][l] = u[3 + ch];
                }
            }
            // Bilinear colours (as `Image::bilinear_at`) and residuals (as `residual`).
            let mut col = [[0.0f32; LANES]; 3];
            for (out, [a, b, c, d]) in col.iter_mut().zip(&q8) {
                for l in 0..LANES {
                    let (a, b, c, d) = (a[l] as f32, b[l] as f32, c[l] as f32, d[l] as f32);
                    let top = a + (b - a) * fx[l];
                    let bot = c + (d - c) * fx[l];
                    out[l] = top + (bot - top) * fy[l];
                }
            }
            let tm = &blk.template[lv];
            let mut e = [0.0f32; LANES];
            for l in 0..LANES {
                let d0 = col[0][l] - v.gain * tm[0][l];
                let d1 = col[1][l] - v.gain * tm[1][l];
                let d2 = col[2][l] - v.gain * tm[2][l];
                e[l] = (d0 * d0 + d1 * d1 + d2 * d2) * inv;
            }
            // The plate matters only where the sample fits (a poor fit costs nearly 1 anyway).
            let mut fits = inside;
            for l in 0..count {
                // (`e` may be NaN: only a sample that compares below the threshold is checked.)
                let checked = inside[l] && e[l] < PLATE_CHECK_E;
                if !checked {
                    continue;
                }
                let rgb = [col[0][l], col[1][l], col[2][l]];
                let background = match plate {
                    Some(p) => v.matches_plate(rgb, p.img.bilinear_at(at[l], fx[l], fy[l])),
                    None => self.trust_plate && v.looks_background(x[l], y[l], rgb),
                };
                fits[l] = !background;
            }
            let mut term = [0.0f32; LANES];
            for l in 0..LANES {
                let r = if fits[l] && e[l].is_finite() {
                    e[l] / (1.0 + e[l])
                } else {
                    1.0
                };
                term[l] = blk.w[l] * r;
            }
            for &t in &term[..count] {
                sum += t;
            }
            if count == LANES && stop(sum / self.coarse_weight) {
                return None;
            }
        }
        // The weights summed in the same order as `coarse_weight` was.
        let n = self.coarse_weight;
        Some(if n > 0.0 { sum / n } else { 1.0 })
    }

    /// The sums `(Σ w I·T, Σ w T·T)` over the samples that fit at the pose `(p, c)` on view `v`
    /// (at `v`'s gain, not on the plate), whose least-squares ratio is the gain that best maps
    /// the template onto the frame there (docs/method.md §2.2, the subject's gain), and the
    /// share of the samples (background ones aside) that fit. Samples within `SATURATED` of
    /// white in the frame or the scaled template are left out of the sums: a clipped highlight
    /// does not follow the gain.
    pub fn gain_terms(&self, v: &View, p: Point, c: Point) -> (f64, f64, f32) {
        const SATURATED: f32 = 250.0;
        let place = self.placement(p, c);
        let inv = self.inv_scale();
        let (mut it, mut tt) = (0.0f64, 0.0f64);
        let (mut wsum, mut win) = (0.0f32, 0.0f32);
        for (k, s) in self.samples.iter().enumerate() {
            let w = self.weight(k);
            if w <= 0.0 || s.background {
                continue;
            }
            wsum += w;
            let (x, y) = place.at(s.t, s.e, s.v);
            let Some(e) = self.residual_at(v, k, x, y, inv) else {
                continue;
            };
            if e >= INLIER_E {
                continue;
            }
            win += w;
            let (Some(col), t) = (v.img.bilinear(x, y), &self.template[k][v.img.k]) else {
                continue;
            };
            if (0..3).any(|ch| col[ch] >= SATURATED || v.gain * t[ch] >= SATURATED) {
                continue;
            }
            let w = w as f64;
            it += w * (0..3).map(|ch| (col[ch] * t[ch]) as f64).sum::<f64>();
            tt += w * (0..3).map(|ch| (t[ch] * t[ch]) as f64).sum::<f64>();
        }
        (it, tt, if wsum > 0.0 { win / wsum } else { 0.0 })
    }

    /// Fit statistics over all samples for the pose `(p, c)` on view `v`.
    pub fn fit(&self, v: &View, p: Point, c: Point) -> Fit {
        self.fit_as(v, p, c, self.mirrored)
    }

    /// [`Strip::fit`] laid mirrored or not as asked.
    pub fn fit_as(&self, v: &View, p: Point, c: Point, mirrored: bool) -> Fit {
        let place = self.placement_as(p, c, mirrored);
        let inv = self.inv_scale();
        let (mut cost, mut inl, mut pe, mut ce) = (0.0, 0.0, 0.0, 0.0);
        let (mut wsum, mut pw, mut cw) = (0.0, 0.0, 0.0);
        let mut res = Vec::with_capacity(self.samples.len());
        for (k, s) in self.samples.iter().enumerate() {
            let w = self.weight(k);
            if w <= 0.0 {
                continue;
            }
            // Only the half of the strip nearest an end speaks for that end.
            let (lp, lc) = match self.shape {
                Shape::Bone => (
                    (1.0 - 2.0 * s.f).clamp(0.0, 1.0),
                    (2.0 * s.f - 1.0).clamp(0.0, 1.0),
                ),
                Shape::Patch => (1.0, 1.0),
            };
            wsum += w;
            pw += w * lp;
            cw += w * lc;
            let (x, y) = place.at(s.t, s.e, s.v);
            let Some(e) = self.residual_at(v, k, x, y, inv) else {
                cost += w;
                continue;
            };
            if !e.is_finite() {
                cost += w;
                continue;
            }
            cost += w * e / (1.0 + e);
            // As bits: for the non-negative values here (e is finite and at least +0), the
            // integer order of the bits is f32::total_cmp's, and integers select faster.
            res.push((e / inv / 3.0).sqrt().to_bits());
            if e < INLIER_E {
                inl += w;
                pe += w * lp;
                ce += w * lc;
            }
        }
        let residual = if res.is_empty() {
            0.0
        } else {
            let q = (res.len() * 2) / 5;
            f32::from_bits(*res.select_nth_unstable(q).1)
        };
        let share = |a: f32, b: f32| if b > 0.0 { a / b } else { 0.0 };
        Fit {
            cost: if wsum > 0.0 { cost / wsum } else { 1.0 },
            inliers: share(inl, wsum),
            parent_end: share(pe, pw),
            child_end: share(ce, cw),
            parent_mass: pw,
            child_mass: cw,
            residual,
        }
    }

    /// Gauss–Newton normal equations of the data term `Σ w_s ρ(e_s)` (scaled by `weight / Σw`)
    /// at the pose `(p, c)` on view `v` (every `2^k`-th sample at level `k`; a sample on a pixel
    /// that looks like the clean plate costs 1 and does not pull), with iteratively reweighted least squares (sample weight
    /// `ρ'(e) = 1/(1+e)²`), the colour scale widened `widen` times (graduated non-convexity: a
    /// wide scale first lets samples on a misplaced sharp edge still pull).
    ///
    /// On a CPU with AVX2 the per-sample work runs in AVX2 instructions, eight samples side by
    /// side (no fused multiply-adds, the sums in sample order: the same bits; see
    /// `simd_normal.rs`).
    pub fn normal(&self, v: &View, p: Point, c: Point, weight: f32, widen: f32) -> Normal {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            return unsafe { self.normal_avx2(v, p, c, weight, widen) };
        }
        self.normal_any(v, p, c, weight, widen)
    }

    /// [`Strip::normal`] for any CPU (inlined into each compiled version).
    #[inline(always)]
    pub(super) fn normal_any(
        &self,
        v: &View,
        p: Point,
        c: Point,
        weight: f32,
        widen: f32,
    ) -> Normal {
        let (img, gain) = (&v.img, v.gain);
        let place = self.placement(p, c);
        let inv = self.inv_scale() / (widen * widen);
        let mut out = Normal::default();
        let stride = 1usize << img.k;
        let scale = (weight * stride as f32 / self.weight_sum()) as f64;
        let (u, n, len, omega, gamma) = (place.u, place.n, place.len, place.w, self.width_exponent);
        let lv = img.k;
        for (k, s) in self.samples.iter().enumerate().step_by(stride) {
            let sw = self.weight(k);
            if sw <= 0.0 {
                continue;
            }
            let (x, y) = place.at(s.t, s.e, s.v);
            let Some((col, gx, gy)) = img.bilinear_grad(x, y) else {
                out.cost += scale * sw as f64;
                continue;
            };
            if self.trust_plate && v.looks_background(x, y, col) {
                out.cost += scale * sw as f64;
                continue;
            }
            let tm = &self.template[k][lv];
            let r = [
                col[0] - gain * tm[0],
                col[1] - gain * tm[1],
                col[2] - gain * tm[2],
            ];
            let e = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) * inv;
            let w = sw / ((1.0 + e) * (1.0 + e));
            out.cost += scale * (sw * e / (1.0 + e)) as f64;
            // Image-space normal equations of this sample: A = Gᵀ G, b = Gᵀ r (2×2, 2).
            let (mut a00, mut a01, mut a11, mut b0, mut b1) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for ch in 0..3 {
                a00 += gx[ch] * gx[ch];
                a01 += gx[ch] * gy[ch];
                a11 += gy[ch] * gy[ch];
                b0 += gx[ch] * r[ch];
                b1 += gy[ch] * r[ch];
            }
            // Jacobian of the sample position: columns for P.x, P.y, C.x, C.y.
            let cols: [[f32; 2]; 4] = match self.shape {
                Shape::Patch => [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0], [0.0, 0.0]],
                Shape::Bone => {
                    // With d = C − P: ∂û/∂d = n̂ n̂ᵀ/L, ∂n̂/∂d = −û n̂ᵀ/L, ∂ω/∂d = −γ ω ûᵀ/L, so
                    // ∂x/∂C·δ = t δ + ω (n̂·δ)/L (e n̂ − v û) − γ ω (û·δ)/L (e û + v n̂),
                    // and ∂x/∂P = I − ∂x/∂C.
                    let m1 = (n * s.e - u * s.v) * (omega / len);
                    let m2 = (u * s.e + n * s.v) * (gamma * omega / len);
                    let cx = [s.t + n.x * m1.x - u.x * m2.x, n.x * m1.y - u.x * m2.y];
                    let cy = [n.y * m1.x - u.y * m2.x, s.t + n.y * m1.y - u.y * m2.y];
                    [[1.0 - cx[0], -cx[1]], [-cy[0], 1.0 - cy[1]], cx, cy]
                }
            };
            let f = (2.0 * inv * w) as f64 * scale;
            let mut ab = [[0.0f32; 2]; 4];
            for (i, col) in cols.iter().enumerate() {
                ab[i] = [a00 * col[0] + a01 * col[1], a01 * col[0] + a11 * col[1]];
                out.g[i] += f * (b0 * col[0] + b1 * col[1]) as f64;
            }
            // The upper triangle of a 4×4 matrix: indices read clearer than zipped iterators.
            #[allow(clippy::needless_range_loop)]
            for i in 0..4 {
                for j in i..4 {
                    out.h[i][j] += f * (cols[i][0] * ab[j][0] + cols[i][1] * ab[j][1]) as f64;
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

#[cfg(test)]
mod tests {
    use super::floor_small;

    #[test]
    fn floor_small_is_the_conversion() {
        let mut xs = vec![0.0f32, -0.0, 0.5, 1.0, 1.5, 2.5, 3.5, 639.0, 8_388_607.5];
        for i in 0..2000 {
            let x = i as f32 * 0.37;
            xs.extend([
                x,
                f32::from_bits(x.to_bits() + 1),
                f32::from_bits(x.to_bits().max(1) - 1),
            ]);
        }
        for x in xs {
            let (i, f) = floor_small(x);
            assert_eq!(
                (i, f.to_bits()),
                (x as u32, (x as u32 as f32).to_bits()),
                "{x}"
            );
            assert_eq!((x - f).to_bits(), (x - x as u32 as f32).to_bits(), "{x}");
        }
    }
}
