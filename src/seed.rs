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

use std::fmt::Write as _;
use std::path::Path;

use toml::de::{DeString, DeTable, DeValue};
use toml::Spanned;

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

/// 1-based line holding byte `offset` of `bytes`.
fn line_of_offset(bytes: &[u8], offset: usize) -> usize {
    let end = offset.min(bytes.len());
    bytes[..end].iter().filter(|&&b| b == b'\n').count() + 1
}

/// Levenshtein distance between `a` and `b`, ignoring ASCII case.
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().map(|c| c.to_ascii_lowercase()).collect();
    let b: Vec<char> = b.chars().map(|c| c.to_ascii_lowercase()).collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for (i, ca) in a.iter().enumerate() {
        cur[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// The candidate nearest to `word`, if it is close enough to be a likely typo.
fn nearest<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let limit = (word.chars().count() / 3).max(1);
    candidates
        .into_iter()
        .map(|c| (edit_distance(word, c), c))
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, _)| d)
        .map(|(_, c)| c)
}

/// `; did you mean `x`?` or nothing.
fn did_you_mean_key(word: &str, candidates: &[&str]) -> String {
    nearest(word, candidates.iter().copied())
        .map(|c| format!("; did you mean `{c}`?"))
        .unwrap_or_default()
}

/// A short excerpt of source text, for "found ..." in messages.
fn excerpt(s: &str) -> String {
    let s = s.trim();
    let mut out: String = s.chars().take(40).collect();
    if out.len() < s.len() {
        out.push('…');
    }
    out
}

type Entry<'a, 'i> = (&'a Spanned<DeString<'i>>, &'a Spanned<DeValue<'i>>);

/// A joint as read, before parent links are resolved.
struct RawJoint {
    joint: SeedJoint,
    parent_line: usize,
}

struct Parser<'t> {
    text: &'t str,
    path: &'t Path,
    /// Byte offsets of the text's line breaks, so a line number is a binary search (a file of
    /// 10 000 joints asks for tens of thousands).
    newlines: Vec<usize>,
}

impl<'t> Parser<'t> {
    /// 1-based line holding byte `offset` of the text.
    fn line(&self, offset: usize) -> usize {
        self.newlines.partition_point(|&nl| nl < offset) + 1
    }

    fn err(&self, line: Option<usize>, joint: Option<&str>, msg: impl Into<String>) -> Error {
        Error::Seed {
            path: self.path.to_path_buf(),
            line,
            joint: joint.map(str::to_owned),
            msg: msg.into(),
        }
    }

