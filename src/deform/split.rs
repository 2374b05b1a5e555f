//! Splitting the mesh at hinges, between skinning and stage one.
//!
//! One planar mesh cannot let a limb swing past a neighbour hinged on the same joint (an arm
//! past the body, a thigh past the other thigh): the triangles between them would have to fold.
//! So joint triangles are kept only between a bone and the parent bone it continues (sharing a
//! joint, less than 75° apart at rest: elbow, knee, neck; a foot at right angles to its shin
//! hinges like a limb). Every other triangle whose vertices
//! lie on several bones is given to one of them (the most frequent; ties to the bone nearer the
//! root, then the earlier): its other vertices are duplicated onto that bone. The limbs become
//! flaps hinged on their joints, drawn in layer order; on a ball joint the seam does not show.

use super::triangulate::Mesh;
use crate::geom::Point;
use crate::skeleton::Skeleton;

/// A mesh split at its hinges.
#[derive(Debug, Clone, PartialEq)]
pub struct Split {
    pub mesh: Mesh,
    /// Bone of each vertex.
    pub skin: Vec<u16>,
    /// `(vertex, copy)`: each duplicate with the vertex it copies (one place at rest, on two
    /// bones): where the mesh may open. Only pairs whose two vertices are both drawn (a vertex
    /// all of whose triangles went to copies is in no triangle).
    pub seams: Vec<(u32, u32)>,
    /// The seam fillers ([`super::fill::fillers`]) joining the cuts again, drawn beneath.
    pub fill: Vec<[u32; 3]>,
}

/// Splits `mesh` (with vertex bones `skin`) at hinges. Vertices keep their indices; duplicates
/// are appended.
pub fn split_hinges(
    mesh: &Mesh,
    skin: &[u16],
    skeleton: &Skeleton,
    bones: &[(usize, usize)],
    joints: &[Point],
) -> Split {
    let dir = |b: usize| {
        let d = joints[bones[b].1] - joints[bones[b].0];
        let l = d.norm();
        if l > 1e-6 {
            d / l
        } else {
            d
        }
    };
    let hinged = |a: usize, b: usize| {
        let parent_of = |c: usize, p: usize| bones[c].0 == bones[p].1;
        (parent_of(a, b) || parent_of(b, a)) && dir(a).dot(&dir(b)) > 75f32.to_radians().cos()
    };
    let depth: Vec<usize> = bones.iter().map(|&(_, c)| skeleton.depth(c)).collect();
    let mut out = mesh.clone();
    let mut skin_out = skin.to_vec();
    let mut copies: std::collections::BTreeMap<(u32, u16), u32> = Default::default();
    for t in out.triangles.iter_mut() {
        let b = t.map(|v| skin[v as usize] as usize);
        let keep = (0..3).all(|i| (i + 1..3).all(|j| b[i] == b[j] || hinged(b[i], b[j])));
        if keep {
            continue;
        }
        let count = |x: usize| b.iter().filter(|&&y| y == x).count();
        let owner = *b
            .iter()
            .min_by_key(|&&x| (std::cmp::Reverse(count(x)), depth[x], x))
            // Cannot fail: a triangle always has three vertices.
            .expect("three vertices");
        for v in t.iter_mut() {
            if skin[*v as usize] as usize == owner {
                continue;
            }
            let key = (*v, owner as u16);
            let new = *copies.entry(key).or_insert_with(|| {
                out.rest.push(mesh.rest[*v as usize]);
                out.on_outline.push(false);
                skin_out.push(owner as u16);
                (out.rest.len() - 1) as u32
            });
            *v = new;
        }
    }
    let mut used = vec![false; out.rest.len()];
    for t in &out.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let fill = super::fill::fillers(mesh, &out);
    Split {
        seams: copies
            .into_iter()
            .map(|((v, _), c)| (v, c))
            .filter(|&(v, c)| used[v as usize] && used[c as usize])
            .collect(),
        fill,
        mesh: out,
        skin: skin_out,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three bones from one root joint: a trunk up, two legs down-left and down-right. A strip of
    /// triangles joins everything at the root.
    #[test]
    fn siblings_come_apart_and_continuations_stay_joined() {
        let skeleton = Skeleton::new(
            ["root", "top", "left", "right", "tip"]
                .map(String::from)
                .to_vec(),
            vec![None, Some(0), Some(0), Some(0), Some(1)],
        );
        let bones = skeleton.bones();
        let joints = [
            Point::new(0.0, 0.0),
            Point::new(0.0, -10.0),
            Point::new(-8.0, 8.0),
            Point::new(8.0, 8.0),
            Point::new(0.0, -20.0),
        ];
        // Vertices: 0 on top (bone 0), 1 on left (bone 1), 2 on right (bone 2), 3 on tip (bone 3).
        let mesh = Mesh {
            rest: vec![
                Point::new(0.0, -5.0),
                Point::new(-4.0, 4.0),
                Point::new(4.0, 4.0),
                Point::new(1.0, -15.0),
            ],
            triangles: vec![[0, 2, 1], [0, 3, 2]],
            outline: vec![],
            on_outline: vec![false; 4],
            spacing_px: 5.0,
        };
        let skin = [0, 1, 2, 3];
        let Split {
            mesh: m,
            skin: s,
            seams,
            fill,
        } = split_hinges(&mesh, &skin, &skeleton, &bones, &joints);
        // Vertices 1, 2 and 3 lost every triangle to their copies 5, 4 and 6: nothing drawn can
        // open there, so no seam is named.
        assert!(seams.is_empty(), "{seams:?}");
        // Triangle 0 mixes siblings: all its vertices end on one bone (the trunk, nearest root).
        let b0: Vec<u16> = m.triangles[0].iter().map(|&v| s[v as usize]).collect();
        assert_eq!(b0, vec![0, 0, 0]);
        // Triangle 1 mixes trunk (0), tip (3: continues the trunk) and right (2, a sibling of the
        // trunk): one owner again, the trunk.
        assert!(m.triangles[1].iter().all(|&v| s[v as usize] == 0));
        // Vertices 1, 2 and 3 copied onto the trunk, vertex 2 once for both triangles.
        assert_eq!(m.rest.len(), 7);
        assert_eq!(&s[..4], &skin);
        // The one edge of two triangles, 0-2, is on vertex 0 and copy 4 in both: no cut, no
        // filler.
        assert!(fill.is_empty(), "{fill:?}");
    }
}
