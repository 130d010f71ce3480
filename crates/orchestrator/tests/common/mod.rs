//! Mock stage kinds that count their runs, and a temporary project to run pipelines in.
#![allow(dead_code)]

use anyhow::{Result, bail};
use orchestrator::{
    InputSpec, Inputs, ParamSpec, ParamType, Params, Plan, ProgressMode, Registry, RunOptions,
    RunSummary, StageContext, StageKind, StageReport, What, Workspace,
};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use store::ArtefactWriter;

/// `add`: value = `value` + the inputs' values. Counts runs; may be slow, fail, mark its start
/// and write a side output `figures/<label>.txt`.
#[derive(Clone)]
pub struct Add {
    pub name: &'static str,
    pub version: u64,
    pub runs: Arc<Mutex<Vec<String>>>,
    /// How long a stage with `slow = true` sleeps (not a parameter: not part of the key).
    pub slow_ms: Arc<AtomicU64>,
    /// Folder where `<stage>.started` marker files are written when a stage starts.
    pub markers: Option<PathBuf>,
}

impl Add {
    pub fn new() -> Self {
        Self {
            name: "add",
            version: 1,
            runs: Arc::default(),
            slow_ms: Arc::new(AtomicU64::new(0)),
            markers: None,
        }
    }
    pub fn runs(&self) -> Vec<String> {
        self.runs.lock().unwrap().clone()
    }
}

impl StageKind for Add {
    fn name(&self) -> &str {
        self.name
    }
    fn code_version(&self) -> u64 {
        self.version
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("value", ParamType::float()).default(0.0),
            ParamSpec::new("scale", ParamType::float_range(0.0, 10.0)).default(1.0),
            ParamSpec::new("n", ParamType::int_range(3, 13)).default(5),
            ParamSpec::new("mode", ParamType::one_of(&["fast", "exact"])).default("fast"),
            ParamSpec::new("fail", ParamType::Bool).default(false),
            ParamSpec::new("slow", ParamType::Bool).default(false),
            ParamSpec::new("label", ParamType::string()).default(""),
        ]
    }
    fn inputs(&self, _p: &Params) -> Vec<InputSpec> {
        vec![InputSpec::many("inputs", &[]).optional()]
    }
    fn side_outputs(&self, p: &Params) -> Vec<String> {
        match p.str("label") {
            Ok(l) if !l.is_empty() => vec![format!("figures/{l}.txt")],
            _ => vec![],
        }
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        p: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        self.runs.lock().unwrap().push(ctx.stage.clone());
        if let Some(dir) = &self.markers {
            std::fs::create_dir_all(dir)?;
            std::fs::write(dir.join(format!("{}.started", ctx.stage)), b"")?;
        }
        // write part of the artefact before sleeping, so a kill leaves a real partial file
        out.write_f64_1d("data", &vec![1.0; 10_000])?;
        if p.bool("slow")? {
            let ms = self.slow_ms.load(Ordering::SeqCst);
            let t0 = std::time::Instant::now();
            while t0.elapsed().as_millis() < ms as u128 {
                std::thread::sleep(std::time::Duration::from_millis(10));
                ctx.progress(t0.elapsed().as_millis() as f64 / ms as f64, "sleeping");
            }
        }
        if p.bool("fail")? {
            bail!("failing on purpose");
        }
        let mut v = p.f64("value")? * p.f64("scale")?;
        for r in inputs.all("inputs") {
            v += r.attr_f64("value")?;
        }
        out.set_attr("value", v)?;
        let label = p.str("label")?;
        if !label.is_empty() {
            ctx.emit_file(
                &format!("figures/{label}.txt"),
                format!("{v}\n").into_bytes(),
            );
        }
        Ok(StageReport::with_stats(
            json!({"value": v, "iterations": 3}),
        ))
    }
}

/// A second kind, to test kind constraints on inputs.
#[derive(Clone)]
pub struct Source;

