//! Retargeting (docs/method.md §4, eq. 16–19): the captured motion drives a target skeleton,
//! bone by bone: each target bone is driven by a source bone, a pair of source points (joints or
//! midpoints of two; see [`mapping`]), whatever the two skeletons' shapes.
//!
//! For target bone m at frame t with source length `l_mt` and angle `a_mt` (unwrapped) of its
//! source bone:
//! `Δl_mt = l_mt / l_m,t−1`, `Δa_mt = a_mt − a_m,t−1` (16), applied to the target's rest bone:
//! `l'_mt = l'_m,t−1 · Δl_mt`, `a'_mt = a'_m,t−1 + Δa_mt` (17). The products and sums telescope,
//! so they are computed as `a'_mt = a'_m0 + (a_mt − a_m0)` and `l'_mt = L'_m · l_mt / L_m`: the
//! same increments without rounding piling up over a long clip. The lengths are anchored at the
//! source bone's median length over the clip `L_m` (the target's rest length `L'_m` stands for
//! it), not at its first frame's: on real footage the first frame can be an odd one (the dance
//! clip's seed frame has the subject close to the camera, and a knee and an ankle 4 px apart),
//! and a first-frame anchor would carry that oddity through the whole clip. The ratio
//! `l_mt / L_m` is kept within [`MIN_LENGTH_RATIO`]..[`MAX_LENGTH_RATIO`]. A target bone with no
//! source bone keeps its rest length and its rest angle relative to its parent bone. Each root
//! follows its source point's displacement from the first frame, scaled by the ratio of sizes
//! (sums over the driven bones: target rest lengths against source median lengths); the other
//! joints follow by forward kinematics.
//!
//! Lengths follow their source bones only with [`RetargetOptions::stretch`] (squash and stretch
//! for a cartoon); by default every bone keeps the character's rest length and only angles
//! follow, so real footage, where a bone's length in the picture changes with its turn and with
//! the subject's distance to the camera, does not pull the character apart.
//!
//! Before that, the tracks are cleaned ([`cleanup`], by `crate::app::retarget`, docs/method.md
//! §4.5), optionally the source joints are smoothed ([`Smooth`]) and each bone's length and
//! angle signals go through the cartoon filter ([`Cartoon`], docs/method.md §4.4). After the
//! forward kinematics the feet on the ground are found and held still ([`contacts`], §4.6).
//! [`files`] reads and writes `retarget/pose.csv`, `bones.csv` and `retarget.toml`; the options
//! are in `options.rs`, the source motion's reading, measures and placement in `source.rs`.

pub mod cleanup;
pub mod contacts;
pub mod files;
pub mod filter;
pub mod mapping;

mod options;
mod source;

use crate::skeleton::Skeleton;
use mapping::Mapping;
pub use options::{Cartoon, Placement, RetargetOptions, Smooth, DEFAULT_CARTOON_SIGMA};
pub use source::{driven_sizes, motion_from_tracks, place, reference_lengths, skeleton_size};
use source::{median, smooth_motion};

/// Bounds of a driven bone's length relative to its rest length (its source bone's length over
/// the source's median length): beyond them the source bone is a mislabelled or lost joint
/// rather than a pose (on the dance clip a forearm labelled at 3 times its length, a head
/// squashed to a fifth), and the target would show a needle or a disc.
pub const MIN_LENGTH_RATIO: f64 = 1.0 / 3.0;
/// See [`MIN_LENGTH_RATIO`].
pub const MAX_LENGTH_RATIO: f64 = 1.5;

/// A position in f64 px (image space, see [`crate::geom`]).
pub type P64 = [f64; 2];

/// Joint positions over consecutive frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    /// The frame index of each row of `joints` (consecutive).
    pub frames: Vec<u64>,
    /// `[t][joint]`: position (px), joints in their skeleton's order.
    pub joints: Vec<Vec<P64>>,
}

/// A retargeted animation.
#[derive(Debug, Clone, PartialEq)]
pub struct Retargeted {
    pub frames: Vec<u64>,
    /// `[t][target joint]`: position, output px.
    pub joints: Vec<Vec<P64>>,
    /// Target bones `(parent, child)`, in the child's file order.
    pub bones: Vec<(usize, usize)>,
    /// `[t][bone]`: length, px.
    pub length: Vec<Vec<f64>>,
    /// `[t][bone]`: angle, radians clockwise on screen, unwrapped.
    pub angle: Vec<Vec<f64>>,
    /// The target's feet and legs ([`contacts::legs`]).
    pub legs: Vec<contacts::Leg>,
    /// `[leg][t]`: the foot is on the ground ([`contacts::detect`]).
    pub contact: Vec<Vec<bool>>,
}

