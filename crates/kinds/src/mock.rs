//! `mock`: a stage kind for testing the engine end to end (CLI, locking, interruption). Its
//! value is its `value` parameter plus the values of its inputs; it can sleep and fail on
//! purpose, and can write a side output.

use anyhow::{Result, bail};
use orchestrator::{InputSpec, Inputs, ParamSpec, ParamType, StageContext, StageReport, TypedKind};
use serde::Deserialize;
use serde_json::json;
use store::ArtefactWriter;

/// The `mock` stage kind.
pub struct MockKind;

/// The `mock` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MockParams {
    /// Own value.
    pub value: f64,
    /// Seconds to sleep.
    pub sleep_s: f64,
    /// Fail on purpose.
    pub fail: bool,
    /// Side output path ("" = none).
    pub side_output: String,
}

impl TypedKind for MockKind {
    type Params = MockParams;
    /// Lower bound 0: a test kind holding a number, no grid-sized allocation.
    fn memory_estimate(
        &self,
        _params: &orchestrator::Params,
        _inputs: &std::collections::BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        Some(0)
    }
    fn name(&self) -> &str {
        "mock"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn doc(&self) -> &str {
        "engine tests: value = `value` + the inputs' values; may sleep, fail, write a text file"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("value", ParamType::float()).default(0.0),
            ParamSpec::new("sleep_s", ParamType::float_range(0.0, 3600.0)).default(0.0),
            ParamSpec::new("fail", ParamType::Bool).default(false),
            ParamSpec::new("side_output", ParamType::string()).default(""),
        ]
    }
    fn inputs(&self, _params: &MockParams) -> Vec<InputSpec> {
        vec![InputSpec::many("inputs", &[]).optional()]
    }
    fn side_outputs(&self, params: &MockParams) -> Vec<String> {
        if params.side_output.is_empty() {
            Vec::new()
        } else {
            vec![params.side_output.clone()]
        }
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &MockParams,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let sleep = params.sleep_s;
        let steps = 20;
        for i in 0..steps {
            std::thread::sleep(std::time::Duration::from_secs_f64(sleep / steps as f64));
            ctx.progress((i + 1) as f64 / steps as f64, "sleeping");
        }
        if params.fail {
            bail!("failing on purpose (fail = true)");
        }
        let mut v = params.value;
        for r in inputs.all("inputs") {
            v += r.attr_f64("value")?;
        }
        out.set_attr("value", v)?;
        out.write_f64_1d("value", &[v])?;
        let side = &params.side_output;
        if !side.is_empty() {
            ctx.emit_file(side, format!("value = {v}\n").into_bytes());
        }
        Ok(StageReport::with_stats(json!({ "value": v })))
    }
}
