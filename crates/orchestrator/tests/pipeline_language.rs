//! The pipeline language: named values, matrix templates, the `"<<"` merge key and `extends`
//! expand into concrete stages whose keys are those of the same stages written out by hand,
//! and mistakes in a template name the template, the instance and the file:line.

mod common;

use common::*;
use orchestrator::{ParamsFile, PipelineFile};

/// The same three stages, once by hand and once as a template over a named value.
#[test]
fn a_template_gives_the_stages_written_by_hand() {
    let by_hand = r#"
[settings]
n = { default = 5 }

[stages.a_square]
kind = "add"
params = { n = "$n", mode = "fast", value = 1.0, label = "a_square" }

[stages.a_hexagonal]
kind = "add"
params = { n = "$n", mode = "exact", value = 2.0, label = "a_hexagonal" }

[stages.sum]
kind = "add"
inputs = { inputs = ["a_square", "a_hexagonal"] }
params = { scale = 3.0 }
"#;
    let templated = r#"
[settings]
n = { default = 5 }

[values]
models = [{ lattice = "square", mode = "fast", value = 1.0 }, { lattice = "hexagonal", mode = "exact", value = 2.0 }]
common = { n = "$n" }
sum.inputs = ["a_square", "a_hexagonal"]

[stages.a]
matrix.model = "{models}"
name = "a_{model.lattice}"
kind = "add"
params = { "<<" = "{common}", mode = "{model.mode}", value = "{model.value}", label = "a_{model.lattice}" }

[stages.sum]
kind = "add"
inputs = { inputs = "{sum.inputs}" }
params = { scale = 3.0 }
"#;
    let add = Add::new();
    let reg = registry(&add);
    for params in ["", "n = 7"] {
        let a = concrete_stages(&Project::new(by_hand, params).plan(&reg));
        let b = concrete_stages(&Project::new(templated, params).plan(&reg));
        assert_eq!(a.len(), 3);
        assert_eq!(a, b, "params: {params:?}");
    }
}

#[test]
fn a_matrix_is_the_cartesian_product() {
    let p = PipelineFile::parse_str(
        "p.toml",
        r#"
[stages.s]
matrix = { x = ["a", "b", "c"], y = [1, 2] }
name = "s_{x}{y}"
kind = "add"
params = { label = "{x}-{y}", n = "{y}" }
"#,
    )
    .unwrap();
    let names: Vec<&str> = p.stages.keys().map(String::as_str).collect();
    assert_eq!(names, ["s_a1", "s_a2", "s_b1", "s_b2", "s_c1", "s_c2"]);
    let s = &p.stages["s_b2"];
    assert_eq!(s.params["label"].value, "b-2");
    assert_eq!(
        s.params["n"].value, 2,
        "a whole-string reference keeps the type"
    );
    // every value of an instance says where it came from
    let ctx = s.origin.context.as_deref().unwrap();
    assert_eq!(ctx, "template `s`, instance `s_b2`");
    assert_eq!((s.origin.line, s.origin.col), (2, 9));
}

#[test]
fn braces_escape_and_references_inside_strings() {
    let p = PipelineFile::parse_str(
        "p.toml",
        "[values]\nw = \"world\"\nk = 3\n[stages.a]\nkind = \"add\"\nparams = { label = \"{{x}} {w}_{k}\" }\n",
    )
    .unwrap();
    assert_eq!(p.stages["a"].params["label"].value, "{x} world_3");
}

#[test]
fn an_error_in_a_template_names_the_template_the_instance_and_the_line() {
    let add = Add::new();
    let reg = registry(&add);
    // a value out of range in one instance only: reported there, at the row that holds it
    let m = Project::new(
        r#"[stages.t]
matrix.row = [{ id = "ok", scale = 2.0 },
              { id = "bad", scale = 11.0 }]
name = "t_{row.id}"
kind = "add"
params = { scale = "{row.scale}" }
"#,
        "",
    )
    .plan_err(&reg);
    assert_has(
        &m,
        &[
            "p.toml:3:37",
            "stage `t_bad` (kind `add`): parameter `scale`: 11 is out of range",
            "(in template `t`, instance `t_bad`)",
        ],
    );
    assert!(!m.contains("t_ok"), "{m}");
    // an unknown name: did-you-mean, the names known, every instance
    let m = Project::new(
        "[values]\nlattices = [\"square\", \"hexagonal\"]\n[stages.t]\nmatrix = { lattice = \"{lattices}\" }\nname = \"t_{lattice}\"\nkind = \"add\"\nparams = { label = \"{latice}\" }\n",
        "",
    )
    .plan_err(&reg);
    assert_has(
        &m,
        &[
            "p.toml:7:20: unknown name `{latice}`; did you mean `{lattice}`? known: lattice, lattices",
            "(in template `t`, instance `t_square`)",
            "(in template `t`, instance `t_hexagonal`)",
        ],
    );
    // a missing field
    let m = Project::new(
        "[stages.t]\nmatrix.m = [{ a = 1 }]\nname = \"t_{m.b}\"\nkind = \"add\"\n",
        "",
    )
    .plan_err(&reg);
    assert_has(
        &m,
        &["p.toml:3:8", "`{m.b}`: `m` has no field `b`; its fields: a"],
    );
}

