//! The captured motion as a named animation in the animator's own Spine 4.2 skeleton JSON.
//!
//! **Matching.** Each of their bones is matched to a joint of the retargeted character: by
//! `--bone THEIR_BONE=JOINT`, else when its name is the joint's Spine bone name (the joint's
//! name as an identifier, [`super::spine::bone_names`]). A bone matched to a joint with a parent
//! follows the character's bone ending at that joint (parent joint -> joint); a bone matched to
//! a root joint follows that joint's position. Bones not matched keep their setup pose relative
//! to their parent.
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
//! Keys start at time 0 and are reduced as in [`super::spine`] ([`Keys`]).
//!
//! **The file.** Only the animation is written into their text: `"NAME": {...}` is inserted at
//! the start of `animations` (or replaces an animation of that name; or `animations` is added at
//! the end of the file), and every other byte of their file stays as it was.

use super::keys::{self, Keys};
use super::{round, spine, Animation};
use crate::error::{Error, Result};
use serde_json::value::RawValue;
use serde_json::{json, Map, Value};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

/// What [`add_animation`] made.
#[derive(Debug, Clone)]
pub struct RigAnimation {
    /// Their file's text with the animation in it.
    pub text: String,
    /// One line per matched bone (`their_bone <- joint`), then the bones left alone.
    pub matches: Vec<String>,
}

/// Their bone, as read from the skeleton JSON.
struct Bone {
    name: String,
    parent: Option<usize>,
    length: f64,
    /// Setup rotation, degrees, local.
    rotation: f64,
}

