//! The lock on `results/`.
//!
//! `results/.lock` is a small file holding the holder's pid, host, start time and command. The
//! lock itself is an OS advisory lock (`flock` on Unix, via `std::fs::File::lock`) on that file:
//! it belongs to the open file and dies with the process, so a killed or crashed run never
//! leaves a lock that blocks. The file's text is only information; an old text left behind is
//! harmless and is overwritten by the next holder.
//!
//! Modes: `run` and `gc` take it exclusively; `run-stage` takes it shared, so that many
//! `run-stage` processes (e.g. cluster jobs) may run at once while no `run` or `gc` does;
//! `status`, `graph` and `--dry-run` take none.
//!
//! Clearing a "stale" lock is never needed: if `saddleflow` reports the results folder as locked,
//! a live process holds it (its pid and host are named). Stop that process (`kill PID`) or wait
//! for it (`--wait`). Do not delete `results/.lock` while a holder runs: a new run would lock a
//! new file and both would write. Deleting it when no saddleflow process runs is safe and
//! unnecessary. On network file systems without working `flock`, run one pipeline at a time.

use anyhow::{Context, Result, bail};
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Exclusive or shared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LockMode {
    /// `run`, `gc`.
    Exclusive,
    /// `run-stage`.
    Shared,
}

/// A held lock; released on drop (or when the process dies).
#[derive(Debug)]
pub struct ResultsLock {
    _file: File,
    path: PathBuf,
}

impl ResultsLock {
    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Takes the lock on `results/`. Without `wait`, a lock held by another process is an error
/// naming the holder; with `wait`, blocks until it is free (printing who it waits for).
pub fn acquire(path: &Path, mode: LockMode, wait: bool, command: &str) -> Result<ResultsLock> {
    store::fsutil::ensure_parent(path)?;
    let mut file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(path)
        .with_context(|| format!("cannot open lock file `{}`", path.display()))?;
    let attempt = match mode {
        LockMode::Exclusive => file.try_lock(),
        LockMode::Shared => file.try_lock_shared(),
    };
    match attempt {
        Ok(()) => {}
        Err(TryLockError::WouldBlock) => {
            let holder = holder_text(&mut file);
            if !wait {
                bail!(
                    "the results folder is locked by another saddleflow process: {holder}.\n\
                     Wait for it to finish (or pass --wait), or stop it. The lock is an OS lock that \
                     dies with its process, so it is never stale; do not delete `{}` while that process runs.",
                    path.display()
                );
            }
            eprintln!("waiting for the lock on the results folder, held by {holder} ...");
            match mode {
                LockMode::Exclusive => file.lock(),
                LockMode::Shared => file.lock_shared(),
            }
            .with_context(|| format!("cannot lock `{}`", path.display()))?;
        }
        Err(TryLockError::Error(e)) => {
            return Err(e).with_context(|| {
                format!(
                    "cannot lock `{}` (does this file system support advisory locks?)",
                    path.display()
                )
            });
        }
    }
    {
        let text = format!(
            "{}pid {} on host {} since {}: {}\n",
            if mode == LockMode::Shared {
                "(shared with other run-stage processes) "
            } else {
                ""
            },
            std::process::id(),
            store::fsutil::host_name(),
            store::fsutil::utc_now_iso8601(),
            command
        );
        let _ = file.set_len(0);
        let _ = file.seek(SeekFrom::Start(0));
        let _ = file.write_all(text.as_bytes());
        let _ = file.flush();
    }
    Ok(ResultsLock {
        _file: file,
        path: path.to_path_buf(),
    })
}

fn holder_text(file: &mut File) -> String {
    let mut s = String::new();
    let _ = file.seek(SeekFrom::Start(0));
    let _ = file.read_to_string(&mut s);
    let s = s.trim();
    if s.is_empty() {
        "a process that recorded no details (a `run-stage` holds it shared)".into()
    } else {
        s.to_string()
    }
}
