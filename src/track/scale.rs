//! The resolution the tracker works at. Large frames are halved before tracking (2×2 box
//! averages, as the pyramid's levels are made: [`super::pixels::halve_image`]) as many times as keeps the seed
//! rectangles at least [`TrackParams::work_box_px`] px: the same character in twice the pixels
//! then costs about what it costs at the smaller size, instead of two to three times as much
//! (the search windows, the grids over them and the samples per bone grow with the bones'
//! length in pixels).
//!
//! Positions go in and come out at the frame's own resolution. Inside the tracker everything,
//! the parameters in px included, is at the working resolution: a frame halved `k` times has
//! pixel `x_k` covering frame pixels `2^k·x_k … 2^k·x_k + 2^k − 1`, so a frame position `x` is
//! `x_k = (x − (2^k − 1)/2) / 2^k` there (the convention of [`super::pixels::Pyramid`]).

use super::pixels::halve_image;
use super::TrackParams;
use crate::background::Background;
use crate::geom::Point;
use crate::seed::Seeds;
use image::RgbImage;
use std::borrow::Cow;

/// Most halvings: a 4K frame (3840 px wide) to 960 px.
pub const MAX_HALVINGS: u32 = 2;

const _: () = assert!(
    MAX_HALVINGS as usize <= 2,
    "Background::halved_thresholds holds two"
);

/// How many times frames are halved before tracking.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WorkScale {
    pub halvings: u32,
}

impl WorkScale {
    /// Full resolution.
    pub const FULL: WorkScale = WorkScale { halvings: 0 };

    /// The scale for a run seeded with `seeds`: halved as many times (at most [`MAX_HALVINGS`])
    /// as keeps the median of the rectangles' smaller sides at least `params.work_box_px`
    /// (0: full resolution). The median, so that one small rectangle (an eye) does not hold the
    /// whole body at full resolution, nor one large one push it down.
    pub fn for_seeds(params: &TrackParams, seeds: &Seeds) -> WorkScale {
        let mut sides: Vec<u32> = seeds
            .joints
            .iter()
            .map(|j| j.bbox.w.min(j.bbox.h))
            .collect();
        if params.work_box_px <= 0.0 || sides.is_empty() {
            return WorkScale::FULL;
        }
        sides.sort_unstable();
        let median = sides[sides.len() / 2] as f32;
        let mut halvings = 0;
        while halvings < MAX_HALVINGS && median / (2u32 << halvings) as f32 >= params.work_box_px {
            halvings += 1;
        }
        WorkScale { halvings }
    }

    /// `2^k`.
    pub fn factor(self) -> f32 {
        (1u32 << self.halvings) as f32
    }

    /// `(2^k − 1) / 2`: where the first working pixel's centre lies in the frame (px).
    fn offset(self) -> f32 {
        0.5 * (self.factor() - 1.0)
    }

    /// A frame position (px) at the working resolution.
    pub fn to_work(self, p: Point) -> Point {
        let (s, o) = (self.factor(), self.offset());
        Point::new((p.x - o) / s, (p.y - o) / s)
    }

    /// A working position (px) in the frame.
    pub fn to_frame(self, p: Point) -> Point {
        let (s, o) = (self.factor(), self.offset());
        Point::new(p.x * s + o, p.y * s + o)
    }

    /// `img` at the working resolution (borrowed when that is the full one).
    pub fn image(self, img: &RgbImage) -> Cow<'_, RgbImage> {
        if self.halvings == 0 {
            return Cow::Borrowed(img);
        }
        let mut out = halve_image(img);
        for _ in 1..self.halvings {
            out = halve_image(&out);
        }
        Cow::Owned(out)
    }

    /// `seeds` at the working resolution: centres moved, sides divided (at least 1 px).
    pub fn seeds(self, seeds: &Seeds) -> Seeds {
        let mut out = seeds.clone();
        if self.halvings > 0 {
            let s = self.factor();
            for j in &mut out.joints {
                let c = self.to_work(j.bbox.centre());
                j.bbox.cx = c.x;
                j.bbox.cy = c.y;
                j.bbox.w = ((j.bbox.w as f32 / s).round() as u32).max(1);
                j.bbox.h = ((j.bbox.h as f32 / s).round() as u32).max(1);
            }
        }
        out
    }

    /// `bg` at the working resolution: the plate halved alike, the foreground threshold kept.
    /// (Measured again on the halved frames, it came out the same on the `noisy` synth clips at
    /// 1280x720: flicker, which averaging does not lower, sets it there; clean clips sit at
    /// [`crate::background::MIN_THRESHOLD`] either way.)
    pub fn background(self, bg: Background) -> Background {
        if self.halvings == 0 {
            return bg;
        }
        Background {
            plate: self.image(&bg.plate).into_owned(),
            threshold: bg.threshold,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::parse_seeds;
    use std::path::Path;

    fn seeds(side: u32) -> Seeds {
        let text = format!(
            "frame = 0\n[[joint]]\nname = \"a\"\nx = 100.0\ny = 60.0\nw = {side}\nh = {side}\n\
             [[joint]]\nname = \"b\"\nx = 140.0\ny = 60.0\nw = {side}\nh = {side}\nparent = \"a\"\n"
        );
        parse_seeds(&text, Path::new("seeds.toml")).unwrap()
    }

    #[test]
    fn rectangles_keep_at_least_the_working_size() {
        let p = TrackParams::default();
        assert_eq!(p.work_box_px, 20.0);
        // 21 px (the synth clips at 640x360) and 15 px stay at full resolution; 43 px (1280x720)
        // is halved once; 90 px twice; 200 px no more than MAX_HALVINGS.
        for (side, k) in [
            (15, 0),
            (21, 0),
            (39, 0),
            (40, 1),
            (43, 1),
            (79, 1),
            (80, 2),
            (200, 2),
        ] {
            assert_eq!(
                WorkScale::for_seeds(&p, &seeds(side)).halvings,
                k,
                "side {side}"
            );
        }
        let off = TrackParams {
            work_box_px: 0.0,
            ..TrackParams::default()
        };
        assert_eq!(WorkScale::for_seeds(&off, &seeds(200)), WorkScale::FULL);
    }

    #[test]
    fn positions_go_there_and_back_and_match_the_halved_pixels() {
        let w = WorkScale { halvings: 1 };
        let p = Point::new(13.25, 7.5);
        let back = w.to_frame(w.to_work(p));
        assert!((back - p).norm() < 1e-5);
        // Working pixel 3 averages frame pixels 6 and 7: its centre is at 6.5.
        assert_eq!(w.to_frame(Point::new(3.0, 0.0)).x, 6.5);
        let s = w.seeds(&seeds(43));
        assert_eq!((s.joints[0].bbox.w, s.joints[0].bbox.cx), (22, 49.75));
        let img = RgbImage::from_fn(8, 6, |x, _| image::Rgb([(x * 10) as u8, 0, 0]));
        let half = w.image(&img);
        assert_eq!(half.dimensions(), (4, 3));
        // Frame pixels 6 and 7 (60 and 70) average to 65 at working pixel 3.
        assert_eq!(half.get_pixel(3, 1)[0], 65);
    }
}
