//! One person on one frame (docs/method.md §2.8), as `mocap2d seed` and the `serve` page's
//! Detect button both ask for it: the detector's people, the one a [`Pick`] chooses, and its
//! landmarks read from the crop they call for, on the crop and its mirror averaged
//! ([`find`]); then those landmarks as a proposal for a skeleton's joints, its left and right
//! settled by the joints' tracked positions ([`propose`]).

use super::blazepose::{Detection, Landmark, Landmarks};
use super::engine::Engine;
use super::{choose, detect, landmarks, landmarks_both_ways, names, Pick};
use crate::error::Result;
use crate::geom::{JointBox, Point};
use image::RgbImage;

/// How many times the network looks again, from the crop its landmarks call for, after the
/// detector's rough box (each look on the crop and its mirror).
pub const LOOKS: usize = 1;

/// What [`find`] saw on a frame.
#[derive(Debug, Clone)]
pub struct Found {
    /// People the detector found.
    pub people: usize,
    /// The chosen person, and which of the picks chose them; `None` when no pick chose anyone.
    pub person: Option<(Detection, usize)>,
    /// The chosen person's landmarks.
    pub landmarks: Option<Landmarks>,
}

/// The person the first of `picks` that chooses anyone chooses on `img`, and their landmarks:
/// first from the detector's box, then [`LOOKS`] times from the crop the landmarks call for,
/// on the crop and its mirror averaged (the detector's box is rough).
pub fn find(engine: &mut dyn Engine, img: &RgbImage, picks: &[Pick]) -> Result<Found> {
    let found = detect(engine, img)?;
    let Some((person, k)) = picks
        .iter()
        .enumerate()
        .find_map(|(k, &p)| choose(&found, p).map(|d| (d, k)))
    else {
        return Ok(Found {
            people: found.len(),
            person: None,
            landmarks: None,
        });
    };
    let mut lm = landmarks(engine, img, &person.roi())?;
    for _ in 0..LOOKS {
        lm = landmarks_both_ways(engine, img, &lm.next_roi)?;
    }
    Ok(Found {
        people: found.len(),
        person: Some((person, k)),
        landmarks: Some(lm),
    })
}

/// The rectangle around `points` (top-left, bottom-right), as a pick of the person they are
/// on; `None` for no points.
pub fn around(points: &[Point]) -> Option<Pick> {
    let first = points.first()?;
    let (mut lo, mut hi) = (*first, *first);
    for p in points {
        lo = Point::new(lo.x.min(p.x), lo.y.min(p.y));
        hi = Point::new(hi.x.max(p.x), hi.y.max(p.y));
    }
    Some(Pick::Inside(lo, hi))
}

/// The side (px) of the square a person's joint is seeded with, by `mocap2d seed` and the
/// seeding page's Detect (docs/guide.md, "seed"): 15 % of the torso of the landmarks `points`,
/// at least [`crate::seed::MIN_BOX_PX`] and at most 200 px.
pub fn seed_side(points: &[Landmark]) -> u32 {
    ((super::torso(points) * 0.15).round() as u32).clamp(crate::seed::MIN_BOX_PX, 200)
}

/// The `side` px square seeded around `pos`, moved whole inside a `width` × `height` frame
/// (pixel centres on whole numbers), as [`seed_side`]'s users place it.
pub fn seed_box(pos: Point, side: u32, width: u32, height: u32) -> JointBox {
    let (w, h, half) = (width as f32, height as f32, side as f32 / 2.0);
    // (A frame narrower than the square: its centre, never a panic of `clamp`.)
    let inside = |v: f32, room: f32| v.clamp(half - 0.5, (room - half - 0.5).max(half - 0.5));
    JointBox {
        cx: inside(pos.x, w),
        cy: inside(pos.y, h),
        w: side,
        h: side,
        angle_rad: 0.0,
    }
}

/// One joint of a [`Proposal`].
#[derive(Debug, Clone, PartialEq)]
pub struct ProposedJoint {
    pub name: String,
    pub pos: Point,
    /// The network's visibility of its landmark; `None` for a joint the network has no landmark
    /// for, which keeps its tracked position.
    pub visibility: Option<f32>,
}

