//! Blending passes over one segment between two keyframes (forward from the first, backward
//! from the second, each with the appearance built on its keyframe and with the appearance of
//! the seed frame), joint by joint and frame by frame.
//!
//! A pass's weight for a joint on a frame is its score (a tenth of it while the joint is not
//! seen). Passes that started from different keyframes or appearances and still land within
//! [`AGREE_PX`] of each other are strong evidence, so each candidate's support is its weight
//! plus the weights of the other passes that agree with it; the best supported candidate wins
//! (the more confident of equally supported ones), averaged (by weight) with the passes that
//! agree with it. A lone pass that disagrees is
//! taken whole, never averaged with the others (halfway between a right and a wrong place is
//! wrong).
//!
//! When the winner is only `low` and no other pass agrees with it, while another pass also
//! says it saw the joint (somewhere else), neither is trusted: the joint is marked `occluded`
//! on that frame, so that the segment's gap filling interpolates over it from the frames around
//! (passes that start from two corrections and see a joint in two places on the same frame
//! mostly mean that it is covered and one of them took another limb for it). A lone `low`
//! winner that the other passes did not see at all stands: a `low` measurement is right more
//! often than the interpolation. A lone `ok` winner in the same dispute keeps its place but is
//! only `low`: `ok` should mean the passes agree. The measurements behind these rules are in
//! docs/NOTES.md ("Blending passes").

use crate::run::segments::turns_near;
use crate::track::{JointEstimate, Status};

/// Passes closer than this (px) agree: two passes that started from different keyframes and
/// land a few pixels apart have mostly found the same limb, each a little off; the disputed
/// rule above is for passes that found different ones.
pub const AGREE_PX: f32 = 8.0;

/// A pass's weight for an estimate.
fn weight(e: &JointEstimate) -> f32 {
    let w = if e.status.seen() {
        e.score
    } else {
        0.1 * e.score
    };
    w + 1e-6
}

