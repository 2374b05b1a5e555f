use super::*;
use crate::export::keys;

/// A smooth swing with a little noise: what a tracked bone's angle looks like.
fn swing(n: usize) -> Vec<Vec<f64>> {
    let mut seed = 11u64;
    (0..n)
        .map(|i| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            let j = (seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5;
            let t = i as f64 / 30.0;
            vec![35.0 * (2.1 * t).sin() + 12.0 * (0.6 * t).cos() + 0.1 * j]
        })
        .collect()
}

fn times(n: usize, fps: f64) -> Vec<f64> {
    (0..n).map(|i| round(i as f64 / fps, 6)).collect()
}

/// Every frame's value from Spine keys, evaluated as spine-core does.
fn spine_eval(values: &[Vec<f64>], times: &[f64], kept: &[CurveKey], dec: i32) -> Vec<Vec<f64>> {
    let key = |t: usize, c: usize| round(values[t][c], dec);
    let dims = values[0].len();
    (0..values.len())
        .map(|i| {
            let after = kept.partition_point(|k| k.at <= i);
            let k = &kept[after - 1];
            if k.at == i || after == kept.len() {
                return (0..dims).map(|c| key(k.at, c)).collect();
            }
            let b = kept[after].at;
            (0..dims)
                .map(|c| {
                    let (ta, tb) = (times[k.at], times[b]);
                    let (va, vb) = (key(k.at, c), key(b, c));
                    match &k.curve {
                        None => va + (times[i] - ta) / (tb - ta) * (vb - va),
                        Some(h) => {
                            let h = [h[4 * c], h[4 * c + 1], h[4 * c + 2], h[4 * c + 3]];
                            spine_value(ta, va, &spine_points(ta, va, h, tb, vb), tb, vb, times[i])
                        }
                    }
                })
                .collect()
        })
        .collect()
}

fn worst(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    a.iter().zip(b).map(|(x, y)| dist(x, y)).fold(0.0, f64::max)
}

#[test]
fn spine_sampling_follows_the_cubic_and_is_exact_on_a_line() {
    let (t1, t2, v1, v2) = (0.5, 1.3, 10.0, -4.0);
    let h = [t1 + 0.8 / 3.0, 30.0, t1 + 1.6 / 3.0, 25.0];
    let p = spine_points(t1, v1, h, t2, v2);
    for k in 1..80 {
        let s = k as f64 / 80.0;
        let t = t1 + s * (t2 - t1);
        // The time handles at thirds: the curve is the cubic in s.
        let cubic = (1.0 - s).powi(3) * v1
            + 3.0 * s * (1.0 - s).powi(2) * h[1]
            + 3.0 * s * s * (1.0 - s) * h[3]
            + s.powi(3) * v2;
        let got = spine_value(t1, v1, &p, t2, v2, t);
        // Chords of 10 samples: within a few tenths on this strong bend, not equal.
        assert!((got - cubic).abs() < 0.5, "{s}: {got} vs {cubic}");
    }
    let line = [
        t1 + 0.8 / 3.0,
        v1 + (v2 - v1) / 3.0,
        t1 + 1.6 / 3.0,
        v1 + 2.0 * (v2 - v1) / 3.0,
    ];
    let p = spine_points(t1, v1, line, t2, v2);
    let t = t1 + 0.37 * (t2 - t1);
    assert!((spine_value(t1, v1, &p, t2, v2, t) - (v1 + 0.37 * (v2 - v1))).abs() < 1e-5);
}

