//! Video files decoded by FFmpeg (ffmpeg-next), converted to RGB one frame at a time.

use super::{spread_indices, ClipInfo, FrameSource, Recycler, DEFAULT_IMAGE_FPS};
use crate::error::{Error, Result};
use ff::codec::threading;
use ff::format::Pixel;
use ff::software::scaling;
use ff::{Rational, Rescale};
use ffmpeg_next as ff;
use image::RgbImage;
use std::collections::{HashMap, HashSet};
use std::path::Path;

mod rgb;
mod sampling;

use rgb::RgbConverter;

/// FFmpeg's timestamps without a value (`AV_NOPTS_VALUE`).
const NO_PTS: i64 = i64::MIN;
/// The unit of `avformat_seek_file` with no stream (`AV_TIME_BASE`): microseconds.
const MICROSECONDS: Rational = Rational(1, 1_000_000);

/// FFmpeg's own log level. Its error lines (`[h264 @ 0x…] mmco: unref short failure` after a
/// seek, `moov atom not found`, concealed damage) go straight to stderr, unprefixed by us and
/// mostly harmless; what matters reaches the user as our error, which names the file and quotes
/// FFmpeg's error code. Fatal still lets through FFmpeg's last words before it aborts.
const FFMPEG_LOG_LEVEL: ff::util::log::Level = ff::util::log::Level::Fatal;

/// Initialises FFmpeg once per process and silences its logging (see [`FFMPEG_LOG_LEVEL`]).
pub(crate) fn init() {
    static INIT: std::sync::Once = std::sync::Once::new();
    INIT.call_once(|| {
        // Only registers codecs on FFmpeg < 5; it cannot fail in a way worth reporting.
        let _ = ff::init();
        ff::util::log::set_level(FFMPEG_LOG_LEVEL);
    });
}

/// A video file's frames, decoded by FFmpeg with frame threading and converted to RGB.
pub struct FfmpegSource {
    info: ClipInfo,
    input: ff::format::context::Input,
    stream_index: usize,
    decoder: ff::decoder::Video,
    /// The last frame the decoder gave, reused.
    decoded: ff::frame::Video,
    to_rgb: RgbConverter,
    /// The demuxer is exhausted and the decoder told so; only buffered frames remain.
    eof_sent: bool,
    /// Frames returned so far (for error messages).
    frames_out: u64,
    /// When set, the decoder skips every non-reference frame except those whose packets carry
    /// one of these timestamps (pts): the frames nothing else is predicted from cost nothing
    /// unless they are wanted.
    decode_only: Option<HashSet<i64>>,
}

/// A scaler (pixel-format converter) context, made `Send`.
pub(crate) struct Scaler(pub(crate) scaling::Context);

// SAFETY: an `SwsContext` holds no thread-local state; it is only unsafe to use from two threads
// at once, which `&mut` access through `FfmpegSource` rules out. ffmpeg-next only omits the impl.
unsafe impl Send for Scaler {}

impl std::fmt::Debug for FfmpegSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FfmpegSource")
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

/// Whether FFmpeg's demuxer `name` reads still pictures: `image2` (a picture file named as
/// one) and the `*_pipe` demuxers (a picture's content, whatever its name; a pipe of several
/// pictures is a clip).
fn is_picture_demuxer(name: &str) -> bool {
    name.split(',')
        .any(|n| n == "image2" || n.ends_with("_pipe"))
}

/// The packets of stream `index` in the file at `path`, counted up to `most` (0 when it does
/// not open again).
fn packets_up_to(path: &Path, index: usize, most: usize) -> usize {
    let Ok(mut input) = ff::format::input(path) else {
        return 0;
    };
    input
        .packets()
        .filter(|(s, _)| s.index() == index)
        .take(most)
        .count()
}

impl FfmpegSource {
    /// Opens the best video stream of `path`; `fps` (frames per second) overrides the stream's
    /// average rate (30 if the container states none).
    ///
    /// Errors: [`Error::Clip`] if FFmpeg cannot open the file, it has no video stream, or FFmpeg
    /// has no decoder for its codec.
    pub fn open(path: &Path, fps: Option<f64>) -> Result<Self> {
        Self::open_with_threads(path, fps, |_, _| super::decoder_threads())
    }

