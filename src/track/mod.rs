//! Joint tracking (docs/method.md §2), one frame at a time, by [`Tracker`]:
//!
//! 1. **Predict** every joint with constant-acceleration Kalman filters (§2.1,
//!    [`kalman`], [`motion`]): a root's position in the image, every other joint's bone
//!    direction and log length relative to its parent, so a swinging limb is predicted along its
//!    arc.
//! 2. **Search** (§2.3, [`locate`]): on coarse levels of an image [`pixels::Pyramid`], the
//!    whole body's translation, then down the skeleton each bone's angle and length, scored by
//!    the robust colour cost of its [`strip`] (its seed appearance, rotated and stretched with
//!    the bone) plus the distance from the prediction, over windows sized by the filters'
//!    uncertainty.
//! 3. **Refine** all joints at once, coarse level to full resolution, by Gauss–Newton on every
//!    bone's robust colour cost with the motion and bone-length priors ([`solve`]).
//! 4. **Judge** ([`hidden`]): the share of a bone's samples that fit near a joint says whether
//!    the joint is seen. A hidden joint (`occluded`) keeps its predicted place relative to its
//!    parent (or where two-bone inverse kinematics puts it between a seen parent and child), its
//!    filters coast, and every frame its bone is looked for all around its parent so that it is
//!    re-acquired when it shows again. Seen bones learn: their running appearance (anchored to
//!    the seed appearance, so it cannot drift away) and which seed pixels really move with them.
//!
//! Joints hidden for a while are filled afterwards by [`gapfill`] once they are seen again.
//! Conventions (px, radians clockwise on screen, frames) are [`crate::geom`]'s.

mod bodies;
mod exposure;
pub mod flow;
pub mod gapfill;
mod hidden;
pub mod kalman;
mod locate;
mod model;
mod motion;
mod params;
pub mod pixels;
mod redetect;
pub mod rooted;
pub mod scale;
pub mod search;
pub mod solve;
pub mod state;
pub mod strip;
mod tracker;

pub use params::{PoseMode, TrackParams};
pub use tracker::{Timings, Trace, Tracker};

use crate::geom::Point;
use serde::{Deserialize, Serialize};

/// What the tracker concluded about a joint on a frame (the `status` column of `tracks.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// The seed frame: position given by the user.
    Seed,
    /// Seen: most samples of its bones near it fit.
    Ok,
    /// Seen, but poorly (few samples fit, or its bone changed length sharply), or hidden itself
    /// but placed by a child's bone found whole (an elbow behind the torso placed by its
    /// forearm): worth a look.
    Low,
    /// Hidden: the position follows the prediction (and is filled afterwards if seen again).
    Occluded,
    /// Hidden for longer than `lost_after_frames`: the position is a guess.
    Lost,
}

impl Status {
    /// The word written to `tracks.csv`.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Seed => "seed",
            Status::Ok => "ok",
            Status::Low => "low",
            Status::Occluded => "occluded",
            Status::Lost => "lost",
        }
    }

    /// Every status, in the order the tracker state numbers them.
    pub const ALL: [Status; 5] = [
        Status::Seed,
        Status::Ok,
        Status::Low,
        Status::Occluded,
        Status::Lost,
    ];

    /// A word of `tracks.csv` and the segment files back to its status ([`Status::as_str`]).
    pub fn from_word(word: &str) -> Option<Status> {
        Status::ALL.into_iter().find(|s| s.as_str() == word)
    }

    /// Whether the joint was seen (a measurement) rather than inferred.
    pub fn seen(self) -> bool {
        matches!(self, Status::Seed | Status::Ok | Status::Low)
    }
}

/// One joint on one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointEstimate {
    /// Rectangle centre (px).
    pub pos: Point,
    /// Rotation of the rectangle from its seed pose (radians, clockwise on screen, unwrapped).
    pub angle_rad: f32,
    /// Confidence in [0, 1]: the share of the samples near the joint that fit.
    pub score: f32,
    pub status: Status,
}

impl JointEstimate {
    /// Whether the joint's own strips fit as an `ok` joint's do (`score` at least `ok_share`),
    /// whether or not its body fits as well (the body's part of the `ok` rule, docs/method.md
    /// §2.5): how far the tracker can be trusted over a span between keys is judged by this.
    pub fn fits_alone(&self, ok_share: f32) -> bool {
        match self.status {
            Status::Seed | Status::Ok => true,
            Status::Low => self.score >= ok_share,
            Status::Occluded | Status::Lost => false,
        }
    }
}
