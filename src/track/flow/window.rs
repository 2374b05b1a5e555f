//! Lucas–Kanade's window arithmetic ([`super::track_point`]): a window's bilinear samples
//! share their columns' and rows' axes, and the level rows they blend, so each is found once;
//! the sums are added in the window's order, as a sample at a time would add them.

use super::GreyLevel;

/// One axis of a bilinear sample at `v` (level px) on a level `len` px long: the cell and the
/// fraction within it, `None` outside (one pixel margin). A window's samples share their
/// columns' and rows' axes, so each is found once per window rather than once per pixel.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN is outside too
fn axis(v: f32, len: usize) -> Option<(usize, f32)> {
    if !(v >= 0.0) {
        return None;
    }
    let v0 = v as usize;
    if v0 + 1 >= len {
        return None;
    }
    Some((v0, v - v0 as f32))
}

/// A window's columns (or rows) as [`axis`] gives them: per one its cell and fraction, apart.
#[derive(Default)]
pub(super) struct Axes {
    cell: Vec<usize>,
    frac: Vec<f32>,
    /// Every cell the one before plus one (the usual case).
    consecutive: bool,
}

impl Axes {
    fn clear(&mut self) {
        self.cell.clear();
        self.frac.clear();
    }

    fn push(&mut self, (cell, frac): (usize, f32)) {
        self.cell.push(cell);
        self.frac.push(frac);
    }

    fn finish(&mut self) {
        self.consecutive = self
            .cell
            .iter()
            .enumerate()
            .all(|(i, &v)| v == self.cell[0] + i);
    }

    /// The axes of `c + i`, `i` in `-half..=half`, on a level `len` px long; false when one
    /// is outside.
    pub(super) fn set(&mut self, c: f32, half: i32, len: usize) -> bool {
        self.clear();
        for i in -half..=half {
            let Some(a) = axis(c + i as f32, len) else {
                return false;
            };
            self.push(a);
        }
        self.finish();
        true
    }
}

/// A template window's axes: the centres' `x = c + i` and their neighbours' `x - 1` and
/// `x + 1`, as the template's samples take them.
#[derive(Default)]
pub(super) struct Triple {
    centre: Axes,
    before: Axes,
    after: Axes,
}

impl Triple {
    /// False when a sample would be outside.
    pub(super) fn set(&mut self, c: f32, half: i32, len: usize) -> bool {
        if !self.centre.set(c, half, len) {
            return false;
        }
        self.before.clear();
        self.after.clear();
        for i in -half..=half {
            let x = c + i as f32;
            let (Some(b), Some(a)) = (axis(x - 1.0, len), axis(x + 1.0, len)) else {
                return false;
            };
            self.before.push(b);
            self.after.push(a);
        }
        self.before.finish();
        self.after.finish();
        true
    }
}

/// Buffers of [`template`] and [`window_sums`].
#[derive(Default)]
pub(super) struct Work {
    /// The template's columns and rows on frame a.
    pub(super) cols: Triple,
    pub(super) rows: Triple,
    /// The window's columns and rows on frame b, this step.
    pub(super) wcols: Axes,
    pub(super) wrows: Axes,
    /// Level rows interpolated across at the template's columns (centres on every row the
    /// template's samples touch, from `lo_c`; neighbours on the template's rows, from `lo_s`).
    centre: Vec<f32>,
    left: Vec<f32>,
    right: Vec<f32>,
    /// Two level rows interpolated across at the window's columns.
    upper: Vec<f32>,
    lower: Vec<f32>,
    /// One window row's terms of the sums (the template's: its neighbours' values).
    terms_x: Vec<f32>,
    terms_y: Vec<f32>,
}

/// Level row `r` interpolated across at `cols`: per column the `top` of a bilinear sample,
/// `d[x0] + fx (d[x0 + 1] − d[x0])`.
#[inline(always)]
fn across(level: &GreyLevel, r: usize, cols: &Axes, out: &mut [f32]) {
    let n = cols.cell.len();
    let d = &level.data[r * level.width..(r + 1) * level.width];
    let (out, f) = (&mut out[..n], &cols.frac[..n]);
    if cols.consecutive {
        // One slice, no index checks: the compiler makes vector arithmetic of it.
        let d = &d[cols.cell[0]..cols.cell[0] + n + 1];
        for i in 0..n {
            out[i] = d[i] + f[i] * (d[i + 1] - d[i]);
        }
    } else {
        for ((o, &x), &fx) in out.iter_mut().zip(&cols.cell).zip(f) {
            *o = d[x] + fx * (d[x + 1] - d[x]);
        }
    }
}

/// Level rows `lo..=hi` interpolated across at `cols`, one after another into `out`.
#[inline(always)]
fn across_rows(level: &GreyLevel, lo: usize, hi: usize, cols: &Axes, out: &mut Vec<f32>) {
    let n = cols.cell.len();
    out.resize((hi - lo + 1) * n, 0.0);
    for (r, o) in (lo..=hi).zip(out.chunks_exact_mut(n)) {
        across(level, r, cols, o);
    }
}