    /// [`FfmpegSource::open`] with the decoder's thread count given by `threads(width, height)`
    /// of the stream's frames (0: one per core, FFmpeg's choice). Decoded frames do not depend
    /// on it.
    pub fn open_with_threads(
        path: &Path,
        fps: Option<f64>,
        threads: impl Fn(u32, u32) -> usize,
    ) -> Result<Self> {
        init();
        let clip_err = |msg: String| Error::Clip {
            path: path.to_owned(),
            msg,
        };
        if !path.exists() {
            return Err(clip_err("no such file or folder".into()));
        }
        if path.to_str().is_none() {
            // FFmpeg's bindings take the path as UTF-8 text.
            return Err(clip_err(
                "its path is not valid UTF-8, which FFmpeg cannot open; rename the file (or \
                 the folder holding it) to a UTF-8 name"
                    .into(),
            ));
        }
        let input = ff::format::input(path).map_err(|e| {
            let empty = std::fs::metadata(path).is_ok_and(|m| m.len() == 0);
            clip_err(if empty {
                "the file is empty (0 bytes); give a video file or a folder of frames".into()
            } else {
                format!(
                    "not a video FFmpeg can decode ({e}); if it is one, it may be cut short \
                     (an MP4 or MOV whose index is at its end cannot be read at all when the end \
                     is missing: copy or record it again)"
                )
            })
        })?;
        let stream = input
            .streams()
            .best(ff::media::Type::Video)
            .ok_or_else(|| clip_err("has no video stream".into()))?;
        let stream_index = stream.index();
        // A picture (PNG, JPEG, … whatever its name) opens as a one-frame "video": say so
        // rather than track a single frame.
        let demuxer = input.format().name().to_owned();
        if is_picture_demuxer(&demuxer) && packets_up_to(path, stream_index, 2) < 2 {
            return Err(clip_err(format!(
                "a single picture (FFmpeg reads it as `{demuxer}`), not a video: one frame has \
                 no motion to track; give the video, or a folder of its frames as numbered \
                 PNG/JPEG files"
            )));
        }
        let time_base = stream.time_base();
        let mut context = ff::codec::context::Context::from_parameters(stream.parameters())
            .map_err(|e| clip_err(format!("cannot read the video stream's parameters ({e})")))?;
        // The frame size the stream states, before the decoder opens (it may correct it).
        // SAFETY: `context` owns a valid AVCodecContext, filled from the stream's parameters.
        let (stated_w, stated_h) = unsafe {
            let c = context.as_ptr();
            ((*c).width.max(0) as u32, (*c).height.max(0) as u32)
        };
        // Decoders are single-threaded unless asked; count 0 lets FFmpeg pick one per core.
        context.set_threading(threading::Config {
            kind: threading::Type::Frame,
            count: threads(stated_w, stated_h),
            ..Default::default()
        });
        let mut decoder = context.decoder();
        decoder.set_packet_time_base(time_base);
        let codec_id = decoder.id();
        let decoder = decoder.video().map_err(|e| {
            clip_err(format!(
                "FFmpeg cannot decode its video codec {codec_id:?} ({e})"
            ))
        })?;
        let (width, height) = (decoder.width(), decoder.height());
        if width == 0 || height == 0 {
            return Err(clip_err("the video stream states no frame size".into()));
        }
        super::check_frame_size(path, width, height)?;
        let fps = fps.unwrap_or_else(|| stream_fps(&stream));
        let frame_count_hint = if stream.frames() > 0 {
            Some(stream.frames() as u64)
        } else {
            duration_seconds(&input, &stream)
                .map(|s| (s * fps).round() as u64)
                .filter(|&n| n > 0)
        };
        let info = ClipInfo {
            path: path.to_owned(),
            width,
            height,
            fps,
            frame_count_hint,
            stated_frames: u64::try_from(stream.frames()).ok().filter(|&n| n > 0),
        };
        Ok(FfmpegSource {
            info,
            input,
            stream_index,
            decoder,
            decoded: ff::frame::Video::empty(),
            to_rgb: RgbConverter::new(width, height),
            eof_sent: false,
            frames_out: 0,
            decode_only: None,
        })
    }

    fn decode_error(&self, msg: String) -> Error {
        Error::Decode {
            path: self.info.path.clone(),
            frame: self.frames_out,
            msg,
        }
    }

