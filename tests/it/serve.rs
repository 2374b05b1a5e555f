//! `mocap2d serve` at the HTTP level: a server on a free port of 127.0.0.1 in a thread, spoken
//! to over plain TCP so that malformed and hostile requests can be sent exactly: the page and
//! API answer, a save rewrites the segment file by the sent amounts and keeps the old one,
//! and bad requests get 4xx without touching any file.
#![cfg(feature = "ffmpeg")]

use crate::common::write_synth;
use mocap2d::progress::NoProgress;
use mocap2d::seed::{read_seeds, to_toml};
use mocap2d::synth::Scenario;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A synth walk (320×240, `frames` frames) tracked into `r.mocap` in segments of `segment_len`.
pub(crate) fn tracked_walk(frames: u32, segment_len: u64) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    write_synth(dir.path(), Scenario::Walk, 320, 240, 4, Some(frames));
    let mut opts = mocap2d::app::TrackOptions::new(
        dir.path().join("clip.mp4"),
        dir.path().join("joints.toml"),
    );
    opts.out = Some(dir.path().join("r.mocap"));
    opts.segment_len = segment_len;
    let run = mocap2d::app::track(&opts, &NoProgress).unwrap().run_dir;
    (dir, run)
}

/// A tracked synth run (320×240, 30 frames) with segment files at frames 0, 10 and 20.
fn run_with_segments() -> (tempfile::TempDir, PathBuf) {
    let (dir, run) = tracked_walk(30, mocap2d::app::DEFAULT_SEGMENT_LEN);
    let (seeds, _) = read_seeds(&run.join("seeds.toml")).unwrap();
    let rows = mocap2d::run::tracks::read_tracks(&run.join("tracks.csv")).unwrap();
    // Replace the segment files `track` wrote (frames 0 and 29) with three of our own.
    for e in std::fs::read_dir(run.join("segments")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            std::fs::remove_file(p).unwrap();
        }
    }
    for (k, f) in [0u64, 10, 20].into_iter().enumerate() {
        let joints: Vec<_> = seeds
            .joints
            .iter()
            .map(|j| {
                let r = rows
                    .iter()
                    .find(|r| r.frame == f && r.joint == j.name)
                    .unwrap();
                let mut j = j.clone();
                (j.bbox.cx, j.bbox.cy, j.bbox.angle_rad) = (r.x, r.y, r.angle);
                j.score = Some(r.score);
                j.status = Some(r.status.clone());
                j
            })
            .collect();
        let text = to_toml(f, &joints, &format!("segment {k}\nframes {f}.."));
        std::fs::write(run.join(format!("segments/{k:03}.toml")), text).unwrap();
    }
    (dir, run)
}

