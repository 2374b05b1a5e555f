//! Exhaustive search over a window (docs/method.md §2.3, eq. 7–8; exhaustive rather than a
//! greedy walk from the prediction, which stops in the first local minimum): a grid over two
//! parameters, then two finer passes around the best cell.

use rayon::prelude::*;

/// A two-parameter window: centre, half-width and coarse grid step per parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    pub centre: [f32; 2],
    pub half: [f32; 2],
    pub step: [f32; 2],
}

/// Minimises `f` over `w`: every grid point of the window, then 3×3 neighbourhoods of the best
/// point at half and a quarter of the step. Returns the best point and its cost. Ties keep the
/// first point found (row by row from the low corner), so results are deterministic.
pub fn grid_min(w: &Window, f: impl Fn([f32; 2]) -> f32 + Sync) -> ([f32; 2], f32) {
    grid_min_bounded(w, |q, _| f(q))
}

/// [`grid_min`] for a cost that may give up early: `f(q, limit)` must return the cost of `q`
/// exactly when it is below `limit`, and otherwise any value at least `limit` (such a point
/// cannot be the first minimum, so the result is [`grid_min`]'s to the bit). The coarse grid
/// is cut into a few runs of points evaluated in parallel, each against the best point before
/// it in its run (or the centre); the runs are compared in order, so the result does not
/// depend on the threads.
pub fn grid_min_bounded(w: &Window, f: impl Fn([f32; 2], f32) -> f32 + Sync) -> ([f32; 2], f32) {
    grid_min_in_runs(w, RUNS, f)
}

/// [`grid_min_bounded`] on the calling thread alone, for a caller that runs several searches
/// side by side: one run, so every point is judged against the best point before it (fewer
/// evaluated to the end), and no thread is woken. The same result to the bit.
pub fn grid_min_bounded_serial(
    w: &Window,
    f: impl Fn([f32; 2], f32) -> f32 + Sync,
) -> ([f32; 2], f32) {
    grid_min_in_runs(w, 1, f)
}

/// [`grid_min_bounded`] with the coarse grid cut into `runs` runs (1: all on this thread).
fn grid_min_in_runs(
    w: &Window,
    runs: usize,
    f: impl Fn([f32; 2], f32) -> f32 + Sync,
) -> ([f32; 2], f32) {
    let n = [0, 1].map(|i| {
        if w.step[i] > 0.0 {
            (w.half[i] / w.step[i]).ceil().max(0.0) as i32
        } else {
            0
        }
    });
    let mut points = Vec::with_capacity(((2 * n[0] + 1) * (2 * n[1] + 1)) as usize);
    for a in -n[0]..=n[0] {
        for b in -n[1]..=n[1] {
            if a == 0 && b == 0 {
                continue;
            }
            points.push([
                w.centre[0] + a as f32 * w.step[0],
                w.centre[1] + b as f32 * w.step[1],
            ]);
        }
    }
    let mut best = (w.centre, f(w.centre, f32::INFINITY));
    lowest(&points, runs, &f, &mut best);
    let mut step = w.step;
    for _ in 0..2 {
        step = [step[0] * 0.5, step[1] * 0.5];
        let centre = best.0;
        points.clear();
        for a in -1..=1 {
            for b in -1..=1 {
                if a == 0 && b == 0 {
                    continue;
                }
                points.push([
                    centre[0] + a as f32 * step[0],
                    centre[1] + b as f32 * step[1],
                ]);
            }
        }
        lowest(&points, 1, &f, &mut best);
    }
    best
}

/// How many runs the coarse grid of [`grid_min_bounded`] is cut into: enough to keep two cores
/// busy, few enough that most points are judged against a good best point.
const RUNS: usize = 4;

/// Replaces `best` by the first of `points` that costs less, in order: `points` cut into `runs`
/// runs evaluated in parallel (see [`grid_min_bounded`]).
fn lowest(
    points: &[[f32; 2]],
    runs: usize,
    f: &(impl Fn([f32; 2], f32) -> f32 + Sync),
    best: &mut ([f32; 2], f32),
) {
    if points.is_empty() {
        return;
    }
    let limit = best.1;
    let run = |chunk: &[[f32; 2]]| {
        let mut found: Option<([f32; 2], f32)> = None;
        for &q in chunk {
            let lim = found.map_or(limit, |b| b.1);
            let c = f(q, lim);
            if c < lim {
                found = Some((q, c));
            }
        }
        found
    };
    let size = points.len().div_ceil(runs.max(1));
    let found: Vec<Option<([f32; 2], f32)>> = if runs > 1 {
        points.par_chunks(size).map(run).collect()
    } else {
        vec![run(points)]
    };
    for (q, c) in found.into_iter().flatten() {
        if c < best.1 {
            *best = (q, c);
        }
    }
}

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
        let bounded = grid_min_bounded(&w, |q, limit| {
            let c = f(q);
            if c >= limit {
                given_up.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                limit + 1.0
            } else {
                c
            }
        });
        assert_eq!(bounded, reference(&w, f));
        let serial = grid_min_bounded_serial(&w, |q, limit| {
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
}
