//! Several bodies in one clip (two flies, two characters): one body never takes the place of
//! another. Bodies that look alike fool the colour cost: a hidden root coasting onto the other
//! character, or the whole-frame re-detection finding the look-alike, would put both skeletons
//! on one body and call both `ok`. A body that was hidden on the previous frame and would be seen
//! again on top of another body that is seen there stays hidden instead (its filters coast, the
//! re-detection goes on looking elsewhere), so the status tells the user where to look.

use super::Tracker;
use crate::geom::Point;

impl Tracker {
    /// Reach (px) of every root's body on the seed frame: the largest distance from the root to
    /// one of its joints (0 for other joints).
    pub(super) fn body_reach(parents: &[Option<usize>], seed_pos: &[Point]) -> Vec<f32> {
        let mut reach = vec![0.0f32; parents.len()];
        for j in 0..parents.len() {
            let mut r = j;
            while let Some(p) = parents[r] {
                r = p;
            }
            reach[r] = reach[r].max((seed_pos[j] - seed_pos[r]).norm());
        }
        reach
    }

    /// For every joint, the mean of `evidence` over the joints of its body (its root's tree): a
    /// joint is `ok` only where its body as a whole fits as well (docs/method.md §2.5). A lone
    /// limb that fits where the rest of its body is lost has most likely settled on something
    /// that looks like it, not on itself.
    pub(super) fn body_fit(parents: &[Option<usize>], evidence: &[f32]) -> Vec<f32> {
        let root = |mut j: usize| {
            while let Some(p) = parents[j] {
                j = p;
            }
            j
        };
        let roots: Vec<usize> = (0..parents.len()).map(root).collect();
        let (mut sum, mut count) = (vec![0.0f32; parents.len()], vec![0u32; parents.len()]);
        for (j, &r) in roots.iter().enumerate() {
            sum[r] += evidence[j];
            count[r] += 1;
        }
        roots.iter().map(|&r| sum[r] / count[r] as f32).collect()
    }

    /// Whether root `r` placed at `q` would sit on another body: within half the smaller body's
    /// reach of a root that was seen on the previous frame and is seen on this one (`evidence`).
    pub(super) fn on_another_body(
        &self,
        r: usize,
        q: Point,
        x: &[Point],
        evidence: &[f32],
    ) -> bool {
        (0..x.len()).any(|o| {
            o != r
                && self.parents[o].is_none()
                && self.joints[o].hidden_run == 0
                && evidence[o] >= self.params.seen_share
                && (x[o] - q).norm() < self.reach[r].min(self.reach[o])
        })
    }

    /// Keeps bodies apart (see the module doc): every joint of a body whose root was hidden on
    /// the previous frame and would be seen now on another body gets no evidence (and is not
    /// `found`).
    pub(super) fn keep_bodies_apart(&self, x: &[Point], evidence: &mut [f32], found: &mut [bool]) {
        for r in 0..x.len() {
            if self.parents[r].is_some()
                || self.joints[r].hidden_run == 0
                || evidence[r] < self.params.seen_share
                || !self.on_another_body(r, x[r], x, evidence)
            {
                continue;
            }
            for k in self.descendants_and_self(r) {
                evidence[k] = 0.0;
                found[k] = false;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_body_reaches_as_far_as_its_farthest_joint() {
        let parents = [None, Some(0), Some(1), None, Some(3)];
        let pos = [
            Point::new(0.0, 0.0),
            Point::new(3.0, 4.0),
            Point::new(6.0, 8.0),
            Point::new(100.0, 0.0),
            Point::new(100.0, 7.0),
        ];
        let reach = Tracker::body_reach(&parents, &pos);
        assert_eq!(reach, vec![10.0, 0.0, 0.0, 7.0, 0.0]);
    }

    #[test]
    fn a_body_fits_by_the_mean_over_its_own_joints() {
        // Two bodies: a lone forearm (joint 2) fitting on a body whose other joints are lost,
        // and a second body seen whole.
        let parents = [None, Some(0), Some(1), None, Some(3)];
        let evidence = [0.1, 0.2, 0.9, 0.8, 0.6];
        let fit = Tracker::body_fit(&parents, &evidence);
        for (j, want) in [0.4, 0.4, 0.4, 0.7, 0.7].into_iter().enumerate() {
            assert!((fit[j] - want).abs() < 1e-6, "{fit:?}");
        }
    }
}
