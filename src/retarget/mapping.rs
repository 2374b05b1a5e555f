//! Which source joints drive which target bone: bone mapping, not renaming.
//!
//! A target bone `parent -> child` is driven by a *source bone*: a pair of source points, each a
//! source joint or a virtual joint, the midpoint of two (`mid(left_hip, right_hip)`). The bone
//! takes that pair's changes of angle and length ([`super::retarget`]); a target bone with no
//! source keeps its rest angle relative to its parent bone (and its rest length); source joints
//! that drive nothing are ignored. Each target root follows a source point too (by default its
//! own; failing that, the mean of all source joints).
//!
//! The drivers, for each target bone, first match wins:
//! 1. the character file's `[bones]` entry for the bone's child joint: `elbow_l = ["left_shoulder",
//!    "left_elbow"]`;
//! 2. the source points of the bone's two joints when both are named: the same name in the run,
//!    or the character's `[map]` (`pelvis = "mid(left_hip, right_hip)"`);
//! 3. recognised body parts ([`recognise`]): the COCO 17 keypoint names (`nose`, `left_eye`, ...,
//!    `right_ankle`) and their variants (`elbow_l`, `l_elbow`, `LeftElbow`, `elbow.L`, `hand` for
//!    wrist, `foot` for ankle, ...), and `pelvis`, `chest`, `neck`, `head`, `toe`. A recognised
//!    joint is driven along its anatomical bone (an elbow from the shoulder, a knee from the hip,
//!    the chest from the pelvis, the head from the neck), with virtual joints where the source
//!    lacks one (pelvis = mid(left_hip, right_hip), chest and neck = mid(left_shoulder,
//!    right_shoulder), head = the nose, or mid(ears), or mid(eyes)).
//!
//! A pair whose two points are the same (chest and neck both at the shoulders' midpoint) drives
//! nothing. A head (or face point) driven through recognised names takes its source bone's
//! angle only and keeps its rest length: the distance from the shoulders to the nose changes as
//! the head turns or the subject turns her back, not as the head grows.

use crate::character::Character;
use crate::error::{Error, Result};
use crate::skeleton::Skeleton;
use std::path::Path;

use super::P64;

/// A source point: the mean of these source joints (one: the joint itself; two: their midpoint).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SourcePoint(pub Vec<usize>);

impl SourcePoint {
    /// Its position in a frame of source joints.
    pub fn at(&self, frame: &[P64]) -> P64 {
        let n = self.0.len().max(1) as f64;
        let (x, y) = self
            .0
            .iter()
            .fold((0.0, 0.0), |(x, y), &j| (x + frame[j][0], y + frame[j][1]));
        [x / n, y / n]
    }

    /// As the character file writes it: `name`, `mid(a, b)`, or the mean of all joints.
    pub fn describe(&self, source: &Skeleton) -> String {
        match self.0.as_slice() {
            [j] => source.names[*j].clone(),
            [a, b] => format!("mid({}, {})", source.names[*a], source.names[*b]),
            _ => "the mean of all source joints".into(),
        }
    }
}

/// The drivers of a target skeleton.
#[derive(Debug, Clone, PartialEq)]
pub struct Mapping {
    /// `[target bone]` (in `target.bones()` order): the source points the bone runs between, or
    /// `None`: it keeps its rest angle relative to its parent bone.
    pub bone: Vec<Option<(SourcePoint, SourcePoint)>>,
    /// `[target joint]`: the source point a root follows (`None` for non-roots).
    pub root: Vec<Option<SourcePoint>>,
    /// `[target bone]`: true when the bone takes only its source bone's angle and keeps its
    /// rest length (a head driven through face keypoints, whose distance from the shoulders
    /// changes as the head turns, not as it grows).
    pub keep_length: Vec<bool>,
}

