//! Synthetic clips (`mocap2d synth`): determinism, ground truth inside the frame, a seed frame
//! that shows every joint, and the motion each scenario promises, measured on the ground truth.

use mocap2d::geom::{wrap_angle, JointBox};
use mocap2d::synth::{render, write_clip, Scenario, SynthClip, SynthOptions};

fn opts(
    scenario: Scenario,
    width: u32,
    height: u32,
    seed: u64,
    frames: Option<u32>,
) -> SynthOptions {
    SynthOptions {
        scenario,
        width,
        height,
        seed,
        frames,
    }
}

fn joint(clip: &SynthClip, name: &str) -> usize {
    clip.joint_names.iter().position(|n| n == name).unwrap()
}

fn dist(a: (f32, f32), b: (f32, f32)) -> f32 {
    ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt()
}

/// Distance (px) from `p` to the segment `a`–`b`.
fn dist_to_segment(p: (f32, f32), a: (f32, f32), b: (f32, f32)) -> f32 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    dist(p, (a.0 + t * dx, a.1 + t * dy))
}

/// Direction (rad) of the bone ending at joint `j` on one frame.
fn bone_angle(clip: &SynthClip, frame: usize, j: usize) -> f32 {
    let p = clip.parents[j].unwrap();
    let (a, b) = (clip.gt[frame][p], clip.gt[frame][j]);
    (b.1 - a.1).atan2(b.0 - a.0)
}

/// Per frame transition `t-1 → t`: the largest displacement (px) among `joints`, and the largest
/// turn (degrees) among the bones ending at `joints`.
fn per_frame_motion(clip: &SynthClip, joints: &[usize]) -> (Vec<f32>, Vec<f32>) {
    let mut px = Vec::new();
    let mut deg = Vec::new();
    for t in 1..clip.gt.len() {
        px.push(
            joints
                .iter()
                .map(|&j| dist(clip.gt[t - 1][j], clip.gt[t][j]))
                .fold(0.0, f32::max),
        );
        deg.push(
            joints
                .iter()
                .filter(|&&j| clip.parents[j].is_some())
                .map(|&j| {
                    wrap_angle(bone_angle(clip, t, j) - bone_angle(clip, t - 1, j))
                        .abs()
                        .to_degrees()
                })
                .fold(0.0, f32::max),
        );
    }
    (px, deg)
}

fn median(v: &[f32]) -> f32 {
    let mut s = v.to_vec();
    s.sort_by(f32::total_cmp);
    s[s.len() / 2]
}

#[test]
fn same_options_give_identical_clips() {
    for s in [Scenario::Walk, Scenario::Noisy, Scenario::Squash] {
        let o = opts(s, 160, 120, 7, Some(16));
        let (a, b) = (render(&o), render(&o));
        assert!(a == b, "{s}: two renders differ");
        assert_eq!(a.frames.len(), 16);
    }
}

#[test]
fn different_seeds_vary_the_motion() {
    let a = render(&opts(Scenario::Walk, 160, 120, 1, Some(30)));
    let b = render(&opts(Scenario::Walk, 160, 120, 2, Some(30)));
    let moved = (0..30)
        .flat_map(|t| (0..a.gt[t].len()).map(move |j| (t, j)))
        .map(|(t, j)| dist(a.gt[t][j], b.gt[t][j]))
        .fold(0.0, f32::max);
    assert!(
        moved > 2.0,
        "seeds 1 and 2 give nearly the same motion ({moved} px)"
    );
    assert_ne!(a.frames[10], b.frames[10]);
}

#[test]
fn character_has_at_least_13_joints_in_one_tree() {
    let clip = render(&opts(Scenario::Walk, 160, 120, 0, Some(2)));
    let n = clip.joint_names.len();
    assert!(n >= 13, "{n} joints");
    assert_eq!(clip.parents.len(), n);
    assert_eq!(clip.gt[0].len(), n);
    let roots: Vec<_> = (0..n).filter(|&j| clip.parents[j].is_none()).collect();
    assert_eq!(roots, [0], "one root, first");
    assert_eq!(clip.joint_names[0], "pelvis");
    for (j, p) in clip.parents.iter().enumerate() {
        assert!(p.is_none_or(|p| p < j), "parents come before children");
    }
    let mut names = clip.joint_names.clone();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), n, "unique names");
}

