//! The `mocap2d` binary: parse flags, call the library, report, exit (0 ok, 2 user error, 1
//! failure, 130 interrupted by Ctrl-C).

use clap::Parser;
use cli::{BatchArgs, Cli, Command};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use mocap2d::app;
use mocap2d::batch::{BatchProgress, ClipOutcome, Status};
use mocap2d::error::EXIT_INTERRUPTED;
use mocap2d::progress::Progress;
use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

mod cli;

/// Set by the first Ctrl-C (SIGINT) or SIGTERM: work stops at its next frame (see [`Bars`]).
static STOP: AtomicBool = AtomicBool::new(false);

/// Set once work that polls [`STOP`] has started (its first progress stage); until then a Ctrl-C
/// exits at once (quick commands never poll, and their files are written atomically anyway).
static POLLED: AtomicBool = AtomicBool::new(false);

/// `println!` that ends the program quietly with success when stdout is a closed pipe
/// (`mocap2d eval RUN --gt gt.csv --per-joint | head`), as ripgrep does, instead of panicking;
/// any other write error is reported and exits 1.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout().lock(), $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
            eprintln!("mocap2d: cannot write to standard output: {e}");
            std::process::exit(1);
        }
    }};
}

/// The first Ctrl-C asks the work to stop at its next frame and leave its output consistent;
/// a second one exits at once (output files are written through temp files, so even then no
/// file is left half-written under its real name).
fn handle_interrupts() {
    let installed = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) || !POLLED.load(Ordering::SeqCst) {
            eprintln!("mocap2d: interrupted; exiting now");
            std::process::exit(EXIT_INTERRUPTED.into());
        }
        eprintln!(
            "mocap2d: interrupted; stopping after the current frame (Ctrl-C again to quit now)"
        );
    });
    if let Err(e) = installed {
        eprintln!("mocap2d: warning: Ctrl-C will stop without cleaning up ({e})");
    }
}

/// indicatif bars on stderr, one per stage.
struct Bars {
    on: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl Progress for Bars {
    fn start(&self, stage: &str, total: Option<u64>) {
        POLLED.store(true, Ordering::SeqCst);
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
        !STOP.load(Ordering::SeqCst)
    }
    fn finish(&self) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish_and_clear();
        }
    }
}

/// Batch progress: a total bar above a bar per running clip, in one `MultiProgress` (drawing
/// nothing when bars are off); a failed clip's error line is printed above the bars.
struct BatchBars {
    multi: MultiProgress,
    total: ProgressBar,
}

impl BatchBars {
    fn new(on: bool) -> BatchBars {
        let multi = MultiProgress::with_draw_target(match on {
            true => ProgressDrawTarget::stderr(),
            false => ProgressDrawTarget::hidden(),
        });
        let total = multi.add(ProgressBar::new(0).with_style(style(
            "{msg:>24} [{bar:30}] {pos}/{len} clips, elapsed {elapsed}, eta {eta}",
        )));
        total.set_message("batch");
        BatchBars { multi, total }
    }
}

fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ")
}

impl BatchProgress for BatchBars {
    fn begin(&self, clips: usize) {
        // From here on a Ctrl-C stops the batch cleanly (see `stopped`).
        POLLED.store(true, Ordering::SeqCst);
        self.total.set_length(clips as u64);
    }
    fn stopped(&self) -> bool {
        STOP.load(Ordering::SeqCst)
    }
    fn clip_started(&self, clip: &Path) -> Box<dyn Progress + '_> {
        let name = clip.file_name().unwrap_or(clip.as_os_str());
        Box::new(ClipBar {
            owner: self,
            label: name.to_string_lossy().into_owned(),
            bar: Mutex::new(None),
        })
    }
    fn clip_finished(&self, o: &ClipOutcome) {
        self.total.inc(1);
        if let Status::Failed { message, .. } = &o.status {
            self.multi
                .suspend(|| eprintln!("mocap2d: {}: {message}", o.clip.display()));
        }
    }
}

/// One running clip's bar: a bar per stage, below the total.
struct ClipBar<'a> {
    owner: &'a BatchBars,
    label: String,
    bar: Mutex<Option<ProgressBar>>,
}