#[test]
fn template_mistakes_are_reported() {
    let add = Add::new();
    let reg = registry(&add);
    let err = |text: &str| Project::new(text, "").plan_err(&reg);
    assert_has(
        &err("[stages.t]\nmatrix = { x = [1, 2] }\nkind = \"add\"\n"),
        &[
            "p.toml:1:9",
            "template `t` has a `matrix`, so it needs `name = \"...\"`",
            "{x}",
        ],
    );
    assert_has(
        &err("[stages.t]\nmatrix = { x = [1, 2], y = [3, 4] }\nname = \"t_{x}\"\nkind = \"add\"\n"),
        &["p.toml:3:8", "two instances are named `t_1`", "{x}, {y}"],
    );
    // a mistake in the name pattern: once, for the template
    let m = err("[stages.t]\nmatrix = { x = [1, 2] }\nname = \"t_{z}\"\nkind = \"add\"\n");
    assert_has(&m, &["p.toml:3:8: unknown name `{z}`", "(in template `t`)"]);
    assert_eq!(m.lines().count(), 1, "{m}");
    assert_has(
        &err("[stages.t]\nmatrix = { x = [] }\nname = \"t_{x}\"\nkind = \"add\"\n"),
        &[
            "p.toml:2:16",
            "matrix variable `x` must be a non-empty array",
        ],
    );
    assert_has(
        &err("[stages.t]\nname = \"t_1\"\nkind = \"add\"\n"),
        &[
            "p.toml:2:1",
            "`name` names the instances of a template; it needs a `matrix`",
        ],
    );
    assert_has(
        &err(
            "[stages.t_1]\nkind = \"add\"\n[stages.t]\nmatrix = { x = [1] }\nname = \"t_{x}\"\nkind = \"add\"\n",
        ),
        &[
            "stage `t_1` is defined twice:",
            "p.toml:1:9",
            "p.toml:3:9 (in template `t`, instance `t_1`)",
        ],
    );
    assert_has(
        &err("[values]\na = \"{b}\"\nb = [\"{a}\"]\n[stages.s]\nkind = \"add\"\n"),
        &["named values refer to each other in a cycle: a → b → a"],
    );
    assert_has(
        &err("[stages.s]\nkind = \"add\"\nparams = { label = \"x}\" }\n"),
        &["p.toml:3:20", "unmatched `}` in \"x}\""],
    );
    assert_has(
        &err("[stages.s]\nkind = \"add\"\nparams = { \"<<\" = 3 }\n"),
        &[
            "p.toml:3:19",
            "merges a table (or a list of tables) into this one, found an integer",
        ],
    );
    assert_has(
        &err(
            "[values]\nt = { a = 1 }\n[stages.s]\nkind = \"add\"\nparams = { label = \"x{t}\" }\n",
        ),
        &[
            "p.toml:5:20",
            "`{t}` is a table",
            "only a string or an integer can be part of a longer string",
        ],
    );
}

#[test]
fn presets_extend_each_other_deep_merged() {
    let add = Add::new();
    let reg = registry(&add);
    let p = Project::new(
        "[settings]\nn = { type = \"int\" }\nmode = { default = \"fast\" }\n[stages.a]\nkind = \"add\"\nparams = { n = \"$n\", mode = \"$mode\" }\n",
        "extends = \"base.toml\"\nn = 9\n",
    );
    p.write("params/base.toml", "n = 4\nmode = \"exact\"\n");
    let plan = p.plan(&reg);
    let a = plan.stage("a").unwrap();
    assert_eq!(a.params.i64("n").unwrap(), 9, "the extending file wins");
    assert_eq!(
        a.params.str("mode").unwrap(),
        "exact",
        "the base's value is kept"
    );

    // a pipeline extending another: one parameter of one stage changed, the rest kept
    p.write(
        "pipeline/base.toml",
        "[stages.a]\nkind = \"add\"\nparams = { value = 1.0, scale = 2.0 }\n[stages.b]\nkind = \"add\"\n",
    );
    p.write(
        "pipeline/p.toml",
        "extends = \"base.toml\"\n[stages.a.params]\nscale = 3.0\n",
    );
    p.write("params/x.toml", "");
    let plan = p.plan(&reg);
    let a = plan.stage("a").unwrap();
    assert_eq!(
        (
            a.params.f64("value").unwrap(),
            a.params.f64("scale").unwrap()
        ),
        (1.0, 3.0)
    );
    assert!(plan.stage("b").is_some());
}

#[test]
fn an_extends_cycle_or_a_missing_base_is_an_error() {
    let p = Project::new("[stages.a]\nkind = \"add\"\n", "");
    let err = |text: &str| {
        p.write("params/x.toml", text);
        ParamsFile::load(&p.path("params/x.toml"))
            .unwrap_err()
            .to_string()
    };
    p.write("params/y.toml", "extends = \"x.toml\"\n");
    assert_has(
        &err("extends = \"y.toml\"\n"),
        &[
            "y.toml:1:11",
            "`extends` forms a cycle:",
            "x.toml → ",
            "y.toml → ",
        ],
    );
    assert_has(
        &err("extends = \"nope.toml\"\n"),
        &[
            "x.toml:1:11",
            "no file",
            "nope.toml",
            "relative to this file's folder",
        ],
    );
    assert_has(
        &err("extends = 3\n"),
        &["x.toml:1:11", "`extends` must be a file name"],
    );
}
