//! The `sweep` artefact's records and attributes: written by [`crate::sweep`], read back by
//! [`SweepData::read`] (the flow kind and the scenes read through it). The layout is described
//! in the [`crate::sweep`] module doc; each table below is one [`formats::record!`]
//! declaration, so its writer, reader and column list cannot drift apart.

use crate::sweep_params::{LoadUnit, SweepParams};
use anyhow::{Context, Result};
use contact::path::Branch;
use contact::{Interaction, Solution};
use formats::records::{Record, read_in};
use std::fmt;
use store::{ArtefactReader, ArtefactWriter};

/// A hysteresis loop between the branches: see [`analysis::hysteresis`]; `x` in control values
/// (loads in E* h0/λ, or strengths).
pub use analysis::hysteresis::Loop;
pub use analysis::hysteresis::{Thresholds, Transition};

formats::record! {
    /// One solved point (`points/*`).
    #[derive(Clone, Debug, PartialEq)]
    pub struct Point {
        /// Loading (control increasing) or unloading.
        pub branch: Branch,
        /// Index in the planned path (forward and reverse numbered continuously).
        pub step: i64,
        /// Mean pressure (E* h0/λ).
        pub load: f64,
        /// γ0 or γr (0 for the hard wall).
        pub strength: f64,
        /// Relative contact area (fraction of nodes with g = 0).
        pub contact_area: f64,
        /// Perimeter-corrected contact area.
        pub contact_area_corrected: f64,
        /// Mean gap (h0).
        pub mean_gap: f64,
        /// Mean of u (h0).
        pub mean_displacement: f64,
        /// Energy per area.
        pub energy: f64,
        /// Minimiser iterations.
        pub iterations: i64,
        /// Final constraint violation.
        pub max_violation: f64,
        /// Final force residual.
        pub force_residual: f64,
        /// Met the tolerance.
        pub converged: bool,
        /// Why it did not converge ("" if it did).
        pub stop_reason: String,
        /// Wall time of the solve (s).
        pub wall_s: f64,
        /// Contact clusters (8-connected).
        pub contact_clusters: i64,
        /// Fluid (4-connected) wraps along x.
        pub fluid_percolates_x: bool,
        /// Fluid wraps along y.
        pub fluid_percolates_y: bool,
        /// A refinement point (a bisection midpoint of a step that jumped, `refine_jumps`),
        /// not in the plan: `step` is the planned point it precedes.
        pub refined: bool,
    }
}

impl Point {
    /// The fluid wraps along x or y.
    pub fn fluid(&self) -> bool {
        self.fluid_percolates_x || self.fluid_percolates_y
    }
}

/// Which detector found a jump.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Detector {
    /// [`analysis::detect_jumps`]: larger than the neighbours' trend.
    Trend,
    /// An end of a hysteresis loop the trend detector missed ([`Loop`]).
    Loop,
}

impl fmt::Display for Detector {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Detector::Trend => "trend",
            Detector::Loop => "loop",
        })
    }
}

impl std::str::FromStr for Detector {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "trend" => Ok(Detector::Trend),
            "loop" => Ok(Detector::Loop),
            _ => Err(format!("detector `{s}`: allowed trend, loop")),
        }
    }
}

formats::text_column!(Detector);

formats::record! {
    /// One detected jump (`jumps/*`).
    #[derive(Clone, Debug, PartialEq)]
    pub struct JumpRow {
        /// Branch.
        pub branch: Branch,
        /// Point index before the jump.
        pub index: usize,
        /// Point index after the jump (the next converged point of the branch).
        pub index_after: usize,
        /// Load before (E* h0/λ).
        pub load_before: f64,
        /// Load after.
        pub load_after: f64,
        /// Strength before.
        pub strength_before: f64,
        /// Strength after.
        pub strength_after: f64,
        /// Area before.
        pub area_before: f64,
        /// Area after.
        pub area_after: f64,
        /// Jump size over the neighbours' trend (NaN for a loop end the trend detector missed).
        pub ratio: f64,
        /// [`analysis::hysteresis::classify`].
        pub event: String,
        /// Which detector found it.
        pub detector: Detector,
    }
}

impl JumpRow {
    /// Loads before and after (E* h0/λ).
    pub fn load(&self) -> (f64, f64) {
        (self.load_before, self.load_after)
    }
    /// Strengths before and after.
    pub fn strength(&self) -> (f64, f64) {
        (self.strength_before, self.strength_after)
    }
    /// Areas before and after.
    pub fn area(&self) -> (f64, f64) {
        (self.area_before, self.area_after)
    }
}

