//! The integration tests, one test binary: `cargo test --test it` runs them all, and
//! `cargo test --test it segments::` (a module path) or `cargo test --test it resume` (any part
//! of a test's name) a few. Each module was its own binary (`tests/NAME.rs`) before; they are
//! one crate now so that the library and the helpers in [`common`] are linked once.
//!
//! Modules that need the `ffmpeg` feature say so with `#![cfg(feature = "ffmpeg")]` at their top.

mod common;

mod accuracy;
mod animate;
mod batch;
mod camera;
mod cleanup;
mod cli;
mod cli_accuracy;
mod cli_errors;
mod dance;
mod decode;
mod eval;
mod export;
mod export_curves;
mod export_dlc;
mod export_keys;
mod export_runtimes;
mod export_their_skeleton;
mod exposure;
mod hardening;
mod hardening_files;
mod hardening_run;
mod keyframes;
mod pose;
mod review;
mod run_lock;
mod run_safety;
mod scale;
mod seams;
mod seeds;
mod segments;
mod segments_keys;
mod segments_resume;
mod serve;
mod serve_detect;
mod serve_http;
mod serve_keys;
mod serve_resume;
mod serve_seed_detect;
mod serve_seeds;
mod signals;
mod synth;
