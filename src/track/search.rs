//! Exhaustive search over a window (docs/method.md §2.3, eq. 7–8; exhaustive rather than a
//! greedy walk from the prediction, which stops in the first local minimum): a grid over two
//! parameters, then two finer passes around the best cell.

use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// A two-parameter window: centre, half-width and coarse grid step per parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    pub centre: [f32; 2],
    pub half: [f32; 2],
    pub step: [f32; 2],
}

/// Minimises `f` over `w`: every grid point of the window, then 3×3 neighbourhoods of the best
/// point at half and a quarter of the step. A window of more than [`MAX_STEPS`] steps a side is
/// walked at the step doubled until it fits, its [`KEEP`] best points each refined by as many
/// more halvings, down to a quarter of the asked step. Returns the best point and its cost.
/// Ties keep the first point found (row by row from the low corner), so results are
/// deterministic.
pub fn grid_min(w: &Window, f: impl Fn([f32; 2]) -> f32 + Sync) -> ([f32; 2], f32) {
    grid_min_bounded(w, MAX_STEPS, |q, _| f(q))
}

/// [`grid_min`] for a cost that may give up early: `f(q, limit)` must return the cost of `q`
/// exactly when it is below `limit`, and otherwise any value at least `limit` (such a point
/// cannot be the first minimum, so the result is [`grid_min`]'s to the bit). The coarse grid
/// is dealt out to a few runs evaluated in parallel, nearest the centre first, each point
/// judged against the best point found so far by any run (a tie going to the point first row by
/// row), so the result does not depend on the threads. A window of more than `max_steps`
/// steps a side (at least 1; [`MAX_STEPS`] in [`grid_min`]) is walked coarsely as there.
pub fn grid_min_bounded(
    w: &Window,
    max_steps: u32,
    f: impl Fn([f32; 2], f32) -> f32 + Sync,
) -> ([f32; 2], f32) {
    grid_min_in_runs(w, RUNS, max_steps, f)
}

/// [`grid_min_bounded`] on the calling thread alone, for a caller that runs several searches
/// side by side: one run, and no thread is woken. The same result to the bit.
pub fn grid_min_bounded_serial(
    w: &Window,
    max_steps: u32,
    f: impl Fn([f32; 2], f32) -> f32 + Sync,
) -> ([f32; 2], f32) {
    grid_min_in_runs(w, 1, max_steps, f)
}

