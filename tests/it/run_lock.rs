//! One writer at a time in a run folder: a second `track` or `resume` started while another
//! writes the folder is refused (exit 2) naming the other process, writes nothing, and the
//! folder ends byte for byte as one run alone leaves it.
#![cfg(feature = "ffmpeg")]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::common::*;

/// A synth walk of `frames` frames (320×240) in `dir`: (clip, seed file).
fn synth_walk(dir: &Path, frames: u32) -> (PathBuf, PathBuf) {
    write_synth(
        dir,
        mocap2d::synth::Scenario::Walk,
        320,
        240,
        2,
        Some(frames),
    );
    (dir.join("clip.mp4"), dir.join("joints.toml"))
}

fn track_args<'a>(clip: &'a Path, seeds: &'a Path, out: &'a Path) -> Vec<&'a str> {
    vec![
        "track",
        s(clip),
        "--seeds",
        s(seeds),
        "--out",
        s(out),
        "--segment-len",
        "50",
        "-q",
    ]
}

fn spawn(args: &[&str]) -> Child {
    bin()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Waits until `run/.lock` names a `mocap2d {what}` (the first writer is at work).
fn wait_for_lock(run: &Path, what: &str, first: &mut Child) {
    let t = Instant::now();
    let lock = run.join(mocap2d::run::lock::LOCK_FILE);
    loop {
        let text = std::fs::read_to_string(&lock).unwrap_or_default();
        if text.contains(&format!("`mocap2d {what}`")) {
            return;
        }
        assert!(
            first.try_wait().unwrap().is_none(),
            "the first {what} finished before it was seen at work"
        );
        assert!(t.elapsed() < Duration::from_secs(60), "no lock file");
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Runs `second` while `first` (started) holds the lock: the second is refused with exit 2
/// naming the first's pid, while the first is still running. Returns the first's output.
fn second_is_refused(mut first: Child, run: &Path, what: &str, second: &[&str]) -> Output {
    wait_for_lock(run, what, &mut first);
    let o = bin().args(second).output().unwrap();
    let still_running = first.try_wait().unwrap().is_none();
    let pid = format!("pid {}", first.id());
    assert_fails(&o, 2, &["another mocap2d is writing", &pid, what]);
    assert!(
        still_running,
        "the first {what} finished before the second was refused; lengthen the clip"
    );
    let out = first.wait_with_output().unwrap();
    assert_ok(&out);
    out
}

#[test]
fn a_second_track_into_the_same_folder_is_refused_and_the_first_ends_as_if_alone() {
    let dir = tempfile::tempdir().unwrap();
    let (clip, seeds) = synth_walk(dir.path(), 600);
    let alone = dir.path().join("alone.mocap");
    assert_ok(&run(&track_args(&clip, &seeds, &alone)));
    assert!(!alone.join(mocap2d::run::lock::LOCK_FILE).exists());

    let both = dir.path().join("both.mocap");
    let first = spawn(&track_args(&clip, &seeds, &both));
    second_is_refused(first, &both, "track", &track_args(&clip, &seeds, &both));
    assert_same_folders(&alone, &both);
}

#[test]
fn a_second_resume_of_the_same_folder_is_refused_and_the_first_ends_as_if_alone() {
    let dir = tempfile::tempdir().unwrap();
    let (clip, seeds) = synth_walk(dir.path(), 600);
    let alone = dir.path().join("alone.mocap");
    assert_ok(&run(&track_args(&clip, &seeds, &alone)));
    let both = dir.path().join("both.mocap");
    let cp = Command::new("cp")
        .args(["-a", s(&alone), s(&both)])
        .status()
        .unwrap();
    assert!(cp.success());
    let resume = |run: &Path| -> Vec<String> {
        ["resume", s(run), "--segment", "0", "-q"]
            .map(str::to_owned)
            .to_vec()
    };
    let a = resume(&alone);
    assert_ok(&run(&a.iter().map(String::as_str).collect::<Vec<_>>()));
    let b = resume(&both);
    let b: Vec<&str> = b.iter().map(String::as_str).collect();
    let first = spawn(&b);
    second_is_refused(first, &both, "resume", &b);
    assert!(both.join("history/001-tracks.csv").is_file());
    assert_same_folders(&alone, &both);
}

/// A writer killed with SIGKILL leaves its `.lock` file, but the operating system released the
/// lock: the next `resume` takes it over and finishes the run.
#[test]
fn a_lock_left_by_a_killed_track_does_not_block_the_resume() {
    let dir = tempfile::tempdir().unwrap();
    let (clip, seeds) = synth_walk(dir.path(), 300);
    let out = dir.path().join("r.mocap");
    let mut first = spawn(&track_args(&clip, &seeds, &out));
    let t = Instant::now();
    while !out.join("segments/001.csv").exists() {
        assert!(first.try_wait().unwrap().is_none(), "finished too soon");
        assert!(t.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(1));
    }
    first.kill().unwrap();
    first.wait().unwrap();
    assert!(out.join(mocap2d::run::lock::LOCK_FILE).is_file());
    let o = run(&["resume", s(&out), "-q"]);
    assert_ok(&o);
    assert!(out.join("tracks.csv").is_file());
    assert!(!out.join(mocap2d::run::lock::LOCK_FILE).exists());
}
