//! The character's silhouette by marching squares on its alpha channel (docs/method.md
//! §5.1), resampled to evenly spaced points.
//!
//! Alpha values sit on pixel centres; the contour is the iso-line at [`ISO`] between them,
//! placed by linear interpolation along cell edges (sub-pixel). A saddle cell is resolved by the
//! mean of its corners. Every closed loop is returned (outer outlines and holes), in image px.

use crate::geom::Point;
use image::RgbaImage;

/// The alpha level (0–255) of the contour: half-way between the inside threshold
/// ([`crate::character::ALPHA_INSIDE`], 128) and the value below it.
pub const ISO: f32 = 127.5;

/// Closed contour loops of `alpha >= ISO` (each point once; the last connects to the first).
/// Loops are in a consistent orientation: outer outlines have positive [`signed_area`] (clockwise
/// on screen), holes negative.
pub fn contours(img: &RgbaImage) -> Vec<Vec<Point>> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    // Padded grid: value (gx, gy) is pixel (gx - 1, gy - 1), zero outside the image.
    let (gw, gh) = (w + 2, h + 2);
    let mut f = vec![0.0f32; gw * gh];
    for (x, y, p) in img.enumerate_pixels() {
        f[(y as usize + 1) * gw + x as usize + 1] = p[3] as f32;
    }
    let inside = |v: f32| v >= ISO;
    // Edge ids: horizontal edge (x,y)-(x+1,y) is y*gw + x; vertical (x,y)-(x,y+1) is
    // gw*gh + y*gw + x. `next[e]` is the edge the contour goes to from the crossing on e.
    let n_edges = 2 * gw * gh;
    let mut next = vec![u32::MAX; n_edges];
    let hid = |x: usize, y: usize| y * gw + x;
    let vid = |x: usize, y: usize| gw * gh + y * gw + x;
    for y in 0..gh - 1 {
        for x in 0..gw - 1 {
            // Corners clockwise on screen: a (x,y), b (x+1,y), c (x+1,y+1), d (x,y+1), and the
            // edges walked in that order: a→b (top), b→c (right), c→d (bottom), d→a (left).
            let v = [
                f[y * gw + x],
                f[y * gw + x + 1],
                f[(y + 1) * gw + x + 1],
                f[(y + 1) * gw + x],
            ];
            let ins = v.map(inside);
            if ins.iter().all(|&i| i) || ins.iter().all(|&i| !i) {
                continue;
            }
            let edges = [hid(x, y), vid(x + 1, y), hid(x, y + 1), vid(x, y)];
            // Crossings in walk order: (edge, exits the inside?)
            let mut cross: Vec<(usize, bool)> = Vec::with_capacity(4);
            for k in 0..4 {
                if ins[k] != ins[(k + 1) % 4] {
                    cross.push((edges[k], ins[k]));
                }
            }
            if cross.len() == 2 {
                let (exit, enter) = if cross[0].1 {
                    (cross[0].0, cross[1].0)
                } else {
                    (cross[1].0, cross[0].0)
                };
                next[exit] = enter as u32;
            } else {
                // Saddle: four crossings alternating exit/enter along the walk.
                let centre_inside = inside(v.iter().sum::<f32>() / 4.0);
                for i in 0..4 {
                    if !cross[i].1 {
                        continue;
                    }
                    let j = if centre_inside {
                        (i + 1) % 4
                    } else {
                        (i + 3) % 4
                    };
                    next[cross[i].0] = cross[j].0 as u32;
                }
            }
        }
    }
    let point_on = |e: usize| -> Point {
        let (horizontal, id) = if e < gw * gh {
            (true, e)
        } else {
            (false, e - gw * gh)
        };
        let (x, y) = (id % gw, id / gw);
        let (x2, y2) = if horizontal { (x + 1, y) } else { (x, y + 1) };
        let (f0, f1) = (f[y * gw + x], f[y2 * gw + x2]);
        let t = ((ISO - f0) / (f1 - f0)).clamp(0.0, 1.0);
        let px = x as f32 + t * (x2 as f32 - x as f32) - 1.0;
        let py = y as f32 + t * (y2 as f32 - y as f32) - 1.0;
        Point::new(px, py)
    };
    let mut loops = Vec::new();
    let mut done = vec![false; n_edges];
    for start in 0..n_edges {
        if next[start] == u32::MAX || done[start] {
            continue;
        }
        let mut pts = Vec::new();
        let mut e = start;
        while !done[e] {
            done[e] = true;
            pts.push(point_on(e));
            e = next[e] as usize;
            if e == u32::MAX as usize {
                break;
            }
        }
        if pts.len() >= 3 {
            loops.push(pts);
        }
    }
    loops
}

