//! Joint tracking (METHOD.md §2), one frame at a time:
//!
//! 1. **Predict** every joint with constant-acceleration Kalman filters (eq. 4.3–4.4, [`kalman`]):
//!    a root's position in the image, every other joint's bone direction and log length relative
//!    to its parent, so a swinging limb is predicted along its arc (eq. 4.2's rotation).
//! 2. **Search** (eq. 4.5–4.6, [`search`]): down the skeleton, parents first, the colour cost of
//!    each bone's [`strip`] (its seed appearance, rotated and stretched with the bone) plus the
//!    distance from the prediction, minimised over a window whose size comes from the filters'
//!    uncertainty: a translation window for a root, an angle × length window for a bone.
//! 3. **Refine** all joints at once, sub-pixel, by Gauss–Newton on the robust colour cost of every
//!    bone with the motion and bone-length priors ([`solve`]).
//! 4. **Judge**: the share of a bone's samples that fit says how much of it is seen. A joint none
//!    of whose bones is seen near it is hidden (`occluded`): it follows the prediction, its
//!    filters coast, and every frame its bone is looked for on the whole circle around its parent
//!    so that it is re-acquired when it reappears. Seen bones update their running appearance
//!    (anchored to the seed appearance, so it cannot drift away).
//!
//! Joints hidden for a while are filled afterwards by [`gapfill`] once they are seen again.

pub mod gapfill;
pub mod kalman;
pub mod pixels;
pub mod search;
pub mod solve;
pub mod strip;

use crate::background::Background;
use crate::geom::{direction, unwrap_angle, Point, Vector};
use crate::seed::Seeds;
use image::RgbImage;
use kalman::{Ca, Kalman};
use pixels::{Level, Pyramid, LEVELS};
use search::{grid_min, Window};
use serde::{Deserialize, Serialize};
use solve::{LengthPrior, PositionPrior, Problem};
use strip::{Extent, Fit, Shape, Strip, StripSpec};

/// Tracking parameters (all recorded in `run.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackParams {
    /// Smallest search radius (px) of a root, and smallest arc (px) swept by a bone's end.
    pub search_min_px: f32,
    /// Largest search radius (px) of a root.
    pub search_max_px: f32,
    /// Search window half-size in standard deviations of the prediction.
    pub search_sigmas: f32,
    /// Grid step (px, at a bone's end) of the coarse search.
    pub search_step_px: f32,
    /// A search moves a bone off its prediction only if that lowers its mean robust colour cost
    /// (0–1) by more than this.
    pub move_evidence: f32,
    /// Widest angle window of a bone, each side of the prediction (degrees).
    pub angle_max_deg: f32,
    /// Narrowest and widest length window of a bone, each side of the prediction (share of its
    /// length).
    pub stretch_min: f32,
    pub stretch_max: f32,
    /// W_g of eq. 4.5: the cost, against a bone's mean robust colour cost (0–1), of being at the
    /// edge of the search window.
    pub geo_weight: f32,
    /// Weight of each bone's colour term in the refinement, against the priors (per px²).
    pub colour_weight: f32,
    /// Weight of the motion prior in the refinement (scales 1 / predicted variance).
    pub prior_weight: f32,
    /// Smallest standard deviation (px) of the motion prior in the refinement: the motion
    /// model is only a model.
    pub prior_sigma_px: f32,
    /// Smallest spread of a bone's length prior (share of its length).
    pub length_sigma: f32,
    /// Smallest initial colour scale σ of the robust cost (levels per channel); it starts at
    /// twice the clip's measured noise if that is more, and adapts per bone to the residuals it
    /// sees, between 0.75× and 2× its start.
    pub colour_sigma: f32,
    /// Weight of the seed appearance (anchor) in a bone's template; the rest is its running one.
    pub anchor_weight: f32,
    /// Blend rate of the running appearance on confident frames.
    pub update_rate: f32,
    /// Half-width of a bone's strip, as a share of the smaller side of its child's rectangle.
    pub bone_half_width: f32,
    /// How far a bone's strip reaches past a leaf joint (the hand past the wrist, the foot past
    /// the ankle), as a share of half that joint's rectangle.
    pub end_reach: f32,
    /// How far a bone's strip reaches past a root, and past any other joint, as a share of the
    /// limb's half-width plus `edge_margin_px` (so that it holds the limb's rounded end).
    pub root_reach: f32,
    pub joint_reach: f32,
    /// Margin (px) past a limb's edge that its strip holds.
    pub edge_margin_px: f32,
    /// Colour distance (levels, RGB) within which a seed pixel shared by two bones' strips is
    /// taken for the other bone's (see `Strip::doubt_foreign`); 0 turns this off.
    pub foreign_tolerance: f32,
    /// How a limb's width follows its length, ×(L₀/L)^γ: 0 keeps it (real limbs), 0.5 is a
    /// cartoon squash-and-stretch, 1 keeps the area in the image.
    pub width_exponent: f32,
    /// Most samples per bone.
    pub max_samples: usize,
    /// Most samples per bone in the coarse search.
    pub coarse_samples: usize,
    /// Gauss–Newton iterations of the refinement.
    pub iterations: usize,
    /// Measurement standard deviation of a cleanly seen joint (px).
    pub meas_sigma_px: f32,
    /// Prior speed uncertainty of a root at the seed frame (px/frame).
    pub speed_sigma: f32,
    /// Prior turn-rate uncertainty of a bone at the seed frame (rad/frame).
    pub turn_sigma: f32,
    /// Random jerk of a root's motion model (px/frame³).
    pub jerk_sigma: f32,
    /// Random angular jerk of a bone's motion model (rad/frame³).
    pub turn_jerk_sigma: f32,
    /// Random jerk of a bone's log length (per frame³).
    pub stretch_jerk_sigma: f32,
    /// A joint is seen when at least this share of the samples near it (of any of its bones)
    /// fit; below, it is hidden (`occluded`).
    pub seen_share: f32,
    /// A seen joint is `ok` from this share on; below, `low`.
    pub ok_share: f32,
    /// A hidden bone found again on the circle around its parent is taken when this share of
    /// its samples fit.
    pub reacquire_share: f32,
    /// A seen joint whose bone length differs from the predicted one by more than this share is
    /// `low`.
    pub bone_tolerance: f32,
    /// `true`: a root joint's angle turns with the bone to its first child; `false`: it keeps
    /// its seed orientation.
    pub rotate_roots: bool,
    /// Longest hidden stretch (frames) filled afterwards by interpolating the bone between the
    /// frames on either side (0: no filling; frames are held back that long).
    pub fill_gaps_max: u32,
    /// Frames in a row hidden before the status turns from `occluded` to `lost`.
    pub lost_after_frames: u32,
}