#[test]
fn ground_truth_keeps_a_whole_box_inside_the_frame() {
    for s in Scenario::ALL {
        for (w, h, frames) in [
            (640, 360, Some(120)),
            (320, 240, None),
            (160, 120, Some(60)),
            (64, 48, Some(30)),
            (300, 400, Some(60)),
        ] {
            let clip = render(&opts(s, w, h, 3, frames));
            let b = clip.box_size;
            for (t, f) in clip.gt.iter().enumerate() {
                for (j, &(x, y)) in f.iter().enumerate() {
                    assert!(
                        JointBox::centred(x, y, b, b).inside(w, h),
                        "{s} {w}x{h} frame {t}: {} at ({x}, {y}) box {b} leaves the frame",
                        clip.joint_names[j]
                    );
                }
            }
        }
    }
}

#[test]
fn frame_zero_shows_every_joint() {
    for s in Scenario::ALL {
        for seed in 0..8 {
            let clip = render(&opts(s, 320, 240, seed, Some(1)));
            for (j, &v) in clip.visibility[0].iter().enumerate() {
                assert!(
                    v >= 0.75,
                    "{s} seed {seed}: {} only {v:.2} visible on frame 0",
                    clip.joint_names[j]
                );
            }
        }
    }
}

#[test]
fn seeds_toml_is_a_seed_file_for_frame_zero() {
    let clip = render(&opts(Scenario::Occlude, 320, 240, 5, Some(3)));
    let text = clip.seeds_toml();
    let table: toml::Table = text.parse().unwrap();
    assert_eq!(table["frame"].as_integer(), Some(0));
    let joints = table["joint"].as_array().unwrap();
    assert_eq!(joints.len(), clip.joint_names.len());
    for (j, t) in joints.iter().enumerate() {
        assert_eq!(t["name"].as_str(), Some(clip.joint_names[j].as_str()));
        assert!((t["x"].as_float().unwrap() as f32 - clip.gt[0][j].0).abs() < 1e-3);
        assert!((t["y"].as_float().unwrap() as f32 - clip.gt[0][j].1).abs() < 1e-3);
        assert_eq!(t["w"].as_integer(), Some(clip.box_size as i64));
        assert_eq!(t["h"].as_integer(), Some(clip.box_size as i64));
        let parent = clip.parents[j].map(|p| clip.joint_names[p].as_str());
        assert_eq!(t.get("parent").and_then(|p| p.as_str()), parent);
    }
    // The crate's own reader accepts it, for this clip.
    let path = std::path::Path::new("joints.toml");
    let seeds = mocap2d::seed::parse_seeds(&text, path).unwrap();
    seeds.check_against_clip(path, 320, 240, Some(3)).unwrap();
}

#[test]
fn gt_csv_has_one_row_per_joint_per_frame() {
    let clip = render(&opts(Scenario::Walk, 160, 120, 0, Some(4)));
    let csv = clip.gt_csv();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "frame,joint,x,y,visible");
    assert_eq!(lines.len(), 1 + 4 * clip.joint_names.len());
    let (x, y) = clip.gt[0][0];
    let v = clip.visibility[0][0];
    assert_eq!(lines[1], format!("0,pelvis,{x:.3},{y:.3},{v:.2}"));
    let last = clip.joint_names.last().unwrap();
    assert!(lines.last().unwrap().starts_with(&format!("3,{last},")));
}

/// Walk at 320x240: the limbs move a few px a frame, never more than 10.
#[test]
fn walk_moves_a_few_px_per_frame() {
    for seed in 0..4 {
        let clip = render(&opts(Scenario::Walk, 320, 240, seed, None));
        let all: Vec<usize> = (0..clip.joint_names.len()).collect();
        let (px, deg) = per_frame_motion(&clip, &all);
        let max = px.iter().cloned().fold(0.0, f32::max);
        assert!(
            (3.0..=10.0).contains(&median(&px)),
            "seed {seed}: median {}",
            median(&px)
        );
        assert!(max <= 10.0, "seed {seed}: {max} px in one frame");
        assert!(
            deg.iter().all(|&d| d < 10.0),
            "seed {seed}: a bone turns >= 10° in a frame"
        );
    }
}

