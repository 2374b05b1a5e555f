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
mod tests {
    use super::*;

    #[test]
    fn finds_the_minimum_of_a_bowl_to_a_quarter_step() {
        let f = |q: [f32; 2]| (q[0] - 3.3).powi(2) + (q[1] + 1.7).powi(2);
        let w = Window {
            centre: [0.0, 0.0],
            half: [6.0, 6.0],
            step: [2.0, 2.0],
        };
        let (q, _) = grid_min(&w, f);
        assert!(
            (q[0] - 3.3).abs() <= 0.25 && (q[1] + 1.7).abs() <= 0.25,
            "{q:?}"
        );
    }

    #[test]
    fn giving_up_at_the_limit_finds_the_same_point() {
        // A bumpy cost with ties, so the first-minimum rule matters.
        let f = |q: [f32; 2]| ((q[0] * 1.7).sin() + (q[1] * 0.9).cos() * 0.5 + 2.0).floor() * 0.25;
        let w = Window {
            centre: [0.3, -0.2],
            half: [7.0, 5.0],
            step: [0.5, 0.5],
        };
        let given_up = std::sync::atomic::AtomicUsize::new(0);
        let bounded = grid_min_bounded(&w, MAX_STEPS, |q, limit| {
            let c = f(q);
            if c >= limit {
                given_up.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                limit + 1.0
            } else {
                c
            }
        });
        assert_eq!(bounded, reference(&w, f));
        let serial = grid_min_bounded_serial(&w, MAX_STEPS, |q, limit| {
            let c = f(q);
            if c >= limit {
                limit + 1.0
            } else {
                c
            }
        });
        assert_eq!(serial, reference(&w, f));
        assert_eq!(grid_min(&w, f), reference(&w, f));
        assert!(given_up.into_inner() > 100);
    }

    /// The plain sequential search: every grid point in order, then the two finer passes.
    fn reference(w: &Window, f: impl Fn([f32; 2]) -> f32) -> ([f32; 2], f32) {
        let n = [0, 1].map(|i| (w.half[i] / w.step[i]).ceil() as i32);
        let mut best = (w.centre, f(w.centre));
        let try_at = |q: [f32; 2], best: &mut ([f32; 2], f32)| {
            let c = f(q);
            if c < best.1 {
                *best = (q, c);
            }
        };
        for a in -n[0]..=n[0] {
            for b in -n[1]..=n[1] {
                if a != 0 || b != 0 {
                    let q = [
                        w.centre[0] + a as f32 * w.step[0],
                        w.centre[1] + b as f32 * w.step[1],
                    ];
                    try_at(q, &mut best);
                }
            }
        }
        let mut step = w.step;
        for _ in 0..2 {
            step = [step[0] * 0.5, step[1] * 0.5];
            let centre = best.0;
            for a in -1..=1 {
                for b in -1..=1 {
                    if a != 0 || b != 0 {
                        let q = [
                            centre[0] + a as f32 * step[0],
                            centre[1] + b as f32 * step[1],
                        ];
                        try_at(q, &mut best);
                    }
                }
            }
        }
        best
    }

    #[test]
    fn a_wide_window_is_walked_coarsely_and_still_refined_to_a_quarter_step() {
        // 200 steps a side: 160 801 points walked in full; capped, a coarser grid and the
        // refinements of its best points.
        let f = |q: [f32; 2]| (q[0] - 31.3).powi(2) + (q[1] + 17.7).powi(2);
        let w = Window {
            centre: [0.0, 0.0],
            half: [200.0, 200.0],
            step: [1.0, 1.0],
        };
        let count = |cap: u32| {
            let calls = std::sync::atomic::AtomicUsize::new(0);
            let (q, c) = grid_min_bounded(&w, cap, |q, _| {
                calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                f(q)
            });
            assert!(
                (q[0] - 31.3).abs() <= 0.25 && (q[1] + 17.7).abs() <= 0.25,
                "cap {cap}: {q:?}"
            );
            (q, c, calls.into_inner())
        };
        let (q16, c16, calls16) = count(MAX_STEPS);
        assert_eq!((q16, c16), grid_min(&w, f));
        // Step 1 doubled 4 times (16 × 13 ≥ 200): a 27 × 27 grid, 2 + 4 refinement passes of 8
        // points each.
        assert!(calls16 <= 27 * 27 + KEEP * 6 * 8, "{calls16} evaluations");
        // Capped at 8: doubled 5 times (32 × 7 ≥ 200), a 15 × 15 grid, 2 + 5 passes.
        let (_, _, calls8) = count(8);
        assert!(calls8 <= 15 * 15 + KEEP * 7 * 8, "{calls8} evaluations");
        assert!(calls8 < calls16, "{calls8} against {calls16}");
        // 0 is taken as 1: a 3 × 3 grid of the step doubled until it fits.
        let (_, _, calls0) = count(0);
        assert!(calls0 < calls8, "{calls0} against {calls8}");
    }

