//! Pipeline commands: run, run-stage, status, gc, graph. (Owner: orchestrator.)
//!
//! All of them read a pipeline file (default `pipeline/paper.toml`) and a params file (default
//! `params/draft.toml`) relative to the project root (`-C DIR`, default the current folder), and
//! work on `results/` there. Human-readable output goes to stdout, progress and logs to stderr.

use anyhow::{Context, Result, bail};
use orchestrator::ops;
use orchestrator::util::{human_duration, human_size, short};
use orchestrator::{Action, EntryState, Plan, ProgressMode, RunOptions, Workspace};
use stages::orchestrator;
use std::path::{Path, PathBuf};

/// Where the declarative files are.
#[derive(clap::Args, Clone, Debug)]
pub struct Files {
    /// Pipeline file (scenes and stages).
    #[arg(long, default_value = "pipeline/paper.toml")]
    pipeline: PathBuf,
    /// Params file (fidelity: grid exponents, tolerances, load steps).
    #[arg(long, default_value = "params/draft.toml")]
    params: PathBuf,
    /// Run as if started in DIR (the project root holding pipeline/, params/, results/).
    #[arg(short = 'C', long = "root", value_name = "DIR")]
    root: Option<PathBuf>,
}

#[derive(clap::Subcommand)]
pub enum Command {
    /// Run the pipeline: compute what is not cached, in dependency order.
    Run {
        #[command(flatten)]
        files: Files,
        /// Only these scenes (or stages), with everything upstream. Repeatable.
        #[arg(long, value_name = "SCENE")]
        only: Vec<String>,
        /// Say what would run and why (new, parameters changed, code version changed, input
        /// changed), and run nothing.
        #[arg(long)]
        dry_run: bool,
        /// Recompute this stage even if cached. Repeatable.
        #[arg(long, value_name = "STAGE")]
        force: Vec<String>,
        /// Stages run in parallel (with SLURM: jobs in flight) [default: 1, or the cluster
        /// profile's `jobs`].
        #[arg(long, short = 'j')]
        jobs: Option<usize>,
        /// Wait for another run holding the results folder instead of failing.
        #[arg(long)]
        wait: bool,
        #[command(flatten)]
        cluster: crate::cluster::ClusterArgs,
    },
    /// Run one stage, selected by its key (or a unique prefix), from cached inputs.
    RunStage {
        /// The stage key (`saddleflow status` lists keys).
        key: String,
        #[command(flatten)]
        files: Files,
        /// Recompute even if cached.
        #[arg(long)]
        force: bool,
        /// Wait for a run holding the results folder instead of failing.
        #[arg(long)]
        wait: bool,
    },
    /// Show each stage's cache state, size and scenes.
    Status {
        #[command(flatten)]
        files: Files,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// List what the cached stages cost when they were computed (wall time, peak memory),
        /// most expensive first, with per-scene sums and the critical path.
        #[arg(long)]
        costs: bool,
        /// With `--costs`: how many stages to list (0: all).
        #[arg(long, default_value_t = 15, requires = "costs")]
        top: usize,
    },
    /// Delete cache entries that no pipeline/*.toml × params/*.toml combination reaches.
    Gc {
        /// List what would be deleted, with sizes, and delete nothing.
        #[arg(long)]
        dry_run: bool,
        /// Wait for a run holding the results folder instead of failing.
        #[arg(long)]
        wait: bool,
        /// Run as if started in DIR.
        #[arg(short = 'C', long = "root", value_name = "DIR")]
        root: Option<PathBuf>,
    },
    /// Print the stage graph in Graphviz DOT (`saddleflow graph | dot -Tsvg > graph.svg`).
    Graph {
        #[command(flatten)]
        files: Files,
        /// Only these scenes (or stages) and their upstream.
        #[arg(long, value_name = "SCENE")]
        only: Vec<String>,
    },
}

fn enter(root: &Option<PathBuf>) -> Result<Workspace> {
    if let Some(r) = root {
        std::env::set_current_dir(r).with_context(|| format!("cannot enter `{}`", r.display()))?;
    }
    Ok(Workspace::new(""))
}

fn load(files: &Files) -> Result<(Workspace, Plan)> {
    let ws = enter(&files.root)?;
    let plan = Plan::load(&stages::registry(), &files.pipeline, Some(&files.params))?;
    Ok((ws, plan))
}

