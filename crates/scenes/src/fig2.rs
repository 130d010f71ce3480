//! Figure 2 (scene `fig2`): relative contact area against mean pressure, square model, hard
//! wall, adhesion and repulsion (inputs `hardwall`, `adhesion`, `repulsion`: load-controlled
//! `sweep` stages on the same grid); loading red, unloading blue, detected jumps circled, p_fc
//! marked; points that did not converge are left out, with a warning.
//!
//! Outputs:
//! - figures `fig2` (linear area axis) and `fig2_log` (logarithmic: shows the small-area
//!   hysteresis);
//! - `fig2.csv`, one row per path point: `interaction`, `branch`, `step`, `load` (E* h0/λ),
//!   `load_over_p_fc`, `contact_area`, `contact_area_corrected`, `mean_gap`, `iterations`,
//!   `force_residual`, `max_violation`, `converged`, `contact_clusters`, `fluid_percolates`
//!   (along x or y), `jump` (the state jumps between this point and the branch's next
//!   converged point);
//! - `fig2_jumps.csv`, one row per jump of the loops and per pull-off: `interaction`, `branch`,
//!   `event` (contact formation, coalescence, break-up, full contact, trough opening, pull-off,
//!   ...), `load_before`, `load_after`, `load_before_over_p_fc`, `load_after_over_p_fc`,
//!   `area_before`, `area_after`, `ratio` (jump over its neighbours' trend; empty for a
//!   pull-off, where the path ends: `load_after` is the first load without equilibrium and
//!   `area_after` is 0), `detector` (`trend`, `loop`, or `solver` for a pull-off);
//! - `fig2_loops.csv`, one row per hysteresis loop between loading and unloading (loads at
//!   which the two branches are in different states): `interaction`, `load_lo`, `load_hi`,
//!   `load_lo_over_p_fc`, `load_hi_over_p_fc`, `max_area_difference`,
//!   `load_at_max_over_p_fc`.
//!
//! Artefact attributes: `scene`, `rows`, `points_plotted`, `points_left_out`.

use crate::jumptable::GridSweep;
use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::{Result, bail};
use figures::scenes::fig2::{Branch, Fig2Data, LoadLoop};
use kinds::sweep::{Branch as PathBranch, SweepData};
use orchestrator::{InputSpec, Inputs, Params, StageContext};
use store::ArtefactWriter;
use tables::Table;

/// The `fig2` scene.
pub struct Fig2;

impl Scene for Fig2 {
    fn name(&self) -> &'static str {
        "fig2"
    }
    fn doc(&self) -> &'static str {
        "Figure 2: contact area against load, hard wall, adhesion and repulsion (figure, log-area figure, points, jumps and loops tables)"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        inputs()
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::figure("figure", "fig2"),
            OutputSpec::figure("log", "fig2_log"),
            OutputSpec::table("points", "fig2.csv"),
            OutputSpec::table("jumps", "fig2_jumps.csv"),
            OutputSpec::table("loops", "fig2_loops.csv"),
        ]
    }
    fn render(
        &self,
        ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let sweeps = read(inputs)?;
        let mut loops = Vec::new();
        let mut plotted = 0usize;
        let mut left_out = 0usize;
        for d in &sweeps {
            let (l, bad) = load_loop(d);
            if bad > 0 {
                ctx.warn(format!(
                    "{bad} non-converged points of the {} sweep are left out of the figure",
                    d.interaction
                ));
            }
            plotted += l.loading.area.len() + l.unloading.area.len();
            left_out += bad;
            loops.push(l);
        }
        let label = |d: &SweepData, what: &str, sym: &str, key: &str| -> Result<String> {
            let r = inputs.one(&d.interaction)?;
            Ok(format!(
                "{what}, {sym} = {}, $ρ$ = {}",
                r.attr_f64(key)?,
                r.attr_f64("rho")?
            ))
        };
        let data = Fig2Data {
            adhesion_label: label(&sweeps[1], "exponential adhesion", "$γ$_0", "gamma0")?,
            repulsion_label: label(&sweeps[2], "Gaussian repulsion", "$γ$_r", "gamma_r")?,
            hard_wall: loops[0].clone(),
            adhesion: loops[1].clone(),
            repulsion: loops[2].clone(),
            p_fc: Some(sweeps[0].p_fc),
            a_p: None,
            log_area: false,
            pressure_range: None,
        };
        out.set_attr("points_plotted", plotted as i64)?;
        out.set_attr("points_left_out", left_out as i64)?;

        let log = Fig2Data {
            log_area: true,
            ..data.clone()
        };
        let (points, jumps, loops) = tables(&sweeps);
        Ok(Outputs::new()
            .figure("figure", figures::scenes::fig2::figure(&data)?)
            .figure("log", figures::scenes::fig2::figure(&log)?)
            .table("points", points)
            .table("jumps", jumps)
            .table("loops", loops))
    }
}

/// The interactions of Figure 2, in the order of its inputs.
pub const INTERACTIONS: [&str; 3] = ["hardwall", "adhesion", "repulsion"];

