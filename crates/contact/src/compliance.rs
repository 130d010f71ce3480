//! The elastic operator as the Polonsky–Keer minimiser sees it: a compliance G (pressure →
//! displacement) and an approximate stiffness K ≈ G⁻¹ for its preconditioner, both applied by
//! FFT with row callbacks. Implementations: the periodic half-space
//! ([`crate::elastic::ElasticKernel`], K = G⁻¹ exactly), the free-boundary one on a zero-padded
//! grid ([`crate::free_kernel::FreeKernel`], K the inverse of G's circulant embedding) and the
//! composite operator of local refinement ([`crate::refinement::Composite`], K a two-level
//! approximation of its inverse, [`crate::refinement::twolevel`]), the last two reached
//! through `FreeKernel`.

use crate::spectral::RowSums;

/// A symmetric compliance on an `nx × ny` grid of nodes (row-major, first index x).
pub trait Compliance {
    /// Grid shape (nx, ny).
    fn shape(&self) -> (usize, usize);
    /// Whether the row passes run on several threads.
    fn parallel(&self) -> bool;
    /// Displacement of a node under a unit pressure on that node alone.
    fn point_compliance(&self) -> f64;
    /// `u = G p`.
    fn displacement(&mut self, p: &[f64], u: &mut [f64]);
    /// `G` (`stiffness = false`) or `K` (`true`) applied with row callbacks, with the contract of
    /// [`crate::spectral::Spectral::convolve_fused`]: returns the row sums of `prepare`, the
    /// quadratic form Σ input · output, and the row sums of `finish`.
    fn apply_fused<P, F>(
        &mut self,
        stiffness: bool,
        input: &mut [f64],
        prepare: P,
        output: Option<&mut [f64]>,
        finish: F,
    ) -> (RowSums, f64, RowSums)
    where
        P: Fn(usize, &mut [f64]) -> RowSums + Sync,
        F: Fn(usize, &[f64], &mut [f64]) -> RowSums + Sync;
    /// `u += G c` for a pressure `c` that is zero except at the listed (node, value) pairs.
    fn add_point_displacements(&mut self, sources: &[(usize, f64)], u: &mut [f64]);
    /// The area each unknown covers, if unknowns are forces on unequal areas (the composite
    /// operator's W = Pᵀ1, in the first nodes; the rest weigh 1); `None`: every node weighs 1.
    fn weights(&self) -> Option<&[f64]> {
        None
    }
}

impl Compliance for crate::elastic::ElasticKernel {
    fn shape(&self) -> (usize, usize) {
        crate::elastic::ElasticKernel::shape(self)
    }
    fn parallel(&self) -> bool {
        crate::elastic::ElasticKernel::parallel(self)
    }
    fn point_compliance(&self) -> f64 {
        crate::elastic::ElasticKernel::point_compliance(self)
    }
    fn displacement(&mut self, p: &[f64], u: &mut [f64]) {
        crate::elastic::ElasticKernel::displacement(self, p, u)
    }
    fn apply_fused<P, F>(
        &mut self,
        stiffness: bool,
        input: &mut [f64],
        prepare: P,
        output: Option<&mut [f64]>,
        finish: F,
    ) -> (RowSums, f64, RowSums)
    where
        P: Fn(usize, &mut [f64]) -> RowSums + Sync,
        F: Fn(usize, &[f64], &mut [f64]) -> RowSums + Sync,
    {
        crate::elastic::ElasticKernel::apply_fused(self, stiffness, input, prepare, output, finish)
    }
    fn add_point_displacements(&mut self, sources: &[(usize, f64)], u: &mut [f64]) {
        crate::elastic::ElasticKernel::add_point_displacements(self, sources, u)
    }
}
