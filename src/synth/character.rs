//! The synthetic character: its joints, proportions and looks.
//!
//! A cartoon figure seen in profile. Arms articulate at the chest joint (the shoulder line) and
//! legs at the pelvis joint (the hip line), so every bone runs between two joints and its length
//! is the distance between their ground-truth positions. Lengths and radii are in *character
//! heights* (sole to the top of the head when standing); the renderer multiplies them by the
//! character height in px.

/// Root joint: the hip line, where both thighs articulate.
pub const PELVIS: usize = 0;
/// The shoulder line, where both upper arms articulate; top of the torso.
pub const CHEST: usize = 1;
/// Top of the neck, base of the skull.
pub const NECK: usize = 2;
/// Centre of the head.
pub const HEAD: usize = 3;
/// Left elbow (the near side when the character faces +x).
pub const ELBOW_L: usize = 4;
/// Left wrist.
pub const WRIST_L: usize = 5;
/// Right elbow (the far side when the character faces +x).
pub const ELBOW_R: usize = 6;
/// Right wrist.
pub const WRIST_R: usize = 7;
/// Left knee.
pub const KNEE_L: usize = 8;
/// Left ankle.
pub const ANKLE_L: usize = 9;
/// Tip of the left foot.
pub const TOE_L: usize = 10;
/// Right knee.
pub const KNEE_R: usize = 11;
/// Right ankle.
pub const ANKLE_R: usize = 12;
/// Tip of the right foot.
pub const TOE_R: usize = 13;

/// Number of joints.
pub const JOINT_COUNT: usize = 14;

/// Joint names, in index order (parents before children).
pub const JOINT_NAMES: [&str; JOINT_COUNT] = [
    "pelvis", "chest", "neck", "head", "elbow_l", "wrist_l", "elbow_r", "wrist_r", "knee_l",
    "ankle_l", "toe_l", "knee_r", "ankle_r", "toe_r",
];

/// Parent of each joint; a bone runs parent → child.
pub const PARENTS: [Option<usize>; JOINT_COUNT] = [
    None,
    Some(PELVIS),
    Some(CHEST),
    Some(NECK),
    Some(CHEST),
    Some(ELBOW_L),
    Some(CHEST),
    Some(ELBOW_R),
    Some(PELVIS),
    Some(KNEE_L),
    Some(ANKLE_L),
    Some(PELVIS),
    Some(KNEE_R),
    Some(ANKLE_R),
];

/// Rest length (character heights) of the bone that ends at each joint; 0 for the root.
pub const BONE_LENGTH: [f32; JOINT_COUNT] = [
    0.0, 0.28, 0.07, 0.065, 0.17, 0.16, 0.17, 0.16, 0.255, 0.245, 0.09, 0.255, 0.245, 0.09,
];

/// Limb radius (character heights) at each joint: the drawn half-width there.
pub const JOINT_RADIUS: [f32; JOINT_COUNT] = [
    0.066, 0.078, 0.026, 0.068, 0.028, 0.022, 0.028, 0.022, 0.038, 0.028, 0.019, 0.038, 0.028,
    0.019,
];

/// Body side of a limb: index 0 is left, 1 is right.
pub const LEFT: usize = 0;
/// See [`LEFT`].
pub const RIGHT: usize = 1;

/// How a part's surface is patterned, in the part's own frame (`u` along the bone, `v` across).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pattern {
    /// One colour.
    Flat,
    /// Bands across the bone.
    Bands,
    /// Stripes along the bone.
    Stripes,
    /// A checkerboard.
    Checks,
    /// Dots on a staggered lattice.
    Dots,
    /// Stripes at 45°.
    Diagonal,
    /// V-shaped bands pointing along the bone.
    Chevrons,
    /// Skin with hair on the back and top, and an eye at the front.
    Face,
}

/// The colours and pattern of one part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Look {
    /// Base colour (RGB, 0–255).
    pub fill: [f32; 3],
    /// Pattern colour (RGB, 0–255).
    pub accent: [f32; 3],
    pub pattern: Pattern,
    /// Pattern period in character heights.
    pub period: f32,
}

/// The geometry of a drawn part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartShape {
    /// A tapered capsule from joint `a` to joint `b`.
    Capsule,
    /// A disc centred on joint `b` (the head), oriented along `a → b`.
    Disc,
    /// A fist: a disc just beyond joint `b` (the wrist), along `a → b`.
    Fist,
}

/// One drawn part of the character.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Part {
    pub name: &'static str,
    /// Start joint (the bone's parent end).
    pub a: usize,
    /// End joint (the bone's child end); the part is scaled with this joint's bone.
    pub b: usize,
    pub shape: PartShape,
    /// Radii at `a` and `b` (character heights); a disc uses `rb`.
    pub ra: f32,
    pub rb: f32,
    /// Body side for limbs (`LEFT`/`RIGHT`), `None` for the trunk and head.
    pub side: Option<usize>,
    pub look: Look,
}

const fn rgb(r: u8, g: u8, b: u8) -> [f32; 3] {
    [r as f32, g as f32, b as f32]
}

const fn look(fill: [f32; 3], accent: [f32; 3], pattern: Pattern, period: f32) -> Look {
    Look {
        fill,
        accent,
        pattern,
        period,
    }
}

