//! Commands, as library calls: each validates its inputs completely before writing anything,
//! then runs the stages in order. `main.rs` only parses flags and reports.

mod export;
mod guide;
mod params;
mod pose;
mod render;
mod report;
mod resume;
mod retarget;
mod review;
mod serve;
mod track;
pub use crate::decode::read_frame;
pub use crate::render::Renderer;
pub use crate::run::blend::blend;
pub use export::{export, ExportOptions, ExportSummary, UserSkeleton};
pub use guide::{guide, GuideOptions, GuideSummary};
pub use params::read_params;
pub use pose::{seed, SeedOptions, SeedSummary, POSE_CSV};
pub use render::{render, RenderOptions, RenderSummary};
pub use report::{eval, report};
pub use resume::{resume, ResumeOptions};
pub use retarget::{check_character, retarget, run_frame, RetargetSummary, RETARGET_DIR};
pub use review::{review, ReviewSummary, REVIEW_DIR};
pub use serve::{serve, serve_seeds, DEFAULT_PORT};
pub use track::{
    default_run_dir, track, track_into, OtherClip, TrackOptions, TrackSummary, DEFAULT_SEGMENT_LEN,
};

#[cfg(test)]
mod tests;
