//! kinds: the compute stage kinds of the saddleflow pipeline, each an adapter from typed
//! parameters and input artefacts to the physics crates and back to an artefact.
//!
//! | kind | what | inputs | output |
//! |---|---|---|---|
//! | `surface` | one of the three models on a 2^n × 2^n grid, statistics, critical points | – | `height`, `lx`, `ly`, `critical/*` |
//! | `sweep` | quasi-static loading/unloading path (or γ path at fixed load): area, gap, energy, solver statistics per point, detected jumps, pull-off | `surface` | `points/*`, `jumps/*`, `loops/*`, `ended/*`, `thresholds/*` (γ paths), optional `fields/*` |
//! | `flow` | Reynolds flow at every stored gap of a load path: flux, conductivity, percolation, where flow stops; optional current densities | `sweep` | `points/*`, `stops/*`, `currents/*` |
//! | `flowmap` | current density at a near-critical hard-wall state l = (L − L_c)/L_c < 0 (L_c by bisection on the grid) | `surface` | `gap`, `pressure`, `current_x`, `current_y`, `bisection/*` |
//! | `critical` | percolation threshold of the hard-wall contact on one or more grids (coarse to fine), averaged over sub-grid shifts: L_c brackets (x, y, any), a_p raw and corrected, sub-grid L_c and ζ from the saddle gap, the finest grid's near-critical fields | – | `level/<n>/*`, `gap`, `above/*` |
//! | `resolution` | one model's `critical` levels extrapolated to zero grid spacing | `levels` (`critical`) | per quantity `v`, `sem`, `h` and the fit |
//! | `ladder` | hard-wall solves at reduced loads l around L_c (±0.002 … ±0.02 and 0), warm-started, coarse to fine: a window of gap and pressure around one saddle and the flux per rung | `critical` | `level/<n>/*` |
//! | `exponents` | ζ, υ, χ, β per model from the ladders (fit and grid-spread errors), the identity β = 3ζ + υ − χ | `ladder` (one per model) | `model/<lattice>/*` |
//! | `extremes` | the solvers at extreme loads and grids, with wall time and peak memory | – | table side output |
//! | `selfaffine` | a self-affine random surface (H, q_r, q_s, rms height or slope, seed) on a periodic 2^n grid, statistics, binned PSD | – | `height`, `lx`, `ly`, `psd/*` |
//! | `topography` | a user's height file (.npy, .h5, text; its content in the key), statistics, binned PSD | – | `height`, `lx`, `ly`, `psd/*` |
//! | `leakage` | warm-started load path on any height field: area, gap, flux x/y, percolation per load; the fluid percolation load (bisection) and a_p; optional gap/pressure map | `surface` (`surface`, `selfaffine`, `topography`) | `points/*`, `percolation/*`, `map/*` |
//! | `constriction` | the last constriction of a surface near its fluid percolation load: L_c, a 1-2-5 ladder below it, flux, constriction gap, η, pressure-drop fraction per rung, running β and the β fit | `surface` (any height field) | summary attributes, `rungs/*`, `running/*`, `map/gap` |
//! | `mock` | engine tests: sums its inputs' values, may sleep or fail | `inputs` (any, optional) | `value` |
//!
//! Each kind lives in the module of its name and implements [`orchestrator::TypedKind`] (its
//! parameters a serde struct, registered through [`orchestrator::Typed`]); a kind with a large
//! artefact keeps its records in `<kind>_artefact` and its parameters in `<kind>_params` beside
//! it; [`solver`] holds the shared contact-solver parameters; the
//! readers of a kind's artefact live in its module too (the scenes read through them).
//! [`headline`] is the shared record of headline numbers that kinds publish.

pub mod constriction;
pub mod critical;
mod critical_write;
pub mod exponents;
pub mod extremes;
pub mod flow;
pub mod flow_artefact;
pub mod flowmap;
pub mod headline;
pub mod ladder;
pub mod leakage;
pub mod mock;
pub mod neck_truncation;
pub mod record_table;
pub mod refined_chain;
pub mod refined_ladder;
pub mod refined_neck;
pub mod refined_window;
pub mod resolution;
pub mod selfaffine;
pub mod solver;
pub mod surface;
pub mod sweep;
pub mod sweep_artefact;
pub mod sweep_params;
pub mod topography;

use orchestrator::{Registry, Typed};

/// Registers every compute kind.
pub fn register(r: &mut Registry) {
    r.register(Typed(surface::SurfaceKind));
    r.register(Typed(sweep::SweepKind));
    r.register(Typed(flow::FlowKind));
    r.register(Typed(flowmap::FlowMapKind));
    r.register(Typed(critical::CriticalKind));
    r.register(Typed(constriction::ConstrictionKind));
    r.register(Typed(resolution::ResolutionKind));
    r.register(Typed(ladder::LadderKind));
    r.register(Typed(refined_ladder::RefinedLadderKind));
    r.register(Typed(refined_window::RefinedWindowKind));
    r.register(Typed(exponents::ExponentsKind));
    r.register(Typed(extremes::ExtremesKind));
    r.register(Typed(mock::MockKind));
    r.register(Typed(selfaffine::SelfAffineKind));
    r.register(Typed(topography::TopographyKind));
    r.register(Typed(leakage::LeakageKind));
}
