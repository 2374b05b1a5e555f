//! Foot contacts and planted feet (docs/method.md §4.6): when a foot of the retargeted character
//! is slow and near the floor it is on the ground; during such a contact a two-bone IK on its
//! leg (hip, knee, foot) holds it where it landed, blended in over the frames before the contact
//! and out over the frames after.
//!
//! The feet are the target joints recognised as ankles (or feet, [`super::mapping::recognise`])
//! that have a parent and a grandparent (the knee and the hip, or whatever the character calls
//! them). Speeds and heights are in output px and measured against the leg's rest length, so the
//! thresholds hold at any size.

use super::mapping::{recognise, Part};
use super::{dist, P64};
use crate::skeleton::Skeleton;

/// A foot on the ground moves less than this fraction of its leg's length a frame.
pub const SPEED_LEG_FRACTION: f64 = 0.025;
/// ... and is at most this fraction of its leg's length above the floor.
pub const HEIGHT_LEG_FRACTION: f64 = 0.08;
/// The floor under a frame is the lowest any foot gets within this many frames either side, so
/// a subject stepping towards or away from the camera (the floor moving in the picture) is
/// followed.
const FLOOR_REACH_FRAMES: usize = 25;
/// Contacts or gaps shorter than this many frames are noise: gaps are closed, then short
/// contacts dropped.
const SHORTEST_FRAMES: usize = 3;
/// Frames over which the IK is blended in before a contact and out after it.
pub const BLEND_FRAMES: usize = 3;

/// A foot of the target and its leg.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Leg {
    pub hip: usize,
    pub knee: usize,
    pub foot: usize,
}

/// The legs of `target`: every joint recognised as an ankle or foot with a parent and a
/// grandparent, in joint order.
pub fn legs(target: &Skeleton) -> Vec<Leg> {
    (0..target.len())
        .filter(|&j| matches!(recognise(&target.names[j]), Some(Part::Ankle(_))))
        .filter_map(|foot| {
            let knee = target.parent(foot)?;
            let hip = target.parent(knee)?;
            Some(Leg { hip, knee, foot })
        })
        .collect()
}

/// `[leg][t]`: whether the leg's foot is on the ground on frame `t` of `joints` (output px).
pub fn detect(joints: &[Vec<P64>], legs: &[Leg], rest: &[P64]) -> Vec<Vec<bool>> {
    let frames = joints.len();
    if frames == 0 {
        return vec![Vec::new(); legs.len()];
    }
    // The lowest foot (largest y: image y points down) on each frame, then over the reach.
    let lowest: Vec<f64> = joints
        .iter()
        .map(|f| {
            legs.iter()
                .map(|l| f[l.foot][1])
                .fold(f64::NEG_INFINITY, f64::max)
        })
        .collect();
    let floor: Vec<f64> = (0..frames)
        .map(|t| {
            let lo = t.saturating_sub(FLOOR_REACH_FRAMES);
            let hi = (t + FLOOR_REACH_FRAMES).min(frames - 1);
            lowest[lo..=hi]
                .iter()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max)
        })
        .collect();
    legs.iter()
        .map(|l| {
            let leg_len = dist(rest[l.hip], rest[l.knee]) + dist(rest[l.knee], rest[l.foot]);
            let (vmax, hmax) = (SPEED_LEG_FRACTION * leg_len, HEIGHT_LEG_FRACTION * leg_len);
            let on: Vec<bool> = (0..frames)
                .map(|t| {
                    let (a, b) = (t.saturating_sub(1), (t + 1).min(frames - 1));
                    let speed = dist(joints[a][l.foot], joints[b][l.foot]) / (b - a).max(1) as f64;
                    speed <= vmax && floor[t] - joints[t][l.foot][1] <= hmax
                })
                .collect();
            tidy(on)
        })
        .collect()
}

/// Closes gaps shorter than [`SHORTEST_FRAMES`] between contacts, then drops contacts shorter
/// than that.
fn tidy(mut on: Vec<bool>) -> Vec<bool> {
    for (value, _) in [(false, ()), (true, ())] {
        let mut t = 0;
        while t < on.len() {
            if on[t] != value {
                t += 1;
                continue;
            }
            let start = t;
            while t < on.len() && on[t] == value {
                t += 1;
            }
            // A gap (false run) only between two contacts; a contact anywhere.
            let inner = !value && start > 0 && t < on.len();
            if t - start < SHORTEST_FRAMES && (value || inner) {
                on[start..t].iter_mut().for_each(|v| *v = !value);
            }
        }
    }
    on
}

