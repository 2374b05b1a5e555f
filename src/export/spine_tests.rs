use super::*;
use crate::skeleton::Skeleton;

#[test]
fn points_and_angles_round_trip_through_spine_axes() {
    let origin = [120.0, 300.0];
    for p in [[0.0, 0.0], [120.0, 300.0], [311.25, -7.5]] {
        let q = to_spine_point(p, origin);
        let back = from_spine_point(q, origin);
        assert!((back[0] - p[0]).abs() < 1e-12 && (back[1] - p[1]).abs() < 1e-12);
    }
    // Above the floor point is +y in Spine.
    assert_eq!(to_spine_point([120.0, 250.0], origin), [0.0, 50.0]);
    // Straight up on screen (−π/2, y down) is +90° in Spine.
    assert!((to_spine_degrees(-std::f64::consts::FRAC_PI_2) - 90.0).abs() < 1e-12);
    // A direction rotated by the Spine angle gives back the screen direction.
    let theta = 0.7f64;
    let a = to_spine_degrees(theta).to_radians();
    let screen = [theta.cos(), theta.sin()];
    let spine = [a.cos(), a.sin()];
    assert!((spine[0] - screen[0]).abs() < 1e-12 && (spine[1] + screen[1]).abs() < 1e-12);
}

/// Forward kinematics the way Spine does it for this export: the parent's scale x stretches
/// the child's position and turns its axes (`noScale`), and each bone's own scale only
/// moves its tip. Returns each joint's position (output px) at frame `t` of the JSON.
fn spine_fk(doc: &Value, anim: &Animation, t: usize) -> Vec<P64> {
    let names = bone_names(anim);
    let anim_doc = &doc["animations"][ANIMATION]["bones"];
    let bones = doc["bones"].as_array().unwrap();
    let origin = anim.floor_origin();
    // name -> (x, y, world angle rad, scale x, length)
    let mut world: std::collections::HashMap<String, (f64, f64, f64, f64, f64)> =
        Default::default();
    for b in bones {
        let name = b["name"].as_str().unwrap();
        let f = |k: &str| b[k].as_f64().unwrap_or(0.0);
        let tl = &anim_doc[name];
        let key = |k: &str, f2: &str, d: f64| {
            tl[k]
                .as_array()
                .map_or(d, |a| a[t][f2].as_f64().unwrap_or(d))
        };
        let (lx, ly) = (
            f("x") + key("translate", "x", 0.0),
            f("y") + key("translate", "y", 0.0),
        );
        let rot = (f("rotation") + key("rotate", "value", 0.0)).to_radians();
        let sx = key("scale", "x", 1.0);
        let len = f("length");
        let w = match b["parent"].as_str() {
            None => (lx, ly, rot, sx, len),
            Some(p) => {
                let (px, py, pa, ps, _) = world[p];
                let (c, s) = (pa.cos(), pa.sin());
                let (x, y) = (px + c * ps * lx - s * ly, py + s * ps * lx + c * ly);
                let dir = (rot.sin()).atan2(ps * rot.cos());
                (x, y, pa + dir, sx, len)
            }
        };
        world.insert(name.to_owned(), w);
    }
    (0..anim.skeleton.len())
        .map(|j| {
            let (x, y, a, s, len) = world[&names.of_joint[j]];
            let q = match anim.skeleton.parent(j) {
                None => [x, y],
                Some(_) => [x + a.cos() * s * len, y + a.sin() * s * len],
            };
            from_spine_point(q, origin)
        })
        .collect()
}

#[test]
fn bone_names_are_plain_unique_identifiers() {
    let anim = Animation {
        skeleton: Skeleton::new(
            ["hip", "knee.L", "knee-L", "2nd", "root", "toe"]
                .map(String::from)
                .to_vec(),
            vec![None, Some(0), Some(0), Some(0), None, Some(1)],
        ),
        frames: vec![0],
        joints: vec![vec![[0.0; 2]; 6]],
        fps: 30.0,
        width: 10,
        height: 10,
    };
    let n = bone_names(&anim);
    assert_eq!(
        n.of_joint,
        vec![
            "hip",
            "hip_to_knee_L",
            "hip_to_knee_L_2",
            "hip_to_2nd",
            "root",
            // The knee's only bone, named for the knee, where it turns.
            "knee_L"
        ]
    );
    assert_eq!(n.top.as_deref(), Some("root_2"));
}

#[test]
fn keys_put_every_joint_where_the_pose_has_it() {
    // A stretching, turning chain on one root, and a second root.
    let sk = Skeleton::new(
        ["hip", "knee", "foot", "toe", "ball"]
            .map(String::from)
            .to_vec(),
        vec![None, Some(0), Some(1), Some(1), None],
    );
    let joints: Vec<Vec<P64>> = (0..6)
        .map(|t| {
            let t = t as f64;
            let hip = [50.0 + 3.0 * t, 40.0 - t];
            let a1 = 1.2 + 0.9 * t; // crosses ±π on the way
            let knee = [
                hip[0] + (20.0 + 4.0 * t) * a1.cos(),
                hip[1] + (20.0 + 4.0 * t) * a1.sin(),
            ];
            let a2 = -0.4 * t;
            let foot = [knee[0] + 15.0 * a2.cos(), knee[1] + 15.0 * a2.sin()];
            let toe = [
                knee[0] + (9.0 - t) * (a2 + 1.0).cos(),
                knee[1] + (9.0 - t) * (a2 + 1.0).sin(),
            ];
            vec![hip, knee, foot, toe, [5.0, 5.0 + t]]
        })
        .collect();
    let anim = Animation {
        skeleton: sk,
        frames: (10..16).collect(),
        joints,
        fps: 24.0,
        width: 100,
        height: 100,
    };
    let mesh = SkinMesh {
        name: "c".into(),
        image: "c.png".into(),
        image_width: 10,
        image_height: 10,
        uvs: vec![],
        rest: vec![],
        bone: vec![],
        triangles: vec![],
        hull: 0,
    };
    let doc: Value = serde_json::from_str(&to_spine(&anim, &mesh, Keys::EveryFrame, &[])).unwrap();
    assert_eq!(doc["bones"][0]["name"], "root");
    // Bones are named by their pivot: hip (a root) to knee, then the knee's two bones.
    assert_eq!(doc["bones"][2]["name"], "hip_to_knee");
    assert_eq!(doc["bones"][3]["name"], "knee_to_foot");
    // The clock starts at the first frame (frame 10), whatever its index.
    let hip = &doc["animations"][ANIMATION]["bones"]["hip"]["translate"];
    assert_eq!(hip[0]["time"], 0.0);
    assert_eq!(hip[2]["time"], round(2.0 / 24.0, 6));
    for t in 0..anim.frames.len() {
        for (j, p) in spine_fk(&doc, &anim, t).iter().enumerate() {
            let want = anim.joints[t][j];
            let err = (p[0] - want[0]).hypot(p[1] - want[1]);
            assert!(err < 1e-3, "frame {t} joint {j}: {p:?} vs {want:?}");
        }
    }
}
