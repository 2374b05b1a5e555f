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

use super::pixels::{coarse_levels, halve_image, halve_image_into};
use super::TrackParams;
use crate::background::Background;
use crate::decode::Recycler;
use crate::geom::Point;
use crate::seed::Seeds;
use image::RgbImage;
use std::borrow::Cow;
use std::sync::OnceLock;

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
            lit_threshold: bg.lit_threshold,
        }
    }
}

/// A decoded frame and, when the tracker works below full resolution, the same frame at the
/// working resolution, made once by the thread that decodes it ([`WorkScale::frame`]) instead
/// of by the tracker on each step. A run that never reads frames at full resolution (a plain
/// `track` of a clip tracked halved) keeps only the working image.
///
/// A frame made with a [`Recycler`] hands its buffers back to it when dropped, for the decode
/// thread to write later frames into.
#[derive(Debug, Clone)]
pub struct Frame {
    /// The frame at its own resolution (`None`: dropped once the working image was made).
    full: Option<RgbImage>,
    work: Option<(WorkScale, RgbImage)>,
    /// The working image's pyramid levels below the first, with the scale and depth asked.
    coarse: OnceLock<(WorkScale, usize, Vec<RgbImage>)>,
    recycler: Option<Recycler>,
}

impl Frame {
    /// `rgb` alone: its working image is made when asked for ([`Frame::at`]).
    pub fn plain(rgb: RgbImage) -> Frame {
        Frame {
            full: Some(rgb),
            work: None,
            coarse: OnceLock::new(),
            recycler: None,
        }
    }

    /// The frame at its own resolution.
    ///
    /// # Panics
    /// On a frame made without it ([`WorkScale::frame`] with `keep_full` false): made so only
    /// for runs that never ask.
    pub fn full(&self) -> &RgbImage {
        self.full
            .as_ref()
            .expect("a frame kept at its working resolution alone is read only there")
    }

    /// Whether it holds the frame at full resolution ([`Frame::full`]).
    pub fn has_full(&self) -> bool {
        self.full.is_some()
    }

    /// The frame at `work`'s resolution: the image made beforehand when it is at that scale,
    /// else made now ([`WorkScale::image`]; the same bytes either way).
    pub fn at(&self, work: WorkScale) -> Cow<'_, RgbImage> {
        match &self.work {
            Some((w, img)) if *w == work => Cow::Borrowed(img),
            _ => work.image(self.full()),
        }
    }

    /// The levels after the first of the pyramid of `levels` levels of the frame at `work`
    /// ([`coarse_levels`]): made by the first pass that asks (the carried pass, the passes
    /// from a key and back from a correction all step over the same frames) and shared by the
    /// rest. `None` when the first asked at another scale or depth, or the working image was
    /// not made beforehand: the caller makes its own.
    pub fn coarse(&self, work: WorkScale, levels: usize) -> Option<&[RgbImage]> {
        let img = match (&self.work, &self.full) {
            (Some((w, img)), _) if *w == work => img,
            (_, Some(img)) if work.halvings == 0 => img,
            _ => return None,
        };
        let (w, l, c) = self
            .coarse
            .get_or_init(|| (work, levels, coarse_levels(img, levels)));
        (*w == work && *l == levels).then_some(c.as_slice())
    }

    /// Bytes held by its images (the pyramid's levels aside).
    pub fn bytes(&self) -> usize {
        let len = |img: &RgbImage| img.as_raw().len();
        self.full.as_ref().map_or(0, len) + self.work.as_ref().map_or(0, |(_, w)| len(w))
    }
}

impl From<RgbImage> for Frame {
    fn from(rgb: RgbImage) -> Frame {
        Frame::plain(rgb)
    }
}

impl Drop for Frame {
    fn drop(&mut self) {
        if let Some(r) = &self.recycler {
            for img in [self.full.take(), self.work.take().map(|(_, w)| w)]
                .into_iter()
                .flatten()
            {
                r.give(img.into_raw());
            }
        }
    }
}

/// A frame the tracker reads at its working resolution: an image (halved when asked) or a
/// decoded [`Frame`], whose working image may be made already and whose pyramid is shared.
pub trait AtWork: Sync {
    /// The frame at `work`'s resolution.
    fn at_work(&self, work: WorkScale) -> Cow<'_, RgbImage>;

