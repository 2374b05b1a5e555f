//! Frames out: [`VideoWriter`] encodes RGB frames to a video file with FFmpeg (feature `ffmpeg`).
//!
//! H.264 (libx264, yuv420p) when FFmpeg has it, else MPEG-4 Part 2. The file is written to
//! `<path>.tmp` and renamed into place by [`VideoWriter::finish`], so a crash never leaves half a
//! video under the real name. Settings are fixed (thread count included), so the same frames
//! give a byte-identical file on the same FFmpeg build.

use crate::atomic;
use crate::decode::{init_ffmpeg, Scaler};
use crate::error::{Error, Result};
use ff::codec::threading;
use ff::format::Pixel;
use ff::software::scaling;
use ff::{Dictionary, Rational};
use ffmpeg_next as ff;
use image::RgbImage;
use std::path::{Path, PathBuf};

/// Encoder threads: fixed, so the output does not depend on the machine's core count.
const ENCODER_THREADS: usize = 4;
/// libx264 speed/size trade-off; `veryfast` keeps overlay videos cheap next to tracking.
const X264_PRESET: &str = "veryfast";
/// FFmpeg's `FF_QP2LAMBDA`: quantiser to lambda scale, for MPEG-4's fixed-quality mode.
const QP2LAMBDA: i32 = 118;

/// Settings for [`VideoWriter::create_with`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriterOptions {
    /// Quality, as x264's constant rate factor 0–51: lower is better, 18 looks lossless, 35 is
    /// strong compression. MPEG-4 maps it to a comparable fixed quantiser.
    pub crf: u8,
    /// At most this many frames between keyframes (smaller seeks faster, files grow); `None`
    /// leaves the encoder's default (250 for x264, 12 for MPEG-4).
    pub keyframe_interval: Option<u32>,
}

impl Default for WriterOptions {
    fn default() -> Self {
        WriterOptions {
            crf: 18,
            keyframe_interval: None,
        }
    }
}

/// Encodes RGB frames of one size into a video file, atomically.
pub struct VideoWriter {
    path: PathBuf,
    tmp: PathBuf,
    width: u32,
    height: u32,
    /// The FFmpeg state; `None` once finished.
    inner: Option<Inner>,
}

struct Inner {
    output: ff::format::context::Output,
    encoder: ff::encoder::Video,
    scaler: Scaler,
    /// The padded RGB frame handed to the scaler, reused.
    rgb: ff::frame::Video,
    encoder_time_base: Rational,
    stream_time_base: Rational,
    frames: i64,
}

impl std::fmt::Debug for VideoWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VideoWriter")
            .field("path", &self.path)
            .field("width", &self.width)
            .field("height", &self.height)
            .finish_non_exhaustive()
    }
}

impl VideoWriter {
    /// Starts a video of `width × height` px frames at `fps` frames per second with quality `crf`
    /// (lower = better; 18 typical, 35 = strong compression), in the container named by `path`'s
    /// extension (`.mp4`, `.m4v`, `.mov`, `.mkv`, `.avi`). H.264 (libx264, yuv420p) if available,
    /// else MPEG-4 Part 2. yuv420p needs even sizes, so an odd width or height is padded by one
    /// px, repeating the last column or row (see [`VideoWriter::encoded_size`]).
    ///
    /// Errors: [`Error::Usage`] for a crf above 51; [`Error::Io`] if the file cannot be created;
    /// [`Error::Encode`] for an unknown extension, an empty size, a bad rate or an encoder that
    /// refuses the settings.
    pub fn create(path: &Path, width: u32, height: u32, fps: f64, crf: u8) -> Result<Self> {
        let options = WriterOptions {
            crf,
            ..WriterOptions::default()
        };
        Self::create_with(path, width, height, fps, options)
    }

