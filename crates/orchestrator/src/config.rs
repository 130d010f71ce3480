//! The declarative files: `pipeline/*.toml` and `params/*.toml`.
//!
//! # Pipeline files
//!
//! ```toml
//! # What a params file may (or must) set. Each entry: `type` ("int", "float", "string", "bool",
//! # "array", "any") and/or `default`; optional `min`, `max` (numbers, inclusive), `allowed`
//! # (strings), `doc`. A setting without a default must be set by every params file.
//! [settings]
//! n     = { type = "int", min = 3, max = 13, doc = "grid exponent: 2^n × 2^n nodes" }
//! tol   = { default = 1e-8, min = 0.0, doc = "solver tolerance" }
//! steps = { default = 40, min = 2 }
//!
//! # A scene is one figure or table; it names the stages it needs (their inputs come along).
//! [scenes.fig2]
//! doc = "Figure 2: relative contact area against load, square model"
//! stages = ["fig2"]
//!
//! # A stage: a kind, its parameters, its inputs (other stages, by name).
//! [stages.square]
//! kind = "surface"
//! params = { lattice = "square", n = "$n" }      # "$n": the params file's setting `n`
//!
//! [stages.sweep_hardwall]
//! kind = "sweep"
//! inputs = { surface = "square" }
//! params = { interaction = "hardwall", steps = "$steps", tol = "$tol" }
//!
//! [stages.fig2]
//! kind = "fig2"
//! inputs = { curves = ["sweep_hardwall", "sweep_adhesion"] }   # a list where the kind allows
//! ```
//!
//! A parameter value that is a string starting with `$` refers to a setting (`"$n"`); write
//! `"$$"` for a literal leading `$`. References may appear inside arrays and tables too.
//! Every parameter is then validated by the stage's kind (type, range, allowed values) and its
//! defaults are filled in, so that the key of a stage sees all of them.
//!
//! # Named values, templates, `extends`
//!
//! ```toml
//! extends = "base.toml"          # this file's tables deep-merged onto base.toml's
//!
//! [values]                       # written once, used by name
//! lattices = ["square", "hexagonal"]
//! common = { tol = "$tol" }
//!
//! [stages.surface]               # a template: one stage per combination of the matrix
//! matrix = { lattice = "{lattices}", n = [5, 6] }
//! name = "surface_{lattice}_{n}" # surface_square_5, surface_square_6, surface_hexagonal_5, ...
//! kind = "surface"
//! params = { "<<" = "{common}", lattice = "{lattice}", n = "{n}" }
//! ```
//!
//! `"{name}"` is replaced by a named value or matrix variable (any type), `"{name.field}"` by a
//! field of it (`"{rows.0}"`: an element), and `"x_{name}"` splices a string or integer into a
//! longer string (`{{`, `}}`: literal braces); `"<<"` merges a table into the one it is written
//! in. A matrix variable written `"$setting"` takes a list-valued setting (a list, or a range
//! `{ from = 1, to = 16 }`), so the template is expanded per preset
//! ([`PipelineFile::for_params`]); an input `"TEMPLATE[*]"` is every instance of a template, in
//! matrix order. Params files may use `extends` too. The expansion (`config/expand.rs`) and the merge
//! (`config/tree.rs`) happen before anything else sees the file: a plan, its keys, dry-run reasons and errors are
//! per concrete stage, and an error in a template instance names the template and the instance
//! after its `file:line:col`. `docs/pipeline.md` has the full description.
//!
//! # Params files
//!
//! A flat table of settings declared by the pipeline file:
//!
//! ```toml
//! # params/draft.toml: minutes on two cores
//! n = 9
//! tol = 1e-9
//! ```
//!
//! Errors name the file, line and column, the key, and what is allowed.

use crate::schema::{ParamType, describe};
use crate::util::did_you_mean;
use serde_json::Value;
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use toml::Spanned;
use tree::{Key, Node, Val};

mod expand;
mod tree;

/// A place in a file: `file:line:col` (1-based).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Origin {
    /// The file as the user named it.
    pub file: Arc<str>,
    /// Line, 1-based.
    pub line: usize,
    /// Column (characters), 1-based.
    pub col: usize,
    /// For a value of an expanded template: "template `T`, instance `I`" (printed after the
    /// message of an error at this place).
    pub context: Option<Arc<str>>,
}

