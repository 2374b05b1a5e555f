//! `mocap2d export`, end to end on run folders built from synthetic ground truth: the Spine
//! export loaded by the official Spine runtime (spine-core's SkeletonJson) and the DragonBones
//! export by the DragonBones runtime's core, both posed at every frame and compared with
//! `retarget/pose.csv`; BVH and DeepLabCut CSV round trips; the errors of bad combinations.
//!
//! The runtime checks run Node.js scripts in tests/js/ against the npm packages that
//! `scripts/setup` installs there (`npm ci`). Without them the tests fail, saying how to install
//! them; `MOCAP2D_SKIP_JS=1` skips them instead, loudly.

use crate::common::{self, root, run as mocap2d, s, synth_clip};
use mocap2d::character::read_character;
use mocap2d::export::{self, Animation};
use mocap2d::retarget::files::{read_manifest, read_pose, read_skeleton};
use mocap2d::synth::{self, Scenario, SynthClip};
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub(crate) fn clip(scenario: Scenario, frames: u32) -> SynthClip {
    synth_clip(scenario, 320, 240, 1, Some(frames))
}

/// A run folder whose tracks are `clip`'s ground truth: tracks.csv, seeds.toml, run.toml.
fn run_from_gt(dir: &Path, clip: &SynthClip) -> PathBuf {
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
const SEED_FRAME: u64 = 6;

/// A walk seeded on frame [`SEED_FRAME`], retargeted onto the robot with the cartoon filter (so
/// the first frame is not the rest pose and bones stretch): the run folder, its animation and
/// the target file.
fn retargeted_walk(dir: &Path) -> (PathBuf, Animation, PathBuf) {
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

/// Copies the files of folder `from` into a new folder `to` (no subfolders expected), then
/// deletes `from`: what a user moving or zipping an export does.
fn move_folder(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        assert!(e.file_type().unwrap().is_file(), "{}", e.path().display());
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
    std::fs::remove_dir_all(from).unwrap();
}

/// The names of the files in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// For each joint, its position (runtime axes) at each time: a root joint's bone origin, else
/// the tip of the bone ending at it. `bones` is the runtime's list of posed bones.
fn joint_tracks(anim: &Animation, bones: &[Value]) -> Vec<Vec<[f64; 2]>> {
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
fn worst_error(
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
fn spine_folder_moved_elsewhere_loads_and_poses_every_joint_where_pose_csv_has_it() {
    let d = tempfile::tempdir().unwrap();
    let (run, anim, target) = retargeted_walk(d.path());
    assert_eq!(anim.frames[0], SEED_FRAME);
    let out = d.path().join("out/robot.json");
    std::fs::create_dir_all(out.parent().unwrap()).unwrap();
    // No --target: the export takes the character retarget.toml names. One key a frame, to
    // check the pose exactly (the reduced keys are checked below).
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "spine",
        "--out",
        s(&out),
        "--every-frame",
    ]));
    // The folder holds the JSON, its atlas and the image, and names them relative to itself.
    assert_eq!(
        listing(&d.path().join("out")),
        ["robot.atlas", "robot.json", "robot.png"]
    );
    assert_eq!(
        std::fs::read(d.path().join("out/robot.png")).unwrap(),
        std::fs::read(root().join("configs/characters/robot.png")).unwrap()
    );
    let atlas_text = std::fs::read_to_string(out.with_extension("atlas")).unwrap();
    assert!(atlas_text.starts_with("robot.png\n"), "{atlas_text}");
    let moved = d.path().join("elsewhere/zipped");
    move_folder(&d.path().join("out"), &moved);
    let (out, atlas) = (moved.join("robot.json"), moved.join("robot.atlas"));

    let ts: Vec<String> = times(&anim).iter().map(|t| t.to_string()).collect();
    let Some(text) = node(
        "spine_pose.mjs",
        "@esotericsoftware/spine-core",
        &[s(&out), s(&atlas), &ts.join(",")],
    ) else {
        return;
    };
    let r: Value = serde_json::from_str(&text).unwrap();
    assert!(
        r["version"].as_str().unwrap().starts_with("4.2"),
        "{}",
        r["version"]
    );
    assert_eq!(r["animation"], "mocap");
    assert_eq!(r["images"], "./");
    assert_eq!(r["pages"][0]["name"], "robot.png");
    // Bone names are plain identifiers, named by their pivot: `elbow_l` is the forearm, turning
    // at the elbow; the chest's several bones are `chest_to_...`.
    let names: Vec<&str> = r["bones"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["name"].as_str().unwrap())
        .collect();
    for n in &names {
        assert!(
            n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'),
            "{n}"
        );
    }
    for n in [
        "pelvis",
        "pelvis_to_chest",
        "chest_to_neck",
        "chest_to_elbow_l",
        "elbow_l",
        "knee_l",
        "ankle_l",
    ] {
        assert!(names.contains(&n), "{n} not in {names:?}");
    }
    let forearm = r["bones"]
        .as_array()
        .unwrap()
        .iter()
        .find(|b| b["name"] == "elbow_l")
        .unwrap();
    let elbow = anim.skeleton.index_of("elbow_l").unwrap();
    for t in 0..anim.frames.len() {
        let f = |k: &str| forearm[k][t].as_f64().unwrap();
        let p = export::spine::from_spine_point([f("x"), f("y")], anim.floor_origin());
        let want = anim.joints[t][elbow];
        assert!((p[0] - want[0]).hypot(p[1] - want[1]) < 0.5, "frame {t}");
    }
    // The animation lasts from the seed frame (time 0) to the last frame.
    let duration = r["duration"].as_f64().unwrap();
    assert!(
        (duration - (anim.frames.len() - 1) as f64 / anim.fps).abs() < 1e-6,
        "{duration}"
    );
    let origin = anim.floor_origin();
    let tracks = joint_tracks(&anim, r["bones"].as_array().unwrap());
    let worst = worst_error(&anim, &tracks, |q| {
        export::spine::from_spine_point(q, origin)
    });
    eprintln!(
        "spine runtime: worst joint error {worst:.4} px over {} frames",
        anim.frames.len()
    );
    assert!(worst < 0.5, "worst joint error {worst} px");
    // The pose is not trivially still: joints move by tens of px over the clip.
    let travel = (0..anim.skeleton.len())
        .map(|j| {
            let (a, b) = (anim.joints[0][j], anim.joints[anim.frames.len() - 1][j]);
            (a[0] - b[0]).hypot(a[1] - b[1])
        })
        .fold(0.0f64, f64::max);
    assert!(travel > 10.0, "{travel}");

    // The skin: one weighted mesh on the character's atlas region, bound so that the runtime
    // shows it, in the setup pose, where mocap2d puts it.
    let slots = r["slots"].as_array().unwrap();
    assert_eq!(slots.len(), 1);
    assert_eq!(slots[0]["type"], "MeshAttachment");
    assert_eq!(slots[0]["weighted"], true);
    assert_eq!(slots[0]["region"], "robot");
    let character = read_character(&target).unwrap();
    let m = read_manifest(&run.join("retarget/retarget.toml")).unwrap();
    let mesh = export::skin::skin_mesh(&character, m.placement(), &anim.joints[0]).unwrap();
    assert_eq!(slots[0]["vertices"], mesh.rest.len());
    assert_eq!(slots[0]["triangles"], mesh.triangles.len());
    assert!(mesh.rest.len() > 100);
    let world = r["vertices"][0][0].as_array().unwrap();
    let mut worst_vertex = 0.0f64;
    for (v, want) in mesh.rest.iter().enumerate() {
        let q = [
            world[2 * v].as_f64().unwrap(),
            world[2 * v + 1].as_f64().unwrap(),
        ];
        let p = export::spine::from_spine_point(q, origin);
        worst_vertex = worst_vertex.max((p[0] - want[0]).hypot(p[1] - want[1]));
    }
    eprintln!("spine runtime: mesh vertices in the setup pose off by at most {worst_vertex:.4} px");
    assert!(worst_vertex < 0.05, "mesh vertex off by {worst_vertex} px");
}

#[test]
fn dragonbones_folder_moved_elsewhere_loads_and_poses_every_joint_where_pose_csv_has_it() {
    let d = tempfile::tempdir().unwrap();
    let (run, anim, target) = retargeted_walk(d.path());
    let out = d.path().join("db/walk_ske.json");
    std::fs::create_dir_all(out.parent().unwrap()).unwrap();
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "dragonbones",
        "--target",
        s(&target),
        "--out",
        s(&out),
        "--every-frame",
    ]));
    assert_eq!(
        listing(&d.path().join("db")),
        ["walk_ske.json", "walk_tex.json", "walk_tex.png"]
    );
    let moved = d.path().join("elsewhere/db");
    move_folder(&d.path().join("db"), &moved);
    let (out, tex) = (moved.join("walk_ske.json"), moved.join("walk_tex.json"));
    // DragonBones' animation clock starts at the run's first frame.
    let ts: Vec<String> = times(&anim).iter().map(|t| t.to_string()).collect();
    let Some(text) = node(
        "dragonbones_pose.mjs",
        "@cocos/dragonbones-js",
        &[s(&out), &ts.join(","), s(&tex)],
    ) else {
        return;
    };
    let r: Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    assert_eq!(r["version"], "5.5");
    assert_eq!(r["animation"], "mocap");
    assert_eq!(r["slots"], serde_json::json!(["robot"]));
    assert_eq!(r["texture"]["imagePath"], "walk_tex.png");
    assert_eq!(r["meshes"][0]["texture"], "robot");
    let origin = anim.floor_origin();
    // y down (DragonBones' data axes) and y up (this runtime's Cocos default, which flips y).
    let down = joint_tracks(&anim, r["bonesYDown"].as_array().unwrap());
    let worst_down = worst_error(&anim, &down, |q| [q[0] + origin[0], q[1] + origin[1]]);
    let up = joint_tracks(&anim, r["bonesYUp"].as_array().unwrap());
    let worst_up = worst_error(&anim, &up, |q| [q[0] + origin[0], origin[1] - q[1]]);
    eprintln!("dragonbones runtime: worst joint error {worst_down:.4} px (y down), {worst_up:.4} px (y up)");
    assert!(
        worst_down < 0.5,
        "y down: worst joint error {worst_down} px"
    );
    assert!(worst_up < 0.5, "y up: worst joint error {worst_up} px");
    // The mesh, deformed by the runtime's bones on the first frame, is where mocap2d puts it.
    let character = read_character(&target).unwrap();
    let m = read_manifest(&run.join("retarget/retarget.toml")).unwrap();
    let mesh = export::skin::skin_mesh(&character, m.placement(), &anim.joints[0]).unwrap();
    let world = r["verticesYDown"][0][0].as_array().unwrap();
    assert_eq!(world.len(), 2 * mesh.rest.len());
    let mut worst_vertex = 0.0f64;
    for (v, want) in mesh.rest.iter().enumerate() {
        let p = [
            world[2 * v].as_f64().unwrap() + origin[0],
            world[2 * v + 1].as_f64().unwrap() + origin[1],
        ];
        worst_vertex = worst_vertex.max((p[0] - want[0]).hypot(p[1] - want[1]));
    }
    eprintln!(
        "dragonbones runtime: mesh vertices on the first frame off by at most {worst_vertex:.4} px"
    );
    assert!(worst_vertex < 0.05, "mesh vertex off by {worst_vertex} px");
    // y up (the Cocos default): the same mesh, mirrored into its axes.
    let world = r["verticesYUp"][0][0].as_array().unwrap();
    let mut worst_up_vertex = 0.0f64;
    for (v, want) in mesh.rest.iter().enumerate() {
        let p = [
            world[2 * v].as_f64().unwrap() + origin[0],
            origin[1] - world[2 * v + 1].as_f64().unwrap(),
        ];
        worst_up_vertex = worst_up_vertex.max((p[0] - want[0]).hypot(p[1] - want[1]));
    }
    eprintln!("dragonbones runtime: y up, mesh vertices off by at most {worst_up_vertex:.4} px");
    assert!(
        worst_up_vertex < 0.05,
        "y up: mesh vertex off by {worst_up_vertex} px"
    );
}

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

