//! Run-folder safety: smaller defects, each tried as a user would: paths that are not UTF-8, a batch
//! over a run holding an unapplied edit, a truncated MKV, `track --out` into another clip's run
//! folder, a seed file with too many joints, a degenerate character, `resume` looking for the
//! clip beside the run folder, and error messages that name the right line once.
#![cfg(feature = "ffmpeg")]

use std::ffi::OsString;
use std::os::unix::ffi::OsStringExt;
use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common::*;

/// `dir/NAME` with a byte 0xff in NAME (not UTF-8).
fn not_utf8(dir: &Path, before: &str, after: &str) -> PathBuf {
    let mut name = before.as_bytes().to_vec();
    name.push(0xff);
    name.extend_from_slice(after.as_bytes());
    dir.join(OsString::from_vec(name))
}

fn run_os(args: &[&std::ffi::OsStr]) -> Output {
    bin().args(args).output().unwrap()
}

#[test]
fn paths_that_are_not_utf8_are_refused_without_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let clip = not_utf8(dir.path(), "bad", "name.mp4");
    std::fs::copy(walk("clip.mp4"), &clip).unwrap();
    let seeds = walk("joints.toml");
    let o = run_os(&[
        "track".as_ref(),
        clip.as_os_str(),
        "--seeds".as_ref(),
        seeds.as_os_str(),
        "-q".as_ref(),
    ]);
    assert_fails(&o, 2, &["not valid UTF-8", "rename"]);
    assert_eq!(files(dir.path()), vec![clip.clone()], "nothing written");

    let run_dir = dir.path().join("r.mocap");
    assert_ok(&run(&[
        "track",
        s(&walk("clip.mp4")),
        "--seeds",
        s(&seeds),
        "--out",
        s(&run_dir),
        "-q",
    ]));
    let o = run_os(&[
        "review".as_ref(),
        run_dir.as_os_str(),
        "--clip".as_ref(),
        clip.as_os_str(),
        "-q".as_ref(),
    ]);
    assert_fails(&o, 2, &["not valid UTF-8"]);

    assert_ok(&run(&["retarget", s(&run_dir), "--target", s(&robot())]));
    let video = not_utf8(dir.path(), "o", ".mp4");
    let o = run_os(&[
        "render".as_ref(),
        run_dir.as_os_str(),
        "--target".as_ref(),
        robot().as_os_str(),
        "--out".as_ref(),
        video.as_os_str(),
        "-q".as_ref(),
    ]);
    assert_fails(&o, 2, &["not valid UTF-8"]);
    assert!(!video.exists());
    assert!(
        temp_files(dir.path()).is_empty(),
        "{:?}",
        temp_files(dir.path())
    );
}

