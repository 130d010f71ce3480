//! The engine's promises, checked on the runner's event log (never on time): incremental reruns,
//! failure isolation, interruption, invalid cache entries, locking, run-stage, gc, keys.

mod common;

use common::*;
use orchestrator::{Action, EntryState, RunOptions};
use std::sync::atomic::Ordering;
use store::ArtefactReader;

#[test]
fn first_run_runs_everything_and_an_unchanged_rerun_runs_nothing() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    let s1 = p.run(&reg, &quiet());
    assert!(s1.ok());
    assert_eq!(ran(&s1), ["a", "b", "c", "d", "e"]);
    assert!(
        ["a", "b", "c", "d", "e"]
            .iter()
            .all(|n| reasons(&s1, n) == ["new"])
    );
    assert_eq!(
        std::fs::read_to_string(p.path("figures/d.txt")).unwrap(),
        "3\n"
    );

    let s2 = p.run(&reg, &quiet());
    assert!(
        started(&s2).is_empty(),
        "an unchanged rerun started {:?}",
        started(&s2)
    );
    assert_eq!(s2.cached.len(), 5);
    assert_eq!(add.runs().len(), 5, "kinds ran again");
    // the event log is on disk too
    let log = std::fs::read_to_string(s2.log.as_ref().unwrap()).unwrap();
    assert!(
        log.lines()
            .all(|l| serde_json::from_str::<serde_json::Value>(l).is_ok())
    );
    assert!(log.contains("\"event\":\"cached\""));
    // and provenance is on the artefacts
    let plan = p.plan(&reg);
    let c = plan.stage("c").unwrap();
    let prov = ArtefactReader::open_complete(p.ws().artefact_of(c))
        .unwrap()
        .provenance()
        .unwrap();
    assert_eq!(prov.key, c.key);
    assert_eq!(prov.kind, "add");
    assert_eq!(
        prov.inputs["inputs"],
        vec![
            plan.stage("a").unwrap().key.clone(),
            plan.stage("b").unwrap().key.clone()
        ]
    );
    assert_eq!(prov.params["scale"], 1.0);
    assert_eq!(prov.stats["iterations"], 3);
}

#[test]
fn editing_one_parameter_reruns_exactly_the_stages_downstream_of_it() {
    let p = Project::new(PIPELINE, "va = 1.0\n");
    let add = Add::new();
    let reg = registry(&add);
    p.run(&reg, &quiet());

    // a setting in the params file
    p.write("params/x.toml", "va = 10.0\n");
    let dry = p.run(
        &reg,
        &RunOptions {
            dry_run: true,
            ..quiet()
        },
    );
    assert!(started(&dry).is_empty());
    let would: Vec<&str> = dry
        .decisions
        .iter()
        .filter(|d| d.action == Action::Run)
        .map(|d| d.name.as_str())
        .collect();
    assert_eq!(would, ["a", "c", "d"]);
    assert_eq!(reasons(&dry, "a"), ["params_changed"]);
    assert!(
        dry.decisions[0].reasons[0]
            .to_string()
            .contains("value 1.0 → 10.0"),
        "{}",
        dry.decisions[0].reasons[0]
    );
    assert_eq!(reasons(&dry, "c"), ["input_changed"]);
    assert_eq!(reasons(&dry, "d"), ["input_changed"]);
    assert_eq!(reasons(&dry, "b"), Vec::<String>::new());

    let s = p.run(&reg, &quiet());
    assert_eq!(ran(&s), ["a", "c", "d"]);
    assert_eq!(
        std::fs::read_to_string(p.path("figures/d.txt")).unwrap(),
        "12\n"
    );

    // a parameter in the pipeline file, in the middle of the graph
    let edited = PIPELINE.replace(
        "inputs = { inputs = [\"a\", \"b\"] }",
        "inputs = { inputs = [\"a\", \"b\"] }\nparams = { scale = 2 }",
    );
    p.write("pipeline/p.toml", &edited);
    let s = p.run(&reg, &quiet());
    assert_eq!(ran(&s), ["c", "d"]);
    assert_eq!(reasons(&s, "c"), ["params_changed"]);

    // --only runs just a scene's stages
    p.write("params/x.toml", "va = 10.0\nve = 6\n");
    let s = p.run(
        &reg,
        &RunOptions {
            only: vec!["main".into()],
            ..quiet()
        },
    );
    assert!(ran(&s).is_empty());
    assert!(!s.decisions.iter().any(|d| d.name == "e"));
    let s = p.run(
        &reg,
        &RunOptions {
            only: vec!["other".into()],
            ..quiet()
        },
    );
    assert_eq!(ran(&s), ["e"]);

    // reverting to earlier values finds them in the cache: nothing runs
    p.write("params/x.toml", "va = 1.0\nve = 5.0\n");
    p.write("pipeline/p.toml", PIPELINE);
    let s = p.run(&reg, &quiet());
    assert!(ran(&s).is_empty(), "{:?}", ran(&s));
    assert_eq!(
        std::fs::read_to_string(p.path("figures/d.txt")).unwrap(),
        "3\n",
        "side output restored"
    );
}

