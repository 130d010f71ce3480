//! Your own surface through the pipeline (issue 14, items 7–8) and `leakage --load-path`:
//! the smoke preset's `leakage` and `surface_ensemble` scene groups on copies of the project's
//! files, through the real binary. Checks the tables and figures, that an unchanged rerun runs
//! nothing, and that editing the height file (its content is in the key) reruns exactly the
//! stages downstream of it. Tiny grids: seconds.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;
use tables::ColumnType;

mod common;

use common::{project, run};

/// Runs the two scene groups on the smoke preset; returns the stages that ran.
fn run_groups(root: &Path) -> BTreeSet<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_saddleflow"))
        .args(["run", "-C"])
        .arg(root)
        .args([
            "--params",
            "params/smoke.toml",
            "-j",
            "2",
            "--only",
            "leakage",
        ])
        .args(["--only", "surface_ensemble"])
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "saddleflow run failed:\n{err}");
    // "[k/N] ran NAME (kind key) in …" lines of the progress log
    err.lines()
        .filter_map(|l| l.split_once("] ran ").map(|(_, r)| r))
        .map(|r| r.split_whitespace().next().unwrap().to_string())
        .collect()
}

#[test]
fn leakage_and_ensemble_scenes_run_and_rerun_on_a_file_edit() {
    let dir = project();
    let root = dir.path();
    let first = run_groups(root);
    assert!(first.contains("surface_leakage") && first.contains("surface_ensemble"));
    assert_eq!(first.len(), 8, "2 seeds × 2 + 4: {first:?}");
    // the per-load table: as many rows as the preset's loads, areas increasing with load
    let t = tables::read_csv(
        &root.join("results/tables/leakage.csv"),
        &[
            ("load_over_p_fc", ColumnType::F64),
            ("contact_area", ColumnType::F64),
        ],
    )
    .unwrap();
    assert_eq!(t.n_rows(), 10);
    let a = t.f64("contact_area").unwrap();
    assert!(
        a.windows(2).all(|w| w[1] >= w[0]) && a[0] > 0.0 && a[9] < 1.0,
        "{a:?}"
    );
    for f in ["leakage", "leakage_map", "leakage_surface"] {
        assert!(root.join(format!("figures/{f}.png")).is_file(), "{f}.png");
    }
    // the ensemble: smoke's 2 seeds (`ensemble_seeds`), then mean, sd, sem; a_p a fraction;
    // mean the mean of the seeds
    let e = tables::read_csv(
        &root.join("results/tables/surface_ensemble.csv"),
        &[("seed", ColumnType::Str), ("a_p", ColumnType::F64)],
    )
    .unwrap();
    let (seeds, ap) = (e.str("seed").unwrap(), e.f64("a_p").unwrap());
    assert_eq!(seeds[..2], ["1", "2"].map(String::from));
    assert_eq!(seeds[2..], ["mean", "sd", "sem"].map(String::from));
    assert!(ap[..2].iter().all(|a| *a > 0.0 && *a < 1.0), "{ap:?}");
    let mean = ap[..2].iter().sum::<f64>() / 2.0;
    assert!((ap[2] - mean).abs() < 1e-12, "{} vs {mean}", ap[2]);

    // unchanged: nothing runs
    assert!(run_groups(root).is_empty());
    // the height file edited (one height changed in its last bits): the stages downstream of it rerun, the
    // ensemble stays cached
    let npy = root.join("params/examples/measured_patch.npy");
    let mut bytes = std::fs::read(&npy).unwrap();
    // the last height's least significant mantissa byte (little-endian f64): a change in
    // the last bits, which the key must still see
    let low = bytes.len() - 8;
    bytes[low] ^= 0x01;
    std::fs::write(&npy, bytes).unwrap();
    let again = run_groups(root);
    let want: BTreeSet<String> = ["leakage_surface", "leakage_path", "surface_leakage"]
        .map(String::from)
        .into();
    assert_eq!(again, want);
}

/// `--load-path START:STOP:COUNT[:log|lin]`: the generated loads (relative to p_fc) are the
/// geometric ladder 0.01, 0.0316…, 0.1 (oracle: 0.01 · 10^(k/2)); a bad spec is refused naming
/// the option, and so is giving both --loads and --load-path.
#[test]
fn leakage_load_path_generates_the_loads() {
    let npy = common::project_root().join("params/examples/measured_patch.npy");
    let f = npy.to_str().unwrap();
    let base = [
        "leakage",
        "--surface",
        f,
        "--lx",
        "64",
        "--ly",
        "64",
        "--relative",
    ];
    let args: Vec<&str> = base
        .iter()
        .copied()
        .chain(["--load-path", "0.01:0.1:3"])
        .collect();
    let (ok, v, err) = run(&args);
    assert!(ok, "{err}");
    let pts = v["points"].as_array().unwrap();
    let rel: Vec<f64> = pts
        .iter()
        .map(|p| p["load_over_p_fc"].as_f64().unwrap())
        .collect();
    for (k, r) in rel.iter().enumerate() {
        let want = 0.01 * 10f64.powf(k as f64 / 2.0);
        // load = rel · p_fc, then divided by p_fc again: rounding only
        assert!((r - want).abs() < 1e-12 * want, "{rel:?}");
    }
    let bad: Vec<&str> = base
        .iter()
        .copied()
        .chain(["--load-path", "0.1:0.01:3"])
        .collect();
    let (ok, _, err) = run(&bad);
    assert!(!ok && err.contains("--load-path"), "{err}");
    let both: Vec<&str> = base
        .iter()
        .copied()
        .chain(["--load-path", "0.01:0.1:3", "--loads", "0.1"])
        .collect();
    let (ok, _, err) = run(&both);
    assert!(!ok && err.contains("--load"), "{err}");
}
