//! DeepLabCut CSV files read as seeds (`mocap2d track --seeds-from-dlc FILE --seed-frame N`);
//! the file format is [`super::dlc_csv`].
//!
//! The labels of the seed frame become `size`-px square rectangles. **Parents**: the CSV has no
//! skeleton. `--skeleton FILE` gives one: a TOML file of `[[joint]]` tables with `name` and
//! `parent` (a seed file works: its other keys are ignored); joints it does not name stay roots.
//! Without it, the joints are linked as a chain in column order (each individual its own chain),
//! as DeepLabCut projects usually list bodyparts along the body, and the command says so.

pub use super::dlc_csv::{parse_dlc_csv, read_dlc_csv, DlcRow, DlcTable};
use super::{parse_seeds, to_toml, SeedJoint, Seeds, MIN_BOX_PX};
use crate::error::{Error, Result};
use crate::geom::JointBox;
use crate::skeleton::Skeleton;
use std::path::{Path, PathBuf};

/// Default seed rectangle side (px) for joints read from a DeepLabCut CSV.
pub const DEFAULT_SEED_SIZE: u32 = 15;

/// How to make seeds from a DeepLabCut CSV.
#[derive(Debug, Clone, PartialEq)]
pub struct DlcSeedOptions {
    /// The frame whose labels become the seeds.
    pub frame: u64,
    /// Rectangle side, px.
    pub size: u32,
    /// Parent links (TOML `[[joint]]` tables with `name` and `parent`).
    pub skeleton: Option<PathBuf>,
}

