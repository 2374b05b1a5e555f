//! Bone strips: the seed appearance of one bone (parent joint → child joint), stored in the
//! bone's own coordinates so that it can be laid onto any later pose of the bone (docs/method.md
//! §2.2, eq. 4: the pixels resampled turned and stretched with the whole limb segment rather
//! than with a joint rectangle).
//!
//! A joint rectangle holds two limbs that turn differently (upper arm and forearm at the elbow),
//! so one rotated template never fits both; a bone is rigid up to stretch. A sample at
//! `(t, e, v)` lies at `P + t·(C − P) + e·û + v·n̂` for a bone from `P` to `C` with unit direction
//! `û` and normal `n̂ = (−û_y, û_x)`: `t ∈ [0, 1]` stretches with the bone (squash and stretch),
//! `e` (px) reaches past an end (a hand past the wrist, the hips below the pelvis) without
//! stretching, `v` (px) runs across. A joint without any bone (a lone root) gets a
//! [`Shape::Patch`] instead: its seed rectangle, translated but never turned.
//!
//! Costs are a robust colour difference (docs/method.md eq. 5): per sample
//! `e = |I(x) − g·T|² / (3σ²)` (`g` the frame's brightness gain, `σ` the strip's colour scale in
//! levels per channel), through the bounded Geman–McClure penalty `ρ(e) = e / (1 + e)`. A pixel
//! of another limb costs at most 1, so a partly hidden bone is still placed by its visible part,
//! and the share of samples that fit ([`Fit::inliers`]) says how much of it is seen.
//!
//! Each sample also carries a reliability learnt as the clip goes ([`Strip::learn`]): a seed
//! pixel that turns out to move with another bone (the torso showing where the far arm is
//! hidden behind it on the seed frame) fades out of every cost.

use super::pixels::{Level, Rgb, MAX_LEVELS};
use crate::geom::{Point, Vector};

mod cost;
mod learn;
mod sample;
#[cfg(target_arch = "x86_64")]
mod simd;
#[cfg(target_arch = "x86_64")]
mod simd_normal;

/// What a strip is matched against: one pyramid level of the frame, the same level of the
/// clean plate when there is one, and the frame's brightness gain over the plate.
#[derive(Clone, Copy)]
pub struct View<'a> {
    pub img: Level<'a>,
    pub plate: Option<Level<'a>>,
    pub gain: f32,
    /// `1 / (3 (2σ_n)²)` for the clip's noise σ_n per channel: a frame pixel within 2σ_n (rms
    /// over channels) of gain × plate looks like background.
    pub bg_inv: f32,
}

impl View<'_> {
    /// Whether the frame colour `col` at `(x, y)` (px) is explained by the clean plate there: such
    /// a pixel is no evidence for any limb (a flesh-coloured hand against a sky of the same
    /// colour), whatever the template says.
    #[inline(always)]
    fn looks_background(&self, x: f32, y: f32, col: Rgb) -> bool {
        let Some(plate) = &self.plate else {
            return false;
        };
        plate
            .bilinear(x, y)
            .is_some_and(|b| self.matches_plate(col, b))
    }

    /// Whether the frame colour `col` is within the noise of the plate colour `b` (see
    /// [`View::looks_background`]).
    #[inline(always)]
    fn matches_plate(&self, col: Rgb, b: Rgb) -> bool {
        let d: f32 = (0..3).map(|k| (col[k] - self.gain * b[k]).powi(2)).sum();
        d * self.bg_inv < 1.0
    }
}

/// Squared normalised residual below which a sample counts as fitting.
pub const INLIER_E: f32 = 2.5;

/// Residuals `e` below which a sample's pixel is checked against the clean plate (above, the
/// sample costs over 0.9 of a misfit anyway).
const PLATE_CHECK_E: f32 = 9.0;

/// A bone learns its [`Strip::seen_stretch`] on frames where at least this share of what
/// typically fits does.
const CLEAR_SHARE: f32 = 0.8;

/// Most other strips a sample is checked against in [`Strip::learn`].
const ALTERNATIVES: usize = 2;

