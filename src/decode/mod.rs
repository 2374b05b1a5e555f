//! Frames in: a [`FrameSource`] yields a clip's frames one at a time, in display order, as RGB
//! images (see [`crate::geom`]'s Conventions for colour and time).
//!
//! Three sources implement it: a video file decoded by FFmpeg (`ffmpeg.rs`, behind the `ffmpeg`
//! feature), a folder of numbered PNG/JPEG frames (`images.rs`) and frames held in memory
//! (`memory.rs`, for tests). [`open`] picks the first two by looking at the path;
//! [`spawn_reader`] runs any source on its own thread so decoding overlaps with tracking, and
//! [`sample_frames`] reads a cheap, evenly spread subset of a clip for the background model.
//!
//! Frames are streamed: no source holds more than a few frames, whatever the clip's length.

#[cfg(feature = "ffmpeg")]
mod ffmpeg;
mod images;
mod memory;
mod recycle;
mod salvage;

use crate::error::{Error, Result};
use image::RgbImage;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{sync_channel, Receiver};

#[cfg(feature = "ffmpeg")]
pub use self::ffmpeg::FfmpegSource;
#[cfg(feature = "ffmpeg")]
pub(crate) use self::ffmpeg::{init as init_ffmpeg, Scaler};
pub use self::images::{natural_cmp, ImageFolderSource};
pub use self::memory::MemorySource;
pub use self::recycle::Recycler;
pub use self::salvage::{salvage, short_of_duration, DecodeStop, Salvage};

