//! The correction report (`report.md`): which segments need a look, ranked, with the frames and
//! joints, from the per-frame evidence in the tracks. Recall matters more than precision: a
//! segment the report does not flag is one the user will not open.
//!
//! Evidence, per joint and frame ([`evidence`]), each with the weight it carries: the share of
//! joint-frames showing it that were more than 10 px off, measured on the synth scenarios
//! (walk, occlude, fast, squash, noisy in segments of 30 and 150, a mixed clip in segments of
//! 40), so that a segment's weights add up to about how many of its joint-frames are that far off:
//! - **hidden** (0.35): status `occluded` or `lost`;
//! - **low** (0.08): seen poorly (status `low`, or a score under [`Thresholds::score_min`]);
//! - **jump** (0.2): moved further from the previous frame than [`Thresholds::jump`] rectangle
//!   sides;
//! - **off its motion** (0.25; 0.45 at twice the distance): further from the constant-velocity
//!   prediction of the two previous frames than [`Thresholds::residual`] rectangle sides;
//! - **bone length** (0.3; 0.33 and 0.46 outside the seed ranges): its bone's length left the
//!   range it had over the last [`Thresholds::bone_window`] frames by more than
//!   [`Thresholds::bone_tolerance`], or is outside [`Thresholds::bone_range`] (or the wider
//!   [`Thresholds::bone_range_wide`]) times its seed length;
//! - **doubtful start** (0.25): a segment restarted from a joint whose status was not `ok`.
//!
//! A joint-frame weighs the most of the evidence it shows. A segment's need is the sum of its
//! weights: about how many joint-frames are far off. Segments whose need reaches
//! [`Thresholds::min_need`] (and [`Thresholds::min_share`] of their joint-frames) are flagged, most
//! needy first. The report lists, per flagged segment, each doubtful joint with the frames
//! where evidence shows, widened by [`Thresholds::spread`] frames either side (a drift starts
//! before it shows and lasts after): on those scenarios 94 to 100 % of the joint-frames more
//! than 10 px off are listed.

use crate::geom::Point;
use crate::run::segments::{parse_status, Plan};
use crate::run::tracks::TrackRow;
use crate::skeleton::Skeleton;
use crate::track::Status;
use std::fmt::Write as _;

/// Kinds of evidence, as bits of a joint-frame's doubt mask.
pub const LOW: u8 = 1;
pub const HIDDEN: u8 = 2;
pub const JUMP: u8 = 4;
pub const RESIDUAL: u8 = 8;
pub const BONE: u8 = 16;
pub const START: u8 = 32;
/// Set on the frames a doubt spreads to.
pub const NEAR: u8 = 64;

/// The words of the evidence bits, in bit order.
const KIND_WORDS: [(u8, &str); 6] = [
    (LOW, "low score"),
    (HIDDEN, "hidden"),
    (JUMP, "jump"),
    (RESIDUAL, "off its motion"),
    (BONE, "bone length"),
    (START, "doubtful start"),
];

/// When evidence counts, and when a segment is flagged.
#[derive(Debug, Clone, PartialEq)]
pub struct Thresholds {
    /// A seen joint scoring under this (0–1) is doubtful.
    pub score_min: f32,
    /// Largest move between frames, in rectangle sides (the mean of `w` and `h`).
    pub jump: f32,
    /// Largest distance from the constant-velocity prediction, in rectangle sides.
    pub residual: f32,
    /// Frames over which a bone's recent length range is taken.
    pub bone_window: usize,
    /// Share a bone's length may leave its recent range by.
    pub bone_tolerance: f32,
    /// Range of a bone's length, as multiples of its seed length, and a wider one.
    pub bone_range: (f32, f32),
    pub bone_range_wide: (f32, f32),
    /// Frames a doubt spreads to, either side, in the listing.
    pub spread: u64,
    /// Need (about how many joint-frames are far off) that flags a segment.
    pub min_need: f32,
    /// Share of a segment's joint-frames its need must also reach (0–1), for long segments.
    pub min_share: f32,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            score_min: 0.5,
            jump: 1.0,
            residual: 0.25,
            bone_window: 30,
            bone_tolerance: 0.15,
            bone_range: (0.75, 1.33),
            bone_range_wide: (0.6, 1.6),
            spread: 5,
            min_need: 3.0,
            min_share: 0.005,
        }
    }
}

