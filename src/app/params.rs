//! Tracking parameters from the user: read from a TOML file, and validated in one place
//! ([`TrackParams::validate`]) on every path that tracks with them: `track` (command line and
//! library callers of [`crate::app::track`]), `resume` (the parameters `run.toml` holds, and
//! `--params`), and `batch`.

use crate::error::{Error, Result};
use crate::track::TrackParams;
use std::path::Path;

impl TrackParams {
    /// Checks the values the tracker cannot work with: [`Error::Usage`] naming the field, its
    /// value and the fix.
    pub fn validate(&self) -> Result<()> {
        if !(0.0..=1.0).contains(&self.length_anchor) {
            return Err(Error::Usage(format!(
                "length_anchor = {} is out of range; give a share from 0 (the predicted length) \
                 to 1 (the seed length, scaled with its body)",
                self.length_anchor
            )));
        }
        if self.search_max_steps == 0 {
            return Err(Error::Usage(
                "search_max_steps = 0 is out of range; give at least 1 grid step each side \
                 (16 is the default; 8 is faster and coarser)"
                    .to_owned(),
            ));
        }
        if !(self.work_box_px.is_finite() && self.work_box_px >= 0.0) {
            return Err(Error::Usage(format!(
                "work_box_px = {} is out of range; give a rectangle side in px (0 tracks at \
                 full resolution)",
                self.work_box_px
            )));
        }
        Ok(())
    }
}

/// Reads a tracking-parameter TOML file (none: the defaults); unknown keys are errors naming
/// the key, and the values are validated ([`TrackParams::validate`], the message naming the
/// file).
pub fn read_params(path: Option<&Path>) -> Result<TrackParams> {
    let Some(path) = path else {
        return Ok(TrackParams::default());
    };
    let text = std::fs::read_to_string(path).map_err(|e| {
        Error::Usage(format!(
            "{}: cannot read the parameter file: {e}",
            path.display()
        ))
    })?;
    let params: TrackParams = toml::from_str(&text).map_err(|e| {
        // The line of the value or key at fault, when the parser knows it.
        let line = e
            .span()
            .map(|s| format!(", line {}", text[..s.start].matches('\n').count() + 1))
            .unwrap_or_default();
        Error::Usage(format!("{}{line}: {}", path.display(), e.message()))
    })?;
    params.validate().map_err(|e| match e {
        Error::Usage(msg) => Error::Usage(format!("{}: {msg}", path.display())),
        e => e,
    })?;
    Ok(params)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_of_range_values_are_named_with_the_fix() {
        assert!(TrackParams::default().validate().is_ok());
        let p = TrackParams {
            work_box_px: -1.0,
            ..TrackParams::default()
        };
        let e = p.validate().unwrap_err();
        assert!(e.is_user_error());
        assert!(e.to_string().contains("work_box_px = -1"), "{e}");
        let p = TrackParams {
            length_anchor: 1.5,
            ..TrackParams::default()
        };
        assert!(p
            .validate()
            .unwrap_err()
            .to_string()
            .contains("length_anchor"));
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("p.toml");
        std::fs::write(&f, "work_box_px = nan\n").unwrap();
        let e = read_params(Some(&f)).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}: work_box_px", f.display())),
            "{e}"
        );
        std::fs::write(&f, "search_max_steps = 0\n").unwrap();
        let e = read_params(Some(&f)).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}: search_max_steps = 0", f.display())),
            "{e}"
        );
        // A value of the wrong type: the line it is on.
        std::fs::write(&f, "search_sigmas = 3.0\nsearch_max_steps = -1\n").unwrap();
        let e = read_params(Some(&f)).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}, line 2: ", f.display())), "{e}");
        let p = TrackParams {
            search_max_steps: 8,
            ..TrackParams::default()
        };
        assert!(p.validate().is_ok());
    }
}
