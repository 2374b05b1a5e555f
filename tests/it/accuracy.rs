//! Tracking accuracy against ground truth, through the whole `track` command: render a synth
//! clip at 640×360 (120 frames, seed 1), encode it to H.264, track it from the seed file the
//! clip comes with, and compare with the exact joint positions. Bounds sit just under today's
//! measured figures (in the comments), so a regression fails; the targets are noted
//! where the tracker does not reach them yet.

use crate::common::{synth_clip, write_synth};
use mocap2d::app::{eval, resume, track, ResumeOptions, TrackOptions};
use mocap2d::eval::read_gt;
use mocap2d::progress::NoProgress;
use mocap2d::run::segments::file_path;
use mocap2d::run::tracks::read_tracks;
use mocap2d::seed::{read_seeds, to_toml};
use mocap2d::synth::Scenario;
use std::collections::HashMap;
use std::path::Path;

/// Renders `scenario` at 640×360 (`frames`: its default length when `None`), tracks it, and
/// returns (median px, PCK@5 in 0–1) with the folder holding `clip.mp4`, `gt.csv` and the run
/// folder `run/`.
fn synth_run(scenario: Scenario, frames: Option<u32>) -> ((f32, f32), tempfile::TempDir) {
    synth_run_with(scenario, frames, TrackOptions::new("", "").segment_len, 1)
}

/// [`synth_run`] with segments of `segment_len` frames, of the clip rendered with `seed`.
fn synth_run_with(
    scenario: Scenario,
    frames: Option<u32>,
    segment_len: u64,
    seed: u64,
) -> ((f32, f32), tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    write_synth(dir.path(), scenario, 640, 360, seed, frames);
    let opts = TrackOptions {
        out: Some(dir.path().join("run")),
        segment_len,
        ..TrackOptions::new(dir.path().join("clip.mp4"), dir.path().join("joints.toml"))
    };
    track(&opts, &NoProgress).unwrap();
    let line = &eval(&dir.path().join("run"), &dir.path().join("gt.csv"), false).unwrap()[0];
    println!("{scenario} seed {seed}: {line}");
    (parse_line(line), dir)
}

/// Median and PCK@5 of one joint of a run made by [`synth_run_with`] (its `eval` line, printed).
fn joint_figures(dir: &tempfile::TempDir, joint: &str) -> (f32, f32) {
    let lines = eval(&dir.path().join("run"), &dir.path().join("gt.csv"), true).unwrap();
    let prefix = format!("{joint}:");
    let line = lines.iter().find(|l| l.starts_with(&prefix)).unwrap();
    println!("{line}");
    parse_line(line)
}

/// Tracks with `opts` into `dir/run` and scores it against `dir/gt.csv`: the `eval` line
/// (printed after `label`) with its median and PCK@5.
fn track_into_run(dir: &Path, opts: TrackOptions, label: &str) -> (String, (f32, f32)) {
    let opts = TrackOptions {
        out: Some(dir.join("run")),
        ..opts
    };
    track(&opts, &NoProgress).unwrap();
    let line = eval(&dir.join("run"), &dir.join("gt.csv"), false).unwrap()[0].clone();
    println!("{label}: {line}");
    let figures = parse_line(&line);
    (line, figures)
}

/// Pulls median and PCK@5 out of an `eval` line.
fn parse_line(line: &str) -> (f32, f32) {
    let field = |key: &str, end: &str| -> f32 {
        let s = &line[line.find(key).unwrap() + key.len()..];
        s[..s.find(end).unwrap()].parse().unwrap()
    };
    (field("median=", "px"), field("PCK@5=", "%") / 100.0)
}

/// Asserts a scenario's median (px) and PCK@5 (0–1) bounds.
fn assert_accuracy(scenario: Scenario, max_median: f32, min_pck5: f32) {
    let ((median, pck5), _dir) = synth_run(scenario, None);
    assert!(median <= max_median, "{scenario}: median {median} px");
    assert!(pck5 >= min_pck5, "{scenario}: PCK@5 {pck5}");
}

