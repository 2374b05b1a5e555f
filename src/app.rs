//! Commands, as library calls: each validates its inputs completely before writing anything,
//! then runs the stages in order. `main.rs` only parses flags and reports.

use crate::background::Background;
use crate::decode::{self, FrameSource};
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::run::{hash_clip, ClipId, Manifest, TracksWriter};
use crate::seed::{read_seeds, Seeds};
use crate::track::{gapfill::GapFiller, JointEstimate, TrackParams, Tracker};
use image::RgbImage;
use std::path::{Path, PathBuf};

/// Frames sampled across the clip for the temporal-median clean plate.
pub const BACKGROUND_SAMPLES: usize = 25;

/// Options of `mocap2d track`.
#[derive(Debug, Clone)]
pub struct TrackOptions {
    pub clip: PathBuf,
    /// The seed file; with `dlc`, a DeepLabCut CSV.
    pub seeds: PathBuf,
    /// Read `seeds` as a DeepLabCut CSV: which frame, rectangle size, parent links.
    pub dlc: Option<crate::seed::dlc::DlcSeedOptions>,
    /// Run folder; default `<clip stem>.mocap` beside the clip.
    pub out: Option<PathBuf>,
    /// Frame rate for image folders (and override for videos).
    pub fps: Option<f64>,
    /// A clean plate instead of the temporal median.
    pub background: Option<PathBuf>,
    /// Skip background subtraction altogether.
    pub no_background: bool,
    pub params: TrackParams,
}

impl TrackOptions {
    /// Options for tracking `clip` from `seeds` with every default: run folder beside the clip,
    /// temporal-median background, default parameters.
    pub fn new(clip: impl Into<PathBuf>, seeds: impl Into<PathBuf>) -> Self {
        TrackOptions {
            clip: clip.into(),
            seeds: seeds.into(),
            dlc: None,
            out: None,
            fps: None,
            background: None,
            no_background: false,
            params: TrackParams::default(),
        }
    }
}

/// What a finished `track` reports.
#[derive(Debug, Clone)]
pub struct TrackSummary {
    pub run_dir: PathBuf,
    pub frames: u64,
    pub tracked_frames: u64,
    pub joints: usize,
    /// Joint-frames per status word.
    pub status_counts: Vec<(String, u64)>,
    /// Something the user should know about the inputs (e.g. guessed parent links), or empty.
    pub note: String,
    /// The clip is damaged or cut short: where decoding stopped (also in `run.toml`).
    pub decode_stop: Option<decode::DecodeStop>,
}

/// The default run folder for a clip: `<stem>.mocap` beside it.
pub fn default_run_dir(clip: &Path) -> PathBuf {
    let stem = clip
        .file_stem()
        .map(|s| s.to_os_string())
        .unwrap_or_else(|| "clip".into());
    let mut name = stem;
    name.push(".mocap");
    clip.parent().unwrap_or(Path::new(".")).join(name)
}

/// [`Error::Clip`]: the clip opened but gave no frame.
fn no_frames(clip: &Path) -> Error {
    Error::Clip {
        path: clip.to_owned(),
        msg: "no frames: the clip is empty, or damaged from its first frame".into(),
    }
}

/// Builds the background model the options ask for.
pub fn background_for(
    opts: &TrackOptions,
    width: u32,
    height: u32,
) -> Result<(Option<Background>, String)> {
    if opts.no_background {
        return Ok((None, "none".into()));
    }
    if let Some(plate) = &opts.background {
        return Ok((
            Some(Background::from_plate_file(plate, width, height)?),
            format!("plate:{}", plate.display()),
        ));
    }
    let samples = decode::sample_frames(&opts.clip, BACKGROUND_SAMPLES)?;
    if samples.is_empty() {
        return Err(no_frames(&opts.clip));
    }
    let n = samples.len();
    Ok((Some(Background::fit(&samples)?), format!("median:{n}")))
}

