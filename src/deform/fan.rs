//! Joint fans (docs/method.md §5.5): the vertices of a hinge's joint triangles (§5.4: elbow,
//! knee, neck) placed by turning them about the joint, the turn blended by their angle around it.
//!
//! Around the joint `J` the parent bone points back to `P`, the child on to `C`. A vertex at
//! rest angle `α` and distance `r` from `J` keeps `r` (times its bones' scale) and takes the
//! angle `g(α)`: within `β` of either bone's direction it turns with that bone (rigidly), and on
//! each of the two arcs between them the angle is stretched or squeezed linearly. `g` is
//! increasing around the whole turn whatever the bend (each arc keeps a positive width, `β` being
//! at most a quarter of the narrower arc, at rest and now), so the map is one to one and keeps
//! orientation: a joint area can be squeezed on the inside of a bend but never turned over.

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
        r: d.norm(),
        t: (angle(d) - a_p).rem_euclid(TAU),
    }
}

/// Places the fan vertices `fans` into `out` for the joints at `now`, rest joints `rest`, each
/// bone's length scale `scale`.
pub fn place(fans: &[FanVertex], rest: &[Point], now: &[Point], scale: &[f32], out: &mut [Point]) {
    for f in fans {
        let (_, w0) = arc(rest, f.joints);
        let (a_p, w1) = arc(now, f.joints);
        let b = RIGID_HALF_WIDTH
            .min(w0 / 4.0)
            .min((TAU - w0) / 4.0)
            .min(w1 / 4.0)
            .min((TAU - w1) / 4.0);
        // Knots of g (angles from the parent's direction): rest → now, over [−β, 2π − β).
        let knots = [
            (-b, -b, 0.0),
            (b, b, 0.0),
            (w0 - b, w1 - b, 1.0),
            (w0 + b, w1 + b, 1.0),
            (TAU - b, TAU - b, 0.0),
        ];
        let t = (f.t + b).rem_euclid(TAU) - b;
        let k = (0..4).find(|&k| t <= knots[k + 1].0).unwrap_or(3);
        let (x0, y0, s0) = knots[k];
        let (x1, y1, s1) = knots[k + 1];
        let u = if x1 > x0 {
            ((t - x0) / (x1 - x0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let g = y0 + u * (y1 - y0);
        // The radius follows the bones' scales, blended as the angle is.
        let mix = s0 + u * (s1 - s0);
        let s = scale[f.bones[0] as usize] * (1.0 - mix) + scale[f.bones[1] as usize] * mix;
        let a = a_p + g;
        out[f.vertex as usize] = now[f.joints[1]] + Vector::new(a.cos(), a.sin()) * (f.r * s);
    }
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
        let mut out = vec![Point::origin(); 16];
        place(&fans, &rest, &rest, &[1.0, 1.0], &mut out);
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
            place(&fans, &rest, &now, &[1.0, 1.0], &mut out);
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
}