formats::record! {
    /// A hysteresis loop as stored (`loops/*`): [`Loop`] with its range split.
    #[derive(Clone, Debug, PartialEq)]
    pub struct LoopRow {
        /// Lower control value.
        pub x_lo: f64,
        /// Upper control value.
        pub x_hi: f64,
        /// Largest area difference between the branches.
        pub max_area_difference: f64,
        /// Where it is largest.
        pub x_at_max: f64,
    }
}

impl From<&Loop> for LoopRow {
    fn from(l: &Loop) -> Self {
        LoopRow {
            x_lo: l.x.0,
            x_hi: l.x.1,
            max_area_difference: l.max_area_difference,
            x_at_max: l.x_at_max,
        }
    }
}

impl From<LoopRow> for Loop {
    fn from(l: LoopRow) -> Self {
        Loop {
            x: (l.x_lo, l.x_hi),
            max_area_difference: l.max_area_difference,
            x_at_max: l.x_at_max,
        }
    }
}

formats::record! {
    /// A branch that ended early (`ended/*`).
    #[derive(Clone, Debug, PartialEq)]
    pub struct Ended {
        /// Branch.
        pub branch: Branch,
        /// The load at which no equilibrium was found (E* h0/λ).
        pub load: f64,
        /// The strength there.
        pub strength: f64,
        /// Why.
        pub message: String,
    }
}

formats::record! {
    /// A topological threshold the path crosses (`thresholds/*`, strength paths).
    #[derive(Clone, Debug, PartialEq)]
    pub struct ThresholdRow {
        /// One of [`Thresholds::NAMES`].
        pub name: String,
        /// Control value (strength) before.
        pub x_before: f64,
        /// Control value after.
        pub x_after: f64,
        /// Area before.
        pub area_before: f64,
        /// Area after.
        pub area_after: f64,
    }
}

/// The rows of the thresholds found.
fn threshold_rows(t: &Thresholds) -> Vec<ThresholdRow> {
    t.all()
        .into_iter()
        .filter_map(|(name, tr)| {
            tr.map(|tr| ThresholdRow {
                name: name.into(),
                x_before: tr.x.0,
                x_after: tr.x.1,
                area_before: tr.area.0,
                area_after: tr.area.1,
            })
        })
        .collect()
}

/// The thresholds of `thresholds/*` (none if the artefact has none: a load path).
fn read_thresholds(r: &ArtefactReader) -> Result<Thresholds> {
    let mut t = Thresholds::default();
    if !r.has_dataset("thresholds/name") {
        return Ok(t);
    }
    for row in read_in::<ThresholdRow>(r, "thresholds")? {
        let tr = Transition {
            x: (row.x_before, row.x_after),
            area: (row.area_before, row.area_after),
        };
        if !t.set(&row.name, tr) {
            anyhow::bail!(
                "`thresholds/name`: `{}`; allowed {}",
                row.name,
                Thresholds::NAMES.join(", ")
            );
        }
    }
    Ok(t)
}

/// A sweep artefact, read back (for the flow kind and the scenes).
#[derive(Clone, Debug, PartialEq)]
pub struct SweepData {
    /// hardwall, adhesion or repulsion.
    pub interaction: String,
    /// load or strength.
    pub control: String,
    /// Full-contact pressure of the grid (E* h0/λ).
    pub p_fc: f64,
    /// Surface model.
    pub lattice: String,
    /// Grid exponent.
    pub n: i64,
    /// Points in path order.
    pub points: Vec<Point>,
    /// Detected jumps.
    pub jumps: Vec<JumpRow>,
    /// Hysteresis loops between the branches.
    pub loops: Vec<Loop>,
    /// Branches that ended early.
    pub ended: Vec<Ended>,
    /// A strength path's topological thresholds (none on a load path).
    pub thresholds: Thresholds,
}

impl SweepData {
    /// Reads a `sweep` artefact.
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let ctx = || format!("reading sweep artefact `{}`", r.path().display());
        (|| -> Result<Self> {
            Ok(SweepData {
                interaction: r.attr_str("interaction")?,
                control: r.attr_str("control")?,
                p_fc: r.attr_f64("p_fc")?,
                lattice: r.attr_str("lattice")?,
                n: r.attr_i64("n")?,
                points: read_in(r, "points")?,
                jumps: read_in(r, "jumps")?,
                loops: read_in::<LoopRow>(r, "loops")?
                    .into_iter()
                    .map(Loop::from)
                    .collect(),
                ended: read_in(r, "ended")?,
                thresholds: read_thresholds(r)?,
            })
        })()
        .with_context(ctx)
    }

    /// Reads only the points of a `sweep` artefact.
    pub fn read_points(r: &ArtefactReader) -> Result<Vec<Point>> {
        read_in(r, "points")
    }

    /// Indices of the points of `branch`, in path order.
    pub fn branch_indices(&self, branch: Branch) -> Vec<usize> {
        (0..self.points.len())
            .filter(|&k| self.points[k].branch == branch)
            .collect()
    }
}