/// The `fast` claim, at 640x360: on at least a third of the frame transitions, a wrist or ankle
/// moves >= 20 px *and* an arm or leg bone turns >= 10° (and both happen at all).
#[test]
fn fast_moves_limbs_20px_and_10_degrees_per_frame() {
    for seed in 0..4 {
        let clip = render(&opts(Scenario::Fast, 640, 360, seed, None));
        let ends: Vec<usize> = ["wrist_l", "wrist_r", "ankle_l", "ankle_r"]
            .iter()
            .map(|n| joint(&clip, n))
            .collect();
        let limbs: Vec<usize> = [
            "elbow_l", "wrist_l", "elbow_r", "wrist_r", "knee_l", "ankle_l", "knee_r", "ankle_r",
        ]
        .iter()
        .map(|n| joint(&clip, n))
        .collect();
        let (px, _) = per_frame_motion(&clip, &ends);
        let (_, deg) = per_frame_motion(&clip, &limbs);
        let both = px
            .iter()
            .zip(&deg)
            .filter(|(&p, &d)| p >= 20.0 && d >= 10.0)
            .count();
        assert!(
            both * 3 >= px.len(),
            "seed {seed}: only {both} of {} transitions have >= 20 px and >= 10°",
            px.len()
        );
    }
}

/// `occlude`: the near (left) wrist passes inside the torso's outline, the far (right) wrist is
/// hidden behind the torso, and the knees cross.
#[test]
fn occlude_overlaps_arms_with_the_torso_and_crosses_the_legs() {
    for seed in 0..4 {
        let clip = render(&opts(Scenario::Occlude, 320, 240, seed, None));
        let [pelvis, chest, wrist_l, wrist_r, knee_l, knee_r] =
            ["pelvis", "chest", "wrist_l", "wrist_r", "knee_l", "knee_r"].map(|n| joint(&clip, n));
        let n = clip.gt.len();
        // The torso is drawn about 0.23 torso lengths wide each side of its axis; 0.2 is inside.
        let over_torso = (0..n)
            .filter(|&t| {
                let f = &clip.gt[t];
                dist_to_segment(f[wrist_l], f[pelvis], f[chest]) < 0.2 * dist(f[pelvis], f[chest])
            })
            .count();
        assert!(
            over_torso * 6 >= n,
            "seed {seed}: wrist_l over the torso on {over_torso} of {n} frames"
        );
        let hidden = (0..n)
            .filter(|&t| clip.visibility[t][wrist_r] < 0.3)
            .count();
        assert!(
            hidden * 10 >= n,
            "seed {seed}: wrist_r hidden on {hidden} of {n} frames"
        );
        let side: Vec<bool> = clip.gt.iter().map(|f| f[knee_l].0 > f[knee_r].0).collect();
        let crossings = side.windows(2).filter(|w| w[0] != w[1]).count();
        assert!(crossings >= 2, "seed {seed}: knees cross {crossings} times");
        let closest = clip
            .gt
            .iter()
            .map(|f| dist(f[knee_l], f[knee_r]))
            .fold(f32::INFINITY, f32::min);
        assert!(closest < 0.1 * dist(clip.gt[0][pelvis], clip.gt[0][chest]));
    }
}

/// `squash`: every bone's length varies by at least 25 % (longest / shortest >= 1.25).
#[test]
fn squash_stretches_every_bone_by_at_least_25_percent() {
    let clip = render(&opts(Scenario::Squash, 320, 240, 2, None));
    for (j, p) in clip.parents.iter().enumerate() {
        let Some(p) = *p else { continue };
        let lengths: Vec<f32> = clip.gt.iter().map(|f| dist(f[p], f[j])).collect();
        let (lo, hi) = lengths
            .iter()
            .fold((f32::INFINITY, 0.0f32), |(lo, hi), &l| {
                (lo.min(l), hi.max(l))
            });
        assert!(
            hi / lo >= 1.25,
            "{}: lengths {lo:.1}..{hi:.1} px",
            clip.joint_names[j]
        );
    }
}

/// Standard deviation of the grey level along the middle of the torso on frame 0.
fn torso_texture(clip: &SynthClip) -> f32 {
    let (a, b) = (clip.gt[0][0], clip.gt[0][1]);
    let vals: Vec<f32> = (30..=70)
        .map(|k| {
            let t = k as f32 / 100.0;
            let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
            let p = clip.frames[0]
                .get_pixel(x.round() as u32, y.round() as u32)
                .0;
            (p[0] as f32 + p[1] as f32 + p[2] as f32) / 3.0
        })
        .collect();
    let mean = vals.iter().sum::<f32>() / vals.len() as f32;
    (vals.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / vals.len() as f32).sqrt()
}

#[test]
fn squash_is_flat_colour_and_walk_is_textured() {
    let flat = render(&opts(Scenario::Squash, 640, 360, 0, Some(1)));
    let textured = render(&opts(Scenario::Walk, 640, 360, 0, Some(1)));
    assert!(
        torso_texture(&flat) < 3.0,
        "squash torso std {}",
        torso_texture(&flat)
    );
    assert!(
        torso_texture(&textured) > 10.0,
        "walk torso std {}",
        torso_texture(&textured)
    );
}

