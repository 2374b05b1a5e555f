//! `mocap2d report` and `mocap2d eval`: what a finished run folder says.

use crate::error::{Error, Result};
use crate::run::Manifest;
use crate::seed::read_seeds;
use std::path::Path;

/// `mocap2d report`: the correction report of a run folder (see [`crate::run::report`]), as
/// `report.md` holds it, recomputed from its `tracks.csv` and segment files, with `keys` frames
/// worth keying.
pub fn report(run_dir: &Path, keys: usize) -> Result<crate::run::report::Report> {
    let manifest = Manifest::read(&run_dir.join(crate::run::manifest::RUN_TOML))?;
    let (base, _) = read_seeds(&run_dir.join("seeds.toml"))?;
    if !manifest.complete {
        return Err(Error::RunFolder {
            path: run_dir.to_owned(),
            msg: format!(
                "the run is not complete (tracked {} segments); `mocap2d resume {}` finishes it",
                manifest.tracked_segments,
                run_dir.display()
            ),
        });
    }
    Ok(crate::run::report::for_run(run_dir, &manifest, &base, keys)?.1)
}

/// `mocap2d eval`: accuracy of a run folder's tracks against ground truth, as printable lines
/// (all joints first; when the ground truth has a `visible` column, the joints seen in the image
/// and those hidden; the labelled joints the run lacks, counted as misses, and then the joints
/// it has alone; then one line per joint when asked). Frames from the seed frame on. No joint
/// name in common: exit 2.
pub fn eval(run_dir: &Path, gt_path: &Path, per_joint: bool) -> Result<Vec<String>> {
    use crate::eval::{summarise, PointError};
    let rows = crate::run::tracks::read_tracks(&run_dir.join("tracks.csv"))?;
    let first = rows.first().map_or(0, |r| r.frame);
    let gt = crate::eval::read_gt(gt_path)?;
    // The run's joints: those of its first frame, in order.
    let names: Vec<&str> = rows
        .iter()
        .take_while(|r| r.frame == first)
        .map(|r| r.joint.as_str())
        .collect();
    crate::eval::check_shared(&names, &gt, run_dir, gt_path)?;
    let missing = crate::eval::untracked_joints(&names, &gt, first);
    let errs = crate::eval::errors(
        rows.iter().map(|r| (r.frame, r.joint.as_str(), r.x, r.y)),
        &gt,
        first,
    );
    let px = |keep: &dyn Fn(&PointError) -> bool| -> Vec<f32> {
        errs.iter().filter(|e| keep(e)).map(|e| e.px).collect()
    };
    let mut lines = vec![format!("all joints: {}", summarise(&px(&|_| true)))];
    if errs.iter().any(|e| e.visible.is_some()) {
        let seen = px(&|e| e.visible == Some(true));
        let hidden = px(&|e| e.visible == Some(false));
        lines.push(format!("visible joints: {}", summarise(&seen)));
        lines.push(format!("hidden joints: {}", summarise(&hidden)));
    }
    if !missing.is_empty() {
        let list: Vec<String> = missing
            .iter()
            .map(|(n, k)| format!("{n} ({k} points)"))
            .collect();
        lines.push(format!(
            "labelled but not in the run, counted as misses: {}",
            list.join(", ")
        ));
        // The same over the joints the run tracks: what compares with a tracker given the same
        // seed file, and with a baseline scored on those joints.
        let tracked = px(&|e| names.contains(&e.joint.as_str()));
        lines.push(format!("joints in the run: {}", summarise(&tracked)));
    }
    if per_joint {
        let all = names
            .iter()
            .copied()
            .chain(missing.iter().map(|(n, _)| n.as_str()));
        for n in all {
            lines.push(format!("{n}: {}", summarise(&px(&|e| e.joint == n))));
        }
    }
    Ok(lines)
}
