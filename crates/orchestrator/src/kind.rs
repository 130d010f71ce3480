//! Stage kinds: what a stage computes. Kinds are registered from outside this crate (the
//! physics kinds live in `crates/stages`); the orchestrator knows nothing about physics.

use crate::schema::{ParamIssue, ParamSpec};
use anyhow::{Context, Result, anyhow};
use serde::de::DeserializeOwned;
use serde_json::{Map, Value};
use std::collections::BTreeMap;
use std::sync::Arc;
use store::{ArtefactReader, ArtefactWriter};

/// A stage's validated parameters (every default filled in), with typed getters whose errors
/// name the parameter.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Params(pub Map<String, Value>);

impl Params {
    /// The raw value of `key`.
    pub fn get(&self, key: &str) -> Result<&Value> {
        self.0
            .get(key)
            .ok_or_else(|| anyhow!("parameter `{key}` is missing"))
    }
    /// A float parameter (integers convert).
    pub fn f64(&self, key: &str) -> Result<f64> {
        self.get(key)?
            .as_f64()
            .ok_or_else(|| anyhow!("parameter `{key}` is not a number"))
    }
    /// An integer parameter.
    pub fn i64(&self, key: &str) -> Result<i64> {
        self.get(key)?
            .as_i64()
            .ok_or_else(|| anyhow!("parameter `{key}` is not an integer"))
    }
    /// A boolean parameter.
    pub fn bool(&self, key: &str) -> Result<bool> {
        self.get(key)?
            .as_bool()
            .ok_or_else(|| anyhow!("parameter `{key}` is not a boolean"))
    }
    /// A string parameter.
    pub fn str(&self, key: &str) -> Result<&str> {
        self.get(key)?
            .as_str()
            .ok_or_else(|| anyhow!("parameter `{key}` is not a string"))
    }
    /// An array-of-floats parameter.
    pub fn f64_array(&self, key: &str) -> Result<Vec<f64>> {
        self.get(key)?
            .as_array()
            .ok_or_else(|| anyhow!("parameter `{key}` is not an array"))?
            .iter()
            .map(|v| {
                v.as_f64()
                    .ok_or_else(|| anyhow!("parameter `{key}` has a non-numeric element"))
            })
            .collect()
    }
    /// An array-of-strings parameter.
    pub fn str_array(&self, key: &str) -> Result<Vec<String>> {
        self.get(key)?
            .as_array()
            .ok_or_else(|| anyhow!("parameter `{key}` is not an array"))?
            .iter()
            .map(|v| {
                v.as_str()
                    .map(str::to_string)
                    .ok_or_else(|| anyhow!("parameter `{key}` has a non-string element"))
            })
            .collect()
    }
    /// Deserialises the whole parameter set into a typed struct.
    pub fn parse<T: DeserializeOwned>(&self) -> Result<T> {
        serde_json::from_value(Value::Object(self.0.clone())).context("parameters")
    }
    /// The parameters as a JSON value.
    pub fn to_value(&self) -> Value {
        Value::Object(self.0.clone())
    }
}

/// One named input a kind expects.
#[derive(Clone, Debug, PartialEq)]
pub struct InputSpec {
    /// Its name in the pipeline's `inputs` table.
    pub name: String,
    /// Kinds accepted (empty: any kind).
    pub kinds: Vec<String>,
    /// Whether it must be given.
    pub required: bool,
    /// Whether a list of stages may be given (otherwise exactly one).
    pub many: bool,
    /// One line of documentation.
    pub doc: String,
}

impl InputSpec {
    /// A required input taking exactly one stage of one of `kinds` (empty: any).
    pub fn one(name: &str, kinds: &[&str]) -> Self {
        Self {
            name: name.into(),
            kinds: kinds.iter().map(|s| s.to_string()).collect(),
            required: true,
            many: false,
            doc: String::new(),
        }
    }
    /// A required input taking a non-empty list of stages.
    pub fn many(name: &str, kinds: &[&str]) -> Self {
        Self {
            many: true,
            ..Self::one(name, kinds)
        }
    }
    /// Makes it optional.
    pub fn optional(mut self) -> Self {
        self.required = false;
        self
    }
    /// With documentation.
    pub fn doc(mut self, doc: &str) -> Self {
        self.doc = doc.into();
        self
    }
}