/// Tracks as a dense table: `frames[i]` and its joints' rows `est[i]` (seed-file order).
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    pub frames: Vec<u64>,
    pub pos: Vec<Vec<Point>>,
    pub score: Vec<Vec<f32>>,
    pub status: Vec<Vec<Status>>,
}

impl Table {
    /// The table of `tracks.csv` rows (by frame, then joint; `joints` per frame). Unknown status
    /// words count as `lost`.
    pub fn from_rows(rows: &[TrackRow], joints: usize) -> Table {
        let mut t = Table {
            frames: Vec::new(),
            pos: Vec::new(),
            score: Vec::new(),
            status: Vec::new(),
        };
        for chunk in rows.chunks(joints.max(1)) {
            t.frames.push(chunk[0].frame);
            t.pos
                .push(chunk.iter().map(|r| Point::new(r.x, r.y)).collect());
            t.score.push(chunk.iter().map(|r| r.score).collect());
            t.status.push(
                chunk
                    .iter()
                    .map(|r| parse_status(&r.status).unwrap_or(Status::Lost))
                    .collect(),
            );
        }
        t
    }
}

/// Evidence on every joint-frame of a table: which kinds show (bits [`LOW`] … [`START`], or
/// [`NEAR`] within [`Thresholds::spread`] frames of some) and what the joint-frame weighs.
#[derive(Debug, Clone, PartialEq)]
pub struct Evidence {
    pub mask: Vec<Vec<u8>>,
    pub weight: Vec<Vec<f32>>,
}

/// The evidence on every joint of every frame of `t`. `sides` is each joint's rectangle side
/// (px), `seed_len` each bone's length on the seed frame (px, by child joint; roots unused),
/// `starts` the table indices where a tracker restarted from a file that was not corrected.
pub fn evidence(
    t: &Table,
    sk: &Skeleton,
    sides: &[f32],
    seed_len: &[f32],
    starts: &[usize],
    th: &Thresholds,
) -> Evidence {
    let n = t.frames.len();
    let nj = sk.len();
    let mut m = vec![vec![0u8; nj]; n];
    let mut w = vec![vec![0f32; nj]; n];
    let outside = |v: f32, (lo, hi): (f32, f32)| v < lo || v > hi;
    for i in 0..n {
        for j in 0..nj {
            let st = t.status[i][j];
            let (mut b, mut wt) = (0u8, 0f32);
            let mut add = |bit: u8, weight: f32| {
                b |= bit;
                wt = wt.max(weight);
            };
            if st == Status::Low || (st.seen() && t.score[i][j] < th.score_min) {
                add(LOW, 0.08);
            }
            if !st.seen() {
                add(HIDDEN, 0.35);
            }
            if i >= 1 && (t.pos[i][j] - t.pos[i - 1][j]).norm() > th.jump * sides[j] {
                add(JUMP, 0.2);
            }
            if i >= 2 {
                let pred = t.pos[i - 1][j] + (t.pos[i - 1][j] - t.pos[i - 2][j]);
                let r = (t.pos[i][j] - pred).norm() / (th.residual * sides[j]);
                if r > 2.0 {
                    add(RESIDUAL, 0.45);
                } else if r > 1.0 {
                    add(RESIDUAL, 0.25);
                }
            }
            if let Some(p) = sk.parents[j] {
                let len = |k: usize| (t.pos[k][j] - t.pos[k][p]).norm();
                let l = len(i);
                if seed_len[j] > 0.0 {
                    let ratio = l / seed_len[j];
                    if outside(ratio, th.bone_range_wide) {
                        add(BONE, 0.46);
                    } else if outside(ratio, th.bone_range) {
                        add(BONE, 0.33);
                    }
                }
                if i >= 1 {
                    let from = i.saturating_sub(th.bone_window);
                    let (mut a, mut z) = (f32::MAX, 0f32);
                    for k in from..i {
                        a = a.min(len(k));
                        z = z.max(len(k));
                    }
                    let tol = th.bone_tolerance;
                    if l < a * (1.0 - tol) - 1.0 || l > z * (1.0 + tol) + 1.0 {
                        add(BONE, 0.3);
                    }
                }
            }
            m[i][j] = b;
            w[i][j] = wt;
        }
    }
    // A tracker restarted on a doubtful joint: the segment is in doubt for it.
    let mut bounds: Vec<usize> = starts.to_vec();
    bounds.push(n);
    for win in bounds.windows(2) {
        let (s, e) = (win[0], win[1].min(n));
        if s >= e {
            continue;
        }
        for j in 0..nj {
            if !matches!(t.status[s][j], Status::Ok | Status::Seed) {
                for i in s..e {
                    m[i][j] |= START;
                    w[i][j] = w[i][j].max(0.25);
                }
            }
        }
    }
    // Spread, for the listing.
    let raw: Vec<Vec<bool>> = m
        .iter()
        .map(|r| r.iter().map(|&b| b != 0).collect())
        .collect();
    let sp = th.spread as usize;
    for j in 0..nj {
        let mut last: Option<usize> = None;
        for i in 0..n {
            if raw[i][j] {
                last = Some(i);
            }
            if last.is_some_and(|l| i - l <= sp) && m[i][j] == 0 {
                m[i][j] = NEAR;
            }
        }
        let mut next: Option<usize> = None;
        for i in (0..n).rev() {
            if raw[i][j] {
                next = Some(i);
            }
            if next.is_some_and(|l| l - i <= sp) && m[i][j] == 0 {
                m[i][j] = NEAR;
            }
        }
    }
    Evidence { mask: m, weight: w }
}

