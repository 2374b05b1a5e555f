//! The settings of a retarget (docs/method.md §4.4–4.6) and where the target's rest skeleton is
//! placed in the output frame.

use super::{cleanup, P64};
use crate::geom::Point;

/// The cartoon animation filter's settings (docs/method.md §4.4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cartoon {
    /// A: 0 is off; 1–3 is visible.
    pub strength: f64,
    /// σ of the Gaussian, frames.
    pub sigma_frames: f64,
}

/// Default σ of the cartoon filter, frames.
pub const DEFAULT_CARTOON_SIGMA: f64 = 4.0;

/// Smoothing of the source joint tracks before retargeting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Smooth {
    /// Running median over this many frames (odd).
    Median { window_frames: usize },
    /// Gaussian with this standard deviation (frames).
    Gaussian { sigma_frames: f64 },
}

impl std::fmt::Display for Smooth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Smooth::Median { window_frames } => write!(f, "median:{window_frames}"),
            Smooth::Gaussian { sigma_frames } => write!(f, "gaussian:{sigma_frames}"),
        }
    }
}

impl std::str::FromStr for Smooth {
    type Err = String;
    /// `median:N` (N odd frames, 3 to 99) or `gaussian:S` (S frames, above 0 to 30).
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let bad = || {
            format!("{s:?}: expected median:N (odd N, 3 to 99) or gaussian:S (S frames, 0 to 30)")
        };
        let (kind, v) = s.split_once(':').ok_or_else(bad)?;
        match kind {
            "median" => match v.parse::<usize>() {
                Ok(n) if n % 2 == 1 && (3..=99).contains(&n) => {
                    Ok(Smooth::Median { window_frames: n })
                }
                _ => Err(bad()),
            },
            "gaussian" => match v.parse::<f64>() {
                Ok(g) if g > 0.0 && g <= 30.0 => Ok(Smooth::Gaussian { sigma_frames: g }),
                _ => Err(bad()),
            },
            _ => Err(bad()),
        }
    }
}

/// What `retarget` does on top of docs/method.md eq. 16–17.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RetargetOptions {
    /// The clean-up of the tracks (docs/method.md §4.5), applied by [`crate::app::retarget`]
    /// before [`super::retarget`]; on by default.
    pub clean: cleanup::Cleanup,
    pub smooth: Option<Smooth>,
    pub cartoon: Option<Cartoon>,
    /// Bones follow their source bones' changes of length (eq. 18: squash and stretch, for
    /// cartoon characters); off by default: every bone keeps the character's length.
    pub stretch: bool,
    /// With `stretch`, keep the character's size when the whole source grows or shrinks (the
    /// subject walking towards or away from the camera): each frame's driven length ratios are
    /// divided by their median over the bones, so only the bones' lengths relative to each
    /// other follow.
    pub keep_size: bool,
    /// Hold each foot still while it is on the ground (docs/method.md §4.6); on by default.
    pub plant_feet: bool,
}

impl Default for RetargetOptions {
    fn default() -> Self {
        RetargetOptions {
            clean: cleanup::Cleanup::default(),
            smooth: None,
            cartoon: None,
            stretch: false,
            keep_size: false,
            plant_feet: true,
        }
    }
}

/// Where the target's rest skeleton goes in the output frame: `out = image · scale + offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Output px per image px.
    pub scale: f64,
    /// px.
    pub offset: P64,
}

impl Placement {
    /// An image position (px) in output px.
    pub fn apply(&self, p: Point) -> P64 {
        [
            p.x as f64 * self.scale + self.offset[0],
            p.y as f64 * self.scale + self.offset[1],
        ]
    }
}
