//! Figure 3's inputs, data and thresholds: relative contact area against the surface energy γ0
//! at zero load, for the three models, increasing and decreasing γ0 (each step warm-started
//! from the previous one).
//!
//! Inputs `hexagonal`, `square`, `triangular`: one or more `sweep` stages per model with
//! `interaction = "adhesion"`, `control = "strength"` and zero load, on one or more grids (the
//! figure shows the finest; the tables list every grid, which is the resolution check).
//!
//! # Thresholds (computed by the `sweep` kind: its `thresholds/*`, [`SweepData::thresholds`])
//! On the increasing-γ0 branch:
//! - γ_p (coalescence, contact percolation): the first point at which the non-contact region
//!   percolates along neither axis (contact patches have merged around every fluid pool);
//! - γ_fc (full contact): the first point with relative contact area 1.
//!
//! On the decreasing branch: `break-up` (the fluid percolates again) and `trough opening` (the
//! area leaves 1). Each is a bracket (the last point before, the first point after): the
//! instability lies in between; its midpoint is the estimate, the bracket the uncertainty.
//! γ_fc/γ_p is the ratio of midpoints, bounded by the ratios of the bracket ends; if both
//! happen in the same step (the triangular model jumps from isolated patches straight to full
//! contact) it is one instability and the ratio is exactly 1.

use crate::jumptable::GridSweep;
use crate::scene::{OutputSpec, Outputs, Scene};
use analysis::hysteresis::Transition;
use anyhow::{Result, bail};
use figures::scenes::fig3::{Fig3Data, GammaBranch, ModelGammaPath};
use figures::style::Model;
use kinds::sweep::{Branch as PathBranch, SweepData};
use orchestrator::{InputSpec, Inputs};
use orchestrator::{Params, StageContext};
use store::ArtefactWriter;

/// The models of Figure 3, in the order of its inputs (and of Figure 1's panels).
pub const MODELS: [&str; 3] = ["hexagonal", "square", "triangular"];

/// γ_fc/γ_p as the paper states it (hexagonal, square: not stated, triangular).
pub fn paper_ratio(model: &str) -> Option<f64> {
    match model {
        "hexagonal" => Some(135.0),
        "triangular" => Some(1.0),
        _ => None,
    }
}

/// Headline numbers: γ_p, γ_fc and γ_fc/γ_p of each model on its finest grid (error: half
/// the bracket; for the ratio, half the spread of its bounds).
pub fn headlines(models: &[(String, Vec<GridSweep>)]) -> Vec<kinds::headline::Headline> {
    use kinds::headline::Headline;
    let mut out = Vec::new();
    for (m, grids) in models {
        let Some(finest) = grids.last() else { continue };
        let t = &finest.data.thresholds;
        let half = |tr: &Transition| 0.5 * (tr.x.1 - tr.x.0).abs();
        if let Some(p) = &t.coalescence {
            out.push(Headline::new(format!("gamma_p {m}"), p.mid(), half(p)));
        }
        if let Some(fc) = &t.full_contact {
            out.push(Headline::new(format!("gamma_fc {m}"), fc.mid(), half(fc)));
        }
        if let Some((r, lo, hi)) = t.ratio() {
            let h = Headline::new(format!("gamma_fc/gamma_p {m}"), r, 0.5 * (hi - lo));
            out.push(match paper_ratio(m) {
                Some(pr) => h.paper(pr, f64::NAN),
                None => h,
            });
        }
    }
    out
}

/// The inputs of Figure 3's kinds.
pub fn inputs() -> Vec<InputSpec> {
    MODELS
        .iter()
        .map(|m| {
            InputSpec::many(m, &["sweep"]).doc(&format!(
                "adhesive γ0 sweeps at zero load of the {m} model, one per grid"
            ))
        })
        .collect()
}

/// Checks that a sweep is a zero-load adhesive strength path of `model`.
pub fn check(d: &SweepData, model: &str, input: &str) -> Result<()> {
    if d.interaction != "adhesion" || d.control != "strength" {
        bail!(
            "input `{input}` holds the {} sweep varying the {}; Figure 3 needs adhesion with control = \"strength\"",
            d.interaction,
            d.control
        );
    }
    if d.lattice != model {
        bail!(
            "input `{input}` is a sweep of the {} model; it must be the {model} model",
            d.lattice
        );
    }
    if let Some(p) = d.points.iter().find(|p| p.load != 0.0) {
        bail!(
            "input `{input}`: Figure 3 is at zero load, the sweep has load {} E* h0/λ",
            p.load
        );
    }
    Ok(())
}

