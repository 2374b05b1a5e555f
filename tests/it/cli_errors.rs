//! The `mocap2d` binary on the bundled sample clip (`clips/walk`): the exit code and message of
//! every user error (a bad clip, seed file, flag or parameter file; exit 2, one message, no run
//! folder), and a parameter file recorded in `run.toml`. Each test works in a fresh temp dir.
//!
//! The sample clip is an mp4, so the file needs the `ffmpeg` feature (on by default).
#![cfg(feature = "ffmpeg")]

use crate::cli::{read, Dir};
use crate::common::{assert_exit, s, stderr, walk};
use std::process::Output;

/// The seed file of the sample with `from` replaced by `to` (which must occur).
fn edited_seeds(from: &str, to: &str) -> String {
    let text = read(&walk("joints.toml"));
    assert!(text.contains(from), "joints.toml has no {from:?}");
    text.replacen(from, to, 1)
}

#[test]
fn params_file_is_recorded_and_checked() {
    let d = Dir::new();
    let params = d.write(
        "params.toml",
        "search_max_px = 40.0\nlost_after_frames = 12\n",
    );
    let run = d.track_ok(
        &walk("clip.mp4"),
        &walk("joints.toml"),
        "walk.mocap",
        &["--params", s(&params)],
    );
    let manifest = read(&run.join("run.toml"));
    let unset = format!(
        "search_min_px = {:?}",
        mocap2d::track::TrackParams::default().search_min_px
    );
    for line in ["search_max_px = 40.0", "lost_after_frames = 12", &unset] {
        assert!(
            manifest.lines().any(|l| l == line),
            "run.toml has no line {line:?}:\n{manifest}"
        );
    }
    // A parameter file track refuses: one message naming the file and what is wrong in it, and
    // no run folder left behind.
    let refused = |name: &str, text: &str, needles: &[&str]| {
        let file = d.write(name, text);
        let out = format!("{name}.mocap");
        let o = d.track_walk(&out, &["--params", s(&file)]);
        assert_user_error(&o, needles);
        assert!(!d.path(&out).exists());
    };
    refused(
        "bad.toml",
        "search_max = 40.0\n",
        &["bad.toml", "search_max"],
    );
    refused(
        "range.toml",
        "length_anchor = 1.5\n",
        &["range.toml", "length_anchor = 1.5", "from 0"],
    );
    refused(
        "box.toml",
        "work_box_px = -4.0\n",
        &[
            "box.toml",
            "work_box_px = -4",
            "0 tracks at full resolution",
        ],
    );
}

/// Exit code 2 and one message on stderr, `mocap2d: ...`, holding every string of `needles`.
/// FFmpeg's own log lines (`[mov,mp4,...] ...`) are not counted.
fn assert_user_error(o: &Output, needles: &[&str]) {
    assert_exit(o, 2);
    let err = stderr(o);
    let lines: Vec<&str> = err.lines().filter(|l| !l.starts_with('[')).collect();
    assert_eq!(lines.len(), 1, "one message expected:\n{err}");
    assert!(lines[0].starts_with("mocap2d: "), "{err}");
    for n in needles {
        assert!(lines[0].contains(n), "message lacks {n:?}:\n{err}");
    }
    assert!(
        o.stdout.is_empty(),
        "stdout: {}",
        String::from_utf8_lossy(&o.stdout)
    );
}

#[test]
fn bad_clips_exit_2_without_a_run_folder() {
    let d = Dir::new();
    d.write("x.mp4", "not a video\n");
    std::fs::create_dir(d.path("empty")).unwrap();
    d.write("empty/notes.txt", "no frames here\n");
    let seeds = walk("joints.toml");
    for clip in ["missing.mp4", "x.mp4", "empty"] {
        let o = d.run(&["track", clip, "--seeds", s(&seeds), "--out", "out.mocap"]);
        assert_user_error(&o, &[&format!("mocap2d: {clip}: ")]);
        assert!(!d.path("out.mocap").exists(), "{clip}: run folder written");
        assert!(!d
            .path(&format!("{}.mocap", clip.trim_end_matches(".mp4")))
            .exists());
    }
}

#[test]
fn seed_errors_exit_2_naming_file_line_and_joint() {
    let d = Dir::new();
    let cycle = "name = \"pelvis\"\nx = 211.330\ny = 154.781\nw = 15\nh = 15\n";
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "unknown_key",
            edited_seeds("w = 15\n", "colour = 3\nw = 15\n"),
            vec!["line 9", "\"pelvis\"", "colour"],
        ),
        (
            "missing_field",
            edited_seeds("y = 119.872\n", ""),
            vec!["line 12", "\"chest\"", "missing `y`"],
        ),
        (
            "duplicate_name",
            edited_seeds("name = \"neck\"", "name = \"chest\""),
            vec!["line 21", "\"chest\"", "line 12"],
        ),
        (
            "unknown_parent",
            edited_seeds("parent = \"elbow_l\"", "parent = \"elbow_x\""),
            vec!["\"wrist_l\"", "\"elbow_x\"", "did you mean \"elbow_l\""],
        ),
        (
            "parent_cycle",
            edited_seeds(cycle, &format!("{cycle}parent = \"chest\"\n")),
            vec!["\"pelvis\"", "cycle"],
        ),
        (
            "too_small",
            edited_seeds("w = 15", "w = 4"),
            vec!["line 9", "\"pelvis\"", "at least 5"],
        ),
        (
            "outside",
            edited_seeds("x = 211.330", "x = 318.0"),
            vec!["line 5", "\"pelvis\"", "inside"],
        ),
        (
            "beyond_clip",
            edited_seeds("frame = 0", "frame = 100000"),
            vec!["100000", "60 frames"],
        ),
        (
            "no_joints",
            "# nothing to track\nframe = 0\n".to_owned(),
            vec!["no joints"],
        ),
        (
            "bad_toml",
            edited_seeds("w = 15", "w = = 15"),
            vec!["line 9", "TOML"],
        ),
    ];
    for (name, text, needles) in &cases {
        let file = format!("{name}.toml");
        d.write(&file, text);
        let o = d.run(&[
            "track",
            s(&walk("clip.mp4")),
            "--seeds",
            &file,
            "--out",
            "out.mocap",
        ]);
        let mut all = vec![&*file];
        all.extend(needles);
        assert_user_error(&o, &all);
        assert!(
            stderr(&o).starts_with(&format!("mocap2d: {file}: ")),
            "{name}: {}",
            stderr(&o)
        );
        assert!(!d.path("out.mocap").exists(), "{name}: run folder written");
    }
    let o = d.run(&[
        "track",
        s(&walk("clip.mp4")),
        "--seeds",
        "nowhere.toml",
        "--out",
        "out.mocap",
    ]);
    assert_user_error(&o, &["nowhere.toml", "not found"]);
    assert!(!d.path("out.mocap").exists());
}

#[test]
fn bad_flags_exit_2() {
    let d = Dir::new();
    assert_exit(&d.run(&["track", s(&walk("clip.mp4"))]), 2);
    assert_exit(
        &d.run(&["synth", "walk", "--out", "x", "--size", "321x240"]),
        2,
    );
    assert_exit(&d.run(&["frobnicate"]), 2);
    assert!(
        std::fs::read_dir(d.tmp.path()).unwrap().next().is_none(),
        "nothing written"
    );
}
