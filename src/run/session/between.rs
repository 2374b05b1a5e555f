//! A segment's frames between its keys, after its passes forward ([`super::segment`]): the
//! passes backward from the next correction, their blend with the forward ones, and the path
//! solved through both ends (docs/method.md §3, "Motion between keys").

use super::flow;
use super::pass::{Appearance, Frames, Pass};
use super::segment::{keyed_row, SegmentPlan};
use super::spans;
use super::Session;
use crate::error::Result;
use crate::geom::Point;
use crate::run::keyed;
use crate::run::segments::Start;
use crate::track::flow::GreyPyramid;
use crate::track::scale::Frame;
use crate::track::JointEstimate;
use image::RgbImage;

/// What a segment's forward passes left: the carried pass's rows and the other passes', the
/// frames held, and the frames and rows at the segment's end.
pub(super) struct Tracked {
    /// The carried pass's rows: the segment's first frame's, then the held frames'.
    pub(super) out: Vec<(u64, Vec<JointEstimate>)>,
    /// The other forward passes' rows.
    pub(super) forward: Vec<Vec<(u64, Vec<JointEstimate>)>>,
    /// The frames after the first, held for the passes backward and the path between keys.
    pub(super) held: Vec<Frame>,
    /// The next segment's first frame, unless the clip ended first.
    pub(super) boundary: Option<Frame>,
    /// The clip's last frame when a correction lies on it inside this segment.
    pub(super) tail: Option<Frame>,
    /// The carried pass's row on the next segment's first frame.
    pub(super) at_next: Option<Vec<JointEstimate>>,
    /// Where the carried tracker got to on the next key's frame.
    pub(super) carried_end: Option<Vec<Point>>,
}

/// What the passes backward and the span's early judgement leave for the path between keys.
pub(super) struct Early {
    /// The tracker built on the next correction, run backward to this segment's start.
    back_here: Option<Vec<Vec<Point>>>,
    /// Which cue leads the span, when judged before the blend (see `lean`).
    led: Option<keyed::Lead>,
    /// Lucas–Kanade's pyramids, when built for the early judgement.
    pyramids: Option<Vec<GreyPyramid>>,
    /// Lucas–Kanade's ways between the keys, when found for the early judgement.
    ways: Option<keyed::Ways>,
}

