//! Seam fillers (docs/method.md §5.4, §5.8): where the hinge split ([`super::split`]) cut the
//! mesh, zero-width strips that join the two sides again, drawn beneath every part.
//!
//! Every edge of the mesh before the split whose two triangles ended on different copies of its
//! vertices becomes a quad between the two copies of the edge (two triangles); every vertex left
//! with three copies or more becomes a fan over its copies, in their order around it. At rest a
//! filler has no area; when the parts turn apart it spans the opening, textured with the colours
//! along the cut (its texture coordinates are the rest positions, which the copies share). With
//! the fillers the parts and strips form one surface again (the split mesh's disc with strips
//! sewn into its cuts), so no point inside the deformed outline can show the ground; a part that
//! swings over its neighbour still does so freely, its strip folding underneath out of sight.

use super::triangulate::Mesh;
use crate::geom::Point;
use std::collections::BTreeMap;

/// The filler triangles of a split: `before` is the mesh before the split, `after` the split
/// mesh (the same triangles in the same order, some vertices replaced by copies).
pub fn fillers(before: &Mesh, after: &Mesh) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    // Each original edge (low, high) → the copies (of low, of high) in each of its triangles.
    let mut edges: BTreeMap<(u32, u32), Vec<(u32, u32)>> = BTreeMap::new();
    // Each original vertex → its copies, each with the centroids of the triangles using it.
    let mut corners: BTreeMap<u32, BTreeMap<u32, Vec<Point>>> = BTreeMap::new();
    for (t0, t1) in before.triangles.iter().zip(&after.triangles) {
        let centroid = Point::from(
            (before.rest[t0[0] as usize].coords
                + before.rest[t0[1] as usize].coords
                + before.rest[t0[2] as usize].coords)
                / 3.0,
        );
        for k in 0..3 {
            let (a, b) = (t0[k], t0[(k + 1) % 3]);
            let (ca, cb) = (t1[k], t1[(k + 1) % 3]);
            let key = if a < b { (a, b) } else { (b, a) };
            let val = if a < b { (ca, cb) } else { (cb, ca) };
            edges.entry(key).or_default().push(val);
            corners
                .entry(a)
                .or_default()
                .entry(ca)
                .or_default()
                .push(centroid);
        }
    }
    for sides in edges.values() {
        if let [(u1, w1), (u2, w2)] = sides[..] {
            if (u1, w1) == (u2, w2) {
                continue;
            }
            if w1 != w2 {
                out.push([u1, w1, w2]);
            }
            if u1 != u2 {
                out.push([u1, w2, u2]);
            }
        }
    }
    for (&v, copies) in &corners {
        if copies.len() < 3 {
            continue;
        }
        let c = before.rest[v as usize];
        let mut around: Vec<(f32, u32)> = copies
            .iter()
            .map(|(&copy, cents)| {
                let d = cents
                    .iter()
                    .fold(nalgebra::Vector2::zeros(), |s, p| s + (p - c));
                (d.y.atan2(d.x), copy)
            })
            .collect();
        around.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for k in 1..around.len() - 1 {
            out.push([around[0].1, around[k].1, around[k + 1].1]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of four triangles around a centre vertex 4; triangles 1, 2 and 3 moved onto
    /// copies: three cut edges and a centre with three copies.
    #[test]
    fn cut_edges_become_quads_and_a_corner_of_three_copies_a_fan() {
        let rest = vec![
            Point::new(0.0, 0.0),
            Point::new(10.0, 0.0),
            Point::new(10.0, 10.0),
            Point::new(0.0, 10.0),
            Point::new(5.0, 5.0),
        ];
        let tris = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        let before = Mesh {
            rest: rest.clone(),
            triangles: tris,
            outline: vec![vec![0, 1, 2, 3]],
            on_outline: vec![true, true, true, true, false],
            spacing_px: 10.0,
        };
        let mut after = before.clone();
        // Triangle 1 on copies 5 (of 2) and 6 (of 4); triangle 2 on copy 7 (of 4) with 5.
        after.rest.extend([rest[2], rest[4], rest[4]]);
        after.triangles[1] = [1, 5, 6];
        after.triangles[2] = [5, 3, 7];
        let f = fillers(&before, &after);
        // Edges 1-4 (4 | 6), 2-4 (6,5 | 7,5), 3-4 (7 | 4): three quads with one end shared,
        // one triangle each; the centre 4 has copies 4, 6, 7: one fan triangle.
        assert_eq!(f.len(), 4, "{f:?}");
        let has = |a: u32, b: u32, c: u32| {
            f.iter().any(|t| {
                let mut s = *t;
                s.sort_unstable();
                let mut w = [a, b, c];
                w.sort_unstable();
                s == w
            })
        };
        assert!(has(1, 4, 6) && has(5, 6, 7), "{f:?}");
        assert!(has(4, 6, 7), "no fan over the centre's copies: {f:?}");
        assert!(has(3, 4, 7), "{f:?}");
        // Nothing is cut: no filler.
        assert!(fillers(&before, &before).is_empty());
    }
}
