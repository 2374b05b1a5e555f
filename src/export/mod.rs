//! Exports to the formats animators load: [`spine`] (Spine 4.2 JSON + atlas + image),
//! [`dragonbones`] (DragonBones 5.5 `_ske.json` + `_tex.json` + `_tex.png`), [`bvh`] (Biovision
//! hierarchy, 2D), [`dlc`] (DeepLabCut CSV) and [`json`] (mocap2d's own schema). Spine and
//! DragonBones write a folder that travels: every file they name is written beside the main
//! file and named by its file name alone; their keys are reduced by [`keys`], and the foot
//! contacts of the retarget become their events ([`contacts`]).
//!
//! Each writer is a pure function from plain data to text; `mocap2d export`
//! ([`crate::app::export`]) reads the run folder, checks it, and writes atomically. Positions come
//! in as [`crate::geom`]'s conventions (px, y down, angles clockwise on screen); every format
//! converts to its own axes and units inside its own file (Spine and BVH are y up and
//! counter-clockwise, DragonBones is y down and clockwise, in degrees).
//!
//! The skeleton formats (Spine, DragonBones, BVH) share one placement: their origin is the
//! **floor point** ([`Animation::floor_origin`]), below the first root joint at the height of
//! the lowest joint, both on the first exported frame; so the character stands on y = 0.

pub mod bvh;
pub mod contacts;
pub mod curves;
pub mod dlc;
pub mod dragonbones;
pub mod json;
pub mod keys;
pub mod rig_map;
pub mod rig_pose;
pub mod skin;
pub mod spine;
pub mod spine_keys;
pub mod spine_rig;
pub mod splice;

use crate::error::{Error, Result};
use crate::retarget::P64;
use crate::run::TrackRow;
use crate::skeleton::Skeleton;
use std::path::Path;

/// An export format, as `--format` names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Format {
    /// Spine 4.2 JSON (+ an .atlas and the image beside it): bones, one weighted mesh, one
    /// animation.
    Spine,
    /// DragonBones 5.5 (`_ske.json` + `_tex.json` + `_tex.png`): armature, bones, one weighted
    /// mesh, one animation.
    #[value(name = "dragonbones")]
    DragonBones,
    /// Biovision hierarchy (2D: X/Y position and Z rotation channels), for Blender.
    Bvh,
    /// DeepLabCut CSV of the tracks: x, y, likelihood per joint.
    #[value(name = "dlc-csv")]
    DlcCsv,
    /// The tracks and the retargeted pose in mocap2d's JSON schema.
    Json,
}

impl Format {
    /// The name `--format` takes.
    pub fn name(self) -> &'static str {
        match self {
            Format::Spine => "spine",
            Format::DragonBones => "dragonbones",
            Format::Bvh => "bvh",
            Format::DlcCsv => "dlc-csv",
            Format::Json => "json",
        }
    }

    /// True for formats that export the retargeted pose (they need `mocap2d retarget` first).
    pub fn needs_retarget(self) -> bool {
        matches!(self, Format::Spine | Format::DragonBones | Format::Bvh)
    }

    /// True for formats that carry the target character's image (its skin): they need the
    /// target character file, from `--target` or as `retarget.toml` names it.
    pub fn needs_target(self) -> bool {
        matches!(self, Format::Spine | Format::DragonBones)
    }
}

/// A retargeted animation as the exporters read it.
#[derive(Debug, Clone, PartialEq)]
pub struct Animation {
    /// Target joints (pose.csv order) and parent links.
    pub skeleton: Skeleton,
    /// Frame index of each pose: consecutive, from the run's seed frame.
    pub frames: Vec<u64>,
    /// `[t][joint]`: position, output px (y down).
    pub joints: Vec<Vec<P64>>,
    /// Frames per second.
    pub fps: f64,
    /// Output frame size, px.
    pub width: u32,
    pub height: u32,
}