fn command_line() -> String {
    std::env::args().collect::<Vec<_>>().join(" ")
}

pub fn run(cmd: Command) -> Result<()> {
    match cmd {
        Command::Run {
            files,
            only,
            dry_run,
            force,
            jobs,
            wait,
            cluster,
        } => {
            let (ws, plan) = load(&files)?;
            let (executor, jobs) = cluster.executor(&files.pipeline, &files.params, jobs)?;
            let opts = RunOptions {
                only,
                force,
                jobs,
                dry_run,
                wait,
                progress: ProgressMode::Auto,
                log_file: true,
                command: command_line(),
                executor,
            };
            let summary = orchestrator::run(&ws, &plan, &opts)?;
            if dry_run {
                print_decisions(&plan, &summary.decisions);
                return Ok(());
            }
            let to_run = summary
                .decisions
                .iter()
                .filter(|d| d.action == Action::Run)
                .count();
            eprintln!(
                "{} ran, {} cached{}{}, {} failed, {} skipped in {} ({} with {}){}",
                summary.ran.len(),
                summary.cached.len(),
                if summary.restored.is_empty() {
                    ""
                } else {
                    " (side outputs restored for "
                },
                if summary.restored.is_empty() {
                    String::new()
                } else {
                    format!("{})", summary.restored.join(", "))
                },
                summary.failed.len(),
                summary.skipped.len(),
                human_duration(summary.wall_s),
                plan.pipeline,
                plan.params,
                summary
                    .log
                    .as_ref()
                    .map(|p| format!("; log {}", p.display()))
                    .unwrap_or_default()
            );
            let _ = to_run;
            eprintln!("{}", hashing_line(&summary));
            // the stages ran in this process only with the local executor
            let cpu_s = matches!(opts.executor, orchestrator::Executor::Local)
                .then(process_cpu_s)
                .flatten();
            if let Some(line) = expensive_line(&summary, cpu_s) {
                eprintln!("{line}");
            }
            // the summary first: a warning such as a full disk comes after the counts and
            // the failed stages, never instead of them
            let warnings: String = summary
                .warnings
                .iter()
                .map(|w| format!("\nwarning: {w}"))
                .collect();
            if summary.ok() && !warnings.is_empty() {
                eprintln!("{}", warnings.trim_start());
            }
            if !summary.ok() {
                let mut msg = String::new();
                for (name, key, err) in &summary.failed {
                    msg.push_str(&format!("\n  stage `{name}` (key {key}) failed: {err}"));
                }
                for (name, because) in &summary.skipped {
                    msg.push_str(&format!(
                        "\n  stage `{name}` skipped: upstream `{because}` failed"
                    ));
                }
                bail!(
                    "{} stage(s) failed, {} skipped; the other results are kept:{msg}{warnings}",
                    summary.failed.len(),
                    summary.skipped.len()
                );
            }
            Ok(())
        }
        Command::RunStage {
            key,
            files,
            force,
            wait,
        } => {
            let (ws, plan) = load(&files)?;
            let opts = RunOptions {
                wait,
                command: command_line(),
                ..Default::default()
            };
            let summary = orchestrator::run_stage(&ws, &plan, &key, force, &opts)?;
            let s = plan.stage_by_key(&key)?;
            if let Some((_, _, err)) = summary.failed.first() {
                bail!("stage `{}` (key {}) failed: {err}", s.name, s.key);
            }
            let state = if summary.ran.is_empty() {
                "cached"
            } else {
                "ran"
            };
            println!(
                "{state} {} ({} {}) → {}",
                s.name,
                s.kind,
                s.key,
                ws.artefact_of(s).display()
            );
            Ok(())
        }
        Command::Status {
            files,
            json,
            costs,
            top,
        } => {
            let (ws, plan) = load(&files)?;
            if costs {
                let report = ops::costs(&ws, &plan);
                if json {
                    println!("{}", serde_json::to_string_pretty(&report)?);
                } else {
                    print_costs(&plan, &report, top);
                }
                return Ok(());
            }
            let st = ops::status(&ws, &plan);
            if json {
                println!("{}", serde_json::to_string_pretty(&st)?);
                return Ok(());
            }
            println!("{} with {}", plan.pipeline, plan.params);
            let w = column_width(st.iter().map(|s| s.name.as_str()), "stage");
            let kw = column_width(st.iter().map(|s| s.kind.as_str()), "kind");
            let (mut cached, mut bytes) = (0, 0);
            for s in &st {
                if s.state == EntryState::Valid {
                    cached += 1;
                }
                let state = s.state.label();
                bytes += s.bytes;
                println!(
                    "  {state:<8} {:<w$} {:<kw$} {}  {:>10}  {}{}",
                    s.name,
                    s.kind,
                    short(&s.key),
                    if s.bytes > 0 {
                        human_size(s.bytes)
                    } else {
                        "-".into()
                    },
                    if s.scenes.is_empty() {
                        "(no scene)".to_string()
                    } else {
                        s.scenes.join(", ")
                    },
                    s.side_outputs
                        .iter()
                        .zip(&s.side_output_origin)
                        .map(|((f, ok), note)| match (ok, note) {
                            (false, _) => format!("  {f} (missing)"),
                            (true, Some(n)) => format!("  {f} ({n})"),
                            (true, None) => format!("  {f}"),
                        })
                        .collect::<String>()
                );
            }
            for (scene, doc) in &plan.scene_docs {
                let members: Vec<&ops::StageStatus> =
                    st.iter().filter(|s| s.scenes.contains(scene)).collect();
                let ok = members
                    .iter()
                    .filter(|s| s.state == EntryState::Valid)
                    .count();
                println!(
                    "scene {scene}: {ok}/{} stages cached{}",
                    members.len(),
                    if doc.is_empty() {
                        String::new()
                    } else {
                        format!(" ({doc})")
                    }
                );
            }
            println!("{cached}/{} stages cached, {}", st.len(), human_size(bytes));
            Ok(())
        }
        Command::Gc {
            dry_run,
            wait,
            root,
        } => {
            let ws = enter(&root)?;
            let plans = all_plans()?;
            let report = ops::gc(&ws, &plans, dry_run, wait)?;
            let total: u64 = report.deleted.iter().map(|(_, b)| b).sum();
            for (p, b) in &report.deleted {
                println!(
                    "{} {:>10}  {}",
                    if dry_run { "would delete" } else { "deleted" },
                    human_size(*b),
                    p.display()
                );
            }
            println!(
                "{} {} files ({}); kept {} entries ({}) reached by {} pipeline × params combinations",
                if dry_run { "would delete" } else { "deleted" },
                report.deleted.len(),
                human_size(total),
                report.kept,
                human_size(report.kept_bytes),
                plans.len()
            );
            Ok(())
        }
        Command::Graph { files, only } => {
            let (ws, plan) = load(&files)?;
            let sel = plan.select(&only)?;
            print!("{}", ops::graph(&ws, &plan, &sel));
            Ok(())
        }
    }
}

