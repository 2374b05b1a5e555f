//! Bone appearance models: the pixels of one limb segment (parent joint → child joint) on the
//! seed frame, stored in the bone's own frame so that they can be laid onto any later pose of
//! the bone (METHOD.md eq. 4.2, rotation resampling, applied to a whole segment instead of a
//! joint rectangle).
//!
//! A joint rectangle holds two limbs that turn differently (the upper arm and the forearm at
//! the elbow), so one rotated template never fits both. A bone is rigid: once its two end
//! joints are placed, every pixel of it is placed. A sample at `(t, e, v)` lies at
//! `A + t·(B − A) + e·û + v·n̂` for a bone from `A` to `B` with unit direction `û` and normal
//! `n̂ = (−û_y, û_x)`: `t` stretches with the bone (squash and stretch), `e` (px) extends it
//! beyond an end (the fist past the wrist), `v` (px) runs across it.
//!
//! The cost of a pose is the mean truncated squared RGB difference over the samples (eq. 4.6's
//! colour term made robust): a pixel covered by another limb, or a seed pixel that belonged to
//! something else, costs at most [`TRUNCATE`], so a partly hidden bone is still found by its
//! visible part.

use super::template::sample;
use crate::background::Background;
use crate::geom::{Point, Vector};
use image::RgbImage;

/// Largest squared RGB difference (levels², summed over channels) one sample may cost.
pub const TRUNCATE: f32 = 3.0 * 48.0 * 48.0;

/// Most samples used on the coarse search grid.
const COARSE_SAMPLES: usize = 48;
/// Most samples used in fine refinement.
const FINE_SAMPLES: usize = 320;

/// One seed pixel of a bone, in bone coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    t: f32,
    e: f32,
    v: f32,
    rgb: [f32; 3],
}

/// The seed appearance of the bone from joint `parent` to joint `child`.
#[derive(Debug, Clone, PartialEq)]
pub struct BoneModel {
    pub parent: usize,
    pub child: usize,
    /// Bone length on the seed frame (px).
    pub seed_len: f32,
    fine: Vec<Sample>,
    coarse: Vec<Sample>,
    /// Samples of the half of the bone nearest its parent end (`t ≤ 0.5`): this part moves
    /// with the parent joint and hardly depends on where the child end went.
    near_fine: Vec<Sample>,
    near_coarse: Vec<Sample>,
    /// Distinctiveness: mean cost of the seed appearance laid a few pixels off the seed pose,
    /// on the seed frame (at least a floor). Costs are judged as a share of it.
    pub distinct: f32,
    /// The same for the parent half alone, under whole-bone shifts.
    pub distinct_near: f32,
}

/// Which samples a cost uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Samples {
    /// All, thinned for a coarse grid.
    Coarse,
    /// All, for refinement.
    Fine,
    /// The parent half only, thinned.
    NearCoarse,
    /// The parent half only.
    NearFine,
}

impl Samples {
    /// The coarse or fine set of the same part.
    pub fn of(coarse: bool, near: bool) -> Samples {
        match (coarse, near) {
            (true, false) => Samples::Coarse,
            (false, false) => Samples::Fine,
            (true, true) => Samples::NearCoarse,
            (false, true) => Samples::NearFine,
        }
    }
}

/// Which end of a bone is being moved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    Parent,
    Child,
}

/// Distance (px) from `p` to the segment `a`–`b`.
fn segment_distance(p: Point, a: Point, b: Point) -> f32 {
    let d = b - a;
    let l2 = d.norm_squared();
    if l2 < 1e-6 {
        return (p - a).norm();
    }
    let t = ((p - a).dot(&d) / l2).clamp(0.0, 1.0);
    (p - (a + d * t)).norm()
}

/// Keeps at most `n` of `s`, evenly spread (deterministic).
fn thin(s: &[Sample], n: usize) -> Vec<Sample> {
    if s.len() <= n {
        return s.to_vec();
    }
    (0..n).map(|k| s[k * s.len() / n]).collect()
}

/// Geometry of a bone from `a` to `b`: origin, along-axis and across-axis (px per unit `t`,
/// unit `û`, unit `n̂`).
#[inline]
fn frame_of(a: Point, b: Point) -> (Vector, Vector, Vector) {
    let d = b - a;
    let l = d.norm().max(1e-3);
    let u = d / l;
    (d, u, Vector::new(-u.y, u.x))
}

