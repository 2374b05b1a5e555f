//! Bad input, damaged files, full and read-only disks: the `mocap2d` binary must answer each with
//! one clear message and exit code 2 (user-fixable) or 1, never a panic (exit 101) or a hang, and
//! leave no half-written file. Bad files are made in a temp dir by each test.
//!
//! Needs the `ffmpeg` feature and the `ffmpeg` command (installed by scripts/setup) to remux the
//! sample clip.
#![cfg(feature = "ffmpeg")]

use crate::common::{self, assert_ok, run, s, stderr, temp_files, walk};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// [`common::assert_fails`], and the message is one `mocap2d:` line.
fn assert_fails(o: &Output, code: i32, parts: &[&str]) -> String {
    let err = common::assert_fails(o, code, parts);
    assert!(err.starts_with("mocap2d: "), "{err}");
    err
}

/// A seed file of one joint `w`×`h` px centred at (`x`, `y`).
fn one_joint_seeds(dir: &Path, x: f32, y: f32, w: u32, h: u32) -> PathBuf {
    let p = dir.join("one.toml");
    std::fs::write(
        &p,
        format!("frame = 0\n[[joint]]\nname = \"a\"\nx = {x}\ny = {y}\nw = {w}\nh = {h}\n"),
    )
    .unwrap();
    p
}

/// Runs the `ffmpeg` command (quiet, overwriting), asserting it succeeds.
fn ffmpeg(args: &[&str]) {
    let o = Command::new("ffmpeg")
        .args(["-v", "error", "-y"])
        .args(args)
        .output()
        .expect("the ffmpeg command (scripts/setup installs it)");
    assert!(o.status.success(), "ffmpeg {args:?}: {}", stderr(&o));
}

/// A YUV4MPEG2 (.y4m) video: a text header stating `w`×`h` 4:2:0 frames at 25 fps, then
/// `frames` grey frames. The header alone is enough for FFmpeg to state the size.
fn y4m(path: &Path, w: u32, h: u32, frames: usize) {
    let mut bytes = format!("YUV4MPEG2 W{w} H{h} F25:1 Ip A1:1 C420jpeg\n").into_bytes();
    let (cw, ch) = (w.div_ceil(2) as usize, h.div_ceil(2) as usize);
    for _ in 0..frames {
        bytes.extend_from_slice(b"FRAME\n");
        bytes.extend(std::iter::repeat_n(
            128u8,
            w as usize * h as usize + 2 * cw * ch,
        ));
    }
    std::fs::write(path, bytes).unwrap();
}

// ---------------------------------------------------------------- video input

#[test]
fn missing_clip_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let clip = dir.path().join("nope.mp4");
    let o = run(&["track", s(&clip), "--seeds", s(&walk("joints.toml"))]);
    assert_fails(&o, 2, &[s(&clip), "no such file"]);
}

#[test]
fn folder_without_images_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    std::fs::write(frames.join("notes.txt"), "no frames here").unwrap();
    let o = run(&["track", s(&frames), "--seeds", s(&walk("joints.toml"))]);
    assert_fails(&o, 2, &[s(&frames), "no PNG or JPEG frames"]);
    assert!(!dir.path().join("frames.mocap").exists());
}

#[test]
fn text_file_named_mp4_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let clip = dir.path().join("notes.mp4");
    std::fs::write(&clip, "these are my notes, not a video\n").unwrap();
    let o = run(&["track", s(&clip), "--seeds", s(&walk("joints.toml"))]);
    assert_fails(&o, 2, &[s(&clip), "not a video FFmpeg can decode"]);
    let empty = dir.path().join("empty.mp4");
    std::fs::write(&empty, "").unwrap();
    let o = run(&["track", s(&empty), "--seeds", s(&walk("joints.toml"))]);
    assert_fails(&o, 2, &[s(&empty), "empty"]);
    assert!(!dir.path().join("notes.mocap").exists());
}

/// The sample mp4 keeps its index (moov) at the end: cut in half, nothing can be read, and the
/// message says the file may be cut short.
#[test]
fn mp4_cut_in_half_without_its_index_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(walk("clip.mp4")).unwrap();
    let clip = dir.path().join("half.mp4");
    std::fs::write(&clip, &bytes[..bytes.len() / 2]).unwrap();
    let o = run(&["track", s(&clip), "--seeds", s(&walk("joints.toml"))]);
    assert_fails(&o, 2, &[s(&clip), "cut short"]);
}