impl Origin {
    /// `file:line:col`, followed by the template instance it belongs to, if any.
    pub fn with_context(&self) -> String {
        match &self.context {
            Some(c) => format!("{self} (in {c})"),
            None => self.to_string(),
        }
    }
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.col)
    }
}

/// One error in a declarative file.
#[derive(Clone, Debug, PartialEq)]
pub struct ConfigError {
    /// Where (if known).
    pub origin: Option<Origin>,
    /// What is wrong and what is allowed.
    pub message: String,
}

impl ConfigError {
    /// An error at `origin`.
    pub fn at(origin: &Origin, message: impl Into<String>) -> Self {
        Self {
            origin: Some(origin.clone()),
            message: message.into(),
        }
    }
    /// An error with no position.
    pub fn plain(message: impl Into<String>) -> Self {
        Self {
            origin: None,
            message: message.into(),
        }
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.origin {
            Some(o) => write!(f, "{o}: {}", self.message)?,
            None => write!(f, "{}", self.message)?,
        }
        match self.origin.as_ref().and_then(|o| o.context.as_ref()) {
            Some(c) => write!(f, " (in {c})"),
            None => Ok(()),
        }
    }
}

/// All errors found in the declarative files (reported together, like a compiler does).
#[derive(Clone, Debug, PartialEq)]
pub struct ConfigErrors(pub Vec<ConfigError>);

impl fmt::Display for ConfigErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.0.len();
        for (i, e) in self.0.iter().enumerate().take(30) {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{e}")?;
        }
        if n > 30 {
            write!(f, "\n... and {} more errors", n - 30)?;
        }
        Ok(())
    }
}

impl std::error::Error for ConfigErrors {}

/// A value with the place it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct Located<T> {
    /// The value.
    pub value: T,
    /// Where it was written.
    pub origin: Origin,
}

/// A source file with line offsets, to turn byte spans into lines and columns.
struct Source {
    name: Arc<str>,
    text: String,
    line_starts: Vec<usize>,
}

impl Source {
    fn new(name: &str, text: String) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Self {
            name: name.into(),
            text,
            line_starts,
        }
    }
    fn origin(&self, offset: usize) -> Origin {
        let line = self.line_starts.partition_point(|&s| s <= offset).max(1);
        let start = self.line_starts[line - 1];
        let end = offset.min(self.text.len());
        let col = self
            .text
            .get(start..end)
            .map_or(1, |s| s.chars().count() + 1);
        Origin {
            file: self.name.clone(),
            line,
            col,
            context: None,
        }
    }
    fn at<T>(&self, s: &Spanned<T>) -> Origin {
        self.origin(s.span().start)
    }
}

/// Whether `name` is a valid stage, scene or setting name: ASCII letters, digits, `_`, `-`,
/// starting with a letter or `_`.
pub fn valid_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// A setting a params file may set, declared in the pipeline's `[settings]`.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingDecl {
    /// Type and range.
    pub ty: ParamType,
    /// Default (`None`: every params file must set it).
    pub default: Option<Value>,
    /// Documentation.
    pub doc: String,
    /// Where it was declared.
    pub origin: Origin,
}

/// A scene: one figure or table and the stages it needs.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneDecl {
    /// Target stages (their inputs come along).
    pub stages: Vec<Located<String>>,
    /// Documentation.
    pub doc: String,
    /// Where it was declared.
    pub origin: Origin,
}

/// A stage as written in a pipeline file (parameters unresolved).
#[derive(Clone, Debug, PartialEq)]
pub struct StageDecl {
    /// Its kind.
    pub kind: Located<String>,
    /// Input name → stage names (a single name is a list of one; `many` tells which form).
    pub inputs: BTreeMap<String, InputDecl>,
    /// Parameters as written (may hold `$setting` references).
    pub params: BTreeMap<String, Located<Value>>,
    /// Where each parameter's name is written.
    pub param_keys: BTreeMap<String, Origin>,
    /// Documentation.
    pub doc: String,
    /// Where it was declared (its table header).
    pub origin: Origin,
}

