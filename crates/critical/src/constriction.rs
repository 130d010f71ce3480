//! The last constriction of a seal on any height field and the near-critical ladder below its
//! fluid percolation load (issue 15): L_c by bisection, a ladder of reduced loads below it, and
//! at every rung the certified Reynolds flux, the last constriction (position, local gap, the
//! saddle's curvature ratio η of the heights and of the gap, the fraction of the pressure drop
//! across a small window around it), the running exponents of the flux and of the constriction's
//! gap between neighbouring rungs, and the β fit over a window of rungs.
//!
//! # Criterion and axis
//! L_c is the `any` transition of [`crate::leakage::percolation_load`]: above it the fluid
//! percolates along no axis (the paper's "the seal closes"). Just below it the fluid winds along
//! the axis that closes last; that axis is the flow axis of the whole ladder (x if both still
//! wind at the bracket's lower end).
//!
//! # Seeded bracket
//! L_c's search may start from the brackets of another search on the same field, periodic
//! boundary and winding criterion (`seed`: a `leakage` stage brackets the same three
//! transitions with the same solver to a coarser width). The seed is a guess only: its ends are
//! re-solved here and each criterion must be open at its `lo` and blocked at its `hi`;
//! otherwise it is rejected (a note says which end failed) and the search starts from the
//! default guess. Either way every end of the final brackets was probed by this search, and the
//! result agrees with an unseeded search to `rel_width` (the probes differ, so the last bits
//! of L_c may).
//!
//! # The constriction ([`analyse_constriction`])
//! The maximin bottleneck of [`percolation::last_constriction`] along the flow axis. On a generic
//! field it is one node. On symmetric fields (the lattices) several nodes are tied; the node
//! reported is the essential junction if there is one, otherwise the junction with the smallest
//! gradient of the gap (central differences): a saddle is a critical point, while the tied
//! nodes of the lattices' level lines that also join troughs are not. Curvatures: the heights'
//! Hessian with the eighth-order stencil (the undeformed surface is smooth to its sampling);
//! the gap's with the eighth-order stencil if no node of its 9 × 9 block is in contact, else
//! second order if its 3 × 3 block is open, else none (the gap is only C¹ across contact lines,
//! [`surface::curvature`]); [`GapCurvatureStatus`] says which, or why there is none (a one-node
//! throat just below L_c has contact in its 3 × 3 block on most random surfaces). η = −f''∥/f''⊥ with the channel descending in h and ascending in g.
//! `width_nodes`: the number of contiguous open nodes through the bottleneck along x and along y,
//! the smaller of the two — how many nodes resolve the throat.
//!
//! # Pressure drop
//! The fraction of the mean pressure drop per period (ΔP = 1) taken at the constriction: the
//! spread max − min of the pressure over the flowing nodes of the (2w+1)² square around the
//! bottleneck (w = `window_half_length`, pressure continued across the cell boundary along the
//! flow). It does not depend on the throat's orientation, which on a random surface is any; a
//! uniform channel along the flow gives 2w/n, a closing throat drives it to 1 (the ponds on
//! either side are at uniform pressure). It overestimates the throat's share if another
//! channel with a different pressure passes through the square. The directional measure of
//! [`reynolds::pressure_drop_fraction`] (faces across the flow axis) is reported beside it; it is
//! negative where the throat's channel runs against the flow axis.
//!
//! # Ladder
//! Distances d = (L_c − L)/L_c > 0 (the reduced load is l = −d), by default the 1-2-5 sequence
//! 5e-2, 2e-2, 1e-2, … down to 1e-4 ([`ladder_125`]); solved in ascending load (largest d
//! first), each warm-started from the previous one, then once more at the bracket's lower end
//! (just below L_c, for the constriction "at L_c"). A rung is *resolved* when the contact solve
//! converged, the flux is certified (percolating, flow converged, flux > 0: as the lattices'
//! ladder), the throat is at least `min_width` nodes wide, and the rung is not in the *affine
//! regime*: while the contact set around the constriction stays the one it has at L_c, the
//! hard-wall gap there is affine in the load, so the throat's gap closes linearly (g ∝ d) and the
//! flux of a one-node throat goes as g³ ∝ d³ — exponents of the grid, not of the saddle. A rung
//! counts only if at least `min_contact_changes` nodes within `affine_radius` of the
//! constriction at L_c have another contact state than just below L_c. With
//! `same_constriction_only` (default) a rung also needs its constriction to be the one at L_c
//! (within 2 nodes): far from L_c another bottleneck can be the narrowest. Only resolved rungs enter the
//! running exponents and the fits; the others are reported with the reason.
//!
//! # Errors of the exponents
//! Running exponents ([`analysis::local_slopes`]): flux with σ = flux × the flow solver's
//! a-posteriori relative error estimate, constriction gap with σ = the contact tolerance
//! (`tol_gap`). These are the measurement errors only; no grid error is available from one grid
//! (the CLI and the ensemble say so). The β window fit is a least-squares power law in log–log
//! ([`crate::scaling::fit_exponent`]), 1σ scaled by the reduced χ²; it needs 3 rungs (with two, the
//! single running exponent is the only value).
//!
//! No I/O.

