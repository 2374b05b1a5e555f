//! Retargeting tests on hand-made skeletons and motions.

use super::*;
use crate::character::Scale;
use crate::geom::Point;
use crate::run::TrackRow;
use std::path::Path;

/// Lengths follow the source (eq. 18), feet left as retargeted: the equations alone.
fn stretching() -> RetargetOptions {
    RetargetOptions {
        stretch: true,
        plant_feet: false,
        ..Default::default()
    }
}

/// pelvis (root) -> chest -> head; pelvis -> knee -> ankle.
fn skel() -> Skeleton {
    Skeleton::new(
        ["pelvis", "chest", "head", "knee", "ankle"]
            .map(String::from)
            .to_vec(),
        vec![None, Some(0), Some(1), Some(0), Some(3)],
    )
}

/// A motion that walks, bends, stretches and spins a bone once around (angles cross ±π).
fn wobbly(frames: usize) -> Motion {
    wobbly_stretching(frames, 1.0)
}

/// [`wobbly`] with its bones' stretching scaled by `stretch` (0: rigid bones).
fn wobbly_stretching(frames: usize, stretch: f64) -> Motion {
    let joints = (0..frames)
        .map(|t| {
            let t = t as f64;
            let root = [100.0 + 2.0 * t, 200.0 + 3.0 * (0.3 * t).sin()];
            let polar =
                |from: P64, len: f64, a: f64| [from[0] + len * a.cos(), from[1] + len * a.sin()];
            let chest = polar(
                root,
                50.0 * (1.0 + stretch * 0.2 * (0.2 * t).sin()),
                -1.5 + 0.1 * (0.4 * t).sin(),
            );
            let head = polar(chest, 20.0, -1.5 + t * std::f64::consts::TAU / 40.0);
            let knee = polar(root, 45.0, 1.7 + 0.5 * (0.25 * t).sin());
            let ankle = polar(
                knee,
                44.0 * (1.0 - stretch * 0.25 * (0.3 * t).sin()),
                1.6 + 0.6 * (0.25 * t).cos(),
            );
            vec![root, chest, head, knee, ankle]
        })
        .collect();
    Motion {
        frames: (5..5 + frames as u64).collect(),
        joints,
    }
}

/// Onto the source skeleton in its first frame's pose, rigid bones come back as tracked. (With
/// stretching bones they do up to the lengths' anchor: the median length, not the first
/// frame's; see the module docs.)
#[test]
fn identity_retarget_reproduces_the_tracks() {
    let s = skel();
    let m = wobbly_stretching(80, 0.0);
    let ident = Mapping::identity(&s);
    let rest: Vec<Point> = m.joints[0]
        .iter()
        .map(|p| Point::new(p[0] as f32, p[1] as f32))
        .collect();
    let place = place(
        &s,
        &rest,
        Scale::Fit,
        &ident,
        &m.joints[0],
        &reference_lengths(&m.joints, &ident),
    );
    let rest_out: Vec<P64> = rest.iter().map(|&p| place.apply(p)).collect();
    let r = retarget(&m, &s, &ident, &rest_out, &stretching());
    assert_eq!(r.frames, m.frames);
    let mut worst: f64 = 0.0;
    for (a, b) in r.joints.iter().zip(&m.joints) {
        for (p, q) in a.iter().zip(b) {
            worst = worst.max(dist(*p, *q));
        }
    }
    // The rest position only goes through f32 (the character file's precision).
    assert!(worst < 0.01, "worst joint error {worst} px");
}