    fn src(&self, span: std::ops::Range<usize>) -> &'t str {
        self.text.get(span).unwrap_or("")
    }

    /// "found float 1.5" for a value of the wrong type.
    fn found(&self, v: &Spanned<DeValue<'_>>) -> String {
        let kind = match v.get_ref() {
            DeValue::Table(_) => return "found a table".into(),
            DeValue::Array(_) => return "found an array".into(),
            other => other.type_str(),
        };
        format!("found {kind} {}", excerpt(self.src(v.span())))
    }

    fn parse(&self) -> Result<Seeds> {
        let doc = DeTable::parse(self.text).map_err(|e| self.syntax_error(&e))?;
        let mut entries: Vec<Entry<'_, '_>> = doc.get_ref().iter().collect();
        entries.sort_by_key(|(k, _)| k.span().start);

        let mut frame = 0u64;
        let mut joint_value = None;
        for &(k, v) in &entries {
            let key: &str = k.get_ref();
            let line = Some(self.line(k.span().start));
            match key {
                "frame" => frame = self.frame(v, line)?,
                "joint" => joint_value = Some(v),
                other if JOINT_KEYS.contains(&other) => {
                    return Err(self.err(
                        line,
                        None,
                        format!(
                            "`{other}` belongs to a joint; put it after a [[joint]] line \
                             (the top level takes only `frame`)"
                        ),
                    ))
                }
                other => {
                    return Err(self.err(
                        line,
                        None,
                        format!(
                            "unknown key `{other}`{}; the top level takes `frame` and [[joint]] \
                             tables",
                            did_you_mean_key(other, TOP_KEYS)
                        ),
                    ))
                }
            }
        }

        let no_joints = || {
            self.err(
                None,
                None,
                "no joints: add a [[joint]] table (name, x, y, w, h) for each joint to track",
            )
        };
        let tables = match joint_value.map(|v| (v, v.get_ref())) {
            None => return Err(no_joints()),
            Some((v, DeValue::Table(_))) => return Err(self.err(
                Some(self.line(v.span().start)),
                None,
                "`joint` is a single table; write [[joint]] (double brackets) before each joint",
            )),
            Some((_, DeValue::Array(a))) => a,
            Some((v, _)) => {
                return Err(self.err(
                    Some(self.line(v.span().start)),
                    None,
                    format!(
                        "`joint` must be [[joint]] tables, {}; write a [[joint]] table \
                         (name, x, y, w, h) for each joint",
                        self.found(v)
                    ),
                ))
            }
        };
        if tables.is_empty() {
            return Err(no_joints());
        }
        if let Some(t) = tables.get(MAX_JOINTS) {
            return Err(self.err(
                Some(self.line(t.span().start)),
                None,
                too_many_joints(tables.len()),
            ));
        }

        let mut raw: Vec<RawJoint> = Vec::with_capacity(tables.len());
        for (n, t) in tables.iter().enumerate() {
            let j = self.joint(n, t, &raw)?;
            raw.push(j);
        }
        let skeleton = self.skeleton(&raw)?;
        Ok(Seeds {
            frame,
            joints: raw.into_iter().map(|r| r.joint).collect(),
            skeleton,
        })
    }

    fn syntax_error(&self, e: &toml::de::Error) -> Error {
        let Some(span) = e.span() else {
            return self.err(None, None, format!("invalid TOML: {}", e.message()));
        };
        let line = self.line(span.start);
        let line_start = self.text.as_bytes()[..span.start.min(self.text.len())]
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1);
        let column = self
            .text
            .get(line_start..span.start)
            .map_or(1, |s| s.chars().count() + 1);
        let mut msg = e.message().to_owned();
        if msg == "duplicate key" {
            let key = self.src(span.clone());
            if key == "joint" {
                msg = "`joint` is defined twice; write [[joint]] (double brackets) before every \
                       joint"
                    .into();
            } else {
                msg = format!(
                    "duplicate key `{key}`; each key may appear once per table (start the next \
                     joint with [[joint]])"
                );
            }
            return self.err(Some(line), None, format!("invalid TOML: {msg}"));
        }
        self.err(
            Some(line),
            None,
            format!("invalid TOML at column {column}: {msg}; fix the syntax"),
        )
    }

    fn frame(&self, v: &Spanned<DeValue<'_>>, line: Option<usize>) -> Result<u64> {
        let DeValue::Integer(i) = v.get_ref() else {
            return Err(self.err(
                line,
                None,
                format!(
                    "`frame` must be a whole number (0 for the first frame), {}",
                    self.found(v)
                ),
            ));
        };
        match i64::from_str_radix(i.as_str(), i.radix()) {
            Ok(f) if f < 0 => Err(self.err(
                line,
                None,
                format!("`frame` must be 0 or more (0 is the first frame), found {f}"),
            )),
            Ok(f) => Ok(f as u64),
            Err(_) => Err(self.err(
                line,
                None,
                format!("`frame` {} is too large", excerpt(self.src(v.span()))),
            )),
        }
    }

    /// Reads the `n`-th (0-based) `[[joint]]` table; `earlier` are the joints before it.
    fn joint(&self, n: usize, t: &Spanned<DeValue<'_>>, earlier: &[RawJoint]) -> Result<RawJoint> {
        let header = self.line(t.span().start);
        let DeValue::Table(table) = t.get_ref() else {
            return Err(self.err(
                Some(header),
                None,
                format!(
                    "joint #{} must be a table with name, x, y, w, h, {}",
                    n + 1,
                    self.found(t)
                ),
            ));
        };
        let mut entries: Vec<Entry<'_, '_>> = table.iter().collect();
        entries.sort_by_key(|(k, _)| k.span().start);
        let get = |key: &str| entries.iter().find(|(k, _)| k.get_ref() == key).copied();
        let key_line = |e: Entry<'_, '_>| self.line(e.0.span().start);

        // The name first, so that every later message can name the joint.
        let Some(name_entry) = get("name") else {
            return Err(self.err(
                Some(header),
                None,
                format!(
                    "the [[joint]] here (joint #{}) has no `name`; add name = \"...\" \
                     (letters, digits, _ . -)",
                    n + 1
                ),
            ));
        };
        let name_line = key_line(name_entry);
        let DeValue::String(name) = name_entry.1.get_ref() else {
            return Err(self.err(
                Some(name_line),
                None,
                format!(
                    "`name` must be a string such as \"knee\", {}",
                    self.found(name_entry.1)
                ),
            ));
        };
        let name: &str = name;
        if !is_valid_joint_name(name) {
            let bad: String = name.chars().filter(|&c| !is_name_char(c)).take(5).collect();
            let msg = if name.is_empty() {
                "`name` is empty; give the joint a name (letters, digits, _ . -)".to_owned()
            } else {
                format!(
                    "`name` has characters that are not allowed ({bad:?}); use only letters, \
                     digits, _ . and -"
                )
            };
            return Err(self.err(Some(name_line), Some(name), msg));
        }
        if let Some(first) = earlier.iter().find(|r| r.joint.name == name) {
            return Err(self.err(
                Some(name_line),
                Some(name),
                format!(
                    "`name` is already used by the joint on line {}; joint names must be unique",
                    first.joint.line
                ),
            ));
        }
        let err = |e: Entry<'_, '_>, msg: String| self.err(Some(key_line(e)), Some(name), msg);

        for &e in &entries {
            let key: &str = e.0.get_ref();
            if JOINT_KEYS.contains(&key) {
                continue;
            }
            let msg = if key == "frame" {
                "`frame` must come before the first [[joint]]; move it to the top of the file"
                    .to_owned()
            } else {
                format!(
                    "unknown key `{key}`{}; a joint takes {}",
                    did_you_mean_key(key, JOINT_KEYS),
                    JOINT_KEYS.join(", ")
                )
            };
            return Err(err(e, msg));
        }
        for key in REQUIRED_JOINT_KEYS {
            if get(key).is_none() {
                return Err(self.err(
                    Some(header),
                    Some(name),
                    format!("missing `{key}`; {}", required_hint(key)),
                ));
            }
        }
        // Cannot fail: every required key was checked present just above.
        let required = |key: &str| get(key).expect("checked above");

        let coord = |key: &str| -> Result<f32> {
            let e = required(key);
            let what = format!("`{key}` (rectangle centre, px)");
            let v = self.number(e, &what, name)?;
            if !v.is_finite() {
                return Err(err(
                    e,
                    format!(
                        "{what} must be a finite number, found {}",
                        excerpt(self.src(e.1.span()))
                    ),
                ));
            }
            Ok(v)
        };
        let cx = coord("x")?;
        let cy = coord("y")?;
        let size = |key: &str| -> Result<u32> {
            let e = required(key);
            let what = if key == "w" { "width" } else { "height" };
            let v = match e.1.get_ref() {
                DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix()).ok(),
                _ => {
                    return Err(err(
                        e,
                        format!(
                        "`{key}` (rectangle {what}) must be a whole number of px such as 21, {}",
                        self.found(e.1)
                    ),
                    ))
                }
            };
            match v {
                Some(v) if v >= i64::from(MIN_BOX_PX) && v <= i64::from(u32::MAX) => Ok(v as u32),
                Some(v) if v < i64::from(MIN_BOX_PX) => Err(err(
                    e,
                    format!(
                        "`{key}` (rectangle {what}) must be at least {MIN_BOX_PX} px, found {v}; \
                         make the rectangle cover the joint"
                    ),
                )),
                _ => Err(err(
                    e,
                    format!(
                        "`{key}` (rectangle {what}) {} is too large",
                        excerpt(self.src(e.1.span()))
                    ),
                )),
            }
        };
        let w = size("w")?;
        let h = size("h")?;

        let angle_rad = match get("angle") {
            None => 0.0,
            Some(e) => {
                let what = "`angle` (radians)";
                let v = self.number(e, what, name)?;
                if !v.is_finite() {
                    return Err(err(
                        e,
                        format!(
                            "{what} must be a finite number, found {}",
                            excerpt(self.src(e.1.span()))
                        ),
                    ));
                }
                v
            }
        };
        let score = match get("score") {
            None => None,
            Some(e) => {
                let v = self.number(e, "`score`", name)?;
                if !(0.0..=1.0).contains(&v) {
                    return Err(err(
                        e,
                        format!(
                            "`score` must be between 0 and 1, found {}",
                            excerpt(self.src(e.1.span()))
                        ),
                    ));
                }
                Some(v)
            }
        };
        let string = |key: &str, hint: &str| -> Result<Option<(String, usize)>> {
            match get(key) {
                None => Ok(None),
                Some(e) => match e.1.get_ref() {
                    DeValue::String(s) => Ok(Some((s.to_string(), key_line(e)))),
                    _ => Err(err(
                        e,
                        format!("`{key}` must be a string {hint}, {}", self.found(e.1)),
                    )),
                },
            }
        };
        let status = string("status", "such as \"ok\"")?.map(|(s, _)| s);
        let parent = string("parent", "naming another joint, such as \"hip\"")?;
        let parent_line = parent.as_ref().map_or(header, |&(_, l)| l);

        let mut bbox = JointBox::centred(cx, cy, w, h);
        bbox.angle_rad = angle_rad;
        Ok(RawJoint {
            joint: SeedJoint {
                name: name.to_owned(),
                bbox,
                parent: parent.map(|(p, _)| p),
                score,
                status,
                line: header,
            },
            parent_line,
        })
    }

    /// A float or integer value as `f32`; `what` names the field in the message.
    fn number(&self, e: Entry<'_, '_>, what: &str, joint: &str) -> Result<f32> {
        let v = match e.1.get_ref() {
            DeValue::Float(f) => f.as_str().parse::<f64>().ok(),
            DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix())
                .ok()
                .map(|v| v as f64),
            _ => {
                return Err(self.err(
                    Some(self.line(e.0.span().start)),
                    Some(joint),
                    format!("{what} must be a number, {}", self.found(e.1)),
                ))
            }
        };
        v.map(|v| v as f32).ok_or_else(|| {
            self.err(
                Some(self.line(e.0.span().start)),
                Some(joint),
                format!(
                    "{what} is not a number TOML can read: {}",
                    excerpt(self.src(e.1.span()))
                ),
            )
        })
    }

    /// Resolves parent names into a [`Skeleton`], rejecting unknown parents and cycles.
    fn skeleton(&self, raw: &[RawJoint]) -> Result<Skeleton> {
        let names: Vec<String> = raw.iter().map(|r| r.joint.name.clone()).collect();
        let mut parents = Vec::with_capacity(raw.len());
        for r in raw {
            let j = &r.joint;
            let Some(p) = &j.parent else {
                parents.push(None);
                continue;
            };
            let Some(pi) = names.iter().position(|n| n == p) else {
                let guess = parent_guesses(p, &names);
                let guess = match guess.as_slice() {
                    [] => String::new(),
                    [g] => format!("did you mean {g:?}? "),
                    gs => format!(
                        "did you mean one of {}? ",
                        gs.iter()
                            .map(|g| format!("{g:?}"))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                };
                return Err(self.err(
                    Some(r.parent_line),
                    Some(&j.name),
                    format!(
                        "parent {p:?} is not a joint in this file; {guess}known joints: {}",
                        list_names(&names)
                    ),
                ));
            };
            parents.push(Some(pi));
        }
        let skeleton = Skeleton::new(names, parents);
        if let Some(cycle) = skeleton.find_cycle() {
            let first = &raw[cycle[0]];
            let msg = if cycle.len() == 1 {
                "`parent` names the joint itself; remove `parent` to make it a root, or name \
                 another joint"
                    .to_owned()
            } else {
                let chain: Vec<String> = cycle
                    .iter()
                    .chain(std::iter::once(&cycle[0]))
                    .map(|&i| format!("{:?}", skeleton.names[i]))
                    .collect();
                format!(
                    "parent links form a cycle: {} (each arrow points to the parent); remove \
                     one `parent` so that the chain ends at a root",
                    chain.join(" -> ")
                )
            };
            return Err(self.err(Some(first.parent_line), Some(&first.joint.name), msg));
        }
        Ok(skeleton)
    }
}

