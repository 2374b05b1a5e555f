//! Reduced keys on a retargeted walk: the Spine export with straight lines between its keys
//! (`--linear`) starts every channel at time 0 (the seed frame) and reproduces the every-frame
//! export within the default tolerance with far fewer keys; the reduced DragonBones export's
//! keys last until the next one, and its runtime poses it close to the pose. (The Bézier curves
//! are checked by `export_curves`.)

use crate::common::{run as mocap2d, s};
use crate::export::{joint_tracks, node, ok, retargeted_walk, times, worst_error};
use serde_json::Value;
use std::path::Path;

/// Linear interpolation at `t` (s) of Spine keys `keys` (field `field`; a missing `time` is 0).
fn spine_value_at(keys: &[Value], field: &str, t: f64) -> f64 {
    let time = |k: &Value| k["time"].as_f64().unwrap_or(0.0);
    let v = |k: &Value| k[field].as_f64().unwrap();
    let after = keys.iter().position(|k| time(k) > t + 1e-9);
    match after {
        Some(0) => v(&keys[0]),
        None => v(keys.last().unwrap()),
        Some(i) => {
            let (a, b) = (&keys[i - 1], &keys[i]);
            let s = (t - time(a)) / (time(b) - time(a));
            v(a) + s * (v(b) - v(a))
        }
    }
}

#[test]
fn reduced_keys_start_at_zero_and_reproduce_every_frame_within_the_tolerance() {
    let d = tempfile::tempdir().unwrap();
    let (run, anim, _) = retargeted_walk(d.path());
    let every = d.path().join("every.json");
    let reduced = d.path().join("reduced.json");
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "spine",
        "--out",
        s(&every),
        "--every-frame",
    ]));
    // The default tolerance, 0.5 px and 0.5 degrees, with straight lines between the keys (the
    // curves are checked in spine-core by export_curves).
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "spine",
        "--out",
        s(&reduced),
        "--linear",
    ]));
    let read =
        |p: &Path| -> Value { serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap() };
    let (e, r) = (read(&every), read(&reduced));
    let lengths: std::collections::HashMap<String, f64> = e["bones"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| {
            (
                b["name"].as_str().unwrap().to_owned(),
                b["length"].as_f64().unwrap_or(0.0),
            )
        })
        .collect();
    let ts = times(&anim);
    let (mut all, mut kept) = (0usize, 0usize);
    let mut worst = (0.0f64, 0.0f64); // px, degrees
    for (bone, tl) in e["animations"]["mocap"]["bones"].as_object().unwrap() {
        for (channel, fields) in [
            ("translate", &["x", "y"][..]),
            ("rotate", &["value"][..]),
            ("scale", &["x"][..]),
        ] {
            let Some(ek) = tl[channel].as_array() else {
                continue;
            };
            let rk = r["animations"]["mocap"]["bones"][bone][channel]
                .as_array()
                .unwrap_or_else(|| panic!("{bone} {channel} missing"));
            // Every channel starts at time 0, the seed frame, though that is frame 6 of the clip.
            assert_eq!(
                rk[0]["time"].as_f64().unwrap_or(0.0),
                0.0,
                "{bone} {channel}"
            );
            assert_eq!(ek.len(), anim.frames.len());
            all += ek.len();
            kept += rk.len();
            for (t, k) in ek.iter().enumerate() {
                let diff: Vec<f64> = fields
                    .iter()
                    .map(|f| spine_value_at(rk, f, ts[t]) - k[*f].as_f64().unwrap())
                    .collect();
                match channel {
                    "translate" => worst.0 = worst.0.max(diff[0].hypot(diff[1])),
                    "rotate" => worst.1 = worst.1.max(diff[0].abs()),
                    // A scale error moves the bone's tip by that share of its length.
                    _ => worst.0 = worst.0.max(diff[0].abs() * lengths[bone.as_str()]),
                }
            }
        }
    }
    eprintln!(
        "spine keys: {kept} of {all} kept; worst {:.4} px, {:.4} degrees",
        worst.0, worst.1
    );
    // Rounding of the written values adds at most 1e-4.
    assert!(worst.0 <= 0.5 + 1e-3 && worst.1 <= 0.5 + 1e-3, "{worst:?}");
    assert!(kept * 3 < all, "{kept} of {all} keys kept");
    // Sanity: the check can fail, e.g. with the every-frame keys of a shifted clip.
    let shifted = spine_value_at(
        e["animations"]["mocap"]["bones"]["knee_l"]["rotate"]
            .as_array()
            .unwrap(),
        "value",
        ts[5],
    ) - spine_value_at(
        e["animations"]["mocap"]["bones"]["knee_l"]["rotate"]
            .as_array()
            .unwrap(),
        "value",
        ts[15],
    );
    assert!(shifted.abs() > 1.0, "the knee does not move: {shifted}");

    // DragonBones: the same reduction, keys lasting until the next one.
    let db = d.path().join("walk_ske.json");
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "dragonbones",
        "--out",
        s(&db),
    ]));
    let doc = read(&db);
    let arm = &doc["armature"][0];
    assert_eq!(arm["animation"][0]["duration"], anim.frames.len());
    for tl in arm["animation"][0]["bone"].as_array().unwrap() {
        for ch in ["translateFrame", "rotateFrame", "scaleFrame"] {
            if let Some(keys) = tl[ch].as_array() {
                let total: u64 = keys.iter().map(|k| k["duration"].as_u64().unwrap()).sum();
                assert_eq!(total as usize, anim.frames.len(), "{} {ch}", tl["name"]);
                assert!(
                    keys.len() < anim.frames.len(),
                    "{} {ch} not reduced",
                    tl["name"]
                );
            }
        }
    }
    // The runtime poses the reduced DragonBones export close to the pose on every frame.
    let ts: Vec<String> = times(&anim).iter().map(|t| t.to_string()).collect();
    let tex = d.path().join("walk_tex.json");
    let Some(text) = node(
        "dragonbones_pose.mjs",
        "@cocos/dragonbones-js",
        &[s(&db), &ts.join(","), s(&tex)],
    ) else {
        return;
    };
    let r: Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    let origin = anim.floor_origin();
    let down = joint_tracks(&anim, r["bonesYDown"].as_array().unwrap());
    let worst = worst_error(&anim, &down, |q| [q[0] + origin[0], q[1] + origin[1]]);
    eprintln!("dragonbones runtime, reduced keys: worst joint error {worst:.4} px");
    // Each joint sums the tolerances of the channels above it (at most 4 bones deep here).
    assert!(worst < 4.0, "worst joint error {worst} px");
}
