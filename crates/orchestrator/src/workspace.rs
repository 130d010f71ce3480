//! The results folder: cache layout, the index of last keys, and why a stage must run.

use crate::plan::{Plan, PlannedStage};
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::HashMap;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use store::{ArtefactReader, Integrity};

/// A project root: `results/` (cache, runs, lock) and side outputs live under it.
///
/// Every cache entry is verified before use ([`store::digest::check`]: complete mark, expected
/// key, content digest). The content digest costs a read of the whole file, so a verified file
/// is remembered by its stamp: device, inode, size, modification and status-change times (ns).
/// Any write to the file or replacement of it changes the stamp (the status-change time cannot
/// be set back without privileges), and the next look re-reads it in full. The stamps live in
/// memory for the process and in `results/cache/verified.json` across runs (written by `run`);
/// with a matching stamp the entry is valid without being opened: a no-op rerun costs one
/// `stat` per entry. Deleting that file forces a full verification (e.g. to look for silent
/// media corruption, which changes no stamp).
///
/// An artefact this process publishes is stamped at once ([`Workspace::mark_verified`]): its
/// writer computed the digest from the values it wrote, and the stamp is taken after the
/// rename. So the first rerun after a run re-reads nothing. What a stamp cannot see is a write
/// by another process within the same file-system clock tick (a few ms) after the rename; cache
/// writers hold the results lock, so only a process ignoring it could do that. On a file system
/// with whole-second times (both nanosecond parts zero) that window is a second, and such a
/// stamp is trusted for this process only until it is [`RACY_NS`] old, as git does with its
/// "racily clean" entries.
#[derive(Clone, Debug)]
pub struct Workspace {
    /// The project root.
    pub root: PathBuf,
    verified: Arc<Mutex<Memo>>,
}

/// Verified stamps: this process's, and those read from (and to be written to) disk.
#[derive(Debug, Default)]
struct Memo {
    session: HashMap<PathBuf, Stamp>,
    disk: Option<BTreeMap<String, Stamp>>,
    dirty: bool,
}

/// A stamp must be this much older than its verification to be trusted across runs (ns).
const RACY_NS: i64 = 2_000_000_000;

/// What identifies one version of a file cheaply (see [`Workspace`]).
type Stamp = [i64; 5];

fn stamp(p: &Path) -> Option<Stamp> {
    let m = std::fs::metadata(p).ok()?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        Some([
            m.dev() as i64,
            m.ino() as i64,
            m.size() as i64,
            m.mtime() * 1_000_000_000 + m.mtime_nsec(),
            m.ctime() * 1_000_000_000 + m.ctime_nsec(),
        ])
    }
    #[cfg(not(unix))]
    {
        let _ = m;
        None // no status-change time: always verify in full
    }
}

/// Whether a stamp's times have a sub-second part (a file system with whole-second times has
/// both nanosecond parts zero; on a finer one both are zero only by a rare coincidence, which
/// costs one re-read).
fn fine_times(st: &Stamp) -> bool {
    st[3] % 1_000_000_000 != 0 || st[4] % 1_000_000_000 != 0
}

impl Workspace {
    /// A workspace rooted at `root`.
    pub fn new(root: impl Into<PathBuf>) -> Self {
        Self {
            root: root.into(),
            verified: Arc::default(),
        }
    }
    /// `results/`.
    pub fn results(&self) -> PathBuf {
        self.root.join("results")
    }
    /// `results/cache/`.
    pub fn cache_dir(&self) -> PathBuf {
        self.results().join("cache")
    }
    /// `results/cache/<kind>/<key>.h5`.
    pub fn artefact_path(&self, kind: &str, key: &str) -> PathBuf {
        self.cache_dir().join(kind).join(format!("{key}.h5"))
    }
    /// The artefact path of a planned stage.
    pub fn artefact_of(&self, s: &PlannedStage) -> PathBuf {
        self.artefact_path(&s.kind, &s.key)
    }
    /// `results/cache/index.json`.
    pub fn index_path(&self) -> PathBuf {
        self.cache_dir().join("index.json")
    }
    /// `results/runs/` (event logs).
    pub fn runs_dir(&self) -> PathBuf {
        self.results().join("runs")
    }
    /// `results/.lock`.
    pub fn lock_path(&self) -> PathBuf {
        self.results().join(".lock")
    }
    /// A side output's path.
    pub fn side_output_path(&self, rel: &str) -> PathBuf {
        self.root.join(rel)
    }

