//! Reynolds flow through a locally refined saddle: the conductance of the periodic cell along
//! the channel when the contact was solved with one window refined 2^k times
//! ([`contact::refinement`]), so that the flux exponent β (K ∝ |l|^β, l < 0) can be followed
//! below the reduced loads a uniform grid resolves.
//!
//! # Method: series replacement of the window's resistance
//! A refined solve gives the gap on two lattices: the fine gap on the refined region R
//! ([`Refined::window_gap`]) and, on every base node, the base gap ([`base_gap`]: the fine gap at
//! the base nodes inside R, the hat-weighted mean gap of the coarse unknowns outside it). The
//! flow window W is a rectangle of base nodes i0 ..= i0 + wx, j0 ..= j0 + wy inside R (by default
//! R shortened along the channel, [`FlowWindow::inside`]); its fine nodes are the fine lattice's
//! nodes of the same rectangle, so W is the same physical region on both lattices, bounded by
//! the same node lines. With resistances R = ΔP/Q (Q the volume flux of the whole cell for a
//! pressure drop ΔP = 1):
//! - R_cc: the periodic cell on the base gap ([`reynolds::solve`]);
//! - R_wc: W on the base gap, its two end lines across the channel held as isobars and its side
//!   lines closed ([`reynolds::solve_between_isobars`], [`SideEdges::NoFlux`]);
//! - R_wf: the same on the fine gap of W;
//! - composite: R = R_cc − R_wc + R_wf, K = L_flow / (R L_cross).
//!
//! Exact (for the discrete problems): if, in the base cell's solution, W's two end lines are
//! isobars and no flux crosses its side lines, the base cell is exactly W in series with the
//! rest, and the composite is the cell discretised fine in W and coarse outside it with those
//! lines as the interfaces. The end lines are node lines of both lattices (that is why the
//! isobars sit on nodes, not half a cell beyond them as in [`reynolds::solve_between_reservoirs`]),
//! so nothing is counted twice or left out. Tested on a channel whose gap varies only along the
//! flow (every node column an isobar): the composite equals the face-by-face series sum to 1e-11.
//!
//! Approximated: (i) the end lines are not exact isobars. In the channel's funnels the pressure
//! varies across a line by [`WindowFlow::isobar_spread`] (of the drop across W; measured on the
//! base cell's solution), and the replacement then moves the neck's resistance between
//! slightly different boundary conditions; (ii) side lines that cross open fluid
//! ([`WindowFlow::open_side_nodes`]) are closed in the window problems but not in the cell. Both
//! vanish as the neck shrinks inside a fixed window: near p_c the resistance concentrates in a
//! neck of length ∝ |l|^χ and width ∝ |l|^υ, the funnels at the window's ends become isobaric,
//! and the side lines lie in the contact patches that flank the channel (for the square model
//! with η = 1 the contact lines leave the saddle at ±45°, so a window longer across the channel
//! than along it has closed sides; [`FlowWindow::inside`] halves R along the channel). What stays
//! is the base grid's discretisation of the rest of the cell, a regular resistance that the
//! diverging neck resistance dwarfs: the composite K's relative error to the uniform fine grid
//! tends to that of the contact solve's gap near the saddle (times d ln K/d ln g_s = β/ζ), and the running
//! exponent's error to the change of that gap error between loads.
//!
//! Near p_c R_cc and R_wc are both dominated by the same coarse neck, so R_cc − R_wc (the rest)
//! is a difference of nearly equal numbers: it loses log10(R_wc/(R_cc − R_wc)) digits of the
//! fluxes' ~1e-12 accuracy ([`WindowFlow::neck_share`] reports R_wc/R_cc).
//!
//! # Measured (square model, saddle (0, ½), channel and flow along x, tol_gap 1e-13 h0)
//! Each discretisation at its own p_c (bisection to 1e-9 on the saddle node's gap), K of the
//! cell along x; "method" is the series replacement applied to the uniform fine solution itself
//! (its gap subsampled on the base nodes, fine in the flow window) against that solution's
//! periodic K, i.e. the flow method's own error; "K" the refined composite against the uniform
//! fine K, which adds the contact solve's error.
//!
//! Oracle without contact (test): gap max(0, ε + cos 2πx + cos 2πy) on 32² with the window
//! ×4 against the uniform 128² gap: composite −8.4e-4, −3.0e-6, −3.4e-9, −4.1e-12 at ε = 1e-1,
//! 1e-2, 1e-3, 1e-4 (base alone −1.1e-2, +9.2e-2, +0.19, +9.2e-4).
//!
//! 64² base, k = 2, region 16² (flow window 8 × 14 base cells), against uniform 256² (test
//! `tests/window_flow.rs`, 5 s): at l = −1e-2, −5e-3, −2e-3, −1e-3, −5e-4
//! - saddle gap +2.9e-3, +1.0e-3, +9.5e-4, +1.7e-3, +2.0e-3;
//! - K +8.4e-3, +2.9e-3, +2.8e-3, +5.2e-3, +6.6e-3 (base alone −0.11, −0.35, −0.48, −0.47,
//!   −0.35); method −1.2e-5, −1.3e-6, −5.8e-8, −4.6e-9, −3.0e-10;
//! - β_eff, refined − uniform: +7.9e-3, +1.4e-4, −3.5e-3, −1.9e-3 (base alone +0.45, +0.24,
//!   −0.03, −0.29).
//!
//! 128² base, k = 3, region 32² blockwise (margin 8; flow window 16 × 30 base cells), against
//! uniform 1024² (example: `n=7 k=3 region=32 margin=8 trim_along=8`; 113 CPU-s in all, 72 s
//! refined and 45 s uniform wall, 247 MB peak): p_c +9.5e-6 from the uniform one; at
//! l = −1e-2, −5e-3, −2e-3, −1e-3, −5e-4, −2e-4, −1e-4
//! - saddle gap +6.5e-4, +4.3e-4, +8.4e-4, +1.2e-3, +1.5e-3, +1.9e-3, +2.0e-3;
//! - K +1.9e-3, +1.2e-3, +2.4e-3, +3.5e-3, +4.4e-3, +5.7e-3, +6.4e-3 (base alone −1.9e-3,
//!   −3.4e-2, −0.24, −0.47, −0.56, −0.59, −0.59); method −3.2e-6, −3.2e-7, −1.4e-8, −1.4e-9,
//!   −1.3e-10, −5.4e-12, −4.6e-13;
//! - β_eff (uniform 3.4666, 3.4421, 3.4260, 3.4172, 3.4286, 3.5239), refined − uniform
//!   +9.3e-4, −1.3e-3, −1.6e-3, −1.3e-3, −1.3e-3, −1.1e-3 (base alone up to +0.53); ζ_eff
//!   within 5.3e-4.
//!
//! 256² base, k = 3, region 32² blockwise (margin 8; flow window 16 × 30), against uniform
//! 2048² (example: `n=8 k=3 region=32 margin=8 trim_along=8`; 261 CPU-s in all, 142 s refined
//! and 349 s uniform wall on a shared machine, load average 5–9; 943 MB peak, the uniform
//! 2048² solve's): p_c +4.2e-7 from the uniform one; at the same seven loads
//! - saddle gap −3.6e-4, −6.9e-4, +1.4e-4, +5.1e-4, +4.5e-4, +8.8e-5, +1.9e-4;
//! - K −1.1e-3, −2.0e-3, +4.1e-4, +1.5e-3, +1.3e-3, +2.9e-4, +6.4e-4 (base alone −1.7e-3,
//!   −3.2e-3, −1.5e-2, −0.10, −0.30, −0.58, −0.63); method −9.3e-5, −1.4e-5, −7.5e-7,
//!   −7.1e-8, −6.3e-9, −2.8e-10, −2.6e-11 (this flow window is 1/16 λ long, so at l = −1e-2
//!   its end lines are less isobaric: spread 1.7e-3, and 36–68 open fine nodes on its sides);
//! - β_eff (uniform 3.4657, 3.4403, 3.4209, 3.4075, 3.3979, 3.3909), refined − uniform
//!   +1.2e-3, −2.6e-3, −1.5e-3, +2.3e-4, +1.1e-3, −5.0e-4 (base alone up to +0.55); ζ_eff
//!   within 9.0e-4.
//!
//! Beyond the uniform grids (the same 256² base, k = 3, refined only, 95 CPU-s, 69 MB; the
//! uniform 2048² rows above are its fine spacing): K at l = −5e-5, −2e-5, −1e-5 is 6.87e-16,
//! 2.52e-17, 1.69e-18; β_eff 3.4669, 3.4377, 3.4193, 3.4077, 3.3990, 3.3904, 3.4308, 3.6087,
//! 3.8973 between the neighbours of l = −1e-2 … −1e-5 (ζ_eff 1.1960 … 1.1646, then 1.1689,
//! 1.1719, 1.1808). The up-turn below |l| = 1e-4 is the 2048² spacing running out (as 1024²'s
//! below 5e-4), not a measurement of β: k = 3 is not enough there.
//!
//! k = 3 against k = 4 (256² base, region 16², flow window 8 × 14, tol_gap 1e-12: k = 4 at
//! 1e-13 stagnated in the contact solve at 0.2284 p_fc, cold; 22 and 106 CPU-s for the whole
//! bisection and ten loads, 40 and 89 MB; p_c/p_fc 0.2286052913 and 0.2286051698): β_eff
//! (k = 4) 3.4629, 3.4420, 3.4143, 3.4066, 3.3917, 3.3838, 3.3775, 3.3904, 3.4888 between the
//! neighbours of l = −1e-2 … −1e-5; k = 4 − k = 3: −4.2e-4, −5.3e-4, −1.2e-3, −2.2e-3,
//! −4.8e-3, −5.7e-3, then −5.3e-2, −0.22, −0.41 where 2048² spacing fails. So at 4096²
//! spacing β_eff keeps falling to 3.378 (l = −1e-4 … −5e-5) before its own up-turn below
//! 5e-5; its grid error (the k = 3 → 4 change) passes 0.005 from |l| = 5e-4 on. This small
//! region is too small at l = −1e-2 (neck share 0.949, end-line spread 2e-2, 130 open side
//! nodes at k = 3): there the k = 3 K is −5.3e-3 from uniform 2048² (region 32²: −1.1e-3), of
//! which ~−1.9e-3 is the contact's gap error ×3 and ~−3.4e-3 the flow window's; from
//! |l| = 1e-3 on the region-16² k = 3 K is within 2.9e-3 of uniform 2048² and its β_eff
//! within 1.4e-3 (region 32²: 1.5e-3 and 2.6e-3 over the same loads).
//!
//! The fine window's flux alone (the neck without the rest of the cell) has a running exponent
//! above the cell's by +3.8e-3, +4.1e-4, +2.8e-5, +2.9e-6, +2.3e-7, … +4.4e-12 over the same
//! pairs: the cell's K and the neck's converge to one exponent as |l| → 0, the difference
//! falling like the rest's share of the resistance.
//!
//! What the numbers say:
//! - The flow method's own error falls like |l|^3.4 ≈ |l|^β: it is the rest of the cell's share
//!   of the resistance (1 − [`WindowFlow::neck_share`] = 8e-5 at l = −1e-2 on 1024²) times
//!   the rest's discretisation and end-line error; so the composite correction vanishes as
//!   |l| → 0, and its effect on β_eff is below 1e-5 at every load measured.
//! - The K error is the contact solve's saddle-gap error times d ln K / d ln g_s = β/ζ ≈ 2.9
//!   to 3.2 at every load on both grids: the refined flux is as good as the refined gap, no
//!   better. That error (~1e-3 in the gap, the composite contact discretisation's floor, see
//!   [`contact::refinement`]) does not vanish as |l| → 0 (on 1024² it grows slowly, +6.5e-4 →
//!   +2.0e-3; on 2048² it stays within ±7e-4), but it changes slowly with l, so β_eff errs by
//!   ≤ 1.6e-3 on 1024² and ≤ 2.6e-3 on 2048² (≤ 7.9e-3 on 256²) from the uniform grid of
//!   the same spacing. That is the refinement's own error, within the 0.005 from 1024²
//!   spacing on; the grid error proper (the change between spacings) is another matter, below.
//! - On the uniform 1024² grid β_eff turns up below |l| = 5e-4 (3.417 → 3.429 → 3.524),
//!   on 2048² it keeps falling (3.408, 3.398, 3.391 between 1e-3 and 1e-4): the up-turn is
//!   1024²'s resolution, which the refined discretisation with the same fine spacing reproduces
//!   exactly; the refinement level k, not the flow, decides where β_eff can be trusted.
//! - β_eff of the square model falls with |l| at every spacing down to where that spacing
//!   fails (3.467 at l = −1e-2/−5e-3, 3.391 at −2e-4/−1e-4 on 2048², 3.378 at −1e-4/−5e-5 on
//!   4096²), and the k = 3 → 4 change exceeds 0.005 from |l| = 5e-4 on: these numbers do not
//!   decide whether β tends to the paper's 3.45 or below it; k ≥ 5 at |l| ≤ 1e-4 is needed.
//!   Tried: k = 5 (256² base, region 16², tol_gap 1e-12, bracket 0.228603–0.228608 p_fc) —
//!   the refined contact solve stagnated during the p_c bisection (at 0.2286035 p_fc, warm
//!   and then cold) after 875 CPU-s; no flow was reached. That is the contact solver's limit,
//!   not this module's.
//!
//! # Several windows ([`scaled_replacement`], [`refined_multi_flow`])
//! In the hexagonal and triangular cells the flow passes through twelve saddles
//! ([`contact::refinement::flow_saddles`]), in series and in parallel, four of them with their
//! channel along a grid axis and eight at ±60° to it. The single-window subtraction
//! R_cc − R_wc + R_wf is exact for one window in series with the rest, but the corrections of
//! several windows do not add: for two equal windows in parallel, each changed from R to R',
//! the cell changes by (R' − R)/2, not 2 (R' − R) (in general ∂R_cell/∂R_w = (Q_w/Q)², Q_w the
//! flux through window w: 1 in series, 1/n² for n parallel equal windows, and first order
//! only).
//!
//! What is done instead: each window's two-terminal problem (isobaric end lines across the
//! grid axis nearest its channel, [`SaddleFlowWindow::around`]; closed sides) is solved on the
//! base gap and on the fine gap; the ratio s_w = Q_fine/Q_coarse multiplies g³ on every base node
//! of the window (g × s_w^⅓). Face conductances are harmonic means of g³, so every face inside
//! the window is multiplied by exactly s_w, and with it the window's two-terminal conductance;
//! the periodic base cell with its windows so rescaled is solved once more (K along x and
//! along y from the same rescaled windows). The network (series, parallel, any number of
//! windows, flow along either axis) is then the base cell's own, with each window carrying the
//! fine gap's conductance. Approximated: (i) the faces joining a window's edge nodes to the
//! rest of the cell are harmonic means of one scaled and one unscaled node (changed by up to
//! 2 s/(1 + s) where they should not change) — they lie in the funnels at the window's ends,
//! whose share of the resistance vanishes as the neck closes; (ii) the isobar and closed-side
//! conditions of the window problems, as for one window ([`WindowScale::open_side_nodes`]);
//! for a channel at ±60° the end lines cross it obliquely. For one window this is not the
//! series replacement (which stays as it was for the square ladder): the two differ by (i).
//!
//! Measured (tests/window_flow_multi.rs; triangular, 64² base, k = 1, regions 10² at every
//! saddle, flow windows 6 × 8 or 8 × 6 base cells, against uniform 128²): the method alone
//! (the uniform solution's own gap, subsampled outside the windows) −3.1e-4 (Kx), −4.5e-4 (Ky)
//! at l = −2e-2, −6.7e-5, −1.0e-4 at −1e-2, −8.7e-6, −1.3e-5 at −5e-3, −3.8e-7, −4.8e-7 at −2e-3
//! (the base gap alone −0.13 … +0.14): it falls as the necks take the cell's resistance, as
//! for one window. The refined composite's K: +3.2e-2 … +5.7e-2 (x), +3.2e-2 … +0.16 (y) from
//! uniform, the contact gap's error (up to 7.5e-2 on this base, see contact::refinement) times
//! d ln K/d ln g_s ≈ 3; Kx/Ky 0.916, 0.921, 0.803, 0.836 against the uniform 128² grid's
//! 0.916, 0.934, 0.834, 0.919. The uniform grid's own Kx ≠ Ky is its anisotropy at this
//! spacing; refinement to the same spacing reproduces it (to the contact floor), it cannot
//! do better than the fine spacing it refines to.
//!
//! Near p_c (example `multi_window`, `n=8 k=2 region=16 margin=8`: triangular, 256² base,
//! k = 2, twelve regions of 16², flow windows 12 × 14 or 14 × 12, blockwise margin 8, against
//! uniform 1024² at the same reduced load from its own p_c; 0.4 s of flow per load): at
//! l = −1e-3, −5e-4, −2e-4, −1e-4
//! - Kx relative to uniform: +5.0e-3, −2.8e-3, −4.0e-3, −2.1e-3; Ky: +1.7e-2, +2.7e-2, +7.1e-2, +0.12
//!   (the flow along y crosses the 90° saddles in series, and their gaps are the ones off by
//!   +7.6e-3 … +6.0e-2, a load shift, see contact::refinement);
//! - Kx/Ky refined 0.972, 0.949, 0.928, 0.931; uniform 1024² 0.983, 0.977, 0.998, 1.047; one
//!   window at the axis saddle (the others coarse) 1.081, 1.136, 1.093, 0.963;
//! - β_eff along x refined 3.540, 3.445, 3.293 (uniform 3.528, 3.444, 3.296); along y 3.506,
//!   3.421, 3.297 (uniform 3.520, 3.467, 3.364); one window: 3.37, 3.07, 1.84 and 3.45, 3.03,
//!   1.65 (the coarse saddles close early).
//! - up to 40 open fine nodes on the flow windows' side lines (the ±60° channels leave the
//!   windows through their sides: the oblique necks are wider than these windows at these
//!   loads).
//!
//! Hexagonal model, the same set-up: the uniform 1024² cell's flow along x did not converge
//! (reynolds: RoundoffLimited) from l = −5e-4 on, nor the refined base cell's from −2e-4 on
//! (K ~ 1e-14): no Kx there. At l = −1e-3 Kx/Ky is 0.805 refined against 0.850 uniform, at
//! −5e-4 0.690 refined. Ky follows uniform within +4.1e-3, +5.3e-3, +5.8e-3, +8.5e-3, β_eff
//! along y 3.224, 3.241, 3.098 against 3.226, 3.242, 3.102.
//!
//! Is Kx = Ky restored by refinement? Not beyond the fine spacing's own: the uniform 1024²
//! grid departs from Kx = Ky by up to 4.7 % over these loads, the refined composite with the
//! same fine spacing by up to 7.2 % (its contact floor: the 90° saddles' load shift), and one
//! refined window leaves it at up to 14 %. Refining every saddle removes the one-window
//! artefact (coarse saddles closing early, β_eff collapsing); the remaining anisotropy is the
//! composite contact discretisation's (coarse region, ~4e-6 in the closing loads), which must
//! fall below ~1e-7 before Kx = Ky can check anything at |l| = 1e-4.
//!
//! # Left out
//! - No two-grid (Schwarz) iteration: the series replacement's own error is ≤ 1e-4 and falls
//!   like |l|^β, far below the contact solve's.
//!
use contact::refinement::{RefineOptions, Refined, RefinedModel, Window};
use contact::{Interaction, Model, Solution, SolverOptions};
use ndarray::{Array2, ArrayView2};
use reynolds::{FlowAxis, FlowOptions, FlowResult, SideEdges};
use std::time::Instant;
use surface::{Grid, Lattice, Surface};

