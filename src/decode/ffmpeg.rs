//! Video files decoded by FFmpeg (ffmpeg-next), converted to RGB one frame at a time.

use super::{spread_indices, ClipInfo, FrameSource, DEFAULT_IMAGE_FPS};
use crate::error::{Error, Result};
use ff::codec::threading;
use ff::format::Pixel;
use ff::software::scaling;
use ff::{Rational, Rescale};
use ffmpeg_next as ff;
use image::RgbImage;
use std::collections::HashSet;
use std::path::Path;

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
}

/// Converts decoded frames to RGB images of the clip's size.
struct RgbConverter {
    width: u32,
    height: u32,
    scaler: Option<Scaler>,
    /// The (padded) RGB frame the scaler writes, reused.
    rgb: ff::frame::Video,
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
            to_rgb: RgbConverter {
                width,
                height,
                scaler: None,
                rgb: ff::frame::Video::new(Pixel::RGB24, width, height),
            },
            eof_sent: false,
            frames_out: 0,
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

    /// The keyframe at or before each of `n` evenly spaced timestamps (the centres of `n` equal
    /// slices of the stream's duration), found by seeking and reading the first video packet
    /// there, without decoding. Returns one target (µs) per distinct keyframe, the first that
    /// lands on it, in clip order: seeking to it again lands on that keyframe. Empty when the file
    /// states no duration or cannot seek. A few milliseconds, however many targets share a
    /// keyframe, so a clip with few keyframes costs nothing to rule out.
    fn keyframe_targets(&mut self, n: usize) -> Vec<i64> {
        let Some((start_us, duration_us)) = self.time_span_us() else {
            return Vec::new();
        };
        let mut seen = HashSet::new();
        let mut targets = Vec::new();
        let mut packet = ff::Packet::empty();
        'targets: for i in 0..n as i64 {
            let target = start_us + ((2 * i + 1) * duration_us) / (2 * n as i64);
            // The keyframe at or before the target.
            if self.input.seek(target, ..target).is_err() {
                break;
            }
            let landed = loop {
                match packet.read(&mut self.input) {
                    Ok(()) if packet.stream() == self.stream_index => {
                        break packet.pts().or(packet.dts());
                    }
                    Ok(()) | Err(ff::Error::InvalidData) => {}
                    Err(_) => continue 'targets,
                }
            };
            // Without a timestamp there is nothing to compare: keep it, as decoding would.
            if landed.is_none_or(|ts| seen.insert(ts)) {
                targets.push(target);
            }
        }
        targets
    }

    /// The first frame decoded after seeking to each of `targets` (µs), skipping a frame already
    /// taken (same timestamp). Stops early, with what it has, on a seek or decode error: this is
    /// only a sample, and the caller decides whether it is enough.
    fn decode_at(&mut self, targets: &[i64]) -> Vec<RgbImage> {
        let mut seen = HashSet::new();
        let mut frames = Vec::new();
        for &target in targets {
            if self.input.seek(target, ..target).is_err() {
                break;
            }
            self.decoder.flush();
            self.eof_sent = false;
            match self.decode_next() {
                Ok(true) => {}
                Ok(false) => continue,
                Err(_) => break,
            }
            if let Some(ts) = self.decoded.timestamp() {
                if !seen.insert(ts) {
                    continue;
                }
            }
            match self.convert() {
                Ok(frame) => frames.push(frame),
                Err(_) => break,
            }
        }
        frames
    }

    /// One frame at the keyframe at or before each of `n` evenly spaced timestamps, distinct
    /// keyframes only, in clip order. Fewer frames (possibly none) when the file cannot seek or
    /// has few keyframes.
    #[cfg(test)]
    fn sample_by_seeking(&mut self, n: usize) -> Vec<RgbImage> {
        let targets = self.keyframe_targets(n);
        self.decode_at(&targets)
    }

    /// The video stream's start and duration in microseconds, if the file states a duration.
    fn time_span_us(&self) -> Option<(i64, i64)> {
        let stream = self.input.stream(self.stream_index)?;
        let tb = stream.time_base();
        let start = match stream.start_time() {
            NO_PTS => 0,
            t => t.rescale(tb, MICROSECONDS),
        };
        let duration = if stream.duration() > 0 {
            stream.duration().rescale(tb, MICROSECONDS)
        } else {
            self.input.duration()
        };
        (duration > 0).then_some((start, duration))
    }

    /// `n` frames spread over the clip from one sequential decode. Keeps every `stride`-th frame,
    /// doubling `stride` (and dropping every other kept frame) whenever `2n` are held, so memory
    /// stays bounded whatever the clip's length. Kept frames are the decoder's own (reference
    /// counted, not copied); only the `n` chosen at the end are converted to RGB.
    ///
    /// Frame `also`, when given and reached, is converted too and returned beside them.
    fn sample_sequentially(
        &mut self,
        n: usize,
        also: Option<u64>,
    ) -> Result<(Vec<RgbImage>, Option<RgbImage>)> {
        let mut extra = None;
        let mut kept: Vec<(u64, ff::frame::Video)> = Vec::new();
        let mut stride = 1u64;
        let mut index = 0u64;
        // A clip damaged part-way is sampled from the frames before the damage (as `track`
        // tracks those); one that decodes no frame at all is an error.
        while match self.decode_next() {
            Ok(more) => more,
            Err(_) if !kept.is_empty() => false,
            Err(e) => return Err(e),
        } {
            if also == Some(index) {
                // A frame that will not convert is left to the caller's own decode.
                extra = self.to_rgb.convert(&self.decoded).ok();
            }
            if index.is_multiple_of(stride) {
                // Take the frame; the next `receive_frame` fills a fresh one.
                let frame = std::mem::replace(&mut self.decoded, ff::frame::Video::empty());
                kept.push((index, frame));
                if kept.len() >= 2 * n {
                    kept = kept.into_iter().step_by(2).collect();
                    stride *= 2;
                }
            }
            index += 1;
            self.frames_out += 1;
        }
        let mut frames = Vec::with_capacity(n);
        for i in spread_indices(kept.len(), n) {
            let (index, frame) = &kept[i];
            frames.push(self.to_rgb.convert(frame).map_err(|msg| Error::Decode {
                path: self.info.path.clone(),
                frame: *index,
                msg,
            })?);
        }
        Ok((frames, extra))
    }
}