#[test]
fn a_code_version_bump_reruns_the_kind_and_says_so() {
    let p = Project::new(PIPELINE, "");
    let mut add = Add::new();
    p.run(&registry(&add), &quiet());
    add.version = 2;
    let s = p.run(
        &registry(&add),
        &RunOptions {
            only: vec!["other".into()],
            ..quiet()
        },
    );
    assert_eq!(ran(&s), ["e"]);
    assert_eq!(reasons(&s, "e"), ["code_version_changed"]);
}

#[test]
fn force_reruns_only_the_named_stage() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    p.run(&reg, &quiet());
    let s = p.run(
        &reg,
        &RunOptions {
            force: vec!["c".into()],
            ..quiet()
        },
    );
    assert_eq!(ran(&s), ["c"]);
    assert_eq!(reasons(&s, "c"), ["forced"]);
    let err = orchestrator::run(
        &p.ws(),
        &p.plan(&reg),
        &RunOptions {
            force: vec!["cc".into()],
            ..quiet()
        },
    )
    .unwrap_err();
    assert!(format!("{err:#}").contains("did you mean `c`?"), "{err:#}");
}

#[test]
fn a_failing_stage_is_reported_while_independent_stages_finish_and_are_kept() {
    let failing = PIPELINE.replace(
        "params = { value = \"$vb\" }",
        "params = { value = \"$vb\", fail = true }",
    );
    let p = Project::new(&failing, "");
    let add = Add::new();
    let reg = registry(&add);
    let s = p.run(&reg, &RunOptions { jobs: 2, ..quiet() });
    assert!(!s.ok());
    assert_eq!(s.failed.len(), 1);
    let (name, key, err) = &s.failed[0];
    assert_eq!(name, "b");
    assert_eq!(key, &p.plan(&reg).stage("b").unwrap().key);
    assert!(err.contains("failing on purpose"), "{err}");
    assert_eq!(ran(&s), ["a", "e"]);
    let mut skipped: Vec<&str> = s.skipped.iter().map(|(n, _)| n.as_str()).collect();
    skipped.sort();
    assert_eq!(skipped, ["c", "d"]);
    // nothing of b is visible, not even a temporary file
    assert!(
        !p.files().iter().any(|f| f.contains(&key[..12])),
        "{:?}",
        p.files()
    );

    // fix it: only b and what depends on it run
    p.write("pipeline/p.toml", PIPELINE);
    let s = p.run(&reg, &quiet());
    assert_eq!(ran(&s), ["b", "c", "d"]);
}

#[test]
fn a_truncated_or_unfinished_cache_file_is_detected_and_recomputed() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    p.run(&reg, &quiet());
    let plan = p.plan(&reg);
    let c = p.ws().artefact_of(plan.stage("c").unwrap());
    let bytes = std::fs::read(&c).unwrap();
    std::fs::write(&c, &bytes[..bytes.len() / 2]).unwrap();
    assert_eq!(
        p.ws().entry_state(plan.stage("c").unwrap()),
        EntryState::Invalid
    );
    let s = p.run(&reg, &quiet());
    assert_eq!(
        ran(&s),
        ["c"],
        "downstream d keeps its key and its cache entry"
    );
    assert_eq!(reasons(&s, "c"), ["output_invalid"]);
    assert!(ArtefactReader::is_valid(&c));

    // garbage and a deleted file count as missing too
    std::fs::write(&c, b"garbage").unwrap();
    let a = p.ws().artefact_of(plan.stage("a").unwrap());
    std::fs::remove_file(&a).unwrap();
    let s = p.run(&reg, &quiet());
    assert_eq!(ran(&s), ["a", "c"]);
    assert_eq!(reasons(&s, "a"), ["output_missing"]);
}

#[test]
fn deleted_or_edited_side_outputs_are_restored_from_the_cache() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    p.run(&reg, &quiet());
    std::fs::write(p.path("figures/d.txt"), "edited by hand\n").unwrap();
    let s = p.run(&reg, &quiet());
    assert!(ran(&s).is_empty());
    assert_eq!(s.restored, ["d"]);
    assert_eq!(
        std::fs::read_to_string(p.path("figures/d.txt")).unwrap(),
        "3\n"
    );
    std::fs::remove_file(p.path("figures/d.txt")).unwrap();
    let s = p.run(&reg, &quiet());
    assert_eq!(s.restored, ["d"]);
    assert!(p.path("figures/d.txt").exists());
}