impl Animation {
    /// The floor point (output px, y down): x of the first root joint (in parents-first order),
    /// y of the lowest joint, both on the first frame. Skeleton formats put their origin here.
    pub fn floor_origin(&self) -> P64 {
        let first = &self.joints[0];
        let root = self.skeleton.topo_order().first().copied().unwrap_or(0);
        let floor = first.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max);
        [first[root][0], floor]
    }

    /// Bones `(parent, child)` in the child's joint order, with `[t][bone]` lengths (px) and
    /// angles (radians, clockwise on screen, unwrapped over the frames; a bone of zero length
    /// keeps its previous angle).
    pub fn bone_series(&self) -> BoneSeries {
        let bones = self.skeleton.bones();
        let mut length = Vec::with_capacity(self.joints.len());
        let mut angle: Vec<Vec<f64>> = Vec::with_capacity(self.joints.len());
        for f in &self.joints {
            let mut l = Vec::with_capacity(bones.len());
            let mut a = Vec::with_capacity(bones.len());
            for (b, &(p, c)) in bones.iter().enumerate() {
                let (dx, dy) = (f[c][0] - f[p][0], f[c][1] - f[p][1]);
                let len = dx.hypot(dy);
                let raw = dy.atan2(dx);
                a.push(match angle.last() {
                    None => raw,
                    Some(prev) if len < 1e-9 => prev[b],
                    Some(prev) => prev[b] + wrap(raw - prev[b]),
                });
                l.push(len);
            }
            length.push(l);
            angle.push(a);
        }
        BoneSeries {
            bones,
            length,
            angle,
        }
    }
}

/// Bone lengths and angles over the frames (see [`Animation::bone_series`]).
#[derive(Debug, Clone, PartialEq)]
pub struct BoneSeries {
    /// `(parent, child)` joint indices, in the child's order.
    pub bones: Vec<(usize, usize)>,
    /// `[t][bone]`: px.
    pub length: Vec<Vec<f64>>,
    /// `[t][bone]`: radians, clockwise on screen, unwrapped.
    pub angle: Vec<Vec<f64>>,
}

impl BoneSeries {
    /// Index of the bone ending at joint `c`, if any.
    pub fn ending_at(&self, c: usize) -> Option<usize> {
        self.bones.iter().position(|&(_, ch)| ch == c)
    }
}

/// A run's tracks, one row per joint per frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracks {
    /// The run's joints (seed-file order) and parent links.
    pub skeleton: Skeleton,
    /// Frame index of each row group: consecutive, from the seed frame.
    pub frames: Vec<u64>,
    /// `[t][joint]`: the `tracks.csv` row, joints in skeleton order.
    pub rows: Vec<Vec<TrackRow>>,
}

impl Tracks {
    /// Groups `tracks.csv` rows (read from `path`, named in errors) by frame, checking that every
    /// frame lists every joint of `skeleton` once, in the skeleton's order, frames consecutive.
    pub fn from_rows(rows: Vec<TrackRow>, skeleton: Skeleton, path: &Path) -> Result<Tracks> {
        let n = skeleton.len();
        let err = |line: usize, msg: String| Error::RunFolder {
            path: path.to_owned(),
            msg: format!("line {line}: {msg}; the run folder is damaged: track the clip again"),
        };
        if rows.is_empty() || n == 0 {
            return Err(err(2, "no tracked frames".into()));
        }
        let mut frames = Vec::new();
        let mut grouped: Vec<Vec<TrackRow>> = Vec::new();
        for (i, r) in rows.into_iter().enumerate() {
            let k = i % n;
            if k == 0 {
                if let Some(&last) = frames.last() {
                    if r.frame != last + 1 {
                        return Err(err(
                            i + 2,
                            format!("frame {} follows frame {last}", r.frame),
                        ));
                    }
                }
                frames.push(r.frame);
                grouped.push(Vec::with_capacity(n));
            }
            if r.joint != skeleton.names[k] || Some(&r.frame) != frames.last() {
                return Err(err(
                    i + 2,
                    format!(
                        "expected joint {:?} of frame {}, found {:?} of frame {}",
                        skeleton.names[k],
                        // Cannot fail: row 0 of each frame (k == 0) pushed it.
                        frames.last().expect("pushed"),
                        r.joint,
                        r.frame
                    ),
                ));
            }
            grouped.last_mut().expect("pushed").push(r);
        }
        if grouped.last().is_some_and(|g| g.len() != n) {
            return Err(err(
                n * grouped.len() + 1,
                "the last frame does not list every joint".into(),
            ));
        }
        Ok(Tracks {
            skeleton,
            frames,
            rows: grouped,
        })
    }
}

