use super::*;
use image::RgbImage;

fn frame(sx: f32) -> GreyPyramid {
    let img = RgbImage::from_fn(160, 120, |x, y| {
        let u = x as f32 - sx;
        let g = 128.0 + 60.0 * (u * 0.21).sin() * (y as f32 * 0.17).cos();
        image::Rgb([g as u8, g as u8, g as u8])
    });
    GreyPyramid::new(&img, 3)
}

#[test]
fn the_keys_say_which_cue_leads_a_span() {
    // The tracker hit the keys for most joints and called the span ok: not led by flow, and
    // only a joint whose tracker missed and whose Lucas–Kanade landed at under half the
    // miss takes the flow.
    let drawn = [
        Some((1.0, 9.0)),
        Some((1.5, 12.0)),
        Some((20.0, 5.0)),
        Some((20.0, 15.0)),
        None,
    ];
    assert_eq!(lead(&drawn, 0.9), Lead::Tracker);
    assert_eq!(
        keep_tracker(&drawn, Lead::Tracker),
        [true, true, false, true, true]
    );
    // Lucas–Kanade landed nearer for most joints: every joint the tracker missed follows it.
    let video = [
        Some((60.0, 20.0)),
        Some((80.0, 30.0)),
        Some((1.0, 9.0)),
        Some((20.0, 15.0)),
    ];
    assert_eq!(lead(&video, 0.9), Lead::Flow);
    assert_eq!(
        keep_tracker(&video, Lead::Flow),
        [false, false, true, false]
    );
    // The tracker lost most joint-frames but landed nearer for the median joint: each
    // joint follows whichever landed nearer.
    assert_eq!(lead(&drawn, 0.3), Lead::Doubt);
    assert_eq!(
        keep_tracker(&drawn, Lead::Doubt),
        [true, true, false, false, true]
    );
    let mixed = [Some((20.0, 15.0)), Some((20.0, 25.0)), Some((30.0, 40.0))];
    assert_eq!(lead(&mixed, 0.3), Lead::Doubt);
    assert_eq!(keep_tracker(&mixed, Lead::Doubt), [false, true, true]);
    // In doubt, and the blend hardly ever found the body: the flow leads. Only doubt is
    // settled so.
    assert_eq!(settle(Lead::Doubt, 0.1), Lead::Flow);
    assert_eq!(settle(Lead::Doubt, 0.4), Lead::Doubt);
    assert_eq!(settle(Lead::Tracker, 0.1), Lead::Tracker);
}

#[test]
fn path_follows_the_motion_and_meets_both_keys() {
    let frames: Vec<_> = (0..6).map(|t| frame(2.0 * t as f32)).collect();
    let start = [Point::new(60.0, 60.0)];
    // The end key 1 px off the true motion: the path must still end on it, and lean
    // toward it the nearer it is.
    let end = [Some(Point::new(71.0, 60.0))];
    let out = solve(
        &frames,
        &start,
        Some(&end),
        &[],
        &[],
        &[25],
        &KeyedParams::default(),
    )
    .rows;
    assert_eq!(out[5][0].pos, Point::new(71.0, 60.0));
    for (t, row) in out.iter().enumerate() {
        let want = 60.0 + 2.0 * t as f32 + 0.2 * t as f32;
        assert!(
            (row[0].pos.x - want).abs() < 0.3,
            "frame {t}: {:?}",
            row[0].pos
        );
        assert!(row[0].sigma_px < 3.0, "frame {t}: {:?}", row[0]);
    }
}
