use super::*;
use crate::decode;

/// A gradient with a moving square, so motion and colour both matter.
fn frame(w: u32, h: u32, t: u32) -> RgbImage {
    RgbImage::from_fn(w, h, |x, y| {
        let inside = x.abs_diff(5 + 2 * t) < 6 && y.abs_diff(h / 2) < 6;
        if inside {
            image::Rgb([230, 40, 30])
        } else {
            image::Rgb([(x * 255 / w) as u8, (y * 255 / h) as u8, 128])
        }
    })
}

fn mean_abs_diff(a: &RgbImage, b: &RgbImage) -> f64 {
    assert_eq!(a.dimensions(), b.dimensions());
    let sum: u64 = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| x.abs_diff(*y) as u64)
        .sum();
    sum as f64 / a.as_raw().len() as f64
}

fn encode(path: &Path, frames: &[RgbImage], crf: u8) {
    let (w, h) = frames[0].dimensions();
    let mut writer = VideoWriter::create(path, w, h, 25.0, crf).unwrap();
    for f in frames {
        writer.write(f).unwrap();
    }
    writer.finish().unwrap();
}

/// True when `dir` holds no temp file (`*.tmp`).
fn no_temp(dir: &std::path::Path) -> bool {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .all(|e| !e.file_name().to_string_lossy().ends_with(".tmp"))
}

#[test]
fn round_trip_keeps_count_size_and_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("clip.mp4");
    let frames: Vec<_> = (0..12).map(|t| frame(64, 48, t)).collect();
    encode(&path, &frames, 18);
    assert!(no_temp(dir.path()));
    let source = decode::open(&path, None).unwrap();
    let info = source.info().clone();
    assert_eq!((info.width, info.height), (64, 48));
    assert!((info.fps - 25.0).abs() < 1e-9, "{}", info.fps);
    assert_eq!(info.frame_count_hint, Some(12));
    let back = decode::read_all(&path, None).unwrap();
    assert_eq!(back.len(), 12);
    for (a, b) in frames.iter().zip(&back) {
        let d = mean_abs_diff(a, b);
        assert!(d < 4.0, "mean abs diff {d}");
    }
}

#[test]
fn same_frames_give_identical_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let frames: Vec<_> = (0..8).map(|t| frame(64, 48, t)).collect();
    // Several encodes in one process: leftover heap bytes differ between them, which once
    // leaked into libx264's output (see `padded_yuv_frame`).
    let files: Vec<Vec<u8>> = (0..4)
        .map(|k| {
            let path = dir.path().join(format!("{k}.mp4"));
            encode(&path, &frames, 23);
            std::fs::read(&path).unwrap()
        })
        .collect();
    for (k, bytes) in files.iter().enumerate() {
        assert!(
            bytes == &files[0],
            "encode {k}: {} bytes, encode 0: {}",
            bytes.len(),
            files[0].len()
        );
    }
}

#[test]
fn odd_size_is_padded_by_repeating_the_edge() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("odd.mkv");
    let frames: Vec<_> = (0..6).map(|t| frame(33, 25, t)).collect();
    let mut writer = VideoWriter::create(&path, 33, 25, 10.0, 18).unwrap();
    assert_eq!(writer.encoded_size(), (34, 26));
    for f in &frames {
        writer.write(f).unwrap();
    }
    writer.finish().unwrap();
    let back = decode::read_all(&path, None).unwrap();
    assert_eq!(back.len(), 6);
    assert_eq!(back[0].dimensions(), (34, 26));
    let cropped = image::imageops::crop_imm(&back[3], 0, 0, 33, 25).to_image();
    let d = mean_abs_diff(&frames[3], &cropped);
    assert!(d < 8.0, "mean abs diff {d}");
    // The padding column and row repeat the edge.
    for y in 0..25 {
        let (edge, pad) = (back[3].get_pixel(32, y), back[3].get_pixel(33, y));
        assert!(
            edge.0.iter().zip(pad.0).all(|(a, b)| a.abs_diff(b) < 24),
            "row {y}"
        );
    }
}

#[test]
fn wrong_frame_size_and_bad_settings_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.mp4");
    let mut writer = VideoWriter::create(&path, 16, 16, 30.0, 18).unwrap();
    let err = writer.write(&RgbImage::new(8, 8)).unwrap_err();
    assert!(
        matches!(err, Error::Encode { .. }) && err.to_string().contains("8x8"),
        "{err}"
    );
    drop(writer);
    assert!(!path.exists() && no_temp(dir.path()));

    let empty = VideoWriter::create(&path, 16, 16, 30.0, 18)
        .unwrap()
        .finish()
        .unwrap_err();
    assert!(empty.to_string().contains("no frames"), "{empty}");
    assert!(!path.exists() && no_temp(dir.path()));

    let ext = VideoWriter::create(&dir.path().join("x.gif"), 16, 16, 30.0, 18).unwrap_err();
    assert!(ext.to_string().contains("extension"), "{ext}");
    let crf = VideoWriter::create(&path, 16, 16, 30.0, 60).unwrap_err();
    assert!(matches!(crf, Error::Usage(_)), "{crf}");
    let missing = VideoWriter::create(&dir.path().join("no/dir/x.mp4"), 16, 16, 30.0, 18);
    assert!(matches!(missing.unwrap_err(), Error::Io { .. }));
}

#[test]
fn frame_rates_fit_sixteen_bits() {
    assert_eq!(frame_rate(25.0), Rational::new(25, 1));
    assert_eq!(frame_rate(29.97), Rational::new(2997, 100));
    assert_eq!(frame_rate(24000.0 / 1001.0), Rational::new(24000, 1001));
    assert!(frame_rate(std::f64::consts::PI).denominator() <= 65535);
}

#[test]
fn mpeg4_quantiser_follows_crf() {
    assert_eq!(mpeg4_quantiser(18), 3);
    assert_eq!(mpeg4_quantiser(24), 6);
    assert_eq!(mpeg4_quantiser(0), 1);
    assert_eq!(mpeg4_quantiser(51), 31);
}
