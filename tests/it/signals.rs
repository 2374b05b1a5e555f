//! Ctrl-C (SIGINT) during `track`, `render` and `resume`: each stops within seconds with exit
//! code 130 and the "interrupted" message, leaves no temp file and no half-written file, and an
//! interrupted `track` or `resume` keeps a consistent checkpoint that `resume` finishes to the
//! very bytes of an uninterrupted run. (`batch` is in `tests/it/batch.rs`.)
#![cfg(feature = "ffmpeg")]

use mocap2d::run::Manifest;
use std::path::Path;
use std::process::{Command, Output};
use std::time::Duration;

use crate::common;
use crate::common::*;

/// The sample clip looped `times` times (remuxed, not re-encoded) into `path`.
fn long_clip(path: &Path, times: u32) {
    let o = Command::new("ffmpeg")
        .args([
            "-v",
            "error",
            "-y",
            "-stream_loop",
            &(times - 1).to_string(),
            "-i",
        ])
        .arg(walk("clip.mp4"))
        .args(["-c", "copy"])
        .arg(path)
        .output()
        .expect("the ffmpeg command (scripts/setup installs it)");
    assert!(o.status.success(), "{}", stderr(&o));
}

/// [`common::interrupt`] of `mocap2d ARGS`.
fn interrupt(args: &[&str], started: impl Fn() -> bool) -> Option<(Output, Duration)> {
    let mut cmd = bin();
    cmd.args(args);
    common::interrupt(cmd, started)
}

#[test]
fn sigint_during_track_and_render_stops_promptly_and_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let clip = dir.path().join("long.mp4");
    long_clip(&clip, 10); // 600 frames
    let out = dir.path().join("long.mocap");
    let seeds = walk("joints.toml");
    let args = ["track", s(&clip), "--seeds", s(&seeds), "--out", s(&out)];
    let first = out.join("segments").join("000.toml");
    let (o, took) = interrupt(&args, || first.exists()).expect("SIGINT while tracking");
    assert_fails(&o, 130, &["interrupted"]);
    assert!(
        took < Duration::from_secs(3),
        "exit took {took:?} after SIGINT"
    );
    // Nothing half-written: the folder this run made is gone, or holds only whole files.
    assert!(
        temp_files(dir.path()).is_empty(),
        "{:?}",
        temp_files(dir.path())
    );
    assert!(!out.join("tracks.csv").exists() || out.join("run.toml").exists());
    // The checkpoint is kept: `resume` finishes the run.
    if out.join("run.toml").exists() {
        assert_ok(&run(&["resume", s(&out)]));
        assert!(out.join("tracks.csv").exists());
    }

    // Render: a full run of the long clip, then Ctrl-C mid-render.
    assert_ok(&run(&args));
    assert_ok(&run(&["retarget", s(&out), "--target", s(&robot())]));
    let video = dir.path().join("robot.mp4");
    let frames = dir.path().join("frames");
    let target = robot();
    let args = [
        "render",
        s(&out),
        "--target",
        s(&target),
        "--out",
        s(&video),
        "--frames-dir",
        s(&frames),
    ];
    let drawn = || std::fs::read_dir(&frames).is_ok_and(|mut d| d.next().is_some());
    let (o, took) = interrupt(&args, drawn).expect("SIGINT while rendering");
    assert_fails(&o, 130, &["interrupted"]);
    assert!(
        took < Duration::from_secs(3),
        "exit took {took:?} after SIGINT"
    );
    assert!(!video.exists(), "a half video was left");
    assert!(
        !frames.exists(),
        "frames of an interrupted render were left"
    );
    assert!(
        temp_files(dir.path()).is_empty(),
        "{:?}",
        temp_files(dir.path())
    );
}

/// `(complete, tracked_segments)` as a run's `run.toml` says, once it reads.
fn checkpoint(run: &Path) -> Option<(bool, u64)> {
    let m = Manifest::read(&run.join("run.toml")).ok()?;
    Some((m.complete, m.tracked_segments))
}

