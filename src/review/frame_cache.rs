//! The clip's frames and `tracks.csv` as the correction page asks for them, kept between
//! requests: the decoder where it stopped (stepping forward is cheap), the last few frames
//! (decoded, and as PNG once asked for: the picture shown and the Detect button read the same
//! frame), and the tracks as last read.

use super::draw::png_bytes;
use super::reply::Reply;
use crate::decode::FrameSource;
use crate::run::TrackRow;
use image::RgbImage;
use std::collections::VecDeque;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

/// Frames kept.
const KEEP_FRAMES: usize = 3;

/// The clip's decoder where it stopped, the last frames as PNG, and `tracks.csv` as last read.
#[derive(Default)]
pub struct FrameCache {
    decoder: Mutex<Decoder>,
    pub(super) tracks: Mutex<Option<TracksRead>>,
}

/// `tracks.csv` as read: its modification time and size then, and its rows.
type TracksRead = (Option<SystemTime>, u64, Arc<Vec<TrackRow>>);

#[derive(Default)]
struct Decoder {
    /// The open clip and the number of the frame it gives next.
    source: Option<(Box<dyn FrameSource>, u64)>,
    recent: VecDeque<Kept>,
}

/// A decoded frame kept, and its PNG once asked for.
struct Kept {
    frame: u64,
    image: Arc<RgbImage>,
    png: Option<Arc<Vec<u8>>>,
}

impl FrameCache {
    /// Frame `n` (digits) of `clip` decoded at `fps`, as a PNG reply: 404 for a frame that is
    /// not a number or is beyond the clip.
    pub fn png(&self, clip: &Path, fps: Option<f64>, n: &str) -> Reply {
        let Ok(f) = n.parse::<u64>() else {
            return Reply::error(404, format!("no frame {n:?}: frames are numbers"));
        };
        let mut d = self.decoder.lock().unwrap_or_else(|e| e.into_inner());
        let at = match d.frame(clip, fps, f) {
            Ok(i) => i,
            Err(r) => return r,
        };
        let entry = &mut d.recent[at];
        let png = entry
            .png
            .get_or_insert_with(|| Arc::new(png_bytes(&entry.image)))
            .clone();
        png_reply(&png)
    }

    /// Frame `f` of `clip` decoded at `fps` (kept with the last few, as [`FrameCache::png`]
    /// keeps them), or the error reply: 404 beyond the clip, 500 when it cannot be decoded.
    pub fn image(
        &self,
        clip: &Path,
        fps: Option<f64>,
        f: u64,
    ) -> std::result::Result<Arc<RgbImage>, Reply> {
        let mut d = self.decoder.lock().unwrap_or_else(|e| e.into_inner());
        let at = d.frame(clip, fps, f)?;
        Ok(d.recent[at].image.clone())
    }
}

impl Decoder {
    /// The index in `recent` of frame `f`, decoded if it is not kept.
    fn frame(
        &mut self,
        clip: &Path,
        fps: Option<f64>,
        f: u64,
    ) -> std::result::Result<usize, Reply> {
        if let Some(i) = self.recent.iter().position(|k| k.frame == f) {
            return Ok(i);
        }
        if self.source.as_ref().is_none_or(|(_, next)| *next > f) {
            match crate::decode::open(clip, fps) {
                Ok(s) => self.source = Some((s, 0)),
                Err(e) => return Err(Reply::error(500, e.to_string())),
            }
        }
        let (source, next) = self.source.as_mut().expect("opened above");
        let img = loop {
            match source.next_frame() {
                Ok(Some(img)) if *next == f => {
                    *next += 1;
                    break img;
                }
                Ok(Some(_)) => *next += 1,
                Ok(None) => {
                    self.source = None;
                    return Err(Reply::error(
                        404,
                        format!("frame {f} is beyond the clip {}", clip.display()),
                    ));
                }
                Err(e) => {
                    self.source = None;
                    return Err(Reply::error(500, e.to_string()));
                }
            }
        };
        if self.recent.len() >= KEEP_FRAMES {
            self.recent.pop_front();
        }
        self.recent.push_back(Kept {
            frame: f,
            image: Arc::new(img),
            png: None,
        });
        Ok(self.recent.len() - 1)
    }
}

fn png_reply(png: &Arc<Vec<u8>>) -> Reply {
    Reply {
        status: 200,
        content_type: "image/png",
        body: png.as_ref().clone(),
    }
}
