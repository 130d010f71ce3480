//! `extremes`: the costly cases of the extremes suite, run at the preset's scale (the cheap ones
//! are tests on small grids: `contact/tests/extremes.rs`, the reynolds tests). Each case is a
//! solve with a check it must pass; the stage fails, naming every failed case, if one does not.
//!
//! # Cases (hard wall, the model of `lattice`)
//! - **largest grid**: a cold solve at 0.3 p_fc on 2^`n_largest` × 2^`n_largest` nodes (13: 67 M
//!   nodes, ≈ 7 GB) and on the next coarser grid. Check: both converge to `tol_gap` and their
//!   contact areas differ by at most 8 grid spacings of the coarser grid (the area's
//!   discretisation error is of the order of the contact line's length, < 4 λ, times dx).
//! - **tiny load**: 1e-8 p_fc on 2^`n`. Check: converged, some contact, and only at nodes within
//!   1e-3 h0 of the highest (Hertz: the contact is a few nodes around each maximum).
//! - **just below / above full contact**: p_fc(1 ∓ 1e-9). Check: converged; some node open below,
//!   every node closed above.
//! - **near-critical**: L_c(1 + l) for each reduced load l of `ls` (down to |l| = 1e-4), on the
//!   finest grid of the `critical` input, with that grid's bisected L_c (unshifted). Check:
//!   converged; the fluid percolates below L_c and not above it; below, the Reynolds flux along
//!   an open axis converges and is positive and finite; above, it is exactly zero.
//!
//! # Artefact
//! `cases/*` one entry per case (the columns of [`Case`], also the table's) and the side output
//! `results/tables/extremes.csv`: `case`, `n`, `load` (E* h0/λ), `value` (the checked quantity),
//! `reference` (what it is checked against, NaN if nothing), `bound`, `passed`, `iterations`,
//! `wall_s`, `check` (the check in words).

use anyhow::{Context, Result, anyhow, bail};
use contact::{Interaction, Lattice, Model, Solution, Surface};
use formats::records::{Record, read_in};
use orchestrator::{InputSpec, Inputs, ParamSpec, ParamType, StageContext, StageReport, TypedKind};
use reynolds::{FlowAxis, FlowOptions};
use serde::Deserialize;
use serde_json::json;
use store::{ArtefactReader, ArtefactWriter};
use tables::Table;

use crate::critical::CriticalLevel;

/// The `extremes` stage kind.
pub struct ExtremesKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 1;

/// Where the table goes.
pub const TABLE: &str = "results/tables/extremes.csv";

formats::record! {
    /// One case and its verdict (`cases/*`, and a row of the table).
    #[derive(Debug, Clone, PartialEq)]
    pub struct Case {
        /// What was solved.
        pub case: String,
        /// Grid exponent.
        pub n: u32,
        /// Mean pressure (E* h0/λ).
        pub load: f64,
        /// The checked quantity.
        pub value: f64,
        /// What it is checked against (NaN if nothing).
        pub reference: f64,
        /// The bound of the check (NaN if none).
        pub bound: f64,
        /// Whether the check passed.
        pub passed: bool,
        /// Contact-solver iterations.
        pub iterations: usize,
        /// Wall time of the case (s).
        pub wall_s: f64,
        /// The check in words.
        pub check: String,
    }
}

/// The table of the cases: every column of [`Case`], in its order.
pub fn table(cases: &[Case]) -> Table {
    crate::record_table::table(cases)
}

/// Reads the cases of an `extremes` artefact.
pub fn read_cases(r: &ArtefactReader) -> Result<Vec<Case>> {
    read_in(r, "cases")
}

fn solve(model: &mut Model, load: f64, tol_gap: f64) -> Result<Solution> {
    let opts = crate::solver::SolverParams::tol_gap(tol_gap).options();
    Ok(model.solve(Interaction::HardWall, load, &opts, None)?)
}

/// The `extremes` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExtremesParams {
    /// Which model.
    #[serde(deserialize_with = "crate::solver::from_str")]
    pub lattice: Lattice,
    /// The largest grid solved (and the next coarser one).
    pub n_largest: u32,
    /// Grid of the load extremes.
    pub n: u32,
    /// Reduced loads (L − L_c)/L_c at the critical input's finest grid, non-zero.
    pub ls: Vec<f64>,
    /// Polonsky–Keer tolerance on the constraint violation (h0).
    pub tol_gap: f64,
}

