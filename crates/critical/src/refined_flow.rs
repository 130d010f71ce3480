//! The flux of the refined ladder: on every rung of a [`Refinement`] (l < 0) the conductance
//! along the channel through the composite gap, so that β_eff (K ∝ |l|^β) follows ζ_eff below
//! the uniform grids' reach, with the same level and margin errors
//! ([`crate::refined::running_exponent`] of [`Measured::Flux`](crate::refined::Measured::Flux)).
//!
//! # What is measured ([`FluxMethod`])
//! - **Square model: the cell's conductivity** K along the channel axis by the series
//!   replacement R = R_cc − R_wc + R_wf ([`crate::window_flow::refined_flow`]): the periodic
//!   base cell with the flow window's coarse resistance replaced by its fine one. The square
//!   cell's flow along the channel crosses the one critical saddle in series with the rest, so
//!   this is exact for the discrete problems up to the end lines' departure from isobars, whose
//!   error falls like the rest of the cell's share of the resistance (~|l|^β; 9.3e-5 in K at
//!   l = −1e-2 on 256²/k = 3, far less below; `critical::window_flow`).
//! - **Triangular and hexagonal models: the refined saddle's own two-terminal conductance**
//!   ([`FluxMethod::SaddleWindow`]): the flux through the flow window around the refined saddle
//!   on the fine gap, its two end lines across the channel held as isobars (ΔP = 1), its sides
//!   closed ([`reynolds::solve_between_isobars`]). This is **not the cell's conductivity**: it is
//!   the conductance of the single critical neck. Its exponent is β by the paper's argument: near
//!   p_c the cell's resistance is dominated by the critical necks in series (the rest is a
//!   regular resistance), and all necks have the same shape by symmetry, so the cell's K and
//!   one neck's conductance share the exponent, their running exponents differing by a term
//!   that falls like the rest's share of the resistance (square model, where both are measured:
//!   +3.8e-3 at 0.01→0.005, +4.1e-4 at 0.005→0.002, +2.8e-5 at 0.002→0.001, `window_flow`).
//!   Why not the cell: with one refined window the other critical saddles stay on the coarse
//!   base grid, whose closing load differs from p_c(D) by ~3e-5 (triangular 256²), so the
//!   cell's K through them collapses or lags as |l| approaches that shift (one window,
//!   `window_flow` "Several windows": β_eff along x 3.37, 3.07, 1.84 against uniform 3.52,
//!   3.47, 3.36). Refining every flow saddle (`refined_multi_flow`, twelve windows) fixes that
//!   but needs another contact discretisation (`RefinedModel::multi`), whose k = 3 p_c search
//!   did not finish in 15 CPU-min on a 256² base: too slow for the ladder's levels and margin
//!   check. The measurement on small grids is the test `tests/window_flow_refined.rs`
//!   (triangular, 32² base, k = 2, window 8 against uniform 128²: numbers there).
//!
//! # Errors
//! The conductance's 1σ is the solver tolerance of the contact solve propagated: K ∝
//! g_s^(β/ζ) near the saddle, β/ζ ≈ 3 (measured 2.9–3.2 on the refined and uniform grids,
//! `window_flow`), so σ_K / K = 3 tol_gap / g_s (the flow solve's own residual, 1e-10 relative in
//! the flux, is far below it at every rung). The discretisation error is what the ladder's level
//! and margin comparisons measure, as for ζ.
//!
//! # Flow window
//! The refined region shortened by `trim_along` = ⌊window/4⌋ base cells at each end along the
//! channel (at most (window − 5)/2, so that 5 cells remain) and by one base cell across it
//! ([`FlowWindow::inside`]): 8 × 14 base cells for the 16-cell windows of the draft and paper
//! presets (the set-up of `window_flow`'s k = 3 vs k = 4 measurements), 6 × 6 … for the smoke
//! preset's 8-cell window.

use crate::CriticalError;
use crate::ladder::Window;
use crate::refined::{RefinedRung, Refinement};
use crate::window_flow::{
    FlowWindow, WindowFlowError, between_isobars, open_side_nodes, percolating, refined_flow,
};
use contact::refinement::Refined;
use reynolds::{FlowAxis, FlowOptions};
use surface::{Grid, Lattice};

