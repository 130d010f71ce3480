//! From declarative files to a validated, keyed DAG of stages ([`Plan::build`] in
//! [`build`]).

mod build;

use crate::config::{Located, Origin, ParamsFile, PipelineFile};
use crate::kind::{CodeIdentity, Params, Registry, StageKind};
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
