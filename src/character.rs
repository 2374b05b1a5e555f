//! Target characters: the TOML file that `mocap2d retarget` and `mocap2d render` take with
//! `--target`, and its checks against the source skeleton.
//!
//! ```toml
//! image = "robot.png"      # PNG with alpha, the character in its rest pose; relative to this file
//! scale = "fit"            # output px per image px, or "fit" (default): the rest skeleton gets the
//!                          # source skeleton's size (sum of bone lengths)
//! background = "#ffffff"   # "#rrggbb" (default white), "transparent", or a frame-sized image file
//! mesh_vertices = 500      # about how many mesh vertices to deform (default 500, 50 to 5000)
//!
//! [[joint]]
//! name = "pelvis"          # unique; letters, digits, _ . -
//! x = 120.0                # rest position in the image, px; origin top-left, y down
//! y = 210.5
//! # parent = "chest"       # omitted for a root; the bone runs parent -> this joint
//! # layer = 1              # draw order of the bone ending here (higher on top; default 0)
//!
//! [map]                    # optional: target joint = source joint, or a virtual one
//! hip = "mid(left_hip, right_hip)"
//!
//! [bones]                  # optional: the bone ending at a target joint = a source bone
//! elbow_l = ["left_shoulder", "left_elbow"]
//! ```
//! Positions follow [`crate::geom`]'s conventions. [`read_character`] checks the file on its own
//! (syntax, keys, types, image, joints inside the image and on the character);
//! [`crate::retarget::mapping::build`] works out which source joints drive which bone (same
//! names, `[map]`, `[bones]`, recognised body-part names).
//! Every problem is an [`Error::Character`] naming the file, line and joint, with the fix: exit 2.

mod image_file;

use self::image_file::{load_image, near_opaque};
use crate::error::{Error, Result};
use crate::geom::Point;
use crate::seed::is_valid_joint_name;
use crate::skeleton::Skeleton;
use image::RgbaImage;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Default of `mesh_vertices`.
pub const DEFAULT_MESH_VERTICES: usize = 500;

/// Alpha (0–255) at or above which a pixel belongs to the character.
pub const ALPHA_INSIDE: u8 = 128;

/// How image px become output px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scale {
    /// The rest skeleton is scaled to the source rest skeleton's size (sum of bone lengths).
    Fit,
    /// Output px per image px.
    Factor(f32),
}

/// What the character is drawn over.
#[derive(Debug, Clone, PartialEq)]
pub enum Backdrop {
    /// An opaque colour, RGB.
    Colour([u8; 3]),
    /// Nothing: PNG frames keep alpha; the video shows black.
    Transparent,
    /// A frame-sized image (the path as resolved against the character file's folder).
    Plate(PathBuf),
}

/// A parsed and checked target character.
#[derive(Debug, Clone)]
pub struct Character {
    /// The character file.
    pub path: PathBuf,
    /// The resolved image path.
    pub image_path: PathBuf,
    /// The image, RGBA.
    pub image: RgbaImage,
    /// Joint names and parent links, in file order.
    pub skeleton: Skeleton,
    /// Rest position of each joint in the image (px).
    pub rest: Vec<Point>,
    /// Draw layer of the bone ending at each joint (0 for roots and by default).
    pub layers: Vec<i32>,
    pub scale: Scale,
    pub backdrop: Backdrop,
    /// About how many mesh vertices to use.
    pub mesh_vertices: usize,
    /// `[map]`: target joint name -> source point (`name` or `mid(a, b)`).
    pub map: BTreeMap<String, String>,
    /// `[bones]`: target joint name -> the source points the bone ending there runs between.
    pub bones: BTreeMap<String, (String, String)>,
    /// 1-based line of each joint's `[[joint]]` header.
    pub lines: Vec<usize>,
    /// blake3 (hex) of the file's text.
    pub blake3: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCharacter {
    image: String,
    scale: Option<toml::Value>,
    background: Option<String>,
    mesh_vertices: Option<i64>,
    joint: Vec<RawJoint>,
    #[serde(default)]
    map: BTreeMap<String, String>,
    #[serde(default)]
    bones: BTreeMap<String, Vec<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawJoint {
    name: String,
    x: f64,
    y: f64,
    parent: Option<String>,
    layer: Option<i64>,
}

/// Largest character file read, in bytes (4 MiB); a wrong file is refused at once.
pub const MAX_CHARACTER_FILE_BYTES: u64 = 4 << 20;

/// Reads and checks the character file at `path`, loading its image.
pub fn read_character(path: &Path) -> Result<Character> {
    let err = |line: Option<usize>, joint: Option<&str>, msg: String| Error::Character {
        path: path.to_owned(),
        line,
        joint: joint.map(str::to_owned),
        msg,
    };
    if path.is_dir() {
        return Err(err(
            None,
            None,
            "is a folder; give the character's .toml file".into(),
        ));
    }
    let bytes = crate::seed::read_capped(path, MAX_CHARACTER_FILE_BYTES)
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => err(
                None,
                None,
                "character file not found; see configs/characters/ for examples".into(),
            ),
            _ => Error::io(path, e),
        })?
        .ok_or_else(|| {
            err(
                None,
                None,
                format!(
                    "larger than {} MiB, the limit for a character file; is this the right file?",
                    MAX_CHARACTER_FILE_BYTES >> 20
                ),
            )
        })?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        err(
            Some(line),
            None,
            format!("not valid UTF-8 text (byte {at}); save the character file as UTF-8"),
        )
    })?;
    parse_character(&text, path)
}

