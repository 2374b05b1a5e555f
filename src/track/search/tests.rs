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
