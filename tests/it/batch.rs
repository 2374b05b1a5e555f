//! `mocap2d batch` end to end with the real binary on tiny synthetic clips (160x120, 30
//! frames; 300 for Ctrl-C): run folders, a failing clip among good ones, re-runs skipping
//! finished clips, output independent of --jobs, shards covering the batch once, and Ctrl-C
//! stopping the batch cleanly for a re-run to finish.
#![cfg(feature = "ffmpeg")]

use crate::common::{self, assert_exit, bin, folder_bytes as files, stdout, temp_files};
use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::Duration;

/// A temp dir holding `shots/cN.mp4` with `shots/cN.toml` seed files.
struct Shots {
    tmp: tempfile::TempDir,
}

impl Shots {
    /// `good` synthetic walks of 30 frames with their seed files, from different motion seeds.
    fn new(good: u64) -> Shots {
        Shots::with_frames(good, 30)
    }

    /// `good` synthetic walks of `frames` frames (160x120) with their seed files.
    fn with_frames(good: u64, frames: u32) -> Shots {
        let tmp = tempfile::tempdir().unwrap();
        let shots = tmp.path().join("shots");
        std::fs::create_dir(&shots).unwrap();
        let s = Shots { tmp };
        for i in 1..=good {
            let out = format!("synth{i}");
            let o = s.run(&[
                "synth",
                "walk",
                "--size",
                "160x120",
                "--frames",
                &frames.to_string(),
                "--seed",
                &i.to_string(),
                "--out",
                &out,
            ]);
            assert_exit(&o, 0);
            let from = s.path(&out);
            std::fs::rename(from.join("clip.mp4"), shots.join(format!("c{i}.mp4"))).unwrap();
            std::fs::rename(from.join("joints.toml"), shots.join(format!("c{i}.toml"))).unwrap();
        }
        s
    }

    fn path(&self, rel: &str) -> PathBuf {
        self.tmp.path().join(rel)
    }

    /// Runs `mocap2d ARGS -q` in the temp dir.
    fn run(&self, args: &[&str]) -> Output {
        bin()
            .args(args)
            .arg("-q")
            .current_dir(self.tmp.path())
            .output()
            .unwrap()
    }

    fn batch(&self, extra: &[&str]) -> Output {
        self.run(&batch_args(extra))
    }

    /// Starts `mocap2d batch ... EXTRA -q`, waits until `started()` says the work is under way
    /// (a file it writes appeared), sends SIGINT, and returns its output and how long it took
    /// to exit after the signal. `None` if it finished first.
    fn interrupt(&self, extra: &[&str], started: impl Fn() -> bool) -> Option<(Output, Duration)> {
        let mut cmd = bin();
        cmd.args(batch_args(extra))
            .arg("-q")
            .current_dir(self.tmp.path());
        common::interrupt(cmd, started)
    }

    /// [`Shots::interrupt`], which must happen: checks the batch exited with 130 within 5 s of
    /// the signal and did not panic, and returns its stderr.
    fn interrupted(&self, extra: &[&str], started: impl Fn() -> bool) -> String {
        let (o, took) = self
            .interrupt(extra, started)
            .expect("SIGINT while the batch was tracking");
        eprintln!("{extra:?}: exited {took:?} after SIGINT");
        assert_exit(&o, 130);
        assert!(
            took < Duration::from_secs(5),
            "exit took {took:?} after SIGINT"
        );
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(stdout(&o), "", "no table for an interrupted batch");
        err
    }
}

/// `batch shots --seeds {dir}/{stem}.toml EXTRA`.
fn batch_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["batch", "shots", "--seeds", "{dir}/{stem}.toml"];
    args.extend_from_slice(extra);
    args
}

/// Error lines (`mocap2d: ...`) on stderr.
fn error_lines(o: &Output) -> Vec<String> {
    String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| l.starts_with("mocap2d: "))
        .map(str::to_string)
        .collect()
}

/// The status column of the summary table's row for `clip`.
fn status(o: &Output, clip: &str) -> String {
    let out = stdout(o);
    let row = out
        .lines()
        .find(|l| l.starts_with(clip))
        .unwrap_or_else(|| panic!("no row for {clip} in\n{out}"));
    row.split_whitespace().last().unwrap().to_string()
}

