//! Code identity of the stage kinds: which sources can change a kind's output, and their hashes.
//! Used by `build.rs` (at build time) and by `tests/code_identity.rs` (on a copy of the tree);
//! std and `blake3` only.
//!
//! A kind lives in the module `crates/<c>/src/<kind>.rs` of a kind crate ([`MODULE_CRATES`]:
//! `kinds` for compute kinds, `scenes` for report scenes). Its identity has one part per
//! source it depends on:
//! - `<c>/src/<m>.rs` (a file module) or `<c>/src/<m>/` (a folder module, `mod.rs` and every
//!   file under it) for the module itself and every module of a kind crate it reaches
//!   through `crate::m` or `super::m` paths in its own crate, or `kinds::m` from another
//!   (including `use crate::{a, b::c}` lists), transitively;
//! - `crate <c>` for every workspace crate those modules name as `c::` (the `[dependencies]`
//!   of the kind crates that are workspace crates), and for their own workspace
//!   `[dependencies]`, transitively. A crate's hash covers every file of the crate but its
//!   `tests/`, `benches/`, `examples/` and hidden files (so `src/`, `assets/`, `Cargo.toml`,
//!   `build.rs`).
//!
//! Engine crates ([`ENGINE`]: the pipeline engine and its file utilities) are left out: they
//! move and verify bytes but compute none; a change of the artefact format they write is a
//! change of the key scheme instead. The scan is textual, so it errs on the side of more
//! dependencies (a name in a comment counts); external crates' versions are covered by the
//! kinds' explicit `code_version` (Cargo.lock is not hashed).
//!
//! Overrides: a line `PART NOW WAS` in `crates/stages/code-identity-overrides.txt` says that
//! the part whose hash is now NOW computes what it did at WAS (a refactoring, a comment): the
//! identity keeps WAS. Any further edit of that part changes its hash away from NOW, and the
//! override stops applying (a stale override is reported by the build).

use std::collections::{BTreeMap, BTreeSet};
use std::io;
use std::path::{Path, PathBuf};

/// Crates that never change a stage's output (see the module docs).
pub const ENGINE: &[&str] = &["orchestrator", "fsutil"];

/// A workspace crate: its folder and workspace dependencies.
#[derive(Debug, Clone)]
pub struct CrateInfo {
    pub dir: PathBuf,
    pub deps: Vec<String>,
}

fn put(h: &mut blake3::Hasher, bytes: &[u8]) {
    h.update(&(bytes.len() as u64).to_le_bytes());
    h.update(bytes);
}

fn files_under(dir: &Path, top: bool, out: &mut Vec<PathBuf>) -> io::Result<()> {
    for e in std::fs::read_dir(dir)? {
        let e = e?;
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with('.')
            || (top && matches!(name.as_str(), "tests" | "benches" | "examples" | "target"))
        {
            continue;
        }
        let p = e.path();
        if e.file_type()?.is_dir() {
            files_under(&p, false, out)?;
        } else {
            out.push(p);
        }
    }
    Ok(())
}

/// The files of a crate that its hash covers, sorted.
pub fn crate_files(dir: &Path) -> io::Result<Vec<PathBuf>> {
    let mut v = Vec::new();
    files_under(dir, true, &mut v)?;
    v.sort();
    Ok(v)
}

/// BLAKE3 over a crate's files (relative path and bytes of each, sorted by path).
pub fn crate_hash(dir: &Path) -> io::Result<String> {
    let mut h = blake3::Hasher::new();
    for f in crate_files(dir)? {
        let rel = f
            .strip_prefix(dir)
            .unwrap_or(&f)
            .to_string_lossy()
            .replace('\\', "/");
        put(&mut h, rel.as_bytes());
        put(&mut h, &std::fs::read(&f)?);
    }
    Ok(h.finalize().to_hex().to_string())
}

/// Package name and `[dependencies]` / `[build-dependencies]` keys of a Cargo.toml.
fn manifest(text: &str) -> (Option<String>, Vec<String>) {
    let (mut section, mut name, mut deps) = (String::new(), None, Vec::new());
    for line in text.lines().map(str::trim) {
        if line.starts_with('[') {
            section = line.trim_matches(|c| c == '[' || c == ']').to_string();
            continue;
        }
        let Some((k, v)) = line.split_once('=') else {
            continue;
        };
        let k = k.trim();
        if section == "package" && k == "name" {
            name = Some(v.trim().trim_matches('"').replace('-', "_"));
        } else if section == "dependencies" || section == "build-dependencies" {
            let k = k.split('.').next().unwrap_or(k).trim();
            deps.push(k.replace('-', "_"));
        }
    }
    (name, deps)
}

