//! Per-byte median of several equal-sized buffers (the clean plate's temporal median), by a
//! sorting network (only the comparators the middle element depends on) run over many bytes
//! side by side, stretches of the buffers in parallel.

/// Bytes worked on side by side: each comparator of the network is a `min`/`max` over this
/// many bytes, which the compiler turns into a few vector instructions.
const CHUNK: usize = 64;

/// The comparators `(a, b)`, `a < b`, of Batcher's odd–even merge sort for `n` elements: after
/// them, in this order, element `a` holds the smaller and `b` the larger of each pair, and the
/// `n` elements are sorted. (The network for the next power of two with the comparators that
/// reach past `n` left out: on elements past `n` padded with 255, those change nothing.)
fn network(n: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut p = 1;
    while p < n {
        let mut k = p;
        while k >= 1 {
            let mut j = k % p;
            while j + k < n {
                for i in 0..k {
                    let (a, b) = (i + j, i + j + k);
                    if b < n && a / (2 * p) == b / (2 * p) {
                        out.push((a, b));
                    }
                }
                j += 2 * k;
            }
            k /= 2;
        }
        p *= 2;
    }
    out
}

/// The comparators of [`network`]`(n)` that the element at index `k` depends on, in order:
/// going backward from it, a comparator is kept when it writes an element read later (by a
/// kept comparator or as the result). One that writes only elements nobody reads again is left
/// out, which changes nothing at index `k`.
fn selection_network(n: usize, k: usize) -> Vec<(usize, usize)> {
    let mut live = vec![false; n];
    if k < n {
        live[k] = true;
    }
    let mut kept: Vec<(usize, usize)> = network(n)
        .into_iter()
        .rev()
        .filter(|&(a, b)| {
            let keep = live[a] || live[b];
            if keep {
                (live[a], live[b]) = (true, true);
            }
            keep
        })
        .collect();
    kept.reverse();
    kept
}

/// Output bytes each parallel task of [`median_bytes`] makes: many [`CHUNK`]s, so a task is
/// worth handing to another thread.
const TASK: usize = 64 * CHUNK;

/// For each byte position, the median of that byte over `bufs` (all the same length; at least
/// one): the element at index `n / 2` of the sorted values, as `select_nth_unstable(n / 2)`
/// picks it. Runs the comparators that element depends on ([`selection_network`]), over
/// stretches of the buffers in parallel.
pub(super) fn median_bytes(bufs: &[&[u8]]) -> Vec<u8> {
    use rayon::prelude::*;
    let n = bufs.len();
    let len = bufs.first().map_or(0, |b| b.len());
    let net = selection_network(n, n / 2);
    let mut out = vec![0u8; len];
    out.par_chunks_mut(TASK).enumerate().for_each_init(
        || vec![[0u8; CHUNK]; n],
        |rows, (t, task)| {
            for (c, dst) in task.chunks_mut(CHUNK).enumerate() {
                let start = t * TASK + c * CHUNK;
                let m = dst.len();
                for (row, buf) in rows.iter_mut().zip(bufs) {
                    row[..m].copy_from_slice(&buf[start..start + m]);
                }
                for &(a, b) in &net {
                    let (lo, hi) = rows.split_at_mut(b);
                    let (ra, rb) = (&mut lo[a], &mut hi[0]);
                    for (x, y) in ra.iter_mut().zip(rb.iter_mut()) {
                        let (s, l) = ((*x).min(*y), (*x).max(*y));
                        (*x, *y) = (s, l);
                    }
                }
                dst.copy_from_slice(&rows[n / 2][..m]);
            }
        },
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_network_sorts_every_small_size() {
        // Pseudo-random bytes with many ties, against a plain sort.
        let mut seed = 12345u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
            (seed >> 16) as u8 % 7 * 40
        };
        for n in 1..=40 {
            for _ in 0..50 {
                let mut v: Vec<u8> = (0..n).map(|_| next()).collect();
                let mut sorted = v.clone();
                sorted.sort_unstable();
                for (a, b) in network(n) {
                    let (s, l) = (v[a].min(v[b]), v[a].max(v[b]));
                    (v[a], v[b]) = (s, l);
                }
                assert_eq!(v, sorted, "n = {n}");
            }
        }
    }

    #[test]
    fn the_selection_network_finds_every_rank_of_every_small_size() {
        let mut seed = 777u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
            (seed >> 16) as u8 % 5 * 50
        };
        for n in 1..=40 {
            for k in [0, n / 2, n - 1] {
                let net = selection_network(n, k);
                assert!(net.len() <= network(n).len());
                for _ in 0..50 {
                    let mut v: Vec<u8> = (0..n).map(|_| next()).collect();
                    let mut sorted = v.clone();
                    sorted.sort_unstable();
                    for &(a, b) in &net {
                        let (s, l) = (v[a].min(v[b]), v[a].max(v[b]));
                        (v[a], v[b]) = (s, l);
                    }
                    assert_eq!(v[k], sorted[k], "n = {n}, k = {k}");
                }
            }
        }
    }

    #[test]
    fn medians_match_select_nth() {
        // Longer than one parallel task, and not a whole number of chunks.
        let bufs: Vec<Vec<u8>> = (0..25u32)
            .map(|f| {
                (0..(2 * TASK as u32 + 77))
                    .map(|i| ((i * 37 + f * f * 11) % 251) as u8)
                    .collect()
            })
            .collect();
        let refs: Vec<&[u8]> = bufs.iter().map(|b| b.as_slice()).collect();
        let got = median_bytes(&refs);
        for (i, &g) in got.iter().enumerate() {
            let mut col: Vec<u8> = bufs.iter().map(|b| b[i]).collect();
            assert_eq!(g, *col.select_nth_unstable(12).1, "byte {i}");
        }
    }
}
