//! The spans between a segment's anchors solved, for [`super::segment`]: each joint from its
//! key to its next (a key that leaves a joint out is no end of its span, [`keyed::joint_spans`]),
//! through the tracker's blend and Lucas–Kanade's ways, the cue that leads each span judged by
//! how near each landed to the keys (docs/method.md, "Motion between keys").

use crate::geom::Point;
use crate::run::keyed;
use crate::track::flow::GreyPyramid;
use crate::track::{JointEstimate, Status};

/// What a segment's spans are solved from: the frames from the segment's first (place 0) to its
/// last anchor.
pub(super) struct Between<'a> {
    /// The anchors: each one's place among the frames and the joints it keys (the first keys
    /// every joint).
    pub(super) anchors: &'a [(usize, Vec<Option<Point>>)],
    /// The frames' grey pyramids, for Lucas–Kanade.
    pub(super) pyramids: &'a [GreyPyramid],
    /// The tracker's blended rows on the frames.
    pub(super) blended: &'a [&'a [JointEstimate]],
    /// Whether each joint's own strips fit there as an `ok` joint's do.
    pub(super) track_ok: &'a [Vec<bool>],
    /// Each joint's rectangle's smaller side (px): Lucas–Kanade's window.
    pub(super) boxes: &'a [u32],
    /// The cue that leads the one span, when judged before the blend.
    pub(super) led_early: Option<keyed::Lead>,
    /// The last anchor is a corrected segment file: the tracker's passes ran both ways up to it.
    pub(super) corrected_end: bool,
    /// The pass built on that correction, run backward, on the frames before it.
    pub(super) back_here: Option<&'a [Vec<Point>]>,
    /// Where the carried tracker got to on the last anchor's frame.
    pub(super) carried_end: Option<&'a [Point]>,
    pub(super) ok_share: f32,
}

impl Between<'_> {
    /// Solves every joint's spans: moves `track_pos` (the tracker's positions on the frames,
    /// as `blended`) onto the paths solved and returns each joint-frame's doubt (px; NaN where
    /// the tracker's blend stands as it is). `early_ways`: Lucas–Kanade's ways over the one
    /// span, when followed already to judge it.
    pub(super) fn solve(
        &self,
        track_pos: &mut [Vec<Point>],
        mut early_ways: Option<keyed::Ways>,
    ) -> Vec<Vec<f32>> {
        let top = self.anchors.last().map_or(0, |a| a.0);
        let joints_n = self.anchors.first().map_or(0, |a| a.1.len());
        let prm = keyed::KeyedParams::default();
        let mut doubt: Vec<Vec<f32>> = vec![vec![0.0; joints_n]; top + 1];
        // Each joint from its key to its next one: a key that leaves a joint out is no end
        // of that joint's span.
        let keyed_at: Vec<Vec<bool>> = self
            .anchors
            .iter()
            .map(|(_, k)| k.iter().map(Option::is_some).collect())
            .collect();
        for (pa, pb, joints) in keyed::joint_spans(&keyed_at) {
            let ((ia, ka), (ib, kb)) = (&self.anchors[pa], &self.anchors[pb]);
            let kb: Vec<Option<Point>> = kb
                .iter()
                .zip(&joints)
                .map(|(k, &on)| k.filter(|_| on))
                .collect();
            let kb = &kb;
            let start_pos: Vec<Point> = ka
                .iter()
                .zip(&track_pos[*ia])
                .map(|(k, p)| k.unwrap_or(*p))
                .collect();
            // Lucas–Kanade's ways, unless followed already to judge the span (`lean`: one
            // span over the whole segment, the same frames and keys).
            let ways = match early_ways.take() {
                Some(w) if self.anchors.len() == 2 => w,
                _ => keyed::ways_of(
                    &self.pyramids[*ia..=*ib],
                    &start_pos,
                    Some(kb),
                    self.boxes,
                    &prm,
                    &joints,
                ),
            };
            let solved = keyed::solve_with(
                &ways,
                &start_pos,
                Some(kb),
                &track_pos[*ia..=*ib],
                &self.track_ok[*ia..=*ib],
                &prm,
            );
            // Per joint, how far the tracker's ways and Lucas–Kanade's missed the keys (px):
            // up to a corrected segment file both ways of each; between keys of keys.toml,
            // where the tracker ran forward only, forward alone. `None`: no key on `b`.
            let two_ways = *ib == top && self.corrected_end;
            let misses: Vec<Option<(f32, f32)>> = match (self.back_here, self.carried_end) {
                (Some(bh), Some(ce)) if two_ways => (0..joints_n)
                    .map(|j| {
                        let (xa, xb) = (start_pos[j], kb[j]?);
                        let back_a = bh.get(*ia).map_or(xa, |r| r[j]);
                        let miss_t = (ce[j] - xb).norm() + (back_a - xa).norm();
                        Some((miss_t, solved.lk_miss[j]))
                    })
                    .collect(),
                _ => (0..joints_n)
                    .map(|j| {
                        let miss_t = (track_pos[*ib][j] - kb[j]?).norm();
                        Some((miss_t, solved.lk_fwd_miss[j]))
                    })
                    .collect(),
            };
            // The share of the span's joint-frames where `keep` holds.
            let span = &self.blended[*ia..=*ib];
            let all = span.iter().map(|r| r.len()).sum::<usize>() as f32;
            let share = |keep: fn(&JointEstimate, f32) -> bool| {
                let n = span
                    .iter()
                    .flat_map(|r| r.iter())
                    .filter(|e| keep(e, self.ok_share));
                n.count() as f32 / all
            };
            let lead = self
                .led_early
                .unwrap_or_else(|| keyed::lead(&misses, share(JointEstimate::fits_alone)));
            let body_share = share(|e, _| e.status == Status::Ok);
            let keep_blend = keyed::keep_tracker(&misses, keyed::settle(lead, body_share));
            let blend_kept = *ib == top && self.corrected_end && self.back_here.is_some();
            let len = (ib - ia) as f32;
            for (t, row) in solved.rows.iter().enumerate().skip(1) {
                for (j, s) in row.iter().enumerate().filter(|(j, _)| joints[*j]) {
                    match (keep_blend[j], blend_kept, kb[j]) {
                        (true, true, _) => doubt[ia + t][j] = f32::NAN,
                        (true, false, Some(xb)) => {
                            let lam = t as f32 / len;
                            let miss = xb - track_pos[*ib][j];
                            track_pos[ia + t][j] += miss * lam;
                            doubt[ia + t][j] = miss.norm() * 2.0 * lam.min(1.0 - lam);
                        }
                        (true, false, None) => doubt[ia + t][j] = f32::NAN,
                        (false, ..) => {
                            track_pos[ia + t][j] = s.pos;
                            doubt[ia + t][j] = s.sigma_px;
                        }
                    }
                }
            }
        }
        doubt
    }
}
