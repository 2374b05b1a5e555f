//! The `mocap2d` binary: parse flags, call the library, report, exit (0 ok, 2 user error, 1 failure).

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use mocap2d::app;
use mocap2d::cli::{Cli, Command};
use mocap2d::progress::Progress;
use std::io::IsTerminal;
use std::process::ExitCode;
use std::sync::Mutex;

/// indicatif bars on stderr, one per stage.
struct Bars {
    on: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl Progress for Bars {
    fn start(&self, stage: &str, total: Option<u64>) {
        if !self.on {
            return;
        }
        let bar = match total {
            Some(n) => ProgressBar::new(n).with_style(
                ProgressStyle::with_template(
                    "{msg:>10} [{bar:40}] {pos}/{len} frames {per_sec} eta {eta}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
            ),
            None => ProgressBar::new_spinner(),
        };
        bar.set_message(stage.to_string());
        *self.bar.lock().unwrap_or_else(|e| e.into_inner()) = Some(bar);
    }
    fn advance(&self, n: u64) -> bool {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            b.inc(n);
        }
        true
    }
    fn finish(&self) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish_and_clear();
        }
    }
}

fn run(cli: Cli) -> mocap2d::Result<()> {
    let bars = Bars {
        on: !cli.quiet && std::io::stderr().is_terminal(),
        bar: Mutex::new(None),
    };
    match cli.command {
        Command::Track(a) => {
            let opts = app::TrackOptions {
                params: mocap2d::cli::read_params(a.params.as_deref())?,
                clip: a.clip,
                seeds: a.seeds,
                out: a.out,
                fps: a.fps,
                background: a.background,
                no_background: a.no_background,
                segment_len: a.segment_len,
            };
            let s = app::track(&opts, &bars)?;
            print_summary("tracked", &s);
        }
        Command::Resume(a) => {
            let opts = app::ResumeOptions {
                params: match &a.params {
                    Some(p) => Some(mocap2d::cli::read_params(Some(p))?),
                    None => None,
                },
                run: a.run,
                segment: a.segment,
                clip: a.clip,
            };
            match app::resume(&opts, &bars)? {
                Some(s) => print_summary("resumed:", &s),
                None => eprintln!(
                    "{}: nothing to do: the run is complete and no segment file changed since it \
                     was tracked (edit one, or give --segment K)",
                    opts.run.display()
                ),
            }
        }
        Command::Report(a) => {
            print!("{}", app::report(&a.run)?.to_markdown());
        }
        Command::Synth(a) => {
            let opts = mocap2d::synth::SynthOptions {
                scenario: a.scenario,
                width: a.size.0,
                height: a.size.1,
                seed: a.seed,
                frames: a.frames,
            };
            opts.validate()?;
            let clip = mocap2d::synth::render(&opts);
            mocap2d::synth::write_clip(&clip, &a.out)?;
            eprintln!(
                "wrote {} frames of {} to {}",
                clip.frames.len(),
                a.scenario,
                a.out.display()
            );
        }
        Command::Retarget(a) => {
            let s = app::retarget(&a.run, &a.target, &a.options())?;
            eprintln!(
                "retargeted {} joints over {} frames (scale {:.3} px per image px) -> {}",
                s.joints,
                s.frames,
                s.scale,
                s.dir.display()
            );
        }
        Command::Render(a) => {
            let opts = app::RenderOptions {
                run: a.run,
                target: a.target,
                out: a.out,
                frames_dir: a.frames_dir,
                deform: mocap2d::deform::DeformOptions {
                    area_preservation: !a.no_area_preservation,
                    stage_two: true,
                },
            };
            let s = app::render(&opts, &bars)?;
            let to: Vec<String> = [&opts.out, &opts.frames_dir]
                .into_iter()
                .flatten()
                .map(|p| p.display().to_string())
                .collect();
            eprintln!(
                "rendered {} frames ({} vertices, {} triangles, {} in joint areas) -> {}",
                s.frames,
                s.vertices,
                s.triangles,
                s.joint_vertices,
                to.join(" and ")
            );
        }
        Command::Eval(a) => {
            for line in app::eval(&a.run, &a.gt, a.per_joint)? {
                println!("{line}");
            }
        }
    }
    Ok(())
}

/// Prints what `track` or `resume` did, and the report's summary (stdout).
fn print_summary(what: &str, s: &app::TrackSummary) {
    let counts: Vec<String> = s
        .status_counts
        .iter()
        .map(|(k, v)| format!("{k} {v}"))
        .collect();
    eprintln!(
        "{what} {} joints over {} frames in {} segments -> {} ({})",
        s.joints,
        s.tracked_frames,
        s.segments,
        s.run_dir.display(),
        counts.join(", ")
    );
    println!("{}", s.report);
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("mocap2d: {e}");
            let mut src = std::error::Error::source(&e);
            while let Some(s) = src {
                eprintln!("  caused by: {s}");
                src = s.source();
            }
            ExitCode::from(if e.is_user_error() { 2 } else { 1 })
        }
    }
}
