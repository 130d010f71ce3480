//! The SLURM executor: the controller keeps the DAG, each stage runs as one batch job
//! (`saddleflow run-stage KEY`), and a stage counts as done only when its artefact is published
//! in the cache.
//!
//! How it works, and why:
//! - **One name per run.** Every job of a run is named `saddleflow-<run id>`, so the status of the
//!   whole run is one `squeue --name` query. The job's comment is `saddleflow:<key>@<root>`, so a
//!   later controller recognises jobs of the same results folder by key.
//! - **Submission when the inputs are published**, never through `--dependency` (which breaks
//!   when a controller restarts and cannot see the cache): the runner hands a stage to
//!   [`Slurm::execute`] only once its upstream stages are published.
//! - **Completion from the cache.** The waiting worker checks its artefact on the shared file
//!   system every [`POLL_FILE`] (a `stat`, no scheduler load); the scheduler is asked once per
//!   round for all of the run's jobs, at most every `poll` seconds (default 5), backing off to 4×
//!   while nothing changes and while the controller does not answer (a slow or restarting
//!   `slurmctld` is tolerated for [`MAX_SILENT_ROUNDS`] rounds). A job that left the queue
//!   without publishing failed; its class (timeout, out of memory, node failure, cancelled,
//!   stage error) comes from the state `squeue --states=all` still shows for `MinJobAge`, else
//!   from `sacct` when accounting is on, else "unknown".
//! - **Retries**: a timeout is resubmitted with twice the time, out of memory with twice the
//!   memory, a node failure as it was, up to `retries` times; a stage error or a cancellation is
//!   final. Independent stages keep going, as with the local executor.
//! - **Resources**: cores from the options (default 1; the job's rayon pool is sized to it); memory
//!   and time from the provenance of earlier artefacts of the same kind (and the same grid
//!   exponent `n` when the stage has one): 1.5 × the largest peak memory + 256 MiB, 3 × the
//!   longest wall time + 1 min; otherwise the stated defaults (2 GiB, 60 min); never less memory
//!   than the kind's lower bound of the peak + 256 MiB. A profile's `[resources.NAME]` (a stage or
//!   a kind) overrides any of the three.
//! - **Interruption**: SIGINT, SIGTERM or SIGHUP of the controller cancels the run's jobs
//!   (`scancel --name`, through [`cancel_active_runs`], which the CLI's signal handler calls) and
//!   ends it by the signal. A controller killed with SIGKILL cancels nothing: its jobs finish
//!   and publish atomically; the next run adopts the live jobs whose comment names one of its
//!   keys and this results folder instead of submitting them again, and finds what they published.
//!
//! The scheduler is behind the [`Scheduler`] trait, so the logic is tested with a fake one; the
//! real one ([`SlurmCli`]) runs `sbatch`, `squeue`, `sacct` and `scancel`.

use crate::events::{EventLog, What};
use crate::plan::PlannedStage;
use crate::progress::Progress;
use crate::runner::{Executed, restore_side_outputs};
use crate::util::short;
use crate::workspace::{EntryState, Workspace, file_size};
use anyhow::{Context, Result, bail};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// How often a waiting stage looks for its published artefact.
pub const POLL_FILE: Duration = Duration::from_millis(100);
/// Rounds without an answer from the scheduler before the run gives up on it.
pub const MAX_SILENT_ROUNDS: u32 = 24;
const COMMENT_PREFIX: &str = "saddleflow:";

/// Resources of one job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Resources {
    /// Cores (`--cpus-per-task`).
    pub cpus: u32,
    /// Memory, MiB (`--mem`).
    pub mem_mib: u64,
    /// Time limit, minutes (`--time`).
    pub time_min: u64,
}