impl RgbConverter {
    /// `frame` as an RGB image of the clip's size; the error says what could not be converted.
    fn convert(&mut self, frame: &ff::frame::Video) -> std::result::Result<RgbImage, String> {
        let (w, h) = (self.width, self.height);
        let src = (frame.format(), frame.width(), frame.height());
        let stale = self.scaler.as_ref().is_none_or(|s| {
            let i = s.0.input();
            (i.format, i.width, i.height) != src
        });
        if stale {
            // A stream can change size mid-clip; every frame still comes out at the first size.
            let ctx = scaling::Context::get(
                src.0,
                src.1,
                src.2,
                Pixel::RGB24,
                w,
                h,
                // Without ACCURATE_RND, same-size yuv420p → RGB takes swscale's SIMD fast path:
                // about 1.4 ms less a 720p frame (2.5 vs 3.8 s of CPU for 900 frames).
                scaling::Flags::BILINEAR,
            )
            .map_err(|e| {
                format!(
                    "cannot convert {:?} {}x{} to RGB ({e})",
                    src.0, src.1, src.2
                )
            })?;
            self.scaler = Some(Scaler(ctx));
        }
        // Cannot fail: a scaler was made just above when none matched.
        let scaler = self.scaler.as_mut().expect("scaler set above");
        scaler
            .0
            .run(frame, &mut self.rgb)
            .map_err(|e| format!("cannot convert the frame to RGB ({e})"))?;
        // Rows are padded to the stride (e.g. at odd widths): copy only the pixels.
        let stride = self.rgb.stride(0);
        let data = self.rgb.data(0);
        let row = w as usize * 3;
        let mut out = Vec::with_capacity(row * h as usize);
        for y in 0..h as usize {
            out.extend_from_slice(&data[y * stride..y * stride + row]);
        }
        // Cannot fail: `out` holds exactly h rows of w*3 bytes.
        Ok(RgbImage::from_raw(w, h, out).expect("buffer is width*height*3"))
    }
}