#[test]
fn keys_ignore_spelling_order_defaults_and_names() {
    let add = Add::new();
    let reg = registry(&add);
    let a = Project::new(
        "[stages.x]\nkind = \"add\"\nparams = { value = 0.1, scale = 1 }\n",
        "",
    );
    let b = Project::new(
        "[stages.y]\nkind = \"add\"\nparams = { scale = 1.0, value = 1e-1, mode = \"fast\" }\n",
        "",
    );
    let ka = a.plan(&reg).stages[0].key.clone();
    let kb = b.plan(&reg).stages[0].key.clone();
    assert_eq!(ka, kb);
    let c = Project::new(
        "[stages.x]\nkind = \"add\"\nparams = { value = 0.1, scale = 1.5 }\n",
        "",
    );
    assert_ne!(ka, c.plan(&reg).stages[0].key);
    // an input's key is part of the key
    let d = Project::new(PIPELINE, "va = 1.5");
    let e = Project::new(PIPELINE, "");
    assert_ne!(
        d.plan(&reg).stage("d").unwrap().key,
        e.plan(&reg).stage("d").unwrap().key
    );
    assert_eq!(
        d.plan(&reg).stage("e").unwrap().key,
        e.plan(&reg).stage("e").unwrap().key
    );
}

#[test]
fn run_stage_runs_one_stage_from_cached_inputs() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    let ws = p.ws();
    let plan = p.plan(&reg);
    let c = plan.stage("c").unwrap().key.clone();
    let err = orchestrator::run_stage(&ws, &plan, &c[..10], false, &quiet()).unwrap_err();
    let msg = format!("{err:#}");
    assert!(
        msg.contains("inputs not in the cache")
            && msg.contains("stage `a`")
            && msg.contains("stage `b`"),
        "{msg}"
    );
    for n in ["a", "b"] {
        let k = &plan.stage(n).unwrap().key;
        let s = orchestrator::run_stage(&ws, &plan, k, false, &quiet()).unwrap();
        assert_eq!(s.ran, [n]);
    }
    let s = orchestrator::run_stage(&ws, &plan, &c[..10], false, &quiet()).unwrap();
    assert_eq!(s.ran, ["c"]);
    let s = orchestrator::run_stage(&ws, &plan, &c, false, &quiet()).unwrap();
    assert_eq!(s.cached, ["c"]);
    assert!(orchestrator::run_stage(&ws, &plan, "ffffffffff", false, &quiet()).is_err());
    // a following run finds them
    let s = p.run(&reg, &quiet());
    assert_eq!(ran(&s), ["d", "e"]);
}

#[test]
fn gc_keeps_what_the_plans_reach_and_deletes_the_rest() {
    let p = Project::new(PIPELINE, "va = 1.0");
    let add = Add::new();
    let reg = registry(&add);
    p.run(&reg, &quiet());
    p.write("params/x.toml", "va = 7.0");
    p.run(&reg, &quiet());
    let plan = p.plan(&reg);
    // a stale temporary of a killed run
    let stale = p.path("results/cache/add/.deadbeef.h5.tmp-4000000000-0");
    std::fs::write(&stale, b"partial").unwrap();
    let dry = orchestrator::ops::gc(&p.ws(), std::slice::from_ref(&plan), true, false).unwrap();
    // old a, c, d, their whole-file checksums, the temporary
    assert_eq!(dry.deleted.len(), 7, "{:?}", dry.deleted);
    assert!(stale.exists());
    let before = p.files().len();
    let r = orchestrator::ops::gc(&p.ws(), std::slice::from_ref(&plan), false, false).unwrap();
    assert_eq!(r.deleted.len(), 7);
    assert_eq!(p.files().len(), before - 7);
    let s = p.run(&reg, &quiet());
    assert!(ran(&s).is_empty());
}

#[test]
fn graph_and_status() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    p.run(
        &reg,
        &RunOptions {
            only: vec!["other".into()],
            ..quiet()
        },
    );
    let plan = p.plan(&reg);
    let st = orchestrator::ops::status(&p.ws(), &plan);
    let e = st.iter().find(|s| s.name == "e").unwrap();
    assert_eq!(e.state, EntryState::Valid);
    assert_eq!(e.scenes, ["other"]);
    assert!(e.bytes > 0);
    let a = st.iter().find(|s| s.name == "a").unwrap();
    assert_eq!(a.state, EntryState::Missing);
    let dot = orchestrator::ops::graph(&p.ws(), &plan, &plan.select(&[]).unwrap());
    assert!(dot.starts_with("digraph"));
    assert!(dot.contains("\"a\" -> \"c\" [label=\"inputs\"]"), "{dot}");
    assert!(dot.contains("scene:main"));
}

