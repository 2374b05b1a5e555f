//! The captured motion as a named animation in the animator's own Spine 4.2 skeleton JSON.
//!
//! **Matching** ([`super::rig_map`]): each of their bones follows a part of the retargeted
//! character: as the user maps it (`--bone BONE=PIVOT`, `--bone-map FILE`: the joint the bone
//! turns at), else by structure (chains from the root matched between the two skeletons), else
//! when its name is one of the bundled export's bone names ([`super::spine::bone_names`]). A
//! bone following a character bone turns with it; a bone following a root joint moves with it.
//! Bones not matched keep their setup pose relative to their parent.
//! `--bone` twice for one bone is refused, and so is a mapping that names the joint at the end
//! of the bone the structure matched (the old end-joint form), with the mapping to give instead.
//! [`add_animation`] returns the mapping as lines to print and as a TOML file the user can edit
//! and pass back with `--bone-map`.
//!
//! **Keys.** Their bones keep their setup pose, lengths and attachments: the animation turns
//! them and moves the roots, nothing else. A matched bone's world rotation at frame t is its
//! setup world rotation plus the turn of its character bone since the first frame (Spine
//! degrees, counter-clockwise); its `rotate` key is that turn less the turn of its nearest matched
//! ancestor (which its parent chain passes on: a child's world rotation is its parent's plus its
//! own, for bones that inherit rotation and are not sheared or non-uniformly scaled, as rigs
//! usually are). A bone matched to a root joint gets `translate` keys: the joint's displacement
//! since the first frame, in Spine axes, scaled by the ratio of their matched bones' lengths to
//! the character's (1 when their bones have no length), turned into the parent's setup frame.
//! Keys start at time 0 and are reduced as in [`super::spine`] ([`Keys`]), with curves between
//! them ([`super::spine_keys`]).
//!
//! **IK constraints** whose bones include a matched bone would override its keys: the animation
//! keys their `mix` to 0 (their setup is untouched, other animations keep them), and says so.
//! With `keep_ik` the constraints stay and their targets get `translate` keys instead, placing
//! each target at the tip its chain reaches with the keyed rotations (the constraint's bend
//! direction is kept, so a knee bent the other way is solved its way).
//!
//! **Side view.** When their rig is drawn from the side (its left and right shoulders and hips
//! less than 0.35 of the spine's height apart) and the capture faces the camera (more than 0.5),
//! a warning says so: arms and legs then swing across the body.
//!
//! **Foot contacts** ([`super::contacts`]) become the animation's `events` (`contact_start` /
//! `contact_end`, the character's foot joint as the string), as in the bundled export. Spine
//! needs each event defined in the file's top-level `events`: a definition it lacks is added
//! (`"contact_start": {}`), one it has is left as it is, and the export says which.
//!
//! **The file.** Only the animation (and those event definitions) is written into their text:
//! `"NAME": {...}` is inserted at the start of `animations` (or replaces an animation of that
//! name; or `animations` is added at the end of the file), and every other byte of their file
//! stays as it was ([`super::splice`]).

use super::contacts::{ContactEvent, CONTACT_END, CONTACT_START};
use super::keys::Keys;
use super::rig_map::{self, Follow, RigBone};
use super::rig_pose::{read_bones, world, Bone, Ik};
use super::spine_keys;
use super::splice::splice;
use super::{round, spine, Animation};
use crate::error::{Error, Result};
use serde_json::{json, Map, Value};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

/// Below this width (left to right over the spine's height) a rig is drawn from the side.
pub const SIDE_VIEW_WIDTH: f64 = 0.35;
/// Above this width a capture faces the camera.
pub const FRONT_VIEW_WIDTH: f64 = 0.5;