/// A server on a free port; stopped when dropped.
pub(crate) struct Served {
    pub(crate) addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Served {
    pub(crate) fn start(run: &Path) -> Served {
        let run = run.to_owned();
        Served::start_with(move |stop, ready| mocap2d::app::serve(&run, None, 0, stop, ready))
    }

    /// A server started by `serve(stop, ready)` (one of the app's serve functions on port 0).
    pub(crate) fn start_with(
        serve: impl FnOnce(&AtomicBool, &dyn Fn(SocketAddr)) -> mocap2d::Result<()> + Send + 'static,
    ) -> Served {
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = std::sync::mpsc::channel();
        let s = stop.clone();
        let thread = std::thread::spawn(move || {
            serve(&s, &|a| tx.send(a).unwrap()).unwrap();
        });
        let addr = rx.recv().unwrap();
        Served {
            addr,
            stop,
            thread: Some(thread),
        }
    }

    /// Sends one request (HTTP/1.0, so the reply is never chunked) with a JSON body and returns
    /// status and body.
    fn raw(&self, method: &str, target: &str, host: &str, body: &[u8]) -> (u16, Vec<u8>) {
        self.raw_with(
            method,
            target,
            &format!("Host: {host}\r\nContent-Type: application/json"),
            body,
        )
    }

    /// As [`Served::raw`] with the given header lines (`\r\n`-separated).
    fn raw_with(&self, method: &str, target: &str, headers: &str, body: &[u8]) -> (u16, Vec<u8>) {
        let mut s = TcpStream::connect(self.addr).unwrap();
        // A server that stops answering fails the test instead of hanging it.
        s.set_read_timeout(Some(std::time::Duration::from_secs(20)))
            .unwrap();
        let head = format!(
            "{method} {target} HTTP/1.0\r\n{headers}\r\nConnection: close\r\n\
             Content-Length: {}\r\n\r\n",
            body.len()
        );
        s.write_all(head.as_bytes()).unwrap();
        let _ = s.write_all(body); // the server may stop reading an oversized body
        let mut out = Vec::new();
        let _ = s.read_to_end(&mut out);
        let text_end = out
            .windows(4)
            .position(|w| w == b"\r\n\r\n")
            .expect("a response");
        let status_line = String::from_utf8_lossy(&out[..text_end]).into_owned();
        let status: u16 = status_line.split(' ').nth(1).unwrap().parse().unwrap();
        (status, out[text_end + 4..].to_vec())
    }

    pub(crate) fn req(&self, method: &str, target: &str, body: &[u8]) -> (u16, Vec<u8>) {
        self.raw(
            method,
            target,
            &format!("127.0.0.1:{}", self.addr.port()),
            body,
        )
    }

    pub(crate) fn json(&self, method: &str, target: &str, body: &[u8]) -> (u16, serde_json::Value) {
        let (st, b) = self.req(method, target, body);
        (
            st,
            serde_json::from_slice(&b)
                .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&b))),
        )
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[test]
fn page_api_and_save() {
    let (_dir, run) = run_with_segments();
    let srv = Served::start(&run);
    assert!(srv.addr.ip().is_loopback());

    let (st, page) = srv.req("GET", "/", b"");
    assert_eq!(st, 200);
    assert!(String::from_utf8_lossy(&page).contains("Resume from here"));
    assert_eq!(srv.req("GET", "/app.js", b"").0, 200);
    assert_eq!(srv.req("GET", "/style.css?v=1", b"").0, 200);

    let (st, info) = srv.json("GET", "/api/run", b"");
    assert_eq!(st, 200);
    assert_eq!(info["width"], 320);
    let segs = info["segments"].as_array().unwrap();
    assert_eq!(segs.len(), 3);
    assert_eq!(
        (
            segs[1]["id"].as_str(),
            segs[1]["frame"].as_u64(),
            segs[1]["end"].as_u64()
        ),
        (Some("001"), Some(10), Some(20))
    );
    assert_eq!(info["resume"], true);

    // The first frame of segment 001 is frame 10 of the clip, pixel for pixel.
    let (st, png) = srv.req("GET", "/api/segments/001/frame.png", b"");
    assert_eq!(st, 200);
    let img = image::load_from_memory(&png).unwrap().to_rgb8();
    let clip = mocap2d::decode::read_all(&run.parent().unwrap().join("clip.mp4"), None).unwrap();
    assert!(img == clip[10]);

    let (st, seg) = srv.json("GET", "/api/segments/001", b"");
    assert_eq!(st, 200);
    assert_eq!(seg["frame"], 10);
    let mut joints: Vec<serde_json::Value> = seg["joints"].as_array().unwrap().clone();
    assert_eq!(joints.len(), 14);
    let path = run.join("segments/001.toml");
    let old_text = std::fs::read_to_string(&path).unwrap();
    let (old, _) = read_seeds(&path).unwrap();

    // Move the head by (+7.5, -3), widen it by 4 px and turn it 0.3 rad.
    let hi = joints.iter().position(|j| j["name"] == "head").unwrap();
    let h = &mut joints[hi];
    h["x"] = (h["x"].as_f64().unwrap() + 7.5).into();
    h["y"] = (h["y"].as_f64().unwrap() - 3.0).into();
    h["w"] = (h["w"].as_u64().unwrap() + 4).into();
    h["angle"] = 0.3.into();
    let edits: Vec<serde_json::Value> = joints
        .iter()
        .map(|j| serde_json::json!({"name": j["name"], "x": j["x"], "y": j["y"], "w": j["w"], "h": j["h"], "angle": j["angle"]}))
        .collect();
    let body = serde_json::json!({ "joints": edits }).to_string();
    let (st, r) = srv.json("POST", "/api/segments/001", body.as_bytes());
    assert_eq!(st, 200, "{r}");
    assert_eq!(r["saved"], true);
    assert_eq!(r["previous"], "segments/history/001.001.toml");
    let (new, new_text) = read_seeds(&path).unwrap();
    assert!(
        new_text.starts_with("# segment 1\n# frames 10..\n"),
        "{new_text}"
    );
    assert_eq!(new.frame, 10);
    for (a, b) in old.joints.iter().zip(&new.joints) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.parent, b.parent);
        assert_eq!(a.status, b.status);
        if a.name == "head" {
            assert!(
                (b.bbox.cx - a.bbox.cx - 7.5).abs() < 2e-3,
                "{} -> {}",
                a.bbox.cx,
                b.bbox.cx
            );
            assert!((b.bbox.cy - a.bbox.cy + 3.0).abs() < 2e-3);
            assert_eq!(b.bbox.w, a.bbox.w + 4);
            assert_eq!(b.bbox.h, a.bbox.h);
            assert!((b.bbox.angle_rad - 0.3).abs() < 1e-4);
        } else {
            assert!((a.bbox.cx - b.bbox.cx).abs() < 1e-3 && (a.bbox.cy - b.bbox.cy).abs() < 1e-3);
            assert_eq!((a.bbox.w, a.bbox.h), (b.bbox.w, b.bbox.h));
            assert!((a.bbox.angle_rad - b.bbox.angle_rad).abs() < 1e-4);
        }
    }
    assert_eq!(
        std::fs::read_to_string(run.join("segments/history/001.001.toml")).unwrap(),
        old_text
    );
    // Saving the same again changes nothing and keeps no extra version.
    let (st, r) = srv.json("POST", "/api/segments/001", body.as_bytes());
    assert_eq!((st, r["saved"].as_bool()), (200, Some(false)));
    assert!(!run.join("segments/history/001.002.toml").exists());

    let (st, r) = srv.json("POST", "/api/segments/001/resume", b"");
    // The button runs `resume`: its errors come back as they would on the command line (these
    // hand-made segment files do not follow the run's layout, whose segment 1 is its last frame).
    assert_eq!(st, 400, "{r}");
    assert!(
        r["error"].as_str().unwrap().contains("segments/001.toml"),
        "{r}"
    );
    let (st, r) = srv.json("POST", "/api/segments/000/resume", b"");
    assert_eq!(st, 400, "{r}");
    assert!(
        r["error"].as_str().unwrap().contains("set it back to 29"),
        "{r}"
    );
}

