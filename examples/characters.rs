//! Writes the sample target characters of `configs/characters/` (PNG + TOML each):
//!
//!     cargo run --release --example characters [-- OUT_DIR]
//!
//! - `robot`: a boxy robot with the synthetic walker's proportions;
//! - `imp`: other proportions: a big head, long arms, a short body and short legs;
//! - `dancer`: front-facing, with shoulders and hips, its joints named as the COCO keypoints
//!   (`left_shoulder`, `right_hip`, ...) plus `pelvis`, `chest`, `neck` and `head`.
//!
//! The robot and the imp stand in the pose of the bundled sample's seed frame
//! (`clips/walk/joints.toml`: every bone at the same angle), so they retarget any `mocap2d synth
//! walk` clip (seed 1) as they are: the `_l` limbs behind the body (layer -1), the `_r` limbs in
//! front (layer 1), as the walker faces -x. The dancer faces the camera, arms hanging a little
//! out from the body and legs slightly apart (its left on the image's right), arms in front of
//! the body (layer 1) and legs behind it (layer -1), for front-facing footage such as a dance.
//! Each part is drawn from exact signed distances (anti-aliased), back to front. Stripes across
//! the limbs show how they stretch.

use mocap2d::seed::read_seeds;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

type V = [f32; 2];

/// One drawn part along a bone.
struct Part {
    from: usize,
    to: usize,
    /// Half-width at `from` and at `to` (character heights).
    r0: f32,
    r1: f32,
    /// Corner rounding of a box (character heights); `None` draws a tapered capsule.
    boxy: Option<f32>,
    fill: [u8; 3],
    stripe: [u8; 3],
    /// A bulge: at this fraction along the part, this half-width (px at 1 character height).
    bulge: Option<(f32, f32)>,
}

impl Part {
    fn mid(mut self, at: f32, half_width: f32) -> Part {
        self.bulge = Some((at, half_width));
        self
    }
}

struct Design {
    name: &'static str,
    /// Character height in image px.
    height_px: f32,
    /// Bone length per joint (character heights), 0 for the root.
    bone: [f32; 14],
    parts: Vec<Part>,
    /// Head: radius (character heights), fill, eye colour, boxy.
    head: (f32, [u8; 3], [u8; 3], bool),
    background: &'static str,
    comment: &'static str,
}

const NAMES: [&str; 14] = [
    "pelvis", "chest", "neck", "head", "elbow_l", "wrist_l", "elbow_r", "wrist_r", "knee_l",
    "ankle_l", "toe_l", "knee_r", "ankle_r", "toe_r",
];
const PARENTS: [Option<usize>; 14] = [
    None,
    Some(0),
    Some(1),
    Some(2),
    Some(1),
    Some(4),
    Some(1),
    Some(6),
    Some(0),
    Some(8),
    Some(9),
    Some(0),
    Some(11),
    Some(12),
];
/// Draw layer of the bone ending at each joint.
const LAYERS: [i32; 14] = [0, 0, 0, 0, -1, -1, 1, 1, -1, -1, -1, 1, 1, 1];

/// A character's joints in its rest pose.
struct Skel {
    names: Vec<&'static str>,
    parents: Vec<Option<usize>>,
    layers: Vec<i32>,
    /// Rest positions, px (any origin: the image is cropped around them).
    joints: Vec<V>,
    /// The head joint (the head is drawn around it).
    head: usize,
    /// Which way the face looks: -1 (to -x) or +1 in profile, 0 at the camera.
    facing: f32,
    /// Where the rest pose comes from (a comment line of the TOML).
    rest: &'static str,
}

/// The walker's skeleton with `d`'s bone lengths at the source's bone angles `src`.
fn walker_skel(d: &Design, src: &[V]) -> Skel {
    let h = d.height_px;
    // Forward kinematics at the source's angles with this design's lengths (px).
    let mut j = vec![[0.0f32; 2]; 14];
    for c in 1..14 {
        let p = PARENTS[c].expect("non-root");
        let a = (src[c][1] - src[p][1]).atan2(src[c][0] - src[p][0]);
        j[c] = [
            j[p][0] + d.bone[c] * h * a.cos(),
            j[p][1] + d.bone[c] * h * a.sin(),
        ];
    }
    Skel {
        names: NAMES.to_vec(),
        parents: PARENTS.to_vec(),
        layers: LAYERS.to_vec(),
        joints: j,
        head: 3,
        facing: -1.0,
        rest: "the bone angles of clips/walk/joints.toml (the sample's seed frame)",
    }
}