use crate::bracket::{BracketSeed, SeedOutcome};
use crate::leakage::{Boundary, PercolationOptions, percolation_load};
use crate::scaling::{ExponentFit, fit_exponent};
use crate::{CriticalError, FlowState};
pub use analysis::RunningSlope;
use analysis::{ScalingPoint, local_slopes};
use contact::{Method, Model, Solution, SolverOptions};
use ndarray::{Array2, ArrayView2};
use percolation::{Axis, last_constriction};
use reynolds::{FlowAxis, FlowOptions, PressureDrop, Window, pressure_drop_fraction};
use std::time::Instant;
use surface::{Channel, HeightField, Stencil, saddle_curvature};

/// The 1-2-5 sequence from `d_max` down to `d_min` (both inclusive where they are members):
/// 5e-2, 2e-2, 1e-2, 5e-3, … Values are exact decimal members (mantissa 1, 2 or 5).
pub fn ladder_125(d_max: f64, d_min: f64) -> Vec<f64> {
    let mut out = Vec::new();
    if !(d_max.is_finite() && d_min.is_finite() && d_max > 0.0 && d_min > 0.0) {
        return out;
    }
    let top = d_max.log10().ceil() as i32 + 1;
    let bottom = d_min.log10().floor() as i32 - 1;
    for e in (bottom..=top).rev() {
        for m in [5.0, 2.0, 1.0] {
            let v: f64 = format!("{m}e{e}").parse().expect("a decimal literal");
            // relative slack: d_max = 5e-2 given as 0.05 must count as a member
            if v <= d_max * (1.0 + 1e-12) && v >= d_min * (1.0 - 1e-12) {
                out.push(v);
            }
        }
    }
    out
}

/// Options of [`constriction_study`].
#[derive(Clone, Debug, PartialEq)]
pub struct ConstrictionOptions {
    /// Polonsky–Keer tolerance on the constraint violation (h0). Default 1e-10.
    pub tol_gap: f64,
    /// Iteration cap per contact solve. Default 200 000.
    pub max_iter: usize,
    /// Relative bracket width of L_c. Default 1e-9.
    pub rel_width: f64,
    /// Distances d = (L_c − L)/L_c of the rungs, each in (0, 1). Default
    /// `ladder_125(5e-2, 1e-4)`.
    pub ladder: Vec<f64>,
    /// Nodes the throat must be wide for a rung to count as resolved. Default 2.
    pub min_width: usize,
    /// Half-size (nodes) of the square around the constriction at L_c in which the contact set
    /// of a rung is compared with the one just below L_c. Default 8.
    pub affine_radius: usize,
    /// Nodes in that square whose contact state must differ from L_c's for the rung to count
    /// as resolved (module docs, "affine regime"). Default 1; 0 switches the check off.
    pub min_contact_changes: usize,
    /// Pressure-drop window: half-size of the square around the bottleneck, and nodes on each
    /// side of it along the flow for the directional measure. Default 2.
    pub window_half_length: usize,
    /// Pressure-drop window: nodes on each side across the flow. Default 4.
    pub window_half_width: usize,
    /// The β fit uses the resolved rungs with d in this closed range. Default (0, 1).
    pub fit_window: (f64, f64),
    /// Reynolds solver options.
    pub flow: FlowOptions,
    /// Keep the gap just below L_c (for maps). Default false.
    pub keep_gap: bool,
    /// Only rungs whose constriction is the one at L_c (within 2 nodes) count as resolved: the
    /// claim is about the single critical constriction. Default true.
    pub same_constriction_only: bool,
    /// Starting brackets (any, x, y) of the percolation search from another search on this
    /// field and criterion (a `leakage` stage's, to a coarser width): confirmed by probes
    /// before use, rejected with a note otherwise (module docs, "Seeded bracket"). Default none.
    pub seed: Option<BracketSeed>,
}

impl Default for ConstrictionOptions {
    fn default() -> Self {
        ConstrictionOptions {
            tol_gap: 1e-10,
            max_iter: 200_000,
            rel_width: 1e-9,
            ladder: ladder_125(5e-2, 1e-4),
            min_width: 2,
            affine_radius: 8,
            min_contact_changes: 1,
            window_half_length: 2,
            window_half_width: 4,
            fit_window: (0.0, 1.0),
            flow: FlowOptions::default(),
            keep_gap: false,
            same_constriction_only: true,
            seed: None,
        }
    }
}

