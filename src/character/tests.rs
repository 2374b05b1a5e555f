use super::*;

fn write_fixture(dir: &Path, toml: &str) -> PathBuf {
    let mut img = RgbaImage::new(40, 60);
    for y in 5..55 {
        for x in 10..30 {
            img.put_pixel(x, y, image::Rgba([200, 50, 50, 255]));
        }
    }
    img.save(dir.join("c.png")).unwrap();
    let p = dir.join("c.toml");
    std::fs::write(&p, toml).unwrap();
    p
}

const OK: &str = "image = \"c.png\"\nbackground = \"#102030\"\n\n[[joint]]\nname = \"hip\"\n\
    x = 20\ny = 40\n\n[[joint]]\nname = \"head\"\nx = 20\ny = 10\nparent = \"hip\"\nlayer = 2\n";

#[test]
fn reads_joints_layers_and_defaults() {
    let d = tempfile::tempdir().unwrap();
    let c = read_character(&write_fixture(d.path(), OK)).unwrap();
    assert_eq!(c.skeleton.names, vec!["hip", "head"]);
    assert_eq!(c.skeleton.parents, vec![None, Some(0)]);
    assert_eq!(c.layers, vec![0, 2]);
    assert_eq!(c.lines, vec![4, 9]);
    assert_eq!(c.scale, Scale::Fit);
    assert_eq!(c.backdrop, Backdrop::Colour([0x10, 0x20, 0x30]));
    assert_eq!(c.rest[1], Point::new(20.0, 10.0));
}

fn message(toml: &str) -> String {
    let d = tempfile::tempdir().unwrap();
    let e = read_character(&write_fixture(d.path(), toml)).unwrap_err();
    assert!(e.is_user_error(), "{e}");
    e.to_string()
}

#[test]
fn errors_name_line_joint_and_fix() {
    let m = message(&OK.replace("y = 10", "y = 70"));
    assert!(
        m.contains("line 9: joint \"head\"") && m.contains("outside"),
        "{m}"
    );
    let m = message(&OK.replace("x = 20\ny = 10", "x = 2\ny = 10"));
    assert!(m.contains("transparent"), "{m}");
    let m = message(&OK.replace("c.png", "nope.png"));
    assert!(m.contains("not found"), "{m}");
    let m = message(&OK.replace("layer", "layr"));
    assert!(m.contains("line 14") && m.contains("layr"), "{m}");
    let m = message(&OK.replace("\"hip\"\nlayer", "\"hips\"\nlayer"));
    assert!(m.contains("parent \"hips\""), "{m}");
}

#[test]
fn map_and_bones_are_checked_against_this_file() {
    let m = message(&(OK.to_owned() + "\n[map]\nknee = \"left_knee\"\n"));
    assert!(m.contains("[map] key \"knee\""), "{m}");
    let m = message(&(OK.to_owned() + "\n[bones]\nhip = [\"a\", \"b\"]\n"));
    assert!(
        m.contains("[bones] key \"hip\"") && m.contains("with a parent"),
        "{m}"
    );
    let m = message(&(OK.to_owned() + "\n[bones]\nhead = [\"a\"]\n"));
    assert!(m.contains("two source joints"), "{m}");
    let d = tempfile::tempdir().unwrap();
    let text = OK.to_owned()
        + "\n[map]\nhip = \"mid(l, r)\"\n\n[bones]\nhead = [\"mid(l, r)\", \"nose\"]\n";
    let c = read_character(&write_fixture(d.path(), &text)).unwrap();
    assert_eq!(c.map["hip"], "mid(l, r)");
    assert_eq!(c.bones["head"], ("mid(l, r)".to_owned(), "nose".to_owned()));
}