fn limb(
    from: usize,
    to: usize,
    r0: f32,
    r1: f32,
    boxy: Option<f32>,
    fill: [u8; 3],
    stripe: [u8; 3],
) -> Part {
    Part {
        from,
        to,
        r0,
        r1,
        boxy,
        fill,
        stripe,
        bulge: None,
    }
}

/// The parts of a marionette: a spindle torso (slim at the chest and the pelvis, so the arms and
/// thighs hinge clear of it), tapered limbs, balls at the joints. `w` scales the limbs' widths.
fn marionette(
    w: f32,
    boxy: Option<f32>,
    body: [u8; 3],
    body_s: [u8; 3],
    near: [u8; 3],
    near_s: [u8; 3],
    far: [u8; 3],
    far_s: [u8; 3],
    joint: [u8; 3],
) -> Vec<Part> {
    let l = |from, to, r0: f32, r1: f32, f, st| limb(from, to, r0 * w, r1 * w, boxy, f, st);
    let ball = |at: usize, r: f32, f| limb(at, at, r * w, r * w, None, f, f);
    vec![
        // Far (left) arm and leg, behind the body.
        l(1, 4, 0.009, 0.016, far, far_s),
        ball(4, 0.017, joint),
        l(4, 5, 0.015, 0.013, far, far_s),
        ball(5, 0.018, far),
        l(0, 8, 0.011, 0.022, far, far_s),
        ball(8, 0.021, joint),
        l(8, 9, 0.02, 0.016, far, far_s),
        ball(9, 0.016, joint),
        l(9, 10, 0.016, 0.011, far, far_s),
        // Body: neck, spindle torso, joint balls.
        l(1, 2, 0.01, 0.01, joint, joint),
        limb(1, 0, 0.01, 0.02, boxy, body, body_s).mid(0.55, 0.055 * w),
        ball(1, 0.014, joint),
        ball(0, 0.02, joint),
        // Near (right) leg and arm, in front.
        l(0, 11, 0.011, 0.022, near, near_s),
        ball(11, 0.021, joint),
        l(11, 12, 0.02, 0.016, near, near_s),
        ball(12, 0.016, joint),
        l(12, 13, 0.016, 0.011, near, near_s),
        l(1, 6, 0.009, 0.016, near, near_s),
        ball(6, 0.017, joint),
        l(6, 7, 0.015, 0.013, near, near_s),
        ball(7, 0.018, near),
    ]
}

fn robot() -> Design {
    let metal = [150, 160, 175];
    let dark = [96, 104, 118];
    Design {
        name: "robot",
        height_px: 400.0,
        bone: [
            0.0, 0.28, 0.07, 0.065, 0.17, 0.16, 0.17, 0.16, 0.255, 0.245, 0.09, 0.255, 0.245, 0.09,
        ],
        parts: marionette(
            1.0,
            Some(0.006),
            metal,
            dark,
            [196, 84, 52],
            [150, 58, 36],
            [132, 64, 48],
            [100, 46, 34],
            [70, 76, 88],
        ),
        head: (0.07, metal, [40, 200, 230], true),
        background: "#dde6ee",
        comment: "A robot marionette with the synthetic walker's proportions.",
    }
}

fn imp() -> Design {
    Design {
        name: "imp",
        height_px: 400.0,
        // Big head, long arms, short body, short legs.
        bone: [
            0.0, 0.2, 0.06, 0.11, 0.2, 0.2, 0.2, 0.2, 0.17, 0.16, 0.09, 0.17, 0.16, 0.09,
        ],
        parts: marionette(
            0.9,
            None,
            [236, 186, 60],
            [200, 140, 40],
            [104, 170, 84],
            [76, 130, 60],
            [78, 132, 64],
            [58, 100, 46],
            [60, 96, 50],
        ),
        head: (0.12, [104, 170, 84], [250, 250, 240], false),
        background: "#f3eee0",
        comment: "An imp: a big head, long arms, a short body and short legs.",
    }
}

