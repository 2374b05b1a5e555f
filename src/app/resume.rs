//! `mocap2d resume RUN [--segment K]`: carry on a run after a crash, or re-track it from segment
//! K after the user corrected segment files. Segments before K keep their rows byte for byte;
//! the previous `tracks.csv` goes to `history/`.

use super::track::TrackSummary;
use crate::background::Background;
use crate::decode;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::run::keys;
use crate::run::manifest::RUN_TOML;
use crate::run::segments::{self, hash_file};
use crate::run::session::Session;
use crate::run::{folder, hash_clip, Manifest};
use crate::seed::{read_seeds, Seeds};
use crate::track::TrackParams;
use std::path::{Path, PathBuf};

/// Options of `mocap2d resume`.
#[derive(Debug, Clone, Default)]
pub struct ResumeOptions {
    /// The run folder.
    pub run: PathBuf,
    /// Re-track from this segment on; `None`: from where the run stopped, or from the first
    /// segment edited since it was tracked.
    pub segment: Option<u64>,
    /// The clip, when it is no longer where `run.toml` says.
    pub clip: Option<PathBuf>,
    /// Tracking parameters the user expects the run to have (checked, not changed).
    pub params: Option<TrackParams>,
}

/// `mocap2d resume`. Returns `None` when there is nothing to do (the run is complete and no
/// segment file changed since it was tracked).
pub fn resume(opts: &ResumeOptions, progress: &dyn Progress) -> Result<Option<TrackSummary>> {
    let run_dir = &opts.run;
    if !run_dir.is_dir() {
        return Err(Error::RunFolder {
            path: run_dir.clone(),
            msg: "not a folder; give a run folder written by `mocap2d track`".into(),
        });
    }
    // One writer at a time; everything below reads the folder under the lock.
    let _lock = crate::run::lock::RunLock::acquire(run_dir, "resume")?;
    let manifest_path = run_dir.join(RUN_TOML);
    let manifest = Manifest::read(&manifest_path)?;
    if let Some(p) = &opts.params {
        p.validate()?;
    }
    let clip = check_inputs(opts, &manifest, &manifest_path)?;
    manifest.params.validate().map_err(|e| Error::RunFolder {
        path: manifest_path.clone(),
        msg: format!("{e}; track again into a new folder"),
    })?;
    let (base, _) = read_seeds(&run_dir.join("seeds.toml"))?;
    // keys.toml must read, its frames inside the clip when its length is known, before
    // anything in the folder is touched: a refusal leaves tracks.csv where it is.
    let names: Vec<String> = base.joints.iter().map(|j| j.name.clone()).collect();
    let frames = (manifest.frames > 0).then_some(manifest.frames);
    keys::read(run_dir, &names, manifest.width, manifest.height, frames)?;
    let first = match pick_segment(opts, &manifest, run_dir)? {
        Some(k) => k,
        None => return Ok(None),
    };
    let background = background_of(&manifest, &base, &clip, &manifest_path)?;
    let mut session = Session {
        run_dir: run_dir.clone(),
        base,
        names,
        params: manifest.params.clone(),
        background,
        width: manifest.width,
        height: manifest.height,
        manifest,
        seed_image: None,
        last_angles: None,
        carried: None,
    };
    // Every segment file from K on must read, and K's state be there, before anything is
    // written.
    let count = session.manifest.segment.len() as u64;
    for k in first..count {
        let p = segments::file_path(run_dir, k);
        if k == first || p.exists() {
            session.start(k)?;
        }
    }
    session.check_state(first)?;
    folder::remove_temp_files(run_dir)?;
    folder::archive_previous(run_dir)?;
    session.manifest.complete = false;
    session.manifest.tracked_segments = first;
    session.manifest.write(run_dir)?;
    let source = decode::open_beside_tracking(&clip, Some(session.manifest.fps))?;
    progress.start("track", Some(session.manifest.frames).filter(|&n| n > 0));
    // Resumed segments start on corrections or hold keys: Lucas–Kanade between them reads
    // the frames at full resolution.
    let rx = session.frames_from(source, true);
    let result = session.run(rx.into_iter(), first, progress);
    progress.finish();
    let mut done = result?;
    let mode = session.manifest.params.pose;
    if let Some(lms) = super::pose::recorded(run_dir, mode, done.frames)? {
        crate::run::fuse::apply(run_dir, &session.names, &lms)?;
        done = session.rereport(done.frames)?;
    }
    Ok(Some(TrackSummary::new(run_dir.clone(), &session, &done)))
}

