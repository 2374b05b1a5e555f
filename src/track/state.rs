//! A tracker's state, as bytes: what a segment's tracker hands on to the next one
//! (`segments/NNN.state`, see `crate::run::session`), so that a segment the user did not
//! correct goes on exactly as one tracker through the clip would: which strips are laid
//! mirrored (the character turned round), the running colours, which samples are reliable,
//! the typical costs, the gain the subject showed last, every joint's motion filters, hidden
//! run and last estimate. Every float
//! is stored bit for bit: the tracker is sensitive enough that rounding the running colours
//! to 1/128 level moved PCK@5 on synth clips by up to 25 points either way.
//!
//! Layout (little-endian): the magic line, the frames stepped (u64), the subject's last gain
//! (f32, 0 before the first step; see `super::exposure`), the strip count (u32),
//! each strip as [`Strip::save_learnt`](super::strip::Strip::save_learnt) writes it, the joint
//! count (u32), then per joint its motion ([`Ca::save`] per filter), hidden run (u32) and
//! last estimate (x, y, angle, score: f32; status: u8).

use super::kalman::{Ca, Kalman};
use super::motion::Motion;
use super::{JointEstimate, Status, Tracker};
use crate::geom::Point;

pub mod bytes;

use bytes::{Reader, Writer};

const MAGIC: &[u8] = b"mocap2d tracker state 4\n";

/// Whether `bytes` are a tracker state in this version's layout (a state written by an older
/// mocap2d is not, and cannot be restored).
pub fn is_current(bytes: &[u8]) -> bool {
    bytes.starts_with(MAGIC)
}

impl Tracker {
    /// This tracker's state after the frames it has stepped (see the module docs).
    pub fn state(&self) -> Vec<u8> {
        let mut w = Writer::after(MAGIC);
        w.u64(self.timings.frames);
        w.f32(self.exposure.last.unwrap_or(0.0));
        w.u32(self.model.strips.len() as u32);
        for s in &self.model.strips {
            s.save_learnt(&mut w);
        }
        w.u32(self.joints.len() as u32);
        for j in &self.joints {
            match &j.motion {
                Motion::Root(k) => {
                    w.u8(0);
                    k.x.save(&mut w);
                    k.y.save(&mut w);
                }
                Motion::Bone {
                    angle,
                    log_len,
                    log_len_range,
                } => {
                    w.u8(1);
                    angle.save(&mut w);
                    log_len.save(&mut w);
                    w.f32(log_len_range.0);
                    w.f32(log_len_range.1);
                }
            }
            w.u32(j.hidden_run);
            let e = &j.last;
            for v in [e.pos.x, e.pos.y, e.angle_rad, e.score] {
                w.f32(v);
            }
            w.u8(Status::ALL.iter().position(|&s| s == e.status).unwrap_or(0) as u8);
        }
        w.into_bytes()
    }

    /// Takes on the state `bytes` ([`Tracker::state`]) of a tracker built from the same seed
    /// file, seed frame and parameters. `false` (the tracker then is unusable) when the bytes
    /// are not such a state.
    pub fn restore_state(&mut self, bytes: &[u8]) -> bool {
        let Some(rest) = bytes.strip_prefix(MAGIC) else {
            return false;
        };
        let mut r = Reader::new(rest);
        let (Some(frames), Some(gain)) = (r.u64(), r.f32()) else {
            return false;
        };
        self.exposure.last = (gain > 0.0).then_some(gain);
        if r.u32() != Some(self.model.strips.len() as u32) {
            return false;
        }
        let aw = self.params.anchor_weight;
        for s in &mut self.model.strips {
            if s.load_learnt(&mut r, aw).is_none() {
                return false;
            }
        }
        if r.u32() != Some(self.joints.len() as u32) {
            return false;
        }
        for j in &mut self.joints {
            let Some(()) = load_joint(&mut r, &mut j.motion, &mut j.hidden_run, &mut j.last) else {
                return false;
            };
        }
        self.timings.frames = frames;
        r.is_empty()
    }
}

/// Reads one joint of [`Tracker::state`] into its parts; `None` when the bytes do not fit.
fn load_joint(
    r: &mut Reader,
    motion: &mut Motion,
    hidden_run: &mut u32,
    last: &mut JointEstimate,
) -> Option<()> {
    *motion = match (r.u8()?, &*motion) {
        (0, Motion::Root(_)) => Motion::Root(Kalman {
            x: Ca::load(r)?,
            y: Ca::load(r)?,
        }),
        (1, Motion::Bone { .. }) => Motion::Bone {
            angle: Ca::load(r)?,
            log_len: Ca::load(r)?,
            log_len_range: (r.f32()?, r.f32()?),
        },
        _ => return None,
    };
    *hidden_run = r.u32()?;
    let (x, y, angle_rad, score) = (r.f32()?, r.f32()?, r.f32()?, r.f32()?);
    *last = JointEstimate {
        pos: Point::new(x, y),
        angle_rad,
        score,
        status: *Status::ALL.get(r.u8()? as usize)?,
    };
    Some(())
}
