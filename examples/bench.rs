//! Throughput of each stage of `mocap2d track` on one or more clips, against FFmpeg's own decode
//! to RGB: every row of the speed targets (docs/benchmarks.md), measured in one run.
//!
//!     cargo run --release --example bench -- [--reps 3] [--bin target/release/mocap2d] \
//!         ROW...
//!
//! where each ROW is a clip folder (holding `clip.mp4` and `joints.toml`, as `mocap2d synth`
//! writes them) followed by its own options:
//!
//!     DIR [--label TEXT] [--keys-every N --gt LABELS.csv] [--target-fps F | --target-ratio R]
//!
//! `--keys-every N --gt LABELS.csv`: the clip is tracked with a key every N frames, as a user
//! correcting every segment would (`track --segment-len N`, `scripts/keys-from-labels RUN
//! LABELS.csv`, then `resume RUN --segment 0`; the end-to-end figure is that `resume`).
//! `--target-fps F`: the end to end must reach F frames/s; `--target-ratio R`: R × FFmpeg's
//! decode to RGB.
//!
//! Every stage runs `--reps` times; the table holds medians. Stages (frames/s over the clip):
//! decode (`decode::open` + `next_frame` to RGB, in process), plate (the temporal-median
//! background `track` builds), tracking (`run::session::Session::run`, the loop `track` and
//! `resume` run, over frames already decoded into memory; it writes each segment's rows and
//! state as it goes), writing (what the run writes at its end: `tracks.csv` joined from the
//! segments, `report.md`, `run.toml`), end to end (the `mocap2d` binary as a child process, wall
//! clock, start-up included) and FFmpeg (`ffmpeg -i clip -pix_fmt rgb24 -f rawvideo /dev/null`,
//! wall clock). FFmpeg and the end to end run in turn, and the ratio is the median over those
//! pairs, so that a change of the machine's load between the two does not decide it. Peak RSS
//! of the end to end is GNU `/usr/bin/time -f %M` when present.

use anyhow::{bail, Context, Result};
use mocap2d::app::{self, TrackOptions};
use mocap2d::background::BackgroundChoice;
use mocap2d::decode;
use mocap2d::progress::NoProgress;
use mocap2d::run::manifest::RUN_TOML;
use mocap2d::run::session::Session;
use mocap2d::run::{report, segments, Manifest};
use mocap2d::seed::read_seeds;
use mocap2d::track::scale::WorkScale;
use mocap2d::track::TrackParams;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const GNU_TIME: &str = "/usr/bin/time";

const USAGE: &str = "usage: bench [--reps N] [--bin PATH] DIR [--label TEXT] \
                     [--keys-every N --gt LABELS.csv] [--target-fps F | --target-ratio R] [DIR ...]";

/// What a row must reach.
#[derive(Clone, Copy)]
enum Target {
    /// End to end, frames/s.
    Fps(f64),
    /// End to end over FFmpeg's decode to RGB.
    Ratio(f64),
}

/// One row asked for on the command line.
struct Spec {
    dir: PathBuf,
    label: Option<String>,
    keys: Option<(u64, PathBuf)>,
    target: Option<Target>,
}

/// One row measured.
struct RowBench {
    label: String,
    width: u32,
    height: u32,
    frames: u64,
    joints: usize,
    keyframes: Option<usize>,
    decode: f64,
    plate: f64,
    tracking: f64,
    writing: f64,
    end_to_end: f64,
    end_rss: String,
    ffmpeg: f64,
    /// Median over the runs of end to end ÷ the FFmpeg run just before it.
    ratio: f64,
    target: Option<Target>,
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let (mut specs, mut reps, mut bin) = (Vec::<Spec>::new(), 3, None);
    let mut keys_every = None;
    while let Some(a) = args.next() {
        let last = specs.last_mut();
        match (a.as_str(), last) {
            ("--reps", _) => reps = args.next().context("--reps N")?.parse()?,
            ("--bin", _) => bin = Some(PathBuf::from(args.next().context("--bin PATH")?)),
            ("--label", Some(s)) => s.label = Some(args.next().context("--label TEXT")?),
            ("--keys-every", Some(_)) => {
                keys_every = Some(args.next().context("--keys-every N")?.parse::<u64>()?)
            }
            ("--gt", Some(s)) => {
                let n = keys_every
                    .take()
                    .context("--gt goes after --keys-every N")?;
                s.keys = Some((n, PathBuf::from(args.next().context("--gt LABELS.csv")?)));
            }
            ("--target-fps", Some(s)) => {
                s.target = Some(Target::Fps(args.next().context("--target-fps F")?.parse()?))
            }
            ("--target-ratio", Some(s)) => {
                s.target = Some(Target::Ratio(
                    args.next().context("--target-ratio R")?.parse()?,
                ))
            }
            (_, _) if !a.starts_with('-') => {
                if keys_every.is_some() {
                    bail!("--keys-every needs --gt LABELS.csv");
                }
                specs.push(Spec {
                    dir: PathBuf::from(a),
                    label: None,
                    keys: None,
                    target: None,
                })
            }
            _ => bail!(USAGE),
        }
    }
    if specs.is_empty() || reps == 0 || keys_every.is_some() {
        bail!(USAGE);
    }
    // target/release/examples/bench -> target/release/mocap2d
    let bin = bin.unwrap_or_else(|| {
        let exe = std::env::current_exe().unwrap_or_default();
        exe.parent()
            .and_then(Path::parent)
            .unwrap_or(Path::new("."))
            .join("mocap2d")
    });
    if !bin.is_file() {
        bail!("{}: not built (cargo build --release)", bin.display());
    }
    let mut rows = Vec::new();
    for s in &specs {
        rows.push(bench_row(s, reps, &bin)?);
    }

