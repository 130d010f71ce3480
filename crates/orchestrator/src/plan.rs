//! From declarative files to a validated, keyed DAG of stages.

use crate::config::{ConfigError, ConfigErrors, Located, Origin, ParamsFile, PipelineFile};
use crate::kind::{CodeIdentity, Params, Registry, StageKind};
use crate::schema::validate_params;
use crate::util::did_you_mean;
use anyhow::{Result, anyhow, bail};
use serde_json::{Map, Value, json};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;
use std::sync::Arc;

/// Version of the key derivation itself (bump if the hashed document changes shape).
pub const KEY_SCHEME: u64 = 2;

/// A stage with everything resolved: validated parameters, inputs, key.
#[derive(Clone)]
pub struct PlannedStage {
    /// Name in the pipeline file.
    pub name: String,
    /// Kind name.
    pub kind: String,
    /// The kind's code version.
    pub code_version: u64,
    /// The kind's code identity (part → hash), empty if the registry sets none.
    pub code: CodeIdentity,
    /// Canonical parameters (defaults filled in).
    pub params: Params,
    /// Input name → stage names.
    pub inputs: BTreeMap<String, Vec<String>>,
    /// Input name → keys of those stages.
    pub input_keys: BTreeMap<String, Vec<String>>,
    /// The stage key (BLAKE3, 64 hex digits).
    pub key: String,
    /// Declared side outputs (relative to the project root).
    pub side_outputs: Vec<String>,
    /// Relative cost (for the ETA).
    pub cost: f64,
    /// Lower bound of its peak memory, bytes, if its kind estimates one.
    pub memory: Option<u64>,
    /// Documentation.
    pub doc: String,
    /// Where it is declared.
    pub origin: Origin,
    /// The kind implementation.
    pub(crate) imp: Arc<dyn StageKind>,
}

impl std::fmt::Debug for PlannedStage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PlannedStage")
            .field("name", &self.name)
            .field("kind", &self.kind)
            .field("key", &self.key)
            .finish()
    }
}

/// A validated pipeline under one params file: stages in topological order.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The pipeline file, as named.
    pub pipeline: String,
    /// The params file, as named.
    pub params: String,
    /// Stages in a deterministic topological order (inputs first, then by name).
    pub stages: Vec<PlannedStage>,
    /// Scene name → target stage names.
    pub scenes: BTreeMap<String, Vec<String>>,
    /// Scene documentation.
    pub scene_docs: BTreeMap<String, String>,
    by_name: HashMap<String, usize>,
}

/// The hashed document of a stage key: kind, code version, code identity, canonical
/// parameters with every default, input keys by input name. No names, paths, times or map
/// order.
pub fn stage_key(
    kind: &str,
    code_version: u64,
    code: &CodeIdentity,
    params: &Params,
    input_keys: &BTreeMap<String, Vec<String>>,
) -> Result<String> {
    Ok(store::hash_json(&json!({
        "scheme": KEY_SCHEME,
        "kind": kind,
        "code_version": code_version,
        "code": code,
        "params": params.to_value(),
        "inputs": input_keys,
    }))?)
}

/// [`stage_key`] of a stage whose kind names file inputs ([`StageKind::file_inputs`]): the
/// document also holds the BLAKE3 hash of each file's content, in the order named (not the
/// paths: the path is a parameter already). Without files it is exactly [`stage_key`].
pub fn stage_key_with_files(
    kind: &str,
    code_version: u64,
    code: &CodeIdentity,
    params: &Params,
    input_keys: &BTreeMap<String, Vec<String>>,
    file_hashes: &[String],
) -> Result<String> {
    if file_hashes.is_empty() {
        return stage_key(kind, code_version, code, params, input_keys);
    }
    Ok(store::hash_json(&json!({
        "scheme": KEY_SCHEME,
        "kind": kind,
        "code_version": code_version,
        "code": code,
        "params": params.to_value(),
        "inputs": input_keys,
        "files": file_hashes,
    }))?)
}

