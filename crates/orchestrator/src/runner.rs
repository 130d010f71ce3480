//! Running a plan: decide what is cached and why the rest runs, run stages in topological order
//! with up to `jobs` in parallel, publish atomically, log events.

use crate::events::{Event, EventLog, What};
use crate::kind::{Inputs, ProgressSink, StageContext};
use crate::lock::{LockMode, acquire};
use crate::plan::{Plan, PlannedStage};
use crate::progress::{Progress, ProgressMode};
use crate::util::{human_duration, short};
use crate::workspace::{EntryState, Index, Reason, Workspace, file_size};
use anyhow::{Context, Result, anyhow, bail};
use std::collections::{BTreeMap, BTreeSet};
use std::panic::AssertUnwindSafe;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::mpsc;
use std::time::Instant;
use store::{ArtefactWriter, Provenance, SideOutput};

/// Options of [`run`].
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Scenes (or stages) to run with everything upstream; empty: every stage.
    pub only: Vec<String>,
    /// Stages to recompute even if cached.
    pub force: Vec<String>,
    /// Stages run in parallel (≥ 1).
    pub jobs: usize,
    /// Only decide and explain; write nothing.
    pub dry_run: bool,
    /// Wait for the results lock instead of failing.
    pub wait: bool,
    /// Progress display.
    pub progress: ProgressMode,
    /// Write the event log to `results/runs/`.
    pub log_file: bool,
    /// The command line, recorded in the lock file.
    pub command: String,
    /// Where stages run.
    pub executor: Executor,
}

/// Where the stages of a run are computed.
#[derive(Clone, Debug, Default)]
pub enum Executor {
    /// In this process, `jobs` at a time.
    #[default]
    Local,
    /// As SLURM batch jobs, `jobs` at a time ([`crate::slurm`]).
    Slurm(Box<crate::slurm::SlurmOptions>),
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            only: Vec::new(),
            force: Vec::new(),
            jobs: 1,
            dry_run: false,
            wait: false,
            progress: ProgressMode::Auto,
            log_file: true,
            command: "saddleflow run".into(),
            executor: Executor::Local,
        }
    }
}

/// Whether a stage runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Its artefact is valid in the cache.
    Cached,
    /// It must be computed.
    Run,
}

/// The decision for one selected stage.
#[derive(Clone, Debug)]
pub struct Decision {
    /// Index in [`Plan::stages`].
    pub index: usize,
    /// Stage name.
    pub name: String,
    /// Kind.
    pub kind: String,
    /// Key.
    pub key: String,
    /// Cached or run.
    pub action: Action,
    /// Why it runs (empty when cached).
    pub reasons: Vec<Reason>,
}

/// What a run did.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    /// The decisions, in topological order.
    pub decisions: Vec<Decision>,
    /// All events.
    pub events: Vec<Event>,
    /// Stages computed.
    pub ran: Vec<String>,
    /// Stages found in the cache.
    pub cached: Vec<String>,
    /// Stages whose side outputs were restored from the cache.
    pub restored: Vec<String>,
    /// Failed stages: (name, key, error).
    pub failed: Vec<(String, String, String)>,
    /// Skipped stages: (name, failed upstream stage).
    pub skipped: Vec<(String, String)>,
    /// Wall time, seconds.
    pub wall_s: f64,
    /// The event log file, if written.
    pub log: Option<PathBuf>,
    /// Problems that did not fail a stage (e.g. the cache index could not be saved).
    pub warnings: Vec<String>,
    /// Hashing done by this process during the run: content digests at publication and for
    /// verification, side-output files (summed over threads; SLURM jobs hash in their own
    /// processes and are not counted).
    pub hashing: store::HashStats,
    /// Summed compute time of the stages that ran here, seconds (what `hashing` is compared
    /// with).
    pub stage_s: f64,
}

impl RunSummary {
    /// No failure and nothing skipped.
    pub fn ok(&self) -> bool {
        self.failed.is_empty() && self.skipped.is_empty()
    }
}