/// Errors of the window flow.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WindowFlowError {
    /// A parameter outside its allowed range.
    #[error("invalid {name} = {value}: allowed {allowed}")]
    Parameter {
        /// Name.
        name: &'static str,
        /// Value as given.
        value: String,
        /// Allowed range in words.
        allowed: String,
    },
    /// A flow solve failed, did not converge or found no open path.
    #[error("flow on the {which}: {detail}")]
    Flow {
        /// Which problem: "base cell", "base window", "fine window", "uniform cell".
        which: &'static str,
        /// What went wrong.
        detail: String,
    },
    /// A contact solve failed or did not converge.
    #[error("contact solve ({which}) at load {load}: {detail}")]
    Contact {
        /// "uniform" or "refined".
        which: &'static str,
        /// Mean pressure (E* h0/λ).
        load: f64,
        /// What went wrong.
        detail: String,
    },
}

fn param(name: &'static str, value: impl ToString, allowed: impl ToString) -> WindowFlowError {
    WindowFlowError::Parameter {
        name,
        value: value.to_string(),
        allowed: allowed.to_string(),
    }
}

/// The flow window: base nodes i0 ..= i0 + wx along x and j0 ..= j0 + wy along y (periodic
/// indices), i.e. `wx × wy` base cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FlowWindow {
    /// First base node along x.
    pub i0: usize,
    /// First base node along y.
    pub j0: usize,
    /// Base cells along x.
    pub wx: usize,
    /// Base cells along y.
    pub wy: usize,
}