impl BoneModel {
    /// Samples the bone `parent → child` from the seed frame. `centres` are all seed joint
    /// centres and `bones` every bone of the skeleton (a pixel goes to its nearest bone).
    /// `half_width` (px) bounds the samples across the bone; `ext` (px) extends the bone
    /// past the child end (for a leaf joint). Background pixels (per `bg`) are left out.
    /// Returns `None` for a bone shorter than 2 px or with too few foreground pixels.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        frame: &RgbImage,
        bg: Option<&Background>,
        centres: &[Point],
        bones: &[(usize, usize)],
        parent: usize,
        child: usize,
        half_width: f32,
        ext: f32,
        floor: f32,
    ) -> Option<BoneModel> {
        let (a, b) = (centres[parent], centres[child]);
        let len = (b - a).norm();
        if len < 2.0 {
            return None;
        }
        let (_, u, n) = frame_of(a, b);
        let (fw, fh) = (frame.width() as i32, frame.height() as i32);
        let r = len + ext + half_width + 1.0;
        let (x0, x1) = (((a.x.min(b.x) - r).floor() as i32).max(0), ((a.x.max(b.x) + r).ceil() as i32).min(fw - 1));
        let (y0, y1) = (((a.y.min(b.y) - r).floor() as i32).max(0), ((a.y.max(b.y) + r).ceil() as i32).min(fh - 1));
        let mut samples = Vec::new();
        for y in y0..=y1 {
            for x in x0..=x1 {
                let p = Point::new(x as f32, y as f32);
                let q = p - a;
                let (along, across) = (q.dot(&u), q.dot(&n));
                if along < 0.0 || along > len + ext || across.abs() > half_width {
                    continue;
                }
                if let Some(bg) = bg {
                    if !bg.is_foreground(frame, x as u32, y as u32) {
                        continue;
                    }
                }
                // A pixel clearly nearer another bone belongs to that one.
                let own = segment_distance(p, a, b + u * ext);
                let other = bones
                    .iter()
                    .filter(|&&(pa, pc)| (pa, pc) != (parent, child))
                    .map(|&(pa, pc)| segment_distance(p, centres[pa], centres[pc]))
                    .fold(f32::INFINITY, f32::min);
                if other + 0.5 < own {
                    continue;
                }
                let px = frame.get_pixel(x as u32, y as u32).0;
                let (t, e) = if along <= len {
                    (along / len, 0.0)
                } else {
                    (1.0, along - len)
                };
                samples.push(Sample {
                    t,
                    e,
                    v: across,
                    rgb: [px[0] as f32, px[1] as f32, px[2] as f32],
                });
            }
        }
        let near: Vec<Sample> = samples.iter().copied().filter(|s| s.t <= 0.5 && s.e == 0.0).collect();
        if samples.len() < 8 || near.len() < 4 {
            return None;
        }
        let mut m = BoneModel {
            near_coarse: thin(&near, COARSE_SAMPLES / 2),
            near_fine: thin(&near, FINE_SAMPLES / 2),
            parent,
            child,
            seed_len: len,
            coarse: thin(&samples, COARSE_SAMPLES),
            fine: thin(&samples, FINE_SAMPLES),
            distinct: 1.0,
            distinct_near: 1.0,
        };
        // Near misses: the whole bone shifted 3 px, and the child end swung 3 px sideways.
        let mut sum = 0.0;
        let mut near_sum = 0.0;
        for d in [
            Vector::new(3.0, 0.0),
            Vector::new(-3.0, 0.0),
            Vector::new(0.0, 3.0),
            Vector::new(0.0, -3.0),
        ] {
            sum += m.cost(frame, a + d, b + d, 1.0, Samples::Fine);
            near_sum += m.cost(frame, a + d, b + d, 1.0, Samples::NearFine);
        }
        m.distinct_near = (near_sum / 4.0).max(floor);
        sum += m.cost(frame, a, b + n * 3.0, 1.0, Samples::Fine);
        sum += m.cost(frame, a, b - n * 3.0, 1.0, Samples::Fine);
        m.distinct = (sum / 6.0).max(floor);
        Some(m)
    }

    /// Number of seed samples used in fine matching.
    pub fn samples(&self) -> usize {
        self.fine.len()
    }

    /// Mean truncated colour cost (normalised to [0, 1] by 3·255²) of the bone laid from `a`
    /// to `b` in `frame`, with the seed colours scaled by `gain`, over the sample set `which`.
    /// Samples outside the frame cost the truncation.
    pub fn cost(&self, frame: &RgbImage, a: Point, b: Point, gain: f32, which: Samples) -> f32 {
        let set = match which {
            Samples::Coarse => &self.coarse,
            Samples::Fine => &self.fine,
            Samples::NearCoarse => &self.near_coarse,
            Samples::NearFine => &self.near_fine,
        };
        let (d, u, n) = frame_of(a, b);
        let (fw, fh) = (frame.width() as f32 - 1.0, frame.height() as f32 - 1.0);
        let mut acc = 0.0f32;
        for s in set {
            let p = a + d * s.t + u * s.e + n * s.v;
            if p.x < 0.0 || p.y < 0.0 || p.x > fw || p.y > fh {
                acc += TRUNCATE;
                continue;
            }
            let c = sample(frame, p.x, p.y);
            let mut q = 0.0;
            for k in 0..3 {
                let diff = c[k] - gain * s.rgb[k];
                q += diff * diff;
            }
            acc += q.min(TRUNCATE);
        }
        acc / (set.len() as f32 * 3.0 * 255.0 * 255.0)
    }

    /// Like [`BoneModel::cost`] for the bone leaving `a` in direction `dir` at its seed length
    /// (no stretch): the parent half placed by its parent joint alone.
    pub fn cost_rigid(&self, frame: &RgbImage, a: Point, dir: Vector, gain: f32, which: Samples) -> f32 {
        let u = dir.try_normalize(1e-6).unwrap_or(Vector::new(1.0, 0.0));
        self.cost(frame, a, a + u * self.seed_len, gain, which)
    }

    /// Cost with one end at `p` and the other at `other` (`end` says which end `p` is).
    #[inline]
    pub fn cost_end(
        &self,
        frame: &RgbImage,
        end: End,
        p: Point,
        other: Point,
        gain: f32,
        coarse: bool,
    ) -> f32 {
        match end {
            End::Child => self.cost(frame, other, p, gain, Samples::of(coarse, false)),
            End::Parent => self.cost(frame, p, other, gain, Samples::of(coarse, false)),
        }
    }
}

