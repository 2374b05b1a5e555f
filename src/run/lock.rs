//! One writer at a time in a run folder. `track`, `resume` (also from the page and from
//! `batch`) and a save from `serve` hold an exclusive lock (`flock`) on `RUN/.lock` while they
//! write; a second writer is refused at once, naming the process that holds the lock.
//!
//! The operating system releases the lock when its holder exits, however it exits (kill -9
//! included), so a stale `.lock` file never blocks anyone: the next writer locks it and takes it
//! over. The holder removes the file when it is done, so a finished folder has no `.lock`.
//!
//! A run folder may come from someone else: a `.lock` that is a symbolic link (or anything but a
//! regular file) is refused, never followed, lest locking it truncate the file it points to.

use crate::error::{Error, Result};
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The lock file in a run folder.
pub const LOCK_FILE: &str = ".lock";

/// The held lock of a run folder; released (and its file removed) on drop.
#[derive(Debug)]
pub struct RunLock {
    file: Option<File>,
    path: PathBuf,
}

impl RunLock {
    /// Locks `run_dir` (which must exist) for `what` (the command, e.g. `track`, written into
    /// the lock file so a refused writer can name it). Fails with [`Error::RunFolder`] (exit 2)
    /// naming the other process when another writer holds it.
    pub fn acquire(run_dir: &Path, what: &str) -> Result<RunLock> {
        let path = run_dir.join(LOCK_FILE);
        // The holder removes the file as it releases it: a file locked after that removal is
        // no longer the run folder's lock, so check and try again.
        for _ in 0..100 {
            refuse_unless_regular(&path, std::fs::symlink_metadata(&path).ok())?;
            let mut file = open_no_follow(&path).map_err(|e| match e.raw_os_error() {
                Some(ELOOP) => not_regular(&path, "a symbolic link"),
                _ => Error::io(&path, e),
            })?;
            refuse_unless_regular(&path, file.metadata().ok())?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    return Err(Error::RunFolder {
                        path: run_dir.to_owned(),
                        msg: format!(
                            "another mocap2d is writing this run folder ({}); wait until it \
                             finishes (or stop it), then run this again",
                            holder(&path)
                        ),
                    })
                }
                Err(TryLockError::Error(e)) => return Err(Error::io(&path, e)),
            }
            if !is_same_file(&file, &path) {
                continue;
            }
            let who = format!("pid {}, `mocap2d {what}`\n", std::process::id());
            let written = file
                .set_len(0)
                .and_then(|_| file.rewind())
                .and_then(|_| file.write_all(who.as_bytes()));
            written.map_err(|e| Error::io(&path, e))?;
            return Ok(RunLock {
                file: Some(file),
                path,
            });
        }
        Err(Error::RunFolder {
            path: run_dir.to_owned(),
            msg: "its lock file keeps being replaced by other processes; try again".into(),
        })
    }
}

impl Drop for RunLock {
    fn drop(&mut self) {
        // Remove the file while still holding the lock, then release it by closing.
        let _ = std::fs::remove_file(&self.path);
        drop(self.file.take());
    }
}

/// `ELOOP`: what `open` with `O_NOFOLLOW` fails with on a symbolic link.
#[cfg(unix)]
const ELOOP: i32 = libc::ELOOP;
#[cfg(not(unix))]
const ELOOP: i32 = -1;

/// Opens (creating) the lock file at `path` for reading and writing, not following a symbolic
/// link there (`O_NOFOLLOW`), nor truncating.
fn open_no_follow(path: &Path) -> std::io::Result<File> {
    let mut o = OpenOptions::new();
    o.read(true).write(true).create(true).truncate(false);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NOFOLLOW);
    }
    o.open(path)
}

/// [`Error::RunFolder`] for a lock file at `path` that is `what` instead of a regular file.
fn not_regular(path: &Path, what: &str) -> Error {
    Error::RunFolder {
        path: path.to_owned(),
        msg: format!(
            "is {what}, not a regular file; mocap2d does not follow or write it (it could \
             overwrite another file). Remove it (`rm {}`), then run this again",
            path.display()
        ),
    }
}

