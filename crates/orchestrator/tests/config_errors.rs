//! Errors in pipeline and params files name the file, the line, the key and what is allowed;
//! cycles, unknown references and missing inputs are rejected.

mod common;

use common::*;

fn err(pipeline: &str, params: &str) -> String {
    let p = Project::new(pipeline, params);
    let add = Add::new();
    p.plan_err(&registry(&add))
}

fn assert_has(msg: &str, parts: &[&str]) {
    for part in parts {
        assert!(msg.contains(part), "missing `{part}` in:\n{msg}");
    }
}

const SIMPLE: &str = r#"[settings]
n = { type = "int", min = 3, max = 13, doc = "grid exponent" }
tol = { default = 1e-8, min = 0.0 }

[stages.a]
kind = "add"
params = { n = "$n", scale = 2.0 }
"#;

#[test]
fn params_file_unknown_key() {
    let m = err(SIMPLE, "n = 5\ntoll = 1e-9\n");
    assert_has(
        &m,
        &[
            "params/x.toml:2:1",
            "unknown setting `toll`",
            "did you mean `tol`?",
            "allowed: n, tol",
        ],
    );
}

#[test]
fn params_file_wrong_type() {
    let m = err(SIMPLE, "n = \"five\"\n");
    assert_has(
        &m,
        &[
            "params/x.toml:1:5",
            "setting `n`",
            "expected an integer in 3..=13",
            "the string \"five\"",
            "pipeline/p.toml:2:1",
        ],
    );
}

#[test]
fn params_file_out_of_range() {
    let m = err(SIMPLE, "n = 20\n");
    assert_has(
        &m,
        &[
            "params/x.toml:1:5",
            "setting `n`",
            "20 is out of range",
            "an integer in 3..=13",
        ],
    );
}

#[test]
fn params_file_missing_required_setting() {
    let m = err(SIMPLE, "tol = 1e-9\n");
    assert_has(
        &m,
        &[
            "params/x.toml:1:1",
            "does not set `n`",
            "an integer in 3..=13",
        ],
    );
}

#[test]
fn out_of_range_through_a_reference_is_reported_at_the_params_line() {
    // the setting itself allows 20, the kind's parameter does not
    let pipeline = SIMPLE.replace("min = 3, max = 13, ", "");
    let m = err(&pipeline, "\n\nn = 20\n");
    assert_has(
        &m,
        &[
            "params/x.toml:3:5",
            "stage `a` (kind `add`)",
            "parameter `n`",
            "20 is out of range",
            "an integer in 3..=13",
            "pipeline/p.toml:7:16",
        ],
    );
}

#[test]
fn params_file_invalid_toml() {
    let m = err(SIMPLE, "n = 5\nn = 6\n");
    assert_has(&m, &["params/x.toml:2:", "invalid TOML"]);
}

#[test]
fn pipeline_unknown_keys() {
    let m = err(
        &SIMPLE.replace("kind = \"add\"", "kind = \"add\"\nkidn = 1"),
        "n = 5",
    );
    assert_has(
        &m,
        &[
            "pipeline/p.toml:7:1",
            "unknown key `kidn` in stage `a`",
            "allowed: kind, inputs, params, doc",
        ],
    );
    let m = err(&format!("{SIMPLE}\n[stage.b]\nkind = \"add\"\n"), "n = 5");
    assert_has(
        &m,
        &[
            "pipeline/p.toml:9:2",
            "unknown key `stage`",
            "did you mean `stages`?",
            "allowed: settings, scenes, stages",
        ],
    );
    let m = err(&SIMPLE.replace("scale = 2.0", "scael = 2.0"), "n = 5");
    assert_has(
        &m,
        &[
            "pipeline/p.toml:7:22",
            "parameter `scael`",
            "unknown parameter",
            "did you mean `scale`?",
            "allowed: value, scale, n, mode, fail, slow, label",
        ],
    );
    let m = err(
        &SIMPLE.replace("min = 0.0 }", "min = 0.0, maximum = 1 }"),
        "n = 5",
    );
    assert_has(
        &m,
        &[
            "pipeline/p.toml:3:",
            "unknown key `maximum` in setting `tol`",
            "allowed: type, default, min, max, allowed, doc",
        ],
    );
}

#[test]
fn pipeline_wrong_types_and_ranges() {
    let m = err(&SIMPLE.replace("scale = 2.0", "scale = \"big\""), "n = 5");
    assert_has(
        &m,
        &[
            "pipeline/p.toml:7:30",
            "parameter `scale`",
            "expected a number in [0, 10]",
            "the string \"big\"",
        ],
    );
    let m = err(&SIMPLE.replace("scale = 2.0", "scale = 11"), "n = 5");
    assert_has(
        &m,
        &[
            "pipeline/p.toml:7:30",
            "11 is out of range: expected a number in [0, 10]",
        ],
    );
    let m = err(&SIMPLE.replace("scale = 2.0", "mode = \"slow\""), "n = 5");
    assert_has(
        &m,
        &[
            "parameter `mode`",
            "\"slow\" is not allowed: expected one of \"fast\", \"exact\"",
        ],
    );
    let m = err(&SIMPLE.replace("kind = \"add\"", "kind = \"ad\""), "n = 5");
    assert_has(
        &m,
        &[
            "pipeline/p.toml:6:8",
            "unknown kind \"ad\"",
            "did you mean \"add\"?",
            "allowed: add, needs_source, source",
        ],
    );
    let m = err(&SIMPLE.replace("kind = \"add\"", "kind = 3"), "n = 5");
    assert_has(
        &m,
        &[
            "pipeline/p.toml:6:8",
            "`kind` must be a string, found an integer",
        ],
    );
    let m = err(&SIMPLE.replace("\"$n\"", "\"$nn\""), "n = 5");
    assert_has(
        &m,
        &[
            "pipeline/p.toml:7:16",
            "unknown setting `$nn`",
            "did you mean `$n`?",
        ],
    );
    let m = err(&SIMPLE.replace("default = 1e-8", "default = -1.0"), "n = 5");
    assert_has(
        &m,
        &[
            "pipeline/p.toml:3:",
            "setting `tol`: default: -1 is out of range",
        ],
    );
}

