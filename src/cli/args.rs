//! The command line's flags, one struct per command (clap derive), and the parsers of their
//! values. What the flags ask for becomes the library's options in [`super::options`].

use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct BatchArgs {
    /// Video files, folders of numbered frames, or folders of clips (their .mp4 .mov .mkv .avi
    /// .webm files and sub-folders of PNG/JPEG frames).
    #[arg(required = true, value_name = "CLIP_OR_FOLDER")]
    pub inputs: Vec<PathBuf>,
    /// Each clip's seed file, a path template: {dir} (the clip's folder), {stem} (its name
    /// without extension), {name} (its file name); e.g. "{dir}/{stem}.toml".
    #[arg(long, value_name = "TEMPLATE")]
    pub seeds: String,
    /// Clips processed at once; each clip's stages share the cores left [default: cores].
    #[arg(long, short = 'j', value_name = "N",
          value_parser = clap::value_parser!(u16).range(1..=1024))]
    pub jobs: Option<u16>,
    /// Process only shard INDEX of COUNT (from 1): every COUNT-th clip of the sorted list.
    #[arg(long, value_name = "INDEX/COUNT")]
    pub shard: Option<mocap2d::batch::Shard>,
    /// Write the run folders (<stem>.mocap) here instead of beside each clip.
    #[arg(long, value_name = "DIR")]
    pub out_dir: Option<PathBuf>,
    /// Summary CSV to write [default: batch-summary.csv, or batch-summary-IofN.csv
    /// with --shard; in --out-dir if given].
    #[arg(long, value_name = "CSV")]
    pub summary: Option<PathBuf>,
    /// Frame rate in frames/s (image folders: default 30; videos: overrides the stream's).
    #[arg(long)]
    pub fps: Option<f64>,
    /// Do not subtract the background.
    #[arg(long)]
    pub no_background: bool,
    /// Tracking parameters (TOML, keys as in run.toml's [params]) for every clip.
    #[arg(long, value_name = "TOML")]
    pub params: Option<PathBuf>,
    /// Retarget every run onto this target character (RUN/retarget/, default options).
    #[arg(long, value_name = "CHARACTER.toml")]
    pub retarget: Option<PathBuf>,
    /// Also render every retargeted run to RUN/render.mp4.
    #[arg(long, requires = "retarget")]
    pub render: bool,
}

#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// Run folder written by `mocap2d track` (and, for spine/dragonbones/bvh, `mocap2d retarget`).
    pub run: PathBuf,
    /// Output format.
    #[arg(long, value_enum)]
    pub format: mocap2d::export::Format,
    /// Target character file given to `mocap2d retarget` (spine, dragonbones: its image is the
    /// skin; default: the one RUN/retarget/retarget.toml names).
    #[arg(long)]
    pub target: Option<PathBuf>,
    /// File to write (spine also writes NAME.atlas and the image beside it; dragonbones
    /// NAME_ske.json, NAME_tex.json and NAME_tex.png).
    #[arg(long)]
    pub out: PathBuf,
    /// Spine, dragonbones: key each channel on as few frames as reproduce every frame within
    /// this many px (and degrees for rotations).
    #[arg(long, value_name = "PX", default_value_t = mocap2d::export::keys::DEFAULT_TOLERANCE,
          value_parser = parse_tolerance, conflicts_with = "every_frame")]
    pub tolerance: f64,
    /// Spine, dragonbones: one key per frame on every channel (no key reduction).
    #[arg(long)]
    pub every_frame: bool,
    /// Spine, dragonbones: straight lines between the reduced keys instead of Bézier curves
    /// (more keys; for tools that do not read curves).
    #[arg(long, conflicts_with = "every_frame")]
    pub linear: bool,
    /// Spine: your own Spine 4.2 skeleton JSON; --out gets a copy of it with the motion added as
    /// one animation (their bones, slots, skins and other animations unchanged).
    #[arg(long, value_name = "SKELETON.json")]
    pub skeleton: Option<PathBuf>,
    /// With --skeleton: the animation's name (an animation of that name is replaced).
    #[arg(long, default_value = "mocap", requires = "skeleton")]
    pub animation: String,
    /// With --skeleton: their bone BONE turns at the character's joint PIVOT (repeatable;
    /// PIVOT>JOINT when several bones turn there; a root joint moves the bone); other bones map
    /// by name and structure.
    #[arg(long, value_name = "BONE=PIVOT", requires = "skeleton", value_parser = parse_bone_pair)]
    pub bone: Vec<(String, String)>,
    /// With --skeleton: the bone mapping from this file (as the export writes it beside --out,
    /// NAME.bones.toml); --bone overrides its lines.
    #[arg(long, value_name = "FILE", requires = "skeleton")]
    pub bone_map: Option<PathBuf>,
    /// With --skeleton: keep IK constraints over mapped bones and key their targets instead
    /// (by default the animation keys their mix to 0).
    #[arg(long, requires = "skeleton")]
    pub keep_ik: bool,
}

