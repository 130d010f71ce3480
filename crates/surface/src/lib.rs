//! The three single-wavelength surfaces of Dapp & Müser (2015) on periodic grids.
//!
//! Units (PHYSICS.md): wavelength λ = 1, rms height h0 = 1, contact modulus E* = 1. Lengths along
//! the surface are in λ, heights in h0. Every surface is a finite sum of cosines
//! ([`TrigSurface`]), so heights, gradients and Hessians are exact, and every statistic of the
//! property table can be checked against a closed form.
//!
//! **The paper's labels are swapped.** Its equation labelled "(hexagonal lattice)" is the
//! triangular model and vice versa (PHYSICS.md, "Naming trap"). This crate names the models by what
//! they are: [`Lattice::Triangular`] is
//! `h_t = √(2/3) (3/2 + 2 cos(√3πx) cos(πy) + cos(2πy))` (skewness +√(2/3), maxima on a triangular
//! lattice) and [`Lattice::Hexagonal`] is `√(27/2) − h_t` (maxima on a honeycomb lattice).
//!
//! Grids have 2^n × 2^n nodes at `x_i = (i + sx) lx / nx`, `y_j = (j + sy) ly / ny`, where
//! `(sx, sy)` is an optional sub-grid shift in units of the grid spacing. Arrays have shape
//! `(nx, ny)`: the first index is x.

mod critical;
mod curvature;
mod height_field;
pub mod self_affine;
pub mod spectrum;
mod stats;

pub use critical::{CriticalKind, CriticalPoint};
pub use curvature::{
    Channel, CurvatureError, SaddleCurvature, Stencil, hessian_at, saddle_curvature,
};
pub use height_field::HeightField;
pub use self_affine::{Amplitudes, Normalisation, SelfAffine};
pub use spectrum::{PsdBin, SpectralStatistics, Spectrum};
pub use stats::Statistics;

use ndarray::Array2;
use std::f64::consts::PI;
use std::fmt;
use std::str::FromStr;

/// Smallest and largest allowed grid exponent n (grids of 2^n × 2^n nodes).
pub const N_MIN: u32 = 3;
/// Largest allowed grid exponent: 2^13 × 2^13 = 67 M nodes (0.5 GiB per field).
pub const N_MAX: u32 = 13;

/// Errors from building surfaces and grids.
#[derive(Debug, Clone, PartialEq)]
pub enum SurfaceError {
    /// A lattice name that is none of the three models.
    UnknownLattice(String),
    /// A grid exponent outside `N_MIN..=N_MAX`.
    GridExponent(u32),
    /// A sub-grid shift that is not finite or not in [0, 1).
    Shift(f64, f64),
    /// Any other parameter out of its range.
    Parameter {
        /// Parameter name.
        name: &'static str,
        /// The offending value.
        value: String,
        /// The allowed range.
        allowed: &'static str,
    },
}

impl fmt::Display for SurfaceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SurfaceError::UnknownLattice(s) => write!(
                f,
                "unknown lattice {s:?}: allowed values are \"square\", \"triangular\", \"hexagonal\""
            ),
            SurfaceError::GridExponent(n) => write!(
                f,
                "grid exponent n = {n} is out of range: allowed {N_MIN}..={N_MAX} (grids of 2^n × 2^n nodes)"
            ),
            SurfaceError::Shift(sx, sy) => write!(
                f,
                "sub-grid shift ({sx}, {sy}) is out of range: each component must be finite and in [0, 1)"
            ),
            SurfaceError::Parameter {
                name,
                value,
                allowed,
            } => write!(f, "{name} = {value} is out of range: allowed {allowed}"),
        }
    }
}

impl std::error::Error for SurfaceError {}

/// The three single-wavelength models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Lattice {
    /// `h = 2 + cos 2πx + cos 2πy` on a λ × λ cell; maxima, minima and saddles on square lattices.
    Square,
    /// `h_t = √(2/3) (3/2 + 2 cos(√3πx) cos(πy) + cos(2πy))` on a 4λ/√3 × 2λ cell; maxima on a
    /// triangular lattice, minima on a honeycomb lattice, saddles on a kagome lattice.
    Triangular,
    /// `h_h = √(27/2) − h_t`: maxima on a honeycomb lattice, minima on a triangular lattice.
    Hexagonal,
}

