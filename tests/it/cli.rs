//! The `mocap2d` binary end to end on the bundled sample clip (`clips/walk`, 320×240 px, 60
//! frames, 14 joints): the run folder `track` writes (also seeded mid-clip, tracking backward
//! from there), where it goes by default, determinism, image-folder input and a frame damaged
//! mid-folder. Each test works in a fresh temp dir ([`Dir`]); the helpers here serve
//! `cli_errors` and `cli_accuracy` too.
//!
//! The sample clip is an mp4, so the file needs the `ffmpeg` feature (on by default).
#![cfg(feature = "ffmpeg")]

use crate::common::{assert_exit, run_in, s, stderr, walk};
use std::path::{Path, PathBuf};
use std::process::Output;

/// Joints in clips/walk/joints.toml and frames in clips/walk/clip.mp4.
pub(crate) const JOINTS: usize = 14;
pub(crate) const FRAMES: usize = 60;

/// The status words `tracks.csv` may hold.
const STATUS_WORDS: &[&str] = &["seed", "ok", "low", "occluded", "lost"];

/// A fresh temp dir to run the binary in.
pub(crate) struct Dir {
    pub(crate) tmp: tempfile::TempDir,
}

impl Dir {
    pub(crate) fn new() -> Dir {
        Dir {
            tmp: tempfile::tempdir().unwrap(),
        }
    }

    pub(crate) fn path(&self, rel: &str) -> PathBuf {
        self.tmp.path().join(rel)
    }

    pub(crate) fn write(&self, rel: &str, text: &str) -> PathBuf {
        let p = self.path(rel);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// Runs `mocap2d ARGS` with the temp dir as working directory.
    pub(crate) fn run(&self, args: &[&str]) -> Output {
        run_in(self.tmp.path(), args)
    }

    /// Runs `mocap2d track` on the bundled sample into `out`, with `extra` arguments.
    pub(crate) fn track_walk(&self, out: &str, extra: &[&str]) -> Output {
        let (clip, seeds) = (walk("clip.mp4"), walk("joints.toml"));
        let mut args = vec!["track", s(&clip), "--seeds", s(&seeds), "--out", out];
        args.extend_from_slice(extra);
        self.run(&args)
    }

    /// Runs `mocap2d track CLIP --seeds SEEDS --out OUT`, asserting success.
    pub(crate) fn track_ok(&self, clip: &Path, seeds: &Path, out: &str, extra: &[&str]) -> PathBuf {
        let mut args = vec!["track", s(clip), "--seeds", s(seeds), "--out", out];
        args.extend_from_slice(extra);
        let o = self.run(&args);
        assert_exit(&o, 0);
        self.path(out)
    }
}

pub(crate) fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The sample's seed file moved to frame `frame`: rectangles centred on the ground truth there.
fn seeds_on_frame(frame: u64) -> String {
    let gt = read(&walk("gt.csv"));
    let at = |joint: &str| -> (String, String) {
        let prefix = format!("{frame},{joint},");
        let line = gt.lines().find(|l| l.starts_with(&prefix)).unwrap();
        let v: Vec<&str> = line.split(',').collect();
        (v[2].to_owned(), v[3].to_owned())
    };
    let mut out = String::new();
    let mut xy = None;
    for line in read(&walk("joints.toml")).lines() {
        if let Some(n) = line.strip_prefix("name = ") {
            xy = Some(at(n.trim_matches('"')));
        }
        let line = match (line.split_once(" = "), &xy) {
            (Some(("frame", _)), _) => format!("frame = {frame}"),
            (Some(("x", _)), Some((x, _))) => format!("x = {x}"),
            (Some(("y", _)), Some((_, y))) => format!("y = {y}"),
            _ => line.to_owned(),
        };
        out.push_str(&line);
        out.push('\n');
    }
    out
}

/// Checks `tracks.csv`: header, one row per joint per frame from `first` to the last frame in
/// frame then seed-file order, a status word on every row, `seed` on frame `seed` only.
fn check_tracks(text: &str, first: usize, seed: usize) {
    let names: Vec<String> = read(&walk("joints.toml"))
        .lines()
        .filter_map(|l| {
            l.strip_prefix("name = ")
                .map(|n| n.trim_matches('"').to_owned())
        })
        .collect();
    assert_eq!(names.len(), JOINTS);
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("frame,joint,x,y,angle,score,status"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(
        rows.len(),
        JOINTS * (FRAMES - first),
        "rows = joints × frames from frame {first}"
    );
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r.len(), 7, "row {}: {r:?}", i + 2);
        assert_eq!(
            r[0].parse::<usize>().unwrap(),
            first + i / JOINTS,
            "row {}: {r:?}",
            i + 2
        );
        assert_eq!(r[1], names[i % JOINTS], "row {}: {r:?}", i + 2);
        for v in &r[2..6] {
            assert!(
                v.parse::<f32>().unwrap().is_finite(),
                "row {}: {r:?}",
                i + 2
            );
        }
        let score: f32 = r[5].parse().unwrap();
        assert!((0.0..=1.0).contains(&score), "row {}: {r:?}", i + 2);
        assert!(STATUS_WORDS.contains(&r[6]), "row {}: {r:?}", i + 2);
        assert_eq!(
            r[6] == "seed",
            first + i / JOINTS == seed,
            "`seed` marks the seed frame only; row {}: {r:?}",
            i + 2
        );
    }
}

