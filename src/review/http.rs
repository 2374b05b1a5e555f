//! The HTTP side of `mocap2d serve`, on hyper's HTTP/1 server over tokio: the connections, the
//! parsing of requests and the head's timeout are hyper's; this module adds what the page server
//! refuses before a request reaches its [`Pages`] (see [`Gate::refuse`]), the body's size and
//! time limits, and a clean stop.
//!
//! Every connection is a task on one thread (an idle or slow one costs a few kilobytes, no
//! thread, and there is no cap for idle sockets to fill); the answer to a request is worked out
//! on tokio's blocking pool, so a long answer (a resume) holds up no other. One request per
//! connection (`Connection: close`), as before.

use super::reply::Reply;
use super::serve::{Pages, MAX_BODY, MAX_HEAD, REQUEST_TIMEOUT};
use http_body_util::{BodyExt, Full};
use hyper::body::{Bytes, Incoming};
use hyper::header::{self, HeaderMap, HeaderValue};
use hyper::server::conn::http1;
use hyper::service::service_fn;
use hyper::{Request, Response, StatusCode};
use hyper_util::rt::{TokioIo, TokioTimer};
use std::convert::Infallible;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::net::TcpStream;

/// How often the accept loop looks at the stop flag.
const STOP_POLL: Duration = Duration::from_millis(20);

/// What follows a stop for connections that have sent no whole request: they are closed after
/// this long (requests being answered are waited for).
const STOP_GRACE: Duration = Duration::from_secs(1);

/// After its answer, what a connection still sends (a refused body) is read and dropped for at
/// most this long and this many bytes, so that the client sees the answer, not a reset.
const LINGER: Duration = Duration::from_secs(1);
const LINGER_BYTES: usize = 4 * MAX_BODY;

/// The pages and the port they are served on, shared by every connection.
struct Gate<P> {
    pages: Arc<P>,
    port: u16,
    /// Requests between their head and their answer.
    busy: AtomicUsize,
}

/// Answers connections on `listener` until `stop` is set; then tells the pages (a resume under
/// way stops at its next checkpoint), waits for the requests being answered, and closes the
/// other connections within [`STOP_GRACE`].
pub(super) async fn serve<P: Pages>(
    listener: std::net::TcpListener,
    pages: Arc<P>,
    port: u16,
    stop: &AtomicBool,
) -> std::io::Result<()> {
    let listener = tokio::net::TcpListener::from_std(listener)?;
    let gate = Arc::new(Gate {
        pages,
        port,
        busy: AtomicUsize::new(0),
    });
    let (shut_tx, shut_rx) = tokio::sync::watch::channel(false);
    let mut conns = tokio::task::JoinSet::new();
    let mut tick = tokio::time::interval(STOP_POLL);
    loop {
        tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => {
                    conns.spawn(connection(gate.clone(), stream, shut_rx.clone()));
                }
                // Out of file descriptors, or a connection reset before it was accepted: the
                // listener carries on.
                Err(_) => tokio::time::sleep(Duration::from_millis(10)).await,
            },
            Some(_) = conns.join_next(), if !conns.is_empty() => {}
            _ = tick.tick() => {
                if stop.load(Ordering::SeqCst) {
                    break;
                }
            }
        }
    }
    drop(listener);
    gate.pages.stopping();
    let _ = shut_tx.send(true);
    let grace = Instant::now() + STOP_GRACE;
    while !conns.is_empty() {
        if gate.busy.load(Ordering::SeqCst) == 0 && Instant::now() >= grace {
            break;
        }
        tokio::select! {
            _ = conns.join_next() => {}
            _ = tokio::time::sleep(STOP_POLL) => {}
        }
    }
    conns.abort_all();
    Ok(())
}

/// Serves one connection: hyper reads the request (its head within [`REQUEST_TIMEOUT`], at most
/// [`MAX_HEAD`] bytes: else 431), [`Gate::handle`] answers it, then the connection is closed.
async fn connection<P: Pages>(
    gate: Arc<Gate<P>>,
    stream: TcpStream,
    mut shut: tokio::sync::watch::Receiver<bool>,
) {
    let service = service_fn(move |req| {
        let gate = gate.clone();
        Box::pin(async move { Ok::<_, Infallible>(gate.handle(req).await) })
    });
    let mut conn = http1::Builder::new()
        .timer(TokioTimer::new())
        .header_read_timeout(REQUEST_TIMEOUT)
        .keep_alive(false)
        .max_buf_size(MAX_HEAD)
        .max_header_size(MAX_HEAD)
        .serve_connection(TokioIo::new(stream), service);
    loop {
        tokio::select! {
            _ = std::future::poll_fn(|cx| conn.poll_without_shutdown(cx)) => break,
            _ = shut.changed(), if !*shut.borrow() => Pin::new(&mut conn).graceful_shutdown(),
        }
    }
    linger(conn.into_parts().io.into_inner()).await;
}

/// Ends the answer (FIN), then reads and drops what the client still sends for a moment.
async fn linger(mut stream: TcpStream) {
    use tokio::io::AsyncWrite;
    if std::future::poll_fn(|cx| Pin::new(&mut stream).poll_shutdown(cx))
        .await
        .is_err()
    {
        return;
    }
    let drain = async {
        let (mut left, mut buf) = (LINGER_BYTES, vec![0u8; 8192]);
        while left > 0 && stream.readable().await.is_ok() {
            match stream.try_read(&mut buf) {
                Ok(0) => break,
                Ok(n) => left = left.saturating_sub(n),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                Err(_) => break,
            }
        }
    };
    let _ = tokio::time::timeout(LINGER, drain).await;
}

