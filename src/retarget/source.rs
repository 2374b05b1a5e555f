//! The source motion (docs/method.md §4): read from the tracks, smoothed, measured (its bones'
//! median lengths, its size), and the target's rest skeleton placed beside it.

use super::mapping::Mapping;
use super::{dist, filter, Motion, Placement, Smooth, P64};
use crate::character::Scale;
use crate::error::{Error, Result};
use crate::geom::Point;
use crate::run::TrackRow;
use crate::skeleton::Skeleton;
use std::path::Path;

/// Sum of the bone lengths of `joints` (px): the size of a skeleton.
pub fn skeleton_size(skeleton: &Skeleton, joints: &[P64]) -> f64 {
    skeleton
        .bones()
        .iter()
        .map(|&(p, c)| dist(joints[p], joints[c]))
        .sum()
}

/// `[target bone]`: the median over the frames of `joints` of the length (px) of the bone's
/// source bone; `None` for a bone nothing drives or whose length is not followed
/// ([`Mapping::keep_length`]).
pub fn reference_lengths(joints: &[Vec<P64>], mapping: &Mapping) -> Vec<Option<f64>> {
    mapping
        .bone
        .iter()
        .zip(&mapping.keep_length)
        .map(|(m, &keep)| {
            m.as_ref().filter(|_| !keep).map(|(a, b)| {
                let l: Vec<f64> = joints.iter().map(|f| dist(a.at(f), b.at(f))).collect();
                median(&l)
            })
        })
        .collect()
}

/// The median of `v` (the mean of the two middle values for an even count; 0 when empty).
pub(super) fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => 0.0,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// Sums over the driven bones of the target's lengths in `target_joints` and of their source
/// bones' `reference` lengths ([`reference_lengths`]), px: the sizes [`place`] and
/// [`super::retarget`] compare.
pub fn driven_sizes(
    target: &Skeleton,
    target_joints: &[P64],
    reference: &[Option<f64>],
) -> (f64, f64) {
    target
        .bones()
        .iter()
        .zip(reference)
        .filter_map(|(&(p, c), r)| r.map(|r| (p, c, r)))
        .fold((0.0, 0.0), |(t, s), (p, c, r)| {
            (t + dist(target_joints[p], target_joints[c]), s + r)
        })
}

/// Places the target's rest skeleton (`rest`, image px) in the output frame next to the source's
/// first frame (`source_rest`, px): scaled by `scale` ([`Scale::Fit`]: so that its driven bones
/// are, in sum, as long as their source bones' `reference` lengths), its first root at the x of
/// the source point it follows, and its lowest joint at the height of the source's lowest joint,
/// so both stand on the same floor.
pub fn place(
    target: &Skeleton,
    rest: &[Point],
    scale: Scale,
    mapping: &Mapping,
    source_rest: &[P64],
    reference: &[Option<f64>],
) -> Placement {
    let rest64: Vec<P64> = rest.iter().map(|p| [p.x as f64, p.y as f64]).collect();
    let k = match scale {
        Scale::Factor(f) => f as f64,
        Scale::Fit => {
            let (t, s) = driven_sizes(target, &rest64, reference);
            if t > 1e-9 && s > 1e-9 {
                s / t
            } else {
                1.0
            }
        }
    };
    let root = target.topo_order().first().copied().unwrap_or(0);
    let lowest = |ps: &mut dyn Iterator<Item = f64>| ps.fold(f64::NEG_INFINITY, f64::max);
    let follows = mapping.root[root]
        .as_ref()
        .map_or(source_rest[0], |s| s.at(source_rest));
    let ox = follows[0] - k * rest64[root][0];
    let oy = lowest(&mut source_rest.iter().map(|p| p[1]))
        - k * lowest(&mut rest64.iter().map(|p| p[1]));
    Placement {
        scale: k,
        offset: [ox, oy],
    }
}

/// Builds the source motion from `tracks.csv` rows (from `path`, for messages): every frame
/// must list every joint of `skeleton` once, frames consecutive.
pub fn motion_from_tracks(rows: &[TrackRow], skeleton: &Skeleton, path: &Path) -> Result<Motion> {
    let err = |msg: String| Error::RunFolder {
        path: path.to_owned(),
        msg,
    };
    let n = skeleton.len();
    let mut frames = Vec::new();
    let mut joints: Vec<Vec<P64>> = Vec::new();
    let mut seen: Vec<bool> = Vec::new();
    for (i, r) in rows.iter().enumerate() {
        if frames.last() != Some(&r.frame) {
            if let Some(&last) = frames.last() {
                if seen.iter().any(|s| !s) {
                    return Err(err(format!("frame {last} does not list every joint")));
                }
                if r.frame != last + 1 {
                    return Err(err(format!(
                        "line {}: frame {} follows frame {last}; frames must be consecutive",
                        i + 2,
                        r.frame
                    )));
                }
            }
            frames.push(r.frame);
            joints.push(vec![[0.0; 2]; n]);
            seen = vec![false; n];
        }
        let j = skeleton.index_of(&r.joint).ok_or_else(|| {
            err(format!(
                "line {}: joint {:?} is not in the run's seed file",
                i + 2,
                r.joint
            ))
        })?;
        if seen[j] || !(r.x.is_finite() && r.y.is_finite()) {
            return Err(err(format!(
                "line {}: joint {:?} listed twice in frame {} or not a finite position",
                i + 2,
                r.joint,
                r.frame
            )));
        }
        seen[j] = true;
        // Cannot fail: a frame was pushed before its first row.
        joints.last_mut().expect("pushed above")[j] = [r.x as f64, r.y as f64];
    }
    if frames.is_empty() {
        return Err(err("no tracked frames".into()));
    }
    if seen.iter().any(|s| !s) {
        return Err(err(format!(
            "frame {} does not list every joint",
            // Cannot fail: checked non-empty just above.
            frames.last().expect("non-empty")
        )));
    }
    Ok(Motion { frames, joints })
}

/// `joints` smoothed as `smooth` says (each joint's x and y over the frames), or a copy.
pub(super) fn smooth_motion(joints: &[Vec<P64>], smooth: Option<Smooth>) -> Vec<Vec<P64>> {
    let Some(s) = smooth else {
        return joints.to_vec();
    };
    let mut out = joints.to_vec();
    let n = joints.first().map_or(0, Vec::len);
    for j in 0..n {
        for axis in 0..2 {
            let x: Vec<f64> = joints.iter().map(|f| f[j][axis]).collect();
            let y = match s {
                Smooth::Median { window_frames } => filter::median(&x, window_frames),
                Smooth::Gaussian { sigma_frames } => filter::gaussian(&x, sigma_frames),
            };
            for (f, v) in out.iter_mut().zip(y) {
                f[j][axis] = v;
            }
        }
    }
    out
}
