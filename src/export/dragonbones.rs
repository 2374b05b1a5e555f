//! DragonBones 5.5 JSON (the `_ske.json` of a DragonBones export).
//!
//! **Axes.** DragonBones is y down, in px, rotations in degrees clockwise: the screen's axes, so
//! only the origin moves, to the floor point ([`Animation::floor_origin`]).
//!
//! **Bones** as in [`super::spine`]: one per root joint (named after it, at the joint), one per
//! skeleton bone (named `parent->child`, from the parent joint towards the child, `length` = the
//! bone's length on the first frame) whose parent is the bone ending at its start joint; an
//! extra `root` bone when there are several root joints; parents listed first. Bones do not
//! inherit scale (`inheritScale: false`): DragonBones then moves a child by its parent's full
//! matrix (so a parent's scale x carries the child to the parent's scaled tip) and turns it by
//! the parent's rotation alone, so a child's rotation is simply its angle from its parent bone.
//!
//! **Animation** `mocap`: one key a frame, each lasting one frame (`duration` 1; the animation's
//! `duration` is the frame count), linear to the next (`tweenEasing` 0; the last key holds),
//! values relative to the bone's setup transform (the first frame): `translateFrame` (px) on the
//! root joints' bones, `rotateFrame` (degrees, continuous) and `scaleFrame` (x =
//! length / setup length) on the others. The animation starts at the run's first frame
//! (DragonBones time 0 = the seed frame), at the armature's `frameRate` (the run's fps).
//!
//! **Slots and skin.** One slot per bone (`parent->child`), drawn in bone order, with no display:
//! this export carries the skeleton and its motion; attach images to the slots in DragonBones.

use super::{round, Animation};
use serde_json::{json, Map, Value};

/// The armature's and the animation's name.
pub const NAME: &str = "mocap";

