//! `critical`: the percolation threshold of the hard-wall contact of one model on one or several
//! 2^n grids, averaged over sub-grid shifts (crates/critical). With several n the levels run
//! coarse to fine, each starting its brackets from the level before and warm-started from its
//! near-critical solutions; `resolution` extrapolates them to zero spacing.
//!
//! # Parameters
//! `lattice`; `ns` (grid exponents, strictly ascending); `shifts` (m: the m × m midpoint rule on
//! [0, ½)² spacings, 0 = unshifted grid only; default 0); `tol_gap` (Polonsky–Keer, h0; 1e-10);
//! `rel_width` (bracket, 1e-9); `saddle_loads` (reduced loads l < 0 of the saddle-gap samples,
//! sampled on the first shift only; default six from −0.02 to −0.002; `[]` skips the sub-grid
//! estimate); `fields` (store the near-critical fields of the finest grid's first shift;
//! default true).
//!
//! # Artefact
//! - one group `level/<n>` per grid with attributes `n`, `nx`, `ny`, `h` (sqrt(dx·dy), λ),
//!   `shift_rule`, `p_fc` (grid, mean over shifts), the shift averages `l_c`, `l_c_x`, `l_c_y`,
//!   `a_p_raw[_x|_y]`, `a_p_corrected[_x|_y]`, `p_fc_over_l_c`, each with a `_sem` (standard
//!   error over shifts, 0 for one shift), `l_c_subgrid`, `l_c_subgrid_error`, `zeta`,
//!   `zeta_error` (NaN without a sub-grid fit), `probes`, `iterations`, `retries`, `wall_s`; and
//!   datasets, one entry per shift: `shifts/{sx, sy, p_fc, probes, iterations, wall_s}` and,
//!   per criterion (`any`, `x`, `y`), `<criterion>/{lo, hi, a_p_raw, a_p_corrected, contact_lo,
//!   contact_hi, perimeter_lo, perimeter_hi}`; the first shift's saddle samples `saddle/{angle_deg,
//!   load, reduced, area, gap}` (`gap`: samples × groups, NaN where the interpolation stencil
//!   touched contact) and per-group fits `subgrid/{angle_deg, l_c, l_c_error, zeta, zeta_error,
//!   points}`;
//! - root attributes: `lattice`, `ns`, `tol_gap`, `rel_width`, `p_fc_exact`, `lx`, `ly`, and the
//!   finest level's `n`, `l_c`, `a_p_raw`, `a_p_corrected`, `p_fc_over_l_c`;
//! - with `fields`, for the finest grid's first shift: `height`, `gap`, `displacement`,
//!   `pressure` just below L_c (the fluid still percolates; a valid input of `saddleflow
//!   flow`), `above/gap` and `above/pressure` just above, attributes `load_below`,
//!   `load_above`, `field_shift`.

pub use crate::critical_write::{ShiftRow, SubgridFit, TransitionRow};
use crate::critical_write::{level_stats, write_fields, write_levels, write_root};
use crate::surface::lattice_from_name;
use anyhow::{Context, Result, bail};
use critical::{
    CriticalOptions, LevelSummary, ResolutionOptions, default_saddle_loads, resolution_study_with,
};
use orchestrator::{
    Inputs, ParamIssue, ParamSpec, ParamType, Params, StageContext, StageReport, TypedKind,
};
use serde::Deserialize;
use serde_json::json;
use store::{ArtefactReader, ArtefactWriter};
use surface::Lattice;

/// The `critical` stage kind.
pub struct CriticalKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 2;

/// Largest shift rule m (m² solves per grid).
pub const MAX_SHIFTS: i64 = 8;

/// The grid exponents `ns` (the list of a `critical` or `ladder` stage).
pub(crate) fn ns(params: &Params) -> Result<Vec<u32>> {
    Ok(params
        .get("ns")?
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_i64())
                .map(|v| v as u32)
                .collect()
        })
        .unwrap_or_default())
}

/// The `ns` parameter: at most `max_len` grid exponents in the surface's range.
pub(crate) fn ns_spec(max_len: usize, doc: &str) -> ParamSpec {
    ParamSpec::new(
        "ns",
        ParamType::Array {
            elem: Box::new(ParamType::int_range(
                surface::N_MIN as i64,
                surface::N_MAX as i64,
            )),
            min_len: 1,
            max_len: Some(max_len),
        },
    )
    .doc(doc)
}