impl FlowWindow {
    /// The refined region of `refined` (on the base grid `base`) shortened by `trim_along` base
    /// cells at each end along the flow axis and by `trim_across` at each side across it. The
    /// region's edge base nodes carry hat-weighted mean gaps (see [`Refined::window_gap`]), so
    /// both trims should be ≥ 1.
    pub fn inside(
        refined: &Refined,
        base: &Grid,
        axis: FlowAxis,
        trim_along: usize,
        trim_across: usize,
    ) -> Result<FlowWindow, WindowFlowError> {
        let f = refinement_factor(refined, base)?;
        let region = Window {
            i0: refined.origin.0 / f,
            j0: refined.origin.1 / f,
            wx: (refined.window_grid.nx - 1) / f,
            wy: (refined.window_grid.ny - 1) / f,
        };
        FlowWindow::within(region, base, axis, trim_along, trim_across)
    }

    /// The same for the refined region `region` of a refinement of `base`.
    pub fn within(
        region: Window,
        base: &Grid,
        axis: FlowAxis,
        trim_along: usize,
        trim_across: usize,
    ) -> Result<FlowWindow, WindowFlowError> {
        let (tx, ty) = match axis {
            FlowAxis::X => (trim_along, trim_across),
            FlowAxis::Y => (trim_across, trim_along),
        };
        // 5 base cells along the flow: the isobar problem needs 4 interior node columns
        let need = |w: usize, t: usize, name| {
            if w < 2 * t + 5 {
                Err(param(
                    name,
                    t,
                    format!("at most (region {w} − 5)/2 base cells, so that 5 remain"),
                ))
            } else {
                Ok(w - 2 * t)
            }
        };
        let wx = need(region.wx, tx, "trim along x")?;
        let wy = need(region.wy, ty, "trim along y")?;
        Ok(FlowWindow {
            i0: (region.i0 + tx) % base.nx,
            j0: (region.j0 + ty) % base.ny,
            wx,
            wy,
        })
    }
}