/// Decides, for the selected stages, which are cached and why the others run.
pub fn decide(
    ws: &Workspace,
    plan: &Plan,
    selected: &[usize],
    force: &[String],
) -> Result<Vec<Decision>> {
    let index = Index::load(ws);
    for f in force {
        let Some(i) = plan.index_of(f) else {
            let names: Vec<&str> = plan.stages.iter().map(|s| s.name.as_str()).collect();
            let hint = crate::util::did_you_mean(f, &names)
                .map(|s| format!("did you mean `{s}`? "))
                .unwrap_or_default();
            bail!(
                "--force {f}: no such stage in {}; {hint}stages: {}",
                plan.pipeline,
                names.join(", ")
            );
        };
        if !selected.contains(&i) {
            bail!("--force {f}: the stage is not part of the selected scenes");
        }
    }
    Ok(selected
        .iter()
        .map(|&i| {
            let s = &plan.stages[i];
            let forced = force.iter().any(|f| f == &s.name);
            let verdict = ws.integrity(s);
            let reasons = index.reasons(plan, s, &verdict, forced);
            Decision {
                index: i,
                name: s.name.clone(),
                kind: s.kind.clone(),
                key: s.key.clone(),
                action: if reasons.is_empty() {
                    Action::Cached
                } else {
                    Action::Run
                },
                reasons,
            }
        })
        .collect())
}

fn planned_event(d: &Decision) -> What {
    What::Planned {
        action: match d.action {
            Action::Cached => "cached".into(),
            Action::Run => "run".into(),
        },
        reasons: d.reasons.iter().map(|r| r.tag().to_string()).collect(),
        why: d.reasons.iter().map(|r| r.to_string()).collect(),
    }
}

