//! The real dance clip (`../shared/clips/dance`: 406×720, 450 frames, a pose network's labels
//! on every frame, scored with PCK@20 as its README explains): keys written from the labels into
//! the segment files, `resume` from the first, and the result against linear interpolation of
//! the same keys (what a keyframe editor gives for the same work) and against the run's own
//! `ok` statuses. A slice of the clip runs in `cargo test`; the whole clip is release-only.

use mocap2d::app::{resume, track, ResumeOptions, TrackOptions};
use mocap2d::eval::read_gt;
use mocap2d::progress::NoProgress;
use mocap2d::run::segments::file_path;
use mocap2d::run::tracks::read_tracks;
use mocap2d::seed::read_seeds;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::process::Command;

type Labels = HashMap<(u64, String), (f32, f32)>;

/// The dance's folder, or `None` (with a note) when the shared clips are absent.
fn dance() -> Option<PathBuf> {
    let dir = crate::common::shared("clips/dance");
    if dir.join("clip.mp4").exists() {
        Some(dir)
    } else {
        eprintln!(
            "note: {} is absent; the dance test was not run",
            dir.display()
        );
        None
    }
}

fn labels(dir: &Path) -> Labels {
    read_gt(&dir.join("gt.csv"))
        .unwrap()
        .into_iter()
        .filter(|g| g.x.is_finite() && g.y.is_finite())
        .map(|g| ((g.frame, g.joint), (g.x, g.y)))
        .collect()
}

/// What a keyed run of the dance scores, each share in 0–1 over the labelled points of the
/// seeded joints on the run's frames.
#[derive(Debug)]
struct Scores {
    /// PCK@20 of the run.
    pck20: f64,
    /// PCK@20 of linear interpolation between the same keys.
    interp20: f64,
    /// Of the joint-frames the run calls `ok`, the share more than 20 px off.
    ok_wrong: f64,
}