#[test]
fn walk_keeps_joints_within_5px_through_the_far_arm_passing_behind() {
    // Measured: median 0.09 px, PCK@5 99.9 % (target: >= 95 %, <= 1.5 px).
    assert_accuracy(Scenario::Walk, 0.3, 0.98);
}

#[test]
fn occlude_keeps_joints_within_5px_with_crossing_legs_and_hidden_arm() {
    // Measured: median 0.10 px, PCK@5 96.6 % (target: >= 95 %, <= 1.5 px); 96.8 % before
    // the bone-length prior was anchored to the seed length.
    assert_accuracy(Scenario::Occlude, 0.3, 0.95);
}

#[test]
fn fast_punches_and_kicks_stay_tracked() {
    // Measured: median 0.11 px, PCK@5 100.0 % (target: >= 90 %, <= 2 px).
    assert_accuracy(Scenario::Fast, 0.3, 0.98);
}

#[test]
fn squash_and_stretch_is_tracked() {
    // One seed swings by a point either way on any change (see the README), so the 95 % target
    // is asserted on the mean of seeds 1-5. Measured: 94.8 / 96.2 / 94.0 / 96.0 / 95.8 %, mean
    // 95.36 %, medians 0.36-0.56 px; over seeds 1-30 95.2 %. Before the bone-length prior was
    // anchored to the seed length (`length_anchor = 0`): 95.2 / 96.2 / 92.6 / 96.2 / 94.8 %,
    // mean 95.0 %, over seeds 1-30 94.8 %. Without searching hidden bones at their seen lengths
    // and counting a joint placed by its found child as seen, seed 1 gave 93.3 %.
    let mut sum = 0.0;
    for seed in 1..=5 {
        let ((median, pck5), _dir) = synth_run_with(
            Scenario::Squash,
            None,
            TrackOptions::new("", "").segment_len,
            seed,
        );
        assert!(median <= 0.7, "squash seed {seed}: median {median} px");
        assert!(pck5 >= 0.935, "squash seed {seed}: PCK@5 {pck5}");
        sum += pck5;
    }
    assert!(sum / 5.0 >= 0.952, "squash: mean PCK@5 {}", sum / 5.0);
}

/// A short bone of one flat colour (the shoe, ankle to toe, 17 px) matches anywhere along
/// itself, so nothing in the image stops it creeping shorter; its length prior is centred on its
/// seed length times the body's scale (`length_anchor`), not on the length it crept to.
#[test]
fn a_short_flat_bone_keeps_its_length() {
    let segment_len = TrackOptions::new("", "").segment_len;
    let (_, dir) = synth_run_with(Scenario::Fast, None, segment_len, 27);
    let (median, pck5) = joint_figures(&dir, "toe_r");
    // Measured: median 0.28 px, PCK@5 99.2 %. Centred on the predicted length
    // (`length_anchor = 0`): 5.1 px, 49.2 %, the toe up to 12 px short of the shoe's tip.
    assert!(median <= 1.0, "toe_r median {median} px");
    assert!(pck5 >= 0.95, "toe_r PCK@5 {pck5}");
}

/// A grey shoe on a grey floor (noisy seed 8): its colour is within the clip's noise threshold
/// of the floor's, so most of its seed pixels look like the plate. That is not a body the plate
/// holds (the rule for flies that rest while the plate is sampled): the bone's axis counts as
/// on the plate only by a tighter test, so the shoe's samples keep their weight and the plate
/// is trusted around it.
#[test]
fn a_shoe_the_colour_of_the_floor_is_tracked() {
    let segment_len = TrackOptions::new("", "").segment_len;
    let ((_, pck5), dir) = synth_run_with(Scenario::Noisy, None, segment_len, 8);
    let (median, toe_pck5) = joint_figures(&dir, "toe_r");
    // Measured: toe_r median 1.06 px, PCK@5 100 %; the clip 97.5 %. With the samples' own test
    // for the axis: toe_r 27.9 px, 10.0 % (scored `ok`), the clip 91.1 %.
    assert!(median <= 2.0, "toe_r median {median} px");
    assert!(toe_pck5 >= 0.95, "toe_r PCK@5 {toe_pck5}");
    assert!(pck5 >= 0.96, "PCK@5 {pck5}");
}

