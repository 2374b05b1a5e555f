//! The learned human pose cue (docs/method.md §2.8). BlazePose's person detector and landmark
//! network ([`blazepose`]), run by an engine behind one trait ([`engine::Engine`]), give each
//! frame of a person's clip 33 landmarks with their visibility. A run keeps them in
//! `pose.csv`; [`crate::run::fuse`] combines them with the tracker's rows and the user's keys.
//!
//! The network follows the body from frame to frame as its own graph does: each frame's crop is
//! the region its previous frame's landmarks call for, and the detector looks again only when
//! the person is lost.

pub mod blazepose;
pub mod engine;
pub mod names;
pub mod person;

use crate::error::{Error, Result};
use crate::geom::Point;
use blazepose::{Detection, Landmark, Roi};
use engine::{Engine, Network};
use image::RgbImage;
use std::fmt::Write as _;
use std::path::Path;

pub use blazepose::Landmarks;

/// Below this, the landmark network's person score means the crop has lost the person.
const MIN_PERSON: f32 = 0.5;

/// The network looks at every `LOOK_EVERY`-th frame of a clip, and at the seed frame; the
/// fusion carries the frames between (docs/method.md §2.8).
pub const LOOK_EVERY: usize = 2;

/// Whether the network looks at `frame` of a clip whose seeds are on `seed_frame`.
pub fn looks_at(frame: usize, seed_frame: usize) -> bool {
    frame.is_multiple_of(LOOK_EVERY) || frame == seed_frame
}

/// The torso's length (px) in a frame's landmarks: shoulder centre to hip centre.
pub fn torso(points: &[Landmark]) -> f32 {
    let mid = |a: usize, b: usize| (points[a].pos.coords + points[b].pos.coords) / 2.0;
    (mid(11, 12) - mid(23, 24)).norm()
}

/// Which person to follow when the detector finds several.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pick {
    /// The largest box.
    Largest,
    /// The one whose box overlaps this rectangle (top-left, bottom-right, px) the most.
    Inside(Point, Point),
}

/// Every person the detector finds on a frame, strongest first.
pub fn detect(engine: &mut dyn Engine, img: &RgbImage) -> Result<Vec<Detection>> {
    let (input, side, offset) = blazepose::detector_input(img);
    let out = engine.run(Network::Detector, &input)?;
    let (boxes, scores) = match out.as_slice() {
        [b, s, ..] => (b, s),
        _ => {
            return Err(Error::Engine(
                "the person detector gave too few outputs".into(),
            ))
        }
    };
    Ok(blazepose::decode_detections(boxes, scores, side, offset))
}

/// The person `pick` chooses among `found`.
pub fn choose(found: &[Detection], pick: Pick) -> Option<Detection> {
    match pick {
        Pick::Largest => found
            .iter()
            .copied()
            .max_by(|a, b| a.area().total_cmp(&b.area())),
        Pick::Inside(lo, hi) => {
            let overlap = |d: &Detection| {
                let x0 = d.min.x.max(lo.x);
                let y0 = d.min.y.max(lo.y);
                let x1 = (d.min.x + d.size.x).min(hi.x);
                let y1 = (d.min.y + d.size.y).min(hi.y);
                (x1 - x0).max(0.0) * (y1 - y0).max(0.0)
            };
            found
                .iter()
                .copied()
                .filter(|d| overlap(d) > 0.0)
                .max_by(|a, b| overlap(a).total_cmp(&overlap(b)))
        }
    }
}

/// The landmark network on the crop `roi` of `img`.
pub fn landmarks(engine: &mut dyn Engine, img: &RgbImage, roi: &Roi) -> Result<Landmarks> {
    let out = engine.run(Network::Landmarks, &roi.crop(img))?;
    match out.as_slice() {
        [raw, person, _, heatmap, ..] => Ok(blazepose::decode_landmarks(
            raw,
            person.first().copied().unwrap_or(f32::MIN),
            heatmap,
            roi,
        )),
        _ => Err(Error::Engine(
            "the landmark network gave too few outputs".into(),
        )),
    }
}