/// The group of a sweep point's fields: `fields/<branch>_<index>`.
pub fn fields_group(branch: Branch, index: usize) -> String {
    format!("fields/{branch}_{index}")
}

/// `fields/<branch>_<index>/{gap,displacement,pressure}` of the `index`-th solved point.
pub fn write_fields(
    out: &mut ArtefactWriter,
    point: &Point,
    index: usize,
    sol: &Solution,
) -> Result<()> {
    let g = fields_group(point.branch, index);
    out.write_f64_2d(&format!("{g}/gap"), sol.gap.view())?;
    out.write_f64_2d(&format!("{g}/displacement"), sol.displacement.view())?;
    out.write_f64_2d(&format!("{g}/pressure"), sol.pressure.view())?;
    out.set_attr_at(&g, "load", point.load)?;
    out.set_attr_at(&g, "strength", point.strength)?;
    out.set_attr_at(&g, "contact_area", point.contact_area)?;
    Ok(())
}

/// What the artefact holds besides the attributes.
pub struct Sweep<'a> {
    /// Points in path order.
    pub points: &'a [Point],
    /// Jumps, by branch then index.
    pub jumps: &'a [JumpRow],
    /// Hysteresis loops.
    pub loops: &'a [Loop],
    /// Branches that ended early.
    pub ended: &'a [Ended],
    /// A strength path's thresholds.
    pub thresholds: Option<&'a Thresholds>,
}

/// The root attributes' values that the run computes.
pub struct Attrs<'a> {
    /// The parameters.
    pub params: &'a SweepParams,
    /// The surface.
    pub surface: &'a crate::surface::SurfaceInput,
    /// p_fc or 1.
    pub unit_scale: f64,
    /// Cohesive-zone length and the grid spacings it spans.
    pub zone: (Option<f64>, f64),
    /// Non-converged points.
    pub n_unconverged: usize,
}

/// Writes the root attributes and the record tables.
pub fn write(out: &mut ArtefactWriter, a: &Attrs, s: &Sweep) -> Result<()> {
    let (surface, base) = (a.surface, a.params.interaction());
    out.set_cell(surface.lx, surface.ly)?;
    out.set_attr("interaction", base.name())?;
    if let Interaction::Adhesion { gamma0, .. } = base {
        out.set_attr("gamma0", gamma0)?;
    }
    if let Interaction::Repulsion { gamma_r, .. } = base {
        out.set_attr("gamma_r", gamma_r)?;
    }
    out.set_attr("rho", base.range())?;
    out.set_attr("control", a.params.control.name())?;
    out.set_attr("unit", a.params.unit.name())?;
    out.set_attr("unit_scale", a.unit_scale)?;
    out.set_attr("p_fc", surface.p_fc)?;
    out.set_attr("lattice", surface.lattice.as_str())?;
    out.set_attr("n", surface.n)?;
    out.set_attr("nx", surface.nx as i64)?;
    out.set_attr("ny", surface.ny as i64)?;
    out.set_attr("dx", surface.lx / surface.nx as f64)?;
    out.set_attr("cohesive_zone_length", a.zone.0.unwrap_or(f64::NAN))?;
    out.set_attr("zone_spacings", a.zone.1)?;
    out.set_attr("n_points", s.points.len() as i64)?;
    out.set_attr("n_unconverged", a.n_unconverged as i64)?;
    Point::write(s.points, out, "points")?;
    JumpRow::write(s.jumps, out, "jumps")?;
    let loops: Vec<LoopRow> = s.loops.iter().map(LoopRow::from).collect();
    LoopRow::write(&loops, out, "loops")?;
    Ended::write(s.ended, out, "ended")?;
    if let Some(t) = s.thresholds {
        ThresholdRow::write(&threshold_rows(t), out, "thresholds")?;
    }
    Ok(())
}

/// The unit scale of a sweep's loads: p_fc or 1.
pub fn unit_scale(unit: LoadUnit, p_fc: f64) -> f64 {
    match unit {
        LoadUnit::PFc => p_fc,
        LoadUnit::Absolute => 1.0,
    }
}