impl Mapping {
    /// Every bone driven by the same-named source bone: for a target that is the source skeleton.
    pub fn identity(skeleton: &Skeleton) -> Mapping {
        Mapping {
            bone: skeleton
                .bones()
                .iter()
                .map(|&(p, c)| Some((SourcePoint(vec![p]), SourcePoint(vec![c]))))
                .collect(),
            root: (0..skeleton.len())
                .map(|j| skeleton.parent(j).is_none().then(|| SourcePoint(vec![j])))
                .collect(),
            keep_length: vec![false; skeleton.bones().len()],
        }
    }

    /// One line per target bone and root, saying what drives it; then the ignored source joints.
    pub fn describe(&self, target: &Skeleton, source: &Skeleton) -> Vec<String> {
        let mut lines = Vec::new();
        let bones = target.bones();
        for j in target.topo_order() {
            match (target.parent(j), &self.root[j]) {
                (None, Some(s)) => lines.push(format!(
                    "{} (root) follows {}",
                    target.names[j],
                    s.describe(source)
                )),
                (None, None) => {}
                (Some(p), _) => {
                    // Cannot fail: `j` has a parent, so a bone ends at it.
                    let b = bones.iter().position(|&(_, c)| c == j).expect("bone");
                    let what = match &self.bone[b] {
                        Some((a, z)) if self.keep_length[b] => format!(
                            "{} -> {} (angle only)",
                            a.describe(source),
                            z.describe(source)
                        ),
                        Some((a, z)) => {
                            format!("{} -> {}", a.describe(source), z.describe(source))
                        }
                        None => match target.parent(p) {
                            Some(pp) => format!(
                                "nothing: keeps its rest angle to {} -> {}",
                                target.names[pp], target.names[p]
                            ),
                            None => "nothing: keeps its rest angle".into(),
                        },
                    };
                    lines.push(format!(
                        "{} -> {} <- {what}",
                        target.names[p], target.names[j]
                    ));
                }
            }
        }
        let used: Vec<usize> = self
            .bone
            .iter()
            .flatten()
            .flat_map(|(a, b)| a.0.iter().chain(&b.0).copied())
            .collect();
        let ignored: Vec<&str> = (0..source.len())
            .filter(|j| !used.contains(j))
            .map(|j| source.names[j].as_str())
            .collect();
        if !ignored.is_empty() {
            lines.push(format!(
                "source joints driving no bone: {}",
                ignored.join(", ")
            ));
        }
        lines
    }

    /// Number of driven bones.
    pub fn driven(&self) -> usize {
        self.bone.iter().flatten().count()
    }
}

/// Left or right (the body's own).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Left,
    Right,
}

/// A body part mocap2d recognises in a joint name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    Nose,
    Eye(Side),
    Ear(Side),
    Shoulder(Side),
    Elbow(Side),
    Wrist(Side),
    Hip(Side),
    Knee(Side),
    Ankle(Side),
    Toe(Side),
    Pelvis,
    Chest,
    Neck,
    Head,
}

