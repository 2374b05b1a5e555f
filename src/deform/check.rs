//! Checks of a deformed mesh (docs/method.md §5.8): no triangle folded over (its signed area at
//! or below zero, against its positive area at rest) and no crack, a place where the mesh came
//! apart at a hinge seam ([`super::split`]) and the ground shows between the two sides.

use super::triangulate::{triangle_area, Mesh};
use crate::geom::Point;

/// Two copies of one rest vertex further apart than this (px) have opened the seam.
pub const CRACK_PX: f32 = 1.0;

/// A point this close (px) to a triangle's edge counts as on it (so as covered).
pub const ON_EDGE_PX: f32 = 0.01;

/// What [`defects`] found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Defects {
    /// Triangles folded over (signed area ≤ 0).
    pub folded: Vec<usize>,
    /// Seams `(vertex, copy)` opened by more than [`CRACK_PX`] with uncovered ground between
    /// the two copies.
    pub cracks: Vec<(u32, u32)>,
}

impl Defects {
    /// No fold and no crack.
    pub fn is_clean(&self) -> bool {
        self.folded.is_empty() && self.cracks.is_empty()
    }
}

/// The folds and cracks of `mesh` (with hinge seams `seams` and seam fillers `fill`) at vertices
/// `pos`. A seam is cracked when its two copies are more than [`CRACK_PX`] apart and a point
/// between them (at a quarter, half or three quarters of the way) lies in no triangle of the
/// deformed mesh or its fillers: where a limb swings past a part drawn behind or in front of it,
/// the seam opens over that part and nothing shows through. Fillers have no area at rest and
/// are not checked for folds (one folds underneath wherever its two parts overlap).
pub fn defects(mesh: &Mesh, seams: &[(u32, u32)], fill: &[[u32; 3]], pos: &[Point]) -> Defects {
    let folded = mesh
        .triangles
        .iter()
        .enumerate()
        .filter(|(_, &t)| !(triangle_area(pos, t) > 0.0))
        .map(|(i, _)| i)
        .collect();
    // A point on a triangle's edge (as the point between two copies is on their filler's edge)
    // counts as covered: [`ON_EDGE_PX`] of slack against rounding.
    let covered = |q: Point| {
        mesh.triangles.iter().chain(fill).any(|&t| {
            let [a, b, c] = t.map(|v| pos[v as usize]);
            // Side of q from p→r, times |r − p|, and that slack times |r − p|.
            let side = |p: Point, r: Point| {
                let d = (r.x - p.x) * (q.y - p.y) - (r.y - p.y) * (q.x - p.x);
                (d, ON_EDGE_PX * (r - p).norm())
            };
            let s = [side(a, b), side(b, c), side(c, a)];
            s.iter().all(|&(d, e)| d >= -e) || s.iter().all(|&(d, e)| d <= e)
        })
    };
    let cracks = seams
        .iter()
        .filter(|&&(v, c)| {
            let (p, q) = (pos[v as usize], pos[c as usize]);
            (q - p).norm() > CRACK_PX
                && [0.25f32, 0.5, 0.75]
                    .iter()
                    .any(|&w| !covered(p + (q - p) * w))
        })
        .copied()
        .collect();
    Defects { folded, cracks }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles sharing the edge 1–2, the second drawn with copies 3, 4 of 1, 2.
    fn pair() -> (Mesh, Vec<(u32, u32)>, Vec<Point>) {
        let rest = vec![
            Point::new(0.0, 0.0),
            Point::new(10.0, 0.0),
            Point::new(0.0, 10.0),
            Point::new(10.0, 0.0),
            Point::new(0.0, 10.0),
            Point::new(10.0, 10.0),
        ];
        let mesh = Mesh {
            rest: rest.clone(),
            triangles: vec![[0, 1, 2], [3, 5, 4]],
            outline: vec![],
            on_outline: vec![false; 6],
            spacing_px: 10.0,
        };
        (mesh, vec![(1, 3), (2, 4)], rest)
    }

    #[test]
    fn finds_a_fold_and_an_open_seam_but_not_a_covered_one() {
        let (mesh, seams, mut pos) = pair();
        assert!(defects(&mesh, &seams, &[], &pos).is_clean());
        // The second triangle moves 5 px right: the seam opens onto nothing.
        for v in [3, 4, 5] {
            pos[v].x += 5.0;
        }
        assert_eq!(defects(&mesh, &seams, &[], &pos).cracks, seams);
        // Moved left over the first triangle instead: the opening is covered.
        for v in [3, 4, 5] {
            pos[v].x -= 10.0;
        }
        assert!(defects(&mesh, &seams, &[], &pos).cracks.is_empty());
        // Moved right again, with the fillers the split would give (a quad between the two
        // copies of the edge 1-2): the opening is spanned, no crack; the fold is still found.
        for v in [3, 4, 5] {
            pos[v].x += 10.0;
        }
        let fill = [[1, 2, 4], [1, 4, 3]];
        assert_eq!(defects(&mesh, &seams, &[], &pos).cracks, seams);
        assert!(defects(&mesh, &seams, &fill, &pos).is_clean());
        pos[0] = Point::new(12.0, 12.0);
        assert_eq!(defects(&mesh, &seams, &fill, &pos).folded, vec![0]);
        // The first triangle turned over.
        let (_, _, mut pos) = pair();
        pos[0] = Point::new(12.0, 12.0);
        assert_eq!(defects(&mesh, &seams, &[], &pos).folded, vec![0]);
    }
}
