//! A camera that moves: `track` makes no clean plate from the clip, says so, and records it
//! (docs/method.md §1, "A camera that moves").

use crate::common::*;
use image::RgbImage;
use std::path::Path;

/// A textured scene seen through a 240×180 window at `(ox, oy)`, with a bright two-part figure.
fn view(ox: u32, oy: u32, fx: u32) -> RgbImage {
    RgbImage::from_fn(240, 180, |x, y| {
        if (fx..fx + 14).contains(&x) && (50..150).contains(&y) {
            return image::Rgb([240, 220, 60]);
        }
        let (u, v) = ((x + ox) as f32, (y + oy) as f32);
        let t = 128.0
            + 50.0 * (u * 0.11).sin() * (v * 0.07).cos()
            + 40.0 * ((u + 2.0 * v) * 0.05).sin()
            + 25.0 * ((u * 0.31 + v * 0.23).sin() * (v * 0.17 - u * 0.05).cos());
        let t = t.clamp(0.0, 255.0) as u8;
        image::Rgb([t, t / 2 + 60, 255 - t])
    })
}

/// Writes 30 frames (the figure walking right by 2 px a frame; the camera panning `pan` px a
/// frame) and a seed file for them into `dir`; returns the frames' folder and the seed file.
fn clip(dir: &Path, pan: u32) -> (std::path::PathBuf, std::path::PathBuf) {
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for i in 0..30u32 {
        view(pan * i, 0, 60 + 2 * i)
            .save(frames.join(format!("{i:03}.png")))
            .unwrap();
    }
    let seeds = dir.join("joints.toml");
    std::fs::write(
        &seeds,
        "frame = 0\n\n[[joint]]\nname = \"top\"\nx = 67\ny = 60\nw = 13\nh = 13\n\n\
         [[joint]]\nname = \"bottom\"\nx = 67\ny = 140\nw = 13\nh = 13\nparent = \"top\"\n",
    )
    .unwrap();
    (frames, seeds)
}

#[test]
fn a_panning_camera_is_tracked_without_a_plate_and_a_still_one_with() {
    let tmp = tempfile::tempdir().unwrap();
    for (pan, moves) in [(9, true), (0, false)] {
        let d = tmp.path().join(format!("pan{pan}"));
        let (frames, seeds) = clip(&d, pan);
        let out = d.join("run");
        let o = run(&[
            "track",
            s(&frames),
            "--seeds",
            s(&seeds),
            "--out",
            s(&out),
            "-q",
        ]);
        assert_exit(&o, 0);
        let said = stderr(&o).contains("the camera moves");
        assert_eq!(said, moves, "pan {pan}: {}", stderr(&o));
        let manifest = std::fs::read_to_string(out.join("run.toml")).unwrap();
        let kind = if moves { "moving-camera" } else { "median" };
        assert!(
            manifest.contains(&format!("kind = \"{kind}\"")),
            "pan {pan}: {manifest}"
        );
        // resume reads the setting back: no plate is made then either.
        let o = run(&["resume", s(&out), "--segment", "0", "-q"]);
        assert_exit(&o, 0);
        assert!(!stderr(&o).contains("the camera moves"), "{}", stderr(&o));
    }
}

/// `guide` draws the silhouette against the clip's median: with a camera that moves it says so
/// (exit 2) instead of drawing a wrong one.
#[test]
fn guide_refuses_a_clip_whose_camera_moves() {
    let tmp = tempfile::tempdir().unwrap();
    let (frames, _) = clip(tmp.path(), 9);
    let out = tmp.path().join("guide.png");
    let o = run(&["guide", s(&frames), "--out", s(&out)]);
    assert_fails(&o, 2, &["the camera moves", "--background PLATE", "serve"]);
    assert!(!out.exists());
}

/// A batch says which of its clips were tracked without a plate, in its table and its CSV.
#[test]
fn a_batch_notes_the_clip_whose_camera_moves() {
    let tmp = tempfile::tempdir().unwrap();
    let (frames, seeds) = clip(tmp.path(), 9);
    let summary = tmp.path().join("summary.csv");
    let batch = [
        "batch",
        s(&frames),
        "--seeds",
        s(&seeds),
        "--summary",
        s(&summary),
        "-q",
    ];
    let o = run(&batch);
    assert_exit(&o, 0);
    let out = stdout(&o);
    assert!(
        out.contains(&format!("note: {}: the camera moves", frames.display())),
        "{out}"
    );
    let csv = std::fs::read_to_string(&summary).unwrap();
    let header = csv.lines().next().unwrap();
    assert!(header.ends_with(",note"), "{csv}");
    assert!(csv.contains("the camera moves"), "{csv}");
    // Run again, the clip is finished: skipped, not tracked again for want of a plate.
    let o = run(&batch);
    assert_exit(&o, 0);
    assert!(stdout(&o).contains("1 skipped"), "{}", stdout(&o));
}