    /// The state of a stage's cache entry.
    pub fn entry_state(&self, s: &PlannedStage) -> EntryState {
        EntryState::of(&self.integrity(s))
    }

    /// `results/cache/verified.json` (stamps of verified entries).
    pub fn verified_path(&self) -> PathBuf {
        self.cache_dir().join("verified.json")
    }

    fn memo_key(&self, s: &PlannedStage) -> String {
        format!("{}/{}.h5", s.kind, s.key)
    }

    /// Whether the entry's stamp is a verified one: in this process (`Some(true)`), on disk
    /// (`Some(false)`), or not at all.
    fn known(&self, s: &PlannedStage, p: &Path, now: &Stamp) -> Option<bool> {
        let mut m = self.verified.lock().ok()?;
        if m.session.get(p) == Some(now) {
            return Some(true);
        }
        if m.disk.is_none() {
            m.disk = Some(
                std::fs::read(self.verified_path())
                    .ok()
                    .and_then(|b| serde_json::from_slice(&b).ok())
                    .unwrap_or_default(),
            );
        }
        let disk = m.disk.as_ref()?;
        (disk.get(&self.memo_key(s)) == Some(now)).then_some(false)
    }

    /// `published`: this process wrote the file and stamped it right after renaming it (see
    /// [`Workspace`]).
    fn remember(&self, s: &PlannedStage, p: PathBuf, now: Stamp, published: bool) {
        // file times are coarse (a clock tick of a few ms): a file changed within the same tick
        // after its verification would keep its stamp. As git does with "racily clean"
        // entries, a stamp younger than RACY_NS is trusted for this process only, unless it
        // was taken by the publisher itself on a file system with sub-second times.
        let wall = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as i64);
        let settled = wall - now[3].max(now[4]) > RACY_NS || (published && fine_times(&now));
        if let Ok(mut m) = self.verified.lock() {
            m.session.insert(p, now);
            if !settled {
                return;
            }
            let key = self.memo_key(s);
            let disk = m.disk.get_or_insert_with(BTreeMap::new);
            if disk.get(&key) != Some(&now) {
                disk.insert(key, now);
                m.dirty = true;
            }
        }
    }

    /// The full verdict on a stage's cache entry, with the reason when it is not valid.
    pub fn integrity(&self, s: &PlannedStage) -> Integrity {
        let p = self.artefact_of(s);
        let Some(now) = stamp(&p) else {
            return store::digest::check(&p, &s.key);
        };
        match self.known(s, &p, &now) {
            Some(true) => return Integrity::Valid,
            Some(false) => {
                // mark, key and content verified before (the key is the file's name), file
                // untouched since: nothing to read
                self.remember(s, p, now, false);
                return Integrity::Valid;
            }
            None => {}
        }
        let verdict = store::digest::check(&p, &s.key);
        if verdict.is_valid() {
            self.remember(s, p, now, false);
        }
        verdict
    }

    /// Remembers that the entry of `s` was just written by this process (its digest computed
    /// at publication), so that consumers need not re-read it.
    pub fn mark_verified(&self, s: &PlannedStage) {
        let p = self.artefact_of(s);
        if let Some(now) = stamp(&p) {
            self.remember(s, p, now, true);
        }
    }

    /// Writes the verified stamps to `results/cache/verified.json` if any is new. Failure is
    /// harmless (the next run verifies in full), so it is ignored.
    pub fn save_verified(&self) {
        let Ok(mut m) = self.verified.lock() else {
            return;
        };
        if !m.dirty {
            return;
        }
        let Some(disk) = &m.disk else { return };
        // keep only entries whose file still exists
        let live: BTreeMap<&String, &Stamp> = disk
            .iter()
            .filter(|(k, _)| self.cache_dir().join(k).is_file())
            .collect();
        if let Ok(bytes) = serde_json::to_vec(&live)
            && store::fsutil::write_atomic(&self.verified_path(), &bytes).is_ok()
        {
            m.dirty = false;
        }
    }

    /// Opens a stage's cache entry for reading, verified (key and content); an entry that is
    /// not valid is an error naming the stage and its file.
    pub fn open_entry(&self, s: &PlannedStage) -> Result<ArtefactReader> {
        let path = self.artefact_of(s);
        match self.integrity(s) {
            Integrity::Valid => ArtefactReader::open_complete(&path),
            Integrity::Missing => bail!(
                "the artefact of stage `{}` (`{}`) is missing",
                s.name,
                path.display()
            ),
            bad => bail!(
                "the artefact of stage `{}` cannot be used: {}",
                s.name,
                bad.detail()
            ),
        }
    }

    /// Removes stale temporary files (from killed runs: their writer process is gone) in the
    /// cache and in the folders of the given side outputs. Call while holding the exclusive
    /// lock.
    pub fn remove_stale_temps(&self, side_outputs: &[String]) -> Vec<PathBuf> {
        let mut dirs: Vec<PathBuf> = Vec::new();
        if let Ok(rd) = std::fs::read_dir(self.cache_dir()) {
            dirs.extend(rd.flatten().map(|e| e.path()).filter(|p| p.is_dir()));
        }
        dirs.push(self.cache_dir());
        for f in side_outputs {
            if let Some(parent) = self.side_output_path(f).parent() {
                dirs.push(parent.to_path_buf());
            }
        }
        dirs.sort();
        dirs.dedup();
        let mut removed = Vec::new();
        for d in dirs {
            let Ok(rd) = std::fs::read_dir(&d) else {
                continue;
            };
            for e in rd.flatten() {
                let name = e.file_name().to_string_lossy().into_owned();
                if store::fsutil::is_stale_temp(&name) && std::fs::remove_file(e.path()).is_ok() {
                    removed.push(e.path());
                }
            }
        }
        removed
    }
}

