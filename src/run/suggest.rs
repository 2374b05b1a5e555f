//! Which frames to key next (docs/method.md, "Frames worth keying"): the set of frames that leaves
//! the least doubt over the clip, given the report's evidence of far-off joints frame by frame
//! and the keys the user has placed already.
//!
//! A path between two keys is pinned at both (see [`crate::run::keyed`]): how far it can stray
//! on a frame grows with the distance from the keys, like a random walk's held at both ends,
//! whose spread on frame `t` between keys on `a` and `b` is `√((t − a)(b − t)/(b − a))`; before
//! the first key and after the last it is `√` of the distance to it. A frame's doubt is that
//! spread times its need, and the suggested keys are the `k` frames that make the clip's doubt
//! smallest, found exactly by dynamic programming over the frames (over cells of frames on long
//! clips, see [`MAX_CELLS`]). Where the evidence is the same everywhere (a tracker lost all
//! along) the keys come out evenly spaced; where it gathers, they gather.

/// Share of the clip's mean need that every frame carries on top of its own: quiet evidence is
/// no proof that the tracker is right (on the dance, about 9 % of the joint-frames called `ok`
/// after keying are more than 20 px off), so a long quiet stretch still earns a key when there
/// are keys to spare.
pub const QUIET_NEED: f64 = 0.05;

/// Most cells the frames are grouped into: up to this many frames each frame is a cell (and a
/// place a key can go); a longer clip is cut into this many cells of equal length, a key going
/// on a cell's middle frame. The search costs about `MAX_CELLS³ / 6` steps.
pub const MAX_CELLS: usize = 600;

/// Up to `k` frames worth keying, most worth first: `need` is each frame's evidence (about how
/// many of its joints are far off), in frame order; `keyed` are the frames the user has keyed
/// already (seeds, corrected segment files, `keys.toml`). Nothing is suggested when no frame
/// has any need. A frame's worth is how much the clip's doubt (see the module docs) would grow
/// without it, the others kept.
pub fn suggest(need: &[(u64, f32)], keyed: &[u64], k: usize) -> Vec<u64> {
    let (first, last) = match (need.first(), need.last()) {
        (Some(a), Some(b)) if b.0 >= a.0 => (a.0, b.0),
        _ => return Vec::new(),
    };
    let total: f64 = need.iter().map(|&(_, n)| n.max(0.0) as f64).sum();
    if k == 0 || total <= 0.0 {
        return Vec::new();
    }
    let cells = Cells::new(need, first, last, total);
    // The places a key can go: each cell's middle frame, and the keys already placed.
    let mut places: Vec<(u64, bool)> = cells.mid.iter().map(|&f| (f, false)).collect();
    let mut kept: Vec<u64> = keyed
        .iter()
        .copied()
        .filter(|f| (first..=last).contains(f))
        .collect();
    kept.sort_unstable();
    kept.dedup();
    places.retain(|p| kept.binary_search(&p.0).is_err());
    places.extend(kept.iter().map(|&f| (f, true)));
    places.sort_unstable();
    let free = places.iter().filter(|p| !p.1).count();
    let k = k.min(free);
    if k == 0 {
        return Vec::new();
    }
    let chosen = cheapest(&cells, &places, k);
    let all: Vec<u64> = {
        let mut v: Vec<u64> = chosen.iter().copied().chain(kept.iter().copied()).collect();
        v.sort_unstable();
        v
    };
    let whole = cells.doubt(&all);
    let mut worth: Vec<(f64, u64)> = chosen
        .iter()
        .map(|&f| {
            let without: Vec<u64> = all.iter().copied().filter(|&g| g != f).collect();
            (cells.doubt(&without) - whole, f)
        })
        .collect();
    worth.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    worth.into_iter().map(|(_, f)| f).collect()
}

/// The frames grouped into cells: each cell's weight (its frames' need, each raised by
/// [`QUIET_NEED`] of the mean) sits at its middle frame.
struct Cells {
    mid: Vec<u64>,
    weight: Vec<f64>,
}

