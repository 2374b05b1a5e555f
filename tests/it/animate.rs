//! Retarget and render, end to end, on run folders built from synthetic ground truth (so the
//! tests do not depend on tracking accuracy): identity retarget, area preservation over a squash
//! clip, no inverted triangle over a walk, the cartoon filter on a step, deterministic renders,
//! and the exit code and message of every target-file error.

use crate::common::{self, bin, characters, run as mocap2d, s, synth_clip};
use mocap2d::app::{self, RenderOptions, Renderer};
use mocap2d::character::read_character;
use mocap2d::deform::DeformOptions;
use mocap2d::geom::Point;
use mocap2d::progress::NoProgress;
use mocap2d::render::{coverage, Texture};
use mocap2d::retarget::cleanup::Cleanup;
use mocap2d::retarget::files::read_pose;
use mocap2d::retarget::{Cartoon, RetargetOptions};
use mocap2d::synth::{Scenario, SynthClip};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn clip(scenario: Scenario, w: u32, h: u32, frames: u32) -> SynthClip {
    synth_clip(scenario, w, h, 1, Some(frames))
}

/// A run folder whose tracks are `clip`'s ground truth: tracks.csv, seeds.toml, run.toml.
fn run_from_gt(dir: &Path, clip: &SynthClip) -> PathBuf {
    common::run_from_gt(dir, clip, 0, |_, _| 1.0)
}

/// The joints of every frame of `RUN/retarget/pose.csv`, as points.
fn poses(run: &Path, names: &[String]) -> Vec<Vec<Point>> {
    let (_, joints) = read_pose(&run.join("retarget/pose.csv"), names).unwrap();
    joints
        .iter()
        .map(|f| {
            f.iter()
                .map(|p| Point::new(p[0] as f32, p[1] as f32))
                .collect()
        })
        .collect()
}

#[test]
fn identity_retarget_reproduces_the_tracked_joints() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 160, 120, 40);
    let run = run_from_gt(d.path(), &c);
    // The target is the source skeleton: its rest pose is the seed frame, on an opaque image.
    image::RgbaImage::from_pixel(160, 120, image::Rgba([90, 90, 90, 255]))
        .save(d.path().join("same.png"))
        .unwrap();
    let mut toml = String::from("image = \"same.png\"\n");
    for (j, name) in c.joint_names.iter().enumerate() {
        let (x, y) = c.gt[0][j];
        let _ = write!(
            toml,
            "\n[[joint]]\nname = \"{name}\"\nx = {x:.3}\ny = {y:.3}\n"
        );
        if let Some(p) = c.parents[j] {
            let _ = writeln!(toml, "parent = \"{}\"", c.joint_names[p]);
        }
    }
    let target = d.path().join("same.toml");
    std::fs::write(&target, toml).unwrap();
    // Equations 16-19 alone: no clean-up, feet not planted.
    let o = mocap2d(&[
        "retarget",
        s(&run),
        "--target",
        s(&target),
        "--clean",
        "0",
        "--no-plant",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got = poses(&run, &c.joint_names);
    let mut worst = 0.0f32;
    for (f, joints) in got.iter().enumerate() {
        for (j, p) in joints.iter().enumerate() {
            let (x, y) = c.gt[f][j];
            worst = worst.max((p - Point::new(x, y)).norm());
        }
    }
    assert_eq!(got.len(), 40);
    assert!(worst <= 0.01, "worst joint error {worst} px");
    let bones = std::fs::read_to_string(run.join("retarget/bones.csv")).unwrap();
    assert!(
        bones.starts_with("frame,bone,length,angle\n0,pelvis->chest,"),
        "{}",
        &bones[..60]
    );
}

/// Mesh area drawn (alpha summed, overlaps counted) of every frame, relative to the rest frame.
fn area_changes(run: &Path, target: &Path, deform: DeformOptions) -> Vec<f64> {
    let ch = read_character(target).unwrap();
    let m = mocap2d::retarget::files::read_manifest(&run.join("retarget/retarget.toml")).unwrap();
    let r = Renderer::new(&ch, m.scale, m.width, m.height, deform).unwrap();
    let tex = Texture::new(&ch.image);
    let frames = poses(run, &ch.skeleton.names);
    let area = |j: &[Point]| {
        let pos = r.rig.deform(j);
        coverage(
            &pos,
            &r.rig.mesh.rest,
            &r.rig.mesh.triangles,
            &tex,
            m.width,
            m.height,
        )
    };
    let rest = area(&frames[0]);
    frames.iter().map(|j| area(j) / rest - 1.0).collect()
}

#[test]
fn area_preservation_holds_the_silhouette_area_over_a_squash_clip() {
    let d = tempfile::tempdir().unwrap();
    // Bones stretch and squash by ±30 %.
    let c = clip(Scenario::Squash, 480, 360, 60);
    let run = run_from_gt(d.path(), &c);
    // Lengths follow the source: squash and stretch.
    let stretch = RetargetOptions {
        stretch: true,
        ..Default::default()
    };
    for name in ["imp.toml", "robot.toml"] {
        let target = characters(name);
        app::retarget(&run, &target, &stretch).unwrap();
        let with = area_changes(&run, &target, DeformOptions::default());
        let worst = with.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            worst <= 0.03,
            "{name}: area off by up to {:.1} %",
            100.0 * worst
        );
        let without = area_changes(
            &run,
            &target,
            DeformOptions {
                area_preservation: false,
                stage_two: true,
            },
        );
        let worst_without = without.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            worst_without > 2.0 * worst,
            "{name}: without area preservation {:.1} %, with {:.1} %",
            100.0 * worst_without,
            100.0 * worst
        );
    }
}