fn parse_bone_pair(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((a, b)) if !a.trim().is_empty() && !b.trim().is_empty() => {
            Ok((a.trim().to_owned(), b.trim().to_owned()))
        }
        _ => Err(format!(
            "{s:?}: expected THEIR_BONE=PIVOT (the joint it turns at), e.g. \
             front-upper-arm=left_shoulder"
        )),
    }
}

fn parse_tolerance(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 100.0 => Ok(v),
        _ => Err(format!(
            "{s:?}: expected a tolerance above 0 and at most 100 (px and degrees), e.g. 0.5; \
             --every-frame keys every frame"
        )),
    }
}

#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    /// Run folder written by `mocap2d track` (its segments/ folder is what the page edits); with
    /// --seeds-out, the clip to place the first seeds on.
    #[arg(value_name = "RUN_OR_CLIP")]
    pub run: PathBuf,
    /// Port on 127.0.0.1 (0: any free port).
    #[arg(long, default_value_t = mocap2d::app::DEFAULT_PORT)]
    pub port: u16,
    /// The clip the run was tracked from [default: the path in run.toml, or its name beside
    /// the run folder].
    #[arg(long, conflicts_with = "seeds_out")]
    pub clip: Option<PathBuf>,
    /// Place the first seeds on the clip RUN_OR_CLIP, on any frame, and save them to this new
    /// seed file (never overwritten once it exists).
    #[arg(long, value_name = "SEEDS.toml", requires = "skeleton")]
    pub seeds_out: Option<PathBuf>,
    /// With --seeds-out: the joints to place, a seed file (its names, parents and rectangles,
    /// e.g. the starter of `mocap2d guide --seeds-out`).
    #[arg(long, value_name = "SKELETON.toml", requires = "seeds_out")]
    pub skeleton: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
pub struct ReviewArgs {
    /// Run folder written by `mocap2d track`.
    pub run: PathBuf,
    /// The clip the run was tracked from [default: the path in run.toml, or its name beside
    /// the run folder].
    #[arg(long)]
    pub clip: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
pub struct GuideArgs {
    /// The clip: a video FFmpeg decodes, or a folder of numbered PNG/JPEG frames.
    pub clip: PathBuf,
    /// Frame to draw the guide on (0 = first).
    #[arg(long, default_value_t = 0)]
    pub frame: u64,
    /// PNG to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write a starter seed file (joints j0, j1, … at the points); never overwrites a file.
    #[arg(long, value_name = "TOML")]
    pub seeds_out: Option<PathBuf>,
    /// Frame rate in frames/s (image folders: default 30; videos: overrides the stream's).
    #[arg(long)]
    pub fps: Option<f64>,
    /// A clean plate (image of the background alone, clip-sized) instead of the temporal median.
    #[arg(long, value_name = "PLATE")]
    pub background: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
pub struct RetargetArgs {
    /// Run folder written by `mocap2d track` (optional with --check).
    #[arg(required_unless_present = "check")]
    pub run: Option<PathBuf>,
    /// Target character file (TOML; see docs/formats.md, "Target character file").
    #[arg(long)]
    pub target: PathBuf,
    /// Only check the target character file (and, with RUN, show which source bone would drive
    /// which bone); write nothing.
    #[arg(long)]
    pub check: bool,
    /// Cartoon animation filter strength A (0 = off; 1 to 3 shows): anticipation and
    /// follow-through on every bone's length and angle.
    #[arg(long, value_name = "A", value_parser = parse_strength)]
    pub cartoon: Option<f64>,
    /// Width σ of the cartoon filter's Gaussian, in frames.
    #[arg(long, value_name = "S", default_value_t = mocap2d::retarget::DEFAULT_CARTOON_SIGMA,
          value_parser = parse_sigma, requires = "cartoon")]
    pub cartoon_sigma: f64,
    /// Smooth the tracks first: median:N (N odd frames) or gaussian:S (σ in frames).
    #[arg(long, value_name = "KIND:N")]
    pub smooth: Option<mocap2d::retarget::Smooth>,
    /// Clean-up strength: tracked points that jump as no limb can are dropped and filled, then
    /// every track goes through a Savitzky–Golay filter of 2N+1 frames; 0 turns it off.
    #[arg(long, value_name = "N", default_value_t = mocap2d::retarget::cleanup::DEFAULT_STRENGTH,
          value_parser = parse_clean)]
    pub clean: usize,
    /// Bones follow the tracked bones' changes of length (squash and stretch, for a cartoon);
    /// by default every bone keeps the character's length.
    #[arg(long)]
    pub stretch: bool,
    /// With --stretch: keep the character's size when the subject moves towards or away from
    /// the camera (bone lengths follow relative to each other, not the whole body's growing or
    /// shrinking).
    #[arg(long, requires = "stretch")]
    pub keep_size: bool,
    /// Do not hold the feet still while they are on the ground (contacts.csv is written anyway).
    #[arg(long)]
    pub no_plant: bool,
}

