//! One segment's tracking: its passes forward, the passes backward from the next correction,
//! their blend, and between keys the path solved through both ends (docs/method.md §3, "Motion
//! between keys"). The backward passes, the blend and the path are in [`super::between`].

use super::between::Tracked;
use super::pass::{Appearance, Frames, Pass};
use super::Session;
use super::{ahead, flow};
use crate::error::Result;
use crate::geom::Point;
use crate::run::keys::{self, Key};
use crate::run::segments::Start;
use crate::track::scale::Frame;
use crate::track::{JointEstimate, Status, Tracker};

/// Segment `k`'s plan: where it starts, and the keys it is tracked and solved through
/// ([`crate::run::keys`]) with what they decide.
pub(super) struct SegmentPlan<'a> {
    /// The segment.
    pub(super) k: u64,
    /// Its first frame's index.
    pub(super) first_frame: u64,
    /// The next segment's first frame's index.
    pub(super) next: u64,
    /// Its first frame (already decoded).
    pub(super) first: &'a Frame,
    /// Its file, as read ([`Session::start`]).
    pub(super) start: Start,
    /// Each joint's rectangle's smaller side (px): Lucas–Kanade's window between keys.
    pub(super) boxes: Vec<u32>,
    /// The first frame's row is the file's (segment 0, or a correction).
    pub(super) keyframe: bool,
    /// The segment's file is a correction (not segment 0's).
    pub(super) corrected: bool,
    /// The key on the segment's first frame, if any.
    pub(super) key_here: Option<&'a Key>,
    /// The keys inside the segment.
    pub(super) inner: Vec<&'a Key>,
    /// The key on the next segment's first frame, if any.
    pub(super) key_next: Option<&'a Key>,
    /// The keys past the segment's end its last spans run on to ([`ahead::keys_past_end`]).
    pub(super) past_end: Vec<&'a Key>,
    /// The segment's frames are held for the passes backward and the path between keys.
    pub(super) hold: bool,
    /// A key of every joint lies at or past the segment's end (see [`SegmentPlan::ahead_forward`]).
    far_key: bool,
    /// The segment's first frame is a key of every joint (see [`SegmentPlan::ahead_backward`]).
    start_key: bool,
    /// The passes that only feed the blend wait for the span's early judgement.
    pub(super) lean: bool,
}

