//! Blending a forward and a backward pass over one segment (between two keyframes), joint by
//! joint and frame by frame, by confidence.
//!
//! A pass's confidence in a joint on a frame is its score (a tenth of it while the joint is not
//! seen). Where the passes agree within [`AGREE_PX`] the positions are averaged by confidence;
//! where they do not, the more confident pass is taken (averaging a right and a wrong place
//! gives a wrong place).
//!
//! Measured on the synth `long` clip (900 frames, ground-truth keyframes every 150): this
//! blend gives PCK@5 89.5 % over the frames between keyframes, against 91.4 % for an oracle
//! picking the better pass every time; weighting by nearness to each pass's keyframe (87.4 %)
//! or by a running confidence that stays down after a doubtful frame (86–89 %) did worse.

use crate::track::JointEstimate;

/// Passes closer than this (px) are averaged; further apart, one is chosen.
pub const AGREE_PX: f32 = 3.0;

/// A pass's confidence in an estimate.
fn confidence(e: &JointEstimate) -> f32 {
    let c = if e.status.seen() {
        e.score
    } else {
        0.1 * e.score
    };
    c + 1e-6
}

/// Blends `fwd` (estimates of the frames between two keyframes, in time order, tracked forward
/// from the first keyframe) with `bwd` (the same frames, in time order, tracked backward from
/// the second). Score and status are those of the more confident pass.
pub fn blend(fwd: &[Vec<JointEstimate>], bwd: &[Vec<JointEstimate>]) -> Vec<Vec<JointEstimate>> {
    assert_eq!(fwd.len(), bwd.len(), "both passes cover the same frames");
    fwd.iter()
        .zip(bwd)
        .map(|(fa, fb)| {
            fa.iter()
                .zip(fb)
                .map(|(a, b)| {
                    let (wa, wb) = (confidence(a), confidence(b));
                    let best = if wa >= wb { a } else { b };
                    if (a.pos - b.pos).norm() <= AGREE_PX {
                        let t = wb / (wa + wb);
                        JointEstimate {
                            pos: a.pos + (b.pos - a.pos) * t,
                            angle_rad: a.angle_rad + (b.angle_rad - a.angle_rad) * t,
                            ..*best
                        }
                    } else {
                        *best
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
    use crate::track::Status;

    fn e(x: f32, score: f32, status: Status) -> Vec<JointEstimate> {
        vec![JointEstimate {
            pos: Point::new(x, 0.0),
            angle_rad: 0.0,
            score,
            status,
        }]
    }

    #[test]
    fn agreeing_passes_average_by_score() {
        // 2 px apart; scores 0.75 and 0.25: a quarter of the way to the backward pass.
        let out = blend(&[e(0.0, 0.75, Status::Ok)], &[e(2.0, 0.25, Status::Low)]);
        assert!((out[0][0].pos.x - 0.5).abs() < 1e-4, "{:?}", out[0][0].pos);
        assert_eq!(out[0][0].status, Status::Ok);
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
        let out = blend(&f, &b);
        assert_eq!(out[0][0].pos.x, 0.0, "seen with a higher score");
        for o in &out[1..] {
            assert_eq!(o[0].pos.x, 20.0);
            assert_eq!(o[0].status, Status::Ok);
        }
    }
}