impl Cells {
    fn new(need: &[(u64, f32)], first: u64, last: u64, total: f64) -> Cells {
        let frames = (last - first + 1) as usize;
        let size = frames.div_ceil(MAX_CELLS);
        let count = frames.div_ceil(size);
        let floor = QUIET_NEED * total / frames as f64;
        let bounds = |c: usize| (c * size, ((c + 1) * size).min(frames));
        let mut weight: Vec<f64> = (0..count)
            .map(|c| {
                let (lo, hi) = bounds(c);
                floor * (hi - lo) as f64
            })
            .collect();
        let mid: Vec<u64> = (0..count)
            .map(|c| {
                let (lo, hi) = bounds(c);
                first + ((lo + hi - 1) / 2) as u64
            })
            .collect();
        for &(f, n) in need {
            if (first..=last).contains(&f) {
                weight[(f - first) as usize / size] += n.max(0.0) as f64;
            }
        }
        Cells { mid, weight }
    }

    /// The doubt of the cells between keys on frames `a` and `b` (either end `None`: the clip's
    /// start or end, the stretch tracked from one key only).
    fn between(&self, a: Option<u64>, b: Option<u64>) -> f64 {
        let lo = a.map_or(0, |a| self.mid.partition_point(|&m| m <= a));
        let hi = b.map_or(self.mid.len(), |b| self.mid.partition_point(|&m| m < b));
        let mut sum = 0.0;
        for c in lo..hi {
            let t = self.mid[c] as f64;
            let spread = match (a, b) {
                (Some(a), Some(b)) => {
                    let (a, b) = (a as f64, b as f64);
                    ((t - a) * (b - t) / (b - a)).sqrt()
                }
                (Some(a), None) => (t - a as f64).sqrt(),
                (None, Some(b)) => (b as f64 - t).sqrt(),
                (None, None) => return f64::INFINITY,
            };
            sum += self.weight[c] * spread;
        }
        sum
    }

    /// The clip's doubt with keys on `keys` (sorted).
    fn doubt(&self, keys: &[u64]) -> f64 {
        let mut sum = self.between(None, keys.first().copied());
        for w in keys.windows(2) {
            sum += self.between(Some(w[0]), Some(w[1]));
        }
        sum + self.between(keys.last().copied(), None)
    }
}

/// The `k` free places (`(frame, already keyed)`, in frame order) that, with every place
/// already keyed, leave the least doubt: `best[n][i]` is the least doubt up to a key on place
/// `i` with `n` free places chosen, no key skipped on the way.
fn cheapest(cells: &Cells, places: &[(u64, bool)], k: usize) -> Vec<u64> {
    let m = places.len();
    let fresh = |i: usize| usize::from(!places[i].1);
    let first_kept = places.iter().position(|p| p.1).unwrap_or(m);
    let last_kept = places.iter().rposition(|p| p.1);
    let mut best = vec![vec![f64::INFINITY; m]; k + 1];
    let mut from = vec![vec![usize::MAX; m]; k + 1];
    for i in 0..m.min(first_kept + 1) {
        if fresh(i) <= k {
            best[fresh(i)][i] = cells.between(None, Some(places[i].0));
        }
    }
    for i in 0..m {
        // The doubt between place `i` and each later one up to the next kept key (which cannot
        // be skipped).
        let mut span = Vec::new();
        for j in i + 1..m {
            span.push(cells.between(Some(places[i].0), Some(places[j].0)));
            if places[j].1 {
                break;
            }
        }
        for n in 0..=k {
            let here = best[n][i];
            if !here.is_finite() {
                continue;
            }
            for (d, &cost) in span.iter().enumerate() {
                let j = i + 1 + d;
                let n2 = n + fresh(j);
                if n2 <= k && here + cost < best[n2][j] {
                    best[n2][j] = here + cost;
                    from[n2][j] = i;
                }
            }
        }
    }
    let end = (last_kept.unwrap_or(0)..m)
        .filter(|&i| best[k][i].is_finite())
        .min_by(|&a, &b| {
            let da = best[k][a] + cells.between(Some(places[a].0), None);
            let db = best[k][b] + cells.between(Some(places[b].0), None);
            da.total_cmp(&db).then(a.cmp(&b))
        });
    let mut chosen = Vec::with_capacity(k);
    let (mut i, mut n) = match end {
        Some(i) => (i, k),
        None => return chosen,
    };
    loop {
        if !places[i].1 {
            chosen.push(places[i].0);
        }
        let prev = from[n][i];
        if prev == usize::MAX {
            break;
        }
        n -= fresh(i);
        i = prev;
    }
    chosen.reverse();
    chosen
}

#[cfg(test)]
mod tests;