/// A cache entry's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EntryState {
    /// Published, complete, readable, holding the expected key, content matching its digest.
    Valid,
    /// No file.
    Missing,
    /// A file that is truncated, unreadable or lacks the complete mark.
    Invalid,
    /// A complete, readable file whose key or content digest does not match.
    Damaged,
}

impl EntryState {
    /// The state of a verdict.
    pub fn of(i: &Integrity) -> Self {
        match i {
            Integrity::Valid => Self::Valid,
            Integrity::Missing => Self::Missing,
            Integrity::Invalid(_) => Self::Invalid,
            Integrity::Damaged(_) => Self::Damaged,
        }
    }
    /// How `status` shows it.
    pub fn label(self) -> &'static str {
        match self {
            Self::Valid => "cached",
            Self::Missing => "missing",
            Self::Invalid => "INVALID",
            Self::Damaged => "DAMAGED",
        }
    }
}

/// The last key computed for each stage of a (pipeline, params) pair, to explain why a stage
/// reruns. Stored as `results/cache/index.json`, written atomically.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Index {
    /// `"<pipeline>|<params>|<stage>"` → entry.
    pub stages: BTreeMap<String, IndexEntry>,
}

/// One index entry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexEntry {
    /// Key of the last successful computation (or cache hit).
    pub key: String,
    /// Kind.
    pub kind: String,
    /// Code version.
    pub code_version: u64,
    /// Code identity (part → hash); empty in indexes written before it existed.
    #[serde(default)]
    pub code: BTreeMap<String, String>,
    /// Canonical parameters.
    pub params: Value,
    /// Input name → keys.
    pub input_keys: BTreeMap<String, Vec<String>>,
    /// Input name → stage names.
    pub input_stages: BTreeMap<String, Vec<String>>,
    /// When (UTC).
    pub updated_utc: String,
}