impl Lattice {
    /// All three models in the order the paper's figures use: hexagonal, square, triangular.
    pub const ALL: [Lattice; 3] = [Lattice::Hexagonal, Lattice::Square, Lattice::Triangular];

    /// Lower-case name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Lattice::Square => "square",
            Lattice::Triangular => "triangular",
            Lattice::Hexagonal => "hexagonal",
        }
    }

    /// Periodic cell (lx, ly) in units of λ.
    pub fn cell(self) -> (f64, f64) {
        match self {
            Lattice::Square => (1.0, 1.0),
            Lattice::Triangular | Lattice::Hexagonal => (4.0 / 3f64.sqrt(), 2.0),
        }
    }

    /// The model's height profile as a sum of cosines.
    pub fn surface(self) -> TrigSurface {
        let (lx, ly) = self.cell();
        let tau = 2.0 * PI;
        match self {
            Lattice::Square => TrigSurface {
                lx,
                ly,
                offset: 2.0,
                modes: vec![Mode::new(tau, 0.0, 1.0), Mode::new(0.0, tau, 1.0)],
            },
            Lattice::Triangular | Lattice::Hexagonal => {
                // 2 cos(√3πx) cos(πy) = cos(√3πx + πy) + cos(√3πx − πy): three waves of |k| = 2π
                // at 120° to each other.
                let a = (2.0f64 / 3.0).sqrt();
                let kx = 3f64.sqrt() * PI;
                let sign = if self == Lattice::Triangular {
                    1.0
                } else {
                    -1.0
                };
                let offset = if self == Lattice::Triangular {
                    1.5 * a
                } else {
                    13.5f64.sqrt() - 1.5 * a
                };
                TrigSurface {
                    lx,
                    ly,
                    offset,
                    modes: vec![
                        Mode::new(kx, PI, sign * a),
                        Mode::new(kx, -PI, sign * a),
                        Mode::new(0.0, tau, sign * a),
                    ],
                }
            }
        }
    }
}

impl fmt::Display for Lattice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Lattice {
    type Err = SurfaceError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "square" => Ok(Lattice::Square),
            "triangular" => Ok(Lattice::Triangular),
            "hexagonal" => Ok(Lattice::Hexagonal),
            other => Err(SurfaceError::UnknownLattice(other.to_string())),
        }
    }
}

/// One cosine wave `amp · cos(kx x + ky y)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mode {
    /// Wave-vector x component (1/λ, including the 2π).
    pub kx: f64,
    /// Wave-vector y component.
    pub ky: f64,
    /// Amplitude (h0).
    pub amp: f64,
}

impl Mode {
    /// A cosine wave.
    pub const fn new(kx: f64, ky: f64, amp: f64) -> Self {
        Mode { kx, ky, amp }
    }
}

/// A periodic height profile `h(x, y) = offset + Σ amp cos(kx x + ky y)` on an lx × ly cell.
#[derive(Debug, Clone, PartialEq)]
pub struct TrigSurface {
    /// Cell size along x (λ).
    pub lx: f64,
    /// Cell size along y (λ).
    pub ly: f64,
    /// Constant part (h0).
    pub offset: f64,
    /// The cosine waves.
    pub modes: Vec<Mode>,
}

impl TrigSurface {
    /// Height at (x, y).
    pub fn height(&self, x: f64, y: f64) -> f64 {
        self.offset
            + self
                .modes
                .iter()
                .map(|m| m.amp * (m.kx * x + m.ky * y).cos())
                .sum::<f64>()
    }

