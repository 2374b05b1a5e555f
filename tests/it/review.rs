//! `mocap2d guide` and `mocap2d review` end to end on tiny synth clips: the files they write
//! decode (PNG sizes, the overlay's frame count), the starter seed file parses and can be
//! tracked from, and the user errors exit with 2.
#![cfg(feature = "ffmpeg")]

use crate::common::{assert_exit, run_in as run, write_synth};
use mocap2d::run::TrackRow;
use mocap2d::seed::{read_seeds, to_toml};
use mocap2d::synth::Scenario;
use std::path::Path;

const W: u32 = 320;
const H: u32 = 240;

/// Renders `scenario` (`frames` frames, 320×240) into a temp dir: clip.mp4, joints.toml, ….
fn synth(scenario: Scenario, frames: u32) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    write_synth(dir.path(), scenario, W, H, 2, Some(frames));
    dir
}

fn png_size(p: &Path) -> (u32, u32) {
    let img = image::open(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    (img.width(), img.height())
}

#[test]
fn guide_writes_a_png_and_a_starter_seed_file_that_tracks() {
    let dir = synth(Scenario::Walk, 24);
    let d = dir.path();
    let o = run(
        d,
        &[
            "guide",
            "clip.mp4",
            "--frame",
            "3",
            "--out",
            "g.png",
            "--seeds-out",
            "s.toml",
        ],
    );
    assert_exit(&o, 0);
    assert_eq!(png_size(&d.join("g.png")), (W, H));
    let (seeds, _) = read_seeds(&d.join("s.toml")).unwrap();
    assert_eq!(seeds.frame, 3);
    seeds
        .check_against_clip(&d.join("s.toml"), W, H, Some(24))
        .unwrap();
    // The walker shows at least a head and two feet; names j0, j1, … with one root.
    assert!(seeds.joints.len() >= 3, "{:?}", seeds.joints);
    for (i, j) in seeds.joints.iter().enumerate() {
        assert_eq!(j.name, format!("j{i}"));
    }
    assert_eq!(seeds.skeleton.roots().len(), 1);
    // Every point lies on the character: near some ground-truth joint or limb (within 40 px of
    // a joint on a 240-px frame, where the figure is about 100 px tall).
    let gt = std::fs::read_to_string(d.join("gt.csv")).unwrap();
    let gt3: Vec<(f32, f32)> = gt
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[0] == "3")
        .map(|c| (c[2].parse().unwrap(), c[3].parse().unwrap()))
        .collect();
    for j in &seeds.joints {
        let d = gt3
            .iter()
            .map(|&(x, y)| ((x - j.bbox.cx).powi(2) + (y - j.bbox.cy).powi(2)).sqrt())
            .fold(f32::INFINITY, f32::min);
        assert!(d < 40.0, "{} is {d} px from every joint", j.name);
    }
    // The starter file is a seed file `track` accepts.
    let o = run(
        d,
        &[
            "track", "clip.mp4", "--seeds", "s.toml", "--out", "s.mocap", "-q",
        ],
    );
    assert_exit(&o, 0);
    // It is never overwritten, and the guide must be a PNG.
    let before = std::fs::read(d.join("s.toml")).unwrap();
    let o = run(
        d,
        &[
            "guide",
            "clip.mp4",
            "--out",
            "g2.png",
            "--seeds-out",
            "s.toml",
        ],
    );
    assert_exit(&o, 2);
    assert!(String::from_utf8_lossy(&o.stderr).contains("s.toml"));
    assert_eq!(std::fs::read(d.join("s.toml")).unwrap(), before);
    assert!(!d.join("g2.png").exists());
    assert_exit(&run(d, &["guide", "clip.mp4", "--out", "g.jpg"]), 2);
    let o = run(
        d,
        &["guide", "clip.mp4", "--frame", "24", "--out", "g3.png"],
    );
    assert_exit(&o, 2);
    assert!(String::from_utf8_lossy(&o.stderr).contains("24 frames"));
}