/// One input of a stage declaration.
#[derive(Clone, Debug, PartialEq)]
pub struct InputDecl {
    /// Stage names.
    pub stages: Vec<Located<String>>,
    /// Whether it was written as a list.
    pub list: bool,
    /// Where it was written.
    pub origin: Origin,
}

/// A parsed pipeline file.
#[derive(Clone, Debug, PartialEq)]
pub struct PipelineFile {
    /// Its path as given.
    pub path: PathBuf,
    /// Declared settings, by name.
    pub settings: BTreeMap<String, SettingDecl>,
    /// Scenes, by name.
    pub scenes: BTreeMap<String, SceneDecl>,
    /// Stages, by name.
    pub stages: BTreeMap<String, StageDecl>,
    /// The merged tree, kept when a matrix takes a setting: such templates are expanded again
    /// once the preset is known ([`PipelineFile::for_params`]).
    source: Option<Node>,
}

/// A parsed params file: setting name → value (as written, unchecked).
#[derive(Clone, Debug, PartialEq)]
pub struct ParamsFile {
    /// Its path as given.
    pub path: PathBuf,
    /// Values by setting name.
    pub values: BTreeMap<String, Located<Value>>,
    /// Where each setting's name is written.
    pub keys: BTreeMap<String, Origin>,
    /// Where the file starts (for "missing setting" errors).
    pub origin: Origin,
}

const PIPELINE_KEYS: &[&str] = &["settings", "scenes", "stages", "values", "extends"];
const SETTING_KEYS: &[&str] = &["type", "default", "min", "max", "allowed", "doc"];
const SETTING_TYPES: &[&str] = &["int", "float", "string", "bool", "array", "any"];
const SCENE_KEYS: &[&str] = &["stages", "doc"];
const STAGE_KEYS: &[&str] = &["kind", "inputs", "params", "doc", "matrix", "name"];

impl PipelineFile {
    /// Reads and checks the structure of a pipeline file, following `extends` and expanding
    /// named values and templates (kinds and references are checked when a plan is built).
    pub fn load(path: &Path) -> Result<Self, ConfigErrors> {
        Self::from_tree(path, tree::load_tree(path, None)?, None)
    }

    /// Parses pipeline text (for tests); `name` is used in error messages (and an `extends`
    /// is read relative to its folder).
    pub fn parse_str(name: &str, text: &str) -> Result<Self, ConfigErrors> {
        Self::from_tree(
            Path::new(name),
            tree::load_tree(Path::new(name), Some(text.into()))?,
            None,
        )
    }