fn toml_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(rd) => rd
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    Ok(v)
}

/// Every pipeline/*.toml × params/*.toml plan. Any that fails to build stops gc: deleting on
/// the word of a broken file would be unsafe.
fn all_plans() -> Result<Vec<Plan>> {
    let pipelines = toml_files(Path::new("pipeline"))?;
    let params = toml_files(Path::new("params"))?;
    if pipelines.is_empty() {
        bail!("no pipeline/*.toml here: refusing to collect garbage with nothing to keep");
    }
    let reg = stages::registry();
    let mut plans = Vec::new();
    for p in &pipelines {
        if params.is_empty() {
            plans.push(Plan::load(&reg, p, None)?);
        }
        for q in &params {
            plans.push(Plan::load(&reg, p, Some(q)).with_context(|| {
                format!(
                    "gc keeps what every pipeline × params combination reaches, but {} with {} does not build; fix it first",
                    p.display(),
                    q.display()
                )
            })?);
        }
    }
    Ok(plans)
}

fn print_decisions(plan: &Plan, decisions: &[orchestrator::Decision]) {
    let w = decisions
        .iter()
        .map(|d| d.name.len())
        .max()
        .unwrap_or(5)
        .max(5);
    let kw = decisions
        .iter()
        .map(|d| d.kind.len())
        .max()
        .unwrap_or(4)
        .max(4);
    for d in decisions {
        match d.action {
            Action::Cached => println!(
                "  cached     {:<w$} {:<kw$} {}",
                d.name,
                d.kind,
                short(&d.key)
            ),
            Action::Run => println!(
                "  would run  {:<w$} {:<kw$} {}  {}",
                d.name,
                d.kind,
                short(&d.key),
                d.reasons
                    .iter()
                    .map(|r| r.to_string())
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        }
    }
    let n_run = decisions.iter().filter(|d| d.action == Action::Run).count();
    println!(
        "{n_run} to run, {} cached ({} with {}); dry run: nothing was computed",
        decisions.len() - n_run,
        plan.pipeline,
        plan.params
    );
}

/// One line on the cost of verification: hashing time (summed over threads) against the
/// summed compute time of the stages that ran.
/// The processor time (user + system, every thread, finished ones included) this process has
/// used so far, in seconds, from `/proc/self/stat`; `None` where that is not readable (not
/// Linux). On a machine shared with other work the stages' wall times grow with the load, this
/// much less: it is the figure to compare runs by there.
fn process_cpu_s() -> Option<f64> {
    cpu_s_of_stat(&std::fs::read_to_string("/proc/self/stat").ok()?)
}

/// utime + stime (fields 14 and 15 of proc(5)'s `/proc/<pid>/stat`, after the command name in
/// parentheses, which may itself hold spaces and parentheses) in seconds. The kernel reports
/// them in USER_HZ ticks, 100 per second on every architecture Linux supports (the
/// user-visible clock_t unit is fixed by the ABI, whatever the kernel's own tick rate).
fn cpu_s_of_stat(stat: &str) -> Option<f64> {
    const USER_HZ: f64 = 100.0;
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // after ")": field 3 (state) is fields[0], so field k is fields[k − 3]
    let utime: u64 = fields.get(14 - 3)?.parse().ok()?;
    let stime: u64 = fields.get(15 - 3)?.parse().ok()?;
    Some((utime + stime) as f64 / USER_HZ)
}

/// The stages that ran, most expensive first (at most three), for the run's summary, with the
/// process's processor time `cpu_s` if known.
fn expensive_line(summary: &orchestrator::RunSummary, cpu_s: Option<f64>) -> Option<String> {
    let mut ran: Vec<(&str, f64)> = summary
        .events
        .iter()
        .filter_map(|e| match &e.what {
            orchestrator::What::Ran { wall_s, .. } => Some((e.stage.as_str(), *wall_s)),
            _ => None,
        })
        .collect();
    if ran.len() < 2 {
        return None;
    }
    ran.sort_by(|a, b| b.1.total_cmp(&a.1));
    let top: Vec<String> = ran
        .iter()
        .take(3)
        .map(|(n, t)| format!("{n} {}", human_duration(*t)))
        .collect();
    let cpu = cpu_s.map_or(String::new(), |c| {
        format!(" (processor time of the run: {})", human_duration(c))
    });
    Some(format!(
        "summed stage time {}{cpu}; most expensive: {} (`saddleflow status --costs` lists all)",
        human_duration(summary.stage_s),
        top.join(", ")
    ))
}

/// Width of a left-aligned text column: its widest entry or its header (in characters).
fn column_width<'a>(entries: impl Iterator<Item = &'a str>, header: &str) -> usize {
    entries
        .map(|e| e.chars().count())
        .chain([header.chars().count()])
        .max()
        .unwrap_or(0)
}