/// The network's landmarks as positions of a skeleton's joints.
#[derive(Debug, Clone, PartialEq)]
pub struct Proposal {
    pub joints: Vec<ProposedJoint>,
    /// True when left and right were swapped to follow the tracked body.
    pub mirrored: bool,
    /// Mean distance (px) of the landmark joints from their tracked positions, as the network
    /// names the sides and swapped.
    pub as_named_px: f32,
    pub swapped_px: f32,
}

/// The landmarks `points` as positions of the skeleton's joints `names`, tracked at `tracked`
/// (one a joint, the same order) on that frame, inside a `width` × `height` frame; `None` when
/// the skeleton is not a person's ([`names::human_joints`]).
///
/// A joint with no landmark keeps its tracked position. Left and right are settled by
/// continuity: when the landmarks of each joint's other side lie nearer the tracked body (in
/// mean) than their own, the sides are swapped — the network's sides flip when a person turns
/// her back, the track's do not.
pub fn propose(
    points: &[Landmark],
    names_: &[String],
    tracked: &[Point],
    width: u32,
    height: u32,
) -> Option<Proposal> {
    proposal(points, names_, tracked, true, width, height)
}

/// [`propose`] for a body that is not tracked (the seeding page of a bare clip): the sides are
/// the network's own, and a joint with no landmark keeps its position in `placed`.
pub fn propose_as_named(
    points: &[Landmark],
    names_: &[String],
    placed: &[Point],
    width: u32,
    height: u32,
) -> Option<Proposal> {
    proposal(points, names_, placed, false, width, height)
}