/// [`landmarks`] on the crop and on its mirror image, averaged (the network's two readings of
/// one body; the visibility is the lower of the two).
pub fn landmarks_both_ways(
    engine: &mut dyn Engine,
    img: &RgbImage,
    roi: &Roi,
) -> Result<Landmarks> {
    let mut a = landmarks(engine, img, roi)?;
    let b = landmarks(engine, img, &roi.mirror())?;
    for (p, q) in a.points.iter_mut().zip(&b.points) {
        p.pos = Point::from((p.pos.coords + q.pos.coords) / 2.0);
        p.visibility = p.visibility.min(q.visibility);
        p.presence = p.presence.min(q.presence);
    }
    a.person = a.person.min(b.person);
    Ok(a)
}

/// Follows one person through a clip's frames, frame after frame.
pub struct Follower<'e> {
    engine: &'e mut dyn Engine,
    pick: Pick,
    roi: Option<Roi>,
}

impl<'e> Follower<'e> {
    pub fn new(engine: &'e mut dyn Engine, pick: Pick) -> Self {
        Follower {
            engine,
            pick,
            roi: None,
        }
    }

    /// The person's landmarks on the next frame, or `None` where the network sees no one.
    pub fn next(&mut self, img: &RgbImage) -> Result<Option<Vec<Landmark>>> {
        let lm = match self.roi {
            Some(roi) => landmarks(self.engine, img, &roi)?,
            None => {
                let found = detect(self.engine, img)?;
                let Some(d) = choose(&found, self.pick) else {
                    return Ok(None);
                };
                // The detector's box is rough: look again from the crop the landmarks call for.
                let first = landmarks(self.engine, img, &d.roi())?;
                landmarks(self.engine, img, &first.next_roi)?
            }
        };
        if lm.person < MIN_PERSON || !(lm.next_roi.side > 1.0) {
            self.roi = None;
            return Ok(None);
        }
        // Once followed, the person is whoever the crop holds: keep to its region.
        self.roi = Some(lm.next_roi);
        Ok(Some(lm.points))
    }
}

/// The landmarks of a clip, one entry a frame (`None` where the network saw no one, or did not
/// look: see [`looks_at`]).
pub type ClipLandmarks = Vec<Option<Vec<Landmark>>>;

/// `pose.csv`: `frame,landmark,x,y,visibility,presence`, 33 rows a frame where the network saw
/// the person, positions to 3 decimals.
pub fn to_csv(clip: &ClipLandmarks) -> String {
    let mut s = String::from("frame,landmark,x,y,visibility,presence\n");
    for (f, lms) in clip.iter().enumerate() {
        for (i, l) in lms.iter().flatten().enumerate() {
            let _ = writeln!(
                s,
                "{f},{},{:.3},{:.3},{:.3},{:.3}",
                names::LANDMARK_NAMES[i],
                l.pos.x,
                l.pos.y,
                l.visibility,
                l.presence
            );
        }
    }
    s
}

/// Reads `pose.csv` back ([`to_csv`]) for a clip of `frames` frames.
pub fn read_csv(path: &Path, frames: usize) -> Result<ClipLandmarks> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let bad = |line: usize, msg: &str| Error::RunFolder {
        path: path.to_path_buf(),
        msg: format!(
            "line {line}: {msg}; delete the file and run `mocap2d track` again to remake it"
        ),
    };
    let mut out: ClipLandmarks = vec![None; frames];
    for (n, line) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 6 {
            return Err(bad(
                n + 1,
                "expected frame,landmark,x,y,visibility,presence",
            ));
        }
        let frame: usize = f[0].parse().map_err(|_| bad(n + 1, "bad frame"))?;
        let i = names::LANDMARK_NAMES
            .iter()
            .position(|x| *x == f[1])
            .ok_or_else(|| bad(n + 1, "unknown landmark"))?;
        let num = |s: &str| s.parse::<f32>().map_err(|_| bad(n + 1, "bad number"));
        let l = Landmark {
            pos: Point::new(num(f[2])?, num(f[3])?),
            visibility: num(f[4])?,
            presence: num(f[5])?,
        };
        if frame >= frames {
            return Err(bad(n + 1, "frame past the clip's end"));
        }
        let slot = out[frame].get_or_insert_with(|| {
            vec![
                Landmark {
                    pos: Point::origin(),
                    visibility: 0.0,
                    presence: 0.0,
                };
                blazepose::LANDMARKS
            ]
        });
        slot[i] = l;
    }
    Ok(out)
}
