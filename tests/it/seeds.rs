//! Seed files through the library: valid files parse, and each kind of mistake gives one
//! `Error::Seed` naming the line, joint and field.

use std::path::Path;

use mocap2d::geom::JointBox;
use mocap2d::seed::{parse_seeds, read_seeds, to_toml, SeedJoint, Seeds};
use mocap2d::Error;

fn parse(text: &str) -> mocap2d::Result<Seeds> {
    parse_seeds(text, Path::new("seeds.toml"))
}

/// The error message for `text`, checking it is a user-fixable `Error::Seed`.
fn message(text: &str) -> String {
    match parse(text) {
        Ok(s) => panic!("expected an error, parsed {s:#?}"),
        Err(e) => seed_message(e),
    }
}

fn seed_message(e: Error) -> String {
    assert!(matches!(e, Error::Seed { .. }), "not a seed error: {e:?}");
    assert!(e.is_user_error());
    e.to_string()
}

fn assert_mentions(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "message lacks {p:?}: {msg}");
    }
}

/// A small valid body: line 1 is `frame = 0`; joint headers on lines 3 and 11.
const BODY: &str = r#"frame = 0

[[joint]]
name = "hip"
x = 100.0
y = 80.5
w = 21
h = 21
# a root

[[joint]]
name = "knee"
x = 104
y = 120.25
w = 15
h = 17
parent = "hip"
"#;

#[test]
fn valid_file_parses_with_lines_boxes_and_skeleton() {
    let s = parse(BODY).unwrap();
    assert_eq!(s.frame, 0);
    assert_eq!(s.skeleton.names, vec!["hip", "knee"]);
    assert_eq!(s.skeleton.parents, vec![None, Some(0)]);
    assert_eq!(s.joints[0].line, 3);
    assert_eq!(s.joints[1].line, 11);
    assert_eq!(s.joints[1].bbox, JointBox::centred(104.0, 120.25, 15, 17));
    assert_eq!(s.joints[1].bbox.angle_rad, 0.0);
    assert_eq!(s.joints[1].parent.as_deref(), Some("hip"));
    assert_eq!(s.joints[1].score, None);
    assert_eq!(s.joints[1].status, None);
}

#[test]
fn frame_defaults_to_zero() {
    let s = parse(&BODY.replace("frame = 0\n", "")).unwrap();
    assert_eq!(s.frame, 0);
}

#[test]
fn parent_may_follow_child_and_several_roots_are_allowed() {
    let text = r#"frame = 4
[[joint]]
name = "hand"
x = 10
y = 10
w = 5
h = 5
parent = "elbow"
[[joint]]
name = "tail"
x = 50
y = 10
w = 5
h = 5
[[joint]]
name = "elbow"
x = 20
y = 10
w = 5
h = 5
"#;
    let s = parse(text).unwrap();
    assert_eq!(s.frame, 4);
    assert_eq!(s.skeleton.parents, vec![Some(2), None, None]);
    assert_eq!(s.skeleton.roots(), vec![1, 2]);
    assert_eq!(s.skeleton.bones(), vec![(2, 0)]);
    assert_eq!(s.skeleton.topo_order(), vec![1, 2, 0]);
}

#[test]
fn optional_segment_keys_are_read() {
    let text = BODY.replace(
        "parent = \"hip\"\n",
        "parent = \"hip\"\nangle = -0.5\nscore = 0.75\nstatus = \"lost\"\n",
    );
    let s = parse(&text).unwrap();
    let k = &s.joints[1];
    assert_eq!(k.bbox.angle_rad, -0.5);
    assert_eq!(k.score, Some(0.75));
    assert_eq!(k.status.as_deref(), Some("lost"));
}