/// Refuses the lock file at `path` when `meta` (its metadata, not followed through a link)
/// says it is anything but a regular file; no file yet is fine.
fn refuse_unless_regular(path: &Path, meta: Option<std::fs::Metadata>) -> Result<()> {
    let Some(m) = meta else { return Ok(()) };
    let t = m.file_type();
    if t.is_file() {
        return Ok(());
    }
    Err(not_regular(
        path,
        if t.is_symlink() {
            "a symbolic link"
        } else if t.is_dir() {
            "a folder"
        } else {
            "a special file"
        },
    ))
}

/// Who holds the lock at `path`, as its holder wrote it (`pid N, \`mocap2d track\``). The
/// holder writes that just after locking, so an empty file is read again for a moment.
fn holder(path: &Path) -> String {
    for _ in 0..50 {
        let mut text = String::new();
        if let Ok(mut f) = File::open(path) {
            let _ = f.read_to_string(&mut text);
        }
        let text = text.trim();
        if !text.is_empty() {
            return text.to_owned();
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    "a process that has not said which".into()
}

/// True when the open `file` is the file now at `path` (not one removed since it was opened).
#[cfg(unix)]
fn is_same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::symlink_metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn is_same_file(_: &File, path: &Path) -> bool {
    path.exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_writer_is_refused_naming_the_first_and_a_released_lock_is_taken() {
        let d = tempfile::tempdir().unwrap();
        let a = RunLock::acquire(d.path(), "track").unwrap();
        let err = RunLock::acquire(d.path(), "resume").unwrap_err();
        assert!(err.is_user_error());
        let m = err.to_string();
        let pid = format!("pid {}, `mocap2d track`", std::process::id());
        assert!(m.contains(&pid) && m.contains("another mocap2d"), "{m}");
        drop(a);
        assert!(!d.path().join(LOCK_FILE).exists(), "released and removed");
        let b = RunLock::acquire(d.path(), "resume").unwrap();
        drop(b);
    }

    #[test]
    fn a_stale_lock_file_from_a_killed_process_does_not_block() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join(LOCK_FILE), "pid 1, `mocap2d track`\n").unwrap();
        let l = RunLock::acquire(d.path(), "resume").unwrap();
        let text = std::fs::read_to_string(d.path().join(LOCK_FILE)).unwrap();
        assert_eq!(
            text,
            format!("pid {}, `mocap2d resume`\n", std::process::id())
        );
        drop(l);
    }

    #[cfg(unix)]
    #[test]
    fn a_lock_that_is_a_symbolic_link_is_refused_and_its_target_left_as_it_was() {
        let d = tempfile::tempdir().unwrap();
        let precious = d.path().join("precious");
        std::fs::write(&precious, "keep me\n").unwrap();
        let run = d.path().join("run");
        std::fs::create_dir(&run).unwrap();
        std::os::unix::fs::symlink(&precious, run.join(LOCK_FILE)).unwrap();
        let err = RunLock::acquire(&run, "resume").unwrap_err();
        assert!(err.is_user_error(), "{err}");
        let m = err.to_string();
        assert!(m.contains("symbolic link") && m.contains("rm "), "{m}");
        assert_eq!(std::fs::read_to_string(&precious).unwrap(), "keep me\n");
        // A link to a file not there yet is not created through either.
        let gone = d.path().join("gone");
        std::fs::remove_file(run.join(LOCK_FILE)).unwrap();
        std::os::unix::fs::symlink(&gone, run.join(LOCK_FILE)).unwrap();
        assert!(RunLock::acquire(&run, "track").is_err());
        assert!(!gone.exists(), "the link's target was created");
        assert!(
            run.join(LOCK_FILE).is_symlink(),
            "the link is the user's to remove"
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_lock_that_is_a_folder_is_refused() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join(LOCK_FILE)).unwrap();
        let m = RunLock::acquire(d.path(), "resume")
            .unwrap_err()
            .to_string();
        assert!(m.contains("a folder"), "{m}");
    }
}
