//! A matrix variable that takes a preset's setting (`matrix.seed = "$seeds"`, a list or a
//! range `{ from, to }`) and `"TEMPLATE[*]"` inputs (every instance of a template, in matrix
//! order): the stages are those written out by hand for that preset, mistakes name the file,
//! the key and the value, and an unchanged rerun runs nothing.

mod common;

use common::*;
use orchestrator::PipelineFile;

const TEMPLATED: &str = r#"
[settings]
seeds = { type = "array", doc = "one stage `a_SEED` per seed" }

[stages.a]
matrix.seed = "$seeds"
name = "a_{seed}"
kind = "add"
params = { n = "{seed}", label = "a_{seed}" }

[stages.sum]
kind = "add"
inputs = { inputs = "a[*]" }
params = { scale = 3.0 }
"#;

/// The stages of `TEMPLATED` for the seeds `seeds`, written by hand.
fn by_hand(seeds: &[i64]) -> String {
    let mut s = String::from("[settings]\nseeds = { type = \"array\" }\n");
    for x in seeds {
        s +=
            &format!("[stages.a_{x}]\nkind = \"add\"\nparams = {{ n = {x}, label = \"a_{x}\" }}\n");
    }
    let names: Vec<String> = seeds.iter().map(|x| format!("\"a_{x}\"")).collect();
    s += &format!(
        "[stages.sum]\nkind = \"add\"\ninputs = {{ inputs = [{}] }}\nparams = {{ scale = 3.0 }}\n",
        names.join(", ")
    );
    s
}

#[test]
fn a_preset_list_or_range_gives_the_stages_written_by_hand() {
    let add = Add::new();
    let reg = registry(&add);
    for (params, seeds) in [
        ("seeds = [3, 4]", vec![3, 4]),
        ("seeds = { from = 3, to = 6 }", vec![3, 4, 5, 6]),
        // matrix order is the list's order, not sorted
        ("seeds = [7, 3, 5]", vec![7, 3, 5]),
        ("seeds = [9]", vec![9]),
    ] {
        let plan = Project::new(TEMPLATED, params).plan(&reg);
        let want = concrete_stages(&Project::new(&by_hand(&seeds), params).plan(&reg));
        assert_eq!(concrete_stages(&plan), want, "params: {params}");
        assert_eq!(want.len(), seeds.len() + 1, "params: {params}");
        let sum = plan.stage("sum").unwrap();
        let order: Vec<String> = seeds.iter().map(|x| format!("a_{x}")).collect();
        assert_eq!(sum.inputs["inputs"], order, "params: {params}");
        // an instance still says where it came from
        let a = plan.stage(&order[0]).unwrap();
        assert_eq!(a.params.i64("n").unwrap(), seeds[0]);
    }
}

#[test]
fn a_pipeline_read_without_a_preset_leaves_such_templates_pending() {
    // no default: no instances yet, no error (the plan expands them with the preset)
    let p = PipelineFile::parse_str("p.toml", TEMPLATED).unwrap();
    let names: Vec<&str> = p.stages.keys().map(String::as_str).collect();
    assert_eq!(names, ["sum"]);
    assert!(p.stages["sum"].inputs["inputs"].stages.is_empty());
    // a default: its instances
    let text = TEMPLATED.replace("type = \"array\"", "default = [4, 5]");
    let p = PipelineFile::parse_str("p.toml", &text).unwrap();
    let names: Vec<&str> = p.stages.keys().map(String::as_str).collect();
    assert_eq!(names, ["a_4", "a_5", "sum"]);
}

#[test]
fn a_matrix_setting_that_is_not_a_list_is_an_error() {
    let add = Add::new();
    let reg = registry(&add);
    // an empty list: no instances (a preset opting out), and `a[*]` is the empty list
    let plan = Project::new(TEMPLATED, "seeds = []").plan(&reg);
    assert_eq!(
        concrete_stages(&plan),
        concrete_stages(&Project::new(&by_hand(&[]), "seeds = []").plan(&reg))
    );
    assert!(plan.stage("a_1").is_none() && plan.stage("sum").is_some());
    let err = |params: &str| Project::new(TEMPLATED, params).plan_err(&reg);
    assert_has(
        &err("seeds = 5"),
        &["x.toml:1:9: setting `seeds`", "expected an array"],
    );
    for bad in [
        "{ from = 6, to = 3 }",
        "{ from = 1 }",
        "{ from = 1, to = 2.5 }",
        "{ from = 1, to = 3, by = 2 }",
    ] {
        assert_has(
            &err(&format!("seeds = {bad}")),
            &[
                "x.toml:1:9: setting `seeds`",
                "is not a list nor a range",
                "{ from = 1, to = 16 } (from ≤ to",
            ],
        );
    }
    // a setting of another type taken by a matrix
    let any = TEMPLATED.replace("type = \"array\"", "type = \"any\"");
    assert_has(
        &Project::new(&any, "seeds = \"1..4\"").plan_err(&reg),
        &[
            "x.toml:1:9: setting `seeds` = \"1..4\"",
            "matrix variable `seed`",
            "found a string",
        ],
    );
    // a misspelt setting
    let typo = TEMPLATED.replace("\"$seeds\"", "\"$sedes\"");
    assert_has(
        &Project::new(&typo, "seeds = [3]").plan_err(&reg),
        &[
            "p.toml:6:15: template `a`: matrix variable `seed` = \"$sedes\": unknown setting `sedes`; did you mean `$seeds`?",
        ],
    );
}

#[test]
fn a_template_instance_input_names_a_template() {
    let add = Add::new();
    let reg = registry(&add);
    let m = Project::new(&TEMPLATED.replace("\"a[*]\"", "\"b[*]\""), "seeds = [3]").plan_err(&reg);
    assert_has(
        &m,
        &[
            "p.toml:13:21: stage `sum`: input `inputs`: \"b[*]\" names every instance of a template `b`",
            "did you mean \"a[*]\"?",
            "templates: a",
        ],
    );
    let m = Project::new(
        &(TEMPLATED.replace("\"a[*]\"", "[\"sum2[*]\", \"a[*]\"]")
            + "[stages.sum2]\nkind = \"add\"\n"),
        "seeds = [3]",
    )
    .plan_err(&reg);
    assert_has(&m, &["`sum2` is a single stage: write \"sum2\""]);
    // a list may mix stage names and templates' instances
    let plan = Project::new(
        &(TEMPLATED.replace("\"a[*]\"", "[\"b\", \"a[*]\"]") + "[stages.b]\nkind = \"add\"\n"),
        "seeds = [4, 3]",
    )
    .plan(&reg);
    assert_eq!(
        plan.stage("sum").unwrap().inputs["inputs"],
        ["b", "a_4", "a_3"]
    );
}

#[test]
fn an_unchanged_rerun_runs_nothing_and_a_new_seed_runs_only_its_stages() {
    let add = Add::new();
    let reg = registry(&add);
    let p = Project::new(TEMPLATED, "seeds = { from = 3, to = 4 }");
    assert_eq!(ran(&p.run(&reg, &quiet())), ["a_3", "a_4", "sum"]);
    assert!(ran(&p.run(&reg, &quiet())).is_empty());
    // the same seeds as a list: the same stages, nothing runs
    p.write("params/x.toml", "seeds = [3, 4]");
    assert!(ran(&p.run(&reg, &quiet())).is_empty());
    // one more seed: its stage and the summary run, the others stay cached
    p.write("params/x.toml", "seeds = [3, 4, 5]");
    assert_eq!(ran(&p.run(&reg, &quiet())), ["a_5", "sum"]);
}