#[test]
fn flies_seed_file_parses() {
    let path = crate::common::shared("clips/flies/joints.toml");
    if !path.exists() {
        eprintln!("note: {} is absent; skipping", path.display());
        return;
    }
    let (s, text) = read_seeds(&path).unwrap();
    assert_eq!(text, std::fs::read_to_string(&path).unwrap());
    assert_eq!(s.joints.len(), s.skeleton.len());
    assert!(s.joints.iter().all(|j| j.bbox.w >= 5 && j.bbox.h >= 5));
    let roots = s.skeleton.roots();
    assert!(!roots.is_empty());
    assert_eq!(s.skeleton.topo_order().len(), s.joints.len());
    for r in roots {
        assert!(s.joints[r].parent.is_none());
    }
    // Its boxes fit a frame as large as the clip's extent.
    s.check_against_clip(&path, 1024, 1024, Some(1)).unwrap();
    // And it survives a round trip through the segment format.
    let back = parse(&to_toml(s.frame, &s.joints, "flies")).unwrap();
    assert_eq!(back.skeleton, s.skeleton);
    for (a, b) in back.joints.iter().zip(&s.joints) {
        assert_eq!(a.bbox, b.bbox);
    }
}

#[test]
fn to_toml_round_trips_through_parse_seeds() {
    let joints = vec![
        SeedJoint {
            name: "child".into(),
            bbox: JointBox {
                cx: 12.3456,
                cy: 7.0,
                w: 9,
                h: 11,
                angle_rad: 0.123456,
            },
            parent: Some("root".into()),
            score: Some(0.87654),
            status: Some("ok \"quoted\"".into()),
            line: 0,
        },
        SeedJoint {
            name: "root".into(),
            bbox: JointBox::centred(40.0, 30.5, 5, 5),
            parent: None,
            score: None,
            status: None,
            line: 0,
        },
    ];
    let text = to_toml(42, &joints, "segment 3: frames 42..90\nwritten by mocap2d");
    assert!(text.starts_with("# segment 3: frames 42..90\n# written by mocap2d\n"));
    assert_mentions(
        &text,
        &[
            "frame = 42\n",
            "x = 12.346\n",
            "angle = 0.1235\n",
            "score = 0.877\n",
        ],
    );
    let back = parse(&text).unwrap();
    assert_eq!(back.frame, 42);
    assert_eq!(back.skeleton.parents, vec![Some(1), None]);
    let c = &back.joints[0];
    assert!((c.bbox.cx - 12.346).abs() < 1e-4);
    assert!((c.bbox.angle_rad - 0.1235).abs() < 1e-6);
    assert!((c.score.unwrap() - 0.877).abs() < 1e-6);
    assert_eq!(c.status.as_deref(), Some("ok \"quoted\""));
    assert_eq!(back.joints[1].bbox, joints[1].bbox);
    assert_eq!(back.joints[1].score, None);
    // Deterministic, and stable once rounded.
    assert_eq!(
        to_toml(42, &joints, "segment 3: frames 42..90\nwritten by mocap2d"),
        text
    );
    assert_eq!(
        to_toml(
            42,
            &back.joints,
            "segment 3: frames 42..90\nwritten by mocap2d"
        ),
        text
    );
}

// ---- one test per kind of mistake ----

#[test]
fn toml_syntax_error_gives_line() {
    let m = message(&BODY.replace("y = 120.25", "y = 120.25.3"));
    assert_mentions(&m, &["seeds.toml: line 14: ", "invalid TOML"]);
    let m = message(&BODY.replace("name = \"knee\"", "name = knee"));
    assert_mentions(&m, &["line 12", "invalid TOML"]);
}

#[test]
fn duplicate_key_in_a_joint_is_reported() {
    let m = message(&BODY.replace("h = 17\n", "h = 17\nh = 18\n"));
    assert_mentions(&m, &["line 17", "duplicate key `h`"]);
}

#[test]
fn unknown_top_level_key_suggests_nearest() {
    let m = message(&BODY.replace("frame = 0", "fram = 0"));
    assert_mentions(
        &m,
        &["line 1", "unknown key `fram`", "did you mean `frame`"],
    );
    let m = message(&BODY.replace("[[joint]]", "[[joints]]"));
    assert_mentions(&m, &["line 3", "`joints`", "did you mean `joint`"]);
}

