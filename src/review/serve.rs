//! `mocap2d serve`: a small HTTP server, bound to 127.0.0.1 only, for the correction page. The
//! page's HTML, script and style are compiled into the binary (no CDN: it works offline).
//!
//! Routes (anything else is 404; a wrong method 405):
//! - `GET /`, `/app.js`, `/keys.js`, `/seeds.js`, `/style.css`: the page.
//! - `GET /api/run`: segments with flags, joints, frame size.
//! - `GET /api/segments/ID`, `GET /api/segments/ID/frame.png`: one segment.
//! - `POST /api/segments/ID`: save edited rectangles (JSON, at most [`MAX_BODY`] bytes).
//! - `POST /api/segments/ID/resume`: resume tracking from the segment (501 when the app gives no
//!   resume).
//! - `GET /api/frames/N`, `GET /api/frames/N/frame.png`: any tracked frame, its joints and keys.
//! - `POST /api/keys`: save a key on any frame into `keys.toml` (see [`super::keys_api`]).
//!
//! The seeding page of a bare clip (`serve CLIP --seeds-out FILE`) answers `GET /api/run`,
//! `GET /api/frames/N/frame.png`, `POST /api/seeds` and `POST /api/seeds/track` instead (see
//! [`super::seed_api`]).
//!
//! Segment ids and frame numbers are digits, and every file served or written is a segment
//! file or `keys.toml` of the run folder, the seed file named at start, the clip, or an embedded
//! asset, so no request reaches any other path. Requests
//! whose `Host` is not this server's loopback address are refused (403), so a web page elsewhere
//! cannot reach the server through a DNS name pointed at 127.0.0.1. A handler that panics
//! answers 500 and the server carries on.
//!
//! One client cannot hold up the others: every connection is answered on its own thread (at
//! most [`MAX_CONNECTIONS`] at once; more get 503), one request per connection. A request whose
//! head or body does not arrive within [`REQUEST_TIMEOUT`] gets 408, a head over
//! [`MAX_HEAD`] bytes 431, and a `Content-Length` over [`MAX_BODY`] 413 before any of the body
//! is read, so no client makes the server allocate more than that.

