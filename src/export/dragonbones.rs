//! DragonBones 5.5 JSON (the `_ske.json` of a DragonBones export).
//!
//! **Axes.** DragonBones is y down, in px, rotations in degrees clockwise: the screen's axes, so
//! only the origin moves, to the floor point ([`Animation::floor_origin`]).
//!
//! **Bones** as in [`super::spine`]: one per joint, named by its pivot
//! ([`super::spine::bone_names`]), a root joint's at the joint, any other's from its parent joint towards it (`length` = the
//! bone's length on the first frame), its parent the parent joint's bone; an extra `root` bone
//! when there are several root joints; parents listed first. Bones do not inherit scale
//! (`inheritScale: false`): DragonBones then moves a child by its parent's full matrix (so a
//! parent's scale x carries the child to the parent's scaled tip) and turns it by the parent's
//! rotation alone, so a child's rotation is simply its angle from its parent bone.
//!
//! **Animation** `mocap`, from the run's first frame (DragonBones time 0), at the armature's
//! `frameRate` (the run's fps): each channel keyed on as few frames as reproduce every frame
//! within the tolerance of [`Keys`] (as in Spine; DragonBones tweens a rotation the short way
//! round, so two rotation keys are never 180° or more apart), each key lasting until the next
//! (`duration` in frames; the last lasts to the end: the animation's `duration` is the frame
//! count), eased by a Bézier `curve` `[x1, y1, x2, y2]` fitted as the runtime samples it
//! ([`super::curves`]) or linear (`tweenEasing` 0, where a straight line holds, and with `curves`
//! off; the last key holds), values relative to the bone's setup
//! transform (the first frame): `translateFrame` (px) on the root joints' bones, `rotateFrame`
//! (degrees, continuous) and `scaleFrame` (x = length / setup length) on the others. Foot
//! contacts ([`super::contacts`]) become the animation's `frame` list: each event frame lasts
//! `duration` frames and holds `events` named `contact_start` / `contact_end`, the foot joint's
//! name in `strings`.
//!
//! **Skin.** One slot (named after the image) holding one weighted mesh display, the same mesh
//! as the Spine export's ([`SkinMesh`]): vertices in armature px at the setup pose, each bound to
//! one bone with weight 1 (`bonePose` gives each bone's setup matrix). Its texture is the one
//! region of the texture atlas [`texture_atlas`] writes (`_tex.json`), whose image (`_tex.png`)
//! is the character image copied beside it by `mocap2d export`.

use super::contacts::ContactEvent;
use super::curves::{self, CurveKey};
use super::keys::{self, Keys};
use super::{round, Animation, SkinMesh};
use serde_json::{json, Map, Value};

/// The armature's, the animation's and the texture atlas's name.
pub const NAME: &str = "mocap";

