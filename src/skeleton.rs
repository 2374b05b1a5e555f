//! Joints and their parent links: the character's skeleton.
//!
//! A [`Skeleton`] holds joint names and parent links as indices, in seed-file order. A bone runs
//! from a parent to its child; a joint without a parent is a root, and several roots are allowed
//! (several characters, or loose joints). [`crate::seed`] builds skeletons from seed files and
//! rejects cycles, so a skeleton from there is always a forest.

/// Joint names and parent links, indexed in seed-file order.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Skeleton {
    /// Joint names, unique.
    pub names: Vec<String>,
    /// `parents[i]` is the index of joint `i`'s parent, `None` for a root.
    pub parents: Vec<Option<usize>>,
}

impl Skeleton {
    /// A skeleton from names and parent indices (same length, indices in range). It does not check
    /// for cycles: see [`Skeleton::find_cycle`].
    ///
    /// # Panics
    /// If the lengths differ or a parent index is out of range.
    pub fn new(names: Vec<String>, parents: Vec<Option<usize>>) -> Self {
        assert_eq!(names.len(), parents.len(), "one parent entry per joint");
        assert!(
            parents.iter().flatten().all(|&p| p < names.len()),
            "parent index out of range"
        );
        Skeleton { names, parents }
    }

    /// Number of joints.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// True when there are no joints.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// Index of the joint called `name`.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Parent of joint `i`, `None` for a root.
    pub fn parent(&self, i: usize) -> Option<usize> {
        self.parents[i]
    }

    /// Children of joint `i`, in seed-file order.
    pub fn children(&self, i: usize) -> Vec<usize> {
        (0..self.len())
            .filter(|&c| self.parents[c] == Some(i))
            .collect()
    }

    /// Joints without a parent, in seed-file order.
    pub fn roots(&self) -> Vec<usize> {
        (0..self.len())
            .filter(|&i| self.parents[i].is_none())
            .collect()
    }

    /// Bones as `(parent, child)` pairs, in the child's seed-file order.
    pub fn bones(&self) -> Vec<(usize, usize)> {
        (0..self.len())
            .filter_map(|c| self.parents[c].map(|p| (p, c)))
            .collect()
    }

    /// All joints with every parent before its children. Stable: whenever several joints are
    /// ready, the one earliest in the seed file comes first, so a file that already lists parents
    /// first comes back in file order. Joints on or below a cycle (see [`Skeleton::find_cycle`])
    /// are left out.
    pub fn topo_order(&self) -> Vec<usize> {
        let n = self.len();
        let mut done = vec![false; n];
        let mut order = Vec::with_capacity(n);
        // Ready joints, smallest index first: a min-heap over indices.
        let mut ready: std::collections::BinaryHeap<std::cmp::Reverse<usize>> =
            self.roots().into_iter().map(std::cmp::Reverse).collect();
        let children: Vec<Vec<usize>> = {
            let mut c = vec![Vec::new(); n];
            for (p, ch) in self.bones() {
                c[p].push(ch);
            }
            c
        };
        while let Some(std::cmp::Reverse(i)) = ready.pop() {
            if done[i] {
                continue;
            }
            done[i] = true;
            order.push(i);
            for &c in &children[i] {
                ready.push(std::cmp::Reverse(c));
            }
        }
        order
    }

    /// Joint `i` and everything below it, parents before children (stable as in
    /// [`Skeleton::topo_order`]).
    pub fn subtree(&self, i: usize) -> Vec<usize> {
        self.topo_order()
            .into_iter()
            .filter(|&j| self.is_ancestor_or_self(i, j))
            .collect()
    }

    /// True when `a` is `b` or one of `b`'s ancestors.
    pub fn is_ancestor_or_self(&self, a: usize, b: usize) -> bool {
        let mut cur = Some(b);
        let mut steps = 0;
        while let Some(j) = cur {
            if j == a {
                return true;
            }
            steps += 1;
            if steps > self.len() {
                return false; // a cycle above b
            }
            cur = self.parents[j];
        }
        false
    }

    /// Number of bones between joint `i` and its root (0 for a root).
    ///
    /// # Panics
    /// If `i` is on or below a cycle.
    pub fn depth(&self, i: usize) -> usize {
        let mut d = 0;
        let mut cur = i;
        while let Some(p) = self.parents[cur] {
            d += 1;
            assert!(d <= self.len(), "parent cycle above joint {i}");
            cur = p;
        }
        d
    }

