//! Biovision hierarchy (BVH), 2D, as Blender's importer reads it.
//!
//! **Axes.** BVH is y up: `X = x − x0`, `Y = y0 − y`, `Z = 0`, in px, about the floor point
//! `(x0, y0)` ([`Animation::floor_origin`]); rotations in degrees, counter-clockwise seen from
//! +Z. Blender's importer (File → Import → Motion Capture, default axes: Y up, −Z forward) puts
//! the character upright in the XZ plane; set its Scale to 0.01 for about 1 unit per 100 px.
//!
//! **Hierarchy.** One `JOINT` per joint, named after it, nested as the skeleton (several root
//! joints hang under an extra `ROOT root` at the origin). `OFFSET` is the joint's position
//! relative to its parent on the first frame, which is the rest pose (all rotations 0). A leaf
//! ends in an `End Site` a quarter of its bone's length further along it.
//!
//! **Channels.** Every joint has `Xposition Yposition Zrotation`. The root's position is where it
//! is; a joint's position is its place in its parent's rotated frame. Retargeted bones change
//! length, which rotations alone cannot say, so the child joints carry positions too (Blender
//! reads them as the bone's location relative to its rest `OFFSET`). A joint's frame turns with
//! the bone to its first child (a leaf: with the bone ending at it), by the change from the rest
//! pose; its `Zrotation` is that turn relative to its parent's, unwrapped over the frames.
//! `Frame Time` is 1 / fps; frame 0 of the file is the run's first frame.
//!
//! [`read_bvh`] reads this subset back (used to check round trips).

use super::{round, Animation};
use crate::retarget::P64;
use std::fmt::Write as _;

/// An output position (px, y down) in BVH axes (px, y up) about the floor point `origin`.
pub fn to_bvh_point(p: P64, origin: P64) -> P64 {
    [p[0] - origin[0], origin[1] - p[1]]
}

/// A BVH position (X, Y; px, y up) back in output px (y down); inverse of [`to_bvh_point`].
pub fn from_bvh_point(q: P64, origin: P64) -> P64 {
    [q[0] + origin[0], origin[1] - q[1]]
}

/// The BVH text for `anim` (deterministic).
pub fn to_bvh(anim: &Animation) -> String {
    let sk = &anim.skeleton;
    let origin = anim.floor_origin();
    let series = anim.bone_series();
    let n = sk.len();
    let frames = anim.frames.len();
    let pos = |t: usize, j: usize| to_bvh_point(anim.joints[t][j], origin);
    // Bone whose turn joint j's frame follows.
    let frame_bone: Vec<Option<usize>> = (0..n)
        .map(|j| match sk.children(j).first() {
            Some(&c) => series.ending_at(c),
            None => series.ending_at(j),
        })
        .collect();
    // World turn of joint j's frame at t: radians, counter-clockwise (y up).
    let turn = |t: usize, j: usize| {
        frame_bone[j].map_or(0.0, |b| -(series.angle[t][b] - series.angle[0][b]))
    };

    let roots = sk.roots();
    let top = (roots.len() > 1).then(|| {
        let mut s = String::from("root");
        while sk.index_of(&s).is_some() {
            s.push('_');
        }
        s
    });
    let mut out = String::from("HIERARCHY\n");
    // Channel order = the order joints are written (depth first).
    let mut order: Vec<usize> = Vec::with_capacity(n);
    fn write_joint(
        out: &mut String,
        order: &mut Vec<usize>,
        anim: &Animation,
        series: &super::BoneSeries,
        j: usize,
        depth: usize,
        keyword: &str,
        origin: P64,
    ) {
        let sk = &anim.skeleton;
        let ind = "  ".repeat(depth);
        let p = to_bvh_point(anim.joints[0][j], origin);
        let off = match sk.parent(j) {
            None => p,
            Some(q) => {
                let pq = to_bvh_point(anim.joints[0][q], origin);
                [p[0] - pq[0], p[1] - pq[1]]
            }
        };
        let _ = writeln!(out, "{ind}{keyword} {}", sk.names[j]);
        let _ = writeln!(out, "{ind}{{");
        let _ = writeln!(out, "{ind}  OFFSET {} {} 0", num(off[0]), num(off[1]));
        let _ = writeln!(out, "{ind}  CHANNELS 3 Xposition Yposition Zrotation");
        order.push(j);
        let children = sk.children(j);
        for &c in &children {
            write_joint(out, order, anim, series, c, depth + 1, "JOINT", origin);
        }
        if children.is_empty() {
            let end = match series.ending_at(j) {
                Some(b) => {
                    let (l, a) = (series.length[0][b], series.angle[0][b]);
                    [0.25 * l * a.cos(), -0.25 * l * a.sin()]
                }
                None => [0.0, 10.0],
            };
            let _ = writeln!(out, "{ind}  End Site");
            let _ = writeln!(out, "{ind}  {{");
            let _ = writeln!(out, "{ind}    OFFSET {} {} 0", num(end[0]), num(end[1]));
            let _ = writeln!(out, "{ind}  }}");
        }
        let _ = writeln!(out, "{ind}}}");
    }
    match &top {
        Some(name) => {
            let _ = writeln!(out, "ROOT {name}\n{{\n  OFFSET 0 0 0");
            let _ = writeln!(out, "  CHANNELS 3 Xposition Yposition Zrotation");
            for &r in &roots {
                write_joint(&mut out, &mut order, anim, &series, r, 1, "JOINT", origin);
            }
            out.push_str("}\n");
        }
        None => write_joint(
            &mut out, &mut order, anim, &series, roots[0], 0, "ROOT", origin,
        ),
    }
    let _ = writeln!(out, "MOTION\nFrames: {frames}");
    let _ = writeln!(out, "Frame Time: {:.8}", 1.0 / anim.fps);
    for t in 0..frames {
        let mut line = String::new();
        if top.is_some() {
            line.push_str("0 0 0");
        }
        for &j in &order {
            let (local, parent_turn) = match sk.parent(j) {
                None => (pos(t, j), 0.0),
                Some(p) => {
                    let (a, b) = (pos(t, j), pos(t, p));
                    let d = [a[0] - b[0], a[1] - b[1]];
                    let pt = turn(t, p);
                    let (c, s) = (pt.cos(), pt.sin());
                    ([c * d[0] + s * d[1], -s * d[0] + c * d[1]], pt)
                }
            };
            let rot = (turn(t, j) - parent_turn).to_degrees();
            if !line.is_empty() {
                line.push(' ');
            }
            let _ = write!(line, "{} {} {}", num(local[0]), num(local[1]), num(rot));
        }
        out.push_str(&line);
        out.push('\n');
    }
    out
}

