//! The pose cue fused with the tracker's rows and the user's keys (docs/method.md §2.8).
//!
//! Each joint the network gives is estimated along the whole clip, on each axis, by a Kalman
//! filter and Rauch–Tung–Striebel smoother whose state is the joint's position, its velocity
//! and the network's bias for that joint (the offset between where the network puts the joint
//! and where the user means it). Three measurements enter:
//! - the network's landmark, `z = x + b`, its noise growing as its visibility falls;
//! - the tracker's position where it saw the joint, `z = x`, weak;
//! - a key (the seed frame, a corrected segment file, a key of `keys.toml`), `z = x`, all but
//!   exact.
//!
//! Keys so pin the path on their frame and, through the bias, pull the frames around them. A
//! left/right swap of the network's sides is settled by the keys: on each frame the network's
//! sides are read as the nearest key in time reads them.

use crate::error::Result;
use crate::geom::Point;
use crate::pose::blazepose::Landmark;
use crate::pose::names;
use crate::pose::{ClipLandmarks, LOOK_EVERY};
use crate::run::tracks::{read_tracks, TrackRow, HEADER};
use crate::track::Status;
use nalgebra::{Matrix3, Vector3};
use std::io::Write;
use std::path::Path;

/// The network's noise at full visibility, as a share of the torso's length.
const NET_SIGMA: f32 = 0.05;
/// The tracker's noise where it saw the joint, as a share of the torso's length.
const TRACK_SIGMA: f32 = 0.25;
/// A key's noise (px).
const KEY_SIGMA: f32 = 0.5;
/// Acceleration noise (share of the torso a frame²).
const ACCEL_SIGMA: f32 = 0.05;
/// The bias's spread (share of the torso) and how many frames a key's correction of it lasts:
/// away from keys it returns to zero (a first-order Gauss–Markov process).
const BIAS_SPREAD: f32 = 0.1;
const BIAS_FRAMES: f32 = 20.0;
/// Visibility below which the network is unsure of a point.
const SURE: f32 = 0.5;
/// Tracker and fused position agree within this share of the torso.
const AGREE: f32 = 0.15;

/// The frames of `rows` by frame, each with the joints of `names` in order.
fn by_frame(rows: &[TrackRow], names: &[String]) -> Vec<Vec<TrackRow>> {
    let mut out: Vec<Vec<TrackRow>> = Vec::new();
    for chunk in rows.chunks(names.len().max(1)) {
        out.push(chunk.to_vec());
    }
    out
}

/// The torso's median length over the clip (shoulder centre to hip centre, px), if the network
/// saw it.
fn torso(lms: &ClipLandmarks) -> Option<f32> {
    let mut v: Vec<f32> = lms
        .iter()
        .flatten()
        .map(|p| crate::pose::torso(p))
        .filter(|d| d.is_finite() && *d > 1.0)
        .collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f32::total_cmp);
    Some(v[v.len() / 2])
}

/// Whether the network's sides are crossed against the keys on a keyed frame: the pairs of
/// keyed left and right joints sit closer to the network's other side. `None` without such
/// a pair.
fn crossed(frame: &[TrackRow], map: &[Option<usize>], lm: &[Landmark]) -> Option<bool> {
    let (mut straight, mut cross, mut pairs) = (0f32, 0f32, 0);
    for (j, row) in frame.iter().enumerate() {
        let Some(l) = map[j] else { continue };
        let m = names::mirror(l);
        if m == l || row.status != Status::Seed.as_str() {
            continue;
        }
        let key = Point::new(row.x, row.y);
        straight += (lm[l].pos - key).norm();
        cross += (lm[m].pos - key).norm();
        pairs += 1;
    }
    (pairs > 0).then_some(cross < straight)
}

/// Fuses the run's `tracks.csv` with the network's landmarks `lms` (one entry a frame) and
/// rewrites it. The joints of `names` the network does not give are left as tracked.
pub fn apply(run_dir: &Path, names_: &[String], lms: &ClipLandmarks) -> Result<()> {
    let path = run_dir.join("tracks.csv");
    let rows = read_tracks(&path)?;
    let mut frames = by_frame(&rows, names_);
    fuse(&mut frames, names_, lms);
    crate::atomic::write_with(&path, |w| {
        writeln!(w, "{HEADER}")?;
        for f in &frames {
            for r in f {
                writeln!(
                    w,
                    "{},{},{:.3},{:.3},{:.4},{:.3},{}",
                    r.frame, r.joint, r.x, r.y, r.angle, r.score, r.status
                )?;
            }
        }
        Ok(())
    })
}