impl Progress for ClipBar<'_> {
    fn start(&self, stage: &str, total: Option<u64>) {
        self.finish();
        let bar = match total {
            Some(n) => ProgressBar::new(n)
                .with_style(style("{msg:>24} [{bar:30}] {pos}/{len} frames {per_sec}")),
            None => ProgressBar::new_spinner().with_style(
                ProgressStyle::with_template("{msg:>24} {spinner}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            ),
        };
        let label: String = self.label.chars().take(14).collect();
        bar.set_message(format!("{label} {stage}"));
        let bar = self.owner.multi.add(bar);
        *self.bar.lock().unwrap_or_else(|e| e.into_inner()) = Some(bar);
    }
    fn advance(&self, n: u64) -> bool {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            b.inc(n);
        }
        !STOP.load(Ordering::SeqCst)
    }
    fn finish(&self) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish_and_clear();
            self.owner.multi.remove(&b);
        }
    }
}

impl Drop for ClipBar<'_> {
    fn drop(&mut self) {
        self.finish();
    }
}

/// `mocap2d batch`: plan, run, print the table (stdout), write the CSV; the exit code says
/// whether any clip failed (see [`mocap2d::batch::exit_code`]). Interrupted by Ctrl-C: one line
/// saying how far it got, no table and no CSV, exit code 130.
fn batch(a: BatchArgs, bars_on: bool) -> mocap2d::Result<ExitCode> {
    let opts = a.options()?;
    let plan = mocap2d::batch::plan(&opts)?;
    let summary_path = a.summary_path();
    let shard = a.shard.map(|s| format!(" (shard {s})")).unwrap_or_default();
    eprintln!(
        "batch: {} of {} clips{shard}, {} at a time",
        plan.clips.len(),
        plan.total,
        opts.jobs.min(plan.clips.len()).max(1)
    );
    let bars = BatchBars::new(bars_on);
    let outcomes = mocap2d::batch::run(&opts, &plan, &bars)?;
    bars.total.finish_and_clear();
    if let Some(msg) = mocap2d::batch::summary::interrupted(&outcomes, plan.clips.len()) {
        eprintln!("mocap2d: {msg}");
        return Ok(ExitCode::from(EXIT_INTERRUPTED));
    }
    print!("{}", mocap2d::batch::summary::table(&outcomes));
    if let Some(dir) = summary_path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| mocap2d::Error::io(dir, e))?;
    }
    mocap2d::batch::summary::write_csv(&summary_path, &outcomes)?;
    eprintln!("summary: {}", summary_path.display());
    Ok(ExitCode::from(mocap2d::batch::exit_code(&outcomes)))
}

