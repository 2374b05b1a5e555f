//! Spine 4.2 JSON (esotericsoftware.com/spine-json-format) and its texture atlas.
//!
//! **Axes.** Spine is y up, in px, rotations in degrees counter-clockwise. This file is the only
//! place that converts: `X = x − x0`, `Y = y0 − y` with `(x0, y0)` the floor point
//! ([`Animation::floor_origin`]), and a screen angle θ (radians, clockwise, y down) becomes
//! `−θ` in degrees. [`to_spine_point`] and [`from_spine_point`] are the two directions.
//!
//! **Bones.** One Spine bone per joint, named by its pivot as an animator names it
//! ([`bone_names`], plain identifiers: letters, digits and `_`): a root joint's bone sits at the
//! joint (translate keys) and is named after it; any other joint's bone starts at its parent
//! joint (its pivot, where it rotates) and points at the joint (`length` = the bone's length),
//! named after the pivot (`left_shoulder` for the bone from the shoulder to the elbow), or
//! `PIVOT_to_JOINT` when several bones pivot there or the pivot is a root (`pelvis_to_chest`,
//! `pelvis_to_left_hip`). A bone's parent is its parent joint's bone. Several root joints hang
//! under an extra bone `root` at the origin. Bones are listed parents first.
//!
//! **Animation** `mocap`: starts at time 0 on the run's first frame (`time = (frame − first) /
//! fps`). Each channel (a root's translate, a bone's rotate, a bone's scale) is keyed on as few
//! frames as reproduce every frame within the tolerance of [`Keys`] (default 0.5 px and 0.5°; a
//! scale key's tolerance is that many px at the bone's tip), with Bézier curves between the keys
//! as spine-core evaluates them ([`super::spine_keys`]; straight lines with `curves` off), or on
//! every frame with [`Keys::EveryFrame`]. `rotate` values are
//! offsets (degrees) from the setup pose, `translate` (px) on the root joints' bones, and a bone's
//! length change as `scale` x (length / setup length). Spine bones have no length timeline, and
//! a parent's scale x would shear its children, so bones inherit `noScale` and each rotation key
//! is solved against its parent's scale (Spine turns a child by the parent's scaled axes: the
//! local angle `r` shows as `atan2(sin r, s·cos r)`; we key `r = atan2(s·sin δ, cos δ)` for the
//! wanted angle δ). On every frame the joints land where `pose.csv` has them (within the key
//! tolerance). With foot contacts (`retarget/contacts.csv`, [`super::contacts`]) the animation
//! also has `events`: `contact_start` / `contact_end` at their frames' times, the foot joint's
//! name as the event's string (both events defined in the skeleton's `events`).
//!
//! **Skin.** One slot with one weighted mesh (the target character's image, meshed and skinned as
//! `mocap2d render` does it, each vertex bound to one bone with weight 1, triangles in drawing
//! order). [`atlas`] writes the matching one-region `.atlas`, whose page is the character image,
//! copied beside the JSON by `mocap2d export` (`skeleton.images` is `./`, for the Spine editor's
//! data import): the folder holds everything it names and can be moved or zipped.

use super::contacts::{ContactEvent, CONTACT_END, CONTACT_START};
use super::keys::Keys;
use super::spine_keys;
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

/// Names of the Spine (and DragonBones) bones: one per joint, plus the extra top bone when there
/// are several roots.
pub struct BoneNames {
    /// `[joint]`: the name of the bone that ends at the joint (for a root: whose origin is the
    /// joint), named by its pivot (see [`bone_names`]).
    pub of_joint: Vec<String>,
    /// The extra `root` bone's name, when the skeleton has several roots.
    pub top: Option<String>,
}

/// `name` as a plain identifier: every character other than an ASCII letter, digit or `_`
/// becomes `_`, and a leading digit gets a `_` before it.
pub fn identifier(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert(0, '_');
    }
    s
}

