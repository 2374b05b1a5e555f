//! `mocap2d serve` while a resume started from the page runs, and Ctrl-C then: saves are refused
//! (409) at once, a frame says a resume is running, and Ctrl-C stops the server cleanly, the
//! resume at a checkpoint that `mocap2d resume` carries on from (issue 45, items 7 and 9).
#![cfg(feature = "ffmpeg")]

use super::serve::tracked_walk;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::Path;
use std::time::{Duration, Instant};

/// One request to `addr` (JSON body), as the page sends it: the status (`None` when the
/// connection closed without an answer) and the body.
pub(crate) fn request(
    addr: SocketAddr,
    method: &str,
    target: &str,
    body: &str,
) -> (Option<u16>, String) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(120))).unwrap();
    let head = format!(
        "{method} {target} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nContent-Type: application/json\r\n\
         Content-Length: {}\r\n\r\n{body}",
        addr.port(),
        body.len()
    );
    s.write_all(head.as_bytes()).unwrap();
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out).into_owned();
    let status = text.get(9..12).and_then(|c| c.parse().ok());
    let body = text.split_once("\r\n\r\n").map(|(_, b)| b.to_owned());
    (status, body.unwrap_or_default())
}

/// `request`, timed, its body as JSON.
pub(crate) fn timed(
    addr: SocketAddr,
    method: &str,
    target: &str,
    body: &str,
) -> (u16, serde_json::Value, Duration) {
    let t = Instant::now();
    let (st, b) = request(addr, method, target, body);
    let took = t.elapsed();
    let v = serde_json::from_str(&b).unwrap_or_else(|e| panic!("{method} {target}: {e}: {b:?}"));
    (st.expect("an answer"), v, took)
}

/// Waits (at most 60 s) until the run folder's lock names a running `mocap2d resume`.
fn wait_for_resume(run: &Path, running: impl Fn() -> bool) {
    let lock = run.join(mocap2d::run::lock::LOCK_FILE);
    let t = Instant::now();
    while !std::fs::read_to_string(&lock)
        .unwrap_or_default()
        .contains("`mocap2d resume`")
    {
        assert!(running(), "the resume ended too soon");
        assert!(t.elapsed() < Duration::from_secs(60), "no resume started");
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// The rectangles of segment `id` as the page sends them, unchanged.
fn segment_body(addr: SocketAddr, id: &str) -> String {
    let (st, seg, _) = timed(addr, "GET", &format!("/api/segments/{id}"), "");
    assert_eq!(st, 200, "{seg}");
    let joints: Vec<serde_json::Value> = seg["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| serde_json::json!({"name": j["name"], "x": j["x"], "y": j["y"], "w": j["w"], "h": j["h"], "angle": j["angle"]}))
        .collect();
    serde_json::json!({ "joints": joints }).to_string()
}

/// A child process, killed if the test fails while it runs.
pub(crate) struct Child(pub(crate) std::process::Child);

/// The address in `mocap2d serve`'s first line (`… on http://ADDR/ …`).
pub(crate) fn address(first: &str) -> SocketAddr {
    first
        .split("http://")
        .nth(1)
        .and_then(|r| r.split('/').next())
        .and_then(|a| a.parse().ok())
        .unwrap_or_else(|| panic!("no address in {first:?}"))
}

impl Drop for Child {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A resume started from the page: while it runs, key and segment saves answer 409 at once
/// (today's main makes them wait for the whole resume, then saves them), a frame answers 409
/// saying a resume runs (main: 500 "tracks.csv: No such file"), a second resume 409, and the
/// page's other requests are answered. Then Ctrl-C: the resume stops at a checkpoint (or
/// finishes), its request is answered, `serve` exits 0 leaving no lock, and `mocap2d resume`
/// finishes the run (main: the process exits at once, the request unanswered).
#[test]
fn saves_during_a_page_resume_get_409_at_once_and_ctrl_c_stops_cleanly() {
    let (_dir, run) = tracked_walk(600, 50);
    let mut child = Child(
        crate::common::bin()
            .args(["serve", run.to_str().unwrap(), "--port", "0"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let child = &mut child.0;
    let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    let addr = address(&first);
    let rest = std::thread::spawn(move || lines.map_while(|l| l.ok()).collect::<Vec<_>>());

    let seg_body = segment_body(addr, "002");
    let seg_file = run.join("segments/002.toml");
    let seg_before = std::fs::read(&seg_file).unwrap();
    let resumed =
        std::thread::spawn(move || request(addr, "POST", "/api/segments/000/resume", "{}"));
    wait_for_resume(&run, || !resumed.is_finished());

    let key = r#"{"frame": 120, "joints": {"head": [100, 60]}}"#;
    let (st, r, took) = timed(addr, "POST", "/api/keys", key);
    assert_eq!(st, 409, "a key during the page's resume: {r}");
    assert!(took < Duration::from_secs(1), "{took:?}");
    assert!(r["error"].as_str().unwrap().contains("resume"), "{r}");
    let (st, r, took) = timed(addr, "POST", "/api/segments/002", &seg_body);
    assert_eq!(st, 409, "a segment save during the page's resume: {r}");
    assert!(took < Duration::from_secs(1), "{took:?}");
    let (st, r, _) = timed(addr, "GET", "/api/frames/5", "");
    assert_eq!(st, 409, "a frame during the page's resume: {r}");
    assert!(r["error"].as_str().unwrap().contains("resume"), "{r}");
    let (st, r, _) = timed(addr, "POST", "/api/segments/001/resume", "{}");
    assert_eq!(st, 409, "a second resume: {r}");
    // The page's other requests are answered meanwhile (`/api/run` works out the report, which
    // takes a moment on a loaded machine, not the resume's seconds).
    let (st, _, took) = timed(addr, "GET", "/api/run", "");
    assert_eq!(st, 200);
    assert!(took < Duration::from_secs(3), "{took:?}");
    assert!(
        !resumed.is_finished(),
        "the resume ended before the probes; lengthen the clip"
    );
    assert!(
        !run.join("keys.toml").exists(),
        "the refused key is not written"
    );
    assert_eq!(
        std::fs::read(&seg_file).unwrap(),
        seg_before,
        "nor the segment"
    );

    // Ctrl-C.
    let t = Instant::now();
    let killed = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let (st, body) = resumed.join().unwrap();
    let status = child.wait().unwrap();
    let took = t.elapsed();
    let stderr = rest.join().unwrap().join("\n");
    assert!(
        st == Some(503) || st == Some(200),
        "the resume's request is answered: {st:?} {body} ({stderr})"
    );
    if st == Some(503) {
        assert!(body.contains("checkpoint"), "{body}");
    }
    assert!(
        status.success(),
        "serve exits 0 on Ctrl-C: {status:?}: {stderr}"
    );
    assert!(took < Duration::from_secs(20), "{took:?}");
    assert!(stderr.contains("serve stopped"), "{stderr}");
    assert!(!run.join(mocap2d::run::lock::LOCK_FILE).exists());
    // The run carries on from its checkpoint to the end.
    let o = crate::common::bin()
        .args(["resume", run.to_str().unwrap(), "-q"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rows = mocap2d::run::tracks::read_tracks(&run.join("tracks.csv")).unwrap();
    assert_eq!(rows.iter().map(|r| r.frame).max(), Some(599));
}
