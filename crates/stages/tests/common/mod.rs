//! Shared by the stage tests: a pipeline written into a temporary project and run through the
//! engine, and its artefacts read back.
#![allow(dead_code)] // each test binary uses its own subset

use stages::orchestrator::{Plan, ProgressMode, RunOptions, Workspace};
use std::path::Path;

/// Writes `pipeline` as `dir/pipeline/p.toml` and builds its plan.
pub fn try_plan(dir: &Path, pipeline: &str) -> Result<Plan, String> {
    std::fs::create_dir_all(dir.join("pipeline")).unwrap();
    std::fs::write(dir.join("pipeline/p.toml"), pipeline).unwrap();
    Plan::load(&stages::registry(), &dir.join("pipeline/p.toml"), None)
        .map_err(|e| format!("{e:#}"))
}

/// [`try_plan`], panicking on an invalid pipeline.
pub fn plan(dir: &Path, pipeline: &str) -> Plan {
    try_plan(dir, pipeline).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs every stage silently; returns the plan, the workspace and the failed stages
/// (`Debug`-formatted: name, key, cause).
pub fn run_all(dir: &Path, pipeline: &str) -> Result<(Plan, Workspace, Vec<String>), String> {
    let plan = try_plan(dir, pipeline)?;
    let ws = Workspace::new(dir);
    let opts = RunOptions {
        progress: ProgressMode::Silent,
        ..Default::default()
    };
    let s = stages::orchestrator::run(&ws, &plan, &opts).map_err(|e| format!("{e:#}"))?;
    let failed = s.failed.iter().map(|f| format!("{f:?}")).collect();
    Ok((plan, ws, failed))
}

/// [`run_all`], requiring that every stage succeeds.
pub fn try_run(dir: &Path, pipeline: &str) -> Result<(Plan, Workspace), String> {
    let (plan, ws, failed) = run_all(dir, pipeline)?;
    if failed.is_empty() {
        Ok((plan, ws))
    } else {
        Err(failed.join("\n"))
    }
}

/// [`try_run`], panicking on any failure.
pub fn run(dir: &Path, pipeline: &str) -> (Plan, Workspace) {
    try_run(dir, pipeline).unwrap_or_else(|e| panic!("{e}"))
}

/// The complete artefact of stage `name`.
pub fn reader(plan: &Plan, ws: &Workspace, name: &str) -> store::ArtefactReader {
    let s = plan.stages.iter().find(|s| s.name == name).unwrap();
    store::ArtefactReader::open_complete(ws.artefact_of(s)).unwrap()
}
