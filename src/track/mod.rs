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
    /// How much noisier a poor match is than a clean one: the measurement variance is
    /// `meas_sigma_px² · (1 + low_score_noise · ratio²)`, ratio = cost / distinctiveness.
    pub low_score_noise: f32,
    /// Random jerk of the motion model (px/frame³).
    pub jerk_sigma: f32,
    /// Prior speed uncertainty at the seed frame (px/frame).
    pub speed_sigma: f32,
    /// A match whose colour cost exceeds this share of the joint's distinctiveness (the cost of
    /// its template a few pixels off the seed position) is taken as occlusion.
    pub occlusion_ratio: f32,
    /// Smallest distinctiveness (normalised colour cost) a joint is given.
    pub cost_floor: f32,
    /// A match that makes its bone longer or shorter than its recent length by more than this
    /// share is rejected as a mismatch (the joint is then treated as hidden).
    pub bone_tolerance: f32,
    /// A hidden joint found on the circle around its parent with a colour cost under this share
    /// of its distinctiveness is taken as seen again (re-acquired).
    pub reacquire_ratio: f32,
    /// Whether a root joint's rectangle turns with the bone to its first child (otherwise it
    /// keeps its seed orientation; a root's child is often the least reliable reference).
    pub rotate_roots: bool,
    /// Frames in a row hidden before the status turns from `occluded` to `lost`.
    pub lost_after_frames: u32,
}

