//! Memory pre-flight on the real binary (issue 18, item 8): every kind estimates a lower bound
//! of its peak memory; the estimate is checked against the peaks the provenance records; a
//! stage whose estimate cannot be allocated under an address-space limit fails as that stage,
//! with the estimate and the limit, while independent stages finish.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::{Command, Output};

mod common;

use common::project;

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Sets `key = value` in a params file (the line must exist).
fn set(root: &Path, params: &str, key: &str, value: &str) {
    let p = root.join(params);
    let t = std::fs::read_to_string(&p).unwrap();
    let prefix = format!("{key} = ");
    assert!(
        t.lines().any(|l| l.starts_with(&prefix)),
        "{key} in {params}"
    );
    let t: String = t
        .lines()
        .map(|l| {
            if l.starts_with(&prefix) {
                format!("{key} = {value}\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    std::fs::write(p, t).unwrap();
}

/// (kind, stage stats) of every artefact in the cache.
fn stats(root: &Path) -> Vec<(String, serde_json::Value)> {
    let mut out = Vec::new();
    for k in std::fs::read_dir(root.join("results/cache"))
        .unwrap()
        .flatten()
    {
        if !k.path().is_dir() {
            continue;
        }
        for e in k.path().read_dir().unwrap().flatten() {
            if e.path().extension().is_some_and(|x| x == "h5") {
                let prov = store::ArtefactReader::open(e.path())
                    .unwrap()
                    .provenance()
                    .unwrap();
                out.push((prov.kind, prov.stats));
            }
        }
    }
    out
}

/// How far the measured peak may exceed the estimate: the estimates count the grid fields a
/// kind must hold (a lower bound); solvers hold FFT buffers (complex, zero-padded: 4–8 fields),
/// minimiser state and copies read from HDF5, hence up to `FACTOR` times as much, plus
/// `ALLOWANCE_MIB` of what no grid explains (HDF5 buffers, thread stacks, the allocator's
/// slack; the smoke grids' fields are 8 KiB, so there the allowance is all of it).
const FACTOR: f64 = 16.0;
const ALLOWANCE_MIB: f64 = 64.0;

fn check_bounds(kind: &str, s: &serde_json::Value, seen: &mut BTreeSet<String>) {
    let est = s["memory_estimate_mib"]
        .as_f64()
        .unwrap_or_else(|| panic!("{kind}: no memory estimate recorded: {s}"));
    let peak = s["peak_rss_mib"].as_f64().expect("Linux records the peak");
    let start = s["rss_start_mib"].as_f64().expect("and the start");
    assert_eq!(
        s["peak_rss_scope"], "stage",
        "{kind}: -j 1 measures each stage alone"
    );
    eprintln!(
        "{kind}: estimate {est:.3} MiB, peak {peak:.1} MiB, added {:.1} MiB",
        peak - start
    );
    // a lower bound: the process's peak during the stage holds at least the estimate
    assert!(
        est <= peak,
        "{kind}: estimate {est} MiB above the peak {peak} MiB"
    );
    // and not a meaningless one: what the stage added is within the factor
    assert!(
        peak - start <= FACTOR * est + ALLOWANCE_MIB,
        "{kind}: the stage added {:.1} MiB, more than {FACTOR} × its estimate {est:.1} MiB + {ALLOWANCE_MIB} MiB",
        peak - start
    );
    seen.insert(kind.to_string());
}

#[test]
fn every_kind_has_a_memory_estimate_that_bounds_its_measured_peak() {
    let dir = project();
    let root = dir.path();
    let o = Command::new(env!("CARGO_BIN_EXE_saddleflow"))
        .args(["run", "-j", "1", "-C"])
        .arg(root)
        .args(["--params", "params/smoke.toml"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let mut seen = BTreeSet::new();
    for (kind, s) in stats(root) {
        check_bounds(&kind, &s, &mut seen);
    }
    // the smoke pipeline uses every physics kind (mock is for the orchestrator's tests)
    let all: BTreeSet<String> = stages::registry()
        .names()
        .into_iter()
        .filter(|k| *k != "mock")
        .map(str::to_string)
        .collect();
    assert_eq!(seen, all, "kinds without a checked estimate");

    // In one process a stage often reuses memory that earlier stages freed (the allocator
    // keeps it), so what a stage adds to the resident set can be 0, and only the absolute peak
    // bounds the estimate above. One stage alone in a fresh process adds what it allocates: the
    // square surface on 1024² (8 MiB fields), where the estimate is no longer dwarfed by the
    // allowance.
    std::fs::remove_dir_all(root.join("results/cache")).unwrap();
    set(root, "params/smoke.toml", "n", "10");
    let o = Command::new(env!("CARGO_BIN_EXE_saddleflow"))
        .args(["run", "-j", "1", "--only", "surface_square", "-C"])
        .arg(root)
        .args(["--params", "params/smoke.toml"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let measured = stats(root);
    assert_eq!(measured.len(), 1, "one stage ran");
    let (kind, s) = &measured[0];
    check_bounds(kind, s, &mut BTreeSet::new());
    let est = s["memory_estimate_mib"].as_f64().unwrap();
    let added = s["peak_rss_mib"].as_f64().unwrap() - s["rss_start_mib"].as_f64().unwrap();
    assert_eq!(est, 8.0, "{s}");
    assert!(
        est <= added && added <= FACTOR * est,
        "{kind} on 1024² added {added:.1} MiB: outside [1, {FACTOR}] × its estimate {est} MiB"
    );
}

#[test]
fn a_stage_beyond_the_address_space_limit_fails_alone_with_its_estimate() {
    let dir = project();
    let root = dir.path();
    // the extremes stage's largest grid 8192²: 4 fields of 512 MiB, above a 1.5 GiB limit
    set(root, "params/smoke.toml", "extremes_n_largest", "13");
    let limit = 1536u64 << 20;
    let o = Command::new("prlimit")
        .arg(format!("--as={limit}"))
        .arg(env!("CARGO_BIN_EXE_saddleflow"))
        .args([
            "run", "-j", "2", "--only", "extremes", "--only", "fig2", "-C",
        ])
        .arg(root)
        .args(["--params", "params/smoke.toml"])
        .output()
        .expect("prlimit (util-linux) runs the binary under an address-space limit");
    let t = text(&o);
    assert_eq!(
        o.status.code(),
        Some(1),
        "a stage's failure, not an abort:\n{t}"
    );
    assert!(
        t.contains("stage `extremes_square`")
            && t.contains("needs at least 2048 MiB")
            && t.contains("address-space limit (RLIMIT_AS, `ulimit -v`) is 1536 MiB"),
        "{t}"
    );
    // the summary is printed; the independent stages (fig2, the ladder's critical study)
    // finished
    assert!(t.contains(" ran, ") && t.contains("1 failed"), "{t}");
    assert!(root.join("results/tables/fig2.csv").is_file(), "{t}");
    let done: Vec<String> = stats(root).into_iter().map(|(k, _)| k).collect();
    assert!(done.contains(&"critical".to_string()), "{done:?}");
    assert!(!done.contains(&"extremes".to_string()), "{done:?}");
}
