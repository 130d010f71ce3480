//! [`Plan::build`]: the pipeline and params files to a validated, keyed plan, in steps that
//! each collect their errors (every error of a file is reported at once, each at its line):
//! 1. each stage's parameters (`$setting` references resolved, validated against the kind's
//!    schema and its `check`);
//! 2. each stage's inputs (known stages, the kind's input specs, required inputs), then the
//!    constraints across stages (`check_inputs` on the inputs' parameters);
//! 3. the scenes' stage lists;
//! 4. cycles and the topological order;
//! 5. keys, inputs first, then the checks on the keyed stages (two stages with one key, side
//!    outputs written twice or outside the project).

use super::{
    Plan, PlannedStage, check_side_output_path, deep_inputs, hash_file_inputs, input_params,
    resolve_refs, stage_key_with_files, topo_order,
};
use crate::config::{
    ConfigError, ConfigErrors, InputDecl, Located, Origin, ParamsFile, PipelineFile, StageDecl,
};
use crate::kind::InputSpec;
use crate::kind::{Params, Registry, StageKind};
use crate::schema::validate_params;
use crate::util::did_you_mean;
use serde_json::{Map, Value};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::sync::Arc;

/// Stage name → its kind and validated parameters.
type Resolved<'a> = BTreeMap<&'a str, (Arc<dyn StageKind>, Params)>;
/// Stage name → input name → the stages wired to it.
type Edges<'a> = BTreeMap<&'a str, BTreeMap<String, Vec<String>>>;
/// Settings of the params file by name.
type Settings = BTreeMap<String, Located<Value>>;

impl Plan {
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
        let mut resolved: Resolved = BTreeMap::new();
        for (name, decl) in &pipeline.stages {
            if let Some(r) = resolve_stage(
                registry,
                &kinds,
                name,
                decl,
                &settings,
                settings_ok,
                &mut errs,
            ) {
                resolved.insert(name, r);
            }
        }
        let edges = wire_inputs(pipeline, &resolved, &mut errs);
        check_across(pipeline, &resolved, &edges, &mut errs);
        let (scenes, scene_docs) = scene_lists(pipeline, &mut errs);
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

        let (stages, by_name) = key_stages(registry, pipeline, &resolved, &edges, order)?;
        check_keyed(&stages, &mut errs);
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
}

/// Step 1 for one stage: its kind and validated parameters, or `None` with the errors pushed.
/// A parameter's error is reported at the params file's line when the whole value is a
/// `$setting` reference (with the pipeline line it is used at), else at the pipeline's.
fn resolve_stage(
    registry: &Registry,
    kinds: &[&str],
    name: &str,
    decl: &StageDecl,
    settings: &Settings,
    settings_ok: bool,
    errs: &mut Vec<ConfigError>,
) -> Option<(Arc<dyn StageKind>, Params)> {
    let Some(imp) = registry.get(&decl.kind.value) else {
        let hint = did_you_mean(&decl.kind.value, kinds)
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
        return None;
    };
    let mut given = Map::new();
    let mut source: BTreeMap<&str, (Origin, Option<Origin>)> = BTreeMap::new();
    let mut ok = true;
    for (k, v) in &decl.params {
        let mut used = None;
        match resolve_refs(&v.value, settings, &mut used) {
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
        return None;
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
                return None;
            }
            Some((imp.clone(), p))
        }
        Err(issues) => {
            errs.extend(issues.iter().map(locate));
            None
        }
    }
}

/// Step 2: every stage's inputs, checked against the pipeline's stages and (where the stage's
/// parameters resolved) its kind's input specs.
fn wire_inputs<'a>(
    pipeline: &'a PipelineFile,
    resolved: &Resolved,
    errs: &mut Vec<ConfigError>,
) -> Edges<'a> {
    let stage_names: Vec<&str> = pipeline.stages.keys().map(String::as_str).collect();
    let mut edges: Edges = BTreeMap::new();
    for (name, decl) in &pipeline.stages {
        let mut ins = BTreeMap::new();
        let specs = resolved.get(name.as_str()).map(|(imp, p)| imp.inputs(p));
        for (iname, idecl) in &decl.inputs {
            let mut names = Vec::new();
            for s in &idecl.stages {
                if !pipeline.stages.contains_key(&s.value) {
                    let hint = stage_hint(&s.value, &stage_names);
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
                        format!(
                            "stage `{name}`: input `{iname}` refers to the stage itself (a cycle)"
                        ),
                    ));
                }
                names.push(s.value.clone());
            }
            if let Some(specs) = &specs {
                check_input(pipeline, name, decl, iname, idecl, &names, specs, errs);
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
    edges
}

