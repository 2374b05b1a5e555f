//! `mocap2d serve RUN [--port 8765]`: the local correction page for a run's segment files (see
//! [`crate::review::serve`] for the routes and [`crate::review::api`] for what a save writes);
//! `mocap2d serve CLIP --skeleton FILE --seeds-out SEEDS.toml`: the page that places a clip's
//! first seeds (see [`crate::review::seed_api`]).

use crate::error::Result;
use crate::progress::Progress;
use crate::review::api::{Api, ResumeFn};
use crate::review::seed_api::{SeedApi, TrackFn};
use crate::review::serve::{Pages, Server};
use std::net::SocketAddr;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// Default port of `mocap2d serve`.
pub const DEFAULT_PORT: u16 = 8765;

/// The progress of work started from the page: nothing drawn; it stops at its next checkpoint
/// once the flag is set (the server is stopping).
struct UntilStopped<'a>(&'a AtomicBool);

impl Progress for UntilStopped<'_> {
    fn advance(&self, _n: u64) -> bool {
        !self.0.load(Ordering::SeqCst)
    }
}

/// What the page's "Resume from here" button runs: `mocap2d resume RUN --segment K` (with the
/// clip the server was given, if any), then `mocap2d review RUN` so the overlay shows the result.
fn resume_hook(clip: Option<&Path>) -> Option<Box<ResumeFn>> {
    let clip = clip.map(Path::to_path_buf);
    Some(Box::new(move |run: &Path, k: u32, stop: &AtomicBool| {
        let progress = UntilStopped(stop);
        let opts = super::resume::ResumeOptions {
            run: run.to_path_buf(),
            segment: Some(u64::from(k)),
            clip: clip.clone(),
            params: None,
        };
        let done = super::resume::resume(&opts, &progress)?;
        super::review::review(run, clip.as_deref(), &progress)?;
        Ok(match done {
            Some(s) => format!(
                "resumed from segment {k:03}: {} frames tracked; review/ refreshed. {}",
                s.tracked_frames, s.report
            ),
            None => format!("segment {k:03}: nothing to do; review/ refreshed"),
        })
    }))
}

/// Reads the run, binds `127.0.0.1:port` (0: any free port), calls `ready` with the address,
/// then answers requests until `stop` is set (Ctrl-C): a resume started from the page then stops
/// at its next checkpoint (`mocap2d resume RUN` carries on from there), the requests under way
/// are answered, and it returns.
pub fn serve(
    run: &Path,
    clip: Option<&Path>,
    port: u16,
    stop: &AtomicBool,
    ready: impl FnOnce(SocketAddr),
) -> Result<()> {
    let api = Api::open(run, clip, resume_hook(clip))?;
    answer(api, port, stop, ready)
}

/// What the seeding page's "Track" button runs: `mocap2d track CLIP --seeds SEEDS` into the
/// default run folder.
fn track_hook() -> Box<TrackFn> {
    Box::new(|clip: &Path, seeds: &Path, stop: &AtomicBool| {
        let opts = super::TrackOptions::new(clip, seeds);
        let s = super::track::track(&opts, &UntilStopped(stop))?;
        Ok(format!(
            "tracked {} joints over {} frames -> {}. {} Correct it with `mocap2d serve {}`.",
            s.joints,
            s.tracked_frames,
            s.run_dir.display(),
            s.report,
            s.run_dir.display()
        ))
    })
}

/// Checks the start (see [`SeedApi::open`]: nothing is written when an input is bad), binds
/// `127.0.0.1:port`, calls `ready` with the address, then answers the seeding page of `clip`
/// until `stop` is set.
pub fn serve_seeds(
    clip: &Path,
    skeleton: &Path,
    seeds_out: &Path,
    port: u16,
    stop: &AtomicBool,
    ready: impl FnOnce(SocketAddr),
) -> Result<()> {
    let api = SeedApi::open(clip, skeleton, seeds_out, Some(track_hook()))?;
    answer(api, port, stop, ready)
}

fn answer<P: Pages>(
    api: P,
    port: u16,
    stop: &AtomicBool,
    ready: impl FnOnce(SocketAddr),
) -> Result<()> {
    let server = Server::bind(api, port)?;
    ready(server.addr());
    server.run(stop)
}