/// Signed area (px²) of a closed polygon: positive when it runs clockwise on screen (y down).
pub fn signed_area(poly: &[Point]) -> f32 {
    let n = poly.len();
    let mut a = 0.0f64;
    for i in 0..n {
        let (p, q) = (poly[i], poly[(i + 1) % n]);
        a += p.x as f64 * q.y as f64 - q.x as f64 * p.y as f64;
    }
    (a / 2.0) as f32
}

/// Length (px) of a closed polygon's outline.
pub fn perimeter(poly: &[Point]) -> f32 {
    (0..poly.len())
        .map(|i| (poly[(i + 1) % poly.len()] - poly[i]).norm())
        .sum()
}

/// `poly` resampled to `n >= 3` points evenly spaced along its outline, starting at its first
/// point.
pub fn resample(poly: &[Point], n: usize) -> Vec<Point> {
    let total = perimeter(poly);
    let step = total / n as f32;
    let mut out = Vec::with_capacity(n);
    let (mut i, mut walked) = (0usize, 0.0f32);
    for k in 0..n {
        let target = k as f32 * step;
        loop {
            let (p, q) = (poly[i % poly.len()], poly[(i + 1) % poly.len()]);
            let len = (q - p).norm();
            if walked + len >= target || i >= poly.len() {
                let t = if len > 0.0 {
                    (target - walked) / len
                } else {
                    0.0
                };
                out.push(p + (q - p) * t.clamp(0.0, 1.0));
                break;
            }
            walked += len;
            i += 1;
        }
    }
    out
}

/// Even-odd test: is `p` inside the region bounded by `loops`?
pub fn inside(loops: &[Vec<Point>], p: Point) -> bool {
    let mut c = false;
    for poly in loops {
        let n = poly.len();
        let mut j = n - 1;
        for i in 0..n {
            let (a, b) = (poly[i], poly[j]);
            if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
                c = !c;
            }
            j = i;
        }
    }
    c
}

/// Distance (px) from `p` to the nearest outline segment of `loops`.
pub fn distance_to_outline(loops: &[Vec<Point>], p: Point) -> f32 {
    let mut best = f32::INFINITY;
    for poly in loops {
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            best = best.min(point_segment_distance(p, a, b));
        }
    }
    best
}

/// Distance (px) from `p` to the segment `a–b`.
pub fn point_segment_distance(p: Point, a: Point, b: Point) -> f32 {
    let ab = b - a;
    let l2 = ab.norm_squared();
    let t = if l2 > 0.0 {
        ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * t)).norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc(r: f32) -> RgbaImage {
        let mut img = RgbaImage::new(40, 40);
        for (x, y, p) in img.enumerate_pixels_mut() {
            let d = ((x as f32 - 20.0).powi(2) + (y as f32 - 19.0).powi(2)).sqrt();
            p[3] = ((r - d + 0.5).clamp(0.0, 1.0) * 255.0) as u8;
        }
        img
    }

    #[test]
    fn a_disc_gives_one_clockwise_loop_of_its_area() {
        let loops = contours(&disc(12.0));
        assert_eq!(loops.len(), 1);
        let a = signed_area(&loops[0]);
        let want = std::f32::consts::PI * 144.0;
        assert!(a > 0.0 && (a - want).abs() / want < 0.02, "{a} vs {want}");
        for p in &loops[0] {
            let r = ((p.x - 20.0).powi(2) + (p.y - 19.0).powi(2)).sqrt();
            assert!((r - 12.0).abs() < 0.3, "{p:?} at r {r}");
        }
    }

    #[test]
    fn a_ring_gives_an_outline_and_a_hole() {
        let mut img = disc(14.0);
        let hole = disc(6.0);
        for (p, q) in img.pixels_mut().zip(hole.pixels()) {
            p[3] = p[3].saturating_sub(q[3]);
        }
        let mut areas: Vec<f32> = contours(&img).iter().map(|l| signed_area(l)).collect();
        areas.sort_by(f32::total_cmp);
        assert_eq!(areas.len(), 2, "{areas:?}");
        assert!(areas[0] < 0.0 && areas[1] > 0.0, "{areas:?}");
        let loops = contours(&img);
        assert!(inside(&loops, Point::new(20.0, 29.0)));
        assert!(
            !inside(&loops, Point::new(20.0, 19.0)),
            "the hole is outside"
        );
    }

    #[test]
    fn resample_spaces_points_evenly() {
        let sq = [
            Point::new(0.0, 0.0),
            Point::new(10.0, 0.0),
            Point::new(10.0, 10.0),
            Point::new(0.0, 10.0),
        ];
        let r = resample(&sq, 8);
        assert_eq!(r.len(), 8);
        assert_eq!(r[1], Point::new(5.0, 0.0));
        assert_eq!(r[3], Point::new(10.0, 5.0));
        assert!((perimeter(&r) - 40.0).abs() < 1e-4);
        assert!((distance_to_outline(&[sq.to_vec()], Point::new(5.0, 3.0)) - 3.0).abs() < 1e-6);
    }
}