/// The workspace crates under `crates_dir` (each folder with a Cargo.toml), by package name;
/// dependencies are kept only when they are workspace crates.
pub fn workspace_crates(crates_dir: &Path) -> io::Result<BTreeMap<String, CrateInfo>> {
    let mut out = BTreeMap::new();
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(crates_dir)?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.join("Cargo.toml").is_file())
        .collect();
    dirs.sort();
    for dir in dirs {
        let (name, deps) = manifest(&std::fs::read_to_string(dir.join("Cargo.toml"))?);
        if let Some(name) = name {
            out.insert(name, CrateInfo { dir, deps });
        }
    }
    let names: BTreeSet<String> = out.keys().cloned().collect();
    for c in out.values_mut() {
        c.deps.retain(|d| names.contains(d));
    }
    Ok(out)
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The identifiers of the path segment at the start of `after` (the text after `root::`): one
/// identifier, or every identifier of a `{...}` list.
fn segment_idents(after: &str) -> Vec<String> {
    let segment = if after.starts_with('{') {
        let mut depth = 0usize;
        let end = after
            .char_indices()
            .find(|&(_, c)| {
                depth = match c {
                    '{' => depth + 1,
                    '}' => depth - 1,
                    _ => depth,
                };
                depth == 0
            })
            .map_or(after.len(), |(j, _)| j);
        &after[..end]
    } else {
        &after[..after.find(|c: char| !is_ident(c)).unwrap_or(after.len())]
    };
    segment
        .split(|c: char| !is_ident(c))
        .filter(|w| !w.is_empty())
        .map(str::to_string)
        .collect()
}

/// Identifiers that follow `crate::` or `super::` in `src` (a `{...}` list after it counts
/// whole: every identifier in it).
pub fn module_refs(src: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for prefix in ["crate::", "super::"] {
        let mut rest = src;
        while let Some(i) = rest.find(prefix) {
            let after = &rest[i + prefix.len()..];
            let before_ok = rest[..i].chars().last().is_none_or(|c| !is_ident(c));
            if before_ok {
                out.extend(segment_idents(after));
            }
            rest = after;
        }
    }
    out
}

/// Whether `src` names `krate` as a path root (`krate::`, not `other_krate::` or `x.krate::`).
pub fn names_crate(src: &str, krate: &str) -> bool {
    let pat = format!("{krate}::");
    src.match_indices(&pat).any(|(i, _)| {
        src[..i]
            .chars()
            .last()
            .is_none_or(|c| !is_ident(c) && c != '.')
    })
}

/// Identifiers that follow `krate::` in `src` as a path root (a `{...}` list after it counts
/// whole), like [`module_refs`] for `crate::`.
pub fn crate_refs(src: &str, krate: &str) -> BTreeSet<String> {
    let pat = format!("{krate}::");
    let mut out = BTreeSet::new();
    for (i, _) in src.match_indices(&pat) {
        let before_ok = src[..i]
            .chars()
            .last()
            .is_none_or(|c| !is_ident(c) && c != '.');
        if before_ok {
            out.extend(segment_idents(&src[i + pat.len()..]));
        }
    }
    out
}

/// Transitive closure over workspace crate dependencies.
fn crate_closure(
    roots: &BTreeSet<String>,
    crates: &BTreeMap<String, CrateInfo>,
) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut todo: Vec<String> = roots.iter().cloned().collect();
    while let Some(c) = todo.pop() {
        if seen.insert(c.clone())
            && let Some(info) = crates.get(&c)
        {
            todo.extend(info.deps.iter().cloned());
        }
    }
    seen
}

/// Overrides: part → (now, was).
pub fn parse_overrides(text: &str) -> BTreeMap<String, (String, String)> {
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter_map(|l| {
            let (part, hashes) = l.rsplit_once(char::is_whitespace)?;
            let was = hashes.to_string();
            let (part, now) = part.trim().rsplit_once(char::is_whitespace)?;
            Some((part.trim().to_string(), (now.to_string(), was)))
        })
        .collect()
}

/// Module name → (part → hash).
pub type Identities = BTreeMap<String, BTreeMap<String, String>>;

/// Crates whose modules are stage kinds (a kind lives in `crates/<crate>/src/<kind>.rs`); their
/// sources are followed module by module, every other workspace crate is hashed whole.
pub const MODULE_CRATES: &[&str] = &["kinds", "scenes"];