#[test]
fn dlc_csv_reads_back_to_the_tracks() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 12);
    let run = run_from_gt(d.path(), &c);
    let out = d.path().join("walk.csv");
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "dlc-csv",
        "--out",
        s(&out),
    ]));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.starts_with("scorer,mocap2d,mocap2d,mocap2d,"),
        "{}",
        &text[..80]
    );
    let t = mocap2d::seed::dlc::read_dlc_csv(&out).unwrap();
    assert_eq!(t.joints, c.joint_names);
    assert_eq!(t.rows.len(), 12);
    let rows = mocap2d::run::tracks::read_tracks(&run.join("tracks.csv")).unwrap();
    let mut worst = 0.0f64;
    for r in &rows {
        let row = &t.rows[r.frame as usize];
        assert_eq!(row.frame, Some(r.frame));
        let j = t.joints.iter().position(|n| *n == r.joint).unwrap();
        let p = row.points[j].unwrap();
        worst = worst.max((p[0] - r.x as f64).hypot(p[1] - r.y as f64));
        assert!(
            (row.likelihood[j].unwrap() - r.score as f64).abs() < 1e-6,
            "{r:?}"
        );
    }
    assert!(worst < 0.01, "worst joint error {worst} px");
}

/// A labels file as DeepLabCut (2.2 and later) writes `CollectedData_<scorer>.csv`: three header
/// rows, three index columns (`labeled-data`, the video, the image), empty cells where a point is
/// not labelled. Frame `seed` is fully labelled from `clip`'s ground truth; frame `seed + 3` lacks
/// its second joint.
fn collected_data(clip: &SynthClip, seed: usize) -> String {
    let n = clip.joint_names.len();
    let mut s = String::from("scorer,,");
    s.push_str(&",me".repeat(2 * n));
    s.push_str("\nbodyparts,,");
    for name in &clip.joint_names {
        let _ = write!(s, ",{name},{name}");
    }
    s.push_str("\ncoords,,");
    s.push_str(&",x,y".repeat(n));
    s.push('\n');
    for f in [seed, seed + 3] {
        let _ = write!(s, "labeled-data,walk,img{f:04}.png");
        for (j, (x, y)) in clip.gt[f].iter().enumerate() {
            if f != seed && j == 1 {
                s.push_str(",,");
            } else {
                let _ = write!(s, ",{x:.3},{y:.3}");
            }
        }
        s.push('\n');
    }
    s
}

