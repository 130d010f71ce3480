//! The elastic half-space in Fourier space: σ̃(q) = q E* ũ(q) / 2 (PHYSICS.md).
//!
//! Sign convention (the one place it is fixed): the rigid substrate has heights `h`, the elastic
//! body lies above it, and `u(x, y)` is the height of the body's surface in the same frame. The
//! gap is `g = u − h ≥ 0`. Pushing a region of the body's surface up (larger `u`) compresses it:
//! the elastic stress `σ = K u` (the q ≠ 0 part) is the compressive normal stress the body exerts,
//! and at equilibrium `σ + p̄` equals the pressure the substrate exerts on the body (positive =
//! compressive), where p̄ is the imposed mean pressure. The q = 0 mode of `u` is the body's mean
//! position, fixed by the load.

use crate::spectral::{RowSums, Spectral};
use rayon::prelude::*;
use surface::Grid;

/// Stiffness and compliance multipliers for one grid, plus the FFT plan that applies them.
pub struct ElasticKernel {
    spectral: Spectral,
    /// k(q)/(nx·ny) in the spectral module's multiplier order; 0 at q = 0.
    stiffness: Vec<f64>,
    /// 1/(k(q)·nx·ny) in the same order; 0 at q = 0.
    compliance: Vec<f64>,
    /// Real-space periodic Green's function (displacement of a unit point pressure at node 0,
    /// zero mean), built on first use by [`ElasticKernel::add_point_displacements`].
    green: Option<Vec<f64>>,
    /// Smallest non-zero stiffness q_min E*/2.
    k_min: f64,
    /// Largest stiffness.
    k_max: f64,
    /// Displacement of a node under a unit pressure on that node alone, zero mean:
    /// G(0) = (1/N) Σ_{q≠0} 1/k(q).
    point_compliance: f64,
    nx: usize,
    ny: usize,
}

impl ElasticKernel {
    /// Kernel for `grid` with contact modulus `e_star` (1 in the project's units).
    pub fn new(grid: &Grid, e_star: f64) -> Self {
        let (nx, ny) = (grid.nx, grid.ny);
        let spectral = Spectral::new(nx, ny);
        let m = spectral.half_len();
        let n = nx * ny;
        let tau = 2.0 * std::f64::consts::PI;
        let mut stiffness = vec![0.0; nx * m];
        let mut compliance = vec![0.0; nx * m];
        let (mut k_min, mut k_max) = (f64::INFINITY, 0.0f64);
        let mut point_compliance = 0.0;
        for a in 0..nx {
            let ia = if a <= nx / 2 {
                a as f64
            } else {
                a as f64 - nx as f64
            };
            let qx = tau * ia / grid.lx;
            for b in 0..m {
                let qy = tau * b as f64 / grid.ly;
                let k = 0.5 * e_star * qx.hypot(qy);
                if k > 0.0 {
                    stiffness[a * m + b] = k / n as f64;
                    compliance[a * m + b] = 1.0 / (k * n as f64);
                    // the half spectrum holds b and −b once, except b = 0 and b = ny/2
                    let twice = b != 0 && 2 * b != ny;
                    point_compliance += if twice { 2.0 } else { 1.0 } / (k * n as f64);
                    k_min = k_min.min(k);
                    k_max = k_max.max(k);
                }
            }
        }
        ElasticKernel {
            stiffness: spectral.multiplier(&stiffness),
            compliance: spectral.multiplier(&compliance),
            spectral,
            green: None,
            k_min,
            k_max,
            point_compliance,
            nx,
            ny,
        }
    }

    /// G(0): the displacement of a node under a unit pressure on that node alone (zero-mean
    /// periodic Green's function at its source). 1/G(0) is the stiffness a single node feels.
    pub fn point_compliance(&self) -> f64 {
        self.point_compliance
    }

