//! Keys on any frame from the serve page: `GET /api/frames/N`, `POST /api/keys`, and a resume
//! that puts the keyed joint on its key.

use super::serve::{tracked_walk, Served};
use mocap2d::progress::NoProgress;
use mocap2d::seed::read_seeds;

/// The first joint tracked on frame `f`: name and position.
fn tracked_joint(srv: &Served, f: u64) -> (String, f64, f64) {
    let (st, info) = srv.json("GET", &format!("/api/frames/{f}"), b"");
    assert_eq!(st, 200, "{info}");
    let j = &info["joints"][0];
    let (x, y) = (j["x"].as_f64().unwrap(), j["y"].as_f64().unwrap());
    (j["name"].as_str().unwrap().to_owned(), x, y)
}

/// A key saved from the page on a frame inside a segment: it reads back through the API and
/// from `keys.toml`, and `resume --segment K` (K as the answer says) puts the joint exactly on
/// it, as a seed, on that frame.
#[test]
fn a_key_saved_from_the_page_is_kept_and_resume_puts_the_joint_on_it() {
    let (_dir, run) = tracked_walk(30, 10);
    let srv = Served::start(&run);
    let (st, info) = srv.json("GET", "/api/run", b"");
    assert_eq!(
        (st, &info["segment_len"], &info["seed_frame"]),
        (200, &10.into(), &0.into())
    );
    let (name, x, y) = tracked_joint(&srv, 15);
    let (st, f) = srv.json("GET", "/api/frames/15", b"");
    assert_eq!((st, f["keyed"].as_array().unwrap().len()), (200, 0), "{f}");
    let (png_st, png) = srv.req("GET", "/api/frames/15/frame.png", b"");
    assert_eq!((png_st, &png[..4]), (200, &b"\x89PNG"[..]));
    // Stepping on, and back, decodes the right frames again.
    assert_eq!(srv.req("GET", "/api/frames/16/frame.png", b"").0, 200);
    assert_eq!(
        srv.req("GET", "/api/frames/2/frame.png", b"").1[..4],
        b"\x89PNG"[..]
    );
    assert_eq!(srv.req("GET", "/api/frames/15/frame.png", b"").1, png);
    assert_eq!(srv.req("GET", "/api/frames/999", b"").0, 404);

    let (kx, ky) = ((x + 6.0).min(300.0), (y - 4.0).max(10.0));
    let body = serde_json::json!({ "frame": 15, "joints": { &name: [kx, ky] } }).to_string();
    let (st, r) = srv.json("POST", "/api/keys", body.as_bytes());
    assert_eq!(
        (st, r["saved"].as_bool(), &r["segment"]),
        (200, Some(true), &1.into()),
        "{r}"
    );
    // Resumed from the segment before the key's, whose last frames the key pulls too.
    assert_eq!(r["resume_from"], 0, "{r}");
    assert!(
        r["command"].as_str().unwrap().ends_with("--segment 0"),
        "{r}"
    );
    let (_, f) = srv.json("GET", "/api/frames/15", b"");
    assert_eq!(f["keyed"], serde_json::json!([name]), "{f}");
    assert!(
        (f["keys"][&name][0].as_f64().unwrap() - kx).abs() < 1e-3,
        "{f}"
    );
    let text = std::fs::read_to_string(run.join("keys.toml")).unwrap();
    assert!(
        text.contains("frame = 15") && text.contains(&format!("{name} = [")),
        "{text}"
    );
    // Saving the same again changes nothing.
    let (st, r) = srv.json("POST", "/api/keys", body.as_bytes());
    assert_eq!((st, r["saved"].as_bool()), (200, Some(false)), "{r}");
    drop(srv);

    let opts = mocap2d::app::ResumeOptions {
        run: run.clone(),
        segment: Some(1),
        ..Default::default()
    };
    mocap2d::app::resume(&opts, &NoProgress).unwrap();
    let rows = mocap2d::run::tracks::read_tracks(&run.join("tracks.csv")).unwrap();
    let r = rows
        .iter()
        .find(|r| r.frame == 15 && r.joint == name)
        .unwrap();
    assert!(
        (r.x as f64 - kx).abs() < 1e-3 && (r.y as f64 - ky).abs() < 1e-3,
        "{r:?} vs ({kx}, {ky})"
    );
    assert_eq!(r.status, "seed");
}

