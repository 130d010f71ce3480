//! The near-critical chain through the engine on tiny grids: `critical` → `ladder` →
//! `exponents` → Figure 5, Figure 6's β panel data and the exponent table. Checks that the ladder's loads
//! are the reduced loads it claims relative to the critical stage's L_c, that the windows are
//! centred on an open (l < 0) or closed (l > 0) saddle, and that a grid missing from the
//! critical input is a clear error.

mod common;

use common::{reader, run, run_all};
use stages::kinds::ladder::LadderData;
use stages::orchestrator::Inputs;

const CHAIN: &str = r#"
[stages.crit]
kind = "critical"
params = { lattice = "square", ns = [5, 6], shifts = 0, fields = false }

[stages.lad]
kind = "ladder"
inputs = { critical = "crit" }
params = { ns = [5, 6], ls = [0.01, -0.01, -0.02, 0.0, 0.02], window = 0.25 }

[stages.ex]
kind = "exponents"
inputs = { ladder = ["lad"] }

[stages.fig5]
kind = "fig5"
inputs = { ladder = ["lad"], exponents = "ex" }

[stages.run]
kind = "running"
inputs = { ladder = ["lad"] }
"#;

#[test]
fn the_ladder_sits_at_its_reduced_loads_around_the_critical_stage() {
    let dir = tempfile::tempdir().unwrap();
    let (plan, ws) = run(dir.path(), CHAIN);
    let crit = reader(&plan, &ws, "crit");
    let lad = reader(&plan, &ws, "lad");
    let d = LadderData::read(&lad).unwrap();
    assert_eq!(d.levels.iter().map(|l| l.n).collect::<Vec<_>>(), vec![5, 6]);
    for lv in &d.levels {
        let at = format!("level/{}", lv.n);
        let sub = crit.attr_f64_at(&at, "l_c_subgrid").unwrap();
        let want = if sub.is_finite() {
            sub
        } else {
            crit.attr_f64_at(&at, "l_c").unwrap()
        };
        assert_eq!(lv.l_c, want);
        let ls: Vec<f64> = lv.rungs.iter().map(|r| r.l).collect();
        assert_eq!(ls, vec![-0.02, -0.01, 0.0, 0.01, 0.02], "ascending");
        for r in &lv.rungs {
            assert!(((r.load - lv.l_c) / lv.l_c - r.l).abs() < 1e-14);
            assert!(r.converged);
            // the mean of the full pressure field is not stored, but the window's centre is the
            // saddle: open below L_c, in contact above (the grid's own L_c is within a few 1e-3
            // of the sub-grid one even on 64²)
            let g = r.window.saddle_gap();
            if r.l <= -0.01 {
                assert!(g > 0.0, "n = {} l = {}: {g}", lv.n, r.l);
                assert!(r.percolating && r.flux > 0.0);
            }
            if r.l >= 0.01 {
                assert_eq!(g, 0.0, "n = {} l = {}", lv.n, r.l);
            }
            if r.l == 0.0 {
                // L_c itself gets no flow solve (kinds::ladder, "The flux at l = 0")
                assert!(r.flux.is_nan() && !r.percolating && !r.flow_converged);
            }
        }
        // flux falls towards L_c
        let q: Vec<f64> = lv
            .rungs
            .iter()
            .filter(|r| r.l < 0.0)
            .map(|r| r.flux)
            .collect();
        assert!(q[1] < q[0], "{q:?}");
    }
    let t = std::fs::read_to_string(dir.path().join("results/tables/exponents.csv")).unwrap();
    assert!(
        t.lines()
            .next()
            .unwrap()
            .starts_with("model,exponent,value")
    );
    // one model: the seven rows, then the neck rows upsilon_neck, chi_below and
    // beta_identity_neck (no refined ladder here: no estimate, the method says so)
    assert_eq!(t.lines().count(), 1 + 10, "{t}");
    assert!(dir.path().join("figures/fig5.png").exists());
    // Figure 6's bottom-left panel reads the exponents artefact as its `ladder` input
    let ex = reader(&plan, &ws, "ex");
    let panel =
        stages::scenes::fig6::read_ladder(&Inputs::new([("ladder".to_string(), vec![ex])].into()))
            .unwrap();
    let points = panel.points;
    // no refined ladder in this chain: no refined points, and no asymptotic β on these grids
    assert!(panel.refined.is_empty() && panel.slopes.is_empty());
    assert_eq!(points.len(), 1);
    let sq = d.levels.last().unwrap();
    let below: Vec<_> = sq.rungs.iter().filter(|r| r.l < 0.0).collect();
    assert_eq!(points[0].distance, vec![0.01, 0.02]);
    assert_eq!(points[0].flux[1], 1.0);
    assert!((points[0].flux[0] - below[1].flux / below[0].flux).abs() < 1e-12);

    // the running exponents: ζ between l = −0.02 and −0.01 is the local slope of the saddle
    // gap on the finest level, its grid error the difference to the coarser level's slope
    let t = tables::read_csv(
        &dir.path().join("results/tables/running_exponents.csv"),
        &[],
    )
    .unwrap();
    let (ex, v, ge) = (
        t.str("exponent").unwrap(),
        t.f64("value").unwrap(),
        t.f64("grid_error").unwrap(),
    );
    let k = (0..t.n_rows()).find(|&k| ex[k] == "zeta").expect("a ζ row");
    let slope = |lv: &stages::kinds::ladder::LadderLevel| {
        let g = |l: f64| {
            lv.rungs
                .iter()
                .find(|r| r.l == l)
                .unwrap()
                .window
                .saddle_gap()
        };
        (g(-0.01) / g(-0.02)).ln() / (0.01f64 / 0.02).ln()
    };
    let (fine, coarse) = (slope(&d.levels[1]), slope(&d.levels[0]));
    assert!((v[k] - fine).abs() < 1e-12, "{} vs {fine}", v[k]);
    assert!((ge[k] - (fine - coarse).abs()).abs() < 1e-12);
}

