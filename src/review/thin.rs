//! Hilditch thinning (docs/method.md §6): a binary mask peeled layer by layer down to its curve
//! skeleton, one pixel wide and 8-connected, with the mask's topology (no part cut off, no hole
//! opened or closed).
//!
//! Neighbours of a pixel P1 are numbered clockwise from north (docs/method.md §6):
//! ```text
//!   P9 P2 P3
//!   P8 P1 P4
//!   P7 P6 P5
//! ```
//! `B(P)` is the number of foreground neighbours, `A(P)` the number of 0→1 patterns in the
//! cyclic sequence P2, P3, …, P9, P2. A foreground P1 is removed when
//! 1. `2 ≤ B(P1) ≤ 6` (not an end point, not interior),
//! 2. `A(P1) = 1` (removing it joins no two parts),
//! 3. `P2·P4·P8 = 0` or `A(P2) ≠ 1`,
//! 4. `P2·P4·P6 = 0` or `A(P4) ≠ 1` (a line two pixels thick is not eaten from both sides).
//!
//! Each pass marks the pixels that meet the conditions on the image as the pass found it (so one
//! pass peels one layer, and the skeleton is centred), then removes them one at a time in raster
//! order, checking the conditions again on the image as it now is: the parallel test alone
//! erases a 2×2 block whole. Passes repeat until nothing changes. A final pass removes the corner
//! pixels of diagonal staircases that Hilditch's `A(P1) = 1` keeps (a pixel whose two
//! perpendicular 4-neighbours touch each other diagonally), so every skeleton pixel but the end
//! points is needed for connectivity.

use image::GrayImage;

/// Offsets of P2…P9 (clockwise from north), as `(dx, dy)` with y down.
const RING: [(i32, i32); 8] = [
    (0, -1),
    (1, -1),
    (1, 0),
    (1, 1),
    (0, 1),
    (-1, 1),
    (-1, 0),
    (-1, -1),
];

/// A binary image with a one-pixel background border, so every pixel of the mask has 8
/// neighbours.
#[derive(Clone)]
struct Grid {
    w: i32,
    h: i32,
    px: Vec<bool>,
}

impl Grid {
    fn from_mask(mask: &GrayImage) -> Grid {
        let (w, h) = (mask.width() as i32 + 2, mask.height() as i32 + 2);
        let mut px = vec![false; (w * h) as usize];
        for (x, y, p) in mask.enumerate_pixels() {
            px[((y as i32 + 1) * w + x as i32 + 1) as usize] = p.0[0] != 0;
        }
        Grid { w, h, px }
    }

    fn to_mask(&self) -> GrayImage {
        GrayImage::from_fn((self.w - 2) as u32, (self.h - 2) as u32, |x, y| {
            image::Luma([if self.get(x as i32 + 1, y as i32 + 1) {
                255
            } else {
                0
            }])
        })
    }

    #[inline]
    fn get(&self, x: i32, y: i32) -> bool {
        x >= 0 && y >= 0 && x < self.w && y < self.h && self.px[(y * self.w + x) as usize]
    }

    #[inline]
    fn set(&mut self, x: i32, y: i32, v: bool) {
        self.px[(y * self.w + x) as usize] = v;
    }

    /// P2…P9 of `(x, y)`.
    fn ring(&self, x: i32, y: i32) -> [bool; 8] {
        RING.map(|(dx, dy)| self.get(x + dx, y + dy))
    }

    /// Hilditch's four conditions for removing the foreground pixel `(x, y)`.
    fn removable(&self, x: i32, y: i32) -> bool {
        let p = self.ring(x, y);
        let b = count(&p);
        if !(2..=6).contains(&b) || crossings(&p) != 1 {
            return false;
        }
        let (p2, p4, p6, p8) = (p[0], p[2], p[4], p[6]);
        let c3 = !(p2 && p4 && p8) || crossings(&self.ring(x, y - 1)) != 1;
        let c4 = !(p2 && p4 && p6) || crossings(&self.ring(x + 1, y)) != 1;
        c3 && c4
    }

    /// One Hilditch pass; returns how many pixels it removed.
    fn pass(&mut self) -> usize {
        let mut marked = Vec::new();
        for y in 1..self.h - 1 {
            for x in 1..self.w - 1 {
                if self.get(x, y) && self.removable(x, y) {
                    marked.push((x, y));
                }
            }
        }
        let mut removed = 0;
        for (x, y) in marked {
            if self.removable(x, y) {
                self.set(x, y, false);
                removed += 1;
            }
        }
        removed
    }