/// d ln K / d ln g_s near the saddle (β/ζ; module docs): propagates the gap's 1σ to K's.
pub const FLUX_PER_GAP: f64 = 3.0;

/// What the refined ladder's flux measures (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FluxMethod {
    /// The cell's conductivity along the channel by the single-window series replacement.
    Series,
    /// The refined saddle's two-terminal conductance (its flow window between isobars).
    SaddleWindow,
}

impl FluxMethod {
    /// The method of a model: the series replacement where the cell's flow crosses the one
    /// refined saddle in series (square), the saddle's own conductance elsewhere.
    pub fn of(lattice: Lattice) -> Self {
        match lattice {
            Lattice::Square => FluxMethod::Series,
            _ => FluxMethod::SaddleWindow,
        }
    }

    /// Table name (`series`, `saddle_window`).
    pub fn name(self) -> &'static str {
        match self {
            FluxMethod::Series => "series",
            FluxMethod::SaddleWindow => "saddle_window",
        }
    }
}

/// The flux of one rung.
#[derive(Clone, Debug, PartialEq)]
pub struct RungFlux {
    /// How it was measured.
    pub method: FluxMethod,
    /// The conductance: [`FluxMethod::Series`] the cell's conductivity K along the channel,
    /// [`FluxMethod::SaddleWindow`] the window's flux for a unit pressure drop.
    pub conductance: f64,
    /// Its 1σ (module docs, "Errors").
    pub sigma: f64,
    /// The fine window's two-terminal flux (ΔP = 1; both methods).
    pub window_flux: f64,
    /// R_wc / R_cc of the series replacement (NaN for the saddle window).
    pub neck_share: f64,
    /// The end lines' departure from isobars in the base cell (series only; NaN otherwise).
    pub isobar_spread: f64,
    /// Open fine nodes on the flow window's side lines (closed in the window problems).
    pub open_side_nodes: usize,
    /// Wall time of the flow solves (s).
    pub wall_s: f64,
}

/// What [`rung_flux`] needs of a refinement (so that the ladder's callback can use it while the
/// refinement is borrowed).
#[derive(Clone, Debug)]
pub struct FluxSetup {
    /// Base grid.
    pub grid: Grid,
    /// Flow axis (the channel's).
    pub axis: FlowAxis,
    /// Method.
    pub method: FluxMethod,
    /// Trim along the channel (base cells).
    pub trim_along: usize,
    /// The contact solve's tolerance (h0): the saddle gap's 1σ.
    pub tol_gap: f64,
    /// Flow solver options.
    pub flow: FlowOptions,
}

impl FluxSetup {
    /// The set-up of `refinement` with `method` (module docs, "Flow window"). Errors if its
    /// window is below 7 base cells (5 along the flow after a trim of 1).
    pub fn new(refinement: &Refinement, method: FluxMethod) -> Result<Self, CriticalError> {
        let w = refinement.disc.window;
        if w < 7 {
            return Err(CriticalError::param(
                "window",
                w as f64,
                "≥ 7 base cells for the refined flux (5 along the flow after trims of 1)",
            ));
        }
        Ok(FluxSetup {
            grid: refinement.surface.grid,
            axis: if refinement.frame.channel_axis == 0 {
                FlowAxis::X
            } else {
                FlowAxis::Y
            },
            method,
            trim_along: trim_along(w),
            tol_gap: refinement.opts.tol_gap,
            flow: FlowOptions::default(),
        })
    }
}

/// Base cells the flow window leaves out at each end along the channel of a refined window of
/// `window` ≥ 7 base cells (module docs, "Flow window"): ⌊window/4⌋, between 1 and
/// (window − 5)/2, so that 5 remain.
pub fn trim_along(window: usize) -> usize {
    (window / 4).clamp(1, (window - 5) / 2)
}

