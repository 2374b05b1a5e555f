//! One segment's tracking: its passes forward, the passes backward from the next correction,
//! their blend, and between keys the path solved through both ends (docs/method.md §3, "Motion
//! between keys").

use super::pass::{Appearance, Frames, Pass};
use super::Session;
use super::{ahead, flow, spans};
use crate::error::Result;
use crate::geom::Point;
use crate::run::keyed;
use crate::run::keys::{self, Key};
use crate::track::flow::GreyPyramid;
use crate::track::scale::Frame;
use crate::track::{JointEstimate, Status};
use image::RgbImage;

impl Session {
    /// Tracks segment `k` from its first frame `first` (already decoded) on. Returns its rows
    /// and, unless the clip ends within it, the estimate on the next segment's first frame with
    /// that frame. When segment file `k + 1` is a correction (the next segment's first frame,
    /// or the clip's last frame), the segment's frames are held and tracked backward from it
    /// too, and the passes blended ([`crate::run::blend`]).
    #[allow(clippy::type_complexity)]
    pub(super) fn track_segment<I: Iterator<Item = Result<(u64, Frame)>>>(
        &mut self,
        k: u64,
        first: &Frame,
        frames: &mut Frames<'_, I>,
        keys: &[Key],
    ) -> Result<(
        Vec<(u64, Vec<JointEstimate>)>,
        Option<(Vec<JointEstimate>, Frame)>,
    )> {
        let plan = self.plan();
        let next = plan.first_frame(k + 1);
        let mut start = self.start(k)?;
        if let (true, Some(r)) = (start.corrected, &self.last_angles) {
            start.align_turns(r);
        }
        // Each joint's rectangle's smaller side (px): Lucas–Kanade's window between keys.
        let boxes: Vec<u32> = start
            .seeds
            .joints
            .iter()
            .map(|j| j.bbox.w.min(j.bbox.h))
            .collect();
        let mut end = self.correction(k + 1)?;
        if !first.has_full() {
            // Frames kept at their working resolution alone (a plain `track` that found no
            // corrections and no keys as it started): a correction written since is not blended
            // back from, which needs Lucas–Kanade at full resolution; the segment after starts
            // from it, and `resume` blends it.
            end = None;
        }
        let keyframe = k == 0 || start.corrected;
        let corrected = k > 0 && start.corrected;
        let learnt = match (k, self.carried.take()) {
            (0, _) => None,
            (_, Some(b)) => Some(b),
            (_, None) => Some(self.read_state(k)?),
        };
        let mut forward = vec![self.tracker_at(
            &start,
            first,
            match &learnt {
                None => Appearance::Here,
                Some(b) if corrected => Appearance::LearntMoved(k, b),
                Some(b) => Appearance::Learnt(k, b),
            },
        )?];
        // Keys of `keys.toml` on this segment's first frame, inside it, and on the next one's
        // first frame ([`crate::run::keys`]).
        let first_frame = plan.first_frame(k);
        let key_here = keys.iter().find(|x| x.frame == first_frame);
        let inner: Vec<&Key> = keys
            .iter()
            .filter(|x| x.frame > first_frame && x.frame < next)
            .collect();
        let key_next = keys.iter().find(|x| x.frame == next);
        // The keys after the segment's end that its last spans are solved through (each
        // joint's next), read ahead ([`ahead`]).
        let past_end = ahead::keys_past_end(keys, next, end.is_some(), first.bytes());
        let hold = end.is_some() || !inner.is_empty() || key_next.is_some() || !past_end.is_empty();
        // Whether a key of every joint lies on or beyond frame `idx` for a pass run forward (the
        // next correction, a key at or past the segment's end, or one inside still to come) and
        // for one run backward (the segment's first frame when it is a key, or a key inside still
        // to come): there a pass may leave out the search for a lost body over the whole frame
        // (`redetect_toward_keys`, [`crate::track::Tracker::set_key_ahead`]).
        let far_key = end.is_some()
            || key_next.is_some_and(Key::gives_every_joint)
            || past_end.iter().any(|x| x.gives_every_joint());
        let start_key = keyframe || key_here.is_some_and(Key::gives_every_joint);
        let ahead_forward = |idx: u64| {
            far_key
                || inner
                    .iter()
                    .any(|x| x.frame >= idx && x.gives_every_joint())
        };
        let ahead_backward = |idx: u64| {
            start_key
                || inner
                    .iter()
                    .any(|x| x.frame <= idx && x.gives_every_joint())
        };
        // Between two corrections with no key inside, the passes that only feed the blend wait
        // until the span is known not to be led by flow ([`keyed::lead`]): where it is,
        // the carried pass and the one backward from the correction decide, at two passes'
        // cost instead of five. Those passes are not even built until then.
        let lean = corrected && end.is_some() && inner.is_empty() && key_next.is_none();
        let mut deferred: Vec<Appearance> = Vec::new();
        if corrected {
            deferred.push(Appearance::Here);
            if end.is_some() {
                deferred.push(Appearance::SeedFrame);
            }
        }
        // Builds the forward passes on the segment's first frame, moved onto a key there.
        let build = |session: &Self, appearances: &[Appearance]| -> Result<Vec<Pass>> {
            let mut passes = Vec::new();
            for &a in appearances {
                let mut p = session.tracker_at(&start, first, a)?;
                if let Some(key) = key_here {
                    p.move_to(key);
                }
                passes.push(p);
            }
            Ok(passes)
        };
        if !lean {
            forward.extend(build(self, &deferred)?);
            deferred.clear();
        }
        if let Some(key) = key_here {
            forward[0].move_to(key);
        }
        let mut held: Vec<Frame> = Vec::new();
        let mut boundary: Option<Frame> = None;
        // Lucas–Kanade's pyramids of the frames held (and the first and the next key's), built
        // as they arrive, alongside the passes.
        let mut built = flow::Built::new(hold);
        built.add(first);
        while let Some((idx, frame)) = frames.next()? {
            rayon::join(
                || {
                    for p in &mut forward {
                        p.step(idx, &frame, ahead_forward(idx));
                    }
                },
                || built.add(&frame),
            );
            if idx == next {
                boundary = Some(frame);
                break;
            }
            if let Some(key) = inner.iter().find(|x| x.frame == idx) {
                for p in &mut forward {
                    p.move_to(key);
                }
            }
            if hold {
                held.push(frame);
            }
        }
        if boundary.is_none() {
            // The clip ended inside this segment: a key past its last frame has no frame to
            // pull (docs/formats.md, "Keys").
            let size = (self.width, self.height);
            keys::check_within(&self.run_dir, &self.names, size, keys, frames.count)?;
        }
        let mut passes = forward.into_iter();
        let (mut out, tracker) = passes.next().expect("one forward pass").finish_keep();
        let forward: Vec<Vec<(u64, Vec<JointEstimate>)>> = passes.map(Pass::finish).collect();
        self.carried = Some(tracker.state());
        if keyframe {
            out[0].1 = start.row.clone();
        } else if key_here.is_none()
            && (!inner.is_empty() || key_next.is_some() || !past_end.is_empty())
        {
            // The previous segment's last span ran on to the next key: the row solved on this
            // frame, which the tool wrote into this segment's file ([`ahead`]), is where this
            // segment's first span starts.
            for (e, s) in out[0].1.iter_mut().zip(&start.row) {
                (e.pos, e.score, e.status) = (s.pos, s.score, s.status);
            }
        }
        if let Some(key) = key_here {
            keyed_row(&mut out[0].1, key);
        }
        let mut at_next = boundary.as_ref().map(|_| out.pop().expect("pushed").1);
        // Where the carried tracker got to on the next key's frame.
        let mut carried_end: Option<Vec<Point>> =
            at_next.as_ref().map(|r| r.iter().map(|x| x.pos).collect());
        // A correction on the clip's last frame, inside this segment: the last frame held.
        let tail = match (&mut end, &boundary) {
            (Some(e), None) if !held.is_empty() && e.seeds.frame + 1 == frames.count => {
                let last = &mut out.last_mut().expect("held frames were tracked").1;
                carried_end = Some(last.iter().map(|x| x.pos).collect());
                e.align_turns(&last.iter().map(|x| x.angle_rad).collect::<Vec<_>>());
                *last = e.row.clone();
                held.pop()
            }
            (Some(e), Some(_)) => {
                let at = at_next.as_ref().expect("a boundary");
                e.align_turns(&at.iter().map(|x| x.angle_rad).collect::<Vec<_>>());
                None
            }
            _ => None,
        };
        // Each pass's estimates on the frames between the first and the next keyframe (`n`).
        let between = |p: &[(u64, Vec<JointEstimate>)], n: usize| -> Vec<Vec<JointEstimate>> {
            p[1..=n].iter().map(|(_, e)| e.clone()).collect()
        };
        // The tracker built on the next correction, run backward to this segment's start.
        let mut back_here: Option<Vec<Vec<Point>>> = None;
        // Which cue leads the span, when judged before the blend (see `lean`).
        let mut led_early: Option<keyed::Lead> = None;
        let mut early_pyramids: Option<Vec<GreyPyramid>> = None;
        let mut early_ways: Option<keyed::Ways> = None;
        let passes = if let (Some(end), Some(bf)) = (&end, boundary.as_ref().or(tail.as_ref())) {
            let n = held.len();
            let mut passes: Vec<Vec<Vec<JointEstimate>>> = Vec::new();
            // The tracker built on the correction, run backward over the held frames.
            let back_pass = |appearance: Appearance| -> Result<Vec<(u64, Vec<JointEstimate>)>> {
                let mut p = self.tracker_at(end, bf, appearance)?;
                for (i, f) in held.iter().enumerate().rev() {
                    let idx = plan.first_frame(k) + 1 + i as u64;
                    p.step(idx, f, ahead_backward(idx));
                }
                let mut back = p.finish();
                back.reverse();
                Ok(back)
            };
            let images: Vec<&RgbImage> = std::iter::once(first)
                .chain(held.iter())
                .chain(Some(bf))
                .map(|f| f.full())
                .collect();
            for appearance in [Appearance::Here, Appearance::SeedFrame] {
                if matches!(appearance, Appearance::SeedFrame) && lean_enough(led_early) {
                    break;
                }
                // Lucas–Kanade's pyramids and ways between the keys do not depend on the
                // passes: where the span is to be judged, they are found alongside the first.
                let judge = lean && led_early.is_none();
                // (The spare buffers are this thread's: taken here, not on the pool's.)
                let ready = if judge { built.take() } else { None };
                let (back, flow) = rayon::join(
                    || back_pass(appearance),
                    || {
                        ready.map(|pyramids| {
                            flow::follow_flow(
                                pyramids,
                                &images,
                                &out[0].1,
                                &end.row,
                                carried_end.is_some() && n > 0,
                                &boxes,
                            )
                        })
                    },
                );
                let back = back?;
                if back_here.is_none() {
                    back_here = Some(
                        back[..n]
                            .iter()
                            .map(|(_, r)| r.iter().map(|x| x.pos).collect())
                            .collect(),
                    );
                }
                passes.push(back[..n].iter().map(|(_, e)| e.clone()).collect());
                if let Some((pyramids, ways)) = flow {
                    led_early = Some(flow::early_lead(
                        ways.as_ref(),
                        &out[0].1,
                        &end.row,
                        carried_end.as_deref(),
                        &out[1..=n],
                        &passes[0],
                        self.params.ok_share,
                    ));
                    early_pyramids = Some(pyramids);
                    early_ways = ways;
                }
            }
            // Between two corrections, the passes that start on them decide: the carried tracker
            // adds nothing there (on flies, 12 files corrected, it cost 1.5 points), unless the
            // span is led by flow and the passes built on the keys' appearance were not run.
            let mut first_passes = Vec::new();
            if !corrected || lean_enough(led_early) {
                first_passes.push(between(&out, n));
            }
            let later = match lean_enough(led_early) {
                true => Vec::new(),
                false => run_over(
                    build(self, &deferred)?,
                    first_frame,
                    &held,
                    Some((first_frame + 1 + n as u64, bf)),
                    ahead_forward,
                ),
            };
            first_passes.extend(forward.iter().chain(&later).map(|p| between(p, n)));
            first_passes.extend(passes);
            first_passes
        } else if corrected {
            // After the last correction: the carried tracker and the one built on the
            // correction.
            let n = out.len() - 1;
            let mut passes = vec![between(&out, n)];
            let later = run_over(
                build(self, &deferred)?,
                first_frame,
                &held,
                None,
                ahead_forward,
            );
            passes.extend(forward.iter().chain(&later).map(|p| between(p, n)));
            passes
        } else {
            Vec::new()
        };
        if !passes.is_empty() {
            for (row, b) in out[1..]
                .iter_mut()
                .zip(crate::run::blend::blend(&passes, self.params.ok_share))
            {
                row.1 = b;
            }
        }
        // Between two keys, the path through both ([`crate::run::keyed`]): from the segment's
        // first frame through every key inside it to the next segment's file when that is a
        // correction (or the clip's last frame is), to a key on the next segment's first frame,
        // or on to each joint's next key past the segment's end.
        let last = boundary.as_ref().or(tail.as_ref());
        let n = held.len();
        let ahead = match (past_end.last(), &boundary) {
            (Some(key), Some(_)) => {
                // The last frame a key of every joint read ahead lies on, if any.
                let whole_until = past_end
                    .iter()
                    .filter(|x| x.gives_every_joint())
                    .map(|x| x.frame)
                    .max();
                self.read_ahead(k + 1, next, key.frame, whole_until, frames, &mut built)?
            }
            _ => None,
        };
        let mut anchors: Vec<(usize, Vec<Option<Point>>)> =
            vec![(0, out[0].1.iter().map(|e| Some(e.pos)).collect())];
        anchors.extend(
            inner
                .iter()
                .map(|key| ((key.frame - first_frame) as usize, key.joints.clone())),
        );
        match (&end, key_next, last) {
            (Some(end), _, Some(_)) => {
                anchors.push((n + 1, end.row.iter().map(|e| Some(e.pos)).collect()))
            }
            (None, Some(key), Some(_)) if boundary.is_some() => {
                anchors.push((n + 1, key.joints.clone()))
            }
            _ => {}
        }
        if ahead.is_some() {
            for key in &past_end {
                anchors.push((n + 1 + (key.frame - next) as usize, key.joints.clone()));
            }
        }
        if anchors.len() > 1 {
            let ahead_frames = ahead.iter().flat_map(|a| a.frames.iter().map(|(_, f)| f));
            let images: Vec<&RgbImage> = std::iter::once(first)
                .chain(held.iter())
                .chain(last)
                .chain(ahead_frames)
                .map(|f| f.full())
                .collect();
            let ahead_rows = ahead.iter().flat_map(|a| a.rows.iter());
            // The blend's rows, the next key's frame included (and the frames read ahead).
            let blended: Vec<&[JointEstimate]> = out
                .iter()
                .map(|(_, r)| r.as_slice())
                .chain(at_next.as_deref())
                .chain(ahead_rows.map(Vec::as_slice))
                .collect();
            let mut track_pos: Vec<Vec<Point>> = blended
                .iter()
                .map(|r| r.iter().map(|e| e.pos).collect())
                .collect();
            let ok_share = self.params.ok_share;
            let track_ok: Vec<Vec<bool>> = blended
                .iter()
                .map(|r| r.iter().map(|e| e.fits_alone(ok_share)).collect())
                .collect();
            let top = anchors.last().expect("two anchors").0;
            let pyramids: Vec<GreyPyramid> = match early_pyramids.take() {
                Some(p) => p,
                None => match built.take() {
                    Some(mut p) if p.len() == images.len() => {
                        p.truncate(top + 1);
                        p
                    }
                    _ => flow::pyramids_of(flow::take_spare(), &images[..=top]),
                },
            };
            let between = spans::Between {
                anchors: &anchors,
                pyramids: &pyramids,
                blended: &blended,
                track_ok: &track_ok,
                boxes: &boxes,
                led_early,
                corrected_end: end.is_some(),
                back_here: back_here.as_deref(),
                carried_end: carried_end.as_deref(),
                ok_share,
            };
            let doubt = between.solve(&mut track_pos, early_ways.take());
            // Kept for the next segment's frames; at the clip's end, let go.
            if boundary.is_some() {
                flow::put_spare(pyramids);
            } else {
                flow::put_spare(Vec::new());
            }
            for (i, (_, row)) in out.iter_mut().enumerate().take(top + 1).skip(1) {
                for (j, e) in row.iter_mut().enumerate() {
                    if doubt[i][j].is_nan() {
                        continue;
                    }
                    e.pos = track_pos[i][j];
                    e.score = keyed::score(doubt[i][j]);
                    e.status = keyed::status(doubt[i][j]);
                }
            }
            // The next segment's first frame, on a span that runs on past it: the row it starts
            // from.
            if let (Some(_), Some(row)) = (&ahead, at_next.as_mut()) {
                for (j, e) in row.iter_mut().enumerate() {
                    if !doubt[n + 1][j].is_nan() {
                        e.pos = track_pos[n + 1][j];
                        e.score = keyed::score(doubt[n + 1][j]);
                        e.status = keyed::status(doubt[n + 1][j]);
                    }
                }
            }
            for key in &inner {
                keyed_row(&mut out[(key.frame - first_frame) as usize].1, key);
            }
            if let (None, Some(key), Some(row)) = (&end, key_next, at_next.as_mut()) {
                keyed_row(row, key);
            }
        }
        // The frames read ahead are the next segment's.
        if let Some(a) = ahead {
            frames.unread(a.frames);
        }
        // Hidden stretches are filled again over the whole segment at once, between where the
        // joint was seen on either side and with the frames around each gap at hand (the pass's
        // filler hands frames out after `fill_gaps_max`, and a pass that lost a joint up to a
        // keyframe coasted), up to the next keyframe if any.
        if self.params.fill_gaps_max > 0 {
            let end_row = match (&end, &boundary) {
                (Some(e), Some(_)) => Some((next, e.row.clone())),
                _ => None,
            };
            let rows = out.iter().cloned().chain(end_row).collect();
            let filled = tracker.gap_filler().fill_all(rows);
            for (row, (_, f)) in out.iter_mut().zip(filled) {
                row.1 = f;
            }
        }
        // Rows from several passes, or a pass and its keyframe, may count turns differently.
        for i in 1..out.len() {
            let (done, rest) = out.split_at_mut(i);
            for (e, p) in rest[0].1.iter_mut().zip(&done[i - 1].1) {
                e.angle_rad = crate::run::segments::turns_near(p.angle_rad, e.angle_rad);
            }
        }
        Ok((out, at_next.zip(boundary)))
    }
}

