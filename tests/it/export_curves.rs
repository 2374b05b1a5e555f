//! Reduced keys with Bézier curves (issue 46 item 5, docs/method.md §7.1): the Spine export
//! sampled by spine-core 4.2 and the DragonBones export by the DragonBones runtime on every frame
//! hold every bone within the stated tolerance of the every-frame export's values, with fewer
//! keys than straight lines on the synthetic walk.

use crate::common::{run as mocap2d, s};
use crate::export::{animation, clip, node, ok, run_from_gt_from, times};
use mocap2d::export::Animation;
use mocap2d::synth::Scenario;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The tolerance asked for (px and degrees) and the slack of the written decimals and of the
/// runtimes' 32-bit floats.
const TOL: f64 = 0.5;
const SLACK: f64 = 2e-3;

/// A 150-frame walk retargeted onto the robot with the cartoon filter (bones stretch, so scale
/// channels move too): the run folder and its animation.
fn walk(dir: &Path) -> (PathBuf, Animation) {
    let run = run_from_gt_from(dir, &clip(Scenario::Walk, 150), 0);
    let target = crate::common::root().join("configs/characters/robot.toml");
    ok(&mocap2d(&[
        "retarget",
        s(&run),
        "--target",
        s(&target),
        "--cartoon",
        "2",
    ]));
    let anim = animation(&run);
    (run, anim)
}

fn export(run: &Path, format: &str, out: &Path, extra: &[&str]) -> Value {
    let mut args = vec!["export", s(run), "--format", format, "--out", s(out)];
    args.extend(extra);
    ok(&mocap2d(&args));
    serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap()
}

/// All keys of the animation's bone timelines, and how many of them carry a curve.
fn count(timelines: impl Iterator<Item = Value>) -> (usize, usize) {
    let (mut keys, mut curves) = (0, 0);
    for keys_of in timelines {
        for k in keys_of.as_array().unwrap() {
            keys += 1;
            curves += usize::from(k.get("curve").is_some());
        }
    }
    (keys, curves)
}

fn spine_timelines(doc: &Value) -> impl Iterator<Item = Value> + '_ {
    doc["animations"]["mocap"]["bones"]
        .as_object()
        .unwrap()
        .values()
        .flat_map(|tl| tl.as_object().unwrap().values().cloned())
}

fn db_timelines(doc: &Value) -> impl Iterator<Item = Value> + '_ {
    doc["armature"][0]["animation"][0]["bone"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|tl| {
            ["translateFrame", "rotateFrame", "scaleFrame"]
                .into_iter()
                .filter_map(|ch| tl.get(ch).cloned())
        })
}

/// The worst differences (px for positions and scales at the bone's tip, degrees) between two
/// runtime outputs' `local` values, bone by bone and time by time; `lengths` by bone name.
fn worst_local(a: &[Value], b: &[Value], lengths: &dyn Fn(&str) -> f64) -> (f64, f64) {
    let mut worst = (0.0f64, 0.0f64);
    assert_eq!(a.len(), b.len());
    for (ba, bb) in a.iter().zip(b) {
        assert_eq!(ba["name"], bb["name"]);
        let len = lengths(ba["name"].as_str().unwrap());
        let (la, lb) = (
            ba["local"].as_array().unwrap(),
            bb["local"].as_array().unwrap(),
        );
        assert_eq!(la.len(), lb.len());
        for (pa, pb) in la.iter().zip(lb) {
            let v = |p: &Value, k: usize| p[k].as_f64().unwrap();
            worst.0 = worst
                .0
                .max((v(pa, 0) - v(pb, 0)).hypot(v(pa, 1) - v(pb, 1)));
            let turn = (v(pa, 2) - v(pb, 2) + 540.0).rem_euclid(360.0) - 180.0;
            worst.1 = worst.1.max(turn.abs());
            worst.0 = worst.0.max((v(pa, 3) - v(pb, 3)).abs() * len);
        }
    }
    worst
}

