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

/// One key: a frame and, for each of the run's joints in seed-file order, its position if the
/// key gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct Key {
    pub frame: u64,
    pub joints: Vec<Option<Point>>,
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
                        "no such joint in this run; its joints are {}",
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

/// The text of a keys file holding `keys` (one `[[key]]` per key, in the order given; joints
/// in `names` order, positions as `[x, y]`), which [`parse`] reads back to the same keys. Used
/// by `serve` to save keys from the page; comments in the file it replaces are not kept.
pub fn to_text(keys: &[Key], names: &[String]) -> String {
    let mut out = String::from(
        "# Keys on any frame: `joint = [x, y]` in px. Written by `mocap2d serve`; edit freely.\n",
    );
    for k in keys {
        out.push_str(&format!("\n[[key]]\nframe = {}\n", k.frame));
        for (name, p) in names.iter().zip(&k.joints) {
            if let Some(p) = p {
                out.push_str(&format!("{} = [{:?}, {:?}]\n", toml_key(name), p.x, p.y));
            }
        }
    }
    out
}

/// `name` as a TOML key: bare when it can be (letters, digits, `_`, `-`), else quoted, so that
/// a joint named `female.head` is not read back as a table `female`.
fn toml_key(name: &str) -> String {
    let bare = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if bare {
        name.to_owned()
    } else {
        toml::Value::String(name.to_owned()).to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> Vec<String> {
        ["hip", "knee", "ankle"]
            .iter()
            .map(|s| s.to_string())
            .collect()
    }

    fn parse_str(text: &str) -> Result<Vec<Key>> {
        parse(text, Path::new("keys.toml"), &names(), 100, 80, Some(50))
    }

    #[test]
    fn reads_subsets_of_joints_sorted_by_frame() {
        let keys = parse_str(
            "[[key]]\nframe = 30\nknee = [10, 20.5]\n\n[[key]]\nframe = 4\nhip = [1.0, 2.0]\nankle = [3, 4]\n",
        )
        .unwrap();
        assert_eq!(keys.len(), 2);
        assert_eq!(keys[0].frame, 4);
        assert_eq!(
            keys[0].joints,
            vec![Some(Point::new(1.0, 2.0)), None, Some(Point::new(3.0, 4.0))]
        );
        assert_eq!(
            keys[1].joints,
            vec![None, Some(Point::new(10.0, 20.5)), None]
        );
    }

    #[test]
    fn errors_name_the_line_and_joint() {
        let e =
            parse_str("[[key]]\nframe = 3\nhip = [1, 2]\n\n[[key]]\nframe = 5\nelbow = [1, 2]\n")
                .unwrap_err()
                .to_string();
        assert!(
            e.contains("line 7") && e.contains("elbow") && e.contains("hip, knee, ankle"),
            "{e}"
        );
        let e = parse_str("[[key]]\nframe = 3\nknee = [1, 200]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("outside"), "{e}");
        let e = parse_str("[[key]]\nframe = 60\nknee = [1, 2]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("50 frames"), "{e}");
        let e = parse_str("[[key]]\nframe = 6\nknee = [1, 2]\n[[key]]\nframe = 6\nhip = [1, 2]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 5") && e.contains("second key"), "{e}");
        let e = parse_str("[[key]]\nframe = 6\nknee = 3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("[x, y]"), "{e}");
    }

    #[test]
    fn to_text_reads_back_to_the_same_keys() {
        let keys = parse_str(
            "[[key]]\nframe = 30\nknee = [10, 20.25]\n[[key]]\nframe = 4\nhip = [1.5, 2.0]\nankle = [3, 4]\n",
        )
        .unwrap();
        let text = to_text(&keys, &names());
        assert_eq!(parse_str(&text).unwrap(), keys, "{text}");
        assert!(text.contains("[[key]]\nframe = 4\nhip = [1.5, 2.0]\nankle = [3.0, 4.0]\n"));
        assert_eq!(parse_str(&to_text(&[], &names())).unwrap(), vec![]);
    }

    #[test]
    fn names_that_are_not_bare_keys_are_quoted() {
        // The flies' joints are named like `female.head`: bare, that would be a table.
        let names: Vec<String> = ["female.head", "left wrist", "knee"]
            .map(String::from)
            .to_vec();
        let keys = vec![Key {
            frame: 3,
            joints: vec![
                Some(Point::new(1.0, 2.0)),
                Some(Point::new(3.0, 4.0)),
                Some(Point::new(5.0, 6.0)),
            ],
        }];
        let text = to_text(&keys, &names);
        assert!(text.contains("\"female.head\" = [1.0, 2.0]\n"), "{text}");
        assert!(text.contains("\nknee = [5.0, 6.0]\n"), "{text}");
        let back = parse(&text, Path::new("keys.toml"), &names, 100, 80, None).unwrap();
        assert_eq!(back, keys, "{text}");
    }
}