/// Runs `passes` (started on frame `first_frame`) over the `held` frames that follow it and
/// the frame `last` after them, if any (the next key's: a pass hands rows out after it has seen
/// the frames that follow them, so its rows on the held frames depend on it); `key_ahead(idx)`:
/// whether a key of every joint lies on or beyond frame `idx` ([`Pass::step`]).
fn run_over(
    mut passes: Vec<Pass>,
    first_frame: u64,
    held: &[Frame],
    last: Option<(u64, &Frame)>,
    key_ahead: impl Fn(u64) -> bool,
) -> Vec<Vec<(u64, Vec<JointEstimate>)>> {
    let frames = held
        .iter()
        .enumerate()
        .map(|(i, f)| (first_frame + 1 + i as u64, f));
    for (idx, f) in frames.chain(last) {
        for p in &mut passes {
            p.step(idx, f, key_ahead(idx));
        }
    }
    passes.into_iter().map(Pass::finish).collect()
}

/// Puts a key's joints into a row: their positions, status `seed`, score 1.
pub(super) fn keyed_row(row: &mut [JointEstimate], key: &Key) {
    for (e, k) in row.iter_mut().zip(&key.joints) {
        if let Some(p) = k {
            e.pos = *p;
            e.status = Status::Seed;
            e.score = 1.0;
        }
    }
}

/// Whether a span judged early (from the carried pass and the one backward from the
/// correction) needs no more tracker passes: Lucas–Kanade leads it (see [`keyed::Lead`]). A
/// span in doubt runs them all: its joints go to the tracker where it landed nearer the keys.
fn lean_enough(lead: Option<keyed::Lead>) -> bool {
    lead == Some(keyed::Lead::Flow)
}
