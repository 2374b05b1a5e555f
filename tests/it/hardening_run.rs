//! The run folder under stress: missing or edited files, a folder of another clip, a read-only
//! or full disk (a small tmpfs, mounted when the test may: root in a container that allows it),
//! and a stale temp file from a crash. Every case gives a clear error (exit 2 when the user can
//! fix it, 1 otherwise) and leaves no half-written file and no temp file. Ctrl-C is in
//! `tests/it/signals.rs`.
#![cfg(feature = "ffmpeg")]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::common::*;

/// `track` of the sample clip into `out`, then `retarget` onto the robot.
fn tracked_and_retargeted(out: &Path) {
    assert_ok(&run(&[
        "track",
        s(&walk("clip.mp4")),
        "--seeds",
        s(&walk("joints.toml")),
        "--out",
        s(out),
    ]));
    assert_ok(&run(&["retarget", s(out), "--target", s(&robot())]));
}

/// A tmpfs of `size` mounted at `dir` (options `opts`, e.g. "ro"), unmounted on drop; `None`
/// when this process may not mount (not root, or a container that forbids it).
struct Tmpfs(PathBuf);

impl Tmpfs {
    fn mount(dir: &Path, opts: &str) -> Option<Tmpfs> {
        std::fs::create_dir_all(dir).unwrap();
        let ok = Command::new("mount")
            .args(["-t", "tmpfs", "-o", opts, "tmpfs", s(dir)])
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|st| st.success());
        if !ok {
            eprintln!(
                "SKIPPED: cannot mount a tmpfs at {} (needs root)",
                dir.display()
            );
        }
        ok.then(|| Tmpfs(dir.to_owned()))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

// ------------------------------------------------------------------- run folder

#[test]
fn missing_or_edited_run_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.mocap");
    tracked_and_retargeted(&good);
    let video = dir.path().join("robot.mp4");
    let anim = dir.path().join("walk.json");
    let commands = |run: &Path| -> Vec<Vec<String>> {
        let r = s(run).to_string();
        let t = s(&robot()).to_string();
        vec![
            vec!["retarget".into(), r.clone(), "--target".into(), t.clone()],
            vec![
                "render".into(),
                r.clone(),
                "--target".into(),
                t.clone(),
                "--out".into(),
                s(&video).into(),
            ],
            vec![
                "export".into(),
                r,
                "--format".into(),
                "json".into(),
                "--out".into(),
                s(&anim).into(),
            ],
        ]
    };
    let copy = |name: &str| -> PathBuf {
        let to = dir.path().join(name);
        std::fs::create_dir_all(to.join("retarget")).unwrap();
        for f in files(&good) {
            let rel = f.strip_prefix(&good).unwrap();
            std::fs::create_dir_all(to.join(rel).parent().unwrap()).unwrap();
            std::fs::copy(&f, to.join(rel)).unwrap();
        }
        to
    };
    // Each command's manifest missing, then edited into nonsense, then with its frame size
    // removed: `retarget` and `export` read run.toml, `render` reads retarget/retarget.toml.
    for (manifest, which) in [("run.toml", [0, 2]), ("retarget/retarget.toml", [1, 1])] {
        let name = manifest.replace('/', "_");
        let missing = copy(&format!("missing_{name}"));
        std::fs::remove_file(missing.join(manifest)).unwrap();
        let garbage = copy(&format!("garbage_{name}"));
        std::fs::write(garbage.join(manifest), "width = \"wide\"\n[[[\n").unwrap();
        let edited = copy(&format!("edited_{name}"));
        let text = std::fs::read_to_string(edited.join(manifest)).unwrap();
        let text: String = text
            .lines()
            .filter(|l| !l.starts_with("width"))
            .map(|l| format!("{l}\n"))
            .collect();
        std::fs::write(edited.join(manifest), text).unwrap();
        for run_dir in [&missing, &garbage, &edited] {
            for i in which {
                let args = &commands(run_dir)[i];
                let args: Vec<&str> = args.iter().map(String::as_str).collect();
                let o = run(&args);
                let file = manifest.rsplit('/').next().unwrap();
                assert_fails(&o, 2, &[file]);
                assert!(!video.exists() && !anim.exists(), "{args:?} wrote output");
            }
        }
    }
    // tracks.csv of another skeleton: refused, naming the file.
    let other = copy("other.mocap");
    std::fs::write(
        other.join("tracks.csv"),
        "frame,joint,x,y,angle,score,status\n0,tail,1,2,0,1,seed\n",
    )
    .unwrap();
    let o = run(&["retarget", s(&other), "--target", s(&robot())]);
    assert_fails(&o, 2, &["tracks.csv"]);
    // tracks.csv cut short mid-row.
    let cut = copy("cut.mocap");
    let t = std::fs::read(cut.join("tracks.csv")).unwrap();
    std::fs::write(cut.join("tracks.csv"), &t[..t.len() / 2]).unwrap();
    let o = run(&["retarget", s(&cut), "--target", s(&robot())]);
    assert_fails(&o, 2, &["tracks.csv"]);
    assert!(
        temp_files(dir.path()).is_empty(),
        "{:?}",
        temp_files(dir.path())
    );
}

