//! Segments, the correction report and `resume`, on synthetic clips with ground truth: the
//! report flags where the tracks are far off, corrections written into the flagged segment
//! files lift the accuracy (all of them, or only the worst segment's, past which tracking goes
//! on), frames before a correction stay byte for byte, corrections are
//! never overwritten, a run killed mid-clip resumes to the very bytes of an uninterrupted run,
//! and a run folder refuses another clip.
#![cfg(feature = "ffmpeg")]

use crate::common::{bin, run as run_bin, s, write_synth};
use mocap2d::app::{resume, track, ResumeOptions, TrackOptions, TrackSummary};
use mocap2d::progress::NoProgress;
use mocap2d::run::segments::{file_path, Plan};
use mocap2d::run::tracks::read_tracks;
use mocap2d::seed::{read_seeds, to_toml};
use mocap2d::synth::Scenario;
use std::path::{Path, PathBuf};
use std::process::Output;

/// A rendered synth clip on disk (clip.mp4, joints.toml, gt.csv) with its ground truth.
struct Synth {
    dir: tempfile::TempDir,
    gt: Vec<Vec<(f32, f32)>>,
    size: (u32, u32),
}

impl Synth {
    fn new(scenario: Scenario, width: u32, height: u32, frames: Option<u32>) -> Synth {
        Synth::seeded(scenario, width, height, frames, 1)
    }

    /// [`Synth::new`] rendered with another random `seed` (motion, colours, textures).
    fn seeded(
        scenario: Scenario,
        width: u32,
        height: u32,
        frames: Option<u32>,
        seed: u64,
    ) -> Synth {
        let dir = tempfile::tempdir().unwrap();
        let clip = write_synth(dir.path(), scenario, width, height, seed, frames);
        Synth {
            dir,
            gt: clip.gt,
            size: (width, height),
        }
    }

    fn path(&self, rel: &str) -> PathBuf {
        self.dir.path().join(rel)
    }

    /// Tracks the clip into `out` with segments of `len` frames.
    fn track(&self, out: &str, len: u64) -> TrackSummary {
        let opts = TrackOptions {
            out: Some(self.path(out)),
            segment_len: len,
            ..TrackOptions::new(self.path("clip.mp4"), self.path("joints.toml"))
        };
        track(&opts, &NoProgress).unwrap()
    }

    /// Per joint-frame errors (frame, px) of a run's `tracks.csv`.
    fn errors(&self, run: &Path) -> Vec<(u64, f32)> {
        read_tracks(&run.join("tracks.csv"))
            .unwrap()
            .chunks(self.gt[0].len())
            .flat_map(|rows| {
                rows.iter().enumerate().map(|(j, r)| {
                    let (x, y) = self.gt[r.frame as usize][j];
                    (r.frame, (r.x - x).hypot(r.y - y))
                })
            })
            .collect()
    }

    /// PCK@5 (0–1) of a run.
    fn pck5(&self, run: &Path) -> f32 {
        self.pck5_from(run, 0)
    }

    /// PCK@5 (0–1) of a run over the frames from `from` on.
    fn pck5_from(&self, run: &Path, from: u64) -> f32 {
        let e: Vec<f32> = self
            .errors(run)
            .into_iter()
            .filter(|(f, _)| *f >= from)
            .map(|(_, d)| d)
            .collect();
        e.iter().filter(|d| **d <= 5.0).count() as f32 / e.len() as f32
    }

    /// Corrects segment `k`'s file and the next one's (what the report asks for segment `k`)
    /// and resumes from where they start. Returns PCK@5 from segment `k`'s first frame `from`
    /// on, before and after.
    fn correct_segment(&self, run: &Path, k: u64, from: u64) -> (f32, f32) {
        let before = self.pck5_from(run, from);
        self.correct(run, k);
        self.correct(run, k + 1);
        resume_run(run, None).unwrap();
        let after = self.pck5_from(run, from);
        println!(
            "segment {k} and the next corrected: PCK@5 from frame {from} {:.1} -> {:.1} %",
            100.0 * before,
            100.0 * after
        );
        (before, after)
    }