    println!("### Throughput per stage (frames/s, median of {reps} runs)\n");
    println!(
        "| row | clip | decode | plate | tracking | writing | end to end | FFmpeg → RGB | \
         end to end ÷ FFmpeg | target | peak RSS |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---|---:|");
    for r in &rows {
        let ratio = r.ratio;
        let target = match r.target {
            None => "–".to_string(),
            Some(Target::Fps(f)) => format!(
                "≥ {f:.0} fps: {}",
                if r.end_to_end >= f {
                    "met"
                } else {
                    "**not met**"
                }
            ),
            Some(Target::Ratio(x)) => format!(
                "≥ {x:.2}× FFmpeg: {}",
                if ratio >= x { "met" } else { "**not met**" }
            ),
        };
        let keyframes = r.keyframes.map_or("?".into(), |k| k.to_string());
        println!(
            "| {} | {}x{}, {} frames, {} joints, {} keyframes | {:.1} | {:.1} | {:.1} | {:.0} | \
             {:.1} | {:.1} | {:.2} | {} | {} |",
            r.label,
            r.width,
            r.height,
            r.frames,
            r.joints,
            keyframes,
            r.decode,
            r.plate,
            r.tracking,
            r.writing,
            r.end_to_end,
            r.ffmpeg,
            ratio,
            target,
            r.end_rss
        );
    }
    println!();
    println!(
        "- **decode**: `decode::open` + `next_frame` to RGB and the tracker's working image (what \
         `track`'s decode thread does), all frames, in process\n\
         - **plate**: `BackgroundChoice::Median.build` (what `track` builds before tracking), as \
         frames/s over the clip\n\
         - **tracking**: `run::session::Session::run` (what `track` and `resume` run after the \
         plate) over frames decoded (with their working images) into memory beforehand; includes each segment's rows and \
         state written as it goes\n\
         - **writing**: the run's end: `tracks.csv` joined from the segments, `report.md`, \
         `run.toml`\n\
         - **end to end**: the `mocap2d` binary as a child process, wall clock incl. start-up \
         (`track`; for a keyed row `resume RUN --segment 0` after the keys are written)\n\
         - **FFmpeg → RGB**: `ffmpeg -i clip -pix_fmt rgb24 -f rawvideo /dev/null`, wall clock, \
         each run right before one of the end to end\n\
         - **end to end ÷ FFmpeg**: the median over those pairs of runs of their ratio\n\
         - **peak RSS**: of the end to end (GNU time)"
    );
    if !Path::new(GNU_TIME).is_file() {
        println!("\n_{GNU_TIME} missing (apt package `time`): no peak RSS_");
    }
    println!();
    Ok(())
}