#[test]
fn costs_list_cached_stages_by_their_recorded_wall_time() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    let plan = p.plan(&reg);
    let cold = orchestrator::ops::costs(&p.ws(), &plan);
    assert!(cold.stages.is_empty());
    assert_eq!(cold.uncached.len(), plan.stages.len());
    let s = p.run(&reg, &quiet());
    assert!(s.ok());
    let r = orchestrator::ops::costs(&p.ws(), &plan);
    assert!(r.uncached.is_empty(), "{:?}", r.uncached);
    assert_eq!(r.stages.len(), plan.stages.len());
    // the recorded times are the ones the run's event log reported
    for c in &r.stages {
        let logged = s
            .events
            .iter()
            .find_map(|e| match &e.what {
                orchestrator::What::Ran { wall_s, .. } if e.stage == c.name => Some(*wall_s),
                _ => None,
            })
            .unwrap();
        assert_eq!(c.wall_s, logged, "{}", c.name);
        assert!(c.chain_s >= c.wall_s);
    }
    assert!(r.stages.windows(2).all(|w| w[0].wall_s >= w[1].wall_s));
    let total: f64 = r.stages.iter().map(|c| c.wall_s).sum();
    assert!((r.total_s - total).abs() <= 1e-12 * total.max(1.0));
    // the critical path is a chain of inputs ending at its last stage, and its time is the sum
    // of its stages' times
    let path_s: f64 = r
        .critical_path
        .iter()
        .map(|n| r.stages.iter().find(|c| &c.name == n).unwrap().wall_s)
        .sum();
    assert!((r.critical_path_s - path_s).abs() <= 1e-9);
    for w in r.critical_path.windows(2) {
        let down = plan.stage(&w[1]).unwrap();
        assert!(down.inputs.values().flatten().any(|n| n == &w[0]), "{w:?}");
    }
    assert!(r.lower_bound_s(2) >= r.critical_path_s && r.lower_bound_s(1) >= r.total_s - 1e-12);
}