/// The flux decomposition of one cell (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct WindowFlow {
    /// Flux of the periodic cell on the base gap (ΔP = 1 across the cell).
    pub flux_cell_coarse: f64,
    /// Flux through the window on the base gap (ΔP = 1 between its end lines).
    pub flux_window_coarse: f64,
    /// The same on the fine gap.
    pub flux_window_fine: f64,
    /// Composite flux 1 / (1/Q_cc − 1/Q_wc + 1/Q_wf).
    pub flux: f64,
    /// Composite conductivity K = Q L_flow / L_cross of the cell.
    pub conductivity: f64,
    /// The base cell's own conductivity.
    pub conductivity_coarse: f64,
    /// R_wc / R_cc: the share of the base cell's resistance inside the window.
    pub neck_share: f64,
    /// max over the two end lines of (max − min of the base cell's pressure on its flowing
    /// nodes) over the mean pressure drop between the lines: 0 for exact isobars.
    pub isobar_spread: f64,
    /// Open fine nodes on the window's two side lines (closed in the window problems).
    pub open_side_nodes: usize,
    /// Flow-solve iterations (base cell, base window, fine window).
    pub iterations: [usize; 3],
    /// Wall time of the three flow solves (s).
    pub wall_s: f64,
}

/// Flow along a grid axis of the periodic cell `lx × ly` whose base gap is `coarse` (nx × ny),
/// with the window `window` replaced by the fine gap `fine` ((f wx + 1) × (f wy + 1) fine nodes,
/// first index x; fine node (f a, f b) is base node (i0 + a, j0 + b)). See the module docs.
#[allow(clippy::too_many_arguments)]
pub fn series_replacement(
    coarse: ArrayView2<f64>,
    lx: f64,
    ly: f64,
    fine: ArrayView2<f64>,
    f: usize,
    window: FlowWindow,
    axis: FlowAxis,
    opts: &FlowOptions,
) -> Result<WindowFlow, WindowFlowError> {
    let start = Instant::now();
    let (nx, ny) = coarse.dim();
    let (wx, wy) = (window.wx, window.wy);
    if f == 0 || fine.dim() != (f * wx + 1, f * wy + 1) {
        return Err(param(
            "fine window shape",
            format!("{:?}", fine.dim()),
            format!("(f wx + 1, f wy + 1) = ({}, {})", f * wx + 1, f * wy + 1),
        ));
    }
    if wx + 1 > nx || wy + 1 > ny || window.i0 >= nx || window.j0 >= ny {
        return Err(param(
            "window",
            format!("{window:?}"),
            format!(
                "at most {} × {} base cells, first node inside the grid",
                nx - 1,
                ny - 1
            ),
        ));
    }
    let (dx, dy) = (lx / nx as f64, ly / ny as f64);
    let cell_opts = FlowOptions {
        return_fields: true,
        ..opts.clone()
    };
    let cell = percolating(
        "base cell",
        reynolds::solve(coarse, lx, ly, axis, &cell_opts),
    )?;
    let base_window = Array2::from_shape_fn((wx + 1, wy + 1), |(a, b)| {
        coarse[[(window.i0 + a) % nx, (window.j0 + b) % ny]]
    });
    let window_opts = FlowOptions {
        return_fields: false,
        ..opts.clone()
    };
    let wc = percolating(
        "base window",
        between_isobars(base_window.view(), (dx, dy), axis, &window_opts),
    )?;
    let (fdx, fdy) = (dx / f as f64, dy / f as f64);
    let wf = percolating(
        "fine window",
        between_isobars(fine, (fdx, fdy), axis, &window_opts),
    )?;
    let (r_cc, r_wc, r_wf) = (1.0 / cell.flux, 1.0 / wc.flux, 1.0 / wf.flux);
    let flux = 1.0 / (r_cc - r_wc + r_wf);
    let (lflow, lcross) = match axis {
        FlowAxis::X => (lx, ly),
        FlowAxis::Y => (ly, lx),
    };
    let p = &cell.fields.as_ref().expect("fields asked for").pressure;
    let isobar_spread = end_line_spread(p.view(), window, axis);
    let open_side_nodes = open_side_nodes(fine, axis);
    Ok(WindowFlow {
        flux_cell_coarse: cell.flux,
        flux_window_coarse: wc.flux,
        flux_window_fine: wf.flux,
        flux,
        conductivity: flux * lflow / lcross,
        conductivity_coarse: cell.conductivity,
        neck_share: r_wc / r_cc,
        isobar_spread,
        open_side_nodes,
        iterations: [cell.iterations, wc.iterations, wf.iterations],
        wall_s: start.elapsed().as_secs_f64(),
    })
}

/// The spread of the periodic cell's pressure `p` (NaN off the flowing nodes; `p = −x ΔP/L + φ`
/// with x = i dx, so it drops by ΔP = 1 across the periodic wrap) on the window's two end
/// lines, over the mean drop between them.
fn end_line_spread(p: ArrayView2<f64>, w: FlowWindow, axis: FlowAxis) -> f64 {
    let (nx, ny) = p.dim();
    let line = |k: usize| -> Vec<f64> {
        match axis {
            FlowAxis::X => {
                let (i, wraps) = ((w.i0 + k) % nx, (w.i0 + k) / nx);
                (0..=w.wy)
                    .map(|b| p[[i, (w.j0 + b) % ny]] - wraps as f64)
                    .filter(|v| v.is_finite())
                    .collect()
            }
            FlowAxis::Y => {
                let (j, wraps) = ((w.j0 + k) % ny, (w.j0 + k) / ny);
                (0..=w.wx)
                    .map(|a| p[[(w.i0 + a) % nx, j]] - wraps as f64)
                    .filter(|v| v.is_finite())
                    .collect()
            }
        }
    };
    let last = match axis {
        FlowAxis::X => w.wx,
        FlowAxis::Y => w.wy,
    };
    let (a, b) = (line(0), line(last));
    if a.is_empty() || b.is_empty() {
        return f64::NAN;
    }
    let stats = |v: &[f64]| {
        let (lo, hi) = v
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        (v.iter().sum::<f64>() / v.len() as f64, hi - lo)
    };
    let ((ma, sa), (mb, sb)) = (stats(&a), stats(&b));
    sa.max(sb) / (ma - mb).abs()
}

/// The refinement factor 2^k of `refined` on the base grid `base`.
fn refinement_factor(refined: &Refined, base: &Grid) -> Result<usize, WindowFlowError> {
    let (fnx, fny) = refined.lattice;
    let f = fnx / base.nx;
    if f < 2 || fnx != f * base.nx || fny != f * base.ny {
        return Err(param(
            "base grid",
            format!("{} × {}", base.nx, base.ny),
            format!("the refined solve's base grid (fine lattice {fnx} × {fny})"),
        ));
    }
    Ok(f)
}

/// The base gap of a refined solve on every base node (nx × ny): inside the refined region the
/// fine gap at the node, outside it the coarse unknown's gap (its hat-weighted mean gap, the
/// quantity the composite contact conditions hold for). Values below 0 (penetration within the
/// solver's `tol_gap`) are set to 0. Reads the composite solution's packing (fine unknowns of
/// the region row by row, then the base nodes outside it in row-major order) and checks it
/// against [`Refined::base_pressure`].
pub fn base_gap(refined: &Refined, base: &Grid) -> Result<Array2<f64>, WindowFlowError> {
    let f = refinement_factor(refined, base)?;
    let (fnx, fny) = refined.lattice;
    let (rx, ry) = refined.window_gap.dim();
    let (o0, o1) = refined.origin;
    let gap: Vec<f64> = refined.composite.gap.iter().copied().collect();
    let force: Vec<f64> = refined.composite.pressure.iter().copied().collect();
    let mut next = rx * ry;
    let mut out = Array2::zeros((base.nx, base.ny));
    for i in 0..base.nx {
        for j in 0..base.ny {
            let (a, b) = ((f * i + fnx - o0) % fnx, (f * j + fny - o1) % fny);
            let g = if a < rx && b < ry {
                refined.window_gap[[a, b]]
            } else {
                let (g, r) = (gap[next], force[next]);
                if (r > 0.0) != (refined.base_pressure[[i, j]] > 0.0) {
                    return Err(param(
                        "refined solution",
                        format!("base node ({i}, {j})"),
                        "the packing of contact::refinement (coarse unknowns row-major after the region); it changed",
                    ));
                }
                next += 1;
                g
            };
            out[[i, j]] = g.max(0.0);
        }
    }
    Ok(out)
}