fn run(cli: Cli) -> mocap2d::Result<ExitCode> {
    let bars = Bars {
        on: !cli.quiet && std::io::stderr().is_terminal(),
        bar: Mutex::new(None),
    };
    match cli.command {
        Command::Batch(a) => return batch(a, bars.on),
        Command::Seed(a) => {
            let opts = a.options()?;
            let s = app::seed(&opts)?;
            let unsure = if s.unsure.is_empty() {
                String::new()
            } else {
                format!(
                    "; the network is unsure of {}: check them",
                    s.unsure.join(", ")
                )
            };
            eprintln!(
                "wrote {} joints of the {} on frame {} to {}{unsure}",
                s.joints,
                if s.people > 1 {
                    format!("chosen person of {}", s.people)
                } else {
                    "person".into()
                },
                opts.frame,
                opts.out.display()
            );
        }
        Command::Track(a) => {
            let (opts, other) = a.options()?;
            let s = app::track_into(&opts, other, &bars)?;
            print_summary("tracked", &s);
        }
        Command::Resume(a) => {
            let opts = a.options()?;
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
            print!("{}", app::report(&a.run, a.keys as usize)?.to_markdown());
        }
        Command::Synth(a) => {
            let opts = a.options();
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
        Command::Retarget(a) if a.check => {
            for line in app::check_character(&a.target, a.run.as_deref())? {
                out!("{line}");
            }
        }
        Command::Retarget(a) => {
            // Cannot fail: clap requires RUN unless --check (the arm above).
            let run = a.run.clone().expect("RUN required without --check");
            let s = app::retarget(&run, &a.target, &a.options())?;
            eprintln!("bones (target <- source):");
            for line in &s.mapping {
                eprintln!("  {line}");
            }
            eprintln!(
                "clean-up: {} tracked points dropped as jumps and filled (`filled` in clean.csv)",
                s.dropped
            );
            for (foot, on) in &s.contacts {
                eprintln!("contacts: {foot} on the ground {on} of {} frames", s.frames);
            }
            eprintln!(
                "retargeted {} joints over {} frames (scale {:.3} px per image px) -> {}",
                s.joints,
                s.frames,
                s.scale,
                s.dir.display()
            );
        }
        Command::Render(a) => {
            let opts = a.options();
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
            if let Some(f) = s.defect_frames.first() {
                eprintln!(
                    "warning: {} frames show a folded or cracked triangle (first: frame {f})",
                    s.defect_frames.len()
                );
            }
        }
        Command::Export(a) => {
            let format = a.format;
            let s = app::export(&a.options())?;
            for line in &s.matches {
                eprintln!("  {line}");
            }
            let files: Vec<String> = s.files.iter().map(|p| p.display().to_string()).collect();
            eprintln!(
                "exported {} joints over {} frames as {} -> {}",
                s.joints,
                s.frames,
                format.name(),
                files.join(" and ")
            );
            if !s.note.is_empty() {
                eprintln!("note: {}", s.note);
            }
            for w in &s.warnings {
                eprintln!("warning: {w}");
            }
        }
        Command::Guide(a) => {
            let opts = a.options();
            let s = app::guide(&opts)?;
            let seeds = opts
                .seeds_out
                .as_ref()
                .map(|p| format!(" and {}", p.display()))
                .unwrap_or_default();
            eprintln!(
                "frame {}: silhouette {} px, {} end points, {} branch points -> {}{seeds}",
                opts.frame,
                s.silhouette_px,
                s.end_points,
                s.branch_points,
                opts.out.display()
            );
        }
        Command::Review(a) => {
            let s = app::review(&a.run, a.clip.as_deref(), &bars)?;
            eprintln!(
                "reviewed {} frames -> {} (overlay.mp4, confidence.png, segments.png: {})",
                s.frames,
                s.dir.display(),
                s.sheet_note
            );
        }
        Command::Serve(a) => {
            // Ctrl-C stops the server cleanly: a resume started from the page stops at its next
            // checkpoint and the requests under way are answered (a second Ctrl-C quits now).
            let stop = &STOP;
            POLLED.store(true, Ordering::SeqCst);
            let ready = |addr| {
                let what = match &a.seeds_out {
                    Some(out) => format!("seeding {} -> {}", a.run.display(), out.display()),
                    None => format!("serving {}", a.run.display()),
                };
                eprintln!("{what} on http://{addr}/ (this machine only); Ctrl-C to stop");
            };
            match (&a.seeds_out, &a.skeleton) {
                (Some(out), Some(skeleton)) => {
                    app::serve_seeds(&a.run, skeleton, out, a.port, stop, ready)?
                }
                _ => app::serve(&a.run, a.clip.as_deref(), a.port, stop, ready)?,
            }
            eprintln!("mocap2d: serve stopped");
        }
        Command::Eval(a) => {
            for line in app::eval(&a.run, &a.gt, a.per_joint)? {
                out!("{line}");
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Prints what `track` or `resume` did, and the report's summary (stdout).
fn print_summary(what: &str, s: &app::TrackSummary) {
    if !s.note.is_empty() {
        eprintln!("note: {}", s.note);
    }
    if let Some(stop) = &s.decode_stop {
        eprintln!("warning: the clip is damaged or cut short: {stop}");
    }
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
    out!("{}", s.report);
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    handle_interrupts();
    match run(cli) {
        Ok(code) => code,
        Err(e @ mocap2d::Error::Interrupted) => {
            eprintln!("mocap2d: {e}");
            ExitCode::from(EXIT_INTERRUPTED)
        }
        Err(e) => {
            eprintln!("mocap2d: {e}");
            // Each message is said once: a variant whose message includes a cause's (an I/O
            // error's OS message) does not also give it as its source.
            let mut src = std::error::Error::source(&e);
            while let Some(s) = src {
                eprintln!("  caused by: {s}");
                src = s.source();
            }
            ExitCode::from(if e.is_user_error() { 2 } else { 1 })
        }
    }
}