/// `track --replace` into the run folder of another clip replaces every file: `run.toml` then
/// names the new clip and the tracks are the new clip's (the old retarget is refused as stale).
/// Without `--replace` it is refused: `tests/it/run_safety.rs`.
#[test]
fn track_into_the_folder_of_another_clip_replaces_it_whole() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run.mocap");
    tracked_and_retargeted(&out);
    // Another clip: the sample, mirrored left to right (a different content hash).
    let frames = dir.path().join("mirrored");
    std::fs::create_dir(&frames).unwrap();
    for (i, f) in mocap2d::decode::read_all(&walk("clip.mp4"), None)
        .unwrap()
        .iter()
        .enumerate()
        .take(20)
    {
        image::imageops::flip_horizontal(f)
            .save(frames.join(format!("f{i:03}.png")))
            .unwrap();
    }
    let seeds = mocap2d::seed::read_seeds(&walk("joints.toml")).unwrap().0;
    let mut mirrored = seeds.joints.clone();
    for j in &mut mirrored {
        j.bbox.cx = 319.0 - j.bbox.cx;
        j.bbox.angle_rad = -j.bbox.angle_rad;
    }
    let mseeds = dir.path().join("mirrored.toml");
    std::fs::write(&mseeds, mocap2d::seed::to_toml(seeds.frame, &mirrored, "")).unwrap();
    assert_ok(&run(&[
        "track",
        s(&frames),
        "--seeds",
        s(&mseeds),
        "--out",
        s(&out),
        "--replace",
    ]));
    let m = mocap2d::run::Manifest::read(&out.join("run.toml")).unwrap();
    assert_eq!(m.clip.path, s(&frames));
    assert_eq!(m.frames, 20);
    let rows = mocap2d::run::tracks::read_tracks(&out.join("tracks.csv")).unwrap();
    assert_eq!(rows.last().unwrap().frame, 19);
    let video = dir.path().join("v.mp4");
    let o = run(&[
        "render",
        s(&out),
        "--target",
        s(&robot()),
        "--out",
        s(&video),
    ]);
    assert_fails(&o, 2, &["retarget"]);
    assert!(!video.exists());
}

