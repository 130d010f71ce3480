//! The scene contract: a scene assembles data from its input stages and renders named outputs
//! (figures as PNG + SVG, tables as CSV, text), and is registered once in [`crate::SCENES`].
//! [`SceneKind`] turns a scene into a stage kind of the same name, so each scene has its own
//! parameters, code version and code identity (editing Figure 6 re-renders only Figure 6).
//!
//! Outputs are named, not positional: [`Scene::outputs`] declares them (name, what, file),
//! [`Scene::render`] returns them by name, and the stage fails if the two disagree.
//! Figures go under the stage's `figure_dir` (default `figures`), tables and text under its
//! `table_dir` (default `results/tables`).

use anyhow::{Result, bail};
use figures::Figure;
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, ParamType, Params, StageContext, StageKind,
    StageReport,
};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use store::ArtefactWriter;
use tables::Table;

/// What an output is, and its file name: a figure's stem (`.png` and `.svg` are added) under
/// `figure_dir`, a table's or a text's file name under `table_dir`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OutputFile {
    /// `<figure_dir>/<stem>.png` and `.svg`.
    Figure(&'static str),
    /// `<table_dir>/<file>` (CSV).
    Table(&'static str),
    /// `<table_dir>/<file>` (text, e.g. Markdown).
    Text(&'static str),
}

/// One declared output of a scene.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutputSpec {
    /// The name [`Scene::render`] returns it under.
    pub name: &'static str,
    /// What it is and where it goes.
    pub file: OutputFile,
}

impl OutputSpec {
    /// A figure output.
    pub fn figure(name: &'static str, stem: &'static str) -> Self {
        OutputSpec {
            name,
            file: OutputFile::Figure(stem),
        }
    }
    /// A CSV table output.
    pub fn table(name: &'static str, file: &'static str) -> Self {
        OutputSpec {
            name,
            file: OutputFile::Table(file),
        }
    }
    /// A text output.
    pub fn text(name: &'static str, file: &'static str) -> Self {
        OutputSpec {
            name,
            file: OutputFile::Text(file),
        }
    }
}

/// A rendered output.
pub enum Rendered {
    /// A figure (written as PNG and SVG).
    Figure(Figure),
    /// A table (written as CSV).
    Table(Table),
    /// Text, with the number of data rows it shows.
    Text(String, usize),
}

/// What [`Scene::render`] returns: outputs by name and statistics for the stage report.
#[derive(Default)]
pub struct Outputs {
    map: BTreeMap<&'static str, Rendered>,
    /// Scene statistics, reported under `scene` in the stage's statistics.
    pub stats: Value,
}

impl Outputs {
    /// No outputs yet.
    pub fn new() -> Self {
        Outputs::default()
    }
    /// Adds a figure.
    pub fn figure(mut self, name: &'static str, f: Figure) -> Self {
        self.map.insert(name, Rendered::Figure(f));
        self
    }
    /// Adds a table.
    pub fn table(mut self, name: &'static str, t: Table) -> Self {
        self.map.insert(name, Rendered::Table(t));
        self
    }
    /// Adds a text with its number of data rows.
    pub fn text(mut self, name: &'static str, s: String, rows: usize) -> Self {
        self.map.insert(name, Rendered::Text(s, rows));
        self
    }
    /// Sets the statistics.
    pub fn with_stats(mut self, stats: Value) -> Self {
        self.stats = stats;
        self
    }
}

/// A figure or table of the paper (or any report) built from input stages.
pub trait Scene: Sync {
    /// The stage kind's name (also the module's name).
    fn name(&self) -> &'static str;
    /// One line for `saddleflow kinds` and the docs.
    fn doc(&self) -> &'static str;
    /// Bump when the outputs change for the same inputs without a source change (the code
    /// identity covers source changes).
    fn code_version(&self) -> u64;
    /// The scene's own parameters (the output folders are added by [`SceneKind`]).
    fn params(&self) -> Vec<ParamSpec> {
        Vec::new()
    }
    /// Checks the parameters beyond their declared ranges.
    fn check(&self, _params: &Params) -> Result<(), ParamIssue> {
        Ok(())
    }
    /// How many grid-sized fields the scene reads whole from its inputs (fig1: a displacement,
    /// fig4: a gap, fig6: a gap and two current components): the memory pre-flight's lower
    /// bound is that many fields on the finest upstream grid; 0 for per-point data (kB).
    fn fields_read(&self) -> u64 {
        0
    }
    /// Whether the parameters (validated, defaults filled) parse into the scene's typed
    /// parameter struct (see [`scene_params`]); a scene with parameters overrides this with its
    /// struct. The default: the scene has none.
    fn parse_typed(&self, params: &Params) -> Result<()> {
        scene_params::<NoParams>(self.name(), params).map(drop)
    }
    /// The input stages.
    fn inputs(&self, params: &Params) -> Vec<InputSpec>;
    /// The outputs it writes.
    fn outputs(&self, params: &Params) -> Vec<OutputSpec>;
    /// Assembles the data and renders every declared output (attributes of the stage's artefact
    /// through `out`).
    fn render(
        &self,
        ctx: &mut StageContext,
        params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<Outputs>;
}

/// The parameters of a scene without parameters of its own.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoParams {}

/// A scene's own parameters as its typed struct (`#[serde(deny_unknown_fields)]`): the
/// validated, defaults-filled parameters without the output folders that [`SceneKind`] adds.
pub fn scene_params<T: serde::de::DeserializeOwned>(scene: &str, params: &Params) -> Result<T> {
    let mut own = params.0.clone();
    own.remove("figure_dir");
    own.remove("table_dir");
    orchestrator::parse_params(scene, &Params(own))
}

/// Checks a side-output path: relative, inside the project, no `..`.
pub fn check_relative(key: &str, path: &str) -> Result<(), ParamIssue> {
    let p = std::path::Path::new(path);
    if p.is_absolute()
        || p.components()
            .any(|c| !matches!(c, std::path::Component::Normal(_)))
    {
        return Err(ParamIssue::new(
            key,
            format!(
                "\"{path}\": allowed a relative path inside the project without `.` or `..` (e.g. \"figures\")"
            ),
        ));
    }
    Ok(())
}

fn dir(params: &Params, key: &str, default: &str) -> String {
    params
        .str(key)
        .unwrap_or(default)
        .trim_end_matches('/')
        .to_string()
}

/// The files of an output under the stage's folders.
fn files_of(params: &Params, o: &OutputSpec) -> Vec<String> {
    match o.file {
        OutputFile::Figure(stem) => {
            let d = dir(params, "figure_dir", "figures");
            vec![format!("{d}/{stem}.png"), format!("{d}/{stem}.svg")]
        }
        OutputFile::Table(f) | OutputFile::Text(f) => {
            vec![format!(
                "{}/{f}",
                dir(params, "table_dir", "results/tables")
            )]
        }
    }
}

/// A scene as a stage kind.
pub struct SceneKind(pub &'static dyn Scene);

impl StageKind for SceneKind {
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
        let mut v = self.0.params();
        v.push(
            ParamSpec::new("figure_dir", ParamType::string())
                .default("figures")
                .doc("folder of the figures, relative to the project root"),
        );
        v.push(
            ParamSpec::new("table_dir", ParamType::string())
                .default("results/tables")
                .doc("folder of the tables, relative to the project root"),
        );
        v
    }
    fn check(&self, params: &Params) -> Result<(), ParamIssue> {
        check_relative("figure_dir", &dir(params, "figure_dir", "figures"))?;
        check_relative("table_dir", &dir(params, "table_dir", "results/tables"))?;
        self.0.parse_typed(params).map_err(|e| ParamIssue {
            key: None,
            message: e.to_string(),
            at_key: false,
        })?;
        self.0.check(params)
    }
    fn parse_typed(&self, params: &Params) -> Option<Result<()>> {
        Some(self.0.parse_typed(params))
    }
    fn inputs(&self, params: &Params) -> Vec<InputSpec> {
        self.0.inputs(params)
    }
    fn memory_estimate(
        &self,
        _params: &Params,
        inputs: &BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        let fields = self.0.fields_read();
        if fields == 0 {
            return Some(0);
        }
        // the finest grid upstream, or a topography file's size (a lower bound)
        kinds::topography::upstream_field_bytes(inputs).map(|b| fields * b)
    }
    fn side_outputs(&self, params: &Params) -> Vec<String> {
        self.0
            .outputs(params)
            .iter()
            .flat_map(|o| files_of(params, o))
            .collect()
    }
    fn cost(&self, _params: &Params) -> f64 {
        0.05
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let declared = self.0.outputs(params);
        let mut rendered = self.0.render(ctx, params, inputs, out)?;
        for name in rendered.map.keys() {
            if !declared.iter().any(|o| o.name == *name) {
                bail!(
                    "scene `{}` rendered an undeclared output `{name}`",
                    self.0.name()
                );
            }
        }
        ctx.progress(0.5, "writing");
        let mut rows = serde_json::Map::new();
        let mut bytes = serde_json::Map::new();
        for o in &declared {
            let Some(r) = rendered.map.remove(o.name) else {
                bail!(
                    "scene `{}` did not render its output `{}`",
                    self.0.name(),
                    o.name
                );
            };
            let files = files_of(params, o);
            match (r, &o.file) {
                (Rendered::Figure(f), OutputFile::Figure(_)) => {
                    let png = f.render_png()?;
                    let svg = f.render_svg()?.into_bytes();
                    bytes.insert(files[0].clone(), json!(png.len()));
                    bytes.insert(files[1].clone(), json!(svg.len()));
                    ctx.emit_file(&files[0], png);
                    ctx.emit_file(&files[1], svg);
                }
                (Rendered::Table(t), OutputFile::Table(_)) => {
                    rows.insert(files[0].clone(), json!(t.n_rows()));
                    ctx.emit_file(&files[0], tables::csv_bytes(&t)?);
                }
                (Rendered::Text(s, n), OutputFile::Text(_)) => {
                    rows.insert(files[0].clone(), json!(n));
                    ctx.emit_file(&files[0], s.into_bytes());
                }
                _ => bail!(
                    "scene `{}`: output `{}` rendered as a different type than declared",
                    self.0.name(),
                    o.name
                ),
            }
        }
        out.set_attr("scene", self.0.name())?;
        if !rows.is_empty() {
            out.set_attr("rows", Value::Object(rows.clone()))?;
        }
        ctx.progress(1.0, "rendered");
        Ok(StageReport::with_stats(json!({
            "rows": rows,
            "bytes": bytes,
            "scene": rendered.stats,
        })))
    }
}
