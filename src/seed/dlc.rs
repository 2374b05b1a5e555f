//! DeepLabCut CSV files read as seeds (`mocap2d track --seeds-from-dlc FILE --seed-frame N`).
//!
//! **Layout** (as pandas writes DeepLabCut's tables): header rows `scorer`, optionally
//! `individuals` (multi-animal projects), `bodyparts` and `coords`, then one row a labelled image
//! or video frame. The leading index columns are those whose `coords` cell is not `x`, `y` or
//! `likelihood`: one (`labeled-data/clip/img0042.png`, or a frame number in prediction files and
//! mocap2d's own export) or three (newer DeepLabCut: `labeled-data`, `clip`, `img0042.png`).
//! Every bodypart has `x` and `y` columns (px, origin top-left, y down: our image space), and
//! `likelihood` in predictions. Empty cells and `NaN` are unlabelled points.
//!
//! **Frames.** A row's frame is its index when that is a whole number, else the last number in
//! its image file name (DeepLabCut names extracted frames `img<frame>.png`).
//!
//! **Joints** are the bodyparts in column order, named after them (multi-animal files with
//! several individuals: `<individual>_<bodypart>`); characters other than letters, digits,
//! `_`, `.` and `-` become `_`.
//!
//! **Parents.** The CSV has no skeleton. `--skeleton FILE` gives one: a TOML file of `[[joint]]`
//! tables with `name` and `parent` (a seed file works: its other keys are ignored); joints it
//! does not name stay roots. Without it, the joints are linked as a chain in column order (each
//! individual its own chain), as DeepLabCut projects usually list bodyparts along the body, and
//! the command says so.

use super::{parse_seeds, to_toml, SeedJoint, Seeds, MIN_BOX_PX};
use crate::error::{Error, Result};
use crate::geom::JointBox;
use crate::skeleton::Skeleton;
use std::path::{Path, PathBuf};

/// Default seed rectangle side (px) for joints read from a DeepLabCut CSV.
pub const DEFAULT_SEED_SIZE: u32 = 15;

/// A DeepLabCut CSV, read.
#[derive(Debug, Clone, PartialEq)]
pub struct DlcTable {
    /// The `scorer` of the first point column.
    pub scorer: String,
    /// Joint names, one per bodypart (and individual), in column order.
    pub joints: Vec<String>,
    /// The individual of each joint (`None` without an `individuals` row).
    pub individuals: Vec<Option<String>>,
    pub rows: Vec<DlcRow>,
}

/// One data row of a [`DlcTable`].
#[derive(Debug, Clone, PartialEq)]
pub struct DlcRow {
    /// 1-based line in the file.
    pub line: usize,
    /// The index column(s), joined with `/`.
    pub label: String,
    /// The frame: the index as a whole number, or the last number of the image file name.
    pub frame: Option<u64>,
    /// `[joint]`: position (px), `None` when unlabelled.
    pub points: Vec<Option<[f64; 2]>>,
    /// `[joint]`: likelihood, `None` when the file has none.
    pub likelihood: Vec<Option<f64>>,
}

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

/// Reads a DeepLabCut CSV (see the module docs). Errors name the file, the line and the fix.
pub fn read_dlc_csv(path: &Path) -> Result<DlcTable> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::Seed {
        path: path.to_owned(),
        line: None,
        joint: None,
        msg: format!("cannot read the DeepLabCut CSV ({e}); check the path"),
    })?;
    parse_dlc_csv(&text, path)
}