/// Every part of the character. Each limb part has its own colours and pattern, and left and
/// right differ, so a template match cannot confuse them.
pub const PARTS: [Part; 15] = [
    Part {
        name: "torso",
        a: PELVIS,
        b: CHEST,
        shape: PartShape::Capsule,
        ra: 0.066,
        rb: 0.078,
        side: None,
        look: look(rgb(52, 84, 168), rgb(112, 150, 222), Pattern::Bands, 0.06),
    },
    Part {
        name: "neck",
        a: CHEST,
        b: NECK,
        shape: PartShape::Capsule,
        ra: 0.028,
        rb: 0.026,
        side: None,
        look: look(rgb(214, 170, 138), rgb(190, 146, 116), Pattern::Bands, 0.03),
    },
    Part {
        name: "head",
        a: NECK,
        b: HEAD,
        shape: PartShape::Disc,
        ra: 0.068,
        rb: 0.068,
        side: None,
        look: look(rgb(232, 188, 152), rgb(74, 46, 30), Pattern::Face, 0.068),
    },
    Part {
        name: "upper_arm_l",
        a: CHEST,
        b: ELBOW_L,
        shape: PartShape::Capsule,
        ra: 0.032,
        rb: 0.028,
        side: Some(LEFT),
        look: look(rgb(196, 54, 46), rgb(246, 160, 130), Pattern::Checks, 0.04),
    },
    Part {
        name: "forearm_l",
        a: ELBOW_L,
        b: WRIST_L,
        shape: PartShape::Capsule,
        ra: 0.027,
        rb: 0.022,
        side: Some(LEFT),
        look: look(rgb(232, 140, 34), rgb(252, 222, 120), Pattern::Dots, 0.036),
    },
    Part {
        name: "hand_l",
        a: ELBOW_L,
        b: WRIST_L,
        shape: PartShape::Fist,
        ra: 0.026,
        rb: 0.026,
        side: Some(LEFT),
        look: look(rgb(244, 206, 92), rgb(244, 206, 92), Pattern::Flat, 0.03),
    },
    Part {
        name: "upper_arm_r",
        a: CHEST,
        b: ELBOW_R,
        shape: PartShape::Capsule,
        ra: 0.032,
        rb: 0.028,
        side: Some(RIGHT),
        look: look(
            rgb(120, 60, 156),
            rgb(196, 150, 226),
            Pattern::Diagonal,
            0.04,
        ),
    },
    Part {
        name: "forearm_r",
        a: ELBOW_R,
        b: WRIST_R,
        shape: PartShape::Capsule,
        ra: 0.027,
        rb: 0.022,
        side: Some(RIGHT),
        look: look(rgb(34, 146, 140), rgb(150, 226, 210), Pattern::Bands, 0.034),
    },
    Part {
        name: "hand_r",
        a: ELBOW_R,
        b: WRIST_R,
        shape: PartShape::Fist,
        ra: 0.026,
        rb: 0.026,
        side: Some(RIGHT),
        look: look(rgb(150, 206, 236), rgb(150, 206, 236), Pattern::Flat, 0.03),
    },
    Part {
        name: "thigh_l",
        a: PELVIS,
        b: KNEE_L,
        shape: PartShape::Capsule,
        ra: 0.046,
        rb: 0.038,
        side: Some(LEFT),
        look: look(
            rgb(54, 146, 62),
            rgb(168, 222, 120),
            Pattern::Stripes,
            0.036,
        ),
    },
    Part {
        name: "shin_l",
        a: KNEE_L,
        b: ANKLE_L,
        shape: PartShape::Capsule,
        ra: 0.035,
        rb: 0.028,
        side: Some(LEFT),
        look: look(rgb(196, 186, 54), rgb(120, 104, 30), Pattern::Checks, 0.036),
    },
    Part {
        name: "foot_l",
        a: ANKLE_L,
        b: TOE_L,
        shape: PartShape::Capsule,
        ra: 0.028,
        rb: 0.019,
        side: Some(LEFT),
        look: look(rgb(132, 78, 44), rgb(220, 200, 170), Pattern::Bands, 0.045),
    },
    Part {
        name: "thigh_r",
        a: PELVIS,
        b: KNEE_R,
        shape: PartShape::Capsule,
        ra: 0.046,
        rb: 0.038,
        side: Some(RIGHT),
        look: look(
            rgb(36, 70, 118),
            rgb(120, 170, 210),
            Pattern::Chevrons,
            0.05,
        ),
    },
    Part {
        name: "shin_r",
        a: KNEE_R,
        b: ANKLE_R,
        shape: PartShape::Capsule,
        ra: 0.035,
        rb: 0.028,
        side: Some(RIGHT),
        look: look(rgb(214, 104, 160), rgb(250, 200, 226), Pattern::Dots, 0.034),
    },
    Part {
        name: "foot_r",
        a: ANKLE_R,
        b: TOE_R,
        shape: PartShape::Capsule,
        ra: 0.028,
        rb: 0.019,
        side: Some(RIGHT),
        look: look(rgb(92, 96, 110), rgb(196, 200, 212), Pattern::Stripes, 0.03),
    },
];
