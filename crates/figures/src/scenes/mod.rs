//! One module per figure: a documented data struct and `figure(&data) -> Figure` /
//! `render(&data, out_stem) -> paths`.
//!
//! Units follow PHYSICS.md: E* = 1, λ = 1, h0 = 1; pressures in E* h0/λ, surface energies in
//! E* h0²/λ, lengths along the surface in λ, gaps and displacements in h0.

pub mod constrictions;
pub mod convergence;
pub mod fig2;
pub mod fig3;
pub mod fig5;
pub mod fig6;
pub mod leakage;
pub mod maps;
pub mod running;
pub mod tradeoff;
