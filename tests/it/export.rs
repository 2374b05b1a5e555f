//! `mocap2d export`, end to end on run folders built from synthetic ground truth: the BVH
//! round trip, the JSON export, the same bytes from every format on the same inputs, and the
//! errors of bad combinations. The helpers here (run folders from ground truth, the retargeted
//! walk, the Node.js runtimes) serve the other `export_*` modules too.
//!
//! The runtime checks run Node.js scripts in tests/js/ against the npm packages that
//! `scripts/setup` installs there (`npm ci`). Without them the tests fail, saying how to install
//! them; `MOCAP2D_SKIP_JS=1` skips them instead, loudly.

use crate::common::{self, root, run as mocap2d, s, synth_clip};
use mocap2d::export::{self, Animation};
use mocap2d::retarget::files::{read_manifest, read_pose, read_skeleton};
use mocap2d::synth::{Scenario, SynthClip};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub(crate) fn clip(scenario: Scenario, frames: u32) -> SynthClip {
    synth_clip(scenario, 320, 240, 1, Some(frames))
}

/// A run folder whose tracks are `clip`'s ground truth: tracks.csv, seeds.toml, run.toml.
pub(crate) fn run_from_gt(dir: &Path, clip: &SynthClip) -> PathBuf {
    run_from_gt_from(dir, clip, 0)
}

/// [`run_from_gt`] seeded on frame `first`: the tracks start there.
pub(crate) fn run_from_gt_from(dir: &Path, clip: &SynthClip, first: usize) -> PathBuf {
    common::run_from_gt(dir, clip, first, |f, j| 0.5 + 0.01 * ((f + j) % 50) as f32)
}

pub(crate) fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "exit {:?}: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The retargeted animation of `run`, as the exporters read it.
pub(crate) fn animation(run: &Path) -> Animation {
    let dir = run.join("retarget");
    let skeleton = read_skeleton(&dir.join("pose.csv"), &dir.join("bones.csv")).unwrap();
    let (frames, joints) = read_pose(&dir.join("pose.csv"), &skeleton.names).unwrap();
    let m = read_manifest(&dir.join("retarget.toml")).unwrap();
    Animation {
        skeleton,
        frames,
        joints,
        fps: m.fps,
        width: m.width,
        height: m.height,
    }
}

/// The frame the walk of [`retargeted_walk`] is seeded on.
pub(crate) const SEED_FRAME: u64 = 6;

/// A walk seeded on frame [`SEED_FRAME`], retargeted onto the robot with the cartoon filter (so
/// the first frame is not the rest pose and bones stretch): the run folder, its animation and
/// the target file.
pub(crate) fn retargeted_walk(dir: &Path) -> (PathBuf, Animation, PathBuf) {
    let run = run_from_gt_from(dir, &clip(Scenario::Walk, 42), SEED_FRAME as usize);
    let target = root().join("configs/characters/robot.toml");
    ok(&mocap2d(&[
        "retarget",
        s(&run),
        "--target",
        s(&target),
        "--cartoon",
        "2",
    ]));
    let anim = animation(&run);
    (run, anim, target)
}

/// Runs `tests/js/<script>` with Node.js; `None` (after a loud note) when the JavaScript side is
/// not installed and `MOCAP2D_SKIP_JS=1`; a failure saying how to install it otherwise.
pub(crate) fn node(script: &str, package: &str, args: &[&str]) -> Option<String> {
    let js = root().join("tests/js");
    let installed = js.join("node_modules").join(package).is_dir();
    let node_ok = Command::new("node")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !(installed && node_ok) {
        let what = if node_ok {
            format!("the npm package {package} is not installed in tests/js/node_modules")
        } else {
            "Node.js (`node`) is not on PATH".to_owned()
        };
        if std::env::var("MOCAP2D_SKIP_JS").is_ok_and(|v| v == "1") {
            eprintln!(
                "\n*** SKIPPED {script}: {what} (MOCAP2D_SKIP_JS=1). This export was NOT \
                 checked against its runtime. ***\n"
            );
            return None;
        }
        panic!(
            "{what}: run `bash scripts/setup` (installs Node.js and runs `npm ci` in tests/js), \
             or set MOCAP2D_SKIP_JS=1 to skip the runtime checks"
        );
    }
    let o = Command::new("node")
        .arg(js.join(script))
        .args(args)
        .current_dir(&js)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "node {script} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    Some(String::from_utf8(o.stdout).unwrap())
}

