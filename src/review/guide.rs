//! The seeding guide (docs/method.md §6): the character's silhouette on one frame (foreground
//! against the clean plate), its curve skeleton by Hilditch thinning ([`super::thin`]), and the
//! skeleton's end and branch points, numbered, as candidate joints; drawn over the frame, and
//! written as a starter seed file (`j0`, `j1`, … with parents along the skeleton) for the user
//! to rename, move and trim.

use super::draw;
use super::graph::{prune, Graph, NodeKind};
use super::thin::thin;
use crate::background::Background;
use crate::geom::JointBox;
use crate::seed::{SeedJoint, MIN_BOX_PX};
use image::{GrayImage, Luma, Rgb, RgbImage};
use imageproc::distance_transform::{distance_transform, Norm};
use imageproc::region_labelling::{connected_components, Connectivity};

/// Silhouette parts smaller than this many px are noise and dropped.
const MIN_PART_PX: u32 = 30;
/// Parts smaller than this share of the largest part are dropped.
const MIN_PART_SHARE: f32 = 0.05;
/// Holes smaller than this share of the silhouette's area are filled.
const MAX_HOLE_SHARE: f32 = 0.01;
/// A spur shorter than this many times the silhouette's half-width at its branch point (and
/// than [`MIN_SPUR_PX`]) comes from a bump of the outline, not a limb, and is pruned.
const SPUR_PER_HALF_WIDTH: f32 = 1.5;
const MIN_SPUR_PX: f32 = 4.0;

/// A candidate joint: an end or branch point of the skeleton.
#[derive(Debug, Clone, PartialEq)]
pub struct GuidePoint {
    /// Pixel of the point (px).
    pub at: (u32, u32),
    pub kind: NodeKind,
    /// Distance from the point to the silhouette's outline (px): half the local limb width.
    pub half_width: f32,
    /// Index of the point this one hangs from along the skeleton; `None` for a root.
    pub parent: Option<usize>,
}

/// What the guide found on a frame.
#[derive(Debug, Clone)]
pub struct Guide {
    /// Foreground silhouette, 255 inside.
    pub mask: GrayImage,
    /// Curve skeleton after pruning, 255 on it.
    pub skeleton: GrayImage,
    /// End and branch points, numbered in this order: each part of the silhouette (largest
    /// first) from its root (the branch point with the most paths, nearest the part's centre)
    /// breadth-first along the skeleton, so every parent comes before its children.
    pub points: Vec<GuidePoint>,
}

/// The cleaned foreground silhouette of `frame`: pixels farther from the clean plate than its
/// threshold, opened (specks go) and closed (cracks mend), parts below [`MIN_PART_PX`] or
/// [`MIN_PART_SHARE`] of the largest dropped, and small holes filled.
pub fn silhouette(frame: &RgbImage, bg: &Background) -> GrayImage {
    let (w, h) = frame.dimensions();
    let raw = GrayImage::from_fn(w, h, |x, y| {
        Luma([if bg.is_foreground(frame, x, y) {
            255
        } else {
            0
        }])
    });
    let m = imageproc::morphology::open(&raw, Norm::LInf, 1);
    let mut m = imageproc::morphology::close(&m, Norm::LInf, 2);
    // Keep the substantial parts.
    let labels = connected_components(&m, Connectivity::Eight, Luma([0]));
    let part_areas = areas(&labels);
    let largest = part_areas.iter().skip(1).copied().max().unwrap_or(0);
    let keep = |l: u32| {
        let a = part_areas[l as usize];
        l != 0 && a >= MIN_PART_PX && a as f32 >= MIN_PART_SHARE * largest as f32
    };
    for (x, y, l) in labels.enumerate_pixels() {
        if !keep(l.0[0]) {
            m.put_pixel(x, y, Luma([0]));
        }
    }
    // Fill small holes: background parts (4-connected) that do not reach the border.
    let total = m.pixels().filter(|p| p.0[0] != 0).count() as f32;
    let inv = GrayImage::from_fn(w, h, |x, y| Luma([255 - m.get_pixel(x, y).0[0]]));
    let holes = connected_components(&inv, Connectivity::Four, Luma([0]));
    let hole_areas = areas(&holes);
    let mut border = vec![false; hole_areas.len()];
    for (x, y, l) in holes.enumerate_pixels() {
        if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
            border[l.0[0] as usize] = true;
        }
    }
    for (x, y, l) in holes.enumerate_pixels() {
        let l = l.0[0] as usize;
        if l != 0 && !border[l] && (hole_areas[l] as f32) < MAX_HOLE_SHARE * total {
            m.put_pixel(x, y, Luma([255]));
        }
    }
    m
}

