//! The working resolution: large frames are tracked halved, with positions in and out at the
//! frame's own resolution.

use crate::common::synth_clip;
use image::RgbImage;
use mocap2d::background::Background;
use mocap2d::seed::parse_seeds;
use mocap2d::synth::Scenario;
use mocap2d::track::{TrackParams, Tracker};
use std::path::Path;

/// `img` with every pixel doubled into a 2×2 block: halving it gives `img` back exactly.
fn doubled(img: &RgbImage) -> RgbImage {
    RgbImage::from_fn(2 * img.width(), 2 * img.height(), |x, y| {
        *img.get_pixel(x / 2, y / 2)
    })
}

/// A frame twice the size, tracked halved, gives the small frame's tracks to the bit, mapped to
/// the large frame's pixels (`2x + 0.5`: working pixel `x` is the block of frame pixels `2x`
/// and `2x + 1`). So halving changes nothing but the resolution, and the two sizes share every
/// other step of the tracker (appearance, search, refinement, judging, learning).
#[test]
fn twice_the_pixels_tracked_halved_are_the_same_tracks() {
    let clip = synth_clip(Scenario::Occlude, 320, 180, 2, Some(40));
    let small = parse_seeds(&clip.seeds_toml(), Path::new("joints.toml")).unwrap();
    // The same seed file at twice the size: centres at 2x + 0.5, sides doubled.
    let mut large = small.clone();
    for j in &mut large.joints {
        j.bbox.cx = 2.0 * j.bbox.cx + 0.5;
        j.bbox.cy = 2.0 * j.bbox.cy + 0.5;
        j.bbox.w *= 2;
        j.bbox.h *= 2;
    }
    // 11-px rectangles at 320x180: with 10 px the small frames stay whole, the large are halved.
    // Judged at full resolution: `judge_level` counts the frame's levels, so at 1 the large
    // frame would be judged on its level 1, which is the small frame's level 0, not its 1.
    let params = TrackParams {
        work_box_px: 10.0,
        judge_level: 0,
        ..TrackParams::default()
    };
    let bg = Background::fit(&clip.frames.iter().step_by(4).cloned().collect::<Vec<_>>()).unwrap();
    let bg_large = Background {
        plate: doubled(&bg.plate),
        threshold: bg.threshold,
        lit_threshold: bg.lit_threshold,
    };
    let mut a = Tracker::new(params.clone(), &small, &clip.frames[0], Some(bg));
    let mut b = Tracker::new(
        params.clone(),
        &large,
        &doubled(&clip.frames[0]),
        Some(bg_large.clone()),
    );
    assert_eq!(a.work_scale().halvings, 0);
    assert_eq!(b.work_scale().halvings, 1);
    let mut moved = 0.0f32;
    for frame in &clip.frames[1..] {
        let ea = a.step(frame);
        let eb = b.step(&doubled(frame));
        for (x, y) in ea.iter().zip(&eb) {
            assert_eq!(y.pos.x, 2.0 * x.pos.x + 0.5);
            assert_eq!(y.pos.y, 2.0 * x.pos.y + 0.5);
            assert_eq!(
                (y.angle_rad, y.score, y.status),
                (x.angle_rad, x.score, x.status)
            );
        }
        moved = moved.max((ea[0].pos - small.joints[0].bbox.centre()).norm());
    }
    // The clip moves the body, so the comparison covers a real track.
    assert!(moved > 5.0, "the root moved only {moved} px");
    // A state moves between trackers at the same working resolution (as a run's segments do).
    let mut c = Tracker::new(params, &large, &doubled(&clip.frames[0]), Some(bg_large));
    assert!(c.restore_state(&b.state()));
    assert_eq!(c.current(), b.current());
}