use super::api::{Api, Reply};
use crate::error::{Error, Result};
use std::io::{Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Largest request body accepted, bytes.
pub const MAX_BODY: usize = 1 << 20;

/// Largest request head (request line and headers) accepted, bytes.
pub const MAX_HEAD: usize = 16 << 10;

/// Time a client has to send a whole request (head and body).
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(10);

/// Connections answered at once; more are refused with 503 until one ends.
pub const MAX_CONNECTIONS: usize = 32;

const INDEX_HTML: &str = include_str!("assets/index.html");
const APP_JS: &str = include_str!("assets/app.js");
const KEYS_JS: &str = include_str!("assets/keys.js");
const SEEDS_JS: &str = include_str!("assets/seeds.js");
const STYLE_CSS: &str = include_str!("assets/style.css");

/// What a server answers: the correction page of a run ([`Api`], routes in [`route`]) or the
/// seeding page of a bare clip ([`super::seed_api::SeedApi`]).
pub trait Pages: Send + Sync {
    /// The reply to one request read in full.
    fn answer(&self, method: &str, url: &str, body: &[u8]) -> Reply;
}

impl Pages for Api {
    fn answer(&self, method: &str, url: &str, body: &[u8]) -> Reply {
        route(self, method, url, body)
    }
}

/// The server: a bound socket and the pages it serves.
pub struct Server<P: Pages = Api> {
    listener: TcpListener,
    api: P,
    addr: SocketAddr,
    /// Saves from the page, one at a time (the run folder's lock keeps other processes out).
    saving: std::sync::Mutex<()>,
}

/// A request as read from a connection.
struct Request {
    method: String,
    target: String,
    headers: Vec<(String, String)>,
    body: Vec<u8>,
}

impl Request {
    /// The value of header `name` (case-insensitive), the first if repeated.
    fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }
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
            api,
            addr,
            saving: std::sync::Mutex::new(()),
        })
    }

    /// The address the server listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Answers requests, each connection on its own thread, until `stop` is set (checked every
    /// 20 ms); then waits for the requests under way.
    pub fn run(&self, stop: &AtomicBool) {
        let active = AtomicUsize::new(0);
        std::thread::scope(|scope| {
            while !stop.load(Ordering::Relaxed) {
                let stream = match self.listener.accept() {
                    Ok((s, _)) => s,
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                        std::thread::sleep(Duration::from_millis(20));
                        continue;
                    }
                    Err(_) => {
                        std::thread::sleep(Duration::from_millis(10));
                        continue;
                    }
                };
                if active.fetch_add(1, Ordering::SeqCst) >= MAX_CONNECTIONS {
                    active.fetch_sub(1, Ordering::SeqCst);
                    let busy = Reply::error(503, "too many requests at once; try again");
                    let _ = stream.set_write_timeout(Some(Duration::from_millis(200)));
                    respond(&stream, "GET", &busy);
                    continue;
                }
                let active = &active;
                scope.spawn(move || {
                    self.connection(stream);
                    active.fetch_sub(1, Ordering::SeqCst);
                });
            }
        });
    }

    /// Reads one request from `stream`, answers it and closes the connection.
    fn connection(&self, stream: TcpStream) {
        let deadline = Instant::now() + REQUEST_TIMEOUT;
        let setup = stream
            .set_nonblocking(false)
            .and_then(|_| stream.set_write_timeout(Some(REQUEST_TIMEOUT)));
        if setup.is_err() {
            return;
        }
        let (method, reply) = match self.read_request(&stream, deadline) {
            Ok(req) => {
                let reply = self.answer(&req);
                (req.method, reply)
            }
            Err(reply) => (String::new(), reply),
        };
        respond(&stream, &method, &reply);
        // Read what the client still sends (a refused body) for a moment before closing, so
        // that it sees the answer rather than a reset connection.
        let _ = stream.shutdown(Shutdown::Write);
        let _ = stream.set_read_timeout(Some(Duration::from_millis(200)));
        let (mut left, mut buf) = (4 * MAX_BODY, [0u8; 8192]);
        let until = Instant::now() + Duration::from_secs(1);
        while left > 0 && Instant::now() < until {
            match (&stream).read(&mut buf) {
                Ok(0) | Err(_) => break,
                Ok(n) => left = left.saturating_sub(n),
            }
        }
    }

    /// Reads a request's head and body, by `deadline`; the reply to send instead when it is
    /// malformed, too large or too slow.
    fn read_request(
        &self,
        mut stream: &TcpStream,
        deadline: Instant,
    ) -> std::result::Result<Request, Reply> {
        let timeout = || Reply::error(408, "the request did not arrive in time");
        let mut data = Vec::new();
        let mut buf = [0u8; 4096];
        let head_end = loop {
            if let Some(i) = data.windows(4).position(|w| w == b"\r\n\r\n") {
                break i;
            }
            if data.len() > MAX_HEAD {
                return Err(Reply::error(
                    431,
                    format!("request head over {MAX_HEAD} bytes"),
                ));
            }
            let n = read_by(&mut stream, &mut buf, deadline).map_err(|_| timeout())?;
            if n == 0 {
                return Err(Reply::error(400, "the request ended before its head did"));
            }
            data.extend_from_slice(&buf[..n]);
        };
        if head_end > MAX_HEAD {
            return Err(Reply::error(
                431,
                format!("request head over {MAX_HEAD} bytes"),
            ));
        }
        let bad = |m: &str| Reply::error(400, format!("malformed request: {m}"));
        let head = std::str::from_utf8(&data[..head_end]).map_err(|_| bad("head is not UTF-8"))?;
        let mut lines = head.split("\r\n");
        let line = lines.next().unwrap_or("");
        let mut parts = line.split(' ');
        let (Some(method), Some(target), Some(version), None) =
            (parts.next(), parts.next(), parts.next(), parts.next())
        else {
            return Err(bad("the request line is not `METHOD TARGET HTTP/1.x`"));
        };
        if !version.starts_with("HTTP/1.") || method.is_empty() || !target.starts_with('/') {
            return Err(bad("the request line is not `METHOD TARGET HTTP/1.x`"));
        }
        let mut headers = Vec::new();
        for l in lines {
            let Some((k, v)) = l.split_once(':') else {
                return Err(bad("a header line without `:`"));
            };
            headers.push((k.trim().to_owned(), v.trim().to_owned()));
        }
        let mut req = Request {
            method: method.to_owned(),
            target: target.to_owned(),
            headers,
            body: Vec::new(),
        };
        if req.header("Transfer-Encoding").is_some() {
            return Err(Reply::error(411, "send the body with a Content-Length"));
        }
        let lengths: Vec<&str> = req
            .headers
            .iter()
            .filter(|(k, _)| k.eq_ignore_ascii_case("Content-Length"))
            .map(|(_, v)| v.as_str())
            .collect();
        let len: u64 = match lengths.as_slice() {
            [] => 0,
            [v] => v
                .parse()
                .map_err(|_| bad("Content-Length is not a number"))?,
            _ => return Err(bad("more than one Content-Length")),
        };
        if len > MAX_BODY as u64 {
            return Err(Reply::error(
                413,
                format!("request body over {MAX_BODY} bytes"),
            ));
        }
        if let Some(refused) = self.refuse(&req) {
            return Err(refused);
        }
        let len = len as usize;
        if req
            .header("Expect")
            .is_some_and(|e| e.eq_ignore_ascii_case("100-continue"))
        {
            let _ = stream.write_all(b"HTTP/1.1 100 Continue\r\n\r\n");
        }
        let mut body = data[head_end + 4..].to_vec();
        body.truncate(len);
        while body.len() < len {
            let want = (len - body.len()).min(buf.len());
            let n = read_by(&mut stream, &mut buf[..want], deadline).map_err(|_| timeout())?;
            if n == 0 {
                return Err(bad("the body is shorter than its Content-Length"));
            }
            body.extend_from_slice(&buf[..n]);
        }
        req.body = body;
        Ok(req)
    }

    /// The reply refusing `req` before its body is read: 403 from another site (by `Host` or
    /// `Origin`), 415 for a POST whose body is not declared JSON.
    fn refuse(&self, req: &Request) -> Option<Reply> {
        let host_ok = req.header("Host").is_some_and(|h| self.host_allowed(h));
        // A page from elsewhere may send requests here; its Origin gives it away.
        let origin_ok = req.header("Origin").is_none_or(|o| {
            o.strip_prefix("http://")
                .is_some_and(|h| self.host_allowed(h))
        });
        // Only JSON may be posted: a cross-site form or `text/plain` fetch cannot send it
        // without a CORS preflight, which this server never grants.
        let json = req
            .header("Content-Type")
            .is_some_and(|c| c.split(';').next().unwrap_or("").trim() == "application/json");
        if !host_ok || !origin_ok {
            Some(Reply::error(
                403,
                "requests must come from this machine's page (127.0.0.1 or localhost)",
            ))
        } else if req.method == "POST" && !json {
            Some(Reply::error(
                415,
                "POST bodies must be JSON (Content-Type: application/json)",
            ))
        } else {
            None
        }
    }

    /// The reply to a request read in full.
    fn answer(&self, req: &Request) -> Reply {
        let route = || {
            // Saves from the page wait for each other; `track` or `resume` holding the run
            // folder makes a save answer 409 (see `Api::save`).
            let _one = (req.method == "POST")
                .then(|| self.saving.lock().unwrap_or_else(|e| e.into_inner()));
            self.api.answer(&req.method, &req.target, &req.body)
        };
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(route))
            .unwrap_or_else(|_| Reply::error(500, "internal error; see the server's terminal"))
    }

    /// True for `127.0.0.1:PORT` and `localhost:PORT`.
    fn host_allowed(&self, host: &str) -> bool {
        let port = self.addr.port();
        host == format!("127.0.0.1:{port}") || host == format!("localhost:{port}")
    }
}

