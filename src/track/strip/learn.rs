//! What a strip learns as the clip goes ([`Strip::learn`]): sample reliabilities, running
//! colours, colour scale, typical shares and costs, the lengths the bone is seen at; and
//! saving and loading all that ([`Strip::save_learnt`], [`Strip::load_learnt`]).

use super::{Coarse, Fit, Placement, Shape, Strip, View, CLEAR_SHARE, INLIER_E, LANES};
use crate::geom::Point;
use crate::track::pixels::MAX_LEVELS;
use crate::track::state;

impl Strip {
    /// Remakes the list of weighted coarse samples (and the total weight) from the
    /// reliabilities and templates; call after changing either.
    pub(super) fn refresh_coarse(&mut self) {
        self.coarse.clear();
        self.coarse_len = 0;
        self.coarse_weight = 0.0;
        self.weight_total = self.sum_weights();
        let mut k = 0;
        while k < self.samples.len() {
            let w = self.weight(k);
            if w > 0.0 {
                let s = &self.samples[k];
                let l = self.coarse_len % LANES;
                if l == 0 {
                    self.coarse.push(Coarse::default());
                }
                let b = self.coarse.last_mut().expect("a block was pushed");
                (b.t[l], b.e[l], b.v[l], b.w[l]) = (s.t, s.e, s.v, w);
                for (lv, col) in self.template[k].iter().enumerate() {
                    for (ch, &c) in col.iter().enumerate() {
                        b.template[lv][ch][l] = c;
                    }
                }
                self.coarse_len += 1;
                self.coarse_weight += w;
            }
            k += self.coarse_step;
        }
    }

    /// Appends what this strip has learnt since the seed frame to `out` (see
    /// [`state`]): whether it is mirrored, its colour scale, typical shares and costs,
    /// and per sample its running colour and reliability.
    pub fn save_learnt(&self, out: &mut state::bytes::Writer) {
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
    pub fn load_learnt(&mut self, r: &mut state::bytes::Reader, anchor_weight: f32) -> Option<()> {
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

    /// Lengths (px) this bone has been seen at in this clip: [`Strip::seen_stretch`] times
    /// the seed length.
    pub fn seen_lengths(&self) -> (f32, f32) {
        (
            self.seen_stretch.0 * self.seed_len,
            self.seen_stretch.1 * self.seed_len,
        )
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
                // One running colour per level and channel, indexed alike in `running`.
                #[allow(clippy::needless_range_loop)]
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
