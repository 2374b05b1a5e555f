//! Decomposition (skinning), docs/method.md §5.3, eq. 21: each vertex attaches to its nearest
//! bone segment along a path that does not cross the silhouette.
//!
//! The distance from a vertex to a bone is the straight distance to the bone's nearest point when
//! that straight path stays on the character (alpha >= 64 every 0.5 px); otherwise it is the
//! shortest path along mesh edges to a vertex that sees the bone, plus that vertex's distance.
//! The mesh lies inside the silhouette, so neither path leaves it.
//!
//! Where parts overlap in the image (an arm drawn across the body), the nearest bone is not
//! always the part whose pixels are seen. So each bone also gets a thickness: the 25th
//! percentile of the distance from its middle 60 % to the outline. A vertex within a bone's
//! thickness (plus half a mesh spacing) is *covered* by that bone; among the bones covering it,
//! the one of the highest draw layer wins (its part is the one in front), then the nearest
//! relative to its thickness. A vertex no bone covers takes the nearest bone relative to its
//! thickness (distances in thicknesses, so a wide body keeps its corners). Ties go
//! to the earlier bone.

use super::silhouette::{distance_to_outline, point_segment_distance};
use super::triangulate::Mesh;
use crate::geom::Point;
use image::RgbaImage;

/// Alpha (0–255) a straight path must keep to count as inside the character.
const PATH_ALPHA: f32 = 64.0;

/// For each mesh vertex, the index into `bones` of its bone. `joints` are the rest joint
/// positions (image px), `bones` their `(parent, child)` pairs (non-empty), `layers` each bone's
/// draw layer.
pub fn skin(
    mesh: &Mesh,
    img: &RgbaImage,
    joints: &[Point],
    bones: &[(usize, usize)],
    layers: &[i32],
) -> Vec<u16> {
    assert!(!bones.is_empty(), "skinning needs at least one bone");
    let nv = mesh.rest.len();
    let nb = bones.len();
    let mut dist = vec![f32::INFINITY; nv * nb];
    for (v, &p) in mesh.rest.iter().enumerate() {
        for (b, &(pj, cj)) in bones.iter().enumerate() {
            let (a, c) = (joints[pj], joints[cj]);
            let q = nearest_on_segment(p, a, c);
            if clear_path(img, p, q) {
                dist[v * nb + b] = point_segment_distance(p, a, c);
            }
        }
    }
    // Shortest paths along mesh edges (Bellman-Ford sweeps in vertex order: deterministic).
    let mut nbrs: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            nbrs[a as usize].push(b);
            nbrs[b as usize].push(a);
        }
    }
    for n in &mut nbrs {
        n.sort_unstable();
        n.dedup();
    }
    for _ in 0..nv {
        let mut changed = false;
        for v in 0..nv {
            for &u in &nbrs[v] {
                let step = (mesh.rest[v] - mesh.rest[u as usize]).norm();
                for b in 0..nb {
                    let via = dist[u as usize * nb + b] + step;
                    if via < dist[v * nb + b] {
                        dist[v * nb + b] = via;
                        changed = true;
                    }
                }
            }
        }
        if !changed {
            break;
        }
    }
    let outline: Vec<Vec<Point>> = mesh
        .outline
        .iter()
        .map(|l| l.iter().map(|&v| mesh.rest[v as usize]).collect())
        .collect();
    let thick: Vec<f32> = bones
        .iter()
        .map(|&(p, c)| thickness(&outline, joints[p], joints[c]).max(mesh.spacing_px))
        .collect();
    (0..nv)
        .map(|v| {
            let row = &dist[v * nb..(v + 1) * nb];
            let covered = |b: usize| row[b] <= thick[b] + 0.5 * mesh.spacing_px;
            let mut best = usize::MAX;
            for b in (0..nb).filter(|&b| covered(b)) {
                if best == usize::MAX
                    || layers[b] > layers[best]
                    || (layers[b] == layers[best] && row[b] / thick[b] < row[best] / thick[best])
                {
                    best = b;
                }
            }
            if best == usize::MAX {
                best = 0;
                for b in 1..nb {
                    if row[b] / thick[b] < row[best] / thick[best] {
                        best = b;
                    }
                }
            }
            if row[best].is_infinite() {
                // A piece that sees no bone: the nearest bone, straight.
                best = (0..nb)
                    .min_by(|&x, &y| {
                        let d = |b: usize| {
                            point_segment_distance(
                                mesh.rest[v],
                                joints[bones[b].0],
                                joints[bones[b].1],
                            )
                        };
                        d(x).total_cmp(&d(y))
                    })
                    .unwrap_or(0);
            }
            best as u16
        })
        .collect()
}

/// Thickness (px) of the part around bone `a–c`: the 25th percentile of the distance to the
/// outline from 9 points on the middle 60 % of the bone (0 for a bone outside the outline).
fn thickness(outline: &[Vec<Point>], a: Point, c: Point) -> f32 {
    let mut d: Vec<f32> = (0..9)
        .map(|k| {
            let p = a + (c - a) * (0.2 + 0.6 * k as f32 / 8.0);
            if super::silhouette::inside(outline, p) {
                distance_to_outline(outline, p)
            } else {
                0.0
            }
        })
        .collect();
    d.sort_by(f32::total_cmp);
    d[2]
}