/// Rows `y0` and `y0 + 1` of `h` (rows one after another from level row `lo`, `n` wide)
/// blended down by `fy`: `top + fy (bot − top)`, the bilinear sample's last step.
#[inline(always)]
fn down(h: &[f32], lo: usize, n: usize, y0: usize, fy: f32, out: &mut [f32]) {
    let top = &h[(y0 - lo) * n..][..n];
    let bot = &h[(y0 + 1 - lo) * n..][..n];
    for ((o, &t), &b) in out[..n].iter_mut().zip(top).zip(bot) {
        *o = t + fy * (b - t);
    }
}

/// The window's template on level `la` (at `work.cols`, `work.rows`): its values, gradients
/// and the sums Σ gx², Σ gx gy, Σ gy², with the values bilinear samples give, added in the
/// window's order. Level rows the samples share are interpolated across once.
#[inline(always)]
pub(super) fn template(
    la: &GreyLevel,
    tmpl: &mut [f32],
    gx: &mut [f32],
    gy: &mut [f32],
    work: &mut Work,
) -> (f32, f32, f32) {
    let Work {
        cols,
        rows,
        centre,
        left,
        right,
        upper,
        lower,
        terms_x,
        terms_y,
        ..
    } = work;
    let n = cols.centre.cell.len();
    let all = || {
        rows.centre
            .cell
            .iter()
            .chain(&rows.before.cell)
            .chain(&rows.after.cell)
    };
    let lo_c = *all().min().expect("a row");
    let hi_c = *all().max().expect("a row") + 1;
    let lo_s = *rows.centre.cell.iter().min().expect("a row");
    let hi_s = *rows.centre.cell.iter().max().expect("a row") + 1;
    across_rows(la, lo_c, hi_c, &cols.centre, centre);
    across_rows(la, lo_s, hi_s, &cols.before, left);
    across_rows(la, lo_s, hi_s, &cols.after, right);
    for buf in [&mut *upper, &mut *lower, &mut *terms_x, &mut *terms_y] {
        buf.resize(n, 0.0);
    }
    // The neighbours' rows, left and right.
    let (l_row, r_row) = (terms_x, terms_y);
    let (mut gxx, mut gxy, mut gyy) = (0.0f32, 0.0f32, 0.0f32);
    for jj in 0..n {
        let k = jj * n;
        let (yc, fc) = (rows.centre.cell[jj], rows.centre.frac[jj]);
        let t = &mut tmpl[k..k + n];
        down(centre, lo_c, n, yc, fc, t);
        down(left, lo_s, n, yc, fc, l_row);
        down(right, lo_s, n, yc, fc, r_row);
        down(
            centre,
            lo_c,
            n,
            rows.before.cell[jj],
            rows.before.frac[jj],
            upper,
        );
        down(
            centre,
            lo_c,
            n,
            rows.after.cell[jj],
            rows.after.frac[jj],
            lower,
        );
        let (gxr, gyr) = (&mut gx[k..k + n], &mut gy[k..k + n]);
        for i in 0..n {
            gxr[i] = 0.5 * (r_row[i] - l_row[i]);
            gyr[i] = 0.5 * (lower[i] - upper[i]);
        }
        for (&a, &b) in gxr.iter().zip(gyr.iter()) {
            gxx += a * a;
            gxy += a * b;
            gyy += b * b;
        }
    }
    (gxx, gxy, gyy)
}

/// Lucas–Kanade's sums over the window on level `lb` (at `work.wcols`, `work.wrows`):
/// Σ (tmpl − b) gx and Σ (tmpl − b) gy, added in the window's order, `b` the bilinear sample
/// there. Level rows two window rows share are interpolated across once, and the terms formed
/// a row at a time, so that only the two running sums wait on each other.
#[inline(always)]
pub(super) fn window_sums(
    lb: &GreyLevel,
    tmpl: &[f32],
    gx: &[f32],
    gy: &[f32],
    work: &mut Work,
) -> (f32, f32) {
    let Work {
        wcols,
        wrows,
        upper,
        lower,
        terms_x,
        terms_y,
        ..
    } = work;
    let n = wcols.cell.len();
    for buf in [&mut *upper, &mut *lower, &mut *terms_x, &mut *terms_y] {
        buf.resize(n, 0.0);
    }
    let mut held: Option<usize> = None;
    let (mut bx, mut by) = (0.0f32, 0.0f32);
    for jj in 0..n {
        let (y0, fy) = (wrows.cell[jj], wrows.frac[jj]);
        match held {
            Some(u) if u == y0 => {}
            Some(u) if u + 1 == y0 => {
                std::mem::swap(upper, lower);
                across(lb, y0 + 1, wcols, lower);
            }
            _ => {
                across(lb, y0, wcols, upper);
                across(lb, y0 + 1, wcols, lower);
            }
        }
        held = Some(y0);
        let k = jj * n;
        let (t, gxr, gyr) = (&tmpl[k..k + n], &gx[k..k + n], &gy[k..k + n]);
        for i in 0..n {
            let (top, bot) = (upper[i], lower[i]);
            let diff = t[i] - (top + fy * (bot - top));
            terms_x[i] = diff * gxr[i];
            terms_y[i] = diff * gyr[i];
        }
        for (tx, ty) in terms_x.iter().zip(terms_y.iter()) {
            bx += tx;
            by += ty;
        }
    }
    (bx, by)
}
