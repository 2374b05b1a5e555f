//! Seed files: where each joint's rectangle sits on one frame, and who its parent is.
//!
//! The format (TOML), as the user writes it:
//! ```toml
//! frame = 0                # frame the rectangles are placed on (default 0)
//! [[joint]]
//! name = "pelvis"          # unique; letters, digits, _ . -
//! x = 312.0                # rectangle centre in px; origin top-left, y down
//! y = 240.5
//! w = 21                   # rectangle width and height in whole px, >= 5
//! h = 21
//! # parent = "chest"       # omitted for a root; a bone runs parent -> child
//! ```
//! Optional per-joint keys, written by the tool in segment files: `angle` (radians, the
//! rectangle's rotation from its seed pose, clockwise on screen), `score` (0 to 1) and `status`.
//! Parents may be listed after their children; several roots are allowed.
//!
//! [`parse_seeds`] checks the file on its own and stops at the first problem with one
//! [`Error::Seed`] naming the file, line, joint and field, and the fix.
//! [`Seeds::check_against_clip`] then checks it against the clip (rectangles inside the frame,
//! seed frame within the clip). [`to_toml`] writes the same format back.

pub mod dlc;
pub mod dlc_csv;
mod hints;
mod joint;
mod parse;

use hints::line_of_offset;
use parse::Parser;

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{Error, Result};
use crate::geom::JointBox;
use crate::skeleton::Skeleton;

/// Smallest rectangle side (px) a joint can be tracked with.
pub const MIN_BOX_PX: u32 = 5;

/// The 1-based line of the top-level key `key` (`key = ...` before any table) in a seed file's
/// `text`, if it is there.
pub fn top_key_line(text: &str, key: &str) -> Option<usize> {
    for (i, l) in text.lines().enumerate() {
        let l = l.trim_start();
        if l.starts_with('[') {
            return None;
        }
        if l.strip_prefix(key)
            .is_some_and(|rest| rest.trim_start().starts_with('='))
        {
            return Some(i + 1);
        }
    }
    None
}

/// Most joints a seed file may hold. Tracking costs more than linearly in joints (on the
/// 320×240 sample's 60 frames: 100 joints 0.6 s, 200 joints 2.0 s, 256 joints 4.6 s, 400 joints
/// 44 s), so many more would never finish.
pub const MAX_JOINTS: usize = 256;

/// The message for a seed file (or DeepLabCut table) of `n` joints, over [`MAX_JOINTS`].
pub fn too_many_joints(n: usize) -> String {
    format!(
        "{n} joints, over the limit of {MAX_JOINTS} (tracking time grows faster than the \
         number of joints); track fewer joints, or the subjects in separate runs"
    )
}

/// Keys allowed at the top level of a seed file.
pub const TOP_KEYS: &[&str] = &["frame", "joint"];

/// Keys allowed in a `[[joint]]` table.
pub const JOINT_KEYS: &[&str] = &[
    "name", "x", "y", "w", "h", "parent", "angle", "score", "status",
];

/// Keys every `[[joint]]` table must have.
pub const REQUIRED_JOINT_KEYS: &[&str] = &["name", "x", "y", "w", "h"];

/// One `[[joint]]` table of a seed file.
#[derive(Debug, Clone, PartialEq)]
pub struct SeedJoint {
    /// Unique joint name.
    pub name: String,
    /// The rectangle: centre and size (px), `angle_rad` from `angle` (0 when absent).
    pub bbox: JointBox,
    /// Name of the parent joint, `None` for a root.
    pub parent: Option<String>,
    /// Tracking score in `[0, 1]`, when the file has one (segment files).
    pub score: Option<f32>,
    /// Tracking status, when the file has one (segment files).
    pub status: Option<String>,
    /// 1-based line of the joint's `[[joint]]` header in the file it was read from.
    pub line: usize,
}

/// A parsed, structurally valid seed file.
#[derive(Debug, Clone, PartialEq)]
pub struct Seeds {
    /// The 0-based frame the rectangles are placed on.
    pub frame: u64,
    /// Joints in seed-file order.
    pub joints: Vec<SeedJoint>,
    /// Names and parent links of `joints`, same indices; always a forest.
    pub skeleton: Skeleton,
}

impl Seeds {
    /// The joints' rectangles, in seed-file order.
    pub fn boxes(&self) -> Vec<JointBox> {
        self.joints.iter().map(|j| j.bbox).collect()
    }

