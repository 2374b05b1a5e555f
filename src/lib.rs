//! mocap2d: capture the motion of a character's joints from a 2D video and retarget it.
//!
//! The pipeline, one module a stage, data flowing one way:
//! [`decode`] (frames in) → [`background`] (clean plate, foreground mask) → [`pose`] (learned
//! human pose cue) → [`track`] (template,
//! Kalman filter, search) → [`run`] (run folder, manifest) → [`retarget`] (onto a target
//! [`character`], cartoon filter) → [`deform`] (mesh, skinning, needle model, joint solve) →
//! [`render`] (textured triangles). [`synth`] renders test clips with ground truth. Coordinates
//! and units are stated once in [`geom`]'s Conventions.

pub mod app;
pub mod atomic;
pub mod background;
pub mod batch;
pub mod character;
pub mod decode;
pub mod deform;
#[cfg(feature = "ffmpeg")]
pub mod encode;
pub mod error;
pub mod eval;
pub mod export;
pub mod geom;
pub mod pose;
pub mod progress;
pub mod render;
pub mod retarget;
pub mod review;
pub mod run;
pub mod seed;
pub mod skeleton;
pub mod synth;
pub mod track;

pub use error::{Error, Result};
