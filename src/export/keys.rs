//! Key reduction for the skeleton formats: of a channel sampled on every frame, the frames to key
//! so that linear interpolation between the kept keys reproduces every frame within a tolerance
//! (docs/method.md §7; the exports' default, curves between the keys, is [`super::curves`]).
//!
//! The method is Ramer–Douglas–Peucker with the error measured in the channel's value (the
//! distance, over the value's components, between a frame's value and the straight line between
//! the two keys around it at that frame), not perpendicular to the polyline: time and value have
//! different units, and an animator's tolerance is a value tolerance (px, degrees). The crates
//! that implement RDP (e.g. `ramer_douglas_peucker`) measure perpendicular distance in one
//! metric space, so this is written here. A segment may also be limited in how far its first
//! component moves (`max_step`): DragonBones tweens a rotation the short way round, so two keys
//! must never be 180° or more apart.

/// How the exporters key each channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Keys {
    /// One key a frame.
    EveryFrame,
    /// As few keys as reproduce every frame within this many px (positions, and the tip of a
    /// bone whose length changes) and degrees (rotations); with `curves`, Bézier curves between
    /// the keys ([`super::curves`]), else straight lines ([`reduce`]).
    Reduce { tolerance: f64, curves: bool },
}

/// The default tolerance of [`Keys::Reduce`]: 0.5 px and 0.5°.
pub const DEFAULT_TOLERANCE: f64 = 0.5;

impl Default for Keys {
    fn default() -> Self {
        Keys::Reduce {
            tolerance: DEFAULT_TOLERANCE,
            curves: true,
        }
    }
}

impl Keys {
    /// The tolerance (0 for every frame).
    pub fn tolerance(self) -> f64 {
        match self {
            Keys::EveryFrame => 0.0,
            Keys::Reduce { tolerance, .. } => tolerance,
        }
    }

    /// Whether reduced keys carry Bézier curves.
    pub fn curves(self) -> bool {
        matches!(self, Keys::Reduce { curves: true, .. })
    }
}

/// Indices (ascending) of the samples of `values` (one value, of any number of components, per
/// frame) to key so that every sample lies within `tolerance` of the linear interpolation
/// between the kept keys around it, and no two consecutive keys differ by `max_step` or more in
/// component 0. The first sample is always kept; the last one too, unless every sample is within
/// `tolerance` of the first (then one key holds the whole channel). `tolerance` 0 keeps every
/// sample.
pub fn reduce(values: &[Vec<f64>], tolerance: f64, max_step: Option<f64>) -> Vec<usize> {
    let n = values.len();
    if n == 0 {
        return Vec::new();
    }
    if tolerance <= 0.0 {
        return (0..n).collect();
    }
    if (1..n).all(|i| dist(&values[i], &values[0]) <= tolerance) {
        return vec![0];
    }
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[n - 1] = true;
    // Segments still to check, as (first, last) sample indices (an explicit stack: a long clip
    // would recurse deeply).
    let mut stack = vec![(0usize, n - 1)];
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let mut worst = (a, 0.0f64);
        for i in a + 1..b {
            let s = (i - a) as f64 / (b - a) as f64;
            let line: Vec<f64> = values[a]
                .iter()
                .zip(&values[b])
                .map(|(x, y)| x + s * (y - x))
                .collect();
            let e = dist(&values[i], &line);
            if e > worst.1 {
                worst = (i, e);
            }
        }
        let too_far = max_step.is_some_and(|m| (values[b][0] - values[a][0]).abs() >= m);
        let split = if worst.1 > tolerance {
            worst.0
        } else if too_far {
            (a + b) / 2
        } else {
            continue;
        };
        keep[split] = true;
        stack.push((a, split));
        stack.push((split, b));
    }
    (0..n).filter(|&i| keep[i]).collect()
}

/// The value at sample `i` of the linear interpolation between the kept keys `kept` of `values`
/// (as [`reduce`] returned them; a single key holds).
pub fn interpolate(values: &[Vec<f64>], kept: &[usize], i: usize) -> Vec<f64> {
    let after = kept.partition_point(|&k| k < i);
    if after < kept.len() && kept[after] == i {
        return values[i].clone();
    }
    if after == 0 || after == kept.len() {
        // Before the first key or after the last: the nearest key holds.
        let k = kept[after.min(kept.len() - 1)];
        return values[k].clone();
    }
    let (a, b) = (kept[after - 1], kept[after]);
    let s = (i - a) as f64 / (b - a) as f64;
    values[a]
        .iter()
        .zip(&values[b])
        .map(|(x, y)| x + s * (y - x))
        .collect()
}

/// The Euclidean distance between two key values.
pub(crate) fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn worst(values: &[Vec<f64>], kept: &[usize]) -> f64 {
        (0..values.len())
            .map(|i| dist(&values[i], &interpolate(values, kept, i)))
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_line_needs_two_keys_and_a_constant_one() {
        let line: Vec<Vec<f64>> = (0..50).map(|i| vec![3.0 * i as f64, -1.0]).collect();
        assert_eq!(reduce(&line, 0.5, None), vec![0, 49]);
        let flat: Vec<Vec<f64>> = (0..50).map(|i| vec![2.0 + 0.001 * i as f64]).collect();
        assert_eq!(reduce(&flat, 0.5, None), vec![0]);
        assert_eq!(interpolate(&flat, &[0], 30), vec![2.0]);
        assert_eq!(reduce(&flat, 0.0, None).len(), 50);
    }

    #[test]
    fn every_sample_stays_within_the_tolerance() {
        // A noisy 2D wander: a sum of sines plus a pseudo-random jitter.
        let mut seed = 7u64;
        let values: Vec<Vec<f64>> = (0..400)
            .map(|i| {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
                let j = (seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5;
                let t = i as f64 / 30.0;
                vec![40.0 * (1.3 * t).sin() + j, 25.0 * (0.7 * t).cos() + 0.3 * j]
            })
            .collect();
        for tol in [0.1, 0.5, 2.0] {
            let kept = reduce(&values, tol, None);
            assert!(kept.len() < values.len(), "{tol}: nothing dropped");
            assert!(worst(&values, &kept) <= tol, "{tol}");
            assert_eq!(kept[0], 0);
            assert_eq!(*kept.last().unwrap(), 399);
        }
        // Tighter tolerance, more keys.
        assert!(reduce(&values, 0.1, None).len() > reduce(&values, 2.0, None).len());
    }

    #[test]
    fn max_step_splits_long_turns() {
        // A bone spinning at a constant rate: a line, but 720° in all.
        let spin: Vec<Vec<f64>> = (0..100).map(|i| vec![i as f64 * 7.2]).collect();
        let kept = reduce(&spin, 0.5, Some(180.0));
        assert!(kept.len() > 2);
        for w in kept.windows(2) {
            assert!(spin[w[1]][0] - spin[w[0]][0] < 180.0, "{w:?}");
        }
        assert!(worst(&spin, &kept) <= 1e-9);
    }
}
