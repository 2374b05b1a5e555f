//! Exposure changes over a dark plate (docs/method.md §2.2, `track::exposure`): the gain the
//! templates are judged at follows the subject, not the steps the dark background moves in.

use crate::common::synth_clip;
use image::RgbImage;
use mocap2d::background::{Background, MIN_THRESHOLD};
use mocap2d::synth::Scenario;
use mocap2d::track::{TrackParams, Tracker};
use std::path::Path;

#[test]
fn the_gain_follows_the_subject_not_the_dark_plates_steps() {
    let clip = synth_clip(Scenario::Walk, 160, 120, 1, Some(30));
    let plate = &clip.background;
    // The backdrop replaced by a flat grey of 22 levels, where one level is 4.5 %.
    let dark = |g: f32| image::Rgb([(22.0 * g).round() as u8; 3]);
    let dark_plate = RgbImage::from_pixel(plate.width(), plate.height(), dark(1.0));
    // The exposure falls 0.4 % a frame; every pixel is rounded, the backdrop's all alike.
    let exposure = |f: usize| 1.0 - 0.004 * f as f32;
    let frames: Vec<RgbImage> = clip
        .frames
        .iter()
        .enumerate()
        .map(|(f, img)| {
            let g = exposure(f);
            RgbImage::from_fn(img.width(), img.height(), |x, y| {
                let (px, b) = (img.get_pixel(x, y).0, plate.get_pixel(x, y).0);
                let l1: u32 = (0..3).map(|c| px[c].abs_diff(b[c]) as u32).sum();
                if l1 <= MIN_THRESHOLD {
                    dark(g)
                } else {
                    image::Rgb(px.map(|v| (v as f32 * g).round() as u8))
                }
            })
        })
        .collect();
    let background = Background {
        plate: dark_plate,
        threshold: MIN_THRESHOLD,
        lit_threshold: MIN_THRESHOLD,
    };
    let seeds = mocap2d::seed::parse_seeds(&clip.seeds_toml(), Path::new("seeds")).unwrap();
    let mut t = Tracker::new(
        TrackParams::default(),
        &seeds,
        &frames[0],
        Some(background.clone()),
    );
    t.enable_trace();
    // Largest and summed misses of the plate's gain and of the gain judged at.
    let (mut plate, mut judged) = ((0.0f32, 0.0f32), (0.0f32, 0.0f32));
    for (f, frame) in frames.iter().enumerate().skip(1) {
        t.step(frame);
        let g = exposure(f);
        for (m, gain) in [
            (&mut plate, background.gain(frame)),
            (&mut judged, t.trace().unwrap().gain),
        ] {
            m.0 = m.0.max((gain - g).abs());
            m.1 += (gain - g).abs();
        }
    }
    // The plate's gain misses by up to half a level (2.3 %), the subject's by about 1 %.
    assert!(plate.0 > 0.02, "the plate's gain misses by {plate:?}");
    assert!(judged.0 < 0.015, "the judged gain misses by {judged:?}");
    assert!(judged.1 < 0.6 * plate.1, "{judged:?} against {plate:?}");
}