    /// Writes the ground truth into segment `k`'s file (a correction, as a user would make).
    fn correct(&self, run: &Path, k: u64) {
        let p = file_path(run, k);
        let (mut seeds, _) = read_seeds(&p).unwrap();
        let (w, h) = self.size;
        for (j, joint) in seeds.joints.iter_mut().enumerate() {
            let (x, y) = self.gt[seeds.frame as usize][j];
            let b = &mut joint.bbox;
            let half = |s: u32| s as f32 / 2.0 - 0.5;
            b.cx = x.clamp(half(b.w), w as f32 - 1.0 - half(b.w));
            b.cy = y.clamp(half(b.h), h as f32 - 1.0 - half(b.h));
        }
        let text = to_toml(seeds.frame, &seeds.joints, "corrected to the ground truth");
        std::fs::write(&p, text).unwrap();
    }
}

/// `resume RUN [--segment K]` through the library.
fn resume_run(run: &Path, segment: Option<u64>) -> Option<TrackSummary> {
    let opts = ResumeOptions {
        run: run.to_owned(),
        segment,
        ..Default::default()
    };
    resume(&opts, &NoProgress).unwrap()
}

/// The lines of a run's `tracks.csv` for frames before `frame` (header included).
fn lines_before(run: &Path, frame: u64) -> Vec<String> {
    std::fs::read_to_string(run.join("tracks.csv"))
        .unwrap()
        .lines()
        .filter(|l| {
            l.split(',')
                .next()
                .and_then(|f| f.parse::<u64>().ok())
                .is_none_or(|f| f < frame)
        })
        .map(str::to_owned)
        .collect()
}

/// Of the joint-frames more than 10 px off: how many there are, the share in flagged segments,
/// and the share the report lists (the joint, within its frame range, in a flagged segment).
fn far_recall(s: &Synth, run: &Path, plan: &Plan, flagged: &[u64]) -> (usize, f32, f32) {
    let report = mocap2d::app::report(run, mocap2d::run::report::SUGGESTED).unwrap();
    let names: Vec<String> = read_seeds(&run.join("seeds.toml"))
        .unwrap()
        .0
        .joints
        .into_iter()
        .map(|j| j.name)
        .collect();
    let nj = names.len();
    let far: Vec<(u64, usize)> = s
        .errors(run)
        .into_iter()
        .enumerate()
        .filter(|(_, (_, d))| *d > 10.0)
        .map(|(i, (f, _))| (f, i % nj))
        .collect();
    let in_segment = far
        .iter()
        .filter(|(f, _)| flagged.contains(&plan.segment_of(*f)))
        .count();
    let listed = far
        .iter()
        .filter(|(f, j)| {
            report.ranked().iter().any(|seg| {
                seg.joints
                    .iter()
                    .any(|d| d.joint == names[*j] && (d.first..=d.last).contains(f))
            })
        })
        .count();
    let share = |n: usize| n as f32 / far.len().max(1) as f32;
    (far.len(), share(in_segment), share(listed))
}

/// Tracks `s` in segments of `len`, checks the report's recall, corrects every flagged segment
/// with the ground truth and resumes from the first. Returns PCK@5 before and after.
fn correct_flagged(s: &Synth, len: u64) -> (f32, f32) {
    let run = s.path("run");
    let first = s.track("run", len);
    let before = s.pck5(&run);
    let plan = Plan { seed_frame: 0, len };
    let (far, recall, listed) = far_recall(s, &run, &plan, &first.flagged);
    println!(
        "PCK@5 {:.1} %; flagged {:?} of {} segments; {far} joint-frames > 10 px, {:.1} % in \
         them, {:.1} % listed",
        100.0 * before,
        first.flagged,
        first.segments,
        100.0 * recall,
        100.0 * listed
    );
    assert!(recall >= 0.9, "recall {recall}");
    assert!(listed >= 0.9, "listed {listed}");
    // The files the report says to correct: each flagged segment's and the next one's.
    let files = first.to_correct.clone();
    let Some(&k0) = files.first() else {
        return (before, before);
    };
    let kept = lines_before(&run, plan.first_frame(k0));
    for &k in &files {
        s.correct(&run, k);
    }
    let second = resume_run(&run, Some(k0)).unwrap();
    let after = s.pck5(&run);
    println!(
        "corrected {files:?}, resumed from {k0}: PCK@5 {:.1} %; now flagged {:?}",
        100.0 * after,
        second.flagged
    );
    assert_eq!(
        kept,
        lines_before(&run, plan.first_frame(k0)),
        "frames before the first corrected segment changed"
    );
    assert!(run.join("history/001-tracks.csv").is_file());
    (before, after)
}

