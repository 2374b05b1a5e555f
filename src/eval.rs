//! Accuracy against ground truth: per joint-frame Euclidean error (px) between tracked centres
//! and labelled positions, summarised as median, 95th percentile and PCK@N (share of
//! joint-frames within N px). Ground truth is `frame,joint,x,y` (as the labelled clips ship; a
//! point marked invisible there has no row), with an optional `visible` column: the share (0–1)
//! of the joint drawn on top, which `mocap2d synth` writes, so that joints hidden in the image
//! (below [`VISIBLE_FROM`]) can be told apart from seen ones. A labelled point with no tracked
//! row counts as a miss.

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
/// from `first_frame` on whose joint is tracked at all. A missing tracked row counts as infinite
/// error. Returned in ground-truth order.
pub fn errors<'a>(
    tracked: impl IntoIterator<Item = (u64, &'a str, f32, f32)>,
    gt: &[GtRow],
    first_frame: u64,
) -> Vec<PointError> {
    let mut by_key: HashMap<(u64, &str), (f32, f32)> = HashMap::new();
    let mut joints = std::collections::HashSet::new();
    for (f, j, x, y) in tracked {
        by_key.insert((f, j), (x, y));
        joints.insert(j);
    }
    gt.iter()
        .filter(|g| g.frame >= first_frame && joints.contains(g.joint.as_str()))
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