#[test]
fn no_triangle_inverts_during_a_walk() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 480, 360, 80);
    let run = run_from_gt(d.path(), &c);
    for name in ["imp.toml", "robot.toml"] {
        let target = characters(name);
        app::retarget(&run, &target, &RetargetOptions::default()).unwrap();
        let ch = read_character(&target).unwrap();
        let m =
            mocap2d::retarget::files::read_manifest(&run.join("retarget/retarget.toml")).unwrap();
        let r = Renderer::new(&ch, m.scale, 480, 360, DeformOptions::default()).unwrap();
        for (f, joints) in poses(&run, &ch.skeleton.names).iter().enumerate() {
            let areas = r.rig.triangle_areas(&r.rig.deform(joints));
            let (t, worst) =
                areas
                    .iter()
                    .enumerate()
                    .fold((0, f32::MAX), |m, (t, &a)| if a < m.1 { (t, a) } else { m });
            assert!(
                worst > 0.0,
                "{name}: frame {f}: triangle {t} inverted (area {worst} px²)"
            );
        }
    }
}

#[test]
fn cartoon_filter_anticipates_and_overshoots_a_step() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 160, 120, 2);
    let mut stepped = c.clone();
    // Hold frame 0 for 20 frames, then swing the left forearm down by 0.6 rad and hold 20 frames.
    let (elbow, wrist) = (4, 5);
    let base = c.gt[0].clone();
    let (ex, ey) = base[elbow];
    let (wx, wy) = base[wrist];
    let (l, a) = ((wx - ex).hypot(wy - ey), (wy - ey).atan2(wx - ex));
    let mut swung = base.clone();
    swung[wrist] = (ex + l * (a + 0.6).cos(), ey + l * (a + 0.6).sin());
    stepped.gt = (0..40)
        .map(|t| if t < 20 { base.clone() } else { swung.clone() })
        .collect();
    let run = run_from_gt(d.path(), &stepped);
    // The filter alone, on the step as given.
    let opts = RetargetOptions {
        clean: Cleanup { strength: 0 },
        cartoon: Some(Cartoon {
            strength: 2.0,
            sigma_frames: 3.0,
        }),
        ..Default::default()
    };
    app::retarget(&run, &characters("imp.toml"), &opts).unwrap();
    let bones = std::fs::read_to_string(run.join("retarget/bones.csv")).unwrap();
    let angle: Vec<f64> = bones
        .lines()
        .filter(|l| l.contains(",elbow_l->wrist_l,"))
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(angle.len(), 40);
    let (start, end) = (angle[0], angle[39]);
    assert!(
        (end - start - 0.6).abs() < 1e-3,
        "the step is kept: {start} -> {end}"
    );
    let min = angle[..20].iter().cloned().fold(f64::MAX, f64::min);
    let max = angle[20..].iter().cloned().fold(f64::MIN, f64::max);
    assert!(min < start - 0.02, "no anticipation: min {min} vs {start}");
    assert!(max > end + 0.02, "no follow-through: max {max} vs {end}");
}