/// `redetect_toward_keys = false` changes only the passes run toward a key of every joint: a
/// plain track is the default's to the byte, and a resume after correcting every segment file
/// of the turning clip is not (the whole-frame search finds a turned body between two keys).
#[test]
fn redetect_toward_keys_off_changes_only_the_passes_toward_keys() {
    let s = Synth::seeded(Scenario::Long, 320, 180, Some(240), 1);
    let off = mocap2d::track::TrackParams {
        redetect_toward_keys: false,
        ..Default::default()
    };
    let run_with = |out: &str, params: &mocap2d::track::TrackParams| {
        let opts = TrackOptions {
            out: Some(s.path(out)),
            segment_len: 40,
            params: params.clone(),
            ..TrackOptions::new(s.path("clip.mp4"), s.path("joints.toml"))
        };
        track(&opts, &NoProgress).unwrap().segments
    };
    let csv = |out: &str| std::fs::read(s.path(out).join("tracks.csv")).unwrap();
    let segments = run_with("default", &Default::default());
    assert_eq!(run_with("off", &off), segments);
    assert_eq!(csv("default"), csv("off"), "no key: the same tracks");
    for (out, params) in [("default", None), ("off", Some(off.clone()))] {
        for k in 0..segments {
            s.correct(&s.path(out), k);
        }
        let opts = ResumeOptions {
            run: s.path(out),
            segment: Some(0),
            params,
            ..Default::default()
        };
        resume(&opts, &NoProgress).unwrap();
    }
    let (with, without) = (s.pck5(&s.path("default")), s.pck5(&s.path("off")));
    println!("corrected every segment file: PCK@5 {with} by default, {without} without");
    // Measured: 98.2 % by default, 97.7 % without.
    assert_ne!(csv("default"), csv("off"), "toward keys: other tracks");
}

/// The report's recall where the tracker does well: occlusions, segments of 30 frames.
#[test]
fn the_report_flags_where_the_tracks_are_far_off() {
    let s = Synth::new(Scenario::Occlude, 640, 360, None);
    let first = s.track("run", 30);
    let plan = Plan {
        seed_frame: 0,
        len: 30,
    };
    let (far, recall, listed) = far_recall(&s, &s.path("run"), &plan, &first.flagged);
    println!(
        "{far} far off; {recall} in flagged segments {:?}, {listed} listed",
        first.flagged
    );
    assert!(far > 0, "nothing to find; pick a harder clip");
    assert!(recall >= 0.9 && listed >= 0.9);
}

/// A short mixed clip (walk, turn, walk back), segments of 40 frames, seeds 1-5 (one seed
/// swings by a point either way on any change to the tracker).
#[test]
fn corrections_of_flagged_segments_lift_accuracy() {
    let mut sum = 0.0;
    for seed in 1..=5 {
        let s = Synth::seeded(Scenario::Long, 320, 180, Some(240), seed);
        let (before, after) = correct_flagged(&s, 40);
        println!("seed {seed}: PCK@5 {before} -> {after}");
        // Never worse by more than a few joint-frames (seed 1: 6 of 3360).
        assert!(
            after >= before - 0.002,
            "seed {seed}: PCK@5 {before} -> {after}"
        );
        assert!(after >= 0.955, "seed {seed}: PCK@5 {before} -> {after}");
        sum += after;
    }
    // Measured with re-detection judged by the whole body: 97.4 -> 97.2, 97.3 -> 98.3,
    // 94.0 -> 98.8, 97.2 -> 98.0, 97.8 -> 98.0 %, mean 98.1 %. Earlier figures: docs/NOTES.md.
    assert!(sum / 5.0 >= 0.975, "mean PCK@5 {}", sum / 5.0);
}