impl Default for TrackParams {
    fn default() -> Self {
        TrackParams {
            search_min_px: 6.0,
            search_max_px: 64.0,
            search_sigmas: 3.0,
            search_step_px: 2.0,
            move_evidence: 0.03,
            angle_max_deg: 60.0,
            stretch_min: 0.08,
            stretch_max: 0.35,
            geo_weight: 0.05,
            colour_weight: 100.0,
            prior_weight: 1.0,
            prior_sigma_px: 3.0,
            length_sigma: 0.15,
            colour_sigma: 10.0,
            anchor_weight: 0.5,
            update_rate: 0.1,
            bone_half_width: 0.5,
            end_reach: 1.0,
            root_reach: 1.0,
            joint_reach: 1.0,
            edge_margin_px: 2.0,
            width_exponent: 0.0,
            foreign_tolerance: 20.0,
            max_samples: 256,
            coarse_samples: 48,
            iterations: 8,
            meas_sigma_px: 0.5,
            speed_sigma: 10.0,
            turn_sigma: 0.15,
            jerk_sigma: 2.0,
            turn_jerk_sigma: 0.03,
            stretch_jerk_sigma: 0.01,
            seen_share: 0.3,
            ok_share: 0.6,
            reacquire_share: 0.6,
            bone_tolerance: 0.3,
            rotate_roots: false,
            fill_gaps_max: 120,
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
    /// Seen: most samples of its bones near it fit.
    Ok,
    /// Seen, but poorly (few samples fit, or its bone changed length sharply): worth a look.
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

/// Which end of a strip a joint is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum End {
    Parent,
    Child,
    Patch,
}

/// Motion model of one joint.
#[derive(Debug, Clone)]
enum Motion {
    /// A root: its position.
    Root(Kalman),
    /// Any other joint: the direction (rad, unwrapped) and log length of its bone, and the log
    /// length range it is kept in (a quarter to four times its seed length).
    Bone {
        angle: Ca,
        log_len: Ca,
        log_len_range: (f32, f32),
    },
}

/// Per-joint tracker state.
#[derive(Debug, Clone)]
struct JointState {
    motion: Motion,
    /// Direction (rad) that defines the joint's `angle` 0: its bone's on the seed frame (a root:
    /// the bone to its first child).
    seed_dir: f32,
    hidden_run: u32,
    last: JointEstimate,
}

/// Per-frame prediction of one joint.
#[derive(Debug, Clone, Copy)]
struct Prediction {
    /// Predicted position (px).
    pos: Point,
    /// Root: position sigma (px). Bone: direction sigma (rad).
    sigma: f32,
    /// Bone: log-length sigma.
    len_sigma: f32,
}

/// Half-width (px) of the limb along the bone `p → c` on the seed frame: the median distance
/// from the axis to the first pixel `background` says is background, across the bone at a
/// quarter, half and three quarters of its length, both sides; at most `max`.
fn limb_radius(p: Point, c: Point, max: f32, background: &dyn Fn(f32, f32) -> bool) -> f32 {
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
                if background(q.x, q.y) {
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

/// Where the middle joint of a two-bone chain goes: at distance `l1` (px) from `a` and `l2`
/// from `c`, of the two such points the one nearer `guess` (two-bone inverse kinematics). When
/// `a` and `c` are too far apart or too close for both lengths, it lies on the line through them,
/// splitting the gap in the ratio of the lengths.
fn two_bone(a: Point, c: Point, l1: f32, l2: f32, guess: Point) -> Point {
    let d = c - a;
    let dist = d.norm();
    if dist < 1e-3 {
        return guess;
    }
    let u = d / dist;
    // Distance from `a` along the line to the chord, and half the chord.
    let along = (dist * dist + l1 * l1 - l2 * l2) / (2.0 * dist);
    let h2 = l1 * l1 - along * along;
    if h2 <= 0.0 {
        return a + u * (dist * l1 / (l1 + l2).max(1e-3));
    }
    let n = Vector::new(-u.y, u.x);
    let base = a + u * along;
    let (p1, p2) = (base + n * h2.sqrt(), base - n * h2.sqrt());
    if (p1 - guess).norm() <= (p2 - guess).norm() {
        p1
    } else {
        p2
    }
}

/// Tracks all joints of a seed file frame by frame.
pub struct Tracker {
    params: TrackParams,
    parents: Vec<Option<usize>>,
    children: Vec<Vec<usize>>,
    order: Vec<usize>,
    strips: Vec<Strip>,
    /// Strip of the bone ending at each joint (or of a lone joint's patch).
    strip_of: Vec<Option<usize>>,
    /// Strips touching each joint, and which end of them it is.
    touching: Vec<Vec<(usize, End)>>,
    joints: Vec<JointState>,
    background: Option<Background>,
    /// Bottom-right pixel of the frame (px): roots are kept inside.
    frame_max: Point,
    /// The colour scale the strips started with (levels per channel); they adapt within
    /// 0.75× to 2× of it.
    colour_sigma: f32,
    /// The last frame's intermediate results, when asked for (see [`Tracker::trace`]).
    trace: Option<Trace>,
}

/// Intermediate results of one [`Tracker::step`], for diagnostics: per joint, the predicted
/// position, the position after the coarse search and after refinement (px), and the evidence
/// (share of fitting samples near it).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    pub predicted: Vec<Point>,
    pub searched: Vec<Point>,
    pub refined: Vec<Point>,
    pub evidence: Vec<f32>,
    pub reacquired: Vec<bool>,
}

impl Tracker {
    /// Keeps each step's intermediate results from now on (read them with [`Tracker::trace`]).
    pub fn enable_trace(&mut self) {
        self.trace = Some(Trace::default());
    }

    /// The last step's intermediate results, if [`Tracker::enable_trace`] was called.
    pub fn trace(&self) -> Option<&Trace> {
        self.trace.as_ref()
    }

    /// Builds the tracker from the seed file and the seed frame: one strip per bone (seed pixels
    /// nearer to that bone than to any other, foreground only when a background model is given),
    /// one patch per lone joint.
    pub fn new(
        params: TrackParams,
        seeds: &Seeds,
        seed_frame: &RgbImage,
        background: Option<Background>,
    ) -> Self {
        let sk = &seeds.skeleton;
        let n = sk.len();
        let boxes = seeds.boxes();
        let centres: Vec<Point> = boxes.iter().map(|b| b.centre()).collect();
        let children: Vec<Vec<usize>> = (0..n).map(|i| sk.children(i)).collect();
        let img = Pyramid::new(seed_frame, LEVELS);
        let half_box = |j: usize| 0.5 * boxes[j].w.max(boxes[j].h) as f32;
        let bones: Vec<(usize, usize)> = sk
            .bones()
            .into_iter()
            .filter(|&(p, c)| (centres[c] - centres[p]).norm() >= 2.0)
            .collect();
        let looks_background = |x: f32, y: f32| match &background {
            Some(bg) => {
                let (xi, yi) = (x.round(), y.round());
                xi >= 0.0
                    && yi >= 0.0
                    && (xi as u32) < seed_frame.width()
                    && (yi as u32) < seed_frame.height()
                    && !bg.is_foreground(seed_frame, xi as u32, yi as u32)
            }
            None => false,
        };
        let extents: Vec<Extent> = bones
            .iter()
            .map(|&(p, c)| {
                let max_half = params.bone_half_width * boxes[c].w.min(boxes[c].h) as f32;
                let margin = params.edge_margin_px;
                let r = limb_radius(centres[p], centres[c], max_half, &looks_background);
                let reach = r + margin;
                Extent {
                    a: centres[p],
                    b: centres[c],
                    ext_a: reach
                        * if sk.parents[p].is_none() {
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
        // The colour scale starts at the clip's own noise: twice the per-channel noise of the
        // background model (the template carries the seed frame's noise too), at least
        // `colour_sigma`.
        let noise = background.as_ref().map_or(0.0, |b| b.noise_sigma());
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
            if let Some(s) = Strip::sample(
                &img,
                Shape::Bone,
                (p, c),
                extents[bi],
                &spec,
                &others,
                &looks_background,
            ) {
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
            if let Some(s) = Strip::sample(
                &img,
                Shape::Patch,
                (j, j),
                extent,
                &spec,
                &[],
                &looks_background,
            ) {
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
        let p = &params;
        let joints = (0..n)
            .map(|j| {
                let (motion, seed_dir) = match sk.parents[j] {
                    None => (
                        Motion::Root(Kalman::new(centres[j], p.speed_sigma, 1.0, p.jerk_sigma)),
                        children[j]
                            .first()
                            .map_or(0.0, |&c| direction(centres[j], centres[c])),
                    ),
                    Some(par) => {
                        let d = centres[j] - centres[par];
                        let dir = d.y.atan2(d.x);
                        let len = d.norm().max(1.0);
                        (
                            Motion::Bone {
                                angle: Ca::new(
                                    dir,
                                    0.01,
                                    p.turn_sigma,
                                    0.5 * p.turn_sigma,
                                    p.turn_jerk_sigma,
                                ),
                                log_len_range: (len.ln() - 4f32.ln(), len.ln() + 4f32.ln()),
                                log_len: Ca::new(
                                    len.ln(),
                                    0.01,
                                    0.3 * p.turn_sigma,
                                    0.15 * p.turn_sigma,
                                    p.stretch_jerk_sigma,
                                ),
                            },
                            dir,
                        )
                    }
                };
                JointState {
                    motion,
                    seed_dir,
                    hidden_run: 0,
                    last: JointEstimate {
                        pos: centres[j],
                        angle_rad: 0.0,
                        score: 1.0,
                        status: Status::Seed,
                    },
                }
            })
            .collect();
        Tracker {
            params,
            parents: sk.parents.clone(),
            children,
            order: sk.topo_order(),
            strips,
            strip_of,
            touching,
            joints,
            background,
            frame_max: Point::new(
                seed_frame.width().saturating_sub(1) as f32,
                seed_frame.height().saturating_sub(1) as f32,
            ),
            trace: None,
            colour_sigma: sigma,
        }
    }

    /// Diagnostics: how the strip of the bone ending at joint `child` fits `frame` with its
    /// parent at `p` and the child at `c` (`None` if that bone has no strip).
    pub fn fit_bone(&self, frame: &RgbImage, child: usize, p: Point, c: Point) -> Option<Fit> {
        let s = &self.strips[self.strip_of[child]?];
        Some(s.fit(&Pyramid::new(frame, 1).level(0), p, c, self.gain(frame)))
    }

    /// Diagnostics: [`Strip::probe`] of the bone ending at joint `child`.
    pub fn probe_bone(
        &self,
        frame: &RgbImage,
        child: usize,
        p: Point,
        c: Point,
    ) -> Vec<(f32, f32, f32, f32)> {
        self.strip_of[child].map_or(Vec::new(), |si| {
            self.strips[si].probe(&Pyramid::new(frame, 1).level(0), p, c, self.gain(frame))
        })
    }

    /// One line per strip for diagnostics (see [`Strip::summary`]).
    pub fn strip_summaries(&self) -> Vec<String> {
        self.strips.iter().map(|s| s.summary()).collect()
    }

    /// A gap filler for this skeleton, holding at most `fill_gaps_max` frames back.
    pub fn gap_filler(&self) -> gapfill::GapFiller {
        gapfill::GapFiller::new(
            self.parents.clone(),
            self.order.clone(),
            self.params.fill_gaps_max as usize,
        )
    }

    /// The estimates of the last processed frame (the seed frame right after `new`).
    pub fn current(&self) -> Vec<JointEstimate> {
        self.joints.iter().map(|j| j.last).collect()
    }

    /// Step 1: predicted position of every joint (eq. 4.3), parents first.
    fn predict(&mut self) -> Vec<Prediction> {
        let mut pred = vec![
            Prediction {
                pos: Point::origin(),
                sigma: 0.0,
                len_sigma: 0.0,
            };
            self.joints.len()
        ];
        for &j in &self.order {
            pred[j] = match (&mut self.joints[j].motion, self.parents[j]) {
                (Motion::Root(k), _) => {
                    k.predict();
                    k.clamp(Point::origin(), self.frame_max);
                    Prediction {
                        pos: k.position(),
                        sigma: k.position_sigma(),
                        len_sigma: 0.0,
                    }
                }
                (
                    Motion::Bone {
                        angle,
                        log_len,
                        log_len_range: (lo, hi),
                    },
                    Some(p),
                ) => {
                    let a = angle.predict();
                    log_len.predict();
                    log_len.clamp(*lo, *hi);
                    let len = log_len.value().exp();
                    Prediction {
                        pos: pred[p].pos + Vector::new(a.cos(), a.sin()) * len,
                        sigma: angle.sigma(),
                        len_sigma: log_len.sigma(),
                    }
                }
                (Motion::Bone { .. }, None) => unreachable!("a joint with a bone has a parent"),
            };
        }
        pred
    }

    /// The frame's brightness gain over the clean plate (1 without one).
    fn gain(&self, frame: &RgbImage) -> f32 {
        self.background.as_ref().map_or(1.0, |b| b.gain(frame))
    }

    /// Step 2: the coarse search, parents first; each joint starts where its parent's move
    /// carries its prediction.
    fn search(&self, pyr: &Pyramid, gain: f32, pred: &[Prediction]) -> Vec<Point> {
        let p = &self.params;
        let n = self.joints.len();
        let mut x: Vec<Point> = pred.iter().map(|q| q.pos).collect();
        let mut shift = vec![Vector::zeros(); n];
        for &j in &self.order {
            match self.parents[j] {
                None => {
                    let radius =
                        (p.search_sigmas * pred[j].sigma).clamp(p.search_min_px, p.search_max_px);
                    let d = self.search_root(&pyr.level(2), gain, j, &x, radius);
                    shift[j] = d;
                    x[j] += d;
                }
                Some(par) => {
                    x[j] = pred[j].pos + shift[par];
                    if let Some(si) = self.strip_of[j] {
                        // Grandchildren where the parent's move carries their prediction.
                        let below: Vec<(usize, Point)> = self.children[j]
                            .iter()
                            .filter_map(|&c| Some((self.strip_of[c]?, pred[c].pos + shift[par])))
                            .collect();
                        x[j] = self.search_bone(
                            &pyr.level(1),
                            gain,
                            si,
                            x[par],
                            x[j],
                            &below,
                            &pred[j],
                        );
                    }
                    shift[j] = x[j] - pred[j].pos;
                }
            }
        }
        x
    }

    /// Best translation (px) of root `r` and everything below it within `radius` px, on a
    /// coarse pyramid level: every bone of the subtree at its predicted place relative to the
    /// root, so the whole body's shape anchors the search.
    fn search_root(&self, img: &Level, gain: f32, r: usize, x: &[Point], radius: f32) -> Vector {
        let p = &self.params;
        let strips: Vec<&Strip> = self
            .descendants_and_self(r)
            .into_iter()
            .filter_map(|j| self.strip_of[j])
            .map(|si| &self.strips[si])
            .collect();
        if strips.is_empty() {
            return Vector::zeros();
        }
        let step = (p.search_step_px * img.scale / 2.0).min(radius.max(1.0));
        let w = Window {
            centre: [0.0, 0.0],
            half: [radius, radius],
            step: [step, step],
        };
        let (best, _) = grid_min(&w, |q| {
            let d = Vector::new(q[0], q[1]);
            let colour: f32 = strips
                .iter()
                .map(|s| s.coarse_cost(img, x[s.parent] + d, x[s.child] + d, gain))
                .sum::<f32>()
                / strips.len() as f32;
            colour + p.geo_weight * d.norm_squared() / (radius * radius)
        });
        Vector::new(best[0], best[1])
    }

    /// Best position of the child end of strip `si` with its parent at `parent`, in an angle ×
    /// length window around `guess`. The bones below (`below`: strip and far end when the child
    /// is at `guess`) move rigidly with the child and add their cost, so a bone partly hidden
    /// is still placed by the next one down.
    #[allow(clippy::too_many_arguments)]
    fn search_bone(
        &self,
        img: &Level,
        gain: f32,
        si: usize,
        parent: Point,
        guess: Point,
        below: &[(usize, Point)],
        pred: &Prediction,
    ) -> Point {
        let p = &self.params;
        let s = &self.strips[si];
        let d = guess - parent;
        let len = d.norm().max(1.0);
        let (a0, l0) = (d.y.atan2(d.x), len.ln());
        let half_a = (p.search_sigmas * pred.sigma)
            .max(p.search_min_px / len)
            .min(p.angle_max_deg.to_radians());
        let half_l = (p.search_sigmas * pred.len_sigma).clamp(p.stretch_min, p.stretch_max);
        let step = (p.search_step_px / len).min(half_a.max(1e-3));
        let w = Window {
            centre: [a0, l0],
            half: [half_a, half_l],
            step: [step, (p.search_step_px / len).min(half_l)],
        };
        let at = |q: [f32; 2]| parent + Vector::new(q[0].cos(), q[0].sin()) * q[1].exp();
        let n = (1 + below.len()) as f32;
        let colour = |c: Point| {
            let d = c - guess;
            let mut sum = s.coarse_cost(img, parent, c, gain);
            for &(bi, end) in below {
                sum += self.strips[bi].coarse_cost(img, c, end + d, gain);
            }
            sum / n
        };
        let (best, _) = grid_min(&w, |q| {
            let geo = ((q[0] - a0) / half_a).powi(2) + ((q[1] - l0) / half_l).powi(2);
            colour(at(q)) + p.geo_weight * geo
        });
        // Move only on real evidence: a hidden bone costs nearly 1 everywhere, and its noise
        // must not pull it off its predicted path.
        if colour(at(best)) < colour(guess) - p.move_evidence {
            at(best)
        } else {
            guess
        }
    }

    /// Step 3: Gauss–Newton refinement of every joint.
    fn refine(&self, pyr: &Pyramid, gain: f32, pred: &[Prediction], x: &mut [Point]) {
        let p = &self.params;
        let weights = vec![p.colour_weight; self.strips.len()];
        let lengths: Vec<LengthPrior> = self
            .strips
            .iter()
            .map(|s| {
                let q = &pred[s.child];
                let len = (pred[s.child].pos - pred[s.parent].pos).norm().max(1.0);
                let sigma = len * q.len_sigma.max(p.length_sigma);
                LengthPrior {
                    len,
                    weight: if s.shape == Shape::Bone {
                        1.0 / (sigma * sigma)
                    } else {
                        0.0
                    },
                }
            })
            .collect();
        let positions: Vec<PositionPrior> = (0..x.len())
            .map(|j| {
                let q = &pred[j];
                match self.parents[j] {
                    None => {
                        let s = q.sigma.max(p.prior_sigma_px * 3.0);
                        PositionPrior {
                            parent: None,
                            offset: q.pos.coords,
                            weight: p.prior_weight / (s * s),
                        }
                    }
                    Some(par) => {
                        let off = q.pos - pred[par].pos;
                        let s = (off.norm() * q.sigma.hypot(q.len_sigma)).max(p.prior_sigma_px);
                        PositionPrior {
                            parent: Some(par),
                            offset: off,
                            weight: p.prior_weight / (s * s),
                        }
                    }
                }
            })
            .collect();
        let problem = Problem {
            strips: &self.strips,
            strip_weight: &weights,
            lengths: &lengths,
            positions: &positions,
            gain,
        };
        for lv in (0..pyr.levels()).rev() {
            solve::refine(
                &problem,
                &pyr.level(lv),
                x,
                p.iterations,
                2.0 * (1 << lv) as f32,
            );
        }
    }

    /// Share of fitting samples near each joint (the best of its strips), from strip fits.
    fn evidence(&self, fits: &[Fit]) -> Vec<f32> {
        self.touching
            .iter()
            .map(|t| {
                t.iter()
                    .map(|&(si, end)| match end {
                        End::Parent => fits[si].parent_end,
                        End::Child => fits[si].child_end,
                        End::Patch => fits[si].inliers,
                    })
                    .fold(0.0, f32::max)
                    .min(1.0)
            })
            .collect()
    }

    /// Looks for hidden joint `j`'s bone on the whole circle around its parent (three lengths
    /// around the predicted one). Returns the child position when enough of the bone fits.
    fn reacquire(&self, pyr: &Pyramid, gain: f32, j: usize, x: &[Point]) -> Option<Point> {
        let img = &pyr.level(1);
        let p = &self.params;
        let si = self.strip_of[j]?;
        let par = self.parents[j]?;
        let s = &self.strips[si];
        let d = x[j] - x[par];
        let len = d.norm().max(1.0);
        let step = (p.search_step_px / len).clamp(0.5f32.to_radians(), 5f32.to_radians());
        let w = Window {
            centre: [d.y.atan2(d.x), len.ln()],
            half: [std::f32::consts::PI, 0.15],
            step: [step, 0.15],
        };
        let at = |q: [f32; 2]| x[par] + Vector::new(q[0].cos(), q[0].sin()) * q[1].exp();
        let (best, _) = grid_min(&w, |q| s.coarse_cost(img, x[par], at(q), gain));
        let c = at(best);
        let fit = s.fit(&pyr.level(0), x[par], c, gain);
        if std::env::var("MOCAP_DEBUG").is_ok() {
            eprintln!("single j={j} at {c:?} fit {fit:?}");
        }
        (fit.inliers >= p.reacquire_share && fit.child_end >= p.reacquire_share).then_some(c)
    }

    /// Looks for hidden joint `j` whose parent is hidden too, with the grandparent placed: the
    /// parent on the circle around the grandparent (its bone's current length), `j` on the
    /// circle around the parent. Returns the parent's and `j`'s positions when
    /// enough of the bone between them fits.
    fn reacquire_chain(
        &self,
        pyr: &Pyramid,
        gain: f32,
        j: usize,
        x: &[Point],
    ) -> Option<(Point, Point)> {
        let img = &pyr.level(1);
        let p = &self.params;
        let si = self.strip_of[j]?;
        let par = self.parents[j]?;
        let grand = self.parents[par]?;
        let s = &self.strips[si];
        let d1 = x[par] - x[grand];
        let d2 = x[j] - x[par];
        let (l1, l2) = (d1.norm().max(1.0), d2.norm().max(1.0));
        let w = Window {
            centre: [d1.y.atan2(d1.x), d2.y.atan2(d2.x)],
            half: [std::f32::consts::PI, std::f32::consts::PI],
            step: [
                (p.search_step_px / l1).clamp(1f32.to_radians(), 5f32.to_radians()),
                (p.search_step_px / l2).clamp(2f32.to_radians(), 5f32.to_radians()),
            ],
        };
        let at = |q: [f32; 2]| {
            let b = x[grand] + Vector::new(q[0].cos(), q[0].sin()) * l1;
            (b, b + Vector::new(q[1].cos(), q[1].sin()) * l2)
        };
        let (best, _) = grid_min(&w, |q| {
            let (b, c) = at(q);
            s.coarse_cost(img, b, c, gain)
        });
        let (b, c) = at(best);
        let fit = s.fit(&pyr.level(0), b, c, gain);
        if std::env::var("MOCAP_DEBUG").is_ok() {
            eprintln!("chain j={j} l1={l1:.1} l2={l2:.1} at {b:?} {c:?} fit {fit:?}");
        }
        (fit.inliers >= p.reacquire_share && fit.child_end >= p.reacquire_share).then_some((b, c))
    }

    /// Tracks one frame (the frame after the previous call). Returns every joint's estimate.
    pub fn step(&mut self, frame: &RgbImage) -> Vec<JointEstimate> {
        let pyr = Pyramid::new(frame, LEVELS);
        let img = pyr.level(0);
        let gain = self.gain(frame);
        let pred = self.predict();
        let mut x = self.search(&pyr, gain, &pred);
        let searched = self.trace.is_some().then(|| x.clone());
        self.refine(&pyr, gain, &pred, &mut x);
        let refined = self.trace.is_some().then(|| x.clone());
        let mut reacquired = vec![false; x.len()];
        let mut fits: Vec<Fit> = self
            .strips
            .iter()
            .map(|s| s.fit(&img, x[s.parent], x[s.child], gain))
            .collect();
        let mut evidence = self.evidence(&fits);
        self.place_hidden(&pred, &evidence, &reacquired, &mut x);

        // Hidden joints: look for their bones around their parents.
        let mut moved = false;
        for &j in &self.order {
            if evidence[j] >= self.params.seen_share || self.parents[j].is_none() {
                continue;
            }
            let par = self.parents[j].unwrap_or(j);
            let parent_seen = evidence[par] >= self.params.seen_share || reacquired[par];
            if parent_seen {
                if let Some(c) = self.reacquire(&pyr, gain, j, &x) {
                    let d = c - x[j];
                    for k in self.descendants_and_self(j) {
                        x[k] += d;
                    }
                    reacquired[j] = true;
                    moved = true;
                }
            } else if let Some((b, c)) = self.reacquire_chain(&pyr, gain, j, &x) {
                // The parent is hidden too (an elbow behind the torso): both are placed by the
                // bone between them, as far as it shows.
                let (db, dc) = (b - x[par], c - x[j]);
                x[par] += db;
                for k in self.descendants_and_self(j) {
                    x[k] += dc;
                }
                for &sib in &self.children[par] {
                    if sib != j {
                        for k in self.descendants_and_self(sib) {
                            x[k] += db;
                        }
                    }
                }
                reacquired[par] = true;
                reacquired[j] = true;
                moved = true;
            }
        }
        if moved {
            self.refine(&pyr, gain, &pred, &mut x);
            fits = self
                .strips
                .iter()
                .map(|s| s.fit(&img, x[s.parent], x[s.child], gain))
                .collect();
            evidence = self.evidence(&fits);
            self.place_hidden(&pred, &evidence, &reacquired, &mut x);
        }
        if let (Some(t), Some(searched), Some(refined)) = (self.trace.as_mut(), searched, refined) {
            *t = Trace {
                predicted: pred.iter().map(|q| q.pos).collect(),
                searched,
                refined,
                evidence: evidence.clone(),
                reacquired,
            };
        }
        self.update(&pyr, gain, &pred, &x, &fits, &evidence);
        self.current()
    }

    /// A hidden joint's colour evidence is not to be trusted: it keeps its predicted place
    /// relative to its parent (a root: relative to its seen children), or, when one of its
    /// children is seen, the place that keeps both
    /// of its bones at their predicted lengths nearest to that (two-bone inverse kinematics: an
    /// elbow behind the torso sits where the shoulder and the seen wrist put it). Joints in
    /// `keep` (re-acquired this frame) stay where they are.
    fn place_hidden(&self, pred: &[Prediction], evidence: &[f32], keep: &[bool], x: &mut [Point]) {
        let seen = |j: usize| evidence[j] >= self.params.seen_share || keep[j];
        for &j in &self.order {
            if seen(j) {
                continue;
            }
            let Some(par) = self.parents[j] else {
                // A hidden root sits where its seen children put it.
                let from: Vec<Point> = self.children[j]
                    .iter()
                    .filter(|&&c| seen(c))
                    .map(|&c| x[c] - (pred[c].pos - pred[j].pos))
                    .collect();
                if !from.is_empty() {
                    let sum = from.iter().fold(Vector::zeros(), |a, q| a + q.coords);
                    x[j] = Point::from(sum / from.len() as f32);
                }
                continue;
            };
            let guess = x[par] + (pred[j].pos - pred[par].pos);
            let prior = match self.children[j].iter().copied().find(|&c| seen(c)) {
                Some(c) => {
                    let l1 = (pred[j].pos - pred[par].pos).norm();
                    let l2 = (pred[c].pos - pred[j].pos).norm();
                    two_bone(x[par], x[c], l1, l2, guess)
                }
                None => guess,
            };
            x[j] = prior;
        }
    }

    /// Joint `j` and everything below it.
    fn descendants_and_self(&self, j: usize) -> Vec<usize> {
        let mut out = vec![j];
        let mut k = 0;
        while k < out.len() {
            out.extend(self.children[out[k]].iter().copied());
            k += 1;
        }
        out
    }

    /// Step 4: filters, appearance, statuses.
    fn update(
        &mut self,
        pyr: &Pyramid,
        gain: f32,
        pred: &[Prediction],
        x: &[Point],
        fits: &[Fit],
        evidence: &[f32],
    ) {
        let p = self.params.clone();
        for &j in &self.order.clone() {
            let e = evidence[j];
            let seen = e >= p.seen_share;
            let meas_sigma = p.meas_sigma_px / e.max(0.1);
            let mut low = false;
            let par = self.parents[j];
            let state = &mut self.joints[j];
            match (&mut state.motion, par) {
                (Motion::Root(k), _) => {
                    if seen {
                        k.update(x[j], meas_sigma * meas_sigma);
                    } else {
                        k.damp(0.9, 0.0);
                    }
                }
                (Motion::Bone { angle, log_len, .. }, Some(par)) => {
                    let d = x[j] - x[par];
                    let len = d.norm().max(1.0);
                    // The bone is measured only when both its ends are.
                    if seen && evidence[par] >= p.seen_share {
                        let a = unwrap_angle(angle.value(), d.y.atan2(d.x));
                        let var = (meas_sigma / len).powi(2);
                        angle.update(a, var);
                        log_len.update(len.ln(), var);
                        let expected = (pred[j].pos - pred[par].pos).norm().max(1.0);
                        low = (len / expected - 1.0).abs() > p.bone_tolerance;
                    } else {
                        angle.damp(0.8, 0.0);
                        log_len.damp(0.5, 0.0);
                    }
                }
                (Motion::Bone { .. }, None) => unreachable!("a joint with a bone has a parent"),
            }
            let status = if seen {
                state.hidden_run = 0;
                if e >= p.ok_share && !low {
                    Status::Ok
                } else {
                    Status::Low
                }
            } else {
                state.hidden_run += 1;
                if state.hidden_run > p.lost_after_frames {
                    Status::Lost
                } else {
                    Status::Occluded
                }
            };
            let dir = match par {
                Some(q) => Some(direction(x[q], x[j])),
                None if p.rotate_roots => self.children[j].first().map(|&c| direction(x[j], x[c])),
                None => None,
            };
            let state = &mut self.joints[j];
            let angle_rad = dir.map_or(0.0, |d| {
                unwrap_angle(state.last.angle_rad, d - state.seed_dir)
            });
            state.last = JointEstimate {
                pos: x[j],
                angle_rad,
                score: e.clamp(0.0, 1.0),
                status,
            };
        }
        let bounds = (0.75 * self.colour_sigma, 2.0 * self.colour_sigma);
        let seen =
            |s: &Strip| evidence[s.parent] >= p.seen_share && evidence[s.child] >= p.seen_share;
        let placements: Vec<Option<strip::Placement>> = self
            .strips
            .iter()
            .zip(fits)
            .map(|(s, f)| {
                (seen(s) && f.inliers >= p.ok_share).then(|| s.placement(x[s.parent], x[s.child]))
            })
            .collect();
        for (s, f) in self.strips.iter_mut().zip(fits) {
            if seen(s) {
                let pose = (x[s.parent], x[s.child]);
                s.learn(
                    pyr,
                    pose,
                    &placements,
                    gain,
                    p.update_rate,
                    p.anchor_weight,
                    bounds,
                    f,
                );
            }
        }
    }
}