    /// A parent cycle if there is one: joints in the order of their parent links, starting from
    /// the cycle's joint earliest in the seed file (`[a, b, c]` means a's parent is b, b's is c
    /// and c's is a). `None` when the skeleton is a forest.
    pub fn find_cycle(&self) -> Option<Vec<usize>> {
        // 0 = unvisited, 1 = on the current walk, 2 = known to reach a root.
        let n = self.len();
        let mut state = vec![0u8; n];
        for start in 0..n {
            if state[start] != 0 {
                continue;
            }
            let mut path = Vec::new();
            let mut cur = Some(start);
            while let Some(j) = cur {
                match state[j] {
                    2 => break,
                    1 => {
                        // Cannot fail: state 1 means `j` is on the current walk, i.e. in `path`.
                        let at = path.iter().position(|&p| p == j).expect("on the walk");
                        let mut cycle = path[at..].to_vec();
                        let first = (0..cycle.len()).min_by_key(|&k| cycle[k]).unwrap_or(0);
                        cycle.rotate_left(first);
                        return Some(cycle);
                    }
                    _ => {
                        state[j] = 1;
                        path.push(j);
                        cur = self.parents[j];
                    }
                }
            }
            for j in path {
                state[j] = 2;
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn skel(spec: &[(&str, Option<usize>)]) -> Skeleton {
        Skeleton::new(
            spec.iter().map(|(n, _)| n.to_string()).collect(),
            spec.iter().map(|(_, p)| *p).collect(),
        )
    }

    /// 0 hand -> 1 elbow -> 2 shoulder (root); 3 head -> 2; 4 tail (root).
    fn arm() -> Skeleton {
        skel(&[
            ("hand", Some(1)),
            ("elbow", Some(2)),
            ("shoulder", None),
            ("head", Some(2)),
            ("tail", None),
        ])
    }

    #[test]
    fn topo_order_puts_parents_first_then_file_order() {
        assert_eq!(arm().topo_order(), vec![2, 1, 0, 3, 4]);
    }

    #[test]
    fn topo_order_of_parent_first_file_is_file_order() {
        let s = skel(&[("a", None), ("b", Some(0)), ("c", Some(1)), ("d", Some(0))]);
        assert_eq!(s.topo_order(), vec![0, 1, 2, 3]);
    }

    #[test]
    fn children_roots_and_bones_follow_file_order() {
        let s = arm();
        assert_eq!(s.children(2), vec![1, 3]);
        assert_eq!(s.children(0), Vec::<usize>::new());
        assert_eq!(s.roots(), vec![2, 4]);
        assert_eq!(s.bones(), vec![(1, 0), (2, 1), (2, 3)]);
        assert_eq!(s.index_of("head"), Some(3));
        assert_eq!(s.index_of("knee"), None);
        assert_eq!(s.len(), 5);
        assert!(!s.is_empty());
        assert!(Skeleton::default().is_empty());
    }

    #[test]
    fn depth_and_subtree() {
        let s = arm();
        assert_eq!(s.depth(0), 2);
        assert_eq!(s.depth(4), 0);
        assert_eq!(s.subtree(2), vec![2, 1, 0, 3]);
        assert_eq!(s.subtree(1), vec![1, 0]);
        assert!(s.is_ancestor_or_self(2, 0));
        assert!(!s.is_ancestor_or_self(0, 2));
    }

    #[test]
    fn forest_has_no_cycle() {
        assert_eq!(arm().find_cycle(), None);
    }

    #[test]
    fn cycle_is_reported_from_its_earliest_joint() {
        // 0 root; 1 -> 3 -> 2 -> 1 is a cycle; 4 hangs below it.
        let s = skel(&[
            ("root", None),
            ("a", Some(3)),
            ("b", Some(1)),
            ("c", Some(2)),
            ("d", Some(2)),
        ]);
        assert_eq!(s.find_cycle(), Some(vec![1, 3, 2]));
        // Joints on or below the cycle never become ready.
        assert_eq!(s.topo_order(), vec![0]);
    }

    #[test]
    fn self_parent_is_a_cycle_of_one() {
        let s = skel(&[("a", Some(0))]);
        assert_eq!(s.find_cycle(), Some(vec![0]));
    }
}
