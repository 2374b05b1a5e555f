//! The frame's brightness gain as the subject shows it (docs/method.md §2.2).
//!
//! The plate gives the gain the background shows ([`Background::gain`]), but a dark background
//! tells it only coarsely: the frame's background moves from level to level together as the
//! exposure changes, so on a plate at about 22 levels its gain comes in steps of about 4.5 %
//! ([`Background::gain_step`]), while a bright subject's colours follow the exposure smoothly.
//! Judged at the background's gain, a thin limb whose pixels are only a little brighter than a
//! dark plate falls below the share of samples that counts as seen and is re-acquired on a
//! look-alike. So the gain the templates are scaled by is measured on the subject once the
//! joints are refined, within one such step of the background's, and the next frame starts
//! from it.

use super::strip::{Strip, View};
use crate::background::Background;
use crate::geom::Point;
use rayon::prelude::*;

/// The least [`Background::gain_step`] at which the subject's gain is measured: on the shipped
/// flies, whose exposure does not change, it wanders by up to 1 % over the resting frames
/// (0.992–1.001), so a plate that tells the gain to within twice that is used as it is.
const SUBJECT_MIN_STEP: f32 = 0.02;

/// The gains within one [`Background::gain_step`] `step` of the background's gain `bg`.
fn band(bg: f32, step: f32) -> (f32, f32) {
    (bg * (1.0 - step), bg * (1.0 + step))
}

/// The gain the templates are scaled by on a frame, given the background's: the subject's last
/// measured gain, kept within the band the background allows.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Exposure {
    /// [`Background::gain_step`] of the tracker's plate; 0 without one or when it is under
    /// [`SUBJECT_MIN_STEP`]: the background's gain is then used as it is.
    pub step: f32,
    /// The gain measured on the subject on the last frame stepped, if any.
    pub last: Option<f32>,
}

impl Exposure {
    pub fn new(background: Option<&Background>) -> Self {
        Exposure {
            step: background
                .map(|b| b.gain_step())
                .filter(|&s| s >= SUBJECT_MIN_STEP)
                .unwrap_or(0.0),
            last: None,
        }
    }

    /// The gain to search and refine a frame at whose background shows the gain `bg`.
    pub fn start(&self, bg: f32) -> f32 {
        let (lo, hi) = band(bg, self.step);
        self.last.map_or(bg, |g| g.clamp(lo, hi))
    }

    /// The gain that best maps the `strips`' templates onto the frame at the poses `x` (least
    /// squares over the samples that fit on the strips where at least `clear` of them do,
    /// chosen at `v`'s gain and then again at the first estimate's), within the band the
    /// background's gain `bg` allows; `v`'s gain when nothing fits or there is no band.
    pub fn subject_gain(
        &self,
        strips: &[Strip],
        v: &View,
        x: &[Point],
        bg: f32,
        clear: f32,
    ) -> f32 {
        if self.step <= 0.0 {
            return v.gain;
        }
        let (lo, hi) = band(bg, self.step);
        let mut v = *v;
        // Only bones that clearly fit speak for the gain: on a bone mostly off its limb, what
        // fits is wherever the colours happen to match.
        for _ in 0..2 {
            // Summed in strip order, whatever the threads: the same bits on every run.
            let terms: Vec<(f64, f64, f32)> = strips
                .par_iter()
                .map(|s| s.gain_terms(&v, x[s.parent], x[s.child]))
                .collect();
            let (it, tt) = terms
                .iter()
                .filter(|t| t.2 >= clear)
                .fold((0.0, 0.0), |a, t| (a.0 + t.0, a.1 + t.1));
            if tt <= 0.0 {
                break;
            }
            v.gain = ((it / tt) as f32).clamp(lo, hi);
        }
        v.gain
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_starts_at_the_last_gain_within_a_step_of_the_background() {
        let e = |last| Exposure { step: 0.05, last };
        // The first frame, or none to go on: the background's gain.
        assert_eq!(e(None).start(0.9), 0.9);
        // The exposure moves smoothly while the background's gain jumps a step: the last gain.
        assert_eq!(e(Some(0.97)).start(1.0), 0.97);
        // A jump larger than a step (a light switched on): pulled into the band.
        assert!((e(Some(0.8)).start(1.0) - 0.95).abs() < 1e-6);
        assert!((e(Some(1.2)).start(1.0) - 1.05).abs() < 1e-6);
        // Without a plate there is no band: the background's gain (1) as before.
        let none = Exposure::new(None);
        assert_eq!(
            Exposure {
                last: Some(0.8),
                ..none
            }
            .start(1.0),
            1.0
        );
        // A plate fine enough (0.5 % a level) is used as it is; a dark one (4.5 %) is not.
        let plate = |v: u8| Background {
            plate: image::RgbImage::from_pixel(40, 30, image::Rgb([v, v, v])),
            threshold: 30,
            lit_threshold: 30,
        };
        assert_eq!(Exposure::new(Some(&plate(200))).step, 0.0);
        assert!((Exposure::new(Some(&plate(22))).step - 1.0 / 22.0).abs() < 1e-6);
    }
}
