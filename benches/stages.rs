//! Criterion benches of the hot stages of `mocap2d track`, over frame sizes, on the path the
//! CLI runs:
//!
//! - `decode`: the clip read as `track` reads it, `decode::open_beside_tracking` on a reader
//!   thread (`decode::spawn_reader`), every frame to RGB;
//! - `background`: the plate as `track` makes it (`app::median_background`: sampled frames,
//!   temporal median, resting subjects cleared), `Background::fit` alone on frames in memory,
//!   and the foreground mask of one frame (`Background::is_foreground` at every pixel, as
//!   `guide` draws it);
//! - `tracker_step`: `track::Tracker::step`, the per-frame step of the CLI's tracking loop
//!   (`app/segmented.rs`, `Session`), from a tracker built on frame 0 with the clip's plate;
//! - `flow`: the Lucas–Kanade of keyed tracking (`track::flow`): a frame's grey pyramid, and
//!   every joint followed forward and back to the next frame (`track_checked`);
//! - `track`: `app::track` end to end on a tiny clip (decode thread, background, tracker, run
//!   folder).
//!
//! Inputs are synthetic walks (`mocap2d::synth`) at 320×180, 640×360 and 1280×720, written to a
//! temp dir as `synth` writes them (an H.264 `clip.mp4` with the `ffmpeg` feature, PNG frames
//! without) and decoded back, so the tracker sees what it sees in a run.
//!
//!     cargo bench --bench stages                # every group, a few minutes
//!     cargo bench --bench stages -- --quick     # a rougher figure, faster
//!     cargo bench --bench stages -- tracker_step/640x360
//!
//! `scripts/bench` is the other measure: frames/s of the release binary on 300-frame clips,
//! against FFmpeg, with peak RSS.

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion, Throughput};
use image::RgbImage;
use mocap2d::app::{self, TrackOptions};
use mocap2d::background::Background;
use mocap2d::decode;
use mocap2d::progress::NoProgress;
use mocap2d::run::keyed::KeyedParams;
use mocap2d::seed::{read_seeds, Seeds};
use mocap2d::synth::{self, Scenario, SynthOptions};
use mocap2d::track::flow::{track_checked, GreyPyramid};
use mocap2d::track::{TrackParams, Tracker};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Duration;

/// The frame sizes every stage is measured at.
const SIZES: [(u32, u32); 3] = [(320, 180), (640, 360), (1280, 720)];

/// Frames of each clip.
const FRAMES: u32 = 24;

/// Tracker steps timed per iteration (frames 1..=STEPS, from a tracker built on frame 0).
const STEPS: usize = 6;

/// Pyramid levels of keyed tracking's Lucas–Kanade (`KEYED_LEVELS` in `app/segmented.rs`).
const FLOW_LEVELS: usize = 5;

/// A synthetic walk on disk and decoded back.
struct Clip {
    width: u32,
    height: u32,
    /// Holds the clip; removed when dropped.
    _dir: tempfile::TempDir,
    /// `clip.mp4`, or the folder of PNG frames without the `ffmpeg` feature.
    path: PathBuf,
    seeds_path: PathBuf,
    seeds: Seeds,
    /// Every frame, as decoded from `path`.
    frames: Vec<RgbImage>,
}

impl Clip {
    fn new((width, height): (u32, u32)) -> Clip {
        let dir = tempfile::tempdir().unwrap();
        let clip = synth::render(&SynthOptions {
            scenario: Scenario::Walk,
            width,
            height,
            seed: 1,
            frames: Some(FRAMES),
        });
        synth::write_clip(&clip, dir.path()).unwrap();
        drop(clip);
        let path = if cfg!(feature = "ffmpeg") {
            dir.path().join("clip.mp4")
        } else {
            dir.path().join("clip")
        };
        let seeds_path = dir.path().join("joints.toml");
        let (seeds, _) = read_seeds(&seeds_path).unwrap();
        let mut source = decode::open(&path, None).unwrap();
        let mut frames = Vec::new();
        while let Some(f) = source.next_frame().unwrap() {
            frames.push(f);
        }
        assert_eq!(frames.len(), FRAMES as usize);
        Clip {
            width,
            height,
            _dir: dir,
            path,
            seeds_path,
            seeds,
            frames,
        }
    }

    /// `WxH`, the benchmark's parameter.
    fn size(&self) -> String {
        format!("{}x{}", self.width, self.height)
    }

    /// The plate `track` makes of this clip.
    fn background(&self) -> Background {
        mocap2d::background::median_background(&self.path, None, Some(&self.seeds))
            .unwrap()
            .0
    }
}

