//! Shared by the CLI's integration tests: a temporary project holding copies of the real
//! declarative files (`pipeline/*.toml`, `params/*.toml`, `params/cluster/*.toml`).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The repository's root.
pub fn project_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn copy_tomls(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        if e.path().extension().is_some_and(|x| x == "toml") {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// A temporary project with the real pipeline/ and params/ (and params/cluster/).
pub fn project() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let root = project_root();
    for sub in ["pipeline", "params", "params/cluster"] {
        copy_tomls(&root.join(sub), &dir.path().join(sub));
    }
    dir
}
