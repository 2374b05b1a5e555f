//! Accuracy against ground truth: per joint-frame Euclidean error (px) between tracked centres
//! and labelled positions, summarised as median, 95th percentile and PCK@N (share of
//! joint-frames within N px). Ground truth is `frame,joint,x,y` (as the labelled clips ship; a
//! point marked invisible there has no row), with an optional `visible` column: the share (0–1)
//! of the joint drawn on top, which `mocap2d synth` writes, so that joints hidden in the image
//! (below [`VISIBLE_FROM`]) can be told apart from seen ones. A labelled point with no tracked
//! row counts as a miss, including every point of a labelled joint the run does not track
//! ([`untracked_joints`] names them); a run and a ground truth with no joint name in common are
//! refused ([`check_shared`]).

use crate::error::{Error, Result};
use std::collections::HashMap;
use std::path::Path;

/// One ground-truth point.
#[derive(Debug, Clone, serde::Deserialize)]
pub struct GtRow {
    pub frame: u64,
    pub joint: String,
    pub x: f32,
    pub y: f32,
    /// Share (0–1) of the joint visible in the image, when the ground truth says.
    #[serde(default)]
    pub visible: Option<f32>,
}

/// A joint whose `visible` share is at least this is seen in the image; below, something covers
/// it (the synth's own threshold, see [`crate::synth::SynthClip::visibility`]).
pub const VISIBLE_FROM: f32 = 0.3;

/// The error of one tracked joint-frame against its ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct PointError {
    pub frame: u64,
    pub joint: String,
    /// Centre error (px); infinite when the joint-frame was not tracked.
    pub px: f32,
    /// Whether the joint is seen in the image, when the ground truth says.
    pub visible: Option<bool>,
}

/// Error summary over joint-frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Accuracy {
    /// Joint-frames compared.
    pub count: usize,
    pub median_px: f32,
    pub p95_px: f32,
    /// Share (0–1) within 5 px.
    pub pck5: f32,
    /// Share (0–1) within 10 px.
    pub pck10: f32,
    /// Share (0–1) within 20 px (the real clips' score: their labels are a pose network's).
    pub pck20: f32,
}

impl std::fmt::Display for Accuracy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "n={} median={:.2}px p95={:.2}px PCK@5={:.1}% PCK@10={:.1}% PCK@20={:.1}%",
            self.count,
            self.median_px,
            self.p95_px,
            100.0 * self.pck5,
            100.0 * self.pck10,
            100.0 * self.pck20
        )
    }
}

/// Summarises a list of errors (px). Empty input gives zero counts and NaN statistics.
pub fn summarise(errors: &[f32]) -> Accuracy {
    let mut e: Vec<f32> = errors.to_vec();
    e.sort_by(f32::total_cmp);
    let q = |p: f32| -> f32 {
        if e.is_empty() {
            return f32::NAN;
        }
        e[(((e.len() - 1) as f32) * p).round() as usize]
    };
    let within = |t: f32| e.iter().filter(|&&v| v <= t).count() as f32 / e.len().max(1) as f32;
    Accuracy {
        count: e.len(),
        median_px: q(0.5),
        p95_px: q(0.95),
        pck5: within(5.0),
        pck10: within(10.0),
        pck20: within(20.0),
    }
}

/// Reads a ground-truth CSV (`frame,joint,x,y`, optionally `visible`).
pub fn read_gt(path: &Path) -> Result<Vec<GtRow>> {
    let mut rdr = csv::Reader::from_path(path)
        .map_err(|e| Error::Usage(format!("{}: cannot read ground truth: {e}", path.display())))?;
    rdr.deserialize()
        .enumerate()
        .map(|(i, r)| {
            r.map_err(|e| Error::Usage(format!("{}: line {}: {e}", path.display(), i + 2)))
        })
        .collect()
}

/// Per joint-frame errors of `tracked` (frame, joint, x, y) against `gt`, for ground-truth rows
/// from `first_frame` on. A missing tracked row counts as infinite error, as do all the points
/// of a joint the run does not track. Returned in ground-truth order.
pub fn errors<'a>(
    tracked: impl IntoIterator<Item = (u64, &'a str, f32, f32)>,
    gt: &[GtRow],
    first_frame: u64,
) -> Vec<PointError> {
    let mut by_key: HashMap<(u64, &str), (f32, f32)> = HashMap::new();
    for (f, j, x, y) in tracked {
        by_key.insert((f, j), (x, y));
    }
    gt.iter()
        .filter(|g| g.frame >= first_frame)
        .map(|g| {
            let px = match by_key.get(&(g.frame, g.joint.as_str())) {
                Some(&(x, y)) => ((x - g.x).powi(2) + (y - g.y).powi(2)).sqrt(),
                None => f32::INFINITY,
            };
            PointError {
                frame: g.frame,
                joint: g.joint.clone(),
                px,
                visible: g.visible.map(|v| v >= VISIBLE_FROM),
            }
        })
        .collect()
}