#[test]
fn a_bad_clip_is_reported_and_the_others_go_on() {
    let s = Shots::new(2);
    // A "video" FFmpeg cannot read, with a good seed file: sorted between the good clips.
    std::fs::write(s.path("shots/c1b.mp4"), b"not a video at all").unwrap();
    std::fs::copy(s.path("shots/c1.toml"), s.path("shots/c1b.toml")).unwrap();
    let o = s.batch(&["--jobs", "2"]);
    assert_exit(&o, 2); // an undecodable clip is the user's to fix
    let errors = error_lines(&o);
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert!(
        errors[0].starts_with("mocap2d: shots/c1b.mp4: "),
        "{errors:?}"
    );
    for c in ["c1", "c2"] {
        let run = s.path(&format!("shots/{c}.mocap"));
        let tracks = std::fs::read_to_string(run.join("tracks.csv")).unwrap();
        assert_eq!(
            tracks.lines().count(),
            1 + 30 * 14,
            "{c}: header + 30 frames x 14 joints"
        );
        assert!(run.join("run.toml").is_file() && run.join("seeds.toml").is_file());
        assert_eq!(status(&o, &format!("shots/{c}.mp4")), "done");
    }
    assert!(
        !s.path("shots/c1b.mocap").exists(),
        "a failed clip leaves no run folder"
    );
    assert_eq!(status(&o, "shots/c1b.mp4"), "failed");
    // The table is sorted by clip, and the CSV says the same.
    let rows: Vec<String> = stdout(&o)
        .lines()
        .skip(1)
        .take(3)
        .map(String::from)
        .collect();
    assert!(rows[0].starts_with("shots/c1.mp4") && rows[1].starts_with("shots/c1b.mp4"));
    let csv = std::fs::read_to_string(s.path("batch-summary.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0],
        "clip,run,frames,frames_per_s,status,error,flagged_segments"
    );
    assert_eq!(lines.len(), 4, "{csv}");
    assert!(
        lines[2].starts_with("shots/c1b.mp4,shots/c1b.mocap,,,failed,"),
        "{csv}"
    );
    // A tracked clip's row ends with how many segments its report flags; a failed one's is empty.
    assert!(lines[2].ends_with(','), "{csv}");
    assert!(
        lines[3]
            .rsplit(',')
            .next()
            .unwrap()
            .parse::<usize>()
            .is_ok(),
        "{csv}"
    );
    assert!(
        lines[3].starts_with("shots/c2.mp4,shots/c2.mocap,30,"),
        "{csv}"
    );
    assert!(
        temp_files(&s.path("")).is_empty(),
        "{:?}",
        temp_files(&s.path(""))
    );
}

#[test]
fn a_rerun_skips_finished_clips_and_redoes_changed_ones() {
    let s = Shots::new(2);
    assert_exit(&s.batch(&["--jobs", "1"]), 0);
    let before = files(&s.path("shots/c1.mocap"));
    // Same inputs: nothing runs. An edited seed file (other bytes): tracked again.
    let seeds = s.path("shots/c2.toml");
    let text = std::fs::read_to_string(&seeds).unwrap();
    std::fs::write(&seeds, format!("# checked by hand\n{text}")).unwrap();
    let o = s.batch(&["--jobs", "1"]);
    assert_exit(&o, 0);
    assert_eq!(status(&o, "shots/c1.mp4"), "skipped");
    assert_eq!(status(&o, "shots/c2.mp4"), "done");
    assert_eq!(files(&s.path("shots/c1.mocap")), before);
    let seeds_in_run = std::fs::read(s.path("shots/c2.mocap/seeds.toml")).unwrap();
    assert_eq!(seeds_in_run, std::fs::read(&seeds).unwrap());
    // A run folder without its tracks is not finished.
    std::fs::remove_file(s.path("shots/c1.mocap/tracks.csv")).unwrap();
    let o = s.batch(&[]);
    assert_eq!(status(&o, "shots/c1.mp4"), "done");
    assert_eq!(status(&o, "shots/c2.mp4"), "skipped");
    assert_eq!(files(&s.path("shots/c1.mocap")), before);
}

#[test]
fn jobs_do_not_change_the_output_and_shards_split_the_batch() {
    let s = Shots::new(3);
    assert_exit(&s.batch(&["--jobs", "1", "--out-dir", "one"]), 0);
    assert_exit(&s.batch(&["--jobs", "2", "--out-dir", "two"]), 0);
    for c in ["c1", "c2", "c3"] {
        let run = |d: &str| files(&s.path(&format!("{d}/{c}.mocap")));
        assert_eq!(run("one"), run("two"), "{c}: --jobs 1 and --jobs 2 differ");
    }
    // Shards 1/2 and 2/2 track every clip once between them: c1, c3 and c2.
    let a = s.batch(&["--shard", "1/2", "--out-dir", "sharded"]);
    let b = s.batch(&["--shard", "2/2", "--out-dir", "sharded"]);
    assert_exit(&a, 0);
    assert_exit(&b, 0);
    assert_eq!(status(&a, "shots/c1.mp4"), "done");
    assert_eq!(status(&a, "shots/c3.mp4"), "done");
    assert_eq!(status(&b, "shots/c2.mp4"), "done");
    assert!(!stdout(&a).contains("c2.mp4") && !stdout(&b).contains("c1.mp4"));
    for c in ["c1", "c2", "c3"] {
        let run = |d: &str| files(&s.path(&format!("{d}/{c}.mocap")));
        assert_eq!(run("one"), run("sharded"), "{c}");
    }
    assert!(s.path("sharded/batch-summary-1of2.csv").is_file());
    assert!(s.path("sharded/batch-summary-2of2.csv").is_file());
}

#[test]
fn batch_wide_mistakes_stop_before_any_work() {
    let s = Shots::new(0);
    std::fs::write(s.path("shots/a.mp4"), b"x").unwrap();
    std::fs::write(s.path("shots/a.mov"), b"x").unwrap();
    let seeds = ["--seeds", "{stem}.toml"];
    for (args, says) in [
        (vec!["--shard", "0/4", "--out-dir", "o"], "counts from 1"),
        (vec!["--shard", "5/4", "--out-dir", "o"], "1/4 to 4/4"),
        (
            vec!["--out-dir", "o", "--seeds", "{stme}.toml"],
            "unknown placeholder {stme}",
        ),
        (seeds.to_vec(), "would both write the run folder"),
        (vec!["--render", "--seeds", "x"], "--retarget"),
    ] {
        let mut all = vec!["batch", "shots"];
        all.extend(args.iter().copied());
        if !all.contains(&"--seeds") {
            all.extend(seeds);
        }
        let o = s.run(&all);
        assert_exit(&o, 2);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(says), "{all:?}: {err}");
    }
    assert!(!s.path("shots/a.mocap").exists());
    assert!(!s.path("batch-summary.csv").exists());
}