/// The point of segment `a–c` nearest to `p`.
fn nearest_on_segment(p: Point, a: Point, c: Point) -> Point {
    let ac = c - a;
    let l2 = ac.norm_squared();
    let t = if l2 > 0.0 {
        ((p - a).dot(&ac) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    a + ac * t
}

/// True when the straight path `p → q` keeps alpha >= [`PATH_ALPHA`] (bilinear, every 0.5 px,
/// leaving out the first px: `p` may sit on the outline).
fn clear_path(img: &RgbaImage, p: Point, q: Point) -> bool {
    let d = q - p;
    let len = d.norm();
    let steps = (len / 0.5).ceil() as usize;
    (0..=steps).all(|i| {
        let s = if steps == 0 {
            0.0
        } else {
            i as f32 / steps as f32
        };
        s * len < 1.0 || alpha_at(img, p + d * s) >= PATH_ALPHA
    })
}

/// Bilinear alpha at `p` (image px), 0 outside the image.
fn alpha_at(img: &RgbaImage, p: Point) -> f32 {
    let (x0, y0) = (p.x.floor(), p.y.floor());
    let (fx, fy) = (p.x - x0, p.y - y0);
    let get = |x: f32, y: f32| -> f32 {
        if x < 0.0 || y < 0.0 || x >= img.width() as f32 || y >= img.height() as f32 {
            0.0
        } else {
            img.get_pixel(x as u32, y as u32)[3] as f32
        }
    };
    let top = get(x0, y0) * (1.0 - fx) + get(x0 + 1.0, y0) * fx;
    let bottom = get(x0, y0 + 1.0) * (1.0 - fx) + get(x0 + 1.0, y0 + 1.0) * fx;
    top * (1.0 - fy) + bottom * fy
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deform::triangulate::build_mesh;

    /// A thin bar drawn across a wide block: the bar's bone in front (layer 1) takes the bar's
    /// vertices, the block keeps the rest even where the bar's bone is nearer.
    #[test]
    fn the_front_part_takes_its_pixels_and_no_more() {
        let mut img = RgbaImage::new(80, 60);
        for (x, y, p) in img.enumerate_pixels_mut() {
            let block = (10..50).contains(&x) && (10..50).contains(&y);
            let bar = (20..75).contains(&x) && (27..33).contains(&y);
            if block || bar {
                p[3] = 255;
            }
        }
        let mesh = build_mesh(&img, 400).unwrap();
        // Block bone vertical through x = 30; bar bone horizontal along y = 30.
        let joints = [
            Point::new(30.0, 12.0),
            Point::new(30.0, 48.0),
            Point::new(22.0, 30.0),
            Point::new(73.0, 30.0),
        ];
        let skin = skin(&mesh, &img, &joints, &[(0, 1), (2, 3)], &[0, 1]);
        for (v, p) in mesh.rest.iter().enumerate() {
            if p.x > 51.0 || (p.x > 36.0 && (p.y - 30.0).abs() < 1.5) {
                assert_eq!(skin[v], 1, "bar vertex {p:?}");
            }
            if p.x > 38.0 && p.x < 49.0 && (p.y - 30.0).abs() > 8.0 {
                assert_eq!(skin[v], 0, "block vertex {p:?} given to the bar");
            }
        }
    }

    /// A "U": two vertical bars joined at the bottom, a bone up each bar.
    #[test]
    fn vertices_do_not_attach_across_a_gap() {
        let mut img = RgbaImage::new(60, 60);
        for (x, y, p) in img.enumerate_pixels_mut() {
            let bar = (5..25).contains(&x) || (30..50).contains(&x);
            if (bar && (5..55).contains(&y)) || ((5..50).contains(&x) && (45..55).contains(&y)) {
                p[3] = 255;
            }
        }
        let mesh = build_mesh(&img, 300).unwrap();
        // The left bone runs near the left bar's outer edge, the right bone near the gap: the
        // left bar's inner edge is nearer the right bone, straight across the 5-px gap.
        let joints = [
            Point::new(8.0, 8.0),
            Point::new(8.0, 40.0),
            Point::new(32.0, 8.0),
            Point::new(32.0, 40.0),
        ];
        let bones = [(0, 1), (2, 3)];
        let skin = skin(&mesh, &img, &joints, &bones, &[0, 0]);
        // (Near the bridge at the bottom the right bone is nearer along the mesh, rightly.)
        for (v, p) in mesh.rest.iter().enumerate() {
            if p.x < 26.0 && p.y < 30.0 {
                assert_eq!(skin[v], 0, "left-bar vertex {p:?} attached across the gap");
            }
            if p.x > 29.0 && p.y < 30.0 {
                assert_eq!(skin[v], 1, "right-bar vertex {p:?}");
            }
        }
    }
}