/// Runs the selected part of `plan` in `ws`.
pub fn run(ws: &Workspace, plan: &Plan, opts: &RunOptions) -> Result<RunSummary> {
    let hash0 = store::HashStats::now();
    let selected = plan.select(&opts.only)?;
    let jobs = opts.jobs.max(1);
    let _locks = if opts.dry_run {
        Vec::new()
    } else {
        take_run_locks(ws, opts)?
    };
    if !opts.dry_run {
        let all_side: Vec<String> = selected
            .iter()
            .flat_map(|&i| plan.stages[i].side_outputs.clone())
            .collect();
        ws.remove_stale_temps(&all_side);
    }
    let decisions = decide(ws, plan, &selected, &opts.force)?;
    let log = if opts.log_file && !opts.dry_run {
        EventLog::to_dir(&ws.runs_dir())?
    } else {
        EventLog::in_memory()
    };
    log.push(
        "",
        "",
        "",
        What::RunStarted {
            pipeline: plan.pipeline.clone(),
            params: plan.params.clone(),
            jobs,
            only: opts.only.clone(),
            dry_run: opts.dry_run,
            host: store::fsutil::host_name(),
            pid: std::process::id(),
            utc: store::fsutil::utc_now_iso8601(),
        },
    );
    for d in &decisions {
        log.push(&d.name, &d.kind, &d.key, planned_event(d));
    }
    let mut summary = RunSummary {
        log: log.path().map(PathBuf::from),
        ..Default::default()
    };
    if opts.dry_run {
        summary.events = log.events();
        summary.decisions = decisions;
        return Ok(summary);
    }

    for d in &decisions {
        for r in &d.reasons {
            if let Reason::OutputDamaged(why) | Reason::OutputInvalid(why) = r {
                progress_warn_bad_entry(&d.name, why);
            }
        }
    }
    let mut index = Index::load(ws);
    let to_run: Vec<&Decision> = decisions
        .iter()
        .filter(|d| d.action == Action::Run)
        .collect();
    let total_cost: f64 = to_run.iter().map(|d| plan.stages[d.index].cost).sum();
    let progress = Progress::new(opts.progress, to_run.len(), total_cost);

    // cached stages: nothing to compute; restore side outputs that are missing or edited
    let mut index_dirty = settle_cached(
        ws,
        plan,
        &decisions,
        &log,
        &progress,
        &mut index,
        &mut summary,
    );
    if index_dirty {
        save_index(&index, ws, &mut summary.warnings);
        index_dirty = false;
    }

    // stages to run: wait for the inputs that run too
    let mut sched = Schedule::new(plan, &to_run);
    let (tx, rx) = mpsc::channel::<(usize, Result<Executed>)>();
    let started = Instant::now();
    let mut last_index_save = Instant::now();
    let cluster = match &opts.executor {
        Executor::Local => None,
        Executor::Slurm(o) => {
            let keys = to_run.iter().map(|d| d.key.clone()).collect();
            Some(crate::slurm::Controller::start(
                ws, o, &keys, &log, &progress,
            )?)
        }
    };
    let slurm = cluster.as_ref().map(|c| c.slurm.as_ref());

    // the local executor's cores (the global rayon pool's size: one per core, or
    // RAYON_NUM_THREADS), shared out among the stages it runs at once (see `share_cores`)
    let cores = rayon::current_num_threads();
    let mut busy = 0usize;
    let mut held: BTreeMap<usize, usize> = BTreeMap::new();
    let result = std::thread::scope(|scope| -> Result<()> {
        let mut running = 0usize;
        loop {
            while running < jobs {
                let Some(i) = sched.ready.pop_first() else {
                    break;
                };
                let s = &plan.stages[i];
                // this stage and the ready ones that start beside it now
                let starting = 1 + sched.ready.len().min(jobs - running - 1);
                let threads = share_cores(cores, busy, starting);
                busy += threads;
                held.insert(i, threads);
                log.push(&s.name, &s.kind, &s.key, What::Started);
                let sink = progress.started(&s.name, &s.kind, s.cost);
                let tx = tx.clone();
                let ws = ws.clone();
                let log = &log;
                scope.spawn(move || {
                    let r = match slurm {
                        None => execute_local(&ws, plan, s, Some(sink), jobs == 1, threads),
                        Some(c) => crate::slurm::execute_stage(c, &ws, s, log),
                    };
                    let _ = tx.send((i, r));
                });
                running += 1;
            }
            if running == 0 {
                break;
            }
            let (i, result) = rx.recv().map_err(|_| anyhow!("a stage worker vanished"))?;
            running -= 1;
            busy -= held.remove(&i).unwrap_or(0);
            let s = &plan.stages[i];
            match result {
                Ok(x) => {
                    report_ran(s, x, &log, &progress, &mut summary);
                    index.record(plan, s);
                    index_dirty = true;
                    // the index only explains reruns; saving it at most once a second keeps
                    // two fsyncs per stage off the critical path
                    if last_index_save.elapsed().as_secs_f64() >= 1.0 {
                        index_dirty = !save_index(&index, ws, &mut summary.warnings);
                        last_index_save = Instant::now();
                    }
                    sched.done(i);
                }
                Err(e) => report_failed(plan, &mut sched, i, &e, &log, &progress, &mut summary),
            }
        }
        Ok(())
    });
    if let Some(c) = cluster {
        c.stop();
    }
    result?;
    drop(tx);
    progress.finish();
    if index_dirty {
        save_index(&index, ws, &mut summary.warnings);
    }
    record_outputs(ws, plan, &summary);
    ws.save_verified();
    summary.wall_s = started.elapsed().as_secs_f64();
    summary.hashing = store::HashStats::now().since(&hash0);
    log.push("", "", "", finished_event(&summary, log.elapsed()));
    summary.events = log.events();
    summary.decisions = decisions;
    Ok(summary)
}

/// Stages taken from the cache: their log lines and index entries, and side outputs restored
/// where missing or edited (a stage is done only when its declared outputs are in place).
/// Returns whether the index changed.
fn settle_cached(
    ws: &Workspace,
    plan: &Plan,
    decisions: &[Decision],
    log: &EventLog,
    progress: &Progress,
    index: &mut Index,
    summary: &mut RunSummary,
) -> bool {
    let mut index_dirty = false;
    for d in decisions.iter().filter(|d| d.action == Action::Cached) {
        let s = &plan.stages[d.index];
        log.push(&s.name, &s.kind, &s.key, What::Cached);
        summary.cached.push(s.name.clone());
        if index
            .stages
            .get(&Index::slot(plan, &s.name))
            .map(|e| &e.key)
            != Some(&s.key)
        {
            index.record(plan, s);
            index_dirty = true;
        }
        if !s.side_outputs.is_empty() {
            match restore_side_outputs(ws, s) {
                Ok(files) if !files.is_empty() => {
                    progress.log(&format!(
                        "restored {} from the cache of {}",
                        files.join(", "),
                        s.name
                    ));
                    log.push(&s.name, &s.kind, &s.key, What::Restored { files });
                    summary.restored.push(s.name.clone());
                }
                Ok(_) => {}
                Err(e) => {
                    // a stage is done only when its declared outputs are in place
                    let msg = format!(
                        "its declared outputs are not in place and cannot be rewritten from the cached artefact `{}`: {e:#}",
                        ws.artefact_of(s).display()
                    );
                    progress.log(&format!("FAILED {}: {msg}", s.name));
                    log_failure(s, msg, log, summary);
                }
            }
        }
    }
    index_dirty
}