/// One joint's doubts within a segment.
#[derive(Debug, Clone, PartialEq)]
pub struct JointDoubt {
    pub joint: String,
    /// First and last doubtful frame.
    pub first: u64,
    pub last: u64,
    /// Doubtful frames.
    pub frames: u64,
    /// Evidence bits seen.
    pub kinds: u8,
}

/// One segment of the report.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentNeed {
    pub index: u64,
    pub first: u64,
    pub last: u64,
    /// Its file was edited by the user.
    pub corrected: bool,
    /// About how many of its joint-frames are far off: the sum of their evidence weights.
    pub need: f32,
    pub flagged: bool,
    /// Joints in doubt, most doubtful first.
    pub joints: Vec<JointDoubt>,
}

/// The report: every segment, in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub segments: Vec<SegmentNeed>,
    /// Segment files of the run: one per segment, and one more on the clip's last frame when
    /// the last segment has more than one frame.
    pub files: u64,
}

impl Report {
    /// Builds the report from the evidence `ev` (see [`evidence`]) over table `t`, cut by
    /// `plan`; `corrected[k]` says segment file k is a correction; `files` counts them.
    pub fn build(
        t: &Table,
        ev: &Evidence,
        names: &[String],
        plan: &Plan,
        corrected: &[bool],
        files: u64,
        th: &Thresholds,
    ) -> Report {
        let mut segments: Vec<SegmentNeed> = Vec::new();
        for (i, &f) in t.frames.iter().enumerate() {
            let k = plan.segment_of(f);
            if segments.last().is_none_or(|s| s.index != k) {
                segments.push(SegmentNeed {
                    index: k,
                    first: f,
                    last: f,
                    corrected: corrected.get(k as usize).copied().unwrap_or(false),
                    need: 0.0,
                    flagged: false,
                    joints: names
                        .iter()
                        .map(|n| JointDoubt {
                            joint: n.clone(),
                            first: 0,
                            last: 0,
                            frames: 0,
                            kinds: 0,
                        })
                        .collect(),
                });
            }
            let s = segments.last_mut().expect("pushed above");
            s.last = f;
            s.need += ev.weight[i].iter().sum::<f32>();
            for (jd, &b) in s.joints.iter_mut().zip(&ev.mask[i]) {
                if b != 0 {
                    if jd.frames == 0 {
                        jd.first = f;
                    }
                    jd.last = f;
                    jd.frames += 1;
                    jd.kinds |= b;
                }
            }
        }
        for s in &mut segments {
            let cells = (s.last - s.first + 1) * names.len() as u64;
            s.flagged = s.need >= th.min_need.max(th.min_share * cells as f32);
            s.joints.retain(|j| j.frames > 0);
            s.joints
                .sort_by(|a, b| b.frames.cmp(&a.frames).then(a.first.cmp(&b.first)));
        }
        Report { segments, files }
    }

