//! Signal filters over frames (Δt = 1 frame): the cartoon animation filter (docs/method.md
//! §4.4, eq. 20) and the optional smoothing of noisy tracks (median, Gaussian).
//!
//! Every filter keeps the signal's length and treats the signal as constant beyond its ends, so
//! a still start or end stays still.

/// The cartoon animation filter, docs/method.md eq. 20: `x*(t) = x(t) − A · (x'' ⊗ G_σ)(t)`, an
/// inverted Laplacian of Gaussian. `strength` is A (dimensionless), `sigma_frames` the
/// Gaussian's standard deviation in frames. `x''` is the central second difference (units of x
/// per frame²), zero beyond the ends. A step becomes undershoot (anticipation) then overshoot (follow-through).
pub fn cartoon(x: &[f64], strength: f64, sigma_frames: f64) -> Vec<f64> {
    let n = x.len();
    if n < 3 || strength == 0.0 {
        return x.to_vec();
    }
    let at = |i: isize| x[i.clamp(0, n as isize - 1) as usize];
    let second: Vec<f64> = (0..n as isize)
        .map(|i| at(i + 1) - 2.0 * at(i) + at(i - 1))
        .collect();
    let kernel = gaussian_kernel(sigma_frames);
    let r = (kernel.len() / 2) as isize;
    (0..n)
        .map(|i| {
            let mut acc = 0.0;
            for (k, w) in kernel.iter().enumerate() {
                let j = i as isize + k as isize - r;
                if (0..n as isize).contains(&j) {
                    acc += w * second[j as usize];
                }
            }
            x[i] - strength * acc
        })
        .collect()
}

/// Gaussian smoothing with standard deviation `sigma_frames` (frames); ends repeat the first and
/// last sample.
pub fn gaussian(x: &[f64], sigma_frames: f64) -> Vec<f64> {
    let n = x.len();
    if n == 0 || sigma_frames <= 0.0 {
        return x.to_vec();
    }
    let kernel = gaussian_kernel(sigma_frames);
    let r = (kernel.len() / 2) as isize;
    (0..n as isize)
        .map(|i| {
            kernel
                .iter()
                .enumerate()
                .map(|(k, w)| w * x[(i + k as isize - r).clamp(0, n as isize - 1) as usize])
                .sum()
        })
        .collect()
}

/// Running median over `window_frames` samples (odd; an even window is widened by one); ends
/// repeat the first and last sample.
pub fn median(x: &[f64], window_frames: usize) -> Vec<f64> {
    let n = x.len();
    let r = (window_frames / 2) as isize;
    if n == 0 || r == 0 {
        return x.to_vec();
    }
    let mut buf = Vec::with_capacity(2 * r as usize + 1);
    (0..n as isize)
        .map(|i| {
            buf.clear();
            buf.extend((-r..=r).map(|k| x[(i + k).clamp(0, n as isize - 1) as usize]));
            buf.sort_by(f64::total_cmp);
            buf[r as usize]
        })
        .collect()
}

/// Normalised Gaussian weights over `-⌈3σ⌉..=⌈3σ⌉` frames (at least one tap a side).
fn gaussian_kernel(sigma_frames: f64) -> Vec<f64> {
    let s = sigma_frames.max(1e-3);
    let r = (3.0 * s).ceil().max(1.0) as isize;
    let w: Vec<f64> = (-r..=r)
        .map(|k| (-(k * k) as f64 / (2.0 * s * s)).exp())
        .collect();
    let sum: f64 = w.iter().sum();
    w.into_iter().map(|v| v / sum).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cartoon_turns_a_step_into_undershoot_then_overshoot() {
        let step: Vec<f64> = (0..60).map(|t| if t < 30 { 0.0 } else { 1.0 }).collect();
        let y = cartoon(&step, 2.0, 3.0);
        let (imin, min) = y
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .unwrap();
        let (imax, max) = y
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap();
        assert!(*min < -0.05 && imin < 30, "undershoot {min} at {imin}");
        assert!(*max > 1.05 && imax >= 30, "overshoot {max} at {imax}");
        // Far from the step the signal is untouched.
        assert_eq!(y[0], 0.0);
        assert_eq!(y[59], 1.0);
    }

    #[test]
    fn cartoon_leaves_straight_lines_alone() {
        let ramp: Vec<f64> = (0..40).map(|t| 3.0 + 0.5 * t as f64).collect();
        let y = cartoon(&ramp, 1.5, 4.0);
        // Interior: x'' = 0. Only the ends, where the signal stops, feel the filter.
        for t in 15..25 {
            assert!(
                (y[t] - ramp[t]).abs() < 1e-12,
                "{t}: {} vs {}",
                y[t],
                ramp[t]
            );
        }
        assert_eq!(cartoon(&ramp, 0.0, 4.0), ramp);
    }

    #[test]
    fn median_removes_a_spike_and_gaussian_keeps_the_mean() {
        let mut x = vec![1.0; 9];
        x[4] = 50.0;
        assert_eq!(median(&x, 3), vec![1.0; 9]);
        let mut x = vec![0.0; 11];
        x[5] = 3.0;
        let g = gaussian(&x, 0.8);
        assert!((g.iter().sum::<f64>() - 3.0).abs() < 1e-9);
        assert!(g[5] < 3.0 && g[4] > 0.0 && (g[4] - g[6]).abs() < 1e-12);
    }
}
