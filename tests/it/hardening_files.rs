//! Seed and character files at their worst: non-UTF-8 bytes, NaN and infinite numbers, a 10 MB
//! file, 10 000 joints, and the fuzzers' findings (tests/fuzz_regressions/). Each gives a result
//! or one clear user error, quickly, never a panic, a hang or a stack overflow. (Unknown parents,
//! cycles, duplicate names and rectangles outside the frame are in tests/it/seeds.rs.)

use mocap2d::character::{parse_character, read_character};
use mocap2d::seed::{parse_seeds, read_seeds};
use mocap2d::Error;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn seed_err(r: mocap2d::Result<impl std::fmt::Debug>) -> String {
    match r {
        Ok(v) => panic!("expected an error, got {v:?}"),
        Err(e) => {
            assert!(
                matches!(e, Error::Seed { .. }) && e.is_user_error(),
                "{e:?}"
            );
            e.to_string()
        }
    }
}

fn character_err(r: mocap2d::Result<impl std::fmt::Debug>) -> String {
    match r {
        Ok(v) => panic!("expected an error, got {v:?}"),
        Err(e) => {
            assert!(
                matches!(e, Error::Character { .. }) && e.is_user_error(),
                "{e:?}"
            );
            e.to_string()
        }
    }
}

fn assert_mentions(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "message lacks {p:?}: {msg}");
    }
}

fn assert_quick(t: Instant, what: &str) {
    let limit = Duration::from_secs(3);
    assert!(t.elapsed() < limit, "{what} took {:?}", t.elapsed());
}

const SEED: &str = "frame = 0\n[[joint]]\nname = \"hip\"\nx = 100.0\ny = 80.0\nw = 21\nh = 21\n";

/// A folder holding a 200×200 opaque `c.png`, for character files.
fn character_dir() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    image::RgbaImage::from_pixel(200, 200, image::Rgba([90, 60, 30, 255]))
        .save(d.path().join("c.png"))
        .unwrap();
    d
}

const CHARACTER: &str =
    "image = \"c.png\"\n[[joint]]\nname = \"hip\"\nx = 100\ny = 100\n[[joint]]\nname = \"head\"\nx = 100\ny = 40\nparent = \"hip\"\n";

#[test]
fn seeds_with_non_utf8_bytes_name_line_and_byte() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("s.toml");
    let mut bytes = SEED.replace("\"hip\"", "\"hi\u{0}p\"").into_bytes();
    let at = bytes.iter().position(|&b| b == 0).unwrap();
    bytes[at] = 0xff; // not UTF-8 anywhere
    std::fs::write(&p, &bytes).unwrap();
    let m = seed_err(read_seeds(&p));
    assert_mentions(
        &m,
        &[
            &p.display().to_string(),
            "line 3",
            "UTF-8",
            &format!("byte {at}"),
        ],
    );
}

#[test]
fn seeds_with_nan_or_infinite_numbers_are_refused() {
    for (key, value) in [
        ("x", "nan"),
        ("y", "inf"),
        ("x", "-inf"),
        ("w", "nan"),
        ("h", "inf"),
        ("w", "1e300"),
    ] {
        let text = SEED.replace(
            &format!(
                "{key} = {}",
                if key == "x" {
                    "100.0"
                } else if key == "y" {
                    "80.0"
                } else {
                    "21"
                }
            ),
            &format!("{key} = {value}"),
        );
        assert_ne!(text, SEED);
        let m = seed_err(parse_seeds(&text, Path::new("s.toml")));
        assert_mentions(&m, &["s.toml", "line", "hip"]);
    }
    for extra in ["angle = nan", "score = nan", "angle = inf"] {
        let text = format!("{SEED}{extra}\n");
        let m = seed_err(parse_seeds(&text, Path::new("s.toml")));
        assert_mentions(&m, &["s.toml", "hip"]);
    }
    let m = seed_err(parse_seeds(
        &SEED.replace("frame = 0", "frame = inf"),
        Path::new("s.toml"),
    ));
    assert_mentions(&m, &["frame"]);
}

#[test]
fn ten_megabyte_seed_file_is_refused_quickly() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("big.toml");
    let mut text = SEED.to_string();
    while text.len() < 10 << 20 {
        text.push_str("# padding padding padding padding padding padding padding padding\n");
    }
    std::fs::write(&p, &text).unwrap();
    let t = Instant::now();
    let m = seed_err(read_seeds(&p));
    assert_quick(t, "refusing a 10 MB seed file");
    assert_mentions(&m, &[&p.display().to_string(), "4 MiB"]);
}