impl SegmentPlan<'_> {
    /// Whether a key of every joint lies on or beyond frame `idx` for a pass run forward.
    pub(super) fn ahead_forward(&self, idx: u64) -> bool {
        self.far_key
            || self
                .inner
                .iter()
                .any(|x| x.frame >= idx && x.gives_every_joint())
    }

    /// Whether a key of every joint lies on or before frame `idx` for a pass run backward.
    pub(super) fn ahead_backward(&self, idx: u64) -> bool {
        self.start_key
            || self
                .inner
                .iter()
                .any(|x| x.frame <= idx && x.gives_every_joint())
    }

    /// Builds the forward passes on the segment's first frame, moved onto a key there.
    pub(super) fn build(&self, session: &Session, appearances: &[Appearance]) -> Result<Vec<Pass>> {
        let mut passes = Vec::new();
        for &a in appearances {
            let mut p = session.tracker_at(&self.start, self.first, a)?;
            if let Some(key) = self.key_here {
                p.move_to(key);
            }
            passes.push(p);
        }
        Ok(passes)
    }
}

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
        let (seg, mut end) = self.plan_segment(k, first, keys)?;
        let learnt = match (k, self.carried.take()) {
            (0, _) => None,
            (_, Some(b)) => Some(b),
            (_, None) => Some(self.read_state(k)?),
        };
        let mut forward = vec![self.tracker_at(
            &seg.start,
            first,
            match &learnt {
                None => Appearance::Here,
                Some(b) if seg.corrected => Appearance::LearntMoved(k, b),
                Some(b) => Appearance::Learnt(k, b),
            },
        )?];
        // The passes that only feed the blend, deferred while the span may be lean (see
        // `SegmentPlan::lean`).
        let mut deferred: Vec<Appearance> = Vec::new();
        if seg.corrected {
            deferred.push(Appearance::Here);
            if end.is_some() {
                deferred.push(Appearance::SeedFrame);
            }
        }
        if !seg.lean {
            forward.extend(seg.build(self, &deferred)?);
            deferred.clear();
        }
        if let Some(key) = seg.key_here {
            forward[0].move_to(key);
        }
        // Lucas–Kanade's pyramids of the frames held (and the first and the next key's), built
        // as they arrive, alongside the passes.
        let mut built = flow::Built::new(seg.hold);
        built.add(first);
        let (held, boundary) = self.run_forward(&seg, &mut forward, frames, keys, &mut built)?;
        let (mut run, tracker) =
            self.finish_forward(&seg, &mut end, forward, held, boundary, frames.count);
        let early = self.blend_passes(&seg, end.as_ref(), &mut run, &deferred, &mut built)?;
        self.solve_path(&seg, end.as_ref(), &mut run, frames, &mut built, early)?;
        self.refill_gaps(&seg, end.as_ref(), &mut run, &tracker);
        align_turns(&mut run.out);
        Ok((run.out, run.at_next.zip(run.boundary)))
    }

    /// Reads segment `k`'s file and the next one's correction, if any, and plans the segment
    /// from them and the keys.
    fn plan_segment<'a>(
        &self,
        k: u64,
        first: &'a Frame,
        keys: &'a [Key],
    ) -> Result<(SegmentPlan<'a>, Option<Start>)> {
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
        // Between two corrections with no key inside, the passes that only feed the blend wait
        // until the span is known not to be led by flow ([`keyed::lead`]): where it is,
        // the carried pass and the one backward from the correction decide, at two passes'
        // cost instead of five. Those passes are not even built until then.
        let lean = corrected && end.is_some() && inner.is_empty() && key_next.is_none();
        let seg = SegmentPlan {
            k,
            first_frame,
            next,
            first,
            start,
            boxes,
            keyframe,
            corrected,
            key_here,
            inner,
            key_next,
            past_end,
            hold,
            far_key,
            start_key,
            lean,
        };
        Ok((seg, end))
    }

    /// Runs the forward passes over the segment's frames up to the next segment's first frame
    /// (or the clip's end), moving them onto the keys inside; returns the frames held and the
    /// next segment's first frame.
    fn run_forward<I: Iterator<Item = Result<(u64, Frame)>>>(
        &self,
        seg: &SegmentPlan<'_>,
        forward: &mut [Pass],
        frames: &mut Frames<'_, I>,
        keys: &[Key],
        built: &mut flow::Built,
    ) -> Result<(Vec<Frame>, Option<Frame>)> {
        let mut held: Vec<Frame> = Vec::new();
        let mut boundary: Option<Frame> = None;
        while let Some((idx, frame)) = frames.next()? {
            rayon::join(
                || {
                    for p in forward.iter_mut() {
                        p.step(idx, &frame, seg.ahead_forward(idx));
                    }
                },
                || built.add(&frame),
            );
            if idx == seg.next {
                boundary = Some(frame);
                break;
            }
            if let Some(key) = seg.inner.iter().find(|x| x.frame == idx) {
                for p in forward.iter_mut() {
                    p.move_to(key);
                }
            }
            if seg.hold {
                held.push(frame);
            }
        }
        if boundary.is_none() {
            // The clip ended inside this segment: a key past its last frame has no frame to
            // pull (docs/formats.md, "Keys").
            let size = (self.width, self.height);
            keys::check_within(&self.run_dir, &self.names, size, keys, frames.count)?;
        }
        Ok((held, boundary))
    }

    /// Finishes the forward passes: keeps the carried tracker's state for the next segment,
    /// sets the first frame's row from the keyframe or keys, and aligns the correction that
    /// ends the segment (`end`, `count` frames in the clip so far) to the carried pass.
    fn finish_forward(
        &mut self,
        seg: &SegmentPlan<'_>,
        end: &mut Option<Start>,
        forward: Vec<Pass>,
        mut held: Vec<Frame>,
        boundary: Option<Frame>,
        count: u64,
    ) -> (Tracked, Tracker) {
        let mut passes = forward.into_iter();
        let (mut out, tracker) = passes.next().expect("one forward pass").finish_keep();
        let forward: Vec<Vec<(u64, Vec<JointEstimate>)>> = passes.map(Pass::finish).collect();
        self.carried = Some(tracker.state());
        if seg.keyframe {
            out[0].1 = seg.start.row.clone();
        } else if seg.key_here.is_none()
            && (!seg.inner.is_empty() || seg.key_next.is_some() || !seg.past_end.is_empty())
        {
            // The previous segment's last span ran on to the next key: the row solved on this
            // frame, which the tool wrote into this segment's file ([`ahead`]), is where this
            // segment's first span starts.
            for (e, s) in out[0].1.iter_mut().zip(&seg.start.row) {
                (e.pos, e.score, e.status) = (s.pos, s.score, s.status);
            }
        }
        if let Some(key) = seg.key_here {
            keyed_row(&mut out[0].1, key);
        }
        let at_next = boundary.as_ref().map(|_| out.pop().expect("pushed").1);
        // Where the carried tracker got to on the next key's frame.
        let mut carried_end: Option<Vec<Point>> =
            at_next.as_ref().map(|r| r.iter().map(|x| x.pos).collect());
        // A correction on the clip's last frame, inside this segment: the last frame held.
        let tail = match (end, &boundary) {
            (Some(e), None) if !held.is_empty() && e.seeds.frame + 1 == count => {
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
        let run = Tracked {
            out,
            forward,
            held,
            boundary,
            tail,
            at_next,
            carried_end,
        };
        (run, tracker)
    }

    /// Fills the hidden stretches of the segment's rows again, up to the correction that ends
    /// it if any, with the carried `tracker`'s gap filler.
    fn refill_gaps(
        &self,
        seg: &SegmentPlan<'_>,
        end: Option<&Start>,
        run: &mut Tracked,
        tracker: &Tracker,
    ) {
        // Hidden stretches are filled again over the whole segment at once, between where the
        // joint was seen on either side and with the frames around each gap at hand (the pass's
        // filler hands frames out after `fill_gaps_max`, and a pass that lost a joint up to a
        // keyframe coasted), up to the next keyframe if any.
        if self.params.fill_gaps_max > 0 {
            let end_row = match (end, &run.boundary) {
                (Some(e), Some(_)) => Some((seg.next, e.row.clone())),
                _ => None,
            };
            let rows = run.out.iter().cloned().chain(end_row).collect();
            let filled = tracker.gap_filler().fill_all(rows);
            for (row, (_, f)) in run.out.iter_mut().zip(filled) {
                row.1 = f;
            }
        }
    }
}

/// Unwraps each row's angles near the row before's.
fn align_turns(out: &mut [(u64, Vec<JointEstimate>)]) {
    // Rows from several passes, or a pass and its keyframe, may count turns differently.
    for i in 1..out.len() {
        let (done, rest) = out.split_at_mut(i);
        for (e, p) in rest[0].1.iter_mut().zip(&done[i - 1].1) {
            e.angle_rad = crate::run::segments::turns_near(p.angle_rad, e.angle_rad);
        }
    }
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
