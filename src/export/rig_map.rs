//! Which bone of an animator's own Spine skeleton follows which part of the retargeted character
//! ([`super::spine_rig`]), by structure, by name, or as the user says.
//!
//! **A mapping** names the joint a bone turns at, its pivot, as an animator thinks of it
//! (`front-upper-arm = left_shoulder`): the bone follows the character's bone from that joint to
//! its only child. `PIVOT>JOINT` picks one of several bones that turn at `PIVOT`
//! (`torso = pelvis>chest`). A root joint alone (`hip = pelvis`) moves the bone with the joint
//! (translate keys). `""` (in a map file) leaves the bone in its setup pose.
//!
//! **By structure** ([`structural`]): both skeletons are read as trees of bones (the character's
//! joint tree as the bones ending at each joint). Left and right come from the names' own words
//! (`left`/`l`/`front` and `right`/`r`/`rear`/`back`, split at `-`, `_`, `.` and spaces). A limb
//! is a chain of bones of one side hanging from a bone of no side (IK target bones and their
//! children are controls, not limbs); of a side's limbs the highest is the arm, the lowest the
//! leg. The hip is where the legs hang from (it follows the root joint's position); the spine is
//! the chain from the hip to where the arms hang; the head chain continues from there, through
//! the child that carries on the spine's direction. Chains pair up from their first bone with
//! length, one for one (the spine spread evenly), after a collarbone or hip-socket bone at the
//! start of a character's limb (a joint named `shoulder`, `clavicle`, `collar` or `hip`, or a
//! short sideways first bone) is set aside.

use super::Animation;

/// One of the animator's bones, as far as mapping goes.
#[derive(Debug, Clone)]
pub struct RigBone {
    pub name: String,
    pub parent: Option<usize>,
    pub length: f64,
    /// World position of its origin and its tip in the setup pose, y up.
    pub base: [f64; 2],
    pub tip: [f64; 2],
    /// An IK target or a child of one: a control, never part of a limb.
    pub control: bool,
}

/// What one of their bones follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Follow {
    /// A root joint's position (translate keys).
    Root(usize),
    /// The character's bone ending at this joint, from its parent, the pivot (rotate keys).
    Segment(usize),
}

impl Follow {
    /// The mapping's text: `PIVOT`, `PIVOT>JOINT` when several bones turn at `PIVOT` (or it is
    /// a root), or the root joint's name.
    pub fn spec(self, anim: &Animation) -> String {
        let sk = &anim.skeleton;
        match self {
            Follow::Root(j) => sk.names[j].clone(),
            Follow::Segment(c) => {
                // Cannot fail: a segment ends at a joint with a parent.
                let p = sk.parent(c).expect("a segment has a pivot");
                if sk.children(p).len() == 1 && sk.parent(p).is_some() {
                    sk.names[p].clone()
                } else {
                    format!("{}>{}", sk.names[p], sk.names[c])
                }
            }
        }
    }
}

/// The mapping `spec` (for their bone `bone`) read against the character: `Ok(None)` for `""`.
/// Errors are the message's text, fix included.
pub fn parse_spec(spec: &str, bone: &str, anim: &Animation) -> Result<Option<Follow>, String> {
    let sk = &anim.skeleton;
    let spec = spec.trim();
    if spec.is_empty() {
        return Ok(None);
    }
    let joint = |n: &str| {
        sk.index_of(n.trim()).ok_or_else(|| {
            format!(
                "{bone}={spec}: the retargeted character has no joint {:?} (its joints: {})",
                n.trim(),
                sk.names.join(", ")
            )
        })
    };
    if let Some((p, c)) = spec.split_once('>') {
        let (p, c) = (joint(p)?, joint(c)?);
        if sk.parent(c) != Some(p) {
            return Err(format!(
                "{bone}={spec}: {} is not a child of {}; PIVOT>JOINT names one of the bones \
                 turning at PIVOT ({})",
                sk.names[c],
                sk.names[p],
                children_text(anim, p)
            ));
        }
        return Ok(Some(Follow::Segment(c)));
    }
    let j = joint(spec)?;
    let kids = sk.children(j);
    match (sk.parent(j), kids.len()) {
        (None, _) => Ok(Some(Follow::Root(j))),
        (Some(_), 1) => Ok(Some(Follow::Segment(kids[0]))),
        (Some(_), 0) => Err(format!(
            "{bone}={spec}: {spec} is the end of a bone, and a mapping names the joint the bone \
             turns at (its pivot): {bone}={}",
            Follow::Segment(j).spec(anim)
        )),
        (Some(_), _) => Err(format!(
            "{bone}={spec}: several bones turn at {spec} ({}); name one as {bone}={spec}>JOINT",
            children_text(anim, j)
        )),
    }
}

fn children_text(anim: &Animation, j: usize) -> String {
    let sk = &anim.skeleton;
    let kids: Vec<&str> = sk
        .children(j)
        .iter()
        .map(|&c| sk.names[c].as_str())
        .collect();
    if kids.is_empty() {
        "none".into()
    } else {
        format!("to {}", kids.join(", "))
    }
}