/// Tracks `clip` from the dance's seed file in segments of `every` frames, writes the labels
/// into every segment file but the first (the seed), resumes from segment 0 and scores it.
fn keyed_run(clip: &Path, dir: &Path, every: u64, out: &Path) -> Scores {
    let gt = labels(dir);
    let run = out.join(format!("run-{every}"));
    let opts = TrackOptions {
        out: Some(run.clone()),
        segment_len: every,
        ..TrackOptions::new(clip, dir.join("joints.toml"))
    };
    let s = track(&opts, &NoProgress).unwrap();
    let mut keys: BTreeMap<u64, HashMap<String, (f32, f32)>> = BTreeMap::new();
    let (seeds, _) = read_seeds(&dir.join("joints.toml")).unwrap();
    let names: Vec<String> = seeds.joints.iter().map(|j| j.name.clone()).collect();
    keys.insert(
        seeds.frame,
        seeds
            .joints
            .iter()
            .map(|j| (j.name.clone(), (j.bbox.cx, j.bbox.cy)))
            .collect(),
    );
    // The labels go into the files as `scripts/accuracy` puts them (x and y edited, the rest
    // of each file left as the tool wrote it, as a user editing it by hand would).
    let o = Command::new("bash")
        .arg(crate::common::root().join("scripts/keys-from-labels"))
        .arg(&run)
        .arg(dir.join("gt.csv"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for k in 1..s.segments {
        let (seeds, _) = read_seeds(&file_path(&run, k)).unwrap();
        let at = seeds
            .joints
            .iter()
            .filter(|j| gt.contains_key(&(seeds.frame, j.name.clone())))
            .map(|j| (j.name.clone(), (j.bbox.cx, j.bbox.cy)))
            .collect();
        keys.insert(seeds.frame, at);
    }
    let opts = ResumeOptions {
        run: run.clone(),
        segment: Some(0),
        clip: Some(clip.to_owned()),
        ..Default::default()
    };
    resume(&opts, &NoProgress).unwrap();

    let rows = read_tracks(&run.join("tracks.csv")).unwrap();
    let last = rows.iter().map(|r| r.frame).max().unwrap();
    let interp = |joint: &str, f: u64| -> Option<(f32, f32)> {
        let a = keys
            .range(..=f)
            .rev()
            .find_map(|(&t, k)| Some((t, *k.get(joint)?)))?;
        let b = keys
            .range(f..)
            .find_map(|(&t, k)| Some((t, *k.get(joint)?)));
        Some(match b {
            Some((tb, pb)) if tb > a.0 => {
                let l = (f - a.0) as f32 / (tb - a.0) as f32;
                (a.1 .0 + l * (pb.0 - a.1 .0), a.1 .1 + l * (pb.1 - a.1 .1))
            }
            _ => a.1,
        })
    };
    let near = |p: (f32, f32), q: (f32, f32)| (p.0 - q.0).hypot(p.1 - q.1) <= 20.0;
    let by_key: HashMap<(u64, &str), &mocap2d::run::tracks::TrackRow> = rows
        .iter()
        .map(|r| ((r.frame, r.joint.as_str()), r))
        .collect();
    let (mut n, mut hit, mut ihit, mut ok, mut ok_far) = (0usize, 0usize, 0usize, 0usize, 0usize);
    for ((f, joint), &g) in &gt {
        if *f > last || !names.contains(joint) {
            continue;
        }
        n += 1;
        if let Some(r) = by_key.get(&(*f, joint.as_str())) {
            let good = near((r.x, r.y), g);
            hit += good as usize;
            if r.status == "ok" {
                ok += 1;
                ok_far += !good as usize;
            }
        }
        ihit += interp(joint, *f).is_some_and(|p| near(p, g)) as usize;
    }
    Scores {
        pck20: hit as f64 / n as f64,
        interp20: ihit as f64 / n as f64,
        ok_wrong: ok_far as f64 / ok.max(1) as f64,
    }
}

/// The first 101 frames (0–100: she steps back and shrinks to about half her size) with a key
/// every 25 frames.
#[test]
fn a_slice_of_the_dance_keyed_every_25_frames_beats_interpolating_the_keys() {
    let Some(dir) = dance() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let clip = tmp.path().join("slice.mp4");
    let o = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(dir.join("clip.mp4"))
        .args(["-frames:v", "101", "-c", "copy"])
        .arg(&clip)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = keyed_run(&clip, &dir, 25, tmp.path());
    println!("dance 0-100, keys every 25: {s:?}");
    // Measured: PCK@20 92.3 % against 88.5 % for interpolating the keys; 3.2 % of `ok` over
    // 20 px off.
    assert!(s.pck20 >= 0.91, "{s:?}");
    assert!(s.pck20 >= s.interp20 + 0.03, "{s:?}");
    assert!(s.ok_wrong <= 0.04, "{s:?}");
}

/// The whole clip with keys every 50 and every 25 frames.
#[test]
#[ignore = "long clip: run with cargo test --release --test it dance:: -- --ignored"]
fn the_dance_keyed_every_50_and_25_frames_beats_interpolating_the_keys() {
    let Some(dir) = dance() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let clip = dir.join("clip.mp4");
    let s50 = keyed_run(&clip, &dir, 50, tmp.path());
    let s25 = keyed_run(&clip, &dir, 25, tmp.path());
    println!("dance, keys every 50: {s50:?}\ndance, keys every 25: {s25:?}");
    // Measured over the 16 seeded joints (the labels' right ankle is not in the seed file;
    // `eval` counts its 440 points as misses and reports 72.7 / 82.0 %): keys every 50, PCK@20
    // 77.2 % against 62.0 % for interpolation, 9.1 % of `ok` over 20 px off; every 25, 87.0 %
    // against 78.6 %, 6.4 %. Before spans in doubt whose blend lost the body were led by flow
    // (`keyed::settle`): 76.2 / 85.2 %. The issue asks for 85 / 90 % (docs/benchmarks.md).
    assert!(s50.pck20 >= 0.765 && s25.pck20 >= 0.865, "{s50:?} {s25:?}");
    assert!(s50.pck20 >= s50.interp20 + 0.145, "{s50:?}");
    assert!(s25.pck20 >= s25.interp20 + 0.08, "{s25:?}");
    assert!(
        s50.ok_wrong <= 0.10 && s25.ok_wrong <= 0.075,
        "{s50:?} {s25:?}"
    );
}

/// PCK@20 (0–1) of a run over the labelled points of the joints it tracks.
fn pck20(run: &Path, gt: &Labels) -> f64 {
    let rows = read_tracks(&run.join("tracks.csv")).unwrap();
    let (mut n, mut hit) = (0usize, 0usize);
    for r in &rows {
        if let Some(&(x, y)) = gt.get(&(r.frame, r.joint.clone())) {
            n += 1;
            hit += ((r.x - x).hypot(r.y - y) <= 20.0) as usize;
        }
    }
    hit as f64 / n.max(1) as f64
}

/// Keys of `keys.toml` every 25 frames from frame 12 on (and on the last frame), none on a
/// segment's start: in segments of 150 frames the dance scores what it scores in one segment,
/// the spans across the segments' ends solved through both keys.
#[test]
#[ignore = "long clip: run with cargo test --release --test it dance:: -- --ignored"]
fn keys_off_the_segments_starts_are_solved_across_the_segments_ends() {
    let Some(dir) = dance() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let gt = labels(&dir);
    let (seeds, _) = read_seeds(&dir.join("joints.toml")).unwrap();
    let frames: Vec<u64> = (12..449).step_by(25).chain([449]).collect();
    let mut text = String::new();
    for f in &frames {
        text.push_str(&format!("[[key]]\nframe = {f}\n"));
        for j in &seeds.joints {
            if let Some((x, y)) = gt.get(&(*f, j.name.clone())) {
                text.push_str(&format!("{} = [{x}, {y}]\n", j.name));
            }
        }
    }
    let score = |segment_len: u64| -> f64 {
        let run = tmp.path().join(format!("run-{segment_len}"));
        let opts = TrackOptions {
            out: Some(run.clone()),
            segment_len,
            ..TrackOptions::new(dir.join("clip.mp4"), dir.join("joints.toml"))
        };
        track(&opts, &NoProgress).unwrap();
        std::fs::write(run.join("keys.toml"), &text).unwrap();
        let opts = ResumeOptions {
            run: run.clone(),
            segment: Some(0),
            ..Default::default()
        };
        resume(&opts, &NoProgress).unwrap();
        pck20(&run, &gt)
    };
    let (segmented, whole) = (score(150), score(1000));
    println!(
        "keys every 25 from frame 12: PCK@20 {segmented:.4} in segments of 150, {whole:.4} in one"
    );
    // Measured: 84.6 % in both (seeded joints); before spans ran across the segments' ends,
    // 80.4 % in segments of 150, the frames around each end 10–24 points down.
    assert!(segmented >= 0.84, "{segmented}");
    assert!(
        (segmented - whole).abs() <= 0.01,
        "{segmented} against {whole}"
    );
}

/// The seed file rooted at `root` instead: the parent links on the path from `root` to the old
/// root turned round, everything else as it was.
fn rerooted(dir: &Path, root: &str, out: &Path) -> PathBuf {
    let (seeds, _) = read_seeds(&dir.join("joints.toml")).unwrap();
    let parent: HashMap<String, Option<String>> = seeds
        .joints
        .iter()
        .map(|j| (j.name.clone(), j.parent.clone()))
        .collect();
    let mut path = vec![root.to_owned()];
    while let Some(Some(p)) = parent.get(path.last().unwrap()) {
        path.push(p.clone());
    }
    let mut joints = seeds.joints.clone();
    for j in &mut joints {
        if let Some(i) = path.iter().position(|n| *n == j.name) {
            j.parent = i.checked_sub(1).map(|i| path[i].clone());
        }
    }
    let file = out.join(format!("rooted-at-{root}.toml"));
    std::fs::write(&file, mocap2d::seed::to_toml(seeds.frame, &joints, "")).unwrap();
    file
}

/// The whole clip uncorrected, seeded on frame 0 with the skeleton rooted at the hips (the
/// clip's seed file), a wrist, an ankle and the nose: the root is the user's choice, and the
/// tracking must not depend on it.
#[test]
#[ignore = "long clip: run with cargo test --release --test it dance:: -- --ignored"]
fn the_root_of_the_skeleton_does_not_change_the_uncorrected_dance() {
    let Some(dir) = dance() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let gt = labels(&dir);
    let (mut scores, mut oks) = (Vec::new(), Vec::new());
    for root in ["left_hip", "left_wrist", "left_ankle", "nose"] {
        let run = tmp.path().join(root);
        let opts = TrackOptions {
            out: Some(run.clone()),
            ..TrackOptions::new(dir.join("clip.mp4"), rerooted(&dir, root, tmp.path()))
        };
        track(&opts, &NoProgress).unwrap();
        let rows = read_tracks(&run.join("tracks.csv")).unwrap();
        let (mut n, mut hit, mut ok, mut ok_far) = (0usize, 0usize, 0usize, 0usize);
        for r in &rows {
            if let Some(g) = gt.get(&(r.frame, r.joint.clone())) {
                let near = (r.x - g.0).hypot(r.y - g.1) <= 20.0;
                n += 1;
                hit += near as usize;
                if r.status == "ok" {
                    ok += 1;
                    ok_far += !near as usize;
                }
            }
        }
        scores.push((root, hit as f64 / n as f64));
        oks.push((root, ok, ok_far as f64 / ok.max(1) as f64));
    }
    println!("dance uncorrected, PCK@20 by root: {scores:?}; ok, share over 20 px: {oks:?}");
    // `ok` means something even where the tracker is lost (at most 10 % of `ok` more than
    // 20 px off). Measured: 7.5 % of 173 at every root; before a joint needed its body to fit
    // as well (docs/method.md §2.5), 46.7 % of 1013 at the hips.
    for &(root, ok, wrong) in &oks {
        assert!(ok >= 150 && wrong <= 0.085, "{root}: {oks:?}");
    }
    // Measured over the 16 seeded joints: 29.5, 29.5, 29.2, 30.6 % (`eval`, counting the
    // unseeded right ankle as misses: 27.8, 27.8, 27.5, 28.8 %). Before a re-detected body had
    // to fit better than where it was, a hidden root could take a mirrored body: 20.9 % at the
    // hips (`eval`).
    let lo = scores.iter().map(|s| s.1).fold(1.0, f64::min);
    let hi = scores.iter().map(|s| s.1).fold(0.0, f64::max);
    assert!(lo >= 0.285, "{scores:?}");
    assert!(hi - lo <= 0.02, "{scores:?}");
}

/// The dance seen through a window that pans (366×716 of its 406×720, moving up to 40 px across
/// and 4 px down, as a camera on a slow pan would): the median of such a clip is a smear, so
/// `track` finds that the camera moves and tracks without a plate (docs/method.md §1).
#[test]
#[ignore = "long clip: run with cargo test --release --test it dance:: -- --ignored"]
fn a_panned_dance_is_tracked_without_its_smeared_plate() {
    let Some(dir) = dance() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let off = |n: u64| {
        let n = n as f64;
        (
            (20.0 + 20.0 * (2.0 * std::f64::consts::PI * n / 150.0).sin()).round() as f32,
            (2.0 - 2.0 * (2.0 * std::f64::consts::PI * n / 200.0).cos()).round() as f32,
        )
    };
    let clip = tmp.path().join("panned.mp4");
    let o = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(dir.join("clip.mp4"))
        .args([
            "-an",
            "-vf",
            "crop=366:716:'round(20+20*sin(2*PI*n/150))':'round(2-2*cos(2*PI*n/200))'",
            "-c:v",
            "libx264",
            "-crf",
            "18",
        ])
        .arg(&clip)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The seed file and the labels moved with the window.
    let (ox, oy) = off(0);
    let seeds_text: String = std::fs::read_to_string(dir.join("joints.toml"))
        .unwrap()
        .lines()
        .map(|l| match l.split_once(" = ") {
            Some(("x", v)) => format!("x = {}\n", v.parse::<f32>().unwrap() - ox),
            Some(("y", v)) => format!("y = {}\n", v.parse::<f32>().unwrap() - oy),
            _ => format!("{l}\n"),
        })
        .collect();
    let seeds = tmp.path().join("joints.toml");
    std::fs::write(&seeds, seeds_text).unwrap();
    let run = tmp.path().join("run");
    let opts = TrackOptions {
        out: Some(run.clone()),
        ..TrackOptions::new(clip, seeds)
    };
    let summary = track(&opts, &NoProgress).unwrap();
    assert!(
        summary.note.contains("the camera moves"),
        "{}",
        summary.note
    );
    let gt = labels(&dir);
    let (mut n, mut hit) = (0usize, 0usize);
    for r in read_tracks(&run.join("tracks.csv")).unwrap() {
        if let Some(g) = gt.get(&(r.frame, r.joint.clone())) {
            let (dx, dy) = off(r.frame);
            n += 1;
            hit += ((r.x - (g.0 - dx)).hypot(r.y - (g.1 - dy)) <= 20.0) as usize;
        }
    }
    let pck = hit as f64 / n as f64;
    println!("panned dance, PCK@20 over the seeded joints: {pck:.3}");
    // Measured: 26.6 % (`eval`, counting the unseeded right ankle as misses: 25.0 %). With the
    // clip's median plate, as before the camera check, `eval` gave 16.9 %; without a plate
    // before limbs were measured by their edges, 24.6 % (docs/NOTES.md, "a camera that
    // moves" and "limbs measured by their edges").
    assert!(pck >= 0.26, "{pck}");
}