#[test]
fn a_ladder_grid_missing_from_the_critical_input_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let bad = r#"
[stages.crit]
kind = "critical"
params = { lattice = "square", ns = [5], shifts = 0, fields = false }

[stages.lad]
kind = "ladder"
inputs = { critical = "crit" }
params = { ns = [4], ls = [-0.01] }
"#;
    let (_, _, failed) = run_all(dir.path(), bad).unwrap();
    assert_eq!(failed.len(), 1, "{failed:?}");
    assert!(
        failed[0].contains("n = 4 is not a level of the `critical` input"),
        "{failed:?}"
    );
}

/// The refined ladder feeds the results: its running ζ, υ, χ, β pairs become `refined` rows of
/// `running_exponents.csv` (the same values as `refined_running.csv`), the uniform rows are
/// those of a run without it, and `exponents.csv` says which ladder each asymptotic estimate
/// used and keeps the uniform-only one.
#[test]
fn the_refined_ladder_feeds_the_running_table_and_the_exponents() {
    let refined = r#"
[stages.ref]
kind = "refined_ladder"
params = { lattice = "square", base = 5, levels = [1, 2], window = 8, margin = 5, margin_check = 7, ls = [-0.02, -0.01, -0.005, 0.01, 0.02], tol_gap = 1e-10 }

[stages.refined]
kind = "refined"
inputs = { refined = ["ref"] }
"#;
    let chain = CHAIN
        .replace(
            "inputs = { ladder = [\"lad\"] }\n\n[stages.fig5]",
            "inputs = { ladder = [\"lad\"], refined = [\"ref\"] }\n\n[stages.fig5]",
        )
        .replace(
            "inputs = { ladder = [\"lad\"], exponents = \"ex\" }",
            "inputs = { ladder = [\"lad\"], exponents = \"ex\", refined = [\"ref\"] }",
        )
        .replace(
            "kind = \"running\"\ninputs = { ladder = [\"lad\"] }",
            "kind = \"running\"\ninputs = { ladder = [\"lad\"], refined = [\"ref\"] }",
        );
    assert_ne!(chain, CHAIN);
    let dir = tempfile::tempdir().unwrap();
    run(dir.path(), &(chain + refined));
    let plain = tempfile::tempdir().unwrap();
    run(plain.path(), CHAIN);
    let read = |d: &std::path::Path, f: &str| {
        tables::read_csv(&d.join("results/tables").join(f), &[]).unwrap()
    };
    let t = read(dir.path(), "running_exponents.csv");
    let p = read(plain.path(), "running_exponents.csv");
    let method = t.str("method").unwrap();
    let n_uniform = method.iter().filter(|m| *m == "uniform").count();
    assert_eq!(n_uniform, p.n_rows());
    assert!(p.str("method").unwrap().iter().all(|m| m == "uniform"));
    for c in ["value", "grid_error", "fit_error", "resolution"] {
        let (a, b) = (t.f64(c).unwrap(), p.f64(c).unwrap());
        for k in 0..n_uniform {
            assert!(
                a[k] == b[k] || (a[k].is_nan() && b[k].is_nan()),
                "{c} row {k}"
            );
        }
    }
    // the refined rows are refined_running.csv's, in order, ζ, υ, χ and β; then the neck rows
    // (column `measure`: the exponent's own measure on every other row)
    let measure = t.str("measure").unwrap();
    let own = ["saddle_gap", "half_width", "half_length", "flux"];
    let n_own = measure.iter().filter(|m| own.contains(&m.as_str())).count();
    assert!(
        measure[n_own..].iter().all(|m| m.starts_with("neck_")),
        "the neck rows come last: {measure:?}"
    );
    for (k, e) in t.str("exponent").unwrap()[..n_own].iter().enumerate() {
        let want = ["zeta", "upsilon", "chi", "beta"]
            .iter()
            .position(|x| x == e)
            .map(|i| own[i]);
        assert_eq!(Some(measure[k].as_str()), want, "row {k}");
    }
    let r = read(dir.path(), "refined_running.csv");
    assert_eq!(n_own - n_uniform, r.n_rows());
    assert!(r.n_rows() >= 3);
    let (ex, rex) = (t.str("exponent").unwrap(), r.str("exponent").unwrap());
    let (v, rv) = (t.f64("value").unwrap(), r.f64("value").unwrap());
    let (fl, rfl) = (t.str("flag").unwrap(), r.str("flag").unwrap());
    for k in 0..r.n_rows() {
        assert_eq!(method[n_uniform + k], "refined");
        assert_eq!(ex[n_uniform + k], rex[k]);
        assert_eq!(v[n_uniform + k], rv[k]);
        assert_eq!(fl[n_uniform + k], rfl[k]);
    }
    for e in ["zeta", "upsilon", "chi", "beta"] {
        assert!(rex.iter().any(|x| x == e), "no refined {e} pair: {rex:?}");
    }
    // every rung below p_c has a flux (square: the cell's K, positive and falling towards p_c),
    // none above it
    let rungs = read(dir.path(), "refined_rungs.csv");
    let (l, k) = (rungs.f64("l").unwrap(), rungs.f64("conductance").unwrap());
    for j in 0..rungs.n_rows() {
        if l[j] < 0.0 {
            assert!(k[j] > 0.0, "rung {j}: l = {}, K = {}", l[j], k[j]);
        } else {
            assert!(k[j].is_nan(), "rung {j}: l = {}, K = {}", l[j], k[j]);
        }
        if j > 0 && l[j] < 0.0 && l[j - 1] < l[j] {
            assert!(k[j] < k[j - 1], "K does not fall towards p_c at rung {j}");
        }
    }
    // exponents.csv: the same columns with or without the refined ladder, ending with the
    // method and the uniform-only estimate; with these grids no ladder has a grid-converged
    // window (no estimate either way), so the two estimates agree (both NaN)
    let e = read(dir.path(), "exponents.csv");
    let pe = read(plain.path(), "exponents.csv");
    let names =
        |t: &tables::Table| -> Vec<String> { t.columns().iter().map(|c| c.name.clone()).collect() };
    assert_eq!(names(&e), names(&pe));
    let n = names(&e);
    let tail: Vec<&str> = n[n.len() - 4..].iter().map(|s| s.as_str()).collect();
    assert_eq!(
        tail,
        [
            "asymptotic_method",
            "uniform_asymptotic_value",
            "uniform_asymptotic_error",
            "uniform_asymptotic_l_min"
        ]
    );
    let (a, u) = (
        e.f64("asymptotic_value").unwrap(),
        e.f64("uniform_asymptotic_value").unwrap(),
    );
    for k in 0..e.n_rows() {
        assert!(a[k] == u[k] || (a[k].is_nan() && u[k].is_nan()), "row {k}");
    }
    // fig5_collapse.csv: the uniform rows as without the refined ladder (none on these grids:
    // no uniform χ fit), then `refined` rows (one refined model here, so only its rungs'
    // collapse, l < 0, in units from its own fits) with a finite residual
    let typed = |d: &std::path::Path| {
        let f = d.join("results/tables/fig5_collapse.csv");
        tables::read_csv(&f, &[("rms_ln", tables::ColumnType::F64)]).unwrap()
    };
    let c = typed(dir.path());
    // an empty CSV reads as text columns
    let pc = read(plain.path(), "fig5_collapse.csv");
    let cm = c.str("method").unwrap();
    let n_u = cm.iter().filter(|m| *m == "uniform").count();
    assert_eq!(n_u, pc.n_rows());
    let rms = c.f64("rms_ln").unwrap();
    if n_u > 0 {
        let pt = typed(plain.path());
        let prms = pt.f64("rms_ln").unwrap();
        for k in 0..n_u {
            assert!(
                rms[k] == prms[k] || (rms[k].is_nan() && prms[k].is_nan()),
                "row {k}"
            );
        }
    }
    assert!(cm.len() > n_u, "no refined rows in fig5_collapse.csv");
    let (side, model) = (c.str("side").unwrap(), c.str("model").unwrap());
    for k in n_u..cm.len() {
        assert_eq!(cm[k], "refined");
        assert_eq!(side[k], "open");
        assert_eq!(model[k], "square");
        assert!(rms[k].is_finite() && rms[k] >= 0.0, "row {k}: {}", rms[k]);
    }
}