/// The body part a joint name means, if mocap2d recognises it: the COCO keypoint names and their
/// variants. The name is split into words at `_`, `.`, `-`, spaces and lower-to-upper case
/// changes; `left`/`l` and `right`/`r` give the side.
pub fn recognise(name: &str) -> Option<Part> {
    let mut words: Vec<String> = Vec::new();
    let mut cur = String::new();
    let mut prev_lower = false;
    for c in name.chars() {
        if !c.is_ascii_alphanumeric() {
            if !cur.is_empty() {
                words.push(std::mem::take(&mut cur));
            }
            prev_lower = false;
            continue;
        }
        if c.is_ascii_uppercase() && prev_lower && !cur.is_empty() {
            words.push(std::mem::take(&mut cur));
        }
        prev_lower = c.is_ascii_lowercase() || c.is_ascii_digit();
        cur.push(c.to_ascii_lowercase());
    }
    if !cur.is_empty() {
        words.push(cur);
    }
    let mut side = None;
    let mut rest: Vec<&str> = Vec::new();
    for w in &words {
        match w.as_str() {
            "left" | "l" => side = Some(Side::Left),
            "right" | "r" => side = Some(Side::Right),
            w => rest.push(w),
        }
    }
    let word = rest.concat();
    let sided = |f: fn(Side) -> Part| side.map(f);
    match word.as_str() {
        "nose" => Some(Part::Nose),
        "eye" => sided(Part::Eye),
        "ear" => sided(Part::Ear),
        "shoulder" => sided(Part::Shoulder),
        "elbow" => sided(Part::Elbow),
        "wrist" | "hand" => sided(Part::Wrist),
        "hip" if side.is_some() => sided(Part::Hip),
        "knee" => sided(Part::Knee),
        "ankle" | "foot" => sided(Part::Ankle),
        "toe" | "toes" | "bigtoe" => sided(Part::Toe),
        "pelvis" | "hip" | "hips" | "midhip" | "root" => Some(Part::Pelvis),
        "chest" | "thorax" | "torso" | "upperchest" => Some(Part::Chest),
        "neck" => Some(Part::Neck),
        "head" | "headtop" | "tophead" => Some(Part::Head),
        _ => None,
    }
}

impl std::fmt::Display for Part {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use Part::*;
        let side = |s: &Side| match s {
            Side::Left => "left",
            Side::Right => "right",
        };
        match self {
            Nose => write!(f, "nose"),
            Pelvis => write!(f, "pelvis"),
            Chest => write!(f, "chest"),
            Neck => write!(f, "neck"),
            Head => write!(f, "head"),
            Eye(s) => write!(f, "{} eye", side(s)),
            Ear(s) => write!(f, "{} ear", side(s)),
            Shoulder(s) => write!(f, "{} shoulder", side(s)),
            Elbow(s) => write!(f, "{} elbow", side(s)),
            Wrist(s) => write!(f, "{} wrist", side(s)),
            Hip(s) => write!(f, "{} hip", side(s)),
            Knee(s) => write!(f, "{} knee", side(s)),
            Ankle(s) => write!(f, "{} ankle", side(s)),
            Toe(s) => write!(f, "{} toe", side(s)),
        }
    }
}

impl Part {
    /// The part its anatomical bone starts at (the elbow's is the shoulder).
    fn anatomical_parent(self) -> Option<Part> {
        use Part::*;
        Some(match self {
            Pelvis => return None,
            Chest => Pelvis,
            Neck => Chest,
            Head | Nose => Neck,
            Eye(_) => Nose,
            Ear(s) => Eye(s),
            Shoulder(_) => Chest,
            Elbow(s) => Shoulder(s),
            Wrist(s) => Elbow(s),
            Hip(_) => Pelvis,
            Knee(s) => Hip(s),
            Ankle(s) => Knee(s),
            Toe(s) => Ankle(s),
        })
    }
}

/// The source point of `part` in a source whose joints are the parts `parts`: the joint itself,
/// or a virtual one standing in for it (see the module docs).
fn find(part: Part, parts: &[Option<Part>]) -> Option<SourcePoint> {
    use Part::*;
    use Side::*;
    let direct = |p: Part| parts.iter().position(|&q| q == Some(p));
    let one = |p: Part| direct(p).map(|j| SourcePoint(vec![j]));
    let mid = |a: Part, b: Part| Some(SourcePoint(vec![direct(a)?, direct(b)?]));
    if let Some(s) = one(part) {
        return Some(s);
    }
    match part {
        Pelvis => mid(Hip(Left), Hip(Right)),
        Chest => mid(Shoulder(Left), Shoulder(Right)).or_else(|| one(Neck)),
        Neck => mid(Shoulder(Left), Shoulder(Right)).or_else(|| one(Chest)),
        Head => one(Nose)
            .or_else(|| mid(Ear(Left), Ear(Right)))
            .or_else(|| mid(Eye(Left), Eye(Right))),
        Nose => one(Head),
        Shoulder(_) => one(Chest).or_else(|| one(Neck)),
        Hip(_) => one(Pelvis),
        _ => None,
    }
}

