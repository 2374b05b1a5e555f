//! The `mocap2d` binary end to end on the bundled sample clip (`clips/walk`, 320×240 px, 60
//! frames, 14 joints): the run folder `track` writes, determinism, image-folder input, `eval`,
//! and the exit code and message of every user error. Each test works in a fresh temp dir.
//!
//! The sample clip is an mp4, so the file needs the `ffmpeg` feature (on by default).
#![cfg(feature = "ffmpeg")]

use crate::common::{assert_exit, bin, run_in, s, stderr, walk};
use std::path::{Path, PathBuf};
use std::process::Output;

/// Joints in clips/walk/joints.toml and frames in clips/walk/clip.mp4.
const JOINTS: usize = 14;
const FRAMES: usize = 60;

/// The status words `tracks.csv` may hold.
const STATUS_WORDS: &[&str] = &["seed", "ok", "low", "occluded", "lost"];

/// A fresh temp dir to run the binary in.
struct Dir {
    tmp: tempfile::TempDir,
}

impl Dir {
    fn new() -> Dir {
        Dir {
            tmp: tempfile::tempdir().unwrap(),
        }
    }

    fn path(&self, rel: &str) -> PathBuf {
        self.tmp.path().join(rel)
    }

    fn write(&self, rel: &str, text: &str) -> PathBuf {
        let p = self.path(rel);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// Runs `mocap2d ARGS` with the temp dir as working directory.
    fn run(&self, args: &[&str]) -> Output {
        run_in(self.tmp.path(), args)
    }

    /// Runs `mocap2d track` on the bundled sample into `out`, with `extra` arguments.
    fn track_walk(&self, out: &str, extra: &[&str]) -> Output {
        let (clip, seeds) = (walk("clip.mp4"), walk("joints.toml"));
        let mut args = vec!["track", s(&clip), "--seeds", s(&seeds), "--out", out];
        args.extend_from_slice(extra);
        self.run(&args)
    }

    /// Runs `mocap2d track CLIP --seeds SEEDS --out OUT`, asserting success.
    fn track_ok(&self, clip: &Path, seeds: &Path, out: &str, extra: &[&str]) -> PathBuf {
        let mut args = vec!["track", s(clip), "--seeds", s(seeds), "--out", out];
        args.extend_from_slice(extra);
        let o = self.run(&args);
        assert_exit(&o, 0);
        self.path(out)
    }
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The seed file of the sample with `from` replaced by `to` (which must occur).
fn edited_seeds(from: &str, to: &str) -> String {
    let text = read(&walk("joints.toml"));
    assert!(text.contains(from), "joints.toml has no {from:?}");
    text.replacen(from, to, 1)
}

/// The sample's seed file moved to frame `frame`: rectangles centred on the ground truth there.
fn seeds_on_frame(frame: u64) -> String {
    let gt = read(&walk("gt.csv"));
    let at = |joint: &str| -> (String, String) {
        let prefix = format!("{frame},{joint},");
        let line = gt.lines().find(|l| l.starts_with(&prefix)).unwrap();
        let v: Vec<&str> = line.split(',').collect();
        (v[2].to_owned(), v[3].to_owned())
    };
    let mut out = String::new();
    let mut xy = None;
    for line in read(&walk("joints.toml")).lines() {
        if let Some(n) = line.strip_prefix("name = ") {
            xy = Some(at(n.trim_matches('"')));
        }
        let line = match (line.split_once(" = "), &xy) {
            (Some(("frame", _)), _) => format!("frame = {frame}"),
            (Some(("x", _)), Some((x, _))) => format!("x = {x}"),
            (Some(("y", _)), Some((_, y))) => format!("y = {y}"),
            _ => line.to_owned(),
        };
        out.push_str(&line);
        out.push('\n');
    }
    out
}

/// Checks `tracks.csv`: header, one row per joint per frame from `first` to the last frame in
/// frame then seed-file order, a status word on every row, `seed` on frame `seed` only.
fn check_tracks(text: &str, first: usize, seed: usize) {
    let names: Vec<String> = read(&walk("joints.toml"))
        .lines()
        .filter_map(|l| {
            l.strip_prefix("name = ")
                .map(|n| n.trim_matches('"').to_owned())
        })
        .collect();
    assert_eq!(names.len(), JOINTS);
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("frame,joint,x,y,angle,score,status"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(
        rows.len(),
        JOINTS * (FRAMES - first),
        "rows = joints × frames from frame {first}"
    );
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r.len(), 7, "row {}: {r:?}", i + 2);
        assert_eq!(
            r[0].parse::<usize>().unwrap(),
            first + i / JOINTS,
            "row {}: {r:?}",
            i + 2
        );
        assert_eq!(r[1], names[i % JOINTS], "row {}: {r:?}", i + 2);
        for v in &r[2..6] {
            assert!(
                v.parse::<f32>().unwrap().is_finite(),
                "row {}: {r:?}",
                i + 2
            );
        }
        let score: f32 = r[5].parse().unwrap();
        assert!((0.0..=1.0).contains(&score), "row {}: {r:?}", i + 2);
        assert!(STATUS_WORDS.contains(&r[6]), "row {}: {r:?}", i + 2);
        assert_eq!(
            r[6] == "seed",
            first + i / JOINTS == seed,
            "`seed` marks the seed frame only; row {}: {r:?}",
            i + 2
        );
    }
}

#[test]
fn track_writes_tracks_manifest_and_seed_copy() {
    let d = Dir::new();
    let run = d.track_ok(&walk("clip.mp4"), &walk("joints.toml"), "walk.mocap", &[]);
    check_tracks(&read(&run.join("tracks.csv")), 0, 0);
    assert_eq!(
        read(&run.join("seeds.toml")),
        read(&walk("joints.toml")),
        "seeds.toml is a verbatim copy"
    );
    let manifest = read(&run.join("run.toml"));
    for line in [
        "width = 320",
        "height = 240",
        &format!("frames = {FRAMES}"),
        "seed_frame = 0",
        &format!("joints = {JOINTS}"),
        "[clip]",
        &format!("path = {:?}", s(&walk("clip.mp4"))),
        "[params]",
    ] {
        assert!(
            manifest.lines().any(|l| l == line),
            "run.toml has no line {line:?}:\n{manifest}"
        );
    }
    let mut names: Vec<_> = std::fs::read_dir(&run)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "report.md",
            "run.toml",
            "seeds.toml",
            "segments",
            "tracks.csv"
        ],
        "no temp files left behind"
    );
    // One segment (60 frames < 150): its seed file and its rows, which are tracks.csv's, and
    // the file on the clip's last frame.
    let mut segs: Vec<_> = std::fs::read_dir(run.join("segments"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    segs.sort();
    assert_eq!(segs, ["000.csv", "000.toml", "001.toml"]);
    assert!(read(&run.join("segments/001.toml")).contains(&format!("frame = {}", FRAMES - 1)));
    assert_eq!(
        read(&run.join("segments/000.csv")),
        read(&run.join("tracks.csv"))
    );
    assert!(manifest.lines().any(|l| l == "complete = true"));
}

/// Seeded on frame 30 of the 60-frame walk, `track` follows the joints backward from there to
/// frame 0 as well as forward: every frame has rows, `seed` only on frame 30, and the frames
/// before it are as near the truth as the frames after. A second run repeats the bytes, and
/// `resume --segment 0` too.
#[test]
fn frames_before_the_seed_frame_are_tracked_backward() {
    let d = Dir::new();
    let seeds = d.write("frame30.toml", &seeds_on_frame(30));
    let run = d.track_ok(&walk("clip.mp4"), &seeds, "walk.mocap", &[]);
    let text = read(&run.join("tracks.csv"));
    check_tracks(&text, 0, 30);
    assert!(read(&run.join("run.toml"))
        .lines()
        .any(|l| l == "seed_frame = 30"));
    // Measured: frames 0-29 PCK@5 100 %, mean error 0.28 px; frames 30-59 99.3 %, 0.33 px.
    let gt = read(&walk("gt.csv"));
    let truth: std::collections::HashMap<(u64, String), (f32, f32)> = gt
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            (
                (v[0].parse().unwrap(), v[1].to_owned()),
                (v[2].parse().unwrap(), v[3].parse().unwrap()),
            )
        })
        .collect();
    let (mut near, mut all, mut sum) = (0, 0, 0.0f32);
    for l in text.lines().skip(1) {
        let v: Vec<&str> = l.split(',').collect();
        let f: u64 = v[0].parse().unwrap();
        if f >= 30 {
            continue;
        }
        let (x, y): (f32, f32) = (v[2].parse().unwrap(), v[3].parse().unwrap());
        let (tx, ty) = truth[&(f, v[1].to_owned())];
        let e = ((x - tx).powi(2) + (y - ty).powi(2)).sqrt();
        near += (e <= 5.0) as usize;
        all += 1;
        sum += e;
    }
    assert_eq!(all, 30 * JOINTS);
    assert!(near as f32 >= 0.98 * all as f32, "PCK@5 {near}/{all}");
    assert!(
        sum / (all as f32) < 0.6,
        "mean error {} px",
        sum / all as f32
    );
    // The same bytes again: tracking from scratch, and resuming from segment 0.
    let again = d.track_ok(&walk("clip.mp4"), &seeds, "again.mocap", &[]);
    assert_eq!(read(&again.join("tracks.csv")), text);
    let o = d.run(&["resume", s(&run), "--segment", "0"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(read(&run.join("tracks.csv")), text);
}

#[test]
fn default_run_folder_is_beside_the_clip() {
    let d = Dir::new();
    std::fs::copy(walk("clip.mp4"), d.path("clip.mp4")).unwrap();
    let o = d.run(&["track", "clip.mp4", "--seeds", s(&walk("joints.toml"))]);
    assert_exit(&o, 0);
    assert!(d.path("clip.mocap/tracks.csv").is_file(), "{}", stderr(&o));
}

#[test]
fn two_runs_write_identical_files() {
    let d = Dir::new();
    let a = d.track_ok(&walk("clip.mp4"), &walk("joints.toml"), "a.mocap", &[]);
    let b = d.track_ok(&walk("clip.mp4"), &walk("joints.toml"), "b.mocap", &[]);
    for f in [
        "tracks.csv",
        "run.toml",
        "seeds.toml",
        "report.md",
        "segments/000.toml",
    ] {
        assert!(
            std::fs::read(a.join(f)).unwrap() == std::fs::read(b.join(f)).unwrap(),
            "{f} differs between runs"
        );
    }
}

/// Decodes the sample through the library and saves its frames as PNGs, so the folder holds the
/// very pixels the mp4 decodes to.
fn write_frames(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let mut source = mocap2d::decode::open(&walk("clip.mp4"), None).unwrap();
    let mut n = 0;
    while let Some(frame) = source.next_frame().unwrap() {
        n += 1;
        frame.save(dir.join(format!("frame{n:04}.png"))).unwrap();
    }
    assert_eq!(n, FRAMES);
}

#[test]
fn image_folder_tracks_like_the_video() {
    let d = Dir::new();
    write_frames(&d.path("frames"));
    // A shared clean plate: the temporal-median background samples different frames from a
    // video (keyframe seeks, or a strided decode) than from a folder, so it may differ.
    let plate = walk("background.png");
    let extra = ["--background", s(&plate)];
    let video = d.track_ok(
        &walk("clip.mp4"),
        &walk("joints.toml"),
        "video.mocap",
        &extra,
    );
    let folder = d.track_ok(
        &d.path("frames"),
        &walk("joints.toml"),
        "folder.mocap",
        &extra,
    );
    let (tv, tf) = (
        read(&video.join("tracks.csv")),
        read(&folder.join("tracks.csv")),
    );
    check_tracks(&tf, 0, 0);
    assert!(
        tv == tf,
        "tracks.csv differs between the mp4 and its frames as PNGs"
    );
}

#[test]
fn eval_prints_accuracy() {
    let d = Dir::new();
    let run = d.track_ok(&walk("clip.mp4"), &walk("joints.toml"), "walk.mocap", &[]);
    let o = d.run(&["eval", s(&run), "--gt", s(&walk("gt.csv"))]);
    assert_exit(&o, 0);
    let out = String::from_utf8(o.stdout.clone()).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    // The sample's ground truth says which joints are visible: all, seen and hidden ones apart.
    assert!(lines[0].starts_with("all joints: n=840 "), "{out}");
    assert!(lines[1].starts_with("visible joints: n="), "{out}");
    assert!(lines[2].starts_with("hidden joints: n="), "{out}");
    let n = |l: &str| -> usize {
        let rest = &l[l.find("n=").unwrap() + 2..];
        rest[..rest.find(' ').unwrap()].parse().unwrap()
    };
    assert_eq!(n(lines[1]) + n(lines[2]), 840, "{out}");
    assert!(n(lines[2]) > 0, "the sample has hidden joint-frames: {out}");
    let o = d.run(&["eval", s(&run), "--gt", s(&walk("gt.csv")), "--per-joint"]);
    assert_exit(&o, 0);
    let out = String::from_utf8(o.stdout.clone()).unwrap();
    assert_eq!(
        out.lines().filter(|l| l.contains("PCK@5")).count(),
        3 + JOINTS,
        "{out}"
    );
    // Piped into a reader that has gone (`| head -1`): a quiet success, not a panic.
    let mut child = bin()
        .args(["eval", s(&run), "--gt", s(&walk("gt.csv")), "--per-joint"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert_exit(&o, 0);
    assert!(stderr(&o).is_empty(), "stderr: {}", stderr(&o));
}

/// Seed rectangles large against `work_box_px` are tracked on halved frames: `track` says so,
/// and the tracks come out in the clip's pixels, as accurate (the sample's 15-px rectangles
/// with `work_box_px = 7`: tracked at 160x120; measured median 0.32 px, PCK@5 100 %, against
/// 0.11 px at full resolution).
#[test]
fn large_rectangles_are_tracked_halved_and_said() {
    let d = Dir::new();
    let params = d.write("params.toml", "work_box_px = 7.0\n");
    let o = d.track_walk("half.mocap", &["--params", s(&params)]);
    assert_exit(&o, 0);
    assert!(
        stderr(&o).contains("note: tracked at 160x120, the frames halved once"),
        "{}",
        stderr(&o)
    );
    let o = d.run(&["eval", "half.mocap", "--gt", s(&walk("gt.csv"))]);
    assert_exit(&o, 0);
    let out = String::from_utf8(o.stdout).unwrap();
    let all = out.lines().next().unwrap();
    let field = |k: &str| -> f32 {
        let rest = &all[all.find(k).unwrap() + k.len()..];
        rest[..rest
            .find(|c: char| c != '.' && !c.is_ascii_digit())
            .unwrap()]
            .parse()
            .unwrap()
    };
    assert!(field("median=") <= 0.6, "{all}");
    assert!(field("PCK@5=") >= 99.0, "{all}");
    // At the default the sample stays at full resolution, and nothing is said.
    let o = d.track_walk("full.mocap", &[]);
    assert_exit(&o, 0);
    assert!(!stderr(&o).contains("halved"), "{}", stderr(&o));
}

#[test]
fn params_file_is_recorded_and_checked() {
    let d = Dir::new();
    let params = d.write(
        "params.toml",
        "search_max_px = 40.0\nlost_after_frames = 12\n",
    );
    let run = d.track_ok(
        &walk("clip.mp4"),
        &walk("joints.toml"),
        "walk.mocap",
        &["--params", s(&params)],
    );
    let manifest = read(&run.join("run.toml"));
    let unset = format!(
        "search_min_px = {:?}",
        mocap2d::track::TrackParams::default().search_min_px
    );
    for line in ["search_max_px = 40.0", "lost_after_frames = 12", &unset] {
        assert!(
            manifest.lines().any(|l| l == line),
            "run.toml has no line {line:?}:\n{manifest}"
        );
    }
    // A parameter file track refuses: one message naming the file and what is wrong in it, and
    // no run folder left behind.
    let refused = |name: &str, text: &str, needles: &[&str]| {
        let file = d.write(name, text);
        let out = format!("{name}.mocap");
        let o = d.track_walk(&out, &["--params", s(&file)]);
        assert_user_error(&o, needles);
        assert!(!d.path(&out).exists());
    };
    refused(
        "bad.toml",
        "search_max = 40.0\n",
        &["bad.toml", "search_max"],
    );
    refused(
        "range.toml",
        "length_anchor = 1.5\n",
        &["range.toml", "length_anchor = 1.5", "from 0"],
    );
    refused(
        "box.toml",
        "work_box_px = -4.0\n",
        &[
            "box.toml",
            "work_box_px = -4",
            "0 tracks at full resolution",
        ],
    );
}

/// Exit code 2 and one message on stderr, `mocap2d: ...`, holding every string of `needles`.
/// FFmpeg's own log lines (`[mov,mp4,...] ...`) are not counted.
fn assert_user_error(o: &Output, needles: &[&str]) {
    assert_exit(o, 2);
    let err = stderr(o);
    let lines: Vec<&str> = err.lines().filter(|l| !l.starts_with('[')).collect();
    assert_eq!(lines.len(), 1, "one message expected:\n{err}");
    assert!(lines[0].starts_with("mocap2d: "), "{err}");
    for n in needles {
        assert!(lines[0].contains(n), "message lacks {n:?}:\n{err}");
    }
    assert!(
        o.stdout.is_empty(),
        "stdout: {}",
        String::from_utf8_lossy(&o.stdout)
    );
}

#[test]
fn bad_clips_exit_2_without_a_run_folder() {
    let d = Dir::new();
    d.write("x.mp4", "not a video\n");
    std::fs::create_dir(d.path("empty")).unwrap();
    d.write("empty/notes.txt", "no frames here\n");
    let seeds = walk("joints.toml");
    for clip in ["missing.mp4", "x.mp4", "empty"] {
        let o = d.run(&["track", clip, "--seeds", s(&seeds), "--out", "out.mocap"]);
        assert_user_error(&o, &[&format!("mocap2d: {clip}: ")]);
        assert!(!d.path("out.mocap").exists(), "{clip}: run folder written");
        assert!(!d
            .path(&format!("{}.mocap", clip.trim_end_matches(".mp4")))
            .exists());
    }
}

#[test]
fn seed_errors_exit_2_naming_file_line_and_joint() {
    let d = Dir::new();
    let cycle = "name = \"pelvis\"\nx = 211.330\ny = 154.781\nw = 15\nh = 15\n";
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "unknown_key",
            edited_seeds("w = 15\n", "colour = 3\nw = 15\n"),
            vec!["line 9", "\"pelvis\"", "colour"],
        ),
        (
            "missing_field",
            edited_seeds("y = 119.872\n", ""),
            vec!["line 12", "\"chest\"", "missing `y`"],
        ),
        (
            "duplicate_name",
            edited_seeds("name = \"neck\"", "name = \"chest\""),
            vec!["line 21", "\"chest\"", "line 12"],
        ),
        (
            "unknown_parent",
            edited_seeds("parent = \"elbow_l\"", "parent = \"elbow_x\""),
            vec!["\"wrist_l\"", "\"elbow_x\"", "did you mean \"elbow_l\""],
        ),
        (
            "parent_cycle",
            edited_seeds(cycle, &format!("{cycle}parent = \"chest\"\n")),
            vec!["\"pelvis\"", "cycle"],
        ),
        (
            "too_small",
            edited_seeds("w = 15", "w = 4"),
            vec!["line 9", "\"pelvis\"", "at least 5"],
        ),
        (
            "outside",
            edited_seeds("x = 211.330", "x = 318.0"),
            vec!["line 5", "\"pelvis\"", "inside"],
        ),
        (
            "beyond_clip",
            edited_seeds("frame = 0", "frame = 100000"),
            vec!["100000", "60 frames"],
        ),
        (
            "no_joints",
            "# nothing to track\nframe = 0\n".to_owned(),
            vec!["no joints"],
        ),
        (
            "bad_toml",
            edited_seeds("w = 15", "w = = 15"),
            vec!["line 9", "TOML"],
        ),
    ];
    for (name, text, needles) in &cases {
        let file = format!("{name}.toml");
        d.write(&file, text);
        let o = d.run(&[
            "track",
            s(&walk("clip.mp4")),
            "--seeds",
            &file,
            "--out",
            "out.mocap",
        ]);
        let mut all = vec![&*file];
        all.extend(needles);
        assert_user_error(&o, &all);
        assert!(
            stderr(&o).starts_with(&format!("mocap2d: {file}: ")),
            "{name}: {}",
            stderr(&o)
        );
        assert!(!d.path("out.mocap").exists(), "{name}: run folder written");
    }
    let o = d.run(&[
        "track",
        s(&walk("clip.mp4")),
        "--seeds",
        "nowhere.toml",
        "--out",
        "out.mocap",
    ]);
    assert_user_error(&o, &["nowhere.toml", "not found"]);
    assert!(!d.path("out.mocap").exists());
}

#[test]
fn bad_flags_exit_2() {
    let d = Dir::new();
    assert_exit(&d.run(&["track", s(&walk("clip.mp4"))]), 2);
    assert_exit(
        &d.run(&["synth", "walk", "--out", "x", "--size", "321x240"]),
        2,
    );
    assert_exit(&d.run(&["frobnicate"]), 2);
    assert!(
        std::fs::read_dir(d.tmp.path()).unwrap().next().is_none(),
        "nothing written"
    );
}

#[test]
fn damage_mid_clip_keeps_the_frames_before_it() {
    let d = Dir::new();
    write_frames(&d.path("frames"));
    // Frame 30 keeps a valid PNG header (the folder opens fine) but loses its pixel data, so
    // decoding fails there, after tracking has begun: frames 0..29 are tracked, with a warning
    // naming the file, and run.toml records where decoding stopped.
    let f30 = d.path("frames/frame0030.png");
    let bytes = std::fs::read(&f30).unwrap();
    std::fs::write(&f30, &bytes[..100]).unwrap();
    let plate = walk("background.png");
    let o = d.run(&[
        "track",
        s(&d.path("frames")),
        "--seeds",
        s(&walk("joints.toml")),
        "--out",
        "broken.mocap",
        "--background",
        s(&plate),
    ]);
    assert_exit(&o, 0);
    let err = stderr(&o);
    assert!(
        err.contains("warning")
            && err.contains("frame0030.png")
            && err.contains("stopped at frame 29"),
        "{err}"
    );
    let m = mocap2d::run::Manifest::read(&d.path("broken.mocap/run.toml")).unwrap();
    assert_eq!(m.frames, 29);
    assert_eq!(m.decode_stop.map(|s| s.frame), Some(29));
}

/// The skeleton's root is the user's choice and tracking does not depend on it: the walk
/// rooted at the left wrist (a label file's order may root it anywhere) is tracked as well as
/// rooted at the pelvis, every joint-frame within 5 px of where the pelvis-rooted run puts
/// it. Measured: both 100 % PCK@5; rooted at the wrist before the tracker centred each body,
/// 91.5 %.
#[test]
fn the_root_of_the_skeleton_does_not_change_the_tracking() {
    let d = Dir::new();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/it/data");
    let pelvis = d.track_ok(&walk("clip.mp4"), &walk("joints.toml"), "pelvis.mocap", &[]);
    let wrist = d.track_ok(
        &walk("clip.mp4"),
        &data.join("walk-rooted-at-wrist.toml"),
        "wrist.mocap",
        &[],
    );
    let rows = |run: &Path| -> std::collections::HashMap<(String, String), (f32, f32)> {
        read(&run.join("tracks.csv"))
            .lines()
            .skip(1)
            .map(|l| {
                let v: Vec<&str> = l.split(',').collect();
                (
                    (v[0].to_owned(), v[1].to_owned()),
                    (v[2].parse().unwrap(), v[3].parse().unwrap()),
                )
            })
            .collect()
    };
    let (a, b) = (rows(&pelvis), rows(&wrist));
    assert_eq!(a.len(), FRAMES * JOINTS);
    assert_eq!(b.len(), a.len());
    let far: Vec<_> = a
        .iter()
        .filter(|(k, p)| {
            let q = b[*k];
            (p.0 - q.0).hypot(p.1 - q.1) > 5.0
        })
        .map(|(k, _)| k.clone())
        .collect();
    assert!(far.is_empty(), "{} joint-frames apart: {far:?}", far.len());
    for run in [&pelvis, &wrist] {
        let o = d.run(&["eval", s(run), "--gt", s(&walk("gt.csv"))]);
        let out = String::from_utf8(o.stdout).unwrap();
        assert!(
            out.lines().next().unwrap().contains("PCK@5=100.0%"),
            "{out}"
        );
    }
}

/// `report.md` names frames worth keying: on the walk sample (one segment flagged), at most ten
/// distinct frames of the clip, none on the seed frame (already keyed).
#[test]
fn the_report_names_frames_worth_keying() {
    let d = Dir::new();
    let run = d.track_ok(&walk("clip.mp4"), &walk("joints.toml"), "walk.mocap", &[]);
    let frames = |report: &str| -> Vec<usize> {
        let line = report
            .lines()
            .find(|l| l.starts_with("Frames worth keying next"))
            .unwrap_or_else(|| panic!("no suggestions in:\n{report}"));
        let list = line.split(": ").nth(1).unwrap().split('.').next().unwrap();
        let frames: Vec<usize> = list.split(", ").map(|f| f.parse().unwrap()).collect();
        let mut sorted = frames.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), frames.len(), "{line}");
        assert!(frames.iter().all(|&f| f > 0 && f < FRAMES), "{line}");
        frames
    };
    let ten = frames(&read(&run.join("report.md")));
    assert!(!ten.is_empty() && ten.len() <= 10, "{ten:?}");
    // `report --keys K` names the K keyed together (printed, report.md left as it was).
    let o = d.run(&["report", s(&run), "--keys", "3"]);
    assert_exit(&o, 0);
    let three = frames(&String::from_utf8_lossy(&o.stdout));
    assert_eq!(three.len(), 3, "{three:?}");
    assert_eq!(frames(&read(&run.join("report.md"))), ten);
    let o = d.run(&["report", s(&run), "--keys", "0"]);
    assert_exit(&o, 2);
    assert!(String::from_utf8_lossy(&o.stderr).contains("--keys"));
}
