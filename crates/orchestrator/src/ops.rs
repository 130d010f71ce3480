//! `status`, `gc` and `graph`.

use crate::lock::{LockMode, acquire};
use crate::plan::Plan;
use crate::workspace::{EntryState, Workspace, file_size};
use anyhow::{Context, Result};
use serde::Serialize;
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::PathBuf;

/// The state of one stage.
#[derive(Clone, Debug, Serialize)]
pub struct StageStatus {
    /// Name.
    pub name: String,
    /// Kind.
    pub kind: String,
    /// Key.
    pub key: String,
    /// Cache entry state.
    pub state: EntryState,
    /// Artefact size, bytes (0 if missing).
    pub bytes: u64,
    /// Scenes that need it.
    pub scenes: Vec<String>,
    /// Declared side outputs and whether each exists.
    pub side_outputs: Vec<(String, bool)>,
    /// Per declared side output: a note when the file on disk is not this stage's (another
    /// params file wrote it, it was edited, or the manifest has no entry); `None` when current.
    pub side_output_origin: Vec<Option<String>>,
    /// The kind's code identity (part → hash).
    pub code: std::collections::BTreeMap<String, String>,
}

/// Each scene with the set of stages (plan indices) it needs.
fn scene_sets(plan: &Plan) -> Vec<(String, BTreeSet<usize>)> {
    plan.scenes
        .keys()
        .map(|s| {
            let set = plan
                .select(std::slice::from_ref(s))
                .map(|v| v.into_iter().collect())
                .unwrap_or_default();
            (s.clone(), set)
        })
        .collect()
}

/// Per-stage state of a plan's cache entries, in topological order.
pub fn status(ws: &Workspace, plan: &Plan) -> Vec<StageStatus> {
    let manifest = crate::workspace::Manifest::load(ws);
    let scene_sets = scene_sets(plan);
    plan.stages
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let state = ws.entry_state(s);
            StageStatus {
                name: s.name.clone(),
                kind: s.kind.clone(),
                key: s.key.clone(),
                state,
                bytes: if state == EntryState::Missing {
                    0
                } else {
                    file_size(&ws.artefact_of(s))
                },
                scenes: scene_sets
                    .iter()
                    .filter(|(_, set)| set.contains(&i))
                    .map(|(n, _)| n.clone())
                    .collect(),
                side_outputs: s
                    .side_outputs
                    .iter()
                    .map(|f| (f.clone(), ws.side_output_path(f).is_file()))
                    .collect(),
                side_output_origin: s
                    .side_outputs
                    .iter()
                    .map(|f| manifest.origin_note(ws, s, f))
                    .collect(),
                code: s.code.clone(),
            }
        })
        .collect()
}

/// What one cached stage cost when it was computed, from its artefact's provenance.
#[derive(Clone, Debug, Serialize)]
pub struct StageCost {
    /// Name.
    pub name: String,
    /// Kind.
    pub kind: String,
    /// Wall time of the stage's `run`, seconds.
    pub wall_s: f64,
    /// Peak resident memory of the process while the stage ran, MiB, when recorded.
    pub peak_rss_mib: Option<f64>,
    /// The scenes that need it.
    pub scenes: Vec<String>,
    /// The longest chain of stage times ending at this stage (its own included), seconds: no
    /// number of cores computes it sooner.
    pub chain_s: f64,
}

/// The measured cost of a plan's cached stages (`saddleflow status --costs`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct CostReport {
    /// Cached stages, most expensive first.
    pub stages: Vec<StageCost>,
    /// Stages with no valid cache entry (their cost is unknown).
    pub uncached: Vec<String>,
    /// Summed wall time of the cached stages, seconds.
    pub total_s: f64,
    /// The longest chain of dependent stages, seconds, and its stages (upstream first): a lower
    /// bound on the wall time of a cold run on any number of cores.
    pub critical_path_s: f64,
    /// The stages on that chain.
    pub critical_path: Vec<String>,
    /// Per scene: summed wall time of the stages it needs (a stage shared by several scenes
    /// counts in each).
    pub scenes: Vec<(String, f64)>,
}