#[test]
fn unknown_joint_key_suggests_nearest() {
    let m = message(&BODY.replace("parent = ", "prent = "));
    assert_mentions(
        &m,
        &[
            "line 17",
            "joint \"knee\"",
            "unknown key `prent`",
            "did you mean `parent`",
        ],
    );
}

#[test]
fn frame_inside_a_joint_says_to_move_it() {
    let m = message(
        &BODY
            .replace("frame = 0\n", "")
            .replace("h = 17\n", "h = 17\nframe = 2\n"),
    );
    assert_mentions(
        &m,
        &[
            "line 16",
            "joint \"knee\"",
            "`frame`",
            "before the first [[joint]]",
        ],
    );
}

#[test]
fn missing_field_is_named() {
    let m = message(&BODY.replace("w = 15\n", ""));
    assert_mentions(&m, &["line 11", "joint \"knee\"", "missing `w`"]);
    let m = message(&BODY.replace("y = 80.5\n", ""));
    assert_mentions(&m, &["line 3", "joint \"hip\"", "missing `y`"]);
    let m = message(&BODY.replace("name = \"knee\"\n", ""));
    assert_mentions(&m, &["line 11", "no `name`", "joint #2"]);
}

#[test]
fn wrong_type_is_named() {
    let m = message(&BODY.replace("x = 104", "x = \"104\""));
    assert_mentions(
        &m,
        &[
            "line 13",
            "joint \"knee\"",
            "`x`",
            "must be a number",
            "string",
        ],
    );
    let m = message(&BODY.replace("w = 15", "w = 15.5"));
    assert_mentions(&m, &["line 15", "`w`", "whole number", "float"]);
    let m = message(&BODY.replace("name = \"knee\"", "name = 7"));
    assert_mentions(&m, &["line 12", "`name`", "string", "integer"]);
    let m = message(&BODY.replace("frame = 0", "frame = 1.5"));
    assert_mentions(&m, &["line 1", "`frame`", "whole number", "float"]);
    let m = message(&BODY.replace("parent = \"hip\"", "parent = [\"hip\"]"));
    assert_mentions(&m, &["line 17", "`parent`", "string", "array"]);
    let m = message(&BODY.replace("parent = \"hip\"", "status = 3"));
    assert_mentions(&m, &["line 17", "`status`", "string"]);
}

#[test]
fn duplicate_name_gives_line_of_the_second() {
    let m = message(&BODY.replace("name = \"knee\"", "name = \"hip\""));
    assert_mentions(
        &m,
        &[
            "line 12",
            "joint \"hip\"",
            "already used",
            "line 3",
            "unique",
        ],
    );
}

#[test]
fn invalid_name_characters_are_rejected() {
    let m = message(&BODY.replace("name = \"knee\"", "name = \"left knee\""));
    assert_mentions(
        &m,
        &[
            "line 12",
            "joint \"left knee\"",
            "`name`",
            "letters, digits",
        ],
    );
    let m = message(&BODY.replace("name = \"knee\"", "name = \"\""));
    assert_mentions(&m, &["line 12", "`name` is empty"]);
}

#[test]
fn unknown_parent_lists_known_joints() {
    let m = message(&BODY.replace("parent = \"hip\"", "parent = \"hips\""));
    assert_mentions(
        &m,
        &[
            "seeds.toml: line 17: joint \"knee\": parent \"hips\" is not a joint in this file",
            "did you mean \"hip\"",
            "known joints: \"hip\", \"knee\"",
        ],
    );
}

#[test]
fn parent_cycle_names_its_joints() {
    let text = BODY.replace("# a root", "parent = \"ankle\"")
        + "\n[[joint]]\nname = \"ankle\"\nx = 104\ny = 150\nw = 9\nh = 9\nparent = \"knee\"\n";
    let m = message(&text);
    assert_mentions(
        &m,
        &[
            "line 9",
            "joint \"hip\"",
            "cycle",
            "\"hip\" -> \"ankle\" -> \"knee\" -> \"hip\"",
        ],
    );
}