#[test]
fn spine_curves_hold_every_bone_within_the_tolerance_in_spine_core_with_fewer_keys() {
    let d = tempfile::tempdir().unwrap();
    let (run, anim) = walk(d.path());
    let dir = d.path().join("out");
    std::fs::create_dir(&dir).unwrap();
    let every = export(&run, "spine", &dir.join("every.json"), &["--every-frame"]);
    let linear = export(&run, "spine", &dir.join("linear.json"), &["--linear"]);
    let curved = export(&run, "spine", &dir.join("curves.json"), &[]);
    let (all, _) = count(spine_timelines(&every));
    let (lines, none) = count(spine_timelines(&linear));
    let (kept, curves) = count(spine_timelines(&curved));
    assert_eq!(none, 0);
    // The same animation with the curves taken out: the check below must see the difference.
    let mut stripped = curved.clone();
    for tl in stripped["animations"]["mocap"]["bones"]
        .as_object_mut()
        .unwrap()
        .values_mut()
    {
        for keys in tl.as_object_mut().unwrap().values_mut() {
            for k in keys.as_array_mut().unwrap() {
                k.as_object_mut().unwrap().remove("curve");
            }
        }
    }
    std::fs::write(dir.join("stripped.json"), stripped.to_string()).unwrap();
    std::fs::copy(dir.join("curves.atlas"), dir.join("stripped.atlas")).unwrap();

    let ts: Vec<String> = times(&anim).iter().map(|t| t.to_string()).collect();
    let pose = |name: &str| -> Option<Value> {
        let (json, atlas) = (
            dir.join(format!("{name}.json")),
            dir.join(format!("{name}.atlas")),
        );
        let text = node(
            "spine_pose.mjs",
            "@esotericsoftware/spine-core",
            &[s(&json), s(&atlas), &ts.join(",")],
        )?;
        Some(serde_json::from_str(&text).unwrap())
    };
    let Some(want) = pose("every") else {
        return;
    };
    let (got, bare) = (pose("curves").unwrap(), pose("stripped").unwrap());
    let lengths = |name: &str| -> f64 {
        every["bones"]
            .as_array()
            .unwrap()
            .iter()
            .find(|b| b["name"] == name)
            .and_then(|b| b["length"].as_f64())
            .unwrap_or(0.0)
    };
    let bones = |v: &Value| v["bones"].as_array().unwrap().clone();
    let worst = worst_local(&bones(&want), &bones(&got), &lengths);
    let without = worst_local(&bones(&want), &bones(&bare), &lengths);
    eprintln!(
        "spine, {} frames: every frame {all} keys, linear {lines}, curves {kept} ({curves} with a \
         curve); spine-core worst {:.4} px, {:.4} degrees (curves dropped: {:.3} px, {:.3} degrees)",
        anim.frames.len(),
        worst.0,
        worst.1,
        without.0,
        without.1
    );
    assert!(
        worst.0 <= TOL + SLACK && worst.1 <= TOL + SLACK,
        "{worst:?}"
    );
    assert!(
        kept < lines && curves > 0,
        "{kept} keys with curves, {lines} linear"
    );
    assert!(
        without.0.max(without.1) > TOL,
        "the curves change nothing: {without:?}"
    );
}

#[test]
fn dragonbones_curves_hold_every_bone_within_the_tolerance_in_its_runtime_with_fewer_keys() {
    let d = tempfile::tempdir().unwrap();
    let (run, anim) = walk(d.path());
    let dir = d.path().join("out");
    std::fs::create_dir(&dir).unwrap();
    let every = export(
        &run,
        "dragonbones",
        &dir.join("every_ske.json"),
        &["--every-frame"],
    );
    let linear = export(
        &run,
        "dragonbones",
        &dir.join("linear_ske.json"),
        &["--linear"],
    );
    let curved = export(&run, "dragonbones", &dir.join("curves_ske.json"), &[]);
    let (all, _) = count(db_timelines(&every));
    let (lines, none) = count(db_timelines(&linear));
    let (kept, curves) = count(db_timelines(&curved));
    assert_eq!(none, 0);
    let ts: Vec<String> = times(&anim).iter().map(|t| t.to_string()).collect();
    let pose = |name: &str| -> Option<Value> {
        let text = node(
            "dragonbones_pose.mjs",
            "@cocos/dragonbones-js",
            &[s(&dir.join(format!("{name}_ske.json"))), &ts.join(",")],
        )?;
        Some(serde_json::from_str(text.lines().last().unwrap()).unwrap())
    };
    let Some(want) = pose("every") else {
        return;
    };
    let got = pose("curves").unwrap();
    let lengths = |name: &str| -> f64 {
        every["armature"][0]["bone"]
            .as_array()
            .unwrap()
            .iter()
            .find(|b| b["name"] == name)
            .and_then(|b| b["length"].as_f64())
            .unwrap_or(0.0)
    };
    let bones = |v: &Value| v["bonesYDown"].as_array().unwrap().clone();
    let worst = worst_local(&bones(&want), &bones(&got), &lengths);
    eprintln!(
        "dragonbones, {} frames: every frame {all} keys, linear {lines}, curves {kept} ({curves} \
         with a curve); runtime worst {:.4} px, {:.4} degrees",
        anim.frames.len(),
        worst.0,
        worst.1
    );
    assert!(
        worst.0 <= TOL + SLACK && worst.1 <= TOL + SLACK,
        "{worst:?}"
    );
    assert!(
        kept < lines && curves > 0,
        "{kept} keys with curves, {lines} linear"
    );
}