/// The sample clip re-encoded as MKV (which states a duration, not a frame count) at `path`.
fn sample_as_mkv(path: &Path) {
    let frames = mocap2d::decode::read_all(&walk("clip.mp4"), None).unwrap();
    let mut w = mocap2d::encode::VideoWriter::create(path, 320, 240, 30.0, 18).unwrap();
    for f in &frames {
        w.write(f).unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn a_truncated_mkv_is_tracked_with_a_decode_stop_and_a_whole_one_without() {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole.mkv");
    sample_as_mkv(&whole);
    let bytes = std::fs::read(&whole).unwrap();
    let half = dir.path().join("half.mkv");
    std::fs::write(&half, &bytes[..bytes.len() / 2]).unwrap();
    let track = |clip: &Path| {
        let out = clip.with_extension("mocap");
        let o = run(&[
            "track",
            s(clip),
            "--seeds",
            s(&walk("joints.toml")),
            "--out",
            s(&out),
            "-q",
        ]);
        assert_ok(&o);
        let m = mocap2d::run::Manifest::read(&out.join("run.toml")).unwrap();
        (stderr(&o), m)
    };
    let (err, m) = track(&whole);
    assert!(!err.contains("warning"), "{err}");
    assert_eq!((m.frames, m.decode_stop), (60, None));
    let (err, m) = track(&half);
    let stop = m.decode_stop.expect("a decode_stop in run.toml");
    assert!(stop.frame < 50 && stop.frame == m.frames, "{stop:?}");
    assert!(stop.reason.contains("about 60 frames"), "{stop:?}");
    assert!(
        err.contains("warning: the clip is damaged or cut short") && err.contains("about 60"),
        "{err}"
    );
}

/// Moves joint `joint`'s rectangle in the segment file at `path` by `dx` px (a user's edit).
fn edit_segment(path: &Path, joint: &str, dx: f32) -> f32 {
    let (seeds, text) = mocap2d::seed::read_seeds(path).unwrap();
    let mut joints = seeds.joints.clone();
    let j = joints.iter_mut().find(|j| j.name == joint).unwrap();
    j.bbox.cx += dx;
    let x = j.bbox.cx;
    let comment: String = text
        .lines()
        .take_while(|l| l.starts_with('#'))
        .map(|l| l.trim_start_matches('#').trim_start())
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(path, mocap2d::seed::to_toml(seeds.frame, &joints, &comment)).unwrap();
    x
}

/// A batch re-run over a finished run whose segment file the user edited applies the edit
/// (resumes the run) instead of reporting it `skipped`.
#[test]
fn a_batch_resumes_a_run_with_an_unapplied_edit_instead_of_skipping_it() {
    let dir = tempfile::tempdir().unwrap();
    let shots = dir.path().join("shots");
    std::fs::create_dir(&shots).unwrap();
    write_synth(
        dir.path(),
        mocap2d::synth::Scenario::Walk,
        160,
        120,
        1,
        Some(30),
    );
    std::fs::rename(dir.path().join("clip.mp4"), shots.join("c1.mp4")).unwrap();
    std::fs::rename(dir.path().join("joints.toml"), shots.join("c1.toml")).unwrap();
    let batch = || {
        let o = bin()
            .args(["batch", "shots", "--seeds", "{dir}/{stem}.toml", "-q"])
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert_ok(&o);
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    // The status column of the clip's row in the table.
    let status = |table: String| -> String {
        let row = table.lines().find(|l| l.starts_with("shots/c1.mp4"));
        row.and_then(|l| l.split_whitespace().last())
            .unwrap_or_else(|| panic!("{table}"))
            .to_owned()
    };
    assert_eq!(status(batch()), "done");
    let run_dir = shots.join("c1.mocap");
    assert_eq!(status(batch()), "skipped", "nothing changed");
    // The user moves the head on the clip's last frame (segment file 001).
    let x = edit_segment(&run_dir.join("segments/001.toml"), "head", 6.0);
    assert_eq!(status(batch()), "done", "the edit is applied, not skipped");
    let rows = mocap2d::run::tracks::read_tracks(&run_dir.join("tracks.csv")).unwrap();
    let head = rows.iter().rfind(|r| r.joint == "head").unwrap();
    assert_eq!((head.frame, head.status.as_str()), (29, "seed"));
    assert!((head.x - x).abs() < 0.01, "{} vs {x}", head.x);
    assert_eq!(status(batch()), "skipped", "applied: nothing left to do");
}

/// `track --out` into the run folder of another clip is refused (exit 2, naming the clip it
/// holds) and changes nothing; with `--replace` it is replaced, and the replaced run's
/// tracks, run.toml and seed file are kept together in history/.
#[test]
fn track_into_another_clips_run_folder_is_refused_unless_replace() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run.mocap");
    let seeds = walk("joints.toml");
    assert_ok(&run(&[
        "track",
        s(&walk("clip.mp4")),
        "--seeds",
        s(&seeds),
        "--out",
        s(&out),
        "-q",
    ]));
    let before: Vec<(PathBuf, Vec<u8>)> = files(&out)
        .into_iter()
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    // Another clip: the sample re-encoded (other bytes, same frame size and seeds).
    let other = dir.path().join("other.mkv");
    sample_as_mkv(&other);
    let args = |replace: bool| {
        let mut a = vec![
            "track",
            s(&other),
            "--seeds",
            s(&seeds),
            "--out",
            s(&out),
            "-q",
        ];
        if replace {
            a.push("--replace");
        }
        a
    };
    let o = run(&args(false));
    assert_fails(
        &o,
        2,
        &["run.toml", "another clip", "clip.mp4", "--replace"],
    );
    let after: Vec<(PathBuf, Vec<u8>)> = files(&out)
        .into_iter()
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    assert!(before == after, "the refused track changed the folder");

    assert_ok(&run(&args(true)));
    let m = mocap2d::run::Manifest::read(&out.join("run.toml")).unwrap();
    assert_eq!(m.clip.path, s(&other));
    let old = mocap2d::run::Manifest::read(&out.join("history/001-run.toml")).unwrap();
    assert_eq!(old.clip.path, s(&walk("clip.mp4")));
    let old_tracks = before.iter().find(|f| f.0.ends_with("tracks.csv")).unwrap();
    assert_eq!(
        std::fs::read(out.join("history/001-tracks.csv")).unwrap(),
        old_tracks.1
    );
    assert_eq!(
        std::fs::read(out.join("history/001-seeds.toml")).unwrap(),
        std::fs::read(&seeds).unwrap()
    );
    // The same clip again needs no --replace.
    assert_ok(&run(&args(false)));
}

/// A seed file of `n` joints on the sample's frame, each a 9 px square, chained by parents.
fn many_joints(n: usize) -> String {
    let mut t = String::from("frame = 0\n");
    for i in 0..n {
        let (x, y) = (10 + (i * 13) % 300, 10 + ((i * 13) / 300 * 11) % 220);
        t += &format!("\n[[joint]]\nname = \"j{i}\"\nx = {x}\ny = {y}\nw = 9\nh = 9\n");
        if i > 0 {
            t += &format!("parent = \"j{}\"\n", i - 1);
        }
    }
    t
}

/// 10,000 joints (tracking would never finish) are refused at once, naming the first joint
/// over the limit by its line; a file at the limit reads.
#[test]
fn a_seed_file_over_the_joint_limit_is_refused_naming_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let seeds = dir.path().join("many.toml");
    let text = many_joints(10_000);
    std::fs::write(&seeds, &text).unwrap();
    let line = 1 + text
        .lines()
        .enumerate()
        .filter(|(_, l)| *l == "[[joint]]")
        .nth(mocap2d::seed::MAX_JOINTS)
        .unwrap()
        .0;
    // Refused by the parser (before the binary, whose tracking would not end if it were not).
    assert!(mocap2d::seed::read_seeds(&seeds).is_err());
    let out = dir.path().join("r.mocap");
    let t = std::time::Instant::now();
    let o = run(&[
        "track",
        s(&walk("clip.mp4")),
        "--seeds",
        s(&seeds),
        "--out",
        s(&out),
    ]);
    assert_fails(
        &o,
        2,
        &[
            &format!("many.toml: line {line}: "),
            "10000 joints",
            "limit of 256",
        ],
    );
    assert!(t.elapsed() < std::time::Duration::from_secs(10));
    assert!(!out.exists());
    std::fs::write(&seeds, many_joints(mocap2d::seed::MAX_JOINTS)).unwrap();
    let (s256, _) = mocap2d::seed::read_seeds(&seeds).unwrap();
    assert_eq!(s256.joints.len(), 256);
}

/// The robot character in `dir` with `edit` applied to its text (the image copied beside it).
fn robot_with(dir: &Path, name: &str, edit: impl Fn(&str) -> String) -> PathBuf {
    std::fs::copy(robot().with_file_name("robot.png"), dir.join("robot.png")).unwrap();
    let text = std::fs::read_to_string(robot()).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, edit(&text)).unwrap();
    p
}

