//! `mocap2d serve`: a small HTTP server, bound to 127.0.0.1 only, for the correction page. The
//! page's HTML, script and style are compiled into the binary (no CDN: it works offline).
//!
//! Routes (anything else is 404; a wrong method 405):
//! - `GET /`, `/app.js`, `/style.css`: the page.
//! - `GET /api/run`: segments with flags, joints, frame size.
//! - `GET /api/segments/ID`, `GET /api/segments/ID/frame.png`: one segment.
//! - `POST /api/segments/ID`: save edited rectangles (JSON, at most [`MAX_BODY`] bytes).
//! - `POST /api/segments/ID/resume`: resume tracking from the segment (501 when the app gives no
//!   resume).
//!
//! Segment ids are digits, and every file served or written is a segment file of the run
//! folder or an embedded asset, so no request reaches a path outside the run folder. Requests
//! whose `Host` is not this server's loopback address are refused (403), so a web page elsewhere
//! cannot reach the server through a DNS name pointed at 127.0.0.1. A handler that panics
//! answers 500 and the server carries on.

use super::api::{Api, Reply};
use crate::error::{Error, Result};
use std::io::Read;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Largest request body accepted, bytes.
pub const MAX_BODY: usize = 1 << 20;

const INDEX_HTML: &str = include_str!("assets/index.html");
const APP_JS: &str = include_str!("assets/app.js");
const STYLE_CSS: &str = include_str!("assets/style.css");

/// The correction server: a bound socket and the run it serves.
pub struct Server {
    http: tiny_http::Server,
    api: Api,
    addr: SocketAddr,
}

impl Server {
    /// Binds `127.0.0.1:port` (0 = any free port).
    pub fn bind(api: Api, port: u16) -> Result<Server> {
        let http = tiny_http::Server::http(("127.0.0.1", port)).map_err(|e| {
            Error::Usage(format!(
                "cannot listen on 127.0.0.1:{port}: {e}; choose another --port"
            ))
        })?;
        let addr = http
            .server_addr()
            .to_ip()
            .expect("an IP listener has an IP address");
        Ok(Server { http, api, addr })
    }

    /// The address the server listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Answers requests until `stop` is set (checked every 100 ms).
    pub fn run(&self, stop: &AtomicBool) {
        while !stop.load(Ordering::Relaxed) {
            match self.http.recv_timeout(Duration::from_millis(100)) {
                Ok(Some(req)) => self.answer(req),
                Ok(None) => {}
                Err(_) => std::thread::sleep(Duration::from_millis(10)),
            }
        }
    }

    fn answer(&self, mut req: tiny_http::Request) {
        let method = req.method().as_str().to_owned();
        let url = req.url().to_owned();
        let header = |name: &'static str| {
            req.headers()
                .iter()
                .find(|h| h.field.equiv(name))
                .map(|h| h.value.as_str().to_owned())
        };
        let host_ok = header("Host").is_some_and(|h| self.host_allowed(&h));
        // A page from elsewhere may send requests here; its Origin gives it away.
        let origin_ok = header("Origin").is_none_or(|o| {
            o.strip_prefix("http://")
                .is_some_and(|h| self.host_allowed(h))
        });
        // Only JSON may be posted: a cross-site form or `text/plain` fetch cannot send it
        // without a CORS preflight, which this server never grants.
        let json = header("Content-Type")
            .is_some_and(|c| c.split(';').next().unwrap_or("").trim() == "application/json");
        let reply = if !host_ok || !origin_ok {
            Reply::error(
                403,
                "requests must come from this machine's page (127.0.0.1 or localhost)",
            )
        } else if method == "POST" && !json {
            Reply::error(
                415,
                "POST bodies must be JSON (Content-Type: application/json)",
            )
        } else {
            let mut body = Vec::new();
            let read = req
                .as_reader()
                .take(MAX_BODY as u64 + 1)
                .read_to_end(&mut body);
            if read.is_err() {
                Reply::error(400, "could not read the request body")
            } else if body.len() > MAX_BODY {
                Reply::error(413, format!("request body over {MAX_BODY} bytes"))
            } else {
                let route = || route(&self.api, &method, &url, &body);
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(route)).unwrap_or_else(|_| {
                    Reply::error(500, "internal error; see the server's terminal")
                })
            }
        };
        let header = |k: &str, v: &str| {
            tiny_http::Header::from_bytes(k.as_bytes(), v.as_bytes()).expect("ASCII header")
        };
        let resp = tiny_http::Response::from_data(reply.body)
            .with_status_code(reply.status)
            .with_header(header("Content-Type", reply.content_type))
            .with_header(header("Cache-Control", "no-store"))
            .with_header(header("X-Content-Type-Options", "nosniff"));
        let _ = req.respond(resp);
    }

    /// True for `127.0.0.1:PORT` and `localhost:PORT`.
    fn host_allowed(&self, host: &str) -> bool {
        let port = self.addr.port();
        host == format!("127.0.0.1:{port}") || host == format!("localhost:{port}")
    }
}

/// Answers one request (see the module doc for the routes).
pub fn route(api: &Api, method: &str, url: &str, body: &[u8]) -> Reply {
    let path = url.split(['?', '#']).next().unwrap_or("");
    let asset = |ct: &'static str, s: &str| Reply {
        status: 200,
        content_type: ct,
        body: s.as_bytes().to_vec(),
    };
    let parts: Vec<&str> = path.split('/').collect();
    let get = method == "GET" || method == "HEAD";
    let post = method == "POST";
    let wrong = || Reply::error(405, format!("{method} is not allowed on {path}"));
    match parts.as_slice() {
        ["", ""] | ["", "index.html"] => {
            if get {
                asset("text/html; charset=utf-8", INDEX_HTML)
            } else {
                wrong()
            }
        }
        ["", "app.js"] if get => asset("text/javascript; charset=utf-8", APP_JS),
        ["", "style.css"] if get => asset("text/css; charset=utf-8", STYLE_CSS),
        ["", "api", "run"] if get => api.run_info(),
        ["", "api", "segments", id] if get => api.segment(id),
        ["", "api", "segments", id] if post => api.save(id, body),
        ["", "api", "segments", id, "frame.png"] if get => api.frame_png(id),
        ["", "api", "segments", id, "resume"] if post => api.resume(id),
        ["", "app.js"] | ["", "style.css"] | ["", "api", "run"] => wrong(),
        ["", "api", "segments", _] | ["", "api", "segments", _, "frame.png" | "resume"] => wrong(),
        _ => Reply::error(404, format!("no such page: {path}")),
    }
}
