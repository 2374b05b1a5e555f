//! Keys on any frame: `RUN/keys.toml`, the user's corrections of single frames, any subset of
//! joints (docs/method.md, "Keys and segments").
//!
//! ```toml
//! [[key]]
//! frame = 120
//! left_wrist = [210.5, 300.0]   # x, y in px (the clip's pixels, see crate::geom)
//! right_elbow = [150.0, 280.0]
//! ```
//!
//! A key pulls the tracking both ways: the frames between it and the keys before and after it
//! are solved through all of them ([`super::keyed`]), and the frame-by-frame tracker is moved
//! onto it. The segment files (`segments/NNN.toml`) stay keys of every joint on a segment's
//! first frame, as before.

use crate::error::{Error, Result};
use crate::geom::Point;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use toml_edit::{ArrayOfTables, DocumentMut, Item, Table, Value};

/// One key: a frame and, for each of the run's joints in seed-file order, its position if the
/// key gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct Key {
    pub frame: u64,
    pub joints: Vec<Option<Point>>,
}

impl Key {
    /// Whether the key gives every joint (a key of some joints leaves the others' spans running
    /// on past it).
    pub fn gives_every_joint(&self) -> bool {
        self.joints.iter().all(Option::is_some)
    }
}

/// Where a run keeps its keys.
pub fn path(run_dir: &Path) -> PathBuf {
    run_dir.join("keys.toml")
}

/// Reads `RUN/keys.toml` (no file: no keys). `names` are the run's joints in seed-file order;
/// positions must lie inside the `width × height` frame and frames before `frames` (when
/// known). Returns the keys sorted by frame, one per frame.
pub fn read(
    run_dir: &Path,
    names: &[String],
    width: u32,
    height: u32,
    frames: Option<u64>,
) -> Result<Vec<Key>> {
    let file = path(run_dir);
    let text = match std::fs::read_to_string(&file) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::io(&file, e)),
    };
    parse(&text, &file, names, width, height, frames)
}

/// Refuses `keys` (read from `RUN/keys.toml` by [`read`] before the clip's length was known)
/// when one lies on or past frame `frames`, the clip's length, found as it ended: the error
/// names the file's line, as [`read`] given `frames` does.
pub fn check_within(
    run_dir: &Path,
    names: &[String],
    (width, height): (u32, u32),
    keys: &[Key],
    frames: u64,
) -> Result<()> {
    let Some(past) = keys.iter().find(|k| k.frame >= frames) else {
        return Ok(());
    };
    read(run_dir, names, width, height, Some(frames))?;
    // The file changed since it was read: name the frame without its line.
    Err(Error::Seed {
        path: path(run_dir),
        line: None,
        joint: None,
        msg: format!(
            "frame = {}, but the clip has {frames} frames (0 to {})",
            past.frame,
            frames.saturating_sub(1)
        ),
    })
}

