//! Drawing the deformed character: textured triangles with bilinear texture lookup, composited
//! "over" the frame in the rig's layer order (docs/method.md §5.7).
//!
//! Texture coordinates are the mesh's rest positions in the character image (px). Colours are
//! interpolated premultiplied by alpha, so transparent texels never darken the outline. A pixel
//! (centre on integer coordinates, see [`crate::geom`]) belongs to a triangle when its centre is
//! inside; a centre exactly on an edge shared by two triangles goes to exactly one of them, so
//! the mesh has no seams and no double-drawn pixels.

use crate::geom::Point;
use image::RgbaImage;

mod renderer;

pub use renderer::Renderer;

/// A texture: the character image, premultiplied, as f32 (0–255 per channel).
#[derive(Debug, Clone)]
pub struct Texture {
    width: usize,
    height: usize,
    texels: Vec<[f32; 4]>,
}

impl Texture {
    /// Premultiplies `img`.
    pub fn new(img: &RgbaImage) -> Texture {
        let texels = img
            .pixels()
            .map(|p| {
                let a = p[3] as f32 / 255.0;
                [
                    p[0] as f32 * a,
                    p[1] as f32 * a,
                    p[2] as f32 * a,
                    p[3] as f32,
                ]
            })
            .collect();
        Texture {
            width: img.width() as usize,
            height: img.height() as usize,
            texels,
        }
    }

    /// Bilinear lookup at `(u, v)` (image px), premultiplied RGBA; transparent outside.
    #[inline]
    pub fn sample(&self, u: f32, v: f32) -> [f32; 4] {
        let (x0, y0) = (u.floor(), v.floor());
        let (fx, fy) = (u - x0, v - y0);
        let (x0, y0) = (x0 as isize, y0 as isize);
        let get = |x: isize, y: isize| -> [f32; 4] {
            if x < 0 || y < 0 || x >= self.width as isize || y >= self.height as isize {
                [0.0; 4]
            } else {
                self.texels[y as usize * self.width + x as usize]
            }
        };
        let (a, b, c, d) = (
            get(x0, y0),
            get(x0 + 1, y0),
            get(x0, y0 + 1),
            get(x0 + 1, y0 + 1),
        );
        let mut out = [0.0; 4];
        for k in 0..4 {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            out[k] = top + (bottom - top) * fy;
        }
        out
    }
}

/// Calls `pixel(x, y, u, v)` for every pixel of a `width × height` frame whose centre lies in
/// the triangle `ids` of positions `pos` (px), with `(u, v)` interpolated from `uv`. Either
/// orientation is drawn. Edge functions are evaluated from the lower vertex index to the higher,
/// so neighbouring triangles agree exactly on shared edges.
pub fn raster_triangle(
    pos: &[Point],
    uv: &[Point],
    ids: [u32; 3],
    width: u32,
    height: u32,
    mut pixel: impl FnMut(usize, usize, f32, f32),
) {
    let p = ids.map(|i| pos[i as usize]);
    let q = ids.map(|i| uv[i as usize]);
    let area2 = (p[1].x as f64 - p[0].x as f64) * (p[2].y as f64 - p[0].y as f64)
        - (p[1].y as f64 - p[0].y as f64) * (p[2].x as f64 - p[0].x as f64);
    if area2.abs() < 1e-9 || !area2.is_finite() {
        return;
    }
    // Edge k runs between vertices k and k+1; (a, b, c) with E(x, y) = a·x + b·y + c, evaluated
    // from the lower id, and the sign of the triangle's side.
    let mut edges = [(0.0f64, 0.0f64, 0.0f64, 1.0f64); 3];
    for k in 0..3 {
        let (i, j) = (k, (k + 1) % 3);
        let (s, e) = if ids[i] < ids[j] { (i, j) } else { (j, i) };
        let (ps, pe) = (p[s], p[e]);
        let (dx, dy) = (pe.x as f64 - ps.x as f64, pe.y as f64 - ps.y as f64);
        let a = -dy;
        let b = dx;
        let c = dy * ps.x as f64 - dx * ps.y as f64;
        let third = p[(k + 2) % 3];
        let side = a * third.x as f64 + b * third.y as f64 + c;
        edges[k] = (a, b, c, side.signum());
    }
    // Affine map screen -> uv.
    let (x0, y0) = (p[0].x as f64, p[0].y as f64);
    let (e1x, e1y) = (p[1].x as f64 - x0, p[1].y as f64 - y0);
    let (e2x, e2y) = (p[2].x as f64 - x0, p[2].y as f64 - y0);
    let (du1, dv1) = (q[1].x as f64 - q[0].x as f64, q[1].y as f64 - q[0].y as f64);
    let (du2, dv2) = (q[2].x as f64 - q[0].x as f64, q[2].y as f64 - q[0].y as f64);
    // (s, t) = barycentric weights of p1, p2: s = (e2y·dx − e2x·dy)/area2, t = (−e1y·dx + e1x·dy)/area2.
    let ux = (du1 * e2y - du2 * e1y) / area2;
    let uy = (-du1 * e2x + du2 * e1x) / area2;
    let vx = (dv1 * e2y - dv2 * e1y) / area2;
    let vy = (-dv1 * e2x + dv2 * e1x) / area2;
    let (u0, v0) = (q[0].x as f64, q[0].y as f64);

    let min = |a: f32, b: f32, c: f32| a.min(b).min(c);
    let max = |a: f32, b: f32, c: f32| a.max(b).max(c);
    let xmin = min(p[0].x, p[1].x, p[2].x).ceil().max(0.0);
    let ymin = min(p[0].y, p[1].y, p[2].y).ceil().max(0.0);
    let xmax = max(p[0].x, p[1].x, p[2].x).floor().min(width as f32 - 1.0);
    let ymax = max(p[0].y, p[1].y, p[2].y).floor().min(height as f32 - 1.0);
    if !(xmin <= xmax && ymin <= ymax) {
        return;
    }
    for y in ymin as usize..=ymax as usize {
        let yf = y as f64;
        for x in xmin as usize..=xmax as usize {
            let xf = x as f64;
            let inside = edges.iter().all(|&(a, b, c, side)| {
                let e = a * xf + b * yf + c;
                e * side > 0.0 || (e == 0.0 && side > 0.0)
            });
            if inside {
                let (dx, dy) = (xf - x0, yf - y0);
                let u = u0 + ux * dx + uy * dy;
                let v = v0 + vx * dx + vy * dy;
                pixel(x, y, u as f32, v as f32);
            }
        }
    }
}

