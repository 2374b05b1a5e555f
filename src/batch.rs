//! `mocap2d batch`: many clips in one command, on every core, and on many machines.
//!
//! Each clip gets the run folder `mocap2d track` would make (and, with a target character,
//! what `retarget` and `render` would add), through the same library calls. A clip that fails
//! is reported and the others go on; a clip whose work is already done for the same inputs is
//! skipped ([`skip`]), one whose tracking was interrupted is resumed from its checkpoint.
//! Ctrl-C stops the batch: no further clip starts and the running ones stop at their next
//! frame ([`Status::Interrupted`]). Clips run side by side on a rayon pool of `jobs` threads;
//! each clip's own stages run in a pool of `cores / jobs` threads (at least one), and FFmpeg's
//! decoders get as many, so the batch never asks for much more than the machine's cores.
//! Outputs do not depend on `jobs`: every stage is deterministic and each clip writes only its
//! own folder.
//!
//! Scale-out: `shard` gives one worker every n-th clip of the sorted list, so the workers of a
//! Slurm array or a Kubernetes indexed Job split a batch with no coordinator.

pub mod clips;
pub mod skip;
pub mod summary;

pub use clips::{discover, SeedTemplate, Shard};
pub use summary::{exit_code, ClipOutcome, Status};

use crate::app::{self, TrackOptions};
use crate::character::Character;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::track::TrackParams;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// The video `--render` writes in each run folder.
pub const RENDER_VIDEO: &str = "render.mp4";

/// Options of `mocap2d batch`.
#[derive(Debug, Clone)]
pub struct BatchOptions {
    /// Video files, frame folders, and folders of clips (see [`discover`]).
    pub inputs: Vec<PathBuf>,
    /// Each clip's seed file.
    pub seeds: SeedTemplate,
    /// Clips processed at once (at least 1).
    pub jobs: usize,
    /// Only this worker's share of the clips.
    pub shard: Option<Shard>,
    /// Put the run folders here (`<stem>.mocap`) instead of beside each clip.
    pub out_dir: Option<PathBuf>,
    pub fps: Option<f64>,
    pub no_background: bool,
    pub params: TrackParams,
    /// Retarget every run onto this character file (default options).
    pub retarget: Option<PathBuf>,
    /// Also render each retargeted run to `RUN/render.mp4` (needs `retarget`).
    pub render: bool,
}

/// Receives a batch's progress; the binary draws it (one bar per running clip, plus a total).
pub trait BatchProgress: Sync {
    /// The batch starts with `clips` clips (this shard's).
    fn begin(&self, _clips: usize) {}
    /// A clip starts; its stages report to the returned [`Progress`].
    fn clip_started(&self, clip: &Path) -> Box<dyn Progress + '_>;
    /// A clip ended (done, skipped, failed or interrupted).
    fn clip_finished(&self, _outcome: &ClipOutcome) {}
    /// True once the user asked the batch to stop (Ctrl-C): no further clip starts. Running
    /// clips stop when their [`Progress::advance`] returns `false`.
    fn stopped(&self) -> bool {
        false
    }
}

/// Reports nothing.
pub struct NoBatchProgress;
impl BatchProgress for NoBatchProgress {
    fn clip_started(&self, _clip: &Path) -> Box<dyn Progress + '_> {
        Box::new(crate::progress::NoProgress)
    }
}

/// The clips of a batch, checked, before any work.
#[derive(Debug, Clone)]
pub struct Plan {
    /// This shard's clips, in the sorted order, with their run folders.
    pub clips: Vec<(PathBuf, PathBuf)>,
    /// Clips in the whole batch, all shards together.
    pub total: usize,
}