/// Counts a request as being answered while alive.
struct Busy<'a>(&'a AtomicUsize);

impl<'a> Busy<'a> {
    fn new(n: &'a AtomicUsize) -> Busy<'a> {
        n.fetch_add(1, Ordering::SeqCst);
        Busy(n)
    }
}

impl Drop for Busy<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

impl<P: Pages> Gate<P> {
    /// The answer to a request whose head hyper has read.
    async fn handle(&self, req: Request<Incoming>) -> Response<Full<Bytes>> {
        let _busy = Busy::new(&self.busy);
        let reply = match self.refuse(&req) {
            Some(r) => r,
            None => self.answer(req).await,
        };
        response(reply)
    }

    /// Reads the body (by [`REQUEST_TIMEOUT`]: else 408) and has the pages answer, on the
    /// blocking pool (a handler that panics answers 500).
    async fn answer(&self, req: Request<Incoming>) -> Reply {
        let method = req.method().as_str().to_owned();
        let target = req
            .uri()
            .path_and_query()
            .map_or("/", |p| p.as_str())
            .to_owned();
        let body = match tokio::time::timeout(REQUEST_TIMEOUT, req.into_body().collect()).await {
            Ok(Ok(b)) => b.to_bytes(),
            Ok(Err(_)) => {
                return Reply::error(
                    400,
                    "malformed request: the body is shorter than its Content-Length",
                )
            }
            Err(_) => return Reply::error(408, "the request body did not arrive in time"),
        };
        let pages = self.pages.clone();
        tokio::task::spawn_blocking(move || pages.answer(&method, &target, &body))
            .await
            .unwrap_or_else(|_| Reply::error(500, "internal error; see the server's terminal"))
    }

    /// The reply refusing a request before its body is read, if it is refused: 411 for a body
    /// sent without a `Content-Length`; 413 for a `Content-Length` over [`MAX_BODY`]; 400 for
    /// two `Host`s or a target that is not a path; 403 from another site (by `Host` or `Origin`,
    /// so that a web page elsewhere reaches the server neither directly nor through a DNS name
    /// pointed at 127.0.0.1); 415 for a POST whose body is not declared JSON. (hyper refuses
    /// what HTTP/1.1 does not allow with 400 before this: a malformed request line or header,
    /// a `Content-Length` that is not digits, two that differ.)
    fn refuse(&self, req: &Request<Incoming>) -> Option<Reply> {
        let h = req.headers();
        let bad = |m: &str| Some(Reply::error(400, format!("malformed request: {m}")));
        if h.contains_key(header::TRANSFER_ENCODING) {
            return Some(Reply::error(411, "send the body with a Content-Length"));
        }
        // hyper has checked that the length is a number (and refused two that differ).
        let len = h
            .get(header::CONTENT_LENGTH)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.parse::<u64>().ok())
            .unwrap_or(0);
        if len > MAX_BODY as u64 {
            return Some(Reply::error(
                413,
                format!("request body over {MAX_BODY} bytes"),
            ));
        }
        if h.get_all(header::HOST).iter().count() > 1 {
            return bad("more than one Host");
        }
        if req.uri().authority().is_some() || !req.uri().path().starts_with('/') {
            return bad("the request target is not a path");
        }
        let host_ok = one(h, header::HOST).is_some_and(|v| self.host_allowed(v));
        // A page from elsewhere may send requests here; its Origin gives it away.
        let origin_ok = h.get_all(header::ORIGIN).iter().all(|o| {
            o.to_str()
                .ok()
                .and_then(|o| o.strip_prefix("http://"))
                .is_some_and(|o| self.host_allowed(o))
        });
        if !host_ok || !origin_ok {
            return Some(Reply::error(
                403,
                "requests must come from this machine's page (127.0.0.1 or localhost)",
            ));
        }
        // Only JSON may be posted: a cross-site form or `text/plain` fetch cannot send it
        // without a CORS preflight, which this server never grants.
        let json = one(h, header::CONTENT_TYPE).is_some_and(|c| {
            c.split(';')
                .next()
                .unwrap_or("")
                .trim()
                .eq_ignore_ascii_case("application/json")
        });
        if req.method() == hyper::Method::POST && !json {
            return Some(Reply::error(
                415,
                "POST bodies must be JSON (Content-Type: application/json)",
            ));
        }
        None
    }

    /// True for `127.0.0.1:PORT` and `localhost:PORT` (any case).
    fn host_allowed(&self, host: &str) -> bool {
        let port = self.port;
        host.eq_ignore_ascii_case(&format!("127.0.0.1:{port}"))
            || host.eq_ignore_ascii_case(&format!("localhost:{port}"))
    }
}

/// The value of header `name` when it is given once, as text.
fn one(h: &HeaderMap, name: header::HeaderName) -> Option<&str> {
    let mut all = h.get_all(name).iter();
    match (all.next(), all.next()) {
        (Some(v), None) => v.to_str().ok(),
        _ => None,
    }
}

/// `reply` as a response that is never cached nor sniffed as another type (hyper adds the
/// `Content-Length`, leaves out the body for HEAD, and closes the connection).
fn response(reply: Reply) -> Response<Full<Bytes>> {
    let mut r = Response::new(Full::new(Bytes::from(reply.body)));
    *r.status_mut() =
        StatusCode::from_u16(reply.status).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR);
    let h = r.headers_mut();
    h.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static(reply.content_type),
    );
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    r
}