/// Holds each foot still during its contacts (`contact[leg][t]`, from [`detect`]) by a two-bone
/// IK on its leg, blended in over [`BLEND_FRAMES`] before the contact and out after it. The foot
/// is held at the median of its positions over the contact. The knee bends to the side it bent
/// to before; the hip stays; joints below the foot move with it, others below the knee with the
/// knee. A foot out of reach (the leg would need to stretch) gets as close as the leg allows.
pub fn plant(joints: &mut [Vec<P64>], target: &Skeleton, legs: &[Leg], contact: &[Vec<bool>]) {
    let frames = joints.len();
    for (leg, on) in legs.iter().zip(contact) {
        // (weight, goal) per frame.
        let mut goal: Vec<Option<(f64, P64)>> = vec![None; frames];
        let mut t = 0;
        while t < frames {
            if !on[t] {
                t += 1;
                continue;
            }
            let start = t;
            while t < frames && on[t] {
                t += 1;
            }
            let at = |a: usize| {
                let mut v: Vec<f64> = (start..t).map(|k| joints[k][leg.foot][a]).collect();
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            };
            let p = [at(0), at(1)];
            for k in start..t {
                goal[k] = Some((1.0, p));
            }
            for d in 1..=BLEND_FRAMES {
                let w = smoothstep(1.0 - d as f64 / (BLEND_FRAMES + 1) as f64);
                for k in [start.checked_sub(d), Some(t - 1 + d)]
                    .into_iter()
                    .flatten()
                {
                    if k < frames && goal[k].is_none_or(|(g, _)| g < w) {
                        goal[k] = Some((w, p));
                    }
                }
            }
        }
        let below_foot = target.subtree(leg.foot);
        let below_knee = target.subtree(leg.knee);
        for (f, g) in joints.iter_mut().zip(&goal) {
            let Some((w, p)) = *g else { continue };
            let (h, k, a) = (f[leg.hip], f[leg.knee], f[leg.foot]);
            let want = [a[0] + w * (p[0] - a[0]), a[1] + w * (p[1] - a[1])];
            let (k2, a2) = two_bone(h, k, a, want);
            let (dk, da) = ([k2[0] - k[0], k2[1] - k[1]], [a2[0] - a[0], a2[1] - a[1]]);
            for &j in &below_knee {
                let d = if below_foot.contains(&j) { da } else { dk };
                f[j] = [f[j][0] + d[0], f[j][1] + d[1]];
            }
        }
    }
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// Two-bone IK: the knee and foot of the chain `hip → knee → foot` (bone lengths as given)
/// moved so the foot reaches `goal`, or as near as the chain's lengths allow, the knee on the
/// side of the line hip → foot it was on.
pub fn two_bone(hip: P64, knee: P64, foot: P64, goal: P64) -> (P64, P64) {
    let (l1, l2) = (dist(hip, knee), dist(knee, foot));
    let to = [goal[0] - hip[0], goal[1] - hip[1]];
    let d_goal = to[0].hypot(to[1]);
    if l1 < 1e-9 || l2 < 1e-9 || d_goal < 1e-9 {
        return (knee, goal);
    }
    let d = d_goal.clamp((l1 - l2).abs() + 1e-9, l1 + l2 - 1e-9);
    let u = [to[0] / d_goal, to[1] / d_goal];
    // Along u to the knee's foot point, then sideways.
    let along = (l1 * l1 - l2 * l2 + d * d) / (2.0 * d);
    let side = (l1 * l1 - along * along).max(0.0).sqrt();
    let cross = (knee[0] - hip[0]) * (foot[1] - hip[1]) - (knee[1] - hip[1]) * (foot[0] - hip[0]);
    // The knee's side of hip → foot: the sign of the cross product (foot − hip) × (knee − hip).
    let s = if cross > 0.0 { -1.0 } else { 1.0 };
    let n = [-u[1] * s, u[0] * s];
    let k = [
        hip[0] + u[0] * along + n[0] * side,
        hip[1] + u[1] * along + n[1] * side,
    ];
    let a = [hip[0] + u[0] * d, hip[1] + u[1] * d];
    (k, a)
}

/// `contacts.csv` text: `frame,joint,contact`, one row per frame per foot (in joint order),
/// contact 0 or 1.
pub fn contacts_csv(
    frames: &[u64],
    names: &[String],
    legs: &[Leg],
    contact: &[Vec<bool>],
) -> String {
    let mut s = String::from("frame,joint,contact\n");
    for (t, f) in frames.iter().enumerate() {
        for (leg, on) in legs.iter().zip(contact) {
            s.push_str(&format!("{f},{},{}\n", names[leg.foot], u8::from(on[t])));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_bone_reaches_and_keeps_the_knee_side() {
        let (h, k, a) = ([0.0, 0.0], [10.0, 40.0], [0.0, 80.0]);
        let (k2, a2) = two_bone(h, k, a, [5.0, 70.0]);
        assert!(dist(a2, [5.0, 70.0]) < 1e-6);
        assert!((dist(h, k2) - dist(h, k)).abs() < 1e-6);
        assert!((dist(k2, a2) - dist(k, a)).abs() < 1e-6);
        // The knee stays in front (+x side of the hip → foot line).
        assert!(k2[0] > 2.5, "{k2:?}");
        // Out of reach: straight towards the goal.
        let (_, a3) = two_bone(h, k, a, [0.0, 200.0]);
        assert!((a3[1] - (dist(h, k) + dist(k, a))).abs() < 1e-6, "{a3:?}");
    }

    #[test]
    fn tidy_closes_gaps_and_drops_flickers() {
        let v = |s: &str| s.chars().map(|c| c == '1').collect::<Vec<_>>();
        assert_eq!(tidy(v("0011110111100100")), v("0011111111111100"));
        assert_eq!(tidy(v("0001000110000")), v("0000000000000"));
        assert_eq!(tidy(v("1100011110")), v("0000011110"));
    }
}