/// The stages a run computes, in dependency order: which are ready, which wait for inputs
/// that run too, and which are blocked by a failure upstream.
struct Schedule {
    run_set: BTreeSet<usize>,
    waiting_on: BTreeMap<usize, BTreeSet<usize>>,
    ready: BTreeSet<usize>,
    blocked: BTreeSet<usize>,
}

impl Schedule {
    fn new(plan: &Plan, to_run: &[&Decision]) -> Schedule {
        let run_set: BTreeSet<usize> = to_run.iter().map(|d| d.index).collect();
        let mut waiting_on: BTreeMap<usize, BTreeSet<usize>> = BTreeMap::new();
        for &i in &run_set {
            let deps: BTreeSet<usize> = plan.stages[i]
                .inputs
                .values()
                .flatten()
                .filter_map(|n| plan.index_of(n))
                .filter(|j| run_set.contains(j))
                .collect();
            waiting_on.insert(i, deps);
        }
        let ready = waiting_on
            .iter()
            .filter(|(_, d)| d.is_empty())
            .map(|(i, _)| *i)
            .collect();
        Schedule {
            run_set,
            waiting_on,
            ready,
            blocked: BTreeSet::new(),
        }
    }

    /// Stage `i` ran: the stages waiting for nothing else become ready.
    fn done(&mut self, i: usize) {
        for (j, deps) in self.waiting_on.iter_mut() {
            if deps.remove(&i) && deps.is_empty() && !self.blocked.contains(j) {
                self.ready.insert(*j);
            }
        }
    }

    /// Stage `i` failed: the stages to run downstream of it are blocked; returns those newly
    /// blocked.
    fn fail(&mut self, plan: &Plan, i: usize) -> Vec<usize> {
        let mut newly = Vec::new();
        for j in plan.downstream(i) {
            if self.run_set.contains(&j) && self.blocked.insert(j) {
                self.ready.remove(&j);
                newly.push(j);
            }
        }
        newly
    }
}

/// A stage that ran: its progress line, log event and summary entry.
fn report_ran(
    s: &PlannedStage,
    x: Executed,
    log: &EventLog,
    progress: &Progress,
    summary: &mut RunSummary,
) {
    progress.finished(
        &s.name,
        s.cost,
        &format!(
            "ran {} ({} {}) in {}{}",
            s.name,
            s.kind,
            short(&s.key),
            human_duration(x.wall_s),
            if x.warnings.is_empty() {
                String::new()
            } else {
                format!("; warnings: {}", x.warnings.join("; "))
            }
        ),
    );
    summary.stage_s += x.wall_s;
    log.push(
        &s.name,
        &s.kind,
        &s.key,
        What::Ran {
            wall_s: x.wall_s,
            warnings: x.warnings,
            bytes: x.bytes,
            cpu_s: x.cpu_s,
            threads: x.threads,
        },
    );
    summary.ran.push(s.name.clone());
}

/// A stage that failed: its progress line, log event and summary entry, and the same for every
/// stage downstream that was to run and is now skipped.
fn report_failed(
    plan: &Plan,
    sched: &mut Schedule,
    i: usize,
    e: &anyhow::Error,
    log: &EventLog,
    progress: &Progress,
    summary: &mut RunSummary,
) {
    let s = &plan.stages[i];
    let msg = format!("{e:#}");
    progress.finished(
        &s.name,
        s.cost,
        &format!("FAILED {} ({} {}): {msg}", s.name, s.kind, short(&s.key)),
    );
    log_failure(s, msg, log, summary);
    for j in sched.fail(plan, i) {
        let d = &plan.stages[j];
        progress.finished(
            &d.name,
            d.cost,
            &format!("skipped {} (upstream {} failed)", d.name, s.name),
        );
        log.push(
            &d.name,
            &d.kind,
            &d.key,
            What::Skipped {
                because: s.name.clone(),
            },
        );
        summary.skipped.push((d.name.clone(), s.name.clone()));
    }
}

