//! A run folder as the review tools read it: manifest, seeds, tracks by frame, the segment files
//! (`segments/NNN.toml`, when the run has them) and per-segment flags, and the clip it was
//! tracked from.

use crate::error::{Error, Result};
use crate::run::{Manifest, TrackRow};
use crate::seed::{read_seeds, Seeds};
use std::path::{Path, PathBuf};

/// Folder of a run holding one seed-format file per segment, `NNN.toml`.
pub const SEGMENTS_DIR: &str = "segments";

/// One segment file.
#[derive(Debug, Clone)]
pub struct Segment {
    /// The number in its file name (`007.toml` → 7).
    pub number: u32,
    /// The file name's stem as written (`007`).
    pub id: String,
    pub path: PathBuf,
    pub seeds: Seeds,
}

/// How a span of frames went, from `tracks.csv`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Flags {
    pub frames: u64,
    /// Joint-frames per status.
    pub low: u64,
    pub occluded: u64,
    pub lost: u64,
    /// Lowest score of any joint on any frame of the span (1 when the span has no rows).
    pub min_score: f32,
}

impl Flags {
    /// True when any joint was anything but seen well.
    pub fn flagged(&self) -> bool {
        self.low + self.occluded + self.lost > 0
    }

    /// A short description such as "3 lost, 12 low" or "ok".
    pub fn describe(&self) -> String {
        let parts: Vec<String> = [
            (self.lost, "lost"),
            (self.occluded, "occluded"),
            (self.low, "low"),
        ]
        .iter()
        .filter(|(n, _)| *n > 0)
        .map(|(n, w)| format!("{n} {w}"))
        .collect();
        if parts.is_empty() {
            "ok".into()
        } else {
            parts.join(", ")
        }
    }
}

/// Everything the review tools need from a run folder.
#[derive(Debug, Clone)]
pub struct RunData {
    pub dir: PathBuf,
    pub manifest: Manifest,
    pub seeds: Seeds,
    /// First tracked frame; `frames[i]` holds the rows of frame `first + i`, in seed order.
    pub first: u64,
    pub frames: Vec<Vec<TrackRow>>,
    /// Segment files by number; empty when the run has no `segments/` folder.
    pub segments: Vec<Segment>,
}

impl RunData {
    /// Reads `run.toml`, `seeds.toml`, `tracks.csv` and `segments/*.toml` of `dir`.
    pub fn read(dir: &Path) -> Result<RunData> {
        if !dir.is_dir() {
            return Err(Error::RunFolder {
                path: dir.to_owned(),
                msg: "not a folder; give the run folder written by `mocap2d track`".into(),
            });
        }
        let manifest = Manifest::read(&dir.join("run.toml"))?;
        let (seeds, _) = read_seeds(&dir.join("seeds.toml"))?;
        let tracks = dir.join("tracks.csv");
        let rows = crate::run::tracks::read_tracks(&tracks)?;
        let first = rows.first().map_or(seeds.frame, |r| r.frame);
        let mut frames: Vec<Vec<TrackRow>> = Vec::new();
        for r in rows {
            let i = (r.frame - first) as usize;
            if r.frame < first || i > frames.len() {
                return Err(Error::RunFolder {
                    path: tracks,
                    msg: format!(
                        "frame {} is out of order; tracks.csv must list frames in order",
                        r.frame
                    ),
                });
            }
            if i == frames.len() {
                frames.push(Vec::new());
            }
            frames[i].push(r);
        }
        let segments = read_segments(dir)?;
        Ok(RunData {
            dir: dir.to_owned(),
            manifest,
            seeds,
            first,
            frames,
            segments,
        })
    }

    /// The rows of frame `f`, if it was tracked.
    pub fn rows(&self, f: u64) -> Option<&[TrackRow]> {
        f.checked_sub(self.first)
            .and_then(|i| self.frames.get(i as usize))
            .map(Vec::as_slice)
    }

    /// One past the last tracked frame.
    pub fn end(&self) -> u64 {
        self.first + self.frames.len() as u64
    }

    /// Frame range `[start, end)` of segment `k` (index into `segments`): from its `frame` to
    /// the next segment's, the last one to the end of the tracks.
    pub fn segment_range(&self, k: usize) -> (u64, u64) {
        let start = self.segments[k].seeds.frame;
        let end = self
            .segments
            .get(k + 1)
            .map_or(self.end(), |s| s.seeds.frame);
        (start, end.max(start))
    }