/// The page's "Resume from here" on a run `track` wrote: a rectangle moved and saved on the
/// page is a correction, the button resumes from its segment, and the new tracks start there.
#[test]
fn resume_from_here_takes_the_saved_correction() {
    let (_dir, run) = tracked_walk(24, 10);
    let before = std::fs::read_to_string(run.join("tracks.csv")).unwrap();
    let srv = Served::start(&run);

    // Segment 001 starts on frame 10: move the head 6 px right there and save.
    let (st, seg) = srv.json("GET", "/api/segments/001", b"");
    assert_eq!((st, seg["frame"].as_u64()), (200, Some(10)));
    let edits: Vec<serde_json::Value> = seg["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| {
            let dx = if j["name"] == "head" { 6.0 } else { 0.0 };
            let x = j["x"].as_f64().unwrap() + dx;
            serde_json::json!({"name": j["name"], "x": x, "y": j["y"], "w": j["w"], "h": j["h"], "angle": j["angle"]})
        })
        .collect();
    let body = serde_json::json!({ "joints": edits }).to_string();
    let (st, r) = srv.json("POST", "/api/segments/001", body.as_bytes());
    assert_eq!((st, r["saved"].as_bool()), (200, Some(true)), "{r}");
    let head_x = edits.iter().find(|j| j["name"] == "head").unwrap()["x"]
        .as_f64()
        .unwrap();

    let (st, r) = srv.json("POST", "/api/segments/001/resume", b"");
    assert_eq!((st, r["resumed"].as_bool()), (200, Some(true)), "{r}");
    assert!(
        r["message"].as_str().unwrap().contains("segment 001"),
        "{r}"
    );
    let after = std::fs::read_to_string(run.join("tracks.csv")).unwrap();
    // Frames before the correction stay byte for byte; on it, the head is where it was put.
    let upto = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| {
                l.split(',')
                    .next()
                    .unwrap()
                    .parse::<u64>()
                    .is_ok_and(|f| f < 10)
            })
            .map(str::to_owned)
            .collect()
    };
    assert_eq!(upto(&before), upto(&after));
    let head: Vec<&str> = after
        .lines()
        .find(|l| l.starts_with("10,head,"))
        .unwrap()
        .split(',')
        .collect();
    assert!(
        (head[2].parse::<f64>().unwrap() - head_x).abs() < 0.01,
        "{head:?}"
    );
    assert_eq!(head[6], "seed");
    // The tracks it replaced are kept, and the review was refreshed.
    let history: Vec<_> = std::fs::read_dir(run.join("history")).unwrap().collect();
    assert!(!history.is_empty());
    assert!(run.join("review/confidence.png").exists());
}