impl ConstrictionOptions {
    /// Checks the options; the error names the option and the allowed range.
    pub fn validate(&self) -> Result<(), CriticalError> {
        if !(self.tol_gap > 0.0 && self.tol_gap <= contact::TOL_GAP_MAX) {
            return Err(CriticalError::param(
                "tol_gap",
                self.tol_gap,
                "0 < tol_gap ≤ 1e-3 (h0; contact::TOL_GAP_MAX)",
            ));
        }
        if !(self.rel_width.is_finite() && self.rel_width > 0.0 && self.rel_width < 1e-2) {
            return Err(CriticalError::param(
                "rel_width",
                self.rel_width,
                "in (0, 1e-2) (relative bracket width of L_c)",
            ));
        }
        if self.ladder.is_empty() {
            return Err(CriticalError::Parameter {
                name: "ladder",
                value: "[]".into(),
                allowed: "at least one distance d = (L_c − L)/L_c in (0, 1)",
            });
        }
        if let Some(&d) = self
            .ladder
            .iter()
            .find(|d| !(d.is_finite() && **d > 0.0 && **d < 1.0))
        {
            return Err(CriticalError::param(
                "ladder",
                d,
                "distances d = (L_c − L)/L_c in (0, 1)",
            ));
        }
        if self.min_width == 0 {
            return Err(CriticalError::param("min_width", 0.0, "≥ 1 node"));
        }
        let (a, b) = self.fit_window;
        if !(a.is_finite() && b.is_finite() && a >= 0.0 && b > a) {
            return Err(CriticalError::Parameter {
                name: "fit_window",
                value: format!("({a}, {b})"),
                allowed: "0 ≤ d_lo < d_hi",
            });
        }
        Ok(())
    }
}

/// Curvatures of one field at the bottleneck.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curvature {
    /// f''∥ (field units per λ²).
    pub along: f64,
    /// f''⊥.
    pub across: f64,
    /// η = −f''∥/f''⊥.
    pub eta: f64,
    /// The Hessian's eigenvalues have opposite signs.
    pub is_saddle: bool,
    /// "eighth" or "second".
    pub stencil: &'static str,
}

/// The last constriction of one gap field.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstrictionInfo {
    /// Flow axis.
    pub axis: Axis,
    /// Node of the reported bottleneck (module docs).
    pub node: (usize, usize),
    /// Position (cell units).
    pub x: f64,
    /// Position (cell units).
    pub y: f64,
    /// The maximin gap g* (h0).
    pub gap: f64,
    /// Nodes tied with the bottleneck (1 on a generic field).
    pub tied: usize,
    /// Closing the reported node alone stops the winding (None if not checked).
    pub essential: Option<bool>,
    /// Heights' curvatures at the node (channel descending).
    pub height: Option<Curvature>,
    /// Gap's curvatures at the node (channel ascending); None where contact is too close.
    pub gap_curvature: Option<Curvature>,
    /// Which stencil gave `gap_curvature`, or why there is none ([`GapCurvatureStatus`]).
    pub gap_curvature_status: GapCurvatureStatus,
    /// Open nodes through the bottleneck, the smaller of the x and y runs.
    pub width_nodes: usize,
}

/// How the gap's curvature at the bottleneck was measured, or why it was not: the gap is only
/// C¹ across a contact line, so no stencil that reaches a contact node measures a curvature.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GapCurvatureStatus {
    /// Eighth-order stencil: the 9 × 9 block around the node is open.
    Eighth,
    /// Second-order stencil: contact within the 9 × 9 block, the 3 × 3 block open.
    Second,
    /// Undefined: this many nodes of the 3 × 3 block are in contact (a throat one or two nodes
    /// wide whose walls touch the neighbours).
    ContactInStencil(usize),
    /// Undefined: the stencil could not be evaluated (a grid smaller than the stencil).
    StencilError,
}

impl GapCurvatureStatus {
    /// A short code for tables: `eighth`, `second`, `contact_in_3x3`, `stencil_error`.
    pub fn code(&self) -> &'static str {
        match self {
            GapCurvatureStatus::Eighth => "eighth",
            GapCurvatureStatus::Second => "second",
            GapCurvatureStatus::ContactInStencil(_) => "contact_in_3x3",
            GapCurvatureStatus::StencilError => "stencil_error",
        }
    }
}

fn curvature(
    field: ArrayView2<f64>,
    dx: f64,
    dy: f64,
    node: (usize, usize),
    channel: Channel,
    stencil: Stencil,
) -> Option<Curvature> {
    let c = saddle_curvature(field, dx, dy, node.0, node.1, channel, stencil).ok()?;
    Some(Curvature {
        along: c.along,
        across: c.across,
        eta: c.eta,
        is_saddle: c.is_saddle,
        stencil: match stencil {
            Stencil::Eighth => "eighth",
            Stencil::Second => "second",
        },
    })
}

