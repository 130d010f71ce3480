//! How much time this process spends hashing, so that the cost of a cache that cannot lie is
//! measured rather than estimated.
//!
//! Three purposes are counted apart: content digests computed at publication
//! ([`Purpose::Publish`]), content digests recomputed to verify a cache entry
//! ([`Purpose::Verify`]), and plain files hashed (side outputs compared with their cached copy,
//! the output manifest; [`Purpose::File`]). Each counts calls, bytes fed to BLAKE3 and
//! nanoseconds, summed over threads: with stages in parallel the total is CPU-time-like and is
//! compared with the summed stage time, not with the wall time. The time covers the whole
//! digest, including HDF5 reading the values back, which dominates (BLAKE3 itself runs at
//! GB/s).

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// What a hash was computed for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Purpose {
    /// An artefact's content digest at publication.
    Publish = 0,
    /// A cache entry's content digest recomputed to verify it.
    Verify = 1,
    /// A plain file (side output, manifest).
    File = 2,
}

struct Counter {
    calls: AtomicU64,
    bytes: AtomicU64,
    ns: AtomicU64,
}

static COUNTERS: [Counter; 3] = [const {
    Counter {
        calls: AtomicU64::new(0),
        bytes: AtomicU64::new(0),
        ns: AtomicU64::new(0),
    }
}; 3];

/// Calls, bytes and seconds of one purpose.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tally {
    /// Hashes computed.
    pub calls: u64,
    /// Bytes fed to BLAKE3.
    pub bytes: u64,
    /// Seconds (summed over threads).
    pub seconds: f64,
}

impl Tally {
    fn since(&self, earlier: &Tally) -> Tally {
        Tally {
            calls: self.calls.saturating_sub(earlier.calls),
            bytes: self.bytes.saturating_sub(earlier.bytes),
            seconds: (self.seconds - earlier.seconds).max(0.0),
        }
    }
}

/// The hashing done by this process (or, from [`HashStats::since`], during a part of it).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HashStats {
    /// Content digests at publication.
    pub publish: Tally,
    /// Content digests recomputed to verify cache entries.
    pub verify: Tally,
    /// Plain files hashed.
    pub file: Tally,
}

impl HashStats {
    /// The totals so far.
    pub fn now() -> Self {
        let t = |p: Purpose| {
            let c = &COUNTERS[p as usize];
            Tally {
                calls: c.calls.load(Ordering::Relaxed),
                bytes: c.bytes.load(Ordering::Relaxed),
                seconds: c.ns.load(Ordering::Relaxed) as f64 * 1e-9,
            }
        };
        Self {
            publish: t(Purpose::Publish),
            verify: t(Purpose::Verify),
            file: t(Purpose::File),
        }
    }
    /// What was hashed since `earlier` (a value of [`now`](Self::now)).
    pub fn since(&self, earlier: &HashStats) -> Self {
        Self {
            publish: self.publish.since(&earlier.publish),
            verify: self.verify.since(&earlier.verify),
            file: self.file.since(&earlier.file),
        }
    }
    /// Seconds of all purposes.
    pub fn seconds(&self) -> f64 {
        self.publish.seconds + self.verify.seconds + self.file.seconds
    }
    /// Bytes of all purposes.
    pub fn bytes(&self) -> u64 {
        self.publish.bytes + self.verify.bytes + self.file.bytes
    }
    /// Hashes of all purposes.
    pub fn calls(&self) -> u64 {
        self.publish.calls + self.verify.calls + self.file.calls
    }
}

/// Measures one hash: call [`Timer::done`] with the bytes hashed (a timer dropped without it
/// counts nothing: a failed hash is not a cost of verification worth reporting).
pub struct Timer {
    purpose: Purpose,
    start: Instant,
}

impl Timer {
    /// Starts timing a hash for `purpose`.
    pub fn start(purpose: Purpose) -> Self {
        Self {
            purpose,
            start: Instant::now(),
        }
    }
    /// Counts the hash.
    pub fn done(self, bytes: u64) {
        let c = &COUNTERS[self.purpose as usize];
        c.calls.fetch_add(1, Ordering::Relaxed);
        c.bytes.fetch_add(bytes, Ordering::Relaxed);
        c.ns.fetch_add(self.start.elapsed().as_nanos() as u64, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hash_is_counted_under_its_purpose() {
        let before = HashStats::now();
        let t = Timer::start(Purpose::File);
        std::thread::sleep(std::time::Duration::from_millis(2));
        t.done(1000);
        Timer::start(Purpose::Verify); // dropped: not counted
        let d = HashStats::now().since(&before);
        // other tests of this crate may hash meanwhile, so only lower bounds are exact
        assert!(d.file.calls >= 1 && d.file.bytes >= 1000, "{d:?}");
        assert!(d.file.seconds >= 0.002, "{d:?}");
        assert!(d.seconds() >= d.file.seconds && d.bytes() >= 1000);
    }
}
