//! DeepLabCut: the `dlc-csv` export reads back to the tracks, and a DeepLabCut labels file
//! (`CollectedData_<scorer>.csv`) seeds `track` (`--seeds-from-dlc`) like the same rectangles
//! as a seed file, with its errors (an unlabelled joint, a missing frame) exiting 2.

use crate::common::{run as mocap2d, s};
use crate::export::{clip, ok, run_from_gt};
use mocap2d::synth::{self, Scenario, SynthClip};
use std::fmt::Write as _;

#[test]
fn dlc_csv_reads_back_to_the_tracks() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 12);
    let run = run_from_gt(d.path(), &c);
    let out = d.path().join("walk.csv");
    ok(&mocap2d(&[
        "export",
        s(&run),
        "--format",
        "dlc-csv",
        "--out",
        s(&out),
    ]));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.starts_with("scorer,mocap2d,mocap2d,mocap2d,"),
        "{}",
        &text[..80]
    );
    let t = mocap2d::seed::dlc::read_dlc_csv(&out).unwrap();
    assert_eq!(t.joints, c.joint_names);
    assert_eq!(t.rows.len(), 12);
    let rows = mocap2d::run::tracks::read_tracks(&run.join("tracks.csv")).unwrap();
    let mut worst = 0.0f64;
    for r in &rows {
        let row = &t.rows[r.frame as usize];
        assert_eq!(row.frame, Some(r.frame));
        let j = t.joints.iter().position(|n| *n == r.joint).unwrap();
        let p = row.points[j].unwrap();
        worst = worst.max((p[0] - r.x as f64).hypot(p[1] - r.y as f64));
        assert!(
            (row.likelihood[j].unwrap() - r.score as f64).abs() < 1e-6,
            "{r:?}"
        );
    }
    assert!(worst < 0.01, "worst joint error {worst} px");
}

/// A labels file as DeepLabCut (2.2 and later) writes `CollectedData_<scorer>.csv`: three header
/// rows, three index columns (`labeled-data`, the video, the image), empty cells where a point is
/// not labelled. Frame `seed` is fully labelled from `clip`'s ground truth; frame `seed + 3` lacks
/// its second joint.
fn collected_data(clip: &SynthClip, seed: usize) -> String {
    let n = clip.joint_names.len();
    let mut s = String::from("scorer,,");
    s.push_str(&",me".repeat(2 * n));
    s.push_str("\nbodyparts,,");
    for name in &clip.joint_names {
        let _ = write!(s, ",{name},{name}");
    }
    s.push_str("\ncoords,,");
    s.push_str(&",x,y".repeat(n));
    s.push('\n');
    for f in [seed, seed + 3] {
        let _ = write!(s, "labeled-data,walk,img{f:04}.png");
        for (j, (x, y)) in clip.gt[f].iter().enumerate() {
            if f != seed && j == 1 {
                s.push_str(",,");
            } else {
                let _ = write!(s, ",{x:.3},{y:.3}");
            }
        }
        s.push('\n');
    }
    s
}

#[test]
fn dlc_labels_seed_the_tracker_like_a_seed_file() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 16);
    synth::write_clip(&c, d.path()).unwrap();
    let clip_path = d.path().join("clip.mp4");
    let seed = 4;
    // The same rectangles as a seed file.
    let mut seeds = format!("frame = {seed}\n");
    for (j, name) in c.joint_names.iter().enumerate() {
        let (x, y) = c.gt[seed][j];
        let _ = write!(
            seeds,
            "\n[[joint]]\nname = \"{name}\"\nx = {x:.3}\ny = {y:.3}\nw = 15\nh = 15\n"
        );
        if let Some(p) = c.parents[j] {
            let _ = writeln!(seeds, "parent = \"{}\"", c.joint_names[p]);
        }
    }
    let seeds_path = d.path().join("seeds.toml");
    std::fs::write(&seeds_path, seeds).unwrap();
    let csv = d.path().join("CollectedData_me.csv");
    std::fs::write(&csv, collected_data(&c, seed)).unwrap();
    let a = d.path().join("a.mocap");
    let b = d.path().join("b.mocap");
    ok(&mocap2d(&[
        "track",
        s(&clip_path),
        "--seeds",
        s(&seeds_path),
        "--out",
        s(&a),
        "-q",
    ]));
    // The skeleton from a seed file (synth's joints.toml: frame 0, other positions: only the
    // parent links are read).
    let o = mocap2d(&[
        "track",
        s(&clip_path),
        "--seeds-from-dlc",
        s(&csv),
        "--seed-frame",
        &seed.to_string(),
        "--skeleton",
        s(&d.path().join("joints.toml")),
        "--out",
        s(&b),
        "-q",
    ]);
    ok(&o);
    assert_eq!(
        std::fs::read_to_string(a.join("tracks.csv")).unwrap(),
        std::fs::read_to_string(b.join("tracks.csv")).unwrap()
    );
    let copied = std::fs::read_to_string(b.join("seeds.toml")).unwrap();
    assert!(
        copied.contains("DeepLabCut") && copied.contains("frame = 4"),
        "{copied}"
    );

    // Without --skeleton: a chain, said on stderr.
    let o = mocap2d(&[
        "track",
        s(&clip_path),
        "--seeds-from-dlc",
        s(&csv),
        "--seed-frame",
        "4",
        "--out",
        s(&d.path().join("c.mocap")),
        "-q",
    ]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("note: the DeepLabCut CSV has no skeleton")
            && err.contains("pelvis -> chest -> neck"),
        "{err}"
    );

    // Frame 7 lacks a label; frame 9 is not in the file; no --seed-frame.
    for (args, needles) in [
        (
            vec!["--seed-frame", "7"],
            vec!["line 5", "\"chest\"", "not labelled on frame 7", "frames 4"],
        ),
        (vec!["--seed-frame", "9"], vec!["no row is frame 9", "4, 7"]),
        (
            vec!["--seed-frame", "4", "--seed-size", "400"],
            vec!["not fully inside", "--seed-size"],
        ),
        (vec![], vec!["--seed-frame"]),
    ] {
        let out = d.path().join("bad.mocap");
        let mut all = vec![
            "track",
            s(&clip_path),
            "--seeds-from-dlc",
            s(&csv),
            "--out",
            s(&out),
        ];
        all.extend(args.iter().copied());
        let o = mocap2d(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        for n in needles {
            assert!(err.contains(n), "{args:?}: {n:?} not in {err}");
        }
        assert!(!out.exists());
    }
}