#[test]
fn self_parent_is_a_cycle() {
    let m = message(&BODY.replace("parent = \"hip\"", "parent = \"knee\""));
    assert_mentions(&m, &["line 17", "joint \"knee\"", "itself"]);
}

#[test]
fn small_rectangle_is_rejected() {
    let m = message(&BODY.replace("h = 17", "h = 4"));
    assert_mentions(
        &m,
        &[
            "line 16",
            "joint \"knee\"",
            "`h`",
            "at least 5 px",
            "found 4",
        ],
    );
    let m = message(&BODY.replace("w = 21", "w = -3"));
    assert_mentions(&m, &["line 7", "joint \"hip\"", "`w`", "at least 5"]);
}

#[test]
fn non_finite_position_is_rejected() {
    let m = message(&BODY.replace("x = 100.0", "x = nan"));
    assert_mentions(&m, &["line 5", "joint \"hip\"", "`x`", "finite", "nan"]);
    let m = message(&BODY.replace("y = 120.25", "y = -inf"));
    assert_mentions(&m, &["line 14", "joint \"knee\"", "`y`", "finite", "-inf"]);
    // Finite in TOML, infinite as f32.
    let m = message(&BODY.replace("y = 120.25", "y = 1e300"));
    assert_mentions(&m, &["line 14", "`y`", "finite"]);
}

#[test]
fn negative_frame_is_rejected() {
    let m = message(&BODY.replace("frame = 0", "frame = -2"));
    assert_mentions(&m, &["seeds.toml: line 1: ", "`frame`", "0 or more", "-2"]);
}

#[test]
fn score_out_of_range_is_rejected() {
    let m = message(&BODY.replace("parent = \"hip\"", "score = 1.5"));
    assert_mentions(
        &m,
        &["line 17", "joint \"knee\"", "`score`", "between 0 and 1"],
    );
}

#[test]
fn empty_joint_list_is_rejected() {
    for text in ["", "frame = 3\n", "# only a comment\n", "joint = []\n"] {
        let m = message(text);
        assert_mentions(&m, &["seeds.toml: no joints", "[[joint]]"]);
    }
}

#[test]
fn single_bracket_joint_table_is_rejected() {
    let m = message("[joint]\nname = \"a\"\nx = 9\ny = 9\nw = 5\nh = 5\n");
    assert_mentions(&m, &["line 1", "[[joint]] (double brackets)"]);
}

// ---- checks against the clip ----

#[test]
fn seeds_inside_the_clip_pass() {
    let s = parse(BODY).unwrap();
    s.check_against_clip(Path::new("seeds.toml"), 200, 150, Some(10))
        .unwrap();
    s.check_against_clip(Path::new("seeds.toml"), 200, 150, None)
        .unwrap();
}

#[test]
fn rectangle_outside_the_frame_gives_sizes() {
    let s = parse(BODY).unwrap();
    // knee covers y 111.75..128.75; a 120-px-high frame ends at 119.5.
    let e = s
        .check_against_clip(Path::new("seeds.toml"), 200, 120, Some(10))
        .unwrap_err();
    let m = seed_message(e);
    assert_mentions(
        &m,
        &[
            "line 11",
            "joint \"knee\"",
            "200×120 frame",
            "y 111.75..128.75",
            "x 96.5..111.5",
        ],
    );
}

#[test]
fn seed_frame_beyond_the_clip_is_rejected() {
    let s = parse(&BODY.replace("frame = 0", "frame = 10")).unwrap();
    let e = s
        .check_against_clip(Path::new("seeds.toml"), 200, 150, Some(10))
        .unwrap_err();
    let m = seed_message(e);
    assert_mentions(&m, &["seed frame 10", "10 frames", "0 to 9", "`frame`"]);
    s.check_against_clip(Path::new("seeds.toml"), 200, 150, Some(11))
        .unwrap();
}