/// The content hashes of a stage's file inputs, paths relative to `root`; the error names the
/// file.
fn hash_file_inputs(root: &Path, files: &[String]) -> Result<Vec<String>, String> {
    files
        .iter()
        .map(|f| {
            store::canonical::hash_file(&root.join(f)).map_err(|e| {
                format!(
                    "cannot read the file input `{f}` (relative paths are relative to the project root `{}`): {e}",
                    if root.as_os_str().is_empty() { ".".into() } else { root.display().to_string() }
                )
            })
        })
        .collect()
}

/// Replaces `"$setting"` references in `v`. `$$` escapes a literal `$`.
fn resolve_refs(
    v: &Value,
    settings: &BTreeMap<String, Located<Value>>,
    used: &mut Option<Origin>,
) -> Result<Value, String> {
    Ok(match v {
        Value::String(s) if s.starts_with("$$") => Value::String(s[1..].to_string()),
        Value::String(s) if s.starts_with('$') => {
            let name = &s[1..];
            match settings.get(name) {
                Some(x) => {
                    *used = Some(x.origin.clone());
                    x.value.clone()
                }
                None => {
                    let names: Vec<&str> = settings.keys().map(String::as_str).collect();
                    let hint = did_you_mean(name, &names)
                        .map(|s| format!("did you mean `${s}`? "))
                        .unwrap_or_default();
                    return Err(format!(
                        "unknown setting `{s}`; {hint}settings declared: {} (write `$$` for a literal `$`)",
                        if names.is_empty() {
                            "none".into()
                        } else {
                            names.join(", ")
                        }
                    ));
                }
            }
        }
        Value::Array(a) => Value::Array(
            a.iter()
                .map(|x| resolve_refs(x, settings, used))
                .collect::<Result<_, _>>()?,
        ),
        Value::Object(m) => Value::Object(
            m.iter()
                .map(|(k, x)| Ok((k.clone(), resolve_refs(x, settings, used)?)))
                .collect::<Result<Map<_, _>, String>>()?,
        ),
        other => other.clone(),
    })
}

impl Plan {
    /// Loads `pipeline` and `params` (None: every setting takes its default) and builds the plan.
    pub fn load(registry: &Registry, pipeline: &Path, params: Option<&Path>) -> Result<Plan> {
        let p = PipelineFile::load(pipeline)?;
        let q = match params {
            Some(path) => ParamsFile::load(path)?,
            None => ParamsFile::empty(),
        };
        Ok(Plan::build(registry, &p, &q)?)
    }