    /// What to tell the user of joints placed on top of their parent: closer to it than a quarter
    /// of their rectangle's smaller side, a bone too short to show where the joint is (the dance's
    /// seed file puts the left ankle 4 px from the knee, and the ankle then follows the knee,
    /// called `ok`). Empty when there are none.
    pub fn crowding_note(&self) -> String {
        let boxes = self.boxes();
        let crowded: Vec<String> = (0..self.joints.len())
            .filter_map(|j| {
                let p = self.skeleton.parents[j]?;
                let d = (boxes[j].centre() - boxes[p].centre()).norm();
                let side = boxes[j].w.min(boxes[j].h) as f32;
                (d < 0.25 * side).then(|| {
                    format!(
                        "{} is {d:.1} px from its parent {}",
                        self.joints[j].name, self.joints[p].name
                    )
                })
            })
            .collect();
        if crowded.is_empty() {
            return String::new();
        }
        format!(
            "{} (closer than a quarter of its rectangle): a bone that short cannot show where the joint \
             is, so it follows its parent; place it where it is on the seed frame, or seed on a \
             frame where it shows",
            crowded.join(", ")
        )
    }

    /// Checks the seeds against a clip of `width × height` px and `frame_count` frames (`None`
    /// when unknown): the seed frame must be in the clip and every rectangle (unrotated, see
    /// [`JointBox::inside`]) fully inside the frame. `path` is the seed file, for messages.
    pub fn check_against_clip(
        &self,
        path: &Path,
        width: u32,
        height: u32,
        frame_count: Option<u64>,
    ) -> Result<()> {
        let err = |line: Option<usize>, joint: Option<&str>, msg: String| Error::Seed {
            path: path.to_path_buf(),
            line,
            joint: joint.map(str::to_owned),
            msg,
        };
        if let Some(n) = frame_count {
            if n == 0 {
                return Err(err(
                    None,
                    None,
                    format!(
                        "seed frame {} cannot be used: the clip has no frames",
                        self.frame
                    ),
                ));
            }
            if self.frame >= n {
                return Err(err(
                    None,
                    None,
                    format!(
                        "seed frame {} is beyond the clip, which has {n} frames (0 to {}); \
                         set `frame` to a frame of the clip",
                        self.frame,
                        n - 1
                    ),
                ));
            }
        }
        for j in &self.joints {
            if !j.bbox.inside(width, height) {
                let (x0, y0) = j.bbox.corner();
                let (x1, y1) = (x0 + j.bbox.w as f32, y0 + j.bbox.h as f32);
                return Err(err(
                    Some(j.line),
                    Some(&j.name),
                    format!(
                        "rectangle x {x0}..{x1}, y {y0}..{y1} (centre {}, {}, {}×{} px) is not fully \
                         inside the {width}×{height} frame (x -0.5..{}, y -0.5..{}); move its \
                         centre or make w/h smaller",
                        j.bbox.cx,
                        j.bbox.cy,
                        j.bbox.w,
                        j.bbox.h,
                        width as f32 - 0.5,
                        height as f32 - 0.5
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Largest seed file read, in bytes (4 MiB): far above any real one (10 000 joints take about
/// 1 MiB), so a wrong file (a video, a log) is refused at once instead of parsed.
pub const MAX_SEED_FILE_BYTES: u64 = 4 << 20;

/// The bytes of the file at `path`, or `None` if it holds more than `max` bytes. Reads at most
/// `max + 1` bytes, so a huge file, a device or a pipe is not read to its end.
pub(crate) fn read_capped(path: &Path, max: u64) -> std::io::Result<Option<Vec<u8>>> {
    use std::io::Read;
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(max + 1)
        .read_to_end(&mut bytes)?;
    Ok((bytes.len() as u64 <= max).then_some(bytes))
}

/// Reads and parses the seed file at `path` (see [`parse_seeds`]), returning the seeds and the
/// file's verbatim text. A missing file or one that is not UTF-8 is an [`Error::Seed`]; other
/// read failures are [`Error::Io`].
pub fn read_seeds(path: &Path) -> Result<(Seeds, String)> {
    let seed_err = |line: Option<usize>, msg: String| Error::Seed {
        path: path.to_path_buf(),
        line,
        joint: None,
        msg,
    };
    if path.is_dir() {
        return Err(seed_err(
            None,
            "is a directory, not a seed file; give the path of the seed .toml file".into(),
        ));
    }
    let bytes = read_capped(path, MAX_SEED_FILE_BYTES).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => seed_err(
            None,
            "seed file not found; check the path, or write one with a [[joint]] table \
             (name, x, y, w, h) per joint"
                .into(),
        ),
        _ => Error::io(path, e),
    })?;
    let Some(bytes) = bytes else {
        return Err(seed_err(
            None,
            format!(
                "larger than {} MiB, the limit for a seed file (10 000 joints take about 1 MiB); \
                 is this the right file?",
                MAX_SEED_FILE_BYTES >> 20
            ),
        ));
    };
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = line_of_offset(e.as_bytes(), at);
        seed_err(
            Some(line),
            format!("not valid UTF-8 text (byte {at}); save the seed file as UTF-8"),
        )
    })?;
    let seeds = parse_seeds(&text, path)?;
    Ok((seeds, text))
}

/// Parses seed-file `text` and checks its structure: TOML syntax, known keys, field types and
/// ranges, unique and well-formed names, parents that exist and form no cycle, at least one
/// joint. `path` is used in messages only. Checks against the clip are
/// [`Seeds::check_against_clip`].
pub fn parse_seeds(text: &str, path: &Path) -> Result<Seeds> {
    Parser {
        text,
        path,
        newlines: text.match_indices('\n').map(|(i, _)| i).collect(),
    }
    .parse()
}

/// Renders seeds in the seed-file format, for segment files: `header_comment` as `#` lines, then
/// `frame = N` and one `[[joint]]` per joint with `name`, `x`, `y` (3 decimals), `w`, `h`,
/// `parent`, and when present `angle` (non-zero, 4 decimals), `score` (3 decimals) and `status`.
/// The text is deterministic and reads back with [`parse_seeds`].
pub fn to_toml(frame: u64, joints: &[SeedJoint], header_comment: &str) -> String {
    let mut s = String::new();
    if !header_comment.is_empty() {
        for line in header_comment.lines() {
            let line = line.trim_end();
            let line = line.strip_prefix('#').map(str::trim_start).unwrap_or(line);
            if line.is_empty() {
                s.push_str("#\n");
            } else {
                let _ = writeln!(s, "# {line}");
            }
        }
        s.push('\n');
    }
    let _ = writeln!(s, "frame = {frame}");
    for j in joints {
        let b = &j.bbox;
        let _ = writeln!(s, "\n[[joint]]");
        let _ = writeln!(s, "name = {}", toml_string(&j.name));
        let _ = writeln!(s, "x = {}", float(b.cx, 3));
        let _ = writeln!(s, "y = {}", float(b.cy, 3));
        let _ = writeln!(s, "w = {}", b.w);
        let _ = writeln!(s, "h = {}", b.h);
        if let Some(p) = &j.parent {
            let _ = writeln!(s, "parent = {}", toml_string(p));
        }
        if b.angle_rad != 0.0 {
            let _ = writeln!(s, "angle = {}", float(b.angle_rad, 4));
        }
        if let Some(score) = j.score {
            let _ = writeln!(s, "score = {}", float(score, 3));
        }
        if let Some(status) = &j.status {
            let _ = writeln!(s, "status = {}", toml_string(status));
        }
    }
    s
}

/// A TOML float with `decimals` decimals (`nan`/`inf` spelt the TOML way).
fn float(v: f32, decimals: usize) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{v:.decimals$}")
    }
}

/// A TOML basic string, quoted and escaped.
fn toml_string(v: &str) -> String {
    let mut s = String::with_capacity(v.len() + 2);
    s.push('"');
    for c in v.chars() {
        match c {
            '"' => s.push_str("\\\""),
            '\\' => s.push_str("\\\\"),
            '\n' => s.push_str("\\n"),
            '\t' => s.push_str("\\t"),
            '\r' => s.push_str("\\r"),
            c if c.is_control() => {
                let _ = write!(s, "\\u{:04X}", c as u32);
            }
            c => s.push(c),
        }
    }
    s.push('"');
    s
}

/// True for a valid joint name: non-empty; letters, digits, `_`, `.` and `-` only.
pub fn is_valid_joint_name(name: &str) -> bool {
    !name.is_empty() && name.chars().all(is_name_char)
}

fn is_name_char(c: char) -> bool {
    c.is_alphanumeric() || matches!(c, '_' | '.' | '-')
}

#[cfg(test)]
mod tests;
