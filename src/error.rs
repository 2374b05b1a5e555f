//! The crate's error type. Every variant names where the problem is (file, line, joint, field)
//! and, when cheap, the fix. [`Error::is_user_error`] decides the exit code: 2 for problems the
//! user can fix (bad input), 1 for failures they cannot (I/O, a decoder failing mid-clip).

use std::path::PathBuf;

/// Exit code after an interruption (Ctrl-C, SIGTERM): 128 + SIGINT, as shells report it.
pub const EXIT_INTERRUPTED: u8 = 130;

/// Result alias for the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A seed (or segment) file that is malformed or inconsistent.
    #[error("{}: {}{}{msg}", path.display(), line.map(|l| format!("line {l}: ")).unwrap_or_default(), joint.as_ref().map(|j| format!("joint {j:?}: ")).unwrap_or_default())]
    Seed {
        path: PathBuf,
        line: Option<usize>,
        joint: Option<String>,
        msg: String,
    },

    /// A target character file (or its image) that is malformed, or does not fit the run.
    #[error("{}: {}{}{msg}", path.display(), line.map(|l| format!("line {l}: ")).unwrap_or_default(), joint.as_ref().map(|j| format!("joint {j:?}: ")).unwrap_or_default())]
    Character {
        path: PathBuf,
        line: Option<usize>,
        joint: Option<String>,
        msg: String,
    },

    /// A clip that is missing, empty or that FFmpeg cannot open.
    #[error("{}: {msg}", path.display())]
    Clip { path: PathBuf, msg: String },

    /// Decoding failed part-way through a clip that opened fine.
    #[error("{}: frame {frame}: {msg}", path.display())]
    Decode {
        path: PathBuf,
        frame: u64,
        msg: String,
    },

    /// A run folder that does not fit the command (another clip, missing files, edited manifest).
    #[error("{}: {msg}", path.display())]
    RunFolder { path: PathBuf, msg: String },

    /// A bad combination of command-line options or parameter values.
    #[error("{0}")]
    Usage(String),

    /// Reading or writing a file failed. The OS message is part of the message, so it is not
    /// also given as the error's `source` (which would print it twice down an error chain).
    #[error("{}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },

    /// Encoding a video failed.
    #[error("{}: {msg}", path.display())]
    Encode { path: PathBuf, msg: String },

    /// The pose network's engine failed on a frame (not the user's to fix: exit code 1).
    #[error("{0}")]
    Engine(String),

    /// The work was interrupted (Ctrl-C, SIGTERM); no file was left half-written.
    #[error("interrupted; no file was left half-written (a `track` or `resume` carries on with `mocap2d resume RUN`)")]
    Interrupted,
}

impl Error {
    /// True when the user can fix the cause (bad input or options): exit code 2. Otherwise 1.
    pub fn is_user_error(&self) -> bool {
        matches!(
            self,
            Error::Seed { .. }
                | Error::Character { .. }
                | Error::Clip { .. }
                | Error::RunFolder { .. }
                | Error::Usage(_)
        )
    }

    /// Wraps an I/O error with the path it concerns.
    pub fn io(path: impl Into<PathBuf>, error: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            error,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_io_error_says_the_os_message_once() {
        let os = std::io::Error::from(std::io::ErrorKind::NotFound);
        let e = Error::io("a/b.txt", os);
        let msg = e.to_string();
        assert!(msg.starts_with("a/b.txt: "), "{msg}");
        assert!(std::error::Error::source(&e).is_none(), "{msg}");
        assert!(!e.is_user_error());
    }
}
