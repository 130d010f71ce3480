//! The `critical` and `resolution` kinds and the scenes built on them (Figure 4, the
//! convergence figure, the comparison table) through the engine on 16² and 32² grids.
//!
//! The checks recompute what the stages write from the stored raw data, by formulas written out
//! here: shift averages from the per-shift brackets and contact counts, the perimeter correction
//! (Yastrebov et al. 2017) from the counts, the two-grid extrapolation in closed form.

mod common;
use common::reader;

use stages::orchestrator::{Plan, Workspace};
use std::path::Path;
use tables::ColumnType;

fn run(dir: &Path, pipeline: &str) -> (Plan, Workspace, Vec<String>) {
    common::run_all(dir, pipeline).unwrap()
}

const STUDY: &str = r#"
[stages.critical_hexagonal]
kind = "critical"
params = { lattice = "hexagonal", ns = [4, 5], shifts = 2 }

[stages.critical_square]
kind = "critical"
params = { lattice = "square", ns = [4, 5], shifts = 2 }

[stages.critical_triangular]
kind = "critical"
params = { lattice = "triangular", ns = [4, 5], shifts = 2 }

[stages.resolution_hexagonal]
kind = "resolution"
inputs = { levels = "critical_hexagonal" }

[stages.resolution_square]
kind = "resolution"
inputs = { levels = "critical_square" }

[stages.resolution_triangular]
kind = "resolution"
inputs = { levels = "critical_triangular" }

[stages.fig4]
kind = "fig4"
inputs = { hexagonal = "critical_hexagonal", square = "critical_square", triangular = "critical_triangular" }

[stages.convergence]
kind = "convergence"
inputs = { hexagonal = "resolution_hexagonal", square = "resolution_square", triangular = "resolution_triangular" }
"#;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn stored_averages_corrections_and_extrapolations_follow_from_the_raw_data() {
    let dir = tempfile::tempdir().unwrap();
    let (plan, ws, failed) = run(dir.path(), STUDY);
    assert!(failed.is_empty(), "{failed:?}");
    let c = percolation::PERIMETER_CORRECTION;
    let table = tables::read_csv(
        &dir.path().join("results/tables/critical.csv"),
        &[
            ("model", ColumnType::Str),
            ("l_c", ColumnType::F64),
            ("a_p_raw", ColumnType::F64),
            ("a_p_corrected", ColumnType::F64),
            ("p_fc_over_l_c", ColumnType::F64),
        ],
    )
    .unwrap();
    for (row, model) in ["hexagonal", "square", "triangular"].iter().enumerate() {
        let r = reader(&plan, &ws, &format!("critical_{model}"));
        let mut h = Vec::new();
        let mut l_c = Vec::new();
        let mut raw = Vec::new();
        let mut corr = Vec::new();
        for n in [4, 5] {
            let at = format!("level/{n}");
            let nodes =
                (r.attr_i64_at(&at, "nx").unwrap() * r.attr_i64_at(&at, "ny").unwrap()) as f64;
            let lo = r.read_f64_1d(&format!("{at}/any/lo")).unwrap();
            let hi = r.read_f64_1d(&format!("{at}/any/hi")).unwrap();
            assert_eq!(lo.len(), 4, "2 × 2 shifts");
            let ints = |k: &str| r.read_i64_1d(&format!("{at}/any/{k}")).unwrap();
            let (c_lo, c_hi) = (ints("contact_lo"), ints("contact_hi"));
            let (e_lo, e_hi) = (ints("perimeter_lo"), ints("perimeter_hi"));
            let mean = |v: &dyn Fn(usize) -> f64| (0..4).map(v).sum::<f64>() / 4.0;
            let want_l = mean(&|k| 0.5 * (lo[k] + hi[k]));
            let want_raw = mean(&|k| 0.5 * (c_lo[k] + c_hi[k]) as f64 / nodes);
            let want_corr = mean(&|k| {
                0.5 * ((c_lo[k] as f64 - c * e_lo[k] as f64)
                    + (c_hi[k] as f64 - c * e_hi[k] as f64))
                    / nodes
            });
            for k in 0..4 {
                assert!(lo[k] < hi[k] && (hi[k] - lo[k]) / hi[k] <= 1e-9);
                assert!(c_lo[k] < c_hi[k], "the bracket closes the bridging nodes");
            }
            let a = |k: &str| r.attr_f64_at(&at, k).unwrap();
            assert!(close(a("l_c"), want_l, 1e-14), "{model} n = {n}");
            assert!(close(a("a_p_raw"), want_raw, 1e-14), "{model} n = {n}");
            assert!(
                close(a("a_p_corrected"), want_corr, 1e-14),
                "{model} n = {n}"
            );
            // the paper's L_c is the later of the two axis transitions on every shift
            let lx = r.read_f64_1d(&format!("{at}/x/hi")).unwrap();
            let ly = r.read_f64_1d(&format!("{at}/y/hi")).unwrap();
            for k in 0..4 {
                assert!(close(hi[k], lx[k].max(ly[k]), 1e-12), "{model} n = {n}");
            }
            h.push(a("h"));
            l_c.push(a("l_c"));
            raw.push(a("a_p_raw"));
            corr.push(a("a_p_corrected"));
        }
        // two grids: v0 = (h1^p v2 − h2^p v1)/(h1^p − h2^p), areas first order, L_c second
        // (the fallback order: two levels cannot fit one)
        let v0 = |v: &[f64], p: f64| {
            let (a, b) = (h[0].powf(p), h[1].powf(p));
            (a * v[1] - b * v[0]) / (a - b)
        };
        let res = reader(&plan, &ws, &format!("resolution_{model}"));
        let got = |k: &str| res.attr_f64(k).unwrap();
        assert!(close(got("a_p_raw"), v0(&raw, 1.0), 1e-9), "{model}");
        assert!(close(got("a_p_corrected"), v0(&corr, 1.0), 1e-9), "{model}");
        assert!(
            close(got("l_c"), v0(&l_c, critical::FALLBACK_ORDER), 1e-9),
            "{model}"
        );
        assert!(got("a_p_corrected_error") > 0.0 && got("l_c_error") > 0.0);
        // headline numbers for the fidelity trade-off: the same values, the paper's a_p beside
        let heads = stages::kinds::headline::read(&res).unwrap();
        let head = |name: &str| heads.iter().find(|h| h.name == name).unwrap().clone();
        let h = head(&format!("a_p {model} (corrected)"));
        assert_eq!(
            (h.value, h.error),
            (got("a_p_corrected"), Some(got("a_p_corrected_error")))
        );
        assert_eq!(h.paper, Some(got("paper_a_p")));
        assert_eq!(head(&format!("L_c {model}")).value, got("l_c"));
        // the table carries the stage's numbers
        assert_eq!(table.str("model").unwrap()[row], *model);
        for k in ["l_c", "a_p_raw", "a_p_corrected", "p_fc_over_l_c"] {
            assert_eq!(table.f64(k).unwrap()[row], got(k), "{model} {k}");
        }
        // Figure 4's map is the stored gap just below L_c: the fluid still percolates there
        let gap = r.read_f64_2d(store::fields::GAP).unwrap();
        let st = critical::FlowState::of_gap(gap.view()).unwrap();
        assert!(!st.blocked_all(), "{model}: the stored gap is below L_c");
        let above = r.read_f64_2d("above/gap").unwrap();
        assert!(
            critical::FlowState::of_gap(above.view())
                .unwrap()
                .blocked_all()
        );
    }
    for f in [
        "figures/fig4.png",
        "figures/convergence.png",
        "results/tables/critical.md",
    ] {
        assert!(
            std::fs::metadata(dir.path().join(f)).unwrap().len() > 100,
            "{f}"
        );
    }
}

