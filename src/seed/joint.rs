//! Reading one `[[joint]]` table of a seed file: its keys, their types and ranges.

use super::hints::*;
use super::parse::{Entry, Parser, RawJoint};
use super::*;
use toml::de::DeValue;
use toml::Spanned;

impl<'t> Parser<'t> {
    /// Reads the `n`-th (0-based) `[[joint]]` table; `earlier` are the joints before it.
    pub(super) fn joint(
        &self,
        n: usize,
        t: &Spanned<DeValue<'_>>,
        earlier: &[RawJoint],
    ) -> Result<RawJoint> {
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
    pub(super) fn number(&self, e: Entry<'_, '_>, what: &str, joint: &str) -> Result<f32> {
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
}
