//! stages: the stage kinds of the saddleflow pipeline, registered for the orchestrator.
//!
//! [`registry()`] is the one list of kinds the CLI knows. Each kind lives in its own module and
//! implements [`orchestrator::StageKind`]: name, code version (bump it when results change),
//! parameter schema with defaults, inputs, side outputs, `run`.
//!
//! | kind | what | inputs | output |
//! |---|---|---|---|
//! | `surface` | one of the three models on a 2^n × 2^n grid, statistics, critical points | – | `height`, `lx`, `ly`, `critical/*` |
//! | `sweep` | quasi-static loading/unloading path (or γ path at fixed load): area, gap, energy, solver statistics per point, detected jumps, pull-off | `surface` | `points/*`, `jumps/*`, `ended/*`, optional `fields/*` |
//! | `figure` | one of the paper's figures (`scene = "fig1"`, `"fig2"`, `"fig3"`, `"fig4"`, `"fig6"`, `"convergence"`) | per scene (fig2: `hardwall`, `adhesion`, `repulsion` sweeps; fig1, fig3: `hexagonal`, `square`, `triangular` zero-load γ0 sweeps; fig4: `hexagonal`, `square`, `triangular` critical stages; fig6: `flow` stages, optional `current` flowmap and `ladder`; convergence: `hexagonal`, `square`, `triangular` resolution stages) | side outputs `figures/<scene>.png`, `.svg` |
//! | `table` | a scene's data as CSV (`scene = "fig2"`, `"fig2_resolution"`, `"fig3"`, `"fig6"`, `"critical"`) | per scene (as `figure`; critical: three resolution stages) | side outputs `results/tables/<scene>*.csv` (critical: also `critical.md`) |
//! | `flow` | Reynolds flow at every stored gap of a load path: flux, conductivity, percolation, where flow stops; optional current densities | `sweep` | `points/*`, `stops/*`, `currents/*` |
//! | `flowmap` | current density at a near-critical hard-wall state l = (L − L_c)/L_c < 0 (L_c by bisection on the grid) | `surface` | `gap`, `pressure`, `current_x`, `current_y`, `bisection/*` |
//! | `critical` | percolation threshold of the hard-wall contact on one or more grids (coarse to fine), averaged over sub-grid shifts: L_c brackets (x, y, any), a_p raw and corrected, sub-grid L_c and ζ from the saddle gap, the finest grid's near-critical fields | – | `level/<n>/*`, `gap`, `above/*` |
//! | `resolution` | one model's `critical` levels extrapolated to zero grid spacing; also the data of the convergence figures and the comparison table | `levels` (`critical`) | per quantity `v`, `sem`, `h` and the fit |
//! | `ladder` | hard-wall solves at reduced loads l around L_c (±0.002 … ±0.02 and 0), warm-started, coarse to fine: a window of gap and pressure around one saddle and the flux per rung | `critical` | `level/<n>/*` |
//! | `exponents` | ζ, υ, χ, β per model from the ladders (fit and grid-spread errors), the identity β = 3ζ + υ − χ | `ladder` (one per model) | `model/<lattice>/*` |
//! | `mock` | engine tests: sums its inputs' values, may sleep or fail | `inputs` (any, optional) | `value` |

pub mod code_identity;
pub mod critical;
pub mod exponents;
pub mod extremes;
pub mod fig1;
pub mod fig2;
pub mod fig3;
pub mod fig4;
pub mod fig5;
pub mod fig6;
pub mod figure;
pub mod flow;
pub mod flowmap;
pub mod gapfile;
pub mod headline;
pub mod io;
pub mod jumptable;
pub mod ladder;
pub mod mock;
pub mod resolution;
pub mod surface;
pub mod sweep;
pub mod table;
pub mod tradeoff;

/// Re-exported so the CLI reaches the engine through this crate.
pub use orchestrator;
use orchestrator::Registry;

/// Every stage kind of saddleflow.
pub fn registry() -> Registry {
    let mut r = Registry::new();
    r.register(surface::SurfaceKind);
    r.register(sweep::SweepKind);
    r.register(figure::FigureKind);
    r.register(table::TableKind);
    r.register(flow::FlowKind);
    r.register(flowmap::FlowMapKind);
    r.register(critical::CriticalKind);
    r.register(resolution::ResolutionKind);
    r.register(ladder::LadderKind);
    r.register(exponents::ExponentsKind);
    r.register(extremes::ExtremesKind);
    r.register(mock::MockKind);
    // every kind lives in the module of its name
    let names: Vec<String> = r.names().iter().map(|s| s.to_string()).collect();
    for name in names {
        if let Some(code) = code_identity::of(&name) {
            r.set_code_identity(&name, code);
        }
    }
    r
}
