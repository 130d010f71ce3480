//! Shared by the CLI's integration tests: a temporary project holding copies of the real
//! declarative files (`pipeline/*.toml`, `params/*.toml`, `params/cluster/*.toml`) and the
//! example surface in `params/examples/`.
#![allow(dead_code)]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

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
    // the example surface (and its params file) that the `leakage` scene reads by default
    let ex = dir.path().join("params/examples");
    std::fs::create_dir_all(&ex).unwrap();
    for e in std::fs::read_dir(root.join("params/examples"))
        .unwrap()
        .flatten()
    {
        std::fs::copy(e.path(), ex.join(e.file_name())).unwrap();
    }
    dir
}

/// The `saddleflow` binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_saddleflow"))
}

/// Runs the binary; returns (success, parsed stdout JSON or Null, stderr).
pub fn run(args: &[&str]) -> (bool, Value, String) {
    let out = bin().args(args).output().expect("binary runs");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    let json = if out.status.success() {
        assert_eq!(
            stdout.trim().lines().count(),
            1,
            "exactly one JSON line on stdout, got:\n{stdout}"
        );
        serde_json::from_str(stdout.trim()).expect("stdout is JSON")
    } else {
        Value::Null
    };
    (out.status.success(), json, stderr)
}

/// The `surface generate` options of the CLI tests when not given: a 2^6 self-affine surface,
/// H = 0.8, q_r = 2, q_s = 16 (units of 2π/L), rms slope 1, seed 1.
pub const GENERATE_DEFAULTS: [(&str, &str); 6] = [
    ("--n", "6"),
    ("--hurst", "0.8"),
    ("--qr", "2"),
    ("--qs", "16"),
    ("--rms-slope", "1"),
    ("--seed", "1"),
];

/// The arguments of `surface generate --out <out>`: [`GENERATE_DEFAULTS`] with `opts` in
/// place of the defaults of the same option (either rms option replaces the default rms
/// slope), then the other `opts` in order.
pub fn generate_args(out: &Path, opts: &[(&str, &str)]) -> Vec<String> {
    let is_rms = |k: &str| k.starts_with("--rms-");
    let given = |k: &str| {
        opts.iter()
            .any(|(o, _)| *o == k || (is_rms(k) && is_rms(o)))
    };
    let mut args = vec!["surface".to_string(), "generate".to_string()];
    for (k, v) in GENERATE_DEFAULTS.iter().filter(|(k, _)| !given(k)) {
        args.extend([k.to_string(), v.to_string()]);
    }
    for (k, v) in opts {
        args.extend([k.to_string(), v.to_string()]);
    }
    args.extend(["--out".to_string(), out.to_str().unwrap().to_string()]);
    args
}

/// Runs `surface generate` ([`generate_args`]); returns what [`run`] returns.
pub fn generate(out: &Path, opts: &[(&str, &str)]) -> (bool, Value, String) {
    let args = generate_args(out, opts);
    run(&args.iter().map(String::as_str).collect::<Vec<_>>())
}
