//! DeepLabCut CSV files, read (see [`super::dlc`] for making seeds of them).
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

use crate::error::{Error, Result};
use std::path::Path;

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
    // By bytes: the digits are ASCII, so both ends fall on character boundaries even when the
    // name holds multi-byte characters (a fuzzer found `rfind` + 1 landing inside one).
    let bytes = stem.as_bytes();
    let end = bytes.iter().rposition(u8::is_ascii_digit)? + 1;
    let start = bytes[..end]
        .iter()
        .rposition(|b| !b.is_ascii_digit())
        .map_or(0, |i| i + 1);
    stem.get(start..end)?.parse().ok()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A labels file as DeepLabCut 2.3 writes CollectedData_<scorer>.csv: three index columns,
    /// empty cells for unlabelled points.
    pub(crate) const LABELS: &str = "scorer,,,me,me,me,me,me,me\n\
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
        assert_eq!(last_number("é֦042.png"), Some(42));
        assert_eq!(last_number("֦042֦.png"), Some(42));
    }
}
