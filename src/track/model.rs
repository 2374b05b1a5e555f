//! The appearance model built from the seed frame: one [`Strip`] per bone (the pixels nearest
//! to it, out to the limb's edge and past its ends), one patch per lone joint, and which strips
//! touch which joint.

use super::pixels::{Pyramid, MAX_LEVELS};
use super::strip::{Extent, Shape, Strip, StripSpec};
use super::TrackParams;
use crate::background::Background;
use crate::geom::{Point, Vector};
use crate::seed::Seeds;
use image::RgbImage;

/// Which end of a strip a joint is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum End {
    Parent,
    Child,
    Patch,
}

/// The strips of a skeleton.
pub(super) struct Model {
    pub strips: Vec<Strip>,
    /// Strip of the bone ending at each joint (or of a lone joint's patch).
    pub strip_of: Vec<Option<usize>>,
    /// Strips touching each joint, and which end of them it is.
    pub touching: Vec<Vec<(usize, End)>>,
    /// The colour scale the strips start with (levels per channel).
    pub sigma: f32,
    /// Pyramid levels matched on (see [`pyramid_levels`]).
    pub levels: usize,
}

/// How many pyramid levels to match on for joint rectangles whose smaller side is `side` px:
/// as many as keep that side at least `coarse_px` px on the coarsest one (1 to
/// [`MAX_LEVELS`]): coarser than that, a limb is a blur of its neighbours.
pub(super) fn pyramid_levels(side: f32, coarse_px: f32) -> usize {
    let halvings = (side / coarse_px.max(1.0)).log2().floor();
    (1 + halvings.max(0.0) as usize).min(MAX_LEVELS)
}

/// Half-width (px) of the limb along the bone `p → c` on the seed frame: the median distance
/// from the axis to the first pixel `q` that `background(o, q)` says is not the limb (`o` the
/// axis point it is measured from), across the bone at a quarter, half and three quarters of
/// its length, both sides; at most `max`.
fn limb_radius(p: Point, c: Point, max: f32, background: &dyn Fn(Point, Point) -> bool) -> f32 {
    let d = c - p;
    let len = d.norm().max(1e-3);
    let n = Vector::new(-d.y, d.x) / len;
    let mut edges = Vec::with_capacity(6);
    for t in [0.25, 0.5, 0.75] {
        let o = p + d * t;
        for side in [-1.0, 1.0] {
            let mut v = 0.5;
            while v < max {
                let q = o + n * (side * v);
                if background(o, q) {
                    break;
                }
                v += 0.5;
            }
            edges.push(v.min(max));
        }
    }
    edges.sort_by(f32::total_cmp);
    0.5 * (edges[2] + edges[3])
}

/// Without a clean plate, a limb's edge on the seed frame is the first pixel across the bone
/// whose colour differs from the axis's by more than this (L1 over the three channels, 0–765):
/// a clear step, 30 levels a channel. Without it, every strip of a run with no plate spanned
/// half its rectangle whatever the limb's width, and took the background beside a thin limb
/// for the limb (docs/NOTES.md, "Limbs measured by their edges").
const LIMB_EDGE_L1: u32 = 90;

/// The L1 colour distance between the seed frame's pixels nearest `a` and `b` (`None` when
/// either is outside the frame).
fn colour_step(frame: &RgbImage, a: Point, b: Point) -> Option<u32> {
    let px = |q: Point| {
        let (x, y) = (q.x.round(), q.y.round());
        (x >= 0.0 && y >= 0.0 && (x as u32) < frame.width() && (y as u32) < frame.height())
            .then(|| frame.get_pixel(x as u32, y as u32).0)
    };
    Some(crate::background::l1(px(a)?, px(b)?))
}