/// Reads every model's sweeps, coarse to fine (at most one per grid).
pub fn read(inputs: &Inputs) -> Result<Vec<(String, Vec<GridSweep>)>> {
    let mut out = Vec::new();
    for m in MODELS {
        let rs = inputs.all(m);
        if rs.is_empty() {
            bail!("input `{m}`: no sweep given");
        }
        let mut v = Vec::new();
        for r in rs {
            let s = GridSweep::read(r)?;
            check(&s.data, m, m)?;
            v.push(s);
        }
        v.sort_by_key(|s| s.data.n);
        if let Some(w) = v.windows(2).find(|w| w[0].data.n == w[1].data.n) {
            bail!(
                "input `{m}`: two sweeps on the same grid (n = {}); give one per grid",
                w[0].data.n
            );
        }
        out.push((m.to_string(), v));
    }
    Ok(out)
}

fn model_of(name: &str) -> Model {
    match name {
        "hexagonal" => Model::Hexagonal,
        "square" => Model::Square,
        _ => Model::Triangular,
    }
}

/// Figure 3's data from the finest grid of every model, and the points left out (did not
/// converge).
pub fn data(models: &[(String, Vec<GridSweep>)]) -> (Fig3Data, usize) {
    let mut paths = Vec::new();
    let mut left_out = 0;
    for (m, sweeps) in models {
        let d = &sweeps.last().expect("read() checks for one sweep").data;
        let mut branch = |name: PathBranch| {
            let b = crate::fig2::converged_branch(d, name, &|p| p.strength);
            left_out += b.left_out;
            GammaBranch {
                gamma0: b.x,
                area: b.area,
                jumps: b.jumps,
            }
        };
        let (increasing, decreasing) = (branch(PathBranch::Loading), branch(PathBranch::Unloading));
        let t = &d.thresholds;
        paths.push(ModelGammaPath {
            model: model_of(m),
            increasing,
            decreasing,
            gamma_p: t.coalescence.map(|c| c.mid()),
            gamma_fc: t.full_contact.map(|c| c.mid()),
        });
    }
    (
        Fig3Data {
            paths,
            log_gamma: true,
        },
        left_out,
    )
}

/// The thresholds table: one row per model and grid. Columns: `model`, `n`, `dx`, `gamma_max`,
/// per threshold `X` in (`gamma_p`, `gamma_fc`, `gamma_break_up`, `gamma_trough_opening`):
/// `X_before`, `X_after`, `X` (midpoint), `area_X_before`, `area_X_after`, and for γ_p and
/// γ_fc `zone_spacings_X` (ρ²E*/γ in grid spacings there); `ratio` (γ_fc/γ_p), `ratio_lo`,
/// `ratio_hi`, `ratio_paper`. NaN where the path does not reach the threshold.
pub fn thresholds_table(models: &[(String, Vec<GridSweep>)]) -> tables::Table {
    let mut t = tables::Table::new();
    let (mut model, mut n, mut dx, mut gmax) = (vec![], vec![], vec![], vec![]);
    let mut cols: Vec<(String, Vec<f64>)> = Vec::new();
    let push = |name: String, v: f64, cols: &mut Vec<(String, Vec<f64>)>| {
        if let Some(c) = cols.iter_mut().find(|c| c.0 == name) {
            c.1.push(v);
        } else {
            cols.push((name, vec![v]));
        }
    };
    for (m, sweeps) in models {
        for s in sweeps {
            let th = &s.data.thresholds;
            model.push(m.clone());
            n.push(s.data.n);
            dx.push(s.dx);
            gmax.push(s.data.points.iter().map(|p| p.strength).fold(0.0, f64::max));
            for (name, tr, zone) in [
                ("gamma_p", th.coalescence, true),
                ("gamma_fc", th.full_contact, true),
                ("gamma_break_up", th.break_up, false),
                ("gamma_trough_opening", th.trough_opening, false),
            ] {
                let nan = f64::NAN;
                let g = tr.map_or((nan, nan), |t| t.x);
                let a = tr.map_or((nan, nan), |t| t.area);
                push(format!("{name}_before"), g.0, &mut cols);
                push(format!("{name}_after"), g.1, &mut cols);
                push(name.to_string(), tr.map_or(nan, |t| t.mid()), &mut cols);
                push(format!("area_{name}_before"), a.0, &mut cols);
                push(format!("area_{name}_after"), a.1, &mut cols);
                if zone {
                    push(
                        format!("zone_spacings_{name}"),
                        tr.map_or(nan, |t| s.zone_spacings(t.mid())),
                        &mut cols,
                    );
                }
            }
            let r = th.ratio();
            push("ratio".into(), r.map_or(f64::NAN, |r| r.0), &mut cols);
            push("ratio_lo".into(), r.map_or(f64::NAN, |r| r.1), &mut cols);
            push("ratio_hi".into(), r.map_or(f64::NAN, |r| r.2), &mut cols);
            push(
                "ratio_paper".into(),
                paper_ratio(m).unwrap_or(f64::NAN),
                &mut cols,
            );
        }
    }
    t = t
        .with_str("model", model)
        .with_i64("n", n)
        .with_f64("dx", dx)
        .with_f64("gamma_max", gmax);
    for (name, v) in cols {
        t = t.with_f64(&name, v);
    }
    t
}

