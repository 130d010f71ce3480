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
    match try_lock(&mut file, path, mode) {
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
    *HELD
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .entry(path.to_path_buf())
        .or_insert(0) += 1;
    Ok(ResultsLock {
        _file: file,
        path: path.to_path_buf(),
    })
}

/// One attempt at the lock, retried for up to [`OWN_RETRY`] while the holder recorded is this
/// very process although no lock of this process on `path` is alive. A lock released by this
/// process can stay held for a moment: a child that another thread of this process is starting
/// (e.g. `git rev-parse` at the end of a run) holds copies of every open file from its fork
/// until its exec closes them, and a `flock` lives as long as any copy. A library that runs
/// twice in one process (the test suite does, in parallel threads) would otherwise see its own
/// finished run as a live holder. A live lock of this process ([`HELD`]) is refused at once,
/// like any other holder.
fn try_lock(file: &mut File, path: &Path, mode: LockMode) -> Result<(), TryLockError> {
    let own = format!(
        "pid {} on host {} ",
        std::process::id(),
        store::fsutil::host_name()
    );
    let start = std::time::Instant::now();
    loop {
        let attempt = match mode {
            LockMode::Exclusive => file.try_lock(),
            LockMode::Shared => file.try_lock_shared(),
        };
        match attempt {
            Err(TryLockError::WouldBlock)
                if start.elapsed() < OWN_RETRY
                    && !held_here(path)
                    && holder_text(file).contains(&own) =>
            {
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
            other => return other,
        }
    }
}

/// How long a lock recorded as held by this very process is retried (see [`try_lock`]): far
/// longer than a fork-to-exec window, far shorter than any run.
const OWN_RETRY: std::time::Duration = std::time::Duration::from_secs(2);

/// The lock files this process holds a live [`ResultsLock`] on, with how many (shared locks
/// may be taken more than once). Process-wide state, needed only to tell a live lock of this
/// process from a released one whose open file lingers in a starting child (see [`try_lock`]).
static HELD: std::sync::Mutex<std::collections::BTreeMap<PathBuf, usize>> =
    std::sync::Mutex::new(std::collections::BTreeMap::new());

fn held_here(path: &Path) -> bool {
    HELD.lock()
        .unwrap_or_else(|e| e.into_inner())
        .contains_key(path)
}

impl Drop for ResultsLock {
    fn drop(&mut self) {
        let mut held = HELD.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(n) = held.get_mut(&self.path) {
            *n -= 1;
            if *n == 0 {
                held.remove(&self.path);
            }
        }
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_released_lock_whose_file_lingers_in_a_copy_is_taken_after_the_copy_closes() {
        // the copy plays the child between fork and exec: it keeps the flock alive after this
        // process dropped its lock
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("results/.lock");
        let first = acquire(&path, LockMode::Exclusive, false, "first").unwrap();
        let copy = first._file.try_clone().unwrap();
        drop(first);
        let closer = std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_millis(200));
            drop(copy);
        });
        let second = acquire(&path, LockMode::Exclusive, false, "second");
        closer.join().unwrap();
        assert!(second.is_ok(), "{:#}", second.unwrap_err());
    }

    #[test]
    fn a_live_lock_of_this_process_is_refused_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("results/.lock");
        let _first = acquire(&path, LockMode::Exclusive, false, "first").unwrap();
        let t0 = std::time::Instant::now();
        let err = acquire(&path, LockMode::Exclusive, false, "second").unwrap_err();
        assert!(t0.elapsed() < OWN_RETRY / 4, "{:?}", t0.elapsed());
        assert!(format!("{err:#}").contains("locked by another saddleflow process"));
    }
}
