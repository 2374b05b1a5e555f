//! Reduced keys with Bézier curves between them (docs/method.md §7.1): of a channel sampled on
//! every frame, the frames to key and the curve from each key to the next, so that the curve,
//! evaluated exactly as the format's runtime evaluates it, reproduces every frame within the
//! tolerance.
//!
//! **Spine** (4.x, spine-core's `CurveTimeline`): a key's `curve` holds, per value of the
//! timeline, the two handles `cx1, cy1, cx2, cy2` (time in seconds, value in the value's units,
//! both absolute). The runtime does not solve the cubic for time: `setBezier` samples the curve
//! at 9 inner points by forward differences (stored as 32-bit floats) and `getBezierValue` is
//! linear between them. [`spine_points`] and [`spine_value`] do the same.
//!
//! **DragonBones** (5.5, the runtime's `_samplingEasingCurve`): a key's `curve` `[x1, y1, x2, y2]`
//! is one easing of the progress between the key and the next, in the unit square, the same for
//! every value of the frame (x and y of a translation). The runtime samples it at `d + 1` inner
//! points (`d` the key's duration in frames, time found by bisection to 1e-4), stores each
//! progress as an integer of 1/10000 in a 16-bit array, and is linear between them.
//! [`db_progress`] does the same.
//!
//! The time handles sit at a third and two thirds of the segment (so the curve is a cubic in
//! time); the value handles are fitted by least squares to the frames, then weighed towards the
//! worst frames (Lawson's iteration) when the plain fit misses the tolerance. Keys are chosen
//! greedily: from each key, the farthest next key whose curve (or straight line, written without
//! a curve when it suffices) holds every frame in between.

use super::keys::dist;
use super::round;

/// A kept key of a channel reduced with curves.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveKey {
    /// The frame (sample index) keyed.
    pub at: usize,
    /// The curve from this key to the next: Spine, `[cx1, cy1, cx2, cy2]` for each component in
    /// turn (as written); DragonBones, `[x1, y1, x2, y2]`. `None`: linear (and on the last key).
    pub curve: Option<Vec<f64>>,
}

/// Lawson iterations tried when the least-squares handles miss the tolerance.
const LAWSON_ROUNDS: usize = 12;

/// Largest progress a DragonBones curve sample can hold (16-bit integers of 1/10000).
const DB_MAX_PROGRESS: f64 = 3.2;

/// The 9 inner points `(x, y)` (32-bit floats, as stored) spine-core's `setBezier` computes for
/// the curve from `(t1, v1)` to `(t2, v2)` with handles `h = [cx1, cy1, cx2, cy2]`: the same
/// forward differences in the same order.
pub fn spine_points(t1: f64, v1: f64, h: [f64; 4], t2: f64, v2: f64) -> [[f64; 2]; 9] {
    let [cx1, cy1, cx2, cy2] = h;
    let (tmpx, tmpy) = ((t1 - cx1 * 2.0 + cx2) * 0.03, (v1 - cy1 * 2.0 + cy2) * 0.03);
    let dddx = ((cx1 - cx2) * 3.0 - t1 + t2) * 0.006;
    let dddy = ((cy1 - cy2) * 3.0 - v1 + v2) * 0.006;
    let (mut ddx, mut ddy) = (tmpx * 2.0 + dddx, tmpy * 2.0 + dddy);
    let mut dx = (cx1 - t1) * 0.3 + tmpx + dddx * 0.16666667;
    let mut dy = (cy1 - v1) * 0.3 + tmpy + dddy * 0.16666667;
    let (mut x, mut y) = (t1 + dx, v1 + dy);
    let mut out = [[0.0; 2]; 9];
    for p in &mut out {
        *p = [f32s(x), f32s(y)];
        dx += ddx;
        dy += ddy;
        ddx += dddx;
        ddy += dddy;
        x += dx;
        y += dy;
    }
    out
}

/// spine-core's `getBezierValue`: the value at `time` (between the keys) of the segment from key
/// `(t1, v1)` to key `(t2, v2)` (as read from the JSON; the runtime stores them as 32-bit
/// floats) through the inner points `p` of [`spine_points`].
pub fn spine_value(t1: f64, v1: f64, p: &[[f64; 2]; 9], t2: f64, v2: f64, time: f64) -> f64 {
    let lerp = |x: f64, y: f64, x2: f64, y2: f64| y + (time - x) / (x2 - x) * (y2 - y);
    if p[0][0] > time {
        return lerp(f32s(t1), f32s(v1), p[0][0], p[0][1]);
    }
    for k in 1..9 {
        if p[k][0] >= time {
            return lerp(p[k - 1][0], p[k - 1][1], p[k][0], p[k][1]);
        }
    }
    lerp(p[8][0], p[8][1], f32s(t2), f32s(v2))
}