impl CostReport {
    /// A lower bound on a cold run's wall time with `jobs` parallel stages (each stage on one
    /// core): the larger of the summed time over `jobs` and the critical path.
    pub fn lower_bound_s(&self, jobs: usize) -> f64 {
        (self.total_s / jobs.max(1) as f64).max(self.critical_path_s)
    }
}

/// What each cached stage of `plan` cost when it was computed (wall time and peak memory from
/// the provenance of its artefact), most expensive first, with the critical path and per-scene
/// sums. Entries that are missing or not valid are listed, not guessed.
pub fn costs(ws: &Workspace, plan: &Plan) -> CostReport {
    let sets = scene_sets(plan);
    let mut measured: Vec<Option<(f64, Option<f64>)>> = Vec::with_capacity(plan.stages.len());
    for s in &plan.stages {
        let prov = ws.open_entry(s).and_then(|r| r.provenance()).ok();
        measured.push(prov.map(|p| {
            let peak = p.stats.get("peak_rss_mib").and_then(|v| v.as_f64());
            (p.wall_s, peak)
        }));
    }
    // stages are in topological order: the longest chain ending at i is its own time plus the
    // longest chain ending at any input
    let mut chain = vec![0.0_f64; plan.stages.len()];
    let mut via: Vec<Option<usize>> = vec![None; plan.stages.len()];
    for (i, s) in plan.stages.iter().enumerate() {
        let own = measured[i].map_or(0.0, |m| m.0);
        let best = s
            .inputs
            .values()
            .flatten()
            .filter_map(|n| plan.index_of(n))
            .max_by(|&a, &b| chain[a].total_cmp(&chain[b]));
        chain[i] = own + best.map_or(0.0, |j| chain[j]);
        via[i] = best;
    }
    let mut report = CostReport::default();
    for (i, s) in plan.stages.iter().enumerate() {
        match measured[i] {
            Some((wall_s, peak_rss_mib)) => {
                report.total_s += wall_s;
                report.stages.push(StageCost {
                    name: s.name.clone(),
                    kind: s.kind.clone(),
                    wall_s,
                    peak_rss_mib,
                    scenes: sets
                        .iter()
                        .filter(|(_, set)| set.contains(&i))
                        .map(|(n, _)| n.clone())
                        .collect(),
                    chain_s: chain[i],
                });
            }
            None => report.uncached.push(s.name.clone()),
        }
    }
    report
        .stages
        .sort_by(|a, b| b.wall_s.total_cmp(&a.wall_s).then(a.name.cmp(&b.name)));
    if let Some(end) = (0..chain.len()).max_by(|&a, &b| chain[a].total_cmp(&chain[b])) {
        report.critical_path_s = chain[end];
        let mut at = Some(end);
        while let Some(i) = at {
            report.critical_path.push(plan.stages[i].name.clone());
            at = via[i];
        }
        report.critical_path.reverse();
    }
    report.scenes = sets
        .iter()
        .map(|(scene, set)| {
            let sum = set.iter().filter_map(|&i| measured[i]).map(|m| m.0).sum();
            (scene.clone(), sum)
        })
        .collect();
    report
        .scenes
        .sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    report
}

/// What `gc` deleted (or would delete).
#[derive(Clone, Debug, Default, Serialize)]
pub struct GcReport {
    /// Deleted (or, dry run, deletable) files and their sizes.
    pub deleted: Vec<(PathBuf, u64)>,
    /// Cache entries kept.
    pub kept: usize,
    /// Bytes kept.
    pub kept_bytes: u64,
}