/// What a strip's samples hang on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// A bone from joint `parent` to joint `child`.
    Bone,
    /// The rectangle of the lone joint `parent` (`child == parent`).
    Patch,
}

/// Where a strip lies on the seed frame: its bone from `a` to `b`, how far it reaches past each
/// end and across. A pixel belongs to the strip whose (extended) segment is nearest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extent {
    pub a: Point,
    pub b: Point,
    /// Reach (px) past `a` and past `b`.
    pub ext_a: f32,
    pub ext_b: f32,
    /// Half-width (px) across.
    pub half_width: f32,
}

impl Extent {
    /// Unit direction and length (px) of the bone.
    fn axis(&self) -> (Vector, f32) {
        let d = self.b - self.a;
        let len = d.norm();
        (
            if len > 1e-6 {
                d / len
            } else {
                Vector::new(1.0, 0.0)
            },
            len,
        )
    }

    /// Distance (px) from `p` to the extended segment.
    pub fn distance(&self, p: Point) -> f32 {
        let (u, len) = self.axis();
        let s = (p - self.a).dot(&u).clamp(-self.ext_a, len + self.ext_b);
        (p - (self.a + u * s)).norm()
    }

    /// The strip coordinates `(t, e, v)` of `p`, if it lies within the strip.
    pub fn coords(&self, p: Point) -> Option<(f32, f32, f32)> {
        let (u, len) = self.axis();
        let d = p - self.a;
        let (s, v) = (d.dot(&u), u.x * d.y - u.y * d.x);
        if v.abs() > self.half_width || s < -self.ext_a || s > len + self.ext_b {
            return None;
        }
        let (t, e) = split_along(s, len);
        Some((t, e, v))
    }
}

/// `(t, e)` of a point `s` px along a bone of length `len`: `t` clamped to `[0, 1]`, `e` the rest.
fn split_along(s: f32, len: f32) -> (f32, f32) {
    if s < 0.0 || len < 1e-6 {
        (0.0, s)
    } else if s > len {
        (1.0, s - len)
    } else {
        (s / len, 0.0)
    }
}

/// How a strip's samples land for a pose: `x = o + t·a + e·u + v·n`.
#[derive(Debug, Clone, Copy)]
pub struct Placement {
    o: Vector,
    a: Vector,
    u: Vector,
    n: Vector,
    /// Length (px) of the bone, for Jacobians.
    len: f32,
    /// Width factor ω = (L₀ / L)^γ: the limb thins as it stretches (see
    /// [`StripSpec::width_exponent`]); `e` and `v` are scaled by it.
    w: f32,
}

impl Placement {
    /// Image position (px) of sample `(t, e, v)`.
    #[inline(always)]
    pub fn at(&self, t: f32, e: f32, v: f32) -> (f32, f32) {
        let (e, v) = (e * self.w, v * self.w);
        (
            self.o.x + t * self.a.x + e * self.u.x + v * self.n.x,
            self.o.y + t * self.a.y + e * self.u.y + v * self.n.y,
        )
    }
}

/// Statistics of a strip laid at a pose.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Fit {
    /// Mean robust cost per sample, 0 (perfect) to 1 (nothing fits).
    pub cost: f32,
    /// Share of samples that fit (`e <` [`INLIER_E`]), 0 to 1.
    pub inliers: f32,
    /// Share of fitting samples in the half of the strip at the parent end, weighted towards the
    /// end, 0 to 1.
    pub parent_end: f32,
    /// The same at the child end.
    pub child_end: f32,
    /// Weight of the samples behind `parent_end` and `child_end` (end-weighted sample counts).
    pub parent_mass: f32,
    pub child_mass: f32,
    /// 40th percentile of the samples' colour residuals, levels per channel (rms over
    /// channels): the noise level, when most of the bone fits.
    pub residual: f32,
}

/// Normal equations of one strip's data term for a Gauss–Newton step, in the four coordinates
/// `(P.x, P.y, C.x, C.y)` (a patch uses the first two).
#[derive(Debug, Clone, Copy, Default)]
pub struct Normal {
    pub h: [[f64; 4]; 4],
    pub g: [f64; 4],
    pub cost: f64,
}