/// [`apply`] on rows in memory.
pub fn fuse(frames: &mut [Vec<TrackRow>], names_: &[String], lms: &ClipLandmarks) {
    let map: Vec<Option<usize>> = names_.iter().map(|n| names::landmark_of(n)).collect();
    let Some(torso) = torso(lms) else { return };
    let n = frames.len();
    // The network's landmarks of each row frame.
    let at: Vec<Option<&Vec<Landmark>>> = frames
        .iter()
        .map(|f| lms.get(f.first()?.frame as usize)?.as_ref())
        .collect();
    let lm_at = |f: usize| at[f];
    let near = nearest_looks(&at);
    // The sides, as the nearest keyed frame reads them (through the network's nearest look).
    let keyed: Vec<(usize, bool)> = (0..n)
        .filter_map(|f| Some((f, crossed(&frames[f], &map, lm_at(near[f]?)?)?)))
        .collect();
    let swap: Vec<bool> = (0..n)
        .map(|f| {
            let i = keyed.partition_point(|&(k, _)| k < f);
            let after = keyed.get(i);
            let before = i.checked_sub(1).and_then(|i| keyed.get(i));
            match (before, after) {
                (Some(b), Some(a)) => {
                    if f - b.0 <= a.0 - f {
                        b.1
                    } else {
                        a.1
                    }
                }
                (Some(x), None) | (None, Some(x)) => x.1,
                (None, None) => false,
            }
        })
        .collect();
    for (j, l) in map.iter().enumerate() {
        let Some(l) = *l else { continue };
        let mut meas: Vec<Measurements> = Vec::with_capacity(n);
        for f in 0..n {
            let row = &frames[f][j];
            let status = Status::from_word(&row.status).unwrap_or(Status::Lost);
            let side = |p: &Vec<Landmark>| p[if swap[f] { names::mirror(l) } else { l }];
            meas.push(Measurements {
                key: (status == Status::Seed).then(|| Point::new(row.x, row.y)),
                tracker: (status.seen() && status != Status::Seed)
                    .then(|| Point::new(row.x, row.y)),
                net: lm_at(f).map(side),
                near: near[f].and_then(lm_at).map(side),
            });
        }
        let fused = smooth(&meas, torso);
        for f in 0..n {
            let m = &meas[f];
            let row = &mut frames[f][j];
            if m.key.is_some() {
                continue;
            }
            let Some(p) = fused[f] else { continue };
            let vis = m.near.map_or(0.0, |l| l.visibility);
            let agree = m
                .tracker
                .map(|t| (t - p).norm() <= AGREE * torso)
                .unwrap_or(false);
            let status = match (m.near.is_some() && vis >= SURE, agree) {
                (true, true) => Status::Ok,
                (true, false) | (false, true) => Status::Low,
                (false, false) => Status::Occluded,
            };
            row.x = p.x;
            row.y = p.y;
            row.score = if m.near.is_some() {
                vis
            } else {
                row.score.min(0.5)
            };
            row.status = status.as_str().to_string();
        }
    }
}

/// What is known of one joint on one frame.
struct Measurements {
    key: Option<Point>,
    tracker: Option<Point>,
    /// The network's landmark on this frame.
    net: Option<Landmark>,
    /// The network's landmark on this frame or, between two of its looks that saw the person,
    /// on the nearer of them (for the side and the visibility).
    near: Option<Landmark>,
}

/// For each frame, the frame whose landmarks stand for it: itself where the network saw the
/// person; where it did not look, or looked and saw no one, and looks that saw the person lie
/// on both sides fewer than [`LOOK_EVERY`] frames away (or before it, where the clip ends
/// before the next look was due), the nearer of them (the earlier on a tie); else `None`.
fn nearest_looks(at: &[Option<&Vec<Landmark>>]) -> Vec<Option<usize>> {
    let n = at.len();
    (0..n)
        .map(|f| {
            if at[f].is_some() {
                return Some(f);
            }
            let before = (f.saturating_sub(LOOK_EVERY - 1)..f)
                .rev()
                .find(|&g| at[g].is_some())?;
            let after = (f + 1..n.min(f + LOOK_EVERY)).find(|&g| at[g].is_some());
            match after {
                Some(a) if a - f < f - before => Some(a),
                Some(_) => Some(before),
                // The clip ends before the next look was due.
                None => (f + LOOK_EVERY > n).then_some(before),
            }
        })
        .collect()
}