/// Seeds from the labels of frame `options.frame` of the DeepLabCut CSV at `path`: the seed
/// file's text (as written into the run folder), the parsed seeds (lines are the CSV row's) and
/// a note for the user about where the parent links came from.
pub fn seeds_from_dlc(path: &Path, options: &DlcSeedOptions) -> Result<(Seeds, String, String)> {
    let table = read_dlc_csv(path)?;
    let err = |line: Option<usize>, joint: Option<&str>, msg: String| Error::Seed {
        path: path.to_owned(),
        line,
        joint: joint.map(str::to_owned),
        msg,
    };
    if options.size < MIN_BOX_PX {
        return Err(Error::Usage(format!(
            "--seed-size {}: rectangles must be at least {MIN_BOX_PX} px",
            options.size
        )));
    }
    if table.joints.len() > crate::seed::MAX_JOINTS {
        return Err(err(
            None,
            None,
            format!(
                "its bodyparts row: {}",
                crate::seed::too_many_joints(table.joints.len())
            ),
        ));
    }
    let frames: Vec<String> = table
        .rows
        .iter()
        .filter_map(|r| r.frame)
        .take(12)
        .map(|f| f.to_string())
        .collect();
    let matching: Vec<&DlcRow> = table
        .rows
        .iter()
        .filter(|r| r.frame == Some(options.frame))
        .collect();
    let row =
        match matching.as_slice() {
            [] => {
                return Err(err(
                    None,
                    None,
                    format!(
                    "no row is frame {} (frames come from the index: a number, or the number in \
                     the image name); frames in the file: {}{}; give one with --seed-frame",
                    options.frame,
                    if frames.is_empty() { "none".into() } else { frames.join(", ") },
                    if table.rows.len() > frames.len() { ", ..." } else { "" }
                ),
                ))
            }
            [r] => *r,
            several => {
                return Err(err(
                    Some(several[1].line),
                    None,
                    format!(
                        "several rows are frame {} ({}); give the CSV of one video",
                        options.frame,
                        several
                            .iter()
                            .map(|r| r.label.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ))
            }
        };
    if let Some(j) = row.points.iter().position(Option::is_none) {
        let complete: Vec<String> = table
            .rows
            .iter()
            .filter(|r| r.points.iter().all(Option::is_some))
            .filter_map(|r| r.frame)
            .take(12)
            .map(|f| f.to_string())
            .collect();
        return Err(err(
            Some(row.line),
            Some(&table.joints[j]),
            format!(
                "not labelled on frame {} (empty or NaN); every joint needs a position on the \
                 seed frame: label it, or pick a frame where all are labelled with --seed-frame \
                 ({})",
                options.frame,
                if complete.is_empty() {
                    "there is none".into()
                } else {
                    format!("frames {}", complete.join(", "))
                }
            ),
        ));
    }
    let (parents, how) = match &options.skeleton {
        Some(file) => (
            read_links(file, &table.joints)?,
            format!("parent links from {}", file.display()),
        ),
        None => {
            let mut parents = vec![None; table.joints.len()];
            for (j, parent) in parents.iter_mut().enumerate().skip(1) {
                if table.individuals[j] == table.individuals[j - 1] {
                    *parent = Some(j - 1);
                }
            }
            let chain = table.joints.join(" -> ");
            (
                parents,
                format!(
                    "the DeepLabCut CSV has no skeleton: joints linked as a chain in column order \
                     ({chain}); give --skeleton FILE for other links"
                ),
            )
        }
    };
    let joints: Vec<SeedJoint> = table
        .joints
        .iter()
        .enumerate()
        .map(|(j, name)| {
            // Cannot fail: the row was chosen for having every point labelled (checked above).
            let p = row.points[j].expect("checked above");
            SeedJoint {
                name: name.clone(),
                bbox: JointBox::centred(p[0] as f32, p[1] as f32, options.size, options.size),
                parent: parents[j].map(|p| table.joints[p].clone()),
                score: None,
                status: None,
                line: row.line,
            }
        })
        .collect();
    let header = format!(
        "Seeds from the DeepLabCut CSV {}, frame {} (row {:?}), {}×{} px rectangles.\n{how}.",
        path.display(),
        options.frame,
        row.label,
        options.size,
        options.size
    );
    let text = to_toml(options.frame, &joints, &header);
    let mut seeds = parse_seeds(&text, path)?;
    for j in &mut seeds.joints {
        j.line = row.line;
    }
    Ok((seeds, text, how))
}

/// Parent indices for `joints` from a TOML file of `[[joint]]` tables (`name`, `parent`; the
/// other seed-file keys are ignored). Joints the file does not name are roots.
fn read_links(file: &Path, joints: &[String]) -> Result<Vec<Option<usize>>> {
    let err = |msg: String| Error::Seed {
        path: file.to_owned(),
        line: None,
        joint: None,
        msg,
    };
    let text = std::fs::read_to_string(file).map_err(|e| {
        err(format!(
            "cannot read the skeleton file ({e}); check the path"
        ))
    })?;
    let table: toml::Table = toml::from_str(&text).map_err(|e| err(e.to_string()))?;
    let list = table
        .get("joint")
        .and_then(toml::Value::as_array)
        .ok_or_else(|| {
            err("no [[joint]] tables; write one per joint with `name` and `parent`".into())
        })?;
    let known = || joints.join(", ");
    let index = |n: &str, what: &str| {
        joints.iter().position(|j| j == n).ok_or_else(|| {
            err(format!(
                "{what} {n:?} is not a bodypart of the DeepLabCut CSV; its joints are: {}",
                known()
            ))
        })
    };
    let mut parents = vec![None; joints.len()];
    for t in list {
        let name = t
            .get("name")
            .and_then(toml::Value::as_str)
            .ok_or_else(|| err("a [[joint]] has no `name` string".into()))?;
        let j = index(name, "joint")?;
        if let Some(p) = t.get("parent") {
            let p = p
                .as_str()
                .ok_or_else(|| err(format!("joint {name:?}: `parent` must be a string")))?;
            parents[j] = Some(index(p, "parent")?);
        }
    }
    let sk = Skeleton::new(joints.to_vec(), parents.clone());
    if let Some(cycle) = sk.find_cycle() {
        let names: Vec<&str> = cycle.iter().map(|&i| joints[i].as_str()).collect();
        return Err(err(format!(
            "parent links form a cycle ({}); remove one `parent`",
            names.join(" -> ")
        )));
    }
    Ok(parents)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::dlc_csv::tests::LABELS;

    #[test]
    fn seeds_chain_by_default_and_errors_name_the_fix() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("CollectedData_me.csv");
        std::fs::write(&p, LABELS).unwrap();
        let o = |frame| DlcSeedOptions {
            frame,
            size: 9,
            skeleton: None,
        };
        let (seeds, text, note) = seeds_from_dlc(&p, &o(7)).unwrap();
        assert_eq!(seeds.frame, 7);
        assert_eq!(seeds.skeleton.parents, vec![None, Some(0), Some(1)]);
        assert_eq!(seeds.joints[1].bbox, JointBox::centred(14.0, 22.0, 9, 9));
        assert_eq!(seeds.joints[0].line, 4);
        assert!(
            note.contains("chain") && note.contains("--skeleton"),
            "{note}"
        );
        assert!(
            text.starts_with("# Seeds from the DeepLabCut CSV"),
            "{text}"
        );
        let m = seeds_from_dlc(&p, &o(42)).unwrap_err().to_string();
        assert!(
            m.contains("line 5: joint \"left_ear\": not labelled on frame 42")
                && m.contains("frames 7"),
            "{m}"
        );
        let m = seeds_from_dlc(&p, &o(3)).unwrap_err().to_string();
        assert!(
            m.contains("no row is frame 3") && m.contains("7, 42"),
            "{m}"
        );

        let sk = d.path().join("skeleton.toml");
        std::fs::write(&sk, "[[joint]]\nname = \"tail\"\nparent = \"snout\"\n").unwrap();
        let with = DlcSeedOptions {
            skeleton: Some(sk.clone()),
            ..o(7)
        };
        let (seeds, _, _) = seeds_from_dlc(&p, &with).unwrap();
        assert_eq!(seeds.skeleton.parents, vec![None, None, Some(0)]);
        std::fs::write(&sk, "[[joint]]\nname = \"tail\"\nparent = \"nose\"\n").unwrap();
        let m = seeds_from_dlc(&p, &with).unwrap_err().to_string();
        assert!(m.contains("parent \"nose\" is not a bodypart"), "{m}");
    }
}