/// A character with a zero-length bone, or with every joint on one point, is refused by
/// `retarget` and `render` (exit 2) naming the joint and its line; nothing is written.
#[test]
fn a_character_with_a_zero_length_bone_is_refused_naming_the_joint() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r.mocap");
    assert_ok(&run(&[
        "track",
        s(&walk("clip.mp4")),
        "--seeds",
        s(&walk("joints.toml")),
        "--out",
        s(&out),
        "-q",
    ]));
    // The neck placed on the chest (x = 168.8, y = 118.0).
    let on_parent = robot_with(dir.path(), "neck.toml", |t| {
        t.replace("x = 169.2\ny = 90.0\n", "x = 168.8\ny = 118.0\n")
    });
    let neck_line = 1 + std::fs::read_to_string(&on_parent)
        .unwrap()
        .lines()
        .position(|l| l == "name = \"neck\"")
        .unwrap()
        - 1;
    // Every joint on the pelvis.
    let one_point = robot_with(dir.path(), "point.toml", |t| {
        t.lines()
            .map(|l| match l {
                l if l.starts_with("x = ") => "x = 173.8".to_owned(),
                l if l.starts_with("y = ") => "y = 229.9".to_owned(),
                l => l.to_owned(),
            })
            .collect::<Vec<_>>()
            .join("\n")
    });
    let video = dir.path().join("v.mp4");
    for (character, joint, line) in [
        (&on_parent, "\"neck\"", Some(neck_line)),
        (&one_point, "\"chest\"", None),
    ] {
        let o = run(&["retarget", s(&out), "--target", s(character)]);
        let mut parts = vec![joint, "0.00 px long", "move this joint"];
        let at = line.map(|l| format!("line {l}: "));
        if let Some(at) = &at {
            parts.push(at);
        }
        assert_fails(&o, 2, &parts);
        assert!(!out.join("retarget").exists(), "nothing written");
        let o = run(&[
            "render",
            s(&out),
            "--target",
            s(character),
            "--out",
            s(&video),
        ]);
        assert_fails(&o, 2, &parts);
        assert!(!video.exists());
    }
}

