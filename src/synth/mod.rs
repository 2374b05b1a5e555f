//! Synthetic test clips with ground truth: `mocap2d synth`.
//!
//! [`render`] draws an articulated, textured cartoon character (see [`character`] for its 14
//! joints) walking, fighting or waving over a static textured background, and returns the
//! frames with the exact joint positions. [`write_clip`] saves a clip as a run-ready folder:
//! `clip.mp4`, `gt.csv`, `joints.toml` (seed file for frame 0) and `background.png` (clean plate).
//!
//! How a clip is made:
//! - **Motion** (`motion.rs`): forward kinematics from per-bone angle curves (sums of sines whose
//!   amplitudes, periods and phases come from `seed`) plus root travel; the lower foot rests on
//!   the floor and the whole path is fitted into the frame, so every joint stays at least half a
//!   seed box inside it.
//! - **Drawing** (`draw.rs`): each limb is a tapered capsule with its own colours and pattern in
//!   the limb's frame (it rotates and stretches with the bone) and a dark outline; parts are drawn
//!   back to front (far arm, far leg, torso and head, near leg, near arm), anti-aliased from
//!   exact signed distances, so sub-pixel motion changes pixels.
//! - **Scale**: the standing character is [`CHARACTER_HEIGHT`] of the frame height; every length
//!   and speed scales with the height.
//!
//! Rendering is deterministic: the same options give identical pixels, whatever the thread
//! count (frames are drawn in parallel, each from its own state).

pub mod character;
mod draw;
mod motion;

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use image::RgbImage;
use rayon::prelude::*;

use crate::atomic;
use crate::error::{Error, Result};
use character::{JOINT_COUNT, JOINT_NAMES, PARENTS};

/// Height of the standing character (sole to the top of the head) as a fraction of the frame.
pub const CHARACTER_HEIGHT: f32 = 0.52;

/// Frame rate of every synthetic clip (frames per second).
pub const FPS: f64 = 30.0;

/// Smallest frame size `render` accepts (px).
pub const MIN_SIZE: (u32, u32) = (64, 48);

/// Largest frame side `render` accepts (px).
pub const MAX_SIDE: u32 = 8192;

/// What the character does, and how the clip is degraded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Scenario {
    /// A walk cycle at moderate speed; limbs pass briefly behind the torso.
    Walk,
    /// Slow wide steps where the legs cross; the near (left) arm dwells in front of the torso
    /// and the far (right) arm behind it. Always faces +x.
    Occlude,
    /// Punches, kicks and lunges: the wrists and ankles move >= 20 px and their bones turn
    /// >= 10° per frame at 640x360 on many frames.
    Fast,
    /// Flat cartoon colours (no texture) and bones that stretch and squash by ±30 %.
    Squash,
    /// A walk with sensor noise, ±8 % brightness flicker and strong compression.
    Noisy,
    /// 900 frames: walk, turn, walk back, wave both arms, crouch twice, turn, walk waving, turn,
    /// walk.
    Long,
}

impl Scenario {
    /// Every scenario, in declaration order.
    pub const ALL: [Scenario; 6] = [
        Scenario::Walk,
        Scenario::Occlude,
        Scenario::Fast,
        Scenario::Squash,
        Scenario::Noisy,
        Scenario::Long,
    ];

    /// The lowercase name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::Walk => "walk",
            Scenario::Occlude => "occlude",
            Scenario::Fast => "fast",
            Scenario::Squash => "squash",
            Scenario::Noisy => "noisy",
            Scenario::Long => "long",
        }
    }

    /// Number of frames when none is asked for: 900 for `long`, 120 otherwise.
    pub fn default_frames(self) -> u32 {
        match self {
            Scenario::Long => motion::LONG_CYCLE as u32,
            _ => 120,
        }
    }

    /// H.264 constant rate factor for the clip: 33 (strong compression) for `noisy`, else 18.
    pub fn crf(self) -> u8 {
        match self {
            Scenario::Noisy => 33,
            _ => 18,
        }
    }
}

