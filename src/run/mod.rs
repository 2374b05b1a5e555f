//! The run folder: what `track` writes and later commands read.
//!
//! ```text
//! clip.mocap/
//!   tracks.csv   frame,joint,x,y,angle,score,status — one row per joint per frame from the
//!                seed frame to the last, by frame then seed-file order
//!   run.toml     manifest: tool version, clip identity (path, size, content hash), frame count,
//!                fps, frame size, seed file hash, every parameter used
//!   seeds.toml   the seed file, verbatim
//! ```
//! Every file is written atomically (see [`crate::atomic`]).

pub mod manifest;
pub mod tracks;

pub use manifest::{hash_clip, ClipId, Manifest};
pub use tracks::{TrackRow, TracksWriter};
