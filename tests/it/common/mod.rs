//! Helpers shared by the test modules: the `mocap2d` binary under test and how to run it, the
//! bundled sample clip and characters, synthetic clips rendered in memory or into a temp dir,
//! run folders made from ground truth, and comparisons of folders. Each module uses only some of
//! them (and some only with the `ffmpeg` feature), hence `allow(dead_code)`.
#![allow(dead_code)]

use mocap2d::synth::{self, Scenario, SynthClip, SynthOptions};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

// ---------------------------------------------------------------- files of the repository

/// The repository's root (the crate's manifest folder), wherever it is cloned.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A file of the bundled sample clip (`clips/walk/`).
pub fn walk(file: &str) -> PathBuf {
    root().join("clips/walk").join(file)
}

/// A sample character file (`configs/characters/NAME`).
pub fn characters(name: &str) -> PathBuf {
    root().join("configs/characters").join(name)
}

/// The sample target character.
pub fn robot() -> PathBuf {
    characters("robot.toml")
}

/// `REL` in the `shared` folder beside the clone (`../shared/REL`), which holds the large real
/// clips; it may be absent, and the tests that use it say so and skip.
pub fn shared(rel: &str) -> PathBuf {
    root().join("../shared").join(rel)
}

// ---------------------------------------------------------------- the binary under test

/// The binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_mocap2d"))
}

/// Runs the binary with `args`, waiting for it.
pub fn run(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

/// Runs the binary with `args` in the working directory `dir`, waiting for it.
pub fn run_in(dir: &Path, args: &[&str]) -> Output {
    bin().args(args).current_dir(dir).output().unwrap()
}

/// A path as `&str` (test paths are UTF-8).
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The stderr of `o`.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The stdout of `o`.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Asserts exit code `code`, showing stdout and stderr if not.
pub fn assert_exit(o: &Output, code: i32) {
    assert_eq!(
        o.status.code(),
        Some(code),
        "exit code; stdout:\n{}\nstderr:\n{}",
        stdout(o),
        stderr(o)
    );
}

/// Asserts exit code `code`, no panic, and every one of `parts` in stderr; returns stderr.
pub fn assert_fails(o: &Output, code: i32, parts: &[&str]) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(code), "exit code; stderr:\n{err}");
    assert!(!err.contains("panicked"), "{err}");
    for p in parts {
        assert!(err.contains(p), "message lacks {p:?}:\n{err}");
    }
    err
}

/// Asserts exit code 0; returns stderr.
pub fn assert_ok(o: &Output) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(0), "exit code; stderr:\n{err}");
    err
}

/// Starts `cmd`, waits until `started()` says the work is under way (a file it writes appeared),
/// sends SIGINT, and returns its output and how long it took to exit after the signal. `None`
/// if it finished first.
pub fn interrupt(mut cmd: Command, started: impl Fn() -> bool) -> Option<(Output, Duration)> {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t = Instant::now();
    while !started() && t.elapsed() < Duration::from_secs(120) {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let pid = child.id().to_string();
    let sent = Instant::now();
    let killed = Command::new("kill").args(["-INT", &pid]).status().unwrap();
    let o = child.wait_with_output().unwrap();
    let took = sent.elapsed();
    if !killed.success() || o.status.code() == Some(0) {
        eprintln!("finished before SIGINT: {}", stderr(&o));
        return None;
    }
    Some((o, took))
}

// ---------------------------------------------------------------- synthetic clips

/// `scenario` rendered in memory at `width`×`height` from the random `seed`, `frames` frames
/// (`None`: the scenario's own length).
pub fn synth_clip(
    scenario: Scenario,
    width: u32,
    height: u32,
    seed: u64,
    frames: Option<u32>,
) -> SynthClip {
    synth::render(&SynthOptions {
        scenario,
        width,
        height,
        seed,
        frames,
    })
}

/// [`synth_clip`] written into `dir` (clip.mp4 or PNG frames, joints.toml, gt.csv, …).
pub fn write_synth(
    dir: &Path,
    scenario: Scenario,
    width: u32,
    height: u32,
    seed: u64,
    frames: Option<u32>,
) -> SynthClip {
    let clip = synth_clip(scenario, width, height, seed, frames);
    synth::write_clip(&clip, dir).unwrap();
    clip
}

/// A run folder `dir/gt.mocap` whose tracks are `clip`'s ground truth from frame `first` on
/// (tracks.csv, seeds.toml seeded on `first`, run.toml), the score of frame `f`, joint `j`
/// being `score(f, j)`.
pub fn run_from_gt(
    dir: &Path,
    clip: &SynthClip,
    first: usize,
    score: impl Fn(usize, usize) -> f32,
) -> PathBuf {
    let run = dir.join("gt.mocap");
    std::fs::create_dir_all(&run).unwrap();
    let mut t = String::from("frame,joint,x,y,angle,score,status\n");
    for (f, joints) in clip.gt.iter().enumerate().skip(first) {
        for (j, (name, (x, y))) in clip.joint_names.iter().zip(joints).enumerate() {
            let score = score(f, j);
            let _ = writeln!(t, "{f},{name},{x:.3},{y:.3},0.0000,{score:.3},ok");
        }
    }
    std::fs::write(run.join("tracks.csv"), t).unwrap();
    let seeds = clip
        .seeds_toml()
        .replace("\nframe = 0\n", &format!("\nframe = {first}\n"));
    std::fs::write(run.join("seeds.toml"), seeds).unwrap();
    let (w, h) = (clip.width(), clip.height());
    std::fs::write(
        run.join("run.toml"),
        format!("width = {w}\nheight = {h}\nfps = 30.0\n"),
    )
    .unwrap();
    run
}

// ---------------------------------------------------------------- folders

/// Every file under `dir` (recursively), sorted.
pub fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(files(&p));
            } else {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The `.tmp` files under `dir`.
pub fn temp_files(dir: &Path) -> Vec<PathBuf> {
    files(dir)
        .into_iter()
        .filter(|p| p.to_string_lossy().ends_with(".tmp"))
        .collect()
}

/// Every file of a folder, sub-folders included (relative path, bytes), sorted.
pub fn folder_bytes(dir: &Path) -> Vec<(String, Vec<u8>)> {
    files(dir)
        .into_iter()
        .map(|p| {
            let rel = p.strip_prefix(dir).unwrap().display().to_string();
            (rel, std::fs::read(&p).unwrap())
        })
        .collect()
}

/// Asserts that folders `a` and `b` hold the same files with the same bytes (`b` being the
/// reference: the run left alone, uninterrupted, …).
pub fn assert_same_folders(a: &Path, b: &Path) {
    let (x, y) = (folder_bytes(a), folder_bytes(b));
    assert_eq!(
        x.iter().map(|f| &f.0).collect::<Vec<_>>(),
        y.iter().map(|f| &f.0).collect::<Vec<_>>(),
        "the same files"
    );
    for ((name, x), (_, y)) in x.iter().zip(&y) {
        assert!(
            x == y,
            "{name} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}
