//! `tracks.csv`: header `frame,joint,x,y,angle,score,status`.
//!
//! Columns: `frame` (0-based decoded index), `joint` (name from the seed file), `x`, `y`
//! (rectangle centre, px, 3 decimals; conventions in [`crate::geom`]), `angle` (rotation of the
//! rectangle from its seed pose, radians, 4 decimals), `score` (match confidence in [0, 1],
//! 3 decimals), `status` (see [`crate::track::Status`]: `seed`, `ok`, `low`, `occluded`, `lost`).

use crate::error::{Error, Result};
use crate::geom::Point;
use crate::track::{JointEstimate, Status};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The header line of `tracks.csv`.
pub const HEADER: &str = "frame,joint,x,y,angle,score,status";

/// One row of `tracks.csv`, as read back.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
pub struct TrackRow {
    pub frame: u64,
    pub joint: String,
    pub x: f32,
    pub y: f32,
    pub angle: f32,
    pub score: f32,
    pub status: String,
}

/// Streams rows into a temp file beside `path`; [`TracksWriter::finish`] renames it into place, so a crash
/// never leaves a partial `tracks.csv`.
pub struct TracksWriter {
    path: PathBuf,
    tmp: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
}

impl TracksWriter {
    /// Starts writing `path` (through its temp file).
    pub fn create(path: &Path) -> Result<Self> {
        let tmp = crate::atomic::temp_path(path);
        let file = std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        let mut out = std::io::BufWriter::with_capacity(1 << 16, file);
        writeln!(out, "{HEADER}").map_err(|e| Error::io(&tmp, e))?;
        Ok(TracksWriter {
            path: path.to_owned(),
            tmp,
            out,
        })
    }

    /// Appends the rows of one frame, joints in seed-file order.
    pub fn write_frame(
        &mut self,
        frame: u64,
        names: &[String],
        est: &[JointEstimate],
    ) -> Result<()> {
        write_rows(&mut self.out, frame, names, est).map_err(|err| Error::io(&self.tmp, err))
    }

    /// Flushes, syncs and renames the file into place. On failure (a full disk) the temp file is
    /// removed and the error names the real file.
    pub fn finish(self) -> Result<()> {
        let (tmp, path, out) = (self.tmp, self.path, self.out);
        let result = (|| {
            let file = out.into_inner().map_err(|e| e.into_error())?;
            file.sync_all()?;
            std::fs::rename(&tmp, &path)
        })();
        result.map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            Error::io(&path, e)
        })
    }
}

/// Writes the rows of one frame to `out`, joints in seed-file order, in the `tracks.csv` format.
pub fn write_rows(
    out: &mut impl Write,
    frame: u64,
    names: &[String],
    est: &[JointEstimate],
) -> std::io::Result<()> {
    for (name, e) in names.iter().zip(est) {
        writeln!(
            out,
            "{frame},{name},{:.3},{:.3},{:.4},{:.3},{}",
            e.pos.x,
            e.pos.y,
            e.angle_rad,
            e.score,
            e.status.as_str()
        )?;
    }
    Ok(())
}

/// Reads `tracks.csv` (see [`parse_tracks`]).
pub fn read_tracks(path: &Path) -> Result<Vec<TrackRow>> {
    let bytes = std::fs::read(path).map_err(|e| Error::RunFolder {
        path: path.to_owned(),
        msg: format!("cannot read tracks: {e}"),
    })?;
    parse_tracks(&bytes, path)
}

/// Reads `tracks.csv` a frame at a time, without holding the file: `f(frame, positions, scores,
/// statuses)` for each run of `joints` rows (one frame, seed-file order; an unknown status word
/// counts as `lost`). Errors as [`read_tracks`]'s.
pub fn for_each_frame(
    path: &Path,
    joints: usize,
    mut f: impl FnMut(u64, &[Point], &[f32], &[Status]),
) -> Result<()> {
    let file = std::fs::File::open(path).map_err(|e| Error::RunFolder {
        path: path.to_owned(),
        msg: format!("cannot read tracks: {e}"),
    })?;
    let joints = joints.max(1);
    let (mut pos, mut score, mut status) = (Vec::new(), Vec::new(), Vec::new());
    let mut frame = 0;
    for (i, r) in csv::Reader::from_reader(file)
        .deserialize::<TrackRow>()
        .enumerate()
    {
        let r = r.map_err(|e| row_error(path, i, e))?;
        if pos.is_empty() {
            frame = r.frame;
        }
        pos.push(Point::new(r.x, r.y));
        score.push(r.score);
        status.push(Status::from_word(&r.status).unwrap_or(Status::Lost));
        if pos.len() == joints {
            f(frame, &pos, &score, &status);
            pos.clear();
            score.clear();
            status.clear();
        }
    }
    if !pos.is_empty() {
        f(frame, &pos, &score, &status);
    }
    Ok(())
}

/// Row `i` (0-based, after the header) of `path` does not fit the columns: the error names its
/// line.
fn row_error(path: &Path, i: usize, e: csv::Error) -> Error {
    Error::RunFolder {
        path: path.to_owned(),
        msg: format!("line {}: {e}", i + 2),
    }
}

/// Parses the bytes of a `tracks.csv` (`path` for messages only); a row that does not fit the
/// columns is an [`Error::RunFolder`] naming its line.
pub fn parse_tracks(bytes: &[u8], path: &Path) -> Result<Vec<TrackRow>> {
    csv::Reader::from_reader(bytes)
        .deserialize()
        .enumerate()
        .map(|(i, r)| r.map_err(|e| row_error(path, i, e)))
        .collect()
}