/// What a stage run reports besides its artefact; goes into the provenance.
#[derive(Clone, Debug, Default)]
pub struct StageReport {
    /// Solver statistics: iterations, residuals, converged flags, ... (free-form JSON object).
    pub stats: Value,
    /// Warnings (also collected from [`StageContext::warn`]).
    pub warnings: Vec<String>,
}

impl StageReport {
    /// A report with the given statistics.
    pub fn with_stats(stats: Value) -> Self {
        Self {
            stats,
            warnings: Vec::new(),
        }
    }
}

/// The opened input artefacts of a stage, by input name.
pub struct Inputs {
    pub(crate) map: BTreeMap<String, Vec<ArtefactReader>>,
}

impl Inputs {
    /// Inputs from already opened readers (for tests of stage kinds).
    pub fn new(map: BTreeMap<String, Vec<ArtefactReader>>) -> Self {
        Self { map }
    }
    /// The single artefact of input `name`.
    pub fn one(&self, name: &str) -> Result<&ArtefactReader> {
        match self.map.get(name).map(Vec::as_slice) {
            Some([r]) => Ok(r),
            Some(v) => Err(anyhow!(
                "input `{name}` has {} artefacts, expected one",
                v.len()
            )),
            None => Err(anyhow!("input `{name}` was not given")),
        }
    }
    /// The artefacts of input `name`, in the order the pipeline lists them (empty if absent).
    pub fn all(&self, name: &str) -> &[ArtefactReader] {
        self.map.get(name).map(Vec::as_slice).unwrap_or(&[])
    }
    /// Input names given.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.map.keys().map(String::as_str)
    }
}

/// Receives progress of a running stage (fraction in 0..=1 and a short message).
pub trait ProgressSink: Send + Sync {
    /// Called by [`StageContext::progress`].
    fn progress(&self, fraction: f64, message: &str);
}

/// What a running stage may use besides its parameters and inputs.
pub struct StageContext {
    /// The stage's name in the pipeline.
    pub stage: String,
    /// Its key.
    pub key: String,
    /// The project root (side-output paths are relative to it).
    pub root: std::path::PathBuf,
    pub(crate) warnings: Vec<String>,
    pub(crate) side_outputs: Vec<(String, Vec<u8>)>,
    pub(crate) sink: Option<Arc<dyn ProgressSink>>,
}

impl StageContext {
    /// A context for running a kind outside the runner (tests of stage kinds).
    pub fn detached(stage: &str, root: impl Into<std::path::PathBuf>) -> Self {
        Self {
            stage: stage.into(),
            key: String::new(),
            root: root.into(),
            warnings: Vec::new(),
            side_outputs: Vec::new(),
            sink: None,
        }
    }
    /// Reports progress (fraction in 0..=1) for the progress bar and its ETA.
    pub fn progress(&self, fraction: f64, message: &str) {
        if let Some(s) = &self.sink {
            s.progress(fraction.clamp(0.0, 1.0), message);
        }
    }
    /// Records a warning; it is logged and stored in the provenance.
    pub fn warn(&mut self, message: impl Into<String>) {
        self.warnings.push(message.into());
    }
    /// Emits a side output (a figure, a CSV table) at `path` relative to the project root. It
    /// must be one the kind declared in [`StageKind::side_outputs`]. The bytes are stored inside
    /// the artefact and published atomically to `path` after the artefact (and restored from it
    /// when the file is later deleted or edited).
    pub fn emit_file(&mut self, path: &str, bytes: Vec<u8>) {
        self.side_outputs.push((path.to_string(), bytes));
    }
    /// Side outputs emitted so far.
    pub fn emitted(&self) -> impl Iterator<Item = (&str, &[u8])> {
        self.side_outputs
            .iter()
            .map(|(p, b)| (p.as_str(), b.as_slice()))
    }
    /// Warnings recorded so far.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }
}