impl TypedKind for ExtremesKind {
    type Params = ExtremesParams;
    /// Lower bound: heights, displacement, pressure and gap on the largest grid (its doc's
    /// 7 GB at n = 13 is about 13 such fields: FFT buffers and minimiser state).
    fn memory_estimate(
        &self,
        params: &orchestrator::Params,
        _inputs: &std::collections::BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        let n = params.i64("n_largest").ok()?.max(params.i64("n").ok()?);
        Some(4 * crate::surface::field_bytes(n))
    }
    fn name(&self) -> &str {
        "extremes"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "costly extreme cases (largest grid, 1e-8 p_fc, p_fc(1 ± 1e-9), |l| down to 1e-4), each checked"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            crate::surface::lattice_spec(),
            ParamSpec::new(
                "n_largest",
                ParamType::int_range(surface::N_MIN as i64 + 1, surface::N_MAX as i64),
            )
            .doc("the largest grid solved (and the next coarser one); 13 needs ≈ 7 GB"),
            ParamSpec::new(
                "n",
                ParamType::int_range(surface::N_MIN as i64, surface::N_MAX as i64),
            )
            .doc("grid of the load extremes (1e-8 p_fc, p_fc(1 ± 1e-9))"),
            ParamSpec::new(
                "ls",
                ParamType::Array {
                    elem: Box::new(ParamType::float_range(-0.1, 0.1)),
                    min_len: 1,
                    max_len: Some(16),
                },
            )
            .default(json!([-1e-4, 1e-4]))
            .doc("reduced loads (L − L_c)/L_c at the critical input's finest grid, non-zero"),
            crate::solver::tol_gap_spec(),
        ]
    }
    fn inputs(&self, _params: &ExtremesParams) -> Vec<InputSpec> {
        vec![
            InputSpec::one("critical", &["critical"])
                .doc("L_c on the grids of the near-critical cases (unshifted: shifts = 0)"),
        ]
    }
    fn side_outputs(&self, _params: &ExtremesParams) -> Vec<String> {
        vec![TABLE.to_string()]
    }
    fn cost(&self, params: &ExtremesParams) -> f64 {
        let n = params.n_largest as i32;
        4f64.powi(n) / 4f64.powi(9) * 0.3
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &ExtremesParams,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let lattice = params.lattice;
        if let Some(l) = params.ls.iter().find(|l| **l == 0.0) {
            bail!("ls: {l} — the reduced loads must be non-zero (at l = 0 the check has no side)");
        }
        let crit = inputs.one("critical")?;
        let levels = CriticalLevel::read_all(crit)?;
        let level = levels.last().expect("read_all returns at least one level");
        if level.lattice != lattice {
            bail!(
                "the `critical` input `{}` is for the {} model, this stage for the {}",
                crit.path().display(),
                level.lattice.name(),
                lattice.name()
            );
        }
        level.require_unshifted(crit.path(), "the extremes stage's near-critical cases")?;
        let l_c = level
            .get("l_c")
            .map(|v| v.0)
            .ok_or_else(|| anyhow!("{}: no l_c", crit.path().display()))?;
        ctx.progress(0.0, &format!("largest grid n = {}", params.n_largest));
        let mut cases = vec![largest_grid(params)?];
        ctx.progress(0.5, &format!("load extremes, n = {}", params.n));
        cases.extend(load_extremes(params)?);
        ctx.progress(0.75, &format!("near-critical loads, n = {}", level.n));
        cases.extend(near_critical(params, level.n, l_c)?);
        write_cases(ctx, out, &cases, lattice, l_c)?;
        Ok(StageReport::with_stats(json!({
            "cases": cases.len(),
            "largest_nodes": 4f64.powi(params.n_largest as i32),
        })))
    }
}

/// A solve and its wall time (s).
fn timed(f: &mut dyn FnMut() -> Result<Solution>) -> Result<(Solution, f64)> {
    let t0 = std::time::Instant::now();
    let s = f()?;
    Ok((s, t0.elapsed().as_secs_f64()))
}