/// Parses and checks character-file `text` as if read from `path`: the image and a background
/// image are looked for beside `path`, and loaded.
pub fn parse_character(text: &str, path: &Path) -> Result<Character> {
    let err = |line: Option<usize>, joint: Option<&str>, msg: String| Error::Character {
        path: path.to_owned(),
        line,
        joint: joint.map(str::to_owned),
        msg,
    };
    let raw: RawCharacter = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| {
            text.as_bytes()[..s.start.min(text.len())]
                .iter()
                .filter(|&&b| b == b'\n')
                .count()
                + 1
        });
        err(line, None, format!("{}; fix the file", e.message().trim()))
    })?;
    let lines = joint_lines(text);
    let line_of = |i: usize| lines.get(i).copied();
    if raw.joint.is_empty() {
        return Err(err(
            None,
            None,
            "no joints; add a [[joint]] table (name, x, y, parent) per joint".into(),
        ));
    }

    // Joints: names, parents, layers.
    let mut names: Vec<String> = Vec::new();
    for (i, j) in raw.joint.iter().enumerate() {
        if !is_valid_joint_name(&j.name) {
            return Err(err(
                line_of(i),
                Some(&j.name),
                "`name` must be non-empty with letters, digits, _ . - only".into(),
            ));
        }
        if names.contains(&j.name) {
            return Err(err(
                line_of(i),
                Some(&j.name),
                "`name` is used by an earlier joint; joint names must be unique".into(),
            ));
        }
        if !(j.x.is_finite() && j.y.is_finite()) {
            return Err(err(
                line_of(i),
                Some(&j.name),
                "`x` and `y` must be finite numbers (px)".into(),
            ));
        }
        names.push(j.name.clone());
    }
    let mut parents = Vec::with_capacity(names.len());
    let mut layers = Vec::with_capacity(names.len());
    for (i, j) in raw.joint.iter().enumerate() {
        let parent = match &j.parent {
            None => None,
            Some(p) => Some(names.iter().position(|n| n == p).ok_or_else(|| {
                err(
                    line_of(i),
                    Some(&j.name),
                    format!(
                        "parent {p:?} is not a joint of this file; known joints: {}",
                        names.join(", ")
                    ),
                )
            })?),
        };
        let layer =
            match (j.layer, parent) {
                (None, _) => 0,
                (Some(_), None) => return Err(err(
                    line_of(i),
                    Some(&j.name),
                    "`layer` belongs to the bone ending at a joint, and a root has none; remove it"
                        .into(),
                )),
                (Some(l), Some(_)) => i32::try_from(l)
                    .ok()
                    .filter(|l| l.abs() <= 1000)
                    .ok_or_else(|| {
                        err(
                            line_of(i),
                            Some(&j.name),
                            format!("`layer` must be between -1000 and 1000, found {l}"),
                        )
                    })?,
            };
        parents.push(parent);
        layers.push(layer);
    }
    let skeleton = Skeleton::new(names, parents);
    if let Some(cycle) = skeleton.find_cycle() {
        let names: Vec<&str> = cycle.iter().map(|&i| skeleton.names[i].as_str()).collect();
        return Err(err(
            line_of(cycle[0]),
            Some(names[0]),
            format!(
                "parent links form a cycle ({}); remove one `parent`",
                names.join(" -> ")
            ),
        ));
    }

    let scale = match &raw.scale {
        None => Scale::Fit,
        Some(toml::Value::String(s)) if s == "fit" => Scale::Fit,
        Some(v) => {
            let f = match v {
                toml::Value::Float(f) => Some(*f),
                toml::Value::Integer(i) => Some(*i as f64),
                _ => None,
            };
            match f {
                Some(f) if f.is_finite() && f > 0.0 && f <= 100.0 => Scale::Factor(f as f32),
                _ => {
                    return Err(err(
                        None,
                        None,
                        format!(
                            "`scale` must be \"fit\" or a number of output px per image px \
                             above 0 and at most 100, found {v}"
                        ),
                    ))
                }
            }
        }
    };
    let mesh_vertices = match raw.mesh_vertices {
        None => DEFAULT_MESH_VERTICES,
        Some(n) if (50..=5000).contains(&n) => n as usize,
        Some(n) => {
            return Err(err(
                None,
                None,
                format!("`mesh_vertices` must be 50 to 5000, found {n}"),
            ))
        }
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    let backdrop = match raw.background.as_deref() {
        None => Backdrop::Colour([255, 255, 255]),
        Some("transparent") => Backdrop::Transparent,
        Some(s) if s.starts_with('#') => Backdrop::Colour(parse_hex(s).ok_or_else(|| {
            err(
                None,
                None,
                format!("`background` {s:?} is not a colour; write \"#rrggbb\", e.g. \"#ffffff\""),
            )
        })?),
        Some(s) => {
            let p = dir.join(s);
            if !p.is_file() {
                return Err(err(
                    None,
                    None,
                    format!(
                        "`background` image {} not found; give \"#rrggbb\", \"transparent\" or \
                         an image file relative to the character file",
                        p.display()
                    ),
                ));
            }
            Backdrop::Plate(p)
        }
    };

    let image_path = dir.join(&raw.image);
    let image = load_image(&image_path, &|m| err(None, None, m))?;
    let (w, h) = image.dimensions();
    let mut rest = Vec::with_capacity(raw.joint.len());
    for (i, j) in raw.joint.iter().enumerate() {
        let (x, y) = (j.x as f32, j.y as f32);
        if !(x >= -0.5 && y >= -0.5 && x <= w as f32 - 0.5 && y <= h as f32 - 0.5) {
            return Err(err(
                line_of(i),
                Some(&j.name),
                format!(
                    "rest position ({x}, {y}) is outside the {w}×{h} image \
                     (x -0.5..{}, y -0.5..{}); place the joint on the character",
                    w as f32 - 0.5,
                    h as f32 - 0.5
                ),
            ));
        }
        if !near_opaque(&image, x, y, 3) {
            return Err(err(
                line_of(i),
                Some(&j.name),
                format!(
                    "rest position ({x}, {y}) is on a transparent part of the image (no pixel \
                     within 3 px has alpha >= {ALPHA_INSIDE}); place the joint on the character"
                ),
            ));
        }
        rest.push(Point::new(x, y));
    }
    if let Some((i, msg)) = short_bone(&skeleton, &rest) {
        return Err(err(line_of(i), Some(&skeleton.names[i]), msg));
    }
    for t in raw.map.keys() {
        if skeleton.index_of(t).is_none() {
            return Err(err(
                None,
                None,
                format!(
                    "[map] key {t:?} is not a joint of this file; keys are target joint names, \
                     values source joints (`name` or `mid(a, b)`)"
                ),
            ));
        }
    }
    let mut bones = BTreeMap::new();
    for (t, pair) in &raw.bones {
        let j = skeleton.index_of(t);
        if j.and_then(|j| skeleton.parent(j)).is_none() {
            return Err(err(
                None,
                None,
                format!(
                    "[bones] key {t:?} is not a joint of this file with a parent; keys name the \
                     joint a bone ends at"
                ),
            ));
        }
        match pair.as_slice() {
            [a, b] => {
                bones.insert(t.clone(), (a.clone(), b.clone()));
            }
            _ => {
                return Err(err(
                    None,
                    None,
                    format!(
                        "[bones] {t}: give two source joints, from and to, e.g. \
                         {t} = [\"left_shoulder\", \"left_elbow\"]"
                    ),
                ))
            }
        }
    }
    Ok(Character {
        path: path.to_owned(),
        image_path,
        image,
        skeleton,
        rest,
        layers,
        scale,
        backdrop,
        mesh_vertices,
        map: raw.map,
        bones,
        lines,
        blake3: blake3::hash(text.as_bytes()).to_hex().to_string(),
    })
}

