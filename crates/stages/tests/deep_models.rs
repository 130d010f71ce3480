//! Per-model keys of the deep refined ladder (`refined_deep_models`, `refined_deep_window_models`
//! in pipeline/paper.toml; issue 13): a model's table is merged over the shared `refined_deep_*`
//! keys, so its stage takes the shared values where the table is silent, the shared models'
//! stages keep their parameters and keys, the chain's readers get the stage as a `deep` input,
//! and a bad table fails at plan time naming the params file, the key, the value and what is
//! allowed.

use stages::orchestrator::Plan;
use std::path::{Path, PathBuf};

fn project_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The smoke preset (square and triangular deep ladders, 64² base) with `extra` appended, planned.
/// Its error, if any, as the CLI prints it (`{:#}`).
fn plan_with(extra: &str) -> (Result<Plan, String>, String, tempfile::TempDir) {
    let root = project_root();
    let smoke = std::fs::read_to_string(root.join("params/smoke.toml")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("models.toml");
    std::fs::write(&params, format!("{smoke}\n{extra}\n")).unwrap();
    let plan = Plan::load(
        &stages::registry(),
        &root.join("pipeline/paper.toml"),
        Some(&params),
    )
    .map_err(|e| format!("{e:#}"));
    (plan, params.display().to_string(), dir)
}

#[test]
fn a_deep_model_takes_its_own_keys_and_the_shared_ones_elsewhere() {
    let (base, _, _d0) = plan_with("");
    let base = base.expect("the smoke preset plans");
    let (plan, _, _d1) = plan_with(
        "refined_deep_models = [{ lattice = \"hexagonal\", levels = [2, 3], ls = [-0.01, -0.005, -0.002] }]\n\
         refined_deep_window_models = [{ lattice = \"hexagonal\", levels = [2, 3], ls = [-0.01, -0.005, -0.002] }]",
    );
    let plan = plan.expect("a valid model table plans");
    let hex = plan.stage("refined_deep_hexagonal").expect("its stage");
    let sq = base.stage("refined_deep_square").unwrap();
    assert_eq!(hex.kind, "refined_ladder");
    let p = |s: &stages::orchestrator::PlannedStage, k: &str| s.params.0[k].clone();
    assert_eq!(p(hex, "lattice"), serde_json::json!("hexagonal"));
    assert_eq!(p(hex, "levels"), serde_json::json!([2, 3]));
    assert_eq!(p(hex, "ls"), serde_json::json!([-0.01, -0.005, -0.002]));
    // the keys the table does not set are the shared settings'
    for k in [
        "base",
        "window",
        "margin",
        "margin_check",
        "tol_gap",
        "max_iter",
    ] {
        assert_eq!(p(hex, k), p(sq, k), "{k}");
    }
    // the shared models' stages are unchanged (same parameters, same keys)
    for name in [
        "refined_deep_square",
        "refined_deep_triangular",
        "refined_deep_window_square",
        "refined_deep_window_triangular",
    ] {
        if let Some(s) = base.stage(name) {
            assert_eq!(plan.stage(name).unwrap().key, s.key, "{name}");
        }
    }
    // its window check likewise (the window-check keys from refined_deep_window_*)
    let w = plan
        .stage("refined_deep_window_hexagonal")
        .expect("its window check");
    assert_eq!(w.kind, "refined_window");
    assert_eq!(p(w, "levels"), serde_json::json!([2, 3]));
    assert_eq!(p(w, "ls"), serde_json::json!([-0.01, -0.005, -0.002]));
    // the chain's readers take it as a deep ladder (and its window check as a window input)
    for reader in ["exponents", "running", "refined", "fig5"] {
        let s = plan.stage(reader).unwrap();
        let deep = &s.inputs["deep"];
        assert!(
            deep.iter().any(|x| x == "refined_deep_hexagonal"),
            "{reader}: {deep:?}"
        );
        assert!(
            deep.iter().any(|x| x == "refined_deep_square"),
            "{reader}: {deep:?}"
        );
        if let Some(win) = s.inputs.get("window") {
            assert!(
                win.iter().any(|x| x == "refined_deep_window_hexagonal"),
                "{reader}"
            );
        }
    }
}

#[test]
fn a_bad_deep_model_fails_at_plan_time_naming_file_key_value_and_range() {
    let cases: [(&str, &[&str]); 6] = [
        (
            "refined_deep_models = [{ lattice = \"hexagonal\", levels = [5, 4] }]",
            &["parameter `levels`", "[5, 4]", "strictly ascending"],
        ),
        (
            "refined_deep_models = [{ lattice = \"hexagonal\", margin = 2 }]",
            &["parameter `margin`", "2 is out of range", "5..=64"],
        ),
        (
            "refined_deep_models = [{ lattice = \"hexagonal\", ls = [-0.005, 0.0] }]",
            &["parameter `ls`", "0", "|l| ≥ 1e-12"],
        ),
        (
            "refined_deep_models = [{ lattice = \"hexagonal\", lvels = [4, 5] }]",
            &[
                "parameter `lvels`",
                "unknown parameter",
                "did you mean `levels`",
            ],
        ),
        (
            "refined_deep_models = [{ lattice = \"hexgonal\" }]",
            &["parameter `lattice`", "\"hexgonal\"", "\"hexagonal\""],
        ),
        (
            "refined_deep_window_models = [{ lattice = \"hexagonal\", window_check = 9999 }]",
            &["parameter `window_check`", "9999", "3..=512"],
        ),
    ];
    for (extra, wanted) in cases {
        let (plan, file, _d) = plan_with(extra);
        let msg = plan.map(|_| ()).expect_err(extra);
        // the params file and the line of the table
        assert!(msg.contains(&format!("{file}:")), "{extra}: {msg}");
        for w in wanted {
            assert!(msg.contains(w), "{extra}: `{w}` not in {msg}");
        }
    }
    // a model in both lists: one stage name, defined twice
    let (plan, _, _d) = plan_with("refined_deep_models = [{ lattice = \"square\" }]");
    let msg = plan.map(|_| ()).expect_err("square twice");
    assert!(
        msg.contains("refined_deep_square") && msg.contains("defined twice"),
        "{msg}"
    );
    // a table without its model
    let (plan, _, _d) = plan_with("refined_deep_models = [{ levels = [2, 3] }]");
    let msg = plan.map(|_| ()).expect_err("no lattice");
    assert!(msg.contains("no field `lattice`"), "{msg}");
}
