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

/// Per-stage state of a plan's cache entries, in topological order.
pub fn status(ws: &Workspace, plan: &Plan) -> Vec<StageStatus> {
    let manifest = crate::workspace::Manifest::load(ws);
    let scene_sets: Vec<(String, BTreeSet<usize>)> = plan
        .scenes
        .keys()
        .map(|s| {
            let set = plan
                .select(std::slice::from_ref(s))
                .map(|v| v.into_iter().collect())
                .unwrap_or_default();
            (s.clone(), set)
        })
        .collect();
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
