//! `saddleflow constriction --surface FILE` (issue 15): one JSON object with L_c, a_p, the
//! constriction, the rungs and the β fit; bad options named. Small grids, seconds.

use serde_json::Value;
use std::path::Path;

mod common;

use common::run;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn generate(dir: &Path) -> std::path::PathBuf {
    let out = dir.join("s.h5");
    let (ok, _, err) = common::generate(&out, &[("--qs", "8"), ("--seed", "3")]);
    assert!(ok, "{err}");
    out
}

#[test]
fn constriction_prints_one_json_object() {
    let dir = tempfile::tempdir().unwrap();
    let f = generate(dir.path());
    let (ok, v, err) = run(&["constriction", "--surface", s(&f), "--ladder", "5e-2:1e-3"]);
    assert!(ok, "{err}");
    let num = |v: &Value, k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"));
    let l_c = num(&v, "l_c");
    let [lo, hi] = [
        v["bracket"][0].as_f64().unwrap(),
        v["bracket"][1].as_f64().unwrap(),
    ];
    assert!(
        lo < l_c && l_c < hi && (hi - lo) / hi <= 1e-9,
        "{lo} {l_c} {hi}"
    );
    assert!((0.0..1.0).contains(&num(&v, "a_p_raw")));
    let rungs = v["rungs"].as_array().unwrap();
    assert_eq!(rungs.len(), 6);
    // rungs at the loads they claim, largest distance first
    for (r, d) in rungs.iter().zip([5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3]) {
        assert_eq!(num(r, "d"), d);
        assert!((num(r, "load") - l_c * (1.0 - d)).abs() < 1e-9 * l_c);
    }
    // flux falls towards L_c
    let flux: Vec<f64> = rungs.iter().map(|r| num(r, "flux")).collect();
    assert!(flux.windows(2).all(|w| w[1] < w[0]), "{flux:?}");
    let c = &v["constriction"];
    assert!(c["constriction"]["gap"].as_f64().unwrap() > 0.0);
    // just below L_c the throat takes nearly all of the drop
    assert!(num(c, "drop_fraction") > 0.9, "{c}");
    assert!(v["beta_fit"].is_object() || v["beta_fit"].is_null());
}

#[test]
fn bad_options_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let f = generate(dir.path());
    for (args, needle) in [
        (vec!["--ladder", "1e-2:5e-2"], "--ladder"),
        (vec!["--ladder", "0.5,1.5"], "--ladder"),
        (vec!["--boundary", "free"], "--boundary free"),
        (vec!["--fit-window", "3"], "--fit-window"),
    ] {
        let mut a = vec!["constriction", "--surface", s(&f)];
        a.extend(args);
        let (ok, _, err) = run(&a);
        assert!(!ok && err.contains(needle), "{a:?}: {err}");
    }
    let (ok, _, err) = run(&["constriction", "--surface", "/nonexistent.h5"]);
    assert!(!ok && err.contains("/nonexistent.h5"), "{err}");
}