    /// Flagged segments, most needy first (ties: earlier first).
    pub fn ranked(&self) -> Vec<&SegmentNeed> {
        let mut v: Vec<&SegmentNeed> = self.segments.iter().filter(|s| s.flagged).collect();
        v.sort_by(|a, b| b.need.total_cmp(&a.need).then(a.index.cmp(&b.index)));
        v
    }

    /// The segment files to correct: each flagged segment's and the next one's (a segment is
    /// tracked forward from its file and, once the next is corrected, back from that), in order.
    pub fn files_to_correct(&self) -> Vec<u64> {
        let mut v: Vec<u64> = self
            .ranked()
            .iter()
            .flat_map(|s| [s.index, s.index + 1])
            .filter(|&k| k < self.files)
            .collect();
        v.sort();
        v.dedup();
        v
    }

    /// One line for the terminal: which segments need a look, and where the worst starts.
    pub fn summary(&self) -> String {
        let r = self.ranked();
        if r.is_empty() {
            return "no segment needs a look".into();
        }
        let list: Vec<String> = r.iter().take(8).map(|s| s.index.to_string()).collect();
        let more = if r.len() > 8 {
            format!(" and {} more", r.len() - 8)
        } else {
            String::new()
        };
        let top = r[0];
        let joints: Vec<&str> = top
            .joints
            .iter()
            .take(3)
            .map(|j| j.joint.as_str())
            .collect();
        let from = top
            .joints
            .iter()
            .map(|j| j.first)
            .min()
            .unwrap_or(top.first);
        format!(
            "segment{} {}{more} need{} a look (segment {}: joints {} from frame {from}); see report.md",
            if r.len() == 1 { "" } else { "s" },
            list.join(", "),
            if r.len() == 1 { "s" } else { "" },
            top.index,
            joints.join(", "),
        )
    }

