//! Small file-system helpers: atomic publication of plain files, directory fsync, UTC time and
//! host name, shared by the HDF5 writer and by stages that publish side outputs (figures, CSV).
//!
//! The output rule, in one place for every writer: a path may be published over only if it is
//! absent or a regular file. A rename would silently replace a symbolic link, a FIFO, a socket or
//! (as root) a device node with a regular file, so [`commit_rename`] refuses them, and a
//! directory cannot take a file. Paths a user names on the command line are also checked before
//! any work by [`check_output_path`]: their folder must exist (never created silently) and they
//! must not be one of the command's inputs. Every temporary file this process has not yet
//! published or removed is listed, so that an interrupted process can remove them
//! ([`remove_live_temps`]).

use anyhow::{Context, Result, bail};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Temporaries handed out by [`temp_path_for`] and not yet renamed by [`commit_rename`] or
/// removed by [`remove_temp`]. Entries are unique to this process (pid and counter in the name),
/// so removing a listed path that another code path already deleted is harmless.
static LIVE_TEMPS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live_temps() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // a panic while holding the lock leaves a valid Vec: keep using it
    LIVE_TEMPS.lock().unwrap_or_else(|e| e.into_inner())
}

fn forget_temp(tmp: &Path) {
    live_temps().retain(|p| p != tmp);
}

/// Deletes a temporary file (if it exists) and forgets it.
pub fn remove_temp(tmp: &Path) {
    let _ = std::fs::remove_file(tmp);
    forget_temp(tmp);
}

/// Deletes every temporary this process handed out and has not published or removed; returns
/// how many files were deleted. For an interrupted process: what it was writing never appears.
pub fn remove_live_temps() -> usize {
    remove_live_temps_where(|_| true)
}

fn remove_live_temps_where(select: impl Fn(&Path) -> bool) -> usize {
    let mut live = live_temps();
    let (chosen, kept): (Vec<PathBuf>, Vec<PathBuf>) =
        live.drain(..).partition(|p| select(p.as_path()));
    *live = kept;
    drop(live);
    chosen
        .iter()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count()
}

/// What kind of non-regular file `m` describes, in words.
fn kind_name(m: &std::fs::Metadata) -> &'static str {
    let t = m.file_type();
    if t.is_symlink() {
        return "a symbolic link";
    }
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Refuses `path` as a publication target unless it is absent or a regular file (not followed
/// through a symbolic link: the link itself counts).
pub fn require_replaceable(path: &Path) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_file() => Ok(()),
        Ok(m) => bail!(
            "`{}` is {}: refusing to replace it with a file; allowed: an absent path or a \
             regular file",
            path.display(),
            kind_name(&m)
        ),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e).with_context(|| format!("cannot inspect `{}`", path.display())),
    }
}

/// Whether two paths name the same existing file (same device and inode on Unix, same
/// canonical path elsewhere).
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    matches!(
        (std::fs::canonicalize(a), std::fs::canonicalize(b)),
        (Ok(x), Ok(y)) if x == y
    )
}

/// Checks a user-named output path before any work: it has a file name, its folder exists and is
/// a directory (outputs never create folders), it is absent or a regular file (see
/// [`require_replaceable`]), and it is none of `inputs` (same file: same inode, through links
/// too). `what` names the option in errors (`--out`).
pub fn check_output_path(what: &str, path: &Path, inputs: &[(&str, &Path)]) -> Result<()> {
    let shown = path.display();
    let name = path.file_name().filter(|n| *n != "." && *n != "..");
    if name.is_none() || path.as_os_str().to_string_lossy().ends_with('/') {
        bail!("{what} `{shown}`: not a file name; allowed: a path to a file in an existing folder");
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match std::fs::metadata(parent) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => bail!(
            "{what} `{shown}`: `{}` is not a directory",
            parent.display()
        ),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
            "{what} `{shown}`: folder `{}` does not exist; create it first (outputs never \
             create folders)",
            parent.display()
        ),
        Err(e) => {
            return Err(e).with_context(|| {
                format!("{what} `{shown}`: cannot inspect `{}`", parent.display())
            });
        }
    }
    require_replaceable(path).with_context(|| what.to_string())?;
    for (opt, input) in inputs {
        if same_file(path, input) {
            bail!(
                "{what} `{shown}` is the same file as the input {opt} `{}`: writing it would \
                 destroy the input; choose another output path",
                input.display()
            );
        }
    }
    Ok(())
}

/// A temporary path in the same folder as `final_path`, unique in this process and across
/// processes: `.<file name>.tmp-<pid>-<counter>`. Same folder, so the final `rename` is atomic.
/// Names starting with `.` and containing `.tmp-` are what [`is_temp_name`] recognises.
pub fn temp_path_for(final_path: &Path) -> Result<PathBuf> {
    let name = final_path
        .file_name()
        .with_context(|| format!("`{}` has no file name", final_path.display()))?
        .to_string_lossy();
    let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp = final_path.with_file_name(format!(".{name}.tmp-{}-{n}", std::process::id()));
    live_temps().push(tmp.clone());
    Ok(tmp)
}

