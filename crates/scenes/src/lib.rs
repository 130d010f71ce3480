//! scenes: the report stages of the saddleflow pipeline, the paper's figures and tables,
//! assembled from the compute kinds' artefacts (read through the readers in `kinds`), drawn by
//! `figures` and written by `tables`.

//!
//! Each scene is one module (one file) implementing [`scene::Scene`]: its inputs, its own
//! parameters and code version, the data assembly and its named outputs. [`SCENES`] registers
//! it, once; it becomes a stage kind of its name. How to add one: docs/architecture.md.

pub mod convergence;
pub mod fig1;
pub mod fig2;
pub mod fig2_resolution;
pub mod fig3;
pub mod fig4;
pub mod fig5;
pub mod fig5_collapse;
pub mod fig6;
pub mod flowtable;
pub mod jumptable;
pub mod random_constrictions;
pub mod refined;
pub mod running;
pub mod scene;
pub mod surface_ensemble;
pub mod surface_leakage;
pub mod tradeoff;

use orchestrator::Registry;

/// Every scene, in the paper's order.
pub const SCENES: &[&dyn scene::Scene] = &[
    &fig1::Fig1,
    &fig2::Fig2,
    &fig2_resolution::Fig2Resolution,
    &fig3::Fig3,
    &fig4::Fig4,
    &convergence::Convergence,
    &fig5::Fig5,
    &running::Running,
    &refined::Refined,
    &fig6::Fig6,
    &surface_leakage::SurfaceLeakage,
    &surface_ensemble::SurfaceEnsemble,
    &random_constrictions::RandomConstrictions,
];

/// Registers every scene as a stage kind.
pub fn register(r: &mut Registry) {
    for s in SCENES {
        r.register(scene::SceneKind(*s));
    }
}