/// With its index first (`-movflags +faststart`), a cut mp4 still opens: the frames before the
/// cut are tracked, a warning names the frame where decoding stopped, and `run.toml` records it.
#[test]
fn mp4_cut_in_half_tracks_the_frames_before_the_cut() {
    let dir = tempfile::tempdir().unwrap();
    let fast = dir.path().join("fast.mp4");
    ffmpeg(&[
        "-i",
        s(&walk("clip.mp4")),
        "-c",
        "copy",
        "-movflags",
        "+faststart",
        s(&fast),
    ]);
    let bytes = std::fs::read(&fast).unwrap();
    let clip = dir.path().join("cut.mp4");
    std::fs::write(&clip, &bytes[..bytes.len() * 6 / 10]).unwrap();
    let out = dir.path().join("cut.mocap");
    let o = run(&[
        "track",
        s(&clip),
        "--seeds",
        s(&walk("joints.toml")),
        "--out",
        s(&out),
    ]);
    let err = assert_ok(&o);
    assert!(
        err.contains("warning")
            && err.contains("decoding stopped at frame")
            && err.contains("of the 60"),
        "{err}"
    );
    let m = mocap2d::run::Manifest::read(&out.join("run.toml")).unwrap();
    let stop = m.decode_stop.clone().expect("run.toml records the stop");
    assert!(stop.frame > 5 && stop.frame < 60, "{stop:?}");
    assert_eq!(stop.stated_frames, Some(60));
    assert_eq!(m.frames, stop.frame);
    let rows = mocap2d::run::tracks::read_tracks(&out.join("tracks.csv")).unwrap();
    assert_eq!(rows.last().unwrap().frame + 1, stop.frame);
    assert!(temp_files(&out).is_empty());
    // The whole clip records no stop.
    let whole = dir.path().join("whole.mocap");
    assert_ok(&run(&[
        "track",
        s(&fast),
        "--seeds",
        s(&walk("joints.toml")),
        "--out",
        s(&whole),
    ]));
    let text = std::fs::read_to_string(whole.join("run.toml")).unwrap();
    assert!(!text.contains("decode_stop"), "{text}");
}

#[test]
fn clip_with_zero_frames_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let clip = dir.path().join("none.y4m");
    y4m(&clip, 64, 48, 0);
    let seeds = one_joint_seeds(dir.path(), 32.0, 24.0, 11, 11);
    let o = run(&["track", s(&clip), "--seeds", s(&seeds)]);
    assert_fails(&o, 2, &[s(&clip), "no frames"]);
    assert!(!dir.path().join("none.mocap").exists());
}

#[test]
fn image_folder_of_mixed_sizes_names_the_odd_frame() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    for (i, w) in [(1, 64), (2, 64), (10, 80)] {
        image::RgbImage::new(w, 48)
            .save(frames.join(format!("f{i}.png")))
            .unwrap();
    }
    let seeds = one_joint_seeds(dir.path(), 32.0, 24.0, 11, 11);
    let o = run(&["track", s(&frames), "--seeds", s(&seeds)]);
    assert_fails(&o, 2, &["f10.png", "80x48", "64x48"]);
    assert!(!dir.path().join("frames.mocap").exists());
}

/// A 1×1 video decodes, but no joint rectangle (5 px at least) fits in it: refused naming the
/// clip and its size, never a panic.
#[test]
fn one_by_one_video_is_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let clip = dir.path().join("dot.y4m");
    y4m(&clip, 1, 1, 5);
    assert_eq!(mocap2d::decode::read_all(&clip, None).unwrap().len(), 5);
    let seeds = one_joint_seeds(dir.path(), 2.0, 2.0, 5, 5);
    let o = run(&["track", s(&clip), "--seeds", s(&seeds), "--no-background"]);
    assert_fails(&o, 2, &[s(&clip), "1x1 px", "cannot be tracked"]);
    assert!(!dir.path().join("dot.mocap").exists());
}

/// A header stating a huge frame is refused from the header, before any frame is allocated.
#[test]
fn huge_frame_size_is_refused_from_the_header() {
    let dir = tempfile::tempdir().unwrap();
    let clip = dir.path().join("huge.y4m");
    y4m(&clip, 16000, 12000, 0); // 192 Mpx: 576 MB a frame as RGB
    let seeds = one_joint_seeds(dir.path(), 32.0, 24.0, 11, 11);
    let t = std::time::Instant::now();
    let o = run(&["track", s(&clip), "--seeds", s(&seeds)]);
    assert_fails(&o, 2, &[s(&clip), "16000x12000", "above the limit"]);
    assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());

    // The same for an image folder: a PNG whose header states 20000×20000 px.
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    std::fs::write(frames.join("f1.png"), png_header_only(20000, 20000)).unwrap();
    let o = run(&["track", s(&frames), "--seeds", s(&seeds)]);
    assert_fails(&o, 2, &["f1.png", "20000x20000", "above the limit"]);
}

/// The first bytes of a PNG (signature, IHDR chunk stating `w`×`h` RGB px, an empty IDAT).
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    let mut chunk = b"IHDR".to_vec();
    chunk.extend_from_slice(&w.to_be_bytes());
    chunk.extend_from_slice(&h.to_be_bytes());
    chunk.extend_from_slice(&[8, 2, 0, 0, 0]);
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    out.extend_from_slice(&13u32.to_be_bytes());
    out.extend_from_slice(&chunk);
    out.extend_from_slice(&crc32(&chunk).to_be_bytes());
    // An empty IDAT: decoders read the header up to the first image data.
    out.extend_from_slice(&0u32.to_be_bytes());
    out.extend_from_slice(b"IDAT");
    out.extend_from_slice(&crc32(b"IDAT").to_be_bytes());
    out
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}
