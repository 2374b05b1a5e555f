//! Motion: one [`Pose`] a frame per scenario, forward kinematics, and placing the character in
//! the frame.
//!
//! Poses live in the *profile plane*: x forward (the way the character faces), y down, angles
//! from `atan2(dy, dx)` there. The image is the profile plane scaled in x by `facing` (+1 faces
//! +x on screen, −1 faces −x; values in between are a turn seen from the side), so a mirrored
//! character keeps the crate's angle convention. Every angle curve is a sum of sines whose
//! amplitudes, periods and phases come from the seed; frame 0 is always at a pose that shows
//! every joint (limbs spread), and the seed's extra wobble terms vanish there.

use std::f32::consts::{FRAC_PI_2, PI, TAU};

use super::character::*;
use super::{Rng, Scenario};
use crate::geom::Vector;

/// The character's pose on one frame. Angles in radians, lengths in character heights.
#[derive(Debug, Clone, PartialEq)]
pub struct Pose {
    /// Torso tilt forward from vertical.
    pub lean: f32,
    /// Neck bend forward from the torso axis.
    pub neck: f32,
    /// Head bend forward from the neck axis.
    pub head: f32,
    /// Upper-arm swing forward from hanging along the torso, `[left, right]`.
    pub shoulder: [f32; 2],
    /// Forearm flexion forward from the upper-arm axis.
    pub elbow: [f32; 2],
    /// Thigh swing forward from vertical.
    pub hip: [f32; 2],
    /// Shin flexion backward from the thigh axis.
    pub knee: [f32; 2],
    /// Foot angle above horizontal (toes up), absolute.
    pub toe_up: [f32; 2],
    /// Bone length factors, indexed by the bone's child joint (1 = rest length).
    pub scale: [f32; JOINT_COUNT],
    /// x scale of the profile plane on screen: +1 faces +x, −1 faces −x.
    pub facing: f32,
    /// Root advance along +x on screen, character heights, before fitting into the frame.
    pub travel: f32,
    /// Root height above standing on the lower foot, character heights (hops).
    pub lift: f32,
}

impl Default for Pose {
    fn default() -> Self {
        Pose {
            lean: 0.0,
            neck: 0.0,
            head: 0.0,
            shoulder: [0.0; 2],
            elbow: [0.0; 2],
            hip: [0.0; 2],
            knee: [0.0; 2],
            toe_up: [0.0; 2],
            scale: [1.0; JOINT_COUNT],
            facing: 1.0,
            travel: 0.0,
            lift: 0.0,
        }
    }
}

/// Joint positions relative to the pelvis, in px on screen, and each bone's direction.
#[derive(Debug, Clone, PartialEq)]
pub struct Kinematics {
    /// Joint offsets from the pelvis (px, image axes).
    pub rel: [Vector; JOINT_COUNT],
    /// Unit direction on screen of the bone ending at each joint, as if `facing` were ±1 (so it
    /// stays defined mid-turn); the root's entry points up.
    pub dir: [Vector; JOINT_COUNT],
}

/// Forward kinematics of `pose` for a character `hc` px tall.
pub fn kinematics(pose: &Pose, hc: f32) -> Kinematics {
    let mut angle = [0.0f32; JOINT_COUNT];
    let a_torso = -FRAC_PI_2 + pose.lean;
    angle[PELVIS] = a_torso;
    angle[CHEST] = a_torso;
    angle[NECK] = a_torso + pose.neck;
    angle[HEAD] = angle[NECK] + pose.head;
    for (side, (elbow, wrist, knee, ankle, toe)) in [
        (ELBOW_L, WRIST_L, KNEE_L, ANKLE_L, TOE_L),
        (ELBOW_R, WRIST_R, KNEE_R, ANKLE_R, TOE_R),
    ]
    .into_iter()
    .enumerate()
    {
        angle[elbow] = a_torso + PI - pose.shoulder[side];
        angle[wrist] = angle[elbow] - pose.elbow[side];
        angle[knee] = FRAC_PI_2 - pose.hip[side];
        angle[ankle] = angle[knee] + pose.knee[side];
        angle[toe] = -pose.toe_up[side];
    }
    let sign = if pose.facing < 0.0 { -1.0 } else { 1.0 };
    let mut rel = [Vector::zeros(); JOINT_COUNT];
    let mut dir = [Vector::zeros(); JOINT_COUNT];
    // Joints are ordered parents first.
    for j in 0..JOINT_COUNT {
        let (s, c) = angle[j].sin_cos();
        dir[j] = Vector::new(sign * c, s);
        if let Some(p) = PARENTS[j] {
            let len = BONE_LENGTH[j] * pose.scale[j] * hc;
            rel[j] = rel[p] + Vector::new(pose.facing * c * len, s * len);
        }
    }
    Kinematics { rel, dir }
}

