//! The lock of a run folder: one `loomlab run` at a time writes into an `--out` folder.
//!
//! The lock is `flock(2)` on the file [`LOCK_FILE`] inside the folder, taken before anything in the
//! folder is read or changed and held until the run has written its last file (the report and the
//! page included). The file holds the holder's process id, for the refusal message. The kernel
//! drops a `flock` when its process dies (even by `kill -9`), so a lock file left by a dead run is
//! simply taken over. The holder deletes the file while it still holds the lock; a process that
//! opened the file before that and locks it afterwards sees that the path no longer names the file
//! it locked and tries again, so two runs never both believe they hold the folder.
//!
//! The lock file is not a run file: it is never listed in `written.txt` and never makes a folder
//! count as holding a run.

use std::io::{Read as _, Seek as _, Write as _};
use std::os::fd::AsRawFd as _;
use std::os::unix::fs::{MetadataExt as _, OpenOptionsExt as _};
use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};

/// The lock file's name inside the run folder.
pub const LOCK_FILE: &str = ".loomlab-run.lock";

/// How often a lock whose file was replaced while it was taken is tried again before giving up.
const ATTEMPTS: usize = 50;

/// An exclusive lock on a run folder, released (and its file deleted) when dropped.
#[derive(Debug)]
pub struct RunLock {
    path: PathBuf,
    file: std::fs::File,
}

impl RunLock {
    /// Takes the lock of the folder `dir` (which exists), or refuses (bad input, exit 2) naming the
    /// folder and the process that holds it.
    pub fn acquire(dir: &Path) -> anyhow::Result<Self> {
        let path = dir.join(LOCK_FILE);
        for _ in 0..ATTEMPTS {
            let mut file = match std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .mode(0o644)
                .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
                .open(&path)
            {
                Ok(f) => f,
                Err(e) if e.raw_os_error() == Some(libc::ELOOP) => bail!(
                    "{}: a symbolic link where loomlab run keeps the lock of {}; it never writes through a link \
                     (nothing was changed). Remove the link, or use another --out",
                    path.display(),
                    dir.display()
                ),
                Err(e) => {
                    return Err(anyhow::Error::new(e).context(super::run_dir::CannotWrite(format!(
                        "cannot lock {}: cannot create {} (nothing was changed)",
                        dir.display(),
                        path.display()
                    ))));
                }
            };
            // SAFETY: flock on a file descriptor this function owns; no memory is shared.
            if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
                let err = std::io::Error::last_os_error();
                if err.raw_os_error() != Some(libc::EWOULDBLOCK) {
                    bail!("cannot lock {}: {err} (nothing was changed)", path.display());
                }
                let mut text = String::new();
                let _ = file.read_to_string(&mut text);
                let holder = match text.trim().parse::<u32>() {
                    Ok(pid) => format!("process {pid}"),
                    Err(_) => "a process that is just starting".to_string(),
                };
                bail!(
                    "{} is in use by another loomlab run ({holder} holds {}); nothing was changed. Wait for that run \
                     to finish or stop it (then --resume or --overwrite this folder), or use another --out",
                    dir.display(),
                    LOCK_FILE
                );
            }
            // locked: the file must still be the one at the path (not deleted by a holder that
            // released it between our open and our lock)
            let same = match (file.metadata(), std::fs::symlink_metadata(&path)) {
                (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
                _ => false,
            };
            if !same {
                continue;
            }
            let pid = format!("{}\n", std::process::id());
            file.set_len(0)
                .and_then(|()| file.rewind())
                .and_then(|()| file.write_all(pid.as_bytes()))
                .with_context(|| super::run_dir::CannotWrite(format!("cannot write {}", path.display())))?;
            return Ok(Self { path, file });
        }
        bail!(
            "cannot lock {}: its lock file {} kept being replaced (another program is deleting it); nothing was changed",
            dir.display(),
            LOCK_FILE
        )
    }
}

impl Drop for RunLock {
    /// Deletes the lock file while still holding the lock, then releases it (closing the file).
    fn drop(&mut self) {
        let same = match (self.file.metadata(), std::fs::symlink_metadata(&self.path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        };
        if same {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}
