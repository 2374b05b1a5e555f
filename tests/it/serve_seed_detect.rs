//! The seeding page's Detect (`POST /api/frames/N/detect` on `serve CLIP --skeleton FILE
//! --seeds-out SEEDS.toml`): the pose network's proposal of the skeleton's joints on a bare
//! clip, with the rectangles `mocap2d seed` gives them, written nowhere; a clear refusal for a
//! skeleton that is not a person's; and, without the models, an answer saying what is missing
//! and the fix while the server carries on.
#![cfg(feature = "ffmpeg")]

use super::pose::{frames_clip, FRAME_LABELS};
use super::serve::Served;
use super::serve_detect::detect_without_models;
use crate::common::{run, s};
use mocap2d::pose::names::COCO;
use mocap2d::seed::read_seeds;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// A skeleton file of joints `names` (each 9 px square, all children of the first), laid in a
/// column left of the dancer on the bundled frame (203 × 360), off every joint of hers.
fn skeleton(dir: &Path, names: &[&str]) -> PathBuf {
    let mut text = String::from("frame = 0\n");
    for (i, name) in names.iter().enumerate() {
        text += &format!(
            "[[joint]]\nname = \"{name}\"\nx = 12\ny = {}\nw = 9\nh = 9\n",
            10 + 18 * i
        );
        if i > 0 {
            text += &format!("parent = \"{}\"\n", names[0]);
        }
    }
    let path = dir.join("skeleton.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The bundled frame as a 4-frame clip, served for seeding the skeleton `names` into
/// `seeds.toml` (not yet written); returns the folder, the clip, the seed file and the server.
fn seeding(names: &[&str]) -> (tempfile::TempDir, PathBuf, PathBuf, Served) {
    let tmp = tempfile::tempdir().unwrap();
    let clip = frames_clip(tmp.path(), 4);
    let skel = skeleton(tmp.path(), names);
    let out = tmp.path().join("seeds.toml");
    let (c, o) = (clip.clone(), out.clone());
    let srv = Served::start_with(move |stop, ready| {
        mocap2d::app::serve_seeds(&c, &skel, &o, 0, stop, ready)
    });
    (tmp, clip, out, srv)
}

/// The 17 COCO joints and `neck` (no landmark of the network's).
fn person() -> Vec<&'static str> {
    COCO.iter().copied().chain(["neck"]).collect()
}

/// Detect around joints placed on the dancer proposes every COCO joint from the network within
/// 8 px of its label (the bound of the correction page's Detect, `serve_detect`), each with the
/// very rectangle `mocap2d seed` writes for it on that frame; `neck` stays where the page has it,
/// with its size; and nothing is written.
#[test]
fn seeding_detect_proposes_the_seed_files_rectangles_and_writes_nothing() {
    let names = person();
    let (tmp, clip, out, srv) = seeding(&names);
    let (st, info) = srv.json("GET", "/api/run", b"");
    assert_eq!((st, &info["no_detect"]), (200, &Value::Null), "{info}");

    // The page's placed joints: the shoulders and hips on the dancer, and the neck between.
    let placed = json!({ "joints": [
        { "name": "left_shoulder", "x": 140.0, "y": 165.0 },
        { "name": "right_shoulder", "x": 55.0, "y": 160.0 },
        { "name": "left_hip", "x": 125.0, "y": 255.0 },
        { "name": "right_hip", "x": 80.0, "y": 255.0 },
        { "name": "neck", "x": 97.5, "y": 150.25 },
    ]});
    let (st, r) = srv.json(
        "POST",
        "/api/frames/2/detect",
        placed.to_string().as_bytes(),
    );
    assert_eq!(st, 200, "{r}");
    assert_eq!(
        (&r["saved"], &r["people"], r["chosen"].as_str()),
        (
            &false.into(),
            &1.into(),
            Some("the person around the placed joints")
        ),
        "{r}"
    );
    assert!(!out.exists(), "Detect wrote the seed file");
    let joints = r["joints"].as_array().unwrap();
    assert_eq!(joints.len(), names.len(), "{r}");
    let get = |name: &str| joints.iter().find(|j| j["name"] == name).unwrap();
    let f = |v: &Value| v.as_f64().unwrap();

    let neck = get("neck");
    assert_eq!(neck["from"], "placed", "{neck}");
    assert_eq!((f(&neck["x"]), f(&neck["y"])), (97.5, 150.25), "{neck}");
    assert_eq!((&neck["w"], &neck["h"]), (&9.into(), &9.into()), "{neck}");
    assert_eq!(r["kept"], json!(["neck"]), "{r}");

    for (name, x, y) in FRAME_LABELS {
        let j = get(name);
        let d = (f(&j["x"]) - x as f64).hypot(f(&j["y"]) - y as f64);
        assert!(d <= 8.0, "{name}: {d:.1} px from its label: {j}");
    }

    // `mocap2d seed` on the same frame: the same person, squares and places.
    let file = tmp.path().join("by-seed.toml");
    let o = run(&["seed", s(&clip), "--frame", "2", "--out", s(&file)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (seeded, _) = read_seeds(&file).unwrap();
    assert_eq!(seeded.joints.len(), COCO.len());
    for sj in &seeded.joints {
        let j = get(&sj.name);
        assert_eq!(j["from"], "network", "{j}");
        let b = &sj.bbox;
        assert_eq!((&j["w"], &j["h"]), (&b.w.into(), &b.h.into()), "{j}");
        assert_ne!(b.w, 9, "the size is the body's, not the skeleton's");
        assert!(
            (f(&j["x"]) - b.cx as f64).abs() < 0.01 && (f(&j["y"]) - b.cy as f64).abs() < 0.01,
            "{}: proposed {j}, seeded at ({}, {})",
            sj.name,
            b.cx,
            b.cy
        );
    }
    assert!(!out.exists(), "Detect wrote the seed file");

    // Refused before the network runs: a frame beyond the clip, a joint the skeleton has not, a
    // GET.
    let (st, e) = srv.json("POST", "/api/frames/9/detect", b"");
    assert_eq!(st, 404, "{e}");
    assert!(
        e["error"].as_str().unwrap().contains("beyond the clip"),
        "{e}"
    );
    let tail = json!({ "joints": [{ "name": "tail", "x": 1.0, "y": 1.0 }] });
    let (st, e) = srv.json("POST", "/api/frames/1/detect", tail.to_string().as_bytes());
    assert_eq!(st, 400, "{e}");
    assert!(e["error"].as_str().unwrap().contains("\"tail\""), "{e}");
    assert_eq!(srv.req("GET", "/api/frames/1/detect", b"").0, 405);
    assert!(!out.exists());
}

/// A fly's skeleton: `GET /api/run` says why there is no Detect (the page disables the button
/// with it), and a Detect is refused with that reason, writing nothing.
#[test]
fn seeding_detect_is_refused_for_a_skeleton_that_is_not_a_persons() {
    let (_tmp, _clip, out, srv) = seeding(&["thorax", "head", "wingL", "wingR", "abdomen"]);
    let (st, info) = srv.json("GET", "/api/run", b"");
    assert_eq!(st, 200);
    let why = info["no_detect"].as_str().expect("a reason").to_owned();
    assert!(
        why.contains("this skeleton's joints") && why.contains("do not name a person's body"),
        "{why}"
    );
    assert!(why.contains("thorax, head, wingL"), "{why}");
    let (st, r) = srv.json("POST", "/api/frames/1/detect", b"{}");
    assert_eq!((st, r["error"].as_str()), (400, Some(why.as_str())), "{r}");
    assert!(!out.exists());
}

/// `mocap2d serve CLIP --seeds-out` with `MOCAP2D_MODELS` on an empty folder: Detect answers 503
/// naming the missing model and the fix, every time, and the page's other requests are answered.
#[test]
fn seeding_detect_without_the_models_says_so_and_the_server_carries_on() {
    let tmp = tempfile::tempdir().unwrap();
    let clip = frames_clip(tmp.path(), 2);
    let skel = skeleton(tmp.path(), &person());
    let out = tmp.path().join("seeds.toml");
    let empty = tmp.path().join("no-models");
    std::fs::create_dir(&empty).unwrap();
    let args = [s(&clip), "--skeleton", s(&skel), "--seeds-out", s(&out)];
    detect_without_models(&args, &empty, "/api/run");
    assert!(!out.exists());
}
