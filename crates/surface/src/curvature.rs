//! Curvatures of a sampled field at a grid node, and the saddle's curvature ratio η.
//!
//! # Layout and units
//! The field is an `ndarray` of shape `(nx, ny)` (first index x), periodic, with grid spacings
//! `dx`, `dy` (λ); curvatures are in field units per λ² (h0/λ² for heights and gaps).
//!
//! # Method
//! The Hessian by central differences, [`Stencil::Eighth`] by default for smooth fields: eighth
//! order (nine points per axis; the mixed derivative as
//! the product of two eighth-order first-difference stencils, 81 points). For a Fourier mode of
//! wavenumber `k` the stencils' relative error is `O((k h)⁸)`, about `(k h)⁸ / 630` for the second
//! difference: on 64 nodes per wavelength (`k h = 0.1`) that is ~1e-11, so on the lattices' smooth
//! profiles the Hessian is exact to what any downstream use needs; on a random surface sampled
//! near its cut-off the stencil is only as good as the sampling (a field with content up to the
//! Nyquist wavenumber has errors of order one in its second derivatives by any stencil). Near a
//! closing constriction of a *deformed* gap the contact lines come within a few nodes, and the
//! gap is only C¹ across them: there use [`Stencil::Second`] (3 × 3 nodes, error `(k h)²/12`) and
//! check that no stencil node is in contact.
//! Rounding adds about `ε |f| / h²` per entry. Cost: 99 reads per node.
//!
//! # The curvature ratio
//! At a saddle the Hessian has eigenvalues of opposite signs. The fluid channel runs through it
//! along one eigenvector: for **heights** `h` the channel descends into the troughs on both sides,
//! so `h''∥` is the negative eigenvalue ([`Channel::Descending`], as in
//! [`crate::CriticalPoint::axis`]); for **gaps** `g` the channel widens on both sides, so `g''∥`
//! is the positive eigenvalue ([`Channel::Ascending`]). Then `η = −f''∥ / f''⊥ > 0` for either
//! field, and `g = c − h` gives the same η as `h`. PHYSICS.md: η = 3 (hexagonal), 1 (square),
//! 1/3 (triangular) for the undeformed heights (the paper's 4 and 1/4 are wrong). At a node that
//! is not a saddle (both eigenvalues of one sign) η comes out negative and
//! [`SaddleCurvature::is_saddle`] is false.

use crate::critical::eigen;
use ndarray::ArrayView2;
use std::fmt;

/// Eighth-order second-difference weights for offsets 0..=4 (symmetric).
const D2_EIGHTH: [f64; 5] = [
    -205.0 / 72.0,
    8.0 / 5.0,
    -1.0 / 5.0,
    8.0 / 315.0,
    -1.0 / 560.0,
];
/// Eighth-order first-difference weights for offsets 1..=4 (antisymmetric; offset 0 has 0).
const D1_EIGHTH: [f64; 4] = [4.0 / 5.0, -1.0 / 5.0, 4.0 / 105.0, -1.0 / 280.0];

/// The finite-difference stencil of [`hessian_at`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stencil {
    /// Second order, 3 × 3 nodes: for fields smooth only over a few nodes (a deformed gap whose
    /// contact lines come close to the node, where the gap is only C¹).
    Second,
    /// Eighth order, 9 nodes per axis (81 for the mixed derivative): for smooth fields.
    Eighth,
}

impl Stencil {
    /// Second-difference weights for offsets 0..=half.
    fn second(self) -> &'static [f64] {
        match self {
            Stencil::Second => &[-2.0, 1.0],
            Stencil::Eighth => &D2_EIGHTH,
        }
    }

    /// First-difference weights for offsets 1..=half.
    fn first(self) -> &'static [f64] {
        match self {
            Stencil::Second => &[0.5],
            Stencil::Eighth => &D1_EIGHTH,
        }
    }

    /// Nodes on each side of the centre.
    pub fn half_width(self) -> usize {
        self.first().len()
    }
}