#[test]
fn noise_flicker_and_compression_are_tracked() {
    // Measured: median 0.35 px, PCK@5 97.6 % (target: >= 95 %, <= 1.5 px).
    assert_accuracy(Scenario::Noisy, 0.6, 0.95);
}

/// 900 frames of mixed actions with three turns: slow in a debug build, so release-only.
#[test]
#[ignore = "long clip: run with cargo test --release --test it accuracy:: -- --ignored"]
fn long_clip_with_turns_is_tracked() {
    // Default segments of 150: tracking goes on through uncorrected segment files (one
    // segment: 80.5 %).
    let ((median, pck5), _dir) = synth_run(Scenario::Long, None);
    // Measured: median 0.14 px, PCK@5 92.7 % (target: >= 85 %, <= 2.5 px); seeds 2-5:
    // 93.5, 94.7, 95.9, 95.2 %. 87.7 % without filling one joint's gaps while another stays
    // hidden (see gapfill). Earlier figures: docs/NOTES.md.
    assert!(pck5 >= 0.92, "PCK@5 {pck5}, median {median}");
    assert!(median <= 0.5, "median {median}");
}

/// `score`/`status` mean something: where the tracker is more than 10 px off, it says so (the
/// status is not `ok`) for most such joint-frames.
#[test]
fn far_misses_are_flagged() {
    let (_, dir) = synth_run(Scenario::Occlude, None);
    let gt = read_gt(&dir.path().join("gt.csv")).unwrap();
    let rows = read_tracks(&dir.path().join("run/tracks.csv")).unwrap();
    let truth: HashMap<(u64, &str), (f32, f32)> = gt
        .iter()
        .map(|g| ((g.frame, g.joint.as_str()), (g.x, g.y)))
        .collect();
    let (mut far, mut flagged) = (0, 0);
    for r in &rows {
        let (x, y) = truth[&(r.frame, r.joint.as_str())];
        if (r.x - x).hypot(r.y - y) > 10.0 {
            far += 1;
            if r.status != "ok" {
                flagged += 1;
            }
        }
    }
    println!("far misses: {far}, flagged: {flagged}");
    assert!(
        far > 0,
        "no far misses to judge; pick a harder clip for this test"
    );
    assert!(
        flagged as f32 >= 0.9 * far as f32,
        "{flagged} of {far} flagged"
    );
}