impl Index {
    /// Reads the index; a missing or unreadable index is empty (it only explains, it never
    /// decides what is cached).
    pub fn load(ws: &Workspace) -> Self {
        std::fs::read(ws.index_path())
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_default()
    }
    /// Writes it atomically.
    pub fn save(&self, ws: &Workspace) -> Result<()> {
        let bytes = serde_json::to_vec_pretty(self)?;
        store::fsutil::write_atomic(&ws.index_path(), &bytes)
            .context("cannot write the cache index")
    }
    /// The index slot of a stage of a plan.
    pub fn slot(plan: &Plan, stage: &str) -> String {
        format!("{}|{}|{}", plan.pipeline, plan.params, stage)
    }
    /// Records a stage's current identity.
    pub fn record(&mut self, plan: &Plan, s: &PlannedStage) {
        self.stages.insert(
            Self::slot(plan, &s.name),
            IndexEntry {
                key: s.key.clone(),
                kind: s.kind.clone(),
                code_version: s.code_version,
                code: s.code.clone(),
                params: s.params.to_value(),
                input_keys: s.input_keys.clone(),
                input_stages: s.inputs.clone(),
                updated_utc: store::fsutil::utc_now_iso8601(),
            },
        );
    }
    /// Why `s` must run given its cache entry's verdict (which is not valid) or a `--force`.
    pub fn reasons(
        &self,
        plan: &Plan,
        s: &PlannedStage,
        verdict: &Integrity,
        forced: bool,
    ) -> Vec<Reason> {
        let mut out = Vec::new();
        if forced {
            out.push(Reason::Forced);
        }
        let present = match verdict {
            Integrity::Valid => return out,
            Integrity::Missing => None,
            Integrity::Invalid(why) => Some(Reason::OutputInvalid(why.clone())),
            Integrity::Damaged(why) => Some(Reason::OutputDamaged(why.clone())),
        };
        match self.stages.get(&Self::slot(plan, &s.name)) {
            // a bad file under the expected key is reported whatever else changed
            _ if present.is_some() => out.extend(present),
            None => out.push(Reason::New),
            Some(last) if last.key == s.key => out.push(Reason::OutputMissing),
            Some(last) => {
                if last.kind != s.kind {
                    out.push(Reason::KindChanged {
                        from: last.kind.clone(),
                        to: s.kind.clone(),
                    });
                } else if last.code_version != s.code_version {
                    out.push(Reason::CodeVersionChanged {
                        from: last.code_version,
                        to: s.code_version,
                    });
                }
                if last.kind == s.kind && last.code != s.code {
                    let parts: BTreeSet<&String> = last.code.keys().chain(s.code.keys()).collect();
                    out.push(Reason::CodeChanged(
                        parts
                            .into_iter()
                            .filter(|p| last.code.get(*p) != s.code.get(*p))
                            .cloned()
                            .collect(),
                    ));
                }
                let diffs = param_diffs(&last.params, &s.params.to_value());
                if !diffs.is_empty() {
                    out.push(Reason::ParamsChanged(diffs));
                }
                let changed: Vec<String> = s
                    .input_keys
                    .iter()
                    .filter(|(k, v)| last.input_keys.get(*k) != Some(*v))
                    .map(|(k, _)| format!("{k} ← {}", s.inputs[k].join(", ")))
                    .chain(
                        last.input_keys
                            .keys()
                            .filter(|k| !s.input_keys.contains_key(*k))
                            .map(|k| format!("{k} (removed)")),
                    )
                    .collect();
                if !changed.is_empty() {
                    out.push(Reason::InputChanged(changed));
                }
                let files = s.imp.file_inputs(&s.params);
                if (out.is_empty() || (out.len() == 1 && forced)) && !files.is_empty() {
                    out.push(Reason::FileChanged(files));
                }
                if out.is_empty() || (out.len() == 1 && forced) {
                    out.push(Reason::OutputMissing);
                }
            }
        }
        out
    }
}