/// What a user does first: correct only the worst flagged segment (its file and the next one,
/// as the report says) and resume. Tracking goes on past the corrections, and the frames from
/// the correction on must come out better than they were tracked, over seeds 1-5: on one clip
/// a correction can lead a later stretch astray where the uncorrected run happened to hold.
/// 360 frames of `long` (walk, turn, walk back, start waving), so that the worst segment has
/// something to fix: the first 240 frames are tracked at 95-97.5 %.
#[test]
fn correcting_only_the_worst_segment_makes_the_rest_better() {
    let len = 40;
    let (mut before_sum, mut after_sum) = (0.0, 0.0);
    for seed in 1..=5 {
        let s = Synth::seeded(Scenario::Long, 320, 180, Some(360), seed);
        let run = s.path("run");
        let first = s.track("run", len);
        // The worst flagged segment with at least two after it, so that tracking goes on past
        // the corrected files.
        let k = *first
            .flagged
            .iter()
            .find(|&&k| k + 2 < first.segments)
            .unwrap();
        let (before, after) = s.correct_segment(&run, k, k * len);
        assert!(after >= 0.95, "seed {seed}: {before} -> {after}");
        before_sum += before;
        after_sum += after;
    }
    // Measured (360 frames; segment 4, the turn, is the worst in all five): 96.7 -> 98.3, 95.5
    // -> 97.0, 95.8 -> 99.1, 95.3 -> 95.5, 93.3 -> 97.2 %; means 95.3 -> 97.4 %. Earlier
    // figures: docs/NOTES.md.
    assert!(
        after_sum >= before_sum + 0.05,
        "mean PCK@5 {} -> {}",
        before_sum / 5.0,
        after_sum / 5.0
    );
}

/// The same on `long` at 640×360 in segments of 150.
#[test]
#[ignore = "long clip: run with cargo test --release --test it segments:: -- --ignored"]
fn correcting_only_the_first_ranked_segment_of_the_long_clip_makes_it_better() {
    let s = Synth::new(Scenario::Long, 640, 360, None);
    let run = s.path("run");
    let first = s.track("run", 150);
    let (before, after) = s.correct_segment(&run, first.flagged[0], 0);
    // Measured: 92.9 -> 93.2 % (segment 3). Earlier figures (95.6 % before the bounded search
    // and Lucas–Kanade between keys): docs/NOTES.md.
    assert!(after > before && after >= 0.93, "{before} -> {after}");
}

/// The acceptance test of correcting: 900 frames at 640×360, segments of 150.
#[test]
#[ignore = "long clip: run with cargo test --release --test it segments:: -- --ignored"]
fn corrections_of_flagged_segments_lift_the_long_clip() {
    let s = Synth::new(Scenario::Long, 640, 360, None);
    let (before, after) = correct_flagged(&s, 150);
    // Measured: 92.9 % -> 96.3 % (every segment flagged, all seven files corrected). Earlier
    // figures (98.2 % before the bounded search and Lucas–Kanade between keys): docs/NOTES.md.
    assert!(after >= 0.96, "PCK@5 {before} -> {after}");
}

fn assert_exit(o: &Output, code: i32, needles: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(code), "stderr:\n{err}");
    for n in needles {
        assert!(err.contains(n), "stderr lacks {n:?}:\n{err}");
    }
}

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

