//! File inputs (`StageKind::file_inputs`): a file's content enters the stage key, so editing
//! the file reruns the stage and what depends on it, while rewriting it unchanged does not;
//! a missing file fails the plan naming the stage and the file; a kind without file inputs
//! keeps its key exactly.

mod common;

use anyhow::Result;
use common::*;
use orchestrator::{Inputs, ParamSpec, ParamType, Params, StageContext, StageKind, StageReport};
use store::ArtefactWriter;

/// `reads`: value = the number written in the file `path` (relative to the project root).
#[derive(Clone)]
struct Reads;

impl StageKind for Reads {
    fn name(&self) -> &str {
        "reads"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::new("path", ParamType::string())]
    }
    fn file_inputs(&self, p: &Params) -> Vec<String> {
        vec![p.str("path").unwrap().to_string()]
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        p: &Params,
        _inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let text = std::fs::read_to_string(ctx.root.join(p.str("path")?))?;
        out.set_attr("value", text.trim().parse::<f64>()?)?;
        Ok(StageReport::default())
    }
}

const PIPELINE: &str = r#"
[stages.r]
kind = "reads"
params = { path = "data/h.txt" }

[stages.sum]
kind = "add"
inputs = { inputs = ["r"] }
"#;

fn key(p: &orchestrator::Plan, name: &str) -> String {
    p.stages
        .iter()
        .find(|s| s.name == name)
        .unwrap()
        .key
        .clone()
}

#[test]
fn editing_the_file_reruns_the_stage_and_its_dependants() {
    let add = Add::new();
    let mut reg = registry(&add);
    reg.register(Reads);
    let p = Project::new(PIPELINE, "");
    p.write("data/h.txt", "1.5\n");
    let first = p.run(&reg, &quiet());
    assert_eq!(ran(&first), ["r", "sum"]);
    let k1 = key(&p.plan(&reg), "r");
    // the same content written again: same key, nothing runs
    p.write("data/h.txt", "1.5\n");
    assert_eq!(key(&p.plan(&reg), "r"), k1);
    assert!(ran(&p.run(&reg, &quiet())).is_empty());
    // edited: new key, both rerun, and the new value flows downstream
    p.write("data/h.txt", "2.5\n");
    let k2 = key(&p.plan(&reg), "r");
    assert_ne!(k1, k2);
    assert_eq!(ran(&p.run(&reg, &quiet())), ["r", "sum"]);
    let plan = p.plan(&reg);
    let sum = plan.stages.iter().find(|s| s.name == "sum").unwrap();
    let r = store::ArtefactReader::open(p.ws().artefact_path(&sum.kind, &sum.key)).unwrap();
    assert_eq!(r.attr_f64("value").unwrap(), 2.5);
}

#[test]
fn a_missing_file_fails_the_plan_naming_stage_and_file() {
    let add = Add::new();
    let mut reg = registry(&add);
    reg.register(Reads);
    let p = Project::new(PIPELINE, "");
    let e = p.plan_err(&reg);
    assert!(e.contains("stage `r`") && e.contains("data/h.txt"), "{e}");
}

#[test]
fn a_kind_without_file_inputs_keeps_its_key() {
    let add = Add::new();
    let reg = registry(&add);
    let p = Project::new("[stages.a]\nkind = \"add\"\n", "");
    let plan = p.plan(&reg);
    let s = &plan.stages[0];
    let plain =
        orchestrator::plan::stage_key(&s.kind, s.code_version, &s.code, &s.params, &s.input_keys)
            .unwrap();
    assert_eq!(s.key, plain);
}