/// Differences between two parameter objects: `name old → new`.
pub fn param_diffs(old: &Value, new: &Value) -> Vec<String> {
    let (Some(o), Some(n)) = (old.as_object(), new.as_object()) else {
        return vec!["(all)".into()];
    };
    let mut keys: Vec<&String> = o.keys().chain(n.keys()).collect();
    keys.sort();
    keys.dedup();
    let show = |v: Option<&Value>| v.map_or("(none)".to_string(), |v| v.to_string());
    keys.into_iter()
        .filter(|k| o.get(*k) != n.get(*k))
        .map(|k| format!("{k} {} → {}", show(o.get(k)), show(n.get(k))))
        .collect()
}

/// Why a stage runs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Reason {
    /// Never computed for this pipeline and params file.
    New,
    /// `--force`.
    Forced,
    /// Parameters differ from the last computation (`name old → new`).
    ParamsChanged(Vec<String>),
    /// The kind's code version was bumped.
    CodeVersionChanged {
        /// Last version.
        from: u64,
        /// Current version.
        to: u64,
    },
    /// The source of code the kind depends on changed (the parts: `crate contact`, ...).
    CodeChanged(Vec<String>),
    /// The stage's kind was changed in the pipeline file.
    KindChanged {
        /// Last kind.
        from: String,
        /// Current kind.
        to: String,
    },
    /// An input's key changed (`input ← stage`).
    InputChanged(Vec<String>),
    /// Nothing above differs but the key does: the content of a file input changed (the files
    /// the kind reads, [`crate::StageKind::file_inputs`]).
    FileChanged(Vec<String>),
    /// Same key as last time, but the artefact is gone (deleted, or gc'd).
    OutputMissing,
    /// The artefact is truncated, unreadable or unfinished (why, naming the file).
    OutputInvalid(String),
    /// The artefact's key or content digest does not match: edited, damaged or another stage's
    /// file (why, naming the file).
    OutputDamaged(String),
}

impl Reason {
    /// A short machine-readable tag.
    pub fn tag(&self) -> &'static str {
        match self {
            Self::New => "new",
            Self::Forced => "forced",
            Self::ParamsChanged(_) => "params_changed",
            Self::CodeVersionChanged { .. } => "code_version_changed",
            Self::CodeChanged(_) => "code_changed",
            Self::KindChanged { .. } => "kind_changed",
            Self::InputChanged(_) => "input_changed",
            Self::FileChanged(_) => "file_changed",
            Self::OutputMissing => "output_missing",
            Self::OutputInvalid(_) => "output_invalid",
            Self::OutputDamaged(_) => "output_damaged",
        }
    }
}

impl fmt::Display for Reason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::New => write!(f, "new"),
            Self::Forced => write!(f, "forced (--force)"),
            Self::ParamsChanged(d) => write!(f, "parameters changed: {}", d.join(", ")),
            Self::CodeVersionChanged { from, to } => {
                write!(f, "code version changed: {from} → {to}")
            }
            Self::CodeChanged(parts) => write!(f, "code changed ({})", parts.join(", ")),
            Self::KindChanged { from, to } => write!(f, "kind changed: {from} → {to}"),
            Self::InputChanged(d) => write!(f, "input changed: {}", d.join(", ")),
            Self::FileChanged(files) => write!(f, "file input changed: {}", files.join(", ")),
            Self::OutputMissing => write!(f, "cached artefact missing (deleted or collected)"),
            Self::OutputInvalid(why) => write!(
                f,
                "cached artefact invalid (truncated, unreadable or unfinished): {why}"
            ),
            Self::OutputDamaged(why) => write!(f, "cached artefact damaged: {why}"),
        }
    }
}