/// The composite flow of a refined solve: [`series_replacement`] with the base gap
/// ([`base_gap`]) and the fine gap of `window` cut out of [`Refined::window_gap`].
pub fn refined_flow(
    refined: &Refined,
    base: &Grid,
    window: FlowWindow,
    axis: FlowAxis,
    opts: &FlowOptions,
) -> Result<WindowFlow, WindowFlowError> {
    let f = refinement_factor(refined, base)?;
    let (fnx, fny) = refined.lattice;
    let (rx, ry) = refined.window_gap.dim();
    let a0 = (f * window.i0 + fnx - refined.origin.0) % fnx;
    let b0 = (f * window.j0 + fny - refined.origin.1) % fny;
    if a0 + f * window.wx >= rx || b0 + f * window.wy >= ry {
        return Err(param(
            "flow window",
            format!("{window:?}"),
            format!(
                "inside the refined region (fine nodes {:?} + {rx} × {ry})",
                refined.origin
            ),
        ));
    }
    let fine = refined
        .window_gap
        .slice(ndarray::s![
            a0..=a0 + f * window.wx,
            b0..=b0 + f * window.wy
        ])
        .mapv(|g| g.max(0.0));
    let coarse = base_gap(refined, base)?;
    series_replacement(
        coarse.view(),
        base.lx,
        base.ly,
        fine.view(),
        f,
        window,
        axis,
        opts,
    )
}

/// A refined saddle's flow window: a rectangle of base nodes around the saddle and the grid
/// axis of its two-terminal (isobar) problem, the axis nearest the saddle's channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SaddleFlowWindow {
    /// The window (base nodes).
    pub window: FlowWindow,
    /// Axis of the window's own flow problem.
    pub axis: FlowAxis,
}

impl SaddleFlowWindow {
    /// The flow window inside the refined region `region` around a saddle whose channel lies
    /// at `angle_deg` (0° = x): its axis the grid axis nearest the channel, trimmed as
    /// [`FlowWindow::within`].
    pub fn around(
        region: Window,
        angle_deg: f64,
        base: &Grid,
        trim_along: usize,
        trim_across: usize,
    ) -> Result<SaddleFlowWindow, WindowFlowError> {
        let a = angle_deg.to_radians();
        let axis = if a.cos().abs() >= a.sin().abs() {
            FlowAxis::X
        } else {
            FlowAxis::Y
        };
        Ok(SaddleFlowWindow {
            window: FlowWindow::within(region, base, axis, trim_along, trim_across)?,
            axis,
        })
    }
}

/// One window of [`scaled_replacement`].
#[derive(Debug, Clone, PartialEq)]
pub struct WindowScale {
    /// Flux through the window between its isobaric end lines on the base gap (ΔP = 1).
    pub flux_coarse: f64,
    /// The same on the fine gap.
    pub flux_fine: f64,
    /// s = flux_fine / flux_coarse, the factor on g³ of the window's base nodes.
    pub scale: f64,
    /// Open fine nodes on the window's two side lines (closed in the window problems).
    pub open_side_nodes: usize,
}

/// The flow of a cell with several refined windows ([`scaled_replacement`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MultiWindowFlow {
    /// Conductivity of the cell with every window's conductance replaced.
    pub conductivity: f64,
    /// The base cell's own conductivity.
    pub conductivity_coarse: f64,
    /// Per window, in order.
    pub windows: Vec<WindowScale>,
    /// Wall time of all flow solves (s).
    pub wall_s: f64,
}

/// The two-terminal flow through a window's gap `gap` (nodes × `spacing` = its size): the end
/// lines across `axis` held as isobars (ΔP = 1), the sides closed.
pub(crate) fn between_isobars(
    gap: ArrayView2<f64>,
    spacing: (f64, f64),
    axis: FlowAxis,
    opts: &FlowOptions,
) -> Result<FlowResult, reynolds::FlowError> {
    let (nx, ny) = gap.dim();
    reynolds::solve_between_isobars(
        gap,
        nx as f64 * spacing.0,
        ny as f64 * spacing.1,
        axis,
        SideEdges::NoFlux,
        opts,
    )
}

/// Open nodes of `gap` on the two side lines along `axis` (closed in the window problems).
pub(crate) fn open_side_nodes(gap: ArrayView2<f64>, axis: FlowAxis) -> usize {
    let (fx, fy) = gap.dim();
    let side = |a: usize, b: usize| usize::from(gap[[a, b]] > 0.0);
    match axis {
        FlowAxis::X => (0..fx).map(|a| side(a, 0) + side(a, fy - 1)).sum(),
        FlowAxis::Y => (0..fy).map(|b| side(0, b) + side(fx - 1, b)).sum(),
    }
}

/// A flow result that converged, percolates and carries a positive flux (else an error naming
/// `which` problem and why).
pub(crate) fn percolating(
    which: &'static str,
    r: Result<FlowResult, reynolds::FlowError>,
) -> Result<FlowResult, WindowFlowError> {
    let r = usable(which, r)?;
    if !r.percolating || r.flux <= 0.0 {
        return Err(WindowFlowError::Flow {
            which,
            detail: format!(
                "not usable: percolating {}, flux {:e}",
                r.percolating, r.flux
            ),
        });
    }
    Ok(r)
}

/// A flow result that converged (else an error naming `which` problem and why).
fn usable(
    which: &'static str,
    r: Result<FlowResult, reynolds::FlowError>,
) -> Result<FlowResult, WindowFlowError> {
    let r = r.map_err(|e| WindowFlowError::Flow {
        which,
        detail: e.to_string(),
    })?;
    if !r.converged {
        return Err(WindowFlowError::Flow {
            which,
            detail: format!("not converged ({:?})", r.termination),
        });
    }
    Ok(r)
}

