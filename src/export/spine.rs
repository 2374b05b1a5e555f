//! Spine 4.2 JSON (esotericsoftware.com/spine-json-format) and its texture atlas.
//!
//! **Axes.** Spine is y up, in px, rotations in degrees counter-clockwise. This file is the only
//! place that converts: `X = x − x0`, `Y = y0 − y` with `(x0, y0)` the floor point
//! ([`Animation::floor_origin`]), and a screen angle θ (radians, clockwise, y down) becomes
//! `−θ` in degrees. [`to_spine_point`] and [`from_spine_point`] are the two directions.
//!
//! **Bones.** One Spine bone per root joint, named after it, at the joint (translate keys), and
//! one per bone of the skeleton, named `parent->child` as in `bones.csv`, starting at the parent
//! joint and pointing at the child (`length` = the bone's length). A bone's parent is the Spine
//! bone ending at its start joint (or the root joint's bone). Several root joints hang under an
//! extra bone `root` at the origin. Bones are listed parents first.
//!
//! **Animation** `mocap`: one key a frame at `time = frame / fps` (so the animation's clock is
//! the clip's; before the run's first frame the setup pose shows), linear. `rotate` values are
//! offsets (degrees) from the setup pose, `translate` (px) on the root joints' bones, and a bone's
//! length change as `scale` x (length / setup length). Spine bones have no length timeline, and
//! a parent's scale x would shear its children, so bones inherit `noScale` and each rotation key
//! is solved against its parent's scale (Spine turns a child by the parent's scaled axes: the
//! local angle `r` shows as `atan2(sin r, s·cos r)`; we key `r = atan2(s·sin δ, cos δ)` for the
//! wanted angle δ). On every key the joints land where `pose.csv` has them.
//!
//! **Skin.** One slot with one weighted mesh (the target character's image, meshed and skinned as
//! `mocap2d render` does it, each vertex bound to one bone with weight 1, triangles in drawing
//! order). [`atlas`] writes the matching one-region `.atlas`, whose page is the character image
//! itself; `skeleton.images` points at the image's folder for the Spine editor's data import.

use super::{round, wrap, Animation, SkinMesh};
use crate::retarget::P64;
use serde_json::{json, Map, Value};

/// The Spine version written in `skeleton.spine`.
pub const SPINE_VERSION: &str = "4.2.0";

/// The animation's name.
pub const ANIMATION: &str = "mocap";

/// An output position (px, y down) in Spine's axes (px, y up) about the floor point `origin`.
pub fn to_spine_point(p: P64, origin: P64) -> P64 {
    [p[0] - origin[0], origin[1] - p[1]]
}

/// A Spine position (px, y up) back in output px (y down); inverse of [`to_spine_point`].
pub fn from_spine_point(q: P64, origin: P64) -> P64 {
    [q[0] + origin[0], origin[1] - q[1]]
}

/// A screen angle (radians, clockwise, y down) in Spine's degrees (counter-clockwise, y up).
pub fn to_spine_degrees(angle_rad: f64) -> f64 {
    -angle_rad.to_degrees()
}

/// Names of the Spine bones: for each joint, the bone that ends there (`parent->child`) or, for
/// a root joint, the joint's own bone; plus the extra top bone when there are several roots.
pub struct BoneNames {
    /// `[joint]`: the Spine bone whose tip (or, for a root, whose origin) is the joint.
    pub of_joint: Vec<String>,
    /// The extra `root` bone's name, when the skeleton has several roots.
    pub top: Option<String>,
}

/// The Spine bone names for `anim`'s skeleton.
pub fn bone_names(anim: &Animation) -> BoneNames {
    let sk = &anim.skeleton;
    let of_joint = (0..sk.len())
        .map(|j| match sk.parent(j) {
            None => sk.names[j].clone(),
            Some(p) => format!("{}->{}", sk.names[p], sk.names[j]),
        })
        .collect();
    let top = (sk.roots().len() > 1).then(|| {
        let mut n = String::from("root");
        while sk.index_of(&n).is_some() {
            n.push('_');
        }
        n
    });
    BoneNames { of_joint, top }
}