/// Adds `anim` as the animation `name` to the Spine skeleton JSON `text` (read from `path`,
/// named in errors), matching their bones to the character's joints by `bone_map` (their bone
/// -> joint name) or by name. Errors (exit 2) name the file and what to fix.
pub fn add_animation(
    text: &str,
    path: &Path,
    anim: &Animation,
    name: &str,
    bone_map: &BTreeMap<String, String>,
    keys_opt: Keys,
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
    let raw_bones = doc["bones"]
        .as_array()
        .ok_or_else(|| err("no `bones` array: is this a Spine skeleton JSON?".into()))?;
    let mut bones: Vec<Bone> = Vec::with_capacity(raw_bones.len());
    for (i, b) in raw_bones.iter().enumerate() {
        let bname = b["name"]
            .as_str()
            .ok_or_else(|| err(format!("bone {i} has no name")))?;
        let parent = match b["parent"].as_str() {
            None => None,
            Some(p) => Some(bones.iter().position(|x| x.name == p).ok_or_else(|| {
                err(format!(
                    "bone {bname:?}: parent {p:?} is not listed before it; is the file from Spine?"
                ))
            })?),
        };
        bones.push(Bone {
            name: bname.to_owned(),
            parent,
            length: b["length"].as_f64().unwrap_or(0.0),
            rotation: b["rotation"].as_f64().unwrap_or(0.0),
        });
    }

    // Their bone -> joint.
    let sk = &anim.skeleton;
    let ours = spine::bone_names(anim);
    for (theirs, joint) in bone_map {
        if !bones.iter().any(|b| &b.name == theirs) {
            return Err(err(format!(
                "--bone {theirs}={joint}: the skeleton has no bone {theirs:?} (its bones: {})",
                bones
                    .iter()
                    .map(|b| b.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        if sk.index_of(joint).is_none() {
            return Err(Error::Usage(format!(
                "--bone {theirs}={joint}: the retargeted character has no joint {joint:?} (its \
                 joints: {})",
                sk.names.join(", ")
            )));
        }
    }
    let matched: Vec<Option<usize>> = bones
        .iter()
        .map(|b| match bone_map.get(&b.name) {
            Some(j) => sk.index_of(j),
            None => ours.of_joint.iter().position(|n| *n == b.name),
        })
        .collect();
    if matched.iter().all(Option::is_none) {
        return Err(err(format!(
            "no bone matches a joint of the retargeted character: their bones {}; its joints {}. \
             Name the joint of each bone with --bone THEIR_BONE=JOINT",
            bones
                .iter()
                .map(|b| b.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            sk.names.join(", ")
        )));
    }

    // The character's bone turns (Spine degrees) and the translation scale.
    let series = anim.bone_series();
    let n = anim.frames.len();
    let turn = |t: usize, j: usize| -> f64 {
        series.ending_at(j).map_or(0.0, |b| {
            -(series.angle[t][b] - series.angle[0][b]).to_degrees()
        })
    };
    let (mut theirs_len, mut ours_len) = (0.0, 0.0);
    for (b, m) in bones.iter().zip(&matched) {
        if let Some(l) = m.and_then(|j| series.ending_at(j)) {
            if b.length > 0.0 {
                theirs_len += b.length;
                ours_len += series.length[0][l];
            }
        }
    }
    let scale = if theirs_len > 1e-9 && ours_len > 1e-9 {
        theirs_len / ours_len
    } else {
        1.0
    };
    // Setup world rotations (degrees).
    let mut world = vec![0.0f64; bones.len()];
    for i in 0..bones.len() {
        world[i] = bones[i].parent.map_or(0.0, |p| world[p]) + bones[i].rotation;
    }
    let nearest_matched_ancestor = |i: usize| -> Option<usize> {
        let mut cur = bones[i].parent;
        while let Some(p) = cur {
            if matched[p].is_some() {
                return Some(p);
            }
            cur = bones[p].parent;
        }
        None
    };

    let time = |t: usize| round((anim.frames[t] - anim.frames[0]) as f64 / anim.fps, 6);
    let tol = keys_opt.tolerance();
    let mut timelines = Map::new();
    let mut lines = Vec::new();
    let mut alone = Vec::new();
    for (i, b) in bones.iter().enumerate() {
        let Some(j) = matched[i] else {
            alone.push(b.name.clone());
            continue;
        };
        let mut tl = Map::new();
        match sk.parent(j) {
            Some(_) => {
                let up = nearest_matched_ancestor(i)
                    .and_then(|a| matched[a])
                    .filter(|&a| sk.parent(a).is_some());
                let values: Vec<Vec<f64>> = (0..n)
                    .map(|t| vec![turn(t, j) - up.map_or(0.0, |a| turn(t, a))])
                    .collect();
                let k: Vec<Value> = keys::reduce(&values, tol, Some(180.0))
                    .into_iter()
                    .map(|t| json!({ "time": time(t), "value": round(values[t][0], 5) }))
                    .collect();
                tl.insert("rotate".into(), Value::Array(k));
                lines.push(format!(
                    "{} <- {} -> {} (rotate)",
                    b.name,
                    sk.names[sk.parent(j).unwrap_or(j)],
                    sk.names[j]
                ));
            }
            None => {
                let a = -b.parent.map_or(0.0, |p| world[p]).to_radians();
                let values: Vec<Vec<f64>> = (0..n)
                    .map(|t| {
                        let (p, p0) = (anim.joints[t][j], anim.joints[0][j]);
                        // Spine axes: y up.
                        let (dx, dy) = (scale * (p[0] - p0[0]), -scale * (p[1] - p0[1]));
                        vec![a.cos() * dx - a.sin() * dy, a.sin() * dx + a.cos() * dy]
                    })
                    .collect();
                tl.insert(
                    "translate".into(),
                    spine::translate_keys(&values, tol, &time),
                );
                lines.push(format!(
                    "{} <- {} (translate, x{:.3})",
                    b.name, sk.names[j], scale
                ));
            }
        }
        timelines.insert(b.name.clone(), Value::Object(tl));
    }
    if !alone.is_empty() {
        lines.push(format!("left in their setup pose: {}", alone.join(", ")));
    }
    let animation = json!({ "bones": timelines });
    // Cannot fail: plain JSON values.
    let anim_text = serde_json::to_string(&animation).expect("JSON values");
    let key = serde_json::to_string(name).expect("a string");
    Ok(RigAnimation {
        text: splice(text, &key, &anim_text).map_err(err)?,
        matches: lines,
    })
}

/// Byte offset of `inner` (a slice of `outer`) in `outer`.
fn offset_in(outer: &str, inner: &str) -> usize {
    inner.as_ptr() as usize - outer.as_ptr() as usize
}

/// `text` (a JSON object) with `key: value` (both JSON text) as the first entry of its
/// `animations` object, replacing an entry of that key, or with `animations` added last.
fn splice(text: &str, key: &str, value: &str) -> std::result::Result<String, String> {
    let top: HashMap<String, &RawValue> =
        serde_json::from_str(text).map_err(|e| format!("not a JSON object: {e}"))?;
    let name: String = serde_json::from_str(key).map_err(|e| e.to_string())?;
    let Some(raw) = top.get("animations") else {
        // Before the top object's closing brace.
        let close = text.rfind('}').ok_or("does not end in '}'")?;
        let body = text[..close].trim_end();
        let sep = if body.ends_with('{') { "" } else { "," };
        return Ok(format!(
            "{body}{sep}\"animations\":{{{key}:{value}}}{}",
            &text[body.len()..]
        ));
    };
    let anims_text = raw.get();
    let at = offset_in(text, anims_text);
    let entries: HashMap<String, &RawValue> = serde_json::from_str(anims_text)
        .map_err(|_| "`animations` is not an object".to_string())?;
    if let Some(old) = entries.get(&name) {
        let (s, e) = (offset_in(text, old.get()), old.get().len());
        return Ok(format!("{}{value}{}", &text[..s], &text[s + e..]));
    }
    // Just after the opening brace.
    let brace = at
        + anims_text
            .find('{')
            .ok_or("`animations` is not an object")?
        + 1;
    let sep = if entries.is_empty() { "" } else { "," };
    Ok(format!(
        "{}{key}:{value}{sep}{}",
        &text[..brace],
        &text[brace..]
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splice_keeps_every_other_byte() {
        let text =
            "{\n  \"bones\": [{\"name\": \"a\"}],\n  \"animations\": {\n    \"idle\": {}\n  }\n}\n";
        let out = splice(text, "\"mocap\"", "{\"bones\":{}}").unwrap();
        assert_eq!(
            out,
            "{\n  \"bones\": [{\"name\": \"a\"}],\n  \"animations\": {\"mocap\":{\"bones\":{}},\n    \"idle\": {}\n  }\n}\n"
        );
        // The same name again: replaced, not added.
        let again = splice(&out, "\"mocap\"", "{}").unwrap();
        assert_eq!(again, out.replace("{\"bones\":{}}", "{}"));
        // No animations: added last.
        let out = splice("{\"bones\": []}\n", "\"m\"", "{}").unwrap();
        assert_eq!(out, "{\"bones\": [],\"animations\":{\"m\":{}}}\n");
        let v: Value = serde_json::from_str(&out).unwrap();
        assert!(v["animations"]["m"].is_object());
        // Empty animations.
        let out = splice("{\"animations\": { }}", "\"m\"", "1").unwrap();
        assert_eq!(out, "{\"animations\": {\"m\":1 }}");
    }
}