/// A failed stage's log event and summary entry.
fn log_failure(s: &PlannedStage, msg: String, log: &EventLog, summary: &mut RunSummary) {
    log.push(
        &s.name,
        &s.kind,
        &s.key,
        What::Failed { error: msg.clone() },
    );
    summary.failed.push((s.name.clone(), s.key.clone(), msg));
}

/// The run's closing event from its summary.
fn finished_event(summary: &RunSummary, wall_s: f64) -> What {
    let h = &summary.hashing;
    What::RunFinished {
        ran: summary.ran.len(),
        cached: summary.cached.len(),
        failed: summary.failed.len(),
        skipped: summary.skipped.len(),
        wall_s,
        stage_s: summary.stage_s,
        hashing: crate::events::Hashing {
            seconds: h.seconds(),
            bytes: h.bytes(),
            publish_s: h.publish.seconds,
            publish_n: h.publish.calls,
            verify_s: h.verify.seconds,
            verify_n: h.verify.calls,
            files_s: h.file.seconds,
            files_n: h.file.calls,
        },
    }
}

/// Saves the index; a failure (disk full, read-only folder) is a warning of the run, not its
/// end: the index only explains reruns, and the run's summary must still be reported. Returns
/// whether it was saved. The same failure is reported once.
fn save_index(index: &Index, ws: &Workspace, warnings: &mut Vec<String>) -> bool {
    match index.save(ws) {
        Ok(()) => true,
        Err(e) => {
            let w = format!("{e:#} (it only explains reruns; the results are not affected)");
            if !warnings.contains(&w) {
                warnings.push(w);
            }
            false
        }
    }
}

/// Updates the output manifest for the stages whose outputs are in place (ran or cached, not
/// failed); a failure to save it is a warning of the run.
fn record_outputs(ws: &Workspace, plan: &Plan, summary: &RunSummary) {
    let done: Vec<&PlannedStage> = summary
        .ran
        .iter()
        .chain(&summary.cached)
        .filter(|n| !summary.failed.iter().any(|(f, _, _)| f == *n))
        .filter_map(|n| plan.stage(n))
        .filter(|s| !s.side_outputs.is_empty())
        .collect();
    if done.is_empty() {
        return;
    }
    let mut m = crate::workspace::Manifest::load(ws);
    let before = m.outputs.clone();
    let commit = crate::workspace::git_commit(&ws.root);
    for s in done {
        m.record(ws, plan, s, commit.as_deref());
    }
    let changed = m.outputs.iter().any(|(k, e)| {
        before.get(k).is_none_or(|b| {
            (&b.key, &b.blake3, &b.params, &b.commit) != (&e.key, &e.blake3, &e.params, &e.commit)
        })
    });
    if changed && let Err(e) = m.save(ws) {
        eprintln!("warning: {e:#}");
    }
}

fn progress_warn_bad_entry(stage: &str, why: &str) {
    eprintln!("warning: {why}; stage `{stage}` is recomputed");
}