/// A crash leaves `NAME.tmp` files: the next write replaces them, and no reader takes one for
/// the real file.
#[test]
fn stale_temp_files_are_neither_an_obstacle_nor_mistaken_for_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run.mocap");
    std::fs::create_dir(&out).unwrap();
    for name in ["tracks.csv.tmp", "run.toml.tmp", "seeds.toml.tmp"] {
        std::fs::write(out.join(name), "half a file from a crash,").unwrap();
    }
    tracked_and_retargeted(&out);
    assert!(temp_files(&out).is_empty(), "{:?}", temp_files(&out));
    // Only the temp file of tracks.csv is left, as after a crash mid-write: it is not read.
    let tracks = std::fs::read(out.join("tracks.csv")).unwrap();
    std::fs::remove_file(out.join("tracks.csv")).unwrap();
    std::fs::write(out.join("tracks.csv.tmp"), &tracks).unwrap();
    let o = run(&["retarget", s(&out), "--target", s(&robot())]);
    assert_fails(&o, 2, &["tracks.csv"]);
    let json = dir.path().join("a.json");
    std::fs::write(crate_tmp(&json), "stale").unwrap();
    std::fs::rename(out.join("tracks.csv.tmp"), out.join("tracks.csv")).unwrap();
    assert_ok(&run(&[
        "export",
        s(&out),
        "--format",
        "json",
        "--out",
        s(&json),
    ]));
    assert!(!crate_tmp(&json).exists());
    assert!(std::fs::read_to_string(&json).unwrap().starts_with('{'));
}

/// Every file of `run` but `keys.toml` (relative path, bytes).
fn all_but_keys(run: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = folder_bytes(run);
    files.retain(|(name, _)| name != "keys.toml");
    files
}

/// `resume` refuses a keys.toml it cannot use (a key on a frame just past the clip, one far
/// past it, a joint the run lacks, broken TOML) and a `.lock` that is a symbolic link with exit
/// 2, naming the file, before it touches the folder: `tracks.csv` stays, so `review`, `retarget`
/// and the rest still read the run, and the file the link points to is left as it was.
#[test]
fn resume_refuses_bad_keys_and_a_linked_lock_before_touching_the_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run.mocap");
    tracked_and_retargeted(&out);
    let before = all_but_keys(&out);
    let keys = out.join("keys.toml");
    let resume = || run(&["resume", s(&out), "--segment", "0", "-q"]);
    // The sample clip has 60 frames (0 to 59).
    for (text, says) in [
        (
            "[[key]]\nframe = 70\npelvis = [100, 100]\n",
            "line 2: frame = 70",
        ),
        (
            "[[key]]\nframe = 60\npelvis = [100, 100]\n",
            "line 2: frame = 60",
        ),
        (
            "[[key]]\nframe = 600\npelvis = [100, 100]\n",
            "frame = 600, but",
        ),
        ("[[key]]\nframe = 10\nnose = [100, 100]\n", "joint \"nose\""),
        ("[[key]\nframe = 10\n", "line 1"),
    ] {
        std::fs::write(&keys, text).unwrap();
        let err = assert_fails(&resume(), 2, &["keys.toml", says]);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            all_but_keys(&out) == before,
            "the run folder changed: {err}"
        );
    }
    assert_ok(&run(&["retarget", s(&out), "--target", s(&robot())]));
    // A key past the end of a run whose clip's length is not yet known (a run stopped before
    // its end): refused as the clip ends, not a panic; the run resumes once the key is fixed.
    let manifest = std::fs::read_to_string(out.join("run.toml")).unwrap();
    let stopped = manifest
        .replace("frames = 60\n", "frames = 0\n")
        .replace("complete = true\n", "complete = false\n");
    assert_ne!(stopped, manifest);
    std::fs::write(out.join("run.toml"), &stopped).unwrap();
    std::fs::write(&keys, "[[key]]\nframe = 70\npelvis = [100, 100]\n").unwrap();
    assert_fails(
        &resume(),
        2,
        &["keys.toml", "line 2: frame = 70", "60 frames"],
    );
    std::fs::write(&keys, "[[key]]\nframe = 50\npelvis = [100, 100]\n").unwrap();
    assert_ok(&resume());
    assert!(out.join("tracks.csv").is_file());
    // A `.lock` linked to another file: refused, that file left as it was.
    let precious = dir.path().join("precious.txt");
    std::fs::write(&precious, "keep me\n").unwrap();
    std::os::unix::fs::symlink(&precious, out.join(".lock")).unwrap();
    let before = folder_bytes(&out);
    assert_fails(&resume(), 2, &[".lock", "symbolic link"]);
    assert_eq!(std::fs::read_to_string(&precious).unwrap(), "keep me\n");
    assert!(folder_bytes(&out) == before, "the run folder changed");
}

