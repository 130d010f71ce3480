//! Warm starts across grids: a solution prolonged (bilinear, periodic) onto another grid of the
//! same cell, e.g. from 2^(n−1) to 2^n nodes, or to a different sub-grid shift.

use contact::{Interaction, Solution, SolveStats};
use ndarray::{Array2, ArrayView2};
use surface::Grid;

/// Bilinear periodic interpolation of a nodal field on `from` at the nodes of `to`.
pub fn prolong(field: ArrayView2<f64>, from: &Grid, to: &Grid) -> Array2<f64> {
    let (nx, ny) = (from.nx as isize, from.ny as isize);
    Array2::from_shape_fn((to.nx, to.ny), |(i, j)| {
        let (x, y) = to.position(i, j);
        let tx = x / from.dx() - from.shift.0;
        let ty = y / from.dy() - from.shift.1;
        let (ix, iy) = (tx.floor(), ty.floor());
        let (fx, fy) = (tx - ix, ty - iy);
        let (i0, j0) = (ix as isize, iy as isize);
        let at = |a: isize, b: isize| field[[a.rem_euclid(nx) as usize, b.rem_euclid(ny) as usize]];
        (1.0 - fx) * ((1.0 - fy) * at(i0, j0) + fy * at(i0, j0 + 1))
            + fx * ((1.0 - fy) * at(i0 + 1, j0) + fy * at(i0 + 1, j0 + 1))
    })
}

/// A hard-wall warm start on `to` from a solution on another grid of the same cell: its pressure
/// and displacement prolonged. Only the pressure matters to Polonsky–Keer (it rebuilds the
/// displacement from it); the statistics are placeholders.
pub fn warm_start_from(sol: &Solution, to: &Grid) -> Solution {
    let pressure = prolong(sol.pressure.view(), &sol.grid, to);
    let displacement = prolong(sol.displacement.view(), &sol.grid, to);
    Solution {
        grid: *to,
        interaction: Interaction::HardWall,
        mean_pressure: sol.mean_pressure,
        gap: Array2::zeros((to.nx, to.ny)),
        displacement,
        pressure,
        contact_area: sol.contact_area,
        mean_gap: sol.mean_gap,
        mean_displacement: sol.mean_displacement,
        energy: f64::NAN,
        stats: SolveStats {
            method: "prolonged",
            iterations: 0,
            converged: false,
            reason: None,
            max_violation: f64::NAN,
            force_residual: f64::NAN,
            wall_s: 0.0,
            trace: Vec::new(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use surface::Lattice;

    #[test]
    fn prolongation_is_exact_for_bilinear_fields_and_identity_on_the_same_grid() {
        let c = Grid::new(Lattice::Triangular, 3).unwrap();
        let f = Grid::new(Lattice::Triangular, 4)
            .unwrap()
            .shifted(0.25, 0.5)
            .unwrap();
        // a field linear in x inside the cell (periodic wrap aside)
        let field = Array2::from_shape_fn((c.nx, c.ny), |(i, j)| {
            let (x, y) = c.position(i, j);
            2.0 * x + 3.0 * y
        });
        let p = prolong(field.view(), &c, &f);
        for i in 0..f.nx - 2 {
            for j in 0..f.ny - 2 {
                let (x, y) = f.position(i, j);
                assert!((p[[i, j]] - (2.0 * x + 3.0 * y)).abs() < 1e-12);
            }
        }
        let same = prolong(field.view(), &c, &c);
        assert!(
            same.iter()
                .zip(field.iter())
                .all(|(a, b)| (a - b).abs() < 1e-14)
        );
    }
}