/// Runs one stage, selected by (a prefix of) its key, as its own process would: inputs must be
/// in the cache. Takes the results lock shared, so several `run-stage` processes may run at
/// once. Does not update the index (concurrent writers would lose entries).
pub fn run_stage(
    ws: &Workspace,
    plan: &Plan,
    key: &str,
    force: bool,
    opts: &RunOptions,
) -> Result<RunSummary> {
    let s = plan.stage_by_key(key)?;
    let _lock = acquire(&ws.lock_path(), LockMode::Shared, opts.wait, &opts.command)?;
    let log = if opts.log_file {
        EventLog::to_dir(&ws.runs_dir())?
    } else {
        EventLog::in_memory()
    };
    let mut summary = RunSummary {
        log: log.path().map(PathBuf::from),
        ..Default::default()
    };
    let state = ws.entry_state(s);
    if state == EntryState::Valid && !force {
        log.push(&s.name, &s.kind, &s.key, What::Cached);
        summary.cached.push(s.name.clone());
        match restore_side_outputs(ws, s) {
            Ok(files) if !files.is_empty() => {
                log.push(&s.name, &s.kind, &s.key, What::Restored { files });
                summary.restored.push(s.name.clone());
            }
            Ok(_) => {}
            Err(e) => {
                let msg = format!("its declared outputs cannot be rewritten: {e:#}");
                log_failure(s, msg, &log, &mut summary);
            }
        }
        summary.events = log.events();
        return Ok(summary);
    }
    let mut missing = Vec::new();
    for (iname, names) in &s.inputs {
        for n in names {
            let Some(up) = plan.stage(n) else { continue };
            if ws.entry_state(up) != EntryState::Valid {
                missing.push(format!("input `{iname}` ← stage `{n}` (key {})", up.key));
            }
        }
    }
    if !missing.is_empty() {
        bail!(
            "cannot run stage `{}` ({}): inputs not in the cache:\n  {}\nrun them first (`saddleflow run-stage KEY` for each, or `saddleflow run --only {}`)",
            s.name,
            s.key,
            missing.join("\n  "),
            s.name
        );
    }
    let progress = Progress::new(opts.progress, 1, s.cost);
    log.push(&s.name, &s.kind, &s.key, What::Started);
    let sink = progress.started(&s.name, &s.kind, s.cost);
    let result = execute(ws, plan, s, Some(sink), true);
    match result {
        Ok(x) => report_ran(s, x, &log, &progress, &mut summary),
        Err(e) => {
            let msg = format!("{e:#}");
            progress.finished(&s.name, s.cost, &format!("FAILED {}: {msg}", s.name));
            log_failure(s, msg, &log, &mut summary);
        }
    }
    progress.finish();
    summary.events = log.events();
    Ok(summary)
}

/// The locks of a run: `results/.lock` exclusive for the local executor; for SLURM, shared (the
/// jobs' `run-stage` processes take it shared too) plus `results/.controller.lock` exclusive, so
/// that one controller at a time runs on a results folder.
fn take_run_locks(ws: &Workspace, opts: &RunOptions) -> Result<Vec<crate::lock::ResultsLock>> {
    Ok(match opts.executor {
        Executor::Local => vec![acquire(
            &ws.lock_path(),
            LockMode::Exclusive,
            opts.wait,
            &opts.command,
        )?],
        Executor::Slurm(_) => vec![
            acquire(
                &ws.results().join(".controller.lock"),
                LockMode::Exclusive,
                opts.wait,
                &opts.command,
            )?,
            acquire(&ws.lock_path(), LockMode::Shared, opts.wait, &opts.command)?,
        ],
    })
}

/// What [`execute`] returns.
pub(crate) struct Executed {
    pub(crate) wall_s: f64,
    pub(crate) warnings: Vec<String>,
    pub(crate) bytes: u64,
    /// Processor time of the stage's own thread pool (local executor on Linux; else `None`).
    pub(crate) cpu_s: Option<f64>,
    /// Threads of the stage's pool (local executor; else `None`).
    pub(crate) threads: Option<usize>,
}

/// Threads for a stage that starts now, `starting` stages (this one included) starting
/// together, when the running ones hold `busy` of the `cores`: the free cores shared evenly,
/// at least one. A stage that starts alone gets every free core; two stages that start
/// together on two cores get one each, so that a stage's parallel kernels do not hand tiny
/// grids between threads that another stage needs (on the draft's 32²…512² grids the thread
/// hand-offs cost more processor time than they save: docs/pipeline.md, "Draft costs"). A
/// pool cannot grow while its stage runs, so a stage that started beside another keeps its
/// share after that one ends. The number of threads does not change a result: every parallel
/// reduction of the kernels combines fixed chunks in a fixed order (tested in crates contact and
/// reynolds), and the SLURM executor already runs stages with pools of their own size.
pub(crate) fn share_cores(cores: usize, busy: usize, starting: usize) -> usize {
    (cores.saturating_sub(busy) / starting.max(1)).max(1)
}

/// [`execute`] in a rayon pool of its own with `threads` threads; its processor time is that
/// pool's threads' (fresh threads, so all of it is this stage's).
fn execute_local(
    ws: &Workspace,
    plan: &Plan,
    s: &PlannedStage,
    sink: Option<Arc<dyn ProgressSink>>,
    alone: bool,
    threads: usize,
) -> Result<Executed> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("stage-{i}"))
        .build()
        .context("cannot start the stage's thread pool")?;
    let mut x = pool.install(|| execute(ws, plan, s, sink, alone))?;
    x.cpu_s = pool
        .broadcast(|_| thread_cpu_s())
        .into_iter()
        .sum::<Option<f64>>();
    x.threads = Some(threads);
    Ok(x)
}