/// A kind of stage. Implementations live outside the orchestrator and are collected in a
/// [`Registry`].
///
/// Contract: `run` is a pure function of the parameters and the inputs' content (no clocks, no
/// randomness without a seed parameter, no reading of files other than its inputs). An edit of
/// the sources a kind depends on changes its code identity (see [`CodeIdentity`]) and so its
/// keys; bump [`code_version`](Self::code_version) for what that identity cannot see (e.g. a
/// new version of an external crate that changes results).
pub trait StageKind: Send + Sync {
    /// The kind's name as written in pipeline files (`surface`, `sweep`, ...).
    fn name(&self) -> &str;
    /// A constant bumped whenever results change for the same parameters.
    fn code_version(&self) -> u64;
    /// One line of documentation.
    fn doc(&self) -> &str {
        ""
    }
    /// The parameters: names, types, ranges, defaults.
    fn params(&self) -> Vec<ParamSpec>;
    /// Checks across parameters (after types and ranges passed).
    fn check(&self, _params: &Params) -> Result<(), ParamIssue> {
        Ok(())
    }
    /// Checks across stages, at plan time: `inputs` gives, by input name, the validated
    /// parameters of the stages wired to it. A constraint that depends on what the inputs will
    /// hold (e.g. "at least two grids in total") belongs here, so a bad configuration fails
    /// before anything is computed. The message says what is wrong and what is allowed.
    fn check_inputs(
        &self,
        _params: &Params,
        _inputs: &BTreeMap<String, Vec<Params>>,
    ) -> Result<(), String> {
        Ok(())
    }
    /// A lower bound of the stage's peak memory in bytes, from its parameters and its inputs'
    /// (as in [`check_inputs`](Self::check_inputs), each input's parameters also holding its
    /// own inputs' under [`UPSTREAM`], recursively: see [`upstream_max`]); `None`: unknown. A
    /// stage whose bound exceeds the memory available when it would start fails at once,
    /// naming the estimate, instead of being killed midway; so does one for which that many
    /// bytes cannot be reserved (an address-space limit). A lower bound, so that nothing that
    /// fits is refused.
    fn memory_estimate(
        &self,
        _params: &Params,
        _inputs: &BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        None
    }
    /// The inputs this kind takes (may depend on the parameters).
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        Vec::new()
    }
    /// Side outputs (paths relative to the project root, e.g. `figures/fig2.png`) this stage
    /// publishes besides its HDF5 artefact.
    fn side_outputs(&self, _params: &Params) -> Vec<String> {
        Vec::new()
    }
    /// Relative cost, for the ETA of the overall progress bar (default 1).
    fn cost(&self, _params: &Params) -> f64 {
        1.0
    }
    /// Computes the stage: reads `inputs`, writes datasets and attributes into `out` (the
    /// orchestrator adds provenance and publishes it), returns statistics and warnings.
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport>;
    /// Files (paths as given in the parameters; a relative path is relative to the project
    /// root, the folder above the pipeline file's folder) whose CONTENT enters the stage key,
    /// e.g. a user's height file: editing the file reruns the stage and what depends on it.
    /// Default: none (the key is then exactly as without this hook).
    fn file_inputs(&self, _params: &Params) -> Vec<String> {
        Vec::new()
    }
    /// For kinds with typed parameters (see [`TypedKind`]): whether `params` (validated,
    /// defaults filled) deserialise into the kind's parameter struct. `None`: the kind reads its
    /// parameters untyped. Tests use it to hold the [`ParamSpec`] list and the struct together.
    fn parse_typed(&self, _params: &Params) -> Option<Result<()>> {
        None
    }
}

/// Parses validated, defaults-filled parameters into a kind's typed struct; the error names
/// the kind and (through serde) the field.
pub fn parse_params<T: DeserializeOwned>(kind: &str, params: &Params) -> Result<T> {
    serde_json::from_value(params.to_value()).map_err(|e| {
        anyhow!(
            "stage kind `{kind}`: the parameters do not fit its typed parameters: {e} \
             (a kind whose ParamSpec list and parameter struct disagree: a bug in the kind)"
        )
    })
}