fn f32s(x: f64) -> f64 {
    x as f32 as f64
}

/// The DragonBones runtime's progress samples (integers of 1/10000) of the easing curve
/// `c = [x1, y1, x2, y2]` for a key lasting `d` frames: `d + 1` samples at `(i + 1) / (d + 2)`.
pub fn db_samples(c: [f64; 4], d: usize) -> Vec<f64> {
    let point = |t: f64| {
        let lt = 1.0 - t;
        let (pa, pb) = (lt * lt, t * t);
        let (ka, kb, kc, kd) = (lt * pa, 3.0 * t * pa, 3.0 * lt * pb, t * pb);
        (
            ka * 0.0 + kb * c[0] + kc * c[2] + kd * 1.0,
            ka * 0.0 + kb * c[1] + kc * c[3] + kd * 1.0,
        )
    };
    let l = d + 1;
    (0..l)
        .map(|i| {
            let t = (i + 1) as f64 / (l + 1) as f64;
            let (mut lower, mut higher) = (0.0f64, 1.0f64);
            let mut y = 0.0;
            while higher - lower > 0.0001 {
                let pct = (higher + lower) * 0.5;
                let (px, py) = point(pct);
                y = py;
                if t - px > 0.0 {
                    lower = pct;
                } else {
                    higher = pct;
                }
            }
            // JavaScript's Math.round: halves go up.
            (y * 10000.0 + 0.5).floor()
        })
        .collect()
}

/// The DragonBones runtime's progress (`_getEasingCurveValue`) at `progress` (0..1 of the key's
/// duration) through the `samples` of [`db_samples`].
pub fn db_progress(samples: &[f64], progress: f64) -> f64 {
    if progress <= 0.0 {
        return 0.0;
    }
    if progress >= 1.0 {
        return 1.0;
    }
    let seg = samples.len() + 1;
    let vi = (progress * seg as f64).floor() as usize;
    let from = if vi == 0 { 0.0 } else { samples[vi - 1] };
    let to = if vi == seg - 1 { 10000.0 } else { samples[vi] };
    (from + (to - from) * (progress * seg as f64 - vi as f64)) * 0.0001
}

/// The Bernstein weights of the two inner handles at parameter `s`.
fn handle_weights(s: f64) -> [f64; 2] {
    [3.0 * s * (1.0 - s) * (1.0 - s), 3.0 * s * s * (1.0 - s)]
}

/// How a format's segment is fitted and checked.
trait Format {
    /// The curve for keys `a < b`, or `None` when none holds every frame between them within
    /// `tol` (the written, rounded curve is the one checked).
    fn fit(&self, a: usize, b: usize, tol: f64) -> Option<Vec<f64>>;
}

/// Keys of `values` (one value of any number of components per frame) chosen greedily: from each
/// key the farthest next frame that a straight line (within `tol`, as [`super::keys::reduce`]
/// measures it) or `format`'s curve reaches, consecutive keys less than `max_step` apart in
/// component 0. One key when every frame is within `tol` of the first; `tol` 0 keys every frame.
fn reduce(
    values: &[Vec<f64>],
    tol: f64,
    max_step: Option<f64>,
    format: &dyn Format,
) -> Vec<CurveKey> {
    let n = values.len();
    if n == 0 {
        return Vec::new();
    }
    let linear = |a: usize| CurveKey { at: a, curve: None };
    if tol <= 0.0 {
        return (0..n).map(linear).collect();
    }
    if (1..n).all(|i| dist(&values[i], &values[0]) <= tol) {
        return vec![linear(0)];
    }
    let line_holds = |a: usize, b: usize| {
        (a + 1..b).all(|i| {
            let s = (i - a) as f64 / (b - a) as f64;
            let line: Vec<f64> = values[a]
                .iter()
                .zip(&values[b])
                .map(|(x, y)| x + s * (y - x))
                .collect();
            dist(&values[i], &line) <= tol
        })
    };
    let mut keys = Vec::new();
    let mut a = 0;
    while a + 1 < n {
        let mut best = (a + 1, None);
        for b in a + 2..n {
            if max_step.is_some_and(|m| (values[b][0] - values[a][0]).abs() >= m) {
                break;
            }
            if line_holds(a, b) {
                best = (b, None);
            } else if let Some(c) = format.fit(a, b, tol) {
                best = (b, Some(c));
            } else {
                break;
            }
        }
        keys.push(CurveKey {
            at: a,
            curve: best.1,
        });
        a = best.0;
    }
    keys.push(linear(n - 1));
    keys
}