/// The tracking parameters this build has that the manifest at `path` does not list under
/// `[params]` (they took this build's defaults when it was read): a run folder from an earlier
/// build. Empty when all are there or the file does not read.
fn params_missing(path: &Path) -> Vec<String> {
    let listed = std::fs::read_to_string(path)
        .ok()
        .and_then(|text| text.parse::<toml::Table>().ok())
        .and_then(|t| t.get("params").and_then(|p| p.as_table()).cloned());
    let (Some(listed), Ok(all)) = (listed, toml::Table::try_from(TrackParams::default())) else {
        return Vec::new();
    };
    all.keys()
        .filter(|k| !listed.contains_key(*k))
        .cloned()
        .collect()
}

/// Checks that the run folder belongs to the clip, parameters and tool: returns the clip path.
fn check_inputs(opts: &ResumeOptions, m: &Manifest, manifest_path: &Path) -> Result<PathBuf> {
    let err = |msg: String| Error::RunFolder {
        path: manifest_path.to_owned(),
        msg,
    };
    let mut expected = m.clone();
    expected.version = env!("CARGO_PKG_VERSION").into();
    if m.config_hash() != m.config_blake3 {
        let missing = params_missing(manifest_path);
        return Err(err(if missing.is_empty() {
            "the manifest was edited (its config_blake3 does not match its fields); track again \
             into a new folder"
                .into()
        } else {
            format!(
                "written by an earlier build of mocap2d {}, whose tracking parameters had no `{}`; \
                 a resumed run must be tracked by the same build: track again into a new folder",
                m.version,
                missing.join("`, `")
            )
        }));
    }
    if expected.config_hash() != m.config_blake3 {
        return Err(err(format!(
            "written by mocap2d {}, but this is {}: a resumed run must be tracked by the same \
             version; track again into a new folder",
            m.version, expected.version
        )));
    }
    if let Some(p) = &opts.params {
        if p != &m.params {
            let (a, b) = (
                toml::to_string(&m.params).unwrap_or_default(),
                toml::to_string(p).unwrap_or_default(),
            );
            let diff: Vec<String> = a
                .lines()
                .zip(b.lines())
                .filter(|(x, y)| x != y)
                .map(|(x, y)| format!("run has `{x}`, given `{y}`"))
                .collect();
            return Err(err(format!(
                "tracked with other parameters ({}); resume keeps a run's parameters: drop \
                 --params, or track again into a new folder",
                diff.join("; ")
            )));
        }
    }
    let clip = match &opts.clip {
        Some(c) => c.clone(),
        None => recorded_clip(m, manifest_path),
    };
    if !clip.exists() {
        return Err(err(format!(
            "its clip {} is not there, nor beside the run folder; give the clip with --clip",
            clip.display()
        )));
    }
    let (bytes, blake3) = hash_clip(&clip)?;
    if bytes != m.clip.bytes || blake3 != m.clip.blake3 {
        return Err(err(format!(
            "this run was tracked from another clip: {} ({} bytes, blake3 {}), but {} is {bytes} \
             bytes, blake3 {}; give the clip it was tracked from with --clip",
            m.clip.path,
            m.clip.bytes,
            &m.clip.blake3[..16.min(m.clip.blake3.len())],
            clip.display(),
            &blake3[..16],
        )));
    }
    let seeds = manifest_path.with_file_name("seeds.toml");
    let h = hash_file(&seeds)?;
    if h.as_deref() != Some(m.seeds_blake3.as_str()) {
        return Err(Error::RunFolder {
            path: seeds,
            msg: "missing or edited since the run was tracked; to correct the seed frame edit \
                  segments/000.toml instead, or track again"
                .into(),
        });
    }
    Ok(clip)
}