#[test]
fn resolution_needs_two_grids_of_one_model() {
    // both are refused when the plan is built, before anything runs (issue 18.12)
    let dir = tempfile::tempdir().unwrap();
    let err = common::run_all(
        dir.path(),
        r#"
[stages.one]
kind = "critical"
params = { lattice = "square", ns = [4], saddle_loads = [] }

[stages.res]
kind = "resolution"
inputs = { levels = "one" }
"#,
    )
    .map(|_| ())
    .unwrap_err();
    assert!(err.contains("at least two distinct n"), "{err}");

    let dir = tempfile::tempdir().unwrap();
    let err = common::run_all(
        dir.path(),
        r#"
[stages.sq]
kind = "critical"
params = { lattice = "square", ns = [4], saddle_loads = [], fields = false }

[stages.hex]
kind = "critical"
params = { lattice = "hexagonal", ns = [5], saddle_loads = [], fields = false }

[stages.res]
kind = "resolution"
inputs = { levels = ["sq", "hex"] }
"#,
    )
    .map(|_| ())
    .unwrap_err();
    assert!(err.contains("mix models"), "{err}");
}

#[test]
fn grid_exponents_must_ascend() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("pipeline")).unwrap();
    let p = dir.path().join("pipeline/p.toml");
    std::fs::write(
        &p,
        "[stages.c]\nkind = \"critical\"\nparams = { lattice = \"square\", ns = [5, 4] }\n",
    )
    .unwrap();
    let e = match Plan::load(&stages::registry(), &p, None) {
        Ok(_) => panic!("descending ns is accepted"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("ns") && e.contains("ascending"), "{e}");
}