#[test]
fn dlc_labels_seed_the_tracker_like_a_seed_file() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 16);
    synth::write_clip(&c, d.path()).unwrap();
    let clip_path = d.path().join("clip.mp4");
    let seed = 4;
    // The same rectangles as a seed file.
    let mut seeds = format!("frame = {seed}\n");
    for (j, name) in c.joint_names.iter().enumerate() {
        let (x, y) = c.gt[seed][j];
        let _ = write!(
            seeds,
            "\n[[joint]]\nname = \"{name}\"\nx = {x:.3}\ny = {y:.3}\nw = 15\nh = 15\n"
        );
        if let Some(p) = c.parents[j] {
            let _ = writeln!(seeds, "parent = \"{}\"", c.joint_names[p]);
        }
    }
    let seeds_path = d.path().join("seeds.toml");
    std::fs::write(&seeds_path, seeds).unwrap();
    let csv = d.path().join("CollectedData_me.csv");
    std::fs::write(&csv, collected_data(&c, seed)).unwrap();
    let a = d.path().join("a.mocap");
    let b = d.path().join("b.mocap");
    ok(&mocap2d(&[
        "track",
        s(&clip_path),
        "--seeds",
        s(&seeds_path),
        "--out",
        s(&a),
        "-q",
    ]));
    // The skeleton from a seed file (synth's joints.toml: frame 0, other positions: only the
    // parent links are read).
    let o = mocap2d(&[
        "track",
        s(&clip_path),
        "--seeds-from-dlc",
        s(&csv),
        "--seed-frame",
        &seed.to_string(),
        "--skeleton",
        s(&d.path().join("joints.toml")),
        "--out",
        s(&b),
        "-q",
    ]);
    ok(&o);
    assert_eq!(
        std::fs::read_to_string(a.join("tracks.csv")).unwrap(),
        std::fs::read_to_string(b.join("tracks.csv")).unwrap()
    );
    let copied = std::fs::read_to_string(b.join("seeds.toml")).unwrap();
    assert!(
        copied.contains("DeepLabCut") && copied.contains("frame = 4"),
        "{copied}"
    );

    // Without --skeleton: a chain, said on stderr.
    let o = mocap2d(&[
        "track",
        s(&clip_path),
        "--seeds-from-dlc",
        s(&csv),
        "--seed-frame",
        "4",
        "--out",
        s(&d.path().join("c.mocap")),
        "-q",
    ]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("note: the DeepLabCut CSV has no skeleton")
            && err.contains("pelvis -> chest -> neck"),
        "{err}"
    );

    // Frame 7 lacks a label; frame 9 is not in the file; no --seed-frame.
    for (args, needles) in [
        (
            vec!["--seed-frame", "7"],
            vec!["line 5", "\"chest\"", "not labelled on frame 7", "frames 4"],
        ),
        (vec!["--seed-frame", "9"], vec!["no row is frame 9", "4, 7"]),
        (
            vec!["--seed-frame", "4", "--seed-size", "400"],
            vec!["not fully inside", "--seed-size"],
        ),
        (vec![], vec!["--seed-frame"]),
    ] {
        let out = d.path().join("bad.mocap");
        let mut all = vec![
            "track",
            s(&clip_path),
            "--seeds-from-dlc",
            s(&csv),
            "--out",
            s(&out),
        ];
        all.extend(args.iter().copied());
        let o = mocap2d(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        for n in needles {
            assert!(err.contains(n), "{args:?}: {n:?} not in {err}");
        }
        assert!(!out.exists());
    }
}

