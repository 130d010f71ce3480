//! stages: the registry of the saddleflow pipeline: the compute kinds (crate `kinds`) and the
//! report scenes (crate `scenes`), each with its code identity computed at build time.
//!
//! [`registry()`] is the one list of kinds the CLI knows. Each kind lives in its own module (of
//! `kinds` or `scenes`) and implements [`orchestrator::StageKind`]: name, code version (bump it when results change),
//! parameter schema with defaults, inputs, side outputs, `run`.
//!
//! The kinds are listed in the `kinds` crate's docs, the scenes in the `scenes` crate's; how to
//! add one: docs/architecture.md.

pub mod code_identity;

/// Re-exported so the CLI reaches the engine, the kinds and the scenes through this crate.
pub use kinds;
pub use orchestrator;
use orchestrator::Registry;
pub use scenes;

/// Every stage kind of saddleflow.
pub fn registry() -> Registry {
    let mut r = Registry::new();
    kinds::register(&mut r);
    scenes::register(&mut r);
    // every kind lives in the module of its name
    let names: Vec<String> = r.names().iter().map(|s| s.to_string()).collect();
    for name in names {
        if let Some(code) = code_identity::of(&name) {
            r.set_code_identity(&name, code);
        }
    }
    r
}
