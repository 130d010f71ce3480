//! CPU time of the bench process, shared by the contact benches.

/// CPU time of the whole process (every thread), seconds. Prefers the nanosecond counters of
/// schedstat; falls back to utime + stime (10 ms ticks).
pub fn cpu_seconds() -> f64 {
    let mut ns = 0u64;
    let mut ok = false;
    if let Ok(dir) = std::fs::read_dir("/proc/self/task") {
        for e in dir.flatten() {
            if let Ok(s) = std::fs::read_to_string(e.path().join("schedstat"))
                && let Some(v) = s
                    .split_whitespace()
                    .next()
                    .and_then(|v| v.parse::<u64>().ok())
            {
                ns += v;
                ok = true;
            }
        }
    }
    if ok {
        return ns as f64 * 1e-9;
    }
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let rest = s.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |k: usize| f.get(k).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}