/// `resume` finds the clip beside the run folder, as `review` does, when both moved together.
#[test]
fn resume_finds_the_clip_beside_a_moved_run_folder() {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path().join("work");
    std::fs::create_dir(&work).unwrap();
    std::fs::copy(walk("clip.mp4"), work.join("clip.mp4")).unwrap();
    let o = bin()
        .args([
            "track",
            "clip.mp4",
            "--seeds",
            s(&walk("joints.toml")),
            "-q",
        ])
        .args(["--segment-len", "20"])
        .current_dir(&work)
        .output()
        .unwrap();
    assert_ok(&o);
    let moved = dir.path().join("moved");
    std::fs::rename(&work, &moved).unwrap();
    // From another working directory, without --clip.
    let o = bin()
        .args([
            "resume",
            s(&moved.join("clip.mocap")),
            "--segment",
            "1",
            "-q",
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_ok(&o);
    assert!(moved.join("clip.mocap/history/001-tracks.csv").is_file());
}

/// A changed `frame` in a segment file is reported at its own line (the file starts with
/// comments), and an I/O error's cause is not printed twice.
#[test]
fn messages_name_the_frame_line_and_say_an_os_error_once() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r.mocap");
    let track = |out: &Path| {
        run(&[
            "track",
            s(&walk("clip.mp4")),
            "--seeds",
            s(&walk("joints.toml")),
            "--out",
            s(out),
            "--segment-len",
            "20",
            "-q",
        ])
    };
    assert_ok(&track(&out));
    let seg = out.join("segments/001.toml");
    let text = std::fs::read_to_string(&seg).unwrap();
    let line = 1 + text.lines().position(|l| l == "frame = 20").unwrap();
    assert!(line > 1, "{text}");
    std::fs::write(&seg, text.replace("frame = 20", "frame = 21")).unwrap();
    let o = run(&["resume", s(&out), "-q"]);
    assert_fails(
        &o,
        2,
        &[
            &format!("001.toml: line {line}: frame = 21"),
            "set it back to 20",
        ],
    );

    let file = dir.path().join("file.txt");
    std::fs::write(&file, "not a folder").unwrap();
    let o = track(&file.join("r.mocap"));
    let err = assert_fails(&o, 1, &["file.txt", "os error"]);
    assert_eq!(err.matches("os error").count(), 1, "{err}");
    assert!(!err.contains("caused by"), "{err}");
}