/// Parses DeepLabCut CSV `text` (`path` for messages only).
pub fn parse_dlc_csv(text: &str, path: &Path) -> Result<DlcTable> {
    let err = |line: Option<usize>, msg: String| Error::Seed {
        path: path.to_owned(),
        line,
        joint: None,
        msg,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(text.as_bytes());
    let mut records: Vec<(usize, Vec<String>)> = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| err(e.position().map(|p| p.line() as usize), e.to_string()))?;
        let line = rec.position().map_or(0, |p| p.line() as usize);
        records.push((line, rec.iter().map(|c| c.trim().to_owned()).collect()));
    }
    let layout = "a DeepLabCut CSV starts with the header rows `scorer`, `bodyparts` and \
                  `coords` (multi-animal: `individuals` after `scorer`)";
    let first = |i: usize| records.get(i).and_then(|r| r.1.first()).map(String::as_str);
    if first(0) != Some("scorer") {
        return Err(err(
            Some(1),
            format!("the first cell is not `scorer`; {layout}"),
        ));
    }
    let multi = first(1) == Some("individuals");
    let (bp_row, coords_row) = if multi { (2, 3) } else { (1, 2) };
    if first(bp_row) != Some("bodyparts") || first(coords_row) != Some("coords") {
        return Err(err(
            Some(bp_row + 1),
            format!("expected `bodyparts`, then `coords`; {layout}"),
        ));
    }
    let coords = &records[coords_row].1;
    let is_coord = |c: &str| matches!(c, "x" | "y" | "likelihood");
    let n_index = coords.iter().position(|c| is_coord(c)).ok_or_else(|| {
        err(
            Some(coords_row + 1),
            "the `coords` row names no `x`, `y` or `likelihood` column".into(),
        )
    })?;
    let n_index = n_index.max(1);
    let cell = |row: usize, c: usize| records[row].1.get(c).map_or("", String::as_str);

    // Columns: (joint, coordinate 0 = x, 1 = y, 2 = likelihood).
    let mut keys: Vec<(Option<String>, String)> = Vec::new();
    let mut columns: Vec<(usize, usize, usize)> = Vec::new(); // (column, joint, coord)
    for c in n_index..coords.len() {
        let k = match cell(coords_row, c) {
            "x" => 0,
            "y" => 1,
            "likelihood" => 2,
            other => {
                return Err(err(
                    Some(coords_row + 1),
                    format!(
                        "column {}: `coords` is {other:?}; expected x, y or likelihood",
                        c + 1
                    ),
                ))
            }
        };
        let bp = cell(bp_row, c).to_owned();
        if bp.is_empty() {
            return Err(err(
                Some(bp_row + 1),
                format!("column {}: no bodypart name", c + 1),
            ));
        }
        let ind = multi.then(|| cell(1, c).to_owned());
        let key = (ind, bp);
        let j = match keys.iter().position(|k| *k == key) {
            Some(j) => j,
            None => {
                keys.push(key);
                keys.len() - 1
            }
        };
        if columns.iter().any(|&(_, jj, kk)| jj == j && kk == k) {
            return Err(err(
                Some(coords_row + 1),
                format!(
                    "column {}: bodypart {:?} has two {} columns",
                    c + 1,
                    keys[j].1,
                    cell(coords_row, c)
                ),
            ));
        }
        columns.push((c, j, k));
    }
    for (j, key) in keys.iter().enumerate() {
        for (k, name) in ["x", "y"].iter().enumerate() {
            if !columns.iter().any(|&(_, jj, kk)| jj == j && kk == k) {
                return Err(err(
                    Some(coords_row + 1),
                    format!("bodypart {:?} has no {name} column", key.1),
                ));
            }
        }
    }
    let individuals: Vec<Option<String>> = keys.iter().map(|k| k.0.clone()).collect();
    let several = {
        let mut ind: Vec<&Option<String>> = individuals.iter().collect();
        ind.dedup();
        ind.len() > 1
    };
    let mut joints: Vec<String> = Vec::with_capacity(keys.len());
    for (ind, bp) in &keys {
        let raw = match ind {
            Some(i) if several && !i.is_empty() => format!("{i}_{bp}"),
            _ => bp.clone(),
        };
        let name: String = raw
            .chars()
            .map(|c| {
                if c.is_alphanumeric() || matches!(c, '_' | '.' | '-') {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        if joints.contains(&name) {
            return Err(err(
                Some(bp_row + 1),
                format!("two bodyparts are both named {name:?} (after replacing characters other than letters, digits, _ . -); rename one"),
            ));
        }
        joints.push(name);
    }

    let mut rows = Vec::new();
    for (line, rec) in records.iter().skip(coords_row + 1) {
        if rec.iter().all(String::is_empty) {
            continue;
        }
        let index: Vec<&str> = rec.iter().take(n_index).map(String::as_str).collect();
        let label = index.join("/");
        let frame = match label.parse::<u64>() {
            Ok(f) => Some(f),
            Err(_) => last_number(index.last().copied().unwrap_or("")),
        };
        let mut points = vec![[None, None]; joints.len()];
        let mut likelihood = vec![None; joints.len()];
        for &(c, j, k) in &columns {
            let v = rec.get(c).map_or("", String::as_str);
            let value = if v.is_empty() || v.eq_ignore_ascii_case("nan") {
                None
            } else {
                Some(v.parse::<f64>().ok().filter(|x| x.is_finite()).ok_or_else(|| {
                    err(
                        Some(*line),
                        format!(
                            "column {} ({} {}): {v:?} is not a number (leave unlabelled points empty or NaN)",
                            c + 1,
                            joints[j],
                            cell(coords_row, c)
                        ),
                    )
                })?)
            };
            match k {
                2 => likelihood[j] = value,
                _ => points[j][k] = value,
            }
        }
        rows.push(DlcRow {
            line: *line,
            label,
            frame,
            points: points
                .into_iter()
                .map(|p| match p {
                    [Some(x), Some(y)] => Some([x, y]),
                    _ => None,
                })
                .collect(),
            likelihood,
        });
    }
    Ok(DlcTable {
        scorer: cell(0, n_index).to_owned(),
        joints,
        individuals,
        rows,
    })
}

/// The last run of digits in a file name (`img0042.png` → 42).
fn last_number(name: &str) -> Option<u64> {
    let file = name.rsplit(['/', '\\']).next().unwrap_or(name);
    let stem = file.rsplit_once('.').map_or(file, |(s, _)| s);
    let end = stem.rfind(|c: char| c.is_ascii_digit())? + 1;
    let start = stem[..end]
        .rfind(|c: char| !c.is_ascii_digit())
        .map_or(0, |i| i + 1);
    stem[start..end].parse().ok()
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
            for j in 1..table.joints.len() {
                if table.individuals[j] == table.individuals[j - 1] {
                    parents[j] = Some(j - 1);
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

    /// A labels file as DeepLabCut 2.3 writes CollectedData_<scorer>.csv: three index columns,
    /// empty cells for unlabelled points.
    const LABELS: &str = "scorer,,,me,me,me,me,me,me\n\
        bodyparts,,,snout,snout,left ear,left ear,tail,tail\n\
        coords,,,x,y,x,y,x,y\n\
        labeled-data,mouse,img0007.png,10.5,20.25,14,22,60,30\n\
        labeled-data,mouse,img0042.png,11.5,21.25,,,61,31\n";

    #[test]
    fn reads_three_index_columns_and_empty_cells() {
        let t = parse_dlc_csv(LABELS, Path::new("c.csv")).unwrap();
        assert_eq!(t.scorer, "me");
        assert_eq!(t.joints, vec!["snout", "left_ear", "tail"]);
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.rows[0].frame, Some(7));
        assert_eq!(t.rows[0].line, 4);
        assert_eq!(t.rows[1].label, "labeled-data/mouse/img0042.png");
        assert_eq!(t.rows[1].points[1], None);
        assert_eq!(t.rows[1].points[2], Some([61.0, 31.0]));
    }

    #[test]
    fn reads_one_index_column_nan_and_likelihood() {
        let text = "scorer,DLC_resnet50,DLC_resnet50,DLC_resnet50\nbodyparts,a,a,a\n\
                    coords,x,y,likelihood\n0,1.5,2.5,0.9\n1,NaN,NaN,0.1\n";
        let t = parse_dlc_csv(text, Path::new("p.csv")).unwrap();
        assert_eq!(t.rows[0].frame, Some(0));
        assert_eq!(t.rows[0].likelihood[0], Some(0.9));
        assert_eq!(t.rows[1].points[0], None);
    }

    #[test]
    fn multi_animal_names_joints_by_individual() {
        let text = "scorer,me,me,me,me\nindividuals,m1,m1,m2,m2\nbodyparts,nose,nose,nose,nose\n\
                    coords,x,y,x,y\nlabeled-data/v/img001.png,1,2,3,4\n";
        let t = parse_dlc_csv(text, Path::new("m.csv")).unwrap();
        assert_eq!(t.joints, vec!["m1_nose", "m2_nose"]);
        assert_eq!(t.rows[0].frame, Some(1));
    }

    #[test]
    fn last_number_of_image_names() {
        assert_eq!(last_number("img0042.png"), Some(42));
        assert_eq!(last_number("labeled-data/v2/frame_17.jpg"), Some(17));
        assert_eq!(last_number("still.png"), None);
    }

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