    /// Removes staircase corners: pixels, not end points, with exactly one 8-connected run of
    /// neighbours in the Yokoi sense (so removing them changes no topology) and two or more
    /// 4-neighbours. Returns how many it removed.
    fn unstair(&mut self) -> usize {
        let mut removed = 0;
        for y in 1..self.h - 1 {
            for x in 1..self.w - 1 {
                if !self.get(x, y) {
                    continue;
                }
                let p = self.ring(x, y);
                let four = [p[0], p[2], p[4], p[6]].iter().filter(|&&v| v).count();
                if count(&p) >= 2 && four >= 2 && yokoi8(&p) == 1 {
                    self.set(x, y, false);
                    removed += 1;
                }
            }
        }
        removed
    }
}

/// Number of set neighbours, `B(P)`.
fn count(p: &[bool; 8]) -> usize {
    p.iter().filter(|&&v| v).count()
}

/// Number of 0→1 patterns in P2, P3, …, P9, P2: Hilditch's `A(P)`.
fn crossings(p: &[bool; 8]) -> usize {
    (0..8).filter(|&i| !p[i] && p[(i + 1) % 8]).count()
}

/// Yokoi's 8-connectivity number of a pixel with neighbours `p` (P2…P9): 1 exactly when
/// removing the pixel changes neither the number of foreground parts nor of holes.
fn yokoi8(p: &[bool; 8]) -> usize {
    // x̄ for P2..P9; the 4-neighbours are at even indices.
    let n = p.map(|v| !v);
    (0..4)
        .map(|k| {
            let i = 2 * k;
            usize::from(n[i]) - usize::from(n[i] && n[(i + 1) % 8] && n[(i + 2) % 8])
        })
        .sum()
}

/// Thins `mask` (non-zero = foreground) to its curve skeleton by Hilditch's algorithm (see the
/// module doc): returns a mask of the same size, 255 on the skeleton.
pub fn thin(mask: &GrayImage) -> GrayImage {
    let mut g = Grid::from_mask(mask);
    while g.pass() > 0 {}
    while g.unstair() > 0 {}
    g.to_mask()
}

/// Number of 8-neighbours of `(x, y)` set in `mask`.
pub fn neighbours(mask: &GrayImage, x: u32, y: u32) -> usize {
    let (w, h) = (mask.width() as i32, mask.height() as i32);
    RING.iter()
        .filter(|&&(dx, dy)| {
            let (nx, ny) = (x as i32 + dx, y as i32 + dy);
            nx >= 0 && ny >= 0 && nx < w && ny < h && mask.get_pixel(nx as u32, ny as u32).0[0] != 0
        })
        .count()
}

