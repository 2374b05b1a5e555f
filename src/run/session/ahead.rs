//! A span between keys that runs past a segment's end, for [`super::segment`] (docs/method.md,
//! "Keys across a segment's end"): when the next segment's first frame is neither a correction
//! nor a key, the frames after it up to the next key (in that segment or a later one) are read
//! ahead and tracked by the tracker that segment carries on with, so that the path from this
//! segment's last key to that key is solved through both. The frames then go back to the stream,
//! and the next segment starts from the row solved on its first frame (its file's).

use super::flow;
use super::pass::{Frames, Pass};
use super::Session;
use crate::error::Result;
use crate::run::keys::Key;
use crate::track::scale::Frame;
use crate::track::JointEstimate;

/// Most bytes of frames read ahead past a segment's end (about 190 frames of 1280×720, full and
/// working images): a key further on is not reached, and the span is not bridged.
const AHEAD_BYTES: usize = 512 << 20;

/// The frames read ahead past a segment's end, up to and with a key's frame, and the carried
/// tracker's rows on them.
pub(super) struct Ahead {
    pub(super) frames: Vec<(u64, Frame)>,
    pub(super) rows: Vec<Vec<JointEstimate>>,
}

/// The keys a segment's last spans run on to, in frame order: those after the next segment's
/// first frame `next` up to the first that keys each joint (a key may give some joints only),
/// when neither a correction (`corrected_next`) nor a key sits on `next`, as far as the frames
/// up to them, of `frame_bytes` each, fit in [`AHEAD_BYTES`]. Empty when there is none.
pub(super) fn keys_past_end(
    keys: &[Key],
    next: u64,
    corrected_next: bool,
    frame_bytes: usize,
) -> Vec<&Key> {
    if corrected_next || keys.iter().any(|x| x.frame == next) {
        return Vec::new();
    }
    let most = (AHEAD_BYTES / frame_bytes.max(1)) as u64;
    let mut wanted: Option<Vec<bool>> = None;
    let mut out = Vec::new();
    for key in keys.iter().filter(|x| x.frame > next) {
        if key.frame - next > most {
            break;
        }
        let w = wanted.get_or_insert_with(|| vec![true; key.joints.len()]);
        if !key
            .joints
            .iter()
            .zip(w.iter())
            .any(|(k, &w)| w && k.is_some())
        {
            continue;
        }
        for (w, k) in w.iter_mut().zip(&key.joints) {
            *w &= k.is_none();
        }
        out.push(key);
        if !w.iter().any(|&w| w) {
            break;
        }
    }
    out
}

impl Session {
    /// Reads the frames after `from` (the next segment's first frame, just tracked) up to
    /// `key_frame` and tracks them with the tracker segment `k1` carries on with (the state
    /// kept in [`Session::carried`]), their Lucas–Kanade pyramids built alongside (`built`);
    /// up to `whole_until`, a key of every joint lies ahead of the pass
    /// ([`crate::track::Tracker::set_key_ahead`]). `None` when the clip ends first, or the
    /// frames up to the key would take more than [`AHEAD_BYTES`]: the frames read are given
    /// back.
    pub(super) fn read_ahead<I: Iterator<Item = Result<(u64, Frame)>>>(
        &self,
        k1: u64,
        from: u64,
        key_frame: u64,
        whole_until: Option<u64>,
        frames: &mut Frames<'_, I>,
        built: &mut flow::Built,
    ) -> Result<Option<Ahead>> {
        let state = self
            .carried
            .as_deref()
            .expect("the segment's tracker was kept");
        let t = self.restored(k1, state)?;
        let angles: Vec<f32> = t.current().iter().map(|e| e.angle_rad).collect();
        let mut pass = Pass::new(t, &angles, from);
        let mut read: Vec<(u64, Frame)> = Vec::new();
        let (mut bytes, mut reached) = (0usize, false);
        while let Some((idx, frame)) = frames.next()? {
            bytes += frame.bytes();
            let over = bytes > AHEAD_BYTES;
            if !over {
                let ahead = whole_until.is_some_and(|f| idx <= f);
                rayon::join(|| pass.step(idx, &frame, ahead), || built.add(&frame));
                reached = idx == key_frame;
            }
            read.push((idx, frame));
            if over || idx >= key_frame {
                break;
            }
        }
        if !reached {
            frames.unread(read);
            return Ok(None);
        }
        let rows: Vec<Vec<JointEstimate>> = pass
            .finish()
            .into_iter()
            .filter(|(f, _)| *f > from)
            .map(|(_, r)| r)
            .collect();
        debug_assert_eq!(rows.len(), read.len());
        Ok(Some(Ahead { frames: read, rows }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_span_runs_on_to_the_next_key_unless_the_boundary_is_keyed_or_it_is_too_far() {
        let p = Some(crate::geom::Point::new(1.0, 1.0));
        let keys: Vec<Key> = [40, 150, 400]
            .map(|frame| Key {
                frame,
                joints: vec![p],
            })
            .to_vec();
        let at = |next: u64, corrected: bool, bytes: usize| -> Vec<u64> {
            let k = keys_past_end(&keys, next, corrected, bytes);
            k.iter().map(|k| k.frame).collect()
        };
        let mb = 1 << 20;
        assert_eq!(at(30, false, mb), [40]);
        assert_eq!(at(100, false, mb), [150]);
        // A key on the boundary, or a corrected file there, is the span's end already.
        assert!(at(150, false, mb).is_empty());
        assert!(at(100, true, mb).is_empty());
        // 250 frames ahead fit in 512 MiB at 1 MiB a frame, not at 4 MiB.
        assert_eq!(at(160, false, mb), [400]);
        assert!(at(160, false, 4 * mb).is_empty());
        assert!(at(400, false, mb).is_empty());
        // Keys of some joints: on to the first key of each joint, a key of none new skipped.
        let some: Vec<Key> = [
            (50, [p, None]),
            (60, [p, None]),
            (70, [None, p]),
            (80, [p, p]),
        ]
        .map(|(frame, j)| Key {
            frame,
            joints: j.to_vec(),
        })
        .to_vec();
        let frames: Vec<u64> = keys_past_end(&some, 45, false, mb)
            .iter()
            .map(|k| k.frame)
            .collect();
        assert_eq!(frames, [50, 70]);
    }
}