/// Runs every stage of the row `spec`.
fn bench_row(spec: &Spec, reps: usize, bin: &Path) -> Result<RowBench> {
    let dir = &spec.dir;
    let clip = dir.join("clip.mp4");
    let seeds_path = dir.join("joints.toml");
    let (seeds, _) = read_seeds(&seeds_path)?;
    let utf8 = |p: &Path| -> Result<String> {
        Ok(p.to_str()
            .with_context(|| format!("{}: not UTF-8", p.display()))?
            .to_owned())
    };
    let clip_arg = utf8(&clip)?;
    let label = spec
        .label
        .clone()
        .unwrap_or_else(|| dir.display().to_string());
    eprintln!("== {label}");

    // What the decode thread does for `track`: each frame to RGB, then its working image.
    let work = WorkScale::for_seeds(&TrackParams::default(), &seeds);
    let mut frames = 0u64;
    let decode = stage("decode", reps, || {
        let t = Instant::now();
        let mut src = decode::open(&clip, None)?;
        let recycler = decode::Recycler::new();
        src.recycle_from(recycler.clone());
        frames = 0;
        while let Some(f) = src.next_frame()? {
            drop(work.frame(f, Some(&recycler), false));
            frames += 1;
        }
        Ok((frames, t.elapsed().as_secs_f64()))
    })?;
    let info = decode::open(&clip, None)?.info().clone();

    let ffmpeg_cmd = [
        "ffmpeg",
        "-v",
        "error",
        "-y",
        "-i",
        &clip_arg,
        "-pix_fmt",
        "rgb24",
        "-f",
        "rawvideo",
        "/dev/null",
    ];

    let mut bg = None;
    let plate = stage("plate", reps, || {
        let t = Instant::now();
        bg = BackgroundChoice::Median
            .build(&clip, None, info.width, info.height, Some(&seeds))?
            .model;
        Ok((frames, t.elapsed().as_secs_f64()))
    })?;

    // The run folder the tracking and writing stages work in (untimed), with the keys written
    // into its segment files for a keyed row.
    let tmp = tempfile::tempdir()?;
    let run_dir = tmp.path().join("run");
    let mut opts = TrackOptions {
        out: Some(run_dir.clone()),
        ..TrackOptions::new(clip.clone(), seeds_path.clone())
    };
    if let Some((every, _)) = &spec.keys {
        opts.segment_len = *every;
    }
    app::track(&opts, &NoProgress)?;
    let run_arg = utf8(&run_dir)?;
    if let Some((_, gt)) = &spec.keys {
        let ok = Command::new("scripts/keys-from-labels")
            .arg(&run_arg)
            .arg(gt)
            .status()
            .context("running scripts/keys-from-labels (run from the repository's root)")?
            .success();
        if !ok {
            bail!("scripts/keys-from-labels {run_arg} {} failed", gt.display());
        }
    }

    // End to end: the binary, as a user runs it.
    // Each run of it right after a run of FFmpeg's decode of the same clip, so that the ratio
    // compares runs made under the same load.
    let Paired {
        ffmpeg,
        end_to_end,
        ratio,
        rss: end_rss,
    } = if spec.keys.is_some() {
        let cmd = [
            &utf8(bin)?,
            "resume",
            &run_arg,
            "--segment",
            "0",
            "--clip",
            &clip_arg,
            "--quiet",
        ];
        paired_stage("end to end (resume)", reps, frames, &ffmpeg_cmd, &cmd)?
    } else {
        let out = utf8(&tmp.path().join("bin-run"))?;
        let cmd = [
            &utf8(bin)?,
            "track",
            &clip_arg,
            "--seeds",
            &utf8(&seeds_path)?,
            "--out",
            &out,
            "--quiet",
        ];
        paired_stage("end to end (track)", reps, frames, &ffmpeg_cmd, &cmd)?
    };

    // Tracking: the segmented loop over frames already in memory, into the run folder (its
    // segment files, and so its keys, are read as `resume` reads them).
    let mut decoded = Vec::with_capacity(frames as usize);
    let mut src = decode::open(&clip, None)?;
    while let Some(f) = src.next_frame()? {
        decoded.push(work.frame(f, None, spec.keys.is_some()));
    }
    let mut manifest = Manifest::read(&run_dir.join(RUN_TOML))?;
    manifest.complete = false;
    manifest.tracked_segments = 0;
    let (base, _) = read_seeds(&run_dir.join("seeds.toml"))?;
    let tracking = stage("tracking", reps, || {
        let batch = decoded.clone(); // untimed: the tracker takes frames by value
        let items = batch
            .into_iter()
            .enumerate()
            .map(|(i, f)| Ok((i as u64, f)));
        let mut session = Session {
            run_dir: run_dir.clone(),
            names: base.joints.iter().map(|j| j.name.clone()).collect(),
            base: base.clone(),
            params: manifest.params.clone(),
            background: bg.clone(),
            width: manifest.width,
            height: manifest.height,
            manifest: manifest.clone(),
            seed_image: None,
            last_angles: None,
            carried: None,
        };
        let t = Instant::now();
        let done = session.run(items, 0, &NoProgress)?;
        Ok((done.frames, t.elapsed().as_secs_f64()))
    })?;
    drop(decoded);

    // Writing: the run's end, as `Session` writes it once the last segment is tracked.
    let done = Manifest::read(&run_dir.join(RUN_TOML))?;
    let writing = stage("writing", reps, || {
        let t = Instant::now();
        segments::assemble_tracks(&run_dir, done.tracked_segments)?;
        let (_, rep) = report::for_run(&run_dir, &done, &base, report::SUGGESTED)?;
        std::fs::write(run_dir.join("report.md.tmp"), rep.to_markdown())?;
        std::fs::rename(run_dir.join("report.md.tmp"), run_dir.join("report.md"))?;
        done.write(&run_dir)?;
        Ok((done.frames, t.elapsed().as_secs_f64()))
    })?;

    Ok(RowBench {
        label,
        width: info.width,
        height: info.height,
        frames,
        joints: seeds.joints.len(),
        keyframes: keyframes(&clip_arg),
        decode,
        plate,
        tracking,
        writing,
        end_to_end,
        end_rss,
        ffmpeg,
        ratio,
        target: spec.target,
    })
}