impl Session {
    /// Runs the passes backward from the correction that ends the segment (`end`) and the
    /// deferred forward ones, and blends them with the forward passes into `run.out`.
    pub(super) fn blend_passes(
        &self,
        seg: &SegmentPlan<'_>,
        end: Option<&Start>,
        run: &mut Tracked,
        deferred: &[Appearance],
        built: &mut flow::Built,
    ) -> Result<Early> {
        let Tracked {
            out,
            forward,
            held,
            boundary,
            tail,
            carried_end,
            ..
        } = run;
        let first_frame = seg.first_frame;
        // The tracker built on the next correction, run backward to this segment's start.
        let mut back_here: Option<Vec<Vec<Point>>> = None;
        // Which cue leads the span, when judged before the blend (see `lean`).
        let mut led_early: Option<keyed::Lead> = None;
        let mut early_pyramids: Option<Vec<GreyPyramid>> = None;
        let mut early_ways: Option<keyed::Ways> = None;
        let passes = if let (Some(end), Some(bf)) = (end, boundary.as_ref().or(tail.as_ref())) {
            let n = held.len();
            let mut passes: Vec<Vec<Vec<JointEstimate>>> = Vec::new();
            // The tracker built on the correction, run backward over the held frames.
            let back_pass = |appearance: Appearance| -> Result<Vec<(u64, Vec<JointEstimate>)>> {
                let mut p = self.tracker_at(end, bf, appearance)?;
                for (i, f) in held.iter().enumerate().rev() {
                    let idx = first_frame + 1 + i as u64;
                    p.step(idx, f, seg.ahead_backward(idx));
                }
                let mut back = p.finish();
                back.reverse();
                Ok(back)
            };
            let images: Vec<&RgbImage> = std::iter::once(seg.first)
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
                let judge = seg.lean && led_early.is_none();
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
                                &seg.boxes,
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
            if !seg.corrected || lean_enough(led_early) {
                first_passes.push(between(out, n));
            }
            let later = match lean_enough(led_early) {
                true => Vec::new(),
                false => run_over(
                    seg.build(self, deferred)?,
                    first_frame,
                    held,
                    Some((first_frame + 1 + n as u64, bf)),
                    |idx| seg.ahead_forward(idx),
                ),
            };
            first_passes.extend(forward.iter().chain(&later).map(|p| between(p, n)));
            first_passes.extend(passes);
            first_passes
        } else if seg.corrected {
            // After the last correction: the carried tracker and the one built on the
            // correction.
            let n = out.len() - 1;
            let mut passes = vec![between(out, n)];
            let later = run_over(seg.build(self, deferred)?, first_frame, held, None, |idx| {
                seg.ahead_forward(idx)
            });
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
        Ok(Early {
            back_here,
            led: led_early,
            pyramids: early_pyramids,
            ways: early_ways,
        })
    }

    /// Solves the path between the segment's keys through the blended rows (read ahead past
    /// its end when a span runs on), writes it into `run.out` and `run.at_next`, and gives the
    /// frames read ahead back to `frames`.
    pub(super) fn solve_path<I: Iterator<Item = Result<(u64, Frame)>>>(
        &self,
        seg: &SegmentPlan<'_>,
        end: Option<&Start>,
        run: &mut Tracked,
        frames: &mut Frames<'_, I>,
        built: &mut flow::Built,
        early: Early,
    ) -> Result<()> {
        let Tracked {
            out,
            held,
            boundary,
            tail,
            at_next,
            carried_end,
            ..
        } = run;
        let (first_frame, next) = (seg.first_frame, seg.next);
        // Between two keys, the path through both ([`crate::run::keyed`]): from the segment's
        // first frame through every key inside it to the next segment's file when that is a
        // correction (or the clip's last frame is), to a key on the next segment's first frame,
        // or on to each joint's next key past the segment's end.
        let last = boundary.as_ref().or(tail.as_ref());
        let n = held.len();
        let ahead = match (seg.past_end.last(), &boundary) {
            (Some(key), Some(_)) => {
                // The last frame a key of every joint read ahead lies on, if any.
                let whole_until = seg
                    .past_end
                    .iter()
                    .filter(|x| x.gives_every_joint())
                    .map(|x| x.frame)
                    .max();
                self.read_ahead(seg.k + 1, next, key.frame, whole_until, frames, built)?
            }
            _ => None,
        };
        let mut anchors: Vec<(usize, Vec<Option<Point>>)> =
            vec![(0, out[0].1.iter().map(|e| Some(e.pos)).collect())];
        anchors.extend(
            seg.inner
                .iter()
                .map(|key| ((key.frame - first_frame) as usize, key.joints.clone())),
        );
        match (end, seg.key_next, last) {
            (Some(end), _, Some(_)) => {
                anchors.push((n + 1, end.row.iter().map(|e| Some(e.pos)).collect()))
            }
            (None, Some(key), Some(_)) if boundary.is_some() => {
                anchors.push((n + 1, key.joints.clone()))
            }
            _ => {}
        }
        if ahead.is_some() {
            for key in &seg.past_end {
                anchors.push((n + 1 + (key.frame - next) as usize, key.joints.clone()));
            }
        }
        if anchors.len() > 1 {
            let ahead_frames = ahead.iter().flat_map(|a| a.frames.iter().map(|(_, f)| f));
            let images: Vec<&RgbImage> = std::iter::once(seg.first)
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
            let pyramids: Vec<GreyPyramid> = match early.pyramids {
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
                boxes: &seg.boxes,
                led_early: early.led,
                corrected_end: end.is_some(),
                back_here: early.back_here.as_deref(),
                carried_end: carried_end.as_deref(),
                ok_share,
            };
            let doubt = between.solve(&mut track_pos, early.ways);
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
            for key in &seg.inner {
                keyed_row(&mut out[(key.frame - first_frame) as usize].1, key);
            }
            if let (None, Some(key), Some(row)) = (end, seg.key_next, at_next.as_mut()) {
                keyed_row(row, key);
            }
        }
        // The frames read ahead are the next segment's.
        if let Some(a) = ahead {
            frames.unread(a.frames);
        }
        Ok(())
    }
}

/// Each pass's estimates on the frames between the first and the next keyframe (`n`).
fn between(p: &[(u64, Vec<JointEstimate>)], n: usize) -> Vec<Vec<JointEstimate>> {
    p[1..=n].iter().map(|(_, e)| e.clone()).collect()
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

/// Whether a span judged early (from the carried pass and the one backward from the
/// correction) needs no more tracker passes: Lucas–Kanade leads it (see [`keyed::Lead`]). A
/// span in doubt runs them all: its joints go to the tracker where it landed nearer the keys.
fn lean_enough(lead: Option<keyed::Lead>) -> bool {
    lead == Some(keyed::Lead::Flow)
}
