//! stages: the stage kinds of the saddleflow pipeline, registered for the orchestrator.
//!
//! [`registry()`] is the one list of kinds the CLI knows. Each kind lives in its own module and
//! implements [`orchestrator::StageKind`]: name, code version (bump it when results change),
//! parameter schema with defaults, inputs, side outputs, `run`.
//!
//! | kind | what | inputs | output |
//! |---|---|---|---|
//! | `surface` | one of the three models on a 2^n × 2^n grid, statistics, critical points | – | `height`, `lx`, `ly`, `critical/*` |
//! | `flow` | Reynolds flow at every stored gap of a load path: flux, conductivity, percolation, where flow stops; optional current densities | `sweep` | `points/*`, `stops/*`, `currents/*` |
//! | `flowmap` | current density at a near-critical hard-wall state l = (L − L_c)/L_c < 0 (L_c by bisection on the grid) | `surface` | `gap`, `pressure`, `current_x`, `current_y`, `bisection/*` |
//! | `mock` | engine tests: sums its inputs' values, may sleep or fail | `inputs` (any, optional) | `value` |

pub mod flow;
pub mod flowmap;
pub mod gapfile;
pub mod io;
pub mod mock;
pub mod surface;

/// Re-exported so the CLI reaches the engine through this crate.
pub use orchestrator;
use orchestrator::Registry;

/// Every stage kind of saddleflow.
pub fn registry() -> Registry {
    let mut r = Registry::new();
    r.register(surface::SurfaceKind);
    r.register(flow::FlowKind);
    r.register(flowmap::FlowMapKind);
    r.register(mock::MockKind);
    r
}
