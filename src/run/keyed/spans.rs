//! Each joint's spans between its own keys (docs/method.md, "Motion between keys"): a key that
//! gives some joints only is no key for the others, whose paths run on from their key before it
//! to their key after it.

/// The spans to solve between a segment's anchors (the segment's first frame, its keys, and the
/// key its last span runs to), given which joints each anchor keys (`keyed[i][j]`; the first
/// anchor keys every joint): for each joint, from each anchor keying it to the next anchor that
/// does, and from the last one to the last anchor when that does not (a span followed from its
/// first key alone). Returns `(a, b, joints)`: the anchors' places in `keyed` and the joints
/// whose span that is, ordered by `a`, then `b`.
pub fn joint_spans(keyed: &[Vec<bool>]) -> Vec<(usize, usize, Vec<bool>)> {
    let Some(first) = keyed.first() else {
        return Vec::new();
    };
    let (n, joints) = (keyed.len(), first.len());
    let mut spans: Vec<(usize, usize, Vec<bool>)> = Vec::new();
    let mut add =
        |a: usize, b: usize, j: usize| match spans.iter_mut().find(|s| (s.0, s.1) == (a, b)) {
            Some(s) => s.2[j] = true,
            None => {
                let mut on = vec![false; joints];
                on[j] = true;
                spans.push((a, b, on));
            }
        };
    for j in 0..joints {
        let mut last = 0;
        for (i, k) in keyed.iter().enumerate().skip(1) {
            if k[j] {
                add(last, i, j);
                last = i;
            }
        }
        if last + 1 < n {
            add(last, n - 1, j);
        }
    }
    spans.sort_by_key(|s| (s.0, s.1));
    spans
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_joint_a_key_leaves_out_runs_from_its_key_before_to_its_key_after() {
        // Three joints; anchor 1 keys joint 0 only, anchor 2 every joint, anchor 3 joint 1 only.
        let keyed = vec![
            vec![true, true, true],
            vec![true, false, false],
            vec![true, true, true],
            vec![false, true, false],
        ];
        assert_eq!(
            joint_spans(&keyed),
            vec![
                (0, 1, vec![true, false, false]),
                (0, 2, vec![false, true, true]),
                (1, 2, vec![true, false, false]),
                (2, 3, vec![true, true, true]),
            ]
        );
        // Keys of every joint: the anchors in pairs, as before keys could leave joints out.
        let full = vec![vec![true; 2]; 3];
        assert_eq!(
            joint_spans(&full),
            vec![(0, 1, vec![true; 2]), (1, 2, vec![true; 2])]
        );
        assert!(joint_spans(&[]).is_empty());
        assert!(joint_spans(&[vec![true]]).is_empty());
    }
}