/// Blends `passes` (each: the estimates of the same frames, in time order) into one estimate
/// per frame and joint. Score and status are those of the winning candidate. A winner "`ok`"
/// in the rules above is one whose own strips fit as an `ok` joint's do
/// ([`JointEstimate::fits_alone`] at `ok_share`), whether or not its body fits as well.
pub fn blend(passes: &[Vec<Vec<JointEstimate>>], ok_share: f32) -> Vec<Vec<JointEstimate>> {
    let n = passes.first().map_or(0, Vec::len);
    assert!(
        passes.iter().all(|p| p.len() == n),
        "every pass covers the same frames"
    );
    (0..n)
        .map(|i| {
            let joints = passes[0][i].len();
            (0..joints)
                .map(|j| {
                    let c: Vec<&JointEstimate> = passes.iter().map(|p| &p[i][j]).collect();
                    let w: Vec<f32> = c.iter().map(|e| weight(e)).collect();
                    let agree = |a: usize, b: usize| (c[a].pos - c[b].pos).norm() <= AGREE_PX;
                    let support = |a: usize| -> f32 {
                        (0..c.len())
                            .filter(|&b| agree(a, b))
                            .map(|b| w[b])
                            .sum::<f32>()
                    };
                    let best = (0..c.len())
                        .max_by(|&a, &b| {
                            support(a)
                                .total_cmp(&support(b))
                                .then(w[a].total_cmp(&w[b]))
                                .then(b.cmp(&a))
                        })
                        .expect("at least one pass");
                    let (mut pos, mut angle, mut total) = (c[best].pos.coords * 0.0, 0.0, 0.0);
                    let mut backers = 0;
                    for b in (0..c.len()).filter(|&b| agree(best, b)) {
                        pos += c[b].pos.coords * w[b];
                        angle += turns_near(c[best].angle_rad, c[b].angle_rad) * w[b];
                        total += w[b];
                        backers += 1;
                    }
                    // `best` agrees with itself: alone when no other pass backs it.
                    let alone = backers == 1;
                    let seen = c.iter().filter(|e| e.status.seen()).count();
                    let disputed = alone && seen >= 2 && !c[best].fits_alone(ok_share);
                    JointEstimate {
                        pos: (pos / total).into(),
                        angle_rad: angle / total,
                        status: if disputed {
                            Status::Occluded
                        } else if alone && seen >= 2 {
                            // An `ok` no other pass backs while another saw the joint elsewhere:
                            // one of them took another limb for it, so it is worth a look.
                            Status::Low
                        } else {
                            c[best].status
                        },
                        ..*c[best]
                    }
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Point;

    fn e(x: f32, score: f32, status: Status) -> Vec<JointEstimate> {
        vec![JointEstimate {
            pos: Point::new(x, 0.0),
            angle_rad: 0.0,
            score,
            status,
        }]
    }

    #[test]
    fn a_lone_ok_winner_against_a_pass_that_saw_the_joint_elsewhere_is_low() {
        // Two passes see the joint 30 px apart, neither backed: the more confident wins, `low`.
        let out = blend(
            &[
                vec![e(0.0, 0.9, Status::Ok)],
                vec![e(30.0, 0.6, Status::Ok)],
            ],
            0.6,
        );
        assert_eq!(out[0][0].pos.x, 0.0);
        assert_eq!(out[0][0].status, Status::Low);
        // Backed by a second pass, it stays `ok`.
        let out = blend(
            &[
                vec![e(0.0, 0.9, Status::Ok)],
                vec![e(1.0, 0.6, Status::Ok)],
                vec![e(30.0, 0.6, Status::Ok)],
            ],
            0.6,
        );
        assert_eq!(out[0][0].status, Status::Ok);
    }

    #[test]
    fn agreeing_passes_average_by_score() {
        // 2 px apart; scores 0.75 and 0.25: a quarter of the way to the second pass.
        let out = blend(
            &[
                vec![e(0.0, 0.75, Status::Ok)],
                vec![e(2.0, 0.25, Status::Low)],
            ],
            0.6,
        );
        assert!((out[0][0].pos.x - 0.5).abs() < 1e-4, "{:?}", out[0][0].pos);
        assert_eq!(out[0][0].status, Status::Ok);
    }

    #[test]
    fn two_agreeing_passes_outvote_a_more_confident_one() {
        let p = |x: f32, score: f32| vec![e(x, score, Status::Ok)];
        let out = blend(&[p(0.0, 0.9), p(20.0, 0.6), p(21.0, 0.6)], 0.6);
        // Support: 0.9 for the lone pass, 1.2 for each of the pair.
        assert!((out[0][0].pos.x - 20.5).abs() < 1e-4, "{:?}", out[0][0].pos);
    }

    #[test]
    fn passes_a_few_pixels_apart_back_each_other() {
        // 5 px apart (the same limb found twice, each a little off) against a lone pass 20 px
        // away that is more confident than either: the pair wins, averaged by score.
        let out = blend(
            &[
                vec![e(0.0, 0.6, Status::Ok)],
                vec![e(5.0, 0.5, Status::Low)],
                vec![e(20.0, 0.9, Status::Ok)],
            ],
            0.6,
        );
        assert!(
            (out[0][0].pos.x - 2.5 / 1.1).abs() < 1e-4,
            "{:?}",
            out[0][0].pos
        );
        assert_eq!(out[0][0].status, Status::Ok);
    }

    #[test]
    fn two_passes_that_see_a_joint_apart_leave_it_to_the_filling() {
        // Both see it, 20 px apart, the better one only `low`: neither is trusted.
        let out = blend(
            &[
                vec![e(0.0, 0.5, Status::Low)],
                vec![e(20.0, 0.4, Status::Low)],
                vec![e(40.0, 0.9, Status::Occluded)],
            ],
            0.6,
        );
        assert_eq!(out[0][0].status, Status::Occluded);
        assert_eq!(
            out[0][0].pos.x, 0.0,
            "the position is the winner's until filled"
        );
        // An `ok` winner keeps its place, only `low` (see below); a `low` one that only hidden
        // passes dispute stands.
        let ok = blend(
            &[
                vec![e(0.0, 0.8, Status::Ok)],
                vec![e(20.0, 0.4, Status::Low)],
            ],
            0.6,
        );
        assert_eq!((ok[0][0].pos.x, ok[0][0].status), (0.0, Status::Low));
        let lone = blend(
            &[
                vec![e(0.0, 0.5, Status::Low)],
                vec![e(20.0, 0.9, Status::Occluded)],
            ],
            0.6,
        );
        assert_eq!(lone[0][0].status, Status::Low);
    }

    #[test]
    fn a_lost_pass_gives_way_to_a_seen_one() {
        // Forward loses the joint from frame 2 on; backward sees it throughout, 20 px away.
        let f = vec![
            e(0.0, 1.0, Status::Ok),
            e(0.0, 0.9, Status::Occluded),
            e(0.0, 0.9, Status::Lost),
            e(0.0, 0.9, Status::Lost),
        ];
        let b = vec![e(20.0, 0.9, Status::Ok); 4];
        let out = blend(&[f, b], 0.6);
        assert_eq!(out[0][0].pos.x, 0.0, "seen with a higher score");
        for o in &out[1..] {
            assert_eq!(o[0].pos.x, 20.0);
            assert_eq!(o[0].status, Status::Ok);
        }
    }
}