/// Writes `RUN/segments/NNN.toml` at `starts`, in the seed-file format, from the run's tracks
/// (what `track --segment-len` will write).
fn write_segments(run_dir: &Path, starts: &[u64]) {
    let (seeds, _) = read_seeds(&run_dir.join("seeds.toml")).unwrap();
    let rows: Vec<TrackRow> =
        mocap2d::run::tracks::read_tracks(&run_dir.join("tracks.csv")).unwrap();
    std::fs::create_dir_all(run_dir.join("segments")).unwrap();
    for (k, &f) in starts.iter().enumerate() {
        let joints: Vec<_> = seeds
            .joints
            .iter()
            .map(|j| {
                let r = rows
                    .iter()
                    .find(|r| r.frame == f && r.joint == j.name)
                    .unwrap();
                let mut j = j.clone();
                j.bbox.cx = r.x;
                j.bbox.cy = r.y;
                j.bbox.angle_rad = r.angle;
                j.score = Some(r.score);
                j.status = Some(r.status.clone());
                j
            })
            .collect();
        let text = to_toml(f, &joints, &format!("segment {k}"));
        std::fs::write(run_dir.join(format!("segments/{k:03}.toml")), text).unwrap();
    }
}

#[test]
fn review_writes_overlay_plot_and_sheet_that_decode() {
    let dir = synth(Scenario::Occlude, 30);
    let d = dir.path();
    assert_exit(
        &run(
            d,
            &[
                "track",
                "clip.mp4",
                "--seeds",
                "joints.toml",
                "--out",
                "r.mocap",
                "-q",
            ],
        ),
        0,
    );
    let o = run(d, &["review", "r.mocap"]);
    assert_exit(&o, 0);
    // `track` wrote a segment file at the seed frame and one at the last frame.
    assert!(String::from_utf8_lossy(&o.stderr).contains("2 segments"));
    let rev = d.join("r.mocap/review");
    let overlay = mocap2d::decode::read_all(&rev.join("overlay.mp4"), None).unwrap();
    assert_eq!(overlay.len(), 30);
    assert_eq!((overlay[0].width(), overlay[0].height()), (W, H));
    // The overlay differs from the clip where the rectangles are drawn.
    let clip = mocap2d::decode::read_all(&d.join("clip.mp4"), None).unwrap();
    let changed = overlay[5]
        .pixels()
        .zip(clip[5].pixels())
        .filter(|(a, b)| a.0.iter().zip(b.0).any(|(x, y)| x.abs_diff(y) > 60))
        .count();
    assert!(changed > 500, "{changed} px changed");
    let (pw, ph) = png_size(&rev.join("confidence.png"));
    assert_eq!(pw, 1366);
    assert!(ph > 14 * 36, "{ph}");
    let one_tile = png_size(&rev.join("segments.png"));

    // With segment files the sheet has a tile per segment.
    write_segments(&d.join("r.mocap"), &[0, 10, 20]);
    let o = run(d, &["review", "r.mocap"]);
    assert_exit(&o, 0);
    assert!(String::from_utf8_lossy(&o.stderr).contains("3 segments"));
    let three = png_size(&rev.join("segments.png"));
    // Three tiles of the frame width side by side, one row as before.
    assert_eq!(
        three,
        (8 + 3 * (W + 8), one_tile.1),
        "{three:?} vs {one_tile:?}"
    );

    // Same inputs, same bytes.
    let plot1 = std::fs::read(rev.join("confidence.png")).unwrap();
    let sheet1 = std::fs::read(rev.join("segments.png")).unwrap();
    assert_exit(&run(d, &["review", "r.mocap"]), 0);
    assert_eq!(std::fs::read(rev.join("confidence.png")).unwrap(), plot1);
    assert_eq!(std::fs::read(rev.join("segments.png")).unwrap(), sheet1);

    // A broken segment file is named; a missing clip asks for --clip.
    std::fs::write(
        d.join("r.mocap/segments/001.toml"),
        "frame = 10\n[[joint]]\nname = 3\n",
    )
    .unwrap();
    let o = run(d, &["review", "r.mocap"]);
    assert_exit(&o, 2);
    assert!(String::from_utf8_lossy(&o.stderr).contains("001.toml"));
    std::fs::remove_file(d.join("r.mocap/segments/001.toml")).unwrap();
    std::fs::rename(d.join("clip.mp4"), d.join("moved.mp4")).unwrap();
    let o = run(d, &["review", "r.mocap"]);
    assert_exit(&o, 2);
    assert!(String::from_utf8_lossy(&o.stderr).contains("--clip"));
    assert_exit(&run(d, &["review", "r.mocap", "--clip", "moved.mp4"]), 0);
}
