//! Segments and the correction report, on synthetic clips with ground truth: the report flags
//! where the tracks are far off, and corrections written into the flagged segment files lift the
//! accuracy (all of them, or only the worst segment's, past which tracking goes on), frames
//! before a correction staying byte for byte; turning `redetect_toward_keys` off changes only
//! the passes toward keys. The helpers here (the rendered clip [`Synth`], [`resume_run`],
//! [`lines_before`], [`assert_exit`]) serve `segments_resume` and `segments_keys` too.
#![cfg(feature = "ffmpeg")]

use crate::common::write_synth;
use mocap2d::app::{resume, track, ResumeOptions, TrackOptions, TrackSummary};
use mocap2d::progress::NoProgress;
use mocap2d::run::segments::{file_path, Plan};
use mocap2d::run::tracks::read_tracks;
use mocap2d::seed::{read_seeds, to_toml};
use mocap2d::synth::Scenario;
use std::path::{Path, PathBuf};
use std::process::Output;

/// A rendered synth clip on disk (clip.mp4, joints.toml, gt.csv) with its ground truth.
pub(crate) struct Synth {
    dir: tempfile::TempDir,
    pub(crate) gt: Vec<Vec<(f32, f32)>>,
    size: (u32, u32),
}

impl Synth {
    pub(crate) fn new(scenario: Scenario, width: u32, height: u32, frames: Option<u32>) -> Synth {
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

    pub(crate) fn path(&self, rel: &str) -> PathBuf {
        self.dir.path().join(rel)
    }

    /// Tracks the clip into `out` with segments of `len` frames.
    pub(crate) fn track(&self, out: &str, len: u64) -> TrackSummary {
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
    pub(crate) fn correct(&self, run: &Path, k: u64) {
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
pub(crate) fn resume_run(run: &Path, segment: Option<u64>) -> Option<TrackSummary> {
    let opts = ResumeOptions {
        run: run.to_owned(),
        segment,
        ..Default::default()
    };
    resume(&opts, &NoProgress).unwrap()
}

/// The lines of a run's `tracks.csv` for frames before `frame` (header included).
pub(crate) fn lines_before(run: &Path, frame: u64) -> Vec<String> {
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

pub(crate) fn assert_exit(o: &Output, code: i32, needles: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(code), "stderr:\n{err}");
    for n in needles {
        assert!(err.contains(n), "stderr lacks {n:?}:\n{err}");
    }
}