/// Whether a file name is one of our temporaries (see [`temp_path_for`]).
pub fn is_temp_name(name: &str) -> bool {
    name.starts_with('.') && name.contains(".tmp-")
}

/// The pid that wrote a temporary (see [`temp_path_for`]), if the name has one.
pub fn temp_owner(name: &str) -> Option<u32> {
    let rest = &name[name.rfind(".tmp-")? + 5..];
    rest.split('-').next()?.parse().ok()
}

/// Whether a temporary file is stale: its writer process no longer exists (on Linux, checked
/// in /proc; elsewhere every temporary counts as stale, so call this only under the results
/// lock).
pub fn is_stale_temp(name: &str) -> bool {
    if !is_temp_name(name) {
        return false;
    }
    match temp_owner(name) {
        Some(pid) if Path::new("/proc/self").exists() => {
            pid != std::process::id() && !Path::new("/proc").join(pid.to_string()).exists()
        }
        _ => true,
    }
}

/// Makes the parent folder of `path` (and its ancestors).
pub fn ensure_parent(path: &Path) -> Result<()> {
    if let Some(parent) = path.parent()
        && !parent.as_os_str().is_empty()
    {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create folder `{}`", parent.display()))?;
    }
    Ok(())
}

/// fsyncs a folder so that a rename inside it survives a crash. Best effort on platforms where
/// folders cannot be opened.
pub fn sync_dir(dir: &Path) -> Result<()> {
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    match std::fs::File::open(dir) {
        Ok(f) => f
            .sync_all()
            .or_else(|e| if cfg!(unix) { Err(e) } else { Ok(()) })
            .with_context(|| format!("cannot fsync folder `{}`", dir.display())),
        Err(_) if !cfg!(unix) => Ok(()),
        Err(e) => Err(e).with_context(|| format!("cannot open folder `{}`", dir.display())),
    }
}

/// fsyncs `tmp`, renames it to `final_path` and fsyncs the folder. Refuses a `final_path` that
/// exists and is not a regular file (see [`require_replaceable`]). If the rename does not
/// happen, `tmp` is deleted: no failure leaves a temporary behind.
pub fn commit_rename(tmp: &Path, final_path: &Path) -> Result<()> {
    let renamed = require_replaceable(final_path)
        .and_then(|()| {
            std::fs::File::open(tmp)
                .and_then(|f| f.sync_all())
                .with_context(|| format!("cannot fsync `{}`", tmp.display()))
        })
        .and_then(|()| {
            std::fs::rename(tmp, final_path).with_context(|| {
                format!(
                    "cannot rename `{}` to `{}`",
                    tmp.display(),
                    final_path.display()
                )
            })
        });
    if renamed.is_err() {
        remove_temp(tmp);
        return renamed;
    }
    forget_temp(tmp);
    sync_dir(final_path.parent().unwrap_or(Path::new(".")))
}

/// Writes `bytes` to `path` atomically: a temporary file in the same folder, fsync, rename,
/// fsync of the folder. A reader sees the old file or the new one, never a mix.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    ensure_parent(path)?;
    let tmp = temp_path_for(path)?;
    let result = (|| -> Result<()> {
        let mut f = std::fs::File::create(&tmp)
            .with_context(|| format!("cannot create `{}`", tmp.display()))?;
        f.write_all(bytes)
            .with_context(|| format!("cannot write `{}`", tmp.display()))?;
        drop(f);
        commit_rename(&tmp, path)
    })();
    if result.is_err() {
        remove_temp(&tmp);
    }
    result
}

/// Copies `src` to `dst` atomically (see [`write_atomic`]).
pub fn copy_atomic(src: &Path, dst: &Path) -> Result<()> {
    let bytes = std::fs::read(src).with_context(|| format!("cannot read `{}`", src.display()))?;
    write_atomic(dst, &bytes)
}

/// The current time in UTC as ISO-8601 with seconds: `2026-11-05T14:03:27Z`.
pub fn utc_now_iso8601() -> String {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    utc_iso8601(secs)
}

/// Formats seconds since the Unix epoch as ISO-8601 UTC (proleptic Gregorian calendar).
pub fn utc_iso8601(secs: i64) -> String {
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        (rem / 60) % 60,
        rem % 60
    )
}

/// Days since 1970-01-01 to (year, month, day); Howard Hinnant's algorithm.
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

