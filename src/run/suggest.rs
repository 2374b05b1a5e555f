//! Which frames to key next: the report's evidence of far-off joints, frame by frame
//! (docs/method.md §3, "Where to look"), gathered over the stretch a key pulls on, and the
//! frames where most of it gathers picked one by one, each keeping the next ones away from it.

/// Fewest frames a key pulls on, on each side: keys between them solve the path through both
/// ends (see [`crate::run::keyed`]), so a key helps the frames around it, not its own alone.
/// With `k` keys over `n` frames the reach is at least `n / 2k`, so that the keys together
/// can cover the clip: a key where the tracker was lost also sets it back on its way.
pub const REACH: u64 = 12;

/// Up to `k` frames worth keying, most needy first: `need` is each frame's evidence (about how
/// many of its joints are far off), in frame order; `keyed` are the frames the user has keyed
/// already (seeds, corrected segment files, `keys.toml`), whose reach needs nothing more. A
/// window's worth is the need summed over its frames that no key covers, a window running
/// from half a reach (see [`REACH`]) before a frame to one and a half after: the tracker goes
/// on from a key, so a key helps more of what follows it. The key goes on the first needy
/// frame of the worthiest window (ties: the earlier window), and the frames in its window
/// count as covered.
pub fn suggest(need: &[(u64, f32)], keyed: &[u64], k: usize) -> Vec<u64> {
    let span = match (need.first(), need.last()) {
        (Some(a), Some(b)) => b.0 - a.0 + 1,
        _ => return Vec::new(),
    };
    let reach = REACH.max(span / (2 * k.max(1) as u64));
    let (before, after) = (reach / 2, reach + reach / 2);
    // A key on frame f covers what it helps most: from `before` frames before it to `after`
    // after (a user's own keys too).
    let mut covered = vec![false; need.len()];
    let cover = |covered: &mut [bool], f: u64| {
        for (i, (g, _)) in need.iter().enumerate() {
            if *g + before >= f && *g <= f + after {
                covered[i] = true;
            }
        }
    };
    for &f in keyed {
        cover(&mut covered, f);
    }
    let mut picked = Vec::new();
    while picked.len() < k {
        // The window [f − before, f + after] with the most uncovered need (sliding sums).
        let mut best: Option<(usize, usize, f32)> = None;
        let (mut lo, mut hi, mut sum) = (0usize, 0usize, 0.0f64);
        for &(f, _) in need {
            while hi < need.len() && need[hi].0 <= f + after {
                if !covered[hi] {
                    sum += need[hi].1 as f64;
                }
                hi += 1;
            }
            while need[lo].0 + before < f {
                if !covered[lo] {
                    sum -= need[lo].1 as f64;
                }
                lo += 1;
            }
            let worth = sum as f32;
            if worth > 0.0 && best.is_none_or(|b| worth > b.2) {
                best = Some((lo, hi, worth));
            }
        }
        let Some((lo, hi, _)) = best else { break };
        // The key goes on the window's first frame with uncovered need: where the tracker
        // starts to go wrong, so that it goes on from there set right.
        let Some(i) = (lo..hi).find(|&i| !covered[i] && need[i].1 > 0.0) else {
            break;
        };
        picked.push(need[i].0);
        cover(&mut covered, need[i].0);
    }
    picked
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_frames_where_need_gathers_come_first_and_keep_apart() {
        // Need on frames 30-40 (1 each) and a smaller bump at 100 (3 in one frame).
        let need: Vec<(u64, f32)> = (0..200u64)
            .map(|f| {
                let n = if (30..=40).contains(&f) {
                    1.0
                } else if f == 100 {
                    3.0
                } else {
                    0.0
                };
                (f, n)
            })
            .collect();
        // Five keys over 200 frames: a reach of 20.
        let s = suggest(&need, &[], 5);
        assert_eq!(s.len(), 2, "{s:?}: nothing else has any need");
        assert_eq!(s, [30, 100]);
        // A key already near the first bump leaves only the second.
        assert_eq!(suggest(&need, &[35], 5).len(), 1);
    }
}