#[test]
#[cfg(feature = "ffmpeg")]
fn renders_are_deterministic_whatever_the_thread_count() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 160, 120, 12);
    let run = run_from_gt(d.path(), &c);
    let target = characters("robot.toml");
    let o = mocap2d(&[
        "retarget",
        s(&run),
        "--target",
        s(&target),
        "--cartoon",
        "1",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let render = |tag: &str, threads: &str| -> (Vec<u8>, Vec<Vec<u8>>) {
        let (out, frames) = (d.path().join(format!("{tag}.mp4")), d.path().join(tag));
        let o = bin()
            .args(["render", s(&run), "--target", s(&target), "--out", s(&out)])
            .args(["--frames-dir", s(&frames)])
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let pngs = (0..12)
            .map(|f| std::fs::read(frames.join(format!("{f:06}.png"))).unwrap())
            .collect();
        (std::fs::read(out).unwrap(), pngs)
    };
    let (v1, p1) = render("one", "1");
    let (v2, p2) = render("two", "2");
    assert_eq!(p1, p2, "PNG frames differ");
    assert_eq!(v1, v2, "videos differ");
    // The character is drawn: frame 6 differs from frame 0 and from the plain background.
    assert_ne!(p1[0], p1[6]);
}

#[test]
fn target_file_errors_exit_2_and_write_nothing() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 160, 120, 3);
    let run = run_from_gt(d.path(), &c);
    std::fs::copy(characters("imp.png"), d.path().join("imp.png")).unwrap();
    let good = std::fs::read_to_string(characters("imp.toml")).unwrap();
    let cases: [(&str, String, &str); 6] = [
        (
            "map",
            good.clone() + "\n[map]\nhead = \"mid(nose, chin)\"\n",
            "[map] head = \"mid(nose, chin)\": the run has no joint \"nose\"",
        ),
        (
            "bones",
            good.clone() + "\n[bones]\nhead = [\"neck\", \"hat\"]\n",
            "the run has no joint \"hat\"",
        ),
        ("image", good.replace("imp.png", "gone.png"), "not found"),
        (
            "outside",
            good.replacen("x = ", "x = -40 # ", 1),
            "outside the",
        ),
        (
            "unmapped",
            good.replace("name = \"", "name = \"x_")
                .replace("parent = \"", "parent = \"x_"),
            "no bone of this character is driven",
        ),
        (
            "key",
            good.replacen("layer = ", "layr = ", 1),
            "unknown field",
        ),
    ];
    for (tag, text, want) in cases {
        let target = d.path().join(format!("{tag}.toml"));
        std::fs::write(&target, text).unwrap();
        let o = mocap2d(&["retarget", s(&run), "--target", s(&target)]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{tag}: {err}");
        assert!(
            err.contains(want) && err.contains(&format!("{tag}.toml")),
            "{tag}: {err}"
        );
        assert!(!run.join("retarget").exists(), "{tag}: wrote retarget/");
    }
    // Render before retarget: exit 2, no video.
    let out = d.path().join("v.mp4");
    let o = mocap2d(&[
        "render",
        s(&run),
        "--target",
        s(&characters("imp.toml")),
        "--out",
        s(&out),
    ]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("mocap2d retarget"));
    assert!(!out.exists());
}

#[test]
fn render_with_another_target_than_retarget_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 160, 120, 3);
    let run = run_from_gt(d.path(), &c);
    app::retarget(&run, &characters("imp.toml"), &RetargetOptions::default()).unwrap();
    let opts = RenderOptions {
        run: run.clone(),
        target: characters("robot.toml"),
        out: None,
        frames_dir: Some(d.path().join("frames")),
        deform: DeformOptions::default(),
    };
    let e = app::render(&opts, &NoProgress).unwrap_err();
    assert!(
        e.is_user_error() && e.to_string().contains("imp.toml"),
        "{e}"
    );
    assert!(!d.path().join("frames").exists());
}

