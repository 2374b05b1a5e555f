//! Exports onto the animator's own Spine skeleton (`--skeleton`): the motion added as one more
//! animation with every other byte of their file kept, bones matched by `--bone`, by a mapping
//! file (`--bone-map`) or by structure (Spine's spineboy, its leg IK keyed off or kept with
//! `--keep-ik`), spine-core 4.2 posing their bones as the character's turn, and bad matches
//! exiting 2. The runtime checks need the Node.js side in tests/js/ (see [`crate::export`]).

use crate::common::{root, run as mocap2d, s};
use crate::export::{animation, clip, node, ok, retargeted_walk, run_from_gt, times};
use mocap2d::synth::Scenario;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

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
