//! `mocap2d serve`: a small HTTP server, bound to 127.0.0.1 only, for the correction page. The
//! page's HTML, script and style are compiled into the binary (no CDN: it works offline).
//!
//! Routes (anything else is 404; a wrong method 405):
//! - `GET /`, `/app.js`, `/keys.js`, `/seeds.js`, `/style.css`: the page.
//! - `GET /api/run`: segments with flags, joints, frame size.
//! - `GET /api/segments/ID`, `GET /api/segments/ID/frame.png`: one segment.
//! - `POST /api/segments/ID`: save edited rectangles (JSON, at most [`MAX_BODY`] bytes).
//! - `POST /api/segments/ID/resume`: resume tracking from the segment (501 when the app gives no
//!   resume). While it runs, saves and frames answer 409 at once (see [`super::api`]).
//! - `GET /api/frames/N`, `GET /api/frames/N/frame.png`: any tracked frame, its joints and keys.
//! - `POST /api/keys`: save a key on any frame into `keys.toml` (see [`super::keys_api`]).
//! - `POST /api/frames/N/detect`: the pose network's proposal of a key on frame N, written
//!   nowhere (see [`super::detect_api`]).
//!
//! The seeding page of a bare clip (`serve CLIP --seeds-out FILE`) answers `GET /api/run`,
//! `GET /api/frames/N/frame.png`, `POST /api/frames/N/detect`, `POST /api/seeds` and
//! `POST /api/seeds/track` instead (see [`super::seed_api`]).
//!
//! Segment ids and frame numbers are digits, and every file served or written is a segment
//! file or `keys.toml` of the run folder, the seed file named at start, the clip, or an embedded
//! asset, so no request reaches any other path. Requests
//! whose `Host` is not this server's loopback address are refused (403), so a web page elsewhere
//! cannot reach the server through a DNS name pointed at 127.0.0.1. A handler that panics
//! answers 500 and the server carries on.
//!
//! One client cannot hold up the others: the HTTP side is hyper's HTTP/1 server on tokio (module
//! `review::http`): every connection is a task, not a thread, and none is refused for lack of
//! a slot; the answers are worked out on a pool of threads, one request per connection. A
//! request's head must arrive within [`REQUEST_TIMEOUT`] (else the connection is closed) and fit
//! in [`MAX_HEAD`] bytes (431), its body must arrive within [`REQUEST_TIMEOUT`] more (408), and a
//! `Content-Length` over [`MAX_BODY`] gets 413 before any of the body is read, so no client
//! makes the server allocate more than that.

use super::api::{Api, Reply};
use crate::error::{Error, Result};
use std::net::{SocketAddr, TcpListener};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

/// Largest request body accepted, bytes.
pub const MAX_BODY: usize = 1 << 20;

/// Largest request head (request line and headers) accepted, bytes.
pub const MAX_HEAD: usize = 16 << 10;

/// Time a client has to send a request's head, and then as long for its body.
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(10);

const INDEX_HTML: &str = include_str!("assets/index.html");
const APP_JS: &str = include_str!("assets/app.js");
const KEYS_JS: &str = include_str!("assets/keys.js");
const SEEDS_JS: &str = include_str!("assets/seeds.js");
const STYLE_CSS: &str = include_str!("assets/style.css");

/// What a server answers: the correction page of a run ([`Api`], routes in [`route`]) or the
/// seeding page of a bare clip ([`super::seed_api::SeedApi`]).
pub trait Pages: Send + Sync + 'static {
    /// The reply to one request read in full.
    fn answer(&self, method: &str, url: &str, body: &[u8]) -> Reply;

    /// The server is stopping (Ctrl-C): long work under way (a resume, a track) stops at its
    /// next checkpoint, and no more starts.
    fn stopping(&self) {}
}

impl Pages for Api {
    fn answer(&self, method: &str, url: &str, body: &[u8]) -> Reply {
        route(self, method, url, body)
    }

    fn stopping(&self) {
        self.stop_work();
    }
}

/// The server: a bound socket and the pages it serves.
pub struct Server<P: Pages = Api> {
    listener: TcpListener,
    pages: Arc<P>,
    addr: SocketAddr,
}