/// Joint names the user may have meant by the unknown parent `p`: the nearest name if it is a
/// likely typo, else the names whose last part (after `.`, `_` or `-`) is `p`, such as
/// "female.head" and "male.head" for "head".
fn parent_guesses<'a>(p: &str, names: &'a [String]) -> Vec<&'a str> {
    if let Some(g) = nearest(p, names.iter().map(String::as_str)) {
        return vec![g];
    }
    names
        .iter()
        .map(String::as_str)
        .filter(|n| {
            n.strip_suffix(p)
                .is_some_and(|head| head.ends_with(['.', '_', '-']))
        })
        .take(5)
        .collect()
}

/// How to write a missing required key.
fn required_hint(key: &str) -> &'static str {
    match key {
        "x" | "y" => {
            "give the rectangle centre in px as x = ... and y = ... (origin top-left, y down)"
        }
        "w" | "h" => "give the rectangle size in whole px as w = ... and h = ... (at least 5)",
        _ => "add it",
    }
}

/// Up to 12 names, quoted, then how many more.
fn list_names(names: &[String]) -> String {
    const SHOWN: usize = 12;
    let mut s: Vec<String> = names.iter().take(SHOWN).map(|n| format!("{n:?}")).collect();
    if names.len() > SHOWN {
        s.push(format!("and {} more", names.len() - SHOWN));
    }
    s.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Seeds> {
        parse_seeds(text, Path::new("seeds.toml"))
    }

    fn message(text: &str) -> String {
        match parse(text) {
            Ok(s) => panic!("expected an error, parsed {s:?}"),
            Err(e) => {
                assert!(matches!(e, Error::Seed { .. }), "{e:?}");
                assert!(e.is_user_error());
                e.to_string()
            }
        }
    }

    const ARM: &str = "frame = 3\n\
        \n\
        [[joint]]\n\
        name = \"hand\"\n\
        x = 10\n\
        y = 20.5\n\
        w = 9\n\
        h = 7\n\
        parent = \"elbow\"\n\
        \n\
        [[joint]]\n\
        name = \"elbow\"\n\
        x = 30.25\n\
        y = 40\n\
        w = 11\n\
        h = 11\n";

    #[test]
    fn top_key_line_finds_frame_before_the_tables_only() {
        let t = "# segment 2\n\nframe = 40\n\n[[joint]]\nframe = 3\n";
        assert_eq!(super::top_key_line(t, "frame"), Some(3));
        assert_eq!(super::top_key_line("[[joint]]\nframe = 1\n", "frame"), None);
        assert_eq!(super::top_key_line("frames = 1\n", "frame"), None);
    }

    #[test]
    fn parses_parent_after_child() {
        let s = parse(ARM).unwrap();
        assert_eq!(s.frame, 3);
        assert_eq!(s.joints.len(), 2);
        assert_eq!(s.joints[0].name, "hand");
        assert_eq!(s.joints[0].line, 3);
        assert_eq!(s.joints[1].line, 11);
        assert_eq!(s.joints[0].bbox, JointBox::centred(10.0, 20.5, 9, 7));
        assert_eq!(s.joints[0].parent.as_deref(), Some("elbow"));
        assert_eq!(s.skeleton.parents, vec![Some(1), None]);
        assert_eq!(s.skeleton.topo_order(), vec![1, 0]);
    }

    #[test]
    fn error_lines_point_at_the_field() {
        let m = message(&ARM.replace("w = 9", "w = 3"));
        assert!(
            m.starts_with("seeds.toml: line 7: joint \"hand\": `w`"),
            "{m}"
        );
        assert!(m.contains("at least 5"), "{m}");
    }

    #[test]
    fn unknown_key_suggests_nearest() {
        let m = message(&ARM.replace("parent = ", "parnet = "));
        assert!(
            m.contains("line 9") && m.contains("did you mean `parent`"),
            "{m}"
        );
        let m = message(&ARM.replace("frame = 3", "frames = 3"));
        assert!(
            m.contains("line 1") && m.contains("did you mean `frame`"),
            "{m}"
        );
    }

    #[test]
    fn float_formats() {
        assert_eq!(float(1.0, 3), "1.000");
        assert_eq!(float(f32::NAN, 3), "nan");
        assert_eq!(float(f32::NEG_INFINITY, 3), "-inf");
    }

    #[test]
    fn strings_are_escaped() {
        assert_eq!(toml_string("a\"b\\c\n"), "\"a\\\"b\\\\c\\n\"");
    }

    #[test]
    fn edit_distance_counts_edits() {
        assert_eq!(edit_distance("parnet", "parent"), 2);
        assert_eq!(edit_distance("X", "x"), 0);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(nearest("hip", ["hips", "knee"]), Some("hips"));
        assert_eq!(nearest("zzz", ["hips", "knee"]), None);
    }

    #[test]
    fn parent_guesses_match_typos_and_last_parts() {
        let names: Vec<String> = ["female.head", "male.head", "male.thorax"]
            .map(String::from)
            .to_vec();
        assert_eq!(parent_guesses("male.haed", &names), vec!["male.head"]);
        assert_eq!(
            parent_guesses("head", &names),
            vec!["female.head", "male.head"]
        );
        assert_eq!(parent_guesses("wing", &names), Vec::<&str>::new());
    }

    #[test]
    fn names_allow_letters_digits_and_punctuation() {
        assert!(is_valid_joint_name("female.forelegL4"));
        assert!(is_valid_joint_name("left_knee-2"));
        assert!(!is_valid_joint_name("left knee"));
        assert!(!is_valid_joint_name(""));
        assert!(!is_valid_joint_name("a/b"));
    }

    #[test]
    fn to_toml_round_trips() {
        let s = parse(ARM).unwrap();
        let mut joints = s.joints.clone();
        joints[0].score = Some(0.5);
        joints[0].status = Some("ok".into());
        joints[1].bbox.angle_rad = -0.25;
        let text = to_toml(7, &joints, "segment 2\n\nframes 7..20");
        assert!(
            text.starts_with("# segment 2\n#\n# frames 7..20\n\nframe = 7\n"),
            "{text}"
        );
        let back = parse(&text).unwrap();
        assert_eq!(back.frame, 7);
        for (a, b) in back.joints.iter().zip(&joints) {
            assert_eq!(a.name, b.name);
            assert_eq!(a.bbox, b.bbox);
            assert_eq!(a.parent, b.parent);
            assert_eq!(a.score, b.score);
            assert_eq!(a.status, b.status);
        }
        assert_eq!(to_toml(7, &back.joints, "segment 2\n\nframes 7..20"), text);
    }
}