/// The front-facing dancer: shoulders and hips, COCO names, arms in front of the body and legs
/// behind it.
fn dancer() -> (Design, Skel) {
    let h = 400.0;
    #[rustfmt::skip]
    let spec: [(&str, Option<usize>, i32, V); 16] = [
        ("pelvis", None, 0, [0.0, 0.0]),
        ("chest", Some(0), 0, [0.0, -0.28]),
        ("neck", Some(1), 0, [0.0, -0.34]),
        ("head", Some(2), 0, [0.0, -0.425]),
        ("left_shoulder", Some(1), 1, [0.105, -0.27]),
        ("left_elbow", Some(4), 1, [0.127, -0.112]),
        ("left_wrist", Some(5), 1, [0.143, 0.038]),
        ("right_shoulder", Some(1), 1, [-0.105, -0.27]),
        ("right_elbow", Some(7), 1, [-0.127, -0.112]),
        ("right_wrist", Some(8), 1, [-0.143, 0.038]),
        ("left_hip", Some(0), -1, [0.055, 0.02]),
        ("left_knee", Some(10), -1, [0.063, 0.26]),
        ("left_ankle", Some(11), -1, [0.063, 0.49]),
        ("right_hip", Some(0), -1, [-0.055, 0.02]),
        ("right_knee", Some(13), -1, [-0.063, 0.26]),
        ("right_ankle", Some(14), -1, [-0.063, 0.49]),
    ];
    let skin = [232, 178, 140];
    let top = [64, 150, 160];
    let top_s = [44, 116, 126];
    let legs = [70, 80, 150];
    let legs_s = [52, 60, 118];
    let shoe = [60, 50, 50];
    let c = |from, to, r0, r1, f, st| limb(from, to, r0, r1, None, f, st);
    let ball = |at: usize, r: f32, f| limb(at, at, r, r, None, f, f);
    let mut parts = Vec::new();
    // Legs, behind the body.
    for (hip, knee, ankle) in [(10, 11, 12), (13, 14, 15)] {
        parts.push(c(hip, knee, 0.036, 0.028, legs, legs_s));
        parts.push(ball(knee, 0.03, legs_s));
        parts.push(c(knee, ankle, 0.028, 0.022, legs, legs_s));
        parts.push(ball(ankle, 0.03, shoe));
    }
    // Body: the neck, hips, a spindle torso, the shoulder line.
    parts.push(c(1, 2, 0.022, 0.022, skin, skin));
    parts.push(c(13, 10, 0.048, 0.048, legs_s, legs_s));
    parts.push(c(0, 1, 0.05, 0.058, top, top_s).mid(0.5, 0.066));
    parts.push(c(7, 4, 0.032, 0.032, top, top_s));
    // Arms, in front of the body.
    for (shoulder, elbow, wrist) in [(4, 5, 6), (7, 8, 9)] {
        parts.push(c(shoulder, elbow, 0.027, 0.022, top, top_s));
        parts.push(ball(elbow, 0.024, skin));
        parts.push(c(elbow, wrist, 0.022, 0.018, skin, [214, 156, 118]));
        parts.push(ball(wrist, 0.027, skin));
    }
    let design = Design {
        name: "dancer",
        height_px: h,
        bone: [0.0; 14],
        parts,
        head: (0.075, skin, [250, 250, 245], false),
        background: "#f4ece4",
        comment: "A front-facing dancer: shoulders and hips, joints named as the COCO keypoints.",
    };
    let skel = Skel {
        names: spec.iter().map(|s| s.0).collect(),
        parents: spec.iter().map(|s| s.1).collect(),
        layers: spec.iter().map(|s| s.2).collect(),
        joints: spec.iter().map(|s| [s.3[0] * h, s.3[1] * h]).collect(),
        head: 3,
        facing: 0.0,
        rest: "standing, facing the camera, arms hanging a little out from the body",
    };
    (design, skel)
}