/// One declared input against the kind's input specs: a known input, one stage or a list as
/// the spec says, at least one stage if required, stages of the allowed kinds.
#[allow(clippy::too_many_arguments)]
fn check_input(
    pipeline: &PipelineFile,
    name: &str,
    decl: &StageDecl,
    iname: &str,
    idecl: &InputDecl,
    names: &[String],
    specs: &[InputSpec],
    errs: &mut Vec<ConfigError>,
) {
    let Some(sp) = specs.iter().find(|sp| sp.name == iname) else {
        let allowed: Vec<&str> = specs.iter().map(|s| s.name.as_str()).collect();
        errs.push(ConfigError::at(
            &idecl.origin,
            format!(
                "stage `{name}`: kind `{}` takes no input `{iname}`; allowed: {}",
                decl.kind.value,
                if allowed.is_empty() {
                    "none".to_string()
                } else {
                    allowed.join(", ")
                }
            ),
        ));
        return;
    };
    if !sp.many && (idecl.list || names.len() != 1) {
        errs.push(ConfigError::at(
            &idecl.origin,
            format!("stage `{name}`: input `{iname}` takes exactly one stage name, not a list"),
        ));
    }
    if sp.many && names.is_empty() && sp.required {
        errs.push(ConfigError::at(
            &idecl.origin,
            format!("stage `{name}`: input `{iname}` needs at least one stage"),
        ));
    }
    if sp.kinds.is_empty() {
        return;
    }
    for s in &idecl.stages {
        if let Some(other) = pipeline.stages.get(&s.value)
            && !sp.kinds.contains(&other.kind.value)
        {
            errs.push(ConfigError::at(
                &s.origin,
                format!(
                    "stage `{name}`: input `{iname}` must be a stage of kind {}, but `{}` is of kind `{}`",
                    sp.kinds
                        .iter()
                        .map(|k| format!("`{k}`"))
                        .collect::<Vec<_>>()
                        .join(" or "),
                    s.value,
                    other.kind.value
                ),
            ));
        }
    }
}

/// Step 2b: constraints across stages (the inputs' parameters), before anything runs.
fn check_across(
    pipeline: &PipelineFile,
    resolved: &Resolved,
    edges: &Edges,
    errs: &mut Vec<ConfigError>,
) {
    for (name, decl) in &pipeline.stages {
        let Some((imp, p)) = resolved.get(name.as_str()) else {
            continue;
        };
        if let Some(given) = input_params(&edges[name.as_str()], resolved)
            && let Err(e) = imp.check_inputs(p, &given)
        {
            errs.push(ConfigError::at(
                &decl.origin,
                format!("stage `{name}` (kind `{}`): {e}", imp.name()),
            ));
        }
    }
}

/// Step 3: scene name → its stages, and scene name → its documentation.
#[allow(clippy::type_complexity)]
fn scene_lists(
    pipeline: &PipelineFile,
    errs: &mut Vec<ConfigError>,
) -> (BTreeMap<String, Vec<String>>, BTreeMap<String, String>) {
    let stage_names: Vec<&str> = pipeline.stages.keys().map(String::as_str).collect();
    let mut scenes = BTreeMap::new();
    let mut scene_docs = BTreeMap::new();
    for (sname, scene) in &pipeline.scenes {
        for s in &scene.stages {
            if !pipeline.stages.contains_key(&s.value) {
                let hint = stage_hint(&s.value, &stage_names);
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
    (scenes, scene_docs)
}

/// Step 5: the planned stages in `order` (inputs first), each keyed by its kind, code,
/// parameters, file inputs' contents and its inputs' keys; and name → index.
fn key_stages(
    registry: &Registry,
    pipeline: &PipelineFile,
    resolved: &Resolved,
    edges: &Edges,
    order: Vec<String>,
) -> Result<(Vec<PlannedStage>, HashMap<String, usize>), ConfigErrors> {
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
        let at_stage = |e: String| {
            ConfigErrors(vec![ConfigError::at(
                &decl.origin,
                format!("stage `{name}`: {e}"),
            )])
        };
        let code = registry.code_identity(imp.name());
        let file_hashes =
            hash_file_inputs(&project_root, &imp.file_inputs(&params)).map_err(at_stage)?;
        let key = stage_key_with_files(
            imp.name(),
            imp.code_version(),
            &code,
            &params,
            &input_keys,
            &file_hashes,
        )
        .map_err(|e| at_stage(e.to_string()))?;
        if let Some(given) = deep_inputs(&edges[name.as_str()], &deep) {
            deep.insert(name.clone(), with_upstream(&params, given));
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
    Ok((stages, by_name))
}

/// `params` with its inputs' (deep) parameters under [`crate::kind::UPSTREAM`].
fn with_upstream(params: &Params, given: BTreeMap<String, Vec<Params>>) -> Params {
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
    d
}

/// Checks on the keyed stages: no two with one key, side outputs plain, inside the project and
/// written by one stage each.
fn check_keyed(stages: &[PlannedStage], errs: &mut Vec<ConfigError>) {
    // two stages with one key would compute the same artefact twice, race to publish the
    // one cache file, and make the key ambiguous for `run-stage` (a cluster job)
    let mut by_key: BTreeMap<&str, &PlannedStage> = BTreeMap::new();
    for s in stages {
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
    for s in stages {
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
}

/// "did you mean `x`? " for a stage name close to an unknown `name`, else nothing.
fn stage_hint(name: &str, stage_names: &[&str]) -> String {
    did_you_mean(name, stage_names)
        .map(|x| format!("did you mean `{x}`? "))
        .unwrap_or_default()
}