/// The side a name says: `Some(true)` left (`left`, `l`, `front`), `Some(false)` right
/// (`right`, `r`, `rear`, `back` when other words follow), `None` neither.
pub fn side(name: &str) -> Option<bool> {
    let words: Vec<String> = name
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .map(|w| w.to_ascii_lowercase())
        .collect();
    let many = words.len() > 1;
    for w in &words {
        match w.as_str() {
            "left" | "front" => return Some(true),
            "l" if many => return Some(true),
            "right" | "rear" => return Some(false),
            "r" | "back" if many => return Some(false),
            _ => {}
        }
    }
    None
}

/// A skeleton as a tree of bones, for [`structural`].
struct Tree<'a> {
    names: Vec<&'a str>,
    parent: Vec<Option<usize>>,
    length: Vec<f64>,
    base: Vec<[f64; 2]>,
    tip: Vec<[f64; 2]>,
    control: Vec<bool>,
    /// Girdle words in names mark a collarbone (the character's joint names only).
    girdle_names: bool,
}

/// The parts [`Tree::parts`] finds: each a chain of bones (indices), or none.
#[derive(Default)]
struct Parts {
    hip: Option<usize>,
    spine: Vec<usize>,
    head: Vec<usize>,
    /// `[left, right]` × `[arm, leg]`.
    limbs: [[Vec<usize>; 2]; 2],
}

impl Tree<'_> {
    fn children(&self, i: usize) -> Vec<usize> {
        (0..self.names.len())
            .filter(|&c| self.parent[c] == Some(i))
            .collect()
    }

    fn ancestors(&self, i: usize) -> Vec<usize> {
        let mut v = vec![i];
        while let Some(p) = self.parent[*v.last().expect("nonempty")] {
            v.push(p);
        }
        v
    }

    fn lca(&self, nodes: &[usize]) -> Option<usize> {
        let first = self.ancestors(*nodes.first()?);
        first
            .into_iter()
            .find(|a| nodes.iter().all(|&n| self.ancestors(n).contains(a)))
    }

    fn subtree_length(&self, i: usize) -> f64 {
        self.length[i]
            + self
                .children(i)
                .iter()
                .map(|&c| self.subtree_length(c))
                .sum::<f64>()
    }

    fn dir(&self, i: usize) -> [f64; 2] {
        let (d0, d1) = (
            self.tip[i][0] - self.base[i][0],
            self.tip[i][1] - self.base[i][1],
        );
        let l = d0.hypot(d1);
        if l > 1e-9 {
            [d0 / l, d1 / l]
        } else {
            [0.0, 0.0]
        }
    }

    /// A limb from its first bone: down the children of its side carrying the most length; bones
    /// without length and a collarbone at the start left out.
    fn limb(&self, root: usize, s: bool) -> Vec<usize> {
        let mut chain = vec![root];
        let mut cur = root;
        loop {
            let next = self
                .children(cur)
                .into_iter()
                .filter(|&c| !self.control[c] && side(self.names[c]) != Some(!s))
                .max_by(|&a, &b| self.subtree_length(a).total_cmp(&self.subtree_length(b)));
            match next {
                Some(c) => {
                    chain.push(c);
                    cur = c;
                }
                None => break,
            }
        }
        chain.retain(|&i| self.length[i] > 1e-6);
        if chain.len() >= 2 {
            let (a, b) = (chain[0], chain[1]);
            let d = self.dir(a);
            let named = self.girdle_names && {
                let n = self.names[a].to_ascii_lowercase();
                ["shoulder", "clavicle", "collar", "hip"]
                    .iter()
                    .any(|w| n.contains(w))
            };
            let short_sideways = self.length[a] < 0.8 * self.length[b] && d[0].abs() > d[1].abs();
            if named || short_sideways {
                chain.remove(0);
            }
        }
        chain
    }

    fn parts(&self) -> Parts {
        let n = self.names.len();
        let mut parts = Parts::default();
        // `[side][arm, leg]`: the limb's first bone, before bones without length and a
        // collarbone are set aside.
        let mut roots: [[Option<usize>; 2]; 2] = [[None; 2]; 2];
        // Limb roots of each side, highest first.
        for (k, s) in [true, false].into_iter().enumerate() {
            let mut found: Vec<usize> = (0..n)
                .filter(|&i| {
                    !self.control[i]
                        && side(self.names[i]) == Some(s)
                        && self.parent[i].is_some_and(|p| side(self.names[p]) != Some(s))
                })
                .filter(|&i| self.subtree_length(i) > 1e-6)
                .collect();
            found.sort_by(|&a, &b| self.base[b][1].total_cmp(&self.base[a][1]));
            if found.len() >= 2 {
                let (arm, leg) = (found[0], found[found.len() - 1]);
                roots[k] = [Some(arm), Some(leg)];
                parts.limbs[k][0] = self.limb(arm, s);
                parts.limbs[k][1] = self.limb(leg, s);
            }
        }
        let hangs_from = |k: usize| -> Vec<usize> {
            (0..2)
                .filter_map(|s| roots[s][k].and_then(|r| self.parent[r]))
                .collect()
        };
        parts.hip = self.lca(&hangs_from(1));
        let (Some(hip), Some(attach)) = (parts.hip, self.lca(&hangs_from(0))) else {
            return parts;
        };
        let path = self.ancestors(attach);
        if let Some(at) = path.iter().position(|&a| a == hip) {
            let mut spine: Vec<usize> = path[..at].to_vec();
            spine.reverse();
            spine.retain(|&i| self.length[i] > 1e-6);
            parts.spine = spine;
        }
        // The head: from where the arms hang, the child of no side that carries on the spine's
        // direction, and on.
        let mut dir = self.dir(attach);
        if dir == [0.0, 0.0] {
            dir = [0.0, 1.0];
        }
        let mut cur = attach;
        loop {
            let next = self
                .children(cur)
                .into_iter()
                .filter(|&c| !self.control[c] && side(self.names[c]).is_none())
                .filter(|&c| self.length[c] > 1e-6)
                .max_by(|&a, &b| {
                    let (da, db) = (self.dir(a), self.dir(b));
                    (da[0] * dir[0] + da[1] * dir[1]).total_cmp(&(db[0] * dir[0] + db[1] * dir[1]))
                });
            match next {
                Some(c) => {
                    parts.head.push(c);
                    dir = self.dir(c);
                    cur = c;
                }
                None => break,
            }
        }
        parts
    }

    /// How far apart left and right are, across the body: the mean horizontal distance between
    /// the two arms' and the two legs' first bones' origins, over the spine's height. `None`
    /// when a pair or the spine is missing.
    fn width(&self, parts: &Parts) -> Option<f64> {
        let (hip, top) = (parts.hip?, *parts.spine.last()?);
        let height = (self.tip[top][1] - self.base[hip][1]).abs();
        let mut spread = Vec::new();
        for limb in 0..2 {
            if let (Some(&l), Some(&r)) =
                (parts.limbs[0][limb].first(), parts.limbs[1][limb].first())
            {
                spread.push((self.base[l][0] - self.base[r][0]).abs());
            }
        }
        (height > 1e-6 && !spread.is_empty())
            .then(|| spread.iter().sum::<f64>() / spread.len() as f64 / height)
    }
}

