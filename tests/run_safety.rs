//! Issue 27's smaller defects, each tried as a user would: paths that are not UTF-8, a batch
//! over a run holding an unapplied edit, a truncated MKV, `track --out` into another clip's run
//! folder, a seed file with too many joints, a degenerate character, `resume` looking for the
//! clip beside the run folder, and error messages that name the right line once.
#![cfg(feature = "ffmpeg")]

use std::ffi::OsString;
use std::os::unix::ffi::OsStringExt;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::*;

/// `dir/NAME` with a byte 0xff in NAME (not UTF-8).
fn not_utf8(dir: &Path, before: &str, after: &str) -> PathBuf {
    let mut name = before.as_bytes().to_vec();
    name.push(0xff);
    name.extend_from_slice(after.as_bytes());
    dir.join(OsString::from_vec(name))
}

fn run_os(args: &[&std::ffi::OsStr]) -> Output {
    bin().args(args).output().unwrap()
}

#[test]
fn paths_that_are_not_utf8_are_refused_without_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let clip = not_utf8(dir.path(), "bad", "name.mp4");
    std::fs::copy(walk("clip.mp4"), &clip).unwrap();
    let seeds = walk("joints.toml");
    let o = run_os(&[
        "track".as_ref(),
        clip.as_os_str(),
        "--seeds".as_ref(),
        seeds.as_os_str(),
        "-q".as_ref(),
    ]);
    assert_fails(&o, 2, &["not valid UTF-8", "rename"]);
    assert_eq!(files(dir.path()), vec![clip.clone()], "nothing written");

    let run_dir = dir.path().join("r.mocap");
    assert_ok(&run(&[
        "track",
        s(&walk("clip.mp4")),
        "--seeds",
        s(&seeds),
        "--out",
        s(&run_dir),
        "-q",
    ]));
    let o = run_os(&[
        "review".as_ref(),
        run_dir.as_os_str(),
        "--clip".as_ref(),
        clip.as_os_str(),
        "-q".as_ref(),
    ]);
    assert_fails(&o, 2, &["not valid UTF-8"]);

    assert_ok(&run(&["retarget", s(&run_dir), "--target", s(&robot())]));
    let video = not_utf8(dir.path(), "o", ".mp4");
    let o = run_os(&[
        "render".as_ref(),
        run_dir.as_os_str(),
        "--target".as_ref(),
        robot().as_os_str(),
        "--out".as_ref(),
        video.as_os_str(),
        "-q".as_ref(),
    ]);
    assert_fails(&o, 2, &["not valid UTF-8"]);
    assert!(!video.exists());
    assert!(temp_files(dir.path()).is_empty(), "{:?}", temp_files(dir.path()));
}

/// The sample clip re-encoded as MKV (which states a duration, not a frame count) at `path`.
fn sample_as_mkv(path: &Path) {
    let frames = mocap2d::decode::read_all(&walk("clip.mp4"), None).unwrap();
    let mut w = mocap2d::encode::VideoWriter::create(path, 320, 240, 30.0, 18).unwrap();
    for f in &frames {
        w.write(f).unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn a_truncated_mkv_is_tracked_with_a_decode_stop_and_a_whole_one_without() {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole.mkv");
    sample_as_mkv(&whole);
    let bytes = std::fs::read(&whole).unwrap();
    let half = dir.path().join("half.mkv");
    std::fs::write(&half, &bytes[..bytes.len() / 2]).unwrap();
    let track = |clip: &Path| {
        let out = clip.with_extension("mocap");
        let o = run(&[
            "track",
            s(clip),
            "--seeds",
            s(&walk("joints.toml")),
            "--out",
            s(&out),
            "-q",
        ]);
        assert_ok(&o);
        let m = mocap2d::run::Manifest::read(&out.join("run.toml")).unwrap();
        (stderr(&o), m)
    };
    let (err, m) = track(&whole);
    assert!(!err.contains("warning"), "{err}");
    assert_eq!((m.frames, m.decode_stop), (60, None));
    let (err, m) = track(&half);
    let stop = m.decode_stop.expect("a decode_stop in run.toml");
    assert!(stop.frame < 50 && stop.frame == m.frames, "{stop:?}");
    assert!(stop.reason.contains("about 60 frames"), "{stop:?}");
    assert!(
        err.contains("warning: the clip is damaged or cut short") && err.contains("about 60"),
        "{err}"
    );
}