/// The DragonBones JSON text (`_ske.json`) for `anim` with `mesh` as its skin, keyed as `keys`
/// says, with the foot `contacts` as events (deterministic).
pub fn to_dragonbones(
    anim: &Animation,
    mesh: &SkinMesh,
    keys: Keys,
    contacts: &[ContactEvent],
) -> String {
    let sk = &anim.skeleton;
    let origin = anim.floor_origin();
    let series = anim.bone_series();
    let names = super::spine::bone_names(anim);
    let n = anim.frames.len();
    let tol = keys.tolerance();
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
    // The keys of one channel: `values[t]` on every frame, reduced, as `field = value` maps.
    let channel = |values: &[Vec<f64>], fields: &[(&str, i32)], tol: f64, max_step: Option<f64>| {
        let decimals: Vec<i32> = fields.iter().map(|f| f.1).collect();
        let kept: Vec<CurveKey> = if keys.curves() && tol > 0.0 {
            curves::reduce_dragonbones(values, tol, max_step, &decimals)
        } else {
            keys::reduce(values, tol, max_step)
                .into_iter()
                .map(|at| CurveKey { at, curve: None })
                .collect()
        };
        let frames: Vec<Value> = kept
            .iter()
            .enumerate()
            .map(|(i, k)| {
                let t = k.at;
                let mut m = Map::new();
                let next = kept.get(i + 1).map_or(n, |k| k.at);
                m.insert("duration".into(), json!(next - t));
                match &k.curve {
                    Some(c) => {
                        m.insert("curve".into(), json!(c));
                    }
                    None if i + 1 < kept.len() => {
                        m.insert("tweenEasing".into(), json!(0));
                    }
                    None => {}
                }
                for (k, (f, decimals)) in fields.iter().enumerate() {
                    m.insert((*f).into(), json!(round(values[t][k], *decimals)));
                }
                Value::Object(m)
            })
            .collect();
        Value::Array(frames)
    };
    let obj = |pairs: &[(&str, f64)]| -> Map<String, Value> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), json!(v)))
            .collect()
    };

    let mut bones: Vec<Value> = Vec::new();
    // Each joint's bone: its index in `bones` and its setup matrix (a, b, c, d, tx, ty).
    let mut index_of_joint = vec![0usize; sk.len()];
    let mut setup = vec![[0.0f64; 6]; sk.len()];
    if let Some(top) = &names.top {
        bones.push(json!({ "name": top }));
    }
    let mut timelines = Vec::new();
    for j in sk.topo_order() {
        index_of_joint[j] = bones.len();
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
                setup[j] = [1.0, 0.0, 0.0, 1.0, p0[0], p0[1]];
                b.insert(
                    "transform".into(),
                    Value::Object(obj(&[("x", round(p0[0], 4)), ("y", round(p0[1], 4))])),
                );
                let values: Vec<Vec<f64>> = (0..n)
                    .map(|t| {
                        let p = pos(t, j);
                        vec![p[0] - p0[0], p[1] - p0[1]]
                    })
                    .collect();
                tl.insert(
                    "translateFrame".into(),
                    channel(&values, &[("x", 4), ("y", 4)], tol, None),
                );
            }
            Some(p) => {
                // Cannot fail: this joint has a parent (this arm), so a bone ends at it.
                let bi = bone_of(j).expect("has a parent");
                b.insert("parent".into(), json!(names.of_joint[p]));
                b.insert("length".into(), json!(round(series.length[0][bi], 4)));
                b.insert("inheritScale".into(), json!(false));
                let r0 = local_deg(0, j);
                let x = bone_of(p).map_or(0.0, |f| series.length[0][f]);
                let (a, start) = (series.angle[0][bi], pos(0, p));
                setup[j] = [a.cos(), a.sin(), -a.sin(), a.cos(), start[0], start[1]];
                b.insert(
                    "transform".into(),
                    Value::Object(obj(&[
                        ("x", round(x, 4)),
                        ("skX", round(r0, 5)),
                        ("skY", round(r0, 5)),
                    ])),
                );
                let rot: Vec<Vec<f64>> = (0..n).map(|t| vec![local_deg(t, j) - r0]).collect();
                let sc: Vec<Vec<f64>> = (0..n).map(|t| vec![scale(t, bi)]).collect();
                let scale_tol = tol / series.length[0][bi].max(1.0);
                tl.insert(
                    "rotateFrame".into(),
                    channel(&rot, &[("rotate", 5)], tol, Some(180.0)),
                );
                tl.insert(
                    "scaleFrame".into(),
                    channel(&sc, &[("x", 6)], scale_tol, None),
                );
            }
        }
        bones.push(Value::Object(b));
        timelines.push(Value::Object(tl));
    }

    // The skin: one weighted mesh, each vertex on the bone ending at its bone's child joint.
    let vertex_joint: Vec<usize> = mesh.bone.iter().map(|&b| series.bones[b].1).collect();
    let mut used: Vec<usize> = vertex_joint.clone();
    used.sort_by_key(|&j| index_of_joint[j]);
    used.dedup();
    let vertices: Vec<Value> = mesh
        .rest
        .iter()
        .flat_map(|p| [p[0] - origin[0], p[1] - origin[1]])
        .map(|v| json!(round(v, 3)))
        .collect();
    let (uvs, triangles) = super::mesh_uvs_triangles(mesh);
    let weights: Vec<Value> = vertex_joint
        .iter()
        .flat_map(|&j| [json!(1), json!(index_of_joint[j]), json!(1)])
        .collect();
    let bone_pose: Vec<Value> = used
        .iter()
        .flat_map(|&j| {
            let m = setup[j];
            std::iter::once(json!(index_of_joint[j])).chain(m.map(|v| json!(round(v, 6))))
        })
        .collect();
    let root_bone = names
        .top
        .clone()
        .unwrap_or_else(|| names.of_joint[sk.topo_order()[0]].clone());
    let display = json!({
        "type": "mesh",
        "name": mesh.name,
        "path": mesh.name,
        "width": mesh.image_width,
        "height": mesh.image_height,
        "vertices": vertices,
        "uvs": uvs,
        "triangles": triangles,
        "weights": weights,
        "slotPose": [1, 0, 0, 1, 0, 0],
        "bonePose": bone_pose,
    });

    // Bounds of the setup pose (mesh and joints), DragonBones axes.
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let pts = mesh
        .rest
        .iter()
        .map(|p| [p[0] - origin[0], p[1] - origin[1]])
        .chain((0..sk.len()).map(|j| pos(0, j)));
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let mut animation = json!({
        "name": NAME,
        "duration": n,
        "playTimes": 0,
        "bone": timelines,
    });
    if !contacts.is_empty() {
        animation["frame"] = Value::Array(event_frames(anim, contacts));
    }
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
            "slot": [{ "name": mesh.name, "parent": root_bone }],
            "skin": [{ "name": "", "slot": [{ "name": mesh.name, "display": [display] }] }],
            "animation": [animation],
            "defaultActions": [{ "gotoAndPlay": NAME }],
        }],
    });
    // Cannot fail: the document is plain JSON values (no maps with non-string keys).
    let mut s = serde_json::to_string(&doc).expect("JSON values");
    s.push('\n');
    s
}