/// The joints labelled in `gt` from `first_frame` on that are not among `tracked` (the run's
/// joint names), each with its number of labelled points, in ground-truth order: all their
/// points count as misses.
pub fn untracked_joints(tracked: &[&str], gt: &[GtRow], first_frame: u64) -> Vec<(String, usize)> {
    let mut out: Vec<(String, usize)> = Vec::new();
    for g in gt.iter().filter(|g| g.frame >= first_frame) {
        if tracked.contains(&g.joint.as_str()) {
            continue;
        }
        match out.iter_mut().find(|(n, _)| *n == g.joint) {
            Some((_, k)) => *k += 1,
            None => out.push((g.joint.clone(), 1)),
        }
    }
    out
}

/// Refuses (exit 2) a ground truth `gt` (from `gt_path`) that shares no joint name with the run
/// `run` (tracking the joints `tracked`): the message names both sides' joints.
pub fn check_shared(tracked: &[&str], gt: &[GtRow], run: &Path, gt_path: &Path) -> Result<()> {
    if gt.iter().any(|g| tracked.contains(&g.joint.as_str())) {
        return Ok(());
    }
    let mut labelled: Vec<&str> = Vec::new();
    for g in gt {
        if !labelled.contains(&g.joint.as_str()) {
            labelled.push(&g.joint);
        }
    }
    let list = |v: &[&str]| {
        if v.is_empty() {
            "none".to_owned()
        } else {
            v.join(", ")
        }
    };
    Err(Error::Usage(format!(
        "{}: no joint name in common with the run {}: the ground truth labels {}; the run tracks \
         {}. Give the ground truth of this clip, with the seed file's joint names",
        gt_path.display(),
        run.display(),
        list(&labelled),
        list(tracked)
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_by_hand() {
        let a = summarise(&[0.0, 1.0, 2.0, 6.0, 20.0]);
        assert_eq!(a.count, 5);
        assert_eq!(a.median_px, 2.0);
        assert_eq!(a.p95_px, 20.0);
        assert!((a.pck5 - 0.6).abs() < 1e-6);
        assert!((a.pck10 - 0.8).abs() < 1e-6);
    }

    #[test]
    fn missing_rows_count_as_misses() {
        let gt = vec![
            GtRow {
                frame: 0,
                joint: "a".into(),
                x: 0.0,
                y: 0.0,
                visible: None,
            },
            GtRow {
                frame: 1,
                joint: "a".into(),
                x: 3.0,
                y: 4.0,
                visible: None,
            },
        ];
        let e = errors([(0u64, "a", 0.0f32, 0.0f32)], &gt, 0);
        assert_eq!(e[0].px, 0.0);
        assert!(e[1].px.is_infinite());
    }

    fn row(frame: u64, joint: &str) -> GtRow {
        GtRow {
            frame,
            joint: joint.into(),
            x: 1.0,
            y: 1.0,
            visible: None,
        }
    }

    #[test]
    fn a_labelled_joint_the_run_lacks_counts_as_misses_and_is_named() {
        let gt = vec![
            row(0, "a"),
            row(0, "b"),
            row(1, "a"),
            row(1, "b"),
            row(2, "b"),
        ];
        let e = errors([(0u64, "a", 1.0f32, 1.0f32), (1, "a", 1.0, 1.0)], &gt, 0);
        assert_eq!(e.len(), 5, "every labelled point is compared");
        assert_eq!(e.iter().filter(|e| e.px.is_infinite()).count(), 3);
        assert_eq!(untracked_joints(&["a"], &gt, 0), vec![("b".to_owned(), 3)]);
        assert_eq!(untracked_joints(&["a"], &gt, 2), vec![("b".to_owned(), 1)]);
        assert!(untracked_joints(&["a", "b"], &gt, 0).is_empty());
    }

    #[test]
    fn no_shared_joint_name_is_refused_naming_both_sides() {
        let gt = vec![row(0, "nose"), row(0, "left_hip")];
        let e = check_shared(
            &["head", "pelvis"],
            &gt,
            Path::new("r.mocap"),
            Path::new("gt.csv"),
        )
        .unwrap_err();
        assert!(e.is_user_error());
        let m = e.to_string();
        assert!(
            m.contains("gt.csv")
                && m.contains("r.mocap")
                && m.contains("labels nose, left_hip")
                && m.contains("tracks head, pelvis"),
            "{m}"
        );
        assert!(check_shared(&["nose"], &gt, Path::new("r"), Path::new("g")).is_ok());
    }

    #[test]
    fn the_visible_column_is_optional_and_splits_seen_from_hidden() {
        let dir = tempfile::tempdir().unwrap();
        let with = dir.path().join("with.csv");
        std::fs::write(
            &with,
            "frame,joint,x,y,visible\n0,a,0,0,0.80\n0,b,5,5,0.10\n",
        )
        .unwrap();
        let without = dir.path().join("without.csv");
        std::fs::write(&without, "frame,joint,x,y\n0,a,0,0\n").unwrap();
        let gt = read_gt(&with).unwrap();
        let e = errors([(0u64, "a", 1.0f32, 0.0f32), (0, "b", 5.0, 5.0)], &gt, 0);
        assert_eq!(e[0].visible, Some(true));
        assert_eq!(e[1].visible, Some(false));
        assert_eq!(e[0].px, 1.0);
        let gt = read_gt(&without).unwrap();
        assert_eq!(gt[0].visible, None);
        assert_eq!(
            errors([(0u64, "a", 0.0f32, 0.0f32)], &gt, 0)[0].visible,
            None
        );
    }
}
