//! The `flow` and `flowmap` kinds through the engine on tiny grids: flux against load along a
//! hard-wall path, where it stops, current densities, and the near-critical map.

mod common;
use common::{reader, run};

use stages::kinds::flow::FlowData;
use stages::kinds::flow_artefact::FlowPoint;
use stages::orchestrator::{Plan, ProgressMode, RunOptions, Workspace};

/// A hard-wall loading path on the 16² square model, gaps stored at every point, past full
/// contact (p_fc).
const HARD_WALL: &str = r#"
[stages.sq]
kind = "surface"
params = { lattice = "square", n = 4 }

[stages.hw]
kind = "sweep"
inputs = { surface = "sq" }
params = { interaction = "hardwall", reverse = false, fields_all = true,
           path = [{ from = 0.02, to = 0.3, steps = 7 }, { to = 1.2, steps = 2 }, { to = 1.4, steps = 1 }] }

[stages.hw_flow]
kind = "flow"
inputs = { sweep = "hw" }
params = { axis = "x", currents_at = [0.1], current_last_flowing = true }
"#;

#[test]
fn hard_wall_flux_decreases_with_load_and_vanishes_before_full_contact() {
    let dir = tempfile::tempdir().unwrap();
    let (plan, ws) = run(dir.path(), HARD_WALL);
    let r = reader(&plan, &ws, "hw_flow");
    let d = FlowData::read(&r).unwrap();
    // the records as columns
    let col = |f: fn(&FlowPoint) -> f64| -> Vec<f64> { d.points.iter().map(f).collect() };
    let (load, conductivity, flux, contact_area) = (
        col(|p| p.load),
        col(|p| p.conductivity),
        col(|p| p.flux),
        col(|p| p.contact_area),
    );
    let percolating: Vec<bool> = d.points.iter().map(|p| p.percolating).collect();
    let converged: Vec<bool> = d.points.iter().map(|p| p.converged).collect();
    assert_eq!(load.len(), 11);
    assert_eq!(r.attr_i64("n_skipped").unwrap(), 0);
    assert_eq!(
        (d.lattice.as_str(), d.interaction.as_str()),
        ("square", "hardwall")
    );
    assert!(converged.iter().all(|&c| c), "every flow solve converged");
    let p_fc = d.p_fc;
    // flux strictly decreasing while the fluid percolates, then exactly 0
    let flowing: Vec<usize> = (0..load.len()).filter(|&k| percolating[k]).collect();
    assert!(flowing.len() >= 3, "{:?}", conductivity);
    assert_eq!(
        flowing,
        (0..flowing.len()).collect::<Vec<_>>(),
        "flowing points first"
    );
    for w in flowing.windows(2) {
        assert!(
            conductivity[w[1]] < conductivity[w[0]],
            "{:?}",
            conductivity
        );
    }
    for k in flowing.len()..load.len() {
        assert_eq!(flux[k], 0.0);
        assert_eq!(conductivity[k], 0.0);
    }
    // at and above full contact, certainly nothing flows
    let full: Vec<usize> = (0..load.len())
        .filter(|&k| load[k] >= p_fc * (1.0 - 1e-12))
        .collect();
    assert_eq!(full.len(), 2);
    for &k in &full {
        assert_eq!(contact_area[k], 1.0);
        assert!(!percolating[k] && flux[k] == 0.0);
    }
    // on the unit square cell the flux equals the conductivity
    for k in 0..load.len() {
        assert!((flux[k] - conductivity[k]).abs() <= 1e-14 * flux[k].abs());
    }
    // the stop is recorded between the last flowing and the first blocked point
    let lf = r.read_f64_1d("stops/load_flowing").unwrap();
    let lb = r.read_f64_1d("stops/load_blocked").unwrap();
    assert_eq!((lf.len(), lb.len()), (1, 1));
    assert_eq!(lf[0], load[flowing.len() - 1]);
    assert_eq!(lb[0], load[flowing.len()]);
    // the stop lies near the square model's L_c ≈ 0.22 p_fc (coarse grid, coarse steps)
    assert!(lf[0] / p_fc > 0.1 && lb[0] / p_fc < 0.45, "{lf:?} {lb:?}");
    // current densities: at 0.1 p_fc (nearest point) and at the last flowing point; the
    // x-current integrates to the flux through every cross-section
    let groups = r.members("currents").unwrap();
    assert_eq!(groups.len(), 2, "{groups:?}");
    for g in &groups {
        let jx = r.read_f64_2d(&format!("currents/{g}/current_x")).unwrap();
        let flux = r.attr_f64_at(&format!("currents/{g}"), "flux").unwrap();
        let (nx, ny) = jx.dim();
        for i in 0..nx {
            let q: f64 = jx.row(i).sum() / ny as f64;
            assert!(
                (q - flux).abs() <= 1e-6 * flux,
                "{g} row {i}: {q} vs {flux}"
            );
        }
    }
    let prov = r.provenance().unwrap();
    assert_eq!(prov.kind, "flow");
    assert!(prov.warnings.is_empty(), "{:?}", prov.warnings);
}

