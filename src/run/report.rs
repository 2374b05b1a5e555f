//! The correction report (`report.md`): which segments need a look, ranked, with the frames and
//! joints, from the per-frame evidence in the tracks. Recall matters more than precision: a
//! segment the report does not flag is one the user will not open.
//!
//! The evidence and its weights are [`super::evidence`]'s. A segment's need is the sum of its
//! joint-frames' weights: about how many of them are far off. Segments whose need reaches
//! [`Thresholds::min_need`] (and [`Thresholds::min_share`] of their joint-frames) are flagged, most
//! needy first. The report lists, per flagged segment, each doubtful joint with the frames
//! where evidence shows, widened by [`Thresholds::spread`] frames either side (a drift starts
//! before it shows and lasts after): on those scenarios 94 to 100 % of the joint-frames more
//! than 10 px off are listed.

use crate::error::Result;
use crate::run::evidence::{
    Evidence, Stream, Table, Thresholds, BONE, HIDDEN, JUMP, LOW, RESIDUAL,
};
use crate::run::segments::{self, Plan};
use crate::run::tracks::for_each_frame;
use crate::run::Manifest;
use crate::seed::Seeds;
use std::fmt::Write as _;
use std::path::Path;

/// The words of the evidence bits, in bit order.
const KIND_WORDS: [(u8, &str); 5] = [
    (LOW, "low score"),
    (HIDDEN, "hidden"),
    (JUMP, "jump"),
    (RESIDUAL, "off its motion"),
    (BONE, "bone length"),
];

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
    /// Every frame's need (about how many of its joints are far off), in frame order.
    pub frame_need: Vec<(u64, f32)>,
    /// Frames worth keying next, most worth first ([`crate::run::suggest`]).
    pub suggested: Vec<u64>,
}

impl Report {
    /// Builds the report from the evidence `ev` (see [`crate::run::evidence::evidence`]) over
    /// table `t`, cut by
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
        let mut b = Builder::new(names, plan, corrected);
        for (i, &f) in t.frames.iter().enumerate() {
            b.push(f, &ev.mask[i], &ev.weight[i]);
        }
        b.finish(files, th)
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
        if !self.suggested.is_empty() {
            let list: Vec<String> = self.suggested.iter().map(u64::to_string).collect();
            let _ = writeln!(
                s,
                "Frames worth keying next, most worth first: {}. Keyed together they leave the \
                 least doubt over the clip (`mocap2d report RUN --keys K` names K of them). A \
                 key on a frame (in `keys.toml`, any subset of joints) pulls the frames around \
                 it; then run `mocap2d resume RUN --segment K` from the segment before the one \
                 that holds the first (a key pulls the end of that segment too).\n",
                list.join(", ")
            );
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

/// [`Report::build`] frame by frame: the frames' evidence in order, then [`Builder::finish`].
pub struct Builder<'a> {
    names: &'a [String],
    plan: &'a Plan,
    corrected: &'a [bool],
    segments: Vec<SegmentNeed>,
    frame_need: Vec<(u64, f32)>,
}

impl<'a> Builder<'a> {
    /// A report on joints `names`, cut by `plan`; `corrected[k]` says segment file k is a
    /// correction.
    pub fn new(names: &'a [String], plan: &'a Plan, corrected: &'a [bool]) -> Self {
        Builder {
            names,
            plan,
            corrected,
            segments: Vec::new(),
            frame_need: Vec::new(),
        }
    }