impl<P: Pages> Server<P> {
    /// Binds `127.0.0.1:port` (0 = any free port).
    pub fn bind(api: P, port: u16) -> Result<Server<P>> {
        let listen = || -> std::io::Result<(TcpListener, SocketAddr)> {
            let l = TcpListener::bind(("127.0.0.1", port))?;
            l.set_nonblocking(true)?;
            let a = l.local_addr()?;
            Ok((l, a))
        };
        let (listener, addr) = listen().map_err(|e| {
            Error::Usage(format!(
                "cannot listen on 127.0.0.1:{port}: {e}; choose another --port"
            ))
        })?;
        Ok(Server {
            listener,
            pages: Arc::new(api),
            addr,
        })
    }

    /// The address the server listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Answers requests until `stop` is set (looked at every 20 ms); then asks the work under
    /// way to stop at its next checkpoint ([`Pages::stopping`]), waits for the requests being
    /// answered and returns.
    pub fn run(&self, stop: &AtomicBool) -> Result<()> {
        let at = self.addr.to_string();
        let io = |e: std::io::Error| Error::io(std::path::Path::new(&at), e);
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_io()
            .enable_time()
            .build()
            .map_err(io)?;
        let listener = self.listener.try_clone().map_err(io)?;
        let served = runtime.block_on(super::http::serve(
            listener,
            self.pages.clone(),
            self.addr.port(),
            stop,
        ));
        // Dropping the runtime waits for the answers still being worked out.
        drop(runtime);
        served.map_err(io)
    }
}

/// A request's path (without query or fragment) and its parts split at `/`.
pub(super) fn path_parts(url: &str) -> (&str, Vec<&str>) {
    let path = url.split(['?', '#']).next().unwrap_or("");
    (path, path.split('/').collect())
}

/// The page itself (HTML, scripts, style) for a request of it, else `None`.
pub(super) fn page_asset(method: &str, path: &str) -> Option<Reply> {
    let asset = |ct: &'static str, s: &str| Reply {
        status: 200,
        content_type: ct,
        body: s.as_bytes().to_vec(),
    };
    let (html, js, css) = (
        "text/html; charset=utf-8",
        "text/javascript; charset=utf-8",
        "text/css; charset=utf-8",
    );
    let reply = match path {
        "/" | "/index.html" => asset(html, INDEX_HTML),
        "/app.js" => asset(js, APP_JS),
        "/keys.js" => asset(js, KEYS_JS),
        "/seeds.js" => asset(js, SEEDS_JS),
        "/style.css" => asset(css, STYLE_CSS),
        _ => return None,
    };
    Some(if method == "GET" || method == "HEAD" {
        reply
    } else {
        Reply::error(405, format!("{method} is not allowed on {path}"))
    })
}

/// Answers one request (see the module doc for the routes).
pub fn route(api: &Api, method: &str, url: &str, body: &[u8]) -> Reply {
    let (path, parts) = path_parts(url);
    if let Some(r) = page_asset(method, path) {
        return r;
    }
    let get = method == "GET" || method == "HEAD";
    let post = method == "POST";
    let wrong = || Reply::error(405, format!("{method} is not allowed on {path}"));
    match parts.as_slice() {
        ["", "api", "run"] if get => api.run_info(),
        ["", "api", "segments", id] if get => api.segment(id),
        ["", "api", "segments", id] if post => api.save(id, body),
        ["", "api", "segments", id, "frame.png"] if get => api.frame_png(id),
        ["", "api", "segments", id, "resume"] if post => api.resume(id),
        ["", "api", "frames", n] if get => api.frame_info(n),
        ["", "api", "frames", n, "frame.png"] if get => api.any_frame_png(n),
        ["", "api", "keys"] if post => api.save_key(body),
        ["", "api", "frames", n, "detect"] if post => api.detect(n),
        ["", "api", "run"] => wrong(),
        ["", "api", "segments", _] | ["", "api", "segments", _, "frame.png" | "resume"] => wrong(),
        ["", "api", "frames", _]
        | ["", "api", "frames", _, "frame.png" | "detect"]
        | ["", "api", "keys"] => wrong(),
        _ => Reply::error(404, format!("no such page: {path}")),
    }
}