    #[test]
    fn a_narrow_valley_beside_a_broad_one_is_kept_by_the_coarse_walk() {
        // Two valleys: a shallow one centred on a coarse grid point (cost 1) and a deeper one
        // (0.5) between coarse points, whose nearest coarse point costs 1.04: second on the
        // coarse grid, so only refining more than the single best coarse point finds it.
        let f = |q: [f32; 2]| {
            let shallow = 1.0 + 0.001 * ((q[0] + 80.0).powi(2) + q[1].powi(2));
            let deep = 0.5 + 0.03 * ((q[0] - 37.0).powi(2) + (q[1] - 5.0).powi(2));
            shallow.min(deep)
        };
        let w = Window {
            centre: [0.0, 0.0],
            half: [128.0, 128.0],
            step: [1.0, 1.0],
        };
        let (q, _) = grid_min(&w, f);
        assert!(
            (q[0] - 37.0).abs() <= 0.5 && (q[1] - 5.0).abs() <= 0.5,
            "{q:?}"
        );
    }

    #[test]
    fn a_capped_search_gives_the_same_point_on_any_thread_count() {
        let f = |q: [f32; 2]| ((q[0] * 0.37).sin() + (q[1] * 0.21).cos() + 2.0).floor() * 0.5;
        let w = Window {
            centre: [0.3, -0.2],
            half: [90.0, 60.0],
            step: [0.5, 0.5],
        };
        let bounded = |q: [f32; 2], limit: f32| {
            let c = f(q);
            if c >= limit {
                limit + 1.0
            } else {
                c
            }
        };
        let parallel = grid_min_bounded(&w, MAX_STEPS, bounded);
        assert_eq!(parallel, grid_min_bounded_serial(&w, MAX_STEPS, bounded));
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        assert_eq!(
            parallel,
            one.install(|| grid_min_bounded(&w, MAX_STEPS, bounded))
        );
    }

    #[test]
    fn a_zero_window_evaluates_only_the_centre_and_its_refinement() {
        let w = Window {
            centre: [1.0, 1.0],
            half: [0.0, 0.0],
            step: [1.0, 1.0],
        };
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let (q, c) = grid_min(&w, |q| {
            calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            q[0] + q[1]
        });
        assert_eq!(calls.into_inner(), 1 + 8 + 8);
        assert_eq!(q, [0.25, 0.25]);
        assert_eq!(c, 0.5);
    }

    #[test]
    fn the_best_points_found_nearest_first_are_those_found_in_order() {
        // Costs with many ties (the centre's among them), so which of equal points is kept
        // matters.
        let f = |q: [f32; 2]| ((q[0] * 0.37).sin() + (q[1] * 0.21).cos() + 2.0).floor() * 0.5;
        let bounded = |q: [f32; 2], limit: f32| {
            let c = f(q);
            if c >= limit {
                limit + 1.0
            } else {
                c
            }
        };
        let (mut points, mut near) = (Vec::new(), Vec::new());
        for a in -16..=16 {
            for b in -16..=16 {
                if a != 0 || b != 0 {
                    points.push([a as f32 * 1.5, b as f32 * 0.5]);
                    near.push(a * a + b * b);
                }
            }
        }
        let first = ([0.0, 0.0], f([0.0, 0.0]));
        let order = nearest_first(&near);
        for k in [1, 4] {
            let in_order = lowest_k_in_order(&points, 1, &bounded, first, k);
            for runs in [1, 4] {
                assert_eq!(
                    lowest_k(&points, &order, runs, &bounded, first, k),
                    in_order
                );
            }
        }
    }

    #[test]
    fn nearest_first_is_a_stable_sort_by_distance() {
        let near: Vec<i32> = (0..500).map(|i| (i * 37 % 101) % 13).collect();
        let mut sorted: Vec<u32> = (0..near.len() as u32).collect();
        sorted.sort_by_key(|&i| near[i as usize]);
        assert_eq!(nearest_first(&near), sorted);
        assert!(nearest_first(&[]).is_empty());
    }
}