#[test]
fn a_concurrent_second_run_is_refused_or_waits_and_never_corrupts() {
    let slow = PIPELINE.replace(
        "params = { value = \"$ve\" }",
        "params = { value = \"$ve\", slow = true }",
    );
    let p = Project::new(&slow, "");
    let add = Add {
        markers: Some(p.path("markers")),
        ..Add::new()
    };
    add.slow_ms.store(1500, Ordering::SeqCst);
    let reg = registry(&add);
    std::thread::scope(|scope| {
        let first = scope.spawn(|| {
            p.run(
                &reg,
                &RunOptions {
                    only: vec!["other".into()],
                    ..quiet()
                },
            )
        });
        while !p.path("markers/e.started").exists() {
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        // refused, naming the holder
        let err = orchestrator::run(&p.ws(), &p.plan(&reg), &quiet()).unwrap_err();
        let msg = format!("{err:#}");
        assert!(
            msg.contains("locked by another saddleflow process"),
            "{msg}"
        );
        assert!(
            msg.contains(&format!("pid {}", std::process::id())),
            "{msg}"
        );
        assert!(msg.contains("--wait"), "{msg}");
        // waits, then finds e cached
        let second = p.run(
            &reg,
            &RunOptions {
                wait: true,
                ..quiet()
            },
        );
        let first = first.join().unwrap();
        assert_eq!(ran(&first), ["e"]);
        assert_eq!(ran(&second), ["a", "b", "c", "d"]);
    });
    assert_eq!(add.runs().iter().filter(|r| *r == "e").count(), 1);
    for (_, _, v) in values(&p, &reg) {
        assert!(v.is_finite());
    }
}

/// Child half of the interruption test: runs the pipeline with a slow stage until killed.
#[test]
#[ignore = "run by interrupted_run_then_rerun_gives_the_uninterrupted_results"]
fn child_runs_slow_pipeline() {
    let Ok(root) = std::env::var("ORCH_TEST_CHILD_ROOT") else {
        return;
    };
    let root = std::path::PathBuf::from(root);
    let add = Add {
        markers: Some(root.join("markers")),
        ..Add::new()
    };
    add.slow_ms.store(60_000, Ordering::SeqCst);
    let reg = registry(&add);
    let plan = orchestrator::Plan::load(
        &reg,
        &root.join("pipeline/p.toml"),
        Some(&root.join("params/x.toml")),
    )
    .unwrap();
    orchestrator::run(&orchestrator::Workspace::new(&root), &plan, &quiet()).unwrap();
}

const SLOW_C: &str = "inputs = { inputs = [\"a\", \"b\"] }\nparams = { slow = true }";

#[test]
fn interrupted_run_then_rerun_gives_the_uninterrupted_results() {
    for signal in ["KILL", "INT"] {
        interrupt_with(signal);
    }
}

/// Runs the pipeline in a child process, sends it `signal` inside stage c, reruns, compares.
fn interrupt_with(signal: &str) {
    let pipeline = PIPELINE.replace("inputs = { inputs = [\"a\", \"b\"] }", SLOW_C);
    // the reference: an uninterrupted run
    let reference = Project::new(&pipeline, "");
    let add = Add::new();
    let reg = registry(&add);
    reference.run(&reg, &quiet());

    // a child process runs the same pipeline and is killed (SIGKILL) inside stage c
    let p = Project::new(&pipeline, "");
    let mut child = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "child_runs_slow_pipeline",
            "--exact",
            "--ignored",
            "--nocapture",
        ])
        .env("ORCH_TEST_CHILD_ROOT", p.root())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while !p.path("markers/c.started").exists() {
        assert!(
            t0.elapsed().as_secs() < 60,
            "the child never reached stage c"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the child exited early"
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    std::thread::sleep(std::time::Duration::from_millis(100));
    let status = std::process::Command::new("kill")
        .args([format!("-{signal}"), child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let exit = child.wait().unwrap();
    assert!(
        !exit.success(),
        "SIG{signal}: the child finished instead of dying"
    );

    // nothing half-written is visible at a final path: a and b (topological order a, b, c, d, e)
    // are complete; c left only a hidden temporary
    let plan = p.plan(&reg);
    let ws = p.ws();
    let files = p.files();
    for f in &files {
        let name = std::path::Path::new(f)
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        if f.ends_with(".h5") && !name.starts_with('.') {
            assert!(
                ArtefactReader::is_valid(p.path(f)),
                "{f} is visible but not valid"
            );
        }
    }
    assert_eq!(ws.entry_state(plan.stage("a").unwrap()), EntryState::Valid);
    assert_eq!(
        ws.entry_state(plan.stage("c").unwrap()),
        EntryState::Missing
    );
    assert!(
        files.iter().any(|f| f.contains(".tmp-")),
        "expected the killed stage's temporary: {files:?}"
    );
    assert!(!p.path("figures/d.txt").exists());

    // the lock died with the child: a rerun proceeds, computes only what was lost
    let s = p.run(&reg, &quiet());
    assert!(s.ok());
    assert_eq!(ran(&s), ["c", "d", "e"]);
    assert!(
        !p.files().iter().any(|f| f.contains(".tmp-")),
        "temporaries left: {:?}",
        p.files()
    );
    assert_eq!(values(&p, &reg), values(&reference, &reg));
    assert_eq!(
        std::fs::read(p.path("figures/d.txt")).unwrap(),
        std::fs::read(reference.path("figures/d.txt")).unwrap()
    );
    // the killed run's event log ends where it was killed
    let logs: Vec<_> = std::fs::read_dir(p.path("results/runs"))
        .unwrap()
        .flatten()
        .collect();
    assert_eq!(logs.len(), 2);
}

#[test]
fn stages_started_together_share_the_cores_and_report_their_threads_and_processor_time() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let reg = registry(&add);
    let s = p.run(&reg, &RunOptions { jobs: 2, ..quiet() });
    assert!(s.ok());
    let cores = rayon::current_num_threads();
    let order: Vec<&str> = s
        .events
        .iter()
        .filter(|e| matches!(e.what, orchestrator::What::Started))
        .map(|e| e.stage.as_str())
        .collect();
    let threads = |stage: &str| {
        s.events
            .iter()
            .find_map(|e| match &e.what {
                orchestrator::What::Ran { threads, cpu_s, .. } if e.stage == stage => {
                    if cfg!(target_os = "linux") {
                        assert!(cpu_s.is_some_and(|c| c >= 0.0), "{stage}: {cpu_s:?}");
                    }
                    *threads
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("{stage}: no threads in its ran event"))
    };
    // a, b and e are ready at the start: the first two share the cores
    let first = threads(order[0]);
    assert_eq!(first, (cores / 2).max(1), "{order:?}");
    assert_eq!(threads(order[1]), (cores - first).max(1), "{order:?}");
    for st in &order {
        assert!(threads(st) >= 1);
    }
}