#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// Run folder, retargeted with `mocap2d retarget`.
    pub run: PathBuf,
    /// Target character file: the one given to `mocap2d retarget`.
    #[arg(long)]
    pub target: PathBuf,
    /// Video to write (.mp4, .mkv, .mov or .avi; H.264).
    #[arg(long, required_unless_present = "frames_dir")]
    pub out: Option<PathBuf>,
    /// Also (or only) write every frame as a PNG into this folder (000123.png = frame 123).
    #[arg(long, value_name = "DIR")]
    pub frames_dir: Option<PathBuf>,
    /// Needles keep their length when bones stretch (no squash-and-stretch area preservation).
    #[arg(long)]
    pub no_area_preservation: bool,
}

fn parse_clean(s: &str) -> Result<usize, String> {
    let max = mocap2d::retarget::cleanup::MAX_STRENGTH;
    match s.parse::<usize>() {
        Ok(v) if v <= max => Ok(v),
        _ => Err(format!(
            "{s:?}: expected a whole number of frames from 0 (off) to {max}, e.g. 3"
        )),
    }
}

fn parse_strength(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..=20.0).contains(&v) => Ok(v),
        _ => Err(format!("{s:?}: expected a strength from 0 to 20, e.g. 1.5")),
    }
}

fn parse_sigma(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 60.0 => Ok(v),
        _ => Err(format!(
            "{s:?}: expected a width in frames above 0, at most 60, e.g. 4"
        )),
    }
}

#[derive(Debug, clap::Args)]
pub struct TrackArgs {
    /// The clip: a video FFmpeg decodes, or a folder of numbered PNG/JPEG frames.
    pub clip: PathBuf,
    /// Seed file: one rectangle per joint on the seed frame (see docs/formats.md, "Seed file").
    #[arg(
        long,
        required_unless_present = "seeds_from_dlc",
        conflicts_with = "seeds_from_dlc"
    )]
    pub seeds: Option<PathBuf>,
    /// Seeds from a DeepLabCut CSV (labels or predictions) instead: the labels of --seed-frame.
    #[arg(long, value_name = "CSV", requires = "seed_frame")]
    pub seeds_from_dlc: Option<PathBuf>,
    /// The frame of the DeepLabCut CSV whose labels become the seeds (and the run's seed frame).
    #[arg(long, value_name = "N", requires = "seeds_from_dlc")]
    pub seed_frame: Option<u64>,
    /// Side of the seed rectangles made from DeepLabCut labels, px.
    #[arg(long, value_name = "PX", requires = "seeds_from_dlc",
          default_value_t = mocap2d::seed::dlc::DEFAULT_SEED_SIZE)]
    pub seed_size: u32,
    /// Parent links for the DeepLabCut bodyparts: TOML [[joint]] tables with name and parent
    /// (a seed file works) [default: a chain in column order].
    #[arg(long, value_name = "TOML", requires = "seeds_from_dlc")]
    pub skeleton: Option<PathBuf>,
    /// Run folder to write [default: <clip stem>.mocap beside the clip].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Frame rate in frames/s (image folders: default 30; videos: overrides the stream's).
    #[arg(long)]
    pub fps: Option<f64>,
    /// A clean plate (image of the background alone, clip-sized) instead of the temporal median.
    #[arg(long, value_name = "PLATE")]
    pub background: Option<PathBuf>,
    /// Do not subtract the background.
    #[arg(long, conflicts_with = "background")]
    pub no_background: bool,
    /// Tracking parameters (TOML, keys as in run.toml's [params]); unset keys keep their defaults.
    #[arg(long, value_name = "TOML")]
    pub params: Option<PathBuf>,
    /// Frames per segment: every N frames a checkpoint and a file to correct
    /// (segments/NNN.toml); tracking restarts there only from a corrected file.
    #[arg(long, value_name = "N", default_value_t = mocap2d::app::DEFAULT_SEGMENT_LEN,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub segment_len: u64,
    /// Replace the run folder even when it holds the run of another clip (its tracks.csv,
    /// report.md, run.toml and seeds.toml are kept in history/).
    #[arg(long)]
    pub replace: bool,
    /// The learned human pose cue: auto (a person's joint names, the network agreeing with the
    /// seeds on the seed frame), on (a person's joint names), off [default: --params', else auto].
    #[arg(long, value_name = "MODE", value_parser = ["auto", "on", "off"])]
    pub pose: Option<String>,
}