/// A key on any frame (`keys.toml`), for some joints only: after `resume`, those joints sit on
/// the key on its frame (status `seed`), the frames before it in its segment are pulled toward
/// it (they end nearer the truth when the key is the truth), the frames before its segment
/// stay byte for byte, a resume repeats the same bytes, and a key naming no joint of the run
/// is refused with exit 2 naming the file, line and joint.
#[test]
fn a_key_on_any_frame_pulls_the_frames_around_it() {
    let clip = Synth::new(Scenario::Fast, 320, 180, Some(90));
    let run = clip.path("run");
    clip.track("run", 30);
    let before = std::fs::read_to_string(run.join("tracks.csv")).unwrap();
    let names: Vec<String> = read_seeds(&clip.path("joints.toml"))
        .unwrap()
        .0
        .joints
        .iter()
        .map(|j| j.name.clone())
        .collect();
    // Keys inside segment 1 (frames 30-59), eight frames apart, the second where the tracker
    // has drifted most (a joint's error sustained over the four frames up to it), for the
    // three joints that drifted most there: the ground truth, as a user clicking the right
    // place would give.
    let err_at = |f: u64| -> Vec<f32> {
        let rows = read_tracks(&run.join("tracks.csv")).unwrap();
        rows.iter()
            .filter(|r| r.frame == f)
            .enumerate()
            .map(|(j, r)| (r.x - clip.gt[f as usize][j].0).hypot(r.y - clip.gt[f as usize][j].1))
            .collect()
    };
    let errs: Vec<Vec<f32>> = (0..60).map(err_at).collect();
    let sustained = |f: u64, j: usize| {
        (f - 3..=f)
            .map(|g| errs[g as usize][j])
            .fold(f32::MAX, f32::min)
    };
    let drift = |f: u64| {
        (0..names.len())
            .map(|j| sustained(f, j))
            .fold(0.0f32, f32::max)
    };
    let b = (40..=58u64)
        .max_by(|x, y| drift(*x).total_cmp(&drift(*y)))
        .unwrap();
    let a = b - 8;
    let mut worst: Vec<usize> = (0..names.len()).collect();
    worst.sort_by(|x, y| sustained(b, *y).total_cmp(&sustained(b, *x)));
    let keyed = &worst[..3];
    let mut text = String::new();
    for f in [a, b] {
        text.push_str(&format!("[[key]]\nframe = {f}\n"));
        for &j in keyed {
            let (x, y) = clip.gt[f as usize][j];
            text.push_str(&format!("{} = [{x}, {y}]\n", names[j]));
        }
    }
    std::fs::write(run.join("keys.toml"), &text).unwrap();
    let far_before: f32 = (a + 1..b)
        .map(|f| keyed.iter().map(|&j| err_at(f)[j]).sum::<f32>())
        .sum();
    resume_run(&run, Some(1)).unwrap();
    let rows = read_tracks(&run.join("tracks.csv")).unwrap();
    for &j in keyed {
        let r = rows
            .iter()
            .find(|r| r.frame == b && r.joint == names[j])
            .unwrap();
        let (x, y) = clip.gt[b as usize][j];
        assert!(
            (r.x - x).abs() < 1e-3 && (r.y - y).abs() < 1e-3,
            "{}: {r:?}",
            names[j]
        );
        assert_eq!(r.status, "seed");
    }
    let far_after: f32 = (a + 1..b)
        .map(|f| keyed.iter().map(|&j| err_at(f)[j]).sum::<f32>())
        .sum();
    println!(
        "keys on frames {a} and {b}: keyed joints' error summed over the frames between \
         {far_before:.1} -> {far_after:.1} px"
    );
    // Measured: keys on frames 40 and 48 (wrist, knee, chest), 25.2 -> 24.4 px. The wrist's
    // drift (3.0 px on frame 44) is halved; the knee, right on both keys and 2 px off between
    // them, is not helped: keys pull toward themselves, not toward what lies between.
    assert!(far_after < far_before, "{far_before} -> {far_after}");
    let keep = |t: &str| -> Vec<String> {
        t.lines()
            .take(1 + 30 * names.len())
            .map(str::to_owned)
            .collect()
    };
    let after = std::fs::read_to_string(run.join("tracks.csv")).unwrap();
    assert_eq!(
        keep(&before),
        keep(&after),
        "frames before segment 1 changed"
    );
    resume_run(&run, Some(1)).unwrap();
    assert_eq!(
        after,
        std::fs::read_to_string(run.join("tracks.csv")).unwrap()
    );

    std::fs::write(
        run.join("keys.toml"),
        "[[key]]\nframe = 40\nelbow_x = [10, 10]\n",
    )
    .unwrap();
    let o = run_bin(&["resume", s(&run), "--segment", "1", "-q"]);
    assert_exit(
        &o,
        2,
        &[
            "keys.toml",
            "line 3",
            "elbow_x",
            "no such joint",
            "seed file",
        ],
    );
}

/// The x of `joint` on `frame` in a run's `tracks.csv`.
fn x_at(run: &Path, frame: u64, joint: &str) -> f32 {
    let rows = read_tracks(&run.join("tracks.csv")).unwrap();
    rows.iter()
        .find(|r| r.frame == frame && r.joint == joint)
        .unwrap()
        .x
}