/// Seconds of every exported frame on the animation's clock (0 on the first frame), as written
/// in the keys.
pub(crate) fn times(anim: &Animation) -> Vec<f64> {
    anim.frames
        .iter()
        .map(|&f| ((f - anim.frames[0]) as f64 / anim.fps * 1e6).round() / 1e6)
        .collect()
}

/// For each joint, its position (runtime axes) at each time: a root joint's bone origin, else
/// the tip of the bone ending at it. `bones` is the runtime's list of posed bones.
pub(crate) fn joint_tracks(anim: &Animation, bones: &[Value]) -> Vec<Vec<[f64; 2]>> {
    let names = export::spine::bone_names(anim);
    (0..anim.skeleton.len())
        .map(|j| {
            let b = bones
                .iter()
                .find(|b| b["name"] == names.of_joint[j].as_str())
                .unwrap_or_else(|| panic!("no bone {}", names.of_joint[j]));
            let (kx, ky) = match anim.skeleton.parent(j) {
                None => ("x", "y"),
                Some(_) => ("tipX", "tipY"),
            };
            let xs = b[kx].as_array().unwrap();
            let ys = b[ky].as_array().unwrap();
            xs.iter()
                .zip(ys)
                .map(|(x, y)| [x.as_f64().unwrap(), y.as_f64().unwrap()])
                .collect()
        })
        .collect()
}

/// Largest distance (px) between the runtime's joints, mapped to output px by `to_px`, and the
/// pose.
pub(crate) fn worst_error(
    anim: &Animation,
    tracks: &[Vec<[f64; 2]>],
    to_px: impl Fn([f64; 2]) -> [f64; 2],
) -> f64 {
    let mut worst = 0.0f64;
    for (j, track) in tracks.iter().enumerate() {
        assert_eq!(track.len(), anim.frames.len());
        for (t, &q) in track.iter().enumerate() {
            let p = to_px(q);
            let want = anim.joints[t][j];
            worst = worst.max((p[0] - want[0]).hypot(p[1] - want[1]));
        }
    }
    worst
}

#[test]
fn bvh_reads_back_to_the_pose() {
    let d = tempfile::tempdir().unwrap();
    let (run, anim, _) = retargeted_walk(d.path());
    let out = d.path().join("walk.bvh");
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "bvh",
        "--out",
        s(&out),
    ]));
    let text = std::fs::read_to_string(&out).unwrap();
    let m = export::bvh::read_bvh(&text).unwrap();
    let (mut got, mut want) = (m.names.clone(), anim.skeleton.names.clone());
    got.sort();
    want.sort();
    assert_eq!(
        got, want,
        "one BVH joint per joint (a single root: no extra ROOT)"
    );
    assert!((m.frame_time - 1.0 / 30.0).abs() < 1e-8);
    assert_eq!(m.positions.len(), anim.frames.len());
    let origin = anim.floor_origin();
    let mut worst = 0.0f64;
    for (t, frame) in m.positions.iter().enumerate() {
        for (j, name) in anim.skeleton.names.iter().enumerate() {
            let k = m.names.iter().position(|n| n == name).unwrap();
            // Parents as in the skeleton.
            let parent = anim
                .skeleton
                .parent(j)
                .map(|p| anim.skeleton.names[p].as_str());
            assert_eq!(m.parents[k].map(|p| m.names[p].as_str()), parent, "{name}");
            let p = export::bvh::from_bvh_point(frame[k], origin);
            let want = anim.joints[t][j];
            worst = worst.max((p[0] - want[0]).hypot(p[1] - want[1]));
        }
    }
    assert!(worst < 0.01, "worst joint error {worst} px");
}