#[test]
fn bad_requests_get_4xx_and_touch_nothing() {
    let (_dir, run) = run_with_segments();
    let srv = Served::start(&run);
    let snapshot = |p: &Path| -> Vec<(PathBuf, Vec<u8>)> {
        let mut v: Vec<_> = walk(p)
            .into_iter()
            .map(|f| {
                let b = std::fs::read(&f).unwrap();
                (f, b)
            })
            .collect();
        v.sort();
        v
    };
    let before = snapshot(&run);

    // Paths outside the run folder, however spelt.
    for target in [
        "/../run.toml",
        "/api/segments/../../run.toml",
        "/api/segments/..%2F..%2Frun.toml",
        "/api/segments/..%2Fseeds/frame.png",
        "/api/segments/%2e%2e/frame.png",
        "/api/segments/001.toml",
        "/api/segments/001%00",
        "/api/segments/-1",
        "/api/segments/999",
        "/etc/passwd",
        "/segments/001.toml",
    ] {
        let (st, _) = srv.req("GET", target, b"");
        assert!((400..500).contains(&st), "GET {target}: {st}");
        let (st, _) = srv.req("POST", target, b"{\"joints\":[]}");
        assert!((400..500).contains(&st), "POST {target}: {st}");
    }

    // Malformed or invalid bodies.
    let (_, seg) = srv.json("GET", "/api/segments/002", b"");
    let joints = seg["joints"].as_array().unwrap().clone();
    let edits = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut v: Vec<serde_json::Value> = joints
            .iter()
            .map(|j| serde_json::json!({"name": j["name"], "x": j["x"], "y": j["y"], "w": j["w"], "h": j["h"], "angle": j["angle"]}))
            .collect();
        let mut body = serde_json::json!({ "joints": [] });
        f(&mut v[0]);
        body["joints"] = v.into();
        body.to_string()
    };
    let bodies: Vec<(String, &str)> = vec![
        ("not json".into(), "malformed"),
        ("{\"joints\": 3}".into(), "malformed"),
        ("{\"joints\": []}".into(), "missing"),
        (edits(&|j| j["name"] = "nobody".into()), "nobody"),
        (edits(&|j| j["w"] = 3.into()), "`w`"),
        (edits(&|j| j["h"] = 9.5.into()), "`h`"),
        (edits(&|j| j["x"] = (-40.0).into()), "inside"),
        (edits(&|j| j["y"] = 1e9.into()), "inside"),
        (edits(&|j| j["colour"] = "red".into()), "unknown field"),
        (edits(&|j| j["x"] = "12".into()), "malformed"),
    ];
    for (body, expect) in &bodies {
        let (st, r) = srv.json("POST", "/api/segments/002", body.as_bytes());
        assert_eq!(st, 400, "{body}: {r}");
        assert!(r["error"].as_str().unwrap().contains(expect), "{body}: {r}");
    }
    let big = vec![b' '; 2 << 20];
    assert_eq!(srv.req("POST", "/api/segments/002", &big).0, 413);
    // Wrong methods, and a Host that is not this server.
    assert_eq!(srv.req("DELETE", "/api/segments/002", b"").0, 405);
    assert_eq!(srv.req("PUT", "/api/run", b"").0, 405);
    assert_eq!(srv.req("POST", "/", b"").0, 405);
    let (st, _) = srv.raw("GET", "/api/run", "evil.example:80", b"");
    assert_eq!(st, 403);
    let host = format!("Host: 127.0.0.1:{}", srv.addr.port());
    let body = edits(&|_| {});
    // Another site's page, and a body that is not declared JSON (a cross-site form).
    let evil = format!("{host}\r\nOrigin: http://evil.example\r\nContent-Type: application/json");
    assert_eq!(
        srv.raw_with("POST", "/api/segments/002", &evil, body.as_bytes())
            .0,
        403
    );
    let form = format!("{host}\r\nContent-Type: text/plain");
    assert_eq!(
        srv.raw_with("POST", "/api/segments/002", &form, body.as_bytes())
            .0,
        415
    );
    // The same body from the page itself is accepted (and changes nothing: same values).
    let own = format!(
        "{host}\r\nOrigin: http://{host_}\r\nContent-Type: application/json",
        host_ = &host[6..]
    );
    let (st, r) = srv.raw_with("POST", "/api/segments/002", &own, body.as_bytes());
    assert_eq!(st, 200, "{}", String::from_utf8_lossy(&r));

    assert!(
        snapshot(&run) == before,
        "a bad request changed the run folder"
    );
    // And the server still answers.
    assert_eq!(srv.req("GET", "/api/run", b"").0, 200);
}