fn main() -> anyhow::Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("configs/characters"));
    std::fs::create_dir_all(&out)?;
    // The seed frame's bone angles.
    let (seeds, _) = read_seeds(&root.join("clips/walk/joints.toml"))?;
    let src: Vec<V> = seeds
        .joints
        .iter()
        .map(|j| [j.bbox.cx, j.bbox.cy])
        .collect();
    anyhow::ensure!(
        seeds.skeleton.names.iter().map(String::as_str).eq(NAMES),
        "clips/walk/joints.toml has other joints"
    );
    let mut all: Vec<(Design, Skel)> = [robot(), imp()]
        .into_iter()
        .map(|d| {
            let sk = walker_skel(&d, &src);
            (d, sk)
        })
        .collect();
    all.push(dancer());
    for (d, sk) in &all {
        let (png, toml) = draw(d, sk);
        png.save(out.join(format!("{}.png", d.name)))?;
        std::fs::write(out.join(format!("{}.toml", d.name)), toml)?;
        println!("wrote {}/{}.png and .toml", out.display(), d.name);
    }
    Ok(())
}

fn draw(d: &Design, sk: &Skel) -> (image::RgbaImage, String) {
    let h = d.height_px;
    let mut j = sk.joints.clone();
    let margin = 0.14 * h + 8.0;
    let (minx, maxx) = j
        .iter()
        .fold((f32::MAX, f32::MIN), |m, p| (m.0.min(p[0]), m.1.max(p[0])));
    let (miny, maxy) = j
        .iter()
        .fold((f32::MAX, f32::MIN), |m, p| (m.0.min(p[1]), m.1.max(p[1])));
    let (w, ih) = (
        (maxx - minx + 2.0 * margin).ceil() as u32,
        (maxy - miny + 2.0 * margin).ceil() as u32,
    );
    for p in &mut j {
        *p = [p[0] - minx + margin, p[1] - miny + margin];
    }
    let mut img = image::RgbaImage::new(w, ih);
    let outline = [34, 30, 40];
    let ol = 2.2; // outline width, px
    for part in &d.parts {
        let (a, b) = (j[part.from], j[part.to]);
        let one = |p: V, a: V, b: V, r0: f32, r1: f32| match part.boxy {
            Some(round) if a != b => box_sdf(p, a, b, r0, r1, round * h),
            _ => capsule_sdf(p, a, b, r0, r1),
        };
        let sd = |p: V| match part.bulge {
            None => one(p, a, b, part.r0 * h, part.r1 * h),
            Some((at, r)) => {
                let m = [a[0] + at * (b[0] - a[0]), a[1] + at * (b[1] - a[1])];
                one(p, a, m, part.r0 * h, r * h).min(one(p, m, b, r * h, part.r1 * h))
            }
        };
        paint(
            &mut img,
            |p| {
                let s = sd(p);
                let t = along(p, a, b);
                let stripe = (t * 6.0).rem_euclid(1.0) < 0.18;
                (s, if stripe { part.stripe } else { part.fill })
            },
            outline,
            ol,
        );
    }
    // Head.
    let (hr, fill, eye, boxy) = d.head;
    let c = j[sk.head];
    let r = hr * h;
    let facing = sk.facing;
    // One eye in profile, two facing the camera.
    let eyes: Vec<V> = if facing == 0.0 {
        vec![
            [c[0] - 0.38 * r, c[1] - 0.1 * r],
            [c[0] + 0.38 * r, c[1] - 0.1 * r],
        ]
    } else {
        vec![[c[0] + facing * 0.45 * r, c[1] - 0.15 * r]]
    };
    paint(
        &mut img,
        |p| {
            let s = if boxy {
                box_sdf(
                    p,
                    [c[0], c[1] - r * 0.2],
                    [c[0], c[1] + r * 0.2],
                    r,
                    r,
                    0.25 * r,
                )
            } else {
                ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)).sqrt() - r
            };
            let de = eyes
                .iter()
                .map(|e| ((p[0] - e[0]).powi(2) + (p[1] - e[1]).powi(2)).sqrt())
                .fold(f32::MAX, f32::min);
            let colour = if de < 0.22 * r {
                if de < 0.1 * r {
                    [20, 20, 30]
                } else {
                    eye
                }
            } else if boxy
                && (p[1] - (c[1] + 0.45 * r)).abs() < 0.06 * r
                && (p[0] - c[0] - facing * 0.3 * r).abs() < 0.4 * r
            {
                [60, 66, 78]
            } else {
                fill
            };
            (s, colour)
        },
        outline,
        ol,
    );

    let mut t = String::new();
    let _ = writeln!(t, "# {}", d.comment);
    let _ = writeln!(t, "# Generated by `cargo run --release --example characters`; see docs/formats.md, \"Target character file\".");
    let _ = writeln!(t, "# Rest pose: {}.\n", sk.rest);
    let _ = writeln!(t, "image = \"{}.png\"", d.name);
    let _ = writeln!(t, "scale = \"fit\"");
    let _ = writeln!(t, "background = \"{}\"", d.background);
    let _ = writeln!(t, "mesh_vertices = 500");
    for (k, p) in j.iter().enumerate() {
        let _ = writeln!(
            t,
            "\n[[joint]]\nname = \"{}\"\nx = {:.1}\ny = {:.1}",
            sk.names[k], p[0], p[1]
        );
        if let Some(p) = sk.parents[k] {
            let _ = writeln!(t, "parent = \"{}\"", sk.names[p]);
            if sk.layers[k] != 0 {
                let _ = writeln!(t, "layer = {}", sk.layers[k]);
            }
        }
    }
    (img, t)
}