    /// Adds frame `f`'s evidence bits and weights, one per joint.
    pub fn push(&mut self, f: u64, mask: &[u8], weight: &[f32]) {
        let k = self.plan.segment_of(f);
        if self.segments.last().is_none_or(|s| s.index != k) {
            self.segments.push(SegmentNeed {
                index: k,
                first: f,
                last: f,
                corrected: self.corrected.get(k as usize).copied().unwrap_or(false),
                need: 0.0,
                flagged: false,
                joints: self
                    .names
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
        let s = self.segments.last_mut().expect("pushed above");
        s.last = f;
        let need = weight.iter().sum::<f32>();
        s.need += need;
        self.frame_need.push((f, need));
        for (jd, &b) in s.joints.iter_mut().zip(mask) {
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

    /// The report; `files` counts the run's segment files.
    pub fn finish(mut self, files: u64, th: &Thresholds) -> Report {
        for s in &mut self.segments {
            let cells = (s.last - s.first + 1) * self.names.len() as u64;
            s.flagged = s.need >= th.min_need.max(th.min_share * cells as f32);
            s.joints.retain(|j| j.frames > 0);
            s.joints
                .sort_by(|a, b| b.frames.cmp(&a.frames).then(a.first.cmp(&b.first)));
        }
        Report {
            segments: self.segments,
            files,
            frame_need: self.frame_need,
            suggested: Vec::new(),
        }
    }
}

/// What a run's `tracks.csv` holds, counted while the report reads it: frames, and joint-frames
/// per status word (for the summary `track` prints).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tally {
    pub frames: u64,
    pub status: std::collections::BTreeMap<&'static str, u64>,
}

/// Frames `report.md` suggests keying next (`mocap2d report --keys K` asks for another number).
pub const SUGGESTED: usize = 10;

/// The report on `run_dir/tracks.csv`, tracked as `manifest` says from the seeds `base`, with
/// `suggested` frames worth keying. The file is read a frame at a time (see [`Stream`]): memory
/// does not grow with the clip.
pub fn for_run(
    run_dir: &Path,
    manifest: &Manifest,
    base: &Seeds,
    suggested: usize,
) -> Result<(Tally, Report)> {
    let plan = Plan {
        seed_frame: manifest.seed_frame,
        len: manifest.segment_len,
    };
    let sk = &base.skeleton;
    let boxes = base.boxes();
    let sides: Vec<f32> = boxes.iter().map(|b| 0.5 * (b.w + b.h) as f32).collect();
    let seed_len: Vec<f32> = (0..sk.len())
        .map(|j| sk.parents[j].map_or(0.0, |p| (boxes[j].centre() - boxes[p].centre()).norm()))
        .collect();
    let mut corrected = Vec::new();
    for (k, rec) in manifest.segment.iter().enumerate() {
        let h = segments::hash_file(&segments::file_path(run_dir, k as u64))?;
        corrected.push(h.is_some_and(|h| !rec.written.contains(&h)));
    }
    let th = Thresholds::default();
    let names: Vec<String> = base.joints.iter().map(|j| j.name.clone()).collect();
    let mut stream = Stream::new(sk, &sides, &seed_len, &th);
    let mut builder = Builder::new(&names, &plan, &corrected);
    let mut tally = Tally::default();
    for_each_frame(
        &run_dir.join("tracks.csv"),
        names.len(),
        |f, pos, score, status| {
            tally.frames += 1;
            for st in status {
                *tally.status.entry(st.as_str()).or_default() += 1;
            }
            if let Some(j) = stream.push(f, pos, score, status) {
                builder.push(j.frame, &j.mask, &j.weight);
            }
        },
    )?;
    for j in stream.finish() {
        builder.push(j.frame, &j.mask, &j.weight);
    }
    let files = manifest.segment.len() as u64;
    let mut report = builder.finish(files, &th);
    // Frames the user has keyed already: the seed frame, corrected segment files, keys.toml.
    let mut keyed = vec![manifest.seed_frame];
    for (k, c) in corrected.iter().enumerate() {
        if *c {
            keyed.push(plan.first_frame(k as u64));
        }
    }
    // An unreadable keys.toml is resume's to report; here it only keys nothing.
    let keys = crate::run::keys::read(run_dir, &names, manifest.width, manifest.height, None)
        .unwrap_or_default();
    keyed.extend(keys.iter().map(|k| k.frame));
    report.suggested = crate::run::suggest::suggest(&report.frame_need, &keyed, suggested);
    Ok((tally, report))
}

#[cfg(test)]
mod tests;