#[test]
fn a_sweep_without_gap_fields_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = HARD_WALL.replace("fields_all = true,", "");
    std::fs::create_dir_all(dir.path().join("pipeline")).unwrap();
    std::fs::write(dir.path().join("pipeline/p.toml"), &p).unwrap();
    let plan = Plan::load(
        &stages::registry(),
        &dir.path().join("pipeline/p.toml"),
        None,
    )
    .unwrap();
    let ws = Workspace::new(dir.path());
    let opts = RunOptions {
        progress: ProgressMode::Silent,
        ..Default::default()
    };
    let s = stages::orchestrator::run(&ws, &plan, &opts).unwrap();
    let msg = format!("{:?}", s.failed);
    assert!(
        msg.contains("hw_flow") && msg.contains("no gap fields") && msg.contains("fields_all"),
        "{msg}"
    );
}

#[test]
fn near_critical_map_lies_just_below_the_grids_critical_load() {
    let dir = tempfile::tempdir().unwrap();
    let p = r#"
[stages.sq]
kind = "surface"
params = { lattice = "square", n = 5 }

[stages.map]
kind = "flowmap"
inputs = { surface = "sq" }
params = { l = -0.01, axis = "x", rel_width = 1e-4 }
"#;
    let (plan, ws) = run(dir.path(), p);
    let r = reader(&plan, &ws, "map");
    let p_fc = r.attr_f64("p_fc").unwrap();
    let (lo, hi) = (r.attr_f64("l_c_lo").unwrap(), r.attr_f64("l_c_hi").unwrap());
    assert!(hi - lo <= 1e-4 * hi && lo < hi);
    let l_c = r.attr_f64("l_c").unwrap();
    // the square model percolates at L_c ≈ 0.22 p_fc (PHYSICS.md: a_p ≈ 0.40)
    assert!((0.15..0.3).contains(&(l_c / p_fc)), "{}", l_c / p_fc);
    assert!((r.attr_f64("l_actual").unwrap() + 0.01).abs() < 1e-12);
    assert!(r.attr_bool("percolating").unwrap());
    assert!(r.attr_bool("converged").unwrap());
    let flux = r.attr_f64("flux").unwrap();
    assert!(flux > 0.0 && flux < 1e-2, "{flux}");
    // the bisection's probes: flowing below L_c, blocked above
    let loads = r.read_f64_1d("bisection/load").unwrap();
    let flows = r.read_u8_1d("bisection/flows").unwrap();
    for (l, f) in loads.iter().zip(&flows) {
        assert_eq!(*f != 0, *l <= lo, "probe at {l}");
    }
    // a flowing state: the current integrates to the flux across x
    let jx = r.read_f64_2d("current_x").unwrap();
    let (nx, ny) = jx.dim();
    assert_eq!((nx, ny), (32, 32));
    let q: f64 = jx.row(7).sum() / ny as f64;
    assert!((q - flux).abs() <= 1e-6 * flux);
    let gap = r.read_f64_2d("gap").unwrap();
    assert!(gap.iter().any(|&g| g == 0.0) && gap.iter().all(|&g| g >= 0.0));
}