/// [`grid_min_bounded`] with the coarse grid cut into `runs` runs (1: all on this thread),
/// walking at most `max_steps` steps a side.
///
/// The points are evaluated nearest the centre first (where the best point usually is), each
/// judged against the best point found so far by any run, so most give up early; the first
/// minimum in the row-by-row order is still the one returned: a point ranked before the best so
/// far wins a tie (see [`Key`]).
fn grid_min_in_runs(
    w: &Window,
    runs: usize,
    max_steps: u32,
    f: impl Fn([f32; 2], f32) -> f32 + Sync,
) -> ([f32; 2], f32) {
    let max_steps = max_steps.max(1) as f32;
    // A window wider than `max_steps` steps a side is walked at a coarser step (doubled until
    // it fits) and refined by as many more halving passes, so the work of one search is
    // bounded whatever the bone's length in pixels and the prediction's uncertainty.
    let mut w = *w;
    let mut extra = 0;
    for i in 0..2 {
        let mut k = 0;
        while w.step[i] > 0.0 && (w.half[i] / w.step[i]).ceil() > max_steps {
            w.step[i] *= 2.0;
            k += 1;
        }
        extra = extra.max(k);
    }
    let w = &w;
    let n = [0, 1].map(|i| {
        if w.step[i] > 0.0 {
            (w.half[i] / w.step[i]).ceil().max(0.0) as i32
        } else {
            0
        }
    });
    let mut points = Vec::with_capacity(((2 * n[0] + 1) * (2 * n[1] + 1)) as usize);
    let mut near = Vec::with_capacity(points.capacity());
    for a in -n[0]..=n[0] {
        for b in -n[1]..=n[1] {
            if a == 0 && b == 0 {
                continue;
            }
            points.push([
                w.centre[0] + a as f32 * w.step[0],
                w.centre[1] + b as f32 * w.step[1],
            ]);
            near.push(a * a + b * b);
        }
    }
    let first = (w.centre, f(w.centre, f32::INFINITY));
    // A full grid keeps its best point; a coarsened one keeps its `KEEP` best, each refined,
    // so that a narrow valley between two coarse points is not lost to a broad one.
    let starts = if first.1.is_nan() {
        // Nothing compares below a centre that costs NaN, the rule `lowest_k_in_order`'s runs
        // follow as they meet it: kept as it was.
        if extra == 0 {
            vec![first]
        } else {
            lowest_k_in_order(&points, runs, &f, first, KEEP)
        }
    } else {
        let order = nearest_first(&near);
        let k = if extra == 0 { 1 } else { KEEP };
        lowest_k(&points, &order, runs, &f, first, k)
    };
    // The 3×3 neighbourhood of a point, its centre left out, in row order; the edges before
    // the corners.
    const RING: [(i32, i32); 8] = [
        (-1, -1),
        (-1, 0),
        (-1, 1),
        (0, -1),
        (0, 1),
        (1, -1),
        (1, 0),
        (1, 1),
    ];
    const RING_ORDER: [u32; 8] = [1, 3, 4, 6, 0, 2, 5, 7];
    let pass_runs = runs.min(PASS_RUNS);
    let refine = |start: ([f32; 2], f32)| {
        let mut best = start;
        let mut step = w.step;
        for _ in 0..2 + extra {
            step = [step[0] * 0.5, step[1] * 0.5];
            let centre = best.0;
            let points = RING.map(|(a, b)| {
                [
                    centre[0] + a as f32 * step[0],
                    centre[1] + b as f32 * step[1],
                ]
            });
            if !best.1.is_nan() {
                best = lowest_k(&points, &RING_ORDER, pass_runs, &f, best, 1)[0];
            }
        }
        best
    };
    // The best points' refinements do not depend on one another: side by side, then compared
    // in order.
    let refined: Vec<([f32; 2], f32)> = if runs > 1 && starts.len() > 1 {
        starts.into_par_iter().map(refine).collect()
    } else {
        starts.into_iter().map(refine).collect()
    };
    let mut result: Option<([f32; 2], f32)> = None;
    for best in refined {
        if result.is_none_or(|r| best.1 < r.1) {
            result = Some(best);
        }
    }
    result.expect("at least the centre")
}

/// The indices of points `0..near.len()` by `near` (a squared distance from the centre),
/// ties in order.
fn nearest_first(near: &[i32]) -> Vec<u32> {
    // A counting sort: the distances are small integers (at most 2·max_steps²).
    let top = near.iter().copied().max().unwrap_or(0).max(0) as usize;
    let mut at = vec![0u32; top + 2];
    for &d in near {
        at[d.max(0) as usize + 1] += 1;
    }
    for i in 1..at.len() {
        at[i] += at[i - 1];
    }
    let mut order = vec![0u32; near.len()];
    for (i, &d) in near.iter().enumerate() {
        let slot = &mut at[d.max(0) as usize];
        order[*slot as usize] = i as u32;
        *slot += 1;
    }
    order
}

/// A point's cost and rank as one integer, ordered as the first minimum is chosen: by cost
/// (as [`f32::total_cmp`] orders it), then by rank (0 for the point to beat, `i + 1` for
/// `points[i]`, so the grid row by row).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct Key(u64);

impl Key {
    fn new(cost: f32, rank: u32) -> Self {
        let b = cost.to_bits();
        let ordered = if b >> 31 == 1 { !b } else { b | 1 << 31 };
        Key(((ordered as u64) << 32) | rank as u64)
    }

    fn cost(self) -> f32 {
        let o = (self.0 >> 32) as u32;
        f32::from_bits(if o >> 31 == 1 { o & !(1 << 31) } else { !o })
    }

    fn rank(self) -> u32 {
        self.0 as u32
    }

    /// The limit below which the cost of a point of rank `rank` beats this one: its cost, or
    /// the next float up for a point ranked before it (a tie goes to the first).
    fn limit(self, rank: u32) -> f32 {
        let c = self.cost();
        if rank < self.rank() {
            c.next_up()
        } else {
            c
        }
    }
}