/// Tracks the walk in segments of `len` frames, keys a wrist where the tool had it on frame 15
/// and 12 px right of that on frame 25, and a knee 3 px right of where the tool had it on each
/// frame of `knee_on`; resumes from segment 0. Returns the run, the wrist's name and how far it
/// moved right on frames 0–29 (px).
fn wrist_pulled(clip: &Synth, len: u64, knee_on: &[u64]) -> (PathBuf, String, Vec<f32>) {
    let run = clip.path("run");
    clip.track("run", len);
    let (seeds, _) = read_seeds(&clip.path("joints.toml")).unwrap();
    let name = |part: &str| {
        let j = seeds.joints.iter().find(|j| j.name.contains(part));
        j.unwrap().name.clone()
    };
    let (wrist, knee) = (name("wrist"), name("knee"));
    let row = |f: u64, j: &str| {
        let rows = read_tracks(&run.join("tracks.csv")).unwrap();
        let r = rows.into_iter().find(|r| r.frame == f && r.joint == j);
        r.map(|r| (r.x, r.y)).unwrap()
    };
    let before: Vec<f32> = (0..30).map(|f| x_at(&run, f, &wrist)).collect();
    let mut keys: Vec<(u64, String)> = [(15, 0.0), (25, 12.0)]
        .map(|(f, dx)| {
            let (x, y) = row(f, &wrist);
            (f, format!("{wrist} = [{}, {y}]\n", x + dx))
        })
        .to_vec();
    for &f in knee_on {
        let (x, y) = row(f, &knee);
        keys.push((f, format!("{knee} = [{}, {y}]\n", x + 3.0)));
    }
    keys.sort();
    let text: String = keys
        .iter()
        .map(|(f, line)| format!("[[key]]\nframe = {f}\n{line}\n"))
        .collect();
    std::fs::write(run.join("keys.toml"), text).unwrap();
    resume_run(&run, Some(0)).unwrap();
    let shifts = (0..30)
        .map(|f| x_at(&run, f, &wrist) - before[f as usize])
        .collect();
    (run, wrist, shifts)
}

/// A span between keys that crosses a segment's end is solved through both keys: a key on
/// frame 25 (segment 1 of 20-frame segments) that moves a wrist 12 px right of where the tool
/// had it pulls the wrist on frames 20–24 and on segment 0's last frames toward it, when the
/// key before it is on frame 15; segment 1's file holds the row solved on its first frame, and
/// resuming from segment 1 repeats the same bytes.
#[test]
fn a_key_past_a_segments_end_pulls_the_frames_before_that_end() {
    let clip = Synth::new(Scenario::Walk, 320, 180, Some(60));
    let (run, j, shift) = wrist_pulled(&clip, 20, &[]);
    println!(
        "{j}: moved right on frames 15-25 by {:.1?} px",
        &shift[15..=25]
    );
    assert!(shift[15].abs() < 1e-3 && (shift[25] - 12.0).abs() < 1e-3);
    // Segment 0's last frame is pulled toward the key in segment 1, as is segment 1's first.
    assert!(shift[19] > 2.0, "frame 19 moved {:.2} px", shift[19]);
    assert!(shift[20] > 2.5, "frame 20 moved {:.2} px", shift[20]);
    assert!(shift[16] < shift[24], "{shift:?}");
    let (file, _) = read_seeds(&file_path(&run, 1)).unwrap();
    let in_file = file.joints.iter().find(|x| x.name == j).unwrap().bbox.cx;
    assert!(
        (in_file - x_at(&run, 20, &j)).abs() < 0.01,
        "{in_file} in segments/001.toml"
    );
    let whole = std::fs::read(run.join("tracks.csv")).unwrap();
    resume_run(&run, Some(1)).unwrap();
    assert!(
        whole == std::fs::read(run.join("tracks.csv")).unwrap(),
        "resuming from segment 1 changed tracks.csv"
    );
}

/// A key that gives other joints only is no end of a joint's span: keys of a knee on frames 18
/// and 21, between the wrist's keys on 15 and 25, leave the wrist pulled toward its key on 25
/// from frame 16 on, as without them (keys of some joints, as `serve` saves them).
#[test]
fn a_key_of_other_joints_does_not_cut_a_joints_span() {
    let clip = Synth::new(Scenario::Walk, 320, 180, Some(40));
    let (_, j, alone) = wrist_pulled(&clip, 100, &[]);
    let clip = Synth::new(Scenario::Walk, 320, 180, Some(40));
    let (_, _, cut) = wrist_pulled(&clip, 100, &[18, 21]);
    println!(
        "{j}: moved right on frames 15-25 by {:.1?} px, with the knee keyed on 18 and 21 {:.1?}",
        &alone[15..=25],
        &cut[15..=25]
    );
    assert!(cut[17] > 2.0 && cut[20] > 2.0, "{cut:?}");
    for f in 16..25 {
        assert!(
            (cut[f] - alone[f]).abs() < 1.5,
            "frame {f}: {cut:?} against {alone:?}"
        );
    }
}