/// An animator's own Spine 4.2 skeleton of another shape than the robot: a root, hips, a torso
/// with a head, a cape and a two-bone left arm, one leg; a region attachment on the torso, an
/// animation `idle` of their own, and keys in their order and layout.
const THEIR_SKELETON: &str = r#"{
  "skeleton": { "hash": "their-hash", "spine": "4.2.22", "x": -60, "y": 0, "width": 120, "height": 240, "images": "./images/" },
  "bones": [
    { "name": "root" },
    { "name": "hips", "parent": "root", "y": 100 },
    { "name": "torso", "parent": "hips", "length": 60, "rotation": 90 },
    { "name": "head", "parent": "torso", "length": 30, "x": 60 },
    { "name": "cape", "parent": "torso", "length": 40, "rotation": 170, "x": 40 },
    { "name": "upper_arm_l", "parent": "torso", "length": 35, "rotation": -150, "x": 50 },
    { "name": "forearm_l", "parent": "upper_arm_l", "length": 30, "rotation": 10, "x": 35 },
    { "name": "leg", "parent": "hips", "length": 50, "rotation": -95 }
  ],
  "slots": [ { "name": "body", "bone": "torso", "attachment": "body" } ],
  "skins": [ { "name": "default", "attachments": { "body": { "body": { "x": 30, "rotation": -90, "width": 40, "height": 80 } } } } ],
  "animations": {
    "idle": { "bones": { "head": { "rotate": [ { "value": 0 }, { "time": 1, "value": 10 } ] } } }
  }
}
"#;

