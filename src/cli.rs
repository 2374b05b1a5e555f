//! Command-line interface of the binary (clap derive): the flags ([`args`]) and the one step
//! that turns them into the library's options ([`options`]).

use clap::{Parser, Subcommand};

mod args;
mod options;

pub use args::*;

#[derive(Debug, Parser)]
#[command(
    name = "mocap2d",
    version,
    about = "Capture joint motion from a 2D video and retarget it"
)]
pub struct Cli {
    /// No progress bars (they are also off when stderr is not a terminal).
    #[arg(long, short, global = true)]
    pub quiet: bool,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// A person's seed file from the pose network: the 17 COCO joints on one frame.
    Seed(SeedArgs),
    /// Track the joints of a seed file through a clip (video file or folder of numbered frames).
    Track(TrackArgs),
    /// Carry on a run after a crash, or re-track it from a corrected segment file.
    Resume(ResumeArgs),
    /// Print a run's correction report (segments ranked by need of correction) as Markdown.
    Report(ReportArgs),
    /// Render a synthetic test clip with ground truth (clip.mp4, gt.csv, joints.toml, background.png).
    Synth(SynthArgs),
    /// Compare a run's tracks with ground truth (frame,joint,x,y): median, p95, PCK@5/@10.
    Eval(EvalArgs),
    /// Retarget a run's motion onto a target character: RUN/retarget/pose.csv and bones.csv.
    Retarget(RetargetArgs),
    /// Deform and draw the target character along RUN/retarget/pose.csv: a video and/or PNGs.
    Render(RenderArgs),
    /// Export a run for animation tools: Spine, DragonBones, BVH, DeepLabCut CSV or JSON.
    Export(ExportArgs),
    /// Seeding guide for one frame: silhouette, curve skeleton, numbered end and branch points
    /// (PNG), and optionally a starter seed file with one joint per point.
    Guide(GuideArgs),
    /// Review a run: RUN/review/overlay.mp4, confidence.png and segments.png.
    Review(ReviewArgs),
    /// Local page (http://127.0.0.1:PORT) to correct a run's segment files in the browser, or
    /// (--seeds-out) to place a bare clip's first seeds on any frame.
    Serve(ServeArgs),
    /// Track many clips (optionally retarget and render them): one run folder per clip, a
    /// summary table and batch-summary.csv; --shard splits the batch over machines.
    Batch(BatchArgs),
}

#[cfg(test)]
mod tests;