    /// Its pyramid's levels after the first, when they are kept with the frame
    /// ([`Frame::coarse`]); `None`: the caller makes them.
    fn coarse_at(&self, work: WorkScale, levels: usize) -> Option<&[RgbImage]> {
        let _ = (work, levels);
        None
    }
}

impl AtWork for RgbImage {
    fn at_work(&self, work: WorkScale) -> Cow<'_, RgbImage> {
        work.image(self)
    }
}

impl AtWork for Frame {
    fn at_work(&self, work: WorkScale) -> Cow<'_, RgbImage> {
        self.at(work)
    }

    fn coarse_at(&self, work: WorkScale, levels: usize) -> Option<&[RgbImage]> {
        self.coarse(work, levels)
    }
}

impl WorkScale {
    /// `rgb` with, below full resolution, its image at this scale, halved on the calling
    /// thread alone ([`halve_image_into`]: a decode thread keeps its work off rayon's pool).
    /// Without `keep_full`, the frame at full resolution is let go once its working image is
    /// made (see [`Frame::full`]). With `recycler`, the working image is written into a buffer
    /// taken from it, and the frame's buffers go back to it when they are let go.
    pub fn frame(self, rgb: RgbImage, recycler: Option<&Recycler>, keep_full: bool) -> Frame {
        let buf = |len: usize| recycler.map_or_else(|| Vec::with_capacity(len), |r| r.take(len));
        let give = |img: RgbImage| {
            if let Some(r) = recycler {
                r.give(img.into_raw());
            }
        };
        let mut work = None;
        for _ in 0..self.halvings {
            let from: &RgbImage = work.as_ref().unwrap_or(&rgb);
            let len = (from.width() as usize / 2).max(1) * (from.height() as usize / 2).max(1) * 3;
            let next = halve_image_into(from, buf(len));
            if let Some(old) = work.replace(next) {
                give(old);
            }
        }
        let full = if keep_full || work.is_none() {
            Some(rgb)
        } else {
            give(rgb);
            None
        };
        Frame {
            full,
            work: work.map(|w| (self, w)),
            coarse: OnceLock::new(),
            recycler: recycler.cloned(),
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

    #[test]
    fn a_frame_made_beforehand_gives_the_working_image_the_tracker_would_make() {
        let img = RgbImage::from_fn(37, 22, |x, y| {
            image::Rgb([(x * 7) as u8, (y * 11) as u8, 3])
        });
        for halvings in 0..=MAX_HALVINGS {
            let w = WorkScale { halvings };
            let f = w.frame(img.clone(), None, true);
            assert_eq!(*f.at(w), *w.image(&img), "{halvings} halvings");
            assert_eq!(*f.full(), img);
            // Asked at another scale, it is made then, from the frame.
            let other = WorkScale {
                halvings: (halvings + 1) % (MAX_HALVINGS + 1),
            };
            assert_eq!(*f.at(other), *other.image(&img));
        }
        assert_eq!(Frame::plain(img.clone()).bytes(), 37 * 22 * 3);
        assert_eq!(
            WorkScale { halvings: 1 }
                .frame(img.clone(), None, true)
                .bytes(),
            37 * 22 * 3 + 18 * 11 * 3
        );
        // Made with a recycler: the same images, and their buffers go back to it when dropped.
        let r = Recycler::new();
        let w = WorkScale { halvings: 2 };
        let f = w.frame(img.clone(), Some(&r), true);
        assert_eq!(*f.at(w), *w.image(&img));
        let at = f.at(w).as_raw().as_ptr();
        drop(f);
        let again = r.take(9 * 5 * 3);
        assert_eq!(again.as_ptr(), at);
        // Made without its full image: the working image alone, and the full image's buffer
        // back with the recycler at once.
        let full = img.clone();
        let full_at = full.as_raw().as_ptr();
        let f = w.frame(full, Some(&r), false);
        assert_eq!(*f.at(w), *w.image(&img));
        assert_eq!(f.bytes(), 9 * 5 * 3);
        assert!(!f.has_full());
        let again = r.take(37 * 22 * 3);
        assert_eq!(again.as_ptr(), full_at);
        // At full resolution the frame is its working image: kept whatever is asked.
        let f = WorkScale::FULL.frame(img.clone(), None, false);
        assert_eq!(*f.full(), img);
    }
}