/// Flow along `axis` of the periodic cell `lx × ly` whose base gap is `coarse`, with the
/// conductance of each window replaced by that of its fine gap (`fines[w]`: (f wx + 1) ×
/// (f wy + 1) fine nodes of `windows[w].window`, first index x). Each window's two-terminal
/// problem (isobaric end lines across its own axis, closed sides) is solved on both gaps; its
/// flux ratio s = Q_fine / Q_coarse multiplies g³ on every base node of the window (g × s^⅓),
/// which multiplies every face conductance inside the window, and so the window's two-terminal
/// conductance, by exactly s; the cell is then solved once more. See the module docs,
/// "Several windows", for what this gets right (series and parallel windows, any number) and
/// what it approximates (the faces that join a window's edge nodes to the rest).
#[allow(clippy::too_many_arguments)]
pub fn scaled_replacement(
    coarse: ArrayView2<f64>,
    lx: f64,
    ly: f64,
    fines: &[ArrayView2<f64>],
    f: usize,
    windows: &[SaddleFlowWindow],
    axis: FlowAxis,
    opts: &FlowOptions,
) -> Result<MultiWindowFlow, WindowFlowError> {
    let start = Instant::now();
    let (nx, ny) = coarse.dim();
    if fines.len() != windows.len() || windows.is_empty() {
        return Err(param(
            "windows",
            format!("{} windows, {} fine gaps", windows.len(), fines.len()),
            "one fine gap per window, at least one window",
        ));
    }
    let (dx, dy) = (lx / nx as f64, ly / ny as f64);
    let mut owner = Array2::<Option<usize>>::from_elem((nx, ny), None);
    let mut scales = Vec::with_capacity(windows.len());
    for (k, (sw, fine)) in windows.iter().zip(fines).enumerate() {
        let w = sw.window;
        if f == 0 || fine.dim() != (f * w.wx + 1, f * w.wy + 1) {
            return Err(param(
                "fine window shape",
                format!("window {k}: {:?}", fine.dim()),
                format!(
                    "(f wx + 1, f wy + 1) = ({}, {})",
                    f * w.wx + 1,
                    f * w.wy + 1
                ),
            ));
        }
        if w.wx + 1 > nx || w.wy + 1 > ny || w.i0 >= nx || w.j0 >= ny {
            return Err(param(
                "window",
                format!("window {k}: {w:?}"),
                format!(
                    "at most {} × {} base cells, first node inside the grid",
                    nx - 1,
                    ny - 1
                ),
            ));
        }
        for a in 0..=w.wx {
            for b in 0..=w.wy {
                let node = ((w.i0 + a) % nx, (w.j0 + b) % ny);
                if let Some(other) = owner[node] {
                    return Err(param(
                        "windows",
                        format!(
                            "window {other} {:?} and window {k} {w:?}",
                            windows[other].window
                        ),
                        "disjoint (no common base node)",
                    ));
                }
                owner[node] = Some(k);
            }
        }
        let base_window = Array2::from_shape_fn((w.wx + 1, w.wy + 1), |(a, b)| {
            coarse[[(w.i0 + a) % nx, (w.j0 + b) % ny]]
        });
        let (fdx, fdy) = (dx / f as f64, dy / f as f64);
        let wc = usable(
            "base window",
            between_isobars(base_window.view(), (dx, dy), sw.axis, opts),
        )?;
        let wf = usable(
            "fine window",
            between_isobars(*fine, (fdx, fdy), sw.axis, opts),
        )?;
        let (qc, qf) = (
            if wc.percolating { wc.flux } else { 0.0 },
            if wf.percolating { wf.flux } else { 0.0 },
        );
        let scale = match (qc > 0.0, qf > 0.0) {
            (true, _) => qf / qc,
            (false, false) => 1.0,
            (false, true) => {
                return Err(WindowFlowError::Flow {
                    which: "base window",
                    detail: format!(
                        "window {k} {w:?}: closed on the base gap but open on the fine gap \
                         (flux {qf:e}); a closed coarse window cannot be rescaled"
                    ),
                });
            }
        };
        scales.push(WindowScale {
            flux_coarse: qc,
            flux_fine: qf,
            scale,
            open_side_nodes: open_side_nodes(*fine, sw.axis),
        });
    }
    let cell = usable("base cell", reynolds::solve(coarse, lx, ly, axis, opts))?;
    let modified = Array2::from_shape_fn((nx, ny), |(i, j)| match owner[[i, j]] {
        Some(k) => coarse[[i, j]] * scales[k].scale.cbrt(),
        None => coarse[[i, j]],
    });
    let scaled = usable(
        "rescaled cell",
        reynolds::solve(modified.view(), lx, ly, axis, opts),
    )?;
    let k_of = |r: &FlowResult| if r.percolating { r.conductivity } else { 0.0 };
    Ok(MultiWindowFlow {
        conductivity: k_of(&scaled),
        conductivity_coarse: k_of(&cell),
        windows: scales,
        wall_s: start.elapsed().as_secs_f64(),
    })
}

/// The fine gap of `window` cut out of the refined solution (from whichever refined region
/// holds it), negative gaps set to 0.
pub fn fine_window_gap(
    refined: &Refined,
    base: &Grid,
    window: FlowWindow,
) -> Result<Array2<f64>, WindowFlowError> {
    let f = refinement_factor(refined, base)?;
    let (fnx, fny) = refined.lattice;
    for r in &refined.windows {
        let (rx, ry) = r.gap.dim();
        let a0 = (f * window.i0 + fnx - r.origin.0) % fnx;
        let b0 = (f * window.j0 + fny - r.origin.1) % fny;
        if a0 + f * window.wx < rx && b0 + f * window.wy < ry {
            return Ok(r
                .gap
                .slice(ndarray::s![
                    a0..=a0 + f * window.wx,
                    b0..=b0 + f * window.wy
                ])
                .mapv(|g| g.max(0.0)));
        }
    }
    Err(param(
        "flow window",
        format!("{window:?}"),
        "inside one refined region of the solution",
    ))
}

/// The flow of a refined solve with several windows: [`scaled_replacement`] with the base gap
/// ([`Refined::base_gap`]) and each window's fine gap ([`fine_window_gap`]).
pub fn refined_multi_flow(
    refined: &Refined,
    base: &Grid,
    windows: &[SaddleFlowWindow],
    axis: FlowAxis,
    opts: &FlowOptions,
) -> Result<MultiWindowFlow, WindowFlowError> {
    let f = refinement_factor(refined, base)?;
    let fines: Vec<Array2<f64>> = windows
        .iter()
        .map(|w| fine_window_gap(refined, base, w.window))
        .collect::<Result<_, _>>()?;
    let coarse = refined.base_gap.mapv(|g| g.max(0.0));
    let views: Vec<ArrayView2<f64>> = fines.iter().map(|a| a.view()).collect();
    scaled_replacement(
        coarse.view(),
        base.lx,
        base.ly,
        &views,
        f,
        windows,
        axis,
        opts,
    )
}

/// Options of [`compare`].
#[derive(Debug, Clone, PartialEq)]
pub struct CompareOptions {
    /// Model.
    pub lattice: Lattice,
    /// Base grid exponent (2^n nodes per side).
    pub base_n: u32,
    /// Refinement levels k.
    pub levels: u32,
    /// Refined region: base cells per side, square around the saddle.
    pub region: usize,
    /// Blockwise operator margin (base cells), or None for the full composite operator.
    pub margin: Option<usize>,
    /// Trims of the flow window inside the region ([`FlowWindow::inside`]).
    pub trim_along: usize,
    /// See `trim_along`.
    pub trim_across: usize,
    /// Reduced loads l = p/p_c − 1 (< 0).
    pub loads: Vec<f64>,
    /// Contact solver tolerance (h0).
    pub tol_gap: f64,
    /// Bisection bracket for p_c as fractions of the grid's p_fc.
    pub bracket: (f64, f64),
    /// Relative width at which the bisection stops.
    pub rel_width: f64,
    /// Also solve the uniform fine grid (2^(n + k)) as the reference.
    pub uniform: bool,
}

impl Default for CompareOptions {
    fn default() -> Self {
        CompareOptions {
            lattice: Lattice::Square,
            base_n: 5,
            levels: 2,
            region: 8,
            margin: None,
            trim_along: 2,
            trim_across: 1,
            loads: vec![-1e-2, -5e-3, -2e-3, -1e-3, -5e-4],
            tol_gap: 1e-13,
            bracket: (0.2, 0.25),
            rel_width: 1e-9,
            uniform: true,
        }
    }
}

/// One reduced load of [`compare`].
#[derive(Debug, Clone, PartialEq)]
pub struct CompareRow {
    /// Reduced load.
    pub l: f64,
    /// Saddle gap of the uniform fine solve (h0).
    pub gap_uniform: Option<f64>,
    /// Saddle gap of the refined solve (h0).
    pub gap_refined: f64,
    /// K of the uniform fine cell along the channel.
    pub k_uniform: Option<f64>,
    /// The series replacement applied to the uniform fine solution itself (its gap subsampled
    /// on the base nodes, the fine gap in the flow window): the flow method's own error is
    /// `k_uniform_windowed / k_uniform − 1`.
    pub k_uniform_windowed: Option<f64>,
    /// The refined cell's flow.
    pub refined: WindowFlow,
}

/// The refined and uniform discretisations over the reduced loads, each at its own p_c.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// p_c / p_fc of the uniform fine grid.
    pub pc_uniform: Option<f64>,
    /// p_c / p_fc of the refined discretisation.
    pub pc_refined: f64,
    /// Flow axis (the channel's).
    pub axis: FlowAxis,
    /// The flow window.
    pub window: FlowWindow,
    /// Rows in the order of `loads`.
    pub rows: Vec<CompareRow>,
    /// Wall time of the uniform bisection, loads and flows (s).
    pub wall_uniform: f64,
    /// Wall time of the refined bisection, loads and flows (s).
    pub wall_refined: f64,
}