/// The temp name of `p` a crash of an earlier build left (`NAME.tmp`; writes now use
/// `NAME.<pid>.<n>.tmp`, which a write removes on failure and renames on success).
fn crate_tmp(p: &Path) -> PathBuf {
    let mut s = p.as_os_str().to_owned();
    s.push(".tmp");
    PathBuf::from(s)
}

#[test]
fn read_only_output_is_a_clear_error_with_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.mocap");
    tracked_and_retargeted(&good);
    let Some(ro) = Tmpfs::mount(&dir.path().join("ro"), "ro,size=1m") else {
        return;
    };
    let out = ro.0.join("run.mocap");
    let o = run(&[
        "track",
        s(&walk("clip.mp4")),
        "--seeds",
        s(&walk("joints.toml")),
        "--out",
        s(&out),
    ]);
    assert_fails(&o, 1, &[s(&out), "Read-only file system"]);
    let video = ro.0.join("robot.mp4");
    let o = run(&[
        "render",
        s(&good),
        "--target",
        s(&robot()),
        "--out",
        s(&video),
    ]);
    assert_fails(&o, 1, &["robot.mp4", "Read-only file system"]);
    let json = ro.0.join("a.json");
    let o = run(&["export", s(&good), "--format", "json", "--out", s(&json)]);
    assert_fails(&o, 1, &["a.json", "Read-only file system"]);
    assert!(files(&ro.0).is_empty());
}

/// A 24 KiB disk: too small for the tracks (about 40 KB) or the video. Each command fails naming
/// the file and "No space left", and leaves the disk as it found it.
#[test]
fn full_disk_is_a_clear_error_with_nothing_half_written() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.mocap");
    tracked_and_retargeted(&good);
    let Some(full) = Tmpfs::mount(&dir.path().join("full"), "size=24k") else {
        return;
    };
    let out = full.0.join("run.mocap");
    let o = run(&[
        "track",
        s(&walk("clip.mp4")),
        "--seeds",
        s(&walk("joints.toml")),
        "--out",
        s(&out),
    ]);
    assert_fails(&o, 1, &[".mocap", "No space left"]);
    assert!(files(&full.0).is_empty(), "{:?}", files(&full.0));
    let video = full.0.join("robot.mp4");
    let o = run(&[
        "render",
        s(&good),
        "--target",
        s(&robot()),
        "--out",
        s(&video),
        "--frames-dir",
        s(&full.0.join("frames")),
    ]);
    assert_fails(&o, 1, &["No space left"]);
    assert!(files(&full.0).is_empty(), "{:?}", files(&full.0));
    // A retarget into a run folder on the full disk: the old retarget stays whole.
    let small = full.0.join("small.mocap");
    std::fs::create_dir_all(&small).unwrap();
    for f in ["run.toml", "seeds.toml"] {
        std::fs::copy(good.join(f), small.join(f)).unwrap();
    }
    let tracks = std::fs::read(good.join("tracks.csv")).unwrap();
    let short: Vec<&str> = std::str::from_utf8(&tracks)
        .unwrap()
        .lines()
        .take(1 + 14 * 20)
        .collect();
    std::fs::write(small.join("tracks.csv"), short.join("\n") + "\n").unwrap();
    let before = files(&small);
    let o = run(&["retarget", s(&small), "--target", s(&robot())]);
    if o.status.code() != Some(0) {
        assert_fails(&o, 1, &["No space left"]);
        let after = files(&small);
        assert!(after
            .iter()
            .all(|p| before.contains(p) || p.is_file() && std::fs::metadata(p).unwrap().len() > 0));
    }
    assert!(temp_files(&full.0).is_empty(), "{:?}", temp_files(&full.0));
}
