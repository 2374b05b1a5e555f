//! The run folder: what `track` writes and later commands read.
//!
//! ```text
//! clip.mocap/
//!   tracks.csv   frame,joint,x,y,angle,score,status — one row per joint per frame from
//!                frame 0 (before the seed frame: tracked backward from it) to the last, by
//!                frame then seed-file order
//!   run.toml     manifest: tool version, clip identity (path, size, content hash), frame count,
//!                fps, frame size, seed file hash, every parameter used
//!   seeds.toml   the seed file, verbatim
//!   report.md    segments ranked by need of correction ([`report`], from [`evidence`])
//!   segments/    NNN.toml: segment NNN's seed file, the user's place to correct; NNN.csv: its
//!                rows of tracks.csv, the checkpoint `resume` carries on from ([`segments`])
//!   keys.toml    the user's keys on any frame, any subset of joints ([`keys`])
//!   history/     NNN-tracks.csv, NNN-report.md: results a rerun replaced ([`folder`])
//!   .lock        only while a command writes the folder: one writer at a time ([`lock`])
//! ```
//! Every file is written atomically (see [`crate::atomic`]). [`session`] is the tracking loop
//! that writes it, segment by segment, with the keys and corrections ([`keyed`], [`blend`]).

pub mod blend;
pub mod evidence;
pub mod folder;
pub mod fuse;
pub mod keyed;
pub mod keys;
pub mod lock;
pub mod manifest;
pub mod report;
pub mod segments;
pub mod session;
pub mod suggest;
pub mod tracks;

pub use manifest::{hash_clip, ClipId, Manifest, SegmentRecord};
pub use tracks::{TrackRow, TracksWriter};
