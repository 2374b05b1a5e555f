//! The joints' rectangles as both pages send them (the correction page's segment files, the
//! seeding page's seed file): every joint once, each rectangle whole and finite, checked before
//! anything is written.

use super::reply::Reply;
use crate::seed::{SeedJoint, MIN_BOX_PX};
use serde::Deserialize;

/// A rectangle as the page sends it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct BoxEdit {
    pub(super) name: String,
    pub(super) x: f64,
    pub(super) y: f64,
    pub(super) w: f64,
    pub(super) h: f64,
    #[serde(default)]
    pub(super) angle: f64,
}

/// Sets each of `joints`' rectangle from the page's `edits`, which must give every joint once
/// (their names as in `file`, for messages); else the 400 reply saying why.
pub(super) fn apply_boxes(
    joints: &mut [SeedJoint],
    edits: &[BoxEdit],
    file: &str,
) -> std::result::Result<(), Reply> {
    let mut seen = vec![false; joints.len()];
    for b in edits {
        let Some(i) = joints.iter().position(|j| j.name == b.name) else {
            return Err(Reply::error(
                400,
                format!("joint {:?} is not in {file}", b.name),
            ));
        };
        if std::mem::replace(&mut seen[i], true) {
            return Err(Reply::error(
                400,
                format!("joint {:?} is given twice", b.name),
            ));
        }
        if let Err(msg) = check_box(b) {
            return Err(Reply::error(400, format!("joint {:?}: {msg}", b.name)));
        }
        let bb = &mut joints[i].bbox;
        (bb.cx, bb.cy) = (b.x as f32, b.y as f32);
        (bb.w, bb.h) = (b.w as u32, b.h as u32);
        bb.angle_rad = crate::geom::wrap_angle(b.angle as f32);
    }
    match seen.iter().position(|s| !s) {
        Some(i) => Err(Reply::error(
            400,
            format!("joint {:?} is missing; send every joint", joints[i].name),
        )),
        None => Ok(()),
    }
}

/// Why a rectangle from the page cannot be written, if it cannot.
fn check_box(b: &BoxEdit) -> std::result::Result<(), String> {
    for (k, v) in [("x", b.x), ("y", b.y), ("angle", b.angle)] {
        if !v.is_finite() {
            return Err(format!("`{k}` must be a finite number"));
        }
    }
    for (k, v) in [("w", b.w), ("h", b.h)] {
        if v.fract() != 0.0 || v < MIN_BOX_PX as f64 || v > 1e6 {
            return Err(format!(
                "`{k}` must be a whole number of px, at least {MIN_BOX_PX}, got {v}"
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_must_be_whole_and_finite() {
        let b = |w: f64, x: f64| BoxEdit {
            name: "a".into(),
            x,
            y: 1.0,
            w,
            h: 9.0,
            angle: 0.0,
        };
        assert!(check_box(&b(9.0, 3.0)).is_ok());
        assert!(check_box(&b(9.5, 3.0)).is_err());
        assert!(check_box(&b(4.0, 3.0)).is_err());
        assert!(check_box(&b(9.0, f64::NAN)).is_err());
    }
}
