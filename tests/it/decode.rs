//! Frames in and out through the public API: image folders always, video files with `ffmpeg`.

use image::RgbImage;
use mocap2d::decode::{self, MemorySource};
use mocap2d::Error;
use std::path::Path;

/// A still gradient with a square moving right by 2 px a frame (64 × 48 px).
fn frame(t: u32) -> RgbImage {
    RgbImage::from_fn(64, 48, |x, y| {
        if x.abs_diff(8 + 2 * t) < 6 && y.abs_diff(24) < 6 {
            image::Rgb([230, 40, 30])
        } else {
            image::Rgb([(x * 4) as u8, (y * 5) as u8, 128])
        }
    })
}

/// Saves frames as `frame1.png`, `frame2.png`, … (not zero-padded, so order needs natural sort).
fn write_folder(dir: &Path, frames: &[RgbImage]) {
    std::fs::create_dir_all(dir).unwrap();
    for (i, f) in frames.iter().enumerate() {
        f.save(dir.join(format!("frame{}.png", i + 1))).unwrap();
    }
}

#[test]
fn image_folder_reads_back_exactly_in_natural_order() {
    let dir = tempfile::tempdir().unwrap();
    let frames: Vec<_> = (0..12).map(frame).collect();
    write_folder(dir.path(), &frames);
    let source = decode::open(dir.path(), None).unwrap();
    let info = source.info();
    assert_eq!(
        (info.width, info.height, info.fps),
        (64, 48, decode::DEFAULT_IMAGE_FPS)
    );
    assert_eq!(info.frame_count_hint, Some(12));
    assert!(decode::read_all(dir.path(), None).unwrap() == frames);
    assert_eq!(
        decode::open(dir.path(), Some(12.0)).unwrap().info().fps,
        12.0
    );
}

#[test]
fn folder_sample_is_evenly_spread() {
    let dir = tempfile::tempdir().unwrap();
    let frames: Vec<_> = (0..12).map(frame).collect();
    write_folder(dir.path(), &frames);
    let sample = decode::sample_frames(dir.path(), 4).unwrap();
    // The centres of four 3-frame slices: frames 1, 4, 7, 10.
    assert!(sample == [1, 4, 7, 10].map(|i| frames[i].clone()));
}

#[test]
fn reader_thread_yields_every_frame_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let frames: Vec<_> = (0..12).map(frame).collect();
    write_folder(dir.path(), &frames);
    let rx = decode::spawn_reader(decode::open(dir.path(), None).unwrap(), 3);
    let got: Vec<_> = rx.iter().map(|item| item.unwrap()).collect();
    assert_eq!(
        got.iter().map(|(i, _)| *i).collect::<Vec<_>>(),
        (0..12).collect::<Vec<u64>>()
    );
    assert!(got.into_iter().map(|(_, f)| f).collect::<Vec<_>>() == frames);

    let rx = decode::spawn_reader(Box::new(MemorySource::new(frames.clone(), 30.0)), 0);
    assert_eq!(rx.iter().count(), 12);
}

#[test]
fn folder_errors_name_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let err = decode::open(&empty, None).err().unwrap();
    assert!(
        matches!(err, Error::Clip { .. }) && err.is_user_error(),
        "{err}"
    );

    let mixed = dir.path().join("mixed");
    write_folder(&mixed, &[frame(0), frame(1)]);
    RgbImage::new(32, 32)
        .save(mixed.join("frame3.png"))
        .unwrap();
    let err = decode::open(&mixed, None).err().unwrap();
    assert!(matches!(err, Error::Clip { .. }), "{err}");
    assert!(err.to_string().contains("frame3.png"), "{err}");

    let missing = dir.path().join("nowhere.mp4");
    let err = decode::open(&missing, None).err().unwrap();
    assert!(matches!(err, Error::Clip { .. }), "{err}");
    assert!(err.to_string().contains("nowhere.mp4") && err.to_string().contains("no such file"));
}

#[cfg(feature = "ffmpeg")]
mod video {
    use super::*;
    use mocap2d::encode::VideoWriter;

    fn mean_abs_diff(a: &RgbImage, b: &RgbImage) -> f64 {
        let sum: u64 = a
            .as_raw()
            .iter()
            .zip(b.as_raw())
            .map(|(x, y)| x.abs_diff(*y) as u64)
            .sum();
        sum as f64 / a.as_raw().len() as f64
    }

    /// Encodes `count` test frames to `path` (H.264, crf 18, 25 fps).
    fn write_clip(path: &Path, count: u32) -> Vec<RgbImage> {
        let frames: Vec<_> = (0..count).map(frame).collect();
        let mut writer = VideoWriter::create(path, 64, 48, 25.0, 18).unwrap();
        for f in &frames {
            writer.write(f).unwrap();
        }
        writer.finish().unwrap();
        frames
    }

    #[test]
    fn video_round_trip_and_folder_of_its_frames_agree() {
        let dir = tempfile::tempdir().unwrap();
        let clip = dir.path().join("clip.mp4");
        let frames = write_clip(&clip, 24);
        let decoded = decode::read_all(&clip, None).unwrap();
        assert_eq!(
            decoded.len(),
            24,
            "every frame, the decoder's buffered tail included"
        );
        for (i, (a, b)) in frames.iter().zip(&decoded).enumerate() {
            assert_eq!(b.dimensions(), (64, 48));
            let d = mean_abs_diff(a, b);
            assert!(d < 4.0, "frame {i}: mean abs diff {d}");
        }
        // The decoded frames saved as PNGs read back identical (PNG is lossless).
        let folder = dir.path().join("frames");
        write_folder(&folder, &decoded);
        assert!(decode::read_all(&folder, None).unwrap() == decoded);
    }