    /// Gradient (∂h/∂x, ∂h/∂y) at (x, y).
    pub fn gradient(&self, x: f64, y: f64) -> [f64; 2] {
        let mut g = [0.0; 2];
        for m in &self.modes {
            let s = -m.amp * (m.kx * x + m.ky * y).sin();
            g[0] += s * m.kx;
            g[1] += s * m.ky;
        }
        g
    }

    /// Hessian [[h_xx, h_xy], [h_xy, h_yy]] at (x, y).
    pub fn hessian(&self, x: f64, y: f64) -> [[f64; 2]; 2] {
        let mut h = [[0.0; 2]; 2];
        for m in &self.modes {
            let c = -m.amp * (m.kx * x + m.ky * y).cos();
            h[0][0] += c * m.kx * m.kx;
            h[0][1] += c * m.kx * m.ky;
            h[1][1] += c * m.ky * m.ky;
        }
        h[1][0] = h[0][1];
        h
    }

    /// Largest wave-vector magnitude |k| of any mode.
    pub fn k_max(&self) -> f64 {
        self.modes
            .iter()
            .map(|m| m.kx.hypot(m.ky))
            .fold(0.0, f64::max)
    }

    /// Heights sampled on `grid`.
    pub fn sample(&self, grid: &Grid) -> Array2<f64> {
        let (dx, dy) = (grid.dx(), grid.dy());
        let (sx, sy) = grid.shift;
        // Separable evaluation: cos(a + b) = cos a cos b − sin a sin b, with per-axis tables.
        let mut h = Array2::from_elem((grid.nx, grid.ny), self.offset);
        for m in &self.modes {
            let cx: Vec<(f64, f64)> = (0..grid.nx)
                .map(|i| (m.kx * (i as f64 + sx) * dx).sin_cos())
                .collect();
            let cy: Vec<(f64, f64)> = (0..grid.ny)
                .map(|j| (m.ky * (j as f64 + sy) * dy).sin_cos())
                .collect();
            for ((i, j), v) in h.indexed_iter_mut() {
                let (sa, ca) = cx[i];
                let (sb, cb) = cy[j];
                *v += m.amp * (ca * cb - sa * sb);
            }
        }
        h
    }
}

/// A periodic grid of nx × ny nodes on an lx × ly cell, optionally shifted by a fraction of a
/// grid spacing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Nodes along x.
    pub nx: usize,
    /// Nodes along y.
    pub ny: usize,
    /// Cell size along x (λ).
    pub lx: f64,
    /// Cell size along y (λ).
    pub ly: f64,
    /// Sub-grid shift (sx, sy) in units of the grid spacing, each in [0, 1).
    pub shift: (f64, f64),
}

impl Grid {
    /// A 2^n × 2^n grid on the cell of `lattice`, n in `N_MIN..=N_MAX`.
    pub fn new(lattice: Lattice, n: u32) -> Result<Self, SurfaceError> {
        if !(N_MIN..=N_MAX).contains(&n) {
            return Err(SurfaceError::GridExponent(n));
        }
        let (lx, ly) = lattice.cell();
        Ok(Grid {
            nx: 1 << n,
            ny: 1 << n,
            lx,
            ly,
            shift: (0.0, 0.0),
        })
    }

    /// An unshifted grid of nx × ny nodes (each in 2..=2^N_MAX) on an lx × ly cell (finite,
    /// > 0), for height fields that are not one of the lattices.
    pub fn periodic(nx: usize, ny: usize, lx: f64, ly: f64) -> Result<Self, SurfaceError> {
        let max = 1usize << N_MAX;
        if !(2..=max).contains(&nx) || !(2..=max).contains(&ny) {
            return Err(SurfaceError::Parameter {
                name: "grid",
                value: format!("{nx} × {ny} nodes"),
                allowed: "2..=8192 nodes along each axis",
            });
        }
        if !(lx.is_finite() && lx > 0.0 && ly.is_finite() && ly > 0.0) {
            return Err(SurfaceError::Parameter {
                name: "cell",
                value: format!("{lx} × {ly}"),
                allowed: "finite sides > 0",
            });
        }
        Ok(Grid {
            nx,
            ny,
            lx,
            ly,
            shift: (0.0, 0.0),
        })
    }

