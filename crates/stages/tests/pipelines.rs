//! The project's own declarative files build with the registered kinds, and the surface stage
//! runs through the engine.

use stages::orchestrator::{Plan, ProgressMode, RunOptions, Workspace};
use std::path::{Path, PathBuf};

fn project_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn tomls(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|e| e == "toml"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

#[test]
fn every_pipeline_builds_with_every_params_file() {
    let root = project_root();
    let pipelines = tomls(&root.join("pipeline"));
    let params = tomls(&root.join("params"));
    assert!(!pipelines.is_empty() && !params.is_empty());
    let reg = stages::registry();
    for p in &pipelines {
        for q in &params {
            let plan = Plan::load(&reg, p, Some(q))
                .unwrap_or_else(|e| panic!("{} with {}:\n{e:#}", p.display(), q.display()));
            assert!(!plan.stages.is_empty());
        }
    }
}

#[test]
fn surface_stage_writes_a_flow_compatible_artefact() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("pipeline")).unwrap();
    std::fs::write(
        dir.path().join("pipeline/p.toml"),
        "[stages.tri]\nkind = \"surface\"\nparams = { lattice = \"triangular\", n = 4 }\n",
    )
    .unwrap();
    let reg = stages::registry();
    let plan = Plan::load(&reg, &dir.path().join("pipeline/p.toml"), None).unwrap();
    let ws = Workspace::new(dir.path());
    let opts = RunOptions {
        progress: ProgressMode::Silent,
        ..Default::default()
    };
    let s = stages::orchestrator::run(&ws, &plan, &opts).unwrap();
    assert_eq!(s.ran, ["tri"]);
    let r = store::ArtefactReader::open_complete(ws.artefact_of(&plan.stages[0])).unwrap();
    let h = r.read_f64_2d("height").unwrap();
    assert_eq!(h.dim(), (16, 16));
    let (lx, ly) = r.cell().unwrap();
    assert!((lx - 4.0 / 3f64.sqrt()).abs() < 1e-12 && (ly - 2.0).abs() < 1e-12);
    assert!((r.attr_f64("skewness").unwrap() - (2.0f64 / 3.0).sqrt()).abs() < 1e-6);
    let kinds = r.read_strings("critical/kind").unwrap();
    assert!(kinds.iter().any(|k| k == "saddle"));
    let prov = r.provenance().unwrap();
    assert_eq!(prov.kind, "surface");
    assert_eq!(prov.params["n"], 4);
    assert_eq!(prov.stats["nodes"], 256);
}

#[test]
fn surface_parameters_are_validated() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("p.toml");
    std::fs::write(
        &p,
        "[stages.s]\nkind = \"surface\"\nparams = { lattice = \"kagome\", n = 14 }\n",
    )
    .unwrap();
    let e = format!(
        "{:#}",
        Plan::load(&stages::registry(), &p, None).unwrap_err()
    );
    assert!(
        e.contains("p.toml:3:22") && e.contains("one of \"square\", \"triangular\", \"hexagonal\""),
        "{e}"
    );
    assert!(
        e.contains("p.toml:3:36") && e.contains("an integer in 3..=13"),
        "{e}"
    );
}

/// Issue 8 item 2: Figure 2 alone plans the square surface, its three sweeps, the figure and
/// the tables — never a triangular or hexagonal surface, never a flow problem.
#[test]
fn figure2_alone_plans_only_the_square_model_and_no_flow() {
    let root = project_root();
    let reg = stages::registry();
    for q in tomls(&root.join("params")) {
        let plan = Plan::load(&reg, &root.join("pipeline/paper.toml"), Some(&q)).unwrap();
        let selected = plan.select(&["fig2".to_string()]).unwrap();
        let names: std::collections::BTreeSet<&str> = selected
            .iter()
            .map(|&i| plan.stages[i].name.as_str())
            .collect();
        assert_eq!(
            names,
            [
                "surface_square",
                "fig2_hardwall",
                "fig2_adhesion",
                "fig2_repulsion",
                "fig2"
            ]
            .into_iter()
            .collect(),
            "{}",
            q.display()
        );
        for &i in &selected {
            let s = &plan.stages[i];
            assert!(
                ["surface", "sweep", "fig2"].contains(&s.kind.as_str()),
                "{} is a {} stage",
                s.name,
                s.kind
            );
            if s.kind == "surface" {
                assert_eq!(s.params.str("lattice").unwrap(), "square", "{}", s.name);
            }
        }
    }
}
