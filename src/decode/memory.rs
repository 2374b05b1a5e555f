//! Frames held in memory, for tests and synthetic clips.

use super::{ClipInfo, FrameSource};
use crate::error::Result;
use image::RgbImage;

/// In-memory source for tests: frames given as a Vec, yielded in order.
#[derive(Debug)]
pub struct MemorySource {
    info: ClipInfo,
    frames: std::vec::IntoIter<RgbImage>,
}

impl MemorySource {
    /// A source yielding `frames` in order at `fps` frames per second. Its path is `<memory>`;
    /// an empty Vec gives a 0 × 0 clip with no frames.
    ///
    /// # Panics
    /// If the frames differ in size (a bug in the calling test, not user input).
    pub fn new(frames: Vec<RgbImage>, fps: f64) -> Self {
        let (width, height) = frames.first().map_or((0, 0), |f| f.dimensions());
        if let Some((i, f)) = frames
            .iter()
            .enumerate()
            .find(|(_, f)| f.dimensions() != (width, height))
        {
            panic!(
                "MemorySource: frame {i} is {}x{} but frame 0 is {width}x{height}",
                f.width(),
                f.height()
            );
        }
        let info = ClipInfo {
            path: "<memory>".into(),
            width,
            height,
            fps,
            frame_count_hint: Some(frames.len() as u64),
            stated_frames: Some(frames.len() as u64),
        };
        MemorySource {
            info,
            frames: frames.into_iter(),
        }
    }
}

impl FrameSource for MemorySource {
    fn info(&self) -> &ClipInfo {
        &self.info
    }

    fn next_frame(&mut self) -> Result<Option<RgbImage>> {
        Ok(self.frames.next())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yields_frames_in_order_then_none() {
        let frames: Vec<_> = (0..3)
            .map(|v| RgbImage::from_pixel(5, 4, image::Rgb([v, v, v])))
            .collect();
        let mut s = MemorySource::new(frames, 12.0);
        assert_eq!(
            (s.info().width, s.info().height, s.info().fps),
            (5, 4, 12.0)
        );
        assert_eq!(s.info().frame_count_hint, Some(3));
        for v in 0..3 {
            assert_eq!(s.next_frame().unwrap().unwrap().get_pixel(4, 3)[0], v);
        }
        assert!(s.next_frame().unwrap().is_none());
        assert!(s.next_frame().unwrap().is_none());
    }

    #[test]
    #[should_panic(expected = "frame 1 is 3x3")]
    fn mixed_sizes_panic() {
        MemorySource::new(vec![RgbImage::new(2, 2), RgbImage::new(3, 3)], 30.0);
    }
}