/// Pixel count of every label of a label image (index = label).
fn areas(labels: &image::ImageBuffer<Luma<u32>, Vec<u32>>) -> Vec<u32> {
    let max = labels.pixels().map(|p| p.0[0]).max().unwrap_or(0) as usize;
    let mut a = vec![0u32; max + 1];
    for p in labels.pixels() {
        a[p.0[0] as usize] += 1;
    }
    a
}

/// The guide of a silhouette: thins it, prunes spurs, numbers the end and branch points and
/// links each to its parent along the skeleton.
pub fn guide_of_mask(mask: GrayImage) -> Guide {
    let inv = GrayImage::from_fn(mask.width(), mask.height(), |x, y| {
        Luma([255 - mask.get_pixel(x, y).0[0]])
    });
    // Distance of every silhouette pixel to the nearest background pixel.
    let dist = distance_transform(&inv, Norm::L2);
    let half = |p: (u32, u32)| dist.get_pixel(p.0, p.1).0[0] as f32;
    let skeleton = prune(&thin(&mask), |b| {
        (SPUR_PER_HALF_WIDTH * half(b)).max(MIN_SPUR_PX)
    });
    let g = Graph::of(&skeleton);

    // Parts of the node graph, largest silhouette part first.
    let labels = connected_components(&mask, Connectivity::Eight, Luma([0]));
    let part_area = areas(&labels);
    let part = |n: usize| labels.get_pixel(g.nodes[n].at.0, g.nodes[n].at.1).0[0];
    let mut order: Vec<usize> = (0..g.nodes.len()).collect();
    order.sort_by_key(|&n| (std::cmp::Reverse(part_area[part(n) as usize]), part(n)));
    let mut points = Vec::new();
    let mut index = vec![usize::MAX; g.nodes.len()];
    for &start in &order {
        if index[start] != usize::MAX {
            continue;
        }
        let root = root_of(&g, start, &mask);
        let mut queue = std::collections::VecDeque::from([(root, None)]);
        index[root] = usize::MAX - 1;
        while let Some((n, parent)) = queue.pop_front() {
            index[n] = points.len();
            points.push(GuidePoint {
                at: g.nodes[n].at,
                kind: g.nodes[n].kind,
                half_width: half(g.nodes[n].at),
                parent,
            });
            let mut next: Vec<usize> = g
                .edges_at(n)
                .into_iter()
                .map(|e| g.other(e, n))
                .filter(|&m| index[m] == usize::MAX)
                .collect();
            next.sort_by_key(|&m| (g.nodes[m].at.1, g.nodes[m].at.0));
            next.dedup();
            for m in next {
                index[m] = usize::MAX - 1;
                queue.push_back((m, Some(index[n])));
            }
        }
    }
    Guide {
        mask,
        skeleton,
        points,
    }
}

/// The root of the node-graph part holding `start`: its branch point with the most paths, ties
/// to the one nearest the part's centre of mass; an end point (the topmost) when it has none.
fn root_of(g: &Graph, start: usize, mask: &GrayImage) -> usize {
    let mut part = vec![start];
    let mut seen = std::collections::BTreeSet::from([start]);
    let mut i = 0;
    while i < part.len() {
        for e in g.edges_at(part[i]) {
            let m = g.other(e, part[i]);
            if seen.insert(m) {
                part.push(m);
            }
        }
        i += 1;
    }
    let (mut sx, mut sy, mut n) = (0.0f64, 0.0f64, 0.0f64);
    for (x, y, p) in mask.enumerate_pixels() {
        if p.0[0] != 0 {
            sx += x as f64;
            sy += y as f64;
            n += 1.0;
        }
    }
    let c = (sx / n.max(1.0), sy / n.max(1.0));
    let d = |k: usize| {
        let (x, y) = g.nodes[k].at;
        (x as f64 - c.0).powi(2) + (y as f64 - c.1).powi(2)
    };
    let key = |k: usize| {
        let branch = g.nodes[k].kind == NodeKind::Branch;
        let degree = g.edges_at(k).len();
        (
            branch,
            degree,
            std::cmp::Reverse((d(k) * 16.0) as u64),
            std::cmp::Reverse(k),
        )
    };
    part.into_iter().max_by_key(|&k| key(k)).unwrap_or(start)
}