impl fmt::Display for Scenario {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Scenario {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        Scenario::ALL
            .into_iter()
            .find(|sc| sc.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| {
                let names: Vec<_> = Scenario::ALL.iter().map(|s| s.name()).collect();
                Error::Usage(format!(
                    "unknown scenario {s:?}: expected one of {}",
                    names.join(", ")
                ))
            })
    }
}

/// What to render.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SynthOptions {
    pub scenario: Scenario,
    /// Frame width (px).
    pub width: u32,
    /// Frame height (px).
    pub height: u32,
    /// Varies the motion (and the background); the same seed gives the same pixels.
    pub seed: u64,
    /// Number of frames; `None` for the scenario's default ([`Scenario::default_frames`]).
    pub frames: Option<u32>,
}

impl Default for SynthOptions {
    /// `walk`, 640x360, seed 0, default length.
    fn default() -> Self {
        SynthOptions {
            scenario: Scenario::Walk,
            width: 640,
            height: 360,
            seed: 0,
            frames: None,
        }
    }
}

impl SynthOptions {
    /// Number of frames to render.
    pub fn frame_count(&self) -> u32 {
        self.frames
            .unwrap_or_else(|| self.scenario.default_frames())
    }

    /// Checks the size and frame count: at least [`MIN_SIZE`], at most [`MAX_SIDE`] a side, no
    /// narrower than 3:4 (the character must fit sideways), and at least one frame.
    pub fn validate(&self) -> Result<()> {
        let (w, h) = (self.width, self.height);
        if w < MIN_SIZE.0 || h < MIN_SIZE.1 {
            return Err(Error::Usage(format!(
                "--size {w}x{h}: too small for the character; use at least {}x{}",
                MIN_SIZE.0, MIN_SIZE.1
            )));
        }
        if w > MAX_SIDE || h > MAX_SIDE {
            return Err(Error::Usage(format!(
                "--size {w}x{h}: too large; each side must be at most {MAX_SIDE} px"
            )));
        }
        if 4 * w < 3 * h {
            return Err(Error::Usage(format!(
                "--size {w}x{h}: too narrow for the character to move; make the width at least \
                 3/4 of the height ({} px)",
                (3 * h).div_ceil(4)
            )));
        }
        if self.frames == Some(0) {
            return Err(Error::Usage("--frames 0: render at least one frame".into()));
        }
        Ok(())
    }
}

/// A rendered clip with its ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthClip {
    /// Joint names, in index order ([`character::JOINT_NAMES`]).
    pub joint_names: Vec<String>,
    /// Parent of each joint (`None` for the root, the pelvis).
    pub parents: Vec<Option<usize>>,
    /// The frames, in order.
    pub frames: Vec<RgbImage>,
    /// Ground truth `[frame][joint]`: joint positions (px, image space, see [`crate::geom`]).
    pub gt: Vec<Vec<(f32, f32)>>,
    /// `[frame][joint]`: the fraction (0–1) of the joint's articulation disc where one of its own
    /// bones' parts is drawn on top; below about 0.3 the joint is occluded on that frame.
    pub visibility: Vec<Vec<f32>>,
    /// The clean background (no character, no noise).
    pub background: RgbImage,
    /// Seed rectangle side (px, odd): 21 at 360 px high, scaled with the height, at least 9.
    pub box_size: u32,
    /// Frames per second.
    pub fps: f64,
    /// H.264 constant rate factor for [`write_clip`].
    pub crf: u8,
}

/// The seed rectangle side (px) for a frame `height` px high: `21 · height / 360` rounded to the
/// nearest odd number, at least 9.
pub fn box_size_for(height: u32) -> u32 {
    let b = (21.0 * height as f32 / 360.0).round() as u32;
    let b = if b.is_multiple_of(2) { b + 1 } else { b };
    b.max(9)
}