/// Threads each FFmpeg video decoder may use; 0 (the default) lets FFmpeg pick one per core.
static DECODER_THREADS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Limits every FFmpeg video decoder opened from now on to `threads` threads (0: one per core,
/// FFmpeg's choice). `mocap2d batch` sets it so that clips decoded side by side share the cores
/// instead of each taking all of them. Decoded frames do not depend on it.
pub fn set_decoder_threads(threads: usize) {
    DECODER_THREADS.store(threads, std::sync::atomic::Ordering::Relaxed);
}

/// The thread count set by [`set_decoder_threads`].
pub fn decoder_threads() -> usize {
    DECODER_THREADS.load(std::sync::atomic::Ordering::Relaxed)
}

/// Frame rate (frames per second) of an image folder when none is given.
pub const DEFAULT_IMAGE_FPS: f64 = 30.0;

/// What is known about a clip once it is open.
#[derive(Debug, Clone, PartialEq)]
pub struct ClipInfo {
    /// The video file or image folder the frames come from.
    pub path: PathBuf,
    /// Frame width in px; every frame a source yields has this size.
    pub width: u32,
    /// Frame height in px.
    pub height: u32,
    /// Frames per second: the override given to [`open`], else the container's average rate.
    pub fps: f64,
    /// Number of frames if the container states it (or, failing that, duration × fps). Only a
    /// hint for progress bars: the real count is how many frames the source yields.
    pub frame_count_hint: Option<u64>,
    /// Number of frames the file states exactly (the container's count, an image folder's
    /// files), `None` when unstated or only estimated. Fewer decoded frames mean a file cut short.
    pub stated_frames: Option<u64>,
}

/// Largest frame accepted, in px (width × height): 8K UHD, 7680 × 4320 (about 100 MB a frame
/// as RGB). Checked from the stream header or the first image's header, before any frame is
/// decoded, so a huge or corrupt size is refused instead of exhausting memory.
pub const MAX_FRAME_PIXELS: u64 = 7680 * 4320;
/// Largest frame width or height accepted, in px.
pub const MAX_FRAME_SIDE: u32 = 16384;

/// [`Error::Clip`] for a frame size above [`MAX_FRAME_PIXELS`] or [`MAX_FRAME_SIDE`].
pub(crate) fn check_frame_size(path: &Path, width: u32, height: u32) -> Result<()> {
    if width > MAX_FRAME_SIDE
        || height > MAX_FRAME_SIDE
        || u64::from(width) * u64::from(height) > MAX_FRAME_PIXELS
    {
        return Err(Error::Clip {
            path: path.to_owned(),
            msg: format!(
                "frames are {width}x{height} px, above the limit of {MAX_FRAME_PIXELS} px \
                 (7680x4320) and {MAX_FRAME_SIDE} px a side; scale the clip down first \
                 (e.g. ffmpeg -i IN -vf scale=1920:-2 OUT)"
            ),
        });
    }
    Ok(())
}

/// A clip's frames, one at a time, in display order.
pub trait FrameSource: Send {
    /// The clip's size, rate and path.
    fn info(&self) -> &ClipInfo;
    /// Next frame in display order (0-based index implied by call count), or Ok(None) at the end.
    fn next_frame(&mut self) -> Result<Option<RgbImage>>;
    /// From now on, writes frames into buffers taken from `recycler` where it can (the
    /// frames' bytes are the same). Sources that allocate nothing per frame ignore it.
    fn recycle_from(&mut self, recycler: Recycler) {
        let _ = recycler;
    }
}

/// Decodes every frame of `path` into memory, in order. For tests and short clips only:
/// `track` streams frames instead, so its memory does not grow with clip length.
pub fn read_all(path: &Path, fps: Option<f64>) -> Result<Vec<RgbImage>> {
    let mut source = open(path, fps)?;
    let mut frames = Vec::new();
    while let Some(f) = source.next_frame()? {
        frames.push(f);
    }
    Ok(frames)
}

/// Decodes frame `index` of `clip` (streaming through the frames before it).
/// [`Error::Usage`] when the clip is shorter.
pub fn read_frame(clip: &Path, fps: Option<f64>, index: u64) -> Result<RgbImage> {
    let mut source = open(clip, fps)?;
    let mut n = 0u64;
    while let Some(f) = source.next_frame()? {
        if n == index {
            return Ok(f);
        }
        n += 1;
    }
    Err(Error::Usage(format!(
        "--frame {index} is beyond {}, which has {n} frames (0 to {}); give a frame of the clip",
        clip.display(),
        n.saturating_sub(1)
    )))
}

/// Opens a video file (via FFmpeg, feature "ffmpeg") or a directory of numbered PNG/JPEG frames
/// (natural sort: frame2 < frame10); `fps` (frames per second) overrides the video's rate or sets
/// the folder's (image folders default to [`DEFAULT_IMAGE_FPS`]).
///
/// Errors: [`Error::Clip`] for a missing path, a file FFmpeg cannot decode, a folder without
/// frames or with frames of different sizes; [`Error::Usage`] for a non-positive `fps`.
pub fn open(path: &Path, fps: Option<f64>) -> Result<Box<dyn FrameSource>> {
    open_with(path, fps, open_video)
}

/// [`open`] for a source read on its own thread beside the tracker ([`spawn_reader`]): a video's
/// decoder gets one thread for frames up to [`BESIDE_ONE_THREAD_PX`] (see there), FFmpeg's
/// choice above. The frames are the same.
pub fn open_beside_tracking(path: &Path, fps: Option<f64>) -> Result<Box<dyn FrameSource>> {
    open_with(path, fps, open_video_beside)
}

/// How [`open_with`] opens a video file (the FFmpeg source, or a test's stand-in).
type OpenVideo = fn(&Path, Option<f64>) -> Result<Box<dyn FrameSource>>;

/// [`open`] with `video` opening a video file.
fn open_with(path: &Path, fps: Option<f64>, video: OpenVideo) -> Result<Box<dyn FrameSource>> {
    check_fps(fps)?;
    let meta = clip_metadata(path)?;
    if meta.is_dir() {
        let source = ImageFolderSource::open(path, fps.unwrap_or(DEFAULT_IMAGE_FPS))?;
        return Ok(Box::new(source));
    }
    video(path, fps)
}

/// Frames of at most this many pixels (1280×720) are decoded on one thread beside tracking
/// ([`open_beside_tracking`]): about 1 ms a frame at 720p, a fifth of what tracking takes, so
/// the decoder fills the tracker's idle moments instead of FFmpeg's frame threads (one per core
/// and one more) taking cores from the tracker's parallel sections. Larger frames keep FFmpeg's
/// choice, lest decoding fall behind.
pub const BESIDE_ONE_THREAD_PX: u64 = 1280 * 720;

#[cfg(feature = "ffmpeg")]
fn open_video(path: &Path, fps: Option<f64>) -> Result<Box<dyn FrameSource>> {
    Ok(Box::new(FfmpegSource::open(path, fps)?))
}

#[cfg(feature = "ffmpeg")]
fn open_video_beside(path: &Path, fps: Option<f64>) -> Result<Box<dyn FrameSource>> {
    let threads = |w: u32, h: u32| {
        if u64::from(w) * u64::from(h) <= BESIDE_ONE_THREAD_PX {
            1
        } else {
            decoder_threads()
        }
    };
    Ok(Box::new(FfmpegSource::open_with_threads(
        path, fps, threads,
    )?))
}

#[cfg(not(feature = "ffmpeg"))]
fn open_video(path: &Path, _fps: Option<f64>) -> Result<Box<dyn FrameSource>> {
    Err(no_ffmpeg(path))
}

#[cfg(not(feature = "ffmpeg"))]
fn open_video_beside(path: &Path, _fps: Option<f64>) -> Result<Box<dyn FrameSource>> {
    Err(no_ffmpeg(path))
}

#[cfg(not(feature = "ffmpeg"))]
fn no_ffmpeg(path: &Path) -> Error {
    Error::Clip {
        path: path.to_owned(),
        msg: "reading video files needs the `ffmpeg` feature; rebuild with it, or give a \
              folder of numbered PNG/JPEG frames"
            .into(),
    }
}

/// Up to `n` frames spread evenly across the clip, for the background model (temporal median).
///
/// Much cheaper than a full decode on long videos: FFmpeg seeks to `n` evenly spaced timestamps
/// and reads (demuxing only, no decoding) which keyframe each lands on; if at least `n / 2` are
/// distinct, it decodes just those keyframes. Otherwise (short clip, few keyframes: x264 puts one
/// every 250 frames) a spread sample needs the frames before each chosen one decoded back to its
/// keyframe, so it makes one sequential pass: the frames' timestamps, read by demuxing, say
/// which `n` to take (an evenly thinned subset of every frame), and the decoder skips every
/// non-reference frame (one no other frame is predicted from) that is not among them, and stops
/// after the last; only the `n` chosen are converted to RGB. Either way the same clip gives the
/// same frames, at any thread count. Image folders read the `n` chosen files directly. Frames
/// come back in clip order.
pub fn sample_frames(path: &Path, n: usize) -> Result<Vec<RgbImage>> {
    Ok(sample_frames_and(path, n, None)?.0)
}

/// [`sample_frames`], and frame `also` (counted from 0) when the sample is taken by one
/// sequential decode that reaches it: the frame a fresh decode would give, so that the caller
/// need not decode the clip up to it again. `None` otherwise (keyframes sampled, an image
/// folder, a clip that ends or breaks before it): read it yourself.
pub fn sample_frames_and(
    path: &Path,
    n: usize,
    also: Option<u64>,
) -> Result<(Vec<RgbImage>, Option<RgbImage>)> {
    let meta = clip_metadata(path)?;
    if meta.is_dir() {
        return Ok((images::sample(path, n)?, None));
    }
    #[cfg(feature = "ffmpeg")]
    {
        ffmpeg::sample(path, n, also)
    }
    #[cfg(not(feature = "ffmpeg"))]
    {
        let _ = also;
        Err(no_ffmpeg(path))
    }
}

/// Runs a source on its own named thread ("decode"), sending frames through a bounded channel
/// (`std::sync::mpsc::sync_channel`) of `capacity` frames, so decode overlaps with tracking.
///
/// Items are `(frame index, frame)`, indices counting from 0. A decode error is sent as the last
/// item; after the last frame the channel closes. Dropping the receiver stops the thread at its
/// next send.
pub fn spawn_reader(
    source: Box<dyn FrameSource>,
    capacity: usize,
) -> Receiver<Result<(u64, RgbImage)>> {
    spawn_reader_with(source, capacity, |frame| frame)
}

/// [`spawn_reader`], each frame passed through `prepare` on the decode thread before it is
/// sent: work on a frame that the consumer would otherwise do (the tracker's working image)
/// then overlaps with the consumer's, on a frame the decoder has just written.
pub fn spawn_reader_with<T: Send + 'static>(
    mut source: Box<dyn FrameSource>,
    capacity: usize,
    mut prepare: impl FnMut(RgbImage) -> T + Send + 'static,
) -> Receiver<Result<(u64, T)>> {
    let (tx, rx) = sync_channel(capacity);
    let path = source.info().path.clone();
    let fallback = tx.clone();
    let spawned = std::thread::Builder::new()
        .name("decode".into())
        .spawn(move || {
            let mut index = 0u64;
            loop {
                let item = match source.next_frame() {
                    Ok(Some(frame)) => Ok((index, prepare(frame))),
                    Ok(None) => return,
                    Err(e) => Err(e),
                };
                let failed = item.is_err();
                if tx.send(item).is_err() || failed {
                    return;
                }
                index += 1;
            }
        });
    if let Err(e) = spawned {
        // The closure (and its sender) is gone; report through the spare sender. A zero-capacity
        // channel would block here with nobody receiving yet, so try_send.
        let _ = fallback.try_send(Err(Error::Decode {
            path,
            frame: 0,
            msg: format!("cannot start the decode thread: {e}"),
        }));
    }
    rx
}

