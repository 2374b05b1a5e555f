//! The files `mocap2d retarget` writes into `RUN/retarget/`, each atomically:
//!
//! ```text
//! pose.csv        frame,joint,x,y            target joints, output px (3 decimals)
//! bones.csv       frame,bone,length,angle    bone "parent->child": px (3 decimals), radians
//!                                            clockwise on screen, unwrapped (5 decimals)
//! clean.csv       frame,joint,x,y,status     the source tracks after the clean-up (px, 3
//!                                            decimals); status as in tracks.csv, `filled`
//!                                            where the clean-up dropped a jump and filled it
//! contacts.csv    frame,joint,contact        each foot joint of the target: 1 on the ground
//! retarget.toml   the target file's hash, placement, frame size and options, so that
//!                 `mocap2d render` can check it draws the same character
//! ```
//! Rows are by frame, then target-file order.

use super::{Placement, Retargeted, P64};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// The header of `pose.csv`.
pub const POSE_HEADER: &str = "frame,joint,x,y";
/// The header of `bones.csv`.
pub const BONES_HEADER: &str = "frame,bone,length,angle";

/// What `retarget.toml` records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RetargetManifest {
    pub tool: String,
    pub version: String,
    /// The target character file, as given.
    pub target: String,
    /// blake3 of the target character file's text.
    pub target_blake3: String,
    /// blake3 of the run's `tracks.csv`.
    pub tracks_blake3: String,
    /// Output frame size (px) and rate (frames/s), from the run.
    pub width: u32,
    pub height: u32,
    pub fps: f64,
    /// Output px per image px.
    pub scale: f64,
    /// Output px of the image origin.
    pub offset_x: f64,
    pub offset_y: f64,
    /// `none`, `median:N` or `gaussian:S`.
    pub smooth: String,
    /// Cartoon filter strength (0 = off) and σ (frames).
    pub cartoon_strength: f64,
    pub cartoon_sigma_frames: f64,
    /// `--keep-size` (absent in manifests of earlier versions: false).
    #[serde(default)]
    pub keep_size: bool,
    /// The clean-up's strength (`--clean`; 0 = off; absent in earlier manifests: 0).
    #[serde(default)]
    pub clean: usize,
    /// `--stretch` (absent in earlier manifests: false).
    #[serde(default)]
    pub stretch: bool,
    /// Feet held still on the ground (absent in earlier manifests: false).
    #[serde(default)]
    pub plant_feet: bool,
}

impl RetargetManifest {
    /// The placement it records.
    pub fn placement(&self) -> Placement {
        Placement {
            scale: self.scale,
            offset: [self.offset_x, self.offset_y],
        }
    }
}

/// `pose.csv` text for `r`, joints named by `names`.
pub fn pose_csv(r: &Retargeted, names: &[String]) -> String {
    let mut s = String::with_capacity(r.frames.len() * names.len() * 28);
    s.push_str(POSE_HEADER);
    s.push('\n');
    for (f, joints) in r.frames.iter().zip(&r.joints) {
        for (name, p) in names.iter().zip(joints) {
            let _ = writeln!(s, "{f},{name},{:.3},{:.3}", p[0], p[1]);
        }
    }
    s
}

/// `clean.csv` text: the cleaned `motion` of `skeleton` in the order of the `rows` of
/// `tracks.csv` it came from, each with its status, or `filled` where `dropped`.
pub fn clean_csv(
    rows: &[crate::run::TrackRow],
    skeleton: &crate::skeleton::Skeleton,
    motion: &super::Motion,
    dropped: &[Vec<bool>],
) -> String {
    let mut s = String::with_capacity(rows.len() * 36);
    s.push_str("frame,joint,x,y,status\n");
    let first = motion.frames.first().copied().unwrap_or(0);
    for r in rows {
        let t = (r.frame - first) as usize;
        let Some(j) = skeleton.index_of(&r.joint) else {
            continue;
        };
        let p = motion.joints[t][j];
        let status = if dropped[t][j] {
            super::cleanup::FILLED
        } else {
            r.status.as_str()
        };
        let _ = writeln!(
            s,
            "{},{},{:.3},{:.3},{status}",
            r.frame, r.joint, p[0], p[1]
        );
    }
    s
}

/// The name of bone `parent -> child` in `bones.csv`.
pub fn bone_name(names: &[String], (p, c): (usize, usize)) -> String {
    format!("{}->{}", names[p], names[c])
}

/// `bones.csv` text for `r`.
pub fn bones_csv(r: &Retargeted, names: &[String]) -> String {
    let bone_names: Vec<String> = r.bones.iter().map(|&b| bone_name(names, b)).collect();
    let mut s = String::with_capacity(r.frames.len() * r.bones.len() * 36);
    s.push_str(BONES_HEADER);
    s.push('\n');
    for (t, f) in r.frames.iter().enumerate() {
        for (b, name) in bone_names.iter().enumerate() {
            let _ = writeln!(s, "{f},{name},{:.3},{:.5}", r.length[t][b], r.angle[t][b]);
        }
    }
    s
}

#[derive(Deserialize)]
struct PoseRow {
    frame: u64,
    joint: String,
    x: f64,
    y: f64,
}

