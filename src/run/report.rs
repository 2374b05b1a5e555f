//! The correction report (`report.md`): which segments need a look, ranked, with the frames and
//! joints, from the per-frame evidence in the tracks. Recall matters more than precision: a
//! segment the report does not flag is one the user will not open.
//!
//! Evidence, per joint and frame ([`doubts`]):
//! - **low**: seen poorly (status `low`, or a score under [`Thresholds::score_min`]);
//! - **hidden**: status `occluded` or `lost` (an occluded run);
//! - **jump**: moved further from the previous frame than [`Thresholds::jump`] rectangle sides;
//! - **residual**: further from the constant-velocity prediction of the two previous frames
//!   than [`Thresholds::residual`] rectangle sides;
//! - **bone**: its bone's length left the range it had over the last
//!   [`Thresholds::bone_window`] frames by more than [`Thresholds::bone_tolerance`], or is
//!   outside [`Thresholds::bone_range`] times its seed length;
//! - **start**: a segment restarted from a doubtful joint (the file's status was not `ok`): the
//!   tracker built that joint's appearance there, so the whole segment is in doubt for it.
//!
//! A doubt spreads [`Thresholds::spread`] frames either side (a drift starts before it shows
//! and lasts after). A segment's need is its share of doubtful joint-frames; segments with a
//! need of at least [`Thresholds::min_need`] are flagged, most needy first.

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

/// When evidence counts.
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
    /// Range of a bone's length, as multiples of its seed length.
    pub bone_range: (f32, f32),
    /// Frames a doubt spreads to, either side.
    pub spread: u64,
    /// Share of a segment's joint-frames that must be doubtful for it to be flagged (0–1).
    pub min_need: f32,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            score_min: 0.5,
            jump: 1.0,
            residual: 0.5,
            bone_window: 30,
            bone_tolerance: 0.15,
            bone_range: (0.6, 1.6),
            spread: 5,
            min_need: 0.002,
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

/// The doubt mask (bits [`LOW`] … [`NEAR`]) of every joint on every frame of `t`. `sides` is
/// each joint's rectangle side (px), `seed_len` each bone's length on the seed frame (px, by
/// child joint; roots unused), `starts` the table indices where a tracker restarted from a file
/// that was not corrected.
pub fn doubts(
    t: &Table,
    sk: &Skeleton,
    sides: &[f32],
    seed_len: &[f32],
    starts: &[usize],
    th: &Thresholds,
) -> Vec<Vec<u8>> {
    let n = t.frames.len();
    let nj = sk.len();
    let mut m = vec![vec![0u8; nj]; n];
    for i in 0..n {
        for j in 0..nj {
            let st = t.status[i][j];
            let mut b = 0;
            if st == Status::Low || (st.seen() && t.score[i][j] < th.score_min) {
                b |= LOW;
            }
            if !st.seen() {
                b |= HIDDEN;
            }
            if i >= 1 && (t.pos[i][j] - t.pos[i - 1][j]).norm() > th.jump * sides[j] {
                b |= JUMP;
            }
            if i >= 2 {
                let pred = t.pos[i - 1][j] + (t.pos[i - 1][j] - t.pos[i - 2][j]);
                if (t.pos[i][j] - pred).norm() > th.residual * sides[j] {
                    b |= RESIDUAL;
                }
            }
            if let Some(p) = sk.parents[j] {
                let len = |k: usize| (t.pos[k][j] - t.pos[k][p]).norm();
                let l = len(i);
                let (lo, hi) = th.bone_range;
                let mut out = seed_len[j] > 0.0 && (l < lo * seed_len[j] || l > hi * seed_len[j]);
                if i >= 1 {
                    let from = i.saturating_sub(th.bone_window);
                    let (mut a, mut z) = (f32::MAX, 0f32);
                    for k in from..i {
                        a = a.min(len(k));
                        z = z.max(len(k));
                    }
                    let tol = th.bone_tolerance;
                    out |= l < a * (1.0 - tol) - 1.0 || l > z * (1.0 + tol) + 1.0;
                }
                if out {
                    b |= BONE;
                }
            }
            m[i][j] = b;
        }
    }
    // A tracker restarted on a doubtful joint: the segment is in doubt for it.
    let mut bounds: Vec<usize> = starts.to_vec();
    bounds.push(n);
    for w in bounds.windows(2) {
        let (s, e) = (w[0], w[1]);
        if s >= n {
            continue;
        }
        for j in 0..nj {
            if !matches!(t.status[s][j], Status::Ok | Status::Seed) {
                for row in &mut m[s..e] {
                    row[j] |= START;
                }
            }
        }
    }
    // Spread.
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
    m
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
    /// Share of its joint-frames in doubt (0–1).
    pub need: f32,
    pub flagged: bool,
    /// Joints in doubt, most doubtful first.
    pub joints: Vec<JointDoubt>,
}

/// The report: every segment, in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub segments: Vec<SegmentNeed>,
}

impl Report {
    /// Builds the report from doubt masks `m` (see [`doubts`]) over table `t`, cut by `plan`;
    /// `corrected[k]` says segment k's file is a correction.
    pub fn build(
        t: &Table,
        m: &[Vec<u8>],
        names: &[String],
        plan: &Plan,
        corrected: &[bool],
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
            for (jd, &b) in s.joints.iter_mut().zip(&m[i]) {
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
            let doubtful: u64 = s.joints.iter().map(|j| j.frames).sum();
            s.need = doubtful as f32 / cells.max(1) as f32;
            s.flagged = doubtful > 0 && s.need >= th.min_need;
            s.joints.retain(|j| j.frames > 0);
            s.joints
                .sort_by(|a, b| b.frames.cmp(&a.frames).then(a.first.cmp(&b.first)));
        }
        Report { segments }
    }

    /// Flagged segments, most needy first (ties: earlier first).
    pub fn ranked(&self) -> Vec<&SegmentNeed> {
        let mut v: Vec<&SegmentNeed> = self.segments.iter().filter(|s| s.flagged).collect();
        v.sort_by(|a, b| b.need.total_cmp(&a.need).then(a.index.cmp(&b.index)));
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
    pub fn to_markdown(&self, run_name: &str) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Correction report: {run_name}\n");
        let r = self.ranked();
        if r.is_empty() {
            let _ = writeln!(
                s,
                "No segment needs a look: every joint was seen on every frame, with no jump, \
                                 no stretched bone and no doubtful restart.\n"
            );
        } else {
            let _ = writeln!(
                s,
                "{} of {} segments need a look, most needy first. To correct segment K, edit \
                 `segments/K.toml` (its first frame) and run `mocap2d resume RUN --segment K`; \
                 resuming from the segment before a correction also tracks back from it, so the \
                 frames before it improve too.\n",
                r.len(),
                self.segments.len()
            );
            let _ = writeln!(s, "| rank | segment | frames | doubtful joint-frames | joints (first doubtful frame) |");
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
                    "| {} | {:03}{} | {}–{} | {:.1} % | {} |",
                    i + 1,
                    g.index,
                    if g.corrected { " (corrected)" } else { "" },
                    g.first,
                    g.last,
                    100.0 * g.need,
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
            let _ = writeln!(
                s,
                "Segments without doubts worth a look: {}.",
                quiet.join(", ")
            );
        }
        s
    }
}