/// Keys from the page merge per joint and frame, an empty key removes the frame's key, bad keys
/// get 400 naming the problem, and a key while another command holds the run folder gets 409;
/// none of those touch `keys.toml`.
#[test]
fn keys_from_the_page_merge_and_bad_or_locked_ones_touch_nothing() {
    let (_dir, run) = tracked_walk(30, 10);
    let srv = Served::start(&run);
    let (st, f) = srv.json("GET", "/api/frames/4", b"");
    assert_eq!(st, 200);
    let a = f["joints"][0]["name"].as_str().unwrap().to_owned();
    let b = f["joints"][1]["name"].as_str().unwrap().to_owned();
    let post = |v: serde_json::Value| srv.json("POST", "/api/keys", v.to_string().as_bytes());
    assert_eq!(
        post(serde_json::json!({"frame": 4, "joints": {&a: [10, 20]}})).0,
        200
    );
    assert_eq!(
        post(serde_json::json!({"frame": 20, "joints": {&a: [11, 21]}})).0,
        200
    );
    let (st, r) = post(serde_json::json!({"frame": 4, "joints": {&b: [30.5, 40]}}));
    assert_eq!(st, 200, "{r}");
    let keys_now = || std::fs::read_to_string(run.join("keys.toml")).unwrap();
    let names = joint_names(&run);
    let read = || mocap2d::run::keys::read(&run, &names, 320, 240, Some(30)).unwrap();
    let keys = read();
    assert_eq!(keys.iter().map(|k| k.frame).collect::<Vec<_>>(), [4, 20]);
    assert_eq!(keys[0].joints.iter().flatten().count(), 2, "{}", keys_now());

    let before = keys_now();
    for (body, says) in [
        (
            serde_json::json!({"frame": 4, "joints": {"elbow_x": [1, 2]}}),
            "elbow_x",
        ),
        (
            serde_json::json!({"frame": 4, "joints": {&a: [1, 900]}}),
            "outside",
        ),
        (
            serde_json::json!({"frame": 30, "joints": {&a: [1, 2]}}),
            "30 frames",
        ),
        (
            serde_json::json!({"frame": 4, "joints": {&a: [1]}}),
            "malformed",
        ),
        (serde_json::json!({"frame": -1, "joints": {}}), "malformed"),
    ] {
        let (st, r) = post(body.clone());
        let msg = r["error"].as_str().unwrap_or_default();
        assert_eq!(st, 400, "{body}: {r}");
        assert!(msg.contains(says), "{body}: {msg}");
        assert_eq!(keys_now(), before);
    }
    assert_eq!(srv.req("GET", "/api/keys", b"").0, 405);
    assert_eq!(srv.req("POST", "/api/frames/4", b"{}").0, 405);

    let lock = mocap2d::run::lock::RunLock::acquire(&run, "resume").unwrap();
    let (st, r) = post(serde_json::json!({"frame": 6, "joints": {&a: [1, 2]}}));
    assert_eq!(st, 409, "{r}");
    assert!(r["error"].as_str().unwrap().contains("not saved"), "{r}");
    assert_eq!(keys_now(), before);
    drop(lock);

    // An empty key removes frame 4's key; the key on frame 20 stays.
    let (st, r) = post(serde_json::json!({"frame": 4, "joints": {}}));
    assert_eq!((st, r["saved"].as_bool()), (200, Some(true)), "{r}");
    assert_eq!(read().iter().map(|k| k.frame).collect::<Vec<_>>(), [20]);
}