/// 10 000 joints, each the parent of the next: refused at once, over the limit of
/// `MAX_JOINTS` (tracking them would never finish), naming the line of the first one over.
/// A chain at the limit parses in well under a second in release builds, the skeleton walked
/// iteratively, and a cycle through all of it is found, not followed forever.
#[test]
fn ten_thousand_joints_are_refused_quickly_and_a_full_chain_parses() {
    let chain = |n: usize| {
        let mut text = String::from("frame = 0\n");
        for i in 0..n {
            text.push_str(&format!(
                "[[joint]]\nname = \"j{i}\"\nx = {}\ny = {}\nw = 9\nh = 9\n",
                10 + i % 100,
                10 + i / 100
            ));
            if i > 0 {
                text.push_str(&format!("parent = \"j{}\"\n", i - 1));
            }
        }
        text
    };
    let max = mocap2d::seed::MAX_JOINTS;
    let text = chain(10_000);
    let t = Instant::now();
    let m = seed_err(parse_seeds(&text, Path::new("many.toml")));
    assert_quick(t, "refusing 10 000 joints");
    let line = 2 + 7 * max - 1; // joint `max` (0-based) starts after `frame` and `max` joints
    assert_mentions(&m, &[&format!("line {line}:"), "10000 joints", "limit"]);

    let text = chain(max);
    let t = Instant::now();
    let seeds = parse_seeds(&text, Path::new("many.toml")).unwrap();
    assert_quick(t, "parsing a chain of MAX_JOINTS joints");
    assert_eq!(seeds.joints.len(), max);
    assert_eq!(seeds.skeleton.depth(max - 1), max - 1);
    assert_eq!(seeds.skeleton.topo_order().len(), max);
    seeds
        .check_against_clip(Path::new("many.toml"), 200, 200, Some(10))
        .unwrap();
    let last = format!("parent = \"j{}\"\n", max - 1);
    let cyclic = text.replacen("w = 9\nh = 9\n", &format!("w = 9\nh = 9\n{last}"), 1);
    let t = Instant::now();
    let m = seed_err(parse_seeds(&cyclic, Path::new("many.toml")));
    assert_quick(t, "finding a cycle through every joint");
    assert_mentions(&m, &["cycle", "j0"]);
}

#[test]
fn character_with_non_utf8_bytes_is_refused() {
    let d = character_dir();
    let p = d.path().join("c.toml");
    let mut bytes = CHARACTER.as_bytes().to_vec();
    bytes.extend_from_slice(b"# caf\xe9\n");
    std::fs::write(&p, bytes).unwrap();
    let m = character_err(read_character(&p));
    assert_mentions(&m, &[&p.display().to_string(), "UTF-8", "line 11"]);
}

#[test]
fn character_with_nan_or_infinite_numbers_is_refused() {
    let d = character_dir();
    let p = d.path().join("c.toml");
    for (from, to) in [
        ("x = 100\ny = 40", "x = nan\ny = 40"),
        ("x = 100\ny = 40", "x = 100\ny = -inf"),
        ("image", "scale = inf\nimage"),
        ("image", "scale = nan\nimage"),
    ] {
        let m = character_err(parse_character(&CHARACTER.replacen(from, to, 1), &p));
        assert_mentions(&m, &["c.toml"]);
    }
}

#[test]
fn ten_megabyte_character_file_is_refused_quickly() {
    let d = character_dir();
    let p = d.path().join("big.toml");
    let mut text = CHARACTER.to_string();
    while text.len() < 10 << 20 {
        text.push_str("# padding padding padding padding padding padding padding padding\n");
    }
    std::fs::write(&p, &text).unwrap();
    let t = Instant::now();
    let m = character_err(read_character(&p));
    assert_quick(t, "refusing a 10 MB character file");
    assert_mentions(&m, &[&p.display().to_string(), "4 MiB"]);
}

#[test]
fn character_with_ten_thousand_joints_parses_quickly() {
    let d = character_dir();
    let p = d.path().join("many.toml");
    let mut text = String::from("image = \"c.png\"\n");
    for i in 0..10_000 {
        text.push_str(&format!(
            "[[joint]]\nname = \"j{i}\"\nx = {}\ny = {}\n",
            50 + i % 100,
            50 + i / 100
        ));
        if i > 0 {
            text.push_str(&format!("parent = \"j{}\"\n", i - 1));
        }
    }
    std::fs::write(&p, &text).unwrap();
    let t = Instant::now();
    let c = read_character(&p).unwrap();
    assert_quick(t, "reading 10 000 character joints");
    assert_eq!(c.skeleton.len(), 10_000);
}

/// Inputs the fuzzers (fuzz/) found to crash a reader, kept as files: each must now give an
/// error (or a value), not a panic. File names start with the target: seeds-, character-,
/// tracks-, dlc_csv-, manifest-.
#[test]
fn fuzz_findings_give_errors_not_panics() {
    let dir = crate::common::root().join("tests/fuzz_regressions");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return;
    };
    let cdir = character_dir();
    let mut files: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
    files.sort();
    for f in files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        let bytes = std::fs::read(&f).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        let outcome = std::panic::catch_unwind(|| {
            let p = Path::new("fuzz");
            match name.split('-').next().unwrap() {
                "seeds" => drop(parse_seeds(&text, p)),
                "character" => drop(parse_character(&text, &cdir.path().join("c.toml"))),
                "tracks" => drop(mocap2d::run::tracks::parse_tracks(&bytes, p)),
                "dlc_csv" => drop(mocap2d::seed::dlc_csv::parse_dlc_csv(&text, p)),
                "manifest" => {
                    if let Ok(m) = mocap2d::run::Manifest::parse(&text, p) {
                        mocap2d::run::Manifest::parse(&m.to_toml(), p).unwrap();
                    }
                }
                other => panic!("{name}: unknown target {other:?}"),
            }
        });
        assert!(outcome.is_ok(), "{name} panics");
    }
}