/// Nodes in contact (g ≤ 0) in the (2k+1)² block around `node`, periodic.
fn block_contacts(gap: ArrayView2<f64>, node: (usize, usize), k: usize) -> usize {
    let (nx, ny) = gap.dim();
    let k = k as isize;
    let mut count = 0;
    for a in -k..=k {
        for b in -k..=k {
            let i = (node.0 as isize + a).rem_euclid(nx as isize) as usize;
            let j = (node.1 as isize + b).rem_euclid(ny as isize) as usize;
            if gap[[i, j]] <= 0.0 {
                count += 1;
            }
        }
    }
    count
}

/// Contiguous open nodes through `node` along x and along y (periodic; capped at the grid).
fn open_runs(gap: ArrayView2<f64>, node: (usize, usize)) -> (usize, usize) {
    let (nx, ny) = gap.dim();
    let run = |n: usize, at: &dyn Fn(usize) -> f64, c: usize| {
        if at(c) <= 0.0 {
            return 0;
        }
        let mut count = 1;
        for s in 1..n {
            if at((c + s) % n) > 0.0 {
                count += 1;
            } else {
                break;
            }
        }
        if count == n {
            return n;
        }
        for s in 1..n {
            if at((c + n - s) % n) > 0.0 {
                count += 1;
            } else {
                break;
            }
        }
        count.min(n)
    };
    let rx = run(nx, &|i| gap[[i, node.1]], node.0);
    let ry = run(ny, &|j| gap[[node.0, j]], node.1);
    (rx, ry)
}

/// Nodes of the (2r+1)² square around `node` whose contact state (g = 0) differs between the
/// two gap fields (periodic).
fn contact_changes(
    a: ArrayView2<f64>,
    b: ArrayView2<f64>,
    node: (usize, usize),
    r: usize,
) -> usize {
    let (nx, ny) = a.dim();
    let r = r.min(nx / 2).min(ny / 2) as isize;
    let mut k = 0;
    for di in -r..=r {
        for dj in -r..=r {
            let i = (node.0 as isize + di).rem_euclid(nx as isize) as usize;
            let j = (node.1 as isize + dj).rem_euclid(ny as isize) as usize;
            if (a[[i, j]] <= 0.0) != (b[[i, j]] <= 0.0) {
                k += 1;
            }
        }
    }
    k
}

/// |∇f|² at a node by second-order central differences (periodic).
fn gradient_sq(f: ArrayView2<f64>, dx: f64, dy: f64, (i, j): (usize, usize)) -> f64 {
    let (nx, ny) = f.dim();
    let gx = (f[[(i + 1) % nx, j]] - f[[(i + nx - 1) % nx, j]]) / (2.0 * dx);
    let gy = (f[[i, (j + 1) % ny]] - f[[i, (j + ny - 1) % ny]]) / (2.0 * dy);
    gx * gx + gy * gy
}

/// The last constriction of `gap` along `axis` on the periodic `lx × ly` cell, with the
/// curvatures of `heights` and of `gap` at it (module docs). `tie_tolerance` as in
/// [`percolation::last_constriction`]: 1e-12 for sampled analytic fields, 0 for computed gaps.
/// `None` if the fluid does not wind along `axis`.
pub fn analyse_constriction(
    heights: ArrayView2<f64>,
    gap: ArrayView2<f64>,
    lx: f64,
    ly: f64,
    axis: Axis,
    tie_tolerance: f64,
) -> Result<Option<ConstrictionInfo>, CriticalError> {
    if heights.dim() != gap.dim() {
        return Err(CriticalError::Surface(format!(
            "heights {:?} and gap {:?} differ in shape",
            heights.dim(),
            gap.dim()
        )));
    }
    let Some(c) = last_constriction(gap, lx, ly, axis, tie_tolerance)
        .map_err(|e| CriticalError::Surface(format!("last constriction: {e}")))?
    else {
        return Ok(None);
    };
    let (nx, ny) = gap.dim();
    let (dx, dy) = (lx / nx as f64, ly / ny as f64);
    // The reported node: the essential junction, else the junction nearest to a critical point
    // of the gap, else the completing node.
    let pick = c
        .tied
        .iter()
        .find(|b| b.essential == Some(true) && b.junction == Some(true))
        .or_else(|| {
            c.bottlenecks().min_by(|a, b| {
                gradient_sq(gap, dx, dy, (a.i, a.j)).total_cmp(&gradient_sq(
                    gap,
                    dx,
                    dy,
                    (b.i, b.j),
                ))
            })
        })
        .copied()
        .unwrap_or(c.completing);
    let node = (pick.i, pick.j);
    let height = curvature(heights, dx, dy, node, Channel::Descending, Stencil::Eighth);
    let (gap_curvature, gap_curvature_status) =
        if block_contacts(gap, node, Stencil::Eighth.half_width()) == 0 {
            (
                curvature(gap, dx, dy, node, Channel::Ascending, Stencil::Eighth),
                GapCurvatureStatus::Eighth,
            )
        } else {
            match block_contacts(gap, node, 1) {
                0 => (
                    curvature(gap, dx, dy, node, Channel::Ascending, Stencil::Second),
                    GapCurvatureStatus::Second,
                ),
                k => (None, GapCurvatureStatus::ContactInStencil(k)),
            }
        };
    let gap_curvature_status = if gap_curvature.is_none()
        && matches!(
            gap_curvature_status,
            GapCurvatureStatus::Eighth | GapCurvatureStatus::Second
        ) {
        GapCurvatureStatus::StencilError
    } else {
        gap_curvature_status
    };
    let (rx, ry) = open_runs(gap, node);
    Ok(Some(ConstrictionInfo {
        axis,
        node,
        x: pick.x,
        y: pick.y,
        gap: pick.gap,
        tied: c.tied.len().max(1),
        essential: pick.essential,
        height,
        gap_curvature,
        gap_curvature_status,
        width_nodes: rx.min(ry),
    }))
}