/// Processor time (user + system) of the calling thread so far, seconds, from
/// `/proc/thread-self/stat` (fields 14 and 15, USER_HZ = 100 ticks per second on every Linux
/// architecture); `None` where that is not readable.
fn thread_cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
    let rest = &stat[stat.rfind(')')? + 1..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: u64 = f.get(14 - 3)?.parse().ok()?;
    let stime: u64 = f.get(15 - 3)?.parse().ok()?;
    Some((utime + stime) as f64 / 100.0)
}

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into())
}

/// Computes one stage from cached inputs and publishes its artefact, then its side outputs.
/// `alone`: no other stage runs in this process meanwhile, so the process's peak memory during
/// the stage is the stage's own (recorded as `peak_rss_mib` with `peak_rss_scope` "stage";
/// otherwise "process", an upper bound).
fn execute(
    ws: &Workspace,
    plan: &Plan,
    s: &PlannedStage,
    sink: Option<Arc<dyn ProgressSink>>,
    alone: bool,
) -> Result<Executed> {
    if let (Some(need), Some(avail)) = (s.memory, crate::memory::available_bytes()) {
        crate::memory::check_fits(need, avail).map_err(|e| anyhow!(e))?;
    }
    // an allocation failure inside the stage aborts the process (stable Rust); one that can be
    // foreseen fails here, as this stage's failure
    if let Some(need) = s.memory {
        crate::memory::probe(need).map_err(|e| anyhow!(e))?;
    }
    let own_peak = alone && crate::memory::reset_peak();
    let rss_start = crate::memory::rss_mib();
    // open inputs
    let mut map = BTreeMap::new();
    for (iname, names) in &s.inputs {
        let mut readers = Vec::new();
        for n in names {
            let up = plan
                .stage(n)
                .ok_or_else(|| anyhow!("input `{iname}`: unknown stage `{n}`"))?;
            let r = ws
                .open_entry(up)
                .with_context(|| format!("input `{iname}` (stage `{n}`, key {})", up.key))?;
            readers.push(r);
        }
        map.insert(iname.clone(), readers);
    }
    let inputs = Inputs::new(map);
    let final_path = ws.artefact_of(s);
    let mut out = ArtefactWriter::create(&final_path)?;
    let mut ctx = StageContext {
        stage: s.name.clone(),
        key: s.key.clone(),
        root: ws.root.clone(),
        warnings: Vec::new(),
        side_outputs: Vec::new(),
        sink,
    };
    let t0 = Instant::now();
    let report = std::panic::catch_unwind(AssertUnwindSafe(|| {
        s.imp.run(&mut ctx, &s.params, &inputs, &mut out)
    }))
    .map_err(|p| anyhow!("stage panicked: {}", panic_message(&*p)))?
    .map_err(|e| name_producer(ws, plan, s, e))?;
    let wall_s = t0.elapsed().as_secs_f64();
    drop(inputs);

    // side outputs: exactly the declared ones
    let declared: BTreeSet<&str> = s.side_outputs.iter().map(String::as_str).collect();
    let emitted: BTreeSet<&str> = ctx.side_outputs.iter().map(|(p, _)| p.as_str()).collect();
    if let Some(extra) = emitted.difference(&declared).next() {
        bail!("the stage emitted `{extra}`, which its kind does not declare as a side output");
    }
    if let Some(missing) = declared.difference(&emitted).next() {
        bail!("the stage did not emit its declared side output `{missing}`");
    }
    let mut records = Vec::new();
    for (i, (path, bytes)) in ctx.side_outputs.iter().enumerate() {
        let ds = format!("side_outputs/{i}");
        out.write_u8_1d(&ds, bytes)?;
        out.set_attr_at(&ds, "path", path.as_str())?;
        records.push(SideOutput {
            path: path.clone(),
            blake3: store::hash_bytes(bytes),
            bytes: bytes.len() as u64,
        });
    }
    let mut warnings = ctx.warnings.clone();
    warnings.extend(report.warnings.iter().cloned());
    let mut prov = Provenance::new(s.key.clone(), &s.kind, s.code_version, s.params.to_value());
    prov.inputs = s.input_keys.clone();
    prov.wall_s = wall_s;
    prov.stats = if report.stats.is_null() {
        serde_json::json!({})
    } else {
        report.stats.clone()
    };
    if let (Some(peak), Some(obj)) = (crate::memory::peak_mib(), prov.stats.as_object_mut()) {
        obj.insert("peak_rss_mib".into(), serde_json::json!(peak));
        obj.insert(
            "peak_rss_scope".into(),
            serde_json::json!(if own_peak { "stage" } else { "process" }),
        );
        if let Some(start) = rss_start {
            obj.insert("rss_start_mib".into(), serde_json::json!(start));
        }
        if let Some(need) = s.memory {
            obj.insert(
                "memory_estimate_mib".into(),
                serde_json::json!(need as f64 / (1u64 << 20) as f64),
            );
        }
    }
    prov.warnings = warnings.clone();
    prov.side_outputs = records;
    out.write_provenance(&prov)?;
    let path = out.publish()?;
    ws.mark_verified(s);
    for (rel, bytes) in &ctx.side_outputs {
        store::fsutil::write_atomic(&ws.side_output_path(rel), bytes)
            .with_context(|| format!("cannot publish side output `{rel}`"))?;
    }
    Ok(Executed {
        wall_s,
        warnings,
        bytes: file_size(&path),
        cpu_s: None,
        threads: None,
    })
}