    /// Decodes the next frame into `self.decoded`; false at the end of the stream. Sends EOF to
    /// the decoder when the file runs out, so the frames it still buffers come out too.
    fn decode_next(&mut self) -> Result<bool> {
        loop {
            match self.decoder.receive_frame(&mut self.decoded) {
                Ok(()) => return Ok(true),
                Err(ff::Error::Eof) => return Ok(false),
                Err(ff::Error::Other {
                    errno: ff::error::EAGAIN,
                }) => {}
                Err(e) => return Err(self.decode_error(format!("FFmpeg failed to decode ({e})"))),
            }
            if self.eof_sent {
                // EAGAIN after EOF cannot happen with a working decoder; do not spin.
                return Ok(false);
            }
            self.feed_packet()?;
        }
    }

    /// Sends the next packet of the video stream to the decoder, or EOF if there is none.
    fn feed_packet(&mut self) -> Result<()> {
        let mut packet = ff::Packet::empty();
        loop {
            match packet.read(&mut self.input) {
                Ok(()) if packet.stream() == self.stream_index => {
                    if let Some(wanted) = &self.decode_only {
                        // Read by the decoder (and copied to its frame threads) per packet.
                        let wanted = packet.pts().is_some_and(|t| wanted.contains(&t));
                        self.decoder.skip_frame(if wanted {
                            ff::Discard::Default
                        } else {
                            ff::Discard::NonReference
                        });
                    }
                    return self
                        .decoder
                        .send_packet(&packet)
                        .map_err(|e| self.decode_error(format!("FFmpeg rejected a packet ({e})")));
                }
                Ok(()) => {} // audio, subtitles, another video stream
                // A corrupt packet the demuxer can resync past (as its own iterator does).
                Err(ff::Error::InvalidData) => {}
                Err(ff::Error::Eof) => {
                    self.eof_sent = true;
                    return self.decoder.send_eof().map_err(|e| {
                        self.decode_error(format!("FFmpeg failed at the end of the clip ({e})"))
                    });
                }
                Err(e) => return Err(self.decode_error(format!("cannot read the file ({e})"))),
            }
        }
    }

    /// Converts `self.decoded` to an RGB image of the clip's size.
    fn convert(&mut self) -> Result<RgbImage> {
        self.to_rgb
            .convert(&self.decoded)
            .map_err(|msg| self.decode_error(msg))
    }
}

impl FrameSource for FfmpegSource {
    fn info(&self) -> &ClipInfo {
        &self.info
    }

    fn recycle_from(&mut self, recycler: Recycler) {
        self.to_rgb.recycler = Some(recycler);
    }

    fn next_frame(&mut self) -> Result<Option<RgbImage>> {
        if !self.decode_next()? {
            return Ok(None);
        }
        let frame = self.convert()?;
        self.frames_out += 1;
        Ok(Some(frame))
    }
}

/// Up to `n` frames spread over the video at `path`: the keyframes at or before `n` evenly
/// spaced timestamps if at least `n / 2` are distinct, else one sequential pass that skips the
/// non-reference frames it does not take (see [`super::sample_frames`]). Which way is decided
/// by demuxing alone, so a clip with few keyframes is decoded once, not once per seek and then
/// again.
/// With `also`, that frame too when the sequential decode reaches it (see
/// [`super::sample_frames_and`]).
pub(super) fn sample(
    path: &Path,
    n: usize,
    also: Option<u64>,
) -> Result<(Vec<RgbImage>, Option<RgbImage>)> {
    if n == 0 {
        return Ok((Vec::new(), None));
    }
    let mut source = FfmpegSource::open(path, None)?;
    let targets = source.keyframe_targets(n);
    if targets.len() * 2 >= n {
        let sampled = source.decode_at(&targets);
        if sampled.len() * 2 >= n {
            return Ok((sampled, None));
        }
    }
    drop(source);
    // A fresh decoder from the start: the same frames, in the same order, as `track` gets.
    FfmpegSource::open(path, None)?.sample_sequentially(n, also)
}

/// The stream's average frame rate, else its base rate, else 30 frames per second.
fn stream_fps(stream: &ff::format::stream::Stream) -> f64 {
    [stream.avg_frame_rate(), stream.rate()]
        .into_iter()
        .find(|r| r.numerator() > 0 && r.denominator() > 0)
        .map_or(DEFAULT_IMAGE_FPS, f64::from)
}

/// The stream's (else the container's) duration in seconds, if stated.
fn duration_seconds(
    input: &ff::format::context::Input,
    stream: &ff::format::stream::Stream,
) -> Option<f64> {
    if stream.duration() > 0 {
        Some(stream.duration() as f64 * f64::from(stream.time_base()))
    } else if input.duration() > 0 {
        Some(input.duration() as f64 / 1e6)
    } else {
        None
    }
}

#[cfg(test)]
mod tests;
