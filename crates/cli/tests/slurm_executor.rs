//! The SLURM executor on a real cluster (`just slurm-up`: a single-node cluster from Debian's
//! packages): the smoke pipeline through `--executor slurm` gives the same tables and figures as
//! the local executor with every stage's job id in the event log; a failing stage is reported
//! with its job id and log tail while independent stages finish; SIGTERM of the controller
//! cancels its jobs; after SIGKILL a rerun adopts the live job instead of submitting it again.
//!
//! Without a cluster these tests skip; with `SADDLEFLOW_REQUIRE_SLURM=1` (set by CI after
//! `scripts/slurm-up` succeeded) a missing cluster fails them instead.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The cluster has two cores: one test at a time.
static CLUSTER: Mutex<()> = Mutex::new(());

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_saddleflow")
}

fn cluster_up() -> bool {
    let up = Command::new("sinfo")
        .args(["--noheader", "--format=%T"])
        .output()
        .map(|o| {
            let s = String::from_utf8_lossy(&o.stdout);
            o.status.success()
                && s.lines()
                    .any(|l| ["idle", "mixed", "allocated"].contains(&l.trim()))
        })
        .unwrap_or(false);
    if !up {
        assert!(
            std::env::var_os("SADDLEFLOW_REQUIRE_SLURM").is_none(),
            "SADDLEFLOW_REQUIRE_SLURM is set but no SLURM node is up (scripts/slurm-up)"
        );
        eprintln!("SKIPPED: no SLURM cluster here (start one with `just slurm-up`)");
    }
    up
}

mod common;

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(bin())
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "status {}\nstdout:\n{}\nstderr:\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The controllers' event logs (those with a `run_started` event), oldest first.
fn run_logs(dir: &Path) -> Vec<Vec<Value>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("results/runs"))
        .map(|rd| rd.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    files.retain(|p| p.extension().is_some_and(|x| x == "jsonl"));
    files.sort();
    files
        .iter()
        .map(|p| {
            std::fs::read_to_string(p)
                .unwrap()
                .lines()
                .filter_map(|l| serde_json::from_str(l).ok())
                .collect::<Vec<Value>>()
        })
        .filter(|ev| ev.iter().any(|e| e["event"] == "run_started"))
        .collect()
}

fn events<'a>(log: &'a [Value], what: &str) -> Vec<&'a Value> {
    log.iter().filter(|e| e["event"] == what).collect()
}

/// A project with a pipeline of mock stages.
fn mock_project(stages: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::create_dir_all(p.join("pipeline")).unwrap();
    std::fs::create_dir_all(p.join("params/cluster")).unwrap();
    std::fs::write(p.join("pipeline/paper.toml"), stages).unwrap();
    std::fs::write(p.join("params/draft.toml"), "").unwrap();
    std::fs::write(
        p.join("params/cluster/test.toml"),
        "[executor]\nkind = \"slurm\"\njobs = 2\npoll_s = 1\ncpus = 1\nmem_mib = 256\ntime_min = 5\n",
    )
    .unwrap();
    dir
}

const SLURM: [&str; 2] = ["--cluster-profile", "params/cluster/test.toml"];