/// One rung of the ladder (or the state just below L_c).
#[derive(Clone, Debug)]
pub struct ConstrictionRung {
    /// d = (L_c − L)/L_c.
    pub d: f64,
    /// Load (E* h0/λ).
    pub load: f64,
    /// Raw contact area fraction.
    pub contact_area: f64,
    /// The contact solve converged.
    pub converged: bool,
    /// Flux along the flow axis for a unit pressure drop (0 if not percolating).
    pub flux: f64,
    /// The flow solver's a-posteriori relative error estimate of the flux.
    pub flux_error: f64,
    /// The flow solve converged (flux trustworthy).
    pub flow_converged: bool,
    /// The fluid winds along the flow axis.
    pub percolating: bool,
    /// The last constriction (None if the fluid does not wind).
    pub constriction: Option<ConstrictionInfo>,
    /// Pressure-drop fraction at the bottleneck ([`ThroatFlow::drop`]).
    pub drop: Option<f64>,
    /// The directional measure ([`ThroatFlow::drop_axial`]).
    pub drop_axial: Option<PressureDrop>,
    /// Resolved (module docs): used in the exponents.
    pub resolved: bool,
    /// Nodes within `affine_radius` of the constriction at L_c whose contact state differs
    /// from the state just below L_c (0 for that state itself).
    pub contact_changes: usize,
    /// The constriction is the one at L_c (within 2 nodes, periodic); true for that state.
    pub same_constriction: bool,
    /// Why not resolved, or what else went wrong.
    pub note: Option<String>,
    /// Polonsky–Keer iterations of this solve.
    pub iterations: usize,
}

/// Everything [`constriction_study`] finds on one field.
#[derive(Clone, Debug)]
pub struct ConstrictionStudy {
    /// Periodic full-contact pressure (E* h0/λ).
    pub p_fc: f64,
    /// L_c: midpoint of the `any` bracket.
    pub l_c: f64,
    /// The `any` bracket (lo: fluid winds; hi: blocked).
    pub bracket: (f64, f64),
    /// Single-axis transitions (midpoints).
    pub l_c_x: f64,
    /// Single-axis transitions (midpoints).
    pub l_c_y: f64,
    /// Raw contact area at L_c (mean of the bracket ends).
    pub a_p_raw: f64,
    /// Perimeter-corrected contact area at L_c.
    pub a_p_corrected: f64,
    /// The flow axis.
    pub axis: Axis,
    /// The state at the bracket's lower end (or, if the re-solve there is blocked, the nearest
    /// rung where the fluid winds; `notes` says so).
    pub at_l_c: ConstrictionRung,
    /// The gap there, if kept.
    pub gap_at_l_c: Option<Array2<f64>>,
    /// The ladder, largest d first.
    pub rungs: Vec<ConstrictionRung>,
    /// Running β between neighbouring resolved rungs (farthest pair first).
    pub running_beta: Vec<RunningSlope>,
    /// Running exponent of the constriction gap.
    pub running_gap: Vec<RunningSlope>,
    /// β fit over the resolved rungs in the fit window.
    pub beta_fit: Option<ExponentFit>,
    /// Gap-exponent fit over the same rungs.
    pub gap_fit: Option<ExponentFit>,
    /// Notes (rungs left out, fits not possible).
    pub notes: Vec<String>,
    /// Contact solves of the bisection.
    pub probes: usize,
    /// What became of `ConstrictionOptions::seed`.
    pub seed: SeedOutcome,
    /// Polonsky–Keer iterations over all solves.
    pub iterations: usize,
    /// Wall time (s).
    pub wall_s: f64,
}