/// Lists the clips and their run folders, and checks the options that concern every clip: the
/// output folder, and that no two clips of the whole batch (all shards) would share a run
/// folder (`a.mp4` and `a.mov` side by side; two `a.mp4` in different folders with
/// `--out-dir`). Errors are [`Error::Usage`].
pub fn plan(opts: &BatchOptions) -> Result<Plan> {
    opts.params.validate()?;
    if opts.render && opts.retarget.is_none() {
        return Err(Error::Usage(
            "batch --render needs --retarget CHARACTER.toml (the character to draw)".into(),
        ));
    }
    if let Some(d) = &opts.out_dir {
        if d.exists() && !d.is_dir() {
            return Err(Error::Usage(format!(
                "{}: --out-dir exists and is not a folder; choose another",
                d.display()
            )));
        }
    }
    let all = discover(&opts.inputs)?;
    let mut runs: Vec<(PathBuf, PathBuf)> = all
        .iter()
        .map(|c| (c.clone(), run_dir_for(c, opts.out_dir.as_deref())))
        .collect();
    let mut by_run: Vec<&(PathBuf, PathBuf)> = runs.iter().collect();
    by_run.sort_by(|a, b| a.1.cmp(&b.1));
    for w in by_run.windows(2) {
        if w[0].1 == w[1].1 {
            return Err(Error::Usage(format!(
                "{} and {} would both write the run folder {}; rename one, or batch them \
                 separately{}",
                w[0].0.display(),
                w[1].0.display(),
                w[0].1.display(),
                if opts.out_dir.is_some() {
                    " (or without --out-dir)"
                } else {
                    ""
                }
            )));
        }
    }
    if let Some(s) = opts.shard {
        runs = clips::shard(&runs, s);
    }
    Ok(Plan {
        clips: runs,
        total: all.len(),
    })
}

/// The run folder of `clip`: `track`'s default, or `<stem>.mocap` in `out_dir`.
pub fn run_dir_for(clip: &Path, out_dir: Option<&Path>) -> PathBuf {
    let default = app::default_run_dir(clip);
    match out_dir {
        Some(d) => d.join(default.file_name().unwrap_or_default()),
        None => default,
    }
}

/// Runs the plan's clips, `opts.jobs` at a time, and returns one outcome per clip in the plan's
/// order. Fails only on what concerns every clip (the target character file, the thread
/// pool); a clip's own failure is its outcome. Once `progress` says the batch is
/// [stopped](BatchProgress::stopped), no clip starts and the outcomes are those of the clips
/// that did (see [`summary::interrupted`]).
pub fn run(
    opts: &BatchOptions,
    plan: &Plan,
    progress: &dyn BatchProgress,
) -> Result<Vec<ClipOutcome>> {
    let character = match &opts.retarget {
        Some(t) => Some(crate::character::read_character(t)?),
        None => None,
    };
    let jobs = opts.jobs.max(1).min(plan.clips.len().max(1));
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let per_clip = (cores / jobs).max(1);
    crate::decode::set_decoder_threads(per_clip);
    let pool_err = |e: rayon::ThreadPoolBuildError| {
        Error::io(
            "batch",
            std::io::Error::other(format!("cannot start threads: {e}")),
        )
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .thread_name(|i| format!("batch-{i}"))
        .build()
        .map_err(pool_err)?;
    progress.begin(plan.clips.len());
    let next = AtomicUsize::new(0);
    let outcomes: Mutex<Vec<Option<ClipOutcome>>> = Mutex::new(vec![None; plan.clips.len()]);
    // Every pool thread takes the next clip until none is left, each with its own pool for the
    // clip's stages (a waiting `install` never picks up another clip: `broadcast` jobs are not
    // stolen).
    let worker = || -> Result<()> {
        let stages = rayon::ThreadPoolBuilder::new()
            .num_threads(per_clip)
            .build()
            .map_err(pool_err)?;
        loop {
            if progress.stopped() {
                return Ok(());
            }
            let k = next.fetch_add(1, Ordering::SeqCst);
            let Some((clip, run_dir)) = plan.clips.get(k) else {
                return Ok(());
            };
            let bar = progress.clip_started(clip);
            let outcome = stages
                .install(|| process_clip(opts, clip, run_dir, character.as_ref(), bar.as_ref()));
            drop(bar);
            progress.clip_finished(&outcome);
            outcomes.lock().unwrap_or_else(|e| e.into_inner())[k] = Some(outcome);
        }
    };
    for r in pool.broadcast(|_| worker()) {
        r?;
    }
    let outcomes = outcomes.into_inner().unwrap_or_else(|e| e.into_inner());
    Ok(outcomes.into_iter().flatten().collect())
}

/// One clip, all its stages; never fails: a failure (or a panic) becomes the outcome.
fn process_clip(
    opts: &BatchOptions,
    clip: &Path,
    run_dir: &Path,
    character: Option<&Character>,
    progress: &dyn Progress,
) -> ClipOutcome {
    let mut outcome = ClipOutcome {
        clip: clip.to_owned(),
        run_dir: run_dir.to_owned(),
        frames: None,
        track_seconds: None,
        flagged_segments: None,
        note: String::new(),
        status: Status::Skipped,
    };
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        stages(opts, clip, run_dir, character, progress, &mut outcome)
    }));
    let failure = match run {
        Ok(Ok(())) => None,
        Ok(Err(Error::Interrupted)) => {
            outcome.status = Status::Interrupted;
            None
        }
        Ok(Err(e)) => Some((one_line(&e), e.is_user_error())),
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Some((
                format!("internal error (a bug; please report it): {what}"),
                false,
            ))
        }
    };
    if let Some((message, user_error)) = failure {
        outcome.status = Status::Failed {
            message,
            user_error,
        };
    }
    outcome.flagged_segments = summary::flagged_segments_hook(run_dir);
    outcome
}