    /// The pipeline as `params` sees it: a template whose matrix takes a setting
    /// (`matrix.seed = "$ensemble_seeds"`) has one instance per element of the preset's list.
    /// Without such a template this is the pipeline itself (and building the plan reports
    /// errors of `params`); with one, errors of `params` are returned here.
    pub fn for_params(
        &self,
        params: &ParamsFile,
    ) -> Result<std::borrow::Cow<'_, PipelineFile>, ConfigErrors> {
        let Some(root) = &self.source else {
            return Ok(std::borrow::Cow::Borrowed(self));
        };
        // a preset that does not resolve: its errors alone (the templates it would expand
        // would only add "no instances" errors downstream)
        let settings = params.resolve(self)?;
        Self::from_tree(&self.path, root.clone(), Some(&settings)).map(std::borrow::Cow::Owned)
    }

    /// `preset`: the resolved settings (None: only the declared defaults are known).
    fn from_tree(
        path: &Path,
        root: Node,
        preset: Option<&BTreeMap<String, Located<Value>>>,
    ) -> Result<Self, ConfigErrors> {
        let mut errs = Vec::new();
        let mut out = PipelineFile {
            path: path.to_path_buf(),
            settings: BTreeMap::new(),
            scenes: BTreeMap::new(),
            stages: BTreeMap::new(),
            source: None,
        };
        let entries = root.table().unwrap_or_default();
        let mut sections: BTreeMap<&str, &[(Key, Node)]> = BTreeMap::new();
        for (k, v) in entries {
            if !PIPELINE_KEYS.contains(&k.name.as_str()) {
                errs.push(unknown_key(k, "a pipeline file", PIPELINE_KEYS));
            } else if let Some(t) = v.table() {
                sections.insert(&k.name, t);
            } else {
                errs.push(ConfigError::at(
                    &v.origin,
                    format!("`{}` must be a table, found {}", k.name, v.type_name()),
                ));
            }
        }
        let section = |name: &str| sections.get(name).copied().unwrap_or_default();
        for (name, decl) in section("settings") {
            if let Some(d) = parse_setting(name, decl, &mut errs) {
                out.settings.insert(name.name.clone(), d);
            }
        }
        for (name, _) in section("values") {
            check_name(name, "named value", &mut errs);
        }
        let mut values = expand::Values::new(section("values"));
        values.resolve_all(&mut errs);
        if !errs.is_empty() {
            // stages would repeat the errors of the values they use
            return Err(ConfigErrors(errs));
        }
        for (name, decl) in section("scenes") {
            let decl = expand::subst_values(decl, &mut values, &mut errs);
            if let Some(d) = parse_scene(name, &decl, &mut errs) {
                out.scenes.insert(name.name.clone(), d);
            }
        }
        let defaults: BTreeMap<String, Located<Value>> = out
            .settings
            .iter()
            .filter_map(|(k, d)| {
                let value = d.default.clone()?;
                let origin = d.origin.clone();
                Some((k.clone(), Located { value, origin }))
            })
            .collect();
        let mut msettings = expand::MatrixSettings {
            values: preset.unwrap_or(&defaults),
            declared: out.settings.keys().map(String::as_str).collect(),
            preset: preset.is_some(),
            used: false,
        };
        let mut defined: BTreeMap<String, Origin> = BTreeMap::new();
        // template → its instances in matrix order (for `"TEMPLATE[*]"` inputs)
        let mut instances: BTreeMap<String, Vec<String>> = BTreeMap::new();
        let mut concrete = Vec::new();
        for (template, decl) in section("stages") {
            let expanded =
                expand::expand_stage(template, decl, &mut values, &mut msettings, &mut errs);
            if decl
                .table()
                .is_some_and(|t| t.iter().any(|(k, _)| k.name == "matrix"))
            {
                let names = expanded.iter().map(|(k, _)| k.name.clone()).collect();
                instances.insert(template.name.clone(), names);
            }
            for (name, decl) in expanded {
                if let Some(first) = defined.insert(name.name.clone(), name.origin.clone()) {
                    errs.push(ConfigError::plain(format!(
                        "stage `{}` is defined twice: at {} and at {}",
                        name.name,
                        first.with_context(),
                        name.origin.with_context()
                    )));
                    continue;
                }
                concrete.push((name, decl));
            }
        }
        for (name, decl) in &concrete {
            if let Some(d) = parse_stage(name, decl, &instances, &defined, &mut errs) {
                out.stages.insert(name.name.clone(), d);
            }
        }
        let used_settings = msettings.used;
        if out.stages.is_empty() && errs.is_empty() {
            errs.push(ConfigError::at(
                &root.origin,
                "the pipeline declares no stages (add `[stages.NAME]` tables)",
            ));
        }
        if errs.is_empty() {
            if used_settings {
                out.source = Some(root);
            }
            Ok(out)
        } else {
            Err(ConfigErrors(errs))
        }
    }
}

fn unknown_key(key: &Key, what: &str, allowed: &[&str]) -> ConfigError {
    let hint = did_you_mean(&key.name, allowed)
        .map(|s| format!("did you mean `{s}`? "))
        .unwrap_or_default();
    ConfigError::at(
        &key.origin,
        format!(
            "unknown key `{}` in {what}; {hint}allowed: {}",
            key.name,
            allowed.join(", ")
        ),
    )
}

fn check_name(name: &Key, what: &str, errs: &mut Vec<ConfigError>) -> bool {
    if valid_name(&name.name) {
        true
    } else {
        errs.push(ConfigError::at(
            &name.origin,
            format!(
                "invalid {what} name `{}`: use ASCII letters, digits, `_` and `-`, starting with a letter or `_`",
                name.name
            ),
        ));
        false
    }
}

fn as_table<'a>(what: &str, v: &'a Node, errs: &mut Vec<ConfigError>) -> Option<&'a [(Key, Node)]> {
    let t = v.table();
    if t.is_none() {
        errs.push(ConfigError::at(
            &v.origin,
            format!("{what} must be a table, found {}", v.type_name()),
        ));
    }
    t
}

