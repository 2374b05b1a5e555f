//! mocap2d's JSON export: the tracks and the retargeted pose in one file.
//!
//! ```text
//! {
//!   "schema": "mocap2d-export/1",
//!   "width": 640, "height": 360,          output frame size, px
//!   "fps": 30.0,                          frames per second (seconds = frame / fps)
//!   "tracks": {                           the run's tracks.csv
//!     "joints": [{"name": "pelvis", "parent": null}, {"name": "chest", "parent": "pelvis"}, ...],
//!     "frames": [{"frame": 0,             0-based frame index of the clip
//!                 "x": [...], "y": [...], joint centres, px (origin top-left, y down),
//!                                         one value per joint in "joints" order
//!                 "angle": [...],         rectangle rotation from the seed pose, radians,
//!                                         clockwise on screen, unwrapped
//!                 "score": [...],         match confidence 0..1
//!                 "status": [...]}]       seed | ok | low | occluded | lost
//!   },
//!   "pose": null, or {                    the retargeted target character (retarget/)
//!     "target": "robot.toml",             the target character file given to retarget
//!     "joints": [{"name": ..., "parent": ...}],
//!     "bones": ["pelvis->chest", ...],    parent->child, in the child's joint order
//!     "frames": [{"frame": 0, "x": [...], "y": [...],   joints, px
//!                 "length": [...],        bone lengths, px
//!                 "angle": [...]}]        bone directions, radians clockwise on screen,
//!                                         unwrapped over the frames
//!   }
//! }
//! ```
//! Positions have 3 decimals, angles 5 (tracks: 4, as in tracks.csv).

use super::{round, Animation, Tracks};
use crate::skeleton::Skeleton;
use serde_json::{json, Value};

/// The `schema` value.
pub const SCHEMA: &str = "mocap2d-export/1";

fn joints(sk: &Skeleton) -> Value {
    Value::Array(
        (0..sk.len())
            .map(|j| json!({ "name": sk.names[j], "parent": sk.parent(j).map(|p| &sk.names[p]) }))
            .collect(),
    )
}

/// The JSON text (deterministic): `tracks`, and the retargeted `pose` with the target file's
/// name when the run has been retargeted.
pub fn to_json(
    width: u32,
    height: u32,
    fps: f64,
    tracks: &Tracks,
    pose: Option<(&Animation, &str)>,
) -> String {
    let track_frames: Vec<Value> = tracks
        .frames
        .iter()
        .zip(&tracks.rows)
        .map(|(f, rows)| {
            let col = |g: &dyn Fn(&crate::run::TrackRow) -> f64, d: i32| -> Vec<f64> {
                rows.iter().map(|r| round(g(r), d)).collect()
            };
            json!({
                "frame": f,
                "x": col(&|r| r.x as f64, 3),
                "y": col(&|r| r.y as f64, 3),
                "angle": col(&|r| r.angle as f64, 4),
                "score": col(&|r| r.score as f64, 3),
                "status": rows.iter().map(|r| r.status.as_str()).collect::<Vec<_>>(),
            })
        })
        .collect();
    let pose = pose.map_or(Value::Null, |(anim, target)| {
        let s = anim.bone_series();
        let names = &anim.skeleton.names;
        let frames: Vec<Value> = (0..anim.frames.len())
            .map(|t| {
                let c = |k: usize| -> Vec<f64> {
                    anim.joints[t].iter().map(|p| round(p[k], 3)).collect()
                };
                json!({
                    "frame": anim.frames[t],
                    "x": c(0),
                    "y": c(1),
                    "length": s.length[t].iter().map(|&l| round(l, 3)).collect::<Vec<_>>(),
                    "angle": s.angle[t].iter().map(|&a| round(a, 5)).collect::<Vec<_>>(),
                })
            })
            .collect();
        json!({
            "target": target,
            "joints": joints(&anim.skeleton),
            "bones": s.bones.iter().map(|&(p, c)| format!("{}->{}", names[p], names[c])).collect::<Vec<_>>(),
            "frames": frames,
        })
    });
    let doc = json!({
        "schema": SCHEMA,
        "width": width,
        "height": height,
        "fps": fps,
        "tracks": { "joints": joints(&tracks.skeleton), "frames": track_frames },
        "pose": pose,
    });
    // Cannot fail: the document is plain JSON values (no maps with non-string keys).
    let mut s = serde_json::to_string(&doc).expect("JSON values");
    s.push('\n');
    s
}