impl StageKind for Source {
    fn name(&self) -> &str {
        "source"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::new(
            "lattice",
            ParamType::one_of(&["square", "triangular", "hexagonal"]),
        )]
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

/// `needs_source`: takes exactly one `surface` input of kind `source`.
#[derive(Clone)]
pub struct NeedsSource;

impl StageKind for NeedsSource {
    fn name(&self) -> &str {
        "needs_source"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![]
    }
    fn inputs(&self, _p: &Params) -> Vec<InputSpec> {
        vec![InputSpec::one("surface", &["source"])]
    }
    fn run(
        &self,
        _ctx: &mut StageContext,
        _p: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let v = inputs.one("surface")?.attr_f64("value")?;
        out.set_attr("value", v)?;
        Ok(StageReport::default())
    }
}

pub fn registry(add: &Add) -> Registry {
    let mut r = Registry::new();
    r.register(add.clone());
    r.register(Source);
    r.register(NeedsSource);
    r
}

/// The standard test pipeline: a, b → c → d (side output), e independent.
pub const PIPELINE: &str = r#"
[settings]
va = { default = 1.0, doc = "value of a" }
vb = { default = 2.0 }
ve = { default = 5.0 }

[scenes.main]
doc = "d and what it needs"
stages = ["d"]

[scenes.other]
stages = ["e"]

[stages.a]
kind = "add"
params = { value = "$va" }

[stages.b]
kind = "add"
params = { value = "$vb" }

[stages.c]
kind = "add"
inputs = { inputs = ["a", "b"] }

[stages.d]
kind = "add"
inputs = { inputs = ["c"] }
params = { label = "d" }

[stages.e]
kind = "add"
params = { value = "$ve" }
"#;

/// A temporary project folder.
pub struct Project {
    pub dir: tempfile::TempDir,
}

impl Project {
    pub fn new(pipeline: &str, params: &str) -> Self {
        let p = Self {
            dir: tempfile::tempdir().unwrap(),
        };
        p.write("pipeline/p.toml", pipeline);
        p.write("params/x.toml", params);
        p
    }
    pub fn root(&self) -> &Path {
        self.dir.path()
    }
    pub fn path(&self, rel: &str) -> PathBuf {
        self.dir.path().join(rel)
    }
    pub fn write(&self, rel: &str, text: &str) {
        let p = self.path(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    pub fn ws(&self) -> Workspace {
        Workspace::new(self.root())
    }
    pub fn plan(&self, reg: &Registry) -> Plan {
        Plan::load(
            reg,
            &self.path("pipeline/p.toml"),
            Some(&self.path("params/x.toml")),
        )
        .unwrap_or_else(|e| panic!("{e:#}"))
    }
    pub fn plan_err(&self, reg: &Registry) -> String {
        match Plan::load(
            reg,
            &self.path("pipeline/p.toml"),
            Some(&self.path("params/x.toml")),
        ) {
            Ok(_) => panic!("the plan should not build"),
            Err(e) => format!("{e:#}"),
        }
    }
    pub fn run(&self, reg: &Registry, opts: &RunOptions) -> RunSummary {
        orchestrator::run(&self.ws(), &self.plan(reg), opts).unwrap_or_else(|e| panic!("{e:#}"))
    }
    /// Every file under results/ and figures/ (relative paths), sorted.
    pub fn files(&self) -> Vec<String> {
        let mut out = Vec::new();
        for top in ["results/cache", "figures"] {
            walk(&self.path(top), &mut out);
        }
        let mut v: Vec<String> = out
            .into_iter()
            .map(|p| {
                p.strip_prefix(self.root())
                    .unwrap()
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        v.sort();
        v
    }
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            walk(&p, out);
        } else {
            out.push(p);
        }
    }
}

pub fn quiet() -> RunOptions {
    RunOptions {
        progress: ProgressMode::Silent,
        ..Default::default()
    }
}

/// Names of the stages with a given event, in event order.
pub fn with_event(s: &RunSummary, pred: impl Fn(&What) -> bool) -> Vec<String> {
    s.events
        .iter()
        .filter(|e| pred(&e.what))
        .map(|e| e.stage.clone())
        .collect()
}

pub fn ran(s: &RunSummary) -> Vec<String> {
    let mut v = with_event(s, |w| matches!(w, What::Ran { .. }));
    v.sort();
    v
}

pub fn started(s: &RunSummary) -> Vec<String> {
    let mut v = with_event(s, |w| matches!(w, What::Started));
    v.sort();
    v
}

/// The reason tags of a stage's `planned` event.
pub fn reasons(s: &RunSummary, stage: &str) -> Vec<String> {
    s.events
        .iter()
        .find_map(|e| match &e.what {
            What::Planned { reasons, .. } if e.stage == stage => Some(reasons.clone()),
            _ => None,
        })
        .unwrap_or_default()
}

/// (stage, value attribute) of every published artefact of a plan.
pub fn values(p: &Project, reg: &Registry) -> Vec<(String, String, f64)> {
    let plan = p.plan(reg);
    let ws = p.ws();
    plan.stages
        .iter()
        .map(|s| {
            let r = store::ArtefactReader::open_complete(ws.artefact_of(s)).unwrap();
            (s.name.clone(), s.key.clone(), r.attr_f64("value").unwrap())
        })
        .collect()
}

/// What a plan makes of each concrete stage: name → (kind, key, inputs).
pub type ConcreteStages = std::collections::BTreeMap<
    String,
    (
        String,
        String,
        std::collections::BTreeMap<String, Vec<String>>,
    ),
>;

/// The concrete stages of a plan (to compare two spellings of one pipeline).
pub fn concrete_stages(plan: &Plan) -> ConcreteStages {
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

/// Panics unless `msg` contains every one of `parts`.
pub fn assert_has(msg: &str, parts: &[&str]) {
    for part in parts {
        assert!(msg.contains(part), "missing `{part}` in:\n{msg}");
    }
}