/// The `status --costs` table.
fn print_costs(plan: &orchestrator::Plan, r: &ops::CostReport, top: usize) {
    println!(
        "{} with {}: cost of each cached stage when it was computed (its provenance)",
        plan.pipeline, plan.params
    );
    let jobs = std::thread::available_parallelism().map_or(1, |n| n.get());
    let shown = if top == 0 {
        r.stages.len()
    } else {
        top.min(r.stages.len())
    };
    let w = column_width(r.stages[..shown].iter().map(|s| s.name.as_str()), "stage");
    let kw = column_width(r.stages[..shown].iter().map(|s| s.kind.as_str()), "kind");
    println!(
        "  {:<w$} {:<kw$} {:>9} {:>6} {:>6} {:>9}  scenes",
        "stage", "kind", "wall", "share", "cum.", "peak MiB"
    );
    let mut cum = 0.0;
    for s in &r.stages[..shown] {
        cum += s.wall_s;
        let pct = |x: f64| {
            if r.total_s > 0.0 {
                format!("{:.1}%", 100.0 * x / r.total_s)
            } else {
                "-".into()
            }
        };
        println!(
            "  {:<w$} {:<kw$} {:>9} {:>6} {:>6} {:>9}  {}",
            s.name,
            s.kind,
            human_duration(s.wall_s),
            pct(s.wall_s),
            pct(cum),
            s.peak_rss_mib.map_or("-".into(), |m| format!("{m:.0}")),
            s.scenes.join(", ")
        );
    }
    if shown < r.stages.len() {
        println!(
            "  … {} cheaper stages (--top 0 lists all)",
            r.stages.len() - shown
        );
    }
    println!(
        "summed stage time {} over {} cached stages; critical path {} ({}); a cold run takes at least {} with -j {jobs}",
        human_duration(r.total_s),
        r.stages.len(),
        human_duration(r.critical_path_s),
        r.critical_path.join(" → "),
        human_duration(r.lower_bound_s(jobs)),
    );
    let scenes: Vec<String> = r
        .scenes
        .iter()
        .map(|(n, t)| format!("{n} {}", human_duration(*t)))
        .collect();
    println!(
        "per scene (shared stages count in each): {}",
        scenes.join(", ")
    );
    if !r.uncached.is_empty() {
        println!(
            "{} stages not cached, cost unknown: {}",
            r.uncached.len(),
            r.uncached.join(", ")
        );
    }
}