/// "" for a converged solve, else why not (appended to the case's name).
fn conv(s: &Solution) -> String {
    match &s.stats.reason {
        None if s.stats.converged => String::new(),
        Some(r) => format!(" — not converged: {r}"),
        None => " — not converged".into(),
    }
}

/// The largest grid and the next coarser one (only the scalars are kept: at 2^13 a solution
/// holds 1.6 GB).
fn largest_grid(params: &ExtremesParams) -> Result<Case> {
    let (lattice, tol, n_largest) = (params.lattice, params.tol_gap, params.n_largest);
    // Largest grid and the next coarser one (only the scalars are kept: at 2^13 a solution
    // holds 1.6 GB).
    let mut runs = Vec::new();
    for n in [n_largest - 1, n_largest] {
        let s = Surface::new(lattice, n)?;
        let (load, dx) = (0.3 * s.p_fc_grid(), s.grid.dx());
        let mut model = Model::new(&s)?;
        drop(s);
        let (sol, wall) = timed(&mut || solve(&mut model, load, tol))?;
        runs.push((n, dx, load, wall, sol.contact_area, conv(&sol), sol.stats));
    }
    let ((n_c, dx_c, _, _, a_c, _, st_c), (n_f, _, load, wall, a_f, why, st_f)) =
        (&runs[0], &runs[1]);
    let bound = 8.0 * dx_c;
    Ok(Case {
        case: format!("largest grid: contact area at 0.3 p_fc{why}"),
        n: *n_f,
        load: *load,
        value: *a_f,
        reference: *a_c,
        bound,
        passed: st_f.converged && st_c.converged && (a_f - a_c).abs() <= bound,
        iterations: st_f.iterations,
        wall_s: *wall,
        check: format!("converged on 2^{n_f} and 2^{n_c}; |a − a(2^{n_c})| ≤ 8 dx(2^{n_c})"),
    })
}

/// 1e-8 p_fc and p_fc(1 ∓ 1e-9) on 2^n.
fn load_extremes(params: &ExtremesParams) -> Result<Vec<Case>> {
    let (lattice, tol, n_loads) = (params.lattice, params.tol_gap, params.n);
    let mut cases = Vec::new();
    let s = Surface::new(lattice, n_loads)?;
    let p_fc = s.p_fc_grid();
    let h_max = s.heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let nodes = s.heights.len() as f64;
    let mut model = Model::new(&s)?;
    let load = 1e-8 * p_fc;
    let (sol, wall) = timed(&mut || solve(&mut model, load, tol))?;
    let depth = sol
        .pressure
        .iter()
        .zip(s.heights.iter())
        .filter(|(p, _)| **p > 0.0)
        .map(|(_, h)| h_max - h)
        .fold(0.0, f64::max);
    let touching = sol.contact_area * nodes;
    cases.push(Case {
        case: format!(
            "1e-8 p_fc: depth of the lowest contact node below the highest{}",
            conv(&sol)
        ),
        n: n_loads,
        load,
        value: depth,
        reference: touching,
        bound: 1e-3,
        passed: sol.stats.converged && touching >= 1.0 && depth <= 1e-3,
        iterations: sol.stats.iterations,
        wall_s: wall,
        check:
            "converged; contact (reference: contact nodes) only within 1e-3 h0 of the highest node"
                .into(),
    });
    for (sign, what) in [(-1.0, "below"), (1.0, "above")] {
        let load = p_fc * (1.0 + sign * 1e-9);
        let (sol, wall) = timed(&mut || solve(&mut model, load, tol))?;
        let open = (1.0 - sol.contact_area) * nodes;
        let ok = if sign < 0.0 { open >= 1.0 } else { open == 0.0 };
        cases.push(Case {
            case: format!(
                "p_fc(1 {} 1e-9): open nodes{}",
                if sign < 0.0 { "−" } else { "+" },
                conv(&sol)
            ),
            n: n_loads,
            load,
            value: open,
            reference: f64::NAN,
            bound: f64::NAN,
            passed: sol.stats.converged && ok,
            iterations: sol.stats.iterations,
            wall_s: wall,
            check: format!(
                "converged; {} full contact: {}",
                what,
                if sign < 0.0 {
                    "some node open"
                } else {
                    "no node open"
                }
            ),
        });
    }
    drop(model);
    drop(s);
    Ok(cases)
}

