//! An arbitrary height field on a grid: a generated random surface or a measured topography.
//!
//! What the contact solver needs of a [`Surface`](crate::Surface) is its grid and its heights
//! (`contact::Model::from_heights(grid, heights)`); a [`HeightField`] carries exactly these two,
//! under the same field names, so `Model::from_heights(f.grid, f.heights.view())` takes it
//! without any change on the contact side. Unlike a lattice it has no exact profile, so exact
//! critical points and closed-form properties are not available.

use crate::spectrum::Spectrum;
use crate::{Grid, Statistics, SurfaceError};
use ndarray::Array2;

/// Heights sampled on a grid, shape `(nx, ny)` (first index x), all finite.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightField {
    /// The grid (cell size and node counts).
    pub grid: Grid,
    /// Heights at the nodes.
    pub heights: Array2<f64>,
}

impl HeightField {
    /// Checks the shape against the grid and that every height is finite.
    pub fn new(grid: Grid, heights: Array2<f64>) -> Result<Self, SurfaceError> {
        if heights.dim() != (grid.nx, grid.ny) {
            return Err(SurfaceError::Parameter {
                name: "heights",
                value: format!(
                    "shape {:?} on a {} × {} grid",
                    heights.dim(),
                    grid.nx,
                    grid.ny
                ),
                allowed: "shape (nx, ny) of the grid",
            });
        }
        if let Some(((i, j), v)) = heights.indexed_iter().find(|(_, v)| !v.is_finite()) {
            return Err(SurfaceError::Parameter {
                name: "heights",
                value: format!("{v} at node ({i}, {j})"),
                allowed: "finite numbers",
            });
        }
        Ok(HeightField { grid, heights })
    }

    /// Moments of the height distribution (mean, rms, skewness, excess kurtosis, extremes).
    pub fn statistics(&self) -> Statistics {
        Statistics::of(self.heights.view())
    }

    /// The Fourier spectrum on the grid's periodic cell (rms slope, curvature, Nayak, PSD).
    pub fn spectrum(&self) -> Spectrum {
        Spectrum::of(self.heights.view(), self.grid.lx, self.grid.ly)
    }
}

impl From<&crate::Surface> for HeightField {
    fn from(s: &crate::Surface) -> Self {
        HeightField {
            grid: s.grid,
            heights: s.heights.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Lattice, Surface};

    #[test]
    fn lattice_statistics_agree_with_the_closed_forms() {
        // Square model h = 2 + cos 2πx + cos 2πy, q = 2π: rms 1, ⟨|∇h|²⟩ = q², ⟨κ²⟩ = q⁴/4;
        // its wave vectors all have |q| = 2π (a single ring), so α = 1.5.
        let s = Surface::new(Lattice::Square, 5).unwrap();
        let f = HeightField::from(&s);
        let sp = f.spectrum().statistics();
        let q = 2.0 * std::f64::consts::PI;
        assert!((sp.rms_height - 1.0).abs() < 1e-13);
        assert!((sp.rms_slope - q).abs() < 1e-12);
        assert!((sp.rms_curvature - q * q / 2.0).abs() < 1e-11);
        assert!((sp.nayak - 1.5).abs() < 1e-12);
        let st = f.statistics();
        assert!((st.excess_kurtosis - Lattice::Square.exact().excess_kurtosis).abs() < 1e-12);
    }

    #[test]
    fn bad_fields_are_refused() {
        let g = Grid::periodic(4, 4, 1.0, 1.0).unwrap();
        assert!(HeightField::new(g, Array2::zeros((4, 5))).is_err());
        let mut h = Array2::zeros((4, 4));
        h[[1, 2]] = f64::NAN;
        let e = HeightField::new(g, h).unwrap_err().to_string();
        assert!(e.contains("(1, 2)") && e.contains("NaN"), "{e}");
        assert!(Grid::periodic(1, 4, 1.0, 1.0).is_err());
        assert!(Grid::periodic(4, 4, 0.0, 1.0).is_err());
    }
}