/// Retargets `motion` (source joints) onto the target skeleton whose rest pose in output px is
/// `rest_out`, each bone driven as `mapping` says ([`mapping::build`]). Implements
/// docs/method.md eq. 16–19 (see the module docs).
pub fn retarget(
    motion: &Motion,
    target: &Skeleton,
    mapping: &Mapping,
    rest_out: &[P64],
    opts: &RetargetOptions,
) -> Retargeted {
    let frames = motion.frames.len();
    let src = smooth_motion(&motion.joints, opts.smooth);
    let bones = target.bones();
    let mut length = vec![vec![0.0; bones.len()]; frames];
    let mut angle = vec![vec![0.0; bones.len()]; frames];
    let bone_of: Vec<Option<usize>> = (0..target.len())
        .map(|j| bones.iter().position(|&(_, c)| c == j))
        .collect();
    // Each frame's size relative to the median sizes (1 unless `keep_size`): the median over
    // the driven bones of their length ratios.
    let reference = reference_lengths(&src, mapping);
    let size: Vec<f64> = (0..frames)
        .map(|t| {
            if !opts.keep_size {
                return 1.0;
            }
            if !opts.stretch {
                return 1.0;
            }
            let ratios: Vec<f64> = mapping
                .bone
                .iter()
                .zip(&reference)
                .filter_map(|(m, r)| {
                    let ((a, b), r) = (m.as_ref()?, (*r)?);
                    (r > 1e-9).then(|| dist(a.at(&src[t]), b.at(&src[t])) / r)
                })
                .collect();
            let g = median(&ratios);
            if g > 1e-9 {
                g
            } else {
                1.0
            }
        })
        .collect();
    // Parents first, so that an undriven bone can follow its parent bone's angle.
    for c in target.topo_order() {
        let Some(b) = bone_of[c] else { continue };
        let p = bones[b].0;
        let rest_len = dist(rest_out[p], rest_out[c]);
        let rest_angle = angle_of(rest_out[p], rest_out[c]);
        match &mapping.bone[b] {
            Some((from, to)) => {
                let (mut l, mut a) = bone_signals(&src, from, to);
                if let Some(f) = opts.cartoon {
                    l = filter::cartoon(&l, f.strength, f.sigma_frames);
                    a = filter::cartoon(&a, f.strength, f.sigma_frames);
                }
                let l_ref = median(&l).max(1e-9);
                for t in 0..frames {
                    let ratio = if mapping.keep_length[b] || !opts.stretch {
                        1.0
                    } else {
                        (l[t] / l_ref / size[t]).clamp(MIN_LENGTH_RATIO, MAX_LENGTH_RATIO)
                    };
                    length[t][b] = rest_len * ratio;
                    angle[t][b] = rest_angle + (a[t] - a[0]);
                }
            }
            None => {
                let parent = bone_of[p];
                let offset = parent.map_or(rest_angle, |f| {
                    rest_angle - angle_of(rest_out[bones[f].0], rest_out[p])
                });
                for t in 0..frames {
                    length[t][b] = rest_len;
                    angle[t][b] = parent.map_or(0.0, |f| angle[t][f]) + offset;
                }
            }
        }
    }
    limit_girdles(target, &bones, rest_out, &mut angle);
    let (target_size, src_size) = driven_sizes(target, rest_out, &reference);
    let ratio = if src_size > 1e-9 {
        target_size / src_size
    } else {
        1.0
    };
    let order = target.topo_order();
    let all = mapping::SourcePoint((0..src.first().map_or(0, Vec::len)).collect());
    let mut joints: Vec<Vec<P64>> = (0..frames)
        .map(|t| {
            let mut pos = vec![[0.0; 2]; target.len()];
            for &j in &order {
                pos[j] = match (target.parent(j), bone_of[j]) {
                    (Some(p), Some(b)) => {
                        let (l, a) = (length[t][b], angle[t][b]);
                        [pos[p][0] + l * a.cos(), pos[p][1] + l * a.sin()]
                    }
                    _ => {
                        let s = mapping.root[j].as_ref().unwrap_or(&all);
                        let (now, first) = (s.at(&src[t]), s.at(&src[0]));
                        [
                            rest_out[j][0] + ratio * (now[0] - first[0]),
                            rest_out[j][1] + ratio * (now[1] - first[1]),
                        ]
                    }
                };
            }
            pos
        })
        .collect();
    let legs = contacts::legs(target);
    let contact = contacts::detect(&joints, &legs, rest_out);
    if opts.plant_feet {
        contacts::plant(&mut joints, target, &legs, &contact);
        // The bones as the joints now lie (a planted leg's bones turned).
        for (t, f) in joints.iter().enumerate() {
            for (b, &(p, c)) in bones.iter().enumerate() {
                length[t][b] = dist(f[p], f[c]);
                if length[t][b] > 1e-9 {
                    angle[t][b] += wrap(angle_of(f[p], f[c]) - angle[t][b]);
                }
            }
        }
    }
    Retargeted {
        frames: motion.frames.clone(),
        joints,
        bones,
        length,
        angle,
        legs,
        contact,
    }
}