/// The `critical` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CriticalParams {
    /// Which model.
    #[serde(deserialize_with = "crate::solver::from_str")]
    pub lattice: Lattice,
    /// Grid exponents, strictly ascending.
    pub ns: Vec<u32>,
    /// m × m sub-grid shifts; 0 = unshifted grid only.
    pub shifts: usize,
    /// Polonsky–Keer tolerance on the constraint violation (h0).
    pub tol_gap: f64,
    /// Target relative width of each load bracket.
    pub rel_width: f64,
    /// Reduced loads l < 0 of the saddle-gap samples.
    pub saddle_loads: Vec<f64>,
    /// Store the near-critical fields of the finest grid.
    pub fields: bool,
}

/// Grid exponents strictly ascending (the `ns` of `critical` and `ladder`).
pub(crate) fn check_ascending(ns: &[u32]) -> Result<(), ParamIssue> {
    if ns.windows(2).any(|w| w[1] <= w[0]) {
        return Err(ParamIssue::new(
            "ns",
            format!("{ns:?}: allowed a strictly ascending list of grid exponents"),
        ));
    }
    Ok(())
}

impl TypedKind for CriticalKind {
    type Params = CriticalParams;
    /// Lower bound: heights, displacement, pressure and gap on the finest grid.
    fn memory_estimate(
        &self,
        params: &Params,
        _inputs: &std::collections::BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        let n = ns(params).ok()?.into_iter().max()?;
        Some(4 * crate::surface::field_bytes(n as i64))
    }
    fn name(&self) -> &str {
        "critical"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "percolation threshold L_c and contact area a_p of the hard-wall contact on one or more grids, averaged over sub-grid shifts"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            crate::surface::lattice_spec(),
            ns_spec(
                10,
                "grid exponents, strictly ascending: 2^n × 2^n nodes each",
            ),
            ParamSpec::new("shifts", ParamType::int_range(0, MAX_SHIFTS))
                .default(0)
                .doc("m × m sub-grid shifts (midpoint rule on [0, ½)²); 0 = unshifted grid only"),
            crate::solver::tol_gap_spec(),
            ParamSpec::new("rel_width", ParamType::float_range(1e-13, 0.1))
                .default(1e-9)
                .doc("target relative width (hi − lo)/hi of each load bracket"),
            ParamSpec::new(
                "saddle_loads",
                ParamType::Array {
                    elem: Box::new(ParamType::Float {
                        min: Some(-1.0),
                        min_exclusive: true,
                        max: Some(0.0),
                        max_exclusive: true,
                    }),
                    min_len: 0,
                    max_len: Some(64),
                },
            )
            .default(json!(default_saddle_loads()))
            .doc("reduced loads l < 0 of the saddle-gap samples (first shift); [] = none"),
            ParamSpec::new("fields", ParamType::Bool)
                .default(true)
                .doc("store the near-critical fields of the finest grid (first shift)"),
        ]
    }
    fn check(&self, params: &CriticalParams) -> Result<(), ParamIssue> {
        check_ascending(&params.ns)
    }
    fn cost(&self, params: &CriticalParams) -> f64 {
        // ~1000 Polonsky–Keer iterations per shift and level, each an FFT pair; relative to a
        // 512² solve
        let m = params.shifts.max(1) as f64;
        params
            .ns
            .iter()
            .map(|&n| 4f64.powi(n as i32) / 4f64.powi(9) * m * m * 10.0)
            .sum()
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &CriticalParams,
        _inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let lattice = params.lattice;
        let ns = params.ns.clone();
        let mut opts = ResolutionOptions::new(ns.clone(), params.shifts);
        opts.critical = CriticalOptions {
            tol_gap: params.tol_gap,
            rel_width: params.rel_width,
            saddle_loads: params.saddle_loads.clone(),
            ..Default::default()
        };
        // Progress by cost: a level costs ∝ 4^n.
        let weights: Vec<f64> = ns.iter().map(|&n| 4f64.powi(n as i32)).collect();
        let total: f64 = weights.iter().sum();
        let mut done_w = 0.0;
        ctx.progress(0.01, &format!("n = {}", ns[0]));
        let mut written = Vec::new();
        let study = {
            let mut on_level = |l: &LevelSummary| {
                let k = ns.iter().position(|&n| n == l.n).unwrap_or(0);
                done_w += weights[k];
                let next = ns
                    .get(k + 1)
                    .map_or("writing".to_string(), |n| format!("n = {n}"));
                ctx.progress(0.95 * done_w / total, &next);
                written.push(l.n);
            };
            resolution_study_with(lattice, &opts, &mut on_level)
                .with_context(|| format!("{} grids n = {ns:?}", lattice.name()))?
        };
        write_levels(ctx, out, &study)?;
        let finest = study.levels.last().expect("levels");
        let g = finest.results[0].grid;
        write_root(out, lattice, &ns, &opts.critical, finest, g)?;
        if params.fields {
            write_fields(out, lattice, g, study.fields.as_ref().expect("kept"))?;
        }
        ctx.progress(1.0, "written");
        Ok(StageReport::with_stats(level_stats(&study)))
    }
}