#[test]
fn several_errors_are_reported_together() {
    let m = err(
        &SIMPLE.replace("scale = 2.0", "scale = 11, mode = 1"),
        "n = 5\nzz = 1",
    );
    assert_has(&m, &["unknown setting `zz`"]);
    let m = err(
        &SIMPLE.replace("scale = 2.0", "scale = 11, mode = 1"),
        "n = 5",
    );
    assert_has(&m, &["parameter `scale`", "parameter `mode`"]);
}

#[test]
fn a_cycle_is_rejected() {
    let p = r#"
[stages.a]
kind = "add"
inputs = { inputs = ["c"] }

[stages.b]
kind = "add"
inputs = { inputs = ["a"] }

[stages.c]
kind = "add"
inputs = { inputs = ["b"] }

[stages.ok]
kind = "add"
"#;
    let m = err(p, "");
    assert_has(&m, &["the stages form a cycle", "b → c → a"]);
    let m = err(
        "[stages.a]\nkind = \"add\"\ninputs = { inputs = [\"a\"] }\n",
        "",
    );
    assert_has(&m, &["pipeline/p.toml:3:22", "refers to the stage itself"]);
}

#[test]
fn unknown_references_and_missing_inputs_are_rejected() {
    let m = err(
        &PIPELINE.replace("inputs = [\"c\"]", "inputs = [\"cc\"]"),
        "",
    );
    assert_has(
        &m,
        &[
            "pipeline/p.toml:28:22",
            "input `inputs` refers to unknown stage `cc`",
            "did you mean `c`?",
        ],
    );
    let m = err(
        &PIPELINE.replace("stages = [\"e\"]", "stages = [\"f\"]"),
        "",
    );
    assert_has(&m, &["scene `other` refers to unknown stage `f`"]);
    let m = err("[stages.x]\nkind = \"needs_source\"\n", "");
    assert_has(
        &m,
        &[
            "pipeline/p.toml:1:9",
            "missing input `surface` (a stage of kind source)",
        ],
    );
    let m = err(
        "[stages.s]\nkind = \"add\"\n[stages.x]\nkind = \"needs_source\"\ninputs = { surface = \"s\" }\n",
        "",
    );
    assert_has(
        &m,
        &[
            "pipeline/p.toml:5:22",
            "must be a stage of kind `source`, but `s` is of kind `add`",
        ],
    );
    let m = err(
        "[stages.s]\nkind = \"source\"\nparams = { lattice = \"square\" }\n[stages.x]\nkind = \"needs_source\"\ninputs = { surface = [\"s\", \"s\"], extra = \"s\" }\n",
        "",
    );
    assert_has(
        &m,
        &[
            "takes exactly one stage name, not a list",
            "takes no input `extra`; allowed: surface",
        ],
    );
    let m = err("[stages.s]\nkind = \"source\"\n", "");
    assert_has(
        &m,
        &[
            "pipeline/p.toml:1:9",
            "parameter `lattice`: missing; it is required: one of \"square\", \"triangular\", \"hexagonal\"",
        ],
    );
}

#[test]
fn unknown_scene_in_only_lists_scenes() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let plan = p.plan(&registry(&add));
    let e = plan.select(&["mian".into()]).unwrap_err().to_string();
    assert_has(
        &e,
        &[
            "`mian` is neither a scene nor a stage",
            "did you mean `main`?",
            "scenes: main, other",
        ],
    );
    // a stage name works too
    assert_eq!(plan.select(&["c".into()]).unwrap().len(), 3);
}

#[test]
fn literal_dollar_and_nested_references() {
    let p = Project::new(
        "[settings]\nv = { default = 2.5 }\n[stages.a]\nkind = \"add\"\nparams = { label = \"$$x\", value = \"$v\" }\n",
        "v = 4",
    );
    let add = Add::new();
    let plan = p.plan(&registry(&add));
    let a = plan.stage("a").unwrap();
    assert_eq!(a.params.str("label").unwrap(), "$x");
    assert_eq!(a.params.f64("value").unwrap(), 4.0);
    assert_eq!(a.side_outputs, ["figures/$x.txt"]);
}

#[test]
fn duplicate_key_names_the_key() {
    let m = err(SIMPLE, "n = 5\ntol = 1e-9\nn = 6\n");
    assert_has(&m, &["params/x.toml:3:1", "duplicate key `n`"]);
}

#[test]
fn two_stages_with_one_key_are_refused_naming_both() {
    let dup =
        format!("{SIMPLE}\n[stages.b]\nkind = \"add\"\nparams = {{ n = \"$n\", scale = 2.0 }}\n");
    let m = err(&dup, "n = 5\n");
    assert_has(
        &m,
        &[
            "stage `b` computes exactly what stage `a` computes",
            "let its readers take `a` instead",
        ],
    );
    // another parameter value gives another key: accepted
    let other =
        format!("{SIMPLE}\n[stages.b]\nkind = \"add\"\nparams = {{ n = \"$n\", scale = 3.0 }}\n");
    let p = Project::new(&other, "n = 5\n");
    let add = Add::new();
    assert_eq!(p.plan(&registry(&add)).stages.len(), 2);
}