/// The clips at every size, rendered once.
fn clips() -> &'static [Clip] {
    static CLIPS: std::sync::OnceLock<Vec<Clip>> = std::sync::OnceLock::new();
    CLIPS.get_or_init(|| SIZES.into_iter().map(Clip::new).collect())
}

fn decode(c: &mut Criterion) {
    let mut g = c.benchmark_group("decode");
    for clip in clips() {
        g.throughput(Throughput::Elements(clip.frames.len() as u64));
        g.bench_with_input(BenchmarkId::from_parameter(clip.size()), clip, |b, clip| {
            b.iter(|| {
                let source = decode::open_beside_tracking(&clip.path, None).unwrap();
                let mut n = 0;
                for item in decode::spawn_reader(source, 8) {
                    black_box(item.unwrap());
                    n += 1;
                }
                assert_eq!(n, clip.frames.len());
            })
        });
    }
    g.finish();
}

fn background(c: &mut Criterion) {
    let mut g = c.benchmark_group("background");
    for clip in clips() {
        let size = clip.size();
        g.throughput(Throughput::Elements(clip.frames.len() as u64));
        g.bench_with_input(
            BenchmarkId::new("median_background", &size),
            clip,
            |b, clip| b.iter(|| black_box(clip.background())),
        );
        g.bench_with_input(BenchmarkId::new("fit", &size), clip, |b, clip| {
            b.iter(|| black_box(Background::fit(&clip.frames).unwrap()))
        });
        let bg = clip.background();
        let frame = &clip.frames[FRAMES as usize / 2];
        g.throughput(Throughput::Elements(1));
        g.bench_with_input(BenchmarkId::new("mask", &size), frame, |b, frame| {
            b.iter(|| {
                let mut n = 0u32;
                for y in 0..frame.height() {
                    for x in 0..frame.width() {
                        n += bg.is_foreground(frame, x, y) as u32;
                    }
                }
                black_box(n)
            })
        });
    }
    g.finish();
}

fn tracker_step(c: &mut Criterion) {
    let mut g = c.benchmark_group("tracker_step");
    g.throughput(Throughput::Elements(STEPS as u64));
    for clip in clips() {
        // Built as the run's first segment builds it (`Session`: its seed frame, the plate, the
        // default parameters, the working resolution of the seed file), afresh for every
        // iteration and untimed, so each times the same steps.
        let bg = clip.background();
        let build = || {
            Tracker::new(
                TrackParams::default(),
                &clip.seeds,
                &clip.frames[0],
                Some(bg.clone()),
            )
        };
        g.bench_with_input(BenchmarkId::from_parameter(clip.size()), clip, |b, clip| {
            b.iter_batched(
                build,
                |mut t| {
                    for f in &clip.frames[1..=STEPS] {
                        black_box(t.step(f));
                    }
                    t
                },
                BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

fn flow(c: &mut Criterion) {
    let mut g = c.benchmark_group("flow");
    let prm = KeyedParams::default().flow;
    for clip in clips() {
        let size = clip.size();
        g.throughput(Throughput::Elements(1));
        g.bench_with_input(BenchmarkId::new("pyramid", &size), clip, |b, clip| {
            b.iter(|| black_box(GreyPyramid::new(&clip.frames[1], FLOW_LEVELS)))
        });
        let (a, z) = (
            GreyPyramid::new(&clip.frames[1], FLOW_LEVELS),
            GreyPyramid::new(&clip.frames[2], FLOW_LEVELS),
        );
        let points: Vec<_> = clip.seeds.joints.iter().map(|j| j.bbox.centre()).collect();
        g.throughput(Throughput::Elements(points.len() as u64));
        g.bench_with_input(
            BenchmarkId::new("track_checked", &size),
            &points,
            |b, points| {
                b.iter(|| {
                    for &p in points {
                        black_box(track_checked(&a, &z, p, &prm));
                    }
                })
            },
        );
    }
    g.finish();
}

fn track(c: &mut Criterion) {
    let mut g = c.benchmark_group("track");
    let clip = &clips()[0];
    let out = tempfile::tempdir().unwrap();
    let mut run = 0;
    g.throughput(Throughput::Elements(clip.frames.len() as u64));
    g.bench_function(BenchmarkId::new("app_track", clip.size()), |b| {
        b.iter_batched(
            || {
                run += 1;
                TrackOptions {
                    out: Some(out.path().join(format!("run{run}"))),
                    ..TrackOptions::new(clip.path.clone(), clip.seeds_path.clone())
                }
            },
            |opts| black_box(app::track(&opts, &NoProgress).unwrap()),
            BatchSize::PerIteration,
        )
    });
    g.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
}

criterion_group! {
    name = stages;
    config = config();
    targets = decode, background, tracker_step, flow, track
}
criterion_main!(stages);