/// A stage kind whose parameters are a serde struct (`#[serde(deny_unknown_fields)]`, one
/// field per [`ParamSpec`]). Register it wrapped in [`Typed`]: the adapter validates nothing
/// itself (the plan has already checked every parameter against [`params`](Self::params) and
/// filled the defaults, so file:line error messages stay), it parses the checked map into
/// [`Self::Params`] once per call and hands the struct to `check`, `inputs`, `side_outputs`,
/// `cost` and `run`.
///
/// `check_inputs` and `memory_estimate` keep the untyped [`Params`]: they also see the
/// parameters of other stages (of other kinds).
pub trait TypedKind: Send + Sync {
    /// The parameter struct.
    type Params: DeserializeOwned;
    /// See [`StageKind::name`].
    fn name(&self) -> &str;
    /// See [`StageKind::code_version`].
    fn code_version(&self) -> u64;
    /// See [`StageKind::doc`].
    fn doc(&self) -> &str {
        ""
    }
    /// See [`StageKind::params`]: one spec per field of [`Self::Params`].
    fn params(&self) -> Vec<ParamSpec>;
    /// See [`StageKind::check`].
    fn check(&self, _params: &Self::Params) -> Result<(), ParamIssue> {
        Ok(())
    }
    /// See [`StageKind::check_inputs`].
    fn check_inputs(
        &self,
        _params: &Params,
        _inputs: &BTreeMap<String, Vec<Params>>,
    ) -> Result<(), String> {
        Ok(())
    }
    /// See [`StageKind::memory_estimate`].
    fn memory_estimate(
        &self,
        _params: &Params,
        _inputs: &BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        None
    }
    /// See [`StageKind::inputs`].
    fn inputs(&self, _params: &Self::Params) -> Vec<InputSpec> {
        Vec::new()
    }
    /// See [`StageKind::side_outputs`].
    fn side_outputs(&self, _params: &Self::Params) -> Vec<String> {
        Vec::new()
    }
    /// See [`StageKind::cost`].
    fn cost(&self, _params: &Self::Params) -> f64 {
        1.0
    }
    /// See [`StageKind::file_inputs`].
    fn file_inputs(&self, _params: &Self::Params) -> Vec<String> {
        Vec::new()
    }
    /// See [`StageKind::run`].
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &Self::Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport>;
}

/// The adapter that makes a [`TypedKind`] a [`StageKind`] (both interfaces coexist in one
/// [`Registry`]).
pub struct Typed<K>(pub K);

impl<K: TypedKind> Typed<K> {
    fn parse(&self, params: &Params) -> Result<K::Params> {
        parse_params(self.0.name(), params)
    }
}

impl<K: TypedKind> StageKind for Typed<K> {
    fn name(&self) -> &str {
        self.0.name()
    }
    fn code_version(&self) -> u64 {
        self.0.code_version()
    }
    fn doc(&self) -> &str {
        self.0.doc()
    }
    fn params(&self) -> Vec<ParamSpec> {
        self.0.params()
    }
    fn check(&self, params: &Params) -> Result<(), ParamIssue> {
        let p = self.parse(params).map_err(|e| ParamIssue {
            key: None,
            message: e.to_string(),
            at_key: false,
        })?;
        self.0.check(&p)
    }
    fn check_inputs(
        &self,
        params: &Params,
        inputs: &BTreeMap<String, Vec<Params>>,
    ) -> Result<(), String> {
        self.0.check_inputs(params, inputs)
    }
    fn memory_estimate(
        &self,
        params: &Params,
        inputs: &BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        self.0.memory_estimate(params, inputs)
    }
    // The plan calls `check` first and drops a stage whose parameters do not parse, so the
    // fallbacks below are never what a planned stage sees.
    fn inputs(&self, params: &Params) -> Vec<InputSpec> {
        self.parse(params)
            .map(|p| self.0.inputs(&p))
            .unwrap_or_default()
    }
    fn side_outputs(&self, params: &Params) -> Vec<String> {
        self.parse(params)
            .map(|p| self.0.side_outputs(&p))
            .unwrap_or_default()
    }
    fn cost(&self, params: &Params) -> f64 {
        self.parse(params).map_or(1.0, |p| self.0.cost(&p))
    }
    fn file_inputs(&self, params: &Params) -> Vec<String> {
        self.parse(params)
            .map(|p| self.0.file_inputs(&p))
            .unwrap_or_default()
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let p = self
            .parse(params)
            .with_context(|| format!("stage `{}`", ctx.stage))?;
        self.0.run(ctx, &p, inputs, out)
    }
    fn parse_typed(&self, params: &Params) -> Option<Result<()>> {
        Some(self.parse(params).map(drop))
    }
}