/// Parses a keys file's text (see [`read`]); `file` names it in errors.
pub fn parse(
    text: &str,
    file: &Path,
    names: &[String],
    width: u32,
    height: u32,
    frames: Option<u64>,
) -> Result<Vec<Key>> {
    let err = |line: Option<usize>, joint: Option<&str>, msg: String| Error::Seed {
        path: file.to_owned(),
        line,
        joint: joint.map(str::to_owned),
        msg,
    };
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let line = e.span().map(|s| text[..s.start].lines().count().max(1));
        err(line, None, e.message().to_string())
    })?;
    // Where each `[[key]]` starts, to name lines in errors.
    let headers: Vec<usize> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with("[[key]]"))
        .map(|(i, _)| i + 1)
        .collect();
    let line_of = |i: usize, field: &str| -> Option<usize> {
        let from = *headers.get(i)?;
        let to = headers.get(i + 1).copied().unwrap_or(usize::MAX);
        text.lines()
            .enumerate()
            .skip(from)
            .take(to.saturating_sub(from))
            .find(|(_, l)| {
                let l = l.trim_start();
                l.strip_prefix(field)
                    .is_some_and(|r| r.trim_start().starts_with('='))
            })
            .map(|(n, _)| n + 1)
            .or(Some(from))
    };
    for k in table.keys() {
        if k != "key" {
            return Err(err(
                None,
                None,
                format!("unknown table {k:?}: a keys file holds [[key]] entries only"),
            ));
        }
    }
    let Some(entries) = table.get("key") else {
        return Ok(Vec::new());
    };
    let entries = entries
        .as_array()
        .ok_or_else(|| err(None, None, "`key` must be [[key]] entries".into()))?;
    let mut keys: BTreeMap<u64, (usize, Key)> = BTreeMap::new();
    for (i, entry) in entries.iter().enumerate() {
        let entry = entry.as_table().ok_or_else(|| {
            err(
                line_of(i, "frame"),
                None,
                "a [[key]] must be a table".into(),
            )
        })?;
        let frame = match entry.get("frame").and_then(|v| v.as_integer()) {
            Some(f) if f >= 0 => f as u64,
            _ => {
                return Err(err(
                    line_of(i, "frame"),
                    None,
                    "each [[key]] needs `frame = N`, a frame number from 0".into(),
                ))
            }
        };
        if let Some(n) = frames.filter(|&n| frame >= n) {
            return Err(err(
                line_of(i, "frame"),
                None,
                format!(
                    "frame = {frame}, but the clip has {n} frames (0 to {})",
                    n - 1
                ),
            ));
        }
        let mut joints = vec![None; names.len()];
        for (name, value) in entry.iter().filter(|(k, _)| k.as_str() != "frame") {
            let line = line_of(i, name);
            let Some(j) = names.iter().position(|n| n == name) else {
                return Err(err(
                    line,
                    Some(name),
                    format!(
                        "no such joint in this run; its joints are {} (to track another joint, \
                         add it to the seed file with `frame` on a frame that shows every joint \
                         (earlier frames are tracked backward) and run `track` again)",
                        names.join(", ")
                    ),
                ));
            };
            let xy: Option<Vec<f64>> = value.as_array().map(|a| {
                a.iter()
                    .filter_map(|v| v.as_float().or(v.as_integer().map(|i| i as f64)))
                    .collect()
            });
            let p = match xy.as_deref() {
                Some(&[x, y]) if x.is_finite() && y.is_finite() => Point::new(x as f32, y as f32),
                _ => {
                    return Err(err(
                        line,
                        Some(name),
                        "a joint's key is its position, `name = [x, y]` in px".into(),
                    ))
                }
            };
            if p.x < -0.5 || p.y < -0.5 || p.x > width as f32 - 0.5 || p.y > height as f32 - 0.5 {
                return Err(err(
                    line,
                    Some(name),
                    format!("({}, {}) lies outside the {width}×{height} frame", p.x, p.y),
                ));
            }
            joints[j] = Some(p);
        }
        if joints.iter().all(Option::is_none) {
            return Err(err(
                line_of(i, "frame"),
                None,
                format!("the key on frame {frame} gives no joint; add `joint_name = [x, y]`"),
            ));
        }
        if let Some((first, _)) = keys.get(&frame) {
            return Err(err(
                line_of(i, "frame"),
                None,
                format!(
                    "a second key on frame {frame} (the first starts on line {}); give each \
                     frame one [[key]]",
                    headers.get(*first).copied().unwrap_or(0)
                ),
            ));
        }
        keys.insert(frame, (i, Key { frame, joints }));
    }
    Ok(keys.into_values().map(|(_, k)| k).collect())
}

/// The first line of a keys file that `serve` starts.
const HEADER: &str =
    "# Keys on any frame: `joint = [x, y]` in px. Written by `mocap2d serve`; edit freely.\n";