/// What the user chose for the SLURM executor (command line or a profile file).
#[derive(Clone, Debug)]
pub struct SlurmOptions {
    /// `--partition`.
    pub partition: Option<String>,
    /// `--account`.
    pub account: Option<String>,
    /// More `sbatch` arguments, passed as they are.
    pub extra: Vec<String>,
    /// Resubmissions after a timeout, out of memory or node failure.
    pub retries: u32,
    /// Seconds between status rounds (≥ 1).
    pub poll_s: f64,
    /// Resources when no earlier run of the kind is known.
    pub defaults: Resources,
    /// The `saddleflow` binary the jobs run.
    pub program: PathBuf,
    /// Pipeline and params files, absolute.
    pub pipeline: PathBuf,
    /// Params file, absolute.
    pub params: PathBuf,
    /// Resources set by hand for a stage (by name) or a kind; a stage's entry wins over its
    /// kind's, and both over the estimate from earlier runs.
    pub overrides: BTreeMap<String, ResourceOverride>,
}

/// Resources set by hand; what is left `None` keeps the estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResourceOverride {
    /// Cores.
    pub cpus: Option<u32>,
    /// Memory, MiB.
    pub mem_mib: Option<u64>,
    /// Time limit, minutes.
    pub time_min: Option<u64>,
}

impl SlurmOptions {
    /// Defaults around the given binary and files.
    pub fn new(program: PathBuf, pipeline: PathBuf, params: PathBuf) -> Self {
        Self {
            partition: None,
            account: None,
            extra: Vec::new(),
            retries: 1,
            poll_s: 5.0,
            defaults: Resources {
                cpus: 1,
                mem_mib: 2048,
                time_min: 60,
            },
            program,
            pipeline,
            params,
            overrides: BTreeMap::new(),
        }
    }
}

/// One job to submit.
#[derive(Clone, Debug, PartialEq)]
pub struct JobSpec {
    /// Job name (the run's).
    pub name: String,
    /// Comment (`saddleflow:<key>@<root>`).
    pub comment: String,
    /// stdout and stderr.
    pub log: PathBuf,
    /// Working directory.
    pub workdir: PathBuf,
    /// Resources.
    pub resources: Resources,
    /// The command (program and arguments).
    pub command: Vec<String>,
    /// Partition, account, extra arguments.
    pub partition: Option<String>,
    /// Account.
    pub account: Option<String>,
    /// Extra `sbatch` arguments.
    pub extra: Vec<String>,
}

/// A job as the scheduler lists it.
#[derive(Clone, Debug, PartialEq)]
pub struct JobState {
    /// Job id.
    pub id: String,
    /// Job name.
    pub name: String,
    /// State (PENDING, RUNNING, COMPLETED, TIMEOUT, OUT_OF_MEMORY, ...).
    pub state: String,
    /// Comment.
    pub comment: String,
}

impl JobState {
    /// Still queued or running.
    pub fn is_live(&self) -> bool {
        matches!(
            self.state.as_str(),
            "PENDING"
                | "RUNNING"
                | "CONFIGURING"
                | "COMPLETING"
                | "REQUEUED"
                | "RESIZING"
                | "SUSPENDED"
                | "STAGE_OUT"
                | "SIGNALING"
        )
    }
}

/// The scheduler's commands.
pub trait Scheduler: Send + Sync {
    /// Submits a job; returns its id.
    fn submit(&self, job: &JobSpec) -> Result<String>;
    /// Jobs with these names, finished ones included while the scheduler keeps them.
    fn jobs_named(&self, names: &[String]) -> Result<Vec<JobState>>;
    /// The user's live jobs whose name starts with `saddleflow-`.
    fn own_live_jobs(&self) -> Result<Vec<JobState>>;
    /// The final state of a job no longer listed (accounting), if known.
    fn final_state(&self, id: &str) -> Option<String>;
    /// Cancels every job with this name.
    fn cancel(&self, name: &str) -> Result<()>;
}

/// The real scheduler: SLURM's command-line tools.
pub struct SlurmCli;