/// The set 8-neighbours of `(x, y)` in `mask`.
pub fn neighbour_pixels(mask: &GrayImage, x: u32, y: u32) -> Vec<(u32, u32)> {
    let (w, h) = (mask.width() as i32, mask.height() as i32);
    RING.iter()
        .map(|&(dx, dy)| (x as i32 + dx, y as i32 + dy))
        .filter(|&(nx, ny)| {
            nx >= 0 && ny >= 0 && nx < w && ny < h && mask.get_pixel(nx as u32, ny as u32).0[0] != 0
        })
        .map(|(nx, ny)| (nx as u32, ny as u32))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Luma;

    /// A mask with the given filled rectangles `(x0, y0, x1, y1)`, ends inclusive.
    fn mask(w: u32, h: u32, rects: &[(u32, u32, u32, u32)]) -> GrayImage {
        GrayImage::from_fn(w, h, |x, y| {
            let on = rects
                .iter()
                .any(|&(x0, y0, x1, y1)| (x0..=x1).contains(&x) && (y0..=y1).contains(&y));
            Luma([if on { 255 } else { 0 }])
        })
    }

    fn pixels(m: &GrayImage) -> Vec<(u32, u32)> {
        m.enumerate_pixels()
            .filter(|p| p.2 .0[0] != 0)
            .map(|p| (p.0, p.1))
            .collect()
    }

    /// Number of 8-connected parts of `m`.
    fn parts(m: &GrayImage) -> usize {
        let mut seen = std::collections::HashSet::new();
        let mut n = 0;
        for start in pixels(m) {
            if !seen.insert(start) {
                continue;
            }
            n += 1;
            let mut stack = vec![start];
            while let Some((x, y)) = stack.pop() {
                for q in neighbour_pixels(m, x, y) {
                    if seen.insert(q) {
                        stack.push(q);
                    }
                }
            }
        }
        n
    }

    /// Asserts a skeleton is one pixel wide: no 2×2 block is fully set, and no pixel other than
    /// an end point can be removed without changing the topology.
    fn assert_thin(s: &GrayImage) {
        let on = |x: u32, y: u32| s.get_pixel(x, y).0[0] != 0;
        for y in 0..s.height() - 1 {
            for x in 0..s.width() - 1 {
                assert!(
                    !(on(x, y) && on(x + 1, y) && on(x, y + 1) && on(x + 1, y + 1)),
                    "2x2 block at {x},{y}"
                );
            }
        }
        let g = Grid::from_mask(s);
        for (x, y) in pixels(s) {
            let p = g.ring(x as i32 + 1, y as i32 + 1);
            let four = [p[0], p[2], p[4], p[6]].iter().filter(|&&v| v).count();
            assert!(
                !(count(&p) >= 2 && four >= 2 && yokoi8(&p) == 1),
                "redundant staircase pixel at {x},{y}"
            );
        }
    }

    /// The end points (one neighbour) of a skeleton.
    fn ends(s: &GrayImage) -> Vec<(u32, u32)> {
        pixels(s)
            .into_iter()
            .filter(|&(x, y)| neighbours(s, x, y) == 1)
            .collect()
    }

    fn near(p: (u32, u32), q: (u32, u32), tol: i64) -> bool {
        (p.0 as i64 - q.0 as i64).abs() <= tol && (p.1 as i64 - q.1 as i64).abs() <= tol
    }

    #[test]
    fn plus_sign_has_four_arms() {
        // Arms 7 px thick, 41 px across, centred on (25, 25).
        let m = mask(51, 51, &[(5, 22, 45, 28), (22, 5, 28, 45)]);
        let s = thin(&m);
        assert_thin(&s);
        assert_eq!(parts(&s), 1);
        let e = ends(&s);
        assert_eq!(e.len(), 4, "end points {e:?}");
        for tip in [(5, 25), (45, 25), (25, 5), (25, 45)] {
            assert!(
                e.iter().any(|&p| near(p, tip, 4)),
                "no end near {tip:?}: {e:?}"
            );
        }
        // The arms meet near the centre: a pixel there has 3 or more neighbours.
        assert!(pixels(&s)
            .iter()
            .any(|&(x, y)| near((x, y), (25, 25), 3) && neighbours(&s, x, y) >= 3));
        // The skeleton stays inside the mask, on the arms' centre lines.
        for (x, y) in pixels(&s) {
            assert!(m.get_pixel(x, y).0[0] != 0);
            assert!(
                near((x, 25), (x, y), 1) || near((25, y), (x, y), 1),
                "{x},{y}"
            );
        }
    }

    #[test]
    fn l_shape_is_one_bent_line() {
        // A vertical bar 6 px thick, then a horizontal one along the bottom.
        let m = mask(40, 40, &[(5, 3, 10, 34), (5, 29, 35, 34)]);
        let s = thin(&m);
        assert_thin(&s);
        assert_eq!(parts(&s), 1);
        let e = ends(&s);
        assert_eq!(e.len(), 2, "end points {e:?}");
        assert!(e.iter().any(|&p| near(p, (8, 3), 4)), "{e:?}");
        assert!(e.iter().any(|&p| near(p, (35, 31), 4)), "{e:?}");
        // A path: no pixel has more than two neighbours.
        assert!(pixels(&s).iter().all(|&(x, y)| neighbours(&s, x, y) <= 2));
    }

    #[test]
    fn thick_bar_becomes_its_centre_line() {
        let m = mask(60, 30, &[(5, 8, 54, 20)]);
        let s = thin(&m);
        assert_thin(&s);
        assert_eq!(parts(&s), 1);
        let e = ends(&s);
        assert_eq!(e.len(), 2, "end points {e:?}");
        // Most of the line lies on the bar's centre row (14).
        let on_centre = pixels(&s).iter().filter(|p| p.1 == 14).count();
        assert!(on_centre >= 30, "{on_centre} pixels on row 14");
        assert!(e.iter().all(|&(x, _)| x <= 12 || x >= 47), "{e:?}");
    }

    #[test]
    fn two_by_two_block_and_ring_keep_their_topology() {
        // A 2x2 block survives as one part (the parallel test alone would erase it).
        let s = thin(&mask(6, 6, &[(2, 2, 3, 3)]));
        assert_eq!(parts(&s), 1);
        assert!(!pixels(&s).is_empty());
        // A square ring keeps its hole: the skeleton is a closed loop without end points.
        let ring = mask(
            30,
            30,
            &[
                (3, 3, 26, 8),
                (3, 21, 26, 26),
                (3, 3, 8, 26),
                (21, 3, 26, 26),
            ],
        );
        let s = thin(&ring);
        assert_thin(&s);
        assert_eq!(parts(&s), 1);
        assert!(ends(&s).is_empty(), "{:?}", ends(&s));
        assert_eq!(s.get_pixel(15, 15).0[0], 0);
    }

    #[test]
    fn yokoi_number_of_simple_patterns() {
        let mut p = [false; 8];
        p[6] = true; // W only: an end point
        assert_eq!(yokoi8(&p), 1);
        p[2] = true; // W and E: a line's middle
        assert_eq!(yokoi8(&p), 2);
        let mut c = [false; 8];
        c[0] = true; // N and E: a staircase corner
        c[2] = true;
        assert_eq!(yokoi8(&c), 1);
        assert_eq!(crossings(&c), 2);
    }
}