// ---- reading files ----

#[test]
fn read_seeds_returns_verbatim_text() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("joints.toml");
    std::fs::write(&path, BODY).unwrap();
    let (s, text) = read_seeds(&path).unwrap();
    assert_eq!(text, BODY);
    assert_eq!(s.joints.len(), 2);
}

#[test]
fn read_seeds_errors_name_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.toml");
    let m = seed_message(read_seeds(&missing).unwrap_err());
    assert_mentions(&m, &[&missing.display().to_string(), "not found"]);

    let latin1 = dir.path().join("latin1.toml");
    let mut bytes = b"frame = 0\n[[joint]]\nname = \"h".to_vec();
    bytes.push(0xe9);
    bytes.extend_from_slice(b"\"\n");
    std::fs::write(&latin1, bytes).unwrap();
    let m = seed_message(read_seeds(&latin1).unwrap_err());
    assert_mentions(&m, &[&latin1.display().to_string(), "line 3", "UTF-8"]);

    let m = seed_message(read_seeds(dir.path()).unwrap_err());
    assert_mentions(&m, &["directory"]);
}

#[test]
fn fixture_file_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(
        &path,
        BODY.replace("parent = \"hip\"", "parent = \"thigh\""),
    )
    .unwrap();
    let m = seed_message(read_seeds(&path).unwrap_err());
    assert!(
        m.starts_with(&format!(
            "{}: line 17: joint \"knee\": parent \"thigh\"",
            path.display()
        )),
        "{m}"
    );
}

/// `scripts/jitter-seeds SRC OUT K`, its exit status and stderr.
fn jitter(src: &Path, out: &Path, k: &str) -> std::process::Output {
    std::process::Command::new("bash")
        .arg(crate::common::root().join("scripts/jitter-seeds"))
        .args([src, out])
        .arg(k)
        .output()
        .unwrap()
}

/// The seed files `scripts/accuracy --real` tracks the real clips from, beside their shipped
/// ones: every joint moved by at most 3 px, the skeleton and rectangles as they were, the same
/// bytes for the same K, another draw for another K; bad arguments exit 2 saying which.
#[test]
fn jittered_seed_files_move_every_joint_a_little_and_repeat() {
    let dir = tempfile::tempdir().unwrap();
    let src = crate::common::walk("joints.toml");
    let (base, _) = read_seeds(&src).unwrap();
    let out = |name: &str, k: &str| {
        let path = dir.path().join(name);
        let o = jitter(&src, &path, k);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        path
    };
    let (a, again, other) = (out("a.toml", "3"), out("b.toml", "3"), out("c.toml", "4"));
    let bytes = |p: &Path| std::fs::read(p).unwrap();
    assert_eq!(bytes(&a), bytes(&again));
    assert_ne!(bytes(&a), bytes(&other));
    for path in [&a, &other] {
        let (moved, _) = read_seeds(path).unwrap();
        assert_eq!(moved.skeleton.parents, base.skeleton.parents);
        let mut largest = 0.0f32;
        for (m, b) in moved.joints.iter().zip(&base.joints) {
            assert_eq!((&m.name, m.bbox.w, m.bbox.h), (&b.name, b.bbox.w, b.bbox.h));
            for d in [m.bbox.cx - b.bbox.cx, m.bbox.cy - b.bbox.cy] {
                assert!(d.abs() <= 3.006, "{} moved {d} px", m.name);
                largest = largest.max(d.abs());
            }
        }
        assert!(largest > 1.0, "no joint moved more than {largest} px");
    }
    for (k, says) in [("0", "K must be"), ("x", "K must be")] {
        let o = jitter(&src, &dir.path().join("d.toml"), k);
        assert_eq!(o.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&o.stderr).contains(says));
    }
    let o = jitter(
        &dir.path().join("none.toml"),
        &dir.path().join("d.toml"),
        "1",
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no such seed file"));
}