/// The smoothed positions of a joint (see the module's notes), `None` before its first
/// measurement.
fn smooth(meas: &[Measurements], torso: f32) -> Vec<Option<Point>> {
    let n = meas.len();
    let mut out = vec![None; n];
    let Some(first) = meas
        .iter()
        .position(|m| m.key.is_some() || m.net.is_some() || m.tracker.is_some())
    else {
        return out;
    };
    let decay = (-1.0 / BIAS_FRAMES).exp();
    let f_ = Matrix3::new(1.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, decay);
    let qa = (ACCEL_SIGMA * torso).powi(2);
    let qb = (BIAS_SPREAD * torso).powi(2) * (1.0 - decay * decay);
    let q = Matrix3::new(qa / 4.0, qa / 2.0, 0.0, qa / 2.0, qa, 0.0, 0.0, 0.0, qb);
    for axis in 0..2 {
        let get = |p: Point| p[axis];
        let mut xs = vec![Vector3::zeros(); n];
        let mut ps = vec![Matrix3::zeros(); n];
        let mut xp = vec![Vector3::zeros(); n];
        let mut pp = vec![Matrix3::zeros(); n];
        let m0 = &meas[first];
        let start = m0
            .key
            .or(m0.net.map(|l| l.pos))
            .or(m0.tracker)
            .map(get)
            .unwrap_or(0.0);
        let mut x = Vector3::new(start, 0.0, 0.0);
        let big = (10.0 * torso).powi(2);
        let mut p = Matrix3::from_diagonal(&Vector3::new(big, big, (BIAS_SPREAD * torso).powi(2)));
        for t in first..n {
            if t > first {
                x = f_ * x;
                p = f_ * p * f_.transpose() + q;
            }
            xp[t] = x;
            pp[t] = p;
            let m = &meas[t];
            let mut update = |h: Vector3<f32>, z: f32, r: f32| {
                let s = (h.transpose() * p * h)[0] + r;
                let k = p * h / s;
                x += k * (z - (h.transpose() * x)[0]);
                p -= k * h.transpose() * p;
            };
            if let Some(l) = m.net {
                let vis = l.visibility.clamp(0.05, 1.0);
                let r = (NET_SIGMA * torso / vis).powi(2);
                update(Vector3::new(1.0, 0.0, 1.0), get(l.pos), r);
            }
            // The tracker carries the frames where the network sees no one (not those between
            // two of its looks that saw the person).
            if let (Some(tp), None) = (m.tracker, m.near) {
                update(
                    Vector3::new(1.0, 0.0, 0.0),
                    get(tp),
                    (TRACK_SIGMA * torso).powi(2),
                );
            }
            if let Some(kp) = m.key {
                update(Vector3::new(1.0, 0.0, 0.0), get(kp), KEY_SIGMA * KEY_SIGMA);
            }
            xs[t] = x;
            ps[t] = p;
        }
        for t in (first..n.saturating_sub(1)).rev() {
            let Some(inv) = pp[t + 1].try_inverse() else {
                continue;
            };
            let c = ps[t] * f_.transpose() * inv;
            let (xn, pn) = (xs[t + 1], ps[t + 1]);
            xs[t] += c * (xn - xp[t + 1]);
            ps[t] += c * (pn - pp[t + 1]) * c.transpose();
        }
        for t in first..n {
            let v = xs[t][0];
            let prev = out[t].unwrap_or(Point::origin());
            let mut q = prev;
            q[axis] = v;
            out[t] = Some(q);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(frame: u64, joint: &str, p: Point, status: Status) -> TrackRow {
        TrackRow {
            frame,
            joint: joint.to_string(),
            x: p.x,
            y: p.y,
            angle: 0.0,
            score: 1.0,
            status: status.as_str().to_string(),
        }
    }

    /// A body standing still whose network readings of the left wrist sit 12 px right of the
    /// truth, the tracker wrong by 40 px, and keys (the true place) on frames 0 and `key`.
    fn still_body(n: usize, key: usize) -> (Vec<Vec<TrackRow>>, Vec<String>, ClipLandmarks, Point) {
        let truth = Point::new(100.0, 300.0);
        let names_: Vec<String> = vec!["left_hip".into(), "left_wrist".into()];
        let mut lms = ClipLandmarks::new();
        let mut frames = Vec::new();
        for f in 0..n {
            let mut pts = vec![
                Landmark {
                    pos: Point::new(0.0, 0.0),
                    visibility: 1.0,
                    presence: 1.0
                };
                33
            ];
            // Shoulders 200 px above the hips: a torso of 200 px.
            for (i, p) in [
                (11, (90.0, 200.0)),
                (12, (50.0, 200.0)),
                (23, (90.0, 400.0)),
                (24, (50.0, 400.0)),
            ] {
                pts[i].pos = Point::new(p.0, p.1);
            }
            pts[15].pos = truth + crate::geom::Vector::new(12.0, 0.0);
            pts[16].pos = Point::new(40.0, 300.0);
            lms.push(Some(pts));
            let keyed = f == 0 || f == key;
            let hip = if keyed { Status::Seed } else { Status::Ok };
            frames.push(vec![
                row(f as u64, "left_hip", Point::new(90.0, 400.0), hip),
                if keyed {
                    row(f as u64, "left_wrist", truth, Status::Seed)
                } else {
                    row(
                        f as u64,
                        "left_wrist",
                        truth + crate::geom::Vector::new(-40.0, 0.0),
                        Status::Ok,
                    )
                },
            ]);
        }
        (frames, names_, lms, truth)
    }

    #[test]
    fn a_key_beats_the_network_on_its_frame_and_pulls_the_frames_around_it() {
        let (mut frames, names_, lms, truth) = still_body(120, 60);
        fuse(&mut frames, &names_, &lms);
        let err = |f: usize| (Point::new(frames[f][1].x, frames[f][1].y) - truth).norm();
        // On the key: the key.
        assert!(err(60) < 0.01, "{}", err(60));
        assert_eq!(frames[60][1].status, "seed");
        // Beside it: pulled from the network's 12 px toward the key.
        assert!(err(59) < 3.0 && err(61) < 3.0, "{} {}", err(59), err(61));
        assert!(err(70) < err(90), "{} {}", err(70), err(90));
        // Far from any key: the network's reading (the tracker, 40 px off, does not drag it).
        assert!((err(100) - 12.0).abs() < 2.0, "{}", err(100));
    }

    #[test]
    fn frames_between_looks_stand_on_the_nearer_look_and_a_gap_on_none() {
        let p = vec![];
        let at: Vec<Option<&Vec<Landmark>>> = [1, 0, 1, 0, 0, 0, 1, 0]
            .iter()
            .map(|&s| (s == 1).then_some(&p))
            .collect();
        let want = match LOOK_EVERY {
            2 => vec![
                Some(0),
                Some(0),
                Some(2),
                None,
                None,
                None,
                Some(6),
                Some(6),
            ],
            _ => return,
        };
        assert_eq!(nearest_looks(&at), want);
    }

    #[test]
    fn between_looks_the_tracker_does_not_pull_but_still_judges_the_status() {
        // The network looks at every other frame; the tracker is 40 px off on the others.
        let (mut frames, names_, mut lms, truth) = still_body(120, 60);
        for (f, l) in lms.iter_mut().enumerate() {
            if f % 2 == 1 {
                *l = None;
            }
        }
        fuse(&mut frames, &names_, &lms);
        // Far from the keys, to the clip's last frame (which is not a look): the network's
        // reading, 12 px right of the truth, not pulled toward the tracker's 40 px left.
        for f in (101..120).step_by(2) {
            let off = frames[f][1].x - truth.x;
            assert!((off - 12.0).abs() < 2.0, "frame {f}: {off}");
            assert_eq!(
                frames[f][1].status, "low",
                "frame {f}: the tracker disagrees"
            );
            // The hip, where the tracker agrees with the looks on either side: `ok`.
            assert_eq!(frames[f][0].status, "ok", "frame {f}");
        }
    }

    #[test]
    fn the_sides_are_read_as_the_keys_read_them() {
        // The network reads the person's sides the other way round on every frame (as when
        // she turns her back); the keys say which is which.
        let (mut frames, names_, mut lms, truth) = still_body(40, 20);
        for p in lms.iter_mut().flatten() {
            for (a, b) in [(11, 12), (15, 16), (23, 24)] {
                p.swap(a, b);
            }
        }
        fuse(&mut frames, &names_, &lms);
        let err = (Point::new(frames[30][1].x, frames[30][1].y) - truth).norm();
        assert!(err < 13.0, "{err}");
    }
}
