//! The code identity of each stage kind, computed at build time by `build.rs` (method and
//! rules: `build/scan.rs`): for the kind's module, one BLAKE3 hash per source part that can
//! change its output (the modules of this crate it reaches, the workspace crates they use,
//! transitively). [`crate::registry`] attaches it to every kind, so the cache key of a stage
//! changes exactly when a source its kind depends on changes.

use orchestrator::CodeIdentity;

mod generated {
    include!(concat!(env!("OUT_DIR"), "/code_identity.rs"));
}

/// The identity of the kind implemented in module `module` (`None` if there is no such module).
pub fn of(module: &str) -> Option<CodeIdentity> {
    generated::MODULES
        .iter()
        .find(|(m, _)| *m == module)
        .map(|(_, parts)| {
            parts
                .iter()
                .map(|(p, h)| (p.to_string(), h.to_string()))
                .collect()
        })
}