/// How far (radians) a girdle bone may turn from its rest angle to the trunk: 25°.
pub const GIRDLE_LIMIT: f64 = 25.0 * std::f64::consts::PI / 180.0;

/// Joint limits of a front-facing picture (docs/method.md §4.7): a *girdle* bone, one ending at
/// a joint recognised as a shoulder or a hip, turns at most [`GIRDLE_LIMIT`] from its rest angle
/// to the trunk (the bone ending where it starts, or at a root the sibling bone ending at a
/// chest, neck or head). When the subject turns her back the tracked shoulders and hips swap
/// sides and their line turns half a turn against the trunk, which a picture drawn from the
/// front cannot show without tearing.
fn limit_girdles(
    target: &Skeleton,
    bones: &[(usize, usize)],
    rest: &[P64],
    angle: &mut [Vec<f64>],
) {
    use mapping::{recognise, Part};
    let trunk_part = |j: usize| {
        matches!(
            recognise(&target.names[j]),
            Some(Part::Chest | Part::Neck | Part::Head)
        )
    };
    for (b, &(p, c)) in bones.iter().enumerate() {
        if !matches!(
            recognise(&target.names[c]),
            Some(Part::Shoulder(_) | Part::Hip(_))
        ) {
            continue;
        }
        let reference = bones.iter().position(|&(_, e)| e == p).or_else(|| {
            bones
                .iter()
                .position(|&(s, e)| s == p && e != c && trunk_part(e))
        });
        let Some(r) = reference else { continue };
        let rest_rel = angle_of(rest[p], rest[c]) - angle_of(rest[bones[r].0], rest[bones[r].1]);
        for a in angle.iter_mut() {
            let d = wrap(a[b] - a[r] - rest_rel);
            a[b] -= d - d.clamp(-GIRDLE_LIMIT, GIRDLE_LIMIT);
        }
    }
}

/// Length (px) and unwrapped angle (radians) of the source bone `from → to` over the frames. A
/// bone of (near) zero length keeps its previous angle.
fn bone_signals(
    src: &[Vec<P64>],
    from: &mapping::SourcePoint,
    to: &mapping::SourcePoint,
) -> (Vec<f64>, Vec<f64>) {
    let mut l = Vec::with_capacity(src.len());
    let mut a: Vec<f64> = Vec::with_capacity(src.len());
    for f in src {
        let (p, c) = (from.at(f), to.at(f));
        let len = dist(p, c);
        let raw = angle_of(p, c);
        let ang = match a.last() {
            None => raw,
            Some(&prev) if len < 1e-9 => prev,
            Some(&prev) => prev + wrap(raw - prev),
        };
        l.push(len);
        a.push(ang);
    }
    (l, a)
}

/// An angle (radians) wrapped into `(-π, π]` (f64 twin of [`crate::geom::wrap_angle`]).
fn wrap(a: f64) -> f64 {
    let r = a.rem_euclid(std::f64::consts::TAU);
    if r > std::f64::consts::PI {
        r - std::f64::consts::TAU
    } else {
        r
    }
}

fn dist(a: P64, b: P64) -> f64 {
    (b[0] - a[0]).hypot(b[1] - a[1])
}

/// Direction of `a → b`, radians clockwise on screen.
fn angle_of(a: P64, b: P64) -> f64 {
    (b[1] - a[1]).atan2(b[0] - a[0])
}

#[cfg(test)]
mod tests;