/// The Spine skeleton JSON for `anim` with `mesh` as its skin (text, deterministic).
pub fn to_spine(anim: &Animation, mesh: &SkinMesh) -> String {
    let sk = &anim.skeleton;
    let origin = anim.floor_origin();
    let series = anim.bone_series();
    let names = bone_names(anim);
    let pos = |t: usize, j: usize| to_spine_point(anim.joints[t][j], origin);
    let bone_of = |j: usize| series.ending_at(j);

    // World angle of bone b at frame t (degrees, CCW), and its scale (length / setup length).
    let world_deg = |t: usize, b: usize| to_spine_degrees(series.angle[t][b]);
    let scale = |t: usize, b: usize| {
        let l0 = series.length[0][b];
        if l0 > 1e-9 {
            series.length[t][b] / l0
        } else {
            1.0
        }
    };
    // Local rotation (degrees) of the bone ending at joint c at frame t: its world angle
    // relative to its parent bone's, corrected for the parent's scale x (see the module docs).
    let local_deg = |t: usize, c: usize| -> f64 {
        // Cannot fail: `c` is a child, so it has a parent and a bone.
        let b = bone_of(c).expect("c has a parent");
        let p = series.bones[b].0;
        match bone_of(p) {
            None => world_deg(t, b),
            Some(f) => {
                let delta = (world_deg(t, b) - world_deg(t, f)).to_radians();
                let s = scale(t, f);
                let r = delta + wrap((s * delta.sin()).atan2(delta.cos()) - delta);
                r.to_degrees()
            }
        }
    };

    // Bones, parents first; Spine bone index of each joint's bone.
    let mut bones: Vec<Value> = Vec::new();
    let mut index_of_joint = vec![0usize; sk.len()];
    if let Some(top) = &names.top {
        bones.push(json!({ "name": top }));
    }
    for j in sk.topo_order() {
        index_of_joint[j] = bones.len();
        let mut b = Map::new();
        b.insert("name".into(), json!(names.of_joint[j]));
        match sk.parent(j) {
            None => {
                if let Some(top) = &names.top {
                    b.insert("parent".into(), json!(top));
                }
                let p = pos(0, j);
                b.insert("x".into(), json!(round(p[0], 4)));
                b.insert("y".into(), json!(round(p[1], 4)));
            }
            Some(p) => {
                // Cannot fail: this joint has a parent (this arm), so a bone ends at it.
                let bi = bone_of(j).expect("has a parent");
                b.insert("parent".into(), json!(names.of_joint[p]));
                b.insert("length".into(), json!(round(series.length[0][bi], 4)));
                if let Some(f) = bone_of(p) {
                    b.insert("x".into(), json!(round(series.length[0][f], 4)));
                }
                b.insert("rotation".into(), json!(round(local_deg(0, j), 5)));
                b.insert("inherit".into(), json!("noScale"));
            }
        }
        bones.push(Value::Object(b));
    }

    // Animation: per-frame keys.
    let time = |t: usize| round(anim.frames[t] as f64 / anim.fps, 6);
    let mut timelines = Map::new();
    for j in sk.topo_order() {
        let mut tl = Map::new();
        match sk.parent(j) {
            None => {
                let p0 = pos(0, j);
                let keys: Vec<Value> = (0..anim.frames.len())
                    .map(|t| {
                        let p = pos(t, j);
                        json!({
                            "time": time(t),
                            "x": round(p[0] - p0[0], 4),
                            "y": round(p[1] - p0[1], 4),
                        })
                    })
                    .collect();
                tl.insert("translate".into(), Value::Array(keys));
            }
            Some(_) => {
                // Cannot fail: this joint has a parent (this arm), so a bone ends at it.
                let b = bone_of(j).expect("has a parent");
                let r0 = local_deg(0, j);
                let rotate: Vec<Value> = (0..anim.frames.len())
                    .map(|t| json!({ "time": time(t), "value": round(local_deg(t, j) - r0, 5) }))
                    .collect();
                let scale: Vec<Value> = (0..anim.frames.len())
                    .map(|t| json!({ "time": time(t), "x": round(scale(t, b), 6) }))
                    .collect();
                tl.insert("rotate".into(), Value::Array(rotate));
                tl.insert("scale".into(), Value::Array(scale));
            }
        }
        timelines.insert(names.of_joint[j].clone(), Value::Object(tl));
    }

    // The skin: one mesh, each vertex bound to one bone, in that bone's setup frame.
    let mut vertices: Vec<Value> = Vec::with_capacity(mesh.rest.len() * 5);
    for (v, &b) in mesh.bone.iter().enumerate() {
        let (p, c) = series.bones[b];
        let start = pos(0, p);
        let a = world_deg(0, b).to_radians();
        let q = to_spine_point(mesh.rest[v], origin);
        let (dx, dy) = (q[0] - start[0], q[1] - start[1]);
        let (bx, by) = (a.cos() * dx + a.sin() * dy, -a.sin() * dx + a.cos() * dy);
        vertices.extend([
            json!(1),
            json!(index_of_joint[c]),
            json!(round(bx, 3)),
            json!(round(by, 3)),
            json!(1),
        ]);
    }
    let uvs: Vec<Value> = mesh
        .uvs
        .iter()
        .flat_map(|uv| [json!(round(uv[0], 6)), json!(round(uv[1], 6))])
        .collect();
    let triangles: Vec<Value> = mesh
        .triangles
        .iter()
        .flat_map(|t| t.map(|v| json!(v)))
        .collect();
    let attachment = json!({
        "type": "mesh",
        "uvs": uvs,
        "triangles": triangles,
        "vertices": vertices,
        "hull": mesh.hull,
        "width": mesh.image_width,
        "height": mesh.image_height,
    });
    let root_bone = names
        .top
        .clone()
        .unwrap_or_else(|| names.of_joint[sk.topo_order()[0]].clone());

    // Bounds of the setup pose (mesh and joints), Spine axes.
    let pts: Vec<P64> = mesh
        .rest
        .iter()
        .chain(&anim.joints[0])
        .map(|&p| to_spine_point(p, origin))
        .collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let images = match mesh.image.rsplit_once('/') {
        Some((dir, _)) => format!("{dir}/"),
        None => "./".into(),
    };

    let doc = json!({
        "skeleton": {
            "spine": SPINE_VERSION,
            "x": round(lo[0], 2),
            "y": round(lo[1], 2),
            "width": round(hi[0] - lo[0], 2),
            "height": round(hi[1] - lo[1], 2),
            "fps": anim.fps,
            "images": images,
        },
        "bones": bones,
        "slots": [{ "name": mesh.name, "bone": root_bone, "attachment": mesh.name }],
        "skins": [{
            "name": "default",
            "attachments": { (mesh.name.clone()): { (mesh.name.clone()): attachment } },
        }],
        "animations": { ANIMATION: { "bones": timelines } },
    });
    // Cannot fail: the document is plain JSON values (no maps with non-string keys).
    let mut s = serde_json::to_string(&doc).expect("JSON values");
    s.push('\n');
    s
}

