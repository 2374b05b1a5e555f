//! Joint tracking (METHOD.md §2): per frame and joint, predict the centre with a
//! constant-acceleration Kalman filter ([`kalman`]), rotate the joint's template with its bone
//! ([`template`]), search a window sized by the filter's uncertainty for the lowest mixed
//! colour + geometric cost ([`search`]), then decide from the evidence whether the joint was
//! seen (`ok`/`low`) or hidden (`occluded`/`lost`).
//!
//! Drift control: the template is a blend of the seed appearance (the anchor, never changed) and
//! a running appearance updated slowly on confident frames only.

pub mod kalman;
pub mod search;
pub mod template;

use crate::background::Background;
use crate::geom::{direction, unwrap_angle, JointBox, Point};
use crate::seed::Seeds;
use image::RgbImage;
use kalman::Kalman;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use template::{patch_side, Patch, Template};

/// Tracking parameters (all recorded in `run.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackParams {
    /// Smallest search radius (px).
    pub search_min_px: f32,
    /// Largest search radius (px).
    pub search_max_px: f32,
    /// Search radius in standard deviations of the predicted position.
    pub search_sigmas: f32,
    /// W_g of eq. 4.5 relative to the normalised colour cost (distance in search radii).
    pub geo_weight: f32,
    /// Weight of the seed appearance (anchor) in the template; the rest is the running one.
    pub anchor_weight: f32,
    /// Blend rate of the running appearance on confident frames.
    pub update_rate: f32,
    /// Measurement standard deviation of a clean match (px).
    pub meas_sigma_px: f32,
    /// Random jerk of the motion model (px/frame³).
    pub jerk_sigma: f32,
    /// Prior speed uncertainty at the seed frame (px/frame).
    pub speed_sigma: f32,
    /// A match whose colour cost exceeds this many times the joint's typical cost is occlusion.
    pub occlusion_ratio: f32,
    /// Colour cost floor (normalised) under which any match is as good as the typical one.
    pub cost_floor: f32,
    /// Frames in a row hidden before the status turns from `occluded` to `lost`.
    pub lost_after_frames: u32,
}

impl Default for TrackParams {
    fn default() -> Self {
        TrackParams {
            search_min_px: 4.0,
            search_max_px: 48.0,
            search_sigmas: 3.0,
            geo_weight: 0.02,
            anchor_weight: 0.5,
            update_rate: 0.15,
            meas_sigma_px: 0.7,
            jerk_sigma: 1.5,
            speed_sigma: 10.0,
            occlusion_ratio: 4.0,
            cost_floor: 0.003,
            lost_after_frames: 30,
        }
    }
}

/// What the tracker concluded about a joint on a frame (the `status` column of `tracks.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// The seed frame: position given by the user.
    Seed,
    /// Matched with a cost close to the joint's typical cost.
    Ok,
    /// Matched, but the cost is high: worth a look.
    Low,
    /// Colour evidence collapsed; the position follows the prediction.
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
}

/// One joint on one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointEstimate {
    /// Rectangle centre (px).
    pub pos: Point,
    /// Rotation of the rectangle from its seed pose (radians, unwrapped).
    pub angle_rad: f32,
    /// Match confidence in [0, 1].
    pub score: f32,
    pub status: Status,
}

/// Per-joint tracker state.
#[derive(Debug, Clone)]
struct JointState {
    kalman: Kalman,
    w: u32,
    h: u32,
    anchor: Patch,
    running: Patch,
    /// Joint whose direction from (or to) this one defines the rectangle's rotation.
    reference: Option<(usize, bool)>,
    /// Direction (radians) of the reference bone on the seed frame, minus the seed angle.
    seed_dir: f32,
    /// Running typical colour cost on confident frames.
    typical_cost: Option<f32>,
    hidden_run: u32,
    last: JointEstimate,
}

/// Tracks all joints of a seed file frame by frame.
pub struct Tracker {
    params: TrackParams,
    joints: Vec<JointState>,
    background: Option<Background>,
}

impl Tracker {
    /// Starts tracking from the seed rectangles on `seed_frame`.
    pub fn new(params: TrackParams, seeds: &Seeds, seed_frame: &RgbImage, background: Option<Background>) -> Self {
        let sk = &seeds.skeleton;
        let centres: Vec<Point> = seeds.joints.iter().map(|j| j.bbox.centre()).collect();
        let joints = seeds
            .joints
            .iter()
            .enumerate()
            .map(|(i, sj)| {
                let b: JointBox = sj.bbox;
                // A joint rotates with the bone from its parent; a root with the bone to its
                // first child; a lone joint does not rotate.
                let reference = match sk.parents[i] {
                    Some(p) => Some((p, true)),
                    None => sk.children(i).first().map(|&c| (c, false)),
                };
                let dir = |r: Option<(usize, bool)>| match r {
                    Some((p, true)) => direction(centres[p], centres[i]),
                    Some((c, false)) => direction(centres[i], centres[c]),
                    None => 0.0,
                };
                let side = patch_side(b.w, b.h);
                let anchor = Patch::extract(seed_frame, background.as_ref(), b.centre(), b.angle_rad, side, side);
                JointState {
                    kalman: Kalman::new(b.centre(), params.speed_sigma, params.speed_sigma / 2.0, params.jerk_sigma),
                    w: b.w,
                    h: b.h,
                    running: anchor.clone(),
                    anchor,
                    reference,
                    seed_dir: dir(reference) - b.angle_rad,
                    typical_cost: None,
                    hidden_run: 0,
                    last: JointEstimate { pos: b.centre(), angle_rad: b.angle_rad, score: 1.0, status: Status::Seed },
                }
            })
            .collect();
        Tracker { params, joints, background }
    }

