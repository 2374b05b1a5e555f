//! Helpers shared by the tests that drive the `mocap2d` binary on the bundled sample clip
//! (`tests/hardening_run.rs`, `tests/signals.rs`, `tests/batch.rs`). Each test crate uses only some of them.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A file of the bundled sample clip (`clips/walk/`).
pub fn walk(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("clips/walk")
        .join(file)
}

/// The sample target character.
pub fn robot() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/characters/robot.toml")
}

/// The binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_mocap2d"))
}

/// Runs the binary with `args`, waiting for it.
pub fn run(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

/// A path as `&str` (test paths are UTF-8).
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The stderr of `o`.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
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

/// Asserts exit code 0.
pub fn assert_ok(o: &Output) {
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(o));
}

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