fn walk(p: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(p).unwrap() {
        let e = e.unwrap().path();
        if e.is_dir() {
            out.extend(walk(&e));
        } else {
            out.push(e);
        }
    }
    out
}

/// The rectangles of segment `id` as the page sends them, the head moved by `dx` px.
fn save_body(srv: &Served, id: &str, dx: f64) -> String {
    let (st, seg) = srv.json("GET", &format!("/api/segments/{id}"), b"");
    assert_eq!(st, 200, "{seg}");
    let edits: Vec<serde_json::Value> = seg["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| {
            let x = j["x"].as_f64().unwrap() + if j["name"] == "head" { dx } else { 0.0 };
            serde_json::json!({"name": j["name"], "x": x, "y": j["y"], "w": j["w"], "h": j["h"], "angle": j["angle"]})
        })
        .collect();
    serde_json::json!({ "joints": edits }).to_string()
}

/// A save from the page while a command-line `resume` writes the run folder is refused with a
/// clear answer (409, naming the resume) and changes nothing; saved again once the resume is
/// done, the correction is kept, and a later resume tracks from it without rewriting it.
#[test]
fn a_save_while_resume_runs_is_refused_and_the_correction_then_survives() {
    let (_dir, run) = tracked_walk(600, 50);
    let srv = Served::start(&run);
    let file = run.join("segments/002.toml");
    let tool_written = std::fs::read(&file).unwrap();
    let body = save_body(&srv, "002", 9.0);
    let mut child = crate::common::bin()
        .args(["resume", run.to_str().unwrap(), "--segment", "0", "-q"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let lock = run.join(mocap2d::run::lock::LOCK_FILE);
    let t = std::time::Instant::now();
    while !std::fs::read_to_string(&lock)
        .unwrap_or_default()
        .contains("`mocap2d resume`")
    {
        assert!(child.try_wait().unwrap().is_none(), "resume ended too soon");
        assert!(t.elapsed().as_secs() < 60);
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let t = std::time::Instant::now();
    let (st, r) = srv.json("POST", "/api/segments/002", body.as_bytes());
    assert!(t.elapsed() < std::time::Duration::from_secs(1));
    assert_eq!(st, 409, "{r}");
    let msg = r["error"].as_str().unwrap();
    let pid = format!("pid {}", child.id());
    assert!(
        msg.contains(&pid) && msg.contains("resume") && msg.contains("not saved"),
        "{msg}"
    );
    // A key too, at once.
    let key = br#"{"frame": 120, "joints": {"head": [100, 60]}}"#;
    let t = std::time::Instant::now();
    let (st, r) = srv.json("POST", "/api/keys", key);
    assert!(t.elapsed() < std::time::Duration::from_secs(1));
    assert_eq!(st, 409, "{r}");
    assert!(r["error"].as_str().unwrap().contains(&pid), "{r}");
    assert!(!run.join("keys.toml").exists());
    // While the resume replaces tracks.csv, a frame says that a resume writes the run (not 500
    // "tracks.csv: No such file or directory").
    while run.join("tracks.csv").exists() && child.try_wait().unwrap().is_none() {
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let (st, r) = srv.json("GET", "/api/frames/5", b"");
    let still_running = child.try_wait().unwrap().is_none();
    if still_running {
        assert_eq!(st, 409, "{r}");
        let msg = r["error"].as_str().unwrap();
        assert!(msg.contains(&pid) && msg.contains("resume"), "{msg}");
    }
    assert!(
        still_running,
        "the resume ended before the save; lengthen the clip"
    );
    assert_eq!(
        std::fs::read(&file).unwrap(),
        tool_written,
        "refused, unchanged"
    );
    assert!(child.wait().unwrap().success());

    // After the resume: saved, and kept by the next resume, which tracks from it.
    let body = save_body(&srv, "002", 9.0);
    let (st, r) = srv.json("POST", "/api/segments/002", body.as_bytes());
    assert_eq!(
        (st, &r["saved"]),
        (200, &serde_json::Value::Bool(true)),
        "{r}"
    );
    let corrected = std::fs::read(&file).unwrap();
    assert_ne!(corrected, tool_written);
    let o = crate::common::bin()
        .args(["resume", run.to_str().unwrap(), "-q"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read(&file).unwrap(),
        corrected,
        "the correction is kept"
    );
}

/// Sends `head` (the request head, `\r\n\r\n` included) and `body` on a new connection and
/// returns the status of the answer.
fn status_of(srv: &Served, head: &str, body: &[u8]) -> u16 {
    let mut s = TcpStream::connect(srv.addr).unwrap();
    s.set_read_timeout(Some(std::time::Duration::from_secs(30)))
        .unwrap();
    s.write_all(head.as_bytes()).unwrap();
    let _ = s.write_all(body);
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out);
    text.split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("{text:?}"))
}

/// How long a `GET /api/run` takes, asserting it answers 200.
fn time_to_answer(srv: &Served) -> std::time::Duration {
    let t = std::time::Instant::now();
    let (st, _) = srv.req("GET", "/api/run", b"");
    assert_eq!(st, 200);
    t.elapsed()
}

/// A `Content-Length` of 99999999999 (refused or not) is answered 413 without the server
/// allocating it, and the server goes on answering.
#[test]
fn a_lying_content_length_is_refused_and_the_server_lives_on() {
    let (_dir, run) = run_with_segments();
    let srv = Served::start(&run);
    let port = srv.addr.port();
    for host in [format!("127.0.0.1:{port}"), "evil.example".into()] {
        for method in ["POST", "GET"] {
            let head = format!(
                "{method} /api/segments/001 HTTP/1.1\r\nHost: {host}\r\n\
                 Content-Type: application/json\r\nContent-Length: 99999999999\r\n\r\n"
            );
            let st = status_of(&srv, &head, b"{\"joints\":");
            assert!(st == 413 || st == 403, "{method} from {host}: {st}");
            assert!(time_to_answer(&srv) < std::time::Duration::from_secs(1));
        }
    }
    let head = format!(
        "POST /api/segments/001 HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\
         Content-Type: application/json\r\nContent-Length: 18446744073709551616\r\n\r\n"
    );
    assert_eq!(status_of(&srv, &head, b""), 400);
    assert!(time_to_answer(&srv) < std::time::Duration::from_secs(1));
}

/// A client that announces 100000 bytes and sends a few, one that sends half a head, and one
/// that sends nothing hold up no one: the server answers others within 1 s meanwhile.
#[test]
fn a_stalled_request_does_not_block_other_clients() {
    let (_dir, run) = run_with_segments();
    let srv = Served::start(&run);
    let port = srv.addr.port();
    let mut stalled = Vec::new();
    let mut body = TcpStream::connect(srv.addr).unwrap();
    let head = format!(
        "POST /api/segments/001 HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\
         Content-Type: application/json\r\nContent-Length: 100000\r\n\r\n{{\"joints\": ["
    );
    body.write_all(head.as_bytes()).unwrap();
    stalled.push(body);
    let mut half = TcpStream::connect(srv.addr).unwrap();
    half.write_all(b"GET /api/run HTTP/1.1\r\nHost: 127.0")
        .unwrap();
    stalled.push(half);
    stalled.push(TcpStream::connect(srv.addr).unwrap());
    std::thread::sleep(std::time::Duration::from_millis(200));
    for _ in 0..5 {
        let took = time_to_answer(&srv);
        assert!(took < std::time::Duration::from_secs(1), "{took:?}");
    }
    // The page is served too, and a save goes through, all while those three wait.
    assert_eq!(srv.req("GET", "/", b"").0, 200);
    let body = save_body(&srv, "001", 2.0);
    let (st, r) = srv.json("POST", "/api/segments/001", body.as_bytes());
    assert_eq!(st, 200, "{r}");
    // The stalled body, cut short by its client, is refused (400), not taken as a save.
    let before = std::fs::read(run.join("segments/001.toml")).unwrap();
    let mut cut = stalled.remove(0);
    cut.shutdown(std::net::Shutdown::Write).unwrap();
    let mut out = Vec::new();
    let _ = cut.read_to_end(&mut out);
    assert!(
        String::from_utf8_lossy(&out).starts_with("HTTP/1.1 400"),
        "{out:?}"
    );
    assert_eq!(
        std::fs::read(run.join("segments/001.toml")).unwrap(),
        before
    );
    drop(stalled);
}