#[test]
fn length_ratios_and_angle_increments_carry_over_exactly() {
    let s = skel();
    let m = wobbly(120);
    let ident = Mapping::identity(&s);
    // A target with other proportions and another rest pose.
    let rest_out: Vec<P64> = vec![
        [300.0, 100.0],
        [310.0, 20.0],
        [300.0, 0.0],
        [280.0, 150.0],
        [300.0, 220.0],
    ];
    let r = retarget(&m, &s, &ident, &rest_out, &stretching());
    for (b, &(p, c)) in s.bones().iter().enumerate() {
        let (l, a) = bone_signals(
            &m.joints,
            &mapping::SourcePoint(vec![p]),
            &mapping::SourcePoint(vec![c]),
        );
        for t in 1..m.frames.len() {
            let want = l[t] / l[t - 1];
            let got = r.length[t][b] / r.length[t - 1][b];
            assert!(
                (got - want).abs() < 1e-12,
                "bone {b} frame {t}: ratio {got} vs {want}"
            );
            let want = a[t] - a[t - 1];
            let got = r.angle[t][b] - r.angle[t - 1][b];
            assert!(
                (got - want).abs() < 1e-12,
                "bone {b} frame {t}: Δangle {got} vs {want}"
            );
            // The joints agree with the bone table.
            let (jp, jc) = (r.joints[t][p], r.joints[t][c]);
            assert!((dist(jp, jc) - r.length[t][b]).abs() < 1e-9);
        }
    }
    // The spinning head bone turned once around: unwrapped, it never jumps by 2π.
    let head = s.bones().iter().position(|&(_, c)| c == 2).unwrap();
    let total = r.angle.last().unwrap()[head] - r.angle[0][head];
    assert!(
        (total - 119.0 * std::f64::consts::TAU / 40.0).abs() < 1e-9,
        "{total}"
    );
    // The root moves by the source's displacement times the size ratio.
    let (target_size, source_size) =
        driven_sizes(&s, &rest_out, &reference_lengths(&m.joints, &ident));
    let ratio = target_size / source_size;
    let t = 50;
    for (axis, rest) in rest_out[0].iter().enumerate() {
        let want = ratio * (m.joints[t][0][axis] - m.joints[0][0][axis]);
        assert!((r.joints[t][0][axis] - rest - want).abs() < 1e-9);
    }
}

#[test]
fn place_fits_size_and_stands_on_the_source_floor() {
    let s = skel();
    let src: Vec<P64> = vec![
        [100.0, 100.0],
        [100.0, 50.0],
        [100.0, 30.0],
        [100.0, 150.0],
        [100.0, 200.0],
    ];
    // The same figure at half size elsewhere in its image.
    let rest: Vec<Point> = src
        .iter()
        .map(|p| Point::new((p[0] * 0.5 + 7.0) as f32, (p[1] * 0.5 + 3.0) as f32))
        .collect();
    let ident = Mapping::identity(&s);
    let reference = reference_lengths(std::slice::from_ref(&src), &ident);
    let pl = place(&s, &rest, Scale::Fit, &ident, &src, &reference);
    assert!((pl.scale - 2.0).abs() < 1e-9);
    for (p, q) in rest.iter().zip(&src) {
        let o = pl.apply(*p);
        assert!(dist(o, *q) < 1e-4, "{o:?} vs {q:?}");
    }
    let pl = place(&s, &rest, Scale::Factor(1.0), &ident, &src, &reference);
    assert_eq!(pl.scale, 1.0);
    assert!(
        (pl.apply(rest[4])[1] - 200.0).abs() < 1e-9,
        "lowest joint on the floor"
    );
}

#[test]
fn motion_from_tracks_wants_every_joint_every_frame() {
    let s = skel();
    let row = |f: u64, j: &str| TrackRow {
        frame: f,
        joint: j.into(),
        x: 1.0,
        y: 2.0,
        angle: 0.0,
        score: 1.0,
        status: "ok".into(),
    };
    let names = ["pelvis", "chest", "head", "knee", "ankle"];
    let mut rows: Vec<TrackRow> = (3..6).flat_map(|f| names.map(|n| row(f, n))).collect();
    let m = motion_from_tracks(&rows, &s, Path::new("tracks.csv")).unwrap();
    assert_eq!(m.frames, vec![3, 4, 5]);
    rows.remove(7);
    let e = motion_from_tracks(&rows, &s, Path::new("tracks.csv")).unwrap_err();
    assert!(
        e.to_string().contains("frame 4 does not list every joint"),
        "{e}"
    );
}

#[test]
fn smooth_parses_its_two_forms() {
    assert_eq!("median:5".parse(), Ok(Smooth::Median { window_frames: 5 }));
    assert_eq!(
        "gaussian:1.5".parse(),
        Ok(Smooth::Gaussian { sigma_frames: 1.5 })
    );
    assert!("median:4".parse::<Smooth>().is_err());
    assert!("box:3".parse::<Smooth>().is_err());
}

