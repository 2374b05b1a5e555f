//! The clip's frames and `tracks.csv` as the correction page asks for them, kept between
//! requests: the decoder where it stopped (stepping forward is cheap), the last few frames as
//! PNG, and the tracks as last read.

use super::draw::png_bytes;
use super::reply::Reply;
use crate::decode::FrameSource;
use crate::run::TrackRow;
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

/// Frames kept as PNG.
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
    recent: VecDeque<(u64, Arc<Vec<u8>>)>,
}

impl FrameCache {
    /// Frame `n` (digits) of `clip` decoded at `fps`, as a PNG reply: 404 for a frame that is
    /// not a number or is beyond the clip.
    pub fn png(&self, clip: &std::path::Path, fps: Option<f64>, n: &str) -> Reply {
        let Ok(f) = n.parse::<u64>() else {
            return Reply::error(404, format!("no frame {n:?}: frames are numbers"));
        };
        let mut d = self.decoder.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, png)) = d.recent.iter().find(|(g, _)| *g == f) {
            return png_reply(png);
        }
        if d.source.as_ref().is_none_or(|(_, next)| *next > f) {
            match crate::decode::open(clip, fps) {
                Ok(s) => d.source = Some((s, 0)),
                Err(e) => return Reply::error(500, e.to_string()),
            }
        }
        let (source, next) = d.source.as_mut().expect("opened above");
        let img = loop {
            match source.next_frame() {
                Ok(Some(img)) if *next == f => {
                    *next += 1;
                    break img;
                }
                Ok(Some(_)) => *next += 1,
                Ok(None) => {
                    d.source = None;
                    return Reply::error(
                        404,
                        format!("frame {f} is beyond the clip {}", clip.display()),
                    );
                }
                Err(e) => {
                    d.source = None;
                    return Reply::error(500, e.to_string());
                }
            }
        };
        let png = Arc::new(png_bytes(&img));
        if d.recent.len() >= KEEP_FRAMES {
            d.recent.pop_front();
        }
        d.recent.push_back((f, png.clone()));
        png_reply(&png)
    }
}

fn png_reply(png: &Arc<Vec<u8>>) -> Reply {
    Reply {
        status: 200,
        content_type: "image/png",
        body: png.as_ref().clone(),
    }
}