/// Track (unless finished for the same inputs; an unfinished run of them is resumed), then
/// retarget and render when asked (unless finished), filling in `outcome` as it goes.
fn stages(
    opts: &BatchOptions,
    clip: &Path,
    run_dir: &Path,
    character: Option<&Character>,
    progress: &dyn Progress,
    outcome: &mut ClipOutcome,
) -> Result<()> {
    let track = TrackOptions {
        out: opts.out_dir.as_ref().map(|_| run_dir.to_owned()),
        fps: opts.fps,
        background: crate::background::BackgroundChoice::from_flags(None, opts.no_background),
        params: opts.params.clone(),
        ..TrackOptions::new(clip, opts.seeds.for_clip(clip))
    };
    let finished = skip::finished_track(run_dir, &track);
    // A finished run whose segment files hold an edit not yet applied is resumed, not skipped.
    let edited = finished
        .as_ref()
        .is_some_and(|m| skip::unapplied_edit(run_dir, m).is_some());
    let tracked = match finished {
        Some(m) if !edited => {
            outcome.frames = Some(m.frames.saturating_sub(m.seed_frame));
            false
        }
        _ => {
            let start = Instant::now();
            // An interrupted run carries on from its checkpoint, an edited one from its first
            // edited segment; their speed is not measured.
            let resumable = edited || skip::unfinished_track(run_dir, &track).is_some();
            let resumed = match resumable {
                true => app::resume(
                    &app::ResumeOptions {
                        run: run_dir.to_owned(),
                        segment: None,
                        clip: Some(clip.to_owned()),
                        params: Some(opts.params.clone()),
                    },
                    progress,
                )?,
                false => None,
            };
            let fresh = resumed.is_none();
            let s = match resumed {
                Some(s) => s,
                // The run folder is the batch's own: a changed clip is tracked again.
                None => app::track_into(&track, app::OtherClip::Replace, progress)?,
            };
            outcome.frames = Some(s.tracked_frames);
            outcome.note = s.note.clone();
            if fresh {
                outcome.track_seconds = Some(start.elapsed().as_secs_f64());
            }
            outcome.status = Status::Done;
            true
        }
    };
    let (Some(target), Some(character)) = (&opts.retarget, character) else {
        return Ok(());
    };
    let retarget = tracked || !skip::finished_retarget(run_dir, &character.blake3);
    if retarget {
        progress.start("retarget", None);
        let r = app::retarget(run_dir, target, &Default::default());
        progress.finish();
        r?;
        outcome.status = Status::Done;
    }
    let video = run_dir.join(RENDER_VIDEO);
    if opts.render && (retarget || !video.is_file()) {
        let render = app::RenderOptions {
            run: run_dir.to_owned(),
            target: target.clone(),
            out: Some(video),
            frames_dir: None,
            deform: Default::default(),
        };
        app::render(&render, progress)?;
        outcome.status = Status::Done;
    }
    Ok(())
}

/// An error and its causes on one line.
pub fn one_line(e: &Error) -> String {
    let mut s = e.to_string();
    let mut src = std::error::Error::source(e);
    while let Some(c) = src {
        s.push_str(&format!("; caused by: {c}"));
        src = c.source();
    }
    s.replace('\n', " ")
}
