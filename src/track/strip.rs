//! Bone strips: the seed appearance of one bone (parent joint → child joint), stored in the
//! bone's own coordinates so that it can be laid onto any later pose of the bone (METHOD.md
//! eq. 4.2, rotation resampling, applied to the whole limb segment rather than to a joint
//! rectangle).
//!
//! A joint rectangle holds two limbs that turn differently (upper arm and forearm at the elbow),
//! so one rotated template never fits both; a bone is rigid up to stretch. A sample at
//! `(t, e, v)` lies at `P + t·(C − P) + e·û + v·n̂` for a bone from `P` to `C` with unit direction
//! `û` and normal `n̂ = (−û_y, û_x)`: `t ∈ [0, 1]` stretches with the bone (squash and stretch),
//! `e` (px) reaches past an end (a hand past the wrist, the hips below the pelvis) without
//! stretching, `v` (px) runs across. A joint without any bone (a lone root) gets a
//! [`Shape::Patch`] instead: its seed rectangle, translated but never turned.
//!
//! Costs are eq. 4.1's colour difference made robust: per sample `e = |I(x) − g·T|² / (3σ²)`
//! (`g` the frame's brightness gain, `σ` the strip's colour scale in levels per channel),
//! through the bounded Geman–McClure penalty `ρ(e) = e / (1 + e)`. A pixel of another limb costs
//! at most 1, so a partly hidden bone is still placed by its visible part, and the share of
//! samples that fit ([`Fit::inliers`]) says how much of it is seen.
//!
//! Each sample also carries a reliability learnt as the clip goes ([`Strip::learn`]): a seed
//! pixel that turns out to move with another bone (the torso showing where the far arm is
//! hidden behind it on the seed frame) fades out of every cost.

use super::pixels::{Level, Pyramid, Rgb, MAX_LEVELS};

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
use crate::geom::{Point, Vector};

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

