//! The acid test of the pipeline language: `pipeline/paper.toml` and `params/*.toml`, rewritten
//! with named values, templates and `extends`, expand into exactly the concrete stages of the
//! files they replaced (kept in `tests/fixtures/before/`): the same names, kinds, inputs and
//! keys (the key hashes the kind, its code version, the canonical parameters with every
//! default and the input keys), and the same scenes, for all four presets.
//!
//! Both sides are planned with today's stage kinds, so a change to a kind moves both alike. A
//! deliberate change to the pipeline's stages makes this test fail: then make the same change
//! in the fixtures, or retire the fixtures once the rewrite is trusted.

use stages::orchestrator::Plan;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Name → (kind, key, inputs) of every stage of a plan.
type ConcreteStages = BTreeMap<String, (String, String, BTreeMap<String, Vec<String>>)>;

fn concrete_stages(plan: &Plan) -> ConcreteStages {
    plan.stages
        .iter()
        .map(|s| {
            (
                s.name.clone(),
                (s.kind.clone(), s.key.clone(), s.inputs.clone()),
            )
        })
        .collect()
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn plan(pipeline: &Path, params: &Path) -> (ConcreteStages, BTreeMap<String, Vec<String>>) {
    let plan = Plan::load(&stages::registry(), pipeline, Some(params))
        .unwrap_or_else(|e| panic!("{}: {e:#}", params.display()));
    (concrete_stages(&plan), plan.scenes)
}

#[test]
fn the_rewritten_pipeline_keys_every_stage_as_before() {
    let before = root().join("crates/stages/tests/fixtures/before");
    for preset in ["smoke", "draft", "paper", "reference"] {
        let params = format!("params/{preset}.toml");
        let (old, old_scenes) = plan(&before.join("pipeline/paper.toml"), &before.join(&params));
        let (new, new_scenes) = plan(&root().join("pipeline/paper.toml"), &root().join(&params));
        assert_eq!(old.len(), 59, "{preset}: the old pipeline has 59 stages");
        for (name, o) in &old {
            assert_eq!(new.get(name), Some(o), "{preset}: stage `{name}`");
        }
        assert_eq!(
            new.keys().collect::<Vec<_>>(),
            old.keys().collect::<Vec<_>>(),
            "{preset}"
        );
        assert_eq!(new_scenes, old_scenes, "{preset}");
    }
}
