//! The deformed character holds together (docs/method.md §5.4–§5.8): a tracked walk retargeted
//! onto the dancer and rendered gives no frame with a folded triangle or a crack, and the check
//! that says so still finds the cracks the seam fillers cover when they are left out.

use crate::common::{self, characters, run as mocap2d, s, synth_clip};
use mocap2d::app::Renderer;
use mocap2d::character::read_character;
use mocap2d::deform::{check, DeformOptions};
use mocap2d::geom::Point;
use mocap2d::retarget::files::{read_manifest, read_pose};
use mocap2d::synth::Scenario;

#[test]
fn a_walk_rendered_onto_the_dancer_neither_folds_nor_cracks_on_any_frame() {
    let d = tempfile::tempdir().unwrap();
    let c = synth_clip(Scenario::Walk, 320, 240, 1, Some(60));
    let run = common::run_from_gt(d.path(), &c, 0, |_, _| 1.0);
    let target = characters("dancer.toml");
    let o = mocap2d(&["retarget", s(&run), "--target", s(&target)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let frames = d.path().join("frames");
    let o = mocap2d(&[
        "render",
        s(&run),
        "--target",
        s(&target),
        "--frames-dir",
        s(&frames),
    ]);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    assert!(err.contains("rendered 60 frames"), "{err}");
    assert!(!err.contains("folded or cracked"), "{err}");

    // The same frames through the library: clean, and without the fillers the seams do crack
    // (so the check above could have failed).
    let ch = read_character(&target).unwrap();
    let m = read_manifest(&run.join("retarget/retarget.toml")).unwrap();
    let r = Renderer::new(&ch, m.scale, m.width, m.height, DeformOptions::default()).unwrap();
    let (_, joints) = read_pose(&run.join("retarget/pose.csv"), &ch.skeleton.names).unwrap();
    assert!(!r.rig.fill.is_empty());
    let mut cracked_without_fill = 0;
    for f in &joints {
        let pts: Vec<Point> = f
            .iter()
            .map(|p| Point::new(p[0] as f32, p[1] as f32))
            .collect();
        let pos = r.rig.deform(&pts);
        let with = r.rig.defects(&pos);
        assert!(with.is_clean(), "{with:?}");
        let without = check::defects(&r.rig.mesh, &r.rig.seams, &[], &pos);
        assert!(without.folded.is_empty());
        if !without.cracks.is_empty() {
            cracked_without_fill += 1;
        }
    }
    assert!(
        cracked_without_fill > 0,
        "no seam opened onto the ground even without the fillers: the walk tests nothing"
    );
}