/// `scripts/seeds-from-labels SRC LABELS FRAME OUT`, its exit status and stderr.
fn from_labels(src: &Path, labels: &Path, frame: &str, out: &Path) -> std::process::Output {
    std::process::Command::new("bash")
        .arg(crate::common::root().join("scripts/seeds-from-labels"))
        .args([src, labels])
        .arg(frame)
        .arg(out)
        .output()
        .unwrap()
}

/// A seed file written from the labels of another frame: that frame, each joint where its label
/// is, the skeleton and rectangles as they were; a joint without a label there, or a frame that
/// is not a number, exits 2 naming it and writes nothing.
#[test]
fn seeds_from_labels_move_every_joint_to_its_label_on_that_frame() {
    let dir = tempfile::tempdir().unwrap();
    let (src, gt) = (
        crate::common::walk("joints.toml"),
        crate::common::walk("gt.csv"),
    );
    let (base, _) = read_seeds(&src).unwrap();
    let out = dir.path().join("f17.toml");
    let o = from_labels(&src, &gt, "17", &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (moved, _) = read_seeds(&out).unwrap();
    assert_eq!(moved.frame, 17);
    assert_eq!(moved.skeleton.parents, base.skeleton.parents);
    let labels = std::fs::read_to_string(&gt).unwrap();
    let label = |joint: &str| -> (f32, f32) {
        let row = labels
            .lines()
            .map(|l| l.split(',').collect::<Vec<_>>())
            .find(|c| c[0] == "17" && c[1] == joint)
            .unwrap_or_else(|| panic!("no label of {joint} on frame 17"));
        (row[2].parse().unwrap(), row[3].parse().unwrap())
    };
    let mut moved_any = false;
    for (m, b) in moved.joints.iter().zip(&base.joints) {
        assert_eq!((&m.name, m.bbox.w, m.bbox.h), (&b.name, b.bbox.w, b.bbox.h));
        let (x, y) = label(&m.name);
        assert!(
            (m.bbox.cx - x).abs() < 1e-3 && (m.bbox.cy - y).abs() < 1e-3,
            "{}",
            m.name
        );
        moved_any |= (m.bbox.cx - b.bbox.cx).abs() > 1.0;
    }
    assert!(
        moved_any,
        "the walk's joints on frame 17 are where they were on frame 0"
    );
    // TOML needs no spaces around `=`: such a file gets the same positions.
    let tight = dir.path().join("tight.toml");
    let text = std::fs::read_to_string(&src).unwrap();
    std::fs::write(&tight, text.replace(" = ", "=")).unwrap();
    let tight_out = dir.path().join("tight17.toml");
    assert!(from_labels(&tight, &gt, "17", &tight_out).status.success());
    let (tight_moved, _) = read_seeds(&tight_out).unwrap();
    for (a, b) in tight_moved.joints.iter().zip(&moved.joints) {
        assert_eq!((a.bbox.cx, a.bbox.cy), (b.bbox.cx, b.bbox.cy), "{}", a.name);
    }
    // A joint without its `x =` line is refused, not written with its old position.
    let no_x = dir.path().join("no-x.toml");
    let kept: Vec<&str> = text.lines().filter(|l| !l.starts_with("x =")).collect();
    std::fs::write(&no_x, kept.join("\n")).unwrap();
    let o = from_labels(&no_x, &gt, "17", &dir.path().join("bad-no-x.toml"));
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("needs one x = and one y = line"));
    assert!(!dir.path().join("bad-no-x.toml").exists());
    for (frame, says) in [("9999", "no label for joint"), ("x", "FRAME must be")] {
        let bad = dir.path().join(format!("bad-{frame}.toml"));
        let o = from_labels(&src, &gt, frame, &bad);
        assert_eq!(o.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&o.stderr).contains(says));
        assert!(!bad.exists() && !dir.path().join(format!("bad-{frame}.toml.tmp")).exists());
    }
}