/// Rejects a frame rate that is not a positive, finite number of frames per second.
fn check_fps(fps: Option<f64>) -> Result<()> {
    match fps {
        Some(f) if !(f.is_finite() && f > 0.0) => Err(Error::Usage(format!(
            "frame rate must be a positive number of frames per second, got {f}"
        ))),
        _ => Ok(()),
    }
}

/// The clip path's metadata, or [`Error::Clip`] saying it does not exist.
fn clip_metadata(path: &Path) -> Result<std::fs::Metadata> {
    std::fs::metadata(path).map_err(|e| {
        let msg = if e.kind() == std::io::ErrorKind::NotFound {
            "no such file or folder; give a video file or a folder of numbered PNG/JPEG frames"
                .to_string()
        } else {
            format!("cannot open the clip: {e}")
        };
        Error::Clip {
            path: path.to_owned(),
            msg,
        }
    })
}

/// `count` indices spread evenly over `0..len` (the centre of each of `count` equal slices), or
/// all of them when `count >= len`. Increasing, without repeats.
pub(crate) fn spread_indices(len: usize, count: usize) -> Vec<usize> {
    if count >= len {
        return (0..len).collect();
    }
    (0..count)
        .map(|i| ((2 * i + 1) * len) / (2 * count))
        .collect()
}

#[cfg(test)]
mod tests;
