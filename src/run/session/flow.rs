//! Lucas–Kanade between a segment's keys, for [`super::segment`]: the frames' grey pyramids
//! (built in the last segment's buffers) and whether a span is led by flow, judged before the
//! blend (docs/method.md, "Motion between keys").

use crate::geom::Point;
use crate::run::keyed;
use crate::track::flow::GreyPyramid;
use crate::track::scale::Frame;
use crate::track::JointEstimate;
use image::RgbImage;
use rayon::prelude::*;
use std::cell::RefCell;

/// Levels of the grey pyramids Lucas–Kanade works on between keys (a 31 px window on the
/// fifth level covers ±240 px of motion at full resolution).
const KEYED_LEVELS: usize = 5;

thread_local! {
    /// The last segment's grey pyramids, whose buffers the next segment's are built in
    /// ([`GreyPyramid::rebuild`]).
    static SPARE: RefCell<Vec<GreyPyramid>> = const { RefCell::new(Vec::new()) };
}

/// The last segment's pyramids, to build this one's in.
pub(super) fn take_spare() -> Vec<GreyPyramid> {
    SPARE.with(|s| std::mem::take(&mut *s.borrow_mut()))
}

/// The images' grey pyramids for Lucas–Kanade, built in parallel (each on its own) in the
/// buffers of `spare` ([`take_spare`]).
pub(super) fn pyramids_of(mut spare: Vec<GreyPyramid>, images: &[&RgbImage]) -> Vec<GreyPyramid> {
    spare.resize_with(images.len(), || GreyPyramid { levels: Vec::new() });
    spare
        .par_iter_mut()
        .zip(images.par_iter())
        .for_each(|(p, f)| p.rebuild(f, KEYED_LEVELS));
    spare
}

/// A segment's frames' grey pyramids, built one by one as the frames arrive (in the last
/// segment's buffers), when they are wanted.
pub(super) struct Built {
    pyramids: Option<Vec<GreyPyramid>>,
    count: usize,
}

impl Built {
    pub(super) fn new(wanted: bool) -> Built {
        Built {
            pyramids: wanted.then(take_spare),
            count: 0,
        }
    }

    /// Builds the next frame's pyramid (from the frame at full resolution).
    pub(super) fn add(&mut self, frame: &Frame) {
        if let Some(p) = &mut self.pyramids {
            if p.len() == self.count {
                p.push(GreyPyramid { levels: Vec::new() });
            }
            p[self.count].rebuild(frame.full(), KEYED_LEVELS);
            self.count += 1;
        }
    }

    /// The pyramids built, in the frames' order (once).
    pub(super) fn take(&mut self) -> Option<Vec<GreyPyramid>> {
        let mut p = self.pyramids.take()?;
        p.truncate(self.count);
        Some(p)
    }
}

/// Keeps `pyramids` for the next segment's ([`take_spare`]); an empty list lets them go.
pub(super) fn put_spare(pyramids: Vec<GreyPyramid>) {
    SPARE.with(|s| *s.borrow_mut() = pyramids);
}

/// The grey pyramids of `images` (`pyramids`, built as the frames arrived ([`Built`]), else
/// built now in their buffers; the key on the first, `start`, the correction on the last,
/// `end`) and, with `ways`, Lucas–Kanade's ways between the two, for [`early_lead`] and the
/// solve that follows. `boxes[j]`: joint `j`'s rectangle's smaller side (px).
pub(super) fn follow_flow(
    pyramids: Vec<GreyPyramid>,
    images: &[&RgbImage],
    start: &[JointEstimate],
    end: &[JointEstimate],
    ways: bool,
    boxes: &[u32],
) -> (Vec<GreyPyramid>, Option<keyed::Ways>) {
    let pyramids = match pyramids.len() == images.len() {
        true => pyramids,
        false => pyramids_of(pyramids, images),
    };
    if !ways {
        return (pyramids, None);
    }
    let start_pos: Vec<Point> = start.iter().map(|e| e.pos).collect();
    let key_b: Vec<Option<Point>> = end.iter().map(|e| Some(e.pos)).collect();
    let prm = keyed::KeyedParams::default();
    let ways = keyed::ways(&pyramids, &start_pos, Some(&key_b), boxes, &prm);
    (pyramids, Some(ways))
}

/// Which cue leads the span from the key `start` to the correction `end` ([`keyed::lead`]),
/// judged before the blend from Lucas–Kanade's `ways` between them
/// ([`follow_flow`]), the carried pass (`carried` on the frames between, `carried_end` on the
/// last) and the pass backward from the correction (`back` on the frames between).
pub(super) fn early_lead(
    ways: Option<&keyed::Ways>,
    start: &[JointEstimate],
    end: &[JointEstimate],
    carried_end: Option<&[Point]>,
    carried: &[(u64, Vec<JointEstimate>)],
    back: &[Vec<JointEstimate>],
    ok_share: f32,
) -> keyed::Lead {
    let (Some(ways), Some(carried_end), Some(back_a)) = (ways, carried_end, back.first()) else {
        return keyed::Lead::Tracker;
    };
    let start_pos: Vec<Point> = start.iter().map(|e| e.pos).collect();
    let key_b: Vec<Option<Point>> = end.iter().map(|e| Some(e.pos)).collect();
    let lk_miss = ways.misses(&start_pos, Some(&key_b));
    let misses: Vec<Option<(f32, f32)>> = (0..start.len())
        .map(|j| {
            let miss_t =
                (carried_end[j] - end[j].pos).norm() + (back_a[j].pos - start_pos[j]).norm();
            Some((miss_t, lk_miss[j]))
        })
        .collect();
    let rows = carried.iter().map(|(_, r)| r).chain(back);
    let (mut ok, mut all) = (0usize, 0usize);
    for r in rows {
        ok += r.iter().filter(|e| e.fits_alone(ok_share)).count();
        all += r.len();
    }
    let ok_share = ok as f32 / all.max(1) as f32;
    keyed::lead(&misses, ok_share)
}
