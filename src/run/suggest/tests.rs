use super::*;

fn flat(frames: u64, n: f32) -> Vec<(u64, f32)> {
    (0..frames).map(|f| (f, n)).collect()
}

/// The gaps between consecutive keys (the seed on frame 0 with the suggested ones), their mean,
/// and the stretch after the last key.
fn gaps(suggested: &[u64], frames: u64) -> (Vec<u64>, f64, u64) {
    let mut keys = suggested.to_vec();
    keys.push(0);
    keys.sort_unstable();
    let inner: Vec<u64> = keys.windows(2).map(|w| w[1] - w[0]).collect();
    let mean = inner.iter().sum::<u64>() as f64 / inner.len() as f64;
    (inner, mean, frames - 1 - keys[keys.len() - 1])
}

#[test]
fn a_tracker_lost_all_along_gets_evenly_spaced_keys() {
    // The dance's case: the evidence saturates from frame 15 on.
    let need: Vec<(u64, f32)> = (0..450u64)
        .map(|f| (f, if f < 15 { 1.0 } else { 7.0 }))
        .collect();
    let s = suggest(&need, &[0], 9);
    assert_eq!(s.len(), 9);
    let (inner, mean, tail) = gaps(&s, 450);
    for g in &inner {
        assert!(
            (*g as f64) > 0.75 * mean && (*g as f64) < 1.25 * mean,
            "{s:?}: gaps {inner:?} are not even"
        );
    }
    // The end is tracked from one key only, so the last key sits nearer the end than a gap.
    assert!(
        (tail as f64) < mean,
        "{s:?}: {tail} frames after the last key"
    );
}

#[test]
fn keys_gather_where_the_evidence_gathers() {
    // The flies' case: quiet for 300 frames, then lost.
    let need: Vec<(u64, f32)> = (0..1000u64)
        .map(|f| (f, if (300..400).contains(&f) { 5.0 } else { 0.0 }))
        .collect();
    let s = suggest(&need, &[0], 5);
    assert_eq!(s.len(), 5);
    let inside = s.iter().filter(|f| (290..410).contains(*f)).count();
    assert!(inside >= 4, "{s:?}");
    // Nothing to key where nothing is wrong.
    assert!(suggest(&flat(100, 0.0), &[0], 5).is_empty());
    assert!(suggest(&need, &[0], 0).is_empty());
    assert!(suggest(&[], &[0], 3).is_empty());
}

#[test]
fn the_frame_that_lowers_the_doubt_most_comes_first() {
    // A big bump of need at 150–154 and a small one at 50–54: two keys, the big bump's first.
    let need: Vec<(u64, f32)> = (0..200u64)
        .map(|f| {
            let n = if (150..=154).contains(&f) {
                6.0
            } else if (50..=54).contains(&f) {
                2.0
            } else {
                0.0
            };
            (f, n)
        })
        .collect();
    let s = suggest(&need, &[0], 2);
    assert_eq!(s.len(), 2, "{s:?}");
    assert!((148..=156).contains(&s[0]), "{s:?}");
    assert!((48..=56).contains(&s[1]), "{s:?}");
}

#[test]
fn frames_keyed_already_are_kept_and_never_suggested() {
    let need = flat(451, 3.0);
    // Seed on 0, a key on 225, one more key: the middle of one half (the end is tracked from
    // one side only, so it is the later half).
    let s = suggest(&need, &[0, 225], 1);
    assert_eq!(s.len(), 1);
    assert!((300..=420).contains(&s[0]), "{s:?}");
    // Keys on every frame leave nothing to suggest; keys outside the frames are ignored.
    let every: Vec<u64> = (0..451).collect();
    assert!(suggest(&need, &every, 3).is_empty());
    let s = suggest(&need, &[0, 225, 9_999], 3);
    assert_eq!(s.len(), 3);
    assert!(s.iter().all(|f| *f != 0 && *f != 225 && *f <= 450), "{s:?}");
    // Seeded on frame 40 of a clip tracked backward to 0: frames before the seed count too.
    let s = suggest(&need, &[40], 4);
    assert!(
        s.iter().any(|&f| f < 40) || s.iter().all(|&f| f > 40),
        "{s:?}"
    );
    assert!(s.iter().all(|&f| f != 40));
}

#[test]
fn a_long_clip_is_searched_in_cells() {
    // Ten minutes at 30 frames/s: cells of 30 frames, keys on their middles, evenly spread.
    let need = flat(18_000, 2.0);
    let s = suggest(&need, &[0], 10);
    assert_eq!(s.len(), 10);
    let (inner, mean, _) = gaps(&s, 18_000);
    assert!(
        inner.iter().all(|&g| (g as f64 - mean).abs() < 0.2 * mean),
        "{s:?}"
    );
    assert!(
        s.iter().all(|f| f % 30 == 14),
        "{s:?}: not on cells' middles"
    );
}