    /// [`VideoWriter::create`] with every setting spelt out.
    pub fn create_with(
        path: &Path,
        width: u32,
        height: u32,
        fps: f64,
        options: WriterOptions,
    ) -> Result<Self> {
        init_ffmpeg();
        let err = |msg: String| Error::Encode {
            path: path.to_owned(),
            msg,
        };
        if options.crf > 51 {
            return Err(Error::Usage(format!(
                "video quality (crf) must be 0–51 (lower is better), got {}",
                options.crf
            )));
        }
        if width == 0 || height == 0 {
            return Err(err(format!("cannot encode {width}x{height} frames")));
        }
        if !(fps.is_finite() && fps > 0.0) {
            return Err(err(format!("frame rate must be positive, got {fps}")));
        }
        if path.to_str().is_none() {
            // FFmpeg's bindings take the path as UTF-8 text.
            return Err(Error::Usage(format!(
                "{}: the path is not valid UTF-8, which FFmpeg cannot write; choose a UTF-8 name",
                path.display()
            )));
        }
        let muxer = muxer_for(path).ok_or_else(|| {
            err("unsupported video file extension; use .mp4, .mkv, .mov or .avi".into())
        })?;
        let tmp = atomic::temp_path(path);
        // Creating it here first turns a missing folder or a permission problem into a plain
        // I/O error naming the file; FFmpeg then reopens (truncates) it.
        std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        let mut writer = VideoWriter {
            path: path.to_owned(),
            tmp,
            width,
            height,
            inner: None,
        };
        let inner = Inner::new(&writer.tmp, muxer, width, height, fps, options).map_err(err)?;
        writer.inner = Some(inner);
        Ok(writer)
    }

    /// The size in px of the encoded video: the frame size rounded up to even numbers.
    pub fn encoded_size(&self) -> (u32, u32) {
        (even(self.width), even(self.height))
    }

    /// Encodes the next frame; it must be the size given to [`VideoWriter::create`].
    pub fn write(&mut self, frame: &RgbImage) -> Result<()> {
        if frame.dimensions() != (self.width, self.height) {
            return Err(self.error(format!(
                "frame is {}x{} but the video is {}x{}",
                frame.width(),
                frame.height(),
                self.width,
                self.height
            )));
        }
        let inner = self
            .inner
            .as_mut()
            // Cannot fail: `inner` is set by `create_with` and taken only by `finish(self)`.
            .expect("only finish() takes the encoder");
        let result = inner.write(frame);
        result.map_err(|msg| self.error(msg))
    }

    /// Flushes the encoder, completes the file and renames it into place. A video needs at least
    /// one frame.
    pub fn finish(mut self) -> Result<()> {
        // Cannot fail: `inner` is set by `create_with` and taken only here, consuming self.
        let mut inner = self.inner.take().expect("only finish() takes the encoder");
        let result = (|| {
            if inner.frames == 0 {
                return Err(self.error("no frames were written; a video needs at least one".into()));
            }
            inner.finish().map_err(|msg| self.error(msg))?;
            drop(inner); // closes the file
            let sync = std::fs::File::open(&self.tmp).and_then(|f| f.sync_all());
            sync.map_err(|e| Error::io(&self.tmp, e))?;
            std::fs::rename(&self.tmp, &self.path).map_err(|e| Error::io(&self.path, e))
        })();
        if result.is_err() {
            let _ = std::fs::remove_file(&self.tmp);
        }
        result
    }

    fn error(&self, msg: String) -> Error {
        Error::Encode {
            path: self.path.clone(),
            msg,
        }
    }
}

