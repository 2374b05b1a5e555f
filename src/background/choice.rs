//! Which background model a run uses: the one the user asks for ([`BackgroundChoice`]), built
//! from the clip, and recorded in `run.toml` as a [`BackgroundSetting`] that `resume` rebuilds
//! the same model from.

use super::{camera, Background, BackgroundSetting, Limb};
use crate::decode;
use crate::error::{Error, Result};
use crate::seed::Seeds;
use image::RgbImage;
use std::path::{Path, PathBuf};

/// Frames sampled across the clip for the temporal-median clean plate.
pub const BACKGROUND_SAMPLES: usize = 25;

/// The background model the user asks for.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum BackgroundChoice {
    /// The temporal median of frames sampled across the clip (the default).
    #[default]
    Median,
    /// A clean plate: an image of the background alone, clip-sized (`--background PLATE`).
    Plate(PathBuf),
    /// No background subtraction (`--no-background`).
    None,
}

impl BackgroundChoice {
    /// The choice of the `--background PLATE` and `--no-background` flags.
    pub fn from_flags(plate: Option<PathBuf>, no_background: bool) -> BackgroundChoice {
        match (plate, no_background) {
            (_, true) => BackgroundChoice::None,
            (Some(p), false) => BackgroundChoice::Plate(p),
            (None, false) => BackgroundChoice::Median,
        }
    }

    /// Builds the model asked for, frames `width`×`height` of `clip` (read at `fps`); with
    /// `seeds` (for tracking), a median plate is cleared of the subjects that sat still on their
    /// seed frame (see [`median_background`]), and none is made when the camera moves
    /// ([`camera::check`]; without `seeds` the median is made and the check only reported).
    /// Returns it with the setting `run.toml` records.
    pub fn build(
        &self,
        clip: &Path,
        fps: Option<f64>,
        width: u32,
        height: u32,
        seeds: Option<&Seeds>,
    ) -> Result<Built> {
        let built = |model, setting| Built {
            model,
            setting,
            camera: None,
        };
        match self {
            BackgroundChoice::None => Ok(built(None, BackgroundSetting::None)),
            BackgroundChoice::Plate(plate) => Ok(built(
                Some(Background::from_plate_file(plate, width, height)?),
                BackgroundSetting::Plate {
                    path: plate.clone(),
                },
            )),
            BackgroundChoice::Median => median_unless_moving(clip, fps, seeds),
        }
    }
}

/// The background model [`BackgroundChoice::build`] made.
#[derive(Debug, Clone)]
pub struct Built {
    /// The model (`None`: no subtraction).
    pub model: Option<Background>,
    /// What `run.toml` records (`resume` rebuilds the same model from it).
    pub setting: BackgroundSetting,
    /// For a median: how the camera check came out. When the camera
    /// [`moves`](camera::CameraCheck::moves) and the model is for tracking, there is none.
    pub camera: Option<camera::CameraCheck>,
}

impl Built {
    /// What to tell the user when the camera moved and no background is subtracted.
    pub fn note(&self) -> Option<String> {
        let c = self.camera.filter(|c| c.moves())?;
        Some(format!(
            "{}, so no clean plate can be made from the clip: tracking without background \
             subtraction; if the camera is still, give a plate with --background PLATE",
            c.describe()
        ))
    }
}

/// The median plate (for tracking, `seeds` given: only when the camera holds still), with the
/// camera check.
fn median_unless_moving(clip: &Path, fps: Option<f64>, seeds: Option<&Seeds>) -> Result<Built> {
    let (samples, at_seed) =
        decode::sample_frames_and(clip, BACKGROUND_SAMPLES, seeds.map(|s| s.frame))?;
    let camera = Some(camera::check(&samples));
    if seeds.is_some() && camera.is_some_and(|c| c.moves()) {
        return Ok(Built {
            model: None,
            setting: BackgroundSetting::MovingCamera,
            camera,
        });
    }
    let (bg, setting) = median_of(clip, fps, seeds, samples, at_seed)?;
    Ok(Built {
        model: Some(bg),
        setting,
        camera,
    })
}