/// The Spine texture atlas (4.x text format) for `mesh`: one page, the character image itself
/// (its path relative to the atlas), holding one region with the mesh's name.
pub fn atlas(mesh: &SkinMesh) -> String {
    let (w, h) = (mesh.image_width, mesh.image_height);
    format!(
        "{}\nsize:{w},{h}\nfilter:Linear,Linear\n{}\nbounds:0,0,{w},{h}\n",
        mesh.image, mesh.name
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::Skeleton;

    #[test]
    fn points_and_angles_round_trip_through_spine_axes() {
        let origin = [120.0, 300.0];
        for p in [[0.0, 0.0], [120.0, 300.0], [311.25, -7.5]] {
            let q = to_spine_point(p, origin);
            let back = from_spine_point(q, origin);
            assert!((back[0] - p[0]).abs() < 1e-12 && (back[1] - p[1]).abs() < 1e-12);
        }
        // Above the floor point is +y in Spine.
        assert_eq!(to_spine_point([120.0, 250.0], origin), [0.0, 50.0]);
        // Straight up on screen (−π/2, y down) is +90° in Spine.
        assert!((to_spine_degrees(-std::f64::consts::FRAC_PI_2) - 90.0).abs() < 1e-12);
        // A direction rotated by the Spine angle gives back the screen direction.
        let theta = 0.7f64;
        let a = to_spine_degrees(theta).to_radians();
        let screen = [theta.cos(), theta.sin()];
        let spine = [a.cos(), a.sin()];
        assert!((spine[0] - screen[0]).abs() < 1e-12 && (spine[1] + screen[1]).abs() < 1e-12);
    }

    /// Forward kinematics the way Spine does it for this export: the parent's scale x stretches
    /// the child's position and turns its axes (`noScale`), and each bone's own scale only
    /// moves its tip. Returns each joint's position (output px) at frame `t` of the JSON.
    fn spine_fk(doc: &Value, anim: &Animation, t: usize) -> Vec<P64> {
        let names = bone_names(anim);
        let anim_doc = &doc["animations"][ANIMATION]["bones"];
        let bones = doc["bones"].as_array().unwrap();
        let origin = anim.floor_origin();
        // name -> (x, y, world angle rad, scale x, length)
        let mut world: std::collections::HashMap<String, (f64, f64, f64, f64, f64)> =
            Default::default();
        for b in bones {
            let name = b["name"].as_str().unwrap();
            let f = |k: &str| b[k].as_f64().unwrap_or(0.0);
            let tl = &anim_doc[name];
            let key = |k: &str, f2: &str, d: f64| {
                tl[k]
                    .as_array()
                    .map_or(d, |a| a[t][f2].as_f64().unwrap_or(d))
            };
            let (lx, ly) = (
                f("x") + key("translate", "x", 0.0),
                f("y") + key("translate", "y", 0.0),
            );
            let rot = (f("rotation") + key("rotate", "value", 0.0)).to_radians();
            let sx = key("scale", "x", 1.0);
            let len = f("length");
            let w = match b["parent"].as_str() {
                None => (lx, ly, rot, sx, len),
                Some(p) => {
                    let (px, py, pa, ps, _) = world[p];
                    let (c, s) = (pa.cos(), pa.sin());
                    let (x, y) = (px + c * ps * lx - s * ly, py + s * ps * lx + c * ly);
                    let dir = (rot.sin()).atan2(ps * rot.cos());
                    (x, y, pa + dir, sx, len)
                }
            };
            world.insert(name.to_owned(), w);
        }
        (0..anim.skeleton.len())
            .map(|j| {
                let (x, y, a, s, len) = world[&names.of_joint[j]];
                let q = match anim.skeleton.parent(j) {
                    None => [x, y],
                    Some(_) => [x + a.cos() * s * len, y + a.sin() * s * len],
                };
                from_spine_point(q, origin)
            })
            .collect()
    }

    #[test]
    fn keys_put_every_joint_where_the_pose_has_it() {
        // A stretching, turning chain on one root, and a second root.
        let sk = Skeleton::new(
            ["hip", "knee", "foot", "toe", "ball"]
                .map(String::from)
                .to_vec(),
            vec![None, Some(0), Some(1), Some(1), None],
        );
        let joints: Vec<Vec<P64>> = (0..6)
            .map(|t| {
                let t = t as f64;
                let hip = [50.0 + 3.0 * t, 40.0 - t];
                let a1 = 1.2 + 0.9 * t; // crosses ±π on the way
                let knee = [
                    hip[0] + (20.0 + 4.0 * t) * a1.cos(),
                    hip[1] + (20.0 + 4.0 * t) * a1.sin(),
                ];
                let a2 = -0.4 * t;
                let foot = [knee[0] + 15.0 * a2.cos(), knee[1] + 15.0 * a2.sin()];
                let toe = [
                    knee[0] + (9.0 - t) * (a2 + 1.0).cos(),
                    knee[1] + (9.0 - t) * (a2 + 1.0).sin(),
                ];
                vec![hip, knee, foot, toe, [5.0, 5.0 + t]]
            })
            .collect();
        let anim = Animation {
            skeleton: sk,
            frames: (10..16).collect(),
            joints,
            fps: 24.0,
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
        let doc: Value = serde_json::from_str(&to_spine(&anim, &mesh)).unwrap();
        assert_eq!(doc["bones"][0]["name"], "root");
        assert_eq!(doc["bones"][2]["name"], "hip->knee");
        assert_eq!(
            doc["animations"][ANIMATION]["bones"]["hip"]["translate"][2]["time"],
            0.5
        );
        for t in 0..anim.frames.len() {
            for (j, p) in spine_fk(&doc, &anim, t).iter().enumerate() {
                let want = anim.joints[t][j];
                let err = (p[0] - want[0]).hypot(p[1] - want[1]);
                assert!(err < 1e-3, "frame {t} joint {j}: {p:?} vs {want:?}");
            }
        }
    }
}
