//! Settings checked late (issue 18.12): a documented constraint that spans stages fails when the
//! plan is built, before anything runs.

use std::path::{Path, PathBuf};

fn project_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn settings_checked_late_critical_ns_with_one_entry_fails_at_plan_time() {
    let root = project_root();
    let smoke = std::fs::read_to_string(root.join("params/smoke.toml")).unwrap();
    let line = smoke
        .lines()
        .find(|l| l.trim_start().starts_with("critical_ns"))
        .expect("params/smoke.toml sets critical_ns");
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("one.toml");
    std::fs::write(&params, smoke.replace(line, "critical_ns = [5]")).unwrap();
    let err = stages::orchestrator::Plan::load(
        &stages::registry(),
        &root.join("pipeline/paper.toml"),
        Some(&params),
    )
    .map(|_| ())
    .expect_err("one grid cannot be extrapolated");
    let msg = format!("{err:#}");
    assert!(
        msg.contains("at least two distinct n") && msg.contains("resolution"),
        "{msg}"
    );
    // the unchanged file plans
    stages::orchestrator::Plan::load(
        &stages::registry(),
        &root.join("pipeline/paper.toml"),
        Some(&root.join("params/smoke.toml")),
    )
    .unwrap();
}
