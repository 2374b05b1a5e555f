use super::*;

fn names() -> Vec<String> {
    ["hip", "knee", "ankle"]
        .iter()
        .map(|s| s.to_string())
        .collect()
}

fn parse_str(text: &str) -> Result<Vec<Key>> {
    parse(text, Path::new("keys.toml"), &names(), 100, 80, Some(50))
}

#[test]
fn reads_subsets_of_joints_sorted_by_frame() {
    let keys = parse_str(
            "[[key]]\nframe = 30\nknee = [10, 20.5]\n\n[[key]]\nframe = 4\nhip = [1.0, 2.0]\nankle = [3, 4]\n",
        )
        .unwrap();
    assert_eq!(keys.len(), 2);
    assert_eq!(keys[0].frame, 4);
    assert_eq!(
        keys[0].joints,
        vec![Some(Point::new(1.0, 2.0)), None, Some(Point::new(3.0, 4.0))]
    );
    assert_eq!(
        keys[1].joints,
        vec![None, Some(Point::new(10.0, 20.5)), None]
    );
}

#[test]
fn errors_name_the_line_and_joint() {
    let err = |text: &str| parse_str(text).unwrap_err().to_string();
    let e = err("[[key]]\nframe = 3\nhip = [1, 2]\n\n[[key]]\nframe = 5\nelbow = [1, 2]\n");
    assert!(
        e.contains("line 7") && e.contains("elbow") && e.contains("hip, knee, ankle"),
        "{e}"
    );
    let e = err("[[key]]\nframe = 3\nknee = [1, 200]\n");
    assert!(e.contains("line 3") && e.contains("outside"), "{e}");
    let e = err("[[key]]\nframe = 60\nknee = [1, 2]\n");
    assert!(e.contains("line 2") && e.contains("50 frames"), "{e}");
    let e = err("[[key]]\nframe = 6\nknee = [1, 2]\n[[key]]\nframe = 6\nhip = [1, 2]\n");
    assert!(e.contains("line 5") && e.contains("second key"), "{e}");
    let e = err("[[key]]\nframe = 6\nknee = 3\n");
    assert!(e.contains("line 3") && e.contains("[x, y]"), "{e}");
}

/// A hand-written file: comments at the top, above keys, after entries, blank lines, an
/// integer position and a quoted name.
const HAND: &str = "# Keys for the walk, by hand.\n# Second line of the top.\n\n\
                        # Hip hidden behind the arm here.\n[[key]]\nframe = 10\n\
                        hip = [1, 2]   # eyeballed\n\
                        \"ankle\" = [5.25, 6.0]\n\n\
                        # frame 30: the knee only\n[[key]]\nframe = 30 # from the slow-mo\n\
                        # left leg\nknee = [10.0, 20.5]\n\n# The end.\n";