/// Deterministic poses for `frames` frames of `scenario`, varied by `rng`.
pub fn poses(scenario: Scenario, frames: usize, rng: &mut Rng) -> Vec<Pose> {
    // `occlude` always faces +x, so its near arm (the one crossing in front of the torso) is the
    // left one.
    let coin = rng.next_u64() & 1 == 0;
    let facing = if coin || scenario == Scenario::Occlude {
        1.0
    } else {
        -1.0
    };
    let wobble = Wobble::new(rng);
    let mut out = match scenario {
        Scenario::Walk | Scenario::Noisy => walk(frames, rng),
        Scenario::Occlude => occlude(frames, rng),
        Scenario::Fast => fast(frames, rng),
        Scenario::Squash => squash(frames, rng),
        Scenario::Long => long(frames, rng, facing),
    };
    for (t, pose) in out.iter_mut().enumerate() {
        if scenario != Scenario::Long {
            pose.facing = facing;
            pose.travel *= facing;
        }
        wobble.apply(t as f32, pose);
    }
    out
}

/// `((1 + cos x) / 2)^p`: a smooth bump, 1 at x = 0, 0 at x = ±π.
fn bump(x: f32, p: i32) -> f32 {
    (0.5 + 0.5 * x.cos()).powi(p)
}

/// Smooth 0 → 1 between `t0` and `t1` (smoothstep).
fn ramp(t: f32, t0: f32, t1: f32) -> f32 {
    let x = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// 1 inside `[a, b]`, easing in and out over `r` frames at each end.
fn window(t: f32, a: f32, b: f32, r: f32) -> f32 {
    ramp(t, a, a + r) * (1.0 - ramp(t, b - r, b))
}

fn lerp(a: f32, b: f32, w: f32) -> f32 {
    a + (b - a) * w
}

/// Small seeded sums of sines added to every angle channel, zero on frame 0.
struct Wobble {
    /// `(amplitude rad, angular frequency rad/frame, phase rad)`, two terms per channel.
    terms: [[(f32, f32, f32); 2]; 13],
}

impl Wobble {
    fn new(rng: &mut Rng) -> Self {
        let mut terms = [[(0.0, 0.0, 0.0); 2]; 13];
        for ch in terms.iter_mut() {
            for term in ch.iter_mut() {
                *term = (
                    rng.range(0.01, 0.045),
                    TAU / rng.range(20.0, 90.0),
                    rng.range(0.0, TAU),
                );
            }
        }
        Wobble { terms }
    }

    fn value(&self, ch: usize, t: f32) -> f32 {
        self.terms[ch]
            .iter()
            .map(|&(a, w, p)| a * ((w * t + p).sin() - p.sin()))
            .sum()
    }

    fn apply(&self, t: f32, pose: &mut Pose) {
        pose.lean += self.value(0, t);
        pose.neck += self.value(1, t);
        pose.head += self.value(2, t);
        for s in 0..2 {
            pose.shoulder[s] += self.value(3 + s, t);
            pose.elbow[s] += self.value(5 + s, t);
            pose.hip[s] += self.value(7 + s, t);
            pose.knee[s] += 0.5 * self.value(9 + s, t);
            pose.toe_up[s] += self.value(11 + s, t);
        }
    }
}

/// Walk-cycle shape: amplitudes in radians.
struct Gait {
    hip: f32,
    knee: f32,
    arm: f32,
    elbow: f32,
}

impl Gait {
    fn seeded(rng: &mut Rng, scale: f32) -> Self {
        Gait {
            hip: 0.38 * scale * rng.range(0.92, 1.08),
            knee: 0.95 * rng.range(0.9, 1.1),
            arm: 0.62 * scale * rng.range(0.95, 1.1),
            elbow: 0.35 * rng.range(0.85, 1.15),
        }
    }

    /// Distance covered by one cycle (two steps) without the feet sliding, character heights.
    fn stride(&self) -> f32 {
        4.0 * (BONE_LENGTH[KNEE_L] + BONE_LENGTH[ANKLE_L]) * self.hip.sin()
    }

    /// The pose at cycle phase `phi` (rad): left foot strikes at π/2, right at 3π/2.
    fn pose(&self, phi: f32) -> Pose {
        let mut p = Pose {
            lean: 0.07 + 0.025 * (2.0 * phi).cos(),
            neck: -0.06,
            head: 0.08 + 0.03 * (2.0 * phi + 1.0).sin(),
            ..Pose::default()
        };
        for (s, ph) in [phi, phi + PI].into_iter().enumerate() {
            p.hip[s] = 0.06 + self.hip * ph.sin();
            p.knee[s] = 0.1 + self.knee * bump(ph + 0.6, 3);
            p.toe_up[s] = 0.3 * ph.sin();
            let swing = -ph.sin(); // arms swing against the leg on their side
            p.shoulder[s] = 0.05 + self.arm * swing;
            p.elbow[s] = 0.3 + self.elbow * (0.5 + 0.5 * swing);
        }
        p
    }
}

fn walk(frames: usize, rng: &mut Rng) -> Vec<Pose> {
    let period = 46.0 * rng.range(0.88, 1.12);
    let gait = Gait::seeded(rng, 1.0);
    let speed = gait.stride() / period;
    (0..frames)
        .map(|t| {
            let t = t as f32;
            let mut p = gait.pose(FRAC_PI_2 + TAU / period * t);
            p.travel = speed * t;
            p
        })
        .collect()
}

/// Slow steps with wide leg swings that cross each other, the near arm dwelling in front of the
/// torso and the far arm behind it.
fn occlude(frames: usize, rng: &mut Rng) -> Vec<Pose> {
    let leg_period = 48.0 * rng.range(0.9, 1.1);
    let arm_period = 56.0 * rng.range(0.9, 1.1);
    let gait = Gait {
        hip: 0.6 * rng.range(0.95, 1.08),
        knee: 0.7,
        arm: 0.0,
        elbow: 0.0,
    };
    let far_lag = rng.range(0.3, 0.7);
    (0..frames)
        .map(|t| {
            let t = t as f32;
            let mut p = gait.pose(FRAC_PI_2 + TAU / leg_period * t);
            let psi = FRAC_PI_2 + TAU / arm_period * t;
            let near = psi.sin();
            let far = (psi + far_lag).sin();
            p.shoulder[LEFT] = -0.1 + 1.2 * near.powi(3);
            p.elbow[LEFT] = 0.25 + 0.6 * near * near;
            p.shoulder[RIGHT] = -0.1 - 1.0 * far.powi(3);
            p.elbow[RIGHT] = 0.3 + 0.6 * far * far;
            p.travel = 0.004 * t;
            p
        })
        .collect()
}

/// Fighting moves: punches, kicks and lunges, each at its own period.
fn fast(frames: usize, rng: &mut Rng) -> Vec<Pose> {
    let w_arm = TAU / (24.0 * rng.range(0.9, 1.1));
    let w_leg = TAU / (28.0 * rng.range(0.9, 1.1));
    let w_body = TAU / (44.0 * rng.range(0.9, 1.1));
    let arm = 1.25 * rng.range(0.95, 1.1);
    let kick = 0.8 * rng.range(0.95, 1.1);
    (0..frames)
        .map(|t| {
            let t = t as f32;
            let psi = FRAC_PI_2 + w_arm * t;
            let chi = FRAC_PI_2 + w_leg * t;
            let body = w_body * t;
            let mut p = Pose {
                lean: 0.12 + 0.15 * body.sin(),
                neck: -0.05,
                head: 0.05 + 0.1 * (2.0 * body).sin(),
                ..Pose::default()
            };
            p.shoulder[LEFT] = 0.25 + arm * psi.sin();
            p.elbow[LEFT] = 1.0 - 0.85 * (psi + 2.2).sin();
            p.shoulder[RIGHT] = 0.25 - arm * psi.sin();
            p.elbow[RIGHT] = 1.0 + 0.85 * (psi + 2.2).sin();
            p.hip[LEFT] = 0.3 + kick * chi.sin();
            p.knee[LEFT] = 0.8 + 0.6 * (chi + 2.0).sin();
            p.toe_up[LEFT] = 0.3 * chi.sin();
            p.hip[RIGHT] = 0.1 - 0.55 * chi.sin();
            p.knee[RIGHT] = 0.55 - 0.4 * (chi + 2.0).sin();
            p.toe_up[RIGHT] = -0.2 * chi.sin();
            p.travel = 0.5 * (0.8 * body).sin() + 0.1 * (2.3 * body).sin();
            p.lift = 0.05 * (2.0 * w_leg * t).sin().max(0.0).powi(2);
            p
        })
        .collect()
}

/// A bouncy walk whose bones stretch and squash by up to ±30 %.
fn squash(frames: usize, rng: &mut Rng) -> Vec<Pose> {
    let period = 36.0 * rng.range(0.9, 1.1);
    let gait = Gait::seeded(rng, 1.1);
    let speed = gait.stride() / period;
    let w_scale = TAU / (30.0 * rng.range(0.9, 1.1));
    // Each bone at its own rate, starting at rest length (frame 0 is the seed frame) and
    // lengthening or shortening first at random.
    let mut rate = [0.0f32; JOINT_COUNT];
    for r in rate.iter_mut() {
        let sign = if rng.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
        *r = sign * w_scale * rng.range(0.8, 1.25);
    }
    (0..frames)
        .map(|t| {
            let t = t as f32;
            let phi = FRAC_PI_2 + TAU / period * t;
            let mut p = gait.pose(phi);
            for (scale, rate) in p.scale.iter_mut().zip(&rate).skip(1) {
                *scale = 1.0 + 0.3 * (rate * t).sin();
            }
            p.lift = 0.06 * (2.0 * phi).cos().max(0.0).powi(2);
            p.travel = speed * t;
            p
        })
        .collect()
}

/// Length of the long scenario's program; longer clips repeat it (in alternating directions).
pub const LONG_CYCLE: usize = 900;

/// Varied motion: walk, stop and turn, walk back, wave both arms, crouch twice, turn, walk
/// waving the near arm, turn, walk.
fn long(frames: usize, rng: &mut Rng, facing0: f32) -> Vec<Pose> {
    let period = 40.0 * rng.range(0.9, 1.1);
    let gait = Gait::seeded(rng, 1.0);
    let speed = gait.stride() / period;
    let w_wave = TAU / (16.0 * rng.range(0.9, 1.1));
    const TURNS: [f32; 3] = [180.0, 600.0, 762.0];
    let mut phi = FRAC_PI_2;
    let mut travel = 0.0;
    let mut out = Vec::with_capacity(frames);
    for t in 0..frames {
        let cycle = t / LONG_CYCLE;
        let lt = (t % LONG_CYCLE) as f32;
        let tf = t as f32;
        let walking = (1.0 - ramp(lt, 153.0, 168.0))
            .max(window(lt, 195.0, 345.0, 15.0))
            .max(window(lt, 615.0, 750.0, 15.0))
            .max(ramp(lt, 775.0, 790.0));
        let mut facing = facing0 * if cycle % 2 == 1 { -1.0 } else { 1.0 };
        for turn in TURNS {
            facing *= (PI * ramp(lt, turn - 10.0, turn + 10.0)).cos();
        }
        let wave_both = window(lt, 362.0, 475.0, 18.0);
        let wave_near = window(lt, 630.0, 745.0, 18.0);
        let crouch = ((lt - 490.0) / 55.0 * PI).sin().max(0.0)
            * f32::from((490.0..545.0).contains(&lt))
            + ((lt - 550.0) / 55.0 * PI).sin().max(0.0) * f32::from((550.0..605.0).contains(&lt));
        let crouch = crouch * crouch;

        let breathe = 0.02 * (TAU / 70.0 * tf).sin();
        let idle = Pose {
            lean: 0.04 + breathe,
            neck: -0.04,
            head: 0.06 + breathe,
            shoulder: [0.12 + breathe, -0.05],
            elbow: [0.3, 0.32],
            hip: [0.12, -0.06],
            knee: [0.08, 0.1],
            toe_up: [0.0, 0.0],
            ..Pose::default()
        };
        let g = gait.pose(phi);
        let mut p = Pose {
            lean: lerp(idle.lean, g.lean, walking),
            neck: lerp(idle.neck, g.neck, walking),
            head: lerp(idle.head, g.head, walking),
            ..Pose::default()
        };
        let near = if facing >= 0.0 { LEFT } else { RIGHT };
        for s in 0..2 {
            p.hip[s] = lerp(idle.hip[s], g.hip[s], walking);
            p.knee[s] = lerp(idle.knee[s], g.knee[s], walking);
            p.toe_up[s] = lerp(idle.toe_up[s], g.toe_up[s], walking);
            p.shoulder[s] = lerp(idle.shoulder[s], g.shoulder[s], walking);
            p.elbow[s] = lerp(idle.elbow[s], g.elbow[s], walking);
            let wave_phase = w_wave * tf + s as f32 * 2.0;
            let wave = wave_both.max(if s == near { wave_near } else { 0.0 });
            let raise = if s == near { 2.6 } else { 2.1 };
            p.shoulder[s] = lerp(p.shoulder[s], raise + 0.1 * wave_phase.sin(), wave);
            p.elbow[s] = lerp(p.elbow[s], 0.6 + 0.45 * wave_phase.sin(), wave);
            p.hip[s] += 1.4 * crouch;
            p.knee[s] += 2.2 * crouch;
            p.shoulder[s] += 0.9 * crouch;
            p.elbow[s] += 0.3 * crouch;
        }
        p.lean += 0.45 * crouch;
        p.facing = facing;
        p.travel = travel;
        out.push(p);
        phi += TAU / period * walking;
        travel += speed * walking * facing.signum();
    }
    out
}

/// Where the character stands: root positions (px) for every frame so that the lower foot rests
/// on the floor (plus any hop) and every joint stays at least `margin` px inside the frame.
/// `kin` holds each frame's kinematics. Travel is shifted, and shrunk only when it does not fit.
pub fn place_roots(
    poses: &[Pose],
    kin: &[Kinematics],
    hc: f32,
    width: u32,
    height: u32,
    margin: f32,
) -> Vec<Vector> {
    let floor = 0.9 * height as f32;
    let (mut min_dx, mut max_dx) = (f32::INFINITY, f32::NEG_INFINITY);
    let (mut min_tr, mut max_tr) = (f32::INFINITY, f32::NEG_INFINITY);
    for (p, k) in poses.iter().zip(kin) {
        for r in &k.rel {
            min_dx = min_dx.min(r.x);
            max_dx = max_dx.max(r.x);
        }
        min_tr = min_tr.min(p.travel * hc);
        max_tr = max_tr.max(p.travel * hc);
    }
    let lo = margin - min_dx;
    let hi = width as f32 - 1.0 - margin - max_dx;
    let span = max_tr - min_tr;
    let (k, offset) = if hi <= lo {
        (0.0, 0.5 * (width as f32 - 1.0) - 0.5 * (min_dx + max_dx))
    } else if span <= hi - lo {
        (1.0, 0.5 * (lo + hi) - 0.5 * (min_tr + max_tr))
    } else {
        let k = (hi - lo) / span;
        (k, lo - k * min_tr)
    };
    poses
        .iter()
        .zip(kin)
        .map(|(p, k_)| {
            let sole = [ANKLE_L, TOE_L, ANKLE_R, TOE_R]
                .iter()
                .map(|&j| k_.rel[j].y + JOINT_RADIUS[j] * hc)
                .fold(f32::NEG_INFINITY, f32::max);
            Vector::new(offset + k * p.travel * hc, floor - sole - p.lift * hc)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standing_pose_has_the_rest_proportions() {
        let k = kinematics(&Pose::default(), 100.0);
        // Torso straight up, legs straight down, feet forward.
        assert!((k.rel[CHEST] - Vector::new(0.0, -28.0)).norm() < 1e-3);
        assert!((k.rel[ANKLE_L] - Vector::new(0.0, 50.0)).norm() < 1e-3);
        assert!((k.rel[TOE_L] - Vector::new(9.0, 50.0)).norm() < 1e-3);
        // Arms hang along the torso down from the chest.
        assert!((k.rel[WRIST_R] - Vector::new(0.0, 5.0)).norm() < 1e-3);
    }

    #[test]
    fn facing_mirrors_x_only() {
        let mut p = Gait::seeded(&mut Rng::new(3), 1.0).pose(0.3);
        let a = kinematics(&p, 100.0);
        p.facing = -1.0;
        let b = kinematics(&p, 100.0);
        for j in 0..JOINT_COUNT {
            assert!((a.rel[j].x + b.rel[j].x).abs() < 1e-4);
            assert!((a.rel[j].y - b.rel[j].y).abs() < 1e-4);
        }
    }
}
