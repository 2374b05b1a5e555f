//! `resume` and the run folder's files, on synthetic clips: a run killed mid-clip (twice)
//! resumes to the very bytes of an uninterrupted run, a run folder refuses another clip or
//! other parameters, an edited segment file is never overwritten and frames before a
//! correction stay byte for byte, uncorrected segment boundaries track as one tracker, and a
//! missing or changed state file is named and rebuilt from an earlier segment.
#![cfg(feature = "ffmpeg")]

use crate::common::{bin, run as run_bin, s};
use crate::segments::{assert_exit, lines_before, resume_run, Synth};
use mocap2d::run::segments::file_path;
use mocap2d::run::tracks::read_tracks;
use mocap2d::seed::read_seeds;
use mocap2d::synth::Scenario;
use std::path::Path;

/// Starts the binary with `args` and kills it (SIGKILL) once `file` exists. Returns whether
/// it was still running then.
fn kill_when(args: &[&str], file: &Path) -> bool {
    let mut child = bin()
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            assert!(status.success(), "{args:?} failed before the kill");
            return false;
        }
        if file.exists() {
            child.kill().unwrap();
            child.wait().unwrap();
            return true;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}

/// Every file of a run folder (relative path, bytes), temp files included, history excluded.
fn folder_bytes(run: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for sub in ["", "segments"] {
        let mut names: Vec<_> = std::fs::read_dir(run.join(sub))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_file())
            .collect();
        names.sort();
        for p in names {
            let rel = p.strip_prefix(run).unwrap().display().to_string();
            out.push((rel, std::fs::read(&p).unwrap()));
        }
    }
    out
}

#[test]
fn a_run_killed_twice_resumes_to_the_bytes_of_an_uninterrupted_run() {
    let clip = Synth::new(Scenario::Walk, 320, 180, Some(200));
    let (c, j) = (clip.path("clip.mp4"), clip.path("joints.toml"));
    let whole = clip.path("a/run.mocap");
    let killed = clip.path("b/run.mocap");
    let track = |out: &Path| -> Vec<String> {
        [
            "track",
            s(&c),
            "--seeds",
            s(&j),
            "--out",
            s(out),
            "--segment-len",
            "20",
        ]
        .map(str::to_owned)
        .to_vec()
    };
    let args = track(&whole);
    assert_exit(
        &run_bin(&args.iter().map(String::as_str).collect::<Vec<_>>()),
        0,
        &[],
    );
    // Killed in segment 3 or so, then killed again while resuming, then resumed to the end.
    let args = track(&killed);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    assert!(
        kill_when(&args, &killed.join("segments/002.csv")),
        "track finished before the kill; lengthen the clip"
    );
    assert!(!killed.join("tracks.csv").exists());
    let manifest = std::fs::read_to_string(killed.join("run.toml")).unwrap();
    assert!(manifest.contains("complete = false"), "{manifest}");
    assert!(
        kill_when(&["resume", s(&killed)], &killed.join("segments/006.csv")),
        "resume finished before the kill; lengthen the clip"
    );
    let o = run_bin(&["resume", s(&killed)]);
    assert_exit(&o, 0, &["resumed"]);
    assert!(
        !killed.join("history").exists(),
        "an unfinished run has no tracks.csv to keep"
    );
    let (a, b) = (folder_bytes(&whole), folder_bytes(&killed));
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>(),
        "the same files"
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{name} differs from the uninterrupted run's");
    }
}

