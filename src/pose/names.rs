//! Which joints of a skeleton the pose network gives: BlazePose's 33 landmarks by the names a
//! user's skeleton may call them (COCO's `left_elbow`, MediaPipe's `left_foot_index`, the short
//! `elbow_l` / `l_elbow` / `elbowL` forms).

/// BlazePose's landmark names, by index.
pub const LANDMARK_NAMES: [&str; 33] = [
    "nose",
    "left_eye_inner",
    "left_eye",
    "left_eye_outer",
    "right_eye_inner",
    "right_eye",
    "right_eye_outer",
    "left_ear",
    "right_ear",
    "mouth_left",
    "mouth_right",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_pinky",
    "right_pinky",
    "left_index",
    "right_index",
    "left_thumb",
    "right_thumb",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
    "left_heel",
    "right_heel",
    "left_foot_index",
    "right_foot_index",
];

/// The COCO keypoints `mocap2d seed` writes, in COCO's order.
pub const COCO: [&str; 17] = [
    "nose",
    "left_eye",
    "right_eye",
    "left_ear",
    "right_ear",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
];

/// The landmark a joint name stands for, if any: a BlazePose name, or a side-marked body part
/// (`elbow_l`, `l_elbow`, `elbowL`, `left-elbow`, any case).
pub fn landmark_of(name: &str) -> Option<usize> {
    let lower = name.to_ascii_lowercase().replace(['-', ' ', '.'], "_");
    if let Some(i) = LANDMARK_NAMES.iter().position(|n| *n == lower) {
        return Some(i);
    }
    let (side, part) = split_side(name)?;
    let part = match part.as_str() {
        "toe" | "foot" | "foot_index" | "toes" => "foot_index",
        "hand" | "index" => "index",
        p => p,
    };
    let full = format!("{side}_{part}");
    LANDMARK_NAMES.iter().position(|n| *n == full)
}

/// `("left" | "right", part)` of a side-marked name.
fn split_side(name: &str) -> Option<(&'static str, String)> {
    let lower = name.to_ascii_lowercase().replace(['-', ' ', '.'], "_");
    let side = |s: &str| match s {
        "l" | "left" => Some("left"),
        "r" | "right" => Some("right"),
        _ => None,
    };
    if let Some((a, b)) = lower.rsplit_once('_') {
        if let Some(s) = side(b) {
            return Some((s, a.to_string()));
        }
    }
    if let Some((a, b)) = lower.split_once('_') {
        if let Some(s) = side(a) {
            return Some((s, b.to_string()));
        }
    }
    // elbowL / elbowR: the side as a capital at the end.
    let last = name.chars().last()?;
    if name.len() > 1 && (last == 'L' || last == 'R') {
        let part = name[..name.len() - 1].to_ascii_lowercase();
        return Some((if last == 'L' { "left" } else { "right" }, part));
    }
    None
}

/// The landmark of each joint of a skeleton (by its names), and whether the skeleton is a
/// person's: at least a shoulder, a hip and an elbow or knee on each side named for the body.
pub fn human_joints(names: &[String]) -> Option<Vec<Option<usize>>> {
    let map: Vec<Option<usize>> = names.iter().map(|n| landmark_of(n)).collect();
    let has = |ids: &[usize]| ids.iter().any(|i| map.contains(&Some(*i)));
    let person =
        has(&[11, 12, 23, 24]) && has(&[13, 14, 25, 26]) && map.iter().flatten().count() >= 6;
    person.then_some(map)
}

/// The landmark of `i`'s other side (a left one's right one), or `i` on the midline.
pub fn mirror(i: usize) -> usize {
    let name = LANDMARK_NAMES[i];
    let other = if let Some(rest) = name.strip_prefix("left_") {
        format!("right_{rest}")
    } else if let Some(rest) = name.strip_prefix("right_") {
        format!("left_{rest}")
    } else if name == "mouth_left" {
        "mouth_right".into()
    } else if name == "mouth_right" {
        "mouth_left".into()
    } else {
        return i;
    };
    LANDMARK_NAMES.iter().position(|n| *n == other).unwrap_or(i)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn coco_mediapipe_and_short_forms_name_the_same_landmarks() {
        assert_eq!(landmark_of("left_elbow"), Some(13));
        assert_eq!(landmark_of("elbow_l"), Some(13));
        assert_eq!(landmark_of("l_elbow"), Some(13));
        assert_eq!(landmark_of("ElbowL"), Some(13));
        assert_eq!(landmark_of("right_foot_index"), Some(32));
        assert_eq!(landmark_of("toe_r"), Some(32));
        assert_eq!(landmark_of("pelvis"), None);
        assert_eq!(landmark_of("female.eyeL"), None);
    }

    #[test]
    fn a_persons_skeleton_turns_the_cue_on_and_a_flys_does_not() {
        let dance = names(&COCO);
        assert!(human_joints(&dance).is_some());
        let walk = names(&[
            "pelvis", "chest", "neck", "head", "elbow_l", "wrist_l", "elbow_r", "wrist_r",
            "knee_l", "ankle_l", "toe_l", "knee_r", "ankle_r", "toe_r",
        ]);
        // The synthetic walk has no shoulders or hips named for the body.
        assert!(human_joints(&walk).is_none());
        let fly = names(&[
            "female.thorax",
            "female.head",
            "female.eyeL",
            "female.eyeR",
            "female.forelegL4",
            "female.wingL",
            "female.wingR",
        ]);
        assert!(human_joints(&fly).is_none());
    }

    #[test]
    fn mirror_swaps_sides_and_keeps_the_midline() {
        assert_eq!(mirror(13), 14);
        assert_eq!(mirror(14), 13);
        assert_eq!(mirror(0), 0);
        assert_eq!(mirror(9), 10);
        for i in 0..33 {
            assert_eq!(mirror(mirror(i)), i);
        }
    }
}