/// The inputs Figure 2's kinds take.
pub fn inputs() -> Vec<InputSpec> {
    INTERACTIONS
        .iter()
        .map(|i| {
            InputSpec::one(i, &["sweep"]).doc(&format!("load-controlled {i} sweep (square model)"))
        })
        .collect()
}

/// Reads the three sweeps (hard wall, adhesion, repulsion) and checks that each is a load path
/// of the interaction its input is named after, all on the same grid.
pub fn read(inputs: &Inputs) -> Result<Vec<SweepData>> {
    let mut out = Vec::new();
    for name in INTERACTIONS {
        let r = inputs.one(name)?;
        let d = SweepData::read(r)?;
        if d.interaction != name {
            bail!(
                "input `{name}` holds the {} sweep (`{}`); it must be the {name} sweep",
                d.interaction,
                r.path().display()
            );
        }
        if d.control != "load" {
            bail!(
                "input `{name}` varies the {}; Figure 2 needs a load path (control = \"load\")",
                d.control
            );
        }
        out.push(d);
    }
    if let Some(d) = out
        .iter()
        .find(|d| (d.n, &d.lattice) != (out[0].n, &out[0].lattice))
    {
        bail!(
            "the sweeps are on different surfaces: {} n = {} (hardwall) and {} n = {} ({})",
            out[0].lattice,
            out[0].n,
            d.lattice,
            d.n,
            d.interaction
        );
    }
    Ok(out)
}

/// The inputs of Figure 2's resolution check: the same three sweeps on one or more grids each.
pub fn resolution_inputs() -> Vec<InputSpec> {
    INTERACTIONS
        .iter()
        .map(|i| {
            InputSpec::many(i, &["sweep"]).doc(&format!(
                "load-controlled {i} sweeps (square model), one per grid"
            ))
        })
        .collect()
}

/// Reads the resolution check's sweeps: per interaction, its sweeps coarse to fine, each a
/// load path of that interaction on the square model, at most one per grid.
pub fn read_resolution(inputs: &Inputs) -> Result<Vec<(String, Vec<GridSweep>)>> {
    let mut out = Vec::new();
    for name in INTERACTIONS {
        let mut v = Vec::new();
        for r in inputs.all(name) {
            let s = GridSweep::read(r)?;
            if s.data.interaction != name || s.data.control != "load" {
                bail!(
                    "input `{name}` (`{}`) holds the {} sweep varying the {}; it must be a {name} load path",
                    r.path().display(),
                    s.data.interaction,
                    s.data.control
                );
            }
            if s.data.lattice != "square" {
                bail!(
                    "input `{name}` is on the {} model; Figure 2 is the square model",
                    s.data.lattice
                );
            }
            v.push(s);
        }
        if v.is_empty() {
            bail!("input `{name}`: no sweep given");
        }
        v.sort_by_key(|s| s.data.n);
        if let Some(w) = v.windows(2).find(|w| w[0].data.n == w[1].data.n) {
            bail!(
                "input `{name}`: two sweeps on the same grid (n = {}); give one per grid",
                w[0].data.n
            );
        }
        out.push((name.to_string(), v));
    }
    Ok(out)
}

/// One branch of a sweep as a figure draws it (see [`converged_branch`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ConvergedBranch {
    /// Control value of each converged point.
    pub x: Vec<f64>,
    /// Relative contact area of each converged point.
    pub area: Vec<f64>,
    /// Jumps: index i means a jump between converged points i and i + 1.
    pub jumps: Vec<usize>,
    /// Points left out (did not converge).
    pub left_out: usize,
}

/// One branch of a sweep for a figure: the control values (`x` of each point) and areas of its
/// converged points, the jumps re-indexed to them, and how many points were left out.
pub fn converged_branch(
    d: &SweepData,
    name: PathBranch,
    x: &dyn Fn(&kinds::sweep::Point) -> f64,
) -> ConvergedBranch {
    let all = d.branch_indices(name);
    let idx: Vec<usize> = all
        .iter()
        .copied()
        .filter(|&k| d.points[k].converged)
        .collect();
    let jumps = d
        .jumps
        .iter()
        .filter(|j| j.branch == name)
        .filter_map(|j| {
            let pos = idx.iter().position(|&k| k == j.index)?;
            (idx.get(pos + 1) == Some(&j.index_after)).then_some(pos)
        })
        .collect();
    ConvergedBranch {
        x: idx.iter().map(|&k| x(&d.points[k])).collect(),
        area: idx.iter().map(|&k| d.points[k].contact_area).collect(),
        jumps,
        left_out: all.len() - idx.len(),
    }
}

/// One load branch of a sweep for Figure 2.
fn branch(d: &SweepData, name: PathBranch) -> (Branch, usize) {
    let b = converged_branch(d, name, &|p| p.load);
    (
        Branch {
            pressure: b.x,
            area: b.area,
            jumps: b.jumps,
        },
        b.left_out,
    )
}

fn load_loop(d: &SweepData) -> (LoadLoop, usize) {
    let (loading, a) = branch(d, PathBranch::Loading);
    let (unloading, b) = branch(d, PathBranch::Unloading);
    (LoadLoop { loading, unloading }, a + b)
}