/// `text`, a keys file that [`parse`] reads (empty when there is none yet), with the key on
/// `frame` set to the joints `joints` gives (one slot per joint of `names`) and its other joints
/// kept; with no joint given, the key on `frame` is removed. Used by `serve` to save a key from
/// the page. Everything the edit does not change stays as it was, byte for byte: the other
/// keys, comments on lines of their own and after an entry, blank lines, the order of keys and
/// of joints, how numbers are written.
///
/// - A joint given keeps its line and that line's comment; only `[x, y]` changes, and not even
///   that when it already holds the same position.
/// - A joint new to a key goes after the key's joints that come before it in `names` order.
/// - A new key goes before the first key on a later frame (at the end when there is none),
///   after a blank line; comments above the first key that a blank line parts from it stay at
///   the top of the file.
/// - A removed key's `[[key]]`, `frame` and joint lines go; its comments stay where it was,
///   each on a line of its own.
/// - Keys written as `key = [{ frame = N, … }]` come back as `[[key]]` tables; when that
///   array holds comments, which would be lost, the file is refused instead.
pub fn set_key(
    text: &str,
    file: &Path,
    names: &[String],
    frame: u64,
    joints: &[Option<Point>],
) -> Result<String> {
    let base = if text.trim().is_empty() { HEADER } else { text };
    let mut doc: DocumentMut = base
        .parse()
        .map_err(|e: toml_edit::TomlError| Error::Seed {
            path: file.to_owned(),
            line: e.span().map(|s| base[..s.start].lines().count().max(1)),
            joint: None,
            msg: e.message().to_string(),
        })?;
    let err = |msg: &str| Error::Seed {
        path: file.to_owned(),
        line: None,
        joint: None,
        msg: msg.into(),
    };
    let (lead, item) = match doc.as_table_mut().remove_entry("key") {
        Some((k, item)) => (prefix(k.leaf_decor()).to_owned(), item),
        None => (String::new(), Item::None),
    };
    let aot = match item {
        Item::None => ArrayOfTables::new(),
        Item::Value(Value::Array(a)) if a.is_empty() => ArrayOfTables::new(),
        Item::Value(v) if v.to_string().contains('#') => {
            return Err(err(
                "its keys are written `key = [{ frame = N, … }]` with comments inside, which \
                 saving from the page would lose: write them as [[key]] tables",
            ))
        }
        item => item
            .into_array_of_tables()
            .map_err(|_| err("`key` must be [[key]] entries"))?,
    };
    let mut tables: Vec<Table> = aot.into_iter().collect();
    if let Some(first) = tables.first_mut().filter(|_| !lead.is_empty()) {
        // The comments above `key = [`.
        let own = prefix(first.decor()).to_owned();
        first.decor_mut().set_prefix(lead + &own);
    } else if !lead.is_empty() {
        let trailing = doc.trailing().as_str().unwrap_or_default().to_owned();
        doc.set_trailing(lead + &trailing);
    }
    let at = tables.iter().position(|t| frame_of(t) == Some(frame));
    if joints.iter().all(Option::is_none) {
        if let Some(i) = at {
            let gone = tables.remove(i);
            let kept = comments_of(&gone);
            if let Some(next) = tables.get_mut(i) {
                let own = prefix(next.decor()).to_owned();
                if kept.contains('#') {
                    next.decor_mut().set_prefix(kept + &own);
                } else if i == 0 {
                    next.decor_mut().set_prefix(prefix(gone.decor()).to_owned());
                }
            } else if kept.contains('#') {
                let trailing = doc.trailing().as_str().unwrap_or_default().to_owned();
                doc.set_trailing(kept + &trailing);
            }
        }
    } else {
        let i = match at {
            Some(i) => i,
            None => {
                let i = tables
                    .iter()
                    .position(|t| frame_of(t).is_some_and(|f| f > frame))
                    .unwrap_or(tables.len());
                let mut t = Table::new();
                t.insert("frame", toml_edit::value(frame as i64));
                let lead = if let Some(first) = tables.first_mut().filter(|_| i == 0) {
                    // Comments above the first key that a blank line parts from it head the
                    // file: they stay above the new first key.
                    let old = prefix(first.decor()).to_owned();
                    let (head, tail) = old.split_at(after_last_blank_line(&old));
                    first.decor_mut().set_prefix(format!("\n{tail}"));
                    head.to_owned()
                } else if tables.is_empty() {
                    // A file of comments only: they stay above the first key.
                    let mut lead = doc.trailing().as_str().unwrap_or_default().to_owned();
                    doc.set_trailing("");
                    if lead.trim().is_empty() {
                        lead.clear();
                    } else {
                        lead.truncate(lead.trim_end().len());
                        lead.push_str("\n\n");
                    }
                    lead
                } else {
                    "\n".to_owned()
                };
                t.decor_mut().set_prefix(lead);
                tables.insert(i, t);
                i
            }
        };
        for (j, p) in joints.iter().enumerate() {
            if let Some(p) = p {
                set_joint(&mut tables[i], names, j, *p);
            }
        }
    }
    let mut aot = ArrayOfTables::new();
    for t in tables {
        aot.push(t);
    }
    doc.insert("key", Item::ArrayOfTables(aot));
    Ok(doc.to_string())
}