    /// The same grid shifted by (sx, sy) grid spacings.
    pub fn shifted(self, sx: f64, sy: f64) -> Result<Self, SurfaceError> {
        let ok = |s: f64| s.is_finite() && (0.0..1.0).contains(&s);
        if !(ok(sx) && ok(sy)) {
            return Err(SurfaceError::Shift(sx, sy));
        }
        Ok(Grid {
            shift: (sx, sy),
            ..self
        })
    }

    /// Grid spacing along x.
    pub fn dx(&self) -> f64 {
        self.lx / self.nx as f64
    }

    /// Grid spacing along y.
    pub fn dy(&self) -> f64 {
        self.ly / self.ny as f64
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// True for an empty grid (never for grids built by [`Grid::new`]).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Position of node (i, j).
    pub fn position(&self, i: usize, j: usize) -> (f64, f64) {
        (
            (i as f64 + self.shift.0) * self.dx(),
            (j as f64 + self.shift.1) * self.dy(),
        )
    }
}

/// One of the three models sampled on a grid: what the contact solver takes.
#[derive(Debug, Clone)]
pub struct Surface {
    /// Which model.
    pub lattice: Lattice,
    /// The grid the heights are sampled on.
    pub grid: Grid,
    /// Exact profile.
    pub profile: TrigSurface,
    /// Heights h(x_i, y_j) in h0, shape (nx, ny).
    pub heights: Array2<f64>,
}

impl Surface {
    /// The model `lattice` on a 2^n × 2^n grid.
    pub fn new(lattice: Lattice, n: u32) -> Result<Self, SurfaceError> {
        Ok(Self::on_grid(lattice, Grid::new(lattice, n)?))
    }

    /// The model `lattice` sampled on a given grid (which must use the lattice's cell).
    pub fn on_grid(lattice: Lattice, grid: Grid) -> Self {
        let profile = lattice.surface();
        let heights = profile.sample(&grid);
        Surface {
            lattice,
            grid,
            profile,
            heights,
        }
    }

    /// Statistics of the sampled heights.
    pub fn statistics(&self) -> Statistics {
        Statistics::of(self.heights.view())
    }

    /// Full-contact pressure on this grid: the mean pressure at which the last node closes,
    /// `p_fc = (q E*/2)(h̄ − min h)` with q = 2π/λ. With the continuum stiffness the full-contact
    /// solution is exact on any grid (PHYSICS.md), so this is exact for the sampled heights; it
    /// differs from the continuum value `π t̄` only where the trough falls between grid nodes
    /// (triangular model).
    pub fn p_fc_grid(&self) -> f64 {
        let s = self.statistics();
        PI * (s.mean - s.min)
    }

    /// Exact critical points of the profile in the cell (see [`critical`](CriticalPoint)).
    pub fn critical_points(&self) -> Vec<CriticalPoint> {
        critical::find(&self.profile)
    }
}

/// Exact properties of each model, from the closed forms in PHYSICS.md (for reports and tests).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExactProperties {
    /// Maximum height (h0).
    pub max: f64,
    /// Mean height (h0).
    pub mean: f64,
    /// Mean trough depth t̄ = mean − min (h0); the minimum is 0.
    pub trough_depth: f64,
    /// Height of the saddle points (h0).
    pub saddle_height: f64,
    /// Skewness of the height distribution.
    pub skewness: f64,
    /// Excess kurtosis.
    pub excess_kurtosis: f64,
    /// Full-contact pressure π E* t̄ / λ.
    pub p_fc: f64,
    /// Saddle curvature ratio η = −h''∥/h''⊥ (the paper prints 4 and 1/4; the surfaces give 3 and 1/3).
    pub eta: f64,
}