    #[test]
    fn video_reader_thread_and_sample() {
        let dir = tempfile::tempdir().unwrap();
        let clip = dir.path().join("clip.mkv");
        write_clip(&clip, 20);
        let decoded = decode::read_all(&clip, None).unwrap();
        let rx = decode::spawn_reader(decode::open(&clip, None).unwrap(), 2);
        let got: Vec<_> = rx.iter().map(|item| item.unwrap()).collect();
        assert_eq!(got.len(), 20);
        for (k, (i, f)) in got.iter().enumerate() {
            assert_eq!(*i, k as u64);
            assert!(*f == decoded[k], "frame {k} differs between two decodes");
        }
        // One keyframe in 20 frames: seeking finds too few, the sequential fallback spreads 5.
        let sample = decode::sample_frames(&clip, 5).unwrap();
        assert_eq!(sample.len(), 5);
        for (s, i) in sample.iter().zip([0, 4, 8, 12, 16]) {
            assert!(*s == decoded[i], "sample should be frame {i}");
        }
        // The same clip gives the same sample (and so the same clean plate).
        assert!(decode::sample_frames(&clip, 5).unwrap() == sample);
    }

    /// FFmpeg's own log lines (`[mov,mp4,... @ 0x…] moov atom not found`) stay off stderr; the
    /// user gets our one message naming the file and what failed.
    #[test]
    fn ffmpeg_log_lines_do_not_reach_the_user() {
        let dir = tempfile::tempdir().unwrap();
        let seeds = crate::common::walk("joints.toml");
        let bogus = dir.path().join("notes.mp4");
        std::fs::write(&bogus, "this is not a video\n").unwrap();
        // The start of a real clip: its index (moov) is at the end, so it is cut off.
        let cut = dir.path().join("cut.mp4");
        let clip = std::fs::read(crate::common::walk("clip.mp4")).unwrap();
        std::fs::write(&cut, &clip[..clip.len() / 2]).unwrap();
        for path in [&bogus, &cut] {
            let out = crate::common::bin()
                .args(["track", path.to_str().unwrap(), "--seeds"])
                .arg(&seeds)
                .arg("--quiet")
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{stderr}");
            assert_eq!(stderr.lines().count(), 1, "{stderr}");
            assert!(
                stderr.starts_with("mocap2d: ")
                    && stderr.contains(path.to_str().unwrap())
                    && stderr.contains("not a video FFmpeg can decode"),
                "{stderr}"
            );
        }
    }

    #[test]
    fn text_file_named_mp4_is_a_clip_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.mp4");
        std::fs::write(&path, "hello").unwrap();
        let err = decode::open(&path, None).err().unwrap();
        assert!(matches!(err, Error::Clip { .. }), "{err}");
        assert!(
            err.to_string().contains("not a video FFmpeg can decode"),
            "{err}"
        );
    }

    /// A picture given as the clip (PNG or JPEG, by its own name or named `.mp4`) is refused
    /// with one message and exit 2, writing nothing; so is a folder of one frame. A pipe of
    /// several pictures (concatenated JPEGs) is a clip and still reads.
    #[test]
    fn a_picture_given_as_the_clip_is_refused_not_tracked_as_one_frame() {
        let dir = tempfile::tempdir().unwrap();
        let seeds = crate::common::walk("joints.toml");
        let plate = image::open(crate::common::walk("background.png"))
            .unwrap()
            .to_rgb8();
        let (png, jpg) = (dir.path().join("still.png"), dir.path().join("still.jpg"));
        plate.save(&png).unwrap();
        plate.save(&jpg).unwrap();
        let png_mp4 = dir.path().join("png.mp4");
        let jpg_mp4 = dir.path().join("jpg.mp4");
        std::fs::copy(&png, &png_mp4).unwrap();
        std::fs::copy(&jpg, &jpg_mp4).unwrap();
        let one = dir.path().join("one");
        std::fs::create_dir(&one).unwrap();
        std::fs::copy(&png, one.join("frame0.png")).unwrap();
        for (path, says) in [
            (&png, "single picture"),
            (&jpg, "single picture"),
            (&png_mp4, "single picture"),
            (&jpg_mp4, "single picture"),
            (&one, "single frame"),
        ] {
            let out_dir = dir.path().join("r.mocap");
            let out = crate::common::run(&[
                "track",
                path.to_str().unwrap(),
                "--seeds",
                seeds.to_str().unwrap(),
                "--out",
                out_dir.to_str().unwrap(),
                "-q",
            ]);
            let err = crate::common::assert_fails(&out, 2, &[path.to_str().unwrap(), says]);
            assert_eq!(err.lines().count(), 1, "{err}");
            assert!(!out_dir.exists(), "{} wrote a run folder", path.display());
        }
        let mut pipe = std::fs::read(&jpg).unwrap();
        pipe.extend(std::fs::read(&jpg).unwrap());
        let mjpeg = dir.path().join("two.mjpeg");
        std::fs::write(&mjpeg, pipe).unwrap();
        assert_eq!(decode::read_all(&mjpeg, None).unwrap().len(), 2);
    }
}
