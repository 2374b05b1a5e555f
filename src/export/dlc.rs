//! DeepLabCut CSV, as DeepLabCut writes its video predictions: three header rows (`scorer`,
//! `bodyparts`, `coords`), then one row a frame with the frame index and `x`, `y`, `likelihood`
//! for each joint (px, origin top-left, y down: DeepLabCut's image coordinates are ours).
//! `likelihood` is the tracker's `score`. Rows cover the run's tracked frames (from the seed
//! frame on). [`crate::seed::dlc::read_dlc_csv`] reads it back.

use super::Tracks;
use std::fmt::Write as _;

/// The scorer written in the first header row.
pub const SCORER: &str = "mocap2d";

/// The DeepLabCut CSV text for `tracks` (deterministic).
pub fn to_dlc_csv(tracks: &Tracks) -> String {
    let names = &tracks.skeleton.names;
    let mut s = String::from("scorer");
    for _ in names {
        s.push_str(&format!(",{SCORER}").repeat(3));
    }
    s.push_str("\nbodyparts");
    for n in names {
        let _ = write!(s, ",{n},{n},{n}");
    }
    s.push_str("\ncoords");
    s.push_str(&",x,y,likelihood".repeat(names.len()));
    s.push('\n');
    for (f, rows) in tracks.frames.iter().zip(&tracks.rows) {
        let _ = write!(s, "{f}");
        for r in rows {
            let _ = write!(s, ",{:.3},{:.3},{:.3}", r.x, r.y, r.score);
        }
        s.push('\n');
    }
    s
}
