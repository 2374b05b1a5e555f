use super::*;
use crate::skeleton::Skeleton;

/// The dancer's joints (configs/characters/dancer.toml), standing.
fn dancer() -> Animation {
    let joints: [(&str, Option<usize>, [f64; 2]); 16] = [
        ("pelvis", None, [121.0, 234.0]),
        ("chest", Some(0), [121.0, 122.0]),
        ("neck", Some(1), [121.0, 98.0]),
        ("head", Some(2), [121.0, 64.0]),
        ("left_shoulder", Some(1), [163.0, 126.0]),
        ("left_elbow", Some(4), [172.0, 189.0]),
        ("left_wrist", Some(5), [178.0, 249.0]),
        ("right_shoulder", Some(1), [79.0, 126.0]),
        ("right_elbow", Some(7), [70.0, 189.0]),
        ("right_wrist", Some(8), [64.0, 249.0]),
        ("left_hip", Some(0), [141.0, 240.0]),
        ("left_knee", Some(10), [143.0, 330.0]),
        ("left_ankle", Some(11), [144.0, 420.0]),
        ("right_hip", Some(0), [101.0, 240.0]),
        ("right_knee", Some(13), [99.0, 330.0]),
        ("right_ankle", Some(14), [98.0, 420.0]),
    ];
    Animation {
        skeleton: Skeleton::new(
            joints.iter().map(|j| j.0.to_owned()).collect(),
            joints.iter().map(|j| j.1).collect(),
        ),
        frames: vec![0],
        joints: vec![joints.iter().map(|j| j.2).collect()],
        fps: 25.0,
        width: 300,
        height: 500,
    }
}

#[test]
fn a_mapping_names_the_pivot_and_the_old_end_form_gets_the_new_one() {
    let a = dancer();
    let j = |n: &str| a.skeleton.index_of(n).unwrap();
    let f = |s: &str| parse_spec(s, "b", &a);
    assert_eq!(
        f("left_shoulder"),
        Ok(Some(Follow::Segment(j("left_elbow"))))
    );
    assert_eq!(f("pelvis"), Ok(Some(Follow::Root(j("pelvis")))));
    assert_eq!(f("pelvis>chest"), Ok(Some(Follow::Segment(j("chest")))));
    assert_eq!(f(""), Ok(None));
    let e = f("left_wrist").unwrap_err();
    assert!(
        e.contains("end of a bone") && e.ends_with("b=left_elbow"),
        "{e}"
    );
    let e = f("chest").unwrap_err();
    assert!(
        e.contains("several bones turn at chest") && e.contains("to neck"),
        "{e}"
    );
    let e = f("chest>left_elbow").unwrap_err();
    assert!(e.contains("not a child of chest"), "{e}");
    assert!(f("elbow").unwrap_err().contains("no joint \"elbow\""));
    // Specs read back.
    for s in [
        "left_shoulder",
        "pelvis",
        "pelvis>chest",
        "chest>neck",
        "neck",
    ] {
        assert_eq!(f(s).unwrap().unwrap().spec(&a), s);
    }
}

/// Name, parent, origin, tip (setup, y up), control.
type TestBone = (&'static str, Option<usize>, [f64; 2], [f64; 2], bool);

#[test]
fn a_front_view_rig_maps_by_structure() {
    // A rig of another shape: hips, a two-bone spine, a neck and head, arms with a
    // zero-length shoulder bone and a hand, legs with a foot; and an IK target (a control).
    let a = dancer();
    #[rustfmt::skip]
    let bones: [TestBone; 18] = [
        ("root", None, [0.0, 0.0], [0.0, 0.0], false),
        ("hips", Some(0), [0.0, 100.0], [0.0, 100.0], false),
        ("spine1", Some(1), [0.0, 100.0], [0.0, 140.0], false),
        ("spine2", Some(2), [0.0, 140.0], [0.0, 180.0], false),
        ("neck", Some(3), [0.0, 180.0], [0.0, 190.0], false),
        ("head", Some(4), [0.0, 190.0], [0.0, 220.0], false),
        ("shoulder.L", Some(3), [20.0, 178.0], [20.0, 178.0], false),
        ("arm.L", Some(6), [20.0, 178.0], [25.0, 140.0], false),
        ("forearm.L", Some(7), [25.0, 140.0], [28.0, 105.0], false),
        ("hand.L", Some(8), [28.0, 105.0], [29.0, 95.0], false),
        ("shoulder.R", Some(3), [-20.0, 178.0], [-20.0, 178.0], false),
        ("arm.R", Some(10), [-20.0, 178.0], [-25.0, 140.0], false),
        ("thigh.L", Some(1), [10.0, 100.0], [11.0, 55.0], false),
        ("shin.L", Some(12), [11.0, 55.0], [12.0, 10.0], false),
        ("foot.L", Some(13), [12.0, 10.0], [22.0, 0.0], false),
        ("thigh.R", Some(1), [-10.0, 100.0], [-11.0, 55.0], false),
        ("shin.R", Some(15), [-11.0, 55.0], [-12.0, 10.0], false),
        ("target.L", Some(0), [12.0, 10.0], [12.0, 10.0], true),
    ];
    let rig: Vec<RigBone> = bones
        .iter()
        .map(|b| RigBone {
            name: b.0.into(),
            parent: b.1,
            length: (b.3[0] - b.2[0]).hypot(b.3[1] - b.2[1]),
            base: b.2,
            tip: b.3,
            control: b.4,
        })
        .collect();
    let s = structural(&rig, &a);
    let got: Vec<String> = rig
        .iter()
        .zip(&s.follows)
        .map(|(b, f)| format!("{}={}", b.name, f.map_or("-".into(), |f| f.spec(&a))))
        .collect();
    assert_eq!(
        got,
        [
            "root=-",
            "hips=pelvis",
            "spine1=pelvis>chest",
            "spine2=pelvis>chest",
            "neck=chest>neck",
            "head=neck",
            "shoulder.L=-",
            "arm.L=left_shoulder",
            "forearm.L=left_elbow",
            "hand.L=-",
            "shoulder.R=-",
            "arm.R=right_shoulder",
            "thigh.L=left_hip",
            "shin.L=left_knee",
            "foot.L=-",
            "thigh.R=right_hip",
            "shin.R=right_knee",
            "target.L=-",
        ]
    );
    // Both face the camera: no side-view warning.
    let (theirs, ours) = s.widths.unwrap();
    let side = crate::export::spine_rig::SIDE_VIEW_WIDTH;
    assert!(theirs > side && ours > side, "{theirs} {ours}");
}

#[test]
fn sides_come_from_the_names_own_words() {
    for (n, s) in [
        ("front-upper-arm", Some(true)),
        ("rear-thigh", Some(false)),
        ("back-shoulder", Some(false)),
        ("back", None),
        ("elbow_l", Some(true)),
        ("r.hand", Some(false)),
        ("left_knee", Some(true)),
        ("Right Arm", Some(false)),
        ("torso", None),
        ("l", None),
        ("leg", None),
    ] {
        assert_eq!(side(n), s, "{n}");
    }
}