impl Model {
    /// Samples every bone of `seeds` (longer than 2 px) and every lone joint on `seed_frame`.
    /// With a background model, seed pixels that look like the plate carry no weight, limb
    /// widths are measured out to the background, and the colour scale starts at twice the
    /// clip's noise (the template carries the seed frame's noise too), at least
    /// `colour_sigma`.
    pub fn build(
        params: &TrackParams,
        seeds: &Seeds,
        seed_frame: &RgbImage,
        background: Option<&Background>,
    ) -> Model {
        let sk = &seeds.skeleton;
        let n = sk.len();
        let boxes = seeds.boxes();
        let centres: Vec<Point> = boxes.iter().map(|b| b.centre()).collect();
        let children: Vec<Vec<usize>> = (0..n).map(|i| sk.children(i)).collect();
        let side = boxes.iter().map(|b| b.w.min(b.h)).min().unwrap_or(1) as f32;
        let levels = pyramid_levels(side, params.coarse_box_px);
        let img = Pyramid::new(seed_frame, levels);
        let half_box = |j: usize| 0.5 * boxes[j].w.max(boxes[j].h) as f32;
        let bones: Vec<(usize, usize)> = sk
            .bones()
            .into_iter()
            .filter(|&(p, c)| (centres[c] - centres[p]).norm() >= 2.0)
            .collect();
        // How far the seed pixel nearest `(x, y)` is from the plate, as a share of the
        // foreground threshold (infinite without a plate or outside the frame).
        let plate_share = |x: f32, y: f32| match background {
            Some(bg) => {
                let (xi, yi) = (x.round(), y.round());
                if xi >= 0.0
                    && yi >= 0.0
                    && (xi as u32) < seed_frame.width()
                    && (yi as u32) < seed_frame.height()
                {
                    bg.distance(seed_frame, xi as u32, yi as u32) as f32 / bg.threshold as f32
                } else {
                    f32::INFINITY
                }
            }
            None => f32::INFINITY,
        };
        let looks_background = |x: f32, y: f32| plate_share(x, y) <= 1.0;
        let extents: Vec<Extent> = bones
            .iter()
            .map(|&(p, c)| {
                let max_half = params.bone_half_width * boxes[c].w.min(boxes[c].h) as f32;
                // The limb ends where the plate shows; with no plate, where the colour steps
                // away from the axis's.
                let r = match background {
                    Some(_) => limb_radius(centres[p], centres[c], max_half, &|_, q| {
                        looks_background(q.x, q.y)
                    }),
                    None => limb_radius(centres[p], centres[c], max_half, &|o, q| {
                        colour_step(seed_frame, o, q).is_none_or(|d| d > LIMB_EDGE_L1)
                    }),
                };
                let reach = r + params.edge_margin_px;
                let root = sk.parents[p].is_none();
                Extent {
                    a: centres[p],
                    b: centres[c],
                    ext_a: reach
                        * if root {
                            params.root_reach
                        } else {
                            params.joint_reach
                        },
                    ext_b: if children[c].is_empty() {
                        params.end_reach * half_box(c)
                    } else {
                        params.joint_reach * reach
                    },
                    half_width: reach.min(max_half),
                }
            })
            .collect();
        let noise = background.map_or(0.0, |b| b.noise_sigma());
        let sigma = params.colour_sigma.max(2.0 * noise);
        let spec = StripSpec {
            max_samples: params.max_samples,
            coarse_samples: params.coarse_samples,
            sigma,
            width_exponent: params.width_exponent,
        };
        let mut strips: Vec<Strip> = Vec::new();
        let mut strip_of = vec![None; n];
        for (bi, &(p, c)) in bones.iter().enumerate() {
            let others: Vec<Extent> = extents
                .iter()
                .enumerate()
                .filter(|&(k, _)| k != bi)
                .map(|(_, e)| *e)
                .collect();
            let shape = Shape::Bone;
            let s = Strip::sample(
                &img,
                shape,
                (p, c),
                extents[bi],
                &spec,
                &others,
                &plate_share,
            );
            if let Some(s) = s {
                strip_of[c] = Some(strips.len());
                strips.push(s);
            }
        }
        let linked: Vec<Extent> = strips.iter().map(|s| s.extent).collect();
        for (k, s) in strips.iter_mut().enumerate() {
            s.link(k, &linked);
        }
        if params.foreign_tolerance > 0.0 {
            let palettes: Vec<_> = strips.iter().map(|s| s.palette()).collect();
            for (k, s) in strips.iter_mut().enumerate() {
                s.doubt_foreign(k, &palettes, params.foreign_tolerance);
            }
        }
        for j in 0..n {
            if sk.parents[j].is_some() || !children[j].is_empty() {
                continue;
            }
            let b = boxes[j];
            let extent = Extent {
                a: centres[j],
                b: centres[j],
                ext_a: 0.5 * (b.h as f32 - 1.0),
                ext_b: 0.5 * (b.h as f32 - 1.0),
                half_width: 0.5 * (b.w as f32 - 1.0),
            };
            let s = Strip::sample(&img, Shape::Patch, (j, j), extent, &spec, &[], &plate_share);
            if let Some(s) = s {
                strip_of[j] = Some(strips.len());
                strips.push(s);
            }
        }
        let mut touching = vec![Vec::new(); n];
        for (si, s) in strips.iter().enumerate() {
            match s.shape {
                Shape::Bone => {
                    touching[s.parent].push((si, End::Parent));
                    touching[s.child].push((si, End::Child));
                }
                Shape::Patch => touching[s.parent].push((si, End::Patch)),
            }
        }
        Model {
            strips,
            strip_of,
            touching,
            sigma,
            levels,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coarser_levels_only_while_the_rectangles_stay_big_enough() {
        assert_eq!(pyramid_levels(4.0, 5.0), 1);
        assert_eq!(pyramid_levels(15.0, 5.0), 2);
        assert_eq!(pyramid_levels(21.0, 5.0), 3);
        assert_eq!(pyramid_levels(43.0, 5.0), 4);
        assert_eq!(pyramid_levels(400.0, 5.0), MAX_LEVELS);
    }

    #[test]
    fn without_a_plate_a_limb_ends_where_its_colour_steps() {
        // A vertical bar 9 px wide (x 46..=54), red on grey, with a faint texture inside.
        let frame = RgbImage::from_fn(100, 100, |x, y| {
            if (46..=54).contains(&x) {
                image::Rgb([200, 40 + ((x + y) % 3) as u8 * 5, 40])
            } else {
                image::Rgb([120, 120, 120])
            }
        });
        let (p, c) = (Point::new(50.0, 20.0), Point::new(50.0, 80.0));
        let edge = |o: Point, q: Point| colour_step(&frame, o, q).is_none_or(|d| d > LIMB_EDGE_L1);
        // 4.5 px to the last red pixel on one side, 5 on the other (probes every half pixel).
        assert_eq!(limb_radius(p, c, 20.0, &edge), 4.75);
        // Where nothing steps, the limb spans its whole allowance, as with no test at all.
        let flat = RgbImage::from_pixel(100, 100, image::Rgb([120, 120, 120]));
        let none = |o: Point, q: Point| colour_step(&flat, o, q).is_none_or(|d| d > LIMB_EDGE_L1);
        assert_eq!(limb_radius(p, c, 20.0, &none), 20.0);
    }
}
