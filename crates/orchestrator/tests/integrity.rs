//! A cache that cannot lie (issue 18): damaged, foreign and unreadable entries are recomputed
//! with a warning naming the file; a stage is done only when its declared outputs are in place;
//! a failure to save the index does not hide the run's summary. Checked on the runner's events
//! and on the values of the artefacts, never on time.

mod common;

use anyhow::Result;
use common::*;
use orchestrator::{
    EntryState, Inputs, ParamSpec, Params, Registry, StageContext, StageKind, StageReport,
};
use store::ArtefactWriter;

/// Overwrites 8 bytes in the middle of the `data` dataset (10 000 × 1.0) of an `add` artefact.
fn flip_data(path: &std::path::Path) {
    let mut bytes = std::fs::read(path).unwrap();
    let run: Vec<u8> = std::iter::repeat_n(1.0f64.to_le_bytes(), 64)
        .flatten()
        .collect();
    let at = bytes
        .windows(run.len())
        .position(|w| w == run)
        .expect("the data in the file")
        + 8 * 32;
    bytes[at..at + 8].copy_from_slice(&9.0f64.to_le_bytes());
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn cache_contents_are_never_verified_a_value_edited_in_place_is_recomputed() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    p.run(&reg, &quiet());
    let before = values(&p, &reg);
    let plan = p.plan(&reg);
    let c = plan.stage("c").unwrap();
    flip_data(&p.ws().artefact_of(c));
    assert_eq!(p.ws().entry_state(c), EntryState::Damaged);
    let status = orchestrator::ops::status(&p.ws(), &plan);
    assert_eq!(
        status.iter().find(|s| s.name == "c").unwrap().state.label(),
        "DAMAGED"
    );
    let s = p.run(&reg, &quiet());
    assert!(s.ok());
    assert_eq!(ran(&s), ["c"], "only the damaged entry is recomputed");
    assert_eq!(reasons(&s, "c"), ["output_damaged"]);
    let why = s.decisions.iter().find(|d| d.name == "c").unwrap().reasons[0].to_string();
    assert!(why.contains(&c.key), "the warning names the file: {why}");
    assert_eq!(values(&p, &reg), before);
    assert_eq!(p.ws().entry_state(c), EntryState::Valid);
}

#[test]
fn cache_contents_are_never_verified_a_foreign_artefact_is_recomputed() {
    // one stage's valid artefact copied over another's name (issue 18.1, second case)
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    p.run(&reg, &quiet());
    let before = values(&p, &reg);
    let plan = p.plan(&reg);
    let (a, b) = (plan.stage("a").unwrap(), plan.stage("b").unwrap());
    std::fs::copy(p.ws().artefact_of(a), p.ws().artefact_of(b)).unwrap();
    assert_eq!(p.ws().entry_state(b), EntryState::Damaged);
    let s = p.run(&reg, &quiet());
    assert_eq!(ran(&s), ["b"]);
    assert_eq!(values(&p, &reg), before, "c and d were not fed a's value");
}

#[test]
fn a_stage_with_a_declared_output_that_cannot_be_written_fails_the_run() {
    // issue 18.5: the artefact is cached, figures/d.txt is gone and cannot be written (a
    // folder is in the way: unlike a read-only folder, that holds for root too)
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    p.run(&reg, &quiet());
    let out = p.path("figures/d.txt");
    std::fs::remove_file(&out).unwrap();
    std::fs::create_dir(&out).unwrap();
    let s = p.run(&reg, &quiet());
    assert!(!s.ok(), "a run with a declared output missing must fail");
    let (name, _, err) = &s.failed[0];
    assert_eq!(name, "d");
    assert!(err.contains("figures/d.txt"), "{err}");
    assert!(started(&s).is_empty(), "nothing is recomputed for it");
    // once the way is clear, it is rewritten from the artefact, without recomputing
    std::fs::remove_dir(&out).unwrap();
    let s = p.run(&reg, &quiet());
    assert!(s.ok());
    assert!(started(&s).is_empty());
    assert_eq!(s.restored, ["d"]);
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "3\n");
}

#[test]
fn disk_full_summary_an_index_that_cannot_be_saved_does_not_hide_the_summary() {
    // issue 18.13: the index write fails (a folder in its place); the run still returns its
    // summary, with the failure as a warning
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    std::fs::create_dir_all(p.path("results/cache/index.json/x")).unwrap();
    let s = p.run(&reg, &quiet());
    assert_eq!(ran(&s).len(), 5);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("cannot write the cache index")),
        "{:?}",
        s.warnings
    );
}

/// A `source` that writes nothing, so its consumer's read fails.
struct Hollow;

impl StageKind for Hollow {
    fn name(&self) -> &str {
        "source"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![]
    }
    fn run(
        &self,
        _ctx: &mut StageContext,
        _p: &Params,
        _inputs: &Inputs,
        _out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        Ok(StageReport::default())
    }
}