/// Reads `pose.csv`: the frames and `[t][joint]` positions (px), joints in the order of `names`
/// (every frame must list exactly those joints in that order).
pub fn read_pose(path: &Path, names: &[String]) -> Result<(Vec<u64>, Vec<Vec<P64>>)> {
    let err = |msg: String| Error::RunFolder {
        path: path.to_owned(),
        msg,
    };
    let mut rdr = csv::Reader::from_path(path).map_err(|e| {
        err(format!(
            "cannot read the retargeted pose ({e}); run `mocap2d retarget RUN --target ...` first"
        ))
    })?;
    let mut frames = Vec::new();
    let mut joints: Vec<Vec<P64>> = Vec::new();
    for (i, row) in rdr.deserialize::<PoseRow>().enumerate() {
        let row = row.map_err(|e| err(format!("line {}: {e}", i + 2)))?;
        let k = i % names.len();
        if k == 0 {
            frames.push(row.frame);
            joints.push(Vec::with_capacity(names.len()));
        }
        if row.joint != names[k]
            || Some(&row.frame) != frames.last()
            || !row.x.is_finite()
            || !row.y.is_finite()
        {
            return Err(err(format!(
                "line {}: expected joint {:?} of frame {}; was it written for another character? \
                 run `mocap2d retarget` again",
                i + 2,
                names[k],
                // Cannot fail: row 0 (k == 0) pushed a frame.
                frames.last().expect("pushed")
            )));
        }
        // Cannot fail: row 0 (k == 0) pushed a frame.
        joints.last_mut().expect("pushed").push([row.x, row.y]);
    }
    if joints.is_empty() || joints.last().is_some_and(|j| j.len() != names.len()) {
        return Err(err(
            "empty or cut short; run `mocap2d retarget` again".into()
        ));
    }
    Ok((frames, joints))
}

/// The target skeleton of a retarget folder: joint names in `pose.csv` order (its first frame)
/// and parent links from the `parent->child` bone names of `bones.csv` (its first frame), so that
/// exporters need not re-read the target character file. Errors name the file and the fix.
pub fn read_skeleton(pose_path: &Path, bones_path: &Path) -> Result<crate::skeleton::Skeleton> {
    let err = |path: &Path, msg: String| Error::RunFolder {
        path: path.to_owned(),
        msg,
    };
    let again = "run `mocap2d retarget RUN --target ...` (again)";
    let mut names: Vec<String> = Vec::new();
    let mut rdr = csv::Reader::from_path(pose_path).map_err(|e| {
        err(
            pose_path,
            format!("cannot read the retargeted pose ({e}); {again}"),
        )
    })?;
    let mut first = None;
    for (i, row) in rdr.deserialize::<PoseRow>().enumerate() {
        let row = row.map_err(|e| err(pose_path, format!("line {}: {e}; {again}", i + 2)))?;
        if *first.get_or_insert(row.frame) != row.frame {
            break;
        }
        if names.contains(&row.joint) {
            return Err(err(
                pose_path,
                format!(
                    "line {}: joint {:?} listed twice; {again}",
                    i + 2,
                    row.joint
                ),
            ));
        }
        names.push(row.joint);
    }
    if names.is_empty() {
        return Err(err(pose_path, format!("no poses; {again}")));
    }
    let mut parents = vec![None; names.len()];
    let mut rdr = csv::Reader::from_path(bones_path)
        .map_err(|e| err(bones_path, format!("cannot read the bones ({e}); {again}")))?;
    let mut first = None;
    for (i, row) in rdr.records().enumerate() {
        let row = row.map_err(|e| err(bones_path, format!("line {}: {e}; {again}", i + 2)))?;
        let bad = || {
            err(
                bones_path,
                format!(
                    "line {}: not `frame,parent->child,length,angle`; {again}",
                    i + 2
                ),
            )
        };
        let frame: u64 = row.get(0).and_then(|f| f.parse().ok()).ok_or_else(bad)?;
        if *first.get_or_insert(frame) != frame {
            break;
        }
        let (p, c) = row
            .get(1)
            .and_then(|b| b.split_once("->"))
            .ok_or_else(bad)?;
        let index = |n: &str| {
            names.iter().position(|x| x == n).ok_or_else(|| {
                err(
                    bones_path,
                    format!("line {}: joint {n:?} is not in pose.csv; {again}", i + 2),
                )
            })
        };
        let (p, c) = (index(p)?, index(c)?);
        parents[c] = Some(p);
    }
    let skeleton = crate::skeleton::Skeleton::new(names, parents);
    if skeleton.find_cycle().is_some() {
        return Err(err(bones_path, format!("bones form a cycle; {again}")));
    }
    Ok(skeleton)
}

/// Reads `retarget.toml`.
pub fn read_manifest(path: &Path) -> Result<RetargetManifest> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::RunFolder {
        path: path.to_owned(),
        msg: format!("cannot read ({e}); run `mocap2d retarget RUN --target ...` first"),
    })?;
    toml::from_str(&text).map_err(|e| Error::RunFolder {
        path: path.to_owned(),
        msg: format!(
            "damaged or edited: {}; run `mocap2d retarget` again",
            e.message()
        ),
    })
}

/// `retarget.toml` text.
pub fn manifest_toml(m: &RetargetManifest) -> String {
    // Cannot fail: strings, finite-or-not floats and small integers, all plain TOML values.
    let body = toml::to_string(m).expect("plain TOML values");
    format!(
        "# written by `mocap2d retarget`; `mocap2d render` checks the target against it\n{body}"
    )
}