/// The real labelled clip (two flies, 1500 frames at 1024×1024): runs end to end and its error
/// is reported; the bound is what the tracker reaches today.
#[test]
fn flies_clip_runs_and_reports_its_error() {
    let shared = crate::common::shared("clips/flies");
    if !shared.join("clip.mp4").exists() {
        eprintln!(
            "note: {} is absent; the flies regression was not run",
            shared.display()
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let opts = TrackOptions {
        out: Some(dir.path().join("run")),
        ..TrackOptions::new(shared.join("clip.mp4"), shared.join("joints.toml"))
    };
    let s = track(&opts, &NoProgress).unwrap();
    assert_eq!(s.frames, 1500);
    let line = &eval(&dir.path().join("run"), &shared.join("gt.csv"), false).unwrap()[0];
    println!("flies: {line}");
    let (median, pck5) = parse_line(line);
    // Measured: median 0.67 px, PCK@5 73.8 %, PCK@10 76.9 %, counting the labelled points of
    // the joint the seed file lacks (female.midlegL4, hidden on frame 0) as misses. The history
    // of this figure is in docs/NOTES.md.
    assert!(pck5 >= 0.73, "PCK@5 {pck5}");
    assert!(median <= 1.0, "median {median}");

    // The correction workflow on real footage: the labels written into the segment files the
    // report names, then `resume` from the first. Earlier figures: docs/NOTES.md.
    let run = dir.path().join("run");
    assert_eq!(s.to_correct, vec![6, 7, 8, 9, 10], "report: {}", s.report);
    let gt: HashMap<(u64, String), (f32, f32)> = read_gt(&shared.join("gt.csv"))
        .unwrap()
        .into_iter()
        .filter(|g| g.x.is_finite() && g.y.is_finite())
        .map(|g| ((g.frame, g.joint), (g.x, g.y)))
        .collect();
    for &k in &s.to_correct {
        let p = file_path(&run, k);
        let (mut seeds, _) = read_seeds(&p).unwrap();
        for joint in &mut seeds.joints {
            if let Some(&(x, y)) = gt.get(&(seeds.frame, joint.name.clone())) {
                (joint.bbox.cx, joint.bbox.cy) = (x, y);
            }
        }
        std::fs::write(
            &p,
            to_toml(seeds.frame, &seeds.joints, "corrected to the labels"),
        )
        .unwrap();
    }
    let opts = ResumeOptions {
        run: run.clone(),
        segment: Some(s.to_correct[0]),
        ..Default::default()
    };
    resume(&opts, &NoProgress).unwrap();
    let line = &eval(&run, &shared.join("gt.csv"), false).unwrap()[0];
    println!("flies, flagged files corrected: {line}");
    let (_, corrected) = parse_line(line);
    assert!(corrected >= 0.80, "PCK@5 {pck5} -> {corrected}");
}

/// PCK@5 (0–1) over frames `from..` of the walk clip (640×360, seed 1) where the character
/// vanishes on frame 40 and reappears 160 px further across on frame 50 (its pixels moved onto
/// the clean background), tracked in memory with `params`; `key_ahead`: tracked as a pass
/// toward a key ([`mocap2d::track::Tracker::set_key_ahead`]).
fn walk_with_jump_pck5(params: mocap2d::track::TrackParams, from: usize, key_ahead: bool) -> f32 {
    use mocap2d::background::Background;
    use mocap2d::track::Tracker;
    let clip = synth_clip(Scenario::Walk, 640, 360, 1, None);
    let bgi = &clip.background;
    let dx: i64 = if clip.gt[50][0].0 < 320.0 { 160 } else { -160 };
    let mut frames = clip.frames.clone();
    let mut gt = clip.gt.clone();
    for f in 40..frames.len() {
        let mut moved = bgi.clone();
        if f >= 50 {
            for (x, y, px) in clip.frames[f].enumerate_pixels() {
                let b = bgi.get_pixel(x, y);
                let diff: i32 = (0..3).map(|c| (px[c] as i32 - b[c] as i32).abs()).sum();
                let tx = x as i64 + dx;
                if diff > 30 && (0..moved.width() as i64).contains(&tx) {
                    moved.put_pixel(tx as u32, y, *px);
                }
            }
            for g in &mut gt[f] {
                g.0 += dx as f32;
            }
        }
        frames[f] = moved;
    }
    let seeds = mocap2d::seed::parse_seeds(&clip.seeds_toml(), Path::new("seeds")).unwrap();
    let mut t = Tracker::new(
        params,
        &seeds,
        &frames[0],
        Some(Background::fit(std::slice::from_ref(bgi)).unwrap()),
    );
    t.set_key_ahead(key_ahead);
    let (mut hit, mut n) = (0, 0);
    for (f, frame) in frames.iter().enumerate().skip(1) {
        let est = t.step(frame);
        if f >= from {
            for (e, g) in est.iter().zip(&gt[f]) {
                n += 1;
                hit += usize::from((e.pos.x - g.0).hypot(e.pos.y - g.1) <= 5.0);
            }
        }
    }
    hit as f32 / n as f32
}

/// A body lost from sight that reappears far from where it was lost is looked for over the
/// whole frame and found again; without the whole-frame search it is not. A pass run toward a
/// key looks for it too, unless `redetect_toward_keys` is off.
#[test]
fn a_body_lost_for_a_while_is_found_again() {
    use mocap2d::track::TrackParams;
    let with = walk_with_jump_pck5(Default::default(), 75, false);
    let without = walk_with_jump_pck5(
        TrackParams {
            redetect_after: 0,
            ..Default::default()
        },
        75,
        false,
    );
    let toward_key = walk_with_jump_pck5(Default::default(), 75, true);
    let not_toward_keys = TrackParams {
        redetect_toward_keys: false,
        ..Default::default()
    };
    let off_toward_key = walk_with_jump_pck5(not_toward_keys.clone(), 75, true);
    let off_no_key = walk_with_jump_pck5(not_toward_keys, 75, false);
    println!(
        "PCK@5 after the jump: {with} with re-detection, {without} without, {toward_key} toward \
         a key; with redetect_toward_keys off {off_toward_key} toward a key, {off_no_key} with none"
    );
    // Measured: 87.8 % with, 0 % without (frames 75–119); 90.3 % with in the seventh session,
    // 89.2 % before the bone-length prior was anchored to the seed length.
    assert!(with >= 0.8, "with re-detection: PCK@5 {with}");
    assert!(without < 0.5, "without re-detection: PCK@5 {without}");
    assert_eq!(toward_key, with, "toward a key, by default");
    assert!(
        off_toward_key < 0.5,
        "toward a key, off: PCK@5 {off_toward_key}"
    );
    assert_eq!(off_no_key, with, "off, with no key ahead");
}

/// Two look-alike bodies (the walk character and a copy of it 160 px behind, seeded as two
/// skeletons): the first vanishes on frame 40 while its twin walks on. Its root coasts and the
/// whole-frame re-detection looks for it, but it must never be reported seen on top of the twin
/// (both skeletons on one body, both `ok`); the twin stays tracked.
#[test]
fn a_lost_body_is_not_found_again_on_its_look_alike() {
    use mocap2d::background::Background;
    use mocap2d::track::Tracker;
    let clip = synth_clip(Scenario::Walk, 640, 360, 1, Some(64));
    let bgi = &clip.background;
    let xs = clip.gt.iter().flatten().map(|g| g.0);
    let (lo, hi) = xs.fold((f32::MAX, f32::MIN), |(a, b), x| (a.min(x), b.max(x)));
    let dx: i64 = if lo > 170.0 { -160 } else { 160 };
    let shift = dx as f32;
    assert!(
        lo + shift > 10.0 && hi + shift < 630.0,
        "the twin leaves the frame"
    );
    let frames: Vec<_> = clip
        .frames
        .iter()
        .enumerate()
        .map(|(f, frame)| {
            let mut out = if f < 40 { frame.clone() } else { bgi.clone() };
            for (x, y, px) in frame.enumerate_pixels() {
                let b = bgi.get_pixel(x, y);
                let diff: i32 = (0..3).map(|c| (px[c] as i32 - b[c] as i32).abs()).sum();
                let tx = x as i64 + dx;
                if diff > 30 && (0..out.width() as i64).contains(&tx) {
                    out.put_pixel(tx as u32, y, *px);
                }
            }
            out
        })
        .collect();
    // The seed file twice: the twin's joints are named "twin.<name>" and moved by dx.
    let one = clip.seeds_toml();
    let (head, body) = one.split_at(one.find("[[joint]]").unwrap());
    let twin: String = body
        .lines()
        .map(|l| {
            if let Some(v) = l.strip_prefix("x = ") {
                format!("x = {:.3}\n", v.parse::<f32>().unwrap() + dx as f32)
            } else if let Some(n) = l.strip_prefix("name = \"") {
                format!("name = \"twin.{n}\n")
            } else if let Some(n) = l.strip_prefix("parent = \"") {
                format!("parent = \"twin.{n}\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let seeds =
        mocap2d::seed::parse_seeds(&format!("{head}{body}\n{twin}"), Path::new("seeds")).unwrap();
    let n = clip.joint_names.len();
    assert_eq!(seeds.joints.len(), 2 * n);
    let mut t = Tracker::new(
        Default::default(),
        &seeds,
        &frames[0],
        Some(Background::fit(std::slice::from_ref(bgi)).unwrap()),
    );
    let (mut on_twin, mut hit, mut total) = (0, 0, 0);
    for (f, frame) in frames.iter().enumerate().skip(1) {
        let est = t.step(frame);
        if f < 40 {
            continue;
        }
        let twin_root = (clip.gt[f][0].0 + dx as f32, clip.gt[f][0].1);
        let a = est[0];
        let d = (a.pos.x - twin_root.0).hypot(a.pos.y - twin_root.1);
        if a.status.seen() && d < 40.0 {
            on_twin += 1;
        }
        for (e, g) in est[n..].iter().zip(&clip.gt[f]) {
            total += 1;
            hit += usize::from((e.pos.x - g.0 - dx as f32).hypot(e.pos.y - g.1) <= 5.0);
        }
    }
    let twin_pck = hit as f32 / total as f32;
    println!("frames the lost body was seen on its twin: {on_twin}; twin PCK@5 {twin_pck}");
    assert_eq!(on_twin, 0, "the lost body was reported seen on its twin");
    assert!(twin_pck >= 0.9, "twin PCK@5 {twin_pck}");
}

/// The same clip tracked on one thread and on two gives byte-identical tracks.
#[test]
fn tracks_do_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    write_synth(dir.path(), Scenario::Occlude, 320, 240, 1, Some(60));
    let run = |threads: usize| {
        let out = dir.path().join(format!("run{threads}"));
        let opts = TrackOptions {
            out: Some(out.clone()),
            ..TrackOptions::new(dir.path().join("clip.mp4"), dir.path().join("joints.toml"))
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| track(&opts, &NoProgress)).unwrap();
        std::fs::read(out.join("tracks.csv")).unwrap()
    };
    assert!(
        run(1) == run(2),
        "tracks.csv differs between 1 and 2 threads"
    );
}

/// With no clean plate (`--no-background`, or a camera that moves), each limb's width on the
/// seed frame comes from its colour edges (docs/method.md §2.2): the walk is tracked about as
/// well as with its plate.
#[test]
fn walk_without_a_plate_is_tracked() {
    let dir = tempfile::tempdir().unwrap();
    write_synth(dir.path(), Scenario::Walk, 640, 360, 1, None);
    let opts = TrackOptions {
        background: mocap2d::background::BackgroundChoice::None,
        ..TrackOptions::new(dir.path().join("clip.mp4"), dir.path().join("joints.toml"))
    };
    let (line, (median, pck5)) = track_into_run(dir.path(), opts, "walk seed 1, no plate");
    // Measured: PCK@5 99.9 %, median 0.09 px (with its plate 100.0 %); before the edges were
    // used, 69.1 %.
    assert!(pck5 >= 0.99 && median <= 0.15, "{line}");
}

/// The walk filmed through an exposure that swings by ±15 % (period 150 frames; FFmpeg's `geq`,
/// highlights clip) around the plate's: the tracker's noise is measured with each sample of the
/// plate in its own light, so the swing is not taken for noise (docs/method.md §1).
#[test]
fn walk_through_a_brightness_swing_is_tracked() {
    let dir = tempfile::tempdir().unwrap();
    write_synth(dir.path(), Scenario::Walk, 640, 360, 1, None);
    let g = "clip(%c(X,Y)*(1+0.15*sin(2*PI*N/150)),0,255)";
    let swing = ["r", "g", "b"]
        .map(|c| format!("{c}='{}'", g.replace("%c", c)))
        .join(":");
    let o = std::process::Command::new("ffmpeg")
        .args(["-v", "error", "-y", "-i"])
        .arg(dir.path().join("clip.mp4"))
        .args([
            "-vf",
            &format!("geq={swing}"),
            "-c:v",
            "libx264",
            "-crf",
            "18",
        ])
        .args(["-pix_fmt", "yuv420p"])
        .arg(dir.path().join("swing.mp4"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let opts = TrackOptions::new(dir.path().join("swing.mp4"), dir.path().join("joints.toml"));
    let (line, (median, pck5)) = track_into_run(dir.path(), opts, "walk seed 1, a swing");
    // Measured: PCK@5 98.9 %, median 0.13 px; with the swing counted as the tracker's noise
    // (σ_n 38 levels against 3.4), 59.3 %.
    assert!(pck5 >= 0.985 && median <= 0.15, "{line}");
}