/// A hand-written `keys.toml` saved from the page, one joint moved on one frame and a key added
/// on another: every comment stays, every other line stays byte for byte, and the file reads
/// back to the keys meant.
#[test]
fn a_save_from_the_page_keeps_the_users_comments_and_layout() {
    let (_dir, run) = tracked_walk(30, 10);
    let srv = Served::start(&run);
    let (_, f) = srv.json("GET", "/api/frames/4", b"");
    let a = f["joints"][0]["name"].as_str().unwrap().to_owned();
    let b = f["joints"][1]["name"].as_str().unwrap().to_owned();
    let hand = format!(
        "# My corrections of the walk.\n\n# The arm hides {a} here.\n[[key]]\nframe = 4\n\
         {a} = [10, 20]   # eyeballed\n{b}   =   [30.5, 40.0]\n\n# {b} only\n[[key]]\n\
         frame = 20 # slow-mo\n{b} = [11.0, 21.0]\n# end\n"
    );
    std::fs::write(run.join("keys.toml"), &hand).unwrap();
    let post = |v: serde_json::Value| srv.json("POST", "/api/keys", v.to_string().as_bytes());
    let (st, r) = post(serde_json::json!({"frame": 20, "joints": {&b: [12.5, 22]}}));
    assert_eq!((st, r["saved"].as_bool()), (200, Some(true)), "{r}");
    let (st, r) = post(serde_json::json!({"frame": 9, "joints": {&a: [50, 60.25]}}));
    assert_eq!((st, r["saved"].as_bool()), (200, Some(true)), "{r}");
    let text = std::fs::read_to_string(run.join("keys.toml")).unwrap();

    let comments = |t: &str| -> Vec<String> {
        t.lines()
            .filter_map(|l| l.find('#').map(|i| l[i..].to_owned()))
            .collect()
    };
    assert_eq!(comments(&text), comments(&hand), "{text}");
    let moved = format!("{b} = [11.0, 21.0]");
    let mut lines = text.lines();
    for l in hand.lines().filter(|l| *l != moved) {
        assert!(lines.any(|m| m == l), "{l:?} lost or moved:\n{text}");
    }
    assert!(
        text.contains(&format!(
            "[30.5, 40.0]\n\n[[key]]\nframe = 9\n{a} = [50.0, 60.25]\n\n# {b} only\n"
        )),
        "{text}"
    );
    assert!(
        text.contains(&format!("# slow-mo\n{b} = [12.5, 22.0]\n# end\n")),
        "{text}"
    );

    let names = joint_names(&run);
    let keys = mocap2d::run::keys::read(&run, &names, 320, 240, Some(30)).unwrap();
    let at = |k: &mocap2d::run::keys::Key, n: &str| {
        k.joints[names.iter().position(|m| m == n).unwrap()].map(|p| (p.x, p.y))
    };
    assert_eq!(keys.iter().map(|k| k.frame).collect::<Vec<_>>(), [4, 9, 20]);
    assert_eq!(
        (at(&keys[0], &a), at(&keys[0], &b)),
        (Some((10.0, 20.0)), Some((30.5, 40.0)))
    );
    assert_eq!(
        (at(&keys[1], &a), at(&keys[1], &b)),
        (Some((50.0, 60.25)), None)
    );
    assert_eq!(
        (at(&keys[2], &a), at(&keys[2], &b)),
        (None, Some((12.5, 22.0)))
    );
    // The same key again: not written, not a byte changed.
    let (st, r) = post(serde_json::json!({"frame": 4, "joints": {&a: [10, 20]}}));
    assert_eq!((st, r["saved"].as_bool()), (200, Some(false)), "{r}");
    assert_eq!(
        std::fs::read_to_string(run.join("keys.toml")).unwrap(),
        text
    );
}

/// The joints of the run in `run`, in seed-file order.
fn joint_names(run: &std::path::Path) -> Vec<String> {
    read_seeds(&run.join("seeds.toml"))
        .unwrap()
        .0
        .joints
        .iter()
        .map(|j| j.name.clone())
        .collect()
}