#[test]
fn invalid_combinations_exit_2_with_a_clear_message() {
    let d = tempfile::tempdir().unwrap();
    let run = run_from_gt(d.path(), &clip(Scenario::Walk, 8));
    let out = d.path().join("x.out");
    let expect = |args: &[&str], needles: &[&str]| {
        let o = mocap2d(args);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        for n in needles {
            assert!(err.contains(n), "{args:?}: {n:?} not in {err}");
        }
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    };
    let robot = root().join("configs/characters/robot.toml");
    expect(
        &["export", s(&run), "--format", "spine", "--out", s(&out)],
        &["no retargeted pose", "mocap2d retarget"],
    );
    expect(
        &["export", s(&run), "--format", "fbx", "--out", s(&out)],
        &["fbx", "spine", "dragonbones", "bvh", "dlc-csv", "json"],
    );
    for f in ["bvh", "dragonbones"] {
        expect(
            &["export", s(&run), "--format", f, "--out", s(&out)],
            &["no retargeted pose", "mocap2d retarget"],
        );
    }
    expect(
        &[
            "export",
            s(&run),
            "--format",
            "spine",
            "--target",
            s(&robot),
            "--out",
            s(&out),
        ],
        &["no retargeted pose", "mocap2d retarget"],
    );
    expect(
        &[
            "export",
            s(&run),
            "--format",
            "bvh",
            "--target",
            s(&robot),
            "--out",
            s(&out),
        ],
        &["does not use a character file"],
    );
    expect(
        &[
            "export",
            s(&d.path().join("nope")),
            "--format",
            "json",
            "--out",
            s(&out),
        ],
        &["not a folder"],
    );
    expect(
        &[
            "export",
            s(&run),
            "--format",
            "json",
            "--out",
            s(&d.path().join("no/x.json")),
        ],
        &["does not exist"],
    );
    // Retargeted onto the robot, exported as Spine with the imp: refused.
    ok(&mocap2d(&["retarget", s(&run), "--target", s(&robot)]));
    expect(
        &[
            "export",
            s(&run),
            "--format",
            "spine",
            "--target",
            s(&root().join("configs/characters/imp.toml")),
            "--out",
            s(&out),
        ],
        &["was retargeted onto", "robot.toml"],
    );
    // Tracks edited after the retarget: refused.
    let tracks = run.join("tracks.csv");
    let text = std::fs::read_to_string(&tracks).unwrap();
    std::fs::write(&tracks, text.replacen(",ok\n", ",low\n", 1)).unwrap();
    expect(
        &["export", s(&run), "--format", "bvh", "--out", s(&out)],
        &["tracks.csv changed after the retarget"],
    );
}

#[test]
fn json_holds_tracks_and_pose_and_exports_are_deterministic() {
    let d = tempfile::tempdir().unwrap();
    let (run, anim, target) = retargeted_walk(d.path());
    let out = d.path().join("walk.json");
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "json",
        "--out",
        s(&out),
    ]));
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(doc["schema"], export::json::SCHEMA);
    assert_eq!(doc["tracks"]["frames"].as_array().unwrap().len(), 36);
    let pose = &doc["pose"];
    assert_eq!(pose["frames"].as_array().unwrap().len(), anim.frames.len());
    let t = 7;
    for (j, name) in anim.skeleton.names.iter().enumerate() {
        assert_eq!(pose["joints"][j]["name"], name.as_str());
        let x = pose["frames"][t]["x"][j].as_f64().unwrap();
        assert!((x - anim.joints[t][j][0]).abs() < 1e-9);
    }
    // Same inputs, same bytes, for every format.
    for (f, extra) in [
        ("spine", vec!["--target", s(&target)]),
        ("dragonbones", vec!["--target", s(&target)]),
        ("bvh", vec![]),
        ("dlc-csv", vec![]),
        ("json", vec![]),
    ] {
        let a = d.path().join(format!("a.{f}"));
        let b = d.path().join(format!("b.{f}"));
        for p in [&a, &b] {
            let mut args = vec!["export", s(&run), "--format", f, "--out", s(p)];
            args.extend(&extra);
            ok(&mocap2d(&args));
        }
        assert_eq!(
            std::fs::read(&a).unwrap(),
            std::fs::read(&b).unwrap(),
            "{f}"
        );
    }
}
