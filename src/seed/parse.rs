//! The seed-file parser: TOML syntax, top-level keys and the skeleton the parent links make,
//! each problem named by line and joint ([`super::parse_seeds`]). Each `[[joint]]` table is read
//! in `super::joint`.

use super::hints::*;
use super::*;
use toml::de::{DeString, DeTable, DeValue};
use toml::Spanned;

pub(super) type Entry<'a, 'i> = (&'a Spanned<DeString<'i>>, &'a Spanned<DeValue<'i>>);

/// A joint as read, before parent links are resolved.
pub(super) struct RawJoint {
    pub(super) joint: SeedJoint,
    pub(super) parent_line: usize,
}

pub(super) struct Parser<'t> {
    pub(super) text: &'t str,
    pub(super) path: &'t Path,
    /// Byte offsets of the text's line breaks, so a line number is a binary search (a file of
    /// 10 000 joints asks for tens of thousands).
    pub(super) newlines: Vec<usize>,
}

impl<'t> Parser<'t> {
    /// 1-based line holding byte `offset` of the text.
    pub(super) fn line(&self, offset: usize) -> usize {
        self.newlines.partition_point(|&nl| nl < offset) + 1
    }

    pub(super) fn err(
        &self,
        line: Option<usize>,
        joint: Option<&str>,
        msg: impl Into<String>,
    ) -> Error {
        Error::Seed {
            path: self.path.to_path_buf(),
            line,
            joint: joint.map(str::to_owned),
            msg: msg.into(),
        }
    }

    pub(super) fn src(&self, span: std::ops::Range<usize>) -> &'t str {
        self.text.get(span).unwrap_or("")
    }

    /// "found float 1.5" for a value of the wrong type.
    pub(super) fn found(&self, v: &Spanned<DeValue<'_>>) -> String {
        let kind = match v.get_ref() {
            DeValue::Table(_) => return "found a table".into(),
            DeValue::Array(_) => return "found an array".into(),
            other => other.type_str(),
        };
        format!("found {kind} {}", excerpt(self.src(v.span())))
    }

    pub(super) fn parse(&self) -> Result<Seeds> {
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

    pub(super) fn syntax_error(&self, e: &toml::de::Error) -> Error {
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

    pub(super) fn frame(&self, v: &Spanned<DeValue<'_>>, line: Option<usize>) -> Result<u64> {
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

    /// Resolves parent names into a [`Skeleton`], rejecting unknown parents and cycles.
    pub(super) fn skeleton(&self, raw: &[RawJoint]) -> Result<Skeleton> {
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