/// The `k` lowest of `first` and `points` (lowest first; ties in order; a point other than
/// `first` only when it costs less than infinity), `first` not NaN. The points are evaluated in
/// `order` dealt out to `runs` runs in turn (the runs in parallel), each judged against the
/// `k`-th best found so far by all runs.
fn lowest_k(
    points: &[[f32; 2]],
    order: &[u32],
    runs: usize,
    f: &(impl Fn([f32; 2], f32) -> f32 + Sync),
    first: ([f32; 2], f32),
    k: usize,
) -> Vec<([f32; 2], f32)> {
    let k = k.max(1);
    let runs = runs.max(1);
    // The best keys so far, and the `k`-th of them to beat (`u64::MAX` while there are fewer):
    // read without the lock, so a run may judge against a bound a little out of date (a higher
    // one: more work, the same result).
    let kept = Mutex::new(vec![Key::new(first.1, 0)]);
    let full = |kept: &[Key]| {
        if kept.len() < k {
            u64::MAX
        } else {
            kept[k - 1].0
        }
    };
    let bound = AtomicU64::new(full(&kept.lock().unwrap()));
    let run = |r: usize| {
        for &i in order.iter().skip(r).step_by(runs) {
            let rank = i + 1;
            let b = bound.load(Ordering::Relaxed);
            let lim = if b == u64::MAX {
                f32::INFINITY
            } else {
                Key(b).limit(rank)
            };
            let c = f(points[i as usize], lim);
            if c < lim {
                let key = Key::new(c, rank);
                let mut kept = kept.lock().unwrap();
                if kept.len() < k || key < kept[k - 1] {
                    let at = kept.partition_point(|&e| e < key);
                    kept.insert(at, key);
                    kept.truncate(k);
                    bound.store(full(&kept), Ordering::Relaxed);
                }
            }
        }
    };
    if runs > 1 {
        (0..runs).into_par_iter().for_each(run);
    } else {
        run(0);
    }
    let kept = kept.into_inner().unwrap();
    kept.into_iter()
        .map(|key| match key.rank() {
            0 => first,
            r => (points[r as usize - 1], key.cost()),
        })
        .collect()
}

/// The `k` lowest of `first` and `points` (lowest first; ties in order), the points cut into
/// `runs` runs evaluated in parallel in order, each judged against its run's `k`-th best so
/// far: [`lowest_k`] for a `first` that costs NaN.
fn lowest_k_in_order(
    points: &[[f32; 2]],
    runs: usize,
    f: &(impl Fn([f32; 2], f32) -> f32 + Sync),
    first: ([f32; 2], f32),
    k: usize,
) -> Vec<([f32; 2], f32)> {
    let k = k.max(1);
    let run = |chunk: &[[f32; 2]]| {
        let mut kept = vec![first];
        for &q in chunk {
            let lim = if kept.len() < k {
                f32::INFINITY
            } else {
                kept[k - 1].1
            };
            let c = f(q, lim);
            if c < lim {
                let at = kept.partition_point(|e| e.1 <= c);
                kept.insert(at, (q, c));
                kept.truncate(k);
            }
        }
        kept
    };
    let size = points.len().div_ceil(runs.max(1)).max(1);
    let lists: Vec<Vec<([f32; 2], f32)>> = if runs > 1 {
        points.par_chunks(size).map(run).collect()
    } else {
        vec![run(points)]
    };
    let mut all = vec![first];
    for list in lists {
        all.extend(list.into_iter().filter(|e| e.0 != first.0));
    }
    // Stable: equal costs keep the order of the runs.
    all.sort_by(|a, b| a.1.total_cmp(&b.1));
    all.truncate(k);
    all
}

/// Most grid steps on each side of a window's centre (see [`grid_min_bounded`]; the default of
/// the tracker's `search_max_steps`): a search costs at most `(2·16 + 1)²` points and its
/// refinements, so a joint that is lost, or a long bone on a large subject, costs about what a
/// found joint on a small one does (docs/method.md §2.3).
pub const MAX_STEPS: u32 = 16;

/// Best points of a coarsened grid that are each refined (see [`MAX_STEPS`]).
pub const KEEP: usize = 4;

/// How many runs the coarse grid of [`grid_min_bounded`] is cut into: enough to keep two cores
/// busy, few enough that most points are judged against a good best point.
const RUNS: usize = 4;

/// How many runs each refinement pass's eight points are cut into.
const PASS_RUNS: usize = 2;

#[cfg(test)]
mod tests;
