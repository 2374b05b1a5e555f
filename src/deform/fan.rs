//! Joint fans (docs/method.md §5.5): the vertices of a hinge's two bones near its joint (elbow,
//! knee, neck) turned further about the joint, the turn blended by their angle around it.
//!
//! Around the joint `J` the parent bone points back to `P`, the child on to `C`. On a joined
//! mesh a vertex at rest angle `t` from the parent's direction takes the angle `g(t)`: within `β`
//! of either bone's direction it turns with that bone (rigidly), and on each of the two arcs
//! between them the angle is stretched or squeezed linearly. `g` is increasing around the whole
//! turn whatever the bend (each arc keeps a positive width, `β` being at most a quarter of the
//! narrower arc, at rest and now). Stage one turned the vertex with its own bone (`ρ(t)`); the
//! fan turns that placement about the joint by `λ(r) (g(t) − ρ(t))`, `λ` 1 up to `r₀` (the
//! farthest joint-triangle vertex of the hinge) and falling linearly to 0 at `r₁` (half the
//! bone's length, at least `r₀` plus a mesh spacing). With the bones' lengths kept, a vertex
//! keeps its distance from the joint and takes the angle `λ g + (1 − λ) ρ`, which grows with `t`
//! on every circle about the joint (slope `λ g' + 1 − λ > 0`): the map is one to one and keeps
//! orientation, so a joint area can be squeezed on the inside of a bend but never turned over.

use crate::geom::{Point, Vector};
use std::f32::consts::TAU;

/// Half-width (radians) of the sector around each bone's direction that turns rigidly with it.
pub const RIGID_HALF_WIDTH: f32 = 0.5;

/// A joint-area vertex in its hinge's polar frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FanVertex {
    pub vertex: u32,
    /// Joints: the parent bone's start, the hinge, the child bone's end.
    pub joints: [usize; 3],
    /// Bones (indices into the rig's bones): parent, child.
    pub bones: [u16; 2],
    /// Which of the two is the vertex's own bone (0 parent, 1 child).
    pub own: u8,
    /// The fan holds fully up to `r0` px from the joint and hands over to the own bone by `r1`.
    pub r0: f32,
    pub r1: f32,
    /// Distance from the joint at rest (px) and the angle from the parent's direction (radians,
    /// 0 to 2π, the sense of increasing screen angle).
    pub r: f32,
    pub t: f32,
}

fn angle(v: Vector) -> f32 {
    v.y.atan2(v.x)
}

/// The width (0 to 2π) of the arc from the parent's direction to the child's, for joints
/// `[P, J, C]` at `p`.
fn arc(p: &[Point], j: [usize; 3]) -> (f32, f32) {
    let a_p = angle(p[j[0]] - p[j[1]]);
    let a_c = angle(p[j[2]] - p[j[1]]);
    (a_p, (a_c - a_p).rem_euclid(TAU))
}

/// The fan vertex of `vertex` at rest position `x` (px), on hinge `joints` with bones `bones`,
/// the rest joints at `rest`.
pub fn fan_vertex(
    vertex: u32,
    x: Point,
    joints: [usize; 3],
    bones: [u16; 2],
    rest: &[Point],
) -> FanVertex {
    let (a_p, _) = arc(rest, joints);
    let d = x - rest[joints[1]];
    FanVertex {
        vertex,
        joints,
        bones,
        own: 0,
        r: d.norm(),
        t: (angle(d) - a_p).rem_euclid(TAU),
        r0: f32::INFINITY,
        r1: f32::INFINITY,
    }
}

/// The fan vertices of a split mesh (triangles `triangles`, vertex rest positions `rest` and
/// bones `skin`, mesh spacing `spacing`, px): for each hinge (a child bone starting where its
/// parent ends, the two sharing a triangle), the vertices of its two bones within `r₁` of the
/// joint; a vertex near two hinges takes the one whose joint is nearer.
pub fn fans(
    triangles: &[[u32; 3]],
    rest: &[Point],
    skin: &[u16],
    bones: &[(usize, usize)],
    joints: &[Point],
    spacing: f32,
) -> Vec<FanVertex> {
    // Each hinge, with the farthest vertex of its joint triangles from the joint (r₀).
    let mut hinges: std::collections::BTreeMap<([usize; 3], [u16; 2]), f32> = Default::default();
    for t in triangles {
        let b = t.map(|v| skin[v as usize]);
        for &p in &b {
            for &c in &b {
                let (pb, cb) = (bones[p as usize], bones[c as usize]);
                if p == c || cb.0 != pb.1 {
                    continue;
                }
                let r0 = hinges.entry(([pb.0, pb.1, cb.1], [p, c])).or_insert(0.0);
                for &v in t {
                    *r0 = r0.max((rest[v as usize] - joints[pb.1]).norm());
                }
            }
        }
    }
    let mut out: Vec<FanVertex> = Vec::new();
    for (v, &x) in rest.iter().enumerate() {
        let mut best: Option<FanVertex> = None;
        for (&(j, b), &r0) in &hinges {
            let Some(own) = b.iter().position(|&o| o == skin[v]) else {
                continue;
            };
            let len = (joints[j[own + 1]] - joints[j[own]]).norm();
            let mut f = fan_vertex(v as u32, x, j, b, joints);
            f.own = own as u8;
            f.r0 = r0;
            f.r1 = (NEAR_SHARE * len).max(r0 + spacing);
            if f.r < f.r1 && best.map_or(true, |g| f.r < g.r) {
                best = Some(f);
            }
        }
        out.extend(best);
    }
    out
}