fn output(cmd: &mut Command) -> Result<String> {
    let what = format!("{cmd:?}");
    let out = cmd
        .output()
        .with_context(|| format!("cannot start {what} (is SLURM installed?)"))?;
    if !out.status.success() {
        bail!(
            "{what} failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Parses `squeue -o %i|%j|%T|%k` lines (the comment last: it may contain `|`).
fn parse_squeue(text: &str) -> Vec<JobState> {
    text.lines()
        .filter_map(|l| {
            let mut it = l.trim().splitn(4, '|');
            let id = it.next()?.trim().to_string();
            let name = it.next()?.to_string();
            let state = it.next()?.trim().to_string();
            let comment = it.next().unwrap_or("").to_string();
            (!id.is_empty()).then_some(JobState {
                id,
                name,
                state,
                comment,
            })
        })
        .collect()
}

impl Scheduler for SlurmCli {
    fn submit(&self, job: &JobSpec) -> Result<String> {
        let r = job.resources;
        let mut cmd = Command::new("sbatch");
        cmd.arg("--parsable")
            .arg(format!("--job-name={}", job.name))
            .arg(format!("--comment={}", job.comment))
            .arg(format!("--output={}", job.log.display()))
            .arg(format!("--chdir={}", job.workdir.display()))
            .arg(format!("--cpus-per-task={}", r.cpus))
            .arg(format!("--mem={}M", r.mem_mib))
            .arg(format!("--time={}", r.time_min))
            .arg("--ntasks=1")
            .arg("--export=ALL")
            .env("RAYON_NUM_THREADS", r.cpus.to_string());
        if let Some(p) = &job.partition {
            cmd.arg(format!("--partition={p}"));
        }
        if let Some(a) = &job.account {
            cmd.arg(format!("--account={a}"));
        }
        cmd.args(&job.extra);
        cmd.arg("--wrap").arg(shell_join(&job.command));
        let out = output(&mut cmd)?;
        // --parsable prints "id" or "id;cluster"
        let id = out.trim().split(';').next().unwrap_or("").to_string();
        if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit() || c == '_') {
            bail!("sbatch printed no job id: {out:?}");
        }
        Ok(id)
    }
    fn jobs_named(&self, names: &[String]) -> Result<Vec<JobState>> {
        if names.is_empty() {
            return Ok(Vec::new());
        }
        let text = output(
            Command::new("squeue")
                .args(["--noheader", "--states=all", "--format=%i|%j|%T|%k"])
                .arg(format!("--name={}", names.join(","))),
        )?;
        Ok(parse_squeue(&text))
    }
    fn own_live_jobs(&self) -> Result<Vec<JobState>> {
        let user = std::env::var("USER")
            .or_else(|_| std::env::var("LOGNAME"))
            .unwrap_or_else(|_| "root".into());
        let text = output(Command::new("squeue").args([
            "--noheader",
            "--format=%i|%j|%T|%k",
            &format!("--user={user}"),
        ]))?;
        Ok(parse_squeue(&text)
            .into_iter()
            .filter(|j| j.name.starts_with("saddleflow-") && j.is_live())
            .collect())
    }
    fn final_state(&self, id: &str) -> Option<String> {
        let text = output(Command::new("sacct").args([
            "--noheader",
            "--parsable2",
            "--allocations",
            "--starttime=now-7days",
            "--format=State",
            &format!("--jobs={id}"),
        ]))
        .ok()?;
        let s = text.lines().next()?.split_whitespace().next()?.to_string();
        (!s.is_empty()).then_some(s)
    }
    fn cancel(&self, name: &str) -> Result<()> {
        output(Command::new("scancel").arg(format!("--name={name}"))).map(|_| ())
    }
}

/// Quotes words for `sbatch --wrap` (a `sh -c` line): single quotes, `'` as `'\''`.
pub fn shell_join(words: &[String]) -> String {
    words
        .iter()
        .map(|w| {
            if !w.is_empty()
                && w.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_./=:@,+".contains(c))
            {
                w.clone()
            } else {
                format!("'{}'", w.replace('\'', r"'\''"))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// How a job that did not publish ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FailureClass {
    /// Hit its time limit.
    Timeout,
    /// Killed for exceeding its memory.
    OutOfMemory,
    /// Its node failed.
    NodeFailure,
    /// Cancelled (by a user or an administrator).
    Cancelled,
    /// The stage itself failed (non-zero exit).
    StageError,
    /// The scheduler no longer knows the job and accounting is off.
    Unknown,
}

impl FailureClass {
    /// From a SLURM job state.
    pub fn from_state(state: &str) -> Self {
        match state.split_whitespace().next().unwrap_or("") {
            "TIMEOUT" | "DEADLINE" => Self::Timeout,
            "OUT_OF_MEMORY" => Self::OutOfMemory,
            "NODE_FAIL" | "BOOT_FAIL" => Self::NodeFailure,
            "CANCELLED" | "PREEMPTED" | "REVOKED" => Self::Cancelled,
            "FAILED" | "COMPLETED" => Self::StageError,
            _ => Self::Unknown,
        }
    }
    /// Worth submitting again (with more of what ran out).
    pub fn retryable(self) -> bool {
        matches!(self, Self::Timeout | Self::OutOfMemory | Self::NodeFailure)
    }
    fn describe(self) -> &'static str {
        match self {
            Self::Timeout => "timed out",
            Self::OutOfMemory => "ran out of memory",
            Self::NodeFailure => "lost its node",
            Self::Cancelled => "was cancelled",
            Self::StageError => "failed (stage error)",
            Self::Unknown => "ended without publishing (state unknown: no accounting)",
        }
    }
}

/// What the status rounds know about the run's jobs.
#[derive(Default)]
struct Board {
    /// Names of the jobs to query (this run's, and adopted ones).
    names: BTreeSet<String>,
    /// Job id → its last state; absent while unknown.
    states: BTreeMap<String, String>,
    /// Job ids still awaited (no terminal state seen).
    awaited: BTreeSet<String>,
    /// Rounds in a row without an answer.
    silent_rounds: u32,
    /// The last error of the scheduler.
    last_error: Option<String>,
}

/// A run on SLURM: the controller's side.
pub struct Slurm {
    sched: Arc<dyn Scheduler>,
    opts: SlurmOptions,
    /// `saddleflow-<run id>`.
    pub job_name: String,
    root: PathBuf,
    log_dir: PathBuf,
    board: Mutex<Board>,
    changed: Condvar,
    stop: AtomicBool,
    /// Live jobs of earlier controllers, by stage key.
    adopted: Mutex<BTreeMap<String, JobState>>,
    /// [`earlier_costs`] by (kind, grid exponent): read once per run, not once per stage.
    costs: Mutex<BTreeMap<(String, String), Option<PeakAndWall>>>,
}

impl Slurm {
    /// A controller for one run; `root` is the project root (absolute), logs go to
    /// `results/runs/<run id>/`.
    pub fn new(
        sched: Arc<dyn Scheduler>,
        opts: SlurmOptions,
        ws: &Workspace,
        run_id: &str,
    ) -> Result<Self> {
        let root = std::env::current_dir()
            .context("the current directory")?
            .join(&ws.root);
        let log_dir = root.join(ws.runs_dir()).join(format!("slurm-{run_id}"));
        std::fs::create_dir_all(&log_dir)
            .with_context(|| format!("cannot create `{}`", log_dir.display()))?;
        let mut board = Board::default();
        let job_name = format!("saddleflow-{run_id}");
        board.names.insert(job_name.clone());
        Ok(Self {
            sched,
            opts,
            job_name,
            root,
            log_dir,
            board: Mutex::new(board),
            changed: Condvar::new(),
            stop: AtomicBool::new(false),
            adopted: Mutex::new(BTreeMap::new()),
            costs: Mutex::new(BTreeMap::new()),
        })
    }

    fn comment(&self, key: &str) -> String {
        format!("{COMMENT_PREFIX}{key}@{}", self.root.display())
    }

    /// Finds live jobs of earlier controllers on this results folder for these keys; they are
    /// awaited instead of submitted again. Returns (key, job id) pairs.
    pub fn adopt_live_jobs(&self, keys: &BTreeSet<String>) -> Result<Vec<(String, String)>> {
        let live = self.sched.own_live_jobs()?;
        let mut adopted = self.adopted.lock().unwrap();
        let mut board = self.board.lock().unwrap();
        let mut found = Vec::new();
        for j in live {
            let Some(rest) = j.comment.strip_prefix(COMMENT_PREFIX) else {
                continue;
            };
            let Some((key, root)) = rest.split_once('@') else {
                continue;
            };
            if root != self.root.display().to_string() || !keys.contains(key) {
                continue;
            }
            board.names.insert(j.name.clone());
            found.push((key.to_string(), j.id.clone()));
            adopted.insert(key.to_string(), j);
        }
        Ok(found)
    }

    /// Resources for a stage: set by hand for the stage or its kind, else estimated from
    /// earlier artefacts of its kind, else the defaults.
    pub fn resources(&self, ws: &Workspace, s: &PlannedStage) -> Resources {
        let mut r = self.opts.defaults;
        let group = (
            s.kind.clone(),
            s.params
                .0
                .get("n")
                .map(|v| v.to_string())
                .unwrap_or_default(),
        );
        let costs = *self
            .costs
            .lock()
            .unwrap()
            .entry(group)
            .or_insert_with(|| earlier_costs(ws, s));
        if let Some((peak_mib, wall_s)) = costs {
            r.mem_mib = ((peak_mib * 1.5) as u64 + 256).max(256);
            r.time_min = ((wall_s * 3.0 + 60.0) / 60.0).ceil().max(1.0) as u64;
        }
        // the kind's lower bound of the peak (the job's own pre-flight refuses less)
        if let Some(bytes) = s.memory {
            r.mem_mib = r.mem_mib.max((bytes >> 20) + 256);
        }
        for o in [
            self.opts.overrides.get(&s.kind),
            self.opts.overrides.get(&s.name),
        ]
        .into_iter()
        .flatten()
        {
            r.cpus = o.cpus.unwrap_or(r.cpus);
            r.mem_mib = o.mem_mib.unwrap_or(r.mem_mib);
            r.time_min = o.time_min.unwrap_or(r.time_min);
        }
        r
    }

    /// The status loop: one query per round for all of the run's jobs. Runs until
    /// [`Slurm::shutdown`].
    pub fn monitor(&self) {
        let base = Duration::from_secs_f64(self.opts.poll_s.max(0.01));
        let mut interval = base;
        while !self.stop.load(Ordering::Relaxed) {
            self.sleep_unless_stopped(interval);
            // a round judges only the jobs awaited when its query starts: one submitted while
            // the query runs is absent from its answer without having ended
            let (names, asked): (Vec<String>, BTreeSet<String>) = {
                let b = self.board.lock().unwrap();
                if b.awaited.is_empty() {
                    continue;
                }
                (b.names.iter().cloned().collect(), b.awaited.clone())
            };
            let answer = self.sched.jobs_named(&names);
            let mut b = self.board.lock().unwrap();
            match answer {
                Ok(jobs) => {
                    b.silent_rounds = 0;
                    let mut changed = false;
                    let listed: BTreeMap<&str, &JobState> =
                        jobs.iter().map(|j| (j.id.as_str(), j)).collect();
                    let judged: Vec<String> = asked.intersection(&b.awaited).cloned().collect();
                    for id in judged {
                        let state = match listed.get(id.as_str()) {
                            Some(j) => j.state.clone(),
                            None => self
                                .sched
                                .final_state(&id)
                                .unwrap_or_else(|| "GONE".to_string()),
                        };
                        if b.states.get(&id) != Some(&state) {
                            changed = true;
                        }
                        b.states.insert(id.clone(), state.clone());
                        let live = JobState {
                            id: id.clone(),
                            name: String::new(),
                            state,
                            comment: String::new(),
                        }
                        .is_live();
                        if !live {
                            b.awaited.remove(&id);
                        }
                    }
                    interval = if changed {
                        base
                    } else {
                        (interval * 3 / 2).min(base * 4)
                    };
                }
                Err(e) => {
                    b.silent_rounds += 1;
                    b.last_error = Some(format!("{e:#}"));
                    interval = (interval * 2).min(base * 4);
                }
            }
            drop(b);
            self.changed.notify_all();
        }
    }

    fn sleep_unless_stopped(&self, d: Duration) {
        let t = Instant::now();
        while t.elapsed() < d && !self.stop.load(Ordering::Relaxed) {
            std::thread::sleep(POLL_FILE.min(d));
        }
    }

    /// Ends the status loop.
    pub fn shutdown(&self) {
        self.stop.store(true, Ordering::Relaxed);
        self.changed.notify_all();
    }

    /// Cancels every job of this run and of the jobs it adopted.
    pub fn cancel_all(&self) -> Result<()> {
        let names: Vec<String> = self.board.lock().unwrap().names.iter().cloned().collect();
        for n in names {
            self.sched.cancel(&n)?;
        }
        Ok(())
    }

    /// Runs one stage as a job (or awaits the adopted job of an earlier controller) until its
    /// artefact is published; retries per the policy. Returns the job ids used (the last one
    /// first) on success; an error names the job id, the failure class and the log's tail.
    pub fn execute(
        &self,
        ws: &Workspace,
        s: &PlannedStage,
        on_submit: &dyn Fn(&str, &Path, Resources, u32, bool),
    ) -> Result<String> {
        if let Some(j) = self.adopted.lock().unwrap().remove(&s.key) {
            self.board.lock().unwrap().awaited.insert(j.id.clone());
            let log = self.log_dir.join(format!("{}.log", s.name));
            on_submit(&j.id, &log, self.opts.defaults, 0, true);
            match self.await_job(ws, s, &j.id)? {
                None => return Ok(j.id),
                Some(class) => {
                    if !class.retryable() {
                        bail!(
                            "job {} (adopted from an earlier controller) {}",
                            j.id,
                            class.describe()
                        );
                    }
                }
            }
        }
        let mut res = self.resources(ws, s);
        for attempt in 0..=self.opts.retries {
            let log = self.log_dir.join(format!("{}.{attempt}.log", s.name));
            let spec = self.job_spec(s, res, &log);
            let id = self
                .sched
                .submit(&spec)
                .with_context(|| format!("cannot submit stage `{}`", s.name))?;
            self.board.lock().unwrap().awaited.insert(id.clone());
            on_submit(&id, &log, res, attempt, false);
            let Some(class) = self.await_job(ws, s, &id)? else {
                return Ok(id);
            };
            let tail = log_tail(&log, 15);
            if !class.retryable() || attempt == self.opts.retries {
                bail!(
                    "job {id} {} (log {}){}",
                    class.describe(),
                    log.display(),
                    if tail.is_empty() {
                        String::new()
                    } else {
                        format!("; last lines:\n{tail}")
                    }
                );
            }
            match class {
                FailureClass::Timeout => res.time_min *= 2,
                FailureClass::OutOfMemory => res.mem_mib *= 2,
                _ => {}
            }
        }
        unreachable!("the loop returns or fails on its last attempt")
    }

    fn job_spec(&self, s: &PlannedStage, res: Resources, log: &Path) -> JobSpec {
        let o = &self.opts;
        JobSpec {
            name: self.job_name.clone(),
            comment: self.comment(&s.key),
            log: log.to_path_buf(),
            workdir: self.root.clone(),
            resources: res,
            command: vec![
                o.program.display().to_string(),
                "run-stage".into(),
                s.key.clone(),
                "--root".into(),
                self.root.display().to_string(),
                "--pipeline".into(),
                o.pipeline.display().to_string(),
                "--params".into(),
                o.params.display().to_string(),
            ],
            partition: o.partition.clone(),
            account: o.account.clone(),
            extra: o.extra.clone(),
        }
    }

    /// Waits until the stage's artefact is published (→ `None`) or its job ends without it
    /// (→ its failure class).
    fn await_job(
        &self,
        ws: &Workspace,
        s: &PlannedStage,
        id: &str,
    ) -> Result<Option<FailureClass>> {
        let artefact = ws.artefact_of(s);
        // the file as last judged invalid (a damaged entry the job will replace): its content
        // is verified again only once its size or time changes, not on every look
        let mut judged: Option<(u64, Option<std::time::SystemTime>)> = None;
        loop {
            let seen = std::fs::metadata(&artefact)
                .ok()
                .map(|m| (m.len(), m.modified().ok()));
            if seen.is_some() && seen != judged {
                if ws.entry_state(s) == EntryState::Valid {
                    self.board.lock().unwrap().awaited.remove(id);
                    return Ok(None);
                }
                judged = seen;
            }
            let b = self.board.lock().unwrap();
            if b.silent_rounds >= MAX_SILENT_ROUNDS {
                bail!(
                    "the scheduler has not answered for {} rounds (last error: {}); job {id} may still run: rerun to adopt it",
                    b.silent_rounds,
                    b.last_error.as_deref().unwrap_or("none")
                );
            }
            if !b.awaited.contains(id) {
                let state = b.states.get(id).cloned().unwrap_or_default();
                drop(b);
                // published in the moment between the job's end and the round?
                if ws.entry_state(s) == EntryState::Valid {
                    return Ok(None);
                }
                return Ok(Some(FailureClass::from_state(&state)));
            }
            if self.stop.load(Ordering::Relaxed) {
                bail!("the controller is stopping");
            }
            let _ = self.changed.wait_timeout(b, POLL_FILE).unwrap();
        }
    }
}

/// Peak memory (MiB) and wall time (s).
type PeakAndWall = (f64, f64);

/// The largest peak memory (MiB) and wall time (s) recorded by earlier artefacts of the stage's
/// kind (with the same grid exponent `n` when the stage has one).
fn earlier_costs(ws: &Workspace, s: &PlannedStage) -> Option<PeakAndWall> {
    let dir = ws.artefact_of(s).parent()?.to_path_buf();
    let n = s.params.0.get("n").cloned();
    let mut best: Option<PeakAndWall> = None;
    for e in std::fs::read_dir(dir).ok()?.flatten() {
        let p = e.path();
        if p.extension().is_none_or(|x| x != "h5") {
            continue;
        }
        let Ok(r) = store::ArtefactReader::open_complete(&p) else {
            continue;
        };
        let Ok(prov) = r.provenance() else { continue };
        if n.is_some() && prov.params.get("n") != n.as_ref() {
            continue;
        }
        let peak = prov
            .stats
            .get("peak_rss_mib")
            .and_then(|v| v.as_f64())
            .unwrap_or(0.0);
        let (bp, bw) = best.unwrap_or((0.0, 0.0));
        best = Some((bp.max(peak), bw.max(prov.wall_s)));
    }
    best.filter(|(p, _)| *p > 0.0)
}

/// The last `n` lines of a log file (empty if unreadable).
pub fn log_tail(path: &Path, n: usize) -> String {
    let Ok(text) = std::fs::read_to_string(path) else {
        return String::new();
    };
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(n)..]
        .iter()
        .map(|l| format!("    {l}"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// A run id: UTC time and the controller's pid (unique per controller on a host).
pub fn new_run_id() -> String {
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    format!("{t}-{}", std::process::id())
}

/// The controllers running in this process, for [`cancel_active_runs`].
static ACTIVE: Mutex<Vec<std::sync::Weak<Slurm>>> = Mutex::new(Vec::new());

/// Cancels the jobs of every SLURM run this process controls; returns their job names. For the
/// program's signal handler (the `saddleflow` CLI calls it on SIGINT, SIGTERM and SIGHUP before
/// ending by the signal): a controller installs no handler of its own, so that one handler
/// decides how the process ends.
pub fn cancel_active_runs() -> Vec<String> {
    let active: Vec<Arc<Slurm>> = ACTIVE
        .lock()
        .map(|v| v.iter().filter_map(std::sync::Weak::upgrade).collect())
        .unwrap_or_default();
    active
        .iter()
        .map(|s| {
            if let Err(e) = s.cancel_all() {
                eprintln!("warning: {e:#}");
            }
            s.job_name.clone()
        })
        .collect()
}

/// A SLURM run's controller: the [`Slurm`] state and its status loop, registered for
/// [`cancel_active_runs`] while it runs.
pub struct Controller {
    /// The run's state.
    pub slurm: Arc<Slurm>,
    monitor: Option<std::thread::JoinHandle<()>>,
}

impl Controller {
    /// Connects to the scheduler (one `squeue` to adopt live jobs of earlier controllers for
    /// `keys`), starts the status loop and the signal handler.
    pub fn start(
        ws: &Workspace,
        opts: &SlurmOptions,
        keys: &BTreeSet<String>,
        log: &EventLog,
        progress: &Progress,
    ) -> Result<Self> {
        let slurm = Arc::new(Slurm::new(
            Arc::new(SlurmCli),
            opts.clone(),
            ws,
            &new_run_id(),
        )?);
        let adopted = slurm
            .adopt_live_jobs(keys)
            .context("cannot reach the SLURM controller")?;
        for (key, id) in &adopted {
            progress.log(&format!(
                "stage {} is already running as job {id} of an earlier run: awaiting it",
                short(key)
            ));
        }
        log.push(
            "",
            "",
            "",
            What::Note {
                text: format!(
                    "SLURM jobs named {}; {} live job(s) of earlier runs adopted",
                    slurm.job_name,
                    adopted.len()
                ),
            },
        );
        if let Ok(mut v) = ACTIVE.lock() {
            v.push(Arc::downgrade(&slurm));
        }
        let s = slurm.clone();
        let monitor = Some(std::thread::spawn(move || s.monitor()));
        Ok(Self { slurm, monitor })
    }

    /// Ends the status loop (the run is over).
    pub fn stop(mut self) {
        if let Ok(mut v) = ACTIVE.lock() {
            v.retain(|w| !std::ptr::eq(w.as_ptr(), Arc::as_ptr(&self.slurm)));
        }
        self.slurm.shutdown();
        if let Some(m) = self.monitor.take() {
            let _ = m.join();
        }
    }
}

/// Runs one stage on SLURM (see [`Slurm::execute`]), logging each submission, then reads what
/// the job published: wall time and warnings from the provenance; restores side outputs.
pub(crate) fn execute_stage(
    c: &Slurm,
    ws: &Workspace,
    s: &PlannedStage,
    log: &EventLog,
) -> Result<Executed> {
    c.execute(ws, s, &|job, path, r, attempt, adopted| {
        log.push(
            &s.name,
            &s.kind,
            &s.key,
            What::Submitted {
                job: job.to_string(),
                log: path.display().to_string(),
                cpus: r.cpus,
                mem_mib: r.mem_mib,
                time_min: r.time_min,
                attempt,
                adopted,
            },
        )
    })?;
    let path = ws.artefact_of(s);
    let prov = store::ArtefactReader::open_complete(&path)
        .and_then(|r| r.provenance())
        .with_context(|| format!("the artefact `{}` its job published", path.display()))?;
    restore_side_outputs(ws, s)?;
    Ok(Executed {
        wall_s: prov.wall_s,
        warnings: prov.warnings,
        bytes: file_size(&path),
        cpu_s: None,
        threads: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squeue_lines_keep_a_comment_with_bars() {
        let j = parse_squeue("12|saddleflow-1|RUNNING|saddleflow:ab@/x|y\n\n13|n|PENDING|\n");
        assert_eq!(j.len(), 2);
        assert_eq!(j[0].comment, "saddleflow:ab@/x|y");
        assert_eq!(j[1].state, "PENDING");
        assert!(j[0].is_live());
    }

    #[test]
    fn states_map_to_failure_classes() {
        assert_eq!(FailureClass::from_state("TIMEOUT"), FailureClass::Timeout);
        assert_eq!(
            FailureClass::from_state("CANCELLED by 0"),
            FailureClass::Cancelled
        );
        assert_eq!(
            FailureClass::from_state("OUT_OF_MEMORY"),
            FailureClass::OutOfMemory
        );
        assert_eq!(FailureClass::from_state("FAILED"), FailureClass::StageError);
        assert_eq!(FailureClass::from_state("GONE"), FailureClass::Unknown);
        assert!(FailureClass::Timeout.retryable());
        assert!(!FailureClass::StageError.retryable());
    }

    #[test]
    fn wrap_lines_quote_what_the_shell_would_split() {
        let w = [
            "a/b".to_string(),
            "x y".into(),
            "it's".into(),
            String::new(),
        ];
        assert_eq!(shell_join(&w), r"a/b 'x y' 'it'\''s' ''");
    }
}