#[derive(Debug, clap::Args)]
pub struct SeedArgs {
    /// The clip: a video FFmpeg decodes, or a folder of numbered PNG/JPEG frames.
    pub clip: PathBuf,
    /// The frame to seed on (0-based).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub frame: u64,
    /// The seed file to write.
    #[arg(long, value_name = "TOML")]
    pub out: PathBuf,
    /// With several people, the one inside this rectangle (px: left, top, width, height)
    /// [default: the largest].
    #[arg(long = "box", value_name = "X,Y,W,H", value_delimiter = ',')]
    pub within: Option<Vec<f32>>,
    /// Frame rate in frames/s for image folders.
    #[arg(long)]
    pub fps: Option<f64>,
}

#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// Run folder written by `mocap2d track`.
    pub run: PathBuf,
    /// How many frames you mean to key: the report names the K frames that, keyed together,
    /// leave the least doubt (with the keys already placed).
    #[arg(long, value_name = "K", default_value_t = mocap2d::run::report::SUGGESTED as u64,
          value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub keys: u64,
}

#[derive(Debug, clap::Args)]
pub struct ResumeArgs {
    /// Run folder written by `mocap2d track`.
    pub run: PathBuf,
    /// Re-track from segment K on (after editing RUN/segments/K.toml); frames before it stay as
    /// they are [default: where the run stopped, or the first segment edited since].
    #[arg(long, value_name = "K")]
    pub segment: Option<u64>,
    /// The clip, if it moved since `track` (it must be the same clip).
    #[arg(long)]
    pub clip: Option<PathBuf>,
    /// Parameter file the run should have been tracked with (checked against run.toml).
    #[arg(long, value_name = "TOML")]
    pub params: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// Run folder written by `mocap2d track`.
    pub run: PathBuf,
    /// Ground truth CSV with header frame,joint,x,y (px).
    #[arg(long)]
    pub gt: PathBuf,
    /// Also print one line per joint.
    #[arg(long)]
    pub per_joint: bool,
}

#[derive(Debug, clap::Args)]
pub struct SynthArgs {
    /// Scenario: walk, occlude, fast, squash, noisy, long.
    pub scenario: mocap2d::synth::Scenario,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Frame size in px, WIDTHxHEIGHT.
    #[arg(long, default_value = "640x360", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Random seed of the motion and textures.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of frames [default: the scenario's].
    #[arg(long)]
    pub frames: Option<u32>,
}

/// Parses `WIDTHxHEIGHT` (px).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("{s:?}: expected WIDTHxHEIGHT, e.g. 640x360"))?;
    let p = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("{s:?}: expected WIDTHxHEIGHT, e.g. 640x360"))
    };
    let (w, h) = (p(w)?, p(h)?);
    if w < 16 || h < 16 || w > 8192 || h > 8192 || w % 2 == 1 || h % 2 == 1 {
        return Err(format!(
            "{s:?}: width and height must be even, from 16 to 8192 px"
        ));
    }
    Ok((w, h))
}