/// An interrupted run folder is a checkpoint `resume` can carry on from: no temp file, a
/// `run.toml` that reads and says the run is unfinished, the rows of every segment it counts
/// as tracked, the file the next segment starts from, and no `tracks.csv`.
fn assert_checkpoint(run: &Path) {
    assert!(temp_files(run).is_empty(), "{:?}", temp_files(run));
    let m = Manifest::read(&run.join("run.toml")).expect("run.toml of the interrupted run");
    assert!(!m.complete, "an interrupted run marked complete");
    for k in 0..m.tracked_segments {
        let rows = run.join(format!("segments/{k:03}.csv"));
        assert!(rows.is_file(), "{} missing", rows.display());
    }
    let next = run.join(format!("segments/{:03}.toml", m.tracked_segments));
    assert!(next.is_file(), "{} missing", next.display());
    assert!(!run.join("tracks.csv").exists());
}

#[test]
fn sigint_during_resume_stops_promptly_and_resume_finishes_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let synth = dir.path().join("synth");
    assert_ok(&run(&[
        "synth",
        "walk",
        "--size",
        "320x180",
        "--frames",
        "300",
        "--out",
        s(&synth),
        "-q",
    ]));
    let (clip, seeds) = (synth.join("clip.mp4"), synth.join("joints.toml"));
    let track = |out: &Path| -> Vec<String> {
        let args = ["track", s(&clip), "--seeds", s(&seeds), "--out", s(out)];
        let mut v: Vec<String> = args.map(str::to_owned).to_vec();
        v.extend(["--segment-len", "20", "-q"].map(str::to_owned)); // 15 segments
        v
    };
    let whole = dir.path().join("whole.mocap");
    let args = track(&whole);
    assert_ok(&run(&args.iter().map(String::as_str).collect::<Vec<_>>()));

    // A track interrupted after segment 1, a `resume` of it interrupted after segment 5, then a
    // `resume` to the end: the bytes of the uninterrupted run.
    let cut = dir.path().join("cut.mocap");
    let args = track(&cut);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (o, _) = interrupt(&args, || checkpoint(&cut).is_some_and(|(_, k)| k >= 2))
        .expect("SIGINT while tracking");
    assert_fails(&o, 130, &["interrupted"]);
    assert_checkpoint(&cut);
    let resume = ["resume", s(&cut), "-q"];
    let (o, took) = interrupt(&resume, || checkpoint(&cut).is_some_and(|(_, k)| k >= 6))
        .expect("SIGINT while resuming");
    eprintln!("resume exited {took:?} after SIGINT");
    assert_fails(&o, 130, &["interrupted", "mocap2d resume RUN"]);
    assert!(
        took < Duration::from_secs(5),
        "exit took {took:?} after SIGINT"
    );
    assert_checkpoint(&cut);
    let (_, k) = checkpoint(&cut).unwrap();
    assert!((6..15).contains(&k), "stopped after segment {k}");
    assert_ok(&run(&resume));
    assert_same_folders(&whole, &cut);

    // `resume --segment 0` of the finished run: interrupted after segment 2, then `resume`;
    // the same as an uninterrupted `resume --segment 0` (the old tracks kept in history/).
    assert_ok(&run(&["resume", s(&whole), "--segment", "0", "-q"]));
    let again = ["resume", s(&cut), "--segment", "0", "-q"];
    let (o, took) = interrupt(&again, || {
        checkpoint(&cut).is_some_and(|(c, k)| !c && k >= 3)
    })
    .expect("SIGINT while re-tracking from segment 0");
    eprintln!("resume --segment 0 exited {took:?} after SIGINT");
    assert_fails(&o, 130, &["interrupted"]);
    assert!(
        took < Duration::from_secs(5),
        "exit took {took:?} after SIGINT"
    );
    assert_checkpoint(&cut);
    assert!(
        cut.join("history/001-tracks.csv").is_file(),
        "the old tracks are kept"
    );
    assert_ok(&run(&resume));
    assert_same_folders(&whole, &cut);
}