fn as_string(what: &str, v: &Node, errs: &mut Vec<ConfigError>) -> Option<Located<String>> {
    match &v.v {
        Val::Str(s) => Some(Located {
            value: s.clone(),
            origin: v.origin.clone(),
        }),
        _ => {
            errs.push(ConfigError::at(
                &v.origin,
                format!("{what} must be a string, found {}", v.type_name()),
            ));
            None
        }
    }
}

/// A list of names (stages of a scene or an input); `what` names one element.
fn as_names(what: &str, a: &[Node], errs: &mut Vec<ConfigError>) -> Vec<Located<String>> {
    a.iter().filter_map(|x| as_string(what, x, errs)).collect()
}

fn parse_setting(name: &Key, decl: &Node, errs: &mut Vec<ConfigError>) -> Option<SettingDecl> {
    let n = &name.name;
    if !check_name(name, "setting", errs) {
        return None;
    }
    let what =
        format!("setting `{n}` (write `{n} = {{ type = \"int\", default = 3 }}` or similar)");
    let t = as_table(&what, decl, errs)?;
    let before = errs.len();
    let mut ty_name: Option<Located<String>> = None;
    let (mut default, mut min, mut max, mut allowed, mut doc) =
        (None, None, None, None, String::new());
    for (k, v) in t {
        match k.name.as_str() {
            "type" => {
                if let Some(s) = as_string("`type`", v, errs) {
                    if SETTING_TYPES.contains(&s.value.as_str()) {
                        ty_name = Some(s);
                    } else {
                        errs.push(ConfigError::at(
                            &s.origin,
                            format!(
                                "setting `{n}`: unknown type \"{}\"; allowed: {}",
                                s.value,
                                SETTING_TYPES.join(", ")
                            ),
                        ));
                    }
                }
            }
            "default" => default = Some((v.to_json(), v.origin.clone())),
            "min" | "max" => {
                let j = v.to_json();
                if !j.is_number() {
                    errs.push(ConfigError::at(
                        &v.origin,
                        format!(
                            "setting `{n}`: `{}` must be a number, found {}",
                            k.name,
                            describe(&j)
                        ),
                    ));
                } else if k.name == "min" {
                    min = Some(j);
                } else {
                    max = Some(j);
                }
            }
            "allowed" => {
                let j = v.to_json();
                match j.as_array().filter(|a| a.iter().all(Value::is_string)) {
                    Some(a) => {
                        allowed = Some(
                            a.iter()
                                .filter_map(|x| x.as_str().map(str::to_string))
                                .collect::<Vec<_>>(),
                        )
                    }
                    None => errs.push(ConfigError::at(
                        &v.origin,
                        format!("setting `{n}`: `allowed` must be an array of strings"),
                    )),
                }
            }
            "doc" => {
                doc = as_string("`doc`", v, errs)
                    .map(|s| s.value)
                    .unwrap_or_default()
            }
            _ => errs.push(unknown_key(k, &format!("setting `{n}`"), SETTING_KEYS)),
        }
    }
    let Some(ty_name) = ty_name
        .map(|t| t.value)
        .or_else(|| default.as_ref().map(|(v, _)| inferred_type(v).to_string()))
    else {
        errs.push(ConfigError::at(
            &decl.origin,
            format!("setting `{n}` needs a `type` or a `default`"),
        ));
        return None;
    };
    let ty = setting_type(&ty_name, min, max, allowed);
    let default = match default {
        Some((v, origin)) => match list_setting(&ty, &v).and_then(|x| ty.check(&x)) {
            Ok(v) => Some(v),
            Err(e) => {
                errs.push(ConfigError::at(
                    &origin,
                    format!("setting `{n}`: default: {e}"),
                ));
                None
            }
        },
        None => None,
    };
    (errs.len() == before).then(|| SettingDecl {
        ty,
        default,
        doc,
        origin: name.origin.clone(),
    })
}

/// Largest number of elements a range setting `{ from, to }` may give.
const MAX_RANGE: i64 = 100_000;