impl FrameSource for FfmpegSource {
    fn info(&self) -> &ClipInfo {
        &self.info
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
/// spaced timestamps if at least `n / 2` are distinct, else one sequential decode (see
/// [`super::sample_frames`]). Which way is decided by demuxing alone, so a clip with few
/// keyframes is decoded once, not once per seek and then again.
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
mod tests {
    use super::*;
    use crate::decode::{open, sample_frames, sample_frames_and};

    /// Writes `frames` with any FFmpeg encoder and pixel format (unlike `VideoWriter`), at 25 fps
    /// with a keyframe every `gop` frames. The container comes from `path`'s extension.
    fn write_video(path: &Path, frames: &[RgbImage], codec: &str, pixel: Pixel, gop: u32) {
        init();
        let (w, h) = frames[0].dimensions();
        let mut output = ff::format::output(path).unwrap();
        let codec = ff::encoder::find_by_name(codec).unwrap();
        let mut encoder = ff::codec::context::Context::new_with_codec(codec)
            .encoder()
            .video()
            .unwrap();
        encoder.set_width(w);
        encoder.set_height(h);
        encoder.set_format(pixel);
        encoder.set_time_base(Rational(1, 25));
        encoder.set_frame_rate(Some(Rational(25, 1)));
        encoder.set_gop(gop);
        encoder.set_max_b_frames(0);
        if output
            .format()
            .flags()
            .contains(ff::format::Flags::GLOBAL_HEADER)
        {
            encoder.set_flags(ff::codec::Flags::GLOBAL_HEADER);
        }
        // No extra keyframes at "scene cuts": only every `gop` frames.
        let mut options = ff::Dictionary::new();
        options.set("sc_threshold", "1000000000");
        let mut encoder = encoder.open_as_with(codec, options).unwrap();
        let mut stream = output.add_stream(codec).unwrap();
        stream.set_parameters(&encoder);
        stream.set_time_base(Rational(1, 25));
        output.write_header().unwrap();
        let stream_tb = output.stream(0).unwrap().time_base();
        let mut scaler =
            scaling::Context::get(Pixel::RGB24, w, h, pixel, w, h, scaling::Flags::BILINEAR)
                .unwrap();
        let mut packet = ff::Packet::empty();
        let mut drain = |encoder: &mut ff::encoder::Video,
                         output: &mut ff::format::context::Output| {
            while encoder.receive_packet(&mut packet).is_ok() {
                packet.set_stream(0);
                packet.set_duration(1);
                packet.rescale_ts(Rational(1, 25), stream_tb);
                packet.write_interleaved(output).unwrap();
            }
        };
        for (i, f) in frames.iter().enumerate() {
            let mut rgb = ff::frame::Video::new(Pixel::RGB24, w, h);
            let stride = rgb.stride(0);
            for (y, row) in f.as_raw().chunks(w as usize * 3).enumerate() {
                rgb.data_mut(0)[y * stride..y * stride + row.len()].copy_from_slice(row);
            }
            let mut out = ff::frame::Video::empty();
            scaler.run(&rgb, &mut out).unwrap();
            out.set_pts(Some(i as i64));
            encoder.send_frame(&out).unwrap();
            drain(&mut encoder, &mut output);
        }
        encoder.send_eof().unwrap();
        drain(&mut encoder, &mut output);
        output.write_trailer().unwrap();
    }

    /// Noise-like but reproducible colours, so any row misalignment shows.
    fn textured(w: u32, h: u32, t: u32) -> RgbImage {
        RgbImage::from_fn(w, h, |x, y| {
            let v = x.wrapping_mul(73) ^ y.wrapping_mul(151) ^ t.wrapping_mul(29);
            image::Rgb([v as u8, (v >> 3) as u8, (x + y + t) as u8])
        })
    }

    /// Flat grey frames whose level encodes their index (8 levels apart, robust to compression).
    fn numbered(count: u32) -> Vec<RgbImage> {
        (0..count)
            .map(|i| RgbImage::from_pixel(64, 48, image::Rgb([(i * 4) as u8; 3])))
            .collect()
    }

    fn index_of(frame: &RgbImage) -> u32 {
        let sum: u64 = frame.as_raw().iter().map(|&v| v as u64).sum();
        (sum as f64 / frame.as_raw().len() as f64 / 4.0).round() as u32
    }

    fn decode_all(path: &Path) -> Vec<RgbImage> {
        let mut source = open(path, None).unwrap();
        std::iter::from_fn(|| source.next_frame().unwrap()).collect()
    }

    #[test]
    fn odd_width_rows_are_copied_by_stride() {
        let dir = tempfile::tempdir().unwrap();
        let frames: Vec<_> = (0..5).map(|t| textured(321, 241, t)).collect();
        // Lossless RGB: 321 * 3 = 963 bytes a row, padded in FFmpeg's frames; must come back exact.
        let png = dir.path().join("odd.mov");
        write_video(&png, &frames, "png", Pixel::RGB24, 1);
        let back = decode_all(&png);
        assert_eq!(back.len(), 5);
        for (i, (a, b)) in frames.iter().zip(&back).enumerate() {
            assert!(a == b, "frame {i} differs");
        }
        // yuv444p at an odd size through H.264.
        let h264 = dir.path().join("odd444.mkv");
        let smooth: Vec<_> = (0..5)
            .map(|t| {
                RgbImage::from_fn(321, 241, |x, y| {
                    image::Rgb([(x / 2) as u8, y as u8, (t * 40) as u8])
                })
            })
            .collect();
        write_video(&h264, &smooth, "libx264", Pixel::YUV444P, 12);
        let back = decode_all(&h264);
        assert_eq!(back.len(), 5);
        for (a, b) in smooth.iter().zip(&back) {
            assert_eq!(b.dimensions(), (321, 241));
            let diff: u64 = a
                .as_raw()
                .iter()
                .zip(b.as_raw())
                .map(|(x, y)| x.abs_diff(*y) as u64)
                .sum();
            let mean = diff as f64 / a.as_raw().len() as f64;
            assert!(mean < 2.0, "mean abs diff {mean}");
        }
    }

    #[test]
    fn seeking_samples_land_on_keyframes() {
        let dir = tempfile::tempdir().unwrap();
        // All-intra: every seek lands exactly on the frame at or before its target.
        let intra = dir.path().join("intra.mov");
        write_video(&intra, &numbered(60), "png", Pixel::RGB24, 1);
        let got: Vec<_> = FfmpegSource::open(&intra, None)
            .unwrap()
            .sample_by_seeking(8)
            .iter()
            .map(index_of)
            .collect();
        assert_eq!(got, [3, 11, 18, 26, 33, 41, 48, 56]);
        // A keyframe every 5 frames: each sample is the keyframe before its target.
        let gop5 = dir.path().join("gop5.mp4");
        write_video(&gop5, &numbered(60), "mpeg4", Pixel::YUV420P, 5);
        let got: Vec<_> = sample_frames(&gop5, 8)
            .unwrap()
            .iter()
            .map(index_of)
            .collect();
        assert_eq!(got, [0, 10, 15, 25, 30, 40, 45, 55]);
        // Asking for more than there are keyframes: duplicates are dropped, by demuxing alone.
        let mut source = FfmpegSource::open(&gop5, None).unwrap();
        assert_eq!(source.keyframe_targets(30).len(), 12);
        let got: Vec<_> = source.sample_by_seeking(30).iter().map(index_of).collect();
        assert_eq!(got, (0..60).step_by(5).collect::<Vec<_>>());
    }

    #[test]
    fn few_keyframes_fall_back_to_a_thinned_sequential_decode() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("one_gop.mp4");
        write_video(&path, &numbered(30), "mpeg4", Pixel::YUV420P, 300);
        // Every target lands on the one keyframe: known from demuxing, before decoding anything.
        let mut source = FfmpegSource::open(&path, None).unwrap();
        assert_eq!(source.keyframe_targets(10).len(), 1);
        assert_eq!(source.sample_by_seeking(10).len(), 1);
        let got: Vec<_> = sample_frames(&path, 10)
            .unwrap()
            .iter()
            .map(index_of)
            .collect();
        // Frames 0, 2, …, 28 kept (stride doubled once at 20), then 10 of those 15 spread evenly.
        assert_eq!(got, [0, 4, 6, 10, 12, 16, 18, 22, 24, 28]);
        // Deterministic: the same frames, bit for bit, every time.
        assert!(sample_frames(&path, 10).unwrap() == sample_frames(&path, 10).unwrap());
        // More than the clip has: all of it.
        assert_eq!(sample_frames(&path, 100).unwrap().len(), 30);
        assert!(sample_frames(&path, 0).unwrap().is_empty());
        // Any frame the decode passes comes with the sample, as a decode from the start gives it.
        let all = crate::decode::read_all(&path, None).unwrap();
        for k in [0, 7, 29] {
            let (sample, extra) = sample_frames_and(&path, 10, Some(k)).unwrap();
            assert!(sample == sample_frames(&path, 10).unwrap());
            assert!(extra.as_ref() == Some(&all[k as usize]), "frame {k}");
        }
        assert!(sample_frames_and(&path, 10, Some(30)).unwrap().1.is_none());
        // Keyframes sampled: the caller reads the frame itself.
        let gop5 = dir.path().join("gop5.mp4");
        write_video(&gop5, &numbered(60), "mpeg4", Pixel::YUV420P, 5);
        assert!(sample_frames_and(&gop5, 8, Some(0)).unwrap().1.is_none());
    }

    #[test]
    fn info_reports_size_rate_and_count() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.mkv");
        write_video(&path, &numbered(12), "mpeg4", Pixel::YUV420P, 12);
        let mut source = open(&path, None).unwrap();
        let info = source.info().clone();
        assert_eq!((info.width, info.height), (64, 48));
        assert!((info.fps - 25.0).abs() < 1e-6, "{}", info.fps);
        assert_eq!(info.frame_count_hint, Some(12));
        for i in 0..12 {
            assert_eq!(index_of(&source.next_frame().unwrap().unwrap()), i);
        }
        assert!(source.next_frame().unwrap().is_none());
        assert!(source.next_frame().unwrap().is_none());
        assert_eq!(open(&path, Some(12.5)).unwrap().info().fps, 12.5);
    }

    #[test]
    fn ffmpeg_logging_is_silenced_once_opened() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("notes.mp4");
        std::fs::write(&path, "this is not a video\n").unwrap();
        assert!(FfmpegSource::open(&path, None).is_err());
        assert!(matches!(
            ff::util::log::get_level(),
            Ok(ff::util::log::Level::Fatal)
        ));
    }

    #[test]
    fn undecodable_file_is_a_clip_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("notes.mp4");
        std::fs::write(&path, "this is not a video\n").unwrap();
        let err = open(&path, None).err().unwrap();
        assert!(
            matches!(err, Error::Clip { .. }) && err.is_user_error(),
            "{err}"
        );
        let msg = err.to_string();
        assert!(
            msg.contains("notes.mp4") && msg.contains("not a video FFmpeg can decode"),
            "{msg}"
        );
        assert!(matches!(sample_frames(&path, 4), Err(Error::Clip { .. })));
    }
}
