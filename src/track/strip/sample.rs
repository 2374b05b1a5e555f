//! Building a strip on the seed frame: its samples and their seed colours ([`Strip::sample`]),
//! the other strips each sample could belong to ([`Strip::link`]), and the samples that start
//! doubted because they look like an overlapping bone ([`Strip::doubt_foreign`]).

use super::{split_along, Extent, Sample, Shape, Strip, StripSpec, ALTERNATIVES};
use crate::geom::Point;
use crate::track::pixels::{Pyramid, Rgb, MAX_LEVELS};

/// A bone's axis counts as on the clean plate (the plate holds a character that rested while
/// it was sampled) only where its seed pixels are within this share of the foreground
/// threshold of the plate; its samples' own test is the whole threshold. Tighter than the
/// samples' test, so a limb whose colour is close to the floor's (a grey shoe on a grey floor)
/// is not taken for a resting body; tighter still loses other clips (docs/NOTES.md, "Parameter
/// sweeps").
const AXIS_PLATE_SHARE: f32 = 0.75;

impl Strip {
    /// Samples the strip `extent` of the bone `parent → child` on the seed frame (for
    /// `Shape::Patch`, the rectangle `2·ext_a × 2·half_width` around `extent.a`, `child ==
    /// parent`). A pixel is kept when, for a bone, no extent of `others` is nearer to it.
    /// `plate_share(x, y)` is how far the seed pixel is from the clean plate, as a share of the
    /// foreground threshold: within it (at most 1) the pixel looks like the plate, and such
    /// samples get no weight, unless most of the bone's axis is within [`AXIS_PLATE_SHARE`]
    /// (then the plate is wrong there, and no sample is taken for background). Returns `None`
    /// when fewer than 8 samples remain.
    pub fn sample(
        frame: &Pyramid,
        shape: Shape,
        (parent, child): (usize, usize),
        extent: Extent,
        spec: &StripSpec,
        others: &[Extent],
        plate_share: &dyn Fn(f32, f32) -> f32,
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
            coarse_len: 0,
            coarse_weight: 0.0,
            weight_total: 1.0,
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
                        background: plate_share(x, y) <= 1.0,
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
        // trusted along this strip. Judged by a tighter test than the samples' own: a limb
        // whose colour is merely near the floor's (a grey shoe on a grey floor, within the
        // noise threshold) is not a limb the plate holds.
        let core: Vec<bool> = strip
            .samples
            .iter()
            .filter(|s| s.v.abs() <= 2.0 && s.e == 0.0)
            .map(|s| {
                let (x, y) = place.at(s.t, s.e, s.v);
                plate_share(x, y) <= AXIS_PLATE_SHARE
            })
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
}