/// Which eigenvector of the Hessian is the channel through the saddle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// The field decreases along the channel (heights): `f''∥` is the smaller eigenvalue.
    Descending,
    /// The field increases along the channel (gaps): `f''∥` is the larger eigenvalue.
    Ascending,
}

/// Invalid input to [`hessian_at`] / [`saddle_curvature`].
#[derive(Debug, Clone, PartialEq)]
pub enum CurvatureError {
    /// Each side needs at least `2 · half_width + 1` nodes for the stencil (9 for the
    /// eighth-order one).
    GridSize {
        /// Nodes along x.
        nx: usize,
        /// Nodes along y.
        ny: usize,
        /// Smallest allowed side.
        min: usize,
    },
    /// Grid spacings must be positive and finite.
    Spacing {
        /// Spacing along x.
        dx: f64,
        /// Spacing along y.
        dy: f64,
    },
    /// The node lies outside the grid.
    Index {
        /// First index.
        i: usize,
        /// Second index.
        j: usize,
        /// Nodes along x.
        nx: usize,
        /// Nodes along y.
        ny: usize,
    },
    /// A field value inside the stencil is NaN or infinite.
    NonFinite {
        /// First index.
        i: usize,
        /// Second index.
        j: usize,
    },
}

impl fmt::Display for CurvatureError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CurvatureError::GridSize { nx, ny, min } => {
                write!(
                    f,
                    "grid of {nx} x {ny} nodes: each side must be at least {min} for the stencil"
                )
            }
            CurvatureError::Spacing { dx, dy } => {
                write!(f, "grid spacing {dx} x {dy} must be positive and finite")
            }
            CurvatureError::Index { i, j, nx, ny } => {
                write!(f, "node ({i}, {j}) outside the {nx} x {ny} grid")
            }
            CurvatureError::NonFinite { i, j } => {
                write!(
                    f,
                    "field value at ({i}, {j}) inside the stencil is not finite"
                )
            }
        }
    }
}

impl std::error::Error for CurvatureError {}

/// The Hessian `[[f_xx, f_xy], [f_xy, f_yy]]` of the periodic field at node `(i, j)`.
pub fn hessian_at(
    field: ArrayView2<f64>,
    dx: f64,
    dy: f64,
    i: usize,
    j: usize,
    stencil: Stencil,
) -> Result<[[f64; 2]; 2], CurvatureError> {
    let (nx, ny) = field.dim();
    let (d2, d1, half) = (stencil.second(), stencil.first(), stencil.half_width());
    let min = 2 * half + 1;
    if nx < min || ny < min {
        return Err(CurvatureError::GridSize { nx, ny, min });
    }
    if !(dx.is_finite() && dy.is_finite() && dx > 0.0 && dy > 0.0) {
        return Err(CurvatureError::Spacing { dx, dy });
    }
    if i >= nx || j >= ny {
        return Err(CurvatureError::Index { i, j, nx, ny });
    }
    let at = |a: isize, b: isize| -> Result<f64, CurvatureError> {
        let ui = (i as isize + a).rem_euclid(nx as isize) as usize;
        let uj = (j as isize + b).rem_euclid(ny as isize) as usize;
        let v = field[[ui, uj]];
        if v.is_finite() {
            Ok(v)
        } else {
            Err(CurvatureError::NonFinite { i: ui, j: uj })
        }
    };
    let (mut fxx, mut fyy, mut fxy) = (d2[0] * at(0, 0)?, d2[0] * at(0, 0)?, 0.0);
    for m in 1..=half {
        let s = m as isize;
        fxx += d2[m] * (at(s, 0)? + at(-s, 0)?);
        fyy += d2[m] * (at(0, s)? + at(0, -s)?);
        for n in 1..=half {
            let t = n as isize;
            // Product of the antisymmetric stencils: four corners with signs.
            fxy += d1[m - 1] * d1[n - 1] * (at(s, t)? - at(-s, t)? - at(s, -t)? + at(-s, -t)?);
        }
    }
    let xy = fxy / (dx * dy);
    Ok([[fxx / (dx * dx), xy], [xy, fyy / (dy * dy)]])
}