impl Lattice {
    /// The closed-form properties of PHYSICS.md.
    pub fn exact(self) -> ExactProperties {
        let s6 = 6f64.sqrt();
        let s23 = (2.0f64 / 3.0).sqrt();
        let (max, mean, saddle, skew, kurt, eta) = match self {
            Lattice::Hexagonal => (
                13.5f64.sqrt(),
                s6,
                13.5f64.sqrt() - (1.0f64 / 6.0).sqrt(),
                -s23,
                -0.5,
                3.0,
            ),
            Lattice::Square => (4.0, 2.0, 2.0, 0.0, -0.75, 1.0),
            Lattice::Triangular => (
                13.5f64.sqrt(),
                1.5f64.sqrt(),
                (1.0f64 / 6.0).sqrt(),
                s23,
                -0.5,
                1.0 / 3.0,
            ),
        };
        ExactProperties {
            max,
            mean,
            trough_depth: mean,
            saddle_height: saddle,
            skewness: skew,
            excess_kurtosis: kurt,
            p_fc: PI * mean,
            eta,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_names_round_trip_and_bad_names_are_explained() {
        for l in Lattice::ALL {
            assert_eq!(l.name().parse::<Lattice>().unwrap(), l);
        }
        let e = "hexagon".parse::<Lattice>().unwrap_err().to_string();
        assert!(e.contains("hexagon") && e.contains("triangular"), "{e}");
    }

    #[test]
    fn grid_exponent_is_checked() {
        assert!(Grid::new(Lattice::Square, 2).is_err());
        assert!(Grid::new(Lattice::Square, 14).is_err());
        let g = Grid::new(Lattice::Triangular, 3).unwrap();
        assert_eq!((g.nx, g.ny), (8, 8));
        assert!((g.dx() - 4.0 / 3f64.sqrt() / 8.0).abs() < 1e-15);
        let msg = Grid::new(Lattice::Square, 20).unwrap_err().to_string();
        assert!(msg.contains("20") && msg.contains("3..=13"), "{msg}");
        assert!(g.shifted(1.0, 0.0).is_err());
        assert!(g.shifted(f64::NAN, 0.0).is_err());
    }

    #[test]
    fn every_mode_has_the_single_wavelength() {
        for l in Lattice::ALL {
            for m in l.surface().modes {
                assert!((m.kx.hypot(m.ky) - 2.0 * PI).abs() < 1e-12, "{l}: {m:?}");
            }
        }
    }

    #[test]
    fn profiles_are_periodic_on_their_cells() {
        for l in Lattice::ALL {
            let s = l.surface();
            for &(x, y) in &[(0.1, 0.2), (0.37, 1.3), (1.9, 0.05)] {
                let h = s.height(x, y);
                assert!((s.height(x + s.lx, y) - h).abs() < 1e-12);
                assert!((s.height(x, y + s.ly) - h).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn separable_sampling_matches_direct_evaluation() {
        for l in Lattice::ALL {
            let grid = Grid::new(l, 4).unwrap().shifted(0.3, 0.7).unwrap();
            let s = Surface::on_grid(l, grid);
            for ((i, j), &h) in s.heights.indexed_iter() {
                let (x, y) = grid.position(i, j);
                assert!((h - s.profile.height(x, y)).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn gradient_and_hessian_match_finite_differences() {
        let e = 1e-5;
        for l in Lattice::ALL {
            let s = l.surface();
            let (x, y) = (0.31, 0.77);
            let g = s.gradient(x, y);
            let gx = (s.height(x + e, y) - s.height(x - e, y)) / (2.0 * e);
            let gy = (s.height(x, y + e) - s.height(x, y - e)) / (2.0 * e);
            assert!((g[0] - gx).abs() < 1e-8 && (g[1] - gy).abs() < 1e-8);
            let h = s.hessian(x, y);
            let hxy = (s.gradient(x, y + e)[0] - s.gradient(x, y - e)[0]) / (2.0 * e);
            let hxx = (s.gradient(x + e, y)[0] - s.gradient(x - e, y)[0]) / (2.0 * e);
            assert!((h[0][1] - hxy).abs() < 1e-7 && (h[0][0] - hxx).abs() < 1e-7);
        }
    }
}