/// Columns of a CSV that hold wall times (they differ between any two runs).
fn without_timings(csv: &str) -> String {
    let mut lines = csv.lines();
    let Some(header) = lines.next() else {
        return String::new();
    };
    let cols: Vec<&str> = header.split(',').collect();
    let drop: Vec<usize> = (0..cols.len())
        .filter(|&i| cols[i].contains("wall") || cols[i].ends_with("_s"))
        .collect();
    if drop.is_empty() {
        return csv.to_string();
    }
    // the timing column is numeric and precedes any quoted text in these tables
    std::iter::once(header.to_string())
        .chain(lines.map(|l| {
            l.split(',')
                .enumerate()
                .filter(|(i, _)| !drop.contains(i))
                .map(|(_, f)| f)
                .collect::<Vec<_>>()
                .join(",")
        }))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn smoke_pipeline_on_slurm_equals_local() {
    let _g = CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    if !cluster_up() {
        return;
    }
    let (local, cluster) = (common::project(), common::project());
    let o = run(
        local.path(),
        &["run", "--params", "params/smoke.toml", "-j", "2"],
    );
    assert!(o.status.success(), "{}", text(&o));
    let o = run(
        cluster.path(),
        &[
            "run",
            "--params",
            "params/smoke.toml",
            "--cluster-profile",
            "params/cluster/local.toml",
            "--executor",
            "slurm",
            "--slurm-poll",
            "1",
        ],
    );
    assert!(o.status.success(), "{}", text(&o));

    // every computed stage went through one job whose id is logged
    let logs = run_logs(cluster.path());
    let log = logs.last().unwrap();
    let ran: Vec<&str> = events(log, "ran")
        .iter()
        .map(|e| e["stage"].as_str().unwrap())
        .collect();
    assert!(ran.len() > 40, "only {} stages ran", ran.len());
    for s in &ran {
        let jobs: Vec<&Value> = events(log, "submitted")
            .into_iter()
            .filter(|e| e["stage"] == *s)
            .collect();
        assert_eq!(jobs.len(), 1, "stage {s}: {jobs:?}");
        let id = jobs[0]["job"].as_str().unwrap();
        assert!(id.parse::<u64>().is_ok(), "job id {id:?}");
    }

    // the same tables (timing columns aside) and the same figures, byte for byte
    let tables = |d: &Path| {
        let mut v: Vec<(String, String)> = std::fs::read_dir(d.join("results/tables"))
            .unwrap()
            .flatten()
            .map(|e| {
                (
                    e.file_name().to_string_lossy().into_owned(),
                    without_timings(&std::fs::read_to_string(e.path()).unwrap()),
                )
            })
            .collect();
        v.sort();
        v
    };
    let (a, b) = (tables(local.path()), tables(cluster.path()));
    assert!(a.len() > 5);
    assert_eq!(a.len(), b.len());
    for ((na, ta), (nb, tb)) in a.iter().zip(&b) {
        assert_eq!(na, nb);
        assert_eq!(ta, tb, "table {na} differs between the executors");
    }
    for e in std::fs::read_dir(local.path().join("figures"))
        .unwrap()
        .flatten()
    {
        if e.path().extension().is_some_and(|x| x == "svg") {
            let other = cluster.path().join("figures").join(e.file_name());
            assert_eq!(
                std::fs::read(e.path()).unwrap(),
                std::fs::read(&other).unwrap(),
                "figure {:?} differs",
                e.file_name()
            );
        }
    }
}

#[test]
fn failing_stage_names_its_job_and_log_tail_while_others_finish() {
    let _g = CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    if !cluster_up() {
        return;
    }
    let dir = mock_project(
        r#"
[scenes.all]
doc = "a failing stage beside independent ones"
stages = ["good", "downstream", "bad", "after_bad"]

[stages.good]
kind = "mock"
params = { value = 1.0 }

[stages.downstream]
kind = "mock"
inputs = { inputs = ["good"] }
params = { value = 2.0, side_output = "results/tables/downstream.txt" }

[stages.bad]
kind = "mock"
params = { fail = true }

[stages.after_bad]
kind = "mock"
inputs = { inputs = ["bad"] }
"#,
    );
    let o = run(dir.path(), &["run", SLURM[0], SLURM[1]]);
    assert!(!o.status.success(), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("failing on purpose"), "no log tail: {err}");
    let log = run_logs(dir.path()).pop().unwrap();
    let failed = events(&log, "failed");
    assert_eq!(failed.len(), 1, "{failed:?}");
    let bad_job = events(&log, "submitted")
        .into_iter()
        .find(|e| e["stage"] == "bad")
        .unwrap()["job"]
        .as_str()
        .unwrap()
        .to_string();
    let msg = failed[0]["error"].as_str().unwrap();
    assert!(
        msg.contains(&format!("job {bad_job}")) && msg.contains("stage error"),
        "{msg}"
    );
    // independent stages finished and published their outputs; the dependent one was skipped
    let ran: Vec<&str> = events(&log, "ran")
        .iter()
        .map(|e| e["stage"].as_str().unwrap())
        .collect();
    assert_eq!(ran.len(), 2, "{ran:?}");
    assert!(ran.contains(&"good") && ran.contains(&"downstream"));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("results/tables/downstream.txt")).unwrap(),
        "value = 3\n"
    );
    assert_eq!(events(&log, "skipped").len(), 1);
}

