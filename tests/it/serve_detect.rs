//! The serve page's Detect button (`POST /api/frames/N/detect`, issue 44 item 3): the pose
//! network's proposal of a key on a person's frame, near the joints' labels and written
//! nowhere; a clear refusal for a run whose skeleton is not a person's; and, without the
//! models, an answer saying what is missing and the fix while the server carries on.
#![cfg(feature = "ffmpeg")]

use super::pose::{frames_clip, FRAME_LABELS};
use super::serve::Served;
use super::serve_resume::{address, request, timed, Child};
use crate::common::{bin, files, run, s};
use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

/// A clip of 4 copies of the bundled frame, seeded by `mocap2d seed` (the 17 COCO joints) and
/// tracked into `person.mocap`; with `fly`, the same seeds under a fly's joint names, tracked
/// into `fly.mocap`.
fn tracked_person(dir: &Path, fly: bool) -> PathBuf {
    let clip = frames_clip(dir, 4);
    let seeds = dir.join("s.toml");
    let o = run(&["seed", s(&clip), "--out", s(&seeds)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (seeds, out) = if fly {
        let mut text = std::fs::read_to_string(&seeds).unwrap();
        for (i, name) in mocap2d::pose::names::COCO.iter().enumerate() {
            text = text.replace(&format!("\"{name}\""), &format!("\"fly.part{i}\""));
        }
        let f = dir.join("fly.toml");
        std::fs::write(&f, text).unwrap();
        (f, dir.join("fly.mocap"))
    } else {
        (seeds, dir.join("person.mocap"))
    };
    let o = run(&[
        "track",
        s(&clip),
        "--seeds",
        s(&seeds),
        "--out",
        s(&out),
        "-q",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

/// Every file of a folder with its bytes and modification time.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>, std::time::SystemTime)> {
    files(dir)
        .into_iter()
        .map(|p| {
            let t = std::fs::metadata(&p).unwrap().modified().unwrap();
            (p.clone(), std::fs::read(&p).unwrap(), t)
        })
        .collect()
}

/// Detect on a person's frame proposes every joint from the network, each within 8 px of its
/// label (measured: at most 7.5 px, the nose, on the bundled frame at half size), as an
/// unsaved proposal: the run folder is byte for byte and time for time as before. Saved through
/// the page's own key route, the proposal is a key of that frame.
#[test]
fn detect_proposes_the_persons_joints_near_their_labels_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let run_dir = tracked_person(tmp.path(), false);
    let srv = Served::start(&run_dir);
    let (st, info) = srv.json("GET", "/api/run", b"");
    assert_eq!((st, &info["no_detect"]), (200, &serde_json::Value::Null));
    let before = snapshot(&run_dir);
    let (st, r) = srv.json("POST", "/api/frames/2/detect", b"{}");
    assert_eq!(st, 200, "{r}");
    assert_eq!(r["saved"], false, "{r}");
    assert_eq!(r["people"], 1, "{r}");
    assert_eq!(r["mirrored"], false, "{r}");
    let joints = r["joints"].as_array().unwrap();
    assert_eq!(joints.len(), 17, "{r}");
    assert!(joints.iter().all(|j| j["from"] == "network"), "{r}");
    let mut worst = (0f64, "");
    for (name, x, y) in FRAME_LABELS {
        let j = joints.iter().find(|j| j["name"] == name).unwrap();
        let d = (j["x"].as_f64().unwrap() - x as f64).hypot(j["y"].as_f64().unwrap() - y as f64);
        if d > worst.0 {
            worst = (d, name);
        }
        assert!(d <= 8.0, "{name}: {d:.1} px from its label: {j}");
    }
    println!("worst proposed joint: {} at {:.1} px", worst.1, worst.0);
    // A second press uses the engine kept from the first and proposes the same.
    let (st, again) = srv.json("POST", "/api/frames/2/detect", b"{}");
    assert_eq!((st, &again["joints"]), (200, &r["joints"]));
    assert_eq!(
        snapshot(&run_dir),
        before,
        "Detect wrote into the run folder"
    );
    assert!(!run_dir.join("keys.toml").exists());
    // Frames out of the clip, and a GET, are refused.
    let (st, e) = srv.json("POST", "/api/frames/9/detect", b"{}");
    assert_eq!(st, 404, "{e}");
    assert!(
        e["error"].as_str().unwrap().contains("beyond the clip"),
        "{e}"
    );
    assert_eq!(srv.req("GET", "/api/frames/2/detect", b"").0, 405);

    // The user saves the proposal as any key.
    let key: serde_json::Map<String, serde_json::Value> = joints
        .iter()
        .map(|j| {
            let name = j["name"].as_str().unwrap().to_owned();
            (name, serde_json::json!([j["x"], j["y"]]))
        })
        .collect();
    let body = serde_json::json!({ "frame": 2, "joints": key }).to_string();
    let (st, saved) = srv.json("POST", "/api/keys", body.as_bytes());
    assert_eq!((st, saved["saved"].as_bool()), (200, Some(true)), "{saved}");
    assert_eq!(saved["keyed"].as_array().unwrap().len(), 17, "{saved}");
}

/// A fly's run: `GET /api/run` says why there is no Detect (the page disables the button with
/// it), and a Detect is refused with that reason.
#[test]
fn detect_is_refused_on_a_run_whose_skeleton_is_not_a_persons() {
    let tmp = tempfile::tempdir().unwrap();
    let run_dir = tracked_person(tmp.path(), true);
    let srv = Served::start(&run_dir);
    let (st, info) = srv.json("GET", "/api/run", b"");
    assert_eq!(st, 200);
    let why = info["no_detect"].as_str().expect("a reason").to_owned();
    assert!(
        why.contains("do not name a person's body") && why.contains("fly.part0"),
        "{why}"
    );
    let before = snapshot(&run_dir);
    let (st, r) = srv.json("POST", "/api/frames/1/detect", b"{}");
    assert_eq!((st, r["error"].as_str()), (400, Some(why.as_str())), "{r}");
    assert_eq!(snapshot(&run_dir), before);
}

/// `mocap2d serve` with `MOCAP2D_MODELS` on an empty folder: Detect answers 503 naming the
/// missing model and the fix, every time, and the server answers the page's other requests.
#[test]
fn detect_without_the_models_says_so_and_the_server_carries_on() {
    let tmp = tempfile::tempdir().unwrap();
    let run_dir = tracked_person(tmp.path(), false);
    let empty = tmp.path().join("no-models");
    std::fs::create_dir(&empty).unwrap();
    detect_without_models(&[s(&run_dir)], &empty, "/api/frames/1");
    assert!(!run_dir.join("keys.toml").exists());
}

/// `mocap2d serve ARGS --port 0` with `MOCAP2D_MODELS` on the empty folder `models`: Detect
/// answers 503 naming the missing model and the fix, twice, and `GET other` answers 200 after
/// each; the server is still running at the end.
pub(crate) fn detect_without_models(args: &[&str], models: &Path, other: &str) {
    let (mut child, addr) = serve_with(args, "MOCAP2D_MODELS", models);
    for _ in 0..2 {
        let (st, r, _) = timed(addr, "POST", "/api/frames/1/detect", "{}");
        assert_eq!(st, 503, "{r}");
        let msg = r["error"].as_str().unwrap();
        let model = models.join("pose_detection.onnx");
        assert!(
            msg.contains(&model.display().to_string())
                && msg.contains("cannot read the pose model")
                && msg.contains("scripts/setup"),
            "{msg}"
        );
        let (st, _) = request(addr, "GET", other, "");
        assert_eq!(st, Some(200), "the server answers after a failed Detect");
    }
    assert!(child.0.try_wait().unwrap().is_none(), "serve is running");
}

/// `mocap2d serve ARGS --port 0` with the environment variable `var` set to `value`, and the
/// address it serves on.
fn serve_with(args: &[&str], var: &str, value: &Path) -> (Child, SocketAddr) {
    let mut child = Child(
        bin()
            .env(var, value)
            .arg("serve")
            .args(args)
            .args(["--port", "0"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let first = BufReader::new(child.0.stderr.take().unwrap())
        .lines()
        .next()
        .unwrap()
        .unwrap();
    let addr = address(&first);
    (child, addr)
}

/// A server started before ONNX Runtime is installed answers Detect with 503 naming the
/// library's path and the fix, and finds the library once it is there, without a restart.
#[test]
fn detect_finds_onnx_runtime_installed_after_the_server_started() {
    let tmp = tempfile::tempdir().unwrap();
    let run_dir = tracked_person(tmp.path(), false);
    let lib = tmp.path().join("ort").join("libonnxruntime.so");
    let (mut child, addr) = serve_with(&[s(&run_dir)], "MOCAP2D_ONNXRUNTIME", &lib);
    let (st, r, _) = timed(addr, "POST", "/api/frames/1/detect", "{}");
    assert_eq!(st, 503, "{r}");
    let msg = r["error"].as_str().unwrap();
    assert!(
        msg.contains(&lib.display().to_string())
            && msg.contains("cannot load ONNX Runtime")
            && msg.contains("scripts/setup"),
        "{msg}"
    );
    std::fs::create_dir(lib.parent().unwrap()).unwrap();
    std::fs::copy(mocap2d::pose::engine::library_path(), &lib).unwrap();
    let (st, r, _) = timed(addr, "POST", "/api/frames/1/detect", "{}");
    assert_eq!(st, 200, "{r}");
    assert!(child.0.try_wait().unwrap().is_none(), "serve is running");
}