/// Tracks every frame from the seed frame on, calling `sink` with each frame's estimates (the
/// seed frame first). Frames before the seed frame are decoded and skipped. Returns the number
/// of frames the source delivered in all.
pub fn track_frames(
    frames: impl Iterator<Item = Result<(u64, RgbImage)>>,
    seeds: &Seeds,
    params: &TrackParams,
    background: Option<Background>,
    progress: &dyn Progress,
    mut sink: impl FnMut(u64, &[JointEstimate]) -> Result<()>,
) -> Result<u64> {
    let mut tracker: Option<(Tracker, GapFiller)> = None;
    let mut background = background;
    let mut count = 0;
    for item in frames {
        let (idx, frame) = item?;
        count = idx + 1;
        if idx < seeds.frame {
            if !progress.advance(1) {
                return Err(Error::Interrupted);
            }
            continue;
        }
        let done = match tracker.as_mut() {
            None => {
                let t = Tracker::new(params.clone(), seeds, &frame, background.take());
                let mut g = t.gap_filler();
                let done = g.push(idx, t.current());
                tracker = Some((t, g));
                done
            }
            Some((t, g)) => g.push(idx, t.step(&frame)),
        };
        for (i, est) in done {
            sink(i, &est)?;
        }
        if !progress.advance(1) {
            return Err(Error::Interrupted);
        }
    }
    if let Some((_, g)) = tracker.as_mut() {
        for (i, est) in g.finish() {
            sink(i, &est)?;
        }
    }
    Ok(count)
}

/// `mocap2d track`: decode → background → track, writing the run folder.
pub fn track(opts: &TrackOptions, progress: &dyn Progress) -> Result<TrackSummary> {
    // Validate everything before anything is written.
    let (seeds, seed_text, note) = match &opts.dlc {
        None => {
            let (s, t) = read_seeds(&opts.seeds)?;
            (s, t, String::new())
        }
        Some(d) => crate::seed::dlc::seeds_from_dlc(&opts.seeds, d)?,
    };
    let source: Box<dyn FrameSource> = decode::open(&opts.clip, opts.fps)?;
    let info = source.info().clone();
    let min = crate::seed::MIN_BOX_PX;
    if info.width < min || info.height < min {
        return Err(Error::Clip {
            path: opts.clip.clone(),
            msg: format!(
                "frames are {}x{} px, smaller than the smallest joint rectangle ({min} px a side); \
                 this clip cannot be tracked",
                info.width, info.height
            ),
        });
    }
    seeds
        .check_against_clip(&opts.seeds, info.width, info.height, info.frame_count_hint)
        .map_err(|e| match (e, &opts.dlc) {
            (
                Error::Seed {
                    path,
                    line,
                    joint,
                    msg,
                },
                Some(_),
            ) => Error::Seed {
                path,
                line,
                joint,
                msg: format!(
                    "{msg} (with --seeds-from-dlc: a smaller --seed-size or another --seed-frame)"
                ),
            },
            (e, _) => e,
        })?;
    let run_dir = opts
        .out
        .clone()
        .unwrap_or_else(|| default_run_dir(&opts.clip));
    if run_dir.exists() && !run_dir.is_dir() {
        return Err(Error::Usage(format!(
            "{}: exists and is not a folder; choose another --out",
            run_dir.display()
        )));
    }
    progress.start("background", None);
    let (background, bg_desc) = background_for(opts, info.width, info.height)?;
    let threshold = background.as_ref().map_or(0, |b| b.threshold);
    progress.finish();

    let created_dir = !run_dir.exists();
    std::fs::create_dir_all(&run_dir).map_err(|e| Error::io(&run_dir, e))?;
    let tracks_path = run_dir.join("tracks.csv");
    // On failure leave nothing behind: the partial tracks, and a folder this run made with the
    // files it wrote (a full disk can fail the last writes).
    let abandon = |e: Error| -> Error {
        let _ = std::fs::remove_file(crate::atomic::temp_path(&tracks_path));
        if created_dir {
            let _ = std::fs::remove_file(&tracks_path);
            let _ = std::fs::remove_file(run_dir.join("seeds.toml"));
            let _ = std::fs::remove_dir(&run_dir);
        }
        e
    };
    let mut writer = TracksWriter::create(&tracks_path)?;
    let names: Vec<String> = seeds.joints.iter().map(|j| j.name.clone()).collect();
    let mut counts = std::collections::BTreeMap::<&'static str, u64>::new();
    let mut tracked = 0u64;
    progress.start("track", info.frame_count_hint);
    let rx = decode::spawn_reader(source, 8);
    let mut decode_stop = None;
    let result = track_frames(
        decode::salvage(rx.into_iter(), info.stated_frames, &mut decode_stop),
        &seeds,
        &opts.params,
        background,
        progress,
        |idx, est| {
            tracked += 1;
            for e in est {
                *counts.entry(e.status.as_str()).or_default() += 1;
            }
            writer.write_frame(idx, &names, est)
        },
    );
    progress.finish();
    let frames = result.map_err(abandon)?;
    if frames == 0 {
        return Err(abandon(no_frames(&opts.clip)));
    }
    if tracked == 0 {
        return Err(abandon(Error::Seed {
            path: opts.seeds.clone(),
            line: None,
            joint: None,
            msg: format!(
                "frame = {} is beyond the clip, which has {frames} frames (0..{}); set `frame` to a frame of the clip",
                seeds.frame,
                frames.saturating_sub(1)
            ),
        }));
    }
    writer.finish().map_err(abandon)?;
    let (bytes, blake3) = hash_clip(&opts.clip).map_err(abandon)?;
    let manifest = Manifest {
        tool: "mocap2d".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        clip: ClipId {
            path: opts.clip.display().to_string(),
            bytes,
            blake3,
        },
        width: info.width,
        height: info.height,
        fps: info.fps,
        frames,
        seed_frame: seeds.frame,
        joints: seeds.joints.len(),
        seeds_blake3: blake3::hash(seed_text.as_bytes()).to_hex().to_string(),
        background: bg_desc,
        background_threshold: threshold,
        params: opts.params.clone(),
        decode_stop: decode_stop.clone(),
    };
    crate::atomic::write(&run_dir.join("seeds.toml"), seed_text.as_bytes()).map_err(abandon)?;
    // Last, so a folder with run.toml is a complete run.
    crate::atomic::write(&run_dir.join("run.toml"), manifest.to_toml().as_bytes())
        .map_err(abandon)?;
    Ok(TrackSummary {
        run_dir,
        frames,
        tracked_frames: tracked,
        joints: seeds.joints.len(),
        status_counts: counts
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect(),
        note,
        decode_stop,
    })
}

