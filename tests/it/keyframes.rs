//! A tracker built on a correction keyframe takes the seed frame's appearance for the bones
//! hidden on that keyframe, and only for those.

use crate::common::synth_clip;
use mocap2d::background::Background;
use mocap2d::seed::parse_seeds;
use mocap2d::synth::Scenario;
use mocap2d::track::Tracker;
use std::path::Path;

#[test]
fn bones_hidden_on_a_keyframe_keep_the_seed_appearance() {
    let clip = synth_clip(Scenario::Occlude, 640, 360, 1, Some(120));
    let seeds = parse_seeds(&clip.seeds_toml(), Path::new("seeds")).unwrap();
    let name = |j: usize| clip.joint_names[j].as_str();
    let wrist = clip
        .joint_names
        .iter()
        .position(|n| n == "wrist_r")
        .unwrap();
    let elbow = clip.parents[wrist].unwrap();
    let plate = || Some(Background::fit(std::slice::from_ref(&clip.background)).unwrap());
    let seed = Tracker::new(Default::default(), &seeds, &clip.frames[0], plate());
    // A keyframe on frame `f`: the seed file moved to the ground truth there.
    let adopted_on = |f: usize| {
        let mut at = seeds.clone();
        at.frame = f as u64;
        for (j, joint) in at.joints.iter_mut().enumerate() {
            (joint.bbox.cx, joint.bbox.cy) = clip.gt[f][j];
        }
        let mut t = Tracker::new(Default::default(), &at, &clip.frames[f], plate());
        t.adopt_hidden_from(&seed, &clip.frames[f])
    };
    // The frame where the far (right) arm is most hidden, and the one where the least visible
    // joint is most in sight.
    let vis = |f: usize, j: usize| clip.visibility[f][j];
    let hidden = (1..clip.frames.len())
        .min_by(|&a, &b| {
            (vis(a, elbow) + vis(a, wrist)).total_cmp(&(vis(b, elbow) + vis(b, wrist)))
        })
        .unwrap();
    let open = (1..clip.frames.len())
        .max_by(|&a, &b| {
            let m = |f: usize| (0..clip.gt[f].len()).map(|j| vis(f, j)).fold(1.0, f32::min);
            m(a).total_cmp(&m(b))
        })
        .unwrap();
    let on_hidden = adopted_on(hidden);
    println!(
        "frame {hidden} ({} {:.2}, {} {:.2}): {:?}; frame {open}: {:?}",
        name(elbow),
        vis(hidden, elbow),
        name(wrist),
        vis(hidden, wrist),
        on_hidden.iter().map(|&j| name(j)).collect::<Vec<_>>(),
        adopted_on(open)
            .iter()
            .map(|&j| name(j))
            .collect::<Vec<_>>()
    );
    assert!(on_hidden.contains(&wrist), "{on_hidden:?}");
    assert!(
        on_hidden.iter().all(|&j| j == elbow || j == wrist),
        "only the hidden arm: {on_hidden:?}"
    );
    assert!(adopted_on(open).is_empty());
}

/// A key that gives some joints only restarts those: a joint it leaves out keeps what the
/// tracker knew of it (hidden stays hidden, its score stays), where a correction of every joint
/// (`restart_moving`) calls each one seen on the key.
#[test]
fn a_key_of_some_joints_leaves_the_others_as_the_tracker_had_them() {
    use mocap2d::track::Status;
    let clip = synth_clip(Scenario::Occlude, 320, 180, 1, Some(40));
    let seeds = parse_seeds(&clip.seeds_toml(), Path::new("seeds")).unwrap();
    let at = |n: &str| clip.joint_names.iter().position(|x| x == n).unwrap();
    let (knee, elbow) = (at("knee_l"), at("elbow_r"));
    let sample: Vec<_> = clip.frames.iter().step_by(4).cloned().collect();
    let plate = || Some(Background::fit(&sample).unwrap());
    let mut t = Tracker::new(Default::default(), &seeds, &clip.frames[0], plate());
    // Tracked to frame 34, where the far elbow is behind the torso.
    for f in &clip.frames[1..=34] {
        t.step(f);
    }
    let before = t.current();
    assert!(
        matches!(before[elbow].status, Status::Occluded | Status::Lost),
        "{:?}",
        before[elbow]
    );
    let mut centres: Vec<_> = before.iter().map(|e| e.pos).collect();
    centres[knee].x += 3.0;
    let keyed: Vec<bool> = (0..centres.len()).map(|j| j == knee).collect();
    let mut some = Tracker::new(Default::default(), &seeds, &clip.frames[0], plate());
    assert!(some.restore_state(&t.state()));
    let mut all = Tracker::new(Default::default(), &seeds, &clip.frames[0], plate());
    assert!(all.restore_state(&t.state()));
    some.restart_moving_keyed(&centres, &keyed);
    all.restart_moving(&centres);
    let (some, all) = (some.current(), all.current());
    assert_eq!(some[knee].status, Status::Seed);
    assert!(
        (some[knee].pos.x - centres[knee].x).abs() < 1e-3,
        "{:?}",
        some[knee]
    );
    assert_eq!(some[elbow], before[elbow], "the elbow the key left out");
    assert_eq!(all[elbow].status, Status::Seed);
}
