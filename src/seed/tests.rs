use super::hints::*;
use super::*;

fn parse(text: &str) -> Result<Seeds> {
    parse_seeds(text, Path::new("seeds.toml"))
}

fn message(text: &str) -> String {
    match parse(text) {
        Ok(s) => panic!("expected an error, parsed {s:?}"),
        Err(e) => {
            assert!(matches!(e, Error::Seed { .. }), "{e:?}");
            assert!(e.is_user_error());
            e.to_string()
        }
    }
}

const ARM: &str = "frame = 3\n\
    \n\
    [[joint]]\n\
    name = \"hand\"\n\
    x = 10\n\
    y = 20.5\n\
    w = 9\n\
    h = 7\n\
    parent = \"elbow\"\n\
    \n\
    [[joint]]\n\
    name = \"elbow\"\n\
    x = 30.25\n\
    y = 40\n\
    w = 11\n\
    h = 11\n";

#[test]
fn top_key_line_finds_frame_before_the_tables_only() {
    let t = "# segment 2\n\nframe = 40\n\n[[joint]]\nframe = 3\n";
    assert_eq!(super::top_key_line(t, "frame"), Some(3));
    assert_eq!(super::top_key_line("[[joint]]\nframe = 1\n", "frame"), None);
    assert_eq!(super::top_key_line("frames = 1\n", "frame"), None);
}

#[test]
fn parses_parent_after_child() {
    let s = parse(ARM).unwrap();
    assert_eq!(s.frame, 3);
    assert_eq!(s.joints.len(), 2);
    assert_eq!(s.joints[0].name, "hand");
    assert_eq!(s.joints[0].line, 3);
    assert_eq!(s.joints[1].line, 11);
    assert_eq!(s.joints[0].bbox, JointBox::centred(10.0, 20.5, 9, 7));
    assert_eq!(s.joints[0].parent.as_deref(), Some("elbow"));
    assert_eq!(s.skeleton.parents, vec![Some(1), None]);
    assert_eq!(s.skeleton.topo_order(), vec![1, 0]);
}

#[test]
fn error_lines_point_at_the_field() {
    let m = message(&ARM.replace("w = 9", "w = 3"));
    assert!(
        m.starts_with("seeds.toml: line 7: joint \"hand\": `w`"),
        "{m}"
    );
    assert!(m.contains("at least 5"), "{m}");
}

#[test]
fn unknown_key_suggests_nearest() {
    let m = message(&ARM.replace("parent = ", "parnet = "));
    assert!(
        m.contains("line 9") && m.contains("did you mean `parent`"),
        "{m}"
    );
    let m = message(&ARM.replace("frame = 3", "frames = 3"));
    assert!(
        m.contains("line 1") && m.contains("did you mean `frame`"),
        "{m}"
    );
}

#[test]
fn float_formats() {
    assert_eq!(float(1.0, 3), "1.000");
    assert_eq!(float(f32::NAN, 3), "nan");
    assert_eq!(float(f32::NEG_INFINITY, 3), "-inf");
}

#[test]
fn strings_are_escaped() {
    assert_eq!(toml_string("a\"b\\c\n"), "\"a\\\"b\\\\c\\n\"");
}

#[test]
fn edit_distance_counts_edits() {
    assert_eq!(edit_distance("parnet", "parent"), 2);
    assert_eq!(edit_distance("X", "x"), 0);
    assert_eq!(edit_distance("", "abc"), 3);
    assert_eq!(nearest("hip", ["hips", "knee"]), Some("hips"));
    assert_eq!(nearest("zzz", ["hips", "knee"]), None);
}

#[test]
fn parent_guesses_match_typos_and_last_parts() {
    let names: Vec<String> = ["female.head", "male.head", "male.thorax"]
        .map(String::from)
        .to_vec();
    assert_eq!(parent_guesses("male.haed", &names), vec!["male.head"]);
    assert_eq!(
        parent_guesses("head", &names),
        vec!["female.head", "male.head"]
    );
    assert_eq!(parent_guesses("wing", &names), Vec::<&str>::new());
}

#[test]
fn names_allow_letters_digits_and_punctuation() {
    assert!(is_valid_joint_name("female.forelegL4"));
    assert!(is_valid_joint_name("left_knee-2"));
    assert!(!is_valid_joint_name("left knee"));
    assert!(!is_valid_joint_name(""));
    assert!(!is_valid_joint_name("a/b"));
}

#[test]
fn to_toml_round_trips() {
    let s = parse(ARM).unwrap();
    let mut joints = s.joints.clone();
    joints[0].score = Some(0.5);
    joints[0].status = Some("ok".into());
    joints[1].bbox.angle_rad = -0.25;
    let text = to_toml(7, &joints, "segment 2\n\nframes 7..20");
    assert!(
        text.starts_with("# segment 2\n#\n# frames 7..20\n\nframe = 7\n"),
        "{text}"
    );
    let back = parse(&text).unwrap();
    assert_eq!(back.frame, 7);
    for (a, b) in back.joints.iter().zip(&joints) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.bbox, b.bbox);
        assert_eq!(a.parent, b.parent);
        assert_eq!(a.score, b.score);
        assert_eq!(a.status, b.status);
    }
    assert_eq!(to_toml(7, &back.joints, "segment 2\n\nframes 7..20"), text);
}

#[test]
fn a_joint_seeded_on_top_of_its_parent_is_named() {
    // ARM's hand is 28 px from the elbow, its rectangle 7 px: fine.
    assert_eq!(parse(ARM).unwrap().crowding_note(), "");
    // Moved to 2.7 px from the elbow: under half its 7 px side, not under a quarter (a small
    // rectangle on a short bone, as on tiny clips); then to 1.25 px, under a quarter.
    let crowded = ARM
        .replace("x = 10\n", "x = 28\n")
        .replace("y = 20.5\n", "y = 38.5\n");
    assert_eq!(parse(&crowded).unwrap().crowding_note(), "");
    let crowded = ARM
        .replace("x = 10\n", "x = 29\n")
        .replace("y = 20.5\n", "y = 40\n");
    let note = parse(&crowded).unwrap().crowding_note();
    assert!(
        note.starts_with("hand is 1.2 px from its parent elbow (closer than a quarter"),
        "{note}"
    );
}