/// A small, fast, deterministic PRNG (splitmix64).
#[derive(Debug, Clone)]
pub(crate) struct Rng(u64);

/// One splitmix64 step: a good 64-bit mix of `x`.
pub(crate) fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Rng {
    pub(crate) fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        splitmix64(self.0)
    }

    /// Uniform in `[lo, hi)`.
    pub(crate) fn range(&mut self, lo: f32, hi: f32) -> f32 {
        let u = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        lo + (hi - lo) * u
    }
}

/// Renders a clip. Deterministic: the same options give identical frames and ground truth.
///
/// # Panics
/// If `opts` fails [`SynthOptions::validate`].
pub fn render(opts: &SynthOptions) -> SynthClip {
    if let Err(e) = opts.validate() {
        panic!("synth::render: invalid options: {e}");
    }
    let (width, height) = (opts.width, opts.height);
    let frames = opts.frame_count() as usize;
    let hc = CHARACTER_HEIGHT * height as f32;
    let box_size = box_size_for(height);
    let scenario_salt = splitmix64(opts.scenario as u64 + 1);
    let mut rng = Rng::new(opts.seed ^ scenario_salt);

    let poses = motion::poses(opts.scenario, frames, &mut rng);
    let kin: Vec<_> = poses.iter().map(|p| motion::kinematics(p, hc)).collect();
    let margin = 0.5 * box_size as f32 + 1.0;
    let roots = motion::place_roots(&poses, &kin, hc, width, height, margin);
    let joints: Vec<Vec<crate::geom::Vector>> = kin
        .iter()
        .zip(&roots)
        .map(|(k, &root)| k.rel.iter().map(|&d| root + d).collect())
        .collect();

    let background = draw::background(width, height, opts.seed);
    let flat = opts.scenario == Scenario::Squash;
    let noisy = opts.scenario == Scenario::Noisy;
    let noise_seed = rng.next_u64();
    let rendered: Vec<(RgbImage, Vec<f32>)> = (0..frames)
        .into_par_iter()
        .map(|t| {
            let shapes = draw::scene(&poses[t], &kin[t], &joints[t], hc, flat);
            let mut buf = background.clone();
            for s in &shapes {
                s.draw(&mut buf, width, height);
            }
            let vis = draw::visibility(&shapes, &joints[t], hc);
            let noise = noisy.then(|| {
                let seed = splitmix64(noise_seed ^ (t as u64).wrapping_mul(0xA24B_AED4_963E_E407));
                let u = (seed >> 40) as f32 / (1u64 << 23) as f32 - 1.0;
                draw::Noise {
                    seed,
                    gain: 1.0 + 0.08 * u,
                    sigma: 6.0,
                }
            });
            (draw::to_image(&buf, width, height, noise), vis)
        })
        .collect();
    let (frames, visibility): (Vec<_>, Vec<_>) = rendered.into_iter().unzip();

    SynthClip {
        joint_names: JOINT_NAMES.iter().map(|s| s.to_string()).collect(),
        parents: PARENTS.to_vec(),
        frames,
        gt: joints
            .iter()
            .map(|f| f.iter().map(|p| (p.x, p.y)).collect())
            .collect(),
        visibility,
        background: draw::to_image(&background, width, height, None),
        box_size,
        fps: FPS,
        crf: opts.scenario.crf(),
    }
}

impl SynthClip {
    /// Frame width (px).
    pub fn width(&self) -> u32 {
        self.background.width()
    }

    /// Frame height (px).
    pub fn height(&self) -> u32 {
        self.background.height()
    }

