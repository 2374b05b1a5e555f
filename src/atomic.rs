//! Atomic file writes: write to a temp file beside the target (`NAME.<pid>.<n>.tmp`, unique to
//! this write, so two writers never share one), flush, then rename over it, so a crash or Ctrl-C
//! leaves either the old file or the new one, never half of one.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Temp files made by this process so far (the `<n>` of their names).
static TEMPS: AtomicU64 = AtomicU64::new(0);

/// A fresh temporary path for writing `path`: `<path>.<pid>.<n>.tmp`, never the same twice in
/// one process, nor in two processes at once.
pub fn temp_path(path: &Path) -> PathBuf {
    let n = TEMPS.fetch_add(1, Ordering::Relaxed);
    let mut s = path.as_os_str().to_owned();
    s.push(format!(".{}.{n}.tmp", std::process::id()));
    PathBuf::from(s)
}

/// The temp name earlier builds used for every write of `path` (`<path>.tmp`): a crash could
/// leave one, which a successful write of `path` removes.
fn legacy_temp_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".tmp");
    PathBuf::from(s)
}

/// Writes `bytes` to `path` atomically (temp file + fsync + rename).
pub fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    write_with(path, |f| f.write_all(bytes))
}

/// Writes `bytes` to `path` atomically unless `keep_old()`, asked once the new bytes are on
/// disk beside it, just before they would replace it, says the file there must stay (say, the
/// user edited it meanwhile). Returns whether `path` was written. The check and the rename are
/// not one step: a change in between still wins over nothing, but the window is microseconds,
/// not the whole write.
pub fn write_unless(
    path: &Path,
    bytes: &[u8],
    keep_old: impl FnOnce() -> Result<bool>,
) -> Result<bool> {
    let tmp = temp_path(path);
    let staged = (|| -> std::io::Result<()> {
        let mut file = std::fs::File::create(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()
    })();
    if let Err(e) = staged {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    let keep = keep_old();
    if !matches!(keep, Ok(false)) {
        let _ = std::fs::remove_file(&tmp);
        return keep.map(|_| false);
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })?;
    Ok(true)
}

/// Writes `path` atomically with a closure that fills a buffered writer.
pub fn write_with(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    let tmp = temp_path(path);
    let run = || -> std::io::Result<()> {
        let file = std::fs::File::create(&tmp)?;
        let mut w = std::io::BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)?;
        let _ = std::fs::remove_file(legacy_temp_path(path));
        Ok(())
    };
    run().map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn write_replaces_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        super::write(&p, b"one").unwrap();
        super::write(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
        assert_eq!(left.len(), 1, "{left:?}");
    }

    #[test]
    fn write_unless_keeps_the_old_file_when_asked_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        std::fs::write(&p, b"user").unwrap();
        assert!(!super::write_unless(&p, b"tool", || Ok(true)).unwrap());
        assert_eq!(std::fs::read(&p).unwrap(), b"user");
        assert!(super::write_unless(&p, b"tool", || Ok(false)).unwrap());
        assert_eq!(std::fs::read(&p).unwrap(), b"tool");
        let failed = super::write_unless(&p, b"x", || Err(crate::Error::Interrupted));
        assert!(failed.is_err());
        assert_eq!(std::fs::read(&p).unwrap(), b"tool");
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
        assert_eq!(left.len(), 1, "{left:?}");
    }

    #[test]
    fn temp_names_are_unique_and_a_stale_legacy_one_goes() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        let (a, b) = (super::temp_path(&p), super::temp_path(&p));
        assert_ne!(a, b);
        let name = a.file_name().unwrap().to_str().unwrap().to_owned();
        assert!(
            name.starts_with(&format!("a.txt.{}.", std::process::id())) && name.ends_with(".tmp"),
            "{name}"
        );
        std::fs::write(dir.path().join("a.txt.tmp"), "half").unwrap();
        super::write(&p, b"one").unwrap();
        assert!(!dir.path().join("a.txt.tmp").exists());
    }
}
