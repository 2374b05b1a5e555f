//! A tracker on a keyframe: moved or restarted there (a correction, a key), its appearance for
//! bones hidden there taken from the seed frame's tracker, and what diagnostics ask of a bone.

use super::super::motion::Motion;
use super::super::pixels::Pyramid;
use super::super::scale::AtWork;
use super::super::strip::Fit;
use super::super::{JointEstimate, Status};
use super::{Tracker, HIDDEN_AT_KEYFRAME};
use crate::geom::{direction, unwrap_angle, Point};

impl Tracker {
    /// Restarts tracking from `centres` (px, one per joint in seed-file order) as if they were
    /// seeds on the frame last processed: motion filters start at rest there, hidden runs end,
    /// every status is `seed`. The appearance model is kept, and angles stay measured from the
    /// seed pose. For restarting a segment without rebuilding the appearance on its first frame.
    pub fn restart_at(&mut self, centres: &[Point]) {
        self.restart(centres, false)
    }

    /// [`Tracker::restart_at`], the motion filters keeping their rates (a correction).
    pub fn restart_moving(&mut self, centres: &[Point]) {
        self.restart(centres, true)
    }

    /// [`Tracker::restart_moving`] for a key that gives the joints where `keyed` holds only:
    /// the others keep what the tracker knows of them (seen or hidden, their score), their
    /// motion filters moved only where their parent moved (their bone changed).
    pub fn restart_moving_keyed(&mut self, centres: &[Point], keyed: &[bool]) {
        let centres: &[Point] = &centres
            .iter()
            .map(|&c| self.work.to_work(c))
            .collect::<Vec<_>>();
        for o in 0..self.order.len() {
            let j = self.order[o];
            let par = self.parents[j];
            if keyed[j] {
                self.restart_joint(j, centres, true);
            } else if par.is_some_and(|p| keyed[p]) {
                let m = &mut self.joints[j].motion;
                m.moved_to(centres[j], par.map(|p| centres[p]));
            }
        }
    }

    fn restart(&mut self, centres: &[Point], moving: bool) {
        let centres: &[Point] = &centres
            .iter()
            .map(|&c| self.work.to_work(c))
            .collect::<Vec<_>>();
        for o in 0..self.order.len() {
            self.restart_joint(self.order[o], centres, moving);
        }
    }

    /// Restarts joint `j` at `centres[j]` (working px), as [`Tracker::restart`] does.
    fn restart_joint(&mut self, j: usize, centres: &[Point], moving: bool) {
        let par = self.parents[j];
        let motion = if moving {
            let mut m = self.joints[j].motion.clone();
            m.moved_to(centres[j], par.map(|p| centres[p]));
            m
        } else {
            self.motion_at_rest(j, centres)
        };
        let state = &mut self.joints[j];
        state.motion = motion;
        state.hidden_run = 0;
        let dir = match par {
            Some(p) => Some(direction(centres[p], centres[j])),
            None if self.params.rotate_roots => self.children[j]
                .first()
                .map(|&c| direction(centres[j], centres[c])),
            None => None,
        };
        state.last = JointEstimate {
            pos: centres[j],
            angle_rad: dir.map_or(0.0, |d| unwrap_angle(0.0, d - state.seed_dir)),
            score: 1.0,
            status: Status::Seed,
        };
    }

    /// Joint `j`'s motion model at rest with the joints at `x` (px): a root's position, or the
    /// bone from its parent.
    pub(in crate::track) fn motion_at_rest(&self, j: usize, x: &[Point]) -> Motion {
        match self.parents[j] {
            None => Motion::root(x[j], &self.params),
            Some(p) => Motion::bone(x[p], x[j], &self.params),
        }
    }

    /// Diagnostics: how the strip of the bone ending at joint `child` fits `frame` (on the
    /// judging level) with its parent at `p` and the child at `c`.
    pub fn fit_bone(&self, frame: &impl AtWork, child: usize, p: Point, c: Point) -> Option<Fit> {
        let s = &self.model.strips[self.model.strip_of[child]?];
        let frame = &frame.at_work(self.work);
        let (p, c) = (self.work.to_work(p), self.work.to_work(c));
        let pyr = Pyramid::new(frame, self.model.levels);
        let views = Self::views(self.background.as_ref(), &self.plate, &pyr, frame);
        Some(s.fit(&views[self.params.judge_level.min(views.len() - 1)], p, c))
    }

    /// For a tracker built on a keyframe other than the seed frame (a correction): the bones
    /// that `seed` (built on the seed frame) does not find at this tracker's seed positions on
    /// `frame` (this keyframe), laid either way round, were hidden there, so what this tracker
    /// sampled for them is whatever covered them. They take `seed`'s appearance instead.
    /// Returns the joints whose bones did. A bone counts as found when at least
    /// [`HIDDEN_AT_KEYFRAME`] of its samples fit, overall or at its child end.
    /// Both trackers must work at one resolution (nothing is adopted otherwise).
    pub fn adopt_hidden_from(&mut self, seed: &Tracker, frame: &impl AtWork) -> Vec<usize> {
        if seed.work != self.work {
            debug_assert!(false, "trackers at two working resolutions");
            return Vec::new();
        }
        let frame = &frame.at_work(self.work);
        let pyr = Pyramid::new(frame, seed.model.levels);
        let views = Self::views(seed.background.as_ref(), &seed.plate, &pyr, frame);
        let v = &views[seed.params.judge_level.min(views.len() - 1)];
        let mut adopted = Vec::new();
        for (j, par) in self.parents.clone().into_iter().enumerate() {
            let (Some(par), Some(si)) = (par, self.model.strip_of[j]) else {
                continue;
            };
            if seed.model.strip_of[j] != Some(si) {
                continue;
            }
            let s = &seed.model.strips[si];
            let (p, c) = (self.seed_pos[par], self.seed_pos[j]);
            let found = [false, true].into_iter().any(|m| {
                let f = s.fit_as(v, p, c, m);
                f.inliers.max(f.child_end) >= HIDDEN_AT_KEYFRAME
            });
            if !found {
                self.model.strips[si] = s.clone();
                adopted.push(j);
            }
        }
        adopted
    }

    /// Diagnostics: [`Strip::probe`] (the working resolution's level 0; the positions it
    /// returns are in that frame's pixels) of the bone ending at joint `child`.
    pub fn probe_bone(
        &self,
        frame: &impl AtWork,
        child: usize,
        p: Point,
        c: Point,
    ) -> Vec<(f32, f32, f32, f32)> {
        let frame = &frame.at_work(self.work);
        let (p, c) = (self.work.to_work(p), self.work.to_work(c));
        let pyr = Pyramid::new(frame, 1);
        let views = Self::views(self.background.as_ref(), &self.plate, &pyr, frame);
        self.model.strip_of[child].map_or(Vec::new(), |si| {
            self.model.strips[si].probe(&views[0], p, c)
        })
    }

    /// One line per strip for diagnostics (see [`Strip::summary`]).
    pub fn strip_summaries(&self) -> Vec<String> {
        self.model.strips.iter().map(|s| s.summary()).collect()
    }
}