/// `(complete, tracked_segments)` of a run folder's `run.toml`.
fn checkpoint(run: &Path) -> (bool, u64) {
    let m = mocap2d::run::Manifest::read(&run.join("run.toml")).unwrap();
    (m.complete, m.tracked_segments)
}

/// After a Ctrl-C: every run folder under `out` is finished (the same files as `whole`'s),
/// not started, or an unfinished checkpoint (no `tracks.csv`, the rows of every tracked
/// segment); returns how many are unfinished.
fn assert_consistent(out: &Path, whole: &Path) -> usize {
    assert!(temp_files(out).is_empty(), "{:?}", temp_files(out));
    let mut unfinished = 0;
    for c in ["c1", "c2", "c3"] {
        let run = out.join(format!("{c}.mocap"));
        if !run.exists() {
            continue;
        }
        match checkpoint(&run) {
            (true, _) => assert_eq!(files(&run), files(&whole.join(format!("{c}.mocap")))),
            (false, k) => {
                unfinished += 1;
                assert!(!run.join("tracks.csv").exists(), "{c}");
                for k in 0..k {
                    assert!(
                        run.join(format!("segments/{k:03}.csv")).is_file(),
                        "{c}: {k}"
                    );
                }
            }
        }
    }
    unfinished
}

#[test]
fn ctrl_c_stops_the_batch_cleanly_and_a_rerun_finishes_it() {
    // 300 frames: two segments of 150; the signal goes once a clip's first one is checkpointed.
    let s = Shots::with_frames(3, 300);
    assert_exit(&s.batch(&["--jobs", "2", "--out-dir", "whole"]), 0);
    let whole = s.path("whole");
    let same_as_whole = |out: &Path| {
        for c in ["c1", "c2", "c3"] {
            let run = format!("{c}.mocap");
            assert!(
                files(&out.join(&run)) == files(&whole.join(&run)),
                "{c}: differs from the uninterrupted batch's"
            );
        }
    };

    // One clip at a time, Ctrl-C in the second: the first is finished and intact, the second
    // keeps its checkpoint, the third never starts.
    let cut = s.path("cut");
    let c2_first = cut.join("c2.mocap/segments/000.csv");
    let err = s.interrupted(&["--jobs", "1", "--out-dir", "cut"], || c2_first.exists());
    assert!(
        err.contains(
            "mocap2d: batch interrupted: 1 of 3 clips done, stopped part-way: shots/c2.mp4, 1 \
             not started; no file was left half-written; run the same command again"
        ),
        "{err}"
    );
    assert!(!cut.join("batch-summary.csv").exists());
    assert_eq!(assert_consistent(&cut, &whole), 1);
    assert_eq!(checkpoint(&cut.join("c2.mocap")), (false, 1));
    assert!(!cut.join("c3.mocap").exists());
    // The re-run skips c1, resumes c2 from its checkpoint (segment 0's rows stay as they
    // were) and tracks c3: the run folders of the uninterrupted batch.
    let mtime = |p: &Path| std::fs::metadata(p).unwrap().modified().unwrap();
    let first_rows = mtime(&c2_first);
    let o = s.batch(&["--jobs", "1", "--out-dir", "cut"]);
    assert_exit(&o, 0);
    assert_eq!(status(&o, "shots/c1.mp4"), "skipped");
    assert_eq!(status(&o, "shots/c2.mp4"), "done");
    assert_eq!(status(&o, "shots/c3.mp4"), "done");
    assert_eq!(
        mtime(&c2_first),
        first_rows,
        "c2 was tracked again, not resumed"
    );
    same_as_whole(&cut);

    // Two at a time: both running clips stop at their next frame.
    let two = s.path("two");
    let c1_first = two.join("c1.mocap/segments/000.csv");
    let err = s.interrupted(&["--jobs", "2", "--out-dir", "two"], || c1_first.exists());
    assert!(err.contains("stopped part-way: shots/c1.mp4"), "{err}");
    assert!(assert_consistent(&two, &whole) >= 1);
    assert_exit(&s.batch(&["--jobs", "2", "--out-dir", "two"]), 0);
    same_as_whole(&two);
}
