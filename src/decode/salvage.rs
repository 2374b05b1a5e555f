//! A damaged or cut-short clip: decoding stops at the first frame that fails, and where it
//! stopped is said ([`DecodeStop`]), so the frames before it are still tracked.

use super::ClipInfo;
use crate::error::{Error, Result};

/// Where decoding stopped before the end of a damaged or cut-short clip: `track` keeps the
/// frames before it and records this in `run.toml` (`[decode_stop]`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecodeStop {
    /// The first frame (0-based) that could not be decoded: frames `0..frame` were tracked.
    pub frame: u64,
    /// Frames the file states it has, if it does.
    pub stated_frames: Option<u64>,
    /// Why decoding stopped (the decoder's error, or "the file ends early").
    pub reason: String,
}

impl std::fmt::Display for DecodeStop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "decoding stopped at frame {}", self.frame)?;
        if let Some(n) = self.stated_frames {
            write!(f, " of the {n} the file states")?;
        }
        write!(
            f,
            " ({}); only frames 0..{} were used",
            self.reason, self.frame
        )
    }
}

/// Passes frames through and ends at the first decode error once a frame has decoded, recording
/// where in `stop` (a clip damaged or cut short part-way keeps the frames before the damage). At
/// the end, fewer frames than `stated` (see [`ClipInfo::stated_frames`]) is recorded too. An error
/// on the very first frame, or any other error, passes through.
pub struct Salvage<'a, I> {
    inner: I,
    stated: Option<u64>,
    next: u64,
    done: bool,
    stop: &'a mut Option<DecodeStop>,
}

/// See [`Salvage`].
pub fn salvage<I, T>(inner: I, stated: Option<u64>, stop: &mut Option<DecodeStop>) -> Salvage<'_, I>
where
    I: Iterator<Item = Result<(u64, T)>>,
{
    Salvage {
        inner,
        stated,
        next: 0,
        done: false,
        stop,
    }
}

impl<I, T> Iterator for Salvage<'_, I>
where
    I: Iterator<Item = Result<(u64, T)>>,
{
    type Item = Result<(u64, T)>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        match self.inner.next() {
            Some(Ok((i, frame))) => {
                self.next = i + 1;
                Some(Ok((i, frame)))
            }
            Some(Err(Error::Decode { msg, .. })) if self.next > 0 => {
                self.done = true;
                *self.stop = Some(DecodeStop {
                    frame: self.next,
                    stated_frames: self.stated,
                    reason: msg,
                });
                None
            }
            Some(Err(e)) => {
                self.done = true;
                Some(Err(e))
            }
            None => {
                self.done = true;
                if let Some(n) = self.stated.filter(|&n| self.next > 0 && self.next < n) {
                    *self.stop = Some(DecodeStop {
                        frame: self.next,
                        stated_frames: Some(n),
                        reason: "the file ends early; it was probably cut short".into(),
                    });
                }
                None
            }
        }
    }
}

/// For a file that states no frame count but a duration (MKV, WebM): where decoding stopped
/// when it gave clearly fewer than `info.frame_count_hint` (duration × fps) frames, `decoded`,
/// i.e. a file cut short. The duration is approximate, so a shortfall of up to 2 frames or 5 %
/// passes. `None` when the file states its count (then [`salvage`] checks) or no duration.
pub fn short_of_duration(info: &ClipInfo, decoded: u64) -> Option<DecodeStop> {
    if info.stated_frames.is_some() || decoded == 0 {
        return None;
    }
    let h = info.frame_count_hint?;
    (decoded + (h / 20).max(2) < h).then(|| DecodeStop {
        frame: decoded,
        stated_frames: None,
        reason: format!(
            "the file ends early: its header gives a duration of about {h} frames at {:.3} \
             frames/s; it was probably cut short",
            info.fps
        ),
    })
}
