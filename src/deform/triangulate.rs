//! The character's mesh (docs/method.md §5.2): the silhouette resampled at spacing `h`,
//! interior points on a hexagonal lattice of spacing `h` (near-equilateral triangles), and a
//! Delaunay triangulation of both (spade's constrained Delaunay triangulation, the outline as
//! constraint edges), keeping the triangles inside the silhouette.

use super::silhouette::{contours, distance_to_outline, inside, perimeter, resample, signed_area};
use crate::geom::Point;
use image::RgbaImage;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

/// A triangle mesh over the character image.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Vertex rest positions, image px.
    pub rest: Vec<Point>,
    /// Triangles as vertex indices, clockwise on screen (positive area at rest).
    pub triangles: Vec<[u32; 3]>,
    /// Silhouette loops as vertex indices, in order along the outline.
    pub outline: Vec<Vec<u32>>,
    /// True for vertices on the silhouette.
    pub on_outline: Vec<bool>,
    /// Sample spacing, px.
    pub spacing_px: f32,
}

/// Signed area (px², positive clockwise on screen) of triangle `t` with vertex positions `pos`.
pub fn triangle_area(pos: &[Point], t: [u32; 3]) -> f32 {
    let (a, b, c) = (pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]);
    0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x))
}

/// Meshes the opaque part (alpha >= 128) of `img` with about `target_vertices` vertices.
/// Errors (as a message) when the image has no usable opaque region.
pub fn build_mesh(img: &RgbaImage, target_vertices: usize) -> Result<Mesh, String> {
    let raw = contours(img);
    let area: f32 = raw.iter().map(|l| signed_area(l)).sum();
    if area < 16.0 {
        return Err(
            "the image has no opaque region to mesh (alpha >= 128 over 16 px² at least)".into(),
        );
    }
    let per: f32 = raw.iter().map(|l| perimeter(l)).sum();
    // N ≈ A / (h² √3/2) + 0.3 P / h (outline points, less the lattice points kept 0.6 h away
    // from it), solved for the spacing h.
    let n = target_vertices.max(10) as f32;
    let c = 3f32.sqrt() / 2.0;
    let per3 = 0.3 * per;
    let h = ((per3 + (per3 * per3 + 4.0 * n * area / c).sqrt()) / (2.0 * n)).max(1.0);
    let loops: Vec<Vec<Point>> = raw
        .iter()
        .filter(|l| signed_area(l).abs() >= h * h)
        .map(|l| resample(l, ((perimeter(l) / h).round() as usize).max(3)))
        .collect();

    let mut points: Vec<Point> = loops.iter().flatten().copied().collect();
    let n_outline = points.len();
    let mut edges = Vec::with_capacity(n_outline);
    let mut start = 0;
    for l in &loops {
        for i in 0..l.len() {
            edges.push([start + i, start + (i + 1) % l.len()]);
        }
        start += l.len();
    }
    let (w, hgt) = (img.width() as f32, img.height() as f32);
    let dy = h * c;
    let rows = (hgt / dy).ceil() as usize + 1;
    for r in 0..rows {
        let y = r as f32 * dy;
        let x0 = if r % 2 == 1 { h / 2.0 } else { 0.0 };
        let mut x = x0;
        while x < w {
            let p = Point::new(x, y);
            if inside(&loops, p) && distance_to_outline(&loops, p) >= 0.6 * h {
                points.push(p);
            }
            x += h;
        }
    }

    let verts: Vec<Point2<f64>> = points
        .iter()
        .map(|p| Point2::new(p.x as f64, p.y as f64))
        .collect();
    let cdt =
        ConstrainedDelaunayTriangulation::<Point2<f64>>::try_bulk_load_cdt(verts, edges, |_| {})
            .map_err(|e| format!("triangulation failed: {e:?}"))?;
    if cdt.num_vertices() != points.len() {
        return Err("triangulation merged duplicate points; use another mesh_vertices".into());
    }
    let mut tris = Vec::new();
    for f in cdt.inner_faces() {
        let v = f.vertices().map(|v| v.fix().index() as u32);
        let cen = (points[v[0] as usize].coords
            + points[v[1] as usize].coords
            + points[v[2] as usize].coords)
            / 3.0;
        if !inside(&loops, Point::from(cen)) {
            continue;
        }
        let t = if triangle_area(&points, v) < 0.0 {
            [v[0], v[2], v[1]]
        } else {
            v
        };
        if triangle_area(&points, t) > 1e-4 {
            tris.push(t);
        }
    }
    // Drop unused vertices and renumber.
    let mut new_index = vec![u32::MAX; points.len()];
    let mut rest = Vec::new();
    for t in &tris {
        for &v in t {
            if new_index[v as usize] == u32::MAX {
                new_index[v as usize] = 0;
            }
        }
    }
    for (i, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = rest.len() as u32;
            rest.push(points[i]);
        }
    }
    for t in &mut tris {
        *t = t.map(|v| new_index[v as usize]);
    }
    let mut on_outline = vec![false; rest.len()];
    let mut outline = Vec::new();
    let mut start = 0;
    for l in &loops {
        let ids: Vec<u32> = (start..start + l.len())
            .map(|i| new_index[i])
            .filter(|&i| i != u32::MAX)
            .collect();
        start += l.len();
        for &i in &ids {
            on_outline[i as usize] = true;
        }
        if ids.len() >= 3 {
            outline.push(ids);
        }
    }
    debug_assert!(new_index[..n_outline]
        .iter()
        .all(|&i| i == u32::MAX || (i as usize) < rest.len()));
    if tris.is_empty() {
        return Err("the opaque region is too thin to triangulate".into());
    }
    Ok(Mesh {
        rest,
        triangles: tris,
        outline,
        on_outline,
        spacing_px: h,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rectangle_meshes_to_its_area_with_about_the_asked_vertex_count() {
        let mut img = RgbaImage::new(80, 60);
        for y in 10..50 {
            for x in 10..70 {
                img.put_pixel(x, y, image::Rgba([0, 0, 0, 255]));
            }
        }
        let m = build_mesh(&img, 200).unwrap();
        let n = m.rest.len();
        assert!((150..=260).contains(&n), "{n} vertices");
        let area: f32 = m.triangles.iter().map(|&t| triangle_area(&m.rest, t)).sum();
        // Opaque pixels 9.5..69.5 x 9.5..49.5 at the 127.5 iso-line: 60 × 40 px.
        assert!((area - 2400.0).abs() < 24.0, "{area}");
        assert!(m.triangles.iter().all(|&t| triangle_area(&m.rest, t) > 0.0));
        assert_eq!(m.outline.len(), 1);
        assert!(m.on_outline.iter().filter(|&&b| b).count() >= 20);
    }

    #[test]
    fn a_transparent_image_is_an_error() {
        assert!(build_mesh(&RgbaImage::new(20, 20), 100).is_err());
    }
}