#[test]
fn a_read_error_in_a_consumer_names_the_producer_stage_and_its_file() {
    // issue 18.4
    let p = Project::new(
        r#"
[stages.src]
kind = "source"
[stages.use]
kind = "needs_source"
inputs = { surface = "src" }
"#,
        "",
    );
    let mut reg = Registry::new();
    reg.register(Hollow);
    reg.register(NeedsSource);
    let s = p.run(&reg, &quiet());
    let (name, _, err) = &s.failed[0];
    assert_eq!(name, "use");
    let plan = p.plan(&reg);
    let src = plan.stage("src").unwrap();
    assert!(
        err.contains("stage `src`") && err.contains(&src.key),
        "the error names the producer and its file: {err}"
    );
}

#[test]
fn outputs_carry_no_provenance_status_tells_another_params_files_outputs() {
    // issue 18.11: run with x.toml, then with y.toml (another value of a): figures/d.txt is
    // y's, and status under x says so
    let p = Project::new(PIPELINE, "");
    p.write("params/y.toml", "va = 10.0\n");
    let add = Add::new();
    let reg = registry(&add);
    p.run(&reg, &quiet());
    let plan_x = p.plan(&reg);
    let d_of = |st: &[orchestrator::ops::StageStatus]| {
        st.iter()
            .find(|s| s.name == "d")
            .unwrap()
            .side_output_origin[0]
            .clone()
    };
    assert_eq!(d_of(&orchestrator::ops::status(&p.ws(), &plan_x)), None);
    let plan_y = orchestrator::Plan::load(
        &reg,
        &p.path("pipeline/p.toml"),
        Some(&p.path("params/y.toml")),
    )
    .unwrap();
    assert!(orchestrator::run(&p.ws(), &plan_y, &quiet()).unwrap().ok());
    let note = d_of(&orchestrator::ops::status(&p.ws(), &plan_x)).expect("not x's output");
    assert!(note.contains("y.toml"), "{note}");
    assert_eq!(d_of(&orchestrator::ops::status(&p.ws(), &plan_y)), None);
    let m = orchestrator::Manifest::load(&p.ws());
    assert_eq!(
        m.outputs["figures/d.txt"].key,
        plan_y.stage("d").unwrap().key
    );
}

#[test]
fn code_identity_in_the_key_a_changed_part_reruns_its_kind_and_dry_run_names_it() {
    // issue 18.2, the engine's half: the registry's code identity enters the key, and the
    // reason names the changed part
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let mut reg = registry(&add);
    let code = |h: &str| {
        [
            ("crate contact".to_string(), h.to_string()),
            ("crate surface".to_string(), "s".repeat(64)),
        ]
        .into()
    };
    reg.set_code_identity("add", code(&"a".repeat(64)));
    p.run(&reg, &quiet());
    reg.set_code_identity("add", code(&"b".repeat(64)));
    let dry = orchestrator::RunOptions {
        dry_run: true,
        ..quiet()
    };
    let s = p.run(&reg, &dry);
    assert_eq!(reasons(&s, "a"), ["code_changed"]);
    let why = s.decisions[0].reasons[0].to_string();
    assert_eq!(why, "code changed (crate contact)");
    let s = p.run(&reg, &quiet());
    assert_eq!(ran(&s), ["a", "b", "c", "d", "e"]);
}

#[test]
fn verified_stamps_persist_across_runs_and_an_edit_still_forces_a_full_check() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    p.run(&reg, &quiet());
    // stamps younger than 2 s are not trusted across runs (coarse file times)
    std::thread::sleep(std::time::Duration::from_millis(2100));
    assert!(started(&p.run(&reg, &quiet())).is_empty());
    let memo = std::fs::read_to_string(p.ws().verified_path()).unwrap();
    let plan = p.plan(&reg);
    let c = plan.stage("c").unwrap();
    assert!(memo.contains(&c.key), "{memo}");
    flip_data(&p.ws().artefact_of(c));
    let s = p.run(&reg, &quiet());
    assert_eq!(ran(&s), ["c"]);
    assert_eq!(reasons(&s, "c"), ["output_damaged"]);
}

/// An `add` that claims an impossible amount of memory.
struct Greedy;

impl StageKind for Greedy {
    fn name(&self) -> &str {
        "source"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![]
    }
    fn memory_estimate(
        &self,
        _p: &Params,
        _i: &std::collections::BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        Some(u64::MAX / 2)
    }
    fn run(
        &self,
        _ctx: &mut StageContext,
        _p: &Params,
        _inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        out.set_attr("value", 1.0)?;
        Ok(StageReport::default())
    }
}

#[test]
fn no_memory_pre_flight_a_stage_that_cannot_fit_fails_before_it_starts() {
    // issue 18.8: the stage fails with its estimate, the run reports it (no abort)
    if orchestrator::memory::available_bytes().is_none() {
        return; // no /proc/meminfo nor cgroup: nothing to compare with
    }
    let p = Project::new(
        "[stages.big]\nkind = \"source\"\n[stages.use]\nkind = \"needs_source\"\ninputs = { surface = \"big\" }\n",
        "",
    );
    let mut reg = Registry::new();
    reg.register(Greedy);
    reg.register(NeedsSource);
    let s = p.run(&reg, &quiet());
    assert_eq!(s.failed.len(), 1);
    let (name, _, err) = &s.failed[0];
    assert_eq!(name, "big");
    assert!(err.contains("MiB") && err.contains("available"), "{err}");
    assert_eq!(s.skipped.len(), 1);
}