fn wait_for(what: &str, timeout: Duration, mut f: impl FnMut() -> bool) {
    let t = Instant::now();
    while !f() {
        assert!(t.elapsed() < timeout, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The job name of the controller's run (from its note) and whether any of its jobs is live.
fn live_jobs(name: &str) -> usize {
    let o = Command::new("squeue")
        .args(["--noheader", "--format=%T", &format!("--name={name}")])
        .output()
        .unwrap();
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter(|l| !l.trim().is_empty() && l.trim() != "COMPLETED")
        .count()
}

fn job_name(log: &[Value]) -> Option<String> {
    events(log, "note").iter().find_map(|e| {
        let t = e["text"].as_str()?;
        let rest = t.strip_prefix("SLURM jobs named ")?;
        Some(rest.split(';').next()?.to_string())
    })
}

fn start_slow(dir: &Path) -> (Child, String) {
    let child = Command::new(bin())
        .current_dir(dir)
        .args(["run", SLURM[0], SLURM[1]])
        .stderr(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut name = String::new();
    wait_for("the slow job to run", Duration::from_secs(60), || {
        let Some(log) = run_logs(dir).pop() else {
            return false;
        };
        if let Some(n) = job_name(&log) {
            name = n;
        }
        !name.is_empty() && !events(&log, "submitted").is_empty() && {
            let o = Command::new("squeue")
                .args(["--noheader", "--format=%T", &format!("--name={name}")])
                .output()
                .unwrap();
            String::from_utf8_lossy(&o.stdout).contains("RUNNING")
        }
    });
    (child, name)
}

fn slow_project(sleep_s: f64) -> tempfile::TempDir {
    mock_project(&format!(
        r#"
[scenes.all]
doc = "one slow stage"
stages = ["slow"]

[stages.slow]
kind = "mock"
params = {{ value = 5.0, sleep_s = {sleep_s}, side_output = "results/tables/slow.txt" }}
"#
    ))
}

#[test]
fn sigterm_of_the_controller_cancels_its_jobs() {
    let _g = CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    if !cluster_up() {
        return;
    }
    let dir = slow_project(120.0);
    let (mut child, name) = start_slow(dir.path());
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    use std::os::unix::process::ExitStatusExt;
    assert_eq!(status.signal(), Some(15), "ends by the signal: {status}");
    wait_for("the jobs to be cancelled", Duration::from_secs(30), || {
        live_jobs(&name) == 0
    });
    assert!(!dir.path().join("results/tables/slow.txt").exists());
}

#[test]
fn rerun_after_sigkill_adopts_the_live_job() {
    let _g = CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    if !cluster_up() {
        return;
    }
    let dir = slow_project(6.0);
    let (mut child, name) = start_slow(dir.path());
    child.kill().unwrap(); // SIGKILL: no handler runs, the job goes on
    child.wait().unwrap();
    assert!(live_jobs(&name) > 0, "the job died with its controller");
    let o = run(dir.path(), &["run", SLURM[0], SLURM[1]]);
    assert!(o.status.success(), "{}", text(&o));
    let log = run_logs(dir.path()).pop().unwrap();
    let subs = events(&log, "submitted");
    assert_eq!(subs.len(), 1, "{subs:?}");
    assert_eq!(subs[0]["adopted"], true, "{subs:?}");
    assert_eq!(events(&log, "ran").len(), 1);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("results/tables/slow.txt")).unwrap(),
        "value = 5\n"
    );
}
