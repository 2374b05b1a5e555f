//! The skeleton the tracker follows: the user's, each body re-rooted at its centre, so that
//! tracking does not depend on which joint the user made the root (docs/method.md §2). The
//! `angle` column stays the user's: each joint's angle is that of the bone it shares with its
//! user parent, which the tracker follows one way or the other (see [`AngleOf`]).

use crate::skeleton::Skeleton;
use std::collections::VecDeque;

/// Whose tracked angle gives a joint's angle in the user's skeleton.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AngleOf {
    /// The tracker's angle of this joint (the index): its bone is the user's bone, or that
    /// bone reversed (the angle from the seed direction is the same either way).
    Joint(usize),
    /// Always 0: a user root whose angle does not turn.
    Zero,
}

/// `sk` with each body (a connected set of joints) re-rooted at its centre: the joint whose
/// farthest joint is nearest, in bones (ties: the earliest in seed-file order).
pub fn centred(sk: &Skeleton) -> Skeleton {
    let n = sk.len();
    let mut adj = vec![Vec::new(); n];
    for (j, p) in sk.parents.iter().enumerate() {
        if let Some(p) = *p {
            adj[j].push(p);
            adj[p].push(j);
        }
    }
    for a in &mut adj {
        a.sort_unstable();
    }
    let hops = |from: usize| -> Vec<usize> {
        let mut d = vec![usize::MAX; n];
        d[from] = 0;
        let mut q = VecDeque::from([from]);
        while let Some(u) = q.pop_front() {
            for &v in &adj[u] {
                if d[v] == usize::MAX {
                    d[v] = d[u] + 1;
                    q.push_back(v);
                }
            }
        }
        d
    };
    let mut parents = vec![None; n];
    let mut done = vec![false; n];
    for start in 0..n {
        if done[start] {
            continue;
        }
        let body: Vec<usize> = {
            let d = hops(start);
            (0..n).filter(|&j| d[j] != usize::MAX).collect()
        };
        let centre = *body
            .iter()
            .min_by_key(|&&j| {
                let d = hops(j);
                (body.iter().map(|&k| d[k]).max().unwrap_or(0), j)
            })
            .expect("a body has a joint");
        // Parents along the bones, away from the centre.
        let mut q = VecDeque::from([centre]);
        done[centre] = true;
        while let Some(u) = q.pop_front() {
            for &v in &adj[u] {
                if !done[v] {
                    done[v] = true;
                    parents[v] = Some(u);
                    q.push_back(v);
                }
            }
        }
    }
    Skeleton {
        names: sk.names.clone(),
        parents,
    }
}

/// For each joint of the user's skeleton `user`, whose angle in the tracker following `inner`
/// (the same bodies, other roots) gives its angle: a user root turns with the bone to its first
/// child when `rotate_roots`, else not at all.
pub fn angle_of(user: &Skeleton, inner: &Skeleton, rotate_roots: bool) -> Vec<AngleOf> {
    // The tracker's angle of the bone between a and b (neighbours).
    let bone = |a: usize, b: usize| {
        if inner.parents[b] == Some(a) {
            AngleOf::Joint(b)
        } else {
            debug_assert_eq!(inner.parents[a], Some(b));
            AngleOf::Joint(a)
        }
    };
    (0..user.len())
        .map(|j| match user.parents[j] {
            Some(p) => bone(p, j),
            None if rotate_roots => user
                .children(j)
                .first()
                .map_or(AngleOf::Zero, |&c| bone(j, c)),
            None => AngleOf::Zero,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain() -> Skeleton {
        // wrist(0) <- elbow(1) <- shoulder(2) <- hip(3) -> knee(4) -> ankle(5), rooted at the
        // wrist as a label file might be.
        Skeleton {
            names: ["wrist", "elbow", "shoulder", "hip", "knee", "ankle"]
                .map(String::from)
                .to_vec(),
            parents: vec![None, Some(0), Some(1), Some(2), Some(3), Some(4)],
        }
    }

    #[test]
    fn any_root_gives_the_same_centred_skeleton() {
        let a = chain();
        let c = centred(&a);
        // A path of six: the centre is the third joint (the earlier of the two middles).
        assert_eq!(c.parents[2], None);
        let mut b = chain();
        b.parents = vec![Some(1), Some(2), Some(3), None, Some(3), Some(4)];
        assert_eq!(centred(&b).parents, c.parents);
    }

    #[test]
    fn a_reversed_bone_gives_its_angle_through_the_other_joint() {
        let user = chain();
        let inner = centred(&user);
        let of = angle_of(&user, &inner, true);
        // elbow's user bone (wrist -> elbow) is followed as elbow -> wrist: the wrist's angle.
        assert_eq!(of[1], AngleOf::Joint(0));
        // knee's bone (hip -> knee) is followed the same way: its own.
        assert_eq!(of[4], AngleOf::Joint(4));
        // The user root (wrist) turns with its bone to the elbow: the wrist's angle.
        assert_eq!(of[0], AngleOf::Joint(0));
        assert_eq!(angle_of(&user, &inner, false)[0], AngleOf::Zero);
    }
}