/// Reads into `buf` with a timeout that ends at `deadline`.
fn read_by(stream: &mut &TcpStream, buf: &mut [u8], deadline: Instant) -> std::io::Result<usize> {
    let left = deadline.saturating_duration_since(Instant::now());
    if left.is_zero() {
        return Err(std::io::ErrorKind::TimedOut.into());
    }
    stream.set_read_timeout(Some(left))?;
    stream.read(buf)
}

/// Writes `reply` as an HTTP/1.1 response that closes the connection (no body for HEAD).
fn respond(mut stream: &TcpStream, method: &str, reply: &Reply) {
    let head = format!(
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n\
         X-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n",
        reply.status,
        reason(reply.status),
        reply.content_type,
        reply.body.len()
    );
    let mut out = head.into_bytes();
    if method != "HEAD" {
        out.extend_from_slice(&reply.body);
    }
    let _ = stream.write_all(&out);
    let _ = stream.flush();
}

/// The reason phrase of the status codes this server sends.
fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        409 => "Conflict",
        411 => "Length Required",
        413 => "Content Too Large",
        415 => "Unsupported Media Type",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        501 => "Not Implemented",
        503 => "Service Unavailable",
        _ => "",
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
        ["", "api", "run"] => wrong(),
        ["", "api", "segments", _] | ["", "api", "segments", _, "frame.png" | "resume"] => wrong(),
        ["", "api", "frames", _] | ["", "api", "frames", _, "frame.png"] | ["", "api", "keys"] => {
            wrong()
        }
        _ => Reply::error(404, format!("no such page: {path}")),
    }
}