/// Bisects the load (fraction of p_fc) at which `saddle_gap(load)` reaches 0.
fn bisect(
    bracket: (f64, f64),
    rel_width: f64,
    mut saddle_gap: impl FnMut(f64) -> Result<f64, WindowFlowError>,
) -> Result<f64, WindowFlowError> {
    let (mut lo, mut hi) = bracket;
    if saddle_gap(lo)? <= 0.0 || saddle_gap(hi)? > 0.0 {
        return Err(param(
            "bracket",
            format!("{bracket:?}"),
            "fractions of p_fc with the saddle open at the first and closed at the second",
        ));
    }
    while hi / lo - 1.0 > rel_width {
        let mid = 0.5 * (lo + hi);
        if saddle_gap(mid)? > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// Solves the refined discretisation (base 2^n, k levels, a square region around the saddle
/// that [`crate::ladder::axis_saddle`] picks) and, if asked, the uniform fine one, each at the
/// reduced loads from its own p_c (bisection on the saddle node's gap), and the flow along the
/// channel: [`refined_flow`] and the uniform cell's periodic [`reynolds::solve`].
pub fn compare(opts: &CompareOptions) -> Result<Comparison, WindowFlowError> {
    if let Some(&l) = opts.loads.iter().find(|l| !(**l < 0.0 && **l > -1.0)) {
        return Err(param("loads", l, "reduced loads in (−1, 0)"));
    }
    if opts.loads.is_empty() {
        return Err(param("loads", "[]", "at least one reduced load"));
    }
    let surf = |n: u32| Surface::new(opts.lattice, n).map_err(|e| param("grid exponent", n, e));
    let base = surf(opts.base_n)?;
    let frame = crate::ladder::axis_saddle(&base).map_err(|e| param("lattice", "", e))?;
    let axis = if frame.channel_axis == 0 {
        FlowAxis::X
    } else {
        FlowAxis::Y
    };
    let solver = SolverOptions {
        tol_gap: opts.tol_gap,
        ..Default::default()
    };
    let fopts = FlowOptions::default();
    let pfc = base.p_fc_grid();
    let f = 1usize << opts.levels;
    let region = Window::centred(&base.grid, frame.x, frame.y, opts.region, opts.region);
    let window = FlowWindow::within(region, &base.grid, axis, opts.trim_along, opts.trim_across)?;

    // uniform fine reference
    let t = Instant::now();
    let mut uniform = None;
    if opts.uniform {
        let fine = surf(opts.base_n + opts.levels)?;
        let pfc_f = fine.p_fc_grid();
        let mut model = Model::new(&fine).map_err(|e| param("uniform grid", "", e))?;
        let node = (frame.node.0 * f, frame.node.1 * f);
        let mut warm: Option<Solution> = None;
        let mut solve = |load: f64| -> Result<Solution, WindowFlowError> {
            let s = model
                .solve(Interaction::HardWall, load, &solver, warm.as_ref())
                .map_err(|e| WindowFlowError::Contact {
                    which: "uniform",
                    load,
                    detail: e.to_string(),
                })?;
            if !s.stats.converged {
                return Err(WindowFlowError::Contact {
                    which: "uniform",
                    load,
                    detail: format!("not converged: {:?}", s.stats.reason),
                });
            }
            warm = Some(s.clone());
            Ok(s)
        };
        let pc = bisect(opts.bracket, opts.rel_width, |x| {
            Ok(solve(x * pfc_f)?.gap[[node.0, node.1]])
        })?;
        let mut rows = Vec::new();
        for &l in &opts.loads {
            let s = solve(pc * (1.0 + l) * pfc_f)?;
            let r = reynolds::solve(s.gap.view(), fine.grid.lx, fine.grid.ly, axis, &fopts)
                .map_err(|e| WindowFlowError::Flow {
                    which: "uniform cell",
                    detail: e.to_string(),
                })?;
            if !r.converged {
                return Err(WindowFlowError::Flow {
                    which: "uniform cell",
                    detail: format!("not converged ({:?}) at l = {l}", r.termination),
                });
            }
            let sub = Array2::from_shape_fn((base.grid.nx, base.grid.ny), |(i, j)| {
                s.gap[[f * i, f * j]].max(0.0)
            });
            let (fnx, fny) = s.gap.dim();
            let fine_window =
                Array2::from_shape_fn((f * window.wx + 1, f * window.wy + 1), |(a, b)| {
                    s.gap[[(f * window.i0 + a) % fnx, (f * window.j0 + b) % fny]].max(0.0)
                });
            let windowed = series_replacement(
                sub.view(),
                base.grid.lx,
                base.grid.ly,
                fine_window.view(),
                f,
                window,
                axis,
                &fopts,
            )?;
            rows.push((
                s.gap[[node.0, node.1]],
                r.conductivity,
                windowed.conductivity,
            ));
        }
        uniform = Some((pc, rows));
    }
    let wall_uniform = t.elapsed().as_secs_f64();

    // refined
    let t = Instant::now();
    let ropts = RefineOptions {
        levels: opts.levels,
        window: region,
        solver: solver.clone(),
    };
    let mut model = match opts.margin {
        None => RefinedModel::new(&base, &ropts),
        Some(m) => RefinedModel::blockwise(&base, &ropts, m),
    }
    .map_err(|e| param("refinement", format!("{ropts:?}"), e))?;
    let node = (frame.node.0 * f, frame.node.1 * f);
    let mut warm: Option<Refined> = None;
    let mut solve = |load: f64| -> Result<Refined, WindowFlowError> {
        let err = |e: contact::ContactError| WindowFlowError::Contact {
            which: "refined",
            load,
            detail: e.to_string(),
        };
        let mut r = model.solve(load, warm.as_ref()).map_err(err)?;
        if !r.stats.converged && warm.is_some() {
            // a warm start from a distant load can stagnate (seen at k = 4): retry cold
            r = model.solve(load, None).map_err(err)?;
        }
        if !r.stats.converged {
            return Err(WindowFlowError::Contact {
                which: "refined",
                load,
                detail: format!("not converged: {:?}", r.stats.reason),
            });
        }
        warm = Some(r.clone());
        Ok(r)
    };
    let gap_at = |r: &Refined| r.fine_gap(node.0, node.1).unwrap_or(f64::NAN);
    let pc = bisect(opts.bracket, opts.rel_width, |x| {
        Ok(gap_at(&solve(x * pfc)?))
    })?;
    let mut rows = Vec::new();
    for (k, &l) in opts.loads.iter().enumerate() {
        let r = solve(pc * (1.0 + l) * pfc)?;
        let flow = refined_flow(&r, &base.grid, window, axis, &fopts)?;
        let u = uniform.as_ref().map(|(_, u)| u[k]);
        rows.push(CompareRow {
            l,
            gap_uniform: u.map(|u| u.0),
            gap_refined: gap_at(&r),
            k_uniform: u.map(|u| u.1),
            k_uniform_windowed: u.map(|u| u.2),
            refined: flow,
        });
    }
    Ok(Comparison {
        pc_uniform: uniform.map(|u| u.0),
        pc_refined: pc,
        axis,
        window,
        rows,
        wall_uniform,
        wall_refined: t.elapsed().as_secs_f64(),
    })
}

/// The running exponent d ln y / d ln |l| between neighbouring loads: one value per pair.
pub fn running(ls: &[f64], ys: &[f64]) -> Vec<f64> {
    ls.windows(2)
        .zip(ys.windows(2))
        .map(|(l, y)| (y[1] / y[0]).ln() / (l[1] / l[0]).ln())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        (a / b - 1.0).abs()
    }

    /// Harmonic mean of two conductances.
    fn h(a: f64, b: f64) -> f64 {
        2.0 * a * b / (a + b)
    }

    /// Oracle without a contact solve: a straight channel (a band of rows, contact outside it)
    /// whose gap varies only along the flow. Every node column is an isobar, so the series
    /// replacement is exact: the composite resistance is the coarse faces' series sum outside
    /// the window over the coarse band width plus the fine faces' sum inside it over the fine
    /// band width. The window wraps the periodic edge along the flow; both flow axes.
    #[test]
    fn a_channel_varying_along_the_flow_is_replaced_exactly() {
        let (nx, ny, lx, ly, f) = (32usize, 16usize, 1.0, 0.5, 4usize);
        let (dx, dy) = (lx / nx as f64, ly / ny as f64);
        let tau = 2.0 * std::f64::consts::PI;
        // narrowest near x = 0, inside the window
        let g = |x: f64| 0.06 - 0.04 * (tau * x).cos() + 0.01 * (3.0 * tau * x).sin();
        let band = |y: f64| (y - 0.25).abs() < 0.1;
        let w = FlowWindow {
            i0: 28,
            j0: 2,
            wx: 8,
            wy: 12,
        };
        let coarse = Array2::from_shape_fn((nx, ny), |(i, j)| {
            if band(j as f64 * dy) {
                g(i as f64 * dx)
            } else {
                0.0
            }
        });
        let fine = Array2::from_shape_fn((f * w.wx + 1, f * w.wy + 1), |(a, b)| {
            let y = (w.j0 as f64 + b as f64 / f as f64) * dy;
            if band(y) {
                g((w.i0 as f64 + a as f64 / f as f64) * dx)
            } else {
                0.0
            }
        });
        // rows of the band: 7 coarse (j = 5..=11), 25 fine
        let rows_c = (0..ny).filter(|&j| band(j as f64 * dy)).count() as f64;
        let rows_f = (0..=f * w.wy)
            .filter(|&b| band((w.j0 as f64 + b as f64 / f as f64) * dy))
            .count() as f64;
        assert_eq!((rows_c, rows_f), (7.0, 25.0));
        let face = |x0: f64, x1: f64, d: f64| d / h(g(x0).powi(3), g(x1).powi(3));
        // the window's last node i0 + wx = 36 ≡ 4, the cell's faces from there round to i0
        let outside: f64 = (w.i0 + w.wx..w.i0 + nx)
            .map(|i| face(i as f64 * dx, (i + 1) as f64 * dx, dx))
            .sum();
        let inside: f64 = (0..f * w.wx)
            .map(|a| {
                let x = |a: usize| (w.i0 as f64 + a as f64 / f as f64) * dx;
                face(x(a), x(a + 1), dx / f as f64)
            })
            .sum();
        let r = outside / (rows_c * dy) + inside / (rows_f * dy / f as f64);
        let want = lx / (r * ly);
        let opts = FlowOptions::default();
        let got = series_replacement(coarse.view(), lx, ly, fine.view(), f, w, FlowAxis::X, &opts)
            .unwrap();
        // exact discrete values: rounding and the 1e-10 residual target (flux error quadratic)
        assert!(rel(got.conductivity, want) < 1e-11, "{got:?} vs {want}");
        // isobars up to the pressure's first-order error in the residual
        assert!(got.isobar_spread < 1e-8, "{got:?}");
        assert_eq!(got.open_side_nodes, 0);
        assert!(got.neck_share > 0.0 && got.neck_share < 1.0);
        // the coarse cell alone differs (so the check above can fail)
        assert!(rel(got.conductivity_coarse, want) > 1e-3, "{got:?}");
        // the same transposed, flow along y
        let wt = FlowWindow {
            i0: w.j0,
            j0: w.i0,
            wx: w.wy,
            wy: w.wx,
        };
        let got_t =
            series_replacement(coarse.t(), ly, lx, fine.t(), f, wt, FlowAxis::Y, &opts).unwrap();
        assert!(rel(got_t.conductivity, want) < 1e-11, "{got_t:?} vs {want}");
    }

    /// Without a contact solve: the analytic gap g = max(0, ε + cos 2πx + cos 2πy), whose
    /// saddle (1/2, 0) has its channel along x (gap ε at the saddle, contact walls across it).
    /// The composite (base 32² outside, fine ×4 in a window around the saddle that wraps the
    /// cell's edge across the flow) against the uniform 128² cell: the error is the base grid's
    /// discretisation of the rest of the cell plus the end lines' departure from isobars, both
    /// shrinking with the neck's share of the resistance as ε → 0, while the base grid alone
    /// misses the neck.
    #[test]
    fn the_composite_follows_the_uniform_fine_grid_as_the_neck_closes() {
        let (n, f) = (32usize, 4usize);
        let tau = 2.0 * std::f64::consts::PI;
        let w = FlowWindow {
            i0: 12,
            j0: 25,
            wx: 8,
            wy: 14,
        };
        let opts = FlowOptions::default();
        let mut last = f64::INFINITY;
        // measured: −8.4e-4, −3.0e-6, −3.4e-9, −4.1e-12 (the error falls like ε³, as the rest
        // of the cell's share of the resistance, 1 − share: 8e-3, 2e-5, …); bounds ~2–3× above
        for (eps, bound) in [(1e-1, 2e-3), (1e-2, 1e-5), (1e-3, 1e-8), (1e-4, 1e-11)] {
            let gap = |x: f64, y: f64| (eps + (tau * x).cos() + (tau * y).cos()).max(0.0);
            let m = n * f;
            let uniform = Array2::from_shape_fn((m, m), |(i, j)| {
                gap(i as f64 / m as f64, j as f64 / m as f64)
            });
            let k_u = reynolds::solve(uniform.view(), 1.0, 1.0, FlowAxis::X, &opts)
                .unwrap()
                .conductivity;
            let coarse = Array2::from_shape_fn((n, n), |(i, j)| uniform[[f * i, f * j]]);
            let fine = Array2::from_shape_fn((f * w.wx + 1, f * w.wy + 1), |(a, b)| {
                uniform[[(f * w.i0 + a) % m, (f * w.j0 + b) % m]]
            });
            let c = series_replacement(
                coarse.view(),
                1.0,
                1.0,
                fine.view(),
                f,
                w,
                FlowAxis::X,
                &opts,
            )
            .unwrap();
            let (err, err_base) = (rel(c.conductivity, k_u), rel(c.conductivity_coarse, k_u));
            eprintln!(
                "ε = {eps:e}: K uniform {k_u:.6e}, composite {:+.2e}, base alone {:+.2e}, share {:.6}, spread {:.1e}, open sides {}",
                c.conductivity / k_u - 1.0,
                c.conductivity_coarse / k_u - 1.0,
                c.neck_share,
                c.isobar_spread,
                c.open_side_nodes
            );
            assert!(err < bound, "ε = {eps}: {err} above {bound}");
            assert!(err < 0.1 * err_base, "ε = {eps}: {err} vs base {err_base}");
            assert!(err < last, "ε = {eps}: {err} did not fall (was {last})");
            last = err;
        }
    }

    #[test]
    fn windows_that_do_not_fit_are_refused() {
        let grid = Grid {
            nx: 32,
            ny: 32,
            lx: 1.0,
            ly: 1.0,
            shift: (0.0, 0.0),
        };
        let region = Window {
            i0: 10,
            j0: 10,
            wx: 12,
            wy: 12,
        };
        let w = FlowWindow::within(region, &grid, FlowAxis::Y, 3, 1).unwrap();
        assert_eq!((w.i0, w.j0, w.wx, w.wy), (11, 13, 10, 6));
        // 12 − 2·4 = 4 cells along the flow: too few for the isobar problem
        let e = FlowWindow::within(region, &grid, FlowAxis::X, 4, 1).unwrap_err();
        assert!(e.to_string().contains("trim along x"), "{e}");
        let coarse = Array2::from_elem((32, 32), 0.1);
        let fine = Array2::from_elem((41, 24), 0.1);
        let e = series_replacement(
            coarse.view(),
            1.0,
            1.0,
            fine.view(),
            4,
            w,
            FlowAxis::Y,
            &FlowOptions::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("(41, 24)"), "{e}");
    }
}