/// The key under which [`StageKind::memory_estimate`] finds an input's own inputs' parameters
/// (an object: input name → array of parameter objects, each again with this key if it has
/// inputs).
pub const UPSTREAM: &str = "_inputs";

/// The largest integer under any of `keys` (an integer, or the largest of an array of them)
/// in the parameters of `inputs` and of everything upstream of them (through [`UPSTREAM`]).
/// E.g. the finest grid exponent a stage's inputs derive from.
pub fn upstream_max(inputs: &BTreeMap<String, Vec<Params>>, keys: &[&str]) -> Option<i64> {
    fn walk(v: &Value, keys: &[&str], best: &mut Option<i64>) {
        let Some(o) = v.as_object() else { return };
        for k in keys {
            let vals: Vec<i64> = match o.get(*k) {
                Some(Value::Array(a)) => a.iter().filter_map(Value::as_i64).collect(),
                Some(x) => x.as_i64().into_iter().collect(),
                None => Vec::new(),
            };
            for x in vals {
                *best = Some(best.map_or(x, |b| b.max(x)));
            }
        }
        if let Some(up) = o.get(UPSTREAM).and_then(Value::as_object) {
            for list in up.values() {
                for p in list.as_array().into_iter().flatten() {
                    walk(p, keys, best);
                }
            }
        }
    }
    let mut best = None;
    for p in inputs.values().flatten() {
        walk(&p.to_value(), keys, &mut best);
    }
    best
}

/// The automatic identity of the code a kind runs: one hash per source part that can change
/// its output (e.g. `crate contact`, `stages/src/sweep.rs`), computed at build time by the
/// caller. It enters every key of the kind, so an edit of any part reruns exactly the stages
/// whose kind depends on it.
pub type CodeIdentity = BTreeMap<String, String>;

/// The stage kinds available to a pipeline, by name.
#[derive(Clone, Default)]
pub struct Registry {
    kinds: BTreeMap<String, Arc<dyn StageKind>>,
    code: BTreeMap<String, CodeIdentity>,
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Self::default()
    }
    /// Adds a kind; a later kind with the same name replaces the earlier one.
    pub fn register(&mut self, kind: impl StageKind + 'static) -> &mut Self {
        self.kinds.insert(kind.name().to_string(), Arc::new(kind));
        self
    }
    /// Adds a shared kind.
    pub fn register_arc(&mut self, kind: Arc<dyn StageKind>) -> &mut Self {
        self.kinds.insert(kind.name().to_string(), kind);
        self
    }
    /// The kind called `name`.
    pub fn get(&self, name: &str) -> Option<&Arc<dyn StageKind>> {
        self.kinds.get(name)
    }
    /// Sets the code identity of kind `name` (see [`CodeIdentity`]).
    pub fn set_code_identity(&mut self, name: &str, code: CodeIdentity) -> &mut Self {
        self.code.insert(name.to_string(), code);
        self
    }
    /// The code identity of kind `name` (empty if none was set: only `code_version` counts).
    pub fn code_identity(&self, name: &str) -> CodeIdentity {
        self.code.get(name).cloned().unwrap_or_default()
    }
    /// All kind names, sorted.
    pub fn names(&self) -> Vec<&str> {
        self.kinds.keys().map(String::as_str).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn p(v: Value) -> Params {
        Params(v.as_object().unwrap().clone())
    }

    #[test]
    fn upstream_max_finds_the_grid_of_an_input_of_an_input() {
        // flow ← sweep ← surface(n = 7); a second input with ns = [4, 9]
        let sweep = p(json!({"interaction": "hardwall", "_inputs": {"surface": [{"n": 7}]}}));
        let crit = p(json!({"ns": [4, 9]}));
        let mut inputs = BTreeMap::new();
        inputs.insert("sweep".to_string(), vec![sweep.clone()]);
        assert_eq!(upstream_max(&inputs, &["n", "ns"]), Some(7));
        inputs.insert("critical".to_string(), vec![crit]);
        assert_eq!(upstream_max(&inputs, &["n", "ns"]), Some(9));
        assert_eq!(upstream_max(&inputs, &["m"]), None);
    }
}
