//! Throughput of each stage of `mocap2d track` on one or more clips, against FFmpeg's own decode.
//!
//!     cargo run --release --example bench -- CLIP_DIR... [--reps 3] [--bin target/release/mocap2d]
//!
//! Each CLIP_DIR holds `clip.mp4` and `joints.toml` (as `mocap2d synth` writes them). Every stage
//! runs `--reps` times; prints one markdown table, a row per clip and stage, of the median
//! frames/s, its ratio to our decode of that clip and to the `ffmpeg` CLI, and the peak RSS.
//! `scripts/bench` renders the clips (640x360 and 1280x720) and runs this.
//!
//! Peak RSS of in-process stages is VmHWM from /proc/self/status, reset before each stage by
//! writing 5 to /proc/self/clear_refs (if the kernel refuses, it is cumulative: marked "≤").
//! Child processes (`ffmpeg`, the `mocap2d` binary) are measured with GNU `/usr/bin/time -f %M`.

use anyhow::{bail, Context, Result};
use mocap2d::app::{self, TrackOptions};
use mocap2d::background::{BackgroundChoice, BACKGROUND_SAMPLES};
use mocap2d::decode;
use mocap2d::progress::NoProgress;
use mocap2d::run::manifest::RUN_TOML;
use mocap2d::run::session::Session;
use mocap2d::run::Manifest;
use mocap2d::seed::read_seeds;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const GNU_TIME: &str = "/usr/bin/time";

const USAGE: &str = "usage: bench CLIP_DIR... [--reps N] [--bin PATH]";

struct Row {
    stage: &'static str,
    fps: f64,
    /// Peak resident set size, formatted.
    rss: String,
    what: String,
}

/// One clip's rows and what the ratios are taken against.
struct ClipBench {
    dir: PathBuf,
    width: u32,
    height: u32,
    frames: u64,
    joints: usize,
    decode_fps: f64,
    cli_fps: f64,
    rows: Vec<Row>,
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let (mut dirs, mut reps, mut bin) = (Vec::new(), 3, None);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--reps" => reps = args.next().context("--reps N")?.parse()?,
            "--bin" => bin = Some(PathBuf::from(args.next().context("--bin PATH")?)),
            _ if !a.starts_with('-') => dirs.push(PathBuf::from(a)),
            _ => bail!(USAGE),
        }
    }
    if dirs.is_empty() || reps == 0 {
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
    let resettable = reset_peak();
    let mut notes = Vec::new();
    let mut clips = Vec::new();
    for dir in &dirs {
        clips.push(bench_clip(dir, reps, &bin, &mut notes)?);
    }

    println!("### Throughput per stage (frames/s: median of {reps} runs)\n");
    for c in &clips {
        println!(
            "- {}x{}: `{}`, {} frames, {} joints",
            c.width,
            c.height,
            c.dir.display(),
            c.frames,
            c.joints
        );
    }
    println!();
    println!("| size | stage | frames/s | × decode | × ffmpeg CLI | peak RSS |");
    println!("|---|---|---:|---:|---:|---:|");
    for c in &clips {
        for r in &c.rows {
            println!(
                "| {}x{} | {} | {:.1} | {:.2} | {:.2} | {} |",
                c.width,
                c.height,
                r.stage,
                r.fps,
                r.fps / c.decode_fps,
                r.fps / c.cli_fps,
                r.rss
            );
        }
    }
    println!();
    // What each stage times: the same for every clip, apart from the background's milliseconds.
    for (i, r) in clips[0].rows.iter().enumerate() {
        let what = if r.stage == "background" {
            let ms: Vec<String> = clips
                .iter()
                .map(|c| {
                    let fps = c.rows[i].fps;
                    format!(
                        "{:.0} ms at {}x{}",
                        1000.0 * c.frames as f64 / fps,
                        c.width,
                        c.height
                    )
                })
                .collect();
            format!("{} ({})", r.what, ms.join(", "))
        } else {
            r.what.clone()
        };
        println!("- **{}**: {what}", r.stage);
    }
    if !resettable {
        notes.push("/proc/self/clear_refs refused: in-process peak RSS is cumulative over the stages above it".into());
    }
    if !Path::new(GNU_TIME).is_file() {
        notes.push(format!(
            "{GNU_TIME} missing (apt package `time`): no peak RSS for child processes"
        ));
    }
    for n in notes {
        println!("\n_{n}_");
    }
    println!();
    Ok(())
}