fn set(text: &str, frame: u64, joints: &[Option<Point>]) -> String {
    let text = set_key(text, Path::new("keys.toml"), &names(), frame, joints).unwrap();
    parse_str(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    text
}

fn p(x: f32, y: f32) -> Option<Point> {
    Some(Point::new(x, y))
}

fn comments(text: &str) -> Vec<&str> {
    text.lines()
        .filter_map(|l| l.find('#').map(|i| &l[i..]))
        .collect()
}

#[test]
fn set_key_changes_only_the_joint_it_moves_and_the_key_it_adds() {
    let moved = set(HAND, 10, &[None, None, p(7.5, 8.0)]);
    let text = set(&moved, 20, &[p(3.0, 4.0), None, None]);
    assert_eq!(comments(&text), comments(HAND), "{text}");
    // Every line of HAND is still there, in order, but the moved ankle's.
    let kept: Vec<&str> = HAND.lines().filter(|l| !l.contains("ankle")).collect();
    let mut lines = text.lines();
    for l in &kept {
        assert!(lines.any(|m| m == *l), "{l:?} lost or moved:\n{text}");
    }
    assert!(text.contains("\n\"ankle\" = [7.5, 8.0]\n"), "{text}");
    assert!(
            text.contains("eyeballed\n\"ankle\" = [7.5, 8.0]\n\n[[key]]\nframe = 20\nhip = [3.0, 4.0]\n\n# frame 30"),
            "{text}"
        );
    let keys = parse_str(&text).unwrap();
    assert_eq!(
        keys.iter().map(|k| k.frame).collect::<Vec<_>>(),
        [10, 20, 30]
    );
    assert_eq!(keys[0].joints, vec![p(1.0, 2.0), None, p(7.5, 8.0)]);
    assert_eq!(keys[1].joints, vec![p(3.0, 4.0), None, None]);
    assert_eq!(keys[2].joints, vec![None, p(10.0, 20.5), None]);
    // The same position again changes no byte, not even `[1, 2]`.
    assert_eq!(set(HAND, 10, &[p(1.0, 2.0), None, None]), HAND);
}

#[test]
fn a_joint_new_to_a_key_goes_in_joint_order_and_keeps_its_neighbours_comments() {
    let text = set(HAND, 10, &[None, p(9.0, 9.5), None]);
    assert!(
        text.contains("hip = [1, 2]   # eyeballed\nknee = [9.0, 9.5]\n\"ankle\" = [5.25, 6.0]\n"),
        "{text}"
    );
    assert_eq!(comments(&text), comments(HAND));
}

#[test]
fn a_new_first_key_goes_below_the_top_comments_and_above_the_first_keys_own() {
    let text = set(HAND, 2, &[None, None, p(1.0, 1.0)]);
    assert!(
        text.starts_with(
            "# Keys for the walk, by hand.\n# Second line of the top.\n\n\
                              [[key]]\nframe = 2\nankle = [1.0, 1.0]\n\n\
                              # Hip hidden behind the arm here.\n[[key]]\nframe = 10\n"
        ),
        "{text}"
    );
    assert_eq!(comments(&text), comments(HAND));
    let last = set(HAND, 40, &[p(1.0, 1.0), None, None]);
    assert!(
            last.ends_with("left leg\nknee = [10.0, 20.5]\n\n[[key]]\nframe = 40\nhip = [1.0, 1.0]\n\n# The end.\n"),
            "{last}"
        );
}

#[test]
fn a_removed_key_goes_but_its_comments_stay() {
    let text = set(HAND, 30, &[None, None, None]);
    assert_eq!(comments(&text), comments(HAND), "{text}");
    assert!(
        !text.contains("frame = 30") && !text.contains("\nknee"),
        "{text}"
    );
    assert_eq!(
        parse_str(&text)
            .unwrap()
            .iter()
            .map(|k| k.frame)
            .collect::<Vec<_>>(),
        [10]
    );
    let text = set(&text, 10, &[None, None, None]);
    assert_eq!(comments(&text), comments(HAND), "{text}");
    assert_eq!(parse_str(&text).unwrap(), vec![]);
    // Keys again after all were removed: below every comment kept.
    let text = set(&text, 5, &[p(1.0, 1.0), None, None]);
    assert!(
        text.ends_with("\n\n[[key]]\nframe = 5\nhip = [1.0, 1.0]\n"),
        "{text}"
    );
    assert_eq!(comments(&text), comments(HAND), "{text}");
    // A frame without a key: nothing to remove.
    assert_eq!(set(HAND, 11, &[None, None, None]), HAND);
}

#[test]
fn a_new_file_has_the_header_and_reads_back() {
    let text = set("", 4, &[p(1.5, 2.0), None, p(3.0, 4.0)]);
    assert_eq!(
        text,
        format!("{HEADER}\n[[key]]\nframe = 4\nhip = [1.5, 2.0]\nankle = [3.0, 4.0]\n")
    );
    let text = set(&text, 30, &[None, p(10.0, 20.25), None]);
    assert_eq!(parse_str(&text).unwrap().len(), 2, "{text}");
    let only = set("# mine\n", 4, &[p(1.0, 2.0), None, None]);
    assert_eq!(only, "# mine\n\n[[key]]\nframe = 4\nhip = [1.0, 2.0]\n");
    assert_eq!(set("# mine\n\n\n", 4, &[p(1.0, 2.0), None, None]), only);
}

#[test]
fn keys_in_an_inline_array_become_tables_unless_comments_would_go() {
    let text = set(
        "# above\nkey = [{ frame = 3, hip = [1, 2] }, { frame = 9, knee = [3, 4] }]\n",
        9,
        &[None, p(5.0, 6.0), None],
    );
    let keys = parse_str(&text).unwrap();
    assert_eq!(keys[0].joints, vec![p(1.0, 2.0), None, None], "{text}");
    assert_eq!(keys[1].joints, vec![None, p(5.0, 6.0), None], "{text}");
    assert!(text.starts_with("# above\n"), "{text}");
    let commented = "key = [\n  { frame = 3, hip = [1, 2] }, # mine\n]\n";
    let e = set_key(commented, Path::new("keys.toml"), &names(), 3, &[None; 3]);
    assert!(e.unwrap_err().to_string().contains("[[key]] tables"));
}

#[test]
fn names_that_are_not_bare_keys_are_quoted() {
    // The flies' joints are named like `female.head`: bare, that would be a table.
    let names: Vec<String> = ["female.head", "left wrist", "knee"]
        .map(String::from)
        .to_vec();
    let keys = vec![Key {
        frame: 3,
        joints: vec![
            Some(Point::new(1.0, 2.0)),
            Some(Point::new(3.0, 4.0)),
            Some(Point::new(5.0, 6.0)),
        ],
    }];
    let text = set_key("", Path::new("keys.toml"), &names, 3, &keys[0].joints).unwrap();
    assert!(text.contains("\"female.head\" = [1.0, 2.0]\n"), "{text}");
    assert!(text.contains("\nknee = [5.0, 6.0]\n"), "{text}");
    let back = parse(&text, Path::new("keys.toml"), &names, 100, 80, None).unwrap();
    assert_eq!(back, keys, "{text}");
}