#[test]
fn their_own_spine_skeleton_gets_the_motion_as_an_animation_and_keeps_the_rest() {
    let d = tempfile::tempdir().unwrap();
    let (run, anim, _) = retargeted_walk(d.path());
    let rig = d.path().join("rig");
    std::fs::create_dir_all(&rig).unwrap();
    let theirs = rig.join("hero.json");
    std::fs::write(&theirs, THEIR_SKELETON).unwrap();
    image::RgbaImage::from_pixel(4, 4, image::Rgba([200, 30, 30, 255]))
        .save(rig.join("body.png"))
        .unwrap();
    std::fs::write(
        rig.join("hero.atlas"),
        "body.png\nsize:4,4\nfilter:Linear,Linear\nbody\nbounds:0,0,4,4\n",
    )
    .unwrap();
    let out = rig.join("hero-mocap.json");
    let o = mocap2d(&[
        "export",
        s(&run),
        "--format",
        "spine",
        "--skeleton",
        s(&theirs),
        "--animation",
        "dance",
        "--bone",
        "hips=pelvis",
        "--bone",
        "torso=pelvis>chest",
        "--bone",
        "upper_arm_l=chest>elbow_l",
        "--bone",
        "forearm_l=elbow_l",
        "--bone",
        "leg=pelvis>knee_l",
        "--bone",
        "head=neck",
        "--every-frame",
        "--out",
        s(&out),
    ]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    // Each bone names the joint it turns at; the mapping is printed and written beside --out.
    assert!(
        err.contains("upper_arm_l = chest>elbow_l (rotate, by --bone)")
            && err.contains("forearm_l = elbow_l (rotate, by --bone)")
            && err.contains("head = neck (rotate, by --bone)")
            && err.contains("hips = pelvis (translate")
            && err.contains("left in their setup pose: root, cape"),
        "{err}"
    );
    let map = rig.join("hero-mocap.bones.toml");
    let map_text = std::fs::read_to_string(&map).unwrap();
    assert!(
        map_text.contains("\n[bones]\n")
            && map_text.contains("\"forearm_l\" = \"elbow_l\"\n")
            && map_text.contains("\"torso\" = \"pelvis>chest\"\n"),
        "{map_text}"
    );
    // Only the new animation and the definitions of its contact events (their file has no
    // `events`) are added: every other byte of their file is as it was.
    let written = std::fs::read_to_string(&out).unwrap();
    let defs = ",\"events\":{\"contact_start\":{},\"contact_end\":{}}\n}\n";
    assert!(written.ends_with(defs), "{written}");
    let text = written.replacen(defs, "\n}\n", 1);
    let at = THEIR_SKELETON.find("\"animations\": {").unwrap() + "\"animations\": {".len();
    assert!(text.starts_with(&THEIR_SKELETON[..at]), "{text}");
    assert!(text.ends_with(&THEIR_SKELETON[at..]), "{text}");
    let mut doc: Value = serde_json::from_str(&text).unwrap();
    let added = doc["animations"]
        .as_object_mut()
        .unwrap()
        .remove("dance")
        .unwrap();
    assert_eq!(doc, serde_json::from_str::<Value>(THEIR_SKELETON).unwrap());
    assert!(!added["events"].as_array().unwrap().is_empty());
    // Their bones are turned and moved, never scaled or given attachments.
    for (bone, tl) in added["bones"].as_object().unwrap() {
        for k in tl.as_object().unwrap().keys() {
            assert!(k == "rotate" || k == "translate", "{bone}: {k}");
        }
    }

    // spine-core loads it with their atlas, both animations in it; posed at every frame, each
    // matched bone has turned as the character's bone since the first frame.
    let ts: Vec<String> = times(&anim).iter().map(|t| t.to_string()).collect();
    let Some(r) = node(
        "spine_pose.mjs",
        "@esotericsoftware/spine-core",
        &[s(&out), s(&rig.join("hero.atlas")), &ts.join(","), "dance"],
    ) else {
        return;
    };
    let r: Value = serde_json::from_str(&r).unwrap();
    assert_eq!(r["animations"], serde_json::json!(["dance", "idle"]));
    assert_eq!(r["slots"][0]["region"], "body");
    // The foot contacts, as events spine-core reads against the definitions added to the file.
    assert_eq!(
        r["eventNames"],
        serde_json::json!(["contact_start", "contact_end"])
    );
    let events = r["events"].as_array().unwrap();
    assert!(events
        .iter()
        .any(|e| e["name"] == "contact_end" && e["string"] == "ankle_l"));
    let bones = r["bones"].as_array().unwrap();
    let bone = |n: &str| bones.iter().find(|b| b["name"] == n).unwrap();
    let angle = |b: &Value, t: usize| -> f64 {
        let f = |k: &str| b[k][t].as_f64().unwrap();
        (f("tipY") - f("y")).atan2(f("tipX") - f("x")).to_degrees()
    };
    let series = anim.bone_series();
    let joint = |n: &str| anim.skeleton.index_of(n).unwrap();
    let turn = |t: usize, j: usize| {
        let b = series.ending_at(j).unwrap();
        -(series.angle[t][b] - series.angle[0][b]).to_degrees()
    };
    let wrap = |a: f64| (a + 540.0).rem_euclid(360.0) - 180.0;
    let mut worst = 0.0f64;
    let mut moved = 0.0f64;
    for t in 0..anim.frames.len() {
        for (theirs, ours) in [
            ("torso", "chest"),
            ("head", "head"),
            ("upper_arm_l", "elbow_l"),
            ("forearm_l", "wrist_l"),
            ("leg", "knee_l"),
            // The cape is theirs alone: it turns with the torso.
            ("cape", "chest"),
        ] {
            let b = bone(theirs);
            let got = wrap(angle(b, t) - angle(b, 0));
            worst = worst.max(wrap(got - turn(t, joint(ours))).abs());
            moved = moved.max(got.abs());
        }
    }
    eprintln!(
        "their skeleton: bone turns off by at most {worst:.5} degrees (moved up to {moved:.1})"
    );
    assert!(worst < 0.01, "{worst} degrees");
    assert!(moved > 10.0, "{moved}");
    // The hips follow the pelvis, scaled to their bones' size.
    let (mut theirs_len, mut ours_len) = (0.0, 0.0);
    for (n, j, l) in [
        ("torso", "chest", 60.0),
        ("head", "head", 30.0),
        ("upper_arm_l", "elbow_l", 35.0),
        ("forearm_l", "wrist_l", 30.0),
        ("leg", "knee_l", 50.0),
    ] {
        let _ = n;
        theirs_len += l;
        ours_len += series.length[0][series.ending_at(joint(j)).unwrap()];
    }
    let k = theirs_len / ours_len;
    let hips = bone("hips");
    let pelvis = joint("pelvis");
    let last = anim.frames.len() - 1;
    let dx = hips["x"][last].as_f64().unwrap() - hips["x"][0].as_f64().unwrap();
    let want = k * (anim.joints[last][pelvis][0] - anim.joints[0][pelvis][0]);
    assert!((dx - want).abs() < 1e-3, "{dx} vs {want}");
    assert!(want.abs() > 1.0, "the walk moves: {want}");

    // The written mapping passed back gives the same export, and writes no mapping over it.
    let again = rig.join("again.json");
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "spine",
        "--skeleton",
        s(&theirs),
        "--animation",
        "dance",
        "--bone-map",
        s(&map),
        "--every-frame",
        "--out",
        s(&again),
    ]));
    assert_eq!(std::fs::read_to_string(&again).unwrap(), written);
    assert!(!rig.join("again.bones.toml").exists());
    assert_eq!(std::fs::read_to_string(&map).unwrap(), map_text);

    // Bad matches: exit 2, naming what there is.
    let bad = |extra: &[&str], needles: &[&str]| {
        let mut args = vec![
            "export",
            s(&run),
            "--format",
            "spine",
            "--skeleton",
            s(&theirs),
            "--out",
        ];
        let o2 = d.path().join("bad.json");
        args.push(s(&o2));
        args.extend(extra);
        let o = mocap2d(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        for n in needles {
            assert!(err.contains(n), "{n:?} not in {err}");
        }
        assert!(!o2.exists());
    };
    bad(
        &["--bone", "tail=pelvis"],
        &["no bone \"tail\"", "upper_arm_l"],
    );
    bad(
        &["--bone", "torso=spine"],
        &["no joint \"spine\"", "elbow_l"],
    );
    // The old end-joint form, a pivot with several bones, a bone given twice.
    bad(
        &["--bone", "forearm_l=wrist_l"],
        &["wrist_l is the end of a bone", "forearm_l=elbow_l"],
    );
    bad(
        &["--bone", "torso=chest"],
        &["several bones turn at chest", "torso=chest>JOINT"],
    );
    bad(
        &["--bone", "head=neck", "--bone", "head=chest>neck"],
        &["--bone given twice for bone \"head\""],
    );
    std::fs::write(&theirs, THEIR_SKELETON.replace("\"head\"", "\"skull\"")).unwrap();
    bad(&[], &["no bone matches", "skull", "pelvis"]);
    std::fs::write(&theirs, THEIR_SKELETON.replace("4.2.22", "3.8.99")).unwrap();
    bad(&["--bone", "torso=chest"], &["Spine 3.8.99", "4.2"]);
}

