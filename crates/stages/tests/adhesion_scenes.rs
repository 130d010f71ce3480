//! Figures 1 and 3 and the jump tables through the engine on tiny grids: a γ0 path's
//! hysteresis and thresholds against the exact full-contact stability limit, the figures'
//! inputs checked, and the jump positions tabulated per grid.

mod common;
use common::{reader, try_run as run};

use stages::kinds::sweep::{Branch, SweepData};

/// Full contact under adhesion holds while the adhesive stress γ0/ρ can carry the largest
/// tension of the full-contact state, p_fc − p̄ at the trough (exact on the grid: the square
/// model's minimum is a node and the elastic kernel's continuum stiffness gives p_fc
/// exactly). Decreasing γ0 at fixed load p̄ must therefore open the trough in the step that
/// crosses γ0 = ρ (p_fc − p̄), and not before.
#[test]
fn decreasing_gamma_opens_the_trough_where_adhesion_stops_carrying_the_tension() {
    let dir = tempfile::tempdir().unwrap();
    let p = "
[stages.sq]
kind = \"surface\"
params = { lattice = \"square\", n = 4 }
[stages.g]
kind = \"sweep\"
inputs = { surface = \"sq\" }
params = { interaction = \"adhesion\", rho = 0.04, control = \"strength\", load = 0.8,
           path = [{ from = 0.02, to = 0.1, step = 0.0025 }, { to = 1.0, step = 0.1 }] }
";
    let (plan, ws) = run(dir.path(), p).unwrap();
    let d = SweepData::read(&reader(&plan, &ws, "g")).unwrap();
    assert!(d.points.iter().all(|p| p.converged));
    // computed by the sweep kind and stored in its artefact (thresholds/*)
    let t = d.thresholds;
    let fc = t
        .full_contact
        .expect("full contact on the increasing branch");
    let open = t
        .trough_opening
        .expect("the trough opens on the decreasing branch");
    let limit = 0.04 * (1.0 - 0.8) * d.p_fc;
    assert!(
        open.x.1 < limit && limit <= open.x.0,
        "trough opens between γ0 = {:?}, exact limit {limit}",
        open.x
    );
    // hysteresis: reached on the way up no earlier than it is lost on the way down, and the
    // decreasing branch keeps more contact than the increasing one somewhere
    assert!(fc.x.1 >= open.x.0, "{fc:?} {open:?}");
    let up = d.branch_indices(Branch::Loading);
    let down = d.branch_indices(Branch::Unloading);
    // (γ0, area on the increasing branch, area on the decreasing branch) at common γ0
    let pairs: Vec<(f64, f64, f64)> = down
        .iter()
        .filter_map(|&k| {
            let q = &d.points[k];
            up.iter()
                .find(|&&u| d.points[u].strength == q.strength)
                .map(|&u| (q.strength, d.points[u].contact_area, q.contact_area))
        })
        .collect();
    let margin = pairs
        .iter()
        .map(|p| p.2 - p.1)
        .fold(f64::NEG_INFINITY, f64::max);
    // more than the area's discreteness (a few of the 256 nodes)
    assert!(
        margin >= 4.0 / 256.0,
        "decreasing keeps more contact: margin {margin}"
    );
    for &(g, a_up, a_down) in pairs.iter().filter(|p| p.0 >= limit) {
        assert!(
            a_down >= a_up - 1e-12,
            "γ0 = {g}: decreasing branch {a_down} below increasing {a_up}"
        );
    }
}

const SURFACES: &str = "
[stages.s_hexagonal]
kind = \"surface\"
params = { lattice = \"hexagonal\", n = 4 }
[stages.s_square]
kind = \"surface\"
params = { lattice = \"square\", n = 4 }
[stages.s_triangular]
kind = \"surface\"
params = { lattice = \"triangular\", n = 4 }
[stages.s_square5]
kind = \"surface\"
params = { lattice = \"square\", n = 5 }
";

fn gamma_sweep(name: &str, surface: &str, fields: &str) -> String {
    format!(
        "[stages.{name}]\nkind = \"sweep\"\ninputs = {{ surface = \"{surface}\" }}\nparams = {{ interaction = \"adhesion\", control = \"strength\", load = 0.0, path = [{{ from = 0.05, to = 0.2, steps = 3 }}, {{ to = 2.0, steps = 3 }}]{fields} }}\n"
    )
}

#[test]
fn figures_1_and_3_and_their_tables_on_tiny_grids() {
    let dir = tempfile::tempdir().unwrap();
    let mut p = SURFACES.to_string();
    for m in ["hexagonal", "square", "triangular"] {
        p += &gamma_sweep(&format!("g_{m}"), &format!("s_{m}"), ", fields_at = [0.2]");
    }
    p += &gamma_sweep("g_square5", "s_square5", "");
    p += "
[stages.fig1]
kind = \"fig1\"
inputs = { hexagonal = \"g_hexagonal\", square = \"g_square\", triangular = \"g_triangular\" }
params = { figure_dir = \"out\" }
[stages.fig3]
kind = \"fig3\"
inputs = { hexagonal = \"g_hexagonal\", square = [\"g_square\", \"g_square5\"], triangular = \"g_triangular\" }
params = { figure_dir = \"out\", table_dir = \"out/tables\" }
";
    let (plan, ws) = run(dir.path(), &p).unwrap();
    for f in [
        "out/fig1.png",
        "out/fig1.svg",
        "out/fig3.png",
        "out/fig3.svg",
    ] {
        assert!(
            std::fs::metadata(dir.path().join(f)).unwrap().len() > 1000,
            "{f}"
        );
    }
    // Figure 1 shows the increasing branch's state at γ0 = 0.2: its contact areas
    let f1 = reader(&plan, &ws, "fig1");
    let areas = f1.read_f64_1d("contact_area").unwrap();
    for (k, m) in ["g_hexagonal", "g_square", "g_triangular"]
        .iter()
        .enumerate()
    {
        let d = SweepData::read(&reader(&plan, &ws, m)).unwrap();
        let at = d
            .points
            .iter()
            .find(|p| p.branch == Branch::Loading && (p.strength - 0.2).abs() < 1e-12)
            .unwrap();
        assert_eq!(areas[k], at.contact_area, "{m}");
    }
    // thresholds: one row per model and grid, the square model on both grids
    let t = tables::read_csv(&dir.path().join("out/tables/fig3_thresholds.csv"), &[]).unwrap();
    let (m, n) = (t.str("model").unwrap(), t.i64("n").unwrap());
    let rows: Vec<(String, i64)> = (0..t.n_rows()).map(|k| (m[k].clone(), n[k])).collect();
    assert_eq!(
        rows,
        [
            ("hexagonal", 4),
            ("square", 4),
            ("square", 5),
            ("triangular", 4)
        ]
        .map(|(a, b)| (a.to_string(), b))
    );
    for c in [
        "gamma_p",
        "gamma_fc",
        "ratio",
        "ratio_paper",
        "zone_spacings_gamma_p",
    ] {
        assert!(t.f64(c).is_ok(), "column {c}");
    }
    let pts = tables::read_csv(&dir.path().join("out/tables/fig3.csv"), &[]).unwrap();
    assert_eq!(pts.n_rows(), 4 * 13, "13 points per sweep (7 up, 6 down)");
    let j = tables::read_csv(&dir.path().join("out/tables/fig3_jumps.csv"), &[]).unwrap();
    assert!(j.str("control").unwrap().iter().all(|c| c == "gamma"));

    // the 16² grid does not resolve the cohesive zone above γ0 = ρ²/(4 dx): the sweep says so
    let w = reader(&plan, &ws, "g_square")
        .provenance()
        .unwrap()
        .warnings;
    assert!(
        w.iter()
            .any(|w| w.contains("under-resolved cohesive zone") && w.contains("for γ > 0.0064")),
        "{w:?}"
    );
}

#[test]
fn figure_1_needs_the_fields_at_its_gamma() {
    let dir = tempfile::tempdir().unwrap();
    let mut p = SURFACES.to_string();
    for m in ["hexagonal", "square", "triangular"] {
        p += &gamma_sweep(&format!("g_{m}"), &format!("s_{m}"), "");
    }
    p += "
[stages.fig1]
kind = \"fig1\"
inputs = { hexagonal = \"g_hexagonal\", square = \"g_square\", triangular = \"g_triangular\" }
params = { figure_dir = \"out\" }
";
    let e = run(dir.path(), &p).unwrap_err();
    assert!(e.contains("fig1") && e.contains("fields_at"), "{e}");
    // a load path is not a γ0 path
    let dir = tempfile::tempdir().unwrap();
    let mut p = SURFACES.to_string();
    p += "[stages.load]\nkind = \"sweep\"\ninputs = { surface = \"s_square\" }\nparams = { interaction = \"adhesion\", path = [{ from = 0.1, to = 0.2, steps = 1 }] }\n";
    for m in ["hexagonal", "triangular"] {
        p += &gamma_sweep(&format!("g_{m}"), &format!("s_{m}"), "");
    }
    p += "
[stages.tab3]
kind = \"fig3\"
inputs = { hexagonal = \"g_hexagonal\", square = \"load\", triangular = \"g_triangular\" }
params = { figure_dir = \"out\", table_dir = \"out/tables\" }
";
    let e = run(dir.path(), &p).unwrap_err();
    assert!(
        e.contains("tab3") && e.contains("control = \\\"strength\\\""),
        "{e}"
    );
}