/// Least-squares offsets `(p, q)` of the two value handles from the straight line's, for
/// residuals `r` (one per row) with handle weights `w` and row weights `wt`; a tiny ridge keeps
/// a segment of one inner frame solvable (it then moves the handles least).
fn solve(rows: &[([f64; 2], f64, f64)]) -> (f64, f64) {
    let (mut saa, mut sab, mut sbb, mut sar, mut sbr) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &([wa, wb], r, wt) in rows {
        saa += wt * wa * wa;
        sab += wt * wa * wb;
        sbb += wt * wb * wb;
        sar += wt * wa * r;
        sbr += wt * wb * r;
    }
    let ridge = 1e-9 * (saa + sbb).max(1e-12);
    let (saa, sbb) = (saa + ridge, sbb + ridge);
    let det = saa * sbb - sab * sab;
    ((sar * sbb - sbr * sab) / det, (saa * sbr - sab * sar) / det)
}

/// Lawson's iteration on a fit: `fit_with(weights)` gives the errors (one per inner frame) of
/// the curve fitted with these row weights, and the curve when it holds within `tol`.
fn lawson(
    inner: usize,
    tol: f64,
    mut fit_with: impl FnMut(&[f64]) -> (Vec<f64>, Option<Vec<f64>>),
) -> Option<Vec<f64>> {
    let mut w = vec![1.0; inner];
    for _ in 0..=LAWSON_ROUNDS {
        let (errors, curve) = fit_with(&w);
        if curve.is_some() {
            return curve;
        }
        let worst = errors.iter().fold(0.0f64, |m, &e| m.max(e));
        // Far out of reach: more weighting will not bring it within the tolerance.
        if worst > 4.0 * tol {
            return None;
        }
        let total: f64 = w.iter().zip(&errors).map(|(w, e)| w * e).sum();
        if total <= 0.0 {
            return None;
        }
        for (w, e) in w.iter_mut().zip(&errors) {
            *w *= e / total * inner as f64;
            *w = w.max(1e-12);
        }
    }
    None
}

struct Spine<'a> {
    values: &'a [Vec<f64>],
    times: &'a [f64],
    decimals: i32,
}

impl Format for Spine<'_> {
    fn fit(&self, a: usize, b: usize, tol: f64) -> Option<Vec<f64>> {
        let (ta, tb) = (self.times[a], self.times[b]);
        let dims = self.values[a].len();
        let cx = [
            round(ta + (tb - ta) / 3.0, 6),
            round(ta + 2.0 * (tb - ta) / 3.0, 6),
        ];
        // Each inner frame's handle weights: linear between the runtime's sampled points.
        let weights: Vec<[f64; 2]> = (a + 1..b)
            .map(|i| {
                let f = (self.times[i] - ta) / (tb - ta) * 10.0;
                let k = (f.floor() as usize).min(9);
                let u = f - k as f64;
                let (w0, w1) = (
                    handle_weights(k as f64 / 10.0),
                    handle_weights((k + 1) as f64 / 10.0),
                );
                [(1.0 - u) * w0[0] + u * w1[0], (1.0 - u) * w0[1] + u * w1[1]]
            })
            .collect();
        let key = |t: usize, c: usize| round(self.values[t][c], self.decimals);
        lawson(b - a - 1, tol, |wt| {
            let mut curve = Vec::with_capacity(4 * dims);
            for c in 0..dims {
                let (va, vb) = (key(a, c), key(b, c));
                let rows: Vec<([f64; 2], f64, f64)> = (a + 1..b)
                    .zip(&weights)
                    .zip(wt)
                    .map(|((i, &w), &wt)| {
                        let s = (self.times[i] - ta) / (tb - ta);
                        (w, self.values[i][c] - (va + s * (vb - va)), wt)
                    })
                    .collect();
                let (p, q) = solve(&rows);
                let l1 = va + (vb - va) / 3.0;
                let l2 = va + 2.0 * (vb - va) / 3.0;
                curve.extend([
                    cx[0],
                    round(l1 + p, self.decimals),
                    cx[1],
                    round(l2 + q, self.decimals),
                ]);
            }
            // The written curve, evaluated as the runtime does.
            let points: Vec<[[f64; 2]; 9]> = (0..dims)
                .map(|c| {
                    let h = [
                        curve[4 * c],
                        curve[4 * c + 1],
                        curve[4 * c + 2],
                        curve[4 * c + 3],
                    ];
                    spine_points(ta, key(a, c), h, tb, key(b, c))
                })
                .collect();
            let errors: Vec<f64> = (a + 1..b)
                .map(|i| {
                    let got: Vec<f64> = (0..dims)
                        .map(|c| {
                            spine_value(ta, key(a, c), &points[c], tb, key(b, c), self.times[i])
                        })
                        .collect();
                    dist(&got, &self.values[i])
                })
                .collect();
            let holds = errors.iter().all(|&e| e <= tol);
            (errors, holds.then_some(curve))
        })
    }
}