#[test]
fn resume_refuses_another_clip_or_other_parameters() {
    let a = Synth::new(Scenario::Walk, 320, 180, Some(30));
    let b = Synth::new(Scenario::Fast, 320, 180, Some(30));
    let run = a.path("run.mocap");
    let (c, j) = (a.path("clip.mp4"), a.path("joints.toml"));
    assert_exit(
        &run_bin(&[
            "track",
            s(&c),
            "--seeds",
            s(&j),
            "--out",
            s(&run),
            "--segment-len",
            "10",
        ]),
        0,
        &[],
    );
    let before = folder_bytes(&run);
    let o = run_bin(&["report", s(&run)]);
    assert_exit(&o, 0, &[]);
    assert_eq!(
        String::from_utf8_lossy(&o.stdout),
        std::fs::read_to_string(run.join("report.md")).unwrap()
    );
    // Segments 0 to 2 (frames 0-9, 10-19, 20-29), and 003.toml on the last frame.
    assert_exit(
        &run_bin(&["resume", s(&run), "--segment", "9"]),
        2,
        &["--segment 9", "3 segments"],
    );
    assert_exit(
        &run_bin(&["resume", s(&run), "--segment", "3"]),
        2,
        &["last frame", "--segment 2"],
    );
    let o = run_bin(&[
        "resume",
        s(&run),
        "--segment",
        "1",
        "--clip",
        s(&b.path("clip.mp4")),
    ]);
    assert_exit(&o, 2, &["run.toml", "another clip", "--clip"]);
    // The clip replaced where the run says it is.
    std::fs::copy(b.path("clip.mp4"), &c).unwrap();
    let o = run_bin(&["resume", s(&run), "--segment", "1"]);
    assert_exit(&o, 2, &["another clip", s(&c)]);
    let params = a.path("params.toml");
    std::fs::write(&params, "search_max_px = 10.0\n").unwrap();
    let o = run_bin(&["resume", s(&run), "--params", s(&params)]);
    assert_exit(&o, 2, &["other parameters", "search_max_px"]);
    assert!(
        folder_bytes(&run) == before,
        "a refused resume wrote nothing"
    );
    // A run folder from an earlier build, whose parameters lacked one this build has (and whose
    // config_blake3 was made without it): named, not "edited" (its manifest reads, with this
    // build's default in the gap).
    let manifest = run.join("run.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let older: String = text
        .lines()
        .filter(|l| !l.starts_with("length_anchor"))
        .map(|l| match l.starts_with("config_blake3") {
            true => format!("config_blake3 = \"{}\"\n", "0".repeat(64)),
            false => format!("{l}\n"),
        })
        .collect();
    assert_ne!(older, text);
    std::fs::write(&manifest, older).unwrap();
    let before = folder_bytes(&run);
    let o = run_bin(&["resume", s(&run), "--segment", "1"]);
    assert_exit(
        &o,
        2,
        &["run.toml", "earlier build", "length_anchor", "new folder"],
    );
    assert!(
        folder_bytes(&run) == before,
        "a refused resume wrote nothing"
    );
}

#[test]
fn an_edited_file_survives_a_resume_from_an_earlier_segment_and_a_new_track() {
    let clip = Synth::new(Scenario::Walk, 320, 180, Some(60));
    let run = clip.path("run.mocap");
    clip.track("run.mocap", 20);
    let tracks0 = std::fs::read_to_string(run.join("tracks.csv")).unwrap();
    // Nothing edited: nothing to do.
    assert!(resume_run(&run, None).is_none());
    // The user moves the pelvis on frame 40 (segment 2) by 2 px.
    let p2 = file_path(&run, 2);
    let text = std::fs::read_to_string(&p2).unwrap();
    let (seeds, _) = read_seeds(&p2).unwrap();
    let x = seeds.joints[0].bbox.cx;
    let edited = text.replacen(&format!("x = {x:.3}"), &format!("x = {:.3}", x + 2.0), 1);
    assert_ne!(edited, text);
    std::fs::write(&p2, &edited).unwrap();
    let kept = lines_before(&run, 20);
    resume_run(&run, Some(1)).unwrap();
    assert_eq!(
        std::fs::read_to_string(&p2).unwrap(),
        edited,
        "the correction was overwritten"
    );
    assert_eq!(lines_before(&run, 20), kept, "segment 0 changed");
    assert_eq!(
        std::fs::read_to_string(run.join("history/001-tracks.csv")).unwrap(),
        tracks0,
        "the previous tracks.csv is kept in history/"
    );
    let rows = read_tracks(&run.join("tracks.csv")).unwrap();
    let pelvis40 = rows
        .iter()
        .find(|r| r.frame == 40 && r.joint == "pelvis")
        .unwrap();
    assert!((pelvis40.x - (x + 2.0)).abs() < 1e-3, "{pelvis40:?}");
    assert_eq!(pelvis40.status, "seed");
    // Without --segment, resume finds nothing new; a new `track` refuses the folder.
    assert!(resume_run(&run, None).is_none());
    let o = run_bin(&[
        "track",
        s(&clip.path("clip.mp4")),
        "--seeds",
        s(&clip.path("joints.toml")),
        "--out",
        s(&run),
        "--segment-len",
        "20",
    ]);
    assert_exit(&o, 2, &["002.toml", "correction", "resume"]);
    assert_eq!(std::fs::read_to_string(&p2).unwrap(), edited);
}

#[test]
fn a_correction_fixes_the_segment_before_it_only_when_resumed_from_there() {
    let clip = Synth::new(Scenario::Walk, 320, 180, Some(60));
    let run = clip.path("run.mocap");
    clip.track("run.mocap", 20);
    clip.correct(&run, 2);
    // From segment 2: segment 1 stays as it was.
    let seg1 = lines_before(&run, 40);
    resume_run(&run, Some(2)).unwrap();
    assert_eq!(lines_before(&run, 40), seg1);
    // From segment 1: segment 1 is also tracked back from the correction on frame 40.
    resume_run(&run, Some(1)).unwrap();
    assert_eq!(lines_before(&run, 20), seg1[..1 + 20 * clip.gt[0].len()]);
    assert_ne!(
        lines_before(&run, 40),
        seg1,
        "the backward pass changed nothing"
    );
}

#[test]
fn segments_after_a_correction_go_on_from_it_and_resume_to_the_same_bytes() {
    // A correction in the middle: the segments after it start from files the tool wrote, so
    // they go on with the run's tracker, moved to the correction. Resuming from any of them (its
    // state read back from disk) repeats the run that went through in one go, byte for byte.
    let clip = Synth::new(Scenario::Walk, 320, 180, Some(60));
    let run = clip.path("run.mocap");
    clip.track("run.mocap", 15);
    clip.correct(&run, 1);
    resume_run(&run, Some(1)).unwrap();
    let whole = std::fs::read_to_string(run.join("tracks.csv")).unwrap();
    for k in [2, 3] {
        resume_run(&run, Some(k)).unwrap();
        assert_eq!(
            std::fs::read_to_string(run.join("tracks.csv")).unwrap(),
            whole,
            "resumed from segment {k}, after the correction of segment 1"
        );
    }
    let rows = read_tracks(&run.join("tracks.csv")).unwrap();
    assert!(rows
        .iter()
        .filter(|r| r.frame == 15)
        .all(|r| r.status == "seed"));
    assert!(rows
        .iter()
        .filter(|r| r.frame == 30)
        .all(|r| r.status != "seed"));
}

#[test]
fn uncorrected_segment_boundaries_track_as_one_tracker() {
    // A boundary the user did not correct hands the whole tracker state on, so segments change
    // nothing but gap filling: a joint hidden across a boundary is not interpolated over it.
    let clip = Synth::new(Scenario::Walk, 320, 180, Some(90));
    clip.track("one.mocap", 100_000);
    clip.track("seg.mocap", 15);
    let one = read_tracks(&clip.path("one.mocap/tracks.csv")).unwrap();
    let seg = read_tracks(&clip.path("seg.mocap/tracks.csv")).unwrap();
    assert_eq!(one.len(), seg.len());
    let mut hidden_differ = 0;
    for (a, b) in one.iter().zip(&seg) {
        if matches!(a.status.as_str(), "seed" | "ok" | "low") {
            assert_eq!(a, b, "a seen joint-frame differs with segments of 15");
        } else if a != b {
            hidden_differ += 1;
        }
    }
    assert!(
        (hidden_differ as f32) < 0.1 * one.len() as f32,
        "{hidden_differ} of {} hidden joint-frames differ",
        one.len()
    );
    assert!(clip.path("seg.mocap/segments/001.state").exists());
    assert!(!clip.path("one.mocap/segments/001.state").exists());
}

#[test]
fn a_missing_or_changed_state_file_is_named_and_rebuilt_from_an_earlier_segment() {
    let clip = Synth::new(Scenario::Walk, 320, 180, Some(40));
    let run = clip.path("run.mocap");
    clip.track("run.mocap", 10);
    let before = folder_bytes(&run);
    let state = run.join("segments/002.state");
    std::fs::remove_file(&state).unwrap();
    let without: Vec<_> = before
        .iter()
        .filter(|(n, _)| !n.ends_with("002.state"))
        .cloned()
        .collect();
    let o = run_bin(&["resume", s(&run), "--segment", "2"]);
    assert_exit(&o, 2, &["002.state", "is missing", "--segment 0"]);
    assert!(
        folder_bytes(&run) == without,
        "a refused resume wrote nothing"
    );
    std::fs::write(&state, b"mocap2d tracker state 2\nnot a state").unwrap();
    let o = run_bin(&["resume", s(&run), "--segment", "2"]);
    assert_exit(&o, 2, &["002.state", "changed"]);
    assert!(!run.join("history").exists(), "nothing was archived");
    // A state of an older layout, recorded as written (a run folder of an older mocap2d).
    let original = &before
        .iter()
        .find(|(n, _)| n.ends_with("002.state"))
        .unwrap()
        .1;
    let older = [
        b"mocap2d tracker state 2\n",
        &original[original.iter().position(|&b| b == b'\n').unwrap() + 1..],
    ]
    .concat();
    std::fs::write(&state, &older).unwrap();
    let toml = std::fs::read_to_string(run.join("run.toml")).unwrap();
    let toml = toml.replace(
        &mocap2d::run::segments::hash_bytes(original),
        &mocap2d::run::segments::hash_bytes(&older),
    );
    std::fs::write(run.join("run.toml"), toml).unwrap();
    let o = run_bin(&["resume", s(&run), "--segment", "2"]);
    assert_exit(&o, 2, &["002.state", "another version", "--segment 0"]);
    assert!(!run.join("history").exists(), "nothing was archived");
    // Resuming from the segment before rebuilds it: the folder is as track left it.
    let o = run_bin(&["resume", s(&run), "--segment", "1"]);
    assert_exit(&o, 0, &["resumed"]);
    let after: Vec<_> = folder_bytes(&run)
        .into_iter()
        .filter(|(n, _)| n != "run.toml")
        .collect();
    let before: Vec<_> = before
        .into_iter()
        .filter(|(n, _)| n != "run.toml")
        .collect();
    assert!(after == before, "resume rebuilt what track wrote");
}
