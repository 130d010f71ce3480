//! Memory: what is available before a stage starts ([`available_bytes`], [`check_fits`]), and
//! peak resident memory of the process (Linux `/proc`; `None` elsewhere), for the cost of a
//! stage. The peak can be reset (`/proc/self/clear_refs`, Linux ≥ 4.0), so a stage that runs
//! alone in the process gets its own peak; with parallel stages the process peak is an upper
//! bound.

/// Resets the process's peak resident set size to its current size. False if unsupported.
pub fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Peak resident set size of the process in MiB (`VmHWM`), if known.
pub fn peak_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line
        .trim_start_matches("VmHWM:")
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib / 1024.0)
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