/// Number of keyframes in the clip's video stream (ffprobe), if ffprobe runs.
fn keyframes(clip: &str) -> Option<usize> {
    let out = Command::new("ffprobe")
        .args([
            "-v",
            "error",
            "-select_streams",
            "v:0",
            "-skip_frame",
            "nokey",
            "-show_entries",
            "frame=pict_type",
            "-of",
            "csv=p=0",
            clip,
        ])
        .output()
        .ok()?;
    out.status.success().then(|| {
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| !l.trim().is_empty())
            .count()
    })
}

/// Runs `f` (which returns frames done and seconds timed) `reps` times; median frames/s.
fn stage(name: &str, reps: usize, mut f: impl FnMut() -> Result<(u64, f64)>) -> Result<f64> {
    let mut fps = Vec::new();
    for _ in 0..reps {
        let (n, secs) = f().with_context(|| format!("stage {name}"))?;
        fps.push(n as f64 / secs);
        eprintln!("{name}: {n} frames in {secs:.3} s");
    }
    Ok(median(fps))
}

/// What [`paired_stage`] measured: medians of frames/s, the median ratio of the pairs and the
/// largest peak RSS of the end to end.
struct Paired {
    ffmpeg: f64,
    end_to_end: f64,
    ratio: f64,
    rss: String,
}

/// Runs `ffmpeg` then `cmd`, `reps` times in turn (`cmd` under GNU time if present), each over
/// `frames` frames.
fn paired_stage(
    name: &str,
    reps: usize,
    frames: u64,
    ffmpeg: &[&str],
    cmd: &[&str],
) -> Result<Paired> {
    let rss_file = tempfile::NamedTempFile::new()?;
    let (mut base, mut fps, mut ratios, mut rss) = (Vec::new(), Vec::new(), Vec::new(), None);
    for _ in 0..reps {
        let (a, _) = run_child("ffmpeg to RGB", frames, ffmpeg, None)?;
        let (b, kib) = run_child(name, frames, cmd, Some(rss_file.path()))?;
        rss = rss.max(kib);
        ratios.push(b / a);
        base.push(a);
        fps.push(b);
    }
    Ok(Paired {
        ffmpeg: median(base),
        end_to_end: median(fps),
        ratio: median(ratios),
        rss: rss.map_or("n/a".into(), mib),
    })
}

/// Runs `cmd` once (under GNU time, writing to `rss_file`, when given and present): frames/s over
/// `frames` and the peak RSS in KiB.
fn run_child(
    name: &str,
    frames: u64,
    cmd: &[&str],
    rss_file: Option<&Path>,
) -> Result<(f64, Option<u64>)> {
    let timed = rss_file.filter(|_| Path::new(GNU_TIME).is_file());
    let mut c = match timed {
        Some(f) => {
            let mut c = Command::new(GNU_TIME);
            c.arg("-f").arg("%M").arg("-o").arg(f).args(cmd);
            c
        }
        None => {
            let mut c = Command::new(cmd[0]);
            c.args(&cmd[1..]);
            c
        }
    };
    let t = Instant::now();
    let out = c.output().with_context(|| format!("running {}", cmd[0]))?;
    let secs = t.elapsed().as_secs_f64();
    if !out.status.success() {
        bail!(
            "{name}: {} failed: {}",
            cmd.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let kib = match timed {
        Some(f) => Some(std::fs::read_to_string(f)?.trim().parse()?),
        None => None,
    };
    eprintln!("{name}: {frames} frames in {secs:.3} s");
    Ok((frames as f64 / secs, kib))
}

fn mib(kib: u64) -> String {
    format!("{:.0} MiB", kib as f64 / 1024.0)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}