    /// Validates everything and computes keys. All errors are collected.
    pub fn build(
        registry: &Registry,
        pipeline: &PipelineFile,
        params: &ParamsFile,
    ) -> Result<Plan, ConfigErrors> {
        // templates whose matrix takes a preset's setting get their instances now
        let expanded = pipeline.for_params(params)?;
        let pipeline: &PipelineFile = &expanded;
        let mut errs: Vec<ConfigError> = Vec::new();
        let settings = match params.resolve(pipeline) {
            Ok(s) => s,
            Err(e) => {
                errs.extend(e.0);
                BTreeMap::new()
            }
        };
        let settings_ok = errs.is_empty();
        let kinds = registry.names();
        let stage_names: Vec<&str> = pipeline.stages.keys().map(String::as_str).collect();

        // 1. parameters of each stage
        let mut resolved: BTreeMap<&str, (Arc<dyn StageKind>, Params)> = BTreeMap::new();
        for (name, decl) in &pipeline.stages {
            let Some(imp) = registry.get(&decl.kind.value) else {
                let hint = did_you_mean(&decl.kind.value, &kinds)
                    .map(|s| format!("did you mean \"{s}\"? "))
                    .unwrap_or_default();
                errs.push(ConfigError::at(
                    &decl.kind.origin,
                    format!(
                        "stage `{name}`: unknown kind \"{}\"; {hint}allowed: {}",
                        decl.kind.value,
                        kinds.join(", ")
                    ),
                ));
                continue;
            };
            let mut given = Map::new();
            let mut source: BTreeMap<&str, (Origin, Option<Origin>)> = BTreeMap::new();
            let mut ok = true;
            for (k, v) in &decl.params {
                let mut used = None;
                match resolve_refs(&v.value, &settings, &mut used) {
                    Ok(x) => {
                        given.insert(k.clone(), x);
                        // a whole-value reference is reported at the params file's line
                        let whole_ref = v
                            .value
                            .as_str()
                            .is_some_and(|s| s.starts_with('$') && !s.starts_with("$$"));
                        match used {
                            Some(o) if whole_ref => source.insert(k, (o, Some(v.origin.clone()))),
                            _ => source.insert(k, (v.origin.clone(), None)),
                        };
                    }
                    Err(e) => {
                        ok = false;
                        if settings_ok {
                            errs.push(ConfigError::at(
                                &v.origin,
                                format!("stage `{name}`: parameter `{k}`: {e}"),
                            ));
                        }
                    }
                }
            }
            if !ok {
                continue;
            }
            let kind_name = imp.name().to_string();
            let locate = |issue: &crate::schema::ParamIssue| -> ConfigError {
                let what = format!("stage `{name}` (kind `{kind_name}`): {issue}");
                if issue.at_key
                    && let Some(o) = issue.key.as_deref().and_then(|k| decl.param_keys.get(k))
                {
                    return ConfigError::at(o, what);
                }
                match issue.key.as_deref().and_then(|k| source.get(k)) {
                    Some((o, Some(via))) => {
                        ConfigError::at(o, format!("{what} (used via a `$` reference at {via})"))
                    }
                    Some((o, None)) => ConfigError::at(o, what),
                    None => ConfigError::at(&decl.origin, what),
                }
            };
            match validate_params(&imp.params(), &given) {
                Ok(m) => {
                    let p = Params(m);
                    if let Err(issue) = imp.check(&p) {
                        errs.push(locate(&issue));
                        continue;
                    }
                    resolved.insert(name, (imp.clone(), p));
                }
                Err(issues) => errs.extend(issues.iter().map(locate)),
            }
        }

        // 2. inputs
        let mut edges: BTreeMap<&str, BTreeMap<String, Vec<String>>> = BTreeMap::new();
        for (name, decl) in &pipeline.stages {
            let mut ins = BTreeMap::new();
            let specs = resolved.get(name.as_str()).map(|(imp, p)| imp.inputs(p));
            for (iname, idecl) in &decl.inputs {
                let mut names = Vec::new();
                for s in &idecl.stages {
                    if !pipeline.stages.contains_key(&s.value) {
                        let hint = did_you_mean(&s.value, &stage_names)
                            .map(|x| format!("did you mean `{x}`? "))
                            .unwrap_or_default();
                        errs.push(ConfigError::at(
                            &s.origin,
                            format!(
                                "stage `{name}`: input `{iname}` refers to unknown stage `{}`; {hint}stages: {}",
                                s.value,
                                stage_names.join(", ")
                            ),
                        ));
                    } else if s.value == *name {
                        errs.push(ConfigError::at(
                            &s.origin,
                            format!("stage `{name}`: input `{iname}` refers to the stage itself (a cycle)"),
                        ));
                    }
                    names.push(s.value.clone());
                }
                if let Some(specs) = &specs {
                    match specs.iter().find(|sp| &sp.name == iname) {
                        None => {
                            let allowed: Vec<&str> =
                                specs.iter().map(|s| s.name.as_str()).collect();
                            errs.push(ConfigError::at(
                                &idecl.origin,
                                format!(
                                    "stage `{name}`: kind `{}` takes no input `{iname}`; allowed: {}",
                                    decl.kind.value,
                                    if allowed.is_empty() { "none".to_string() } else { allowed.join(", ") }
                                ),
                            ));
                        }
                        Some(sp) => {
                            if !sp.many && (idecl.list || names.len() != 1) {
                                errs.push(ConfigError::at(
                                    &idecl.origin,
                                    format!("stage `{name}`: input `{iname}` takes exactly one stage name, not a list"),
                                ));
                            }
                            if sp.many && names.is_empty() && sp.required {
                                errs.push(ConfigError::at(
                                    &idecl.origin,
                                    format!(
                                        "stage `{name}`: input `{iname}` needs at least one stage"
                                    ),
                                ));
                            }
                            if !sp.kinds.is_empty() {
                                for s in &idecl.stages {
                                    if let Some(other) = pipeline.stages.get(&s.value)
                                        && !sp.kinds.contains(&other.kind.value)
                                    {
                                        errs.push(ConfigError::at(
                                            &s.origin,
                                            format!(
                                                "stage `{name}`: input `{iname}` must be a stage of kind {}, but `{}` is of kind `{}`",
                                                sp.kinds.iter().map(|k| format!("`{k}`")).collect::<Vec<_>>().join(" or "),
                                                s.value,
                                                other.kind.value
                                            ),
                                        ));
                                    }
                                }
                            }
                        }
                    }
                }
                ins.insert(iname.clone(), names);
            }
            if let Some(specs) = &specs {
                for sp in specs.iter().filter(|s| s.required) {
                    if !decl.inputs.contains_key(&sp.name) {
                        let kinds = if sp.kinds.is_empty() {
                            String::new()
                        } else {
                            format!(" (a stage of kind {})", sp.kinds.join(" or "))
                        };
                        errs.push(ConfigError::at(
                            &decl.origin,
                            format!(
                                "stage `{name}`: missing input `{}`{kinds}: write `inputs = {{ {} = \"STAGE\" }}`",
                                sp.name, sp.name
                            ),
                        ));
                    }
                }
            }
            edges.insert(name, ins);
        }

        // 2b. constraints across stages (the inputs' parameters), before anything runs
        for (name, decl) in &pipeline.stages {
            let Some((imp, p)) = resolved.get(name.as_str()) else {
                continue;
            };
            if let Some(given) = input_params(&edges[name.as_str()], &resolved)
                && let Err(e) = imp.check_inputs(p, &given)
            {
                errs.push(ConfigError::at(
                    &decl.origin,
                    format!("stage `{name}` (kind `{}`): {e}", imp.name()),
                ));
            }
        }

        // 3. scenes
        let mut scenes = BTreeMap::new();
        let mut scene_docs = BTreeMap::new();
        for (sname, scene) in &pipeline.scenes {
            for s in &scene.stages {
                if !pipeline.stages.contains_key(&s.value) {
                    let hint = did_you_mean(&s.value, &stage_names)
                        .map(|x| format!("did you mean `{x}`? "))
                        .unwrap_or_default();
                    errs.push(ConfigError::at(
                        &s.origin,
                        format!(
                            "scene `{sname}` refers to unknown stage `{}`; {hint}stages: {}",
                            s.value,
                            stage_names.join(", ")
                        ),
                    ));
                }
            }
            scenes.insert(
                sname.clone(),
                scene.stages.iter().map(|s| s.value.clone()).collect(),
            );
            scene_docs.insert(sname.clone(), scene.doc.clone());
        }

        // 4. cycles and topological order
        let order = match topo_order(&edges) {
            Ok(o) => o,
            Err(cycle) => {
                let first = &pipeline.stages[&cycle[0]];
                errs.push(ConfigError::at(
                    &first.origin,
                    format!("the stages form a cycle: {}", cycle.join(" → ")),
                ));
                Vec::new()
            }
        };
        if !errs.is_empty() {
            return Err(ConfigErrors(errs));
        }

        // 5. keys, inputs first
        // file inputs are relative to the project root: the folder above the pipeline file's
        let project_root = pipeline
            .path
            .parent()
            .and_then(Path::parent)
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let mut stages: Vec<PlannedStage> = Vec::with_capacity(order.len());
        let mut by_name: HashMap<String, usize> = HashMap::new();
        // each stage's parameters with those of everything upstream under `_inputs`, for
        // memory estimates (a flow stage's grid is its sweep's surface's)
        let mut deep: HashMap<String, Params> = HashMap::new();
        for name in order {
            let decl = &pipeline.stages[&name];
            let (imp, params) = resolved[name.as_str()].clone();
            let inputs = edges[name.as_str()].clone();
            let input_keys: BTreeMap<String, Vec<String>> = inputs
                .iter()
                .map(|(k, v)| {
                    (
                        k.clone(),
                        v.iter().map(|s| stages[by_name[s]].key.clone()).collect(),
                    )
                })
                .collect();
            let code = registry.code_identity(imp.name());
            let file_hashes =
                hash_file_inputs(&project_root, &imp.file_inputs(&params)).map_err(|e| {
                    ConfigErrors(vec![ConfigError::at(
                        &decl.origin,
                        format!("stage `{name}`: {e}"),
                    )])
                })?;
            let key = stage_key_with_files(
                imp.name(),
                imp.code_version(),
                &code,
                &params,
                &input_keys,
                &file_hashes,
            )
            .map_err(|e| {
                ConfigErrors(vec![ConfigError::at(
                    &decl.origin,
                    format!("stage `{name}`: {e}"),
                )])
            })?;
            if let Some(given) = deep_inputs(&edges[name.as_str()], &deep) {
                let mut d = params.clone();
                d.0.insert(
                    crate::kind::UPSTREAM.into(),
                    Value::Object(
                        given
                            .into_iter()
                            .map(|(k, v)| {
                                (
                                    k,
                                    Value::Array(v.into_iter().map(|p| p.to_value()).collect()),
                                )
                            })
                            .collect(),
                    ),
                );
                deep.insert(name.clone(), d);
            }
            by_name.insert(name.clone(), stages.len());
            stages.push(PlannedStage {
                kind: imp.name().to_string(),
                code_version: imp.code_version(),
                code,
                side_outputs: imp.side_outputs(&params),
                cost: imp.cost(&params).max(1e-6),
                memory: deep_inputs(&edges[name.as_str()], &deep)
                    .and_then(|given| imp.memory_estimate(&params, &given)),
                inputs,
                input_keys,
                key,
                doc: decl.doc.clone(),
                origin: decl.origin.clone(),
                name,
                params,
                imp,
            });
        }
        // two stages with one key would compute the same artefact twice, race to publish the
        // one cache file, and make the key ambiguous for `run-stage` (a cluster job)
        let mut by_key: BTreeMap<&str, &PlannedStage> = BTreeMap::new();
        for s in &stages {
            if let Some(first) = by_key.insert(s.key.as_str(), s) {
                errs.push(ConfigError::at(
                    &s.origin,
                    format!(
                        "stage `{}` computes exactly what stage `{}` computes (same kind, parameters, inputs and code: key {}); let its readers take `{}` instead",
                        s.name,
                        first.name,
                        &s.key[..12],
                        first.name
                    ),
                ));
            }
        }
        // side outputs must not collide
        let mut owners: BTreeMap<&str, &str> = BTreeMap::new();
        for s in &stages {
            for f in &s.side_outputs {
                if let Err(e) = check_side_output_path(f) {
                    errs.push(ConfigError::at(
                        &s.origin,
                        format!("stage `{}`: side output {e}", s.name),
                    ));
                }
                if let Some(other) = owners.insert(f, &s.name) {
                    errs.push(ConfigError::at(
                        &s.origin,
                        format!("stages `{other}` and `{}` both write `{f}`", s.name),
                    ));
                }
            }
        }
        if !errs.is_empty() {
            return Err(ConfigErrors(errs));
        }
        Ok(Plan {
            pipeline: pipeline.path.to_string_lossy().into_owned(),
            params: params.path.to_string_lossy().into_owned(),
            stages,
            scenes,
            scene_docs,
            by_name,
        })
    }