/// Parses a source point as the character file writes it: a source joint's name or
/// `mid(a, b)`; `Err` says what is wrong.
fn parse_point(text: &str, source: &Skeleton) -> std::result::Result<SourcePoint, String> {
    let t = text.trim();
    let joint = |n: &str| {
        source.index_of(n.trim()).ok_or_else(|| {
            format!(
                "the run has no joint {:?} (its joints: {})",
                n.trim(),
                source.names.join(", ")
            )
        })
    };
    if let Some(inner) = t.strip_prefix("mid(").and_then(|r| r.strip_suffix(')')) {
        let (a, b) = inner
            .split_once(',')
            .ok_or_else(|| format!("{t:?}: write mid(JOINT_A, JOINT_B)"))?;
        return Ok(SourcePoint(vec![joint(a)?, joint(b)?]));
    }
    Ok(SourcePoint(vec![joint(t)?]))
}

/// The drivers of `character`'s bones in the run whose skeleton is `source` (read from
/// `source_path`, named in messages). Errors (exit 2) name the character file, the line or key,
/// and the fix: a `[map]` or `[bones]` entry naming no source joint, or no bone driven at all.
pub fn build(character: &Character, source: &Skeleton, source_path: &Path) -> Result<Mapping> {
    let target = &character.skeleton;
    let err = |joint: Option<usize>, msg: String| Error::Character {
        path: character.path.clone(),
        line: joint.and_then(|j| character.lines.get(j).copied()),
        joint: joint.map(|j| target.names[j].clone()),
        msg,
    };
    let source_parts: Vec<Option<Part>> = source.names.iter().map(|n| recognise(n)).collect();
    // Each target joint's own source point: [map], else the same name, else its part.
    let mut named: Vec<Option<SourcePoint>> = Vec::with_capacity(target.len());
    let mut own: Vec<Option<SourcePoint>> = Vec::with_capacity(target.len());
    for (j, name) in target.names.iter().enumerate() {
        let n = match character.map.get(name) {
            Some(text) => Some(parse_point(text, source).map_err(|m| {
                err(
                    Some(j),
                    format!("[map] {name} = {text:?}: {m}; fix the entry or remove it"),
                )
            })?),
            None => source.index_of(name).map(|s| SourcePoint(vec![s])),
        };
        own.push(
            n.clone()
                .or_else(|| recognise(name).and_then(|p| find(p, &source_parts))),
        );
        named.push(n);
    }
    let bones = target.bones();
    let mut bone = Vec::with_capacity(bones.len());
    let mut keep_length = Vec::with_capacity(bones.len());
    for &(p, c) in &bones {
        let mut recognised = false;
        let cname = &target.names[c];
        let pair = if let Some((a, b)) = character.bones.get(cname) {
            let parse = |t: &str| {
                parse_point(t, source).map_err(|m| {
                    err(
                        Some(c),
                        format!(
                            "[bones] {cname} = [{a:?}, {b:?}]: {m}; fix the entry or remove it"
                        ),
                    )
                })
            };
            Some((parse(a)?, parse(b)?))
        } else if let (Some(a), Some(b)) = (&named[p], &named[c]) {
            Some((a.clone(), b.clone()))
        } else {
            recognised = true;
            let anatomical = recognise(cname)
                .and_then(Part::anatomical_parent)
                .and_then(|a| find(a, &source_parts));
            let end = own[c].clone();
            match (anatomical, end) {
                (Some(a), Some(b)) if a != b => Some((a, b)),
                (_, Some(b)) => own[p].clone().map(|a| (a, b)),
                _ => None,
            }
        };
        let pair = pair.filter(|(a, b)| a != b);
        // A head (or face point) reached through recognised names: its source is a face
        // keypoint, whose distance from the neck or shoulders says how the head turns, not how
        // long it is.
        let face = matches!(
            recognise(cname),
            Some(Part::Head | Part::Nose | Part::Eye(_) | Part::Ear(_))
        );
        keep_length.push(recognised && face && pair.is_some());
        bone.push(pair);
    }
    let all = SourcePoint((0..source.len()).collect());
    let root = (0..target.len())
        .map(|j| {
            target
                .parent(j)
                .is_none()
                .then(|| own[j].clone().unwrap_or_else(|| all.clone()))
        })
        .collect();
    let mapping = Mapping {
        bone,
        root,
        keep_length,
    };
    if mapping.driven() == 0 {
        return Err(err(
            None,
            format!(
                "no bone of this character is driven by a joint of the run ({}): target joints \
                 {}; source joints {}. Name the source of each target joint under [map] (e.g. \
                 `pelvis = \"mid(left_hip, right_hip)\"`), or of each bone under [bones] (e.g. \
                 `elbow_l = [\"left_shoulder\", \"left_elbow\"]`); COCO keypoint names and \
                 left_*/right_*, *_l/*_r variants are recognised without them",
                source_path.display(),
                target.names.join(", "),
                source.names.join(", ")
            ),
        ));
    }
    Ok(mapping)
}

