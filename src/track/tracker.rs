//! [`Tracker`]: the per-frame loop (predict, search, refine, judge, learn) over the appearance
//! model of [`super::model`].

use super::exposure::Exposure;
use super::gapfill::GapFiller;
use super::model::Model;
use super::motion::{Motion, Prediction};
use super::pixels::{halve_all, Image, Level, Pyramid};
use super::rooted::{self, AngleOf};
use super::scale::{AtWork, WorkScale};
use super::strip::{Fit, Placement, Strip, View};
use super::{JointEstimate, Status, TrackParams};
use crate::background::Background;
use crate::geom::{direction, Point};
use crate::seed::Seeds;
use image::RgbImage;

mod keyframe;
mod update;

/// Per-joint tracker state.
#[derive(Debug, Clone)]
pub(super) struct JointState {
    pub motion: Motion,
    /// Direction (rad) that defines the joint's `angle` 0: its bone's on the seed frame (a root:
    /// the bone to its first child).
    pub seed_dir: f32,
    pub hidden_run: u32,
    pub last: JointEstimate,
}

/// See [`Tracker::adopt_hidden_from`]: the share of a bone's samples that must fit on a
/// keyframe for its appearance to be learnt there rather than kept from the seed frame (the
/// middle of a broad plateau of values measured on corrected synth clips; docs/NOTES.md).
pub const HIDDEN_AT_KEYFRAME: f32 = 0.2;

/// Tracks all joints of a seed file frame by frame.
pub struct Tracker {
    pub(super) params: TrackParams,
    /// The user's skeleton (the seed file's parents, its joints parents first), which rows and
    /// gap filling follow.
    user_parents: Vec<Option<usize>>,
    user_order: Vec<usize>,
    /// Whose angle gives each joint's angle in the user's skeleton.
    angle_of: Vec<AngleOf>,
    /// The skeleton followed: the user's, each body rooted at its centre ([`rooted`]).
    pub(super) parents: Vec<Option<usize>>,
    pub(super) children: Vec<Vec<usize>>,
    /// Joints, parents before children.
    pub(super) order: Vec<usize>,
    /// Joints by depth in the skeleton (roots first), each depth in `order`'s order.
    pub(super) depths: Vec<Vec<usize>>,
    pub(super) model: Model,
    pub(super) joints: Vec<JointState>,
    background: Option<Background>,
    /// The clean plate's pyramid levels (level 0 is the plate), when there is one.
    plate: Vec<RgbImage>,
    /// Bottom-right pixel of the frame (px): roots are kept inside.
    pub(super) frame_max: Point,
    /// Every joint's position on the seed frame (px).
    pub(super) seed_pos: Vec<Point>,
    /// Each root's body reach on the seed frame (px; see [`Tracker::body_reach`]).
    pub(super) reach: Vec<f32>,
    /// The resolution tracked at: frames, seeds and positions in and out are converted, and
    /// everything above (positions, `frame_max`, the model) is at that resolution.
    work: WorkScale,
    /// The last frame's intermediate results, when asked for (see [`Tracker::trace`]).
    trace: Option<Trace>,
    /// Time spent in each part of [`Tracker::step`] so far.
    pub(super) timings: Timings,
    /// The gain the templates are scaled by ([`super::exposure`]).
    pub(super) exposure: Exposure,
    /// A key of every joint lies ahead of this tracker's pass (see [`Tracker::set_key_ahead`]).
    key_ahead: bool,
}

/// Time (seconds) spent in each part of [`Tracker::step`] over all frames so far, for the
/// benchmark: the image pyramid, the coarse search, the refinement, judging (fits, evidence,
/// mirroring, hidden joints' placement), re-acquisition, and the motion and appearance updates.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Timings {
    pub pyramid: f64,
    pub search: f64,
    pub refine: f64,
    pub judge: f64,
    pub reacquire: f64,
    pub learn: f64,
    pub frames: u64,
}

/// Intermediate results of one [`Tracker::step`], for diagnostics: per joint, the predicted
/// position, the position after the coarse search and after refinement (px), the evidence
/// (share of fitting samples near it), whether it was re-acquired, and the frame's gain.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    pub predicted: Vec<Point>,
    pub searched: Vec<Point>,
    pub refined: Vec<Point>,
    pub evidence: Vec<f32>,
    pub reacquired: Vec<bool>,
    /// The gain the templates were judged at ([`super::exposure`]), and the plate's.
    pub gain: f32,
    pub plate_gain: f32,
}