/// Runs every stage on the clip folder `dir`; `notes` collects what the table cannot show.
fn bench_clip(dir: &Path, reps: usize, bin: &Path, notes: &mut Vec<String>) -> Result<ClipBench> {
    let clip = dir.join("clip.mp4");
    let seeds_path = dir.join("joints.toml");
    let (seeds, _) = read_seeds(&seeds_path)?;
    let mut rows = Vec::new();

    // decode: FFmpeg (ffmpeg-next) decode + conversion to RGB, nothing else.
    let mut frames = 0u64;
    let (fps, rss) = stage("decode", reps, || {
        let t = Instant::now();
        let mut src = decode::open(&clip, None)?;
        frames = 0;
        while src.next_frame()?.is_some() {
            frames += 1;
        }
        Ok((frames, t.elapsed().as_secs_f64()))
    })?;
    let decode_fps = fps;
    let info = decode::open(&clip, None)?.info().clone();
    rows.push(Row {
        stage: "decode",
        fps,
        rss,
        what: "`decode::open` + `next_frame` to RGB, all frames".into(),
    });

    // ffmpeg CLI: the external reference (decode only, no conversion to RGB).
    let clip_arg = clip.to_str().context("clip path is not UTF-8")?;
    let ffmpeg = [
        "ffmpeg", "-v", "error", "-threads", "0", "-i", clip_arg, "-f", "null", "-",
    ];
    let (cli_fps, rss) = child_stage("ffmpeg CLI", reps, frames, &ffmpeg)?;
    rows.push(Row {
        stage: "ffmpeg CLI",
        fps: cli_fps,
        rss,
        what: "`ffmpeg -threads 0 -i clip.mp4 -f null -`, wall clock; no RGB conversion".into(),
    });

    // background: the model `track` builds (sampled frames, temporal median, cleared of the
    // subjects at rest on the seed frame).
    let mut bg = None;
    let (fps, rss) = stage("background", reps, || {
        let t = Instant::now();
        let (model, _) =
            BackgroundChoice::Median.build(&clip, None, info.width, info.height, Some(&seeds))?;
        bg = model;
        Ok((frames, t.elapsed().as_secs_f64()))
    })?;
    rows.push(Row {
        stage: "background",
        fps,
        rss,
        what: format!(
            "`BackgroundChoice::Median.build` ({BACKGROUND_SAMPLES} sampled frames, median, the \
             resting subjects cleared), as frames/s over the clip"
        ),
    });

    // track: the whole command, in process.
    let tmp = tempfile::tempdir()?;
    let mut run = 0;
    let (fps, rss) = stage("track", reps, || {
        run += 1;
        let opts = TrackOptions {
            out: Some(tmp.path().join(format!("run{run}"))),
            ..TrackOptions::new(clip.clone(), seeds_path.clone())
        };
        let t = Instant::now();
        let s = app::track(&opts, &NoProgress)?;
        Ok((s.frames, t.elapsed().as_secs_f64()))
    })?;
    rows.push(Row {
        stage: "track",
        fps,
        rss,
        what: "`app::track` end to end: decode thread, background, tracker, run folder".into(),
    });

    // track (binary): the same, as a child process.
    if bin.is_file() {
        let out = tmp.path().join("bin-run");
        let cmd = [
            bin.to_str().context("binary path is not UTF-8")?,
            "track",
            clip_arg,
            "--seeds",
            seeds_path.to_str().context("seeds path is not UTF-8")?,
            "--out",
            out.to_str().context("temp path is not UTF-8")?,
            "--quiet",
        ];
        let (fps, rss) = child_stage("track (binary)", reps, frames, &cmd)?;
        rows.push(Row {
            stage: "track (binary)",
            fps,
            rss,
            what: "`mocap2d track` as a child process, wall clock incl. start-up".into(),
        });
    } else {
        let note = format!("{}: not built, so no `track (binary)` row", bin.display());
        if !notes.contains(&note) {
            notes.push(note);
        }
    }

    // track-only: the segmented tracking loop `track` and `resume` run (`Session`), over frames
    // already decoded into memory, into the run folder of the track stage (rewritten each run).
    let mut decoded = Vec::with_capacity(frames as usize);
    let mut src = decode::open(&clip, None)?;
    while let Some(f) = src.next_frame()? {
        decoded.push(f);
    }
    let run_dir = tmp.path().join("run1");
    let mut manifest = Manifest::read(&run_dir.join(RUN_TOML))?;
    manifest.complete = false;
    manifest.tracked_segments = 0;
    let (base, _) = read_seeds(&run_dir.join("seeds.toml"))?;
    let (fps, rss) = stage("track-only", reps, || {
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
    rows.push(Row {
        stage: "track-only",
        fps,
        rss,
        what: "`run::session::Session::run` (what `track` runs after decode and background) over \
               decoded frames in memory (RSS holds the clip twice)"
            .into(),
    });

    Ok(ClipBench {
        dir: dir.to_owned(),
        width: info.width,
        height: info.height,
        frames,
        joints: seeds.joints.len(),
        decode_fps,
        cli_fps,
        rows,
    })
}

/// Runs `f` (which returns frames done and seconds timed) `reps` times; median frames/s and the
/// peak RSS over the runs ("≤" when it could not be reset first, so includes earlier stages).
fn stage(
    name: &str,
    reps: usize,
    mut f: impl FnMut() -> Result<(u64, f64)>,
) -> Result<(f64, String)> {
    let reset = reset_peak();
    let mut fps = Vec::new();
    for _ in 0..reps {
        let (n, secs) = f().with_context(|| format!("stage {name}"))?;
        fps.push(n as f64 / secs);
        eprintln!("{name}: {n} frames in {secs:.3} s");
    }
    let rss = match (peak_rss(), reset) {
        (Some(k), true) => mib(k),
        (Some(k), false) => format!("≤ {}", mib(k)),
        (None, _) => "n/a".into(),
    };
    Ok((median(fps), rss))
}

/// Runs `cmd` `reps` times (under GNU time if present); median frames/s over `frames` and the
/// largest peak RSS.
fn child_stage(name: &str, reps: usize, frames: u64, cmd: &[&str]) -> Result<(f64, String)> {
    let gnu_time = Path::new(GNU_TIME).is_file();
    let rss_file = tempfile::NamedTempFile::new()?;
    let mut fps = Vec::new();
    let mut rss = None;
    for _ in 0..reps {
        let mut c = if gnu_time {
            let mut c = Command::new(GNU_TIME);
            c.arg("-f")
                .arg("%M")
                .arg("-o")
                .arg(rss_file.path())
                .args(cmd);
            c
        } else {
            let mut c = Command::new(cmd[0]);
            c.args(&cmd[1..]);
            c
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
        if gnu_time {
            let kib: u64 = std::fs::read_to_string(rss_file.path())?.trim().parse()?;
            rss = rss.max(Some(kib));
        }
        fps.push(frames as f64 / secs);
        eprintln!("{name}: {frames} frames in {secs:.3} s");
    }
    Ok((median(fps), rss.map_or("n/a".into(), mib)))
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

/// Resets this process's peak RSS (VmHWM) to its current RSS; false if the kernel refuses.
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// This process's peak RSS (VmHWM, KiB).
fn peak_rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}
