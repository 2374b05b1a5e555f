//! The Spine and DragonBones exports of a retargeted walk, loaded and posed by their runtimes
//! (spine-core's SkeletonJson, the DragonBones runtime's core) at every frame after their
//! folder is moved elsewhere: every joint where `retarget/pose.csv` has it and the skinned mesh
//! where mocap2d puts it; and foot contacts (`retarget/contacts.csv`) as events both runtimes
//! fire at the contacts' frames. The runtime checks need the Node.js side in tests/js/ (see
//! [`crate::export`]).

use crate::common::{root, run as mocap2d, s};
use crate::export::{joint_tracks, node, ok, retargeted_walk, times, worst_error, SEED_FRAME};
use mocap2d::character::read_character;
use mocap2d::export;
use mocap2d::retarget::files::read_manifest;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::Path;

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