/// `noisy`: frames differ from the clean background by a global gain within ±8 % that changes
/// from frame to frame, plus per-pixel noise; the clip is meant for strong compression.
#[test]
fn noisy_flickers_and_adds_sensor_noise() {
    let clip = render(&opts(Scenario::Noisy, 320, 240, 4, Some(40)));
    assert!(clip.crf >= 30);
    // The top fifth of the frame is sky: the character never reaches it.
    let region = |img: &image::RgbImage| -> Vec<f32> {
        img.rows()
            .take(48)
            .flat_map(|r| r.flat_map(|p| p.0))
            .map(f32::from)
            .collect()
    };
    let bg = region(&clip.background);
    let mut gains = Vec::new();
    for f in &clip.frames {
        let px = region(f);
        let gain = px.iter().sum::<f32>() / bg.iter().sum::<f32>();
        let resid = px
            .iter()
            .zip(&bg)
            .map(|(p, b)| (p - gain * b).powi(2))
            .sum::<f32>()
            / px.len() as f32;
        assert!((0.91..=1.09).contains(&gain), "gain {gain}");
        assert!(
            (3.0..=9.0).contains(&resid.sqrt()),
            "noise std {}",
            resid.sqrt()
        );
        gains.push(gain);
    }
    let (lo, hi) = gains.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &g| {
        (lo.min(g), hi.max(g))
    });
    assert!(hi - lo >= 0.08, "flicker only {lo:.3}..{hi:.3}");
    let clean = render(&opts(Scenario::Walk, 320, 240, 4, Some(1)));
    assert!(
        clean.crf < 25
            && clean.frames[0]
                .rows()
                .take(48)
                .flat_map(|r| r.flat_map(|p| p.0))
                .eq(clean
                    .background
                    .rows()
                    .take(48)
                    .flat_map(|r| r.flat_map(|p| p.0)))
    );
}

/// `long`: 900 frames by default, three turns, arms raised above the head, and crouches.
#[test]
fn long_walks_turns_waves_and_crouches() {
    let clip = render(&opts(Scenario::Long, 320, 240, 6, None));
    assert_eq!(clip.frames.len(), 900);
    let [pelvis, head, wrist_l, wrist_r, ankle_l, toe_l, ankle_r, toe_r] = [
        "pelvis", "head", "wrist_l", "wrist_r", "ankle_l", "toe_l", "ankle_r", "toe_r",
    ]
    .map(|n| joint(&clip, n));
    // Facing: which way the feet point; count flips with hysteresis.
    let mut facing = 0.0f32;
    let mut turns = 0;
    for f in &clip.gt {
        let dx = f[toe_l].0 - f[ankle_l].0 + f[toe_r].0 - f[ankle_r].0;
        let s = if dx > 5.0 {
            1.0
        } else if dx < -5.0 {
            -1.0
        } else {
            facing
        };
        if facing != 0.0 && s != facing {
            turns += 1;
        }
        facing = s;
    }
    assert_eq!(turns, 3);
    let waving = clip
        .gt
        .iter()
        .filter(|f| f[wrist_l].1 < f[head].1 || f[wrist_r].1 < f[head].1)
        .count();
    assert!(waving >= 100, "arms above the head on {waving} frames");
    let leg = |f: &Vec<(f32, f32)>| f[ankle_l].1.max(f[ankle_r].1) - f[pelvis].1;
    let crouched: Vec<usize> = (0..clip.gt.len())
        .filter(|&t| leg(&clip.gt[t]) < 0.6 * leg(&clip.gt[0]))
        .collect();
    assert!(
        crouched.len() >= 20,
        "crouched on {} frames",
        crouched.len()
    );
    // Twice, between the waving and the second turn, as `long` says.
    let bouts = 1 + crouched.windows(2).filter(|w| w[1] > w[0] + 1).count();
    assert_eq!(bouts, 2, "crouched on frames {crouched:?}");
    assert!(
        crouched.iter().all(|t| (490..605).contains(t)),
        "crouched on frames {crouched:?}"
    );
    // Walking covers ground both ways.
    let xs: Vec<f32> = clip.gt.iter().map(|f| f[pelvis].0).collect();
    let (lo, hi) = xs.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &x| {
        (lo.min(x), hi.max(x))
    });
    assert!(hi - lo > 80.0, "pelvis spans {lo}..{hi}");
}

