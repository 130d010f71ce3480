//! The `sweep`, `figure` and `table` kinds through the engine on tiny grids: what a sweep
//! records, that non-converged points are flagged and never used silently, the cohesive-zone
//! warning, and parameter errors with file and line.

mod common;
use common::{reader, run};

use stages::kinds::sweep::{Branch, SweepData};
use stages::orchestrator::Plan;

const SURFACE: &str = "[stages.sq]\nkind = \"surface\"\nparams = { lattice = \"square\", n = 4 }\n";

#[test]
fn adhesive_sweep_records_points_jumps_pull_off_and_warns_about_resolution() {
    let dir = tempfile::tempdir().unwrap();
    let p = format!(
        "{SURFACE}
[stages.adh]
kind = \"sweep\"
inputs = {{ surface = \"sq\" }}
params = {{ interaction = \"adhesion\", path = [{{ from = 0.01, to = 1.0, step = 0.05 }}],
           reverse_extension = [{{ to = -0.5, step = 0.01 }}], fields_at = [0.5] }}
"
    );
    let (plan, ws) = run(dir.path(), &p);
    let r = reader(&plan, &ws, "adh");
    let d = SweepData::read(&r).unwrap();
    assert_eq!(d.interaction, "adhesion");
    assert!((d.p_fc - 2.0 * std::f64::consts::PI).abs() < 1e-9);
    let up = d.branch_indices(Branch::Loading);
    let down = d.branch_indices(Branch::Unloading);
    assert_eq!(up.len(), 21);
    assert!(
        d.points
            .iter()
            .all(|p| p.converged && (0.0..=1.0).contains(&p.contact_area))
    );
    // unloading continues into tension and ends at pull-off
    assert!(d.points[*down.last().unwrap()].load < 0.0);
    assert_eq!(d.ended.len(), 1, "{:?}", d.ended);
    assert_eq!(d.ended[0].branch, Branch::Unloading);
    assert!(d.ended[0].load < 0.0 && d.ended[0].message.contains("pull-off"));
    // full contact is reached on loading (a jump) and kept on unloading far below where it
    // was reached: a hysteresis loop between the branches
    let events: Vec<&str> = d.jumps.iter().map(|j| j.event.as_str()).collect();
    assert!(events.contains(&"full contact"), "{events:?}");
    assert!(
        d.loops.iter().any(|l| l.max_area_difference > 0.2),
        "{:?}",
        d.loops
    );
    for j in &d.jumps {
        assert_eq!(d.points[j.index].branch, j.branch);
        assert_eq!(
            (d.points[j.index].load, d.points[j.index_after].load),
            j.load()
        );
    }
    // 16² grid: the cohesive zone (0.008 λ) is far below the spacing (1/16 λ)
    let prov = r.provenance().unwrap();
    assert!(
        prov.warnings
            .iter()
            .any(|w| w.contains("under-resolved cohesive zone")),
        "{:?}",
        prov.warnings
    );
    // fields only where asked: one point per branch
    let f = r.members("fields").unwrap();
    assert_eq!(f.len(), 2, "{f:?}");
    assert!(r.has_dataset(&format!("fields/{}/gap", f[0])));
}

#[test]
fn non_converged_points_are_flagged_warned_and_left_out_of_the_figure() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = |name: &str, inter: &str, extra: &str| {
        format!(
            "[stages.{name}]\nkind = \"sweep\"\ninputs = {{ surface = \"sq\" }}\nparams = {{ interaction = \"{inter}\", path = [{{ from = 0.05, to = 0.5, steps = 6 }}]{extra} }}\n"
        )
    };
    let p = format!(
        "{SURFACE}{}{}{}
[stages.fig]
kind = \"fig2\"
inputs = {{ hardwall = \"hw\", adhesion = \"adh\", repulsion = \"rep\" }}
params = {{ figure_dir = \"out\", table_dir = \"out/tables\" }}
",
        sweep("hw", "hardwall", ""),
        sweep("adh", "adhesion", ""),
        // an iteration cap far too small: FIRE cannot converge
        sweep("rep", "repulsion", ", max_iter = 3"),
    );
    let (plan, ws) = run(dir.path(), &p);
    let r = reader(&plan, &ws, "rep");
    let d = SweepData::read(&r).unwrap();
    assert!(
        d.points
            .iter()
            .all(|p| !p.converged && !p.stop_reason.is_empty())
    );
    assert!(d.jumps.is_empty(), "no jumps from unconverged points");
    let prov = r.provenance().unwrap();
    assert!(
        prov.warnings.iter().any(|w| w.contains("did not converge")),
        "{:?}",
        prov.warnings
    );
    assert_eq!(r.attr_i64("n_unconverged").unwrap(), d.points.len() as i64);
    let f = reader(&plan, &ws, "fig");
    assert_eq!(
        f.attr_i64("points_left_out").unwrap(),
        d.points.len() as i64
    );
    assert!(
        f.provenance()
            .unwrap()
            .warnings
            .iter()
            .any(|w| w.contains("left out"))
    );
    assert!(dir.path().join("out/fig2.png").is_file() && dir.path().join("out/fig2.svg").is_file());
    // the table keeps them, flagged
    let t = tables::read_csv(&dir.path().join("out/tables/fig2.csv"), &[]).unwrap();
    let (i, c) = (t.str("interaction").unwrap(), t.bool("converged").unwrap());
    assert!((0..t.n_rows()).all(|k| (i[k] == "repulsion") != c[k]));
}

#[test]
fn sweep_parameter_errors_name_file_line_and_what_is_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("p.toml");
    let cases = [
        (
            "params = { interaction = \"hardwall\", path = [{ from = 0.0, to = 1.0, steps = 4 }] }",
            "without adhesion every load must be > 0",
        ),
        (
            "params = { interaction = \"adhesion\", path = [{ from = 0.1, to = 1.0, stepz = 4 }] }",
            "unknown key `stepz`; allowed: from, to, steps, step",
        ),
        (
            "params = { interaction = \"repulsion\", method = \"polonsky-keer\", path = [{ from = 0.1, to = 1.0, steps = 4 }] }",
            "solves the hard wall only",
        ),
        (
            "params = { interaction = \"adhesion\", path = [{ from = 0.1, to = 1.0, steps = 4 }], reverse_extension = [{ to = 0.5, steps = 2 }] }",
            "must be below the segment's start 0.1",
        ),
    ];
    for (params, want) in cases {
        std::fs::write(
            &p,
            format!(
                "{SURFACE}[stages.s]\nkind = \"sweep\"\ninputs = {{ surface = \"sq\" }}\n{params}\n"
            ),
        )
        .unwrap();
        let e = format!(
            "{:#}",
            Plan::load(&stages::registry(), &p, None).unwrap_err()
        );
        assert!(e.contains("p.toml:7:") && e.contains(want), "{e}");
    }
}