/// A key table's `frame`.
fn frame_of(t: &Table) -> Option<u64> {
    t.get("frame")?.as_integer()?.try_into().ok()
}

/// A decor's prefix as written (nothing when it has none).
fn prefix(d: &toml_edit::Decor) -> &str {
    d.prefix().and_then(|r| r.as_str()).unwrap_or_default()
}

/// Where the text after the last blank line of `s` starts (0 when it has none).
fn after_last_blank_line(s: &str) -> usize {
    let mut at = 0;
    let mut end = 0;
    for line in s.split_inclusive('\n') {
        end += line.len();
        if line.ends_with('\n') && line.trim().is_empty() {
            at = end;
        }
    }
    at
}

/// The comments of a key table, each on a line of its own, with the blank lines before and
/// between them: the key's lines without the key.
fn comments_of(t: &Table) -> String {
    let mut out = String::new();
    let mut lines = |s: &str, own_lines: bool| {
        for line in s.split_inclusive('\n') {
            let l = line.trim();
            if l.starts_with('#') {
                out.push_str(l);
                out.push('\n');
            } else if own_lines && l.is_empty() && line.ends_with('\n') {
                out.push('\n');
            }
        }
    };
    lines(prefix(t.decor()), true);
    lines(
        t.decor()
            .suffix()
            .and_then(|r| r.as_str())
            .unwrap_or_default(),
        false,
    );
    for (name, item) in t.iter() {
        if let Some(key) = t.key(name) {
            lines(prefix(key.leaf_decor()), true);
        }
        if let Some(v) = item.as_value() {
            lines(
                v.decor()
                    .suffix()
                    .and_then(|r| r.as_str())
                    .unwrap_or_default(),
                false,
            );
        }
    }
    out
}

/// Sets joint `j` of `names` to `p` in the key table `t`, keeping its line's layout and
/// comment; a joint not in `t` yet goes after those before it in `names` order.
fn set_joint(t: &mut Table, names: &[String], j: usize, p: Point) {
    let name = names[j].as_str();
    let new: Value = format!("[{:?}, {:?}]", p.x, p.y)
        .parse()
        .expect("two floats are a TOML array");
    if let Some(v) = t.get_mut(name).and_then(Item::as_value_mut) {
        if point_of(v) != Some(p) {
            let decor = v.decor().clone();
            *v = new;
            *v.decor_mut() = decor;
        }
        return;
    }
    let later = |k: &str| names.iter().position(|n| n == k).is_some_and(|i| i > j);
    let moved: Vec<String> = t
        .iter()
        .map(|(k, _)| k.to_owned())
        .skip_while(|k| !later(k))
        .collect();
    let moved: Vec<(toml_edit::Key, Item)> =
        moved.iter().filter_map(|k| t.remove_entry(k)).collect();
    t.insert(name, Item::Value(new));
    for (k, item) in moved {
        t.insert_formatted(&k, item);
    }
}

/// A joint's position as [`parse`] reads it.
fn point_of(v: &Value) -> Option<Point> {
    let a = v.as_array()?;
    let xy: Vec<f64> = a
        .iter()
        .filter_map(|v| v.as_float().or(v.as_integer().map(|i| i as f64)))
        .collect();
    match xy[..] {
        [x, y] if a.len() == 2 => Some(Point::new(x as f32, y as f32)),
        _ => None,
    }
}

#[cfg(test)]
mod tests;