impl Tracker {
    /// Builds the tracker from the seed file and the seed frame (see [`Model::build`]), at the
    /// working resolution the seeds call for ([`WorkScale::for_seeds`]).
    pub fn new(
        params: TrackParams,
        seeds: &Seeds,
        seed_frame: &impl AtWork,
        background: Option<Background>,
    ) -> Self {
        let work = WorkScale::for_seeds(&params, seeds);
        Self::new_at(params, seeds, seed_frame, background, work)
    }

    /// [`Tracker::new`] at the working resolution `work`: trackers whose states or strips are
    /// exchanged (a run's segments, a tracker built on a correction) must share one, whatever
    /// the rectangles of the file each is built from.
    pub fn new_at(
        params: TrackParams,
        seeds: &Seeds,
        seed_frame: &impl AtWork,
        background: Option<Background>,
        work: WorkScale,
    ) -> Self {
        // The tracker follows each body from its centre, whatever the user's root; rows keep the
        // user's angles (`super::rooted`).
        let user = seeds.skeleton.clone();
        let mut seeds = work.seeds(seeds);
        seeds.skeleton = rooted::centred(&user);
        let seeds = &seeds;
        let seed_frame: &RgbImage = &seed_frame.at_work(work);
        let background = background.map(|b| work.background(b));
        // The levels that count the frame's resolution stay where they are in the frame: the
        // halved frame is already the frame's level 1, and judging a quarter-resolution level
        // loses the detail that tells a fit from a near miss.
        let mut params = params;
        params.judge_level = params.judge_level.saturating_sub(work.halvings as usize);
        params.finest_level = params.finest_level.saturating_sub(work.halvings as usize);
        let sk = &seeds.skeleton;
        let centres: Vec<Point> = seeds.boxes().iter().map(|b| b.centre()).collect();
        let children: Vec<Vec<usize>> = (0..sk.len()).map(|i| sk.children(i)).collect();
        let model = Model::build(&params, seeds, seed_frame, background.as_ref());
        let joints = (0..sk.len())
            .map(|j| {
                let (motion, seed_dir) = match sk.parents[j] {
                    None => (
                        Motion::root(centres[j], &params),
                        children[j]
                            .first()
                            .map_or(0.0, |&c| direction(centres[j], centres[c])),
                    ),
                    Some(par) => (
                        Motion::bone(centres[par], centres[j], &params),
                        direction(centres[par], centres[j]),
                    ),
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
        let plate = background
            .as_ref()
            .map_or(Vec::new(), |b| halve_all(&b.plate, model.levels));
        let angle_of = rooted::angle_of(&user, sk, params.rotate_roots);
        let exposure = Exposure::new(background.as_ref());
        Tracker {
            user_parents: user.parents.clone(),
            user_order: user.topo_order(),
            angle_of,
            params,
            parents: sk.parents.clone(),
            children,
            depths: depths(&sk.parents, &sk.topo_order()),
            order: sk.topo_order(),
            model,
            joints,
            background,
            plate,
            frame_max: Point::new(
                seed_frame.width().saturating_sub(1) as f32,
                seed_frame.height().saturating_sub(1) as f32,
            ),
            reach: Self::body_reach(&sk.parents, &centres),
            seed_pos: centres,
            work,
            trace: None,
            timings: Timings::default(),
            exposure,
            key_ahead: false,
        }
    }

    /// Says whether a key of every joint lies ahead of the frames this tracker steps next (a
    /// pass run toward a corrected segment file or such a key, forward or backward). With
    /// [`super::TrackParams::redetect_toward_keys`] off, a body it loses there is not looked
    /// for over the whole frame (re-detection, docs/method.md §2.6): the pass from the other
    /// key and Lucas–Kanade's ways carry the joints over the frames it lost, and the keys say
    /// which to follow (docs/method.md, "Motion between keys"). Off at first.
    pub fn set_key_ahead(&mut self, on: bool) {
        self.key_ahead = on;
    }

    /// Time spent in each part of the steps so far.
    pub fn timings(&self) -> Timings {
        self.timings
    }

    /// Frames stepped so far.
    pub(super) fn frame_count(&self) -> usize {
        self.timings.frames as usize
    }

    /// Keeps each step's intermediate results from now on (read them with [`Tracker::trace`]).
    pub fn enable_trace(&mut self) {
        self.trace = Some(Trace::default());
    }

    /// The last step's intermediate results, if [`Tracker::enable_trace`] was called.
    pub fn trace(&self) -> Option<&Trace> {
        self.trace.as_ref()
    }

    /// A gap filler for this skeleton, holding at most `fill_gaps_max` frames back.
    pub fn gap_filler(&self) -> GapFiller {
        self.gap_filler_over(self.params.fill_gaps_max as usize)
    }

    /// A gap filler for this skeleton, holding at most `max_gap` frames back.
    pub fn gap_filler_over(&self, max_gap: usize) -> GapFiller {
        GapFiller::new(self.user_parents.clone(), self.user_order.clone(), max_gap)
    }

    /// The resolution this tracker works at.
    pub fn work_scale(&self) -> WorkScale {
        self.work
    }

    /// The estimates of the last processed frame (the seed frame right after `new`), positions
    /// in the frame's pixels.
    pub fn current(&self) -> Vec<JointEstimate> {
        self.joints
            .iter()
            .zip(&self.angle_of)
            .map(|(j, of)| JointEstimate {
                pos: self.work.to_frame(j.last.pos),
                angle_rad: match *of {
                    AngleOf::Joint(k) => self.joints[k].last.angle_rad,
                    AngleOf::Zero => 0.0,
                },
                ..j.last
            })
            .collect()
    }

    /// The frame's views: every pyramid level with the plate's (`plate`: its levels), and the
    /// brightness gain.
    fn views<'a>(
        background: Option<&Background>,
        plate: &'a [RgbImage],
        pyr: &'a Pyramid,
        frame: &RgbImage,
    ) -> Vec<View<'a>> {
        let gain = background.map_or(1.0, |b| b.gain(frame));
        Self::views_at_gain(background, plate, pyr, gain)
    }

    /// [`Tracker::views`] with the frame's brightness gain already measured.
    fn views_at_gain<'a>(
        background: Option<&Background>,
        plate: &'a [RgbImage],
        pyr: &'a Pyramid,
        gain: f32,
    ) -> Vec<View<'a>> {
        let noise = background.map_or(1.0, |b| b.noise_sigma());
        let bg_inv = 1.0 / (3.0 * (2.0 * noise).powi(2));
        (0..pyr.levels())
            .map(|k| View {
                img: pyr.level(k),
                plate: plate.get(k).map(|p| Level::new(Image::new(p), k)),
                gain,
                bg_inv,
            })
            .collect()
    }

    /// Tracks one frame (the frame after the previous call). Returns every joint's estimate.
    ///
    /// The step runs on a thread of rayon's pool (the caller waits): its many small parallel
    /// sections then split work among the pool's threads directly, instead of each handing its
    /// work over from outside the pool and sleeping until it is done.
    ///
    /// `frame` is an image, or a decoded [`Frame`](super::scale::Frame) whose working image
    /// may have been made beforehand (by the decode thread) and whose pyramid is made by the
    /// first pass that steps over it and shared by the others.
    pub fn step(&mut self, frame: &impl AtWork) -> Vec<JointEstimate> {
        let (levels, work) = (self.model.levels, self.work);
        rayon::scope(|_| {
            let img = frame.at_work(work);
            self.step_in_pool(&img, || match frame.coarse_at(work, levels) {
                Some(coarse) => Pyramid::over(&img, coarse),
                None => Pyramid::new(&img, levels),
            })
        })
    }

    /// [`Tracker::step`], on whatever thread calls it, with the frame's pyramid from
    /// `pyramid`.
    fn step_in_pool<'f>(
        &mut self,
        frame: &'f RgbImage,
        pyramid: impl FnOnce() -> Pyramid<'f> + Send,
    ) -> Vec<JointEstimate> {
        let mut clock = std::time::Instant::now();
        let mut lap = |t: &mut f64| {
            let now = std::time::Instant::now();
            *t += (now - clock).as_secs_f64();
            clock = now;
        };
        let mut tm = self.timings;
        tm.frames += 1;
        let pred = self.predict();
        // The pyramid and the brightness gain, side by side.
        let background = self.background.as_ref();
        let (pyr, bg_gain) = rayon::join(pyramid, || background.map_or(1.0, |b| b.gain(frame)));
        // The plate's levels are lent to the views while the strips learn.
        let plate = std::mem::take(&mut self.plate);
        let gain = self.exposure.start(bg_gain);
        let mut views = Self::views_at_gain(self.background.as_ref(), &plate, &pyr, gain);
        let mut judge = views[self.params.judge_level.min(views.len() - 1)];
        lap(&mut tm.pyramid);
        let mut x = self.search(&views, &pred);
        let searched = self.trace.is_some().then(|| x.clone());
        lap(&mut tm.search);
        self.refine(&views, &pred, &mut x);
        let refined = self.trace.is_some().then(|| x.clone());
        // Judged and learnt at the gain the subject shows (`super::exposure`).
        let (strips, clear) = (&self.model.strips, self.params.ok_share);
        let gain = self
            .exposure
            .subject_gain(strips, &judge, &x, bg_gain, clear);
        if gain != views[0].gain {
            views = Self::views_at_gain(self.background.as_ref(), &plate, &pyr, gain);
            judge = views[self.params.judge_level.min(views.len() - 1)];
        }
        self.exposure.last = Some(gain);
        lap(&mut tm.refine);
        let mut fits = self.fits(&judge, &x);
        if self.flip_mirrored(&judge, &x, &mut fits) {
            self.refine(&views, &pred, &mut x);
            fits = self.fits(&judge, &x);
        }
        let mut evidence = self.evidence(&fits);
        let mut none = vec![false; x.len()];
        self.keep_bodies_apart(&x, &mut evidence, &mut none);
        self.place_hidden(&pred, &evidence, &none, &mut x);
        lap(&mut tm.judge);
        let mut found = self.reacquire_hidden(&views, &judge, &evidence, &mut x);
        if !self.key_ahead || self.params.redetect_toward_keys {
            for (f, r) in found
                .iter_mut()
                .zip(self.redetect(&views, &judge, &evidence, &mut x))
            {
                *f |= r;
            }
        }
        if found.iter().any(|&f| f) {
            self.refine(&views, &pred, &mut x);
            fits = self.fits(&judge, &x);
            evidence = self.evidence(&fits);
            self.keep_bodies_apart(&x, &mut evidence, &mut found);
            self.place_hidden(&pred, &evidence, &found, &mut x);
        }
        let trace = match (searched, refined) {
            (Some(searched), Some(refined)) => Some(Trace {
                predicted: pred.iter().map(|q| self.work.to_frame(q.pos)).collect(),
                searched: searched.iter().map(|&q| self.work.to_frame(q)).collect(),
                refined: refined.iter().map(|&q| self.work.to_frame(q)).collect(),
                evidence: evidence.clone(),
                reacquired: found.clone(),
                gain,
                plate_gain: bg_gain,
            }),
            _ => None,
        };
        lap(&mut tm.reacquire);
        // A hidden joint placed by its child's bone found whole (an elbow behind the torso
        // placed by its seen forearm) counts as seen, poorly: its place is an inference from
        // what shows, not a coast.
        let anchored: Vec<bool> = (0..x.len())
            .map(|j| {
                found[j]
                    && evidence[j] < self.params.seen_share
                    && self.children[j]
                        .iter()
                        .any(|&c| found[c] && evidence[c] >= self.params.seen_share)
            })
            .collect();
        let placements = self.update(&pred, &x, &evidence, &anchored);
        self.learn(&views, &x, &fits, &evidence, &placements);
        lap(&mut tm.learn);
        self.timings = tm;
        drop(views);
        self.plate = plate;
        if trace.is_some() {
            self.trace = trace;
        }
        self.current()
    }

    /// Predicted position of every joint (docs/method.md eq. 2–3), parents first.
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
            let parent = self.parents[j].map(|p| pred[p].pos);
            pred[j] = self.joints[j].motion.predict(parent, self.frame_max);
        }
        pred
    }

    /// Strips whose bone was seen learn from the frame (see [`Strip::learn`]); `placements`
    /// says where the other seen bones lay, for telling their pixels apart.
    fn learn(
        &mut self,
        views: &[View],
        x: &[Point],
        fits: &[Fit],
        evidence: &[f32],
        placements: &[Option<Placement>],
    ) {
        let p = &self.params;
        let bounds = (0.75 * self.model.sigma, 2.0 * self.model.sigma);
        let seen =
            |s: &Strip| evidence[s.parent] >= p.seen_share && evidence[s.child] >= p.seen_share;
        let clear: Vec<Option<Placement>> = placements
            .iter()
            .zip(fits)
            .map(|(pl, f)| pl.filter(|_| f.inliers >= p.ok_share))
            .collect();
        for (s, f) in self.model.strips.iter_mut().zip(fits) {
            if seen(s) {
                let pose = (x[s.parent], x[s.child]);
                s.learn(
                    views,
                    pose,
                    &clear,
                    p.update_rate,
                    p.anchor_weight,
                    bounds,
                    f,
                );
            }
        }
    }

    /// Joint `j` and everything below it.
    pub(super) fn descendants_and_self(&self, j: usize) -> Vec<usize> {
        let mut out = vec![j];
        let mut k = 0;
        while k < out.len() {
            out.extend(self.children[out[k]].iter().copied());
            k += 1;
        }
        out
    }
}

/// Joints grouped by depth (roots at depth 0), each group in the order of `order` (parents
/// before children).
fn depths(parents: &[Option<usize>], order: &[usize]) -> Vec<Vec<usize>> {
    let mut depth = vec![0usize; parents.len()];
    let mut out: Vec<Vec<usize>> = Vec::new();
    for &j in order {
        depth[j] = parents[j].map_or(0, |p| depth[p] + 1);
        if out.len() <= depth[j] {
            out.resize(depth[j] + 1, Vec::new());
        }
        out[depth[j]].push(j);
    }
    out
}