/// What downstream kinds read from a `critical` artefact.
#[derive(Clone, Debug)]
pub struct CriticalLevel {
    /// Model.
    pub lattice: Lattice,
    /// Grid exponent.
    pub n: u32,
    /// Grid spacing sqrt(dx·dy) (λ).
    pub h: f64,
    /// Shift rule m.
    pub shift_rule: usize,
    /// Shift averages (mean, sem) by name (`l_c`, `a_p_raw_x`, ...).
    pub values: Vec<(String, f64, f64)>,
    /// Sub-grid L_c and its error (NaN without a fit).
    pub l_c_subgrid: (f64, f64),
    /// ζ from the saddle gap and its error.
    pub zeta: (f64, f64),
    /// Full-contact pressure of the grid (mean over shifts).
    pub p_fc: f64,
    /// Polonsky–Keer iterations.
    pub iterations: i64,
}

impl CriticalLevel {
    /// Reads every level of a `critical` artefact, ascending n.
    pub fn read_all(r: &ArtefactReader) -> Result<Vec<Self>> {
        let lattice = lattice_from_name(&r.attr_str("lattice")?)?;
        let mut out = Vec::new();
        for name in r.members("level")? {
            out.push(Self::read(r, lattice, &format!("level/{name}"))?);
        }
        if out.is_empty() {
            bail!("{} has no levels", r.path().display());
        }
        out.sort_by_key(|l| l.n);
        Ok(out)
    }

    fn read(r: &ArtefactReader, lattice: Lattice, at: &str) -> Result<Self> {
        let a = |k: &str| r.attr_f64_at(at, k);
        let mut values = Vec::new();
        for q in ["l_c", "a_p_raw", "a_p_corrected"] {
            for sfx in ["", "_x", "_y"] {
                let k = format!("{q}{sfx}");
                values.push((k.clone(), a(&k)?, a(&format!("{k}_sem"))?));
            }
        }
        values.push((
            "p_fc_over_l_c".into(),
            a("p_fc_over_l_c")?,
            a("p_fc_over_l_c_sem")?,
        ));
        Ok(CriticalLevel {
            lattice,
            n: r.attr_i64_at(at, "n")? as u32,
            h: a("h")?,
            shift_rule: r.attr_i64_at(at, "shift_rule")? as usize,
            values,
            l_c_subgrid: (a("l_c_subgrid")?, a("l_c_subgrid_error")?),
            zeta: (a("zeta")?, a("zeta_error")?),
            p_fc: a("p_fc")?,
            iterations: r.attr_i64_at(at, "iterations")?,
        })
    }

    /// Fails unless this level was solved on the unshifted grid (shifts = 0): `user` (e.g.
    /// "the ladder") solves there and needs that grid's own L_c. `input` is the `critical`
    /// artefact's path, named in the error.
    pub fn require_unshifted(&self, input: &std::path::Path, user: &str) -> Result<()> {
        if self.shift_rule != 0 {
            bail!(
                "the `critical` input `{}` averages over {m}×{m} sub-grid shifts; {user} solves on \
                 the unshifted grid and needs its L_c: set shifts = 0 there",
                input.display(),
                m = self.shift_rule
            );
        }
        Ok(())
    }

    /// `(mean, sem)` of a named shift average.
    pub fn get(&self, name: &str) -> Option<(f64, f64)> {
        self.values
            .iter()
            .find(|(k, _, _)| k == name)
            .map(|(_, v, s)| (*v, *s))
    }
}