/// Squared normalised residual `e` of the colour `col` against the template colour `t`.
#[inline(always)]
fn residual(t: &Rgb, col: Rgb, gain: f32, inv: f32) -> f32 {
    let (d0, d1, d2) = (
        col[0] - gain * t[0],
        col[1] - gain * t[1],
        col[2] - gain * t[2],
    );
    (d0 * d0 + d1 * d1 + d2 * d2) * inv
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

/// A coarse sample as [`Strip::coarse_cost`] reads it: its strip coordinates, weight and
/// template colour per level.
#[derive(Debug, Clone, Copy)]
struct Coarse {
    t: f32,
    e: f32,
    v: f32,
    w: f32,
    template: [Rgb; MAX_LEVELS],
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
    /// Those of the coarse samples that carry weight, with their weight and template: what
    /// [`Strip::coarse_cost`] reads, one contiguous list instead of four. Kept in step with
    /// `rel` and `template` by [`Strip::refresh_coarse`].
    coarse: Vec<Coarse>,
    /// Sum of the weights of `coarse`, in its order.
    coarse_weight: f32,
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
    /// depth; 1: area kept in the image plane (METHOD.md §4's needle model).
    pub width_exponent: f32,
}

impl Strip {
    /// Samples the strip `extent` of the bone `parent → child` on the seed frame (for
    /// `Shape::Patch`, the rectangle `2·ext_a × 2·half_width` around `extent.a`, `child ==
    /// parent`). A pixel is kept when, for a bone, no extent of `others` is nearer to it.
    /// `background(x, y)` says whether the seed pixel looks like the clean plate: such samples
    /// get no weight, unless most of the bone's axis looks like the plate (then the plate is
    /// wrong there, and no sample is taken for background). Returns `None` when fewer than 8
    /// samples remain.
    pub fn sample(
        frame: &Pyramid,
        shape: Shape,
        (parent, child): (usize, usize),
        extent: Extent,
        spec: &StripSpec,
        others: &[Extent],
        background: &dyn Fn(f32, f32) -> bool,
    ) -> Option<Strip> {
        let (_, len) = extent.axis();
        let mut strip = Strip {
            shape,
            parent,
            child,
            extent,
            samples: Vec::new(),
            anchor: Vec::new(),
            running: Vec::new(),
            template: Vec::new(),
            rel: Vec::new(),
            coarse_step: 1,
            coarse: Vec::new(),
            coarse_weight: 0.0,
            sigma: spec.sigma,
            typical: (1.0, 1.0),
            typical_cost: [0.5; MAX_LEVELS],
            seed_len: len,
            seen_stretch: (1.0, 1.0),
            width_exponent: if shape == Shape::Bone {
                spec.width_exponent
            } else {
                0.0
            },
            trust_plate: true,
            mirrored: false,
        };
        let (lo, hi) = match shape {
            Shape::Bone => (-extent.ext_a, len + extent.ext_b),
            Shape::Patch => (-extent.ext_a, extent.ext_a),
        };
        let across = extent.half_width;
        let area = (hi - lo) * 2.0 * across;
        let step = (area / spec.max_samples as f32).sqrt().max(1.0);
        let place = strip.placement(extent.a, extent.b);
        let n_along = ((hi - lo) / step).floor() as i32;
        let m = (across / step).floor() as i32;
        let no_alt = (u32::MAX, 0.0, 0.0, 0.0);
        for i in 0..=n_along {
            let s = lo + i as f32 * step;
            let (t, e) = match shape {
                Shape::Bone => split_along(s, len),
                Shape::Patch => (0.0, s),
            };
            for k in -m..=m {
                let v = k as f32 * step;
                let (x, y) = place.at(t, e, v);
                let q = Point::new(x, y);
                if shape == Shape::Bone {
                    let d = extent.distance(q);
                    if others.iter().any(|o| o.distance(q) < d) {
                        continue;
                    }
                }
                let mut rgb = [[0.0; 3]; MAX_LEVELS];
                let mut inside = true;
                for (k, c) in rgb.iter_mut().enumerate().take(frame.levels()) {
                    match frame.level(k).bilinear(x, y) {
                        Some(v) => *c = v,
                        None => inside = false,
                    }
                }
                if inside {
                    strip.samples.push(Sample {
                        t,
                        e,
                        v,
                        f: if len > 1e-3 { s / len } else { 0.5 },
                        alt: [no_alt; ALTERNATIVES],
                        background: background(x, y),
                    });
                    strip.anchor.push(rgb);
                }
            }
        }
        if strip.samples.len() < 8 {
            return None;
        }
        strip.running = strip.anchor.clone();
        strip.template = strip.anchor.clone();
        // The bone's own axis must be foreground: where the plate says it is background, the
        // plate holds the character (it hardly moved over the sampled frames), and is not
        // trusted along this strip.
        let core: Vec<bool> = strip
            .samples
            .iter()
            .filter(|s| s.v.abs() <= 2.0 && s.e == 0.0)
            .map(|s| s.background)
            .collect();
        if core.len() >= 4 && core.iter().filter(|&&b| b).count() * 2 > core.len() {
            for s in &mut strip.samples {
                s.background = false;
            }
            strip.trust_plate = false;
        }
        strip.rel = strip
            .samples
            .iter()
            .map(|s| if s.background { 0.0 } else { 1.0 })
            .collect();
        strip.coarse_step = strip.samples.len().div_ceil(spec.coarse_samples.max(1));
        strip.refresh_coarse();
        Some(strip)
    }

    /// Remakes the list of weighted coarse samples from the reliabilities and templates; call
    /// after changing either.
    fn refresh_coarse(&mut self) {
        self.coarse.clear();
        self.coarse_weight = 0.0;
        let mut k = 0;
        while k < self.samples.len() {
            let w = self.weight(k);
            if w > 0.0 {
                let s = &self.samples[k];
                self.coarse.push(Coarse {
                    t: s.t,
                    e: s.e,
                    v: s.v,
                    w,
                    template: self.template[k],
                });
                self.coarse_weight += w;
            }
            k += self.coarse_step;
        }
    }

    /// Records, for every sample, the other bone strips (`strips`, this one's index `me`) whose
    /// extent holds its seed position, nearest first, so that [`Strip::learn`] can tell a pixel
    /// of another bone from a hidden one of this bone.
    pub fn link(&mut self, me: usize, strips: &[Extent]) {
        let place = self.placement(self.extent.a, self.extent.b);
        for s in &mut self.samples {
            let (x, y) = place.at(s.t, s.e, s.v);
            let q = Point::new(x, y);
            let mut found: Vec<(f32, u32, (f32, f32, f32))> = strips
                .iter()
                .enumerate()
                .filter(|&(k, _)| k != me)
                .filter_map(|(k, ext)| Some((ext.distance(q), k as u32, ext.coords(q)?)))
                .collect();
            found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            for (slot, (_, k, (t, e, v))) in s.alt.iter_mut().zip(found) {
                *slot = (k, t, e, v);
            }
        }
    }

    /// Diagnostics: every sample's image position (px) at the pose `(p, c)`, its squared
    /// normalised residual `e` (infinite outside the frame) and its weight.
    pub fn probe(&self, v: &View, p: Point, c: Point) -> Vec<(f32, f32, f32, f32)> {
        let place = self.placement(p, c);
        let inv = self.inv_scale();
        (0..self.samples.len())
            .map(|k| {
                let s = &self.samples[k];
                let (x, y) = place.at(s.t, s.e, s.v);
                let e = self.residual_at(v, k, x, y, inv).unwrap_or(f32::INFINITY);
                (x, y, e, self.weight(k))
            })
            .collect()
    }

    /// A one-line summary for diagnostics: samples, exclusive ones, background ones, and the
    /// total weight.
    pub fn summary(&self) -> String {
        let excl = self
            .samples
            .iter()
            .filter(|s| s.alt[0].0 == u32::MAX)
            .count();
        let bg = self.samples.iter().filter(|s| s.background).count();
        format!(
            "{}->{} n={} exclusive={} background={} weight={:.1} sigma={:.1}",
            self.parent,
            self.child,
            self.samples.len(),
            excl,
            bg,
            self.weight_sum(),
            self.sigma
        )
    }

    /// Seed colours of the samples that lie in no other strip's extent and were not background:
    /// what this bone surely looks like (at most 64, evenly spread). Call after [`Strip::link`].
    pub fn palette(&self) -> Vec<Rgb> {
        let own: Vec<Rgb> = self
            .samples
            .iter()
            .zip(&self.anchor)
            .filter(|(s, _)| s.alt[0].0 == u32::MAX && !s.background)
            .map(|(_, c)| c[0])
            .collect();
        let step = own.len().div_ceil(64).max(1);
        own.into_iter().step_by(step).collect()
    }

    /// Where strips overlap on the seed frame a pixel goes to the nearest bone, but the bone in
    /// front may be the other one (the torso over the far arm). A sample whose seed colour is
    /// within `tol` levels (RGB distance) of an overlapping strip's palette and more than twice
    /// that from this strip's own (`palettes[k]`: [`Strip::palette`] of strip `k`) starts with
    /// no weight; it earns weight back only by fitting where this bone moves
    /// ([`Strip::learn`]). Call after [`Strip::link`].
    pub fn doubt_foreign(&mut self, me: usize, palettes: &[Vec<Rgb>], tol: f32) {
        let own = &palettes[me];
        if own.is_empty() {
            return;
        }
        let nearest = |pal: &[Rgb], c: Rgb| {
            pal.iter()
                .map(|p| (0..3).map(|k| (p[k] - c[k]).powi(2)).sum::<f32>())
                .fold(f32::INFINITY, f32::min)
        };
        for k in 0..self.samples.len() {
            let c = self.anchor[k][0];
            let near_other = self.samples[k]
                .alt
                .iter()
                .filter(|a| a.0 != u32::MAX)
                .any(|a| nearest(&palettes[a.0 as usize], c) < tol * tol);
            if near_other && nearest(own, c) > 4.0 * tol * tol {
                self.rel[k] = self.rel[k].min(0.5);
            }
        }
        self.refresh_coarse();
    }

    /// Appends what this strip has learnt since the seed frame to `out` (see
    /// [`super::state`]): whether it is mirrored, its colour scale, typical shares and costs,
    /// and per sample its running colour and reliability.
    pub fn save_learnt(&self, out: &mut super::state::Writer) {
        out.u32(self.samples.len() as u32);
        out.u8(self.mirrored as u8);
        out.f32(self.sigma);
        out.f32(self.typical.0);
        out.f32(self.typical.1);
        out.f32(self.seen_stretch.0);
        out.f32(self.seen_stretch.1);
        for &c in &self.typical_cost {
            out.f32(c);
        }
        for run in &self.running {
            for c in run.iter().flatten() {
                out.f32(*c);
            }
        }
        for &r in &self.rel {
            out.f32(r);
        }
    }

    /// Reads back what [`Strip::save_learnt`] wrote, the template remade from the anchor and
    /// the running colour with `anchor_weight`. `None` when the bytes do not fit this strip.
    pub fn load_learnt(&mut self, r: &mut super::state::Reader, anchor_weight: f32) -> Option<()> {
        if r.u32()? as usize != self.samples.len() {
            return None;
        }
        self.mirrored = match r.u8()? {
            0 => false,
            1 => true,
            _ => return None,
        };
        self.sigma = r.f32()?;
        self.typical = (r.f32()?, r.f32()?);
        self.seen_stretch = (r.f32()?, r.f32()?);
        for c in &mut self.typical_cost {
            *c = r.f32()?;
        }
        for run in &mut self.running {
            for c in run.iter_mut().flatten() {
                *c = r.f32()?;
            }
        }
        for rel in &mut self.rel {
            *rel = r.f32()?;
        }
        for k in 0..self.samples.len() {
            if self.samples[k].background {
                continue;
            }
            for lv in 0..MAX_LEVELS {
                for ch in 0..3 {
                    self.template[k][lv][ch] = anchor_weight * self.anchor[k][lv][ch]
                        + (1.0 - anchor_weight) * self.running[k][lv][ch];
                }
            }
        }
        self.refresh_coarse();
        Some(())
    }

    /// Whether `fit` looks like this bone found: at least `share` of what fits on a frame where
    /// it is seen (its [`Strip::typical`] shares), at its child end and, unless `parent_hidden`,
    /// overall.
    pub fn found(&self, fit: &Fit, share: f32, parent_hidden: bool) -> bool {
        let typical = 0.5 * (self.typical.0 + self.typical.1);
        (parent_hidden || fit.inliers >= share * typical) && fit.child_end >= share * self.typical.1
    }

    /// Lengths (px) this bone has been seen at in this clip: [`Strip::seen_stretch`] times
    /// the seed length.
    pub fn seen_lengths(&self) -> (f32, f32) {
        (
            self.seen_stretch.0 * self.seed_len,
            self.seen_stretch.1 * self.seed_len,
        )
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len()
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
                    (self.seed_len / len).powf(self.width_exponent)
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

    /// Sum of the sample weights (at least 1).
    fn weight_sum(&self) -> f32 {
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

    /// Squared normalised residual `e` of sample `k` against colour `col` at level `lv`.
    #[inline(always)]
    fn residual(&self, k: usize, lv: usize, col: Rgb, gain: f32, inv: f32) -> f32 {
        residual(&self.template[k][lv], col, gain, inv)
    }

    /// Squared normalised residual of sample `k` at `(x, y)` on view `v`: `None` outside the
    /// frame, infinite where the pixel looks like the clean plate.
    #[inline(always)]
    fn residual_at(&self, v: &View, k: usize, x: f32, y: f32, inv: f32) -> Option<f32> {
        let col = v.img.bilinear(x, y)?;
        let e = self.residual(k, v.img.k, col, v.gain, inv);
        // The plate matters only where the sample fits (a poor fit costs nearly 1 anyway):
        // reading it only there halves the work of a search.
        if e < PLATE_CHECK_E && self.trust_plate && v.looks_background(x, y, col) {
            return Some(f32::INFINITY);
        }
        Some(e)
    }

    /// Mean robust cost (0–1) over the coarse samples for the pose `(p, c)` on view `v`: the
    /// search cost.
    pub fn coarse_cost(&self, v: &View, p: Point, c: Point) -> f32 {
        self.coarse_cost_as(v, p, c, self.mirrored)
    }

    /// [`Strip::coarse_cost`] laid mirrored or not as asked.
    pub fn coarse_cost_as(&self, v: &View, p: Point, c: Point, mirrored: bool) -> f32 {
        self.coarse_cost_until(v, p, c, mirrored, |_| false)
            .unwrap_or(1.0)
    }

    /// How many coarse samples [`Strip::coarse_cost_until`] reads between two looks at its
    /// running sum.
    const BOUND_EVERY: usize = 8;

    /// [`Strip::coarse_cost_as`], given up once it is sure to be too high: every few samples,
    /// `stop(m)` is asked with `m` a lower bound of the cost (the running sum over the total
    /// weight; every term is at least 0, and rounding is monotonic, so the cost is at least `m`
    /// to the bit), and `None` is returned when it says so. Otherwise the cost, exactly as
    /// [`Strip::coarse_cost_as`] computes it.
    pub fn coarse_cost_until(
        &self,
        v: &View,
        p: Point,
        c: Point,
        mirrored: bool,
        stop: impl Fn(f32) -> bool,
    ) -> Option<f32> {
        let place = self.placement_as(p, c, mirrored);
        let inv = self.inv_scale();
        let lv = v.img.k;
        let img = &v.img.img;
        // A plate of the frame's size is read at the frame's cell (the same position and
        // fractions as its own `bilinear` would find).
        let plate = v
            .plate
            .as_ref()
            .filter(|p| self.trust_plate && p.k == lv && p.img.same_size(img));
        let (mut sum, mut n) = (0.0, 0.0);
        for (i, s) in self.coarse.iter().enumerate() {
            let (x, y) = place.at(s.t, s.e, s.v);
            let (lx, ly) = v.img.to_level(x, y);
            let e = match img.cell(lx, ly) {
                Some((at, fx, fy)) => {
                    let col = img.bilinear_at(at, fx, fy);
                    let e = residual(&s.template[lv], col, v.gain, inv);
                    let background = e < PLATE_CHECK_E
                        && match plate {
                            Some(p) => v.matches_plate(col, p.img.bilinear_at(at, fx, fy)),
                            None => self.trust_plate && v.looks_background(x, y, col),
                        };
                    if background {
                        f32::INFINITY
                    } else {
                        e
                    }
                }
                None => f32::INFINITY,
            };
            sum += s.w * if e.is_finite() { e / (1.0 + e) } else { 1.0 };
            n += s.w;
            if i % Self::BOUND_EVERY == Self::BOUND_EVERY - 1 && stop(sum / self.coarse_weight) {
                return None;
            }
        }
        Some(if n > 0.0 { sum / n } else { 1.0 })
    }

    /// Fit statistics over all samples for the pose `(p, c)` on view `v`.
    pub fn fit(&self, v: &View, p: Point, c: Point) -> Fit {
        self.fit_as(v, p, c, self.mirrored)
    }

    /// [`Strip::fit`] laid mirrored or not as asked.
    pub fn fit_as(&self, v: &View, p: Point, c: Point, mirrored: bool) -> Fit {
        let place = self.placement_as(p, c, mirrored);
        let inv = self.inv_scale();
        let (mut cost, mut inl, mut pe, mut ce) = (0.0, 0.0, 0.0, 0.0);
        let (mut wsum, mut pw, mut cw) = (0.0, 0.0, 0.0);
        let mut res = Vec::with_capacity(self.samples.len());
        for (k, s) in self.samples.iter().enumerate() {
            let w = self.weight(k);
            if w <= 0.0 {
                continue;
            }
            // Only the half of the strip nearest an end speaks for that end.
            let (lp, lc) = match self.shape {
                Shape::Bone => (
                    (1.0 - 2.0 * s.f).clamp(0.0, 1.0),
                    (2.0 * s.f - 1.0).clamp(0.0, 1.0),
                ),
                Shape::Patch => (1.0, 1.0),
            };
            wsum += w;
            pw += w * lp;
            cw += w * lc;
            let (x, y) = place.at(s.t, s.e, s.v);
            let Some(e) = self.residual_at(v, k, x, y, inv) else {
                cost += w;
                continue;
            };
            if !e.is_finite() {
                cost += w;
                continue;
            }
            cost += w * e / (1.0 + e);
            // As bits: for the non-negative values here (e is finite and at least +0), the
            // integer order of the bits is f32::total_cmp's, and integers select faster.
            res.push((e / inv / 3.0).sqrt().to_bits());
            if e < INLIER_E {
                inl += w;
                pe += w * lp;
                ce += w * lc;
            }
        }
        let residual = if res.is_empty() {
            0.0
        } else {
            let q = (res.len() * 2) / 5;
            f32::from_bits(*res.select_nth_unstable(q).1)
        };
        let share = |a: f32, b: f32| if b > 0.0 { a / b } else { 0.0 };
        Fit {
            cost: if wsum > 0.0 { cost / wsum } else { 1.0 },
            inliers: share(inl, wsum),
            parent_end: share(pe, pw),
            child_end: share(ce, cw),
            parent_mass: pw,
            child_mass: cw,
            residual,
        }
    }

    /// Gauss–Newton normal equations of the data term `Σ w_s ρ(e_s)` (scaled by `weight / Σw`)
    /// at the pose `(p, c)` on view `v` (every `2^k`-th sample at level `k`; a sample on a pixel
    /// that looks like the clean plate costs 1 and does not pull), with iteratively reweighted least squares (sample weight
    /// `ρ'(e) = 1/(1+e)²`), the colour scale widened `widen` times (graduated non-convexity: a
    /// wide scale first lets samples on a misplaced sharp edge still pull).
    pub fn normal(&self, v: &View, p: Point, c: Point, weight: f32, widen: f32) -> Normal {
        let (img, gain) = (&v.img, v.gain);
        let place = self.placement(p, c);
        let inv = self.inv_scale() / (widen * widen);
        let mut out = Normal::default();
        let stride = 1usize << img.k;
        let scale = (weight * stride as f32 / self.weight_sum()) as f64;
        let (u, n, len, omega, gamma) = (place.u, place.n, place.len, place.w, self.width_exponent);
        let lv = img.k;
        for (k, s) in self.samples.iter().enumerate().step_by(stride) {
            let sw = self.weight(k);
            if sw <= 0.0 {
                continue;
            }
            let (x, y) = place.at(s.t, s.e, s.v);
            let Some((col, gx, gy)) = img.bilinear_grad(x, y) else {
                out.cost += scale * sw as f64;
                continue;
            };
            if self.trust_plate && v.looks_background(x, y, col) {
                out.cost += scale * sw as f64;
                continue;
            }
            let tm = &self.template[k][lv];
            let r = [
                col[0] - gain * tm[0],
                col[1] - gain * tm[1],
                col[2] - gain * tm[2],
            ];
            let e = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) * inv;
            let w = sw / ((1.0 + e) * (1.0 + e));
            out.cost += scale * (sw * e / (1.0 + e)) as f64;
            // Image-space normal equations of this sample: A = Gᵀ G, b = Gᵀ r (2×2, 2).
            let (mut a00, mut a01, mut a11, mut b0, mut b1) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for ch in 0..3 {
                a00 += gx[ch] * gx[ch];
                a01 += gx[ch] * gy[ch];
                a11 += gy[ch] * gy[ch];
                b0 += gx[ch] * r[ch];
                b1 += gy[ch] * r[ch];
            }
            // Jacobian of the sample position: columns for P.x, P.y, C.x, C.y.
            let cols: [[f32; 2]; 4] = match self.shape {
                Shape::Patch => [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0], [0.0, 0.0]],
                Shape::Bone => {
                    // With d = C − P: ∂û/∂d = n̂ n̂ᵀ/L, ∂n̂/∂d = −û n̂ᵀ/L, ∂ω/∂d = −γ ω ûᵀ/L, so
                    // ∂x/∂C·δ = t δ + ω (n̂·δ)/L (e n̂ − v û) − γ ω (û·δ)/L (e û + v n̂),
                    // and ∂x/∂P = I − ∂x/∂C.
                    let m1 = (n * s.e - u * s.v) * (omega / len);
                    let m2 = (u * s.e + n * s.v) * (gamma * omega / len);
                    let cx = [s.t + n.x * m1.x - u.x * m2.x, n.x * m1.y - u.x * m2.y];
                    let cy = [n.y * m1.x - u.y * m2.x, s.t + n.y * m1.y - u.y * m2.y];
                    [[1.0 - cx[0], -cx[1]], [-cy[0], 1.0 - cy[1]], cx, cy]
                }
            };
            let f = (2.0 * inv * w) as f64 * scale;
            let mut ab = [[0.0f32; 2]; 4];
            for (i, col) in cols.iter().enumerate() {
                ab[i] = [a00 * col[0] + a01 * col[1], a01 * col[0] + a11 * col[1]];
                out.g[i] += f * (b0 * col[0] + b1 * col[1]) as f64;
            }
            for i in 0..4 {
                for j in i..4 {
                    out.h[i][j] += f * (cols[i][0] * ab[j][0] + cols[i][1] * ab[j][1]) as f64;
                }
            }
        }
        for i in 0..4 {
            for j in 0..i {
                out.h[i][j] = out.h[j][i];
            }
        }
        out
    }

    /// Learns from a frame where the bone was seen at the pose `(p, c)`:
    /// - each sample's reliability moves up (rate `rate`) when it fits, and down (rate
    ///   `2·rate`) when it does not but fits where another strip's bone carried it (`others[k]`:
    ///   the placement of strip `k` when that bone was seen too, more than a pixel away): such a
    ///   seed pixel belongs to the other bone. A sample that fits nowhere is hidden, and
    ///   unchanged; background samples stay out;
    /// - the running colour of the samples that fit moves towards the colour seen (rate
    ///   `rate`), and the template becomes `anchor_weight`·anchor + the rest running;
    /// - the share of samples that fit at each end ([`Strip::typical`]) moves towards `fit`'s,
    ///   and the coarse cost of each level ([`Strip::typical_cost`]) towards this frame's;
    /// - when most of the bone fits, the colour scale moves towards 1.5× the fit's residual,
    ///   within
    ///   `[sigma_min, sigma_max]`.
    #[allow(clippy::too_many_arguments)]
    pub fn learn(
        &mut self,
        views: &[View],
        (p, c): (Point, Point),
        others: &[Option<Placement>],
        rate: f32,
        anchor_weight: f32,
        (sigma_min, sigma_max): (f32, f32),
        fit: &Fit,
    ) {
        self.typical.0 += rate * (fit.parent_end - self.typical.0);
        self.typical.1 += rate * (fit.child_end - self.typical.1);
        if self.shape == Shape::Bone
            && fit.inliers >= CLEAR_SHARE * 0.5 * (self.typical.0 + self.typical.1)
        {
            let k = (c - p).norm() / self.seed_len.max(1e-3);
            self.seen_stretch = (self.seen_stretch.0.min(k), self.seen_stretch.1.max(k));
        }
        for v in views.iter().take(MAX_LEVELS) {
            let cost = self.coarse_cost(v, p, c);
            let t = &mut self.typical_cost[v.img.k];
            *t += rate * (cost - *t);
        }
        let residual = fit.residual;
        let place = self.placement(p, c);
        let inv = self.inv_scale();
        let gain = views[0].gain;
        let g = gain.max(1e-3);
        let img = views[0].img;
        for k in 0..self.samples.len() {
            let s = self.samples[k];
            if s.background {
                continue;
            }
            let (x, y) = place.at(s.t, s.e, s.v);
            let Some(col) = img.bilinear(x, y) else {
                continue;
            };
            if self.residual(k, 0, col, gain, inv) < INLIER_E {
                for lv in 0..MAX_LEVELS.min(views.len()) {
                    let seen = if lv == 0 {
                        Some(col)
                    } else {
                        views[lv].img.bilinear(x, y)
                    };
                    if let Some(seen) = seen {
                        for ch in 0..3 {
                            let r = &mut self.running[k][lv][ch];
                            *r += rate * (seen[ch] / g - *r);
                        }
                    }
                }
                self.rel[k] += rate * (1.0 - self.rel[k]);
            } else {
                let elsewhere = s.alt.iter().any(|&(o, t, e, v)| {
                    let Some(Some(op)) = others.get(o as usize) else {
                        return false;
                    };
                    let (ox, oy) = op.at(t, e, v);
                    ((ox - x).powi(2) + (oy - y).powi(2) > 1.0)
                        && img
                            .bilinear(ox, oy)
                            .is_some_and(|oc| self.residual(k, 0, oc, gain, inv) < INLIER_E)
                });
                if elsewhere {
                    self.rel[k] -= (2.0 * rate).min(1.0) * self.rel[k];
                }
            }
            for lv in 0..MAX_LEVELS.min(views.len()) {
                for ch in 0..3 {
                    self.template[k][lv][ch] = anchor_weight * self.anchor[k][lv][ch]
                        + (1.0 - anchor_weight) * self.running[k][lv][ch];
                }
            }
        }
        if fit.inliers >= 0.6 {
            let target = (1.5 * residual).clamp(sigma_min, sigma_max);
            self.sigma += 0.1 * (target - self.sigma);
        }
        self.refresh_coarse();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    const LEVELS: usize = 3;
    use image::RgbImage;

    /// A smooth 80×60 frame: a bar from `p` to `c`, 5 px half-width with soft edges, coloured
    /// by a sine of the position along it (so it has texture to lock on).
    fn smooth_bar(p: Point, c: Point) -> RgbImage {
        smooth_bar_scaled(p, c, 1.0)
    }

    /// [`smooth_bar`] drawn `k` times larger (frame, bar width, soft edge and texture).
    fn smooth_bar_scaled(p: Point, c: Point, k: f32) -> RgbImage {
        RgbImage::from_fn((80.0 * k) as u32, (60.0 * k) as u32, |x, y| {
            let q = Point::new(x as f32, y as f32);
            let d = c - p;
            let t = (q - p).dot(&d) / d.norm_squared();
            let ext = Extent {
                a: p,
                b: c,
                ext_a: 0.0,
                ext_b: 0.0,
                half_width: 0.0,
            };
            let inside = ((5.0 * k - ext.distance(q)) / (3.0 * k)).clamp(0.0, 1.0);
            let phase = (t * 12.0).sin();
            let bar = [150.0 + 90.0 * phase, 120.0 - 80.0 * phase, 60.0];
            let bg = [90.0, 110.0, 130.0];
            image::Rgb([0, 1, 2].map(|k| (bg[k] + (bar[k] - bg[k]) * inside) as u8))
        })
    }

    fn spec() -> StripSpec {
        StripSpec {
            max_samples: 400,
            coarse_samples: 40,
            sigma: 12.0,
            width_exponent: 0.0,
        }
    }

    fn extent(p: Point, c: Point, ext: f32) -> Extent {
        Extent {
            a: p,
            b: c,
            ext_a: ext,
            ext_b: ext,
            half_width: 6.0,
        }
    }

    /// Level `k` of `pyr` as a view with no plate and no gain.
    fn view<'a>(pyr: &'a Pyramid, k: usize) -> View<'a> {
        View {
            img: pyr.level(k),
            plate: None,
            gain: 1.0,
            bg_inv: 0.0,
        }
    }

    fn bone(img: &Pyramid, p: Point, c: Point, ext: f32) -> Strip {
        // Background: within 30 levels (L1) of the backdrop colour, as the plate test does.
        let bg = |x: f32, y: f32| {
            img.level(0).bilinear(x, y).is_some_and(|c| {
                (c[0] - 90.0).abs() + (c[1] - 110.0).abs() + (c[2] - 130.0).abs() < 30.0
            })
        };
        Strip::sample(
            img,
            Shape::Bone,
            (0, 1),
            extent(p, c, ext),
            &spec(),
            &[],
            &bg,
        )
        .unwrap()
    }

    #[test]
    fn fits_its_seed_pose_and_not_a_shifted_one() {
        let (p, c) = (Point::new(20.3, 30.4), Point::new(50.2, 30.1));
        let img = smooth_bar(p, c);
        let pyr = Pyramid::new(&img, LEVELS);
        let s = bone(&pyr, p, c, 3.0);
        let at_seed = s.fit(&view(&pyr, 0), p, c);
        assert!(at_seed.cost < 1e-3 && at_seed.inliers > 0.99, "{at_seed:?}");
        let off = Vector::new(0.0, 3.0);
        let shifted = s.fit(&view(&pyr, 0), p + off, c + off);
        assert!(shifted.inliers < 0.7, "{shifted:?}");
    }

    #[test]
    fn gradient_matches_finite_differences() {
        // Off the pixel grid, with samples past both ends (e ≠ 0), a limb that thins as it
        // stretches, at every pyramid level (the scene drawn 2^level times larger, so that it
        // is as smooth at that level as at level 0: the analytic gradient is a central
        // difference half a level pixel wide).
        for lv in 0..LEVELS {
            let k = (1 << lv) as f32;
            let (p, c) = (Point::new(20.3, 30.4) * k, Point::new(50.2, 30.1) * k);
            let seed = smooth_bar_scaled(p, c, k);
            let frame =
                smooth_bar_scaled(Point::new(21.0, 30.5) * k, Point::new(51.0, 33.0) * k, k);
            let (sp, fp) = (Pyramid::new(&seed, LEVELS), Pyramid::new(&frame, LEVELS));
            let mut s = bone(&sp, p, c, 4.0 * k);
            s.width_exponent = 0.5;
            let (p0, c0) = (
                p + Vector::new(0.3, -0.2) * k,
                c + Vector::new(1.5, 0.7) * k,
            );
            let img = view(&fp, lv);
            let ne = s.normal(&img, p0, c0, 1.0, 1.0);
            let cost = |q: [f32; 4]| {
                let (a, b) = (Point::new(q[0], q[1]), Point::new(q[2], q[3]));
                s.normal(&img, a, b, 1.0, 1.0).cost
            };
            let q0 = [p0.x, p0.y, c0.x, c0.y];
            for i in 0..4 {
                let h = 0.05 * k;
                let (mut a, mut b) = (q0, q0);
                a[i] += h;
                b[i] -= h;
                let fd = (cost(a) - cost(b)) / (2.0 * h as f64);
                assert!(
                    (fd - ne.g[i]).abs() < 0.2 * fd.abs().max(1e-3),
                    "level {lv}, coordinate {i}: finite difference {fd}, analytic {}",
                    ne.g[i]
                );
            }
        }
    }

    #[test]
    fn gauss_newton_steps_towards_a_turned_and_stretched_bone() {
        // Seed: horizontal, 30 px. Frame: turned and stretched.
        let (p, c) = (Point::new(20.0, 30.0), Point::new(50.0, 30.0));
        let (p1, c1) = (Point::new(21.0, 30.5), Point::new(52.0, 33.0));
        let (seed, frame) = (smooth_bar(p, c), smooth_bar(p1, c1));
        let (sp, fp) = (Pyramid::new(&seed, LEVELS), Pyramid::new(&frame, LEVELS));
        let s = bone(&sp, p, c, 0.0);
        let (mut pp, mut cc) = (p, c);
        for k in 0..30 {
            let ne = s.normal(&view(&fp, 2 - k / 10), pp, cc, 100.0, 1.0);
            let h = nalgebra::Matrix4::from_fn(|i, j| ne.h[i][j] + if i == j { 1e-3 } else { 0.0 });
            let g = nalgebra::Vector4::from_fn(|i, _| ne.g[i]);
            let d = h.cholesky().unwrap().solve(&(-g));
            let clamp = |v: f64| v.clamp(-2.0, 2.0) as f32;
            pp += Vector::new(clamp(d[0]), clamp(d[1]));
            cc += Vector::new(clamp(d[2]), clamp(d[3]));
        }
        assert!((pp - p1).norm() < 0.3, "{pp:?} vs {p1:?}");
        assert!((cc - c1).norm() < 0.3, "{cc:?} vs {c1:?}");
    }

    #[test]
    fn a_pixel_moving_with_another_bone_loses_its_weight() {
        // Seed: bar A horizontal; strip B claims A's pixels too. Frame: A stays, B's bone moved
        // away. B's samples fit where A's bone carries them, so they fade.
        let (p, c) = (Point::new(20.3, 30.4), Point::new(50.2, 30.1));
        let img = smooth_bar(p, c);
        let pyr = Pyramid::new(&img, LEVELS);
        let a = bone(&pyr, p, c, 0.0);
        let mut b = bone(&pyr, p, c, 0.0);
        b.link(1, &[a.extent, b.extent]);
        let moved = (p + Vector::new(0.0, 15.0), c + Vector::new(0.0, 15.0));
        let others = [Some(a.placement(p, c)), None];
        let before = b.weight_sum();
        let views: Vec<View> = (0..LEVELS).map(|k| view(&pyr, k)).collect();
        let fit = Fit::default();
        for _ in 0..10 {
            b.learn(&views, moved, &others, 0.2, 0.5, (5.0, 40.0), &fit);
        }
        assert!(
            b.weight_sum() < 0.1 * before,
            "{} of {before}",
            b.weight_sum()
        );
        // A sample that fits nowhere (hidden) keeps its weight.
        let mut c2 = bone(&pyr, p, c, 0.0);
        c2.link(1, &[a.extent, c2.extent]);
        for _ in 0..10 {
            c2.learn(&views, moved, &[None, None], 0.2, 0.5, (5.0, 40.0), &fit);
        }
        assert_eq!(c2.weight_sum(), before);
    }

    #[test]
    fn learns_the_lengths_a_bone_is_seen_at_only_where_it_fits() {
        // Seed: 30 px. Frames: the bar squashed to 24 px and stretched to 36 px.
        let (p, c) = (Point::new(20.0, 30.0), Point::new(50.0, 30.0));
        let seed_img = smooth_bar(p, c);
        let seed = Pyramid::new(&seed_img, LEVELS);
        let mut s = bone(&seed, p, c, 0.0);
        assert_eq!(s.seen_lengths(), (30.0, 30.0));
        for end in [44.0, 56.0] {
            let c1 = Point::new(end, 30.0);
            let img = smooth_bar(p, c1);
            let pyr = Pyramid::new(&img, LEVELS);
            let views: Vec<View> = (0..LEVELS).map(|k| view(&pyr, k)).collect();
            let fit = s.fit(&views[0], p, c1);
            s.learn(&views, (p, c1), &[None], 0.1, 0.5, (5.0, 40.0), &fit);
        }
        let (lo, hi) = s.seen_lengths();
        assert!(
            (lo - 24.0).abs() < 1e-3 && (hi - 36.0).abs() < 1e-3,
            "{lo} {hi}"
        );
        // Laid where it does not fit (moved off the bar), a length says nothing.
        let (p2, c2) = (p + Vector::new(0.0, 20.0), Point::new(70.0, 50.0));
        let views: Vec<View> = (0..LEVELS).map(|k| view(&seed, k)).collect();
        let fit = s.fit(&views[0], p2, c2);
        s.learn(&views, (p2, c2), &[None], 0.1, 0.5, (5.0, 40.0), &fit);
        assert_eq!(s.seen_lengths(), (lo, hi));
    }
}
