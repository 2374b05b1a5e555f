//! Tests of the report: evidence, segment needs, the markdown.
use super::*;
use crate::geom::Point;
use crate::run::evidence::Stream;
use crate::run::evidence::{evidence, NEAR};
use crate::skeleton::Skeleton;
use crate::track::Status;

/// Two joints (a root and its child 10 px to the right) still for `n` frames, all `ok`.
fn still(n: usize) -> (Table, Skeleton) {
    let t = Table {
        frames: (0..n as u64).collect(),
        pos: vec![vec![Point::new(0.0, 0.0), Point::new(10.0, 0.0)]; n],
        score: vec![vec![0.9, 0.9]; n],
        status: vec![vec![Status::Ok; 2]; n],
    };
    let sk = Skeleton {
        names: vec!["a".into(), "b".into()],
        parents: vec![None, Some(0)],
    };
    (t, sk)
}

fn report(t: &Table, sk: &Skeleton) -> (Evidence, Report) {
    let th = Thresholds::default();
    let ev = evidence(t, sk, &[10.0, 10.0], &[0.0, 10.0], &th);
    let plan = Plan {
        seed_frame: 0,
        len: 10,
    };
    let r = Report::build(t, &ev, &sk.names, &plan, &[], 3, &th);
    (ev, r)
}

#[test]
fn doubts_on_the_first_and_last_frames_spread_inwards() {
    let (mut t, sk) = still(20);
    t.status[0][1] = Status::Occluded;
    t.status[19][1] = Status::Occluded;
    let (ev, _) = report(&t, &sk);
    let b: Vec<u8> = ev.mask.iter().map(|m| m[1]).collect();
    assert_eq!(b[0], HIDDEN);
    assert_eq!(b[19], HIDDEN);
    assert!(b[1..=5].iter().all(|&m| m == NEAR), "{b:?}");
    assert!(b[14..=18].iter().all(|&m| m == NEAR), "{b:?}");
    assert!(b[6..=13].iter().all(|&m| m == 0), "{b:?}");
}

#[test]
fn the_stream_holds_a_window_not_the_clip() {
    // 10 000 frames through the stream: each comes out `spread` frames after it goes in,
    // in order, and no more than the window is ever held.
    let (t, sk) = still(1);
    let th = Thresholds::default();
    let (sides, seed_len) = ([10.0, 10.0], [0.0, 10.0]);
    let mut s = Stream::new(&sk, &sides, &seed_len, &th);
    let mut out = Vec::new();
    for f in 0..10_000u64 {
        out.extend(s.push(f, &t.pos[0], &t.score[0], &t.status[0]));
        assert_eq!(out.len() as u64, (f + 1).saturating_sub(th.spread));
        assert!(s.held_frames() <= 2 * th.spread as usize + 1);
    }
    out.extend(s.finish());
    assert!(out.iter().map(|j| j.frame).eq(0..10_000));
}

#[test]
fn a_still_clip_needs_no_look() {
    let (t, sk) = still(30);
    let (ev, r) = report(&t, &sk);
    assert!(ev.mask.iter().flatten().all(|&b| b == 0));
    assert_eq!(r.segments.len(), 3);
    assert!(r.ranked().is_empty());
    assert_eq!(r.summary(), "no segment needs a look");
}

#[test]
fn a_jump_and_a_stretched_bone_flag_their_segment() {
    let (mut t, sk) = still(30);
    // Frames 12 on: the child jumps 20 px away (2 sides; its bone triples).
    for p in &mut t.pos[12..] {
        p[1] = Point::new(30.0, 0.0);
    }
    let (ev, r) = report(&t, &sk);
    assert_eq!(
        ev.mask[12][1] & (JUMP | RESIDUAL | BONE),
        JUMP | RESIDUAL | BONE
    );
    assert_eq!(ev.mask[7][1], NEAR, "spread 5 frames back");
    assert_eq!(ev.mask[6][1], 0);
    // Segment 1 holds 8 stretched frames (weight 0.46 each), segment 2 ten; segment 0
    // only frames near them.
    let ranked: Vec<u64> = r.ranked().iter().map(|s| s.index).collect();
    assert_eq!(ranked, [2, 1]);
    assert_eq!(r.files_to_correct(), [1, 2]);
    let s1 = &r.segments[1];
    assert_eq!((s1.joints[0].joint.as_str(), s1.joints[0].first), ("b", 10));
    assert!((s1.need - 8.0 * 0.46).abs() < 1e-3, "{}", s1.need);
    assert!(
        r.summary().starts_with("segments 2, 1 need a look"),
        "{}",
        r.summary()
    );
    let md = r.to_markdown();
    assert!(
        md.contains("| b | 10–19 | 10 | jump, off its motion, bone length |"),
        "{md}"
    );
    assert!(md.contains("Segments not flagged: 000."), "{md}");
}