#[cfg(feature = "ffmpeg")]
#[test]
fn write_clip_writes_video_truth_seeds_and_background() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("clip");
    let clip = render(&opts(Scenario::Walk, 160, 120, 0, Some(20)));
    write_clip(&clip, &out).unwrap();
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["background.png", "clip.mp4", "gt.csv", "joints.toml"]
    );
    assert!(std::fs::metadata(out.join("clip.mp4")).unwrap().len() > 1000);
    assert_eq!(
        std::fs::read_to_string(out.join("gt.csv")).unwrap(),
        clip.gt_csv()
    );
    assert_eq!(
        std::fs::read_to_string(out.join("joints.toml")).unwrap(),
        clip.seeds_toml()
    );
    assert_eq!(
        image::open(out.join("background.png")).unwrap().to_rgb8(),
        clip.background
    );
}

#[cfg(not(feature = "ffmpeg"))]
#[test]
fn write_clip_writes_png_frames_without_ffmpeg() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("clip");
    let clip = render(&opts(Scenario::Walk, 160, 120, 0, Some(5)));
    write_clip(&clip, &out).unwrap();
    for name in [
        "background.png",
        "gt.csv",
        "joints.toml",
        "clip/000000.png",
        "clip/000004.png",
    ] {
        assert!(out.join(name).is_file(), "{name} missing");
    }
    assert_eq!(
        image::open(out.join("clip/000004.png")).unwrap().to_rgb8(),
        clip.frames[4]
    );
}

/// Prints per-scenario motion figures and writes sample frames to `$SYNTH_DUMP` (a folder).
#[test]
#[ignore = "writes files; run by hand to look at the clips"]
fn dump_frames() {
    let dir = std::path::PathBuf::from(std::env::var("SYNTH_DUMP").unwrap_or("/tmp/synth".into()));
    std::fs::create_dir_all(&dir).unwrap();
    for s in Scenario::ALL {
        let t0 = std::time::Instant::now();
        let clip = render(&opts(s, 640, 360, 1, None));
        let el = t0.elapsed();
        let n = clip.frames.len();
        let (w, h) = (clip.frames[0].width(), clip.frames[0].height());
        let mut sheet = image::RgbImage::new(2 * w, 2 * h);
        for (k, t) in [0, n / 4, n / 2, 3 * n / 4].into_iter().enumerate() {
            let (x, y) = ((k as u32 % 2) * w, (k as u32 / 2) * h);
            image::imageops::replace(&mut sheet, &clip.frames[t], x as i64, y as i64);
        }
        sheet.save(dir.join(format!("{s}.png"))).unwrap();
        if let Ok(spec) = std::env::var("SYNTH_CROP") {
            // "scenario,frame,x,y,size": a 4x enlarged crop.
            let v: Vec<&str> = spec.split(',').collect();
            if v[0] == s.to_string() {
                let n: Vec<u32> = v[1..].iter().map(|x| x.parse().unwrap()).collect();
                let crop =
                    image::imageops::crop_imm(&clip.frames[n[0] as usize], n[1], n[2], n[3], n[3])
                        .to_image();
                let big = image::imageops::resize(
                    &crop,
                    n[3] * 4,
                    n[3] * 4,
                    image::imageops::FilterType::Nearest,
                );
                big.save(dir.join("crop.png")).unwrap();
            }
        }
        eprintln!("{s}: {n} frames in {el:?}");
    }
}

/// Prints each scenario's motion figures: per-frame joint displacement (max and median of the
/// per-frame max, px) and bone turn (max, degrees), and the least visible joint on frame 0.
#[test]
#[ignore = "prints figures; run by hand"]
fn print_motion_figures() {
    for s in Scenario::ALL {
        for (w, h) in [(640, 360), (320, 240)] {
            let clip = render(&opts(s, w, h, 1, None));
            let all: Vec<usize> = (0..clip.joint_names.len()).collect();
            let (px, deg) = per_frame_motion(&clip, &all);
            let max = |v: &[f32]| v.iter().cloned().fold(0.0, f32::max);
            let vis0 = clip.visibility[0].iter().cloned().fold(1.0, f32::min);
            eprintln!(
                "{s} {w}x{h}: {} frames, max {:.1} px/frame (median {:.1}), max {:.1} deg/frame, \
                 frame-0 visibility >= {vis0:.2}",
                clip.frames.len(),
                max(&px),
                median(&px),
                max(&deg)
            );
        }
    }
}
