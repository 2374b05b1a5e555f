//! Seeing and fixing a run: the seeding guide (silhouette skeleton, docs/method.md §6), the review
//! outputs (overlay video, confidence plot, segment contact sheet) and the local correction page.

pub mod api;
mod boxes;
pub mod data;
pub mod detect_api;
pub mod draw;
pub mod frame_cache;
pub mod graph;
pub mod guide;
mod http;
pub mod keys_api;
pub mod overlay;
pub mod plot;
pub mod reply;
pub mod seed_api;
pub mod serve;
pub mod sheet;
pub mod thin;
