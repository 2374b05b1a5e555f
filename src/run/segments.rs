//! Segments (docs/method.md §3): the clip is cut, from the seed frame on, into segments of
//! `segment_len` frames. Each segment's first frame gets `segments/NNN.toml`, a seed file
//! (`frame =` that first frame) holding the rectangles tracked there with each joint's `angle`,
//! `score` and `status`: tracking goes on through it as it was, unless the user corrects it,
//! and then restarts there from the corrected rectangles. The user corrects a segment by editing
//! its file; `segments/NNN.csv` holds the segment's rows of `tracks.csv` (the checkpoint).
//!
//! A file whose blake3 hash is not one the tool recorded in `run.toml` when it wrote it is a
//! correction: read as the user left it, never overwritten.

use crate::error::{Error, Result};
use crate::geom::{direction, unwrap_angle, JointBox, Point};
use crate::run::tracks::HEADER;
use crate::seed::{read_seeds, to_toml, SeedJoint, Seeds};
use crate::track::{JointEstimate, Status};
use std::path::{Path, PathBuf};

/// The folder of segment files in a run folder.
pub const SEGMENTS_DIR: &str = "segments";

/// Where segments start: every `len` frames from `seed_frame` on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Plan {
    /// The seed frame: segment 0's first frame.
    pub seed_frame: u64,
    /// Frames per segment (at least 1).
    pub len: u64,
}

impl Plan {
    /// First frame of segment `k`.
    pub fn first_frame(&self, k: u64) -> u64 {
        self.seed_frame.saturating_add(k.saturating_mul(self.len))
    }

    /// The segment holding `frame` (frames before the seed frame: segment 0).
    pub fn segment_of(&self, frame: u64) -> u64 {
        frame.saturating_sub(self.seed_frame) / self.len
    }

    /// The segment to resume from for a key on `frame`: the one before the segment holding it,
    /// whose last span the key pulls too (docs/method.md, "Keys across a segment's end").
    pub fn resume_for_key(&self, frame: u64) -> u64 {
        self.segment_of(frame).saturating_sub(1)
    }

    /// Number of segments of a clip of `frames` frames.
    pub fn count(&self, frames: u64) -> u64 {
        frames.saturating_sub(self.seed_frame).div_ceil(self.len)
    }
}

/// `run_dir/segments/NNN.toml`, the seed file of segment `k`.
pub fn file_path(run_dir: &Path, k: u64) -> PathBuf {
    run_dir.join(SEGMENTS_DIR).join(format!("{k:03}.toml"))
}

/// `run_dir/segments/NNN.state`, what tracking had learnt on reaching segment `k`
/// ([`crate::track::Tracker::learnt_state`]).
pub fn state_path(run_dir: &Path, k: u64) -> PathBuf {
    run_dir.join(SEGMENTS_DIR).join(format!("{k:03}.state"))
}

/// `run_dir/segments/NNN.csv`, the tracked rows of segment `k`.
pub fn rows_path(run_dir: &Path, k: u64) -> PathBuf {
    run_dir.join(SEGMENTS_DIR).join(format!("{k:03}.csv"))
}