#[cfg(test)]
mod tests {
    use super::*;
    use Part::*;
    use Side::*;

    #[test]
    fn coco_names_and_variants_are_recognised() {
        for (name, part) in [
            ("left_elbow", Some(Elbow(Left))),
            ("elbow_l", Some(Elbow(Left))),
            ("l_elbow", Some(Elbow(Left))),
            ("LeftElbow", Some(Elbow(Left))),
            ("elbow.R", Some(Elbow(Right))),
            ("right-hand", Some(Wrist(Right))),
            ("left_hip", Some(Hip(Left))),
            ("hip", Some(Pelvis)),
            ("MidHip", Some(Pelvis)),
            ("nose", Some(Nose)),
            ("right_ear", Some(Ear(Right))),
            ("toe_r", Some(Toe(Right))),
            ("head", Some(Head)),
            ("elbow", None),
            ("tail", None),
        ] {
            assert_eq!(recognise(name), part, "{name}");
        }
    }

    fn sk(names: &[&str], parents: &[Option<usize>]) -> Skeleton {
        Skeleton::new(
            names.iter().map(|s| s.to_string()).collect(),
            parents.to_vec(),
        )
    }

    #[test]
    fn virtual_joints_stand_in_for_missing_ones() {
        let coco = sk(
            &[
                "left_hip",
                "right_hip",
                "left_shoulder",
                "right_shoulder",
                "nose",
                "left_elbow",
            ],
            &[None, Some(0), Some(0), Some(1), Some(2), Some(2)],
        );
        let parts: Vec<Option<Part>> = coco.names.iter().map(|n| recognise(n)).collect();
        assert_eq!(find(Pelvis, &parts), Some(SourcePoint(vec![0, 1])));
        assert_eq!(find(Chest, &parts), Some(SourcePoint(vec![2, 3])));
        assert_eq!(find(Head, &parts), Some(SourcePoint(vec![4])));
        assert_eq!(find(Toe(Left), &parts), None);
        let p = SourcePoint(vec![0, 1]);
        assert_eq!(p.at(&[[0.0, 0.0], [4.0, 2.0]]), [2.0, 1.0]);
        assert_eq!(p.describe(&coco), "mid(left_hip, right_hip)");
        assert_eq!(
            parse_point(" mid(left_hip , right_hip)", &coco),
            Ok(SourcePoint(vec![0, 1]))
        );
        assert!(parse_point("mid(left_hip)", &coco).is_err());
        assert!(parse_point("pelvis", &coco)
            .unwrap_err()
            .contains("no joint \"pelvis\""));
    }
}
