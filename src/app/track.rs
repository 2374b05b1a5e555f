//! `mocap2d track`: decode → background → track segment by segment, writing the run folder.

use crate::background::{BackgroundChoice, BackgroundSetting};
use crate::decode::{self, FrameSource};
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::run::session::{Finished, Session};
use crate::run::{folder, hash_clip, segments, ClipId, Manifest, SegmentRecord};
use crate::seed::{read_seeds, Seeds};
use crate::track::{JointEstimate, PoseMode, Status, TrackParams};
use std::path::{Path, PathBuf};

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
    /// The background model: the temporal median, a clean plate, or none.
    pub background: BackgroundChoice,
    /// Frames per segment: a checkpoint and a file to correct (`segments/NNN.toml`) every this many frames.
    pub segment_len: u64,
    pub params: TrackParams,
}

/// Frames per segment when none is asked for.
pub const DEFAULT_SEGMENT_LEN: u64 = 150;

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
            background: BackgroundChoice::Median,
            segment_len: DEFAULT_SEGMENT_LEN,
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
    /// Segments the clip was cut into.
    pub segments: u64,
    /// The report's one-line summary (see [`crate::run::report::Report::summary`]).
    pub report: String,
    /// Segments the report flags, most needy first.
    pub flagged: Vec<u64>,
    /// Segment files the report says to correct, in order.
    pub to_correct: Vec<u64>,
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

/// What `track` does with a run folder that holds the run of another clip (another content).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OtherClip {
    /// Refuse (exit 2), naming the clip it holds: the default.
    #[default]
    Refuse,
    /// Replace it (`track --replace`, and `batch`, whose run folders are its own): its
    /// `tracks.csv`, `report.md`, `run.toml` and `seeds.toml` go to `history/` first.
    Replace,
}

/// `mocap2d track`: decode → background → track segment by segment, writing the run folder
/// (see [`crate::run`]). A run folder that holds corrections is refused (resume applies them),
/// and so is one that holds another clip's run (see [`track_into`]).
pub fn track(opts: &TrackOptions, progress: &dyn Progress) -> Result<TrackSummary> {
    track_into(opts, OtherClip::Refuse, progress)
}