/// Draws the triangles `order` of the mesh (`triangles`, vertices at `pos`, texture coordinates
/// `uv`) over `frame`, each pixel composited "over" what is there.
pub fn draw_mesh(
    frame: &mut RgbaImage,
    pos: &[Point],
    uv: &[Point],
    triangles: &[[u32; 3]],
    order: &[u32],
    tex: &Texture,
) {
    let (w, h) = frame.dimensions();
    let buf: &mut [u8] = frame.as_mut();
    for &t in order {
        raster_triangle(pos, uv, triangles[t as usize], w, h, |x, y, u, v| {
            let s = tex.sample(u, v);
            if s[3] <= 0.0 {
                return;
            }
            let i = 4 * (y * w as usize + x);
            let keep = 1.0 - s[3] / 255.0;
            for k in 0..4 {
                buf[i + k] = (s[k] + buf[i + k] as f32 * keep).round().min(255.0) as u8;
            }
        });
    }
}

/// The drawn area of the mesh (px²): texture alpha (0–1) summed over every pixel every triangle
/// covers, overlaps counted each time (so a limb passing in front of the body does not hide
/// area). For checks of area preservation.
pub fn coverage(
    pos: &[Point],
    uv: &[Point],
    triangles: &[[u32; 3]],
    tex: &Texture,
    width: u32,
    height: u32,
) -> f64 {
    let mut sum = 0.0f64;
    for &t in triangles {
        raster_triangle(pos, uv, t, width, height, |_, _, u, v| {
            sum += tex.sample(u, v)[3] as f64 / 255.0;
        });
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_triangles_cover_a_square_once() {
        // A 10×10 square split along a diagonal, its corners off the pixel grid.
        let pos = [
            Point::new(2.3, 1.7),
            Point::new(12.3, 1.7),
            Point::new(12.3, 11.7),
            Point::new(2.3, 11.7),
        ];
        let mut hits = vec![0u8; 20 * 20];
        for t in [[0, 1, 2], [0, 2, 3]] {
            raster_triangle(&pos, &pos, t, 20, 20, |x, y, u, v| {
                hits[y * 20 + x] += 1;
                assert!((u - x as f32).abs() < 1e-3 && (v - y as f32).abs() < 1e-3);
            });
        }
        assert!(hits.iter().all(|&h| h <= 1), "a pixel drawn twice");
        assert_eq!(hits.iter().filter(|&&h| h == 1).count(), 100);
    }

    #[test]
    fn draw_composites_premultiplied_texture_over_the_frame() {
        let mut img = RgbaImage::new(4, 4);
        for p in img.pixels_mut() {
            *p = image::Rgba([200, 100, 0, 128]);
        }
        let tex = Texture::new(&img);
        let s = tex.sample(1.5, 1.5);
        assert!((s[0] - 200.0 * 128.0 / 255.0).abs() < 1e-3 && s[3] == 128.0);
        let mut frame = RgbaImage::from_pixel(8, 8, image::Rgba([0, 0, 255, 255]));
        let pos = [
            Point::new(0.0, 0.0),
            Point::new(3.0, 0.0),
            Point::new(0.0, 3.0),
        ];
        draw_mesh(&mut frame, &pos, &pos, &[[0, 1, 2]], &[0], &tex);
        // Half-transparent orange over blue.
        assert_eq!(frame.get_pixel(1, 1).0, [100, 50, 127, 255]);
        assert_eq!(frame.get_pixel(6, 6).0, [0, 0, 255, 255]);
    }
}