impl ConstrictionStudy {
    /// The resolved rungs.
    pub fn resolved(&self) -> impl Iterator<Item = &ConstrictionRung> {
        self.rungs.iter().filter(|r| r.resolved)
    }
}

fn flow_axis(axis: Axis) -> FlowAxis {
    match axis {
        Axis::X => FlowAxis::X,
        Axis::Y => FlowAxis::Y,
    }
}

/// The flow along `axis` through a gap field and the pressure drop at `node`.
#[derive(Clone, Debug)]
pub struct ThroatFlow {
    /// Flux for a unit pressure drop per period (0 if not percolating).
    pub flux: f64,
    /// The flow solver's a-posteriori relative error estimate of the flux.
    pub flux_error: f64,
    /// The flow solve converged.
    pub flow_converged: bool,
    /// The fluid winds along `axis`.
    pub percolating: bool,
    /// Fraction of the pressure drop per period across the square around `node` (module docs,
    /// "Pressure drop"); None without flowing nodes there.
    pub drop: Option<f64>,
    /// The directional measure of [`reynolds::pressure_drop_fraction`] (upstream face minus
    /// downstream face along the flow axis; negative where the throat's channel runs against
    /// the axis); None if the window does not fit or has no flowing face (then `note` says why).
    pub drop_axial: Option<PressureDrop>,
    /// Why a measure is missing.
    pub note: Option<String>,
}