/// The real dance clip's seeds use the COCO keypoint names (left_hip, right_shoulder, ...) in a
/// hip-rooted tree unlike either sample's: tracked on its first frames, the run retargets and
/// renders onto every sample character in configs/characters/ with no map and no extra flags,
/// and `retarget` says which source bone drives which target bone.
#[test]
#[cfg(feature = "ffmpeg")]
fn the_dance_with_coco_names_retargets_and_renders_onto_every_sample_character() {
    let dance = common::shared("clips/dance");
    if !dance.join("clip.mp4").exists() {
        eprintln!(
            "note: {} is absent; the COCO-names retarget was not run",
            dance.display()
        );
        return;
    }
    let d = tempfile::tempdir().unwrap();
    // A short slice: the first 6 frames as PNGs.
    let slice = d.path().join("slice");
    std::fs::create_dir_all(&slice).unwrap();
    let mut source = mocap2d::decode::open(&dance.join("clip.mp4"), None).unwrap();
    for f in 0..6 {
        let img = source.next_frame().unwrap().unwrap();
        img.save(slice.join(format!("frame{f}.png"))).unwrap();
    }
    let run = d.path().join("dance.mocap");
    let o = mocap2d(&[
        "track",
        s(&slice),
        "--seeds",
        s(&dance.join("joints.toml")),
        "--out",
        s(&run),
        "-q",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut targets: Vec<PathBuf> = std::fs::read_dir(characters(""))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    targets.sort();
    assert!(targets.len() >= 2, "{targets:?}");
    for target in &targets {
        let name = target.file_stem().unwrap().to_string_lossy().into_owned();
        let o = mocap2d(&["retarget", s(&run), "--target", s(target)]);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{name}: {err}");
        // The hips' midpoint carries the character; the arms follow the source's upper arms.
        assert!(
            err.contains("(root) follows mid(left_hip, right_hip)")
                && err.contains("<- left_shoulder -> left_elbow")
                && err.contains("<- right_elbow -> right_wrist")
                // The head follows the nose's direction, not its distance.
                && err.contains("head <- mid(left_shoulder, right_shoulder) -> nose (angle only)"),
            "{name}: {err}"
        );
        let ch = read_character(target).unwrap();
        let got = poses(&run, &ch.skeleton.names);
        assert_eq!(got.len(), 6, "{name}");
        // The character moves (her arms and head do over these frames) and stays in the frame.
        let moved = (0..ch.skeleton.len())
            .map(|j| (got[5][j] - got[0][j]).norm())
            .fold(0.0f32, f32::max);
        assert!(moved > 1.0, "{name}: nothing moves ({moved} px)");
        for p in got.iter().flatten() {
            assert!(p.x.is_finite() && p.y.is_finite(), "{name}: {p:?}");
        }
        let frames = d.path().join(format!("frames-{name}"));
        let o = mocap2d(&[
            "render",
            s(&run),
            "--target",
            s(target),
            "--frames-dir",
            s(&frames),
            "-q",
        ]);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        // And it exports: a Spine folder holding the JSON, its atlas and the image.
        let folder = d.path().join(format!("spine-{name}"));
        std::fs::create_dir_all(&folder).unwrap();
        let json = folder.join(format!("{name}.json"));
        let o = mocap2d(&["export", s(&run), "--format", "spine", "--out", s(&json)]);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let mut files: Vec<String> = std::fs::read_dir(&folder)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        files.sort();
        assert_eq!(
            files,
            [
                format!("{name}.atlas"),
                format!("{name}.json"),
                format!("{name}.png")
            ]
        );
        // Every frame is drawn, with the character on it (pixels unlike the backdrop).
        for f in 0..6 {
            let img = image::open(frames.join(format!("{f:06}.png")))
                .unwrap()
                .to_rgb8();
            let bg = *img.get_pixel(0, 0);
            let drawn = img.pixels().filter(|p| **p != bg).count();
            assert!(
                drawn > 2000,
                "{name}: frame {f} shows {drawn} px of character"
            );
        }
    }
}

#[test]
fn retarget_check_checks_a_character_file_alone_and_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    let target = characters("dancer.toml");
    let o = mocap2d(&["retarget", "--check", "--target", s(&target)]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        out.contains("dancer.toml: ok: 16 joints, 15 bones")
            && out.contains("left_elbow (parent left_shoulder; recognised: left elbow)"),
        "{out}"
    );
    // With a run: which source bone would drive which bone, and still nothing written.
    let c = clip(Scenario::Walk, 160, 120, 3);
    let run = run_from_gt(d.path(), &c);
    let o = mocap2d(&["retarget", s(&run), "--check", "--target", s(&target)]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        out.contains("left_shoulder -> left_elbow <- chest -> elbow_l")
            && out.contains("chest -> left_shoulder <- nothing"),
        "{out}"
    );
    assert!(!run.join("retarget").exists());
    // A joint off the image: exit 2, the line and the joint named.
    std::fs::copy(characters("dancer.png"), d.path().join("dancer.png")).unwrap();
    let bad = d.path().join("bad.toml");
    let text = std::fs::read_to_string(&target).unwrap();
    std::fs::write(&bad, text.replacen("y = 64.0", "y = 900.0", 1)).unwrap();
    let o = mocap2d(&["retarget", "--check", "--target", s(&bad)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("bad.toml: line 27: joint \"head\"") && err.contains("outside"),
        "{err}"
    );
    // Without --check, RUN is required.
    let o = mocap2d(&["retarget", "--target", s(&target)]);
    assert_eq!(o.status.code(), Some(2));
}

/// `[map]` with a virtual joint and `[bones]` with a source bone of the user's choice drive the
/// bones they name: the printed mapping says so and the retargeted bone turns as that source
/// bone does.
#[test]
fn map_and_bones_entries_choose_the_source_bones() {
    let d = tempfile::tempdir().unwrap();
    let c = clip(Scenario::Walk, 160, 120, 20);
    let run = run_from_gt(d.path(), &c);
    std::fs::copy(characters("imp.png"), d.path().join("imp.png")).unwrap();
    let text = std::fs::read_to_string(characters("imp.toml")).unwrap()
        + "\n[map]\nhead = \"mid(neck, head)\"\n\n[bones]\nwrist_l = [\"chest\", \"wrist_l\"]\n";
    let target = d.path().join("imp.toml");
    std::fs::write(&target, text).unwrap();
    // The mapping alone: no clean-up.
    let o = mocap2d(&["retarget", s(&run), "--target", s(&target), "--clean", "0"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("neck -> head <- neck -> mid(neck, head)")
            && err.contains("elbow_l -> wrist_l <- chest -> wrist_l")
            && err.contains("chest -> elbow_l <- chest -> elbow_l"),
        "{err}"
    );
    // The forearm turns as the source's chest -> wrist line turns.
    let bones = std::fs::read_to_string(run.join("retarget/bones.csv")).unwrap();
    let got: Vec<f64> = bones
        .lines()
        .filter(|l| l.contains(",elbow_l->wrist_l,"))
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    let j = |n: &str| c.joint_names.iter().position(|x| x == n).unwrap();
    let (chest, wrist) = (j("chest"), j("wrist_l"));
    let want: Vec<f64> =
        c.gt.iter()
            .map(|f| {
                let (a, b) = (f[chest], f[wrist]);
                ((b.1 - a.1) as f64).atan2((b.0 - a.0) as f64)
            })
            .collect();
    assert_eq!(got.len(), 20);
    let mut moved = 0.0f64;
    for t in 1..20 {
        let d_got = got[t] - got[0];
        let d_want = (want[t] - want[0] + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        assert!(
            (d_got - d_want).abs() < 1e-3,
            "frame {t}: {d_got} vs {d_want}"
        );
        moved = moved.max(d_want.abs());
    }
    assert!(moved > 0.05, "the source line does not turn: {moved}");
}
