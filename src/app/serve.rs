//! `mocap2d serve RUN [--port 8765]`: the local correction page for a run's segment files (see
//! [`crate::review::serve`] for the routes and [`crate::review::api`] for what a save writes).

use crate::error::Result;
use crate::review::api::{Api, ResumeFn};
use crate::review::serve::Server;
use std::net::SocketAddr;
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// Default port of `mocap2d serve`.
pub const DEFAULT_PORT: u16 = 8765;

/// What the page's "Resume from here" button runs: `None` while the app has no resume.
///
/// Issue 4 adds `mocap2d resume RUN --segment K`. Wire it here, e.g.
/// `Some(Box::new(|run, k| { resume(run, k, &NoProgress)?; review(run, None, &NoProgress)?;
/// Ok(format!("resumed from segment {k:03}; review/ refreshed")) }))`; the endpoint then answers
/// 200 with that message instead of 501, and the page reloads the segment list.
fn resume_hook() -> Option<Box<ResumeFn>> {
    None
}

/// Reads the run, binds `127.0.0.1:port` (0: any free port), calls `ready` with the address,
/// then answers requests until `stop` is set.
pub fn serve(
    run: &Path,
    clip: Option<&Path>,
    port: u16,
    stop: &AtomicBool,
    ready: impl FnOnce(SocketAddr),
) -> Result<()> {
    let api = Api::open(run, clip, resume_hook())?;
    let server = Server::bind(api, port)?;
    ready(server.addr());
    server.run(stop);
    Ok(())
}
