//! The runner's event log: one JSON object per line in `results/runs/<time>-<pid>.jsonl`, and
//! the same events in memory for tests and summaries.

use anyhow::{Context, Result};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

/// How many event logs `results/runs/` keeps.
pub const KEEP_LOGS: usize = 200;

/// Deletes all but the newest `keep` `*.jsonl` files of `dir` (names sort by time).
fn prune(dir: &Path, keep: usize) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let mut logs: Vec<PathBuf> = rd
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "jsonl"))
        .collect();
    if logs.len() <= keep {
        return;
    }
    logs.sort();
    for p in &logs[..logs.len() - keep] {
        let _ = std::fs::remove_file(p);
    }
}

/// What happened to a stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum What {
    /// The run begins.
    RunStarted {
        /// Pipeline file.
        pipeline: String,
        /// Params file.
        params: String,
        /// Parallel stages.
        jobs: usize,
        /// Selected scenes (empty: all).
        only: Vec<String>,
        /// Dry run?
        dry_run: bool,
        /// Host.
        host: String,
        /// Process id.
        pid: u32,
        /// UTC start time.
        utc: String,
    },
    /// The plan's decision for a stage.
    Planned {
        /// `run` or `cached`.
        action: String,
        /// Why it runs (tags: new, forced, params_changed, ...).
        reasons: Vec<String>,
        /// Human-readable reasons.
        why: Vec<String>,
    },
    /// Valid in the cache; nothing to do.
    Cached,
    /// Side outputs rewritten from the cached artefact (they were missing or edited).
    Restored {
        /// The files.
        files: Vec<String>,
    },
    /// Started computing.
    Started,
    /// Submitted to SLURM as a batch job (or, `attempt` 0 with `adopted`, a live job of an
    /// earlier controller awaited instead of a new submission).
    Submitted {
        /// SLURM job id.
        job: String,
        /// The job's stdout and stderr.
        log: String,
        /// Cores asked for.
        cpus: u32,
        /// Memory asked for, MiB.
        mem_mib: u64,
        /// Time limit asked for, minutes.
        time_min: u64,
        /// 0 for the first submission, then 1, 2, ... for retries.
        attempt: u32,
        /// An earlier controller's job, awaited rather than submitted.
        adopted: bool,
    },
    /// Computed and published.
    Ran {
        /// Wall time, seconds.
        wall_s: f64,
        /// Warnings it raised.
        warnings: Vec<String>,
        /// Artefact size, bytes.
        bytes: u64,
        /// Processor time of the stage's thread pool, seconds (local executor on Linux).
        #[serde(skip_serializing_if = "Option::is_none")]
        cpu_s: Option<f64>,
        /// Threads of the stage's pool (local executor).
        #[serde(skip_serializing_if = "Option::is_none")]
        threads: Option<usize>,
    },
    /// Failed; nothing was published.
    Failed {
        /// The error chain.
        error: String,
    },
    /// Information about the run (the executor's set-up, for example).
    Note {
        /// The text.
        text: String,
    },
    /// Not run because an upstream stage failed.
    Skipped {
        /// The failed upstream stage.
        because: String,
    },
    /// The run ends.
    RunFinished {
        /// Stages computed.
        ran: usize,
        /// Stages found in the cache.
        cached: usize,
        /// Stages failed.
        failed: usize,
        /// Stages skipped.
        skipped: usize,
        /// Wall time, seconds.
        wall_s: f64,
        /// Summed compute time of the stages that ran, seconds.
        stage_s: f64,
        /// Hashing done by the run's process.
        hashing: Hashing,
    },
}

/// Time spent hashing during a run (summed over threads), by purpose.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Hashing {
    /// Seconds, all purposes.
    pub seconds: f64,
    /// Bytes fed to BLAKE3, all purposes.
    pub bytes: u64,
    /// Content digests at publication: seconds, count.
    pub publish_s: f64,
    /// (count)
    pub publish_n: u64,
    /// Content digests recomputed to verify cache entries: seconds, count.
    pub verify_s: f64,
    /// (count)
    pub verify_n: u64,
    /// Side-output files hashed: seconds, count.
    pub files_s: f64,
    /// (count)
    pub files_n: u64,
}

/// One event.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Event {
    /// Seconds since the run started.
    pub t_s: f64,
    /// Stage name ("" for run-level events).
    pub stage: String,
    /// Stage kind ("" for run-level events).
    pub kind: String,
    /// Stage key ("" for run-level events).
    pub key: String,
    /// What happened.
    #[serde(flatten)]
    pub what: What,
}

/// Collects events in memory and appends them to a JSON-lines file (flushed per line, so a
/// killed run's log is complete up to the kill).
pub struct EventLog {
    start: Instant,
    events: Mutex<Vec<Event>>,
    file: Mutex<Option<std::fs::File>>,
    path: Option<PathBuf>,
}

impl EventLog {
    /// A log kept in memory only.
    pub fn in_memory() -> Self {
        Self {
            start: Instant::now(),
            events: Mutex::new(Vec::new()),
            file: Mutex::new(None),
            path: None,
        }
    }

    /// A log also written to `<dir>/<UTC time>-<pid>.jsonl`. Only the newest [`KEEP_LOGS`]
    /// logs are kept.
    pub fn to_dir(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create `{}`", dir.display()))?;
        prune(dir, KEEP_LOGS.saturating_sub(1));
        let stamp = store::fsutil::utc_now_iso8601().replace(':', "");
        let path = dir.join(format!("{stamp}-{}.jsonl", std::process::id()));
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .with_context(|| format!("cannot create event log `{}`", path.display()))?;
        Ok(Self {
            file: Mutex::new(Some(file)),
            path: Some(path),
            ..Self::in_memory()
        })
    }

    /// The log file, if any.
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// Seconds since the log started.
    pub fn elapsed(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// Records an event.
    pub fn push(&self, stage: &str, kind: &str, key: &str, what: What) {
        let e = Event {
            t_s: (self.elapsed() * 1e3).round() / 1e3,
            stage: stage.into(),
            kind: kind.into(),
            key: key.into(),
            what,
        };
        if let Ok(mut f) = self.file.lock()
            && let Some(f) = f.as_mut()
            && let Ok(line) = serde_json::to_string(&e)
        {
            let _ = writeln!(f, "{line}");
        }
        if let Ok(mut v) = self.events.lock() {
            v.push(e);
        }
    }

    /// All events so far.
    pub fn events(&self) -> Vec<Event> {
        self.events.lock().map(|v| v.clone()).unwrap_or_default()
    }
}