/// Shortest bone a character may have, px at rest: a shorter one has no direction to turn.
pub const MIN_BONE_PX: f32 = 1.0;

/// The first joint whose bone (from its parent, at rest) is shorter than [`MIN_BONE_PX`], with
/// the message naming it: such a bone (a joint placed on its parent, or every joint on one
/// point) cannot show any motion.
fn short_bone(skeleton: &Skeleton, rest: &[Point]) -> Option<(usize, String)> {
    (0..rest.len()).find_map(|j| {
        let p = skeleton.parents[j]?;
        let (a, b) = (rest[p], rest[j]);
        let len = ((b.x - a.x).powi(2) + (b.y - a.y).powi(2)).sqrt();
        (len < MIN_BONE_PX).then(|| {
            (
                j,
                format!(
                    "the bone from {:?} is {len:.2} px long at rest (the joint at ({}, {})); a bone \
                     needs at least {MIN_BONE_PX} px to turn: move this joint away from its parent",
                    skeleton.names[p], b.x, b.y
                ),
            )
        })
    })
}

/// 1-based lines of the `[[joint]]` headers, in order.
fn joint_lines(text: &str) -> Vec<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| {
            let l = l.trim_start();
            l.starts_with("[[") && l[2..].trim_start().starts_with("joint")
        })
        .map(|(i, _)| i + 1)
        .collect()
}

fn parse_hex(s: &str) -> Option<[u8; 3]> {
    let h = s.strip_prefix('#')?;
    if h.len() != 6 || !h.is_ascii() {
        return None;
    }
    let c = |i: usize| u8::from_str_radix(&h[i..i + 2], 16).ok();
    Some([c(0)?, c(2)?, c(4)?])
}

#[cfg(test)]
mod tests;