#[test]
fn spine_curves_hold_every_frame_with_fewer_keys_than_lines() {
    let values = swing(300);
    let ts = times(300, 30.0);
    for tol in [0.1, 0.5, 2.0] {
        let kept = reduce_spine(&values, &ts, tol, None, 5);
        let linear = keys::reduce(&values, tol, None);
        let err = worst(&spine_eval(&values, &ts, &kept, 5), &values);
        assert!(err <= tol + 1e-5, "{tol}: {err}");
        assert!(
            kept.len() < linear.len(),
            "{tol}: {} curves vs {} lines",
            kept.len(),
            linear.len()
        );
        assert!(kept.iter().any(|k| k.curve.is_some()), "{tol}: no curve");
        assert_eq!((kept[0].at, kept.last().unwrap().at), (0, 299));
    }
    // Two components (a translation) are within the tolerance as a distance.
    let xy: Vec<Vec<f64>> = values
        .iter()
        .enumerate()
        .map(|(i, v)| vec![v[0], 0.2 * i as f64 - v[0] * 0.5])
        .collect();
    let kept = reduce_spine(&xy, &ts, 0.5, None, 4);
    assert!(kept
        .iter()
        .all(|k| k.curve.as_ref().is_none_or(|c| c.len() == 8)));
    assert!(worst(&spine_eval(&xy, &ts, &kept, 4), &xy) <= 0.5 + 1e-4);
}

#[test]
fn still_channels_and_max_steps_as_with_lines() {
    let flat: Vec<Vec<f64>> = (0..50).map(|i| vec![2.0 + 0.001 * i as f64]).collect();
    let ts = times(50, 24.0);
    assert_eq!(
        reduce_spine(&flat, &ts, 0.5, None, 5),
        vec![CurveKey { at: 0, curve: None }]
    );
    assert_eq!(reduce_spine(&flat, &ts, 0.0, None, 5).len(), 50);
    let spin: Vec<Vec<f64>> = (0..100)
        .map(|i| vec![(i as f64 * 0.1).powi(2) * 7.2])
        .collect();
    let kept = reduce_dragonbones(&spin, 0.5, Some(180.0), &[5]);
    for w in kept.windows(2) {
        assert!(spin[w[1].at][0] - spin[w[0].at][0] < 180.0, "{w:?}");
    }
}

#[test]
fn dragonbones_progress_is_linear_for_a_straight_curve() {
    let line = [1.0 / 3.0, 1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0];
    for d in [2usize, 5, 17] {
        let s = db_samples(line, d);
        assert_eq!(s.len(), d + 1);
        for k in 0..=d {
            let p = k as f64 / d as f64;
            assert!((db_progress(&s, p) - p).abs() < 2e-4, "{d} {k}");
        }
    }
}

#[test]
fn dragonbones_curves_hold_every_frame_with_fewer_keys_than_lines() {
    let values = swing(300);
    // A translation along a line with easing: one progress curve serves both components.
    let eased: Vec<Vec<f64>> = (0..300)
        .map(|i| {
            let s = values[i][0];
            vec![3.0 * s, -2.0 * s + 1.0]
        })
        .collect();
    for (vals, dec) in [(&values, &[5][..]), (&eased, &[4, 4][..])] {
        let kept = reduce_dragonbones(vals, 0.5, None, dec);
        let linear = keys::reduce(vals, 0.5, None);
        assert!(
            kept.len() < linear.len(),
            "{} vs {}",
            kept.len(),
            linear.len()
        );
        // Evaluated as the runtime does.
        let key = |t: usize, c: usize| round(vals[t][c], dec[c]);
        let mut err = 0.0f64;
        for w in kept.windows(2) {
            let (a, b) = (w[0].at, w[1].at);
            let d = b - a;
            let samples = w[0]
                .curve
                .as_ref()
                .map(|c| db_samples([c[0], c[1], c[2], c[3]], d));
            for k in 0..d {
                let p = k as f64 / d as f64;
                let pr = samples.as_ref().map_or(p, |s| db_progress(s, p));
                let got: Vec<f64> = (0..dec.len())
                    .map(|c| key(a, c) + (key(b, c) - key(a, c)) * pr)
                    .collect();
                err = err.max(dist(&got, &vals[a + k]));
            }
        }
        assert!(err <= 0.5 + 1e-4, "{err}");
    }
}
