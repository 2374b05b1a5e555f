//! `mocap2d eval` against ground truth whose joints differ from the run's: a labelled joint the
//! run lacks counts as misses and is named; no joint name in common is refused (exit 2), naming
//! both sides' joints.

use crate::common::bin;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Output;

/// A run folder tracking joints `a` and `b` on frames 3..7: `a` at (10, 10), `b` at (20, 20).
fn run(dir: &Path) -> PathBuf {
    let run = dir.join("r.mocap");
    std::fs::create_dir_all(&run).unwrap();
    let mut t = String::from("frame,joint,x,y,angle,score,status\n");
    for f in 3..7 {
        let _ = writeln!(t, "{f},a,10.000,10.000,0.0000,1.000,ok");
        let _ = writeln!(t, "{f},b,20.000,20.000,0.0000,1.000,ok");
    }
    std::fs::write(run.join("tracks.csv"), t).unwrap();
    run
}

fn eval(run: &Path, gt: &Path, extra: &[&str]) -> Output {
    bin()
        .args(["eval", run.to_str().unwrap(), "--gt", gt.to_str().unwrap()])
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn a_labelled_joint_missing_from_the_run_counts_as_a_miss_and_is_named() {
    let d = tempfile::tempdir().unwrap();
    let run = run(d.path());
    // Frames 0..7 labelled; the run starts at 3. `a` within 1 px, `b` 30 px off, `c` untracked.
    let mut gt = String::from("frame,joint,x,y\n");
    for f in 0..7 {
        let _ = writeln!(gt, "{f},a,11,10\n{f},b,50,20\n{f},c,5,5");
    }
    let gt_path = d.path().join("gt.csv");
    std::fs::write(&gt_path, gt).unwrap();
    let o = eval(&run, &gt_path, &["--per-joint"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let out = String::from_utf8(o.stdout).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    // 4 frames × 3 labelled joints: c's 4 points are misses, so 4 of 12 within 5 px.
    assert!(
        lines[0].starts_with("all joints: n=12 ") && lines[0].contains("PCK@5=33.3%"),
        "{out}"
    );
    assert_eq!(
        lines[1], "labelled but not in the run, counted as misses: c (4 points)",
        "{out}"
    );
    // The joints the run has, alone: 4 of 8 within 5 px.
    assert!(
        lines[2].starts_with("joints in the run: n=8 ") && lines[2].contains("PCK@5=50.0%"),
        "{out}"
    );
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("c: n=4 ") && l.contains("PCK@10=0.0%")),
        "{out}"
    );
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("a: n=4 ") && l.contains("PCK@5=100.0%")),
        "{out}"
    );
}

#[test]
fn no_joint_name_in_common_exits_2_naming_both_sides() {
    let d = tempfile::tempdir().unwrap();
    let run = run(d.path());
    let gt_path = d.path().join("other.csv");
    std::fs::write(&gt_path, "frame,joint,x,y\n3,nose,1,1\n3,left_hip,2,2\n").unwrap();
    let o = eval(&run, &gt_path, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        o.stdout.is_empty(),
        "printed {}",
        String::from_utf8_lossy(&o.stdout)
    );
    for needle in [
        "other.csv",
        "r.mocap",
        "no joint name in common",
        "labels nose, left_hip",
        "tracks a, b",
    ] {
        assert!(err.contains(needle), "{needle:?} not in {err}");
    }
}