/// How [`add_animation`] maps and keys.
#[derive(Debug, Clone)]
pub struct RigOptions {
    /// The animation's name.
    pub name: String,
    /// The user's mappings, in order: their bone, the mapping (`PIVOT`, `PIVOT>JOINT`, a root
    /// joint, or `""`), and where it was given (for messages: `--bone`, a file's name).
    pub given: Vec<(String, String, String)>,
    pub keys: Keys,
    /// Keep IK constraints over matched bones and move their targets (else key their mix to 0).
    pub keep_ik: bool,
    /// Foot contacts to carry as events (their definitions added to the file's `events` when
    /// it lacks them).
    pub contacts: Vec<ContactEvent>,
}

/// What [`add_animation`] made.
#[derive(Debug, Clone)]
pub struct RigAnimation {
    /// Their file's text with the animation in it.
    pub text: String,
    /// One line per matched bone (`bone = mapping (how)`), the bones left alone, the IK
    /// constraints keyed.
    pub matches: Vec<String>,
    /// The mapping as a TOML file (`[bones]`, `BONE = "MAPPING"`) for `--bone-map`.
    pub map_file: String,
    /// What the user should check (a side-view rig under a front-view capture).
    pub warnings: Vec<String>,
}

/// Adds `anim` as the animation `opts.name` to the Spine skeleton JSON `text` (read from
/// `path`, named in errors), matching their bones to the character as the module docs say.
/// Errors (exit 2) name the file or the mapping and what to fix.
pub fn add_animation(
    text: &str,
    path: &Path,
    anim: &Animation,
    opts: &RigOptions,
) -> Result<RigAnimation> {
    let err = |msg: String| Error::Usage(format!("{}: {msg}", path.display()));
    let doc: Value = serde_json::from_str(text).map_err(|e| {
        err(format!(
            "line {}: not JSON ({e}); give a Spine skeleton exported as JSON",
            e.line()
        ))
    })?;
    if let Some(v) = doc["skeleton"]["spine"].as_str() {
        if !v.starts_with("4.2") {
            return Err(err(format!(
                "a Spine {v} skeleton; export it from Spine as 4.2 JSON (this export writes 4.2 \
                 timelines)"
            )));
        }
    }
    let (bones, iks) = read_bones(&doc).map_err(err)?;
    let names = || {
        bones
            .iter()
            .map(|b| b.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };

    // Their bone -> what it follows: by structure, else by name; then as given.
    let setup = world(
        &bones,
        &vec![0.0; bones.len()],
        &vec![[0.0; 2]; bones.len()],
    );
    let mut control = vec![false; bones.len()];
    for ik in &iks {
        control[ik.target] = true;
    }
    for i in 0..bones.len() {
        if bones[i].parent.is_some_and(|p| control[p]) {
            control[i] = true;
        }
    }
    let rig: Vec<RigBone> = bones
        .iter()
        .enumerate()
        .map(|(i, b)| RigBone {
            name: b.name.clone(),
            parent: b.parent,
            length: b.length,
            base: setup[i].o,
            tip: setup[i].apply([b.length, 0.0]),
            control: control[i],
        })
        .collect();
    let structure = rig_map::structural(&rig, anim);
    let ours = spine::bone_names(anim);
    let sk = &anim.skeleton;
    let by_name = |b: &Bone| {
        ours.of_joint
            .iter()
            .position(|n| *n == b.name)
            .map(|j| match sk.parent(j) {
                None => Follow::Root(j),
                Some(_) => Follow::Segment(j),
            })
    };
    let mut follows: Vec<Option<Follow>> = Vec::with_capacity(bones.len());
    let mut how: Vec<String> = Vec::with_capacity(bones.len());
    for (i, b) in bones.iter().enumerate() {
        match (structure.follows[i], by_name(b)) {
            (Some(f), _) => {
                follows.push(Some(f));
                how.push("by structure".into());
            }
            (None, Some(f)) => {
                follows.push(Some(f));
                how.push("by name".into());
            }
            (None, None) => {
                follows.push(None);
                how.push(String::new());
            }
        }
    }
    let mut seen: HashMap<&str, (&str, &str)> = HashMap::new();
    for (bone, spec, from) in &opts.given {
        let Some(i) = bones.iter().position(|b| &b.name == bone) else {
            return Err(err(format!(
                "{from} {bone}={spec}: the skeleton has no bone {bone:?} (its bones: {})",
                names()
            )));
        };
        if let Some((spec0, from0)) = seen.insert(bone.as_str(), (spec.as_str(), from.as_str())) {
            if from0 == from {
                return Err(Error::Usage(format!(
                    "{from} given twice for bone {bone:?} ({bone}={spec0} and {bone}={spec}); \
                     give it once"
                )));
            }
        }
        // The old end-joint form: the joint at the end of the bone the structure matched.
        if let Some(Follow::Segment(e)) = structure.follows[i] {
            if !spec.contains('>') && sk.names[e] == spec.trim() {
                return Err(Error::Usage(format!(
                    "{from} {bone}={spec}: {spec} is where the bone {bone} ends; a mapping names \
                     the joint it turns at (its pivot): {bone}={}",
                    Follow::Segment(e).spec(anim)
                )));
            }
        }
        let f = rig_map::parse_spec(spec, bone, anim)
            .map_err(|m| Error::Usage(format!("{from} {m}")))?;
        follows[i] = f;
        how[i] = format!("by {from}");
    }
    if follows.iter().all(Option::is_none) {
        return Err(err(format!(
            "no bone matches a joint of the retargeted character: their bones {}; its joints {}. \
             Name the joint each bone turns at with --bone THEIR_BONE=JOINT",
            names(),
            sk.names.join(", ")
        )));
    }

    // The character's bone turns (Spine degrees) and the translation scale: their matched
    // lengths over the character's, each character bone counted once.
    let series = anim.bone_series();
    let n = anim.frames.len();
    let turn = |t: usize, j: usize| -> f64 {
        series.ending_at(j).map_or(0.0, |b| {
            -(series.angle[t][b] - series.angle[0][b]).to_degrees()
        })
    };
    let mut per_segment: BTreeMap<usize, f64> = BTreeMap::new();
    for (b, f) in bones.iter().zip(&follows) {
        if let Some(Follow::Segment(j)) = f {
            if b.length > 0.0 {
                *per_segment.entry(*j).or_default() += b.length;
            }
        }
    }
    let (mut theirs_len, mut ours_len) = (0.0, 0.0);
    for (&j, &l) in &per_segment {
        if let Some(s) = series.ending_at(j) {
            theirs_len += l;
            ours_len += series.length[0][s];
        }
    }
    let scale = if theirs_len > 1e-9 && ours_len > 1e-9 {
        theirs_len / ours_len
    } else {
        1.0
    };
    let nearest_matched_ancestor = |i: usize| -> Option<usize> {
        let mut cur = bones[i].parent;
        while let Some(p) = cur {
            if follows[p].is_some() {
                return Some(p);
            }
            cur = bones[p].parent;
        }
        None
    };

    // Every frame's local rotate offsets and translations (for the keys and for --keep-ik).
    let mut rot: Vec<Option<Vec<f64>>> = vec![None; bones.len()];
    let mut shift: Vec<Option<Vec<[f64; 2]>>> = vec![None; bones.len()];
    for (i, b) in bones.iter().enumerate() {
        match follows[i] {
            None => {}
            Some(Follow::Segment(j)) => {
                let up = match nearest_matched_ancestor(i).and_then(|a| follows[a]) {
                    Some(Follow::Segment(a)) => Some(a),
                    _ => None,
                };
                rot[i] = Some(
                    (0..n)
                        .map(|t| turn(t, j) - up.map_or(0.0, |a| turn(t, a)))
                        .collect(),
                );
            }
            Some(Follow::Root(j)) => {
                let a = -b.parent.map_or(0.0, |p| {
                    let m = setup[p].m;
                    m[2].atan2(m[0])
                });
                shift[i] = Some(
                    (0..n)
                        .map(|t| {
                            let (p, p0) = (anim.joints[t][j], anim.joints[0][j]);
                            // Spine axes: y up.
                            let (dx, dy) = (scale * (p[0] - p0[0]), -scale * (p[1] - p0[1]));
                            [a.cos() * dx - a.sin() * dy, a.sin() * dx + a.cos() * dy]
                        })
                        .collect(),
                );
            }
        }
    }

    // IK constraints over matched bones: mix 0, or their targets moved.
    let mut ik_keys = Map::new();
    let mut ik_lines = Vec::new();
    let over: Vec<&Ik> = iks
        .iter()
        .filter(|ik| ik.bones.iter().any(|&b| follows[b].is_some()))
        .collect();
    for ik in &over {
        if opts.keep_ik {
            if rot[ik.target].is_some() || shift[ik.target].is_some() {
                continue;
            }
            let last = *ik
                .bones
                .last()
                .expect("read_bones keeps constraints with bones");
            let values: Vec<Vec<f64>> = (0..n)
                .map(|t| {
                    let turn_t: Vec<f64> = rot
                        .iter()
                        .map(|r| r.as_ref().map_or(0.0, |v| v[t]))
                        .collect();
                    let shift_t: Vec<[f64; 2]> = shift
                        .iter()
                        .map(|s| s.as_ref().map_or([0.0; 2], |v| v[t]))
                        .collect();
                    let w = world(&bones, &turn_t, &shift_t);
                    let tip = w[last].apply([bones[last].length, 0.0]);
                    let tb = &bones[ik.target];
                    let local = match tb.parent {
                        None => tip,
                        Some(p) => w[p].inverse_apply(tip),
                    };
                    vec![local[0] - tb.x, local[1] - tb.y]
                })
                .collect();
            shift[ik.target] = Some(values.iter().map(|v| [v[0], v[1]]).collect());
            ik_lines.push(format!(
                "IK constraint {} kept (--keep-ik): its target {} is keyed to follow the motion",
                ik.name, bones[ik.target].name
            ));
        } else {
            let mut key = ik.fields.clone();
            key.insert("mix".into(), json!(0));
            ik_keys.insert(ik.name.clone(), json!([Value::Object(key)]));
        }
    }
    if !opts.keep_ik && !over.is_empty() {
        let list: Vec<&str> = over.iter().map(|ik| ik.name.as_str()).collect();
        ik_lines.push(format!(
            "IK constraints over mapped bones ({}): their mix is keyed to 0 in this animation, \
             so the bones follow the motion (--keep-ik keeps them and moves their targets)",
            list.join(", ")
        ));
    }

    let time = |t: usize| round((anim.frames[t] - anim.frames[0]) as f64 / anim.fps, 6);
    let mut timelines = Map::new();
    let mut map_lines = Vec::new();
    let mut alone = Vec::new();
    let mut lines = Vec::new();
    for (i, b) in bones.iter().enumerate() {
        let mut tl = Map::new();
        if let Some(values) = &rot[i] {
            let values: Vec<Vec<f64>> = values.iter().map(|&v| vec![v]).collect();
            tl.insert(
                "rotate".into(),
                spine_keys::rotate(&values, opts.keys, &time),
            );
        }
        if let Some(values) = &shift[i] {
            let values: Vec<Vec<f64>> = values.iter().map(|v| v.to_vec()).collect();
            tl.insert(
                "translate".into(),
                spine_keys::translate(&values, opts.keys, &time),
            );
        }
        match follows[i] {
            Some(f) => {
                let what = match f {
                    Follow::Root(_) => format!("translate, x{scale:.3}"),
                    Follow::Segment(_) => "rotate".into(),
                };
                let spec = f.spec(anim);
                lines.push(format!("{} = {spec} ({what}, {})", b.name, how[i]));
                map_lines.push(format!("{} = {}", quote(&b.name), quote(&spec)));
            }
            None if !control[i] => alone.push(b.name.clone()),
            None => {}
        }
        if !tl.is_empty() {
            timelines.insert(b.name.clone(), Value::Object(tl));
        }
    }
    if !alone.is_empty() {
        lines.push(format!("left in their setup pose: {}", alone.join(", ")));
    }
    lines.append(&mut ik_lines);
    let mut warnings = Vec::new();
    if let Some((theirs, capture)) = structure.widths {
        if theirs < SIDE_VIEW_WIDTH && capture > FRONT_VIEW_WIDTH {
            warnings.push(format!(
                "{} looks drawn from the side (left and right {:.2} of the spine's height apart) \
                 and the capture faces the camera ({capture:.2}): its arms and legs will swing \
                 across the body; use a front-view rig, or check the result",
                path.display(),
                theirs
            ));
        }
    }
    let mut animation = Map::new();
    animation.insert("bones".into(), Value::Object(timelines));
    if !ik_keys.is_empty() {
        animation.insert("ik".into(), Value::Object(ik_keys));
    }
    let mut text = text.to_owned();
    if !opts.contacts.is_empty() {
        let events: Vec<Value> = opts
            .contacts
            .iter()
            .map(|e| {
                let joint = &anim.skeleton.names[e.joint];
                json!({ "time": time(e.t), "name": e.name(), "string": joint })
            })
            .collect();
        animation.insert("events".into(), Value::Array(events));
        // Their file's event definitions: ours added, theirs never changed.
        let (mut added, mut theirs) = (Vec::new(), Vec::new());
        for name in [CONTACT_END, CONTACT_START] {
            if doc["events"].get(name).is_some() {
                theirs.push(name);
            } else {
                text = splice(&text, "events", &quote(name), "{}", false).map_err(err)?;
                added.push(name);
            }
        }
        let starts = opts.contacts.iter().filter(|e| e.start).count();
        let mut line = format!(
            "foot contacts: {starts} starts and {} ends as events in {}",
            opts.contacts.len() - starts,
            opts.name
        );
        if !added.is_empty() {
            added.reverse();
            line += &format!(
                "; {} added to the file's events (nothing else in it changed)",
                added.join(", ")
            );
        }
        if !theirs.is_empty() {
            line += &format!(
                "; {} already defined in the file, kept as it is",
                theirs.join(", ")
            );
        }
        lines.push(line);
    }
    // Cannot fail: plain JSON values.
    let anim_text = serde_json::to_string(&Value::Object(animation)).expect("JSON values");
    let key = serde_json::to_string(&opts.name).expect("a string");
    let text = splice(&text, "animations", &key, &anim_text, true).map_err(err)?;
    let map_file = format!(
        "# Which bone of {} follows which joint of the retargeted character (mocap2d export).\n\
         # A bone names the joint it turns at (its pivot); PIVOT>JOINT picks one of several bones\n\
         # turning at PIVOT; a root joint alone moves the bone with it; \"\" leaves the bone alone.\n\
         # Edit and pass back with --bone-map THIS_FILE (--bone BONE=PIVOT overrides a line).\n\
         [bones]\n{}\n{}",
        path.file_name().map_or("".into(), |n| n.to_string_lossy()),
        map_lines.join("\n"),
        if alone.is_empty() {
            String::new()
        } else {
            format!("# Left in their setup pose: {}\n", alone.join(", "))
        }
    );
    Ok(RigAnimation {
        text,
        matches: lines,
        map_file,
        warnings,
    })
}

/// `s` as a TOML basic string (JSON's escapes are TOML's).
fn quote(s: &str) -> String {
    // Cannot fail: a string serializes.
    serde_json::to_string(s).expect("a string")
}
