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
//! [`files`] reads and writes `retarget/pose.csv`, `bones.csv` and `retarget.toml`.

pub mod cleanup;
pub mod contacts;
pub mod files;
pub mod filter;
pub mod mapping;

use crate::character::Scale;
use crate::error::{Error, Result};
use crate::geom::Point;
use crate::run::TrackRow;
use crate::skeleton::Skeleton;
use mapping::Mapping;
use std::path::Path;

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

/// The cartoon animation filter's settings (docs/method.md §4.4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cartoon {
    /// A: 0 is off; 1–3 is visible.
    pub strength: f64,
    /// σ of the Gaussian, frames.
    pub sigma_frames: f64,
}

/// Default σ of the cartoon filter, frames.
pub const DEFAULT_CARTOON_SIGMA: f64 = 4.0;

/// Smoothing of the source joint tracks before retargeting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Smooth {
    /// Running median over this many frames (odd).
    Median { window_frames: usize },
    /// Gaussian with this standard deviation (frames).
    Gaussian { sigma_frames: f64 },
}

impl std::fmt::Display for Smooth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Smooth::Median { window_frames } => write!(f, "median:{window_frames}"),
            Smooth::Gaussian { sigma_frames } => write!(f, "gaussian:{sigma_frames}"),
        }
    }
}

impl std::str::FromStr for Smooth {
    type Err = String;
    /// `median:N` (N odd frames, 3 to 99) or `gaussian:S` (S frames, above 0 to 30).
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let bad = || {
            format!("{s:?}: expected median:N (odd N, 3 to 99) or gaussian:S (S frames, 0 to 30)")
        };
        let (kind, v) = s.split_once(':').ok_or_else(bad)?;
        match kind {
            "median" => match v.parse::<usize>() {
                Ok(n) if n % 2 == 1 && (3..=99).contains(&n) => {
                    Ok(Smooth::Median { window_frames: n })
                }
                _ => Err(bad()),
            },
            "gaussian" => match v.parse::<f64>() {
                Ok(g) if g > 0.0 && g <= 30.0 => Ok(Smooth::Gaussian { sigma_frames: g }),
                _ => Err(bad()),
            },
            _ => Err(bad()),
        }
    }
}

/// What `retarget` does on top of docs/method.md eq. 16–17.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RetargetOptions {
    /// The clean-up of the tracks (docs/method.md §4.5), applied by [`crate::app::retarget`]
    /// before [`retarget`]; on by default.
    pub clean: cleanup::Cleanup,
    pub smooth: Option<Smooth>,
    pub cartoon: Option<Cartoon>,
    /// Bones follow their source bones' changes of length (eq. 18: squash and stretch, for
    /// cartoon characters); off by default: every bone keeps the character's length.
    pub stretch: bool,
    /// With `stretch`, keep the character's size when the whole source grows or shrinks (the
    /// subject walking towards or away from the camera): each frame's driven length ratios are
    /// divided by their median over the bones, so only the bones' lengths relative to each
    /// other follow.
    pub keep_size: bool,
    /// Hold each foot still while it is on the ground (docs/method.md §4.6); on by default.
    pub plant_feet: bool,
}

impl Default for RetargetOptions {
    fn default() -> Self {
        RetargetOptions {
            clean: cleanup::Cleanup::default(),
            smooth: None,
            cartoon: None,
            stretch: false,
            keep_size: false,
            plant_feet: true,
        }
    }
}

/// Where the target's rest skeleton goes in the output frame: `out = image · scale + offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Output px per image px.
    pub scale: f64,
    /// px.
    pub offset: P64,
}

impl Placement {
    /// An image position (px) in output px.
    pub fn apply(&self, p: Point) -> P64 {
        [
            p.x as f64 * self.scale + self.offset[0],
            p.y as f64 * self.scale + self.offset[1],
        ]
    }
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
fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => 0.0,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// Sums over the driven bones of the target's lengths in `target_joints` and of their source
/// bones' `reference` lengths ([`reference_lengths`]), px: the sizes [`place`] and [`retarget`]
/// compare.
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

fn smooth_motion(joints: &[Vec<P64>], smooth: Option<Smooth>) -> Vec<Vec<P64>> {
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