/// Composites a shape given as `f(p) -> (signed distance px, colour)` over `img`, with a dark
/// outline `ol` px wide inside the edge.
fn paint(img: &mut image::RgbaImage, f: impl Fn(V) -> (f32, [u8; 3]), outline: [u8; 3], ol: f32) {
    for (x, y, px) in img.enumerate_pixels_mut() {
        let (s, fill) = f([x as f32, y as f32]);
        let cover = (0.5 - s).clamp(0.0, 1.0);
        if cover <= 0.0 {
            continue;
        }
        let inner = (0.5 - (s + ol)).clamp(0.0, 1.0);
        let rgb: [f32; 3] =
            std::array::from_fn(|k| fill[k] as f32 * inner + outline[k] as f32 * (1.0 - inner));
        let a0 = px[3] as f32 / 255.0;
        let a = cover + a0 * (1.0 - cover);
        for k in 0..3 {
            let v = (rgb[k] * cover + px[k] as f32 * a0 * (1.0 - cover)) / a.max(1e-6);
            px[k] = v.round().clamp(0.0, 255.0) as u8;
        }
        px[3] = (a * 255.0).round() as u8;
    }
}

/// Fraction along `a → b` of `p`'s projection (unclamped).
fn along(p: V, a: V, b: V) -> f32 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / (dx * dx + dy * dy).max(1e-6)
}

/// Signed distance (px) to a capsule `a–b` tapering from radius `r0` to `r1`.
fn capsule_sdf(p: V, a: V, b: V, r0: f32, r1: f32) -> f32 {
    let t = along(p, a, b).clamp(0.0, 1.0);
    let q = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt() - (r0 + t * (r1 - r0))
}

/// Signed distance (px) to a rounded box around `a–b` (half-width `r0` to `r1`, reaching half
/// its width past each end), corners rounded by `round`.
fn box_sdf(p: V, a: V, b: V, r0: f32, r1: f32, round: f32) -> f32 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len = (dx * dx + dy * dy).sqrt().max(1e-6);
    let (ux, uy) = (dx / len, dy / len);
    let (rx, ry) = (p[0] - (a[0] + b[0]) / 2.0, p[1] - (a[1] + b[1]) / 2.0);
    let s = rx * ux + ry * uy;
    let n = -rx * uy + ry * ux;
    let t = (s / len + 0.5).clamp(0.0, 1.0);
    let half_w = r0 + t * (r1 - r0);
    let half_l = len / 2.0 + 0.6 * half_w;
    let q = [s.abs() - half_l + round, n.abs() - half_w + round];
    let outside = (q[0].max(0.0).powi(2) + q[1].max(0.0).powi(2)).sqrt();
    outside + q[0].max(q[1]).min(0.0) - round
}