/// The outcome of [`minimise`].
#[derive(Debug, Clone, Copy)]
pub struct Found {
    pub pos: Point,
    /// Fine cost at `pos`.
    pub cost: f32,
    /// Coarse cost at `pos` over the median coarse cost of the search grid: near 0 for a
    /// sharp, clear match, near 1 when nothing in the window stands out (occlusion).
    pub contrast: f32,
}

/// Minimises `cost(p, coarse)` over points within `radius` px of `centre`: a grid at `step` px
/// with the coarse cost, then the best few grid points refined by pattern search (steps
/// `step/2` down to 0.25 px) with the fine cost. Deterministic: ties keep the earlier candidate.
pub fn minimise(centre: Point, radius: f32, step: f32, cost: impl Fn(Point, bool) -> f32) -> Found {
    let k = (radius / step).ceil() as i32;
    let mut grid: Vec<(f32, Point)> = Vec::with_capacity(((2 * k + 1) * (2 * k + 1)) as usize);
    for iy in -k..=k {
        for ix in -k..=k {
            let off = Vector::new(ix as f32 * step, iy as f32 * step);
            if off.norm() <= radius + 1e-3 {
                let p = centre + off;
                grid.push((cost(p, true), p));
            }
        }
    }
    grid.sort_by(|a, b| a.0.total_cmp(&b.0));
    let median = grid[grid.len() / 2].0.max(1e-9);
    let mut best = (centre, f32::INFINITY);
    // Refine the three best grid points (distinct basins are common: two limbs alike).
    for &(_, start) in grid.iter().take(3) {
        let (p, c) = refine(start, step, &cost);
        if c < best.1 {
            best = (p, c);
        }
    }
    Found {
        pos: best.0,
        cost: best.1,
        contrast: cost(best.0, true) / median,
    }
}

/// Pattern search with the fine cost from `start`, step halving from `step/2` to 0.25 px.
pub fn refine(start: Point, step: f32, cost: &impl Fn(Point, bool) -> f32) -> (Point, f32) {
    let mut p = start;
    let mut c = cost(p, false);
    let mut s = (step / 2.0).max(0.25);
    loop {
        let mut moved = false;
        for (dx, dy) in [
            (1.0, 0.0),
            (-1.0, 0.0),
            (0.0, 1.0),
            (0.0, -1.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (1.0, -1.0),
            (-1.0, 1.0),
        ] {
            let q = p + Vector::new(dx * s, dy * s);
            let cq = cost(q, false);
            if cq < c {
                c = cq;
                p = q;
                moved = true;
            }
        }
        if !moved {
            if s <= 0.25 {
                break;
            }
            s /= 2.0;
        }
    }
    (p, c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    /// A frame with a striped bar from (20, 30) to (60, 30), 6 px wide, on grey.
    fn bar_frame(a: Point, b: Point) -> RgbImage {
        let mut img = RgbImage::from_pixel(100, 80, Rgb([90, 90, 90]));
        for y in 0..80 {
            for x in 0..100 {
                let p = Point::new(x as f32, y as f32);
                if segment_distance(p, a, b) <= 3.0 {
                    let t = (p - a).dot(&(b - a)) / (b - a).norm_squared();
                    let c = if (t * 8.0) as i32 % 2 == 0 { 220 } else { 30 };
                    img.put_pixel(x, y, Rgb([c, 40, 255 - c]));
                }
            }
        }
        img
    }

    #[test]
    fn finds_a_turned_bone_end() {
        let (a, b) = (Point::new(20.0, 30.0), Point::new(60.0, 30.0));
        let seed = bar_frame(a, b);
        let centres = [a, b];
        let m = BoneModel::new(&seed, None, &centres, &[(0, 1)], 0, 1, 3.0, 0.0, 0.001).unwrap();
        assert!(m.distinct > 0.01, "{}", m.distinct);
        // The bar turned by 20° about `a`.
        let ang = 20f32.to_radians();
        let b2 = a + Vector::new(ang.cos(), ang.sin()) * 40.0;
        let frame = bar_frame(a, b2);
        let f = minimise(b, 16.0, 2.0, |p, coarse| {
            m.cost_end(&frame, End::Child, p, a, 1.0, coarse)
        });
        assert!((f.pos - b2).norm() < 1.0, "{f:?} vs {b2:?}");
        assert!(f.cost < 0.3 * m.distinct, "cost {} distinct {}", f.cost, m.distinct);
        assert!(f.contrast < 0.3, "{f:?}");
    }
}
