//! `surface`: one of the three single-wavelength models sampled on a 2^n × 2^n grid.
//!
//! Parameters: `lattice` ("square", "triangular", "hexagonal"), `n` (3..=13).
//! Artefact: dataset `height` (nx, ny); root attributes `lx`, `ly`, `lattice`, `n`, `nx`, `ny`,
//! `dx`, `dy` and the statistics of the sampled heights (`h_min`, `h_max`, `h_mean`, `h_rms`,
//! `skewness`, `excess_kurtosis`, `p_fc_grid`); group `critical` with the exact critical points
//! (`kind` strings, `x`, `y`, `height`, `curvature_min`, `curvature_max`, `eta` (NaN except at
//! saddles)).

use anyhow::{Result, anyhow};
use orchestrator::{Inputs, ParamSpec, ParamType, Params, StageContext, StageReport, TypedKind};
use serde::Deserialize;
use serde_json::json;
use store::{ArtefactWriter, fields};
use surface::{CriticalKind, Lattice, Surface};

/// The `surface` stage kind.
pub struct SurfaceKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 1;

/// A `surface` artefact read back as a contact problem: the model on the stored grid and
/// heights, with the grid's full-contact pressure and the model's name and grid exponent.
pub struct SurfaceInput {
    /// The contact problem (grid, heights, elastic kernel).
    pub model: contact::Model,
    /// Cell size (λ).
    pub lx: f64,
    /// Cell size (λ).
    pub ly: f64,
    /// Nodes along x and y.
    pub nx: usize,
    /// Nodes along y.
    pub ny: usize,
    /// Full-contact pressure of the sampled heights (E* h0/λ).
    pub p_fc: f64,
    /// Model name.
    pub lattice: String,
    /// Grid exponent.
    pub n: i64,
}

impl SurfaceInput {
    /// Reads a `surface` artefact (unshifted grid).
    pub fn read(surf: &store::ArtefactReader) -> Result<Self> {
        let heights = surf.read_f64_2d(fields::HEIGHT)?;
        let (lx, ly) = surf.cell()?;
        let (nx, ny) = heights.dim();
        let grid = contact::Grid {
            nx,
            ny,
            lx,
            ly,
            shift: (0.0, 0.0),
        };
        Ok(Self {
            model: contact::Model::from_heights(grid, heights.view())
                .map_err(|e| anyhow!("{e}"))?,
            lx,
            ly,
            nx,
            ny,
            p_fc: surf.attr_f64("p_fc_grid")?,
            lattice: surf.attr_str("lattice")?,
            n: surf.attr_i64("n")?,
        })
    }
}

/// The `lattice` parameter: one of the three models.
pub fn lattice_spec() -> ParamSpec {
    ParamSpec::new(
        "lattice",
        ParamType::one_of(&["square", "triangular", "hexagonal"]),
    )
    .doc("which model")
}

/// Parses a lattice name (through `FromStr for Lattice`), e.g. a `lattice` attribute read back
/// from an artefact.
pub fn lattice_from_name(name: &str) -> Result<Lattice> {
    name.parse().map_err(|e| anyhow!("{e}"))
}

/// The `surface` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceParams {
    /// Which model.
    #[serde(deserialize_with = "crate::solver::from_str")]
    pub lattice: Lattice,
    /// Grid exponent: 2^n × 2^n nodes.
    pub n: u32,
}

/// Bytes of one `f64` field on a 2^n × 2^n grid.
pub fn field_bytes(n: i64) -> u64 {
    8u64 << (2 * n.clamp(0, 30) as u32)
}