/// Where the run's clip is, as `review` looks for it: the path `run.toml` records (relative to
/// the working directory), else that path or its file name beside the run folder (whose
/// `run.toml` is at `manifest_path`); the first there with the recorded size, else the first
/// there, else the recorded path.
fn recorded_clip(m: &Manifest, manifest_path: &Path) -> PathBuf {
    let recorded = PathBuf::from(&m.clip.path);
    let beside = manifest_path
        .parent()
        .and_then(Path::parent)
        .unwrap_or(Path::new("."));
    let mut candidates = vec![recorded.clone(), beside.join(&recorded)];
    if let Some(name) = recorded.file_name() {
        candidates.push(beside.join(name));
    }
    let size_fits = |p: &&PathBuf| {
        p.is_dir() || std::fs::metadata(p).is_ok_and(|f| f.is_file() && f.len() == m.clip.bytes)
    };
    candidates
        .iter()
        .find(size_fits)
        .or_else(|| candidates.iter().find(|p| p.exists()))
        .unwrap_or(&recorded)
        .clone()
}

/// The segment to re-track from: `--segment K` (checked), else the first of where the run
/// stopped and the first segment edited since it was tracked; `None` when nothing is to do.
fn pick_segment(opts: &ResumeOptions, m: &Manifest, run_dir: &Path) -> Result<Option<u64>> {
    let files = m.segment.len() as u64;
    // Segments proper; with the clip's length known, a file after them holds its last frame.
    let plan = segments::Plan {
        seed_frame: m.seed_frame,
        len: m.segment_len,
    };
    let count = if m.frames > 0 {
        plan.count(m.frames).min(files)
    } else {
        files
    };
    if let Some(k) = opts.segment {
        if k >= files {
            let msg = if m.complete {
                format!(
                    "--segment {k}: the run has {count} segments (0 to {})",
                    count.saturating_sub(1)
                )
            } else {
                format!(
                    "--segment {k}: tracking has not reached it yet; `mocap2d resume {}` \
                     carries on from segment {}",
                    run_dir.display(),
                    m.tracked_segments
                )
            };
            return Err(Error::Usage(msg));
        }
        if k >= count {
            return Err(Error::Usage(format!(
                "--segment {k}: segments/{k:03}.toml holds the clip's last frame, which closes \
                 segment {}; resume from --segment {} to track back from it",
                k - 1,
                k - 1
            )));
        }
        let p = segments::file_path(run_dir, k);
        if !p.exists() {
            return Err(Error::RunFolder {
                path: p,
                msg: format!(
                    "missing: tracking starts from it; put it back, or resume from an earlier \
                     segment (mocap2d rewrites it), e.g. --segment {}",
                    k.saturating_sub(1)
                ),
            });
        }
        return Ok(Some(k));
    }
    let last = count.saturating_sub(1);
    let mut edited = None;
    for (k, rec) in m.segment.iter().enumerate() {
        let k = k as u64;
        if k > m.tracked_segments {
            break;
        }
        let h = hash_file(&segments::file_path(run_dir, k))?;
        if h.is_some_and(|h| h != rec.tracked_from) {
            edited = Some(k.min(last));
            break;
        }
    }
    let stopped = (!m.complete).then_some(m.tracked_segments.min(last));
    Ok(match (stopped, edited) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    })
}

/// The background model the run used, rebuilt as `run.toml` describes it.
fn background_of(
    m: &Manifest,
    seeds: &Seeds,
    clip: &Path,
    manifest_path: &Path,
) -> Result<Option<Background>> {
    let bg = m
        .background
        .rebuild(clip, Some(m.fps), m.width, m.height, seeds)?;
    let threshold = bg.as_ref().map_or(0, |b| b.threshold);
    if threshold != m.background_threshold {
        return Err(Error::RunFolder {
            path: manifest_path.to_owned(),
            msg: format!(
                "the background model ({}) no longer comes out as it did (threshold {threshold}, \
                 was {}); track again into a new folder",
                m.background, m.background_threshold
            ),
        });
    }
    Ok(bg)
}