/// Every point of every sweep: `model`, `n`, `branch`, `step`, `gamma0`, `contact_area`,
/// `contact_area_corrected`, `mean_gap`, `contact_clusters`, `fluid_percolates`, `converged`,
/// `iterations`, `force_residual`, `jump` (the state jumps between this point and the
/// branch's next converged point).
pub fn points_table(models: &[(String, Vec<GridSweep>)]) -> tables::Table {
    let (mut model, mut n, mut branch, mut step, mut g) = (vec![], vec![], vec![], vec![], vec![]);
    let (mut a, mut ac, mut gap, mut cl, mut fl) = (vec![], vec![], vec![], vec![], vec![]);
    let (mut conv, mut it, mut fr, mut jump) = (vec![], vec![], vec![], vec![]);
    for (m, sweeps) in models {
        for s in sweeps {
            let d = &s.data;
            for (k, p) in d.points.iter().enumerate() {
                model.push(m.clone());
                n.push(d.n);
                branch.push(p.branch.to_string());
                step.push(p.step);
                g.push(p.strength);
                a.push(p.contact_area);
                ac.push(p.contact_area_corrected);
                gap.push(p.mean_gap);
                cl.push(p.contact_clusters);
                fl.push(p.fluid());
                conv.push(p.converged);
                it.push(p.iterations);
                fr.push(p.force_residual);
                jump.push(d.jumps.iter().any(|j| j.index == k));
            }
        }
    }
    tables::Table::new()
        .with_str("model", model)
        .with_i64("n", n)
        .with_str("branch", branch)
        .with_i64("step", step)
        .with_f64("gamma0", g)
        .with_f64("contact_area", a)
        .with_f64("contact_area_corrected", ac)
        .with_f64("mean_gap", gap)
        .with_i64("contact_clusters", cl)
        .with_bool("fluid_percolates", fl)
        .with_bool("converged", conv)
        .with_i64("iterations", it)
        .with_f64("force_residual", fr)
        .with_bool("jump", jump)
}

/// The `fig3` scene: the figure (finest grid per model, jumps marked, γ_p and γ_fc on the
/// axis) and the tables `fig3.csv` (every point, [`points_table`]), `fig3_thresholds.csv` (γ_p,
/// γ_fc, γ_fc/γ_p, break-up and trough opening per model and grid, [`thresholds_table`]) and
/// `fig3_jumps.csv` (every jump, matched across grids, [`crate::jumptable::table`]); headline
/// numbers [`headlines`]. Attribute `points_left_out`.
pub struct Fig3;

impl Scene for Fig3 {
    fn name(&self) -> &'static str {
        "fig3"
    }
    fn doc(&self) -> &'static str {
        "Figure 3: contact area against γ0 at zero load, three models (figure, points, thresholds and jumps tables, γ headlines)"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        inputs()
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::figure("figure", "fig3"),
            OutputSpec::table("points", "fig3.csv"),
            OutputSpec::table("thresholds", "fig3_thresholds.csv"),
            OutputSpec::table("jumps", "fig3_jumps.csv"),
        ]
    }
    fn render(
        &self,
        ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let models = read(inputs)?;
        kinds::headline::write(out, &headlines(&models))?;
        let (data, left_out) = data(&models);
        if left_out > 0 {
            ctx.warn(format!(
                "{left_out} non-converged points of the finest sweeps are left out of the figure"
            ));
        }
        out.set_attr("points_left_out", left_out as i64)?;
        Ok(Outputs::new()
            .figure("figure", figures::scenes::fig3::figure(&data)?)
            .table("points", points_table(&models))
            .table("thresholds", thresholds_table(&models))
            .table("jumps", crate::jumptable::table(&models)))
    }
}