/// One seed pixel of a strip.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    t: f32,
    e: f32,
    v: f32,
    /// Position along the strip as a share of the seed bone (`t + e / L`), for the end levers.
    f: f32,
    /// Other strips this pixel could belong to, with its coordinates in them (strip index
    /// `u32::MAX`: none).
    alt: [(u32, f32, f32, f32); ALTERNATIVES],
    /// The seed pixel looked like the clean plate there: background showing, unless the plate
    /// itself holds the character (a subject that hardly moves), so it has to earn its weight.
    background: bool,
}

/// How many coarse samples [`Strip::coarse_cost`] reads side by side (one [`Coarse`] block).
const LANES: usize = 8;

/// [`LANES`] coarse samples as [`Strip::coarse_cost`] reads them, field by field so that their
/// arithmetic runs side by side: strip coordinates, weight and template colour per level and
/// channel. The last block of a strip is padded with zeros.
#[derive(Debug, Clone, Copy, Default)]
struct Coarse {
    t: [f32; LANES],
    e: [f32; LANES],
    v: [f32; LANES],
    w: [f32; LANES],
    template: [[[f32; LANES]; 3]; MAX_LEVELS],
}

/// The appearance of one bone (or lone joint).
#[derive(Debug, Clone)]
pub struct Strip {
    pub shape: Shape,
    pub parent: usize,
    pub child: usize,
    /// Where the strip lies on the seed frame.
    pub extent: Extent,
    samples: Vec<Sample>,
    /// Seed colour of each sample, per pyramid level.
    anchor: Vec<[Rgb; MAX_LEVELS]>,
    /// Running colour of each sample (updated on confident frames), per level.
    running: Vec<[Rgb; MAX_LEVELS]>,
    /// The colour matched: `anchor_weight`·anchor + the rest running, per level.
    template: Vec<[Rgb; MAX_LEVELS]>,
    /// Reliability of each sample, 0 to 1 (see [`Strip::learn`]).
    rel: Vec<f32>,
    /// Every `coarse_step`-th sample is used in the coarse search.
    coarse_step: usize,
    /// Those of the coarse samples that carry weight, with their weight and template, in
    /// blocks of [`LANES`]: what [`Strip::coarse_cost`] reads. Kept in step with `rel` and
    /// `template` by [`Strip::refresh_coarse`].
    coarse: Vec<Coarse>,
    /// Number of samples in `coarse` (the last block may hold fewer than [`LANES`]).
    coarse_len: usize,
    /// Sum of the weights of `coarse`, in its order.
    coarse_weight: f32,
    /// [`Strip::weight_sum`], kept by [`Strip::refresh_coarse`] (the refinement asks for it on
    /// every step).
    weight_total: f32,
    /// Colour scale σ (levels per channel) of the robust cost.
    pub sigma: f32,
    /// Share of samples that fit at the parent and the child end on frames where the bone is
    /// seen (an average): what "fully seen" looks like for this bone in this clip.
    pub typical: (f32, f32),
    /// Coarse cost ([`Strip::coarse_cost`]) per pyramid level on frames where the bone is
    /// seen (an average): what "in place" costs for this bone in this clip.
    pub typical_cost: [f32; MAX_LEVELS],
    /// Bone length on the seed frame (px).
    seed_len: f32,
    /// Shortest and longest this bone has been seen, as multiples of `seed_len`, over the
    /// frames it learnt from with most of it fitting: how far it squashes and stretches in
    /// this clip (hidden bones are looked for within that range).
    pub seen_stretch: (f32, f32),
    /// See [`StripSpec::width_exponent`].
    width_exponent: f32,
    /// Whether the clean plate may speak against this strip's samples: not where it holds the
    /// character itself (see [`Strip::sample`]).
    trust_plate: bool,
    /// Laid mirrored across the bone's axis (`v` → `−v`): a character that turned round shows
    /// its limbs from the other side.
    pub mirrored: bool,
}

