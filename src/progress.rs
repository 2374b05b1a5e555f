//! Progress reporting: the library reports, the binary draws (indicatif bars on stderr).

/// Receives progress from long-running work. `advance` returns `false` to ask the work to stop
/// (Ctrl-C); the work then leaves its output consistent and returns [`crate::Error::Interrupted`].
pub trait Progress: Sync {
    /// A stage starts; `total` units if known.
    fn start(&self, _stage: &str, _total: Option<u64>) {}
    /// `n` more units done. Returns `false` to stop.
    fn advance(&self, _n: u64) -> bool {
        true
    }
    /// The stage is over.
    fn finish(&self) {}
}

/// Reports nothing and never stops.
pub struct NoProgress;
impl Progress for NoProgress {}