/// The bone names for `anim`'s skeleton, as [`identifier`]s: a root joint's bone is named after
/// the joint; the bone from joint `p` (its pivot) to joint `c` is named after `p` when `p` is not
/// a root and `c` is its only child, else `p_to_c`. Names are made unique (`_2`, `_3`, ... after
/// a name already taken, in joint order), and `root` (made unique the same way) goes on top when
/// there are several root joints.
pub fn bone_names(anim: &Animation) -> BoneNames {
    let sk = &anim.skeleton;
    let mut taken = std::collections::BTreeSet::new();
    let mut unique = |base: String| {
        let mut n = base.clone();
        let mut k = 2;
        while taken.contains(&n) {
            n = format!("{base}_{k}");
            k += 1;
        }
        taken.insert(n.clone());
        n
    };
    let of_joint: Vec<String> = (0..sk.len())
        .map(|c| {
            unique(identifier(&match sk.parent(c) {
                None => sk.names[c].clone(),
                Some(p) if sk.parent(p).is_some() && sk.children(p).len() == 1 => {
                    sk.names[p].clone()
                }
                Some(p) => format!("{}_to_{}", sk.names[p], sk.names[c]),
            }))
        })
        .collect();
    let top = (sk.roots().len() > 1).then(|| unique("root".into()));
    BoneNames { of_joint, top }
}

/// The Spine skeleton JSON for `anim` with `mesh` as its skin, keyed as `keys` says, with the
/// foot `contacts` as events (text, deterministic).
pub fn to_spine(
    anim: &Animation,
    mesh: &SkinMesh,
    keys: Keys,
    contacts: &[ContactEvent],
) -> String {
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

    // Animation: from time 0, each channel keyed within the tolerance.
    let time = |t: usize| round((anim.frames[t] - anim.frames[0]) as f64 / anim.fps, 6);
    let tol = keys.tolerance();
    let n = anim.frames.len();
    let mut timelines = Map::new();
    for j in sk.topo_order() {
        let mut tl = Map::new();
        match sk.parent(j) {
            None => {
                let p0 = pos(0, j);
                let values: Vec<Vec<f64>> = (0..n)
                    .map(|t| {
                        let p = pos(t, j);
                        vec![p[0] - p0[0], p[1] - p0[1]]
                    })
                    .collect();
                tl.insert(
                    "translate".into(),
                    spine_keys::translate(&values, keys, &time),
                );
            }
            Some(_) => {
                // Cannot fail: this joint has a parent (this arm), so a bone ends at it.
                let b = bone_of(j).expect("has a parent");
                let r0 = local_deg(0, j);
                let rot: Vec<Vec<f64>> = (0..n).map(|t| vec![local_deg(t, j) - r0]).collect();
                let sc: Vec<Vec<f64>> = (0..n).map(|t| vec![scale(t, b)]).collect();
                let scale_tol = tol / series.length[0][b].max(1.0);
                tl.insert("rotate".into(), spine_keys::rotate(&rot, keys, &time));
                tl.insert(
                    "scale".into(),
                    spine_keys::scale_x(&sc, keys, scale_tol, &time),
                );
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
    let (uvs, triangles) = super::mesh_uvs_triangles(mesh);
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
        Some((dir, _)) => format!("./{dir}/"),
        None => "./".into(),
    };

    let mut animation = Map::new();
    animation.insert("bones".into(), Value::Object(timelines));
    if !contacts.is_empty() {
        let events: Vec<Value> = contacts
            .iter()
            .map(|e| json!({ "time": time(e.t), "name": e.name(), "string": sk.names[e.joint] }))
            .collect();
        animation.insert("events".into(), Value::Array(events));
    }
    let mut doc = json!({
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
        "animations": { ANIMATION: animation },
    });
    if !contacts.is_empty() {
        doc["events"] = json!({ CONTACT_START: {}, CONTACT_END: {} });
    }
    // Cannot fail: the document is plain JSON values (no maps with non-string keys).
    let mut s = serde_json::to_string(&doc).expect("JSON values");
    s.push('\n');
    s
}

/// The Spine texture atlas (4.x text format) for `mesh`: one page, the character image (its path
/// relative to the atlas, inside the export's folder), holding one region with the mesh's name.
pub fn atlas(mesh: &SkinMesh) -> String {
    let (w, h) = (mesh.image_width, mesh.image_height);
    format!(
        "{}\nsize:{w},{h}\nfilter:Linear,Linear\n{}\nbounds:0,0,{w},{h}\n",
        mesh.image, mesh.name
    )
}

#[cfg(test)]
#[path = "spine_tests.rs"]
mod tests;