/// This machine's host name (from the kernel, then `$HOSTNAME`), or `unknown`.
pub fn host_name() -> String {
    for path in ["/proc/sys/kernel/hostname", "/etc/hostname"] {
        if let Ok(s) = std::fs::read_to_string(path) {
            let s = s.trim();
            if !s.is_empty() {
                return s.to_string();
            }
        }
    }
    std::env::var("HOSTNAME")
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temp_names() {
        let t = temp_path_for(Path::new("a/b.h5")).unwrap();
        let name = t.file_name().unwrap().to_string_lossy().into_owned();
        assert!(is_temp_name(&name));
        assert_eq!(temp_owner(&name), Some(std::process::id()));
        assert!(!is_stale_temp(&name), "our own temporaries are not stale");
        assert!(is_stale_temp(".b.h5.tmp-4000000000-0"));
        assert!(!is_temp_name("b.h5"));
    }

    #[test]
    fn iso_dates() {
        assert_eq!(utc_iso8601(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc_iso8601(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(utc_iso8601(1_700_000_000), "2023-11-14T22:13:20Z");
    }

    #[test]
    fn atomic_write_replaces() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/a.csv");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(dir.path().join("sub")).unwrap().collect();
        assert_eq!(names.len(), 1);
    }

    fn temps_in(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| is_temp_name(n))
            .collect()
    }

    #[test]
    fn refuses_non_regular_files_as_out() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let target = d.join("target.h5");
        std::fs::write(&target, b"keep").unwrap();
        let link = d.join("link.h5");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let fifo = d.join("fifo.h5");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        let sub = d.join("sub");
        std::fs::create_dir(&sub).unwrap();
        let mut cases = vec![(link.clone(), "symbolic link"), (sub.clone(), "directory")];
        if made.is_ok_and(|s| s.success()) {
            cases.push((fifo, "FIFO"));
        }
        // a device node of our own (a copy of /dev/null, where mknod is allowed: as root), so
        // that a regression replaces nothing outside the temporary folder
        let dev = d.join("null");
        let made = std::process::Command::new("mknod")
            .arg(&dev)
            .args(["c", "1", "3"])
            .status();
        if made.is_ok_and(|s| s.success()) {
            cases.push((dev, "device"));
        }
        let e = format!(
            "{:#}",
            require_replaceable(Path::new("/dev/null")).unwrap_err()
        );
        assert!(e.contains("device"), "{e}");
        for (p, kind) in cases {
            let e = format!("{:#}", check_output_path("--out", &p, &[]).unwrap_err());
            assert!(e.contains("--out") && e.contains(kind), "{e}");
            // the last line of defence, at publication, refuses the same and leaves no temporary
            let e = format!("{:#}", write_atomic(&p, b"new").unwrap_err());
            assert!(e.contains(kind), "{e}");
            assert!(temps_in(p.parent().unwrap()).is_empty());
        }
        assert_eq!(
            std::fs::read(&target).unwrap(),
            b"keep",
            "the link's target is intact"
        );
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        // a regular file and an absent path are fine
        check_output_path("--out", &target, &[]).unwrap();
        check_output_path("--out", &d.join("new.h5"), &[]).unwrap();
    }

    #[test]
    fn refuses_input_as_out() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let input = d.join("in.h5");
        std::fs::write(&input, b"data").unwrap();
        let hard = d.join("hard.h5");
        std::fs::hard_link(&input, &hard).unwrap();
        let alias_dir = d.join("alias");
        std::os::unix::fs::symlink(d, &alias_dir).unwrap();
        for out in [
            input.clone(),
            hard,
            alias_dir.join("in.h5"),
            d.join(".").join("in.h5"),
        ] {
            let e = check_output_path("--fields", &out, &[("--gap", &input)]).unwrap_err();
            let e = format!("{e:#}");
            assert!(e.contains("same file as the input --gap"), "{e}");
        }
        check_output_path("--fields", &d.join("other.h5"), &[("--gap", &input)]).unwrap();
    }

    #[test]
    fn refuses_missing_folder_for_out() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("no/such/dir/x.h5");
        let e = format!("{:#}", check_output_path("--out", &p, &[]).unwrap_err());
        assert!(
            e.contains("no/such/dir") && e.contains("does not exist"),
            "{e}"
        );
        assert!(!dir.path().join("no").exists(), "nothing was created");
        let e = format!(
            "{:#}",
            check_output_path("--out", &dir.path().join("x/"), &[]).unwrap_err()
        );
        assert!(e.contains("not a file name"), "{e}");
    }

    #[test]
    fn failed_rename_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("taken");
        std::fs::create_dir(&target).unwrap();
        let tmp = temp_path_for(&target).unwrap();
        std::fs::write(&tmp, b"x").unwrap();
        assert!(commit_rename(&tmp, &target).is_err());
        assert!(temps_in(dir.path()).is_empty());
        assert!(target.is_dir());
    }

    #[test]
    fn live_temps_are_removed_on_request() {
        let dir = tempfile::tempdir().unwrap();
        let a = temp_path_for(&dir.path().join("a.h5")).unwrap();
        let b = temp_path_for(&dir.path().join("b.h5")).unwrap();
        std::fs::write(&a, b"x").unwrap();
        std::fs::write(&b, b"y").unwrap();
        commit_rename(&b, &dir.path().join("b.h5")).unwrap();
        // other tests run in parallel and hold temporaries of their own: remove ours only
        assert_eq!(remove_live_temps_where(|p| p.starts_with(dir.path())), 1);
        assert!(!a.exists());
        assert_eq!(std::fs::read(dir.path().join("b.h5")).unwrap(), b"y");
    }
}