#[test]
fn bones_of_another_shape_are_driven_by_source_bones_and_the_rest_keep_their_angle() {
    // Source: COCO-like hips and shoulders, the left shoulder hanging from the left hip.
    // (joints: left_hip, right_hip, left_shoulder, right_shoulder, left_elbow)
    let frames = 30;
    let motion = Motion {
        frames: (0..frames as u64).collect(),
        joints: (0..frames)
            .map(|t| {
                let t = t as f64;
                let lean = 0.02 * t; // the torso leans right
                let (lh, rh) = ([110.0 + t, 200.0], [90.0 + t, 200.0]);
                let up = |p: P64| [p[0] + 60.0 * lean.sin(), p[1] - 60.0 * lean.cos()];
                let (ls, rs) = (up(lh), up(rh));
                let a = 1.5 - 0.05 * t; // the left upper arm swings
                vec![
                    lh,
                    rh,
                    ls,
                    rs,
                    [ls[0] + 30.0 * a.cos(), ls[1] + 30.0 * a.sin()],
                ]
            })
            .collect(),
    };
    // Target: pelvis -> chest -> elbow_l, pelvis -> tail (nothing drives the tail).
    let target = Skeleton::new(
        ["pelvis", "chest", "elbow_l", "tail"]
            .map(String::from)
            .to_vec(),
        vec![None, Some(0), Some(1), Some(0)],
    );
    let rest_out: Vec<P64> = vec![[0.0, 0.0], [0.0, -50.0], [20.0, -30.0], [-10.0, 10.0]];
    let pt = |v: &[usize]| mapping::SourcePoint(v.to_vec());
    let m = Mapping {
        bone: vec![
            Some((pt(&[0, 1]), pt(&[2, 3]))),
            Some((pt(&[2]), pt(&[4]))),
            None,
        ],
        root: vec![Some(pt(&[0, 1])), None, None, None],
        keep_length: vec![false; 3],
    };
    let r = retarget(&motion, &target, &m, &rest_out, &stretching());
    for t in 0..frames {
        // The chest leans with the mid-hips -> mid-shoulders line.
        let lean = r.angle[t][0] - r.angle[0][0];
        assert!((lean - 0.02 * t as f64).abs() < 1e-9, "{t}: {lean}");
        // The upper arm turns with the source's, whatever the chest does.
        let arm = r.angle[t][1] - r.angle[0][1];
        assert!((arm + 0.05 * t as f64).abs() < 1e-9, "{t}: {arm}");
        // The tail keeps its rest angle and length (its parent is the root: no bone to follow).
        assert!((r.angle[t][2] - r.angle[0][2]).abs() < 1e-12);
        assert!((r.length[t][2] - dist(rest_out[0], rest_out[3])).abs() < 1e-9);
        // The root follows the hips' midpoint, scaled by the driven bones' size ratio.
        let (ts, ss) = driven_sizes(&target, &rest_out, &reference_lengths(&motion.joints, &m));
        let want = rest_out[0][0] + ts / ss * t as f64;
        assert!((r.joints[t][0][0] - want).abs() < 1e-9, "{t}");
    }
    // An undriven bone under a driven one turns with it.
    let m2 = Mapping {
        bone: vec![Some((pt(&[0, 1]), pt(&[2, 3]))), None, None],
        root: m.root.clone(),
        keep_length: vec![false; 3],
    };
    let r = retarget(&motion, &target, &m2, &rest_out, &stretching());
    for t in 0..frames {
        let d = (r.angle[t][1] - r.angle[t][0]) - (r.angle[0][1] - r.angle[0][0]);
        assert!(d.abs() < 1e-12, "{t}: {d}");
    }
}

#[test]
fn lengths_are_anchored_at_the_median_so_an_odd_first_frame_does_not_carry_over() {
    // A shin 4 px long on the first frame (a bad label), 100 px on every other.
    let s = Skeleton::new(vec!["knee".into(), "ankle".into()], vec![None, Some(0)]);
    let motion = Motion {
        frames: (0..20).collect(),
        joints: (0..20)
            .map(|t| {
                let l = if t == 0 { 4.0 } else { 100.0 };
                vec![[50.0, 50.0], [50.0, 50.0 + l]]
            })
            .collect(),
    };
    let rest_out = vec![[0.0, 0.0], [0.0, 60.0]];
    let m = Mapping::identity(&s);
    let r = retarget(&motion, &s, &m, &rest_out, &stretching());
    // The target's rest length stands for the typical 100 px, not for the first frame's 4 px.
    for t in 1..20 {
        assert!(
            (r.length[t][0] - 60.0).abs() < 1e-9,
            "{t}: {}",
            r.length[t][0]
        );
    }
    // The 4 px frame: a ratio of 0.04, kept at the lower bound.
    assert!((r.length[0][0] - 60.0 * MIN_LENGTH_RATIO).abs() < 1e-9);
    assert_eq!(reference_lengths(&motion.joints, &m), vec![Some(100.0)]);
}