    /// The seed file for frame 0: every joint's ground-truth position with a
    /// `box_size × box_size` rectangle and its parent, in the seed-file format
    /// ([`crate::seed`]).
    pub fn seeds_toml(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::from(
            "# Ground truth of frame 0, written by `mocap2d synth`: one rectangle a joint.\n\n\
             frame = 0\n",
        );
        debug_assert_eq!(self.joint_names.len(), JOINT_COUNT);
        for (j, name) in self.joint_names.iter().enumerate() {
            let (x, y) = self.gt[0][j];
            let _ = write!(
                s,
                "\n[[joint]]\nname = \"{name}\"\nx = {x:.3}\ny = {y:.3}\nw = {b}\nh = {b}\n",
                b = self.box_size
            );
            if let Some(p) = self.parents[j] {
                let _ = writeln!(s, "parent = \"{}\"", self.joint_names[p]);
            }
        }
        s
    }

    /// The ground truth as CSV: header `frame,joint,x,y,visible`, one row a joint a frame
    /// (frames in order, joints in index order), positions in px with 3 decimals and the
    /// joint's [`visibility`](Self::visibility) with 2.
    pub fn gt_csv(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::from("frame,joint,x,y,visible\n");
        for (t, (frame, vis)) in self.gt.iter().zip(&self.visibility).enumerate() {
            for ((name, (x, y)), v) in self.joint_names.iter().zip(frame).zip(vis) {
                let _ = writeln!(s, "{t},{name},{x:.3},{y:.3},{v:.2}");
            }
        }
        s
    }
}

/// Writes `clip` into `out_dir` (created if missing): `clip.mp4` (H.264 at the clip's crf; without
/// the `ffmpeg` feature, a `clip/` folder of `000000.png`… instead), `gt.csv`, `joints.toml` and
/// `background.png`. Every file is written atomically.
pub fn write_clip(clip: &SynthClip, out_dir: &Path) -> Result<()> {
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    write_video(clip, out_dir)?;
    atomic::write(&out_dir.join("gt.csv"), clip.gt_csv().as_bytes())?;
    atomic::write(&out_dir.join("joints.toml"), clip.seeds_toml().as_bytes())?;
    write_png(&clip.background, &out_dir.join("background.png"))
}

fn write_png(img: &RgbImage, path: &Path) -> Result<()> {
    atomic::write_with(path, |w| {
        img.write_to(w, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
}

#[cfg(feature = "ffmpeg")]
fn write_video(clip: &SynthClip, out_dir: &Path) -> Result<()> {
    let path = out_dir.join("clip.mp4");
    let mut video =
        crate::encode::VideoWriter::create(&path, clip.width(), clip.height(), clip.fps, clip.crf)?;
    for frame in &clip.frames {
        video.write(frame)?;
    }
    video.finish()
}

#[cfg(not(feature = "ffmpeg"))]
fn write_video(clip: &SynthClip, out_dir: &Path) -> Result<()> {
    let dir = out_dir.join("clip");
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    for (t, frame) in clip.frames.iter().enumerate() {
        write_png(frame, &dir.join(format!("{t:06}.png")))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_size_scales_with_height_and_stays_odd() {
        assert_eq!(box_size_for(360), 21);
        assert_eq!(box_size_for(240), 15);
        assert_eq!(box_size_for(120), 9);
        assert_eq!(box_size_for(720), 43);
        for h in 48..1000 {
            assert_eq!(box_size_for(h) % 2, 1);
        }
    }

    #[test]
    fn scenario_names_round_trip() {
        for s in Scenario::ALL {
            assert_eq!(s.to_string().parse::<Scenario>().unwrap(), s);
        }
        assert!(matches!("jog".parse::<Scenario>(), Err(Error::Usage(_))));
    }

    #[test]
    fn validate_rejects_unusable_sizes() {
        let ok = SynthOptions::default();
        assert!(ok.validate().is_ok());
        assert!(SynthOptions { width: 32, ..ok }.validate().is_err());
        assert!(SynthOptions {
            width: 100,
            height: 200,
            ..ok
        }
        .validate()
        .is_err());
        assert!(SynthOptions {
            frames: Some(0),
            ..ok
        }
        .validate()
        .is_err());
    }
}