    /// The estimates of the last processed frame (the seed frame right after `new`).
    pub fn current(&self) -> Vec<JointEstimate> {
        self.joints.iter().map(|j| j.last).collect()
    }

    /// Rotation (radians) of joint `i` from its seed pose given all centres, unwrapped near `prev`.
    fn angle_of(&self, i: usize, pts: &[Point], prev: f32) -> f32 {
        let j = &self.joints[i];
        let d = match j.reference {
            Some((p, true)) => direction(pts[p], pts[i]),
            Some((c, false)) => direction(pts[i], pts[c]),
            None => return prev,
        };
        unwrap_angle(prev, d - j.seed_dir)
    }

    /// Tracks one frame (the frame after the previous one) and returns every joint's estimate,
    /// in seed-file order.
    pub fn step(&mut self, frame: &RgbImage) -> Vec<JointEstimate> {
        let p = &self.params;
        // 1. Predict every joint (eq. 4.3) and its rotation from the predicted bone.
        let preds: Vec<Point> = self.joints.iter_mut().map(|j| j.kalman.predict()).collect();
        let pred_angles: Vec<f32> =
            (0..self.joints.len()).map(|i| self.angle_of(i, &preds, self.joints[i].last.angle_rad)).collect();
        // 2. Match every joint independently (eq. 4.5–4.6).
        let matches: Vec<search::Match> = self
            .joints
            .par_iter()
            .zip(preds.par_iter().zip(pred_angles.par_iter()))
            .map(|(j, (&pred, &ang))| {
                let mut appearance = j.running.clone();
                appearance.blend(&j.anchor, p.anchor_weight);
                let t = Template::from_patch(&appearance, ang, j.w as usize, j.h as usize);
                let sigma = (j.kalman.cov[(0, 0)] + p.meas_sigma_px * p.meas_sigma_px).sqrt();
                let radius = (p.search_sigmas * sigma).clamp(p.search_min_px, p.search_max_px);
                search::search(frame, &t, pred, radius, p.geo_weight)
            })
            .collect();
        // 3. Decide seen or hidden, update the filters.
        let mut pts = Vec::with_capacity(self.joints.len());
        let mut out = Vec::with_capacity(self.joints.len());
        for (i, (j, m)) in self.joints.iter_mut().zip(&matches).enumerate() {
            let typical = j.typical_cost.unwrap_or(m.colour_cost).max(p.cost_floor);
            let ratio = m.colour_cost / typical;
            let score = (1.0 - (ratio - 1.0).max(0.0) / (p.occlusion_ratio - 1.0)).clamp(0.0, 1.0);
            let status;
            if ratio > p.occlusion_ratio {
                j.hidden_run += 1;
                status = if j.hidden_run > p.lost_after_frames { Status::Lost } else { Status::Occluded };
                j.kalman.damp(0.9, 0.5);
            } else {
                j.hidden_run = 0;
                let var = p.meas_sigma_px * p.meas_sigma_px * ratio.max(1.0);
                j.kalman.update(m.pos, var);
                status = if score >= 0.5 { Status::Ok } else { Status::Low };
                if status == Status::Ok {
                    let c = j.typical_cost.map_or(m.colour_cost, |t| 0.9 * t + 0.1 * m.colour_cost);
                    j.typical_cost = Some(c);
                }
            }
            pts.push(j.kalman.position());
            out.push((i, score, status));
        }
        // 4. Rotations from the new centres; running appearance on confident frames.
        let mut result = Vec::with_capacity(out.len());
        for (i, score, status) in out {
            let angle = self.angle_of(i, &pts, self.joints[i].last.angle_rad);
            let est = JointEstimate { pos: pts[i], angle_rad: angle, score, status };
            result.push(est);
        }
        let bg = self.background.as_ref();
        let rate = p.update_rate;
        self.joints.par_iter_mut().zip(result.par_iter()).for_each(|(j, est)| {
            j.last = *est;
            if est.status == Status::Ok && est.score > 0.6 {
                let side = j.anchor.w;
                let fresh = Patch::extract(frame, bg, est.pos, est.angle_rad, side, side);
                j.running.blend(&fresh, rate);
            }
        });
        result
    }
}