#[test]
fn keep_size_holds_the_size_when_the_whole_source_zooms() {
    // The wobbly motion, rigid, zoomed about (100, 200) by a factor going 1 -> 0.5 (the
    // subject stepping back), with the chest bone also stretching by 20 % on its own.
    let s = skel();
    let base = wobbly_stretching(40, 0.0);
    let zoom = |t: usize| 1.0 - 0.5 * t as f64 / 39.0;
    let motion = Motion {
        frames: base.frames.clone(),
        joints: base
            .joints
            .iter()
            .enumerate()
            .map(|(t, f)| {
                let mut f: Vec<P64> = f
                    .iter()
                    .map(|p| {
                        [
                            100.0 + zoom(t) * (p[0] - 100.0),
                            200.0 + zoom(t) * (p[1] - 200.0),
                        ]
                    })
                    .collect();
                if t >= 20 {
                    // chest (1) away from the pelvis (0) by 20 % more.
                    f[1] = [
                        f[0][0] + 1.2 * (f[1][0] - f[0][0]),
                        f[0][1] + 1.2 * (f[1][1] - f[0][1]),
                    ];
                    f[2] = [
                        f[1][0] + (base.joints[t][2][0] - base.joints[t][1][0]) * zoom(t),
                        f[1][1] + (base.joints[t][2][1] - base.joints[t][1][1]) * zoom(t),
                    ];
                }
                f
            })
            .collect(),
    };
    let m = Mapping::identity(&s);
    let rest_out = motion.joints[0].clone();
    let keep = RetargetOptions {
        keep_size: true,
        ..stretching()
    };
    let r = retarget(&motion, &s, &m, &rest_out, &keep);
    let free = retarget(&motion, &s, &m, &rest_out, &stretching());
    let rest_len = |b: usize| {
        let (p, c) = s.bones()[b];
        dist(rest_out[p], rest_out[c])
    };
    let knee = s.bones().iter().position(|&(_, c)| c == 3).unwrap();
    let chest = s.bones().iter().position(|&(_, c)| c == 1).unwrap();
    let ref_ratio = |r: &Retargeted, t: usize, b: usize| r.length[t][b] / rest_len(b);
    // Without it the knee bone shrinks with the zoom; with it, the knee keeps one length...
    assert!((ref_ratio(&free, 0, knee) / ref_ratio(&free, 39, knee) - 2.0).abs() < 1e-9);
    assert!((ref_ratio(&r, 0, knee) - ref_ratio(&r, 39, knee)).abs() < 1e-9);
    // ... and the chest still stretches by its own 20 % against the other bones.
    let rel = |t: usize| ref_ratio(&r, t, chest) / ref_ratio(&r, t, knee);
    assert!(
        (rel(30) / rel(10) - 1.2).abs() < 1e-9,
        "{}",
        rel(30) / rel(10)
    );
}

/// By default every bone keeps the character's rest length whatever its source bone does, and
/// the angles still follow exactly.
#[test]
fn by_default_bones_keep_their_length_and_follow_the_angles() {
    let s = skel();
    let m = wobbly_stretching(60, 1.0);
    let ident = Mapping::identity(&s);
    let rest_out = m.joints[0].clone();
    let opts = RetargetOptions {
        plant_feet: false,
        ..Default::default()
    };
    let r = retarget(&m, &s, &ident, &rest_out, &opts);
    let stretched = retarget(&m, &s, &ident, &rest_out, &stretching());
    let mut varied: f64 = 0.0;
    for t in 0..60 {
        for (b, &(p, c)) in s.bones().iter().enumerate() {
            let rest = dist(rest_out[p], rest_out[c]);
            assert!((dist(r.joints[t][p], r.joints[t][c]) - rest).abs() < 1e-9);
            assert!((r.angle[t][b] - stretched.angle[t][b]).abs() < 1e-12);
            varied = varied.max((stretched.length[t][b] / rest - 1.0).abs());
        }
    }
    // The source stretches (chest ±20 %, shin ±25 %): with --stretch the target does too.
    assert!(varied > 0.15, "{varied}");
}