/// Curvatures of a field at a saddle node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SaddleCurvature {
    /// The Hessian at the node.
    pub hessian: [[f64; 2]; 2],
    /// Curvature along the channel, `f''∥`.
    pub along: f64,
    /// Curvature across the channel, `f''⊥`.
    pub across: f64,
    /// Unit vector along the channel (sign arbitrary).
    pub channel: [f64; 2],
    /// `η = −f''∥ / f''⊥`.
    pub eta: f64,
    /// The eigenvalues have opposite signs.
    pub is_saddle: bool,
}

/// The curvatures and η of `field` at node `(i, j)`, the channel chosen by `channel` (see the
/// module docs), the Hessian by `stencil`.
pub fn saddle_curvature(
    field: ArrayView2<f64>,
    dx: f64,
    dy: f64,
    i: usize,
    j: usize,
    channel: Channel,
    stencil: Stencil,
) -> Result<SaddleCurvature, CurvatureError> {
    let hessian = hessian_at(field, dx, dy, i, j, stencil)?;
    let ([lo, hi], v_lo) = eigen(hessian);
    let v_hi = [-v_lo[1], v_lo[0]];
    let (along, across, dir) = match channel {
        Channel::Descending => (lo, hi, v_lo),
        Channel::Ascending => (hi, lo, v_hi),
    };
    Ok(SaddleCurvature {
        hessian,
        along,
        across,
        channel: dir,
        eta: -along / across,
        is_saddle: lo < 0.0 && hi > 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CriticalKind, Lattice, Surface};

    /// Relative error of the eighth-order second-difference symbol for the phase θ = k h:
    /// the stencil returns `−σ(θ)/h²` for a unit cosine instead of `−θ²/h²`.
    fn second_difference_error(theta: f64) -> f64 {
        let (d2, half) = (Stencil::Eighth.second(), Stencil::Eighth.half_width());
        let sigma = -d2[0]
            - 2.0
                * (1..=half)
                    .map(|m| d2[m] * (m as f64 * theta).cos())
                    .sum::<f64>();
        (sigma - theta * theta).abs() / (theta * theta)
    }

    /// On a 64 × 64 grid the modes of the three models have phases k h ≤ 4π/64 ≈ 0.196 per grid
    /// step; the stencils' relative error there is below 1e-8 (checked here from the symbol),
    /// and rounding adds ~1e-16 · 4 h0 · 6 / h² ≈ 1e-12 relative to curvatures ~40 h0/λ². So η,
    /// a ratio of eigenvalues of order one, is good to ~1e-8; the tolerance 1e-6 leaves a margin.
    #[test]
    fn lattice_saddles_have_the_exact_eta() {
        assert!(second_difference_error(4.0 * std::f64::consts::PI / 64.0) < 1e-8);
        for (lattice, eta) in [
            (Lattice::Hexagonal, 3.0),
            (Lattice::Square, 1.0),
            (Lattice::Triangular, 1.0 / 3.0),
        ] {
            let s = Surface::new(lattice, 6).unwrap();
            let (dx, dy) = (s.grid.dx(), s.grid.dy());
            let gap = s.heights.mapv(|h| 5.0 - h);
            let saddles: Vec<_> = s
                .critical_points()
                .into_iter()
                .filter(|p| p.kind == CriticalKind::Saddle)
                .collect();
            assert!(!saddles.is_empty());
            for p in saddles {
                let (i, j) = (
                    (p.x / dx).round() as usize % 64,
                    (p.y / dy).round() as usize % 64,
                );
                assert!((i as f64 * dx - p.x).abs() < 1e-9 && (j as f64 * dy - p.y).abs() < 1e-9);
                let h = saddle_curvature(
                    s.heights.view(),
                    dx,
                    dy,
                    i,
                    j,
                    Channel::Descending,
                    Stencil::Eighth,
                )
                .unwrap();
                let g = saddle_curvature(
                    gap.view(),
                    dx,
                    dy,
                    i,
                    j,
                    Channel::Ascending,
                    Stencil::Eighth,
                )
                .unwrap();
                for c in [h, g] {
                    assert!(c.is_saddle);
                    assert!((c.eta - eta).abs() < 1e-6, "{lattice}: eta {}", c.eta);
                    // The channel is the exact profile's descending axis (up to sign).
                    let dot = c.channel[0] * p.axis[0] + c.channel[1] * p.axis[1];
                    assert!((dot.abs() - 1.0).abs() < 1e-6, "{lattice}: {dot}");
                }
                // Curvatures against the exact Hessian's eigenvalues, 1e-6 relative.
                let scale = p.curvatures[1].abs().max(p.curvatures[0].abs());
                assert!((h.along - p.curvatures[0]).abs() < 1e-6 * scale);
                assert!((h.across - p.curvatures[1]).abs() < 1e-6 * scale);
                assert!((g.along + p.curvatures[0]).abs() < 1e-6 * scale);
            }
        }
    }

    /// The second-order stencil converges at second order: on the triangular model's saddle
    /// (λ/√3, 0) the η error falls by 4 (within 2 %) per doubling of the grid (measured:
    /// 3.2e-3, 8.0e-4, 2.0e-4 on 32², 64², 128²), far from the eighth-order stencil's 1e-9.
    #[test]
    fn second_order_stencil_converges_at_second_order() {
        let mut errors = Vec::new();
        for n in [5u32, 6, 7] {
            let s = Surface::new(Lattice::Triangular, n).unwrap();
            let (dx, dy) = (s.grid.dx(), s.grid.dy());
            let i = s.grid.nx / 4; // x = λ/√3 = lx / 4
            let c = saddle_curvature(
                s.heights.view(),
                dx,
                dy,
                i,
                0,
                Channel::Descending,
                Stencil::Second,
            )
            .unwrap();
            errors.push((c.eta - 1.0 / 3.0).abs());
        }
        assert!(errors[1] > 1e-4 && errors[1] < 1e-2, "{errors:?}");
        for w in errors.windows(2) {
            assert!((w[0] / w[1] - 4.0).abs() < 0.08, "{errors:?}");
        }
    }

    #[test]
    fn minimum_is_not_a_saddle_and_bad_input_is_named() {
        let s = Surface::new(Lattice::Square, 5).unwrap();
        let (dx, dy) = (s.grid.dx(), s.grid.dy());
        // The trough of the square model at (λ/2, λ/2).
        let c = saddle_curvature(
            s.heights.view(),
            dx,
            dy,
            16,
            16,
            Channel::Descending,
            Stencil::Eighth,
        )
        .unwrap();
        assert!(!c.is_saddle && c.eta < 0.0);
        let e = hessian_at(s.heights.view(), 0.0, dy, 0, 0, Stencil::Eighth).unwrap_err();
        assert!(e.to_string().contains("spacing 0 x"));
        let e = hessian_at(s.heights.view(), dx, dy, 32, 0, Stencil::Eighth).unwrap_err();
        assert!(e.to_string().contains("(32, 0)"));
        let small = ndarray::Array2::<f64>::zeros((8, 16));
        let e = hessian_at(small.view(), dx, dy, 0, 0, Stencil::Eighth).unwrap_err();
        assert!(e.to_string().contains("8 x 16") && e.to_string().contains("at least 9"));
        assert!(hessian_at(small.view(), dx, dy, 0, 0, Stencil::Second).is_ok());
        let mut h = s.heights.clone();
        h[[3, 30]] = f64::NAN;
        let e = hessian_at(h.view(), dx, dy, 0, 0, Stencil::Eighth).unwrap_err();
        assert!(e.to_string().contains("(3, 30)"));
    }
}