/// Frames made as the decode thread makes them (the working image halved beforehand) and shared
/// by two trackers (the second borrows the pyramid the first made) give each tracker the same
/// estimates, to the bit, as frames it halves itself.
#[test]
fn frames_made_beforehand_and_shared_track_as_plain_frames() {
    use mocap2d::track::scale::Frame;
    let clip = synth_clip(Scenario::Walk, 320, 180, 4, Some(30));
    let seeds = parse_seeds(&clip.seeds_toml(), Path::new("joints.toml")).unwrap();
    let params = TrackParams {
        work_box_px: 5.0,
        ..TrackParams::default()
    };
    let bg = Background::fit(&clip.frames.iter().step_by(4).cloned().collect::<Vec<_>>()).unwrap();
    let make = || Tracker::new(params.clone(), &seeds, &clip.frames[0], Some(bg.clone()));
    let (mut plain, mut first, mut second) = (make(), make(), make());
    let work = plain.work_scale();
    assert_eq!(work.halvings, 1);
    let recycler = mocap2d::decode::Recycler::new();
    for img in &clip.frames[1..] {
        let frame: Frame = work.frame(img.clone(), Some(&recycler), false);
        let want = plain.step(img);
        assert_eq!(first.step(&frame), want);
        assert_eq!(second.step(&frame), want);
    }
    assert_ne!(
        plain.current()[0].pos,
        seeds.joints[0].bbox.centre(),
        "the body moved"
    );
}

/// A run tracked halved goes through segments, a resume and a correction like any other: the
/// state checkpointed at a segment restores to the same bytes, and a correction whose
/// rectangles are twice the seed file's (sizes may change in a correction) still builds its
/// tracker at the run's working resolution and puts its joints where the user did.
#[cfg(feature = "ffmpeg")]
#[test]
fn a_run_tracked_halved_resumes_and_takes_corrections() {
    use crate::common::write_synth;
    use mocap2d::app::{resume, track, ResumeOptions, TrackOptions};
    use mocap2d::progress::NoProgress;
    use mocap2d::run::segments::file_path;
    use mocap2d::run::tracks::read_tracks;
    use mocap2d::seed::{read_seeds, to_toml};

    let dir = tempfile::tempdir().unwrap();
    let clip = write_synth(dir.path(), Scenario::Walk, 320, 180, 3, Some(60));
    let run = dir.path().join("run");
    // 11-px rectangles: with 5 px they are tracked halved.
    let params = TrackParams {
        work_box_px: 5.0,
        ..TrackParams::default()
    };
    let opts = TrackOptions {
        out: Some(run.clone()),
        segment_len: 20,
        params: params.clone(),
        ..TrackOptions::new(dir.path().join("clip.mp4"), dir.path().join("joints.toml"))
    };
    track(&opts, &NoProgress).unwrap();
    let tracked = std::fs::read(run.join("tracks.csv")).unwrap();
    let resume_from = |segment| {
        let o = ResumeOptions {
            run: run.clone(),
            segment,
            ..Default::default()
        };
        resume(&o, &NoProgress).unwrap().unwrap();
    };
    resume_from(Some(1));
    assert!(std::fs::read(run.join("tracks.csv")).unwrap() == tracked);

    // Segment 2's file (frame 40) corrected to the ground truth, its rectangles doubled.
    let p = file_path(&run, 2);
    let (mut seeds, _) = read_seeds(&p).unwrap();
    for (j, joint) in seeds.joints.iter_mut().enumerate() {
        let (x, y) = clip.gt[40][j];
        let b = &mut joint.bbox;
        b.w *= 2;
        b.h *= 2;
        let half = |s: u32| s as f32 / 2.0 - 0.5;
        b.cx = x.clamp(half(b.w), 319.0 - half(b.w));
        b.cy = y.clamp(half(b.h), 179.0 - half(b.h));
    }
    std::fs::write(&p, to_toml(40, &seeds.joints, "corrected")).unwrap();
    resume_from(None);
    let rows = read_tracks(&run.join("tracks.csv")).unwrap();
    let at_40: Vec<_> = rows.iter().filter(|r| r.frame == 40).collect();
    assert_eq!(at_40.len(), seeds.joints.len());
    for (r, j) in at_40.iter().zip(&seeds.joints) {
        assert_eq!(r.status, "seed");
        assert!((r.x - j.bbox.cx).abs() < 0.01 && (r.y - j.bbox.cy).abs() < 0.01);
    }
    // Frames before the resumed segment are as they were.
    let before = |bytes: &[u8]| {
        let text = String::from_utf8(bytes.to_vec()).unwrap();
        text.lines()
            .filter(|l| {
                l.split(',')
                    .next()
                    .and_then(|f| f.parse::<u64>().ok())
                    .is_some_and(|f| f < 40)
            })
            .map(str::to_owned)
            .collect::<Vec<_>>()
    };
    assert_eq!(
        before(&std::fs::read(run.join("tracks.csv")).unwrap()),
        before(&tracked)
    );
}