/// A setting of type "array" may be written as an inclusive integer range
/// `{ from = 1, to = 16 }`: that is the list `[1, 2, …, 16]`. Other values are unchanged.
fn list_setting(ty: &ParamType, v: &Value) -> Result<Value, String> {
    let (ParamType::Array { .. }, Value::Object(m)) = (ty, v) else {
        return Ok(v.clone());
    };
    let bad = || {
        format!(
            "{v} is not a list nor a range: write a list like [1, 2, 3] or an inclusive integer range {{ from = 1, to = 16 }} (from ≤ to, at most {MAX_RANGE} elements)"
        )
    };
    if m.len() != 2 {
        return Err(bad());
    }
    let (Some(from), Some(to)) = (
        m.get("from").and_then(Value::as_i64),
        m.get("to").and_then(Value::as_i64),
    ) else {
        return Err(bad());
    };
    if from > to || to.saturating_sub(from) >= MAX_RANGE {
        return Err(bad());
    }
    Ok(Value::Array((from..=to).map(Value::from).collect()))
}

/// The type a setting declared only by its default has.
fn inferred_type(default: &Value) -> &'static str {
    match default {
        Value::Number(x) if x.is_f64() => "float",
        Value::Number(_) => "int",
        Value::String(_) => "string",
        Value::Bool(_) => "bool",
        Value::Array(_) => "array",
        _ => "any",
    }
}

/// A setting's type from its name in `SETTING_TYPES` and its range or allowed values.
fn setting_type(
    name: &str,
    min: Option<Value>,
    max: Option<Value>,
    allowed: Option<Vec<String>>,
) -> ParamType {
    let num = |v: &Option<Value>| v.as_ref().and_then(Value::as_f64);
    match name {
        "int" => ParamType::Int {
            min: num(&min).map(|x| x.ceil() as i64),
            max: num(&max).map(|x| x.floor() as i64),
        },
        "float" => ParamType::Float {
            min: num(&min),
            min_exclusive: false,
            max: num(&max),
            max_exclusive: false,
        },
        "string" => ParamType::Str { allowed },
        "bool" => ParamType::Bool,
        "array" => ParamType::Array {
            elem: Box::new(ParamType::Any),
            min_len: 0,
            max_len: None,
        },
        _ => ParamType::Any,
    }
}

fn parse_scene(name: &Key, decl: &Node, errs: &mut Vec<ConfigError>) -> Option<SceneDecl> {
    let n = &name.name;
    if !check_name(name, "scene", errs) {
        return None;
    }
    let t = as_table(&format!("scene `{n}`"), decl, errs)?;
    let before = errs.len();
    let mut stages = None;
    let mut doc = String::new();
    for (k, v) in t {
        match k.name.as_str() {
            "stages" => match &v.v {
                Val::Array(a) => stages = Some(as_names("a scene's stage", a, errs)),
                _ => errs.push(ConfigError::at(
                    &v.origin,
                    format!(
                        "scene `{n}`: `stages` must be an array of stage names, found {}",
                        v.type_name()
                    ),
                )),
            },
            "doc" => {
                doc = as_string("`doc`", v, errs)
                    .map(|s| s.value)
                    .unwrap_or_default()
            }
            _ => errs.push(unknown_key(k, &format!("scene `{n}`"), SCENE_KEYS)),
        }
    }
    let stages = match stages {
        Some(s) if !s.is_empty() => s,
        Some(_) => {
            errs.push(ConfigError::at(
                &name.origin,
                format!("scene `{n}`: `stages` is empty"),
            ));
            return None;
        }
        None => {
            errs.push(ConfigError::at(
                &name.origin,
                format!("scene `{n}` needs `stages = [\"...\"]`, the stages it shows"),
            ));
            return None;
        }
    };
    (errs.len() == before).then(|| SceneDecl {
        stages,
        doc,
        origin: name.origin.clone(),
    })
}

/// The suffix of an input naming every instance of a template: `"ensemble_leakage[*]"`.
const ALL_INSTANCES: &str = "[*]";