/// A number with at most 6 decimals, no trailing zeros.
fn num(x: f64) -> String {
    let r = round(x, 6);
    let s = format!("{r:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.to_owned()
    }
}

/// A BVH file as [`read_bvh`] reads it: joints (not End Sites) in file order, and their world
/// positions (BVH axes: X, Y; px) on every frame.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhMotion {
    pub names: Vec<String>,
    pub parents: Vec<Option<usize>>,
    /// Seconds per frame.
    pub frame_time: f64,
    /// `[frame][joint]`: world position (X, Y).
    pub positions: Vec<Vec<P64>>,
}

/// Reads a 2D BVH file: `ROOT`/`JOINT`/`End Site` blocks with `OFFSET` and any of `Xposition
/// Yposition Zposition Xrotation Yrotation Zrotation`; X and Y rotations must be 0 (a 2D file).
/// A joint's frame is its parent's, moved to its position channels (its `OFFSET` when it has
/// none) and turned by its `Zrotation`, as Blender's importer does. Errors are messages.
pub fn read_bvh(text: &str) -> Result<BvhMotion, String> {
    let mut tok = text.split_whitespace().peekable();
    let mut next = |what: &str| tok.next().ok_or_else(|| format!("file ends before {what}"));
    if next("HIERARCHY")? != "HIERARCHY" {
        return Err("does not start with HIERARCHY".into());
    }
    struct Node {
        parent: Option<usize>,
        offset: P64,
        channels: Vec<String>,
    }
    let mut names = Vec::new();
    let mut nodes: Vec<Node> = Vec::new();
    let mut stack: Vec<Option<usize>> = Vec::new(); // None = an End Site block
    let mut word = next("ROOT")?;
    loop {
        match word {
            "ROOT" | "JOINT" => {
                let name = next("a joint name")?;
                if next("{")? != "{" {
                    return Err(format!("joint {name}: expected {{"));
                }
                let parent = stack.iter().rev().flatten().next().copied();
                names.push(name.to_owned());
                nodes.push(Node {
                    parent,
                    offset: [0.0; 2],
                    channels: Vec::new(),
                });
                stack.push(Some(nodes.len() - 1));
            }
            "End" => {
                if next("Site")? != "Site" || next("{")? != "{" {
                    return Err("expected `End Site {`".into());
                }
                stack.push(None);
            }
            "OFFSET" => {
                let mut v = [0.0; 3];
                for x in &mut v {
                    *x = next("an OFFSET value")?
                        .parse()
                        .map_err(|e| format!("OFFSET: {e}"))?;
                }
                if let Some(Some(i)) = stack.last() {
                    nodes[*i].offset = [v[0], v[1]];
                }
            }
            "CHANNELS" => {
                let k: usize = next("a channel count")?
                    .parse()
                    .map_err(|e| format!("CHANNELS: {e}"))?;
                let i = stack
                    .last()
                    .copied()
                    .flatten()
                    .ok_or("CHANNELS outside a joint")?;
                for _ in 0..k {
                    nodes[i].channels.push(next("a channel name")?.to_owned());
                }
            }
            "}" => {
                stack.pop().ok_or("unbalanced }")?;
            }
            "MOTION" => break,
            other => return Err(format!("unexpected {other:?} in the hierarchy")),
        }
        word = next("MOTION")?;
    }
    if next("Frames:")? != "Frames:" {
        return Err("expected `Frames:`".into());
    }
    let count: usize = next("a frame count")?
        .parse()
        .map_err(|e| format!("Frames: {e}"))?;
    if (next("Frame")?, next("Time:")?) != ("Frame", "Time:") {
        return Err("expected `Frame Time:`".into());
    }
    let frame_time: f64 = next("a frame time")?
        .parse()
        .map_err(|e| format!("Frame Time: {e}"))?;
    let mut positions = Vec::with_capacity(count);
    for f in 0..count {
        // World frame of each node: origin and turn (radians, counter-clockwise).
        let mut world: Vec<(P64, f64)> = Vec::with_capacity(nodes.len());
        for node in &nodes {
            let mut loc = node.offset;
            let mut has_loc = [false; 2];
            let mut rot = 0.0f64;
            for ch in &node.channels {
                let v: f64 = next("a channel value")?
                    .parse()
                    .map_err(|e| format!("frame {f}: {e}"))?;
                match ch.as_str() {
                    "Xposition" => (loc[0], has_loc[0]) = (v, true),
                    "Yposition" => (loc[1], has_loc[1]) = (v, true),
                    "Zposition" => {}
                    "Zrotation" => rot = v.to_radians(),
                    "Xrotation" | "Yrotation" if v.abs() < 1e-9 => {}
                    "Xrotation" | "Yrotation" => {
                        return Err(format!("frame {f}: {ch} is {v}: not a 2D file"))
                    }
                    other => return Err(format!("unknown channel {other:?}")),
                }
            }
            world.push(match node.parent {
                None => (loc, rot),
                Some(p) => {
                    let (o, a) = world[p];
                    let (c, s) = (a.cos(), a.sin());
                    (
                        [
                            o[0] + c * loc[0] - s * loc[1],
                            o[1] + s * loc[0] + c * loc[1],
                        ],
                        a + rot,
                    )
                }
            });
        }
        positions.push(world.into_iter().map(|(o, _)| o).collect());
    }
    Ok(BvhMotion {
        names,
        parents: nodes.iter().map(|n| n.parent).collect(),
        frame_time,
        positions,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::Skeleton;

    #[test]
    fn numbers_are_short_and_never_negative_zero() {
        assert_eq!(num(1.5), "1.5");
        assert_eq!(num(-0.0000001), "0");
        assert_eq!(num(2.0), "2");
        assert_eq!(num(-3.1234567), "-3.123457");
    }

    #[test]
    fn a_stretching_turning_chain_reads_back_exactly() {
        let sk = Skeleton::new(
            ["a", "b", "c", "d"].map(String::from).to_vec(),
            vec![None, Some(0), Some(1), None],
        );
        let joints: Vec<Vec<P64>> = (0..5)
            .map(|t| {
                let t = t as f64;
                let a = [30.0 + t, 50.0];
                let b = [
                    a[0] + (10.0 + t) * (0.5 + t).cos(),
                    a[1] + (10.0 + t) * (0.5 + t).sin(),
                ];
                let c = [b[0] + 8.0 * (2.0 * t).cos(), b[1] + 8.0 * (2.0 * t).sin()];
                vec![a, b, c, [1.0, 2.0 * t]]
            })
            .collect();
        let anim = Animation {
            skeleton: sk,
            frames: (0..5).collect(),
            joints,
            fps: 30.0,
            width: 64,
            height: 64,
        };
        let text = to_bvh(&anim);
        assert!(
            text.starts_with("HIERARCHY\nROOT root\n{\n  OFFSET 0 0 0\n"),
            "{text}"
        );
        let m = read_bvh(&text).unwrap();
        assert_eq!(m.names, vec!["root", "a", "b", "c", "d"]);
        assert!((m.frame_time - 1.0 / 30.0).abs() < 1e-8);
        let origin = anim.floor_origin();
        for (t, f) in m.positions.iter().enumerate() {
            for (j, name) in anim.skeleton.names.iter().enumerate() {
                let k = m.names.iter().position(|n| n == name).unwrap();
                let p = from_bvh_point(f[k], origin);
                let want = anim.joints[t][j];
                assert!((p[0] - want[0]).hypot(p[1] - want[1]) < 1e-4, "{t} {name}");
            }
        }
    }
}