/// Share of a hinged bone's length, from the joint, over which the fan hands over to the bone.
pub const NEAR_SHARE: f32 = 0.5;

/// Places the fan vertices `fans` into `out`, which holds stage one's placement, for the joints
/// at `now` and rest joints `rest`: stage one's placement turned about the joint by `λ (g − ρ)`.
/// With the bone's length kept that is the map above; a stretched bone's needles (`s` along,
/// `1/s` across, docs/method.md eq. 22) keep their area and are turned as they are.
pub fn place(fans: &[FanVertex], rest: &[Point], now: &[Point], out: &mut [Point]) {
    for f in fans {
        let (_, w0) = arc(rest, f.joints);
        let (_, w1) = arc(now, f.joints);
        let b = RIGID_HALF_WIDTH
            .min(w0 / 4.0)
            .min((TAU - w0) / 4.0)
            .min(w1 / 4.0)
            .min((TAU - w1) / 4.0);
        // Knots of g (angles from the parent's direction): rest → now, over [−β, 2π − β).
        let knots = [
            (-b, -b),
            (b, b),
            (w0 - b, w1 - b),
            (w0 + b, w1 + b),
            (TAU - b, TAU - b),
        ];
        let t = (f.t + b).rem_euclid(TAU) - b;
        let k = (0..4).find(|&k| t <= knots[k + 1].0).unwrap_or(3);
        let (x0, y0) = knots[k];
        let (x1, y1) = knots[k + 1];
        let u = if x1 > x0 {
            ((t - x0) / (x1 - x0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        // The own bone's rigid turn (on the same branch as g: both from t in [−β, 2π − β)), the
        // fan's, and λ(r) between them.
        let g_own = t + f.own as f32 * (w1 - w0);
        let g_fan = y0 + u * (y1 - y0);
        let l = if f.r <= f.r0 {
            1.0
        } else {
            ((f.r1 - f.r) / (f.r1 - f.r0)).clamp(0.0, 1.0)
        };
        // Stage one placed the vertex by its own bone (turned by g_own, its needle stretched
        // along and squeezed across, which keeps area): turned on about the joint by what the
        // fan adds, λ (g − g_own).
        let j = now[f.joints[1]];
        let (sn, cs) = (l * (g_fan - g_own)).sin_cos();
        let d = out[f.vertex as usize] - j;
        out[f.vertex as usize] = j + Vector::new(cs * d.x - sn * d.y, sn * d.x + cs * d.y);
    }
}

/// The narrowest angle (radians) a hinge's bend leaves on either side between its two bones:
/// a bend past it would squeeze the joint area's triangles on the inside to slivers that a
/// straight-edged mesh turns over (docs/method.md §5.5). A human elbow or knee closes to about
/// 30°.
pub const MIN_ARC: f32 = 0.8;

/// A hinge: joints `[P, J, C]` and every joint of the child's subtree (`C` and below).
#[derive(Debug, Clone, PartialEq)]
pub struct Hinge {
    pub joints: [usize; 3],
    pub subtree: Vec<usize>,
}

/// The hinges of fan vertices `fans`, root first (by the depth of their joint in `skeleton`).
pub fn hinges(
    fans: &[FanVertex],
    bones: &[(usize, usize)],
    skeleton: &crate::skeleton::Skeleton,
) -> Vec<Hinge> {
    let set: std::collections::BTreeSet<[usize; 3]> = fans.iter().map(|f| f.joints).collect();
    let mut out: Vec<Hinge> = set
        .into_iter()
        .map(|j| {
            let mut subtree = vec![j[2]];
            let mut k = 0;
            while k < subtree.len() {
                let p = subtree[k];
                subtree.extend(bones.iter().filter(|b| b.0 == p).map(|b| b.1));
                k += 1;
            }
            Hinge { joints: j, subtree }
        })
        .collect();
    out.sort_by_key(|h| (skeleton.depth(h.joints[1]), h.joints));
    out
}

/// `joints` with every hinge's bend held to leave at least [`MIN_ARC`] on either side: the
/// child's subtree turned about the joint by what is missing, root first.
pub fn limit_bends(hinges: &[Hinge], joints: &[Point]) -> Vec<Point> {
    let mut out = joints.to_vec();
    for h in hinges {
        let (_, w) = arc(&out, h.joints);
        let turn = if w < MIN_ARC {
            MIN_ARC - w
        } else if TAU - w < MIN_ARC {
            (TAU - w) - MIN_ARC
        } else {
            continue;
        };
        let j = out[h.joints[1]];
        let (s, c) = turn.sin_cos();
        for &k in &h.subtree {
            let d = out[k] - j;
            out[k] = j + Vector::new(c * d.x - s * d.y, s * d.x + c * d.y);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(a: Point, b: Point, c: Point) -> f32 {
        (b - a).perp(&(c - a))
    }

    /// A straight limb bent at its middle joint by every angle short of folding back: a ring of
    /// vertices around the joint keeps its triangles' orientation, and the vertices in the
    /// bones' sectors turn rigidly with them.
    #[test]
    fn a_fan_never_turns_a_triangle_over_and_keeps_the_bones_sectors_rigid() {
        let rest = [
            Point::new(0.0, 0.0),
            Point::new(0.0, 20.0),
            Point::new(0.0, 40.0),
        ];
        let j = [0, 1, 2];
        let ring: Vec<Point> = (0..16)
            .map(|k| {
                let a = k as f32 * TAU / 16.0;
                rest[1] + Vector::new(a.cos(), a.sin()) * 6.0
            })
            .collect();
        let fans: Vec<FanVertex> = ring
            .iter()
            .enumerate()
            .map(|(k, &x)| fan_vertex(k as u32, x, j, [0, 1], &rest))
            .collect();
        // Stage one's placement: every ring vertex is the parent's (fan_vertex's default), and
        // the parent does not move.
        let mut out = ring.clone();
        place(&fans, &rest, &rest, &mut out);
        for (a, b) in out.iter().zip(&ring) {
            assert!((a - b).norm() < 1e-4, "rest not kept: {a:?} {b:?}");
        }
        for deg in (-175..=175).step_by(5) {
            let a = (deg as f32).to_radians();
            let now = [
                rest[0],
                rest[1],
                rest[1] + Vector::new(-a.sin(), a.cos()) * 20.0,
            ];
            out.copy_from_slice(&ring);
            place(&fans, &rest, &now, &mut out);
            for k in 0..16 {
                // Triangles of the joint and two neighbours on the ring: all as at rest (the
                // ring is listed in increasing angle, so each has the rest's sign).
                let s0 = area(rest[1], ring[k], ring[(k + 1) % 16]);
                let s1 = area(now[1], out[k], out[(k + 1) % 16]);
                assert!(s0 * s1 > 0.0, "bent {deg}°: triangle {k} turned over");
            }
            // The vertex straight down the child's way (angle 90° at rest, k = 4) turned with it.
            let want = now[1] + (now[2] - now[1]).normalize() * 6.0;
            assert!((out[4] - want).norm() < 1e-3, "bent {deg}°: {:?}", out[4]);
            // And the one up the parent's way (k = 12) stayed.
            assert!((out[12] - ring[12]).norm() < 1e-3, "bent {deg}°");
        }
    }

    /// An arm folded back to 0.2 rad at the elbow is opened to MIN_ARC, the hand turning with
    /// the forearm and every bone keeping its length; a bend of 1 rad is left alone.
    #[test]
    fn a_bend_sharper_than_the_limit_is_opened_and_a_milder_one_kept() {
        let h = [Hinge {
            joints: [0, 1, 2],
            subtree: vec![2, 3],
        }];
        let at = |inner: f32| {
            let d = Vector::new(inner.sin(), -inner.cos());
            [
                Point::new(0.0, 0.0),
                Point::new(0.0, 30.0),
                Point::new(0.0, 30.0) + d * 25.0,
                Point::new(0.0, 30.0) + d * 35.0,
            ]
        };
        let folded = at(0.2);
        let out = limit_bends(&h, &folded);
        let (_, w) = arc(&out, [0, 1, 2]);
        let inner = w.min(TAU - w);
        assert!((inner - MIN_ARC).abs() < 1e-4, "inner angle {inner}");
        assert_eq!(out[..2], folded[..2]);
        for (a, b) in [(1, 2), (2, 3)] {
            let (l0, l1) = ((folded[b] - folded[a]).norm(), (out[b] - out[a]).norm());
            assert!((l0 - l1).abs() < 1e-3, "bone {a}-{b}: {l0} -> {l1}");
        }
        let mild = at(1.0);
        assert_eq!(limit_bends(&h, &mild), mild.to_vec());
    }
}