/// How to sample a strip on the seed frame.
#[derive(Debug, Clone, Copy)]
pub struct StripSpec {
    /// Most samples kept.
    pub max_samples: usize,
    /// Most samples used in the coarse search.
    pub coarse_samples: usize,
    /// Initial colour scale (levels per channel).
    pub sigma: f32,
    /// How the limb's width follows its length: ×(L₀/L)^γ. 0: rigid width (real limbs,
    /// foreshortening); 0.5: the width of a cartoon squash-and-stretch that keeps its volume in
    /// depth; 1: area kept in the image plane (as docs/method.md §5.5's needle model keeps it).
    pub width_exponent: f32,
}

impl Strip {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Bone length (px) on the frame the strip was sampled on.
    pub fn seed_len(&self) -> f32 {
        self.seed_len
    }

    /// Whether the strip has no samples (never true for a strip from [`Strip::sample`]).
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Where the samples land for the parent joint at `p` and the child at `c`.
    #[inline]
    pub fn placement(&self, p: Point, c: Point) -> Placement {
        self.placement_as(p, c, self.mirrored)
    }

    /// [`Strip::placement`], mirrored or not as asked.
    pub fn placement_as(&self, p: Point, c: Point, mirrored: bool) -> Placement {
        match self.shape {
            Shape::Patch => Placement {
                o: p.coords,
                a: Vector::zeros(),
                u: Vector::new(0.0, 1.0),
                n: Vector::new(1.0, 0.0),
                len: 1.0,
                w: 1.0,
            },
            Shape::Bone => {
                let d = c - p;
                let len = d.norm().max(1e-3);
                let u = d / len;
                let w = if self.width_exponent == 0.0 {
                    1.0
                } else {
                    pow_cached(self.seed_len / len, self.width_exponent)
                };
                Placement {
                    o: p.coords,
                    a: d,
                    u,
                    n: Vector::new(-u.y, u.x) * if mirrored { -1.0 } else { 1.0 },
                    len,
                    w,
                }
            }
        }
    }

    /// Weight of sample `k` in every cost: its reliability, with samples that fit less than a
    /// third of the time left out.
    #[inline(always)]
    fn weight(&self, k: usize) -> f32 {
        ((self.rel[k] - 0.33) * 1.5).clamp(0.0, 1.0)
    }

    /// Sum of the sample weights (at least 1), as of the last [`Strip::refresh_coarse`].
    fn weight_sum(&self) -> f32 {
        self.weight_total
    }

    /// [`Strip::weight_sum`] summed afresh, in sample order.
    fn sum_weights(&self) -> f32 {
        (0..self.samples.len())
            .map(|k| self.weight(k))
            .sum::<f32>()
            .max(1.0)
    }

    /// `1 / (3σ²)`.
    #[inline]
    fn inv_scale(&self) -> f32 {
        1.0 / (3.0 * self.sigma * self.sigma)
    }
}

/// `x.powf(y)`, remembered per thread for the last arguments that fell in each of 64 slots: a
/// search lays the same strips at the same lengths again and again (a translation moves both
/// ends by the same offset, usually without rounding the difference), and `powf` was 3 % of
/// a dance run. The value is `powf`'s to the bit (a pure function); slot 0 starts as
/// `powf(+0, +0) = 1`.
#[inline]
fn pow_cached(x: f32, y: f32) -> f32 {
    use std::cell::Cell;
    thread_local! {
        static SLOTS: [Cell<(u64, f32)>; 64] = const { [const { Cell::new((0, 1.0)) }; 64] };
    }
    let key = (x.to_bits() as u64) << 32 | y.to_bits() as u64;
    let b = x.to_bits();
    let slot = ((b ^ (b >> 6) ^ (b >> 12) ^ (b >> 18)) & 63) as usize;
    SLOTS.with(|s| {
        let (k, v) = s[slot].get();
        if k == key {
            return v;
        }
        let v = x.powf(y);
        s[slot].set((key, v));
        v
    })
}

#[cfg(test)]
mod tests;