/// A stand-in atlas for `skeleton` (Spine JSON): every region and mesh attachment it names, as
/// one-pixel regions of `page.png` (written beside it), so spine-core can load it without the
/// images.
fn stand_in_atlas(skeleton: &Path) -> PathBuf {
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(skeleton).unwrap()).unwrap();
    let mut regions = std::collections::BTreeSet::new();
    for skin in doc["skins"].as_array().unwrap() {
        for atts in skin["attachments"].as_object().unwrap().values() {
            for (name, a) in atts.as_object().unwrap() {
                let ty = a["type"].as_str().unwrap_or("region");
                if ty == "region" || ty == "mesh" || ty == "linkedmesh" {
                    regions.insert(a["path"].as_str().unwrap_or(name).to_owned());
                }
            }
        }
    }
    let dir = skeleton.parent().unwrap();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([0, 0, 0, 255]))
        .save(dir.join("page.png"))
        .unwrap();
    let mut text = "page.png\nsize:2,2\nfilter:Linear,Linear\n".to_owned();
    for r in regions {
        writeln!(text, "{r}\nbounds:0,0,1,1").unwrap();
    }
    let atlas = skeleton.with_extension("atlas");
    std::fs::write(&atlas, text).unwrap();
    atlas
}

/// Spine's own spineboy (a side-view rig with leg IK), under a front-view walk retargeted onto
/// the dancer, with no `--bone`: its bones map by structure (printed, and written as a file),
/// the leg IK is keyed off and said so, the side view is warned about, the file is unchanged
/// but for the animation, spine-core 4.2 loads it and its legs follow the motion; with
/// `--keep-ik` the IK targets carry the legs to the same places.
#[test]
fn spineboy_maps_by_structure_with_no_bone_flag_and_its_legs_follow() {
    let d = tempfile::tempdir().unwrap();
    let run = run_from_gt(d.path(), &clip(Scenario::Walk, 30));
    let target = root().join("configs/characters/dancer.toml");
    ok(&mocap2d(&["retarget", s(&run), "--target", s(&target)]));
    let anim = animation(&run);
    let rig = d.path().join("rig");
    std::fs::create_dir_all(&rig).unwrap();
    let theirs = rig.join("spineboy-pro.json");
    let original =
        std::fs::read_to_string(root().join("tests/it/data/spineboy/spineboy-pro.json")).unwrap();
    std::fs::write(&theirs, &original).unwrap();
    let atlas = stand_in_atlas(&theirs);
    let export = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "export",
            s(&run),
            "--format",
            "spine",
            "--skeleton",
            s(&theirs),
            "--out",
            s(out),
        ];
        args.extend(extra);
        let o = mocap2d(&args);
        ok(&o);
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let out = rig.join("spineboy-mocap.json");
    let err = export(&out, &[]);
    eprintln!("{err}");
    for line in [
        "front-upper-arm = left_shoulder (rotate, by structure)",
        "front-bracer = left_elbow (rotate, by structure)",
        "rear-upper-arm = right_shoulder (rotate, by structure)",
        "rear-bracer = right_elbow (rotate, by structure)",
        "front-thigh = left_hip (rotate, by structure)",
        "front-shin = left_knee (rotate, by structure)",
        "rear-thigh = right_hip (rotate, by structure)",
        "rear-shin = right_knee (rotate, by structure)",
        "hip = pelvis (translate",
        "torso = pelvis>chest (rotate, by structure)",
        "neck = chest>neck (rotate, by structure)",
        "head = neck (rotate, by structure)",
        "IK constraints over mapped bones (aim-ik, front-leg-ik, rear-leg-ik): their mix is \
         keyed to 0",
        "looks drawn from the side",
    ] {
        assert!(err.contains(line), "{line:?} not in {err}");
    }
    let map = rig.join("spineboy-mocap.bones.toml");
    let map_text = std::fs::read_to_string(&map).unwrap();
    assert!(
        map_text.contains("\"front-upper-arm\" = \"left_shoulder\"\n"),
        "{map_text}"
    );

    // Every byte but the animation's and the contact events' definitions (added first in their
    // `events`, their own `footstep` kept) is theirs.
    let text = std::fs::read_to_string(&out).unwrap();
    let defs = "\"contact_start\":{},\"contact_end\":{},";
    let events_at = original.find("\"events\": {").unwrap() + "\"events\": {".len();
    assert_eq!(&text[events_at..events_at + defs.len()], defs);
    assert!(
        err.contains("contact_start, contact_end added to the file's events"),
        "{err}"
    );
    let theirs = text.replacen(defs, "", 1);
    let at = original.find("\"animations\": {").unwrap() + "\"animations\": {".len();
    assert!(theirs.starts_with(&original[..at]));
    assert!(theirs.ends_with(&original[at..]));
    let added: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(added["events"]["footstep"], serde_json::json!({}));
    let added = &added["animations"]["mocap"];
    assert_eq!(
        theirs.len(),
        original.len() + "\"mocap\":".len() + added.to_string().len() + 1
    );
    assert_eq!(added["ik"]["front-leg-ik"][0]["mix"], 0);
    assert_eq!(added["ik"]["front-leg-ik"][0]["bendPositive"], false);
    // Again: the same bytes, and the mapping file (perhaps edited since) is not written over.
    std::fs::write(&map, format!("{map_text}# edited\n")).unwrap();
    let err = export(&out, &[]);
    assert!(err.contains("exists and is left as it is"), "{err}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), text);
    assert_eq!(
        std::fs::read_to_string(&map).unwrap(),
        format!("{map_text}# edited\n")
    );

    // spine-core 4.2 loads it; the legs turn with the dancer's legs since the first frame.
    let ts: Vec<String> = times(&anim).iter().map(|t| t.to_string()).collect();
    let pose = |file: &Path| -> Option<Value> {
        node(
            "spine_pose.mjs",
            "@esotericsoftware/spine-core",
            &[s(file), s(&atlas), &ts.join(","), "mocap"],
        )
        .map(|r| serde_json::from_str(&r).unwrap())
    };
    let Some(r) = pose(&out) else {
        return;
    };
    assert!(r["version"].as_str().unwrap().starts_with("4.2"));
    let bones = r["bones"].as_array().unwrap().clone();
    let bone = |n: &str| bones.iter().find(|b| b["name"] == n).unwrap().clone();
    let angle = |b: &Value, t: usize| -> f64 {
        let f = |k: &str| b[k][t].as_f64().unwrap();
        (f("tipY") - f("y")).atan2(f("tipX") - f("x")).to_degrees()
    };
    let series = anim.bone_series();
    let turn = |t: usize, j: &str| {
        let b = series
            .ending_at(anim.skeleton.index_of(j).unwrap())
            .unwrap();
        -(series.angle[t][b] - series.angle[0][b]).to_degrees()
    };
    let wrap = |a: f64| (a + 540.0).rem_euclid(360.0) - 180.0;
    // Within the key tolerance (0.5 degrees) per keyed bone on the way: the thighs hang from
    // the hip (translated only), a shin from its thigh, an upper arm from the torso.
    for (theirs, end, tolerance) in [
        ("front-thigh", "left_knee", 0.5),
        ("rear-thigh", "right_knee", 0.5),
        ("front-shin", "left_ankle", 1.0),
        ("rear-shin", "right_ankle", 1.0),
        ("front-upper-arm", "left_elbow", 1.0),
    ] {
        let b = bone(theirs);
        let (mut worst, mut moved) = (0.0f64, 0.0f64);
        for t in 0..anim.frames.len() {
            let got = wrap(angle(&b, t) - angle(&b, 0));
            worst = worst.max(wrap(got - turn(t, end)).abs());
            moved = moved.max(got.abs());
        }
        eprintln!("spineboy {theirs}: turns up to {moved:.1} deg, off by {worst:.3} deg");
        assert!(worst < tolerance + 0.01, "{theirs}: off by {worst} degrees");
        assert!(moved > 5.0, "{theirs}: turns only {moved} degrees");
    }

    // --keep-ik: the IK stays and its targets move: the shins end where they do with mix 0
    // (both keyed on every frame, so that only the IK differs).
    let every = rig.join("every.json");
    export(&every, &["--every-frame"]);
    let r = pose(&every).unwrap();
    let bones = r["bones"].as_array().unwrap().clone();
    let bone = |n: &str| bones.iter().find(|b| b["name"] == n).unwrap().clone();
    let kept = rig.join("kept.json");
    let err = export(&kept, &["--keep-ik", "--every-frame"]);
    assert!(err.contains("IK constraint front-leg-ik kept"), "{err}");
    let k: Value = serde_json::from_str(&std::fs::read_to_string(&kept).unwrap()).unwrap();
    assert!(k["animations"]["mocap"].get("ik").is_none());
    assert!(k["animations"]["mocap"]["bones"]["front-leg-target"]["translate"].is_array());
    let r2 = pose(&kept).unwrap();
    let bones2 = r2["bones"].as_array().unwrap();
    let mut worst = 0.0f64;
    for shin in ["front-shin", "rear-shin"] {
        let (a, b) = (
            bone(shin),
            bones2.iter().find(|b| b["name"] == shin).unwrap(),
        );
        for t in 0..anim.frames.len() {
            let f = |v: &Value, k: &str| v[k][t].as_f64().unwrap();
            worst = worst.max((f(&a, "tipX") - f(b, "tipX")).hypot(f(&a, "tipY") - f(b, "tipY")));
        }
    }
    eprintln!("spineboy --keep-ik: shin tips within {worst:.4} px of the mix-0 export");
    assert!(worst < 0.05, "{worst} px");
}