    /// `report.md`.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Correction report\n");
        let r = self.ranked();
        if r.is_empty() {
            let _ = writeln!(
                s,
                "No segment needs a look: in none does the evidence (hidden joints, low scores, \
                 jumps, moves off the joint's motion, bone lengths) add up to a few far-off \
                 joint-frames.\n"
            );
        } else {
            let _ = writeln!(
                s,
                "{} of {} segments need a look, most needy first. Their need is about how many \
                 joint-frames are far off (more than 10 px, going by the evidence: hidden joints, \
                 low scores, jumps, moves off the joint's motion, bone lengths).\n",
                r.len(),
                self.segments.len()
            );
            let files = self.files_to_correct();
            let names: Vec<String> = files
                .iter()
                .map(|k| format!("`segments/{k:03}.toml`"))
                .collect();
            let _ = writeln!(
                s,
                "To correct them, move the wrong rectangles in {} (the first frame of each \
                 segment that needs a look and of the one after it: a segment is tracked \
                 forward from its file and back from a corrected next one; the file after the \
                 last segment holds the clip's last frame), then run `mocap2d resume RUN \
                 --segment {}`.\n",
                names.join(", "),
                files
                    .first()
                    .copied()
                    .unwrap_or(0)
                    .min(self.segments.len() as u64 - 1)
            );
            let _ = writeln!(
                s,
                "| rank | segment | frames | need | joints (first doubtful frame) |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|");
            for (i, g) in r.iter().enumerate() {
                let joints: Vec<String> = g
                    .joints
                    .iter()
                    .take(6)
                    .map(|j| format!("{} ({})", j.joint, j.first))
                    .collect();
                let _ = writeln!(
                    s,
                    "| {} | {:03}{} | {}–{} | {:.0} | {} |",
                    i + 1,
                    g.index,
                    if g.corrected { " (corrected)" } else { "" },
                    g.first,
                    g.last,
                    g.need,
                    joints.join(", ")
                );
            }
            let _ = writeln!(s);
            for g in &r {
                let _ = writeln!(
                    s,
                    "## Segment {:03}: frames {}–{}{}\n",
                    g.index,
                    g.first,
                    g.last,
                    if g.corrected { " (corrected)" } else { "" }
                );
                let _ = writeln!(s, "| joint | frames | doubtful frames | evidence |");
                let _ = writeln!(s, "|---|---|---|---|");
                for j in &g.joints {
                    let kinds: Vec<&str> = KIND_WORDS
                        .iter()
                        .filter(|(b, _)| j.kinds & b != 0)
                        .map(|(_, w)| *w)
                        .collect();
                    let kinds = if kinds.is_empty() {
                        "near doubtful frames".to_string()
                    } else {
                        kinds.join(", ")
                    };
                    let _ = writeln!(
                        s,
                        "| {} | {}–{} | {} | {kinds} |",
                        j.joint, j.first, j.last, j.frames
                    );
                }
                let _ = writeln!(s);
            }
        }
        let quiet: Vec<String> = self
            .segments
            .iter()
            .filter(|g| !g.flagged)
            .map(|g| format!("{:03}", g.index))
            .collect();
        if !quiet.is_empty() {
            let _ = writeln!(s, "Segments not flagged: {}.", quiet.join(", "));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two joints (a root and its child 10 px to the right) still for `n` frames, all `ok`.
    fn still(n: usize) -> (Table, Skeleton) {
        let t = Table {
            frames: (0..n as u64).collect(),
            pos: vec![vec![Point::new(0.0, 0.0), Point::new(10.0, 0.0)]; n],
            score: vec![vec![0.9, 0.9]; n],
            status: vec![vec![Status::Ok; 2]; n],
        };
        let sk = Skeleton {
            names: vec!["a".into(), "b".into()],
            parents: vec![None, Some(0)],
        };
        (t, sk)
    }

    fn report(t: &Table, sk: &Skeleton, starts: &[usize]) -> (Evidence, Report) {
        let th = Thresholds::default();
        let ev = evidence(t, sk, &[10.0, 10.0], &[0.0, 10.0], starts, &th);
        let plan = Plan {
            seed_frame: 0,
            len: 10,
        };
        let r = Report::build(t, &ev, &sk.names, &plan, &[], 3, &th);
        (ev, r)
    }

    #[test]
    fn a_still_clip_needs_no_look() {
        let (t, sk) = still(30);
        let (ev, r) = report(&t, &sk, &[10, 20]);
        assert!(ev.mask.iter().flatten().all(|&b| b == 0));
        assert_eq!(r.segments.len(), 3);
        assert!(r.ranked().is_empty());
        assert_eq!(r.summary(), "no segment needs a look");
    }

    #[test]
    fn a_jump_and_a_stretched_bone_flag_their_segment() {
        let (mut t, sk) = still(30);
        // Frames 12 on: the child jumps 20 px away (2 sides; its bone triples).
        for p in &mut t.pos[12..] {
            p[1] = Point::new(30.0, 0.0);
        }
        let (ev, r) = report(&t, &sk, &[10, 20]);
        assert_eq!(
            ev.mask[12][1] & (JUMP | RESIDUAL | BONE),
            JUMP | RESIDUAL | BONE
        );
        assert_eq!(ev.mask[7][1], NEAR, "spread 5 frames back");
        assert_eq!(ev.mask[6][1], 0);
        // Segment 1 holds 8 stretched frames (weight 0.46 each), segment 2 ten; segment 0
        // only frames near them.
        let ranked: Vec<u64> = r.ranked().iter().map(|s| s.index).collect();
        assert_eq!(ranked, [2, 1]);
        assert_eq!(r.files_to_correct(), [1, 2]);
        let s1 = &r.segments[1];
        assert_eq!((s1.joints[0].joint.as_str(), s1.joints[0].first), ("b", 10));
        assert!((s1.need - 8.0 * 0.46).abs() < 1e-3, "{}", s1.need);
        assert!(
            r.summary().starts_with("segments 2, 1 need a look"),
            "{}",
            r.summary()
        );
        let md = r.to_markdown();
        assert!(
            md.contains("| b | 10–19 | 10 | jump, off its motion, bone length |"),
            "{md}"
        );
        assert!(md.contains("Segments not flagged: 000."), "{md}");
    }

    #[test]
    fn a_restart_on_a_hidden_joint_puts_the_segment_in_doubt() {
        let (mut t, sk) = still(30);
        t.status[20][1] = Status::Occluded;
        let (ev, r) = report(&t, &sk, &[10, 20]);
        assert!(ev.mask[20..].iter().all(|m| m[1] & START != 0));
        assert!(ev.mask[10..15].iter().all(|m| m[1] & START == 0));
        // 0.35 on frame 20, 0.25 on the nine after: flagged.
        assert!((r.segments[2].need - (0.35 + 9.0 * 0.25)).abs() < 1e-3);
        assert!(!r.segments[2].flagged, "2.6 < 3: below the bar");
    }
}