    /// Index of the segment frame `f` falls in, if any.
    pub fn segment_of(&self, f: u64) -> Option<usize> {
        (0..self.segments.len())
            .rev()
            .find(|&k| self.segments[k].seeds.frame <= f)
    }

    /// Flags of the frames `[start, end)`.
    pub fn flags(&self, start: u64, end: u64) -> Flags {
        let mut fl = Flags {
            min_score: 1.0,
            ..Flags::default()
        };
        for f in start..end {
            let Some(rows) = self.rows(f) else { continue };
            fl.frames += 1;
            for r in rows {
                match r.status.as_str() {
                    "low" => fl.low += 1,
                    "occluded" => fl.occluded += 1,
                    "lost" => fl.lost += 1,
                    _ => {}
                }
                fl.min_score = fl.min_score.min(r.score);
            }
        }
        fl
    }

    /// The clip the run was tracked from: `clip` when given, else the manifest's path as written
    /// (relative to the working directory), else that path or its file name beside the run
    /// folder; the first that exists with the manifest's size (a file) wins.
    pub fn clip(&self, clip: Option<&Path>) -> Result<PathBuf> {
        if let Some(c) = clip {
            if !c.exists() {
                return Err(Error::Clip {
                    path: c.to_owned(),
                    msg: "not found; give the clip the run was tracked from".into(),
                });
            }
            return Ok(c.to_owned());
        }
        let recorded = PathBuf::from(&self.manifest.clip.path);
        let beside = self.dir.parent().unwrap_or(Path::new("."));
        let mut candidates = vec![recorded.clone(), beside.join(&recorded)];
        if let Some(name) = recorded.file_name() {
            candidates.push(beside.join(name));
        }
        let fits = |p: &Path| {
            p.is_dir()
                || std::fs::metadata(p)
                    .is_ok_and(|m| m.is_file() && m.len() == self.manifest.clip.bytes)
        };
        candidates
            .into_iter()
            .find(|p| fits(p))
            .ok_or_else(|| Error::RunFolder {
                path: self.dir.join("run.toml"),
                msg: format!(
                "the clip {} the run was tracked from is not there (or has changed size); give \
                 it with --clip PATH",
                recorded.display()
            ),
            })
    }
}

/// True for a segment file name: digits, then `.toml`.
pub fn is_segment_name(name: &str) -> bool {
    name.strip_suffix(".toml")
        .is_some_and(|s| !s.is_empty() && s.len() <= 9 && s.bytes().all(|b| b.is_ascii_digit()))
}

/// Reads `dir/segments/NNN.toml`, in number order; none when there is no such folder.
pub fn read_segments(dir: &Path) -> Result<Vec<Segment>> {
    let sdir = dir.join(SEGMENTS_DIR);
    if !sdir.is_dir() {
        return Ok(Vec::new());
    }
    let mut out = Vec::new();
    for e in std::fs::read_dir(&sdir).map_err(|e| Error::io(&sdir, e))? {
        let e = e.map_err(|e| Error::io(&sdir, e))?;
        let name = e.file_name().to_string_lossy().into_owned();
        if !is_segment_name(&name) || !e.path().is_file() {
            continue;
        }
        let id = name.trim_end_matches(".toml").to_owned();
        let (seeds, _) = read_seeds(&e.path())?;
        out.push(Segment {
            number: id.parse().expect("digits"),
            id,
            path: e.path(),
            seeds,
        });
    }
    out.sort_by_key(|s| (s.number, s.id.clone()));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_names_are_digits() {
        assert!(is_segment_name("000.toml"));
        assert!(is_segment_name("12.toml"));
        assert!(!is_segment_name(".toml"));
        assert!(!is_segment_name("000.toml.prev"));
        assert!(!is_segment_name("a01.toml"));
        assert!(!is_segment_name("../000.toml"));
    }

    #[test]
    fn flags_describe_worst_first() {
        let f = Flags {
            frames: 3,
            low: 2,
            occluded: 0,
            lost: 1,
            min_score: 0.1,
        };
        assert!(f.flagged());
        assert_eq!(f.describe(), "1 lost, 2 low");
        assert_eq!(Flags::default().describe(), "ok");
    }
}