/// The character's image as one mesh, skinned rigidly to the bones, for the skeleton formats.
#[derive(Debug, Clone, PartialEq)]
pub struct SkinMesh {
    /// Attachment and atlas region name (the image's file stem).
    pub name: String,
    /// The image's path relative to the export's folder, `/`-separated.
    pub image: String,
    /// Image size, px.
    pub image_width: u32,
    pub image_height: u32,
    /// Texture coordinates, 0 to 1 from the image's top-left corner.
    pub uvs: Vec<[f64; 2]>,
    /// Vertex positions at the first frame's pose, output px (y down).
    pub rest: Vec<P64>,
    /// Bone of each vertex: index into [`BoneSeries::bones`] (= `skeleton.bones()`).
    pub bone: Vec<usize>,
    /// Triangles in drawing order (back to front), vertices clockwise on screen.
    pub triangles: Vec<[u32; 3]>,
    /// The first `hull` vertices are the outer outline, in order.
    pub hull: usize,
}

/// An angle (radians) wrapped into `(-π, π]`.
pub(crate) fn wrap(a: f64) -> f64 {
    let r = a.rem_euclid(std::f64::consts::TAU);
    if r > std::f64::consts::PI {
        r - std::f64::consts::TAU
    } else {
        r
    }
}

/// A mesh's texture coordinates and triangles as the flat JSON arrays Spine and DragonBones
/// both read.
pub(crate) fn mesh_uvs_triangles(
    mesh: &SkinMesh,
) -> (Vec<serde_json::Value>, Vec<serde_json::Value>) {
    use serde_json::json;
    let uvs = mesh
        .uvs
        .iter()
        .flat_map(|uv| [json!(round(uv[0], 6)), json!(round(uv[1], 6))])
        .collect();
    let triangles = mesh
        .triangles
        .iter()
        .flat_map(|t| t.map(|v| json!(v)))
        .collect();
    (uvs, triangles)
}

/// `x` rounded to `decimals` decimals, as a JSON number (keeps files small and deterministic).
pub(crate) fn round(x: f64, decimals: i32) -> f64 {
    let k = 10f64.powi(decimals);
    let r = (x * k).round() / k;
    if r == 0.0 {
        0.0 // no "-0.0"
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arm() -> Animation {
        Animation {
            skeleton: Skeleton::new(
                vec!["hip".into(), "knee".into(), "foot".into()],
                vec![None, Some(0), Some(1)],
            ),
            frames: vec![4, 5],
            joints: vec![
                vec![[10.0, 10.0], [10.0, 20.0], [20.0, 20.0]],
                vec![[10.0, 10.0], [0.0, 10.0], [0.0, 0.0]],
            ],
            fps: 25.0,
            width: 40,
            height: 30,
        }
    }

    #[test]
    fn floor_origin_is_below_the_root_at_the_lowest_joint() {
        assert_eq!(arm().floor_origin(), [10.0, 20.0]);
    }

    #[test]
    fn bone_angles_unwrap_across_pi() {
        let s = arm().bone_series();
        assert_eq!(s.bones, vec![(0, 1), (1, 2)]);
        // hip->knee: straight down (π/2), then to the left: π, not -π.
        assert!((s.angle[0][0] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((s.angle[1][0] - std::f64::consts::PI).abs() < 1e-12);
        // knee->foot: right (0), then up (-π/2).
        assert!((s.angle[1][1] + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(s.length[1], vec![10.0, 10.0]);
    }
}
