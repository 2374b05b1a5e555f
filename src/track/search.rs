//! Exhaustive search over a window (METHOD.md eq. 4.5–4.6, "an exhaustive search over the window
//! is the robust form" of the thesis's greedy walk): a grid over two parameters, then two finer
//! passes around the best cell.

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
pub fn grid_min(w: &Window, f: impl Fn([f32; 2]) -> f32) -> ([f32; 2], f32) {
    let n = [0, 1].map(|i| {
        if w.step[i] > 0.0 {
            (w.half[i] / w.step[i]).ceil().max(0.0) as i32
        } else {
            0
        }
    });
    let mut best = (w.centre, f(w.centre));
    for a in -n[0]..=n[0] {
        for b in -n[1]..=n[1] {
            if a == 0 && b == 0 {
                continue;
            }
            let q = [
                w.centre[0] + a as f32 * w.step[0],
                w.centre[1] + b as f32 * w.step[1],
            ];
            let c = f(q);
            if c < best.1 {
                best = (q, c);
            }
        }
    }
    let mut step = w.step;
    for _ in 0..2 {
        step = [step[0] * 0.5, step[1] * 0.5];
        let centre = best.0;
        for a in -1..=1 {
            for b in -1..=1 {
                if a == 0 && b == 0 {
                    continue;
                }
                let q = [
                    centre[0] + a as f32 * step[0],
                    centre[1] + b as f32 * step[1],
                ];
                let c = f(q);
                if c < best.1 {
                    best = (q, c);
                }
            }
        }
    }
    best
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
    fn a_zero_window_evaluates_only_the_centre_and_its_refinement() {
        let w = Window {
            centre: [1.0, 1.0],
            half: [0.0, 0.0],
            step: [1.0, 1.0],
        };
        let calls = std::cell::Cell::new(0);
        let (q, c) = grid_min(&w, |q| {
            calls.set(calls.get() + 1);
            q[0] + q[1]
        });
        assert_eq!(calls.get(), 1 + 8 + 8);
        assert_eq!(q, [0.25, 0.25]);
        assert_eq!(c, 0.5);
    }
}