/// max − min of the pressure (continued across the cell boundary along the flow, unit drop per
/// period) over the flowing nodes of the (2r+1)² square around `node`.
fn square_drop(
    pressure: ArrayView2<f64>,
    axis: Axis,
    node: (usize, usize),
    r: usize,
) -> Option<f64> {
    let (nx, ny) = pressure.dim();
    let r = r as isize;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for a in -r..=r {
        for b in -r..=r {
            let (ui, uj) = (node.0 as isize + a, node.1 as isize + b);
            let (i, j) = (ui.rem_euclid(nx as isize), uj.rem_euclid(ny as isize));
            let p = pressure[[i as usize, j as usize]];
            if !p.is_finite() {
                continue;
            }
            let wraps = match axis {
                Axis::X => ui.div_euclid(nx as isize),
                Axis::Y => uj.div_euclid(ny as isize),
            };
            let p = p - wraps as f64;
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (hi >= lo).then_some(hi - lo)
}

/// Solves the periodic Reynolds flow on `gap` along `axis` and measures the fraction of the
/// pressure drop at `node` (the square of half-size `window_half_length`, and the directional
/// window of `window_half_length` along and `window_half_width` across the flow).
pub fn throat_flow(
    gap: ArrayView2<f64>,
    lx: f64,
    ly: f64,
    axis: Axis,
    node: (usize, usize),
    opts: &ConstrictionOptions,
) -> Result<ThroatFlow, CriticalError> {
    let fopts = FlowOptions {
        return_fields: true,
        ..opts.flow.clone()
    };
    let f = reynolds::solve(gap, lx, ly, flow_axis(axis), &fopts).map_err(|e| {
        CriticalError::Solver {
            load: f64::NAN,
            detail: format!("Reynolds flow: {e}"),
        }
    })?;
    let (drop, drop_axial, note) = match f.fields.as_ref() {
        Some(fields) if f.percolating => {
            let window = Window {
                centre: node,
                half_length: opts.window_half_length,
                half_width: opts.window_half_width,
            };
            let p = fields.pressure.view();
            let sq = square_drop(p, axis, node, opts.window_half_length);
            match pressure_drop_fraction(p, flow_axis(axis), &window) {
                Ok(d) => (sq, Some(d), None),
                Err(e) => (sq, None, Some(format!("axial pressure drop: {e}"))),
            }
        }
        _ => (None, None, Some("no flow: no pressure drop".to_string())),
    };
    Ok(ThroatFlow {
        flux: f.flux,
        flux_error: f.flux_error_estimate,
        flow_converged: f.converged,
        percolating: f.percolating,
        drop,
        drop_axial,
        note,
    })
}

/// Measures one solved state: flux, constriction, pressure drop, resolution.
fn measure_rung(
    field: &HeightField,
    sol: &Solution,
    d: f64,
    axis: Axis,
    opts: &ConstrictionOptions,
    iterations: usize,
    reference: Option<(&Array2<f64>, (usize, usize))>,
) -> Result<ConstrictionRung, CriticalError> {
    let changes = reference.map(|(g_ref, node)| {
        contact_changes(g_ref.view(), sol.gap.view(), node, opts.affine_radius)
    });
    let (lx, ly) = (field.grid.lx, field.grid.ly);
    let constriction =
        analyse_constriction(field.heights.view(), sol.gap.view(), lx, ly, axis, 0.0)?;
    let mut rung = ConstrictionRung {
        d,
        load: sol.mean_pressure,
        contact_area: sol.contact_area,
        converged: sol.stats.converged,
        flux: 0.0,
        flux_error: f64::NAN,
        flow_converged: false,
        percolating: false,
        constriction: None,
        drop: None,
        drop_axial: None,
        resolved: false,
        contact_changes: 0,
        same_constriction: true,
        note: None,
        iterations,
    };
    let Some(c) = constriction else {
        rung.note = Some("the fluid does not wind along the flow axis".into());
        return Ok(rung);
    };
    let t = throat_flow(sol.gap.view(), lx, ly, axis, c.node, opts).map_err(|e| match e {
        CriticalError::Solver { detail, .. } => CriticalError::Solver {
            load: sol.mean_pressure,
            detail,
        },
        e => e,
    })?;
    rung.flux = t.flux;
    rung.flux_error = t.flux_error;
    rung.flow_converged = t.flow_converged;
    rung.percolating = t.percolating;
    rung.drop = t.drop;
    rung.drop_axial = t.drop_axial;
    rung.note = t.note;
    if let Some((g_ref, node)) = reference {
        let (nx, ny) = g_ref.dim();
        let dist = |a: usize, b: usize, n: usize| {
            let d = a.abs_diff(b);
            d.min(n - d)
        };
        rung.same_constriction = dist(c.node.0, node.0, nx) <= 2 && dist(c.node.1, node.1, ny) <= 2;
    }
    let reason = if !rung.converged {
        Some("contact solve not converged".to_string())
    } else if !(rung.percolating && rung.flow_converged && rung.flux > 0.0) {
        Some("flux not certified (not percolating or flow not converged)".to_string())
    } else if opts.same_constriction_only && !rung.same_constriction {
        Some(format!(
            "another constriction (node {:?}) than at L_c: the critical one does not yet \
             dominate",
            c.node
        ))
    } else if let Some(k) = changes
        && k < opts.min_contact_changes
    {
        Some(format!(
            "affine regime: {k} node(s) within {} of the constriction at L_c changed contact \
             state (< {}): the gap is affine in the load there, g ∝ d and flux ∝ d³ by \
             construction",
            opts.affine_radius, opts.min_contact_changes
        ))
    } else if c.width_nodes < opts.min_width {
        Some(format!(
            "throat {} node(s) wide < min_width {}: not resolved by the grid",
            c.width_nodes, opts.min_width
        ))
    } else {
        None
    };
    rung.contact_changes = changes.unwrap_or(0);
    rung.resolved = reason.is_none();
    if let Some(r) = reason {
        rung.note = Some(match rung.note.take() {
            Some(n) => format!("{r}; {n}"),
            None => r,
        });
    }
    rung.constriction = Some(c);
    Ok(rung)
}

/// L_c, the ladder below it and the last constriction at every rung, on the periodic cell
/// (module docs). Only the periodic boundary is supported: the maximin path of
/// [`percolation::last_constriction`] is the winding one.
pub fn constriction_study(
    field: &HeightField,
    opts: &ConstrictionOptions,
) -> Result<ConstrictionStudy, CriticalError> {
    opts.validate()?;
    let t0 = Instant::now();
    let perc = percolation_load(
        field,
        Boundary::Periodic,
        &PercolationOptions {
            tol_gap: opts.tol_gap,
            max_iter: opts.max_iter,
            rel_width: opts.rel_width,
            seed: opts.seed,
            ..Default::default()
        },
    )?;
    let l_c = perc.any.l_c();
    let (lo, hi) = (perc.any.bracket.lo, perc.any.bracket.hi);
    let mut model = Model::with_boundary(
        field.grid,
        field.heights.view(),
        contact::free_kernel::Boundary::Periodic,
    )
    .map_err(|e| CriticalError::Solver {
        load: f64::NAN,
        detail: e.to_string(),
    })?;
    let sopts = SolverOptions {
        tol_gap: opts.tol_gap,
        max_iter: opts.max_iter,
        method: Method::PolonskyKeer,
        ..Default::default()
    };
    let mut ds = opts.ladder.clone();
    ds.sort_by(|a, b| b.total_cmp(a));
    ds.dedup();
    let mut iterations = perc.iterations;
    let mut prev: Option<Solution> = None;
    let mut solved: Vec<(f64, Solution, usize)> = Vec::with_capacity(ds.len() + 1);
    for &d in &ds {
        let load = l_c * (1.0 - d);
        let (sol, it, _) = crate::solve_with_retries(&mut model, &sopts, load, prev.take(), &[])?;
        iterations += it;
        solved.push((d, sol.clone(), it));
        prev = Some(sol);
    }
    let (sol_lc, it_lc, _) = crate::solve_with_retries(&mut model, &sopts, lo, prev, &[])?;
    iterations += it_lc;
    let mut notes = Vec::new();
    if let SeedOutcome::Rejected { reason } = &perc.seed {
        notes.push(format!(
            "the seed bracket was rejected ({reason}); L_c was bracketed from the default guess"
        ));
    }
    let state_lc = FlowState::of_gap(sol_lc.gap.view())?;
    // The reference state "at L_c": just below it, or, if the re-solve there comes out blocked
    // (the bisection's probe at the same load started from another state, and the last node
    // closes within the solver's tolerance), the nearest rung where the fluid still winds.
    let (ref_sol, ref_d, ref_it, state) = if state_lc.fluid_any() {
        (&sol_lc, (l_c - lo) / l_c, it_lc, state_lc)
    } else {
        let nearest = solved.iter().rev().find_map(|(d, s, it)| {
            let st = FlowState::of_gap(s.gap.view()).ok()?;
            st.fluid_any().then_some((s, *d, *it, st))
        });
        notes.push(format!(
            "the re-solve at the bracket's lower end {lo} is blocked (its last node closes \
             within the solver tolerance from this warm start); the reference state is {}",
            match &nearest {
                Some((_, d, _, _)) => format!("the rung d = {d:e}"),
                None => "missing: no rung winds".into(),
            }
        ));
        nearest.unwrap_or((&sol_lc, (l_c - lo) / l_c, it_lc, state_lc))
    };
    let axis = if state.fluid(Axis::X) || !state.fluid(Axis::Y) {
        Axis::X
    } else {
        Axis::Y
    };
    let at_l_c = measure_rung(field, ref_sol, ref_d, axis, opts, ref_it, None)?;
    let reference = at_l_c.constriction.as_ref().map(|c| (&ref_sol.gap, c.node));
    let mut rungs = Vec::with_capacity(solved.len());
    for (d, sol, it) in &solved {
        let r = measure_rung(field, sol, *d, axis, opts, *it, reference)?;
        if let Some(n) = &r.note {
            notes.push(format!("d = {d:e}: {n}"));
        }
        rungs.push(r);
    }
    let used: Vec<&ConstrictionRung> = rungs.iter().filter(|r| r.resolved).collect();
    let flux_pts: Vec<ScalingPoint> = used
        .iter()
        .map(|r| ScalingPoint::new(-r.d, r.flux, r.flux * r.flux_error.max(0.0)))
        .collect();
    let gap_pts: Vec<ScalingPoint> = used
        .iter()
        .filter_map(|r| {
            let g = r.constriction.as_ref()?.gap;
            (g > 0.0).then(|| ScalingPoint::new(-r.d, g, opts.tol_gap))
        })
        .collect();
    let slopes = |pts: &[ScalingPoint], what: &str, notes: &mut Vec<String>| {
        if pts.len() < 2 {
            notes.push(format!(
                "running {what}: {} resolved rung(s), 2 needed",
                pts.len()
            ));
            return Vec::new();
        }
        local_slopes(pts).unwrap_or_else(|e| {
            notes.push(format!("running {what}: {e}"));
            Vec::new()
        })
    };
    let running_beta = slopes(&flux_pts, "β", &mut notes);
    let running_gap = slopes(&gap_pts, "gap exponent", &mut notes);
    let (wa, wb) = opts.fit_window;
    let in_window: Vec<&&ConstrictionRung> =
        used.iter().filter(|r| r.d >= wa && r.d <= wb).collect();
    let ls: Vec<f64> = in_window.iter().map(|r| -r.d).collect();
    let fit = |y: Vec<f64>, what: &str, notes: &mut Vec<String>| match fit_exponent(&ls, &y) {
        Ok(f) => Some(f),
        Err(e) => {
            notes.push(format!("{what} fit: {e}"));
            None
        }
    };
    let beta_fit = fit(in_window.iter().map(|r| r.flux).collect(), "β", &mut notes);
    let gap_fit = fit(
        in_window
            .iter()
            .map(|r| r.constriction.as_ref().map_or(f64::NAN, |c| c.gap))
            .collect(),
        "gap exponent",
        &mut notes,
    );
    let a = |t: &crate::Transition| (t.a_p_raw(), t.a_p_corrected());
    let (a_p_raw, a_p_corrected) = a(&perc.any);
    Ok(ConstrictionStudy {
        p_fc: perc.p_fc,
        l_c,
        bracket: (lo, hi),
        l_c_x: perc.x.l_c(),
        l_c_y: perc.y.l_c(),
        a_p_raw,
        a_p_corrected,
        axis,
        at_l_c,
        gap_at_l_c: opts.keep_gap.then(|| ref_sol.gap.clone()),
        rungs,
        running_beta,
        running_gap,
        beta_fit,
        gap_fit,
        notes,
        probes: perc.probes,
        seed: perc.seed,
        iterations,
        wall_s: t0.elapsed().as_secs_f64(),
    })
}