/// Size of a file, 0 if unreadable.
pub fn file_size(p: &Path) -> u64 {
    std::fs::metadata(p).map(|m| m.len()).unwrap_or(0)
}

/// Which stage, key and params file wrote each published output (figures, tables), so that
/// `status` can tell this plan's outputs from another params file's. Stored as
/// `results/manifest.json`, written atomically after every run.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Manifest {
    /// Output path (relative to the project root) → where it came from.
    pub outputs: BTreeMap<String, ManifestEntry>,
}

/// One output's origin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestEntry {
    /// Stage name.
    pub stage: String,
    /// Stage key.
    pub key: String,
    /// Pipeline file.
    pub pipeline: String,
    /// Params file.
    pub params: String,
    /// BLAKE3 of the output's bytes when written.
    pub blake3: String,
    /// The source commit (`git rev-parse HEAD` in the project root), if known.
    pub commit: Option<String>,
    /// When (UTC).
    pub updated_utc: String,
}

impl Manifest {
    /// `results/manifest.json`.
    pub fn path(ws: &Workspace) -> PathBuf {
        ws.results().join("manifest.json")
    }
    /// Reads it; missing or unreadable is empty.
    pub fn load(ws: &Workspace) -> Self {
        std::fs::read(Self::path(ws))
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_default()
    }
    /// Writes it atomically.
    pub fn save(&self, ws: &Workspace) -> Result<()> {
        let bytes = serde_json::to_vec_pretty(self)?;
        store::fsutil::write_atomic(&Self::path(ws), &bytes)
            .context("cannot write the output manifest")
    }
    /// Records the outputs of `s` as they are on disk now.
    pub fn record(&mut self, ws: &Workspace, plan: &Plan, s: &PlannedStage, commit: Option<&str>) {
        for rel in &s.side_outputs {
            let Ok(blake3) = store::canonical::hash_file(&ws.side_output_path(rel)) else {
                continue;
            };
            self.outputs.insert(
                rel.clone(),
                ManifestEntry {
                    stage: s.name.clone(),
                    key: s.key.clone(),
                    pipeline: plan.pipeline.clone(),
                    params: plan.params.clone(),
                    blake3,
                    commit: commit.map(str::to_string),
                    updated_utc: store::fsutil::utc_now_iso8601(),
                },
            );
        }
    }
    /// How output `rel` of stage `s` relates to this plan: `None` when the manifest says this
    /// stage's key wrote the bytes now on disk; otherwise a short note.
    pub fn origin_note(&self, ws: &Workspace, s: &PlannedStage, rel: &str) -> Option<String> {
        let Some(e) = self.outputs.get(rel) else {
            return Some("no manifest entry".into());
        };
        if e.key != s.key {
            return Some(format!("written by {} with {}", e.pipeline, e.params));
        }
        match store::canonical::hash_file(&ws.side_output_path(rel)) {
            Ok(h) if h == e.blake3 => None,
            Ok(_) => Some("edited since written".into()),
            Err(_) => None, // missing: shown as missing
        }
    }
}

/// The commit of the project root's git checkout, if any (`git rev-parse HEAD`).
pub fn git_commit(root: &Path) -> Option<String> {
    let dir = if root.as_os_str().is_empty() {
        Path::new(".")
    } else {
        root
    };
    let out = std::process::Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(["rev-parse", "HEAD"])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()?;
    let s = String::from_utf8(out.stdout).ok()?.trim().to_string();
    (out.status.success() && !s.is_empty()).then_some(s)
}