    /// The stage called `name`.
    pub fn stage(&self, name: &str) -> Option<&PlannedStage> {
        self.by_name.get(name).map(|&i| &self.stages[i])
    }

    /// Index of the stage called `name` in [`Plan::stages`].
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.by_name.get(name).copied()
    }

    /// The stage whose key starts with `prefix` (unique).
    pub fn stage_by_key(&self, prefix: &str) -> Result<&PlannedStage> {
        let prefix = prefix.trim().to_ascii_lowercase();
        if prefix.len() < 4 {
            bail!("key prefix `{prefix}` is too short: give at least 4 hex digits");
        }
        let hits: Vec<&PlannedStage> = self
            .stages
            .iter()
            .filter(|s| s.key.starts_with(&prefix))
            .collect();
        match hits.as_slice() {
            [one] => Ok(one),
            [] => Err(anyhow!(
                "no stage of {} with {} has a key starting with `{prefix}` (pass the --pipeline and --params it was planned with; `saddleflow status` lists keys)",
                self.pipeline,
                self.params
            )),
            many => Err(anyhow!(
                "key prefix `{prefix}` is ambiguous: {}",
                many.iter()
                    .map(|s| format!("{} ({})", s.name, s.key))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        }
    }

    /// Indices (in topological order) of the stages that `only` needs: the named scenes' (or
    /// stages') targets and everything upstream of them. Empty `only`: every stage.
    pub fn select(&self, only: &[String]) -> Result<Vec<usize>> {
        if only.is_empty() {
            return Ok((0..self.stages.len()).collect());
        }
        let mut wanted: BTreeSet<usize> = BTreeSet::new();
        let mut todo: Vec<usize> = Vec::new();
        for o in only {
            if let Some(targets) = self.scenes.get(o) {
                todo.extend(targets.iter().filter_map(|t| self.index_of(t)));
            } else if let Some(i) = self.index_of(o) {
                todo.push(i);
            } else {
                let mut names: Vec<&str> = self.scenes.keys().map(String::as_str).collect();
                let hint = did_you_mean(o, &names)
                    .or_else(|| {
                        did_you_mean(
                            o,
                            &self
                                .stages
                                .iter()
                                .map(|s| s.name.as_str())
                                .collect::<Vec<_>>(),
                        )
                    })
                    .map(|s| format!("did you mean `{s}`? "))
                    .unwrap_or_default();
                names.sort();
                bail!(
                    "`{o}` is neither a scene nor a stage of {}; {hint}scenes: {}",
                    self.pipeline,
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                );
            }
        }
        while let Some(i) = todo.pop() {
            if wanted.insert(i) {
                for names in self.stages[i].inputs.values() {
                    todo.extend(names.iter().filter_map(|n| self.index_of(n)));
                }
            }
        }
        Ok(wanted.into_iter().collect())
    }

    /// Indices of the stages downstream of stage `i` (not including it).
    pub fn downstream(&self, i: usize) -> Vec<usize> {
        let mut out = BTreeSet::new();
        let mut todo = vec![i];
        while let Some(j) = todo.pop() {
            let name = &self.stages[j].name;
            for (k, s) in self.stages.iter().enumerate() {
                if s.inputs.values().any(|v| v.contains(name)) && out.insert(k) {
                    todo.push(k);
                }
            }
        }
        out.into_iter().collect()
    }

    /// Scenes that include stage `name` (directly or upstream of a target).
    pub fn scenes_of(&self, name: &str) -> Vec<String> {
        self.scenes
            .keys()
            .filter(|s| {
                self.select(std::slice::from_ref(*s))
                    .map(|v| v.iter().any(|&i| self.stages[i].name == name))
                    .unwrap_or(false)
            })
            .cloned()
            .collect()
    }
}

/// The validated parameters of the stages wired to each input (`None` if one is unresolved).
fn input_params(
    edges: &BTreeMap<String, Vec<String>>,
    resolved: &BTreeMap<&str, (Arc<dyn StageKind>, Params)>,
) -> Option<BTreeMap<String, Vec<Params>>> {
    edges
        .iter()
        .map(|(iname, names)| {
            let ps: Option<Vec<Params>> = names
                .iter()
                .map(|n| resolved.get(n.as_str()).map(|(_, q)| q.clone()))
                .collect();
            ps.map(|ps| (iname.clone(), ps))
        })
        .collect()
}

/// The parameters of the stages wired to each input, each with its own upstream under
/// [`crate::kind::UPSTREAM`] (`None` if one is unknown).
fn deep_inputs(
    edges: &BTreeMap<String, Vec<String>>,
    deep: &HashMap<String, Params>,
) -> Option<BTreeMap<String, Vec<Params>>> {
    edges
        .iter()
        .map(|(iname, names)| {
            let ps: Option<Vec<Params>> = names.iter().map(|n| deep.get(n).cloned()).collect();
            ps.map(|ps| (iname.clone(), ps))
        })
        .collect()
}

/// Side-output paths must be relative, plain and inside the project.
pub fn check_side_output_path(p: &str) -> Result<(), String> {
    let path = Path::new(p);
    if p.is_empty()
        || path.is_absolute()
        || path
            .components()
            .any(|c| !matches!(c, std::path::Component::Normal(_)))
    {
        return Err(format!("path `{p}` must be relative, without `..` or `.`"));
    }
    if p.starts_with("results/cache") {
        return Err(format!("path `{p}` must not be inside results/cache"));
    }
    Ok(())
}

/// Kahn's algorithm, ready stages taken by name: deterministic. On a cycle, returns one.
fn topo_order(
    edges: &BTreeMap<&str, BTreeMap<String, Vec<String>>>,
) -> Result<Vec<String>, Vec<String>> {
    let mut indeg: BTreeMap<&str, usize> = edges.keys().map(|k| (*k, 0)).collect();
    let mut users: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (name, ins) in edges {
        let deps: BTreeSet<&str> = ins
            .values()
            .flatten()
            .map(String::as_str)
            .filter(|d| edges.contains_key(d))
            .collect();
        *indeg.get_mut(name).unwrap_or(&mut 0) += deps.len();
        for d in deps {
            users.entry(d).or_default().push(name);
        }
    }
    let mut ready: BTreeSet<&str> = indeg
        .iter()
        .filter(|(_, d)| **d == 0)
        .map(|(k, _)| *k)
        .collect();
    let mut order = Vec::new();
    while let Some(n) = ready.pop_first() {
        order.push(n.to_string());
        for u in users.get(n).cloned().unwrap_or_default() {
            if let Some(d) = indeg.get_mut(u) {
                *d -= 1;
                if *d == 0 {
                    ready.insert(u);
                }
            }
        }
    }
    if order.len() == edges.len() {
        return Ok(order);
    }
    // find a cycle among the remaining stages: walk inputs until a stage repeats
    let remaining: BTreeSet<&str> = indeg
        .iter()
        .filter(|(_, d)| **d > 0)
        .map(|(k, _)| *k)
        .collect();
    let start = *remaining.iter().next().unwrap_or(&"");
    let mut path: Vec<&str> = vec![start];
    let mut cur = start;
    loop {
        let next = edges[cur]
            .values()
            .flatten()
            .map(String::as_str)
            .find(|d| remaining.contains(d));
        let Some(next) = next else {
            return Err(vec![start.to_string()]);
        };
        if let Some(pos) = path.iter().position(|p| *p == next) {
            // the cycle, written in data-flow order (input → user)
            let mut cyc: Vec<String> = path[pos..].iter().rev().map(|s| s.to_string()).collect();
            cyc.push(cyc[0].clone());
            return Err(cyc);
        }
        path.push(next);
        cur = next;
    }
}
