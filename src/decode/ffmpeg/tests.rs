use super::*;
use crate::decode::{open, sample_frames, sample_frames_and};

/// Writes `frames` with any FFmpeg encoder and pixel format (unlike `VideoWriter`), at 25 fps
/// with a keyframe every `gop` frames. The container comes from `path`'s extension.
fn write_video(path: &Path, frames: &[RgbImage], codec: &str, pixel: Pixel, gop: u32) {
    write_video_b(path, frames, codec, pixel, gop, 0);
}

/// [`write_video`] with up to `b_frames` B-frames in a row.
fn write_video_b(
    path: &Path,
    frames: &[RgbImage],
    codec: &str,
    pixel: Pixel,
    gop: u32,
    b_frames: usize,
) {
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
    encoder.set_max_b_frames(b_frames);
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
        scaling::Context::get(Pixel::RGB24, w, h, pixel, w, h, scaling::Flags::BILINEAR).unwrap();
    let mut packet = ff::Packet::empty();
    let mut drain = |encoder: &mut ff::encoder::Video, output: &mut ff::format::context::Output| {
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
fn rgb_written_directly_is_the_copied_rows() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wide.mp4");
    // 128 px: 384-byte rows, which swscale writes straight into the image.
    let frames: Vec<_> = (0..4).map(|t| textured(128, 48, t)).collect();
    write_video(&path, &frames, "libx264", Pixel::YUV420P, 12);
    let mut source = FfmpegSource::open(&path, None).unwrap();
    let mut n = 0;
    while source.decode_next().unwrap() {
        let direct = source.to_rgb.convert_via(&source.decoded, true).unwrap();
        let copied = source.to_rgb.convert_via(&source.decoded, false).unwrap();
        assert!(direct == copied, "frame {n}");
        n += 1;
    }
    assert_eq!(n, 4);
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
fn a_sequential_sample_skips_the_unwanted_non_reference_frames() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bframes.mp4");
    // One keyframe, two B-frames (never referenced in MPEG-4 Part 2) between P-frames.
    write_video_b(&path, &numbered(60), "mpeg4", Pixel::YUV420P, 300, 2);
    let all = crate::decode::read_all(&path, None).unwrap();
    assert_eq!(all.len(), 60);
    let want = sampling::thinned_indices(60, 10);
    assert_eq!(want, [0, 8, 12, 20, 24, 32, 36, 44, 48, 56]);
    let sampled = |threads: usize, also: Option<u64>| {
        let mut source = FfmpegSource::open_with_threads(&path, None, |_, _| threads).unwrap();
        let got = source.sample_sequentially(10, also).unwrap();
        (got, source.frames_out)
    };
    for threads in [1, 4] {
        let ((sample, extra), decoded) = sampled(threads, Some(7));
        // The frames a full decode gives there, bit for bit (B-frames 8, 20, … among them).
        assert_eq!(sample.len(), 10);
        for (f, &i) in sample.iter().zip(&want) {
            assert!(*f == all[i as usize], "frame {i}, {threads} threads");
        }
        assert!(extra.as_ref() == Some(&all[7]), "{threads} threads");
        // Frames 0, 3, …, 54 (the reference frames) and the wanted B-frames 7, 8, 20, 32, 44,
        // 56: up to frame 56, then no more.
        assert_eq!(decoded, 19 + 6, "frames decoded, {threads} threads");
    }
    // The same sample as a decode of every frame gives.
    let mut source = FfmpegSource::open(&path, None).unwrap();
    assert!(source.sample_every_frame(10, None).unwrap().0 == sampled(1, None).0 .0);
    assert_eq!(source.frames_out, 60);
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