    /// Number of grid nodes.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// True if the grid has no nodes.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Grid shape (nx, ny).
    pub fn shape(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// Whether transforms on this grid use several threads (see [`Spectral::parallel`]).
    pub fn parallel(&self) -> bool {
        self.spectral.parallel()
    }

    /// Smallest non-zero modal stiffness (E*/λ).
    pub fn k_min(&self) -> f64 {
        self.k_min
    }

    /// Largest modal stiffness (E*/λ).
    pub fn k_max(&self) -> f64 {
        self.k_max
    }

    /// Elastic stress `σ = K u` (zero mean) for a displacement field `u`.
    pub fn stress(&mut self, u: &[f64], sigma: &mut [f64]) {
        self.spectral.convolve_with(u, &self.stiffness, sigma);
    }

    /// Displacement `u = G p` (zero mean) for a pressure field `p`; the mean of `p` is ignored.
    pub fn displacement(&mut self, p: &[f64], u: &mut [f64]) {
        self.spectral.convolve_with(p, &self.compliance, u);
    }

    /// In-place `u = G u`.
    pub fn displacement_in_place(&mut self, field: &mut [f64]) {
        self.spectral
            .convolve_with_in_place(field, &self.compliance);
    }

    /// `G` (`stiffness = false`) or `K` (`true`) applied with row callbacks: see
    /// [`Spectral::convolve_fused`].
    pub fn apply_fused<P, F>(
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
        let mult = if stiffness {
            &self.stiffness
        } else {
            &self.compliance
        };
        self.spectral
            .convolve_fused(input, prepare, mult, output, finish)
    }

    /// `u += G c` for a pressure `c` that is zero except at a few nodes, `sources` = (node index,
    /// value), summed directly with the real-space Green's function: k sources cost k streaming
    /// passes over the grid, cheaper than an FFT pair for a handful of nodes (the Polonsky–Keer
    /// corrections of late iterations). The mean of `c` is ignored, as in
    /// [`ElasticKernel::displacement`].
    pub fn add_point_displacements(&mut self, sources: &[(usize, f64)], u: &mut [f64]) {
        let (nx, ny) = (self.nx, self.ny);
        assert_eq!(u.len(), nx * ny, "field length");
        if self.green.is_none() {
            let mut e = vec![0.0; nx * ny];
            e[0] = 1.0;
            self.spectral
                .convolve_with_in_place(&mut e, &self.compliance);
            self.green = Some(e);
        }
        let green = self.green.as_deref().expect("built above");
        let row = |(i, out): (usize, &mut [f64])| {
            for &(k, c) in sources {
                let (si, sj) = (k / ny, k % ny);
                let gi = (i + nx - si) % nx;
                let src = &green[gi * ny..(gi + 1) * ny];
                // out[j] += c G[gi, (j − sj) mod ny]: two contiguous runs.
                let (lo, hi) = out.split_at_mut(sj);
                for (o, g) in hi.iter_mut().zip(&src[..ny - sj]) {
                    *o += c * g;
                }
                for (o, g) in lo.iter_mut().zip(&src[ny - sj..]) {
                    *o += c * g;
                }
            }
        };
        if self.spectral.parallel() {
            u.par_chunks_mut(ny)
                .enumerate()
                .with_min_len(8)
                .for_each(row);
        } else {
            u.chunks_mut(ny).enumerate().for_each(row);
        }
    }

    /// `out = IFFT(w(q) · FFT(input))` with `w(q) = 1/(k(q) + c)` for q ≠ 0 and `1/c0` at q = 0:
    /// the mass-weighting preconditioner of FIRE. `weights` comes from
    /// [`ElasticKernel::weights`].
    pub fn precondition(&mut self, input: &[f64], weights: &[f64], out: &mut [f64]) {
        self.spectral.convolve_with(input, weights, out);
    }

    /// Builds the multiplier `1/(nx·ny·mass(k))` for a given modal mass function, where `k` is
    /// the modal stiffness (0 for the mean mode), in the order [`ElasticKernel::precondition`]
    /// expects (the spectral module's internal order).
    pub fn weights(&self, mass: impl Fn(f64) -> f64) -> Vec<f64> {
        let n = self.len() as f64;
        self.stiffness
            .iter()
            .map(|&s| 1.0 / (n * mass(s * n)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;
    use surface::{Lattice, Surface};

    #[test]
    fn point_compliance_is_the_displacement_under_a_unit_point_pressure() {
        for (l, n) in [(Lattice::Square, 4), (Lattice::Triangular, 5)] {
            let g = Surface::new(l, n).unwrap().grid;
            let mut kern = ElasticKernel::new(&g, 1.0);
            let mut e = vec![0.0; g.len()];
            e[0] = 1.0;
            let mut u = vec![0.0; g.len()];
            kern.displacement(&e, &mut u);
            let g0 = kern.point_compliance();
            assert!(
                g0 > 0.0 && (u[0] - g0).abs() < 1e-12 * g0,
                "{l:?}: {} vs {g0}",
                u[0]
            );
        }
    }

    #[test]
    fn a_single_wave_has_stress_q_over_two_times_its_amplitude() {
        // On an anisotropic cell a wave cos(qx x) cos(qy y) must feel k = |q| E*/2 exactly.
        let s = Surface::new(Lattice::Triangular, 4).unwrap();
        let g = s.grid;
        let mut kern = ElasticKernel::new(&g, 1.0);
        let (qx, qy) = (2.0 * PI * 3.0 / g.lx, 2.0 * PI * 2.0 / g.ly);
        let u: Vec<f64> = (0..g.len())
            .map(|k| {
                let (x, y) = g.position(k / g.ny, k % g.ny);
                (qx * x).cos() * (qy * y).cos() + 5.0
            })
            .collect();
        let mut sigma = vec![0.0; g.len()];
        kern.stress(&u, &mut sigma);
        let k = 0.5 * qx.hypot(qy);
        for (s, u) in sigma.iter().zip(&u) {
            assert!((s - k * (u - 5.0)).abs() < 1e-12);
        }
        // Compliance inverts stiffness on the zero-mean part.
        let mut back = vec![0.0; g.len()];
        kern.displacement(&sigma, &mut back);
        for (b, u) in back.iter().zip(&u) {
            assert!((b - (u - 5.0)).abs() < 1e-12);
        }
    }

    #[test]
    fn stiffness_range() {
        let g = Grid::new(Lattice::Square, 5).unwrap();
        let kern = ElasticKernel::new(&g, 1.0);
        assert!((kern.k_min() - PI).abs() < 1e-12);
        assert!((kern.k_max() - PI * (16f64 * 16.0 * 2.0).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn point_displacements_match_the_transform() {
        let s = Surface::new(Lattice::Triangular, 5).unwrap();
        let g = s.grid;
        let mut kern = ElasticKernel::new(&g, 1.0);
        let sources = [
            (0, 1.5),
            (37, -0.25),
            (g.len() - 1, 0.75),
            (5 * g.ny + 17, 2.0),
        ];
        let mut c = vec![0.0; g.len()];
        for &(k, v) in &sources {
            c[k] += v;
        }
        let mut want = vec![0.0; g.len()];
        kern.displacement(&c, &mut want);
        let mut u: Vec<f64> = (0..g.len()).map(|k| k as f64 * 1e-3).collect();
        let start = u.clone();
        kern.add_point_displacements(&sources, &mut u);
        for k in 0..g.len() {
            assert!((u[k] - start[k] - want[k]).abs() < 1e-13, "node {k}");
        }
    }
}
