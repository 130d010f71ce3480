//! The elastic half-space in Fourier space: σ̃(q) = q E* ũ(q) / 2 (PHYSICS.md).
//!
//! Sign convention (the one place it is fixed): the rigid substrate has heights `h`, the elastic
//! body lies above it, and `u(x, y)` is the height of the body's surface in the same frame. The
//! gap is `g = u − h ≥ 0`. Pushing a region of the body's surface up (larger `u`) compresses it:
//! the elastic stress `σ = K u` (the q ≠ 0 part) is the compressive normal stress the body exerts,
//! and at equilibrium `σ + p̄` equals the pressure the substrate exerts on the body (positive =
//! compressive), where p̄ is the imposed mean pressure. The q = 0 mode of `u` is the body's mean
//! position, fixed by the load.

use crate::spectral::Spectral;
use surface::Grid;

/// Stiffness and compliance multipliers for one grid, plus the FFT plan that applies them.
pub struct ElasticKernel {
    spectral: Spectral,
    /// k(q)/(nx·ny) in half-spectrum layout; 0 at q = 0.
    stiffness: Vec<f64>,
    /// 1/(k(q)·nx·ny); 0 at q = 0.
    compliance: Vec<f64>,
    /// Smallest non-zero stiffness q_min E*/2.
    k_min: f64,
    /// Largest stiffness.
    k_max: f64,
    n: usize,
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
                    k_min = k_min.min(k);
                    k_max = k_max.max(k);
                }
            }
        }
        ElasticKernel {
            spectral,
            stiffness,
            compliance,
            k_min,
            k_max,
            n,
        }
    }

    /// Number of grid nodes.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True if the grid has no nodes.
    pub fn is_empty(&self) -> bool {
        self.n == 0
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
        self.spectral.convolve(u, &self.stiffness, sigma);
    }

    /// Displacement `u = G p` (zero mean) for a pressure field `p`; the mean of `p` is ignored.
    pub fn displacement(&mut self, p: &[f64], u: &mut [f64]) {
        self.spectral.convolve(p, &self.compliance, u);
    }

    /// In-place `u = G u`.
    pub fn displacement_in_place(&mut self, field: &mut [f64]) {
        self.spectral.convolve_in_place(field, &self.compliance);
    }

    /// `out = IFFT(w(q) · FFT(input))` with `w(q) = 1/(k(q) + c)` for q ≠ 0 and `1/c0` at q = 0:
    /// the mass-weighting preconditioner of FIRE.
    pub fn precondition(&mut self, input: &[f64], weights: &[f64], out: &mut [f64]) {
        self.spectral.convolve(input, weights, out);
    }

    /// Builds the half-spectrum multiplier `1/(nx·ny·mass(k))` for a given modal mass function,
    /// where `k` is the modal stiffness (0 for the mean mode).
    pub fn weights(&self, mass: impl Fn(f64) -> f64) -> Vec<f64> {
        let n = self.n as f64;
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
}