/// An input's stage name, or, written `"TEMPLATE[*]"`, every instance of the template in
/// matrix order.
fn input_names(
    n: &str,
    input: &str,
    s: Located<String>,
    instances: &BTreeMap<String, Vec<String>>,
    defined: &BTreeMap<String, Origin>,
    errs: &mut Vec<ConfigError>,
) -> Vec<Located<String>> {
    let Some(t) = s.value.strip_suffix(ALL_INSTANCES) else {
        return vec![s];
    };
    match instances.get(t) {
        Some(names) => names
            .iter()
            .map(|x| Located {
                value: x.clone(),
                origin: s.origin.clone(),
            })
            .collect(),
        None => {
            let templates: Vec<&str> = instances.keys().map(String::as_str).collect();
            let hint = if defined.contains_key(t) {
                format!("`{t}` is a single stage: write \"{t}\"; ")
            } else {
                did_you_mean(t, &templates)
                    .map(|x| format!("did you mean \"{x}{ALL_INSTANCES}\"? "))
                    .unwrap_or_default()
            };
            errs.push(ConfigError::at(
                &s.origin,
                format!(
                    "stage `{n}`: input `{input}`: \"{}\" names every instance of a template `{t}`, but no template (a stage with a `matrix`) has that name; {hint}templates: {}",
                    s.value,
                    if templates.is_empty() { "none".to_string() } else { templates.join(", ") }
                ),
            ));
            Vec::new()
        }
    }
}

fn parse_inputs(
    n: &str,
    v: &Node,
    instances: &BTreeMap<String, Vec<String>>,
    defined: &BTreeMap<String, Origin>,
    errs: &mut Vec<ConfigError>,
) -> BTreeMap<String, InputDecl> {
    let mut inputs = BTreeMap::new();
    let Some(it) = as_table(&format!("stage `{n}`: `inputs`"), v, errs) else {
        return inputs;
    };
    for (ik, iv) in it {
        let (stages, list) = match &iv.v {
            Val::Str(s) => {
                let one = Located {
                    value: s.clone(),
                    origin: iv.origin.clone(),
                };
                let many = s.ends_with(ALL_INSTANCES);
                (
                    input_names(n, &ik.name, one, instances, defined, errs),
                    many,
                )
            }
            Val::Array(a) => (
                as_names("an input stage", a, errs)
                    .into_iter()
                    .flat_map(|x| input_names(n, &ik.name, x, instances, defined, errs))
                    .collect(),
                true,
            ),
            _ => {
                errs.push(ConfigError::at(
                    &iv.origin,
                    format!(
                        "stage `{n}`: input `{}` must be a stage name or a list of stage names, found {}",
                        ik.name,
                        iv.type_name()
                    ),
                ));
                continue;
            }
        };
        inputs.insert(
            ik.name.clone(),
            InputDecl {
                stages,
                list,
                origin: ik.origin.clone(),
            },
        );
    }
    inputs
}

fn parse_stage(
    name: &Key,
    decl: &Node,
    instances: &BTreeMap<String, Vec<String>>,
    defined: &BTreeMap<String, Origin>,
    errs: &mut Vec<ConfigError>,
) -> Option<StageDecl> {
    let n = &name.name;
    if !check_name(name, "stage", errs) {
        return None;
    }
    let t = as_table(&format!("stage `{n}`"), decl, errs)?;
    let before = errs.len();
    let mut kind = None;
    let mut inputs = BTreeMap::new();
    let mut params = BTreeMap::new();
    let mut param_keys = BTreeMap::new();
    let mut doc = String::new();
    for (k, v) in t {
        match k.name.as_str() {
            "kind" => kind = as_string("`kind`", v, errs),
            "doc" => {
                doc = as_string("`doc`", v, errs)
                    .map(|s| s.value)
                    .unwrap_or_default()
            }
            "params" => {
                for (pk, pv) in
                    as_table(&format!("stage `{n}`: `params`"), v, errs).unwrap_or_default()
                {
                    param_keys.insert(pk.name.clone(), pk.origin.clone());
                    params.insert(
                        pk.name.clone(),
                        Located {
                            value: pv.to_json(),
                            origin: pv.origin.clone(),
                        },
                    );
                }
            }
            "inputs" => inputs = parse_inputs(n, v, instances, defined, errs),
            _ => errs.push(unknown_key(k, &format!("stage `{n}`"), STAGE_KEYS)),
        }
    }
    let Some(kind) = kind else {
        errs.push(ConfigError::at(
            &name.origin,
            format!("stage `{n}` needs `kind = \"...\"`"),
        ));
        return None;
    };
    (errs.len() == before).then(|| StageDecl {
        kind,
        inputs,
        params,
        param_keys,
        doc,
        origin: name.origin.clone(),
    })
}