/// Draws the guide over `frame`: the silhouette tinted blue, the skeleton yellow, end points red
/// and branch points magenta, each labelled with its number, and a legend line.
pub fn render(frame: &RgbImage, guide: &Guide, frame_index: u64) -> RgbImage {
    let mut img = frame.clone();
    let scale = (img.height() / 360).max(1);
    for (x, y, p) in guide.mask.enumerate_pixels() {
        if p.0[0] != 0 {
            draw::tint(&mut img, x, y, Rgb([40, 90, 255]), 0.35);
        }
    }
    let yellow = Rgb([255, 230, 0]);
    for (x, y, p) in guide.skeleton.enumerate_pixels() {
        if p.0[0] != 0 {
            for (dx, dy) in [(0, 0), (1, 0), (0, 1)] {
                let (px, py) = (x + dx, y + dy);
                if px < img.width() && py < img.height() && (scale > 1 || (dx, dy) == (0, 0)) {
                    img.put_pixel(px, py, yellow);
                }
            }
        }
    }
    for (i, p) in guide.points.iter().enumerate() {
        let (colour, r) = match p.kind {
            NodeKind::End => (Rgb([255, 40, 40]), 3),
            NodeKind::Branch => (Rgb([255, 0, 255]), 4),
        };
        let at = (p.at.0 as f32, p.at.1 as f32);
        draw::dot(&mut img, at, r * scale as i32, colour);
        let off = (r + 2) * scale as i32;
        draw::label(
            &mut img,
            at.0 as i32 + off,
            at.1 as i32 - off - 4,
            &format!("j{i}"),
            colour,
            scale,
        );
    }
    let ends = guide
        .points
        .iter()
        .filter(|p| p.kind == NodeKind::End)
        .count();
    let legend = format!(
        "frame {frame_index}: {ends} ends (red), {} branches (magenta)",
        guide.points.len() - ends
    );
    draw::label(&mut img, 2, 2, &legend, draw::WHITE, scale);
    img
}

/// The starter seed joints of a guide for a `width × height` frame: one joint per point, named
/// `j<number>`, parent along the skeleton, a square rectangle as wide as the limb there (at
/// least `MIN_BOX_PX` and a 40th of the frame height, at most a 6th) moved and shrunk so it lies
/// inside the frame.
pub fn starter_joints(guide: &Guide, width: u32, height: u32) -> Vec<SeedJoint> {
    let lo = MIN_BOX_PX.max(height / 40);
    let hi = (height / 6).max(lo).min(width.min(height) - 1);
    guide
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut s = ((2.0 * p.half_width).round() as u32 + 1).clamp(lo, hi);
            if s.is_multiple_of(2) {
                s -= 1;
            }
            let s = s.max(MIN_BOX_PX);
            let half = s as f32 / 2.0;
            let fit = |c: f32, size: u32| c.clamp(half - 0.5, size as f32 - 0.5 - half);
            SeedJoint {
                name: format!("j{i}"),
                bbox: JointBox::centred(
                    fit(p.at.0 as f32, width),
                    fit(p.at.1 as f32, height),
                    s,
                    s,
                ),
                parent: p.parent.map(|k| format!("j{k}")),
                score: None,
                status: None,
                line: 0,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stick figure: a body bar with two legs and two arms (7 px thick limbs).
    fn figure() -> GrayImage {
        GrayImage::from_fn(80, 100, |x, y| {
            let body = (37..=43).contains(&x) && (20..=60).contains(&y);
            let arms = (15..=65).contains(&x) && (30..=36).contains(&y);
            let leg = |x0: i32| {
                let t = (y as i32 - 60) as f32 / 30.0;
                (0.0..=1.0).contains(&t) && ((x as i32 - 40) as f32 - t * x0 as f32).abs() <= 3.5
            };
            Luma([if body || arms || leg(-15) || leg(15) {
                255
            } else {
                0
            }])
        })
    }

    #[test]
    fn figure_gives_limb_ends_and_a_tree() {
        let g = guide_of_mask(figure());
        let ends: Vec<(u32, u32)> = g
            .points
            .iter()
            .filter(|p| p.kind == NodeKind::End)
            .map(|p| p.at)
            .collect();
        // Head, two hands and two feet.
        assert_eq!(ends.len(), 5, "{:?}", g.points);
        let near = |q: (u32, u32)| {
            ends.iter().any(|p| {
                (p.0 as i32 - q.0 as i32).abs() <= 6 && (p.1 as i32 - q.1 as i32).abs() <= 6
            })
        };
        for tip in [(40, 20), (15, 33), (65, 33), (25, 90), (55, 90)] {
            assert!(near(tip), "no end near {tip:?}: {ends:?}");
        }
        // Exactly one root; every parent precedes its child.
        assert_eq!(g.points.iter().filter(|p| p.parent.is_none()).count(), 1);
        for (i, p) in g.points.iter().enumerate() {
            if let Some(k) = p.parent {
                assert!(k < i);
            }
        }
        assert_eq!(g.points[0].kind, NodeKind::Branch);
        let joints = starter_joints(&g, 80, 100);
        let text = crate::seed::to_toml(0, &joints, "starter");
        let back = crate::seed::parse_seeds(&text, std::path::Path::new("s.toml")).unwrap();
        back.check_against_clip(std::path::Path::new("s.toml"), 80, 100, Some(1))
            .unwrap();
        assert_eq!(back.joints.len(), g.points.len());
    }
}