#[test]
fn track_writes_tracks_manifest_and_seed_copy() {
    let d = Dir::new();
    let run = d.track_ok(&walk("clip.mp4"), &walk("joints.toml"), "walk.mocap", &[]);
    check_tracks(&read(&run.join("tracks.csv")), 0, 0);
    assert_eq!(
        read(&run.join("seeds.toml")),
        read(&walk("joints.toml")),
        "seeds.toml is a verbatim copy"
    );
    let manifest = read(&run.join("run.toml"));
    for line in [
        "width = 320",
        "height = 240",
        &format!("frames = {FRAMES}"),
        "seed_frame = 0",
        &format!("joints = {JOINTS}"),
        "[clip]",
        &format!("path = {:?}", s(&walk("clip.mp4"))),
        "[params]",
    ] {
        assert!(
            manifest.lines().any(|l| l == line),
            "run.toml has no line {line:?}:\n{manifest}"
        );
    }
    let mut names: Vec<_> = std::fs::read_dir(&run)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "report.md",
            "run.toml",
            "seeds.toml",
            "segments",
            "tracks.csv"
        ],
        "no temp files left behind"
    );
    // One segment (60 frames < 150): its seed file and its rows, which are tracks.csv's, and
    // the file on the clip's last frame.
    let mut segs: Vec<_> = std::fs::read_dir(run.join("segments"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    segs.sort();
    assert_eq!(segs, ["000.csv", "000.toml", "001.toml"]);
    assert!(read(&run.join("segments/001.toml")).contains(&format!("frame = {}", FRAMES - 1)));
    assert_eq!(
        read(&run.join("segments/000.csv")),
        read(&run.join("tracks.csv"))
    );
    assert!(manifest.lines().any(|l| l == "complete = true"));
}

/// Seeded on frame 30 of the 60-frame walk, `track` follows the joints backward from there to
/// frame 0 as well as forward: every frame has rows, `seed` only on frame 30, and the frames
/// before it are as near the truth as the frames after. A second run repeats the bytes, and
/// `resume --segment 0` too.
#[test]
fn frames_before_the_seed_frame_are_tracked_backward() {
    let d = Dir::new();
    let seeds = d.write("frame30.toml", &seeds_on_frame(30));
    let run = d.track_ok(&walk("clip.mp4"), &seeds, "walk.mocap", &[]);
    let text = read(&run.join("tracks.csv"));
    check_tracks(&text, 0, 30);
    assert!(read(&run.join("run.toml"))
        .lines()
        .any(|l| l == "seed_frame = 30"));
    // Measured: frames 0-29 PCK@5 100 %, mean error 0.28 px; frames 30-59 99.3 %, 0.33 px.
    let gt = read(&walk("gt.csv"));
    let truth: std::collections::HashMap<(u64, String), (f32, f32)> = gt
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            (
                (v[0].parse().unwrap(), v[1].to_owned()),
                (v[2].parse().unwrap(), v[3].parse().unwrap()),
            )
        })
        .collect();
    let (mut near, mut all, mut sum) = (0, 0, 0.0f32);
    for l in text.lines().skip(1) {
        let v: Vec<&str> = l.split(',').collect();
        let f: u64 = v[0].parse().unwrap();
        if f >= 30 {
            continue;
        }
        let (x, y): (f32, f32) = (v[2].parse().unwrap(), v[3].parse().unwrap());
        let (tx, ty) = truth[&(f, v[1].to_owned())];
        let e = ((x - tx).powi(2) + (y - ty).powi(2)).sqrt();
        near += (e <= 5.0) as usize;
        all += 1;
        sum += e;
    }
    assert_eq!(all, 30 * JOINTS);
    assert!(near as f32 >= 0.98 * all as f32, "PCK@5 {near}/{all}");
    assert!(
        sum / (all as f32) < 0.6,
        "mean error {} px",
        sum / all as f32
    );
    // The same bytes again: tracking from scratch, and resuming from segment 0.
    let again = d.track_ok(&walk("clip.mp4"), &seeds, "again.mocap", &[]);
    assert_eq!(read(&again.join("tracks.csv")), text);
    let o = d.run(&["resume", s(&run), "--segment", "0"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(read(&run.join("tracks.csv")), text);
}

#[test]
fn default_run_folder_is_beside_the_clip() {
    let d = Dir::new();
    std::fs::copy(walk("clip.mp4"), d.path("clip.mp4")).unwrap();
    let o = d.run(&["track", "clip.mp4", "--seeds", s(&walk("joints.toml"))]);
    assert_exit(&o, 0);
    assert!(d.path("clip.mocap/tracks.csv").is_file(), "{}", stderr(&o));
}

#[test]
fn two_runs_write_identical_files() {
    let d = Dir::new();
    let a = d.track_ok(&walk("clip.mp4"), &walk("joints.toml"), "a.mocap", &[]);
    let b = d.track_ok(&walk("clip.mp4"), &walk("joints.toml"), "b.mocap", &[]);
    for f in [
        "tracks.csv",
        "run.toml",
        "seeds.toml",
        "report.md",
        "segments/000.toml",
    ] {
        assert!(
            std::fs::read(a.join(f)).unwrap() == std::fs::read(b.join(f)).unwrap(),
            "{f} differs between runs"
        );
    }
}

/// Decodes the sample through the library and saves its frames as PNGs, so the folder holds the
/// very pixels the mp4 decodes to.
fn write_frames(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let mut source = mocap2d::decode::open(&walk("clip.mp4"), None).unwrap();
    let mut n = 0;
    while let Some(frame) = source.next_frame().unwrap() {
        n += 1;
        frame.save(dir.join(format!("frame{n:04}.png"))).unwrap();
    }
    assert_eq!(n, FRAMES);
}

#[test]
fn image_folder_tracks_like_the_video() {
    let d = Dir::new();
    write_frames(&d.path("frames"));
    // A shared clean plate: the temporal-median background samples different frames from a
    // video (keyframe seeks, or a strided decode) than from a folder, so it may differ.
    let plate = walk("background.png");
    let extra = ["--background", s(&plate)];
    let video = d.track_ok(
        &walk("clip.mp4"),
        &walk("joints.toml"),
        "video.mocap",
        &extra,
    );
    let folder = d.track_ok(
        &d.path("frames"),
        &walk("joints.toml"),
        "folder.mocap",
        &extra,
    );
    let (tv, tf) = (
        read(&video.join("tracks.csv")),
        read(&folder.join("tracks.csv")),
    );
    check_tracks(&tf, 0, 0);
    assert!(
        tv == tf,
        "tracks.csv differs between the mp4 and its frames as PNGs"
    );
}

#[test]
fn damage_mid_clip_keeps_the_frames_before_it() {
    let d = Dir::new();
    write_frames(&d.path("frames"));
    // Frame 30 keeps a valid PNG header (the folder opens fine) but loses its pixel data, so
    // decoding fails there, after tracking has begun: frames 0..29 are tracked, with a warning
    // naming the file, and run.toml records where decoding stopped.
    let f30 = d.path("frames/frame0030.png");
    let bytes = std::fs::read(&f30).unwrap();
    std::fs::write(&f30, &bytes[..100]).unwrap();
    let plate = walk("background.png");
    let o = d.run(&[
        "track",
        s(&d.path("frames")),
        "--seeds",
        s(&walk("joints.toml")),
        "--out",
        "broken.mocap",
        "--background",
        s(&plate),
    ]);
    assert_exit(&o, 0);
    let err = stderr(&o);
    assert!(
        err.contains("warning")
            && err.contains("frame0030.png")
            && err.contains("stopped at frame 29"),
        "{err}"
    );
    let m = mocap2d::run::Manifest::read(&d.path("broken.mocap/run.toml")).unwrap();
    assert_eq!(m.frames, 29);
    assert_eq!(m.decode_stop.map(|s| s.frame), Some(29));
}