/// L_c(1 + l) for each l of `ls` on the critical input's finest grid 2^`n`.
fn near_critical(params: &ExtremesParams, n: u32, l_c: f64) -> Result<Vec<Case>> {
    let (lattice, tol) = (params.lattice, params.tol_gap);
    let mut cases = Vec::new();
    let s = Surface::new(lattice, n)?;
    let (lx, ly) = (s.grid.lx, s.grid.ly);
    let mut model = Model::new(&s)?;
    let mut ls = params.ls.clone();
    ls.sort_by(f64::total_cmp);
    for l in ls {
        let load = l_c * (1.0 + l);
        let (sol, wall) = timed(&mut || solve(&mut model, load, tol))?;
        let st = critical::FlowState::of_gap(sol.gap.view())
            .with_context(|| format!("percolation at l = {l:e}"))?;
        let below = l < 0.0;
        let axis = if st.fluid_x { FlowAxis::X } else { FlowAxis::Y };
        let flow = reynolds::solve(sol.gap.view(), lx, ly, axis, &FlowOptions::default())
            .with_context(|| format!("Reynolds flow at l = {l:e}"))?;
        let ok = if below {
            st.fluid_any() && flow.converged && flow.flux.is_finite() && flow.flux > 0.0
        } else {
            !st.fluid_any() && !flow.percolating && flow.flux == 0.0
        };
        cases.push(Case {
            case: format!(
                "L_c(1 {} {:e}): Reynolds flux{}",
                if below { "−" } else { "+" },
                l.abs(),
                conv(&sol)
            ),
            n,
            load,
            value: flow.flux,
            reference: l_c,
            bound: f64::NAN,
            passed: sol.stats.converged && ok,
            iterations: sol.stats.iterations,
            wall_s: wall,
            check: if below {
                "converged; the fluid percolates; the flux converges, finite and > 0".into()
            } else {
                "converged; the fluid does not percolate; the flux is exactly 0".into()
            },
        });
    }
    Ok(cases)
}

/// `cases/*`, the attributes and the table; fails naming every failed case.
fn write_cases(
    ctx: &mut StageContext,
    out: &mut ArtefactWriter,
    cases: &[Case],
    lattice: Lattice,
    l_c: f64,
) -> Result<()> {
    let t = table(cases);
    Case::write(cases, out, "cases")?;
    out.set_attr("lattice", lattice.name())?;
    out.set_attr("l_c", l_c)?;
    ctx.emit_file(TABLE, tables::csv_bytes(&t)?);
    let failed: Vec<String> = cases
        .iter()
        .filter(|c| !c.passed)
        .map(|c| {
            format!(
                "{} (n = {}, value {:e}; check: {})",
                c.case, c.n, c.value, c.check
            )
        })
        .collect();
    if !failed.is_empty() {
        bail!(
            "extreme cases failed their checks:\n  {}",
            failed.join("\n  ")
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn case(passed: bool) -> Case {
        Case {
            case: "tiny load".into(),
            n: 5,
            load: 1e-8,
            value: 2e-4,
            reference: f64::NAN,
            bound: 1e-3,
            passed,
            iterations: 12,
            wall_s: 0.5,
            check: "converged".into(),
        }
    }

    /// The table, the `cases/*` datasets and the reader share the record's columns.
    #[test]
    fn table_and_artefact_follow_the_case_record() {
        let cases = [case(true), case(false)];
        let t = table(&cases);
        let names: Vec<&str> = t.columns().iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "case",
                "n",
                "load",
                "value",
                "reference",
                "bound",
                "passed",
                "iterations",
                "wall_s",
                "check"
            ]
        );
        assert_eq!(t.i64("n").unwrap(), [5, 5]);
        let dir = tempfile::tempdir().unwrap();
        let mut w = ArtefactWriter::create(dir.path().join("x.h5")).unwrap();
        Case::write(&cases, &mut w, "cases").unwrap();
        let r = ArtefactReader::open(w.publish().unwrap()).unwrap();
        assert_eq!(r.read_u8_1d("cases/passed").unwrap(), [1, 0]);
        let back = read_cases(&r).unwrap();
        assert_eq!(back[1].check, "converged");
        assert!(back[0].reference.is_nan());
        assert_eq!((back[0].passed, back[1].passed), (true, false));
    }
}