/// blake3 (hex) of a file's bytes, as recorded in `run.toml`.
pub fn hash_bytes(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

/// blake3 of the file at `path`, `None` when it does not exist.
pub fn hash_file(path: &Path) -> Result<Option<String>> {
    match std::fs::read(path) {
        Ok(b) => Ok(Some(hash_bytes(&b))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(Error::io(path, e)),
    }
}

/// Direction (radians) that defines each joint's `angle` 0, as the tracker measures it: its
/// bone's, from the parent; a root's is the bone to its first child when `rotate_roots`, else
/// `None` (a root then keeps angle 0).
fn pose_dirs(seeds: &Seeds, rotate_roots: bool) -> Vec<Option<f32>> {
    let sk = &seeds.skeleton;
    let c: Vec<Point> = seeds.boxes().iter().map(|b| b.centre()).collect();
    (0..sk.len())
        .map(|j| match sk.parents[j] {
            Some(p) => Some(direction(c[p], c[j])),
            None if rotate_roots => sk.children(j).first().map(|&ch| direction(c[j], c[ch])),
            None => None,
        })
        .collect()
}

/// `a` (radians) plus the whole turns that bring it nearest `reference`: passes started on
/// different frames may count turns differently. Exact in `a` (only whole turns are added).
pub fn turns_near(reference: f32, a: f32) -> f32 {
    let tau = std::f32::consts::TAU;
    a + tau * ((reference - a) / tau).round()
}

/// A segment's starting point, read from its file.
#[derive(Debug, Clone)]
pub struct Start {
    /// The file as seeds (its `frame` is the segment's first frame).
    pub seeds: Seeds,
    /// The file's blake3.
    pub hash: String,
    /// Edited by the user: its rectangles are taken as given (status `seed`, score 1).
    pub corrected: bool,
    /// Each joint's angle on this frame from the run's seed pose (radians, unwrapped near the
    /// file's `angle`).
    pub angles: Vec<f32>,
    /// The row of `tracks.csv` on the first frame.
    pub row: Vec<JointEstimate>,
}

impl Start {
    /// Reads segment `k`'s file: it must be a seed file for `frame = first`, with the joints and
    /// parents of the run's seed file `base` (rectangle sizes may change), rectangles inside the
    /// `width × height` frame. `corrected` says whether it was edited by the user.
    #[allow(clippy::too_many_arguments)]
    pub fn read(
        path: &Path,
        first: u64,
        base: &Seeds,
        width: u32,
        height: u32,
        rotate_roots: bool,
        written: &[String],
    ) -> Result<Start> {
        let (seeds, text) = read_seeds(path)?;
        let err = |line: Option<usize>, joint: Option<&str>, msg: String| Error::Seed {
            path: path.to_owned(),
            line,
            joint: joint.map(str::to_owned),
            msg,
        };
        if seeds.frame != first {
            return Err(err(
                crate::seed::top_key_line(&text, "frame"),
                None,
                format!(
                    "frame = {}, but this segment starts on frame {first}; a segment file's \
                     frame cannot change: set it back to {first}",
                    seeds.frame
                ),
            ));
        }
        if seeds.joints.len() != base.joints.len() {
            return Err(err(
                None,
                None,
                format!(
                    "{} joints, but the run's seed file has {}; a segment file keeps every \
                     joint of the seed file, in its order",
                    seeds.joints.len(),
                    base.joints.len()
                ),
            ));
        }
        for (j, b) in seeds.joints.iter().zip(&base.joints) {
            if j.name != b.name || j.parent != b.parent {
                return Err(err(
                    Some(j.line),
                    Some(&j.name),
                    format!(
                        "expected joint {:?} (parent {}) here, as in the run's seed file; a \
                         segment file keeps every joint of the seed file, in its order, with its \
                         parent",
                        b.name,
                        b.parent.as_deref().unwrap_or("none")
                    ),
                ));
            }
        }
        seeds.check_against_clip(path, width, height, None)?;
        let hash = hash_bytes(text.as_bytes());
        let corrected = !written.contains(&hash);
        let d0 = pose_dirs(base, rotate_roots);
        let d = pose_dirs(&seeds, rotate_roots);
        let angles: Vec<f32> = seeds
            .joints
            .iter()
            .enumerate()
            .map(|(i, j)| match (d[i], d0[i]) {
                (Some(a), Some(a0)) => unwrap_angle(j.bbox.angle_rad, a - a0),
                _ => 0.0,
            })
            .collect();
        let row = seeds
            .joints
            .iter()
            .zip(&angles)
            .map(|(j, &angle_rad)| {
                let status = j.status.as_deref().and_then(Status::from_word);
                let (score, status) = match (corrected, status) {
                    (false, Some(s)) => (j.score.unwrap_or(1.0).clamp(0.0, 1.0), s),
                    _ => (1.0, Status::Seed),
                };
                JointEstimate {
                    pos: j.bbox.centre(),
                    angle_rad,
                    score,
                    status,
                }
            })
            .collect();
        Ok(Start {
            seeds,
            hash,
            corrected,
            angles,
            row,
        })
    }
}

impl Start {
    /// Counts each joint's turns as `reference` (radians, one per joint) does: for a corrected
    /// file, whose `angle` fields the user may have left as they were.
    pub fn align_turns(&mut self, reference: &[f32]) {
        for ((a, r), e) in self.angles.iter_mut().zip(reference).zip(&mut self.row) {
            *a = turns_near(*r, *a);
            e.angle_rad = *a;
        }
    }
}

/// Text of segment file `k` (on frame `first`; with `last`, the file after the last segment,
/// on the clip's last frame: a keyframe that closes the last segment) from the estimates on its first frame:
/// the run's seed joints (`base`: names, sizes, parents) at the estimated centres, each moved
/// just enough to keep its rectangle inside the `width × height` frame, with the estimated
/// `angle`, `score` and `status`. A comment header says how to correct it and which joints are
/// doubtful.
pub fn file_text(
    k: u64,
    first: u64,
    last: bool,
    base: &Seeds,
    est: &[JointEstimate],
    width: u32,
    height: u32,
) -> String {
    let joints: Vec<SeedJoint> = base
        .joints
        .iter()
        .zip(est)
        .map(|(b, e)| {
            let clampc = |v: f32, side: u32, size: u32| {
                let lo = side as f32 / 2.0 - 0.5;
                let hi = size as f32 - 0.5 - side as f32 / 2.0;
                if lo > hi {
                    v
                } else {
                    v.clamp(lo, hi)
                }
            };
            SeedJoint {
                name: b.name.clone(),
                bbox: JointBox {
                    cx: clampc(e.pos.x, b.bbox.w, width),
                    cy: clampc(e.pos.y, b.bbox.h, height),
                    w: b.bbox.w,
                    h: b.bbox.h,
                    angle_rad: e.angle_rad,
                },
                parent: b.parent.clone(),
                score: Some(e.score),
                status: Some(e.status.as_str().to_owned()),
                line: 0,
            }
        })
        .collect();
    let doubtful: Vec<String> = base
        .joints
        .iter()
        .zip(est)
        .filter(|(_, e)| !matches!(e.status, Status::Ok | Status::Seed))
        .map(|(b, e)| format!("{} ({}, score {:.2})", b.name, e.status.as_str(), e.score))
        .collect();
    let mut header = if last {
        format!(
            "frame {first}, the clip's last, written by mocap2d from the tracking. It closes \
             segment {}:\nif the end of the clip went wrong, correct it (move the wrong \
             rectangles) and run\n`mocap2d resume RUN --segment {}`, which then also tracks \
             that segment back from here.\n",
            k.saturating_sub(1),
            k.saturating_sub(1)
        )
    } else {
        format!(
            "segment {k}, from frame {first}: written by mocap2d from the tracking, which goes on \
             through here.\nTo correct it, move the wrong rectangles (x, y; w, h may change \
             too) and run\n`mocap2d resume RUN --segment {k}`: tracking restarts here from them. \
             "
        )
    };
    header.push_str(
        "An edited file is a correction: it is kept as you leave it, and every joint in it\nis \
         taken as right. Delete it to undo a correction.\n",
    );
    if doubtful.is_empty() {
        header.push_str("Every joint was seen here.\n");
    } else {
        header.push_str(&format!("Doubtful here: {}.\n", doubtful.join(", ")));
    }
    to_toml(first, &joints, &header)
}

/// Writes segment `k`'s rows (`tracks.csv` rows with its header) atomically.
pub fn write_rows(
    run_dir: &Path,
    k: u64,
    names: &[String],
    rows: &[(u64, Vec<JointEstimate>)],
) -> Result<()> {
    crate::atomic::write_with(&rows_path(run_dir, k), |w| {
        use std::io::Write;
        writeln!(w, "{HEADER}")?;
        for (frame, est) in rows {
            crate::run::tracks::write_rows(w, *frame, names, est)?;
        }
        Ok(())
    })
}

/// The angles (radians) on the last row of segment `k`'s rows, one per joint.
pub fn last_angles(run_dir: &Path, k: u64) -> Result<Vec<f32>> {
    let p = rows_path(run_dir, k);
    let rows = crate::run::tracks::read_tracks(&p)?;
    let last = rows.last().map_or(0, |r| r.frame);
    Ok(rows
        .iter()
        .filter(|r| r.frame == last)
        .map(|r| r.angle)
        .collect())
}

/// Joins the rows of segments `0..count` into `tracks.csv` (one header), atomically, copying
/// them through a buffer rather than holding them (a long clip's rows are tens of MB).
pub fn assemble_tracks(run_dir: &Path, count: u64) -> Result<()> {
    use std::io::{BufRead, Write};
    let out = run_dir.join("tracks.csv");
    // Every part is checked before anything is written (and opened again in turn below, so
    // that a clip of thousands of segments does not hold thousands of files open).
    let mut parts = Vec::with_capacity(count as usize);
    for k in 0..count {
        let p = rows_path(run_dir, k);
        std::fs::File::open(&p).map_err(|e| Error::RunFolder {
            path: p.clone(),
            msg: format!("cannot read the rows of segment {k} ({e}); run `mocap2d resume` again"),
        })?;
        parts.push(p);
    }
    crate::atomic::write_with(&out, |w| {
        writeln!(w, "{HEADER}")?;
        for p in &parts {
            let mut part = std::io::BufReader::new(std::fs::File::open(p)?);
            let mut header = Vec::new();
            part.read_until(b'\n', &mut header)?;
            std::io::copy(&mut part, w)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::parse_seeds;

    const BASE: &str = "frame = 0\n[[joint]]\nname = \"hip\"\nx = 50\ny = 50\nw = 11\nh = 11\n\
                        [[joint]]\nname = \"knee\"\nx = 60\ny = 50\nw = 11\nh = 11\nparent = \"hip\"\n";

    fn base() -> Seeds {
        parse_seeds(BASE, Path::new("seeds.toml")).unwrap()
    }

    fn est(x: f32, y: f32, angle_rad: f32, status: Status) -> JointEstimate {
        JointEstimate {
            pos: Point::new(x, y),
            angle_rad,
            score: 0.5,
            status,
        }
    }

    #[test]
    fn plan_cuts_from_the_seed_frame() {
        let p = Plan {
            seed_frame: 10,
            len: 30,
        };
        assert_eq!(p.first_frame(2), 70);
        assert_eq!(p.segment_of(69), 1);
        assert_eq!(p.segment_of(70), 2);
        assert_eq!([0, 69, 70, 71].map(|f| p.resume_for_key(f)), [0, 0, 1, 1]);
        assert_eq!(p.count(70), 2);
        assert_eq!(p.count(71), 3);
        assert_eq!(p.count(5), 0);
    }

    #[test]
    fn a_written_file_reads_back_with_its_fields_and_is_not_a_correction() {
        let dir = tempfile::tempdir().unwrap();
        let b = base();
        // The knee turned a quarter turn clockwise (down on screen): angle π/2 from the seed pose.
        let e = [
            est(50.0, 50.0, 0.0, Status::Ok),
            est(50.0, 60.0, std::f32::consts::FRAC_PI_2, Status::Low),
        ];
        let text = file_text(2, 60, false, &b, &e, 100, 100);
        assert!(
            text.contains("Doubtful here: knee (low, score 0.50)"),
            "{text}"
        );
        let p = dir.path().join("002.toml");
        std::fs::write(&p, &text).unwrap();
        let written = vec![hash_bytes(text.as_bytes())];
        let s = Start::read(&p, 60, &b, 100, 100, false, &written).unwrap();
        assert!(!s.corrected);
        assert_eq!(s.row[1].status, Status::Low);
        assert!((s.row[1].angle_rad - std::f32::consts::FRAC_PI_2).abs() < 1e-3);
        assert_eq!(s.row[1].pos, Point::new(50.0, 60.0));
        // Edited: a correction, taken as given.
        std::fs::write(&p, text.replace("y = 60.000", "y = 61.000")).unwrap();
        let s = Start::read(&p, 60, &b, 100, 100, false, &written).unwrap();
        assert!(s.corrected);
        assert_eq!(s.row[1].status, Status::Seed);
        assert_eq!(s.row[1].score, 1.0);
    }

    #[test]
    fn rectangles_are_kept_inside_the_frame() {
        let b = base();
        let e = [
            est(2.0, 50.0, 0.0, Status::Ok),
            est(50.0, 99.0, 0.0, Status::Ok),
        ];
        let s = parse_seeds(&file_text(1, 30, false, &b, &e, 100, 100), Path::new("x")).unwrap();
        assert_eq!(s.joints[0].bbox.cx, 5.0);
        assert_eq!(s.joints[1].bbox.cy, 94.0);
        s.check_against_clip(Path::new("x"), 100, 100, None)
            .unwrap();
    }

    #[test]
    fn a_moved_frame_or_joint_is_an_error_naming_the_fix() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("001.toml");
        std::fs::write(&p, BASE.replace("frame = 0", "frame = 31")).unwrap();
        let m = Start::read(&p, 30, &base(), 100, 100, false, &[])
            .unwrap_err()
            .to_string();
        assert!(
            m.contains("001.toml: line 1: frame = 31") && m.contains("set it back to 30"),
            "{m}"
        );
        std::fs::write(
            &p,
            BASE.replace("frame = 0", "frame = 30")
                .replace("\"knee\"", "\"ankle\""),
        )
        .unwrap();
        let m = Start::read(&p, 30, &base(), 100, 100, false, &[])
            .unwrap_err()
            .to_string();
        assert!(
            m.contains("joint \"ankle\"") && m.contains("expected joint \"knee\""),
            "{m}"
        );
    }
}