/// The animation's `frame` list for `contacts` (sorted by frame): a frame at each event time
/// holding its events, lasting until the next (the last until the end), after an empty frame
/// from 0 when the first event comes later.
fn event_frames(anim: &Animation, contacts: &[ContactEvent]) -> Vec<Value> {
    let n = anim.frames.len();
    let mut starts: Vec<usize> = contacts.iter().map(|e| e.t).collect();
    starts.dedup();
    let mut frames = Vec::new();
    if starts.first().is_some_and(|&t| t > 0) {
        frames.push(json!({ "duration": starts[0] }));
    }
    for (i, &t) in starts.iter().enumerate() {
        let end = starts.get(i + 1).copied().unwrap_or(n);
        let events: Vec<Value> = contacts
            .iter()
            .filter(|e| e.t == t)
            .map(|e| json!({ "name": e.name(), "strings": [anim.skeleton.names[e.joint]] }))
            .collect();
        frames.push(json!({ "duration": end - t, "events": events }));
    }
    frames
}

/// The DragonBones texture atlas JSON (`_tex.json`) for `mesh`: the image `image` (its file
/// name, beside the atlas) as one region named after the mesh.
pub fn texture_atlas(mesh: &SkinMesh, image: &str) -> String {
    let (w, h) = (mesh.image_width, mesh.image_height);
    let doc = json!({
        "name": NAME,
        "imagePath": image,
        "width": w,
        "height": h,
        "SubTexture": [{ "name": mesh.name, "x": 0, "y": 0, "width": w, "height": h }],
    });
    // Cannot fail: plain JSON values.
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
        let mesh = SkinMesh {
            name: "c".into(),
            image: "c.png".into(),
            image_width: 10,
            image_height: 10,
            uvs: vec![],
            rest: vec![],
            bone: vec![],
            triangles: vec![],
            hull: 0,
        };
        let doc: Value =
            serde_json::from_str(&to_dragonbones(&anim, &mesh, Keys::EveryFrame, &[])).unwrap();
        let arm = &doc["armature"][0];
        // Named by the pivot: the hip (a root) to the knee.
        assert_eq!(arm["bone"][1]["name"], "hip_to_knee");
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