impl BackgroundSetting {
    /// Rebuilds the model of a run that recorded this setting (`resume`), from its clip read at
    /// `fps` and its seeds.
    pub fn rebuild(
        &self,
        clip: &Path,
        fps: Option<f64>,
        width: u32,
        height: u32,
        seeds: &Seeds,
    ) -> Result<Option<Background>> {
        Ok(match self {
            BackgroundSetting::None | BackgroundSetting::MovingCamera => None,
            BackgroundSetting::Plate { path } => {
                Some(Background::from_plate_file(path, width, height)?)
            }
            // Cleared of the bodies resting on the seed frame, or the plain median of runs
            // made before that existed.
            BackgroundSetting::Median { rest, .. } => {
                Some(median_background(clip, fps, rest.then_some(seeds))?.0)
            }
        })
    }

    /// True when a run with this setting used the model `choice` asks for. A plate is never
    /// taken for the same: its file may have changed since. A median asked for a clip whose
    /// camera moved is answered by the run made without one (the check decides the same again).
    pub fn answers(&self, choice: &BackgroundChoice) -> bool {
        match (self, choice) {
            (BackgroundSetting::None, BackgroundChoice::None) => true,
            (BackgroundSetting::MovingCamera, BackgroundChoice::Median) => true,
            (BackgroundSetting::Median { rest, .. }, BackgroundChoice::Median) => *rest,
            _ => false,
        }
    }
}

/// [`Error::Clip`]: the clip opened but gave no frame.
fn no_frames(clip: &Path) -> Error {
    Error::Clip {
        path: clip.to_owned(),
        msg: "no frames: the clip is empty, or damaged from its first frame".into(),
    }
}

/// The clip's temporal-median plate over [`BACKGROUND_SAMPLES`] sampled frames, and its
/// setting for `run.toml`: `median:N`, or `median:N,rest` when `seeds` are given and the
/// subjects that sat still on their seed frame (read at `fps`) are cleared from it
/// ([`Background::clear_resting_subject`]).
pub fn median_background(
    clip: &Path,
    fps: Option<f64>,
    seeds: Option<&Seeds>,
) -> Result<(Background, BackgroundSetting)> {
    // The seed frame comes with the sample when one sequential decode passes it.
    let (samples, at_seed) =
        decode::sample_frames_and(clip, BACKGROUND_SAMPLES, seeds.map(|s| s.frame))?;
    median_of(clip, fps, seeds, samples, at_seed)
}

/// [`median_background`] of the samples already decoded (and the seed frame, when decoded with
/// them).
fn median_of(
    clip: &Path,
    fps: Option<f64>,
    seeds: Option<&Seeds>,
    samples: Vec<RgbImage>,
    at_seed: Option<RgbImage>,
) -> Result<(Background, BackgroundSetting)> {
    if samples.is_empty() {
        return Err(no_frames(clip));
    }
    let mut bg = Background::fit(&samples)?;
    let mut rest = false;
    if let Some(seeds) = seeds {
        let seed_frame = match at_seed {
            Some(f) => f,
            None => decode::read_frame(clip, fps, seeds.frame)?,
        };
        bg.clear_resting_subject(&samples, &seed_frame, &seed_bodies(seeds));
        rest = true;
    }
    let samples = samples.len() as u32;
    Ok((bg, BackgroundSetting::Median { samples, rest }))
}

/// Each body of `seeds` (a root and its descendants) as limbs on the seed frame: every bone,
/// reaching half its child's rectangle (the larger side) around it, and every joint's own
/// rectangle.
fn seed_bodies(seeds: &Seeds) -> Vec<Vec<Limb>> {
    let sk = &seeds.skeleton;
    let boxes = seeds.boxes();
    let half = |j: usize| 0.5 * boxes[j].w.max(boxes[j].h) as f32;
    let root = |mut j: usize| {
        while let Some(p) = sk.parents[j] {
            j = p;
        }
        j
    };
    let roots: Vec<usize> = (0..sk.len()).filter(|&j| sk.parents[j].is_none()).collect();
    roots
        .iter()
        .map(|&r| {
            (0..sk.len())
                .filter(|&j| root(j) == r)
                .map(|j| {
                    let c = boxes[j].centre();
                    let a = sk.parents[j].map_or(c, |p| boxes[p].centre());
                    Limb {
                        a,
                        b: c,
                        radius: half(j),
                    }
                })
                .collect()
        })
        .collect()
}
