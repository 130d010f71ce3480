//! Small file-system helpers: atomic publication of plain files, directory fsync, UTC time and
//! host name, shared by the HDF5 writer and by stages that publish side outputs (figures, CSV).

use anyhow::{Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// A temporary path in the same folder as `final_path`, unique in this process and across
/// processes: `.<file name>.tmp-<pid>-<counter>`. Same folder, so the final `rename` is atomic.
/// Names starting with `.` and containing `.tmp-` are what [`is_temp_name`] recognises.
pub fn temp_path_for(final_path: &Path) -> Result<PathBuf> {
    let name = final_path
        .file_name()
        .with_context(|| format!("`{}` has no file name", final_path.display()))?
        .to_string_lossy();
    let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp = format!(".{name}.tmp-{}-{n}", std::process::id());
    Ok(final_path.with_file_name(tmp))
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

/// fsyncs `tmp`, renames it to `final_path` and fsyncs the folder.
pub fn commit_rename(tmp: &Path, final_path: &Path) -> Result<()> {
    std::fs::File::open(tmp)
        .and_then(|f| f.sync_all())
        .with_context(|| format!("cannot fsync `{}`", tmp.display()))?;
    std::fs::rename(tmp, final_path).with_context(|| {
        format!(
            "cannot rename `{}` to `{}`",
            tmp.display(),
            final_path.display()
        )
    })?;
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
        let _ = std::fs::remove_file(&tmp);
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
}