/// `mocap2d eval`: accuracy of a run folder's tracks against ground truth, as printable lines
/// (all joints first, then one line per joint when asked). Frames from the seed frame on.
pub fn eval(run_dir: &Path, gt: &Path, per_joint: bool) -> Result<Vec<String>> {
    let rows = crate::run::tracks::read_tracks(&run_dir.join("tracks.csv"))?;
    let first = rows.first().map_or(0, |r| r.frame);
    let gt = crate::eval::read_gt(gt)?;
    let errs = crate::eval::errors(
        rows.iter().map(|r| (r.frame, r.joint.as_str(), r.x, r.y)),
        &gt,
        first,
    );
    let all: Vec<f32> = errs.iter().map(|e| e.2).collect();
    let mut lines = vec![format!("all joints: {}", crate::eval::summarise(&all))];
    if per_joint {
        let mut names: Vec<&str> = Vec::new();
        for r in &rows {
            if r.frame != first {
                break;
            }
            names.push(&r.joint);
        }
        for n in names {
            let e: Vec<f32> = errs.iter().filter(|e| e.1 == n).map(|e| e.2).collect();
            lines.push(format!("{n}: {}", crate::eval::summarise(&e)));
        }
    }
    Ok(lines)
}

mod animate;
mod export;
mod guide;
mod review;
mod serve;
pub use animate::{
    render, retarget, run_frame, RenderOptions, RenderSummary, Renderer, RetargetSummary,
    RETARGET_DIR,
};
pub use export::{export, ExportOptions, ExportSummary};
pub use guide::{guide, read_frame, GuideOptions, GuideSummary};
pub use review::{review, ReviewSummary, REVIEW_DIR};
pub use serve::{serve, DEFAULT_PORT};
