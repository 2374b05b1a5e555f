//! The variable-length needle model, stage one of the deformation (docs/method.md
//! §5.5, eq. 22).
//!
//! A vertex is the tip of a needle rooted on its bone: at the fraction `tau` (0 to 1) of the way
//! from the parent joint to the child, the needle points sideways by `perp` px (positive to the
//! bone's right on screen, i.e. along +y for a bone pointing +x). A vertex beyond the bone's ends
//! also has an `along` part: its distance past the end, along the bone. When the bone turns and
//! its length scales by `s`, the needle root slides with the bone and turns with it; with area
//! preservation the needle's sideways part scales by `1/s` and its along part by `s`, so every
//! region of the bone keeps its area (`s · 1/s`). Without it, needles keep their lengths.

use crate::geom::{Point, Vector};

/// A vertex in its bone's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Needle {
    /// Index of the bone.
    pub bone: u16,
    /// Where the needle is rooted: 0 at the parent joint, 1 at the child.
    pub tau: f32,
    /// Distance past the bone's nearer end along the bone (px; negative before the parent).
    pub along: f32,
    /// Sideways length (px), positive to the bone's right on screen.
    pub perp: f32,
}

/// Smallest and largest bone scale the needles follow; beyond, they keep the limit (a bone
/// tracked to nearly zero length would otherwise blow its needles up).
pub const SCALE_LIMITS: (f32, f32) = (0.2, 5.0);

/// Unit direction of `a → b` and its right-hand normal `(-u.y, u.x)`; `fallback` when `a == b`.
fn frame(a: Point, b: Point, fallback: Vector) -> (Vector, Vector, f32) {
    let d = b - a;
    let len = d.norm();
    let u = if len > 1e-6 { d / len } else { fallback };
    (u, Vector::new(-u.y, u.x), len)
}

/// The needles of vertices `rest` (px), attached to bones by `skin`, with rest joints `joints`
/// (px, same scale) and `bones` as `(parent, child)` joint pairs.
pub fn needles(
    rest: &[Point],
    skin: &[u16],
    joints: &[Point],
    bones: &[(usize, usize)],
) -> Vec<Needle> {
    rest.iter()
        .zip(skin)
        .map(|(&v, &b)| {
            let (p, c) = (joints[bones[b as usize].0], joints[bones[b as usize].1]);
            let (u, n, len) = frame(p, c, Vector::x());
            let a = (v - p).dot(&u);
            let tau = if len > 1e-6 {
                (a / len).clamp(0.0, 1.0)
            } else {
                0.0
            };
            Needle {
                bone: b,
                tau,
                along: a - tau * len,
                perp: (v - p).dot(&n),
            }
        })
        .collect()
}

/// Stage one: each vertex follows its bone. `joints` are the deformed joints (px), `rest_len`
/// and `rest_dir` each bone's rest length (px) and unit direction. Writes the vertices into `out`.
pub fn stage_one(
    needles: &[Needle],
    joints: &[Point],
    bones: &[(usize, usize)],
    rest_len: &[f32],
    rest_dir: &[Vector],
    area_preservation: bool,
    out: &mut [Point],
) {
    // Per-bone frames once.
    let frames: Vec<(Point, Vector, Vector, f32, f32)> = bones
        .iter()
        .enumerate()
        .map(|(b, &(pj, cj))| {
            let (p, c) = (joints[pj], joints[cj]);
            let (u, n, len) = frame(p, c, rest_dir[b]);
            let s = if rest_len[b] > 1e-6 {
                (len / rest_len[b]).clamp(SCALE_LIMITS.0, SCALE_LIMITS.1)
            } else {
                1.0
            };
            (p, u, n, len, s)
        })
        .collect();
    for (o, nd) in out.iter_mut().zip(needles) {
        let (p, u, n, len, s) = frames[nd.bone as usize];
        let (along, perp) = if area_preservation {
            (nd.along * s, nd.perp / s)
        } else {
            (nd.along, nd.perp)
        };
        *o = p + u * (nd.tau * len + along) + n * perp;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn needles_round_trip_and_follow_a_turned_stretched_bone() {
        let joints = [Point::new(0.0, 0.0), Point::new(10.0, 0.0)];
        let bones = [(0, 1)];
        let rest = [
            Point::new(5.0, 2.0),   // beside the middle, to the right (+y)
            Point::new(12.0, -1.0), // past the child
        ];
        let nd = needles(&rest, &[0, 0], &joints, &bones);
        assert_eq!(
            nd[0],
            Needle {
                bone: 0,
                tau: 0.5,
                along: 0.0,
                perp: 2.0
            }
        );
        assert_eq!(
            nd[1],
            Needle {
                bone: 0,
                tau: 1.0,
                along: 2.0,
                perp: -1.0
            }
        );
        let mut out = [Point::origin(); 2];
        stage_one(
            &nd,
            &joints,
            &bones,
            &[10.0],
            &[Vector::x()],
            true,
            &mut out,
        );
        assert_eq!(out, rest);
        // Turn the bone to point down (+y) and double it.
        let moved = [Point::new(0.0, 0.0), Point::new(0.0, 20.0)];
        stage_one(&nd, &moved, &bones, &[10.0], &[Vector::x()], true, &mut out);
        // Right of a bone pointing down is -x; the needle halves (1/s).
        assert!(
            (out[0] - Point::new(-1.0, 10.0)).norm() < 1e-6,
            "{:?}",
            out[0]
        );
        assert!(
            (out[1] - Point::new(0.5, 24.0)).norm() < 1e-6,
            "{:?}",
            out[1]
        );
        stage_one(
            &nd,
            &moved,
            &bones,
            &[10.0],
            &[Vector::x()],
            false,
            &mut out,
        );
        assert!(
            (out[0] - Point::new(-2.0, 10.0)).norm() < 1e-6,
            "{:?}",
            out[0]
        );
        assert!(
            (out[1] - Point::new(1.0, 22.0)).norm() < 1e-6,
            "{:?}",
            out[1]
        );
    }
}