/// What [`structural`] found.
pub struct Structure {
    /// `[their bone]`: what it follows, by structure.
    pub follows: Vec<Option<Follow>>,
    /// Their rig's width across the body over its spine's height, and the capture's (first
    /// frame); see the side-view check of [`super::spine_rig`].
    pub widths: Option<(f64, f64)>,
}

/// Their bones matched to the character by structure (see the module docs).
pub fn structural(bones: &[RigBone], anim: &Animation) -> Structure {
    let theirs = Tree {
        names: bones.iter().map(|b| b.name.as_str()).collect(),
        parent: bones.iter().map(|b| b.parent).collect(),
        length: bones.iter().map(|b| b.length).collect(),
        base: bones.iter().map(|b| b.base).collect(),
        tip: bones.iter().map(|b| b.tip).collect(),
        control: bones.iter().map(|b| b.control).collect(),
        girdle_names: false,
    };
    let sk = &anim.skeleton;
    let f0 = &anim.joints[0];
    let up = |j: usize| [f0[j][0], -f0[j][1]];
    let ours = Tree {
        names: sk.names.iter().map(String::as_str).collect(),
        parent: sk.parents.clone(),
        length: (0..sk.len())
            .map(|j| {
                sk.parent(j)
                    .map_or(0.0, |p| (f0[j][0] - f0[p][0]).hypot(f0[j][1] - f0[p][1]))
            })
            .collect(),
        base: (0..sk.len())
            .map(|j| up(sk.parent(j).unwrap_or(j)))
            .collect(),
        tip: (0..sk.len()).map(up).collect(),
        control: vec![false; sk.len()],
        girdle_names: true,
    };
    let (a, b) = (theirs.parts(), ours.parts());
    let mut follows = vec![None; bones.len()];
    let follow = |j: usize| match sk.parent(j) {
        None => Follow::Root(j),
        Some(_) => Follow::Segment(j),
    };
    if let (Some(h), Some(j)) = (a.hip, b.hip) {
        follows[h] = Some(follow(j));
    }
    if !b.spine.is_empty() {
        let (n, m) = (a.spine.len(), b.spine.len());
        for (i, &bone) in a.spine.iter().enumerate() {
            follows[bone] = Some(follow(b.spine[i * m / n]));
        }
    }
    let mut pair = |x: &[usize], y: &[usize]| {
        for (&bone, &j) in x.iter().zip(y) {
            follows[bone] = Some(follow(j));
        }
    };
    pair(&a.head, &b.head);
    for s in 0..2 {
        for limb in 0..2 {
            pair(&a.limbs[s][limb], &b.limbs[s][limb]);
        }
    }
    Structure {
        follows,
        widths: theirs.width(&a).zip(ours.width(&b)),
    }
}

#[cfg(test)]
#[path = "rig_map_tests.rs"]
mod tests;