impl TypedKind for SurfaceKind {
    type Params = SurfaceParams;
    /// Lower bound: the height field itself.
    fn memory_estimate(
        &self,
        params: &Params,
        _inputs: &std::collections::BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        params.i64("n").ok().map(field_bytes)
    }
    fn name(&self) -> &str {
        "surface"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "one of the three models on a 2^n × 2^n grid, with statistics and critical points"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            lattice_spec(),
            ParamSpec::new(
                "n",
                ParamType::int_range(surface::N_MIN as i64, surface::N_MAX as i64),
            )
            .doc("grid exponent: 2^n × 2^n nodes"),
        ]
    }
    fn cost(&self, params: &SurfaceParams) -> f64 {
        // sampling is cheap; weight by nodes relative to a 512² contact solve
        4f64.powi(params.n as i32) / 4f64.powi(9) * 0.01
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &SurfaceParams,
        _inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let (lattice, n) = (params.lattice, params.n);
        let s = Surface::new(lattice, n).map_err(|e| anyhow!("{e}"))?;
        ctx.progress(0.5, "sampled");
        let st = s.statistics();
        let g = &s.grid;
        out.set_cell(g.lx, g.ly)?;
        out.set_attr("lattice", lattice.name())?;
        out.set_attr("n", n as i64)?;
        write_grid_and_moments(out, g, &st)?;
        out.set_attr("p_fc_grid", s.p_fc_grid())?;
        out.write_f64_2d(fields::HEIGHT, s.heights.view())?;
        let cps = s.critical_points();
        let kind = |k: CriticalKind| match k {
            CriticalKind::Maximum => "maximum",
            CriticalKind::Minimum => "minimum",
            CriticalKind::Saddle => "saddle",
        };
        // written column by column, not as a record of the formats crate: that crate depends on
        // contact and reynolds, which would enter this kind's code identity (an edit of the
        // flow solver would recompute every lattice surface)
        let names: Vec<&str> = cps.iter().map(|c| kind(c.kind)).collect();
        out.write_strings("critical/kind", &names)?;
        out.write_f64_1d("critical/x", &cps.iter().map(|c| c.x).collect::<Vec<_>>())?;
        out.write_f64_1d("critical/y", &cps.iter().map(|c| c.y).collect::<Vec<_>>())?;
        out.write_f64_1d(
            "critical/height",
            &cps.iter().map(|c| c.height).collect::<Vec<_>>(),
        )?;
        out.write_f64_1d(
            "critical/curvature_min",
            &cps.iter().map(|c| c.curvatures[0]).collect::<Vec<_>>(),
        )?;
        out.write_f64_1d(
            "critical/curvature_max",
            &cps.iter().map(|c| c.curvatures[1]).collect::<Vec<_>>(),
        )?;
        out.write_f64_1d(
            "critical/eta",
            &cps.iter()
                .map(|c| c.eta().unwrap_or(f64::NAN))
                .collect::<Vec<_>>(),
        )?;
        ctx.progress(1.0, "written");
        Ok(StageReport::with_stats(json!({
            "nodes": g.nx * g.ny,
            "critical_points": cps.len(),
        })))
    }
}

/// The part of the surface-artefact layout every height-field kind shares (this kind,
/// `selfaffine`, `topography`): the grid's root attributes `nx`, `ny`, `dx`, `dy` and the
/// moments of the heights `h_min`, `h_max`, `h_mean`, `h_rms`, `skewness`, `excess_kurtosis`.
pub(crate) fn write_grid_and_moments(
    out: &mut ArtefactWriter,
    g: &surface::Grid,
    st: &surface::Statistics,
) -> Result<()> {
    out.set_attr("nx", g.nx as i64)?;
    out.set_attr("ny", g.ny as i64)?;
    out.set_attr("dx", g.dx())?;
    out.set_attr("dy", g.dy())?;
    out.set_attr("h_min", st.min)?;
    out.set_attr("h_max", st.max)?;
    out.set_attr("h_mean", st.mean)?;
    out.set_attr("h_rms", st.rms)?;
    out.set_attr("skewness", st.skewness)?;
    out.set_attr("excess_kurtosis", st.excess_kurtosis)?;
    Ok(())
}
