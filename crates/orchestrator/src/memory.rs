//! Peak resident memory of the process (Linux `/proc`; `None` elsewhere), for the cost of a
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

#[cfg(test)]
mod tests {
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