/// `retarget/contacts.csv` (foot contacts) becomes `contact_start` / `contact_end` events that
/// the Spine and DragonBones runtimes read and fire at the contacts' frames.
#[test]
fn contacts_become_events_in_spine_and_dragonbones() {
    let d = tempfile::tempdir().unwrap();
    let (run, anim, _) = retargeted_walk(d.path());
    // ankle_l planted on frames +0..+4 and +20..+29, ankle_r on +10..+17.
    let mut csv = "frame,joint,contact\n".to_owned();
    for (i, &f) in anim.frames.iter().enumerate() {
        let l = i < 5 || (20..30).contains(&i);
        let r = (10..18).contains(&i);
        writeln!(csv, "{f},ankle_l,{}\n{f},ankle_r,{}", l as u8, r as u8).unwrap();
    }
    std::fs::write(run.join("retarget/contacts.csv"), &csv).unwrap();
    let t = |i: u64| ((i as f64) / anim.fps * 1e6).round() / 1e6;
    let want = [
        (t(0), "contact_start", "ankle_l"),
        (t(5), "contact_end", "ankle_l"),
        (t(10), "contact_start", "ankle_r"),
        (t(18), "contact_end", "ankle_r"),
        (t(20), "contact_start", "ankle_l"),
        (t(30), "contact_end", "ankle_l"),
    ];
    assert!(anim.frames.len() > 31);

    let out = d.path().join("spine/robot.json");
    std::fs::create_dir_all(out.parent().unwrap()).unwrap();
    let o = mocap2d(&["export", s(&run), "--format", "spine", "--out", s(&out)]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("3 contact starts and 3 ends as events"),
        "{err}"
    );
    let db_out = d.path().join("db/robot_ske.json");
    std::fs::create_dir_all(db_out.parent().unwrap()).unwrap();
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "dragonbones",
        "--out",
        s(&db_out),
    ]));

    let Some(r) = node(
        "spine_pose.mjs",
        "@esotericsoftware/spine-core",
        &[s(&out), s(&out.with_extension("atlas")), "0"],
    ) else {
        return;
    };
    let r: Value = serde_json::from_str(&r).unwrap();
    assert_eq!(
        r["eventNames"],
        serde_json::json!(["contact_end", "contact_start"])
    );
    let got: Vec<(f64, String, String)> = r["events"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            (
                e["time"].as_f64().unwrap(),
                e["name"].as_str().unwrap().to_owned(),
                e["string"].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (g, w) in got.iter().zip(&want) {
        assert!(
            (g.0 - w.0).abs() < 1e-4 && g.1 == w.1 && g.2 == w.2,
            "{got:?}"
        );
    }

    let r = node(
        "dragonbones_pose.mjs",
        "@cocos/dragonbones-js",
        &[s(&db_out), "0"],
    )
    .unwrap();
    let r: Value = serde_json::from_str(r.lines().last().unwrap()).unwrap();
    let fired: Vec<(f64, String, String)> = r["events"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            (
                e["time"].as_f64().unwrap(),
                e["name"].as_str().unwrap().to_owned(),
                e["strings"][0].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    assert_eq!(fired.len(), want.len(), "{fired:?}");
    for (g, w) in fired.iter().zip(&want) {
        assert!(
            (g.0 - w.0).abs() < 1e-3 && g.1 == w.1 && g.2 == w.2,
            "{fired:?}"
        );
    }

    // A bad row: exit 2, the file and line named, nothing written.
    std::fs::write(
        run.join("retarget/contacts.csv"),
        csv.replacen("ankle_r", "ankle_x", 1),
    )
    .unwrap();
    let bad = d.path().join("spine/bad.json");
    let o = mocap2d(&["export", s(&run), "--format", "spine", "--out", s(&bad)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("contacts.csv") && err.contains("line 3: joint \"ankle_x\""),
        "{err}"
    );
    assert!(!bad.exists());
}