fn hashing_line(summary: &orchestrator::RunSummary) -> String {
    let h = &summary.hashing;
    let share = if summary.stage_s > 0.0 {
        format!(
            " = {:.2} % of {} stage time",
            100.0 * h.seconds() / summary.stage_s,
            human_duration(summary.stage_s)
        )
    } else {
        String::new()
    };
    format!(
        "hashing: {:.3} s{share} ({:.1} MB; {} digests at publication {:.3} s, {} verifications {:.3} s, {} output files {:.3} s)",
        h.seconds(),
        h.bytes() as f64 / 1e6,
        h.publish.calls,
        h.publish.seconds,
        h.verify.calls,
        h.verify.seconds,
        h.file.calls,
        h.file.seconds,
    )
}

#[cfg(test)]
mod tests {
    use super::{column_width, cpu_s_of_stat};

    #[test]
    fn processor_time_is_utime_plus_stime_after_the_command_name() {
        // a command name with a space and a parenthesis must not shift the fields; utime 250,
        // stime 75 ticks (fields 14 and 15) = 3.25 s at 100 ticks per second
        let stat = "4242 (sf (x) y) R 1 4242 4242 0 -1 4194304 100 0 0 0 250 75 0 0 20 0 3 0";
        assert_eq!(cpu_s_of_stat(stat), Some(3.25));
        // truncated or malformed: unknown, not zero
        assert_eq!(cpu_s_of_stat("4242 (sf) R 1 4242"), None);
        assert_eq!(cpu_s_of_stat("4242 sf R 1"), None);
        assert_eq!(cpu_s_of_stat("1 (a) R 1 1 1 0 -1 0 0 0 0 0 x 75 0"), None);
    }

    #[test]
    fn this_process_has_a_processor_time() {
        // Linux only (the project's platform): the test binary itself has used some time
        if cfg!(target_os = "linux") {
            let t = super::process_cpu_s().expect("/proc/self/stat is readable on Linux");
            assert!(t.is_finite() && t >= 0.0, "{t}");
        }
    }

    #[test]
    fn columns_are_as_wide_as_their_widest_entry_or_header() {
        let kinds = ["sweep", "constriction", "flow"];
        assert_eq!(column_width(kinds.iter().copied(), "kind"), 12);
        let w = column_width(kinds.iter().copied(), "kind");
        for k in kinds {
            // every entry fits with a space to the next column
            assert_eq!(format!("{k:<w$} |").find('|'), Some(13));
        }
        assert_eq!(column_width(["ab"].into_iter(), "stage"), 5);
        assert_eq!(column_width(std::iter::empty(), "kind"), 4);
        // characters, not bytes
        assert_eq!(column_width(["γ0_sweep"].into_iter(), "kind"), 8);
    }
}