/// [`propose`], its sides swapped to follow `tracked` only when `follow` is set.
fn proposal(
    points: &[Landmark],
    names_: &[String],
    tracked: &[Point],
    follow: bool,
    width: u32,
    height: u32,
) -> Option<Proposal> {
    let map = names::human_joints(names_)?;
    let mean = |side: &dyn Fn(usize) -> usize| {
        let (mut sum, mut n) = (0f32, 0usize);
        for (l, t) in map.iter().zip(tracked) {
            if let Some(l) = l {
                sum += (points[side(*l)].pos - *t).norm();
                n += 1;
            }
        }
        sum / n.max(1) as f32
    };
    let as_named_px = mean(&|l| l);
    let swapped_px = mean(&names::mirror);
    let mirrored = follow && swapped_px < as_named_px;
    let (hi_x, hi_y) = (width.max(1) as f32 - 1.0, height.max(1) as f32 - 1.0);
    let joints = names_
        .iter()
        .zip(&map)
        .zip(tracked)
        .map(|((name, l), t)| match l {
            Some(l) => {
                let lm = points[if mirrored { names::mirror(*l) } else { *l }];
                ProposedJoint {
                    name: name.clone(),
                    // Inside the frame, where a key may lie.
                    pos: Point::new(lm.pos.x.clamp(0.0, hi_x), lm.pos.y.clamp(0.0, hi_y)),
                    visibility: Some(lm.visibility),
                }
            }
            None => ProposedJoint {
                name: name.clone(),
                pos: *t,
                visibility: None,
            },
        })
        .collect();
    Some(Proposal {
        joints,
        mirrored,
        as_named_px,
        swapped_px,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::blazepose::LANDMARKS;

    /// 33 landmarks, each at (10 i, 5 i), the left ones' visibility 0.9, the rest 0.6.
    fn points() -> Vec<Landmark> {
        (0..LANDMARKS)
            .map(|i| Landmark {
                pos: Point::new(10.0 * i as f32, 5.0 * i as f32),
                visibility: if names::LANDMARK_NAMES[i].starts_with("left") {
                    0.9
                } else {
                    0.6
                },
                presence: 1.0,
            })
            .collect()
    }

    fn skeleton() -> Vec<String> {
        [
            "pelvis",
            "shoulder_l",
            "shoulder_r",
            "hip_l",
            "hip_r",
            "elbow_l",
            "elbow_r",
            "knee_l",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect()
    }

    fn at(l: usize) -> Point {
        Point::new(10.0 * l as f32, 5.0 * l as f32)
    }

    #[test]
    fn joints_take_their_landmarks_and_a_joint_with_none_keeps_its_track() {
        let names_ = skeleton();
        // Tracked a few px off the landmarks named for each joint.
        let tracked: Vec<Point> = [None, Some(11), Some(12), Some(23), Some(24), Some(13)]
            .iter()
            .chain(&[Some(14), Some(25)])
            .map(|l| {
                l.map_or(Point::new(7.0, 8.0), |l| {
                    at(l) + crate::geom::Vector::new(3.0, -2.0)
                })
            })
            .collect();
        let p = propose(&points(), &names_, &tracked, 1000, 1000).unwrap();
        assert!(!p.mirrored, "{p:?}");
        assert_eq!(p.joints[0].pos, Point::new(7.0, 8.0), "pelvis: no landmark");
        assert_eq!(p.joints[0].visibility, None);
        assert_eq!(p.joints[1].pos, at(11), "shoulder_l");
        assert_eq!(p.joints[1].visibility, Some(0.9));
        assert_eq!(p.joints[6].pos, at(14), "elbow_r");
        assert_eq!(p.joints[6].visibility, Some(0.6));
    }

    /// The skeleton's joints on the landmarks of their other side (the body with its sides the
    /// other way round from the network's naming), the pelvis at (7, 8).
    fn swapped_body() -> Vec<Point> {
        [None, Some(12), Some(11), Some(24), Some(23), Some(14)]
            .iter()
            .chain(&[Some(13), Some(26)])
            .map(|l| l.map_or(Point::new(7.0, 8.0), at))
            .collect()
    }

    #[test]
    fn sides_follow_the_tracked_body_when_the_network_has_them_swapped() {
        let names_ = skeleton();
        let p = propose(&points(), &names_, &swapped_body(), 1000, 1000).unwrap();
        assert!(p.mirrored && p.swapped_px < p.as_named_px, "{p:?}");
        assert_eq!(
            p.joints[1].pos,
            at(12),
            "shoulder_l takes the right shoulder"
        );
        assert_eq!(p.joints[7].pos, at(26), "knee_l takes the right knee");
        assert_eq!(p.joints[7].visibility, Some(0.6));
    }

    #[test]
    fn a_bare_clips_proposal_keeps_the_networks_sides() {
        let names_ = skeleton();
        // Placed the other way round: the sides are kept all the same.
        let p = propose_as_named(&points(), &names_, &swapped_body(), 1000, 1000).unwrap();
        assert!(!p.mirrored && p.swapped_px < p.as_named_px, "{p:?}");
        assert_eq!(
            p.joints[1].pos,
            at(11),
            "shoulder_l takes the left shoulder"
        );
        assert_eq!(
            p.joints[0].pos,
            Point::new(7.0, 8.0),
            "pelvis stays where placed"
        );
    }

    #[test]
    fn a_seed_box_lies_whole_inside_the_frame() {
        let b = seed_box(Point::new(1.0, 98.0), 21, 200, 100);
        assert_eq!((b.cx, b.cy, b.w, b.h), (10.0, 89.0, 21, 21));
        assert!(b.inside(200, 100), "{b:?}");
        let c = seed_box(Point::new(50.0, 40.0), 21, 200, 100);
        assert_eq!((c.cx, c.cy), (50.0, 40.0), "a box inside stays");
    }

    #[test]
    fn a_proposal_stays_inside_the_frame_and_a_flys_skeleton_gets_none() {
        let names_ = skeleton();
        let tracked = vec![Point::new(1.0, 1.0); names_.len()];
        let p = propose(&points(), &names_, &tracked, 200, 100).unwrap();
        for j in &p.joints {
            assert!(
                (0.0..=199.0).contains(&j.pos.x) && (0.0..=99.0).contains(&j.pos.y),
                "{j:?}"
            );
        }
        let fly: Vec<String> = ["thorax", "head", "wingL", "wingR", "forelegL4", "forelegR4"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        assert!(propose(&points(), &fly, &[Point::origin(); 6], 200, 100).is_none());
    }

    #[test]
    fn around_is_the_rectangle_of_the_points() {
        let pick = around(&[
            Point::new(5.0, 9.0),
            Point::new(1.0, 20.0),
            Point::new(3.0, 2.0),
        ]);
        assert_eq!(
            pick,
            Some(Pick::Inside(Point::new(1.0, 2.0), Point::new(5.0, 20.0)))
        );
        assert_eq!(around(&[]), None);
    }
}