/// Deletes cache entries that no stage of `plans` reaches, and stale temporary files. Takes the
/// results lock exclusively (not for a dry run).
pub fn gc(ws: &Workspace, plans: &[Plan], dry_run: bool, wait: bool) -> Result<GcReport> {
    let _lock = if dry_run {
        None
    } else {
        Some(acquire(
            &ws.lock_path(),
            LockMode::Exclusive,
            wait,
            "saddleflow gc",
        )?)
    };
    let reachable: BTreeSet<(String, String)> = plans
        .iter()
        .flat_map(|p| p.stages.iter().map(|s| (s.kind.clone(), s.key.clone())))
        .collect();
    let mut report = GcReport::default();
    let cache = ws.cache_dir();
    let Ok(kinds) = std::fs::read_dir(&cache) else {
        return Ok(report);
    };
    let mut entries: Vec<PathBuf> = Vec::new();
    for k in kinds.flatten() {
        let kdir = k.path();
        if !kdir.is_dir() {
            continue;
        }
        for e in std::fs::read_dir(&kdir)
            .with_context(|| format!("cannot list `{}`", kdir.display()))?
            .flatten()
        {
            entries.push(e.path());
        }
    }
    entries.sort();
    for path in entries {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let kind = path
            .parent()
            .and_then(|p| p.file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let size = file_size(&path);
        let delete = if store::fsutil::is_temp_name(&name) {
            store::fsutil::is_stale_temp(&name)
        } else if let Some(stem) = name
            .strip_suffix(".h5")
            .or_else(|| name.strip_suffix(".h5.b3"))
            .filter(|s| store::is_key(s))
        {
            !reachable.contains(&(kind, stem.to_string()))
        } else {
            false // not ours: leave it
        };
        if delete {
            if !dry_run {
                std::fs::remove_file(&path)
                    .with_context(|| format!("cannot delete `{}`", path.display()))?;
            }
            report.deleted.push((path, size));
        } else {
            report.kept += 1;
            report.kept_bytes += size;
        }
    }
    Ok(report)
}

fn dot_id(s: &str) -> String {
    format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
}

/// The plan as a Graphviz DOT graph: stages (coloured by cache state), data flow, and scenes.
pub fn graph(ws: &Workspace, plan: &Plan, selected: &[usize]) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "digraph saddleflow {{");
    let _ = writeln!(out, "  rankdir=LR;");
    let _ = writeln!(
        out,
        "  node [shape=box, style=\"rounded,filled\", fontname=\"sans-serif\"];"
    );
    let sel: BTreeSet<usize> = selected.iter().copied().collect();
    for &i in selected {
        let s = &plan.stages[i];
        let (color, state) = match ws.entry_state(s) {
            EntryState::Valid => ("palegreen", "cached"),
            EntryState::Missing => ("lightgrey", "missing"),
            EntryState::Invalid => ("salmon", "invalid"),
            EntryState::Damaged => ("salmon", "damaged"),
        };
        let _ = writeln!(
            out,
            "  {} [label={}, fillcolor={color}];",
            dot_id(&s.name),
            dot_id(&format!(
                "{}\n{} · {} · {}",
                s.name,
                s.kind,
                &s.key[..8],
                state
            ))
        );
    }
    for &i in selected {
        let s = &plan.stages[i];
        for (iname, names) in &s.inputs {
            for n in names {
                if plan.index_of(n).is_some_and(|j| sel.contains(&j)) {
                    let _ = writeln!(
                        out,
                        "  {} -> {} [label={}];",
                        dot_id(n),
                        dot_id(&s.name),
                        dot_id(iname)
                    );
                }
            }
        }
    }
    for (scene, targets) in &plan.scenes {
        if !targets
            .iter()
            .any(|t| plan.index_of(t).is_some_and(|j| sel.contains(&j)))
        {
            continue;
        }
        let id = format!("scene:{scene}");
        let _ = writeln!(
            out,
            "  {} [label={}, shape=note, fillcolor=lightyellow];",
            dot_id(&id),
            dot_id(scene)
        );
        for t in targets {
            let _ = writeln!(out, "  {} -> {} [style=dashed];", dot_id(t), dot_id(&id));
        }
    }
    let _ = writeln!(out, "}}");
    out
}