/// The flux of one refined solution whose saddle gap is `saddle_gap` (module docs).
pub fn rung_flux(
    setup: &FluxSetup,
    r: &Refined,
    saddle_gap: f64,
) -> Result<RungFlux, WindowFlowError> {
    let t = std::time::Instant::now();
    let window = FlowWindow::inside(r, &setup.grid, setup.axis, setup.trim_along, 1)?;
    let rel = FLUX_PER_GAP * setup.tol_gap / saddle_gap;
    match setup.method {
        FluxMethod::Series => {
            let w = refined_flow(r, &setup.grid, window, setup.axis, &setup.flow)?;
            Ok(RungFlux {
                method: FluxMethod::Series,
                conductance: w.conductivity,
                sigma: w.conductivity * rel,
                window_flux: w.flux_window_fine,
                neck_share: w.neck_share,
                isobar_spread: w.isobar_spread,
                open_side_nodes: w.open_side_nodes,
                wall_s: t.elapsed().as_secs_f64(),
            })
        }
        FluxMethod::SaddleWindow => {
            let fine = crate::window_flow::fine_window_gap(r, &setup.grid, window)?;
            let q = saddle_window_flux(&fine, &setup.grid, window, setup.axis, &setup.flow)?;
            let open_side_nodes = open_side_nodes(fine.view(), setup.axis);
            Ok(RungFlux {
                method: FluxMethod::SaddleWindow,
                conductance: q,
                sigma: q * rel,
                window_flux: q,
                neck_share: f64::NAN,
                isobar_spread: f64::NAN,
                open_side_nodes,
                wall_s: t.elapsed().as_secs_f64(),
            })
        }
    }
}

/// The two-terminal flux (ΔP = 1 between the isobaric end lines across `axis`, closed sides) of
/// the fine gap `fine` ((f wx + 1) × (f wy + 1) nodes, f = its refinement of `base`) of
/// `window`. Errors if the flow does not converge or does not percolate.
pub fn saddle_window_flux(
    fine: &ndarray::Array2<f64>,
    base: &Grid,
    window: FlowWindow,
    axis: FlowAxis,
    opts: &FlowOptions,
) -> Result<f64, WindowFlowError> {
    let f = (fine.dim().0 - 1) / window.wx.max(1);
    let (dx, dy) = (base.lx / base.nx as f64, base.ly / base.ny as f64);
    let spacing = (dx / f as f64, dy / f as f64);
    let r = percolating(
        "fine window",
        between_isobars(fine.view(), spacing, axis, opts),
    )?;
    Ok(r.flux)
}

/// The rungs of [`ladder_with_flux`] and, per rung, its flux or why none.
pub type FluxLadder = (Vec<RefinedRung>, Vec<Result<RungFlux, String>>);

/// The flux of one rung of a refined ladder as [`ladder_with_flux`] measures it: none above
/// p_c or with the saddle closed (the reason), else [`rung_flux`] (its error as text).
pub fn ladder_rung_flux(
    setup: &FluxSetup,
    rung: &RefinedRung,
    refined: &Refined,
) -> Result<RungFlux, String> {
    if rung.l > 0.0 {
        Err("above p_c: no flux".to_string())
    } else if rung.saddle_gap <= 0.0 {
        Err("saddle closed: no flux".to_string())
    } else {
        rung_flux(setup, refined, rung.saddle_gap).map_err(|e| e.to_string())
    }
}

/// A refined ladder with its flux: [`Refinement::ladder`] at `p_c (1 + l)` for every l of `ls`,
/// each rung below p_c(D) with an open saddle given its [`RungFlux`] (`RefinedRung::flux` =
/// (conductance, 1σ)); a rung whose flow fails keeps NaN and a note. `on_rung` sees every rung
/// (before its flux is filled in) with its solution and saddle window. Returns the rungs, and per rung its flux
/// or why none.
pub fn ladder_with_flux(
    refinement: &mut Refinement,
    p_c: f64,
    ls: &[f64],
    method: FluxMethod,
    on_rung: &mut dyn FnMut(&RefinedRung, &Refined, &Window),
) -> Result<FluxLadder, CriticalError> {
    let setup = FluxSetup::new(refinement, method)?;
    let mut fluxes = Vec::new();
    let mut rungs = refinement.ladder(p_c, ls, &mut |rung, r, w| {
        on_rung(rung, r, w);
        fluxes.push(ladder_rung_flux(&setup, rung, r));
    })?;
    for (rung, f) in rungs.iter_mut().zip(&fluxes) {
        if let Ok(f) = f {
            rung.flux = (f.conductance, f.sigma);
        }
    }
    Ok((rungs, fluxes))
}
