//! An exclusive lock on a bake's output, so two bakes of one file cannot both run (each would
//! resume from and rewrite the same checkpoint, and both would report success).
//!
//! The lock is `flock` (via [`std::fs::File::try_lock`]) on `OUTPUT.lock`, which holds the
//! holder's PID for the message. `flock` rather than a PID file created with `create_new`:
//! the kernel releases it when the process ends however it ends (kill -9, power loss, a
//! panic), so there are no stale locks to detect and take over, and no PID reuse to get
//! wrong. The file is removed on a normal exit; one left by a killed bake is unlocked and is
//! simply taken by the next bake. Not every network file system honours `flock`.

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

/// The lock file of output `output`: `output` with `.lock` appended.
pub(crate) fn lock_path(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".lock");
    PathBuf::from(s)
}

/// Holds the lock of an output (and so of its checkpoint) until dropped.
#[derive(Debug)]
pub(crate) struct OutputLock {
    path: PathBuf,
    file: File,
}

impl OutputLock {
    /// Takes the lock of `output`, or fails naming the bake that holds it.
    pub fn acquire(output: &Path) -> Result<Self> {
        let path = lock_path(output);
        // A holder that exits between our open and our lock removes the file it locked; the
        // lock we then get is on an unlinked file that a third bake would not see. So after
        // locking, the path must still name the file we hold, or we try again.
        for _ in 0..16 {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .with_context(|| format!("creating the lock file {}", path.display()))?;
            match file.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    let mut holder = String::new();
                    let _ = file.read_to_string(&mut holder);
                    let holder = holder.trim();
                    let holder = if holder.chars().all(|c| c.is_ascii_digit()) && !holder.is_empty()
                    {
                        format!(" (process {holder})")
                    } else {
                        String::new()
                    };
                    bail!(
                        "another bake{holder} is writing {}: it holds {}; wait for it to end \
                         or choose another output",
                        output.display(),
                        path.display()
                    );
                }
                Err(std::fs::TryLockError::Error(e)) => {
                    return Err(e).with_context(|| format!("locking {}", path.display()));
                }
            }
            if !still_named_by(&file, &path) {
                continue;
            }
            file.set_len(0)
                .and_then(|()| file.rewind())
                .and_then(|()| write!(file, "{}", std::process::id()))
                .and_then(|()| file.flush())
                .with_context(|| format!("writing {}", path.display()))?;
            return Ok(Self { path, file });
        }
        bail!("could not lock {}: it keeps being replaced", path.display())
    }
}

/// True when `path` is the file `file` is open on.
fn still_named_by(file: &File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (file.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = (file, path);
        true
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Removed while still locked (the lock goes with the file handle just after), so a
        // waiting bake sees either our locked file or none.
        let _ = std::fs::remove_file(&self.path);
        let _ = self.file.unlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_of_one_output_is_refused_until_the_first_is_dropped() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let out = dir.path().join("a.pvs");
        let first = OutputLock::acquire(&out).expect("first lock");
        let e = OutputLock::acquire(&out).expect_err("second lock");
        let text = format!("{e:#}");
        assert!(text.contains("another bake"), "{text}");
        assert!(
            text.contains(&format!("process {}", std::process::id())),
            "{text}"
        );
        drop(first);
        assert!(!lock_path(&out).exists());
        OutputLock::acquire(&out).expect("lock after release");
    }
}