/// Figure 2's tables: points, jumps, loops.
fn tables(sweeps: &[SweepData]) -> (Table, Table, Table) {
    // points
    let (mut inter, mut branch, mut step, mut load, mut load_r) =
        (vec![], vec![], vec![], vec![], vec![]);
    let (mut area, mut area_c, mut gap, mut iters, mut force, mut viol) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let (mut conv, mut clusters, mut fluid, mut jump) = (vec![], vec![], vec![], vec![]);
    // jumps
    let (mut j_inter, mut j_branch, mut j_event) = (vec![], vec![], vec![]);
    let (mut j_lb, mut j_la, mut j_ab, mut j_aa, mut j_ratio) =
        (vec![], vec![], vec![], vec![], vec![]);
    let (mut j_p_fc, mut j_det) = (vec![], vec![]);
    // loops
    let (mut l_inter, mut l_lo, mut l_hi, mut l_d, mut l_x, mut l_p_fc) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for d in sweeps {
        for (k, p) in d.points.iter().enumerate() {
            inter.push(d.interaction.clone());
            branch.push(p.branch.to_string());
            step.push(p.step);
            load.push(p.load);
            load_r.push(p.load / d.p_fc);
            area.push(p.contact_area);
            area_c.push(p.contact_area_corrected);
            gap.push(p.mean_gap);
            iters.push(p.iterations);
            force.push(p.force_residual);
            viol.push(p.max_violation);
            conv.push(p.converged);
            clusters.push(p.contact_clusters);
            fluid.push(p.fluid_percolates_x || p.fluid_percolates_y);
            jump.push(d.jumps.iter().any(|j| j.index == k));
        }
        for j in &d.jumps {
            j_inter.push(d.interaction.clone());
            j_branch.push(j.branch.to_string());
            j_event.push(j.event.clone());
            j_lb.push(j.load_before);
            j_la.push(j.load_after);
            j_ab.push(j.area_before);
            j_aa.push(j.area_after);
            j_ratio.push(j.ratio);
            j_p_fc.push(d.p_fc);
            j_det.push(j.detector.to_string());
        }
        for l in &d.loops {
            l_inter.push(d.interaction.clone());
            l_lo.push(l.x.0);
            l_hi.push(l.x.1);
            l_d.push(l.max_area_difference);
            l_x.push(l.x_at_max);
            l_p_fc.push(d.p_fc);
        }
        for e in &d.ended {
            // the last point of the branch before it ended
            let last = d.branch_indices(e.branch).last().map(|&k| &d.points[k]);
            j_inter.push(d.interaction.clone());
            j_branch.push(e.branch.to_string());
            j_event.push("pull-off".to_string());
            j_lb.push(last.map_or(f64::NAN, |p| p.load));
            j_la.push(e.load);
            j_ab.push(last.map_or(f64::NAN, |p| p.contact_area));
            j_aa.push(0.0);
            j_ratio.push(f64::NAN);
            j_p_fc.push(d.p_fc);
            j_det.push("solver".to_string());
        }
    }
    let points = Table::new()
        .with_str("interaction", inter)
        .with_str("branch", branch)
        .with_i64("step", step)
        .with_f64("load", load)
        .with_f64("load_over_p_fc", load_r)
        .with_f64("contact_area", area)
        .with_f64("contact_area_corrected", area_c)
        .with_f64("mean_gap", gap)
        .with_i64("iterations", iters)
        .with_f64("force_residual", force)
        .with_f64("max_violation", viol)
        .with_bool("converged", conv)
        .with_i64("contact_clusters", clusters)
        .with_bool("fluid_percolates", fluid)
        .with_bool("jump", jump);
    let ratio = |a: &[f64]| -> Vec<f64> { a.iter().zip(&j_p_fc).map(|(x, p)| x / p).collect() };
    let jumps = Table::new()
        .with_str("interaction", j_inter)
        .with_str("branch", j_branch)
        .with_str("event", j_event)
        .with_f64("load_before", j_lb.clone())
        .with_f64("load_after", j_la.clone())
        .with_f64("load_before_over_p_fc", ratio(&j_lb))
        .with_f64("load_after_over_p_fc", ratio(&j_la))
        .with_f64("area_before", j_ab)
        .with_f64("area_after", j_aa)
        .with_f64("ratio", j_ratio)
        .with_str("detector", j_det);
    let over = |a: &[f64]| -> Vec<f64> { a.iter().zip(&l_p_fc).map(|(x, p)| x / p).collect() };
    let loops = Table::new()
        .with_str("interaction", l_inter)
        .with_f64("load_lo", l_lo.clone())
        .with_f64("load_hi", l_hi.clone())
        .with_f64("load_lo_over_p_fc", over(&l_lo))
        .with_f64("load_hi_over_p_fc", over(&l_hi))
        .with_f64("max_area_difference", l_d)
        .with_f64("load_at_max_over_p_fc", over(&l_x));
    (points, jumps, loops)
}