/// Spine keys with curves for `values` (one value per frame; `times` the frames' times as
/// written, seconds), within `tol` (the distance over the components), consecutive keys less than
/// `max_step` apart in component 0; values and value handles are written with `decimals`.
pub fn reduce_spine(
    values: &[Vec<f64>],
    times: &[f64],
    tol: f64,
    max_step: Option<f64>,
    decimals: i32,
) -> Vec<CurveKey> {
    reduce(
        values,
        tol,
        max_step,
        &Spine {
            values,
            times,
            decimals,
        },
    )
}

struct DragonBones<'a> {
    values: &'a [Vec<f64>],
    decimals: &'a [i32],
}

impl Format for DragonBones<'_> {
    fn fit(&self, a: usize, b: usize, tol: f64) -> Option<Vec<f64>> {
        let d = b - a;
        let key = |t: usize, c: usize| round(self.values[t][c], self.decimals[c]);
        let dims = self.values[a].len();
        let delta: Vec<f64> = (0..dims).map(|c| key(b, c) - key(a, c)).collect();
        if delta.iter().all(|x| x.abs() < 1e-9) {
            return None;
        }
        // The runtime's samples at (i + 1) / (d + 2), linear between: each frame's weights.
        let seg = (d + 2) as f64;
        let weights: Vec<[f64; 2]> = (1..d)
            .map(|k| {
                let f = k as f64 / d as f64 * seg;
                let vi = f.floor();
                let u = f - vi;
                let at = |j: f64| handle_weights(j / seg);
                let (w0, w1) = (at(vi), at(vi + 1.0));
                [(1.0 - u) * w0[0] + u * w1[0], (1.0 - u) * w0[1] + u * w1[1]]
            })
            .collect();
        lawson(d - 1, tol, |wt| {
            // Rows over every frame and component: value = a + delta · progress.
            let mut rows = Vec::with_capacity((d - 1) * dims);
            for ((k, &w), &wt) in (1..d).zip(&weights).zip(wt) {
                let s = k as f64 / d as f64;
                for c in 0..dims {
                    let r = self.values[a + k][c] - (key(a, c) + delta[c] * s);
                    rows.push(([w[0] * delta[c], w[1] * delta[c]], r, wt));
                }
            }
            let (p, q) = solve(&rows);
            let curve = vec![
                round(1.0 / 3.0, 6),
                round(1.0 / 3.0 + p, 6),
                round(2.0 / 3.0, 6),
                round(2.0 / 3.0 + q, 6),
            ];
            let samples = db_samples([curve[0], curve[1], curve[2], curve[3]], d);
            let fits_store = samples.iter().all(|s| s.abs() <= DB_MAX_PROGRESS * 10000.0);
            let errors: Vec<f64> = (1..d)
                .map(|k| {
                    let pr = db_progress(&samples, k as f64 / d as f64);
                    let got: Vec<f64> = (0..dims).map(|c| key(a, c) + delta[c] * pr).collect();
                    dist(&got, &self.values[a + k])
                })
                .collect();
            let holds = fits_store && errors.iter().all(|&e| e <= tol);
            (errors, holds.then_some(curve))
        })
    }
}

/// DragonBones keys with curves for `values` (one value per frame), within `tol`, consecutive
/// keys less than `max_step` apart in component 0; component `c` is written with `decimals[c]`.
pub fn reduce_dragonbones(
    values: &[Vec<f64>],
    tol: f64,
    max_step: Option<f64>,
    decimals: &[i32],
) -> Vec<CurveKey> {
    reduce(values, tol, max_step, &DragonBones { values, decimals })
}

#[cfg(test)]
#[path = "curves_tests.rs"]
mod tests;