/// A stage's error that mentions one of its input files gains the producing stage's name and
/// file, so a read error (`has no dataset ...`) points at what to recompute.
fn name_producer(ws: &Workspace, plan: &Plan, s: &PlannedStage, e: anyhow::Error) -> anyhow::Error {
    let text = format!("{e:#}");
    let producers: Vec<String> = s
        .inputs
        .values()
        .flatten()
        .filter_map(|n| plan.stage(n))
        .map(|up| (up, ws.artefact_of(up)))
        .filter(|(_, p)| text.contains(&*p.to_string_lossy()))
        .map(|(up, p)| format!("stage `{}` ({} `{}`)", up.name, up.kind, p.display()))
        .collect();
    if producers.is_empty() {
        e
    } else {
        e.context(format!("reading the artefact of {}", producers.join(", ")))
    }
}

/// Rewrites side outputs of a cached stage that are missing or differ from the cached bytes.
/// Returns the files rewritten.
pub fn restore_side_outputs(ws: &Workspace, s: &PlannedStage) -> Result<Vec<String>> {
    let r = ws.open_entry(s)?;
    let prov = r.provenance()?;
    let mut restored = Vec::new();
    for (i, rec) in prov.side_outputs.iter().enumerate() {
        let target = ws.side_output_path(&rec.path);
        let current = store::canonical::hash_file(&target).ok();
        if current.as_deref() == Some(rec.blake3.as_str()) {
            continue;
        }
        let bytes = r.read_u8_1d(&format!("side_outputs/{i}"))?;
        if store::hash_bytes(&bytes) != rec.blake3 {
            bail!("the cached copy of `{}` is corrupt", rec.path);
        }
        store::fsutil::write_atomic(&target, &bytes)
            .with_context(|| format!("cannot write `{}`", rec.path))?;
        restored.push(rec.path.clone());
    }
    Ok(restored)
}

#[cfg(test)]
mod tests {
    use super::share_cores;

    #[test]
    fn stages_starting_together_share_the_free_cores_and_get_at_least_one() {
        // two stages starting together on two cores: one thread each
        assert_eq!(share_cores(2, 0, 2), 1);
        assert_eq!(share_cores(2, 1, 1), 1);
        // a stage that starts alone gets every free core
        assert_eq!(share_cores(2, 0, 1), 2);
        assert_eq!(share_cores(8, 2, 1), 6);
        assert_eq!(share_cores(8, 0, 3), 2);
        // no free core (a lone stage holds them all): still one thread, never zero
        assert_eq!(share_cores(2, 2, 1), 1);
        assert_eq!(share_cores(1, 0, 2), 1);
        assert_eq!(share_cores(2, 0, 0), 2);
    }
}