/// [`track`], saying what to do with a run folder that holds another clip's run.
pub fn track_into(
    opts: &TrackOptions,
    other_clip: OtherClip,
    progress: &dyn Progress,
) -> Result<TrackSummary> {
    // Validate everything before anything is written.
    opts.params.validate()?;
    let (seeds, seed_text, note) = match &opts.dlc {
        None => {
            let (s, t) = read_seeds(&opts.seeds)?;
            (s, t, String::new())
        }
        Some(d) => crate::seed::dlc::seeds_from_dlc(&opts.seeds, d)?,
    };
    let work = crate::track::scale::WorkScale::for_seeds(&opts.params, &seeds);
    let source: Box<dyn FrameSource> = decode::open_beside_tracking(&opts.clip, opts.fps)?;
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
    if info.stated_frames == Some(1) {
        // (A picture file given as the clip is refused as it opens, crate::decode.)
        return Err(Error::Clip {
            path: opts.clip.clone(),
            msg: "holds a single frame: one frame has no motion to track; give the whole clip"
                .into(),
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
    // The pose cue's engine loads before anything is written.
    let pose_mode = opts.params.pose;
    let mut pose_note = None;
    let engine = if super::pose::wanted(pose_mode, &seeds) {
        let mut engine = super::pose::load_engine()?;
        let why = match pose_mode {
            PoseMode::Auto => {
                super::pose::check_seed_frame(&mut engine, &opts.clip, opts.fps, &seeds)?
            }
            _ => None,
        };
        pose_note = why.map(|why| {
            format!("the pose cue is left out: {why} (`--pose on` uses it all the same)")
        });
        pose_note.is_none().then_some(engine)
    } else {
        None
    };
    // With the cue, the network finds a lost person again: the tracker's whole-frame search
    // for a lost body is left out (docs/method.md §2.8), and run.toml records it.
    let mut with_cue = opts.clone();
    if engine.is_some() {
        with_cue.params.redetect_after = 0;
    }
    let opts = &with_cue;
    if opts.segment_len == 0 {
        return Err(Error::Usage(
            "--segment-len 0: a segment needs at least 1 frame".into(),
        ));
    }
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
    // One writer at a time: the folder is made (if new) to hold the lock, and every check of
    // what it holds is made under the lock.
    // The outermost folder this run makes (the run folder, or a missing parent of it).
    let created = run_dir
        .ancestors()
        .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
        .last()
        .map(Path::to_path_buf);
    let created_dir = created.is_some();
    std::fs::create_dir_all(&run_dir).map_err(|e| Error::io(&run_dir, e))?;
    let _lock = crate::run::lock::RunLock::acquire(&run_dir, "track")?;
    // Until the run starts, a failure (or Ctrl-C) leaves nothing behind in folders it made.
    let unmake = |e: Error| -> Error {
        if let Some(c) = &created {
            let _ = std::fs::remove_dir_all(c);
        }
        e
    };
    folder::check_no_corrections(&run_dir).map_err(unmake)?;
    progress.start("background", None);
    let built = opts
        .background
        .build(&opts.clip, opts.fps, info.width, info.height, Some(&seeds))
        .map_err(unmake)?;
    let camera_note = built.note();
    let crowding = seeds.crowding_note();
    let (background, setting) = (built.model, built.setting);
    let threshold = background.as_ref().map_or(0, |b| b.threshold);
    progress.finish();
    let (bytes, blake3) = hash_clip(&opts.clip).map_err(unmake)?;
    // The folder may hold the run of another clip: replaced only when asked, its inputs kept.
    let other = Manifest::read(&run_dir.join(crate::run::manifest::RUN_TOML))
        .ok()
        .filter(|m| m.clip.bytes != bytes || m.clip.blake3 != blake3);
    if let (Some(m), OtherClip::Refuse) = (&other, other_clip) {
        return Err(Error::RunFolder {
            path: run_dir.join(crate::run::manifest::RUN_TOML),
            msg: format!(
                "this run folder holds the run of another clip ({}, {} bytes, blake3 {}), whose \
                 seed file, segment files and run.toml `track` would replace; track into another \
                 --out, or add --replace to replace it (its tracks.csv, report.md, run.toml and \
                 seeds.toml are kept in history/)",
                m.clip.path,
                m.clip.bytes,
                &m.clip.blake3[..16.min(m.clip.blake3.len())]
            ),
        });
    }
    // On failure leave nothing behind in a folder this run made; an interrupted run keeps its
    // checkpoint for `resume`.
    let abandon = |e: Error| -> Error {
        if created_dir && !matches!(e, Error::Interrupted) {
            let _ = std::fs::remove_dir_all(&run_dir);
        }
        e
    };

    std::fs::create_dir_all(run_dir.join(segments::SEGMENTS_DIR))
        .map_err(|e| unmake(Error::io(&run_dir, e)))?;
    let start = prepare_new_run(
        &run_dir,
        &seeds,
        &seed_text,
        opts,
        &info,
        setting,
        threshold,
        bytes,
        blake3,
        other.is_some(),
    )
    .map_err(abandon)?;
    let names: Vec<String> = seeds.joints.iter().map(|j| j.name.clone()).collect();
    let _ = std::fs::remove_file(run_dir.join(super::pose::POSE_CSV));
    let pose_pass = match engine {
        Some(e) => Some(super::pose::start(e, &opts.clip, opts.fps, &seeds).map_err(abandon)?),
        None => None,
    };
    let mut session = Session {
        run_dir: run_dir.clone(),
        base: seeds,
        names,
        params: opts.params.clone(),
        background,
        width: info.width,
        height: info.height,
        manifest: start,
        seed_image: None,
        last_angles: None,
        carried: None,
    };
    progress.start("track", info.frame_count_hint);
    // Frames at full resolution are kept only where keys are (a new run has no corrections).
    let keep_full = crate::run::keys::path(&run_dir).exists();
    let rx = session.frames_from(source, keep_full);
    let mut decode_stop = None;
    let result = session.run(
        decode::salvage(rx.into_iter(), info.stated_frames, &mut decode_stop),
        0,
        progress,
    );
    progress.finish();
    let done = result.map_err(|e| match e {
        // The seed frame was never reached.
        Error::RunFolder { .. } if session.manifest.tracked_segments == 0 => Error::Seed {
            path: opts.seeds.clone(),
            line: None,
            joint: None,
            msg: format!(
                "frame = {} is beyond the clip; set `frame` to a frame of the clip",
                session.manifest.seed_frame
            ),
        },
        e => e,
    });
    let mut done = done.map_err(abandon)?;
    if let Some(pass) = pose_pass {
        progress.start("pose", None);
        let lms = pass.finish();
        progress.finish();
        pose_note = super::pose::fuse_run(&run_dir, &session.base, pose_mode, &lms?)?;
        done = session.rereport(done.frames)?;
    }
    if decode_stop.is_none() {
        decode_stop = decode::short_of_duration(&info, done.frames);
    }
    if decode_stop.is_some() {
        // The clip is damaged or cut short: say where decoding stopped, in run.toml too.
        session.manifest.decode_stop = decode_stop.clone();
        session.manifest.write(&run_dir)?;
    }
    let mut summary = TrackSummary::new(run_dir, &session, &done);
    let halved = (work.halvings > 0).then(|| {
        let (w, h) = (info.width >> work.halvings, info.height >> work.halvings);
        format!(
            "tracked at {w}x{h}, the frames halved {}: the seed rectangles are large \
             (`work_box_px`; px parameters are in those pixels, the tracks in the clip's; \
             `work_box_px = 0` in --params tracks at full resolution)",
            if work.halvings == 1 { "once" } else { "twice" }
        )
    });
    summary.note = [Some(note), Some(crowding), camera_note, halved, pose_note]
        .into_iter()
        .flatten()
        .filter(|n| !n.is_empty())
        .collect::<Vec<_>>()
        .join("; ");
    summary.decode_stop = decode_stop;
    Ok(summary)
}

/// Writes what a new run starts from: earlier results into `history/` (with `keep_inputs`, the
/// earlier `run.toml` and `seeds.toml` too: another clip's run), `seeds.toml`, the
/// manifest (incomplete, nothing tracked) and `segments/000.toml` from the seeds. Returns the
/// manifest.
#[allow(clippy::too_many_arguments)]
fn prepare_new_run(
    run_dir: &Path,
    seeds: &Seeds,
    seed_text: &str,
    opts: &TrackOptions,
    info: &decode::ClipInfo,
    setting: BackgroundSetting,
    threshold: u32,
    bytes: u64,
    blake3: String,
    keep_inputs: bool,
) -> Result<Manifest> {
    folder::remove_temp_files(run_dir)?;
    let archived = folder::archive_previous(run_dir)?;
    if keep_inputs {
        folder::archive_inputs(run_dir, archived.as_deref())?;
    }
    folder::clear_segments(run_dir)?;
    let _ = std::fs::remove_file(run_dir.join("report.md"));
    let at_seed: Vec<JointEstimate> = seeds
        .joints
        .iter()
        .map(|j| JointEstimate {
            pos: j.bbox.centre(),
            angle_rad: 0.0,
            score: 1.0,
            status: Status::Seed,
        })
        .collect();
    let first = segments::file_text(
        0,
        seeds.frame,
        false,
        seeds,
        &at_seed,
        info.width,
        info.height,
    );
    let mut manifest = Manifest {
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
        frames: 0,
        seed_frame: seeds.frame,
        joints: seeds.joints.len(),
        seeds_blake3: blake3::hash(seed_text.as_bytes()).to_hex().to_string(),
        background: setting,
        background_threshold: threshold,
        segment_len: opts.segment_len,
        config_blake3: String::new(),
        complete: false,
        tracked_segments: 0,
        params: opts.params.clone(),
        decode_stop: None,
        segment: vec![SegmentRecord {
            first_frame: seeds.frame,
            written: vec![segments::hash_bytes(first.as_bytes())],
            ..SegmentRecord::default()
        }],
    };
    manifest.config_blake3 = manifest.config_hash();
    crate::atomic::write(&run_dir.join("seeds.toml"), seed_text.as_bytes())?;
    manifest.write(run_dir)?;
    crate::atomic::write(&segments::file_path(run_dir, 0), first.as_bytes())?;
    Ok(manifest)
}

impl TrackSummary {
    /// The summary of a finished session.
    pub(super) fn new(run_dir: PathBuf, session: &Session, done: &Finished) -> TrackSummary {
        TrackSummary {
            run_dir,
            frames: done.frames,
            tracked_frames: done.tally.frames,
            joints: session.names.len(),
            status_counts: done
                .tally
                .status
                .iter()
                .map(|(k, &v)| (k.to_string(), v))
                .collect(),
            segments: session.manifest.tracked_segments,
            report: done.report.summary(),
            flagged: done.report.ranked().iter().map(|s| s.index).collect(),
            to_correct: done.report.files_to_correct(),
            note: String::new(),
            decode_stop: None,
        }
    }
}