/// The DragonBones JSON text for `anim` (deterministic).
pub fn to_dragonbones(anim: &Animation) -> String {
    let sk = &anim.skeleton;
    let origin = anim.floor_origin();
    let series = anim.bone_series();
    let names = super::spine::bone_names(anim);
    let n = anim.frames.len();
    let pos = |t: usize, j: usize| {
        let p = anim.joints[t][j];
        [p[0] - origin[0], p[1] - origin[1]]
    };
    let bone_of = |j: usize| series.ending_at(j);
    // Rotation (degrees, clockwise) of the bone ending at joint c relative to its parent bone.
    let local_deg = |t: usize, c: usize| -> f64 {
        // Cannot fail: `c` is a child, so it has a parent and a bone.
        let b = bone_of(c).expect("c has a parent");
        let parent_angle = bone_of(series.bones[b].0).map_or(0.0, |f| series.angle[t][f]);
        (series.angle[t][b] - parent_angle).to_degrees()
    };
    let scale = |t: usize, b: usize| {
        let l0 = series.length[0][b];
        if l0 > 1e-9 {
            series.length[t][b] / l0
        } else {
            1.0
        }
    };
    let key = |t: usize, mut m: Map<String, Value>| {
        m.insert("duration".into(), json!(1));
        if t + 1 < n {
            m.insert("tweenEasing".into(), json!(0));
        }
        Value::Object(m)
    };
    let obj = |pairs: &[(&str, f64)]| -> Map<String, Value> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), json!(v)))
            .collect()
    };

    let mut bones: Vec<Value> = Vec::new();
    if let Some(top) = &names.top {
        bones.push(json!({ "name": top }));
    }
    let mut slots = Vec::new();
    let mut timelines = Vec::new();
    for j in sk.topo_order() {
        let mut b = Map::new();
        b.insert("name".into(), json!(names.of_joint[j]));
        let mut tl = Map::new();
        tl.insert("name".into(), json!(names.of_joint[j]));
        match sk.parent(j) {
            None => {
                if let Some(top) = &names.top {
                    b.insert("parent".into(), json!(top));
                }
                let p0 = pos(0, j);
                b.insert(
                    "transform".into(),
                    Value::Object(obj(&[("x", round(p0[0], 4)), ("y", round(p0[1], 4))])),
                );
                let keys = (0..n)
                    .map(|t| {
                        let p = pos(t, j);
                        key(
                            t,
                            obj(&[("x", round(p[0] - p0[0], 4)), ("y", round(p[1] - p0[1], 4))]),
                        )
                    })
                    .collect();
                tl.insert("translateFrame".into(), Value::Array(keys));
            }
            Some(p) => {
                // Cannot fail: this joint has a parent (this arm), so a bone ends at it.
                let bi = bone_of(j).expect("has a parent");
                b.insert("parent".into(), json!(names.of_joint[p]));
                b.insert("length".into(), json!(round(series.length[0][bi], 4)));
                b.insert("inheritScale".into(), json!(false));
                let r0 = local_deg(0, j);
                let x = bone_of(p).map_or(0.0, |f| series.length[0][f]);
                b.insert(
                    "transform".into(),
                    Value::Object(obj(&[
                        ("x", round(x, 4)),
                        ("skX", round(r0, 5)),
                        ("skY", round(r0, 5)),
                    ])),
                );
                let rotate = (0..n)
                    .map(|t| key(t, obj(&[("rotate", round(local_deg(t, j) - r0, 5))])))
                    .collect();
                let scale = (0..n)
                    .map(|t| key(t, obj(&[("x", round(scale(t, bi), 6))])))
                    .collect();
                tl.insert("rotateFrame".into(), Value::Array(rotate));
                tl.insert("scaleFrame".into(), Value::Array(scale));
                slots.push(json!({ "name": names.of_joint[j], "parent": names.of_joint[j] }));
            }
        }
        bones.push(Value::Object(b));
        timelines.push(Value::Object(tl));
    }

    // Bounds of the joints on the first frame, DragonBones axes.
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for j in 0..sk.len() {
        let p = pos(0, j);
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let skin_slots: Vec<Value> = slots
        .iter()
        .map(|s| json!({ "name": s["name"], "display": [] }))
        .collect();
    let doc = json!({
        "frameRate": anim.fps,
        "name": NAME,
        "version": "5.5",
        "compatibleVersion": "5.5",
        "armature": [{
            "type": "Armature",
            "frameRate": anim.fps,
            "name": NAME,
            "aabb": {
                "x": round(lo[0], 2),
                "y": round(lo[1], 2),
                "width": round(hi[0] - lo[0], 2),
                "height": round(hi[1] - lo[1], 2),
            },
            "bone": bones,
            "slot": slots,
            "skin": [{ "name": "", "slot": skin_slots }],
            "animation": [{
                "name": NAME,
                "duration": n,
                "playTimes": 0,
                "bone": timelines,
            }],
            "defaultActions": [{ "gotoAndPlay": NAME }],
        }],
    });
    // Cannot fail: the document is plain JSON values (no maps with non-string keys).
    let mut s = serde_json::to_string(&doc).expect("JSON values");
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::Skeleton;

    /// Forward kinematics as DragonBones 5 does it for bones with `inheritScale: false` (see
    /// `Bone._updateGlobalTransformMatrix`): position through the parent's full matrix, rotation
    /// added to the parent's. Returns each joint (output px) at frame `t`.
    fn db_fk(doc: &Value, anim: &Animation, t: usize) -> Vec<[f64; 2]> {
        let arm = &doc["armature"][0];
        let names = crate::export::spine::bone_names(anim);
        let origin = anim.floor_origin();
        let tls = arm["animation"][0]["bone"].as_array().unwrap();
        // name -> (x, y, rotation rad, scale x, length)
        let mut world: std::collections::HashMap<String, (f64, f64, f64, f64, f64)> =
            Default::default();
        for b in arm["bone"].as_array().unwrap() {
            let name = b["name"].as_str().unwrap();
            let tr = &b["transform"];
            let f = |k: &str| tr[k].as_f64().unwrap_or(0.0);
            let tl = tls.iter().find(|x| x["name"] == name);
            let k = |tlk: &str, field: &str, d: f64| {
                tl.and_then(|x| x[tlk].as_array())
                    .map_or(d, |a| a[t][field].as_f64().unwrap_or(d))
            };
            let (lx, ly) = (
                f("x") + k("translateFrame", "x", 0.0),
                f("y") + k("translateFrame", "y", 0.0),
            );
            let rot = (f("skY") + k("rotateFrame", "rotate", 0.0)).to_radians();
            let sx = k("scaleFrame", "x", 1.0);
            let len = b["length"].as_f64().unwrap_or(0.0);
            let w = match b["parent"].as_str() {
                None => (lx, ly, rot, sx, len),
                Some(p) => {
                    let (px, py, pr, ps, _) = world[p];
                    let (c, s) = (pr.cos(), pr.sin());
                    (
                        px + c * ps * lx - s * ly,
                        py + s * ps * lx + c * ly,
                        pr + rot,
                        sx,
                        len,
                    )
                }
            };
            world.insert(name.to_owned(), w);
        }
        (0..anim.skeleton.len())
            .map(|j| {
                let (x, y, r, s, len) = world[&names.of_joint[j]];
                let q = match anim.skeleton.parent(j) {
                    None => [x, y],
                    Some(_) => [x + r.cos() * s * len, y + r.sin() * s * len],
                };
                [q[0] + origin[0], q[1] + origin[1]]
            })
            .collect()
    }

    #[test]
    fn keys_put_every_joint_where_the_pose_has_it() {
        let sk = Skeleton::new(
            ["hip", "knee", "foot", "toe"].map(String::from).to_vec(),
            vec![None, Some(0), Some(1), Some(1)],
        );
        let joints: Vec<Vec<[f64; 2]>> = (0..5)
            .map(|t| {
                let t = t as f64;
                let hip = [40.0 + 2.0 * t, 30.0];
                let a1 = 1.0 + 1.1 * t;
                let knee = [
                    hip[0] + (20.0 + 3.0 * t) * a1.cos(),
                    hip[1] + (20.0 + 3.0 * t) * a1.sin(),
                ];
                let a2 = 0.3 - 0.5 * t;
                let foot = [knee[0] + 12.0 * a2.cos(), knee[1] + 12.0 * a2.sin()];
                let toe = [
                    knee[0] + (6.0 + t) * (a2 - 1.2).cos(),
                    knee[1] + (6.0 + t) * (a2 - 1.2).sin(),
                ];
                vec![hip, knee, foot, toe]
            })
            .collect();
        let anim = Animation {
            skeleton: sk,
            frames: (3..8).collect(),
            joints,
            fps: 25.0,
            width: 100,
            height: 100,
        };
        let doc: Value = serde_json::from_str(&to_dragonbones(&anim)).unwrap();
        let arm = &doc["armature"][0];
        assert_eq!(arm["bone"][1]["name"], "hip->knee");
        assert_eq!(arm["animation"][0]["duration"], 5);
        for t in 0..anim.frames.len() {
            for (j, p) in db_fk(&doc, &anim, t).iter().enumerate() {
                let want = anim.joints[t][j];
                assert!(
                    (p[0] - want[0]).hypot(p[1] - want[1]) < 1e-3,
                    "{t} {j} {p:?} {want:?}"
                );
            }
        }
    }
}