impl Drop for VideoWriter {
    /// An unfinished video is abandoned: its temp file is removed, the target left untouched.
    fn drop(&mut self) {
        if let Some(inner) = self.inner.take() {
            drop(inner);
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

impl Inner {
    /// Opens the muxer on `tmp` and the encoder, and writes the header. Errors are messages for
    /// [`Error::Encode`].
    fn new(
        tmp: &Path,
        muxer: &str,
        width: u32,
        height: u32,
        fps: f64,
        options: WriterOptions,
    ) -> std::result::Result<Self, String> {
        let (w, h) = (even(width), even(height));
        let mut output = ff::format::output_as(tmp, muxer)
            .map_err(|e| format!("FFmpeg cannot write a {muxer} file ({e})"))?;
        let (codec, x264) = match ff::encoder::find_by_name("libx264") {
            Some(c) => (c, true),
            None => (
                ff::encoder::find(ff::codec::Id::MPEG4)
                    .ok_or("FFmpeg has neither a libx264 nor an MPEG-4 encoder")?,
                false,
            ),
        };
        let rate = frame_rate(fps);
        let time_base = rate.invert();
        let global_header = output
            .format()
            .flags()
            .contains(ff::format::Flags::GLOBAL_HEADER);

        let mut encoder = ff::codec::context::Context::new_with_codec(codec)
            .encoder()
            .video()
            .map_err(|e| format!("cannot set up the encoder ({e})"))?;
        encoder.set_width(w);
        encoder.set_height(h);
        encoder.set_format(Pixel::YUV420P);
        encoder.set_time_base(time_base);
        encoder.set_frame_rate(Some(rate));
        // sws_scale converts with BT.601 limited range; say so, so players agree.
        encoder.set_colorspace(ff::color::Space::BT470BG);
        encoder.set_color_range(ff::color::Range::MPEG);
        if let Some(gop) = options.keyframe_interval {
            encoder.set_gop(gop.max(1));
        }
        let mut flags = ff::codec::Flags::empty();
        if global_header {
            flags |= ff::codec::Flags::GLOBAL_HEADER;
        }
        let mut codec_options = Dictionary::new();
        if x264 {
            encoder.set_threading(threading::Config {
                kind: threading::Type::Frame,
                count: ENCODER_THREADS,
                ..Default::default()
            });
            codec_options.set("preset", X264_PRESET);
            codec_options.set("crf", &options.crf.to_string());
            if let Some(params) = x264_params() {
                codec_options.set("x264-params", params);
            }
        } else {
            encoder.set_threading(threading::Config {
                kind: threading::Type::Slice,
                count: 1,
                ..Default::default()
            });
            flags |= ff::codec::Flags::QSCALE | ff::codec::Flags::BITEXACT;
            encoder.set_global_quality(mpeg4_quantiser(options.crf) * QP2LAMBDA);
        }
        encoder.set_flags(flags);
        let encoder = encoder
            .open_as_with(codec, codec_options)
            .map_err(|e| format!("the encoder refused {w}x{h} at {fps} fps ({e})"))?;

        let mut stream = output
            .add_stream(codec)
            .map_err(|e| format!("cannot add a video stream ({e})"))?;
        stream.set_parameters(&encoder);
        stream.set_time_base(time_base);
        stream.set_avg_frame_rate(rate);
        let mut header_options = Dictionary::new();
        // No library version strings in the file: identical frames give identical bytes.
        header_options.set("fflags", "+bitexact");
        output
            .write_header_with(header_options)
            .map_err(|e| format!("cannot write the file header ({e})"))?;
        let stream_time_base = output.stream(0).map_or(time_base, |s| s.time_base());

        let scaler = scaling::Context::get(
            Pixel::RGB24,
            w,
            h,
            Pixel::YUV420P,
            w,
            h,
            scaling::Flags::BILINEAR | scaling::Flags::ACCURATE_RND,
        )
        .map_err(|e| format!("cannot convert RGB to yuv420p ({e})"))?;
        Ok(Inner {
            output,
            encoder,
            scaler: Scaler(scaler),
            rgb: ff::frame::Video::new(Pixel::RGB24, w, h),
            encoder_time_base: time_base,
            stream_time_base,
            frames: 0,
        })
    }

    fn write(&mut self, frame: &RgbImage) -> std::result::Result<(), String> {
        copy_padded(frame, &mut self.rgb);
        // A fresh frame each time: the encoder may keep a reference to the previous one.
        let mut yuv = padded_yuv_frame(self.rgb.width(), self.rgb.height());
        self.scaler
            .0
            .run(&self.rgb, &mut yuv)
            .map_err(|e| format!("frame {}: cannot convert to yuv420p ({e})", self.frames))?;
        yuv.set_pts(Some(self.frames));
        self.encoder
            .send_frame(&yuv)
            .map_err(|e| format!("frame {}: the encoder failed ({e})", self.frames))?;
        self.frames += 1;
        self.drain()
    }

    /// Writes every packet the encoder has ready.
    fn drain(&mut self) -> std::result::Result<(), String> {
        let mut packet = ff::Packet::empty();
        loop {
            match self.encoder.receive_packet(&mut packet) {
                Ok(()) => {
                    packet.set_stream(0);
                    // Constant frame rate: every frame lasts one tick. Encoders do not always
                    // say so, and without it the muxer can drop the last frame.
                    packet.set_duration(1);
                    packet.rescale_ts(self.encoder_time_base, self.stream_time_base);
                    packet
                        .write_interleaved(&mut self.output)
                        .map_err(|e| format!("cannot write a packet ({e})"))?;
                }
                Err(ff::Error::Other {
                    errno: ff::error::EAGAIN,
                })
                | Err(ff::Error::Eof) => return Ok(()),
                Err(e) => return Err(format!("the encoder failed ({e})")),
            }
        }
    }

    fn finish(&mut self) -> std::result::Result<(), String> {
        self.encoder
            .send_eof()
            .map_err(|e| format!("cannot flush the encoder ({e})"))?;
        self.drain()?;
        self.output
            .write_trailer()
            .map_err(|e| format!("cannot complete the file ({e})"))
    }
}

/// Extra libx264 settings for reproducible output. x264's AVX-512 code (seen with x264 0.164 and
/// FFmpeg 5.1) reads memory it never wrote: the same frames encoded twice in one process gave
/// different files about half the time. x264's SIMD levels are otherwise bit-exact with each
/// other, so on CPUs with AVX-512 it is capped at AVX2 (`asm=AVX2` is auto-detection less
/// AVX-512), which costs little speed and gives the same bytes as any other x86 machine.
fn x264_params() -> Option<&'static str> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        return Some("asm=AVX2");
    }
    None
}

/// A yuv420p frame of `width × height` px whose buffer is zeroed and larger than needed: 64 more
/// bytes than the 64-aligned width on every row and 16 more rows. SIMD code may read past a
/// plane's end; FFmpeg's tight buffers hold leftover heap bytes there, zeroed slack does not (with
/// x264's AVX-512 code, tight buffers made differing files more often than padded ones).
fn padded_yuv_frame(width: u32, height: u32) -> ff::frame::Video {
    let mut frame =
        ff::frame::Video::new(Pixel::YUV420P, width.next_multiple_of(64) + 64, height + 16);
    for plane in 0..3 {
        frame.data_mut(plane).fill(0);
    }
    frame.set_width(width);
    frame.set_height(height);
    frame
}

/// Copies `frame` into the top-left of the (possibly one px larger) RGB24 `dst`, row by row at
/// `dst`'s stride, repeating the last column and row into the padding.
fn copy_padded(frame: &RgbImage, dst: &mut ff::frame::Video) {
    let (w, h) = (frame.width() as usize, frame.height() as usize);
    let (dw, dh) = (dst.width() as usize, dst.height() as usize);
    let stride = dst.stride(0);
    let data = dst.data_mut(0);
    let src = frame.as_raw();
    for y in 0..dh {
        let sy = y.min(h - 1);
        let row = &mut data[y * stride..y * stride + dw * 3];
        row[..w * 3].copy_from_slice(&src[sy * w * 3..(sy + 1) * w * 3]);
        for x in w..dw {
            row.copy_within((w - 1) * 3..w * 3, x * 3);
        }
    }
}

/// The muxer for a file name's extension.
fn muxer_for(path: &Path) -> Option<&'static str> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "mp4" | "m4v" => Some("mp4"),
        "mov" => Some("mov"),
        "mkv" => Some("matroska"),
        "avi" => Some("avi"),
        _ => None,
    }
}

/// `fps` (frames per second) as a fraction whose denominator fits MPEG-4's 16-bit time base
/// (29.97 → 2997/100, 23.976… → 24000/1001).
fn frame_rate(fps: f64) -> Rational {
    let exact = Rational::from(fps);
    if exact.numerator() > 0 && exact.denominator() > 0 && exact.denominator() <= 65535 {
        return exact;
    }
    let ntsc = fps * 1001.0;
    if (ntsc - ntsc.round()).abs() < 1e-3 {
        return Rational::new(ntsc.round() as i32, 1001);
    }
    Rational::new((fps * 1000.0).round().max(1.0) as i32, 1000)
}

/// MPEG-4 quantiser (1–31) of roughly the quality x264 gives at `crf`: 3 at crf 18, doubling
/// every 6.
fn mpeg4_quantiser(crf: u8) -> i32 {
    (3.0 * 2f64.powf((f64::from(crf) - 18.0) / 6.0))
        .round()
        .clamp(1.0, 31.0) as i32
}

/// `n` rounded up to an even number.
fn even(n: u32) -> u32 {
    n + (n & 1)
}

#[cfg(test)]
mod tests;
