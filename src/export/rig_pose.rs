//! An animator's Spine skeleton as [`super::spine_rig`] reads it: their bones' setup pose and IK
//! constraints, and Spine's forward kinematics over them (rotation, translation and scale
//! inherited from the parent; shear and the other inherit modes are not modelled: they only
//! serve to place IK targets and to judge the rig's shape).

use serde_json::{Map, Value};

/// Their bone, as read from the skeleton JSON.
pub struct Bone {
    pub name: String,
    pub parent: Option<usize>,
    pub length: f64,
    /// Setup pose, local: rotation (degrees), position, scale.
    pub rotation: f64,
    pub x: f64,
    pub y: f64,
    pub scale: [f64; 2],
}

/// One of their IK constraints.
pub struct Ik {
    pub name: String,
    pub bones: Vec<usize>,
    pub target: usize,
    /// The setup's fields a key repeats (bendPositive, compress, stretch, softness).
    pub fields: Map<String, Value>,
}

/// A bone's world transform: `[a, b, c, d]` (columns: its x and y axes) and origin.
#[derive(Clone, Copy)]
pub struct World {
    pub m: [f64; 4],
    pub o: [f64; 2],
}

impl World {
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        [
            self.m[0] * p[0] + self.m[1] * p[1] + self.o[0],
            self.m[2] * p[0] + self.m[3] * p[1] + self.o[1],
        ]
    }

    pub fn inverse_apply(&self, q: [f64; 2]) -> [f64; 2] {
        let [a, b, c, d] = self.m;
        let det = a * d - b * c;
        let (x, y) = (q[0] - self.o[0], q[1] - self.o[1]);
        if det.abs() < 1e-12 {
            return [0.0, 0.0];
        }
        [(d * x - b * y) / det, (-c * x + a * y) / det]
    }
}

/// World transforms of `bones` (parents first) with each bone's rotation offset by `turn[i]`
/// degrees and its position by `shift[i]` (local): Spine's forward kinematics for bones that
/// inherit everything and are not sheared.
pub fn world(bones: &[Bone], turn: &[f64], shift: &[[f64; 2]]) -> Vec<World> {
    let mut w: Vec<World> = Vec::with_capacity(bones.len());
    for (i, b) in bones.iter().enumerate() {
        let r = (b.rotation + turn[i]).to_radians();
        let l = [
            r.cos() * b.scale[0],
            -r.sin() * b.scale[1],
            r.sin() * b.scale[0],
            r.cos() * b.scale[1],
        ];
        let p = [b.x + shift[i][0], b.y + shift[i][1]];
        w.push(match b.parent {
            None => World { m: l, o: p },
            Some(q) => {
                let pw = w[q];
                let [a, bb, c, d] = pw.m;
                World {
                    m: [
                        a * l[0] + bb * l[2],
                        a * l[1] + bb * l[3],
                        c * l[0] + d * l[2],
                        c * l[1] + d * l[3],
                    ],
                    o: pw.apply(p),
                }
            }
        });
    }
    w
}

/// Their bones (parents first) and IK constraints, from the skeleton JSON; errors say what is
/// wrong.
pub fn read_bones(doc: &Value) -> std::result::Result<(Vec<Bone>, Vec<Ik>), String> {
    let raw_bones = doc["bones"]
        .as_array()
        .ok_or("no `bones` array: is this a Spine skeleton JSON?")?;
    let mut bones: Vec<Bone> = Vec::with_capacity(raw_bones.len());
    for (i, b) in raw_bones.iter().enumerate() {
        let bname = b["name"]
            .as_str()
            .ok_or_else(|| format!("bone {i} has no name"))?;
        let parent = match b["parent"].as_str() {
            None => None,
            Some(p) => Some(bones.iter().position(|x| x.name == p).ok_or_else(|| {
                format!(
                    "bone {bname:?}: parent {p:?} is not listed before it; is the file from Spine?"
                )
            })?),
        };
        let f = |k: &str, d: f64| b[k].as_f64().unwrap_or(d);
        bones.push(Bone {
            name: bname.to_owned(),
            parent,
            length: f("length", 0.0),
            rotation: f("rotation", 0.0),
            x: f("x", 0.0),
            y: f("y", 0.0),
            scale: [f("scaleX", 1.0), f("scaleY", 1.0)],
        });
    }
    let index = |n: &str, what: &str| {
        bones
            .iter()
            .position(|b| b.name == n)
            .ok_or_else(|| format!("IK constraint {what:?} names bone {n:?}, which is not listed"))
    };
    let mut iks = Vec::new();
    for ik in doc["ik"].as_array().map_or(&[][..], Vec::as_slice) {
        let name = ik["name"].as_str().unwrap_or("").to_owned();
        let mut list = Vec::new();
        for b in ik["bones"].as_array().map_or(&[][..], Vec::as_slice) {
            list.push(index(b.as_str().unwrap_or(""), &name)?);
        }
        let Some(target) = ik["target"].as_str() else {
            continue;
        };
        let target = index(target, &name)?;
        if list.is_empty() {
            continue;
        }
        let mut fields = Map::new();
        for k in ["bendPositive", "compress", "stretch", "softness"] {
            if let Some(v) = ik.get(k) {
                fields.insert(k.into(), v.clone());
            }
        }
        iks.push(Ik {
            name,
            bones: list,
            target,
            fields,
        });
    }
    Ok((bones, iks))
}
