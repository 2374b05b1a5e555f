//! Joint tracking (METHOD.md §2): per frame and joint, predict the centre with a
//! constant-acceleration Kalman filter ([`kalman`]), rotate the joint's template with its bone
//! ([`template`]), search a window sized by the filter's uncertainty for the lowest mixed
//! colour + geometric cost ([`search`]), then decide from the evidence whether the joint was
//! seen (`ok`/`low`) or hidden (`occluded`/`lost`).
//!
//! Drift control: the template is a blend of the seed appearance (the anchor, never changed) and
//! a running appearance updated slowly on confident frames only.

pub mod bone;
pub mod kalman;
pub mod search;
pub mod template;

use crate::background::Background;
use crate::geom::{direction, unwrap_angle, JointBox, Point};
use crate::seed::Seeds;
use image::RgbImage;
use bone::{BoneModel, End, Samples};
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
    /// W_g of eq. 4.5: the cost, in units of a joint's distinctiveness, of being one search
    /// radius away from the prediction.
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
    /// Half-width of a bone's appearance model across the bone, as a share of the smaller
    /// side of its end joints' rectangles.
    pub bone_half_width: f32,
    /// Bone stretch (share of the predicted length) that costs as much as `geo_weight` of a
    /// full search radius in eq. 4.5's geometric term.
    pub length_sigma: f32,
    /// Frames in a row hidden before the status turns from `occluded` to `lost`.
    pub lost_after_frames: u32,
}