/// The identity of every module of the kind crates ([`MODULE_CRATES`]): module name → (part →
/// hash). `stages_dir` is the stages crate's folder; its siblings are the workspace crates.
/// A module reaches the modules of its own crate through `crate::m`/`super::m` and those of
/// another kind crate through `kinds::m`. Overrides are applied; the second value lists the
/// overrides that matched nothing (stale).
pub fn module_identities(
    stages_dir: &Path,
    overrides: &BTreeMap<String, (String, String)>,
) -> io::Result<(Identities, Vec<String>)> {
    let crates_dir = stages_dir.parent().unwrap_or(Path::new(".."));
    let crates = workspace_crates(crates_dir)?;
    // module → (crate, source, part label)
    let mut sources: BTreeMap<String, (String, String, String)> = BTreeMap::new();
    let mut deps_of: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for &mc in MODULE_CRATES {
        let Some(info) = crates.get(mc) else { continue };
        deps_of.insert(
            mc.to_string(),
            info.deps
                .iter()
                .filter(|d| !MODULE_CRATES.contains(&d.as_str()))
                .cloned()
                .collect(),
        );
        let mut entries: Vec<PathBuf> = std::fs::read_dir(info.dir.join("src"))?
            .flatten()
            .map(|e| e.path())
            .collect();
        entries.sort();
        for p in entries {
            let stem = p
                .file_stem()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned();
            // a module is a file `src/m.rs` (with its submodules in `src/m/`, if any) or a
            // folder `src/m/` with `mod.rs`: a module's source is all of its files (sorted, each
            // under its relative path), so an edit to any of them changes its identity
            let folder = |dir: &Path, text: &mut String| -> io::Result<()> {
                let mut files = Vec::new();
                files_under(dir, false, &mut files)?;
                files.sort();
                for f in files
                    .iter()
                    .filter(|f| f.extension().is_some_and(|x| x == "rs"))
                {
                    let rel = f
                        .strip_prefix(dir)
                        .unwrap_or(f)
                        .to_string_lossy()
                        .replace('\\', "/");
                    text.push_str(&format!("// file {rel}\n"));
                    text.push_str(&std::fs::read_to_string(f)?);
                }
                Ok(())
            };
            let source = if p.extension().is_some_and(|x| x == "rs") && stem != "lib" {
                let mut text = std::fs::read_to_string(&p)?;
                let sub = p.with_extension("");
                if sub.is_dir() {
                    folder(&sub, &mut text)?;
                }
                Some((text, format!("{mc}/src/{stem}.rs")))
            } else if p.is_dir() && p.join("mod.rs").is_file() {
                let mut text = String::new();
                folder(&p, &mut text)?;
                Some((text, format!("{mc}/src/{stem}/")))
            } else {
                None
            };
            if let Some((source, label)) = source {
                if let Some((other, ..)) = sources.get(&stem) {
                    return Err(io::Error::other(format!(
                        "module `{stem}` exists in both crates `{other}` and `{mc}`: kind modules must have unique names"
                    )));
                }
                sources.insert(stem, (mc.to_string(), source, label));
            }
        }
    }
    let reached = |m: &str| -> BTreeSet<String> {
        let (krate, src, _) = &sources[m];
        let mut out: BTreeSet<String> = module_refs(src)
            .into_iter()
            .filter(|x| sources.get(x).is_some_and(|(c, ..)| c == krate))
            .collect();
        for &mc in MODULE_CRATES {
            if mc != krate {
                out.extend(
                    crate_refs(src, mc)
                        .into_iter()
                        .filter(|x| sources.get(x).is_some_and(|(c, ..)| c == mc)),
                );
            }
        }
        out
    };
    let mut crate_hashes: BTreeMap<String, String> = BTreeMap::new();
    let mut used: BTreeSet<String> = BTreeSet::new();
    let mut apply = |part: String, hash: String| -> (String, String) {
        match overrides.get(&part) {
            Some((now, was)) if *now == hash => {
                used.insert(part.clone());
                (part, was.clone())
            }
            _ => (part, hash),
        }
    };
    let mut out = BTreeMap::new();
    for m in sources.keys() {
        let mut mods = BTreeSet::new();
        let mut todo = vec![m.clone()];
        while let Some(x) = todo.pop() {
            if sources.contains_key(&x) && mods.insert(x.clone()) {
                todo.extend(reached(&x));
            }
        }
        let named: BTreeSet<String> = mods
            .iter()
            .flat_map(|x| {
                let (krate, src, _) = &sources[x];
                deps_of[krate]
                    .iter()
                    .filter(|c| names_crate(src, c))
                    .cloned()
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut parts = BTreeMap::new();
        for x in &mods {
            let (_, src, label) = &sources[x];
            let h = blake3::hash(src.as_bytes()).to_hex().to_string();
            let (k, v) = apply(label.clone(), h);
            parts.insert(k, v);
        }
        for c in crate_closure(&named, &crates) {
            if ENGINE.contains(&c.as_str()) {
                continue;
            }
            let Some(info) = crates.get(&c) else { continue };
            if !crate_hashes.contains_key(&c) {
                crate_hashes.insert(c.clone(), crate_hash(&info.dir)?);
            }
            let (k, v) = apply(format!("crate {c}"), crate_hashes[&c].clone());
            parts.insert(k, v);
        }
        out.insert(m.clone(), parts);
    }
    let stale = overrides
        .keys()
        .filter(|k| !used.contains(*k))
        .cloned()
        .collect();
    Ok((out, stale))
}
