//! stages: the stage kinds of the saddleflow pipeline, registered for the orchestrator.
//!
//! [`registry()`] is the one list of kinds the CLI knows. Each kind lives in its own module and
//! implements [`orchestrator::StageKind`]: name, code version (bump it when results change),
//! parameter schema with defaults, inputs, side outputs, `run`.
//!
//! | kind | what | inputs | output |
//! |---|---|---|---|
//! | `surface` | one of the three models on a 2^n × 2^n grid, statistics, critical points | – | `height`, `lx`, `ly`, `critical/*` |
//! | `mock` | engine tests: sums its inputs' values, may sleep or fail | `inputs` (any, optional) | `value` |

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
    r.register(mock::MockKind);
    r
}