impl ParamsFile {
    /// Reads a params file, following `extends` (values are checked against a pipeline's
    /// settings by [`ParamsFile::resolve`]).
    pub fn load(path: &Path) -> Result<Self, ConfigErrors> {
        Self::from_tree(path, tree::load_tree(path, None)?)
    }

    /// Parses params text (for tests).
    pub fn parse_str(name: &str, text: &str) -> Result<Self, ConfigErrors> {
        Self::from_tree(
            Path::new(name),
            tree::load_tree(Path::new(name), Some(text.into()))?,
        )
    }

    /// An empty params file (every setting takes its default).
    pub fn empty() -> Self {
        Self {
            path: PathBuf::from("<no params file>"),
            values: BTreeMap::new(),
            keys: BTreeMap::new(),
            origin: Origin {
                file: "<no params file>".into(),
                line: 1,
                col: 1,
                context: None,
            },
        }
    }

    fn from_tree(path: &Path, root: Node) -> Result<Self, ConfigErrors> {
        let mut errs = Vec::new();
        let mut values = BTreeMap::new();
        let mut keys = BTreeMap::new();
        for (k, v) in root.table().unwrap_or_default() {
            if check_name(k, "setting", &mut errs) {
                keys.insert(k.name.clone(), k.origin.clone());
                values.insert(
                    k.name.clone(),
                    Located {
                        value: v.to_json(),
                        origin: v.origin.clone(),
                    },
                );
            }
        }
        if errs.is_empty() {
            Ok(Self {
                path: path.to_path_buf(),
                values,
                keys,
                origin: root.origin,
            })
        } else {
            Err(ConfigErrors(errs))
        }
    }

    /// Checks the values against the pipeline's declared settings (unknown names, types,
    /// ranges, missing required settings) and returns every setting's value with the place it
    /// comes from (the params file, or the declaration's default).
    pub fn resolve(
        &self,
        pipeline: &PipelineFile,
    ) -> Result<BTreeMap<String, Located<Value>>, ConfigErrors> {
        let mut errs = Vec::new();
        let mut out = BTreeMap::new();
        let declared: Vec<&str> = pipeline.settings.keys().map(String::as_str).collect();
        for (k, v) in &self.values {
            let Some(decl) = pipeline.settings.get(k) else {
                let hint = did_you_mean(k, &declared)
                    .map(|s| format!("did you mean `{s}`? "))
                    .unwrap_or_default();
                errs.push(ConfigError::at(
                    self.keys.get(k).unwrap_or(&v.origin),
                    format!(
                        "unknown setting `{k}`: {} does not declare it; {hint}allowed: {}",
                        pipeline.path.display(),
                        if declared.is_empty() {
                            "none".to_string()
                        } else {
                            declared.join(", ")
                        }
                    ),
                ));
                continue;
            };
            match list_setting(&decl.ty, &v.value).and_then(|x| decl.ty.check(&x)) {
                Ok(x) => {
                    out.insert(
                        k.clone(),
                        Located {
                            value: x,
                            origin: v.origin.clone(),
                        },
                    );
                }
                Err(e) => errs.push(ConfigError::at(
                    &v.origin,
                    format!("setting `{k}`: {e} (declared at {})", decl.origin),
                )),
            }
        }
        for (k, decl) in &pipeline.settings {
            if self.values.contains_key(k) {
                continue;
            }
            match &decl.default {
                Some(d) => {
                    out.insert(
                        k.clone(),
                        Located {
                            value: d.clone(),
                            origin: decl.origin.clone(),
                        },
                    );
                }
                None => errs.push(ConfigError::at(
                    &self.origin,
                    format!(
                        "{} does not set `{k}`, which {} requires ({}; declared at {})",
                        self.path.display(),
                        pipeline.path.display(),
                        decl.ty,
                        decl.origin
                    ),
                )),
            }
        }
        if errs.is_empty() {
            Ok(out)
        } else {
            Err(ConfigErrors(errs))
        }
    }
}
