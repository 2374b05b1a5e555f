//! Foot contacts as animation events: `mocap2d retarget` writes `RUN/retarget/contacts.csv`
//! (columns `frame,joint,contact`: the character's foot joint, 1 while it is planted, 0 when
//! not; docs/formats.md); the Spine and DragonBones exports carry each contact's start and end
//! as an event, so a game can play a footstep or plant a foot.
//!
//! **Events.** [`CONTACT_START`] on the first frame of each run of 1s of a joint (also on the
//! animation's first frame when the foot is planted there), [`CONTACT_END`] on the first frame of
//! each run of 0s that follows a run of 1s; each event's string is the joint's name. Events come
//! sorted by frame, then joint order, then end before start.

use crate::error::{Error, Result};
use crate::skeleton::Skeleton;
use std::path::Path;

/// The event a contact's first frame carries.
pub const CONTACT_START: &str = "contact_start";
/// The event the first frame after a contact carries.
pub const CONTACT_END: &str = "contact_end";

/// One contact event.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ContactEvent {
    /// Index into the animation's frames (0 = its first frame).
    pub t: usize,
    /// The foot joint's index in the animation's skeleton.
    pub joint: usize,
    /// True for [`CONTACT_START`], false for [`CONTACT_END`].
    pub start: bool,
}

impl ContactEvent {
    /// The event's name ([`CONTACT_START`] or [`CONTACT_END`]).
    pub fn name(&self) -> &'static str {
        if self.start {
            CONTACT_START
        } else {
            CONTACT_END
        }
    }
}

#[derive(serde::Deserialize)]
struct Row {
    frame: u64,
    joint: String,
    contact: u8,
}

/// The contact events of `path` (a `contacts.csv`) over the animation's `frames` (consecutive),
/// joints named as in `skeleton`. Errors (exit 2) name the file and line.
pub fn read_contacts(
    path: &Path,
    skeleton: &Skeleton,
    frames: &[u64],
) -> Result<Vec<ContactEvent>> {
    let err = |msg: String| Error::RunFolder {
        path: path.to_owned(),
        msg: format!("{msg}; run `mocap2d retarget` again to rewrite it"),
    };
    let mut rdr = csv::Reader::from_path(path).map_err(|e| err(format!("cannot read it ({e})")))?;
    let (first, last) = match (frames.first(), frames.last()) {
        (Some(&a), Some(&b)) => (a, b),
        _ => return Ok(Vec::new()),
    };
    // [joint][t]: the contact flag, None where the file says nothing.
    let mut flags: Vec<Vec<Option<bool>>> = vec![vec![None; frames.len()]; skeleton.len()];
    for (i, row) in rdr.deserialize::<Row>().enumerate() {
        let line = i + 2;
        let row =
            row.map_err(|e| err(format!("line {line}: {e} (expected frame,joint,contact)")))?;
        let j = skeleton.index_of(&row.joint).ok_or_else(|| {
            err(format!(
                "line {line}: joint {:?} is not a joint of the retargeted character ({})",
                row.joint,
                skeleton.names.join(", ")
            ))
        })?;
        if row.frame < first || row.frame > last {
            return Err(err(format!(
                "line {line}: frame {} is outside pose.csv's frames {first}-{last}",
                row.frame
            )));
        }
        if row.contact > 1 {
            return Err(err(format!(
                "line {line}: contact {} (expected 0 or 1)",
                row.contact
            )));
        }
        flags[j][(row.frame - first) as usize] = Some(row.contact == 1);
    }
    Ok(events(&flags))
}

/// The events of `flags` (`[joint][t]`, `None` = unknown: neither starts nor ends a contact).
pub fn events(flags: &[Vec<Option<bool>>]) -> Vec<ContactEvent> {
    let mut out = Vec::new();
    for (joint, f) in flags.iter().enumerate() {
        let mut down = false;
        for (t, v) in f.iter().enumerate() {
            match *v {
                Some(true) if !down => {
                    out.push(ContactEvent {
                        t,
                        joint,
                        start: true,
                    });
                    down = true;
                }
                Some(false) if down => {
                    out.push(ContactEvent {
                        t,
                        joint,
                        start: false,
                    });
                    down = false;
                }
                _ => {}
            }
        }
    }
    out.sort_by_key(|e| (e.t, e.joint, e.start));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn starts_and_ends_where_the_flag_changes() {
        let f = |s: &str| -> Vec<Option<bool>> {
            s.chars()
                .map(|c| match c {
                    '1' => Some(true),
                    '0' => Some(false),
                    _ => None,
                })
                .collect()
        };
        let ev = events(&[f("1100110"), f("0011.00")]);
        let got: Vec<(usize, usize, bool)> = ev.iter().map(|e| (e.t, e.joint, e.start)).collect();
        assert_eq!(
            got,
            vec![
                (0, 0, true),
                (2, 0, false),
                (2, 1, true),
                (4, 0, true),
                (5, 1, false),
                (6, 0, false)
            ]
        );
        assert_eq!(ev[0].name(), "contact_start");
        assert_eq!(ev[1].name(), "contact_end");
    }

    #[test]
    fn bad_rows_name_the_line() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("contacts.csv");
        let sk = Skeleton::new(vec!["hip".into(), "ankle".into()], vec![None, Some(0)]);
        for (text, needle) in [
            ("frame,joint,contact\n3,toe,1\n", "line 2: joint \"toe\""),
            (
                "frame,joint,contact\n3,ankle,1\n9,ankle,0\n",
                "line 3: frame 9",
            ),
            ("frame,joint,contact\n3,ankle,2\n", "contact 2"),
            ("frame,joint\n3,ankle\n", "line 2"),
        ] {
            std::fs::write(&p, text).unwrap();
            let e = read_contacts(&p, &sk, &[3, 4, 5]).unwrap_err().to_string();
            assert!(e.contains(needle) && e.contains("contacts.csv"), "{e}");
        }
        std::fs::write(&p, "frame,joint,contact\n3,ankle,0\n4,ankle,1\n5,ankle,1\n").unwrap();
        let ev = read_contacts(&p, &sk, &[3, 4, 5]).unwrap();
        assert_eq!(
            ev,
            vec![ContactEvent {
                t: 1,
                joint: 1,
                start: true
            }]
        );
    }
}