impl Default for TrackParams {
    fn default() -> Self {
        TrackParams {
            search_min_px: 8.0,
            search_max_px: 48.0,
            search_sigmas: 3.0,
            geo_weight: 0.1,
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
            bone_half_width: 0.5,
            length_sigma: 0.25,
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
    /// Seed appearance of the bone from the parent to this joint (`None` for roots, and for
    /// bones too short or bare to sample: those joints are matched by their rectangle).
    bone: Option<BoneModel>,
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

/// Tracks all joints of a seed file frame by frame.
pub struct Tracker {
    params: TrackParams,
    parents: Vec<Option<usize>>,
    /// Joints with parents before children.
    order: Vec<usize>,
    children: Vec<Vec<usize>>,
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
        let bones = sk.bones();
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
                let bone = sk.parents[i].and_then(|par| {
                    let pb = seeds.joints[par].bbox;
                    let half_width = params.bone_half_width * (b.w.min(b.h).min(pb.w.min(pb.h))) as f32;
                    let leaf = sk.children(i).is_empty();
                    let ext = if leaf { 0.5 * b.w.max(b.h) as f32 } else { 0.0 };
                    BoneModel::new(
                        seed_frame,
                        background.as_ref(),
                        &centres,
                        &bones,
                        par,
                        i,
                        half_width,
                        ext,
                        params.cost_floor,
                    )
                });
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
                    bone,
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
            seed_gain: background
                .as_ref()
                .map_or(1.0, |b| b.gain(seed_frame))
                .max(1e-3),
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

    /// Colour measurement of joint `i` alone with its rotated joint template (joints without a
    /// bone model: lone joints and bones too short or too bare to sample). Returns the position
    /// and the cost as a share of the joint's distinctiveness.
    fn template_match(&self, frame: &RgbImage, i: usize, centre: Point, angle: f32, gain: f32) -> (Point, f32) {
        let p = &self.params;
        let j = &self.joints[i];
        let t = Template::from_patch_gain(&j.appearance, angle, j.w as usize, j.h as usize, gain);
        let radius = self.radius(i);
        let m = search::search(frame, &t, centre, radius, p.geo_weight * j.distinct_cost);
        (m.pos, m.colour_cost / j.distinct_cost)
    }

    /// Search radius (px) of joint `i` from its predicted uncertainty.
    fn radius(&self, i: usize) -> f32 {
        let p = &self.params;
        let j = &self.joints[i];
        let sigma = (j.kalman.cov[(0, 0)] + p.meas_sigma_px * p.meas_sigma_px).sqrt();
        (p.search_sigmas * sigma).clamp(p.search_min_px, p.search_max_px)
    }

    /// Cost (share of distinctiveness, averaged over bones) of joint `i` at `at` against the
    /// bones that touch it and whose other end is in `fixed` (`Some` position).
    fn joint_cost(
        &self,
        frame: &RgbImage,
        i: usize,
        at: Point,
        fixed: &[Option<Point>],
        gain: f32,
        coarse: bool,
    ) -> f32 {
        let mut sum = 0.0;
        let mut n = 0.0;
        if let (Some(b), Some(par)) = (&self.joints[i].bone, self.parents[i]) {
            if let Some(pp) = fixed[par] {
                sum += b.cost_end(frame, End::Child, at, pp, gain, coarse) / b.distinct;
                n += 1.0;
            }
        }
        for &c in &self.children[i] {
            if let (Some(b), Some(cp)) = (&self.joints[c].bone, fixed[c]) {
                sum += b.cost_end(frame, End::Parent, at, cp, gain, coarse) / b.distinct;
                n += 1.0;
            }
        }
        if n == 0.0 {
            f32::INFINITY
        } else {
            sum / n
        }
    }

    /// Cost of joint `i` at `at` as the hub of a star: the bone from its parent at `parent_at`
    /// (if any) and the bones to its children, each child moved with the joint (kept at its
    /// predicted offset `preds[c] − preds[i]`). Each bone's cost is taken in units of its
    /// distinctiveness; the result is their mean. The children pin the joint along its
    /// parent's bone, which a striped limb alone does not.
    #[allow(clippy::too_many_arguments)]
    fn star_cost(
        &self,
        frame: &RgbImage,
        i: usize,
        at: Point,
        parent_at: Option<Point>,
        preds: &[Point],
        gain: f32,
        coarse: bool,
    ) -> f32 {
        let mut sum = 0.0;
        let mut n = 0.0;
        if let (Some(b), Some(pp)) = (&self.joints[i].bone, parent_at) {
            sum += b.cost_end(frame, End::Child, at, pp, gain, coarse) / b.distinct;
            n += 1.0;
        }
        let d = at - preds[i];
        for &c in &self.children[i] {
            if let Some(b) = &self.joints[c].bone {
                sum += b.cost_rigid(frame, at, preds[c] + d - at, gain, Samples::of(coarse, true)) / b.distinct_near;
                n += 1.0;
            }
        }
        if n == 0.0 {
            f32::INFINITY
        } else {
            sum / n
        }
    }

    /// Grid step (px) for a search of `radius` px.
    fn grid_step(radius: f32) -> f32 {
        (radius / 8.0).clamp(1.0, 3.0)
    }

    /// Tracks one frame (the frame after the previous one) and returns every joint's estimate,
    /// in seed-file order.
    ///
    /// 1. Predict every joint (eq. 4.3).
    /// 2. Roots: move the root with its bones to its children (at their predicted offsets) as
    ///    one rigid star and keep the lowest summed bone cost.
    /// 3. Parents before children: lay the bone from the parent's measured position and search
    ///    the child end in a window sized by the filter (eq. 4.5–4.6 with bone costs). A joint
    ///    whose bone cost is too high, or whose bone stretches too far, is hidden: it is looked
    ///    for on the circle of its bone around the parent, and otherwise rides on the parent.
    /// 4. One refinement pass: each seen joint is moved to minimise the cost of all its bones.
    /// 5. Kalman update (eq. 4.4) with a noise that grows with the cost.
    pub fn step(&mut self, frame: &RgbImage) -> Vec<JointEstimate> {
        let p = self.params.clone();
        let n = self.joints.len();
        let preds: Vec<Point> = self.joints.iter_mut().map(|j| j.kalman.predict()).collect();
        let pred_angles: Vec<f32> = (0..n)
            .map(|i| self.angle_of(i, &preds, self.joints[i].last.angle_rad))
            .collect();
        let gain = self
            .background
            .as_ref()
            .map_or(1.0, |b| b.gain(frame) / self.seed_gain);
        // Measured positions (None: hidden) and cost ratios.
        let mut meas: Vec<Option<Point>> = vec![None; n];
        let mut ratio = vec![f32::INFINITY; n];
        let mut reacquired = vec![false; n];
        let mut pts = preds.clone();
        for &i in &self.order {
            match self.parents[i] {
                None => {
                    let has_bones = self.children[i].iter().any(|&c| self.joints[c].bone.is_some());
                    let (at, r) = if has_bones {
                        let radius = self.radius(i);
                        let f = bone::minimise(preds[i], radius, Self::grid_step(radius), |q, co| {
                            self.star_cost(frame, i, q, None, &preds, gain, co)
                        });
                        (f.pos, f.contrast)
                    } else {
                        self.template_match(frame, i, preds[i], pred_angles[i], gain)
                    };
                    ratio[i] = r;
                    if r <= p.occlusion_ratio {
                        meas[i] = Some(at);
                        pts[i] = at;
                    }
                }
                Some(par) => {
                    let centre = pts[par] + (preds[i] - preds[par]);
                    let radius = self.radius(i);
                    let j = &self.joints[i];
                    let (at, r) = match &j.bone {
                        None => self.template_match(frame, i, centre, pred_angles[i], gain),
                        Some(b) => {
                            let pp = pts[par];
                            // Eq. 4.5's geometric term, in units of the bone's distinctiveness:
                            // distance from the prediction in search radii, and stretch of the
                            // bone from its predicted length in shares of `length_sigma`.
                            let pred_len = (preds[i] - preds[par]).norm().max(1.0);
                            let (wg, ls) = (p.geo_weight * b.distinct, p.length_sigma);
                            let geo = move |q: Point| {
                                let d2 = (q - centre).norm_squared() / (radius * radius);
                                let s = ((q - pp).norm() / pred_len - 1.0) / ls;
                                wg * (d2 + s * s)
                            };
                            let f = bone::minimise(centre, radius, Self::grid_step(radius), |q, co| {
                                self.star_cost(frame, i, q, Some(pp), &preds, gain, co)
                                    + geo(q) / b.distinct
                            });
                            (f.pos, f.contrast)
                        }
                    };
                    ratio[i] = r;
                    let mut seen = r <= p.occlusion_ratio;
                    if seen && meas[par].is_some() {
                        let len = (at - pts[par]).norm();
                        if (len - j.bone_len).abs() > (p.bone_tolerance * j.bone_len).max(3.0) {
                            seen = false;
                        }
                    }
                    if seen {
                        meas[i] = Some(at);
                        pts[i] = at;
                        continue;
                    }
                    // Hidden: look on the circle of the bone around a seen parent.
                    if let (Some(b), Some(pp)) = (&j.bone, meas[par]) {
                        let (q, c) = self.circle_search(frame, b, pp, j.bone_len, gain);
                        if c / b.distinct <= p.reacquire_ratio {
                            meas[i] = Some(q);
                            pts[i] = q;
                            ratio[i] = c / b.distinct;
                            reacquired[i] = true;
                            continue;
                        }
                    }
                    // Ride on the parent at the bone's recent length and extrapolated turn.
                    let dir = j.bone_dir + 0.8 * j.bone_turn;
                    pts[i] = pts[par] + crate::geom::Vector::new(dir.cos(), dir.sin()) * j.bone_len;
                }
            }
        }
        if std::env::var("MOCAP_DEBUG").is_ok() {
            for i in 0..n {
                eprintln!("j{i} pred=({:.1},{:.1}) pt=({:.1},{:.1}) ratio={:.3} seen={} distinct={:?}", preds[i].x, preds[i].y, pts[i].x, pts[i].y, ratio[i], meas[i].is_some(), self.joints[i].bone.as_ref().map(|b| (b.distinct, b.samples())));
            }
        }
        // 4. Refinement: every seen joint against all its bones with seen other ends.
        for &i in self.order.iter().chain(self.order.iter()) {
            if meas[i].is_none() {
                continue;
            }
            let fixed: Vec<Option<Point>> = (0..n).map(|k| meas[k].map(|_| pts[k])).collect();
            let c0 = self.joint_cost(frame, i, pts[i], &fixed, gain, false);
            if !c0.is_finite() {
                continue;
            }
            let (q, _) = bone::refine(pts[i], 2.0, &|q, _| self.joint_cost(frame, i, q, &fixed, gain, false));
            pts[i] = q;
            meas[i] = Some(q);
        }
        // 5. Filters and statuses.
        let (fw, fh) = (frame.width() as f32, frame.height() as f32);
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let parent = self.parents[i];
            let j = &mut self.joints[i];
            let score = (1.0 - ratio[i]).clamp(0.0, 1.0);
            let status = if let Some(z) = meas[i] {
                j.hidden_run = 0;
                if reacquired[i] {
                    j.kalman.reset(z, crate::geom::Vector::zeros(), p.meas_sigma_px, p.speed_sigma);
                    Status::Low
                } else {
                    let r = ratio[i];
                    let var = p.meas_sigma_px * p.meas_sigma_px * (1.0 + p.low_score_noise * r * r);
                    j.kalman.update(z, var);
                    if score >= 0.5 {
                        Status::Ok
                    } else {
                        Status::Low
                    }
                }
            } else {
                j.hidden_run += 1;
                let v = pts[i] - j.last.pos;
                if parent.is_some() {
                    j.kalman.reset(pts[i], v * 0.5, 1.0, p.speed_sigma);
                } else {
                    j.kalman.damp(0.8, 0.0);
                }
                if j.hidden_run > p.lost_after_frames {
                    Status::Lost
                } else {
                    Status::Occluded
                }
            };
            j.kalman
                .clamp_to(Point::new(0.0, 0.0), Point::new(fw - 1.0, fh - 1.0));
            pts[i] = j.kalman.position();
            out.push((score, status));
        }
        // Bone lengths and turn rates, from the filtered positions.
        for i in 0..n {
            if let Some(par) = self.parents[i] {
                let v = pts[i] - pts[par];
                let j = &mut self.joints[i];
                let dir = unwrap_angle(j.bone_dir, direction(pts[par], pts[i]));
                if meas[i].is_some() {
                    j.bone_turn = 0.5 * j.bone_turn + 0.5 * (dir - j.bone_dir);
                    if meas[par].is_some() {
                        j.bone_len += 0.1 * (v.norm() - j.bone_len);
                    }
                }
                j.bone_dir = dir;
            }
        }
        let mut result = Vec::with_capacity(n);
        for (i, (score, status)) in out.into_iter().enumerate() {
            let angle = self.angle_of(i, &pts, self.joints[i].last.angle_rad);
            result.push(JointEstimate {
                pos: pts[i],
                angle_rad: angle,
                score,
                status,
            });
        }
        // Running appearance of template-matched joints, on confident frames.
        let bg = self.background.as_ref();
        let rate = p.update_rate;
        let anchor_weight = p.anchor_weight;
        self.joints
            .par_iter_mut()
            .zip(result.par_iter())
            .for_each(|(j, est)| {
                j.last = *est;
                if j.bone.is_none() && est.status == Status::Ok && est.score > 0.6 {
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

    /// Looks for the child end of bone `b` on the circle of radius `len` around `parent_pos`,
    /// every 5°, then refines the best spot. Returns the position and the fine cost.
    fn circle_search(&self, frame: &RgbImage, b: &BoneModel, parent_pos: Point, len: f32, gain: f32) -> (Point, f32) {
        let mut best = (parent_pos, f32::INFINITY);
        for k in 0..72 {
            let dir = (k as f32) * std::f32::consts::PI / 36.0;
            let at = parent_pos + crate::geom::Vector::new(dir.cos(), dir.sin()) * len;
            let c = b.cost_end(frame, End::Child, at, parent_pos, gain, true);
            if c < best.1 {
                best = (at, c);
            }
        }
        bone::refine(best.0, 4.0, &|q, co| b.cost_end(frame, End::Child, q, parent_pos, gain, co))
    }
}