impl Default for TrackParams {
    fn default() -> Self {
        TrackParams {
            search_min_px: 8.0,
            search_max_px: 48.0,
            search_sigmas: 3.0,
            geo_weight: 0.02,
            anchor_weight: 0.5,
            update_rate: 0.15,
            meas_sigma_px: 0.7,
            jerk_sigma: 4.0,
            low_score_noise: 8.0,
            speed_sigma: 10.0,
            occlusion_ratio: 0.8,
            cost_floor: 0.004,
            bone_tolerance: 0.3,
            reacquire_ratio: 0.3,
            rotate_roots: false,
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
    /// The template source: `anchor_weight`·anchor + the rest running, refreshed whenever
    /// `running` changes.
    appearance: Patch,
    /// Joint whose direction from (or to) this one defines the rectangle's rotation.
    reference: Option<(usize, bool)>,
    /// Direction (radians) of the reference bone on the seed frame, minus the seed angle.
    seed_dir: f32,
    /// Distinctiveness: mean colour cost of the seed template 3 px off the seed position on
    /// the seed frame. Match costs are judged against it.
    distinct_cost: f32,
    hidden_run: u32,
    last: JointEstimate,
    /// Recent length (px) of the bone from the parent (EMA over frames where both are seen).
    bone_len: f32,
    /// Direction (radians, unwrapped) of the bone from the parent on the last frame.
    bone_dir: f32,
    /// Recent turn rate of that bone (radians/frame), extrapolated while the joint is hidden.
    bone_turn: f32,
}

/// Mean normalised colour cost of the seed template placed 3 px off the seed centre in 8
/// directions on the seed frame, at least `floor`: how different a near miss looks.
fn distinctiveness(seed_frame: &RgbImage, anchor: &Patch, b: JointBox, floor: f32) -> f32 {
    let t = Template::from_patch(anchor, b.angle_rad, b.w as usize, b.h as usize);
    let (fw, fh) = (seed_frame.width() as i64, seed_frame.height() as i64);
    let norm = t.cost_norm();
    let x0 = (b.cx - (b.w as f32 - 1.0) / 2.0).round() as i64;
    let y0 = (b.cy - (b.h as f32 - 1.0) / 2.0).round() as i64;
    let mut sum = 0.0;
    let mut n = 0;
    for (dx, dy) in [
        (-3, 0),
        (3, 0),
        (0, -3),
        (0, 3),
        (-2, -2),
        (2, 2),
        (-2, 2),
        (2, -2),
    ] {
        let (x, y) = (x0 + dx, y0 + dy);
        if x >= 0 && y >= 0 && x + b.w as i64 <= fw && y + b.h as i64 <= fh {
            sum += search::ssd(seed_frame, &t, x as usize, y as usize, u64::MAX) as f64 / norm;
            n += 1;
        }
    }
    if n == 0 {
        return floor;
    }
    ((sum / n as f64) as f32).max(floor)
}

/// Looks for joint `j` on the circle of its bone's recent length around its parent at
/// `parent_pos`, every 5°, with the template turned to each direction, then refines the best
/// spot with a small window search. Returns the position (px) and its normalised colour cost.
fn circle_search(frame: &RgbImage, j: &JointState, parent_pos: Point, gain: f32) -> (Point, f32) {
    let appearance = &j.appearance;
    let mut best = (parent_pos, f32::INFINITY, 0.0f32);
    for k in 0..72 {
        let dir = (k as f32) * std::f32::consts::PI / 36.0;
        let at = parent_pos + crate::geom::Vector::new(dir.cos(), dir.sin()) * j.bone_len;
        let angle = dir - j.seed_dir;
        let t = Template::from_patch_gain(appearance, angle, j.w as usize, j.h as usize, gain);
        let m = search::search(frame, &t, at, 1.0, 0.0);
        if m.colour_cost < best.1 {
            best = (m.pos, m.colour_cost, angle);
        }
    }
    let t = Template::from_patch_gain(appearance, best.2, j.w as usize, j.h as usize, gain);
    let m = search::search(frame, &t, best.0, 3.0, 0.0);
    (m.pos, m.colour_cost)
}

/// Tracks all joints of a seed file frame by frame.
pub struct Tracker {
    params: TrackParams,
    parents: Vec<Option<usize>>,
    /// Joints with parents before children.
    order: Vec<usize>,
    children: Vec<Vec<usize>>,
    /// Scratch: each joint's position on the previous frame and its distinctiveness.
    last_pos: Vec<Point>,
    distinct: Vec<f32>,
    /// Brightness gain of the seed frame over the clean plate.
    seed_gain: f32,
    joints: Vec<JointState>,
    background: Option<Background>,
}

impl Tracker {
    /// Starts tracking from the seed rectangles on `seed_frame`.
    pub fn new(
        params: TrackParams,
        seeds: &Seeds,
        seed_frame: &RgbImage,
        background: Option<Background>,
    ) -> Self {
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
                    None if params.rotate_roots => sk.children(i).first().map(|&c| (c, false)),
                    None => None,
                };
                let dir = |r: Option<(usize, bool)>| match r {
                    Some((p, true)) => direction(centres[p], centres[i]),
                    Some((c, false)) => direction(centres[i], centres[c]),
                    None => 0.0,
                };
                let side = patch_side(b.w, b.h);
                let anchor = Patch::extract(
                    seed_frame,
                    background.as_ref(),
                    b.centre(),
                    b.angle_rad,
                    side,
                    side,
                );
                let distinct_cost = distinctiveness(seed_frame, &anchor, b, params.cost_floor);
                JointState {
                    kalman: Kalman::new(
                        b.centre(),
                        params.speed_sigma,
                        params.speed_sigma / 2.0,
                        params.jerk_sigma,
                    ),
                    w: b.w,
                    h: b.h,
                    running: anchor.clone(),
                    appearance: anchor.clone(),
                    anchor,
                    reference,
                    seed_dir: dir(reference) - b.angle_rad,
                    distinct_cost,
                    hidden_run: 0,
                    bone_len: sk.parents[i].map_or(0.0, |p| (centres[i] - centres[p]).norm()),
                    bone_dir: sk.parents[i].map_or(0.0, |p| direction(centres[p], centres[i])),
                    bone_turn: 0.0,
                    last: JointEstimate {
                        pos: b.centre(),
                        angle_rad: b.angle_rad,
                        score: 1.0,
                        status: Status::Seed,
                    },
                }
            })
            .collect();
        Tracker {
            params,
            parents: sk.parents.clone(),
            order: sk.topo_order(),
            children: (0..sk.len()).map(|i| sk.children(i)).collect(),
            last_pos: Vec::new(),
            seed_gain: background
                .as_ref()
                .map_or(1.0, |b| b.gain(seed_frame))
                .max(1e-3),
            distinct: Vec::new(),
            joints,
            background,
        }
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
        let pred_angles: Vec<f32> = (0..self.joints.len())
            .map(|i| self.angle_of(i, &preds, self.joints[i].last.angle_rad))
            .collect();
        // Flicker / exposure drift: scale templates by this frame's gain over the seed frame's.
        let gain = self
            .background
            .as_ref()
            .map_or(1.0, |b| b.gain(frame) / self.seed_gain);
        // 2. Match every joint independently (eq. 4.5–4.6).
        let matches: Vec<search::Match> = self
            .joints
            .par_iter()
            .zip(preds.par_iter().zip(pred_angles.par_iter()))
            .map(|(j, (&pred, &ang))| {
                let t =
                    Template::from_patch_gain(&j.appearance, ang, j.w as usize, j.h as usize, gain);
                let sigma = (j.kalman.cov[(0, 0)] + p.meas_sigma_px * p.meas_sigma_px).sqrt();
                let radius = (p.search_sigmas * sigma).clamp(p.search_min_px, p.search_max_px);
                search::search(frame, &t, pred, radius, p.geo_weight)
            })
            .collect();
        // 3. Decide seen or hidden, parents before children, and update the filters. A match
        //    counts when its colour cost is well under the joint's distinctiveness and it keeps
        //    the bone from its parent near its recent length; otherwise the joint is hidden and
        //    rides on its parent at the bone's recent length and extrapolated direction.
        let n = self.joints.len();
        self.last_pos = self.joints.iter().map(|j| j.last.pos).collect();
        self.distinct = self.joints.iter().map(|j| j.distinct_cost).collect();
        let (fw, fh) = (frame.width() as f32, frame.height() as f32);
        let mut pts = vec![Point::origin(); n];
        let mut decided = vec![(0.0f32, Status::Ok); n];
        for &i in &self.order {
            let parent = self.parents[i];
            let m = &matches[i];
            let j = &mut self.joints[i];
            let ratio = m.colour_cost / j.distinct_cost;
            let score = (1.0 - ratio).clamp(0.0, 1.0);
            let mut seen = ratio <= p.occlusion_ratio;
            // The bone check needs a parent that was clearly seen: a child must not be
            // rejected because its parent went wrong.
            if let (true, Some(par)) = (seen, parent.filter(|&q| decided[q].1 == Status::Ok)) {
                let len = (m.pos - pts[par]).norm();
                if (len - j.bone_len).abs() > (p.bone_tolerance * j.bone_len).max(3.0) {
                    seen = false;
                }
            }
            // A joint that is (or just went) hidden is looked for around its seen parent, at the
            // bone's recent length and any direction: limbs come back at new angles.
            let mut found = None;
            if let (false, Some(par)) = (seen, parent) {
                if matches!(decided[par].1, Status::Ok | Status::Low) {
                    let (at, cost) = circle_search(frame, j, pts[par], gain);
                    if cost <= p.reacquire_ratio * j.distinct_cost {
                        found = Some((at, cost / j.distinct_cost));
                    }
                }
            }
            let status;
            if let Some((at, r)) = found {
                j.hidden_run = 0;
                j.kalman.reset(
                    at,
                    crate::geom::Vector::zeros(),
                    p.meas_sigma_px,
                    p.speed_sigma,
                );
                decided[i].0 = (1.0 - r).clamp(0.0, 1.0);
                status = Status::Low;
            } else if seen {
                j.hidden_run = 0;
                // A poorer match is a noisier measurement (eq. 4.4's R grows with the cost).
                let var =
                    p.meas_sigma_px * p.meas_sigma_px * (1.0 + p.low_score_noise * ratio * ratio);
                j.kalman.update(m.pos, var);
                status = if score >= 0.5 {
                    Status::Ok
                } else {
                    Status::Low
                };
            } else {
                j.hidden_run += 1;
                status = if j.hidden_run > p.lost_after_frames {
                    Status::Lost
                } else {
                    Status::Occluded
                };
                match parent {
                    Some(par) => {
                        j.bone_turn *= 0.8;
                        let dir = j.bone_dir + j.bone_turn;
                        let at =
                            pts[par] + crate::geom::Vector::new(dir.cos(), dir.sin()) * j.bone_len;
                        let v = at - j.last.pos;
                        j.kalman.reset(at, v * 0.5, 1.0, p.speed_sigma);
                    }
                    None => {
                        // A hidden root follows its clearly seen children, keeping last
                        // frame's offsets to them; with none, it coasts on a damped filter.
                        let mut sum = crate::geom::Vector::zeros();
                        let mut k = 0.0;
                        for &c in &self.children[i] {
                            if matches[c].colour_cost <= 0.5 * p.occlusion_ratio * self.distinct[c]
                            {
                                sum += matches[c].pos.coords - (self.last_pos[c] - j.last.pos);
                                k += 1.0;
                            }
                        }
                        if k > 0.0 {
                            let at = Point::from(sum / k);
                            let v = at - j.last.pos;
                            j.kalman.reset(at, v, 1.0, p.speed_sigma);
                        } else {
                            j.kalman.damp(0.8, 0.0);
                        }
                    }
                }
            }
            j.kalman
                .clamp_to(Point::new(0.0, 0.0), Point::new(fw - 1.0, fh - 1.0));
            pts[i] = j.kalman.position();
            if let Some(par) = parent {
                let v = pts[i] - pts[par];
                let dir = unwrap_angle(j.bone_dir, direction(pts[par], pts[i]));
                if seen {
                    j.bone_turn = 0.5 * j.bone_turn + 0.5 * (dir - j.bone_dir);
                    if decided[par].1 != Status::Occluded && decided[par].1 != Status::Lost {
                        j.bone_len += 0.1 * (v.norm() - j.bone_len);
                    }
                }
                j.bone_dir = dir;
            }
            decided[i] = (if found.is_some() { decided[i].0 } else { score }, status);
        }
        let out: Vec<(usize, f32, Status)> = decided
            .iter()
            .enumerate()
            .map(|(i, &(s, st))| (i, s, st))
            .collect();
        // 4. Rotations from the new centres; running appearance on confident frames.
        let mut result = Vec::with_capacity(out.len());
        for (i, score, status) in out {
            let angle = self.angle_of(i, &pts, self.joints[i].last.angle_rad);
            let est = JointEstimate {
                pos: pts[i],
                angle_rad: angle,
                score,
                status,
            };
            result.push(est);
        }
        let bg = self.background.as_ref();
        let rate = p.update_rate;
        let anchor_weight = p.anchor_weight;
        self.joints
            .par_iter_mut()
            .zip(result.par_iter())
            .for_each(|(j, est)| {
                j.last = *est;
                if est.status == Status::Ok && est.score > 0.6 {
                    let side = j.anchor.w;
                    let mut fresh = Patch::extract(frame, bg, est.pos, est.angle_rad, side, side);
                    fresh.rgb.iter_mut().for_each(|v| *v /= gain);
                    j.running.blend(&fresh, rate);
                    j.appearance.clone_from(&j.running);
                    j.appearance.blend(&j.anchor, anchor_weight);
                }
            });
        result
    }
}
