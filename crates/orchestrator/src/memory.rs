//! Memory: what is available before a stage starts ([`available_bytes`], [`check_fits`]), and
//! peak resident memory of the process (Linux `/proc`; `None` elsewhere), for the cost of a
//! stage. The peak can be reset (`/proc/self/clear_refs`, Linux ≥ 4.0), so a stage that runs
//! alone in the process gets its own peak; with parallel stages the process peak is an upper
//! bound.

/// Resets the process's peak resident set size to its current size. False if unsupported.
pub fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// A `kB` line of `/proc/self/status` in MiB.
fn status_mib(field: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    let kib: f64 = line
        .trim_start_matches(field)
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib / 1024.0)
}

/// Peak resident set size of the process in MiB (`VmHWM`), if known.
pub fn peak_mib() -> Option<f64> {
    status_mib("VmHWM:")
}

/// Resident set size of the process now in MiB (`VmRSS`), if known.
pub fn rss_mib() -> Option<f64> {
    status_mib("VmRSS:")
}

/// The process's address-space limit (soft `RLIMIT_AS`, `ulimit -v`) in bytes, from
/// `/proc/self/limits`; `None` when unlimited or unknown.
pub fn address_space_limit() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    line.trim_start_matches("Max address space")
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// Tries to reserve `need` bytes (`Vec::try_reserve_exact`) and gives them back at once. Under
/// an address-space limit (`RLIMIT_AS`) this fails as the stage's own allocation would, but
/// here as an error instead of an abort: the message names the estimate and the limit. The
/// pages are never touched, so where memory is overcommitted (no such limit; a cgroup limit)
/// it passes and costs nothing; there [`check_fits`] is the guard.
pub fn probe(need: u64) -> Result<(), String> {
    let mut v: Vec<u8> = Vec::new();
    let Ok(n) = usize::try_from(need) else {
        return Err(format!(
            "needs at least {need} bytes, more than this machine can address"
        ));
    };
    if v.try_reserve_exact(n).is_ok() {
        return Ok(());
    }
    let mib = |b: f64| b / (1u64 << 20) as f64;
    let limit = address_space_limit().map_or("unknown".to_string(), |l| {
        format!("{:.0} MiB", mib(l as f64))
    });
    let used = status_mib("VmSize:").map_or(String::new(), |m| format!(", {m:.0} MiB in use"));
    Err(format!(
        "needs at least {:.0} MiB (its kind's lower estimate of the peak), which cannot be allocated: the process's address-space limit (RLIMIT_AS, `ulimit -v`) is {limit}{used}; raise the limit or use a smaller grid",
        mib(need as f64)
    ))
}

/// Memory available to this process now, bytes: `MemAvailable` of `/proc/meminfo`, lowered to
/// the room left under a cgroup v2 limit (`memory.max` − `memory.current`) if one is set.
/// `None` where neither is readable.
pub fn available_bytes() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        let line = s.lines().find(|l| l.starts_with("MemAvailable:"))?;
        let kib: u64 = line
            .trim_start_matches("MemAvailable:")
            .trim()
            .trim_end_matches("kB")
            .trim()
            .parse()
            .ok()?;
        Some(kib * 1024)
    });
    let read = |f: &str| -> Option<u64> {
        std::fs::read_to_string(format!("/sys/fs/cgroup/{f}"))
            .ok()?
            .trim()
            .parse()
            .ok()
    };
    let cgroup =
        read("memory.max").map(|max| max.saturating_sub(read("memory.current").unwrap_or(0)));
    match (meminfo, cgroup) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// The refusal of a stage whose lower memory bound `need` exceeds what is `available`.
pub fn check_fits(need: u64, available: u64) -> Result<(), String> {
    if need <= available {
        return Ok(());
    }
    let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
    Err(format!(
        "needs at least {:.0} MiB (its kind's lower estimate of the peak) but only {:.0} MiB are available (MemAvailable, cgroup limit): use a smaller grid, or free memory",
        mib(need),
        mib(available)
    ))
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_stage_that_cannot_fit_is_refused_with_its_estimate() {
        let e = super::check_fits(3 << 30, 1 << 30).unwrap_err();
        assert!(e.contains("3072 MiB") && e.contains("1024 MiB"), "{e}");
        assert!(super::check_fits(1 << 20, 1 << 30).is_ok());
        if let Some(a) = super::available_bytes() {
            assert!(a > 0);
        }
    }

    #[test]
    fn a_probe_passes_for_little_and_fails_for_the_impossible() {
        assert!(super::probe(1 << 20).is_ok());
        // 2^62 bytes exceed every address space: the reservation fails without aborting
        let e = super::probe(1 << 62).unwrap_err();
        assert!(
            e.contains("4398046511104 MiB") && e.contains("RLIMIT_AS"),
            "{e}"
        );
    }

    #[test]
    fn the_peak_sees_a_large_allocation() {
        let Some(before) = super::peak_mib() else {
            return; // not Linux
        };
        let v = vec![1u8; 64 << 20];
        std::hint::black_box(&v);
        let after = super::peak_mib().unwrap();
        assert!(after >= before.max(64.0), "{before} → {after} MiB");
    }
}
