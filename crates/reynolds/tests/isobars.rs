//! Flow between two isobaric node columns (`solve_between_isobars`): exact circuits and the
//! equivalence with the reservoir problem.
//!
//! Tolerances: the flux comes from the dissipation (error quadratic in the solver's), so exact
//! discrete values are met to rounding (~1e-14); 1e-11 leaves margin for rounding summed over
//! the faces and for the 1e-10 residual target.

use ndarray::Array2;
use reynolds::{
    FlowAxis, FlowOptions, FlowResult, SideEdges, solve_between_isobars, solve_between_reservoirs,
};

const SIDES: [SideEdges; 2] = [SideEdges::NoFlux, SideEdges::Periodic];

fn run(g: &Array2<f64>, lx: f64, ly: f64, axis: FlowAxis, sides: SideEdges) -> FlowResult {
    let r = solve_between_isobars(g.view(), lx, ly, axis, sides, &FlowOptions::default())
        .expect("valid input");
    assert!(r.converged, "not converged: {:?}", r.termination);
    r
}

fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

/// Harmonic mean of two conductances.
fn h(a: f64, b: f64) -> f64 {
    2.0 * a * b / (a + b)
}

#[test]
fn a_uniform_gap_gives_g_cubed() {
    let g = Array2::from_elem((12, 8), 0.3);
    for sides in SIDES {
        for axis in [FlowAxis::X, FlowAxis::Y] {
            let r = run(&g, 1.5, 0.5, axis, sides);
            assert!(
                rel(r.conductivity, 0.027) < 1e-11,
                "{sides:?} {axis:?}: {r:?}"
            );
        }
    }
}

#[test]
fn a_gap_varying_along_the_flow_gives_the_series_sum_of_its_faces() {
    // Node to node: L = (nx − 1) dx, R = Σ_faces dx / H(g³_i, g³_{i+1}) per unit width.
    let (nx, ny, lx, ly) = (10usize, 6usize, 2.0, 0.75);
    let gx: Vec<f64> = (0..nx)
        .map(|i| 0.05 + 0.02 * (i as f64 * 1.3).sin().abs())
        .collect();
    let dx = lx / nx as f64;
    let series: f64 = (0..nx - 1)
        .map(|i| dx / h(gx[i].powi(3), gx[i + 1].powi(3)))
        .sum();
    let want = (nx - 1) as f64 * dx / series;
    for sides in SIDES {
        let g = Array2::from_shape_fn((nx, ny), |(i, _)| gx[i]);
        let r = run(&g, lx, ly, FlowAxis::X, sides);
        assert!(
            rel(r.conductivity, want) < 1e-11,
            "{sides:?}: {} vs {want}",
            r.conductivity
        );
        // the same along y
        let gt = Array2::from_shape_fn((ny, nx), |(_, j)| gx[j]);
        let r = run(&gt, ly, lx, FlowAxis::Y, sides);
        assert!(
            rel(r.conductivity, want) < 1e-11,
            "{sides:?} y: {}",
            r.conductivity
        );
    }
}

/// Huge end columns are isobars in either problem, and the face from such a column to its
/// neighbour has conductance 2 g³ (harmonic mean with a huge value): so the isobar problem on
/// [huge, G, huge] carries the flux of the reservoir problem on G, up to (g/huge)³.
#[test]
fn huge_end_columns_reproduce_the_reservoir_problem() {
    let (nx, ny) = (14usize, 9usize);
    let mut seed = 12345u64;
    let mut uniform = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64) / ((1u64 << 53) as f64)
    };
    // random gaps with some contact (about 25 %)
    let inner = Array2::from_shape_fn((nx, ny), |_| {
        let u = uniform();
        if u < 0.25 { 0.0 } else { 0.2 + u }
    });
    let (dx, dy) = (0.1, 0.07);
    let padded = Array2::from_shape_fn((nx + 2, ny), |(i, j)| {
        if i == 0 || i == nx + 1 {
            1e3
        } else {
            inner[[i - 1, j]]
        }
    });
    for sides in SIDES {
        let a = run(
            &padded,
            (nx + 2) as f64 * dx,
            ny as f64 * dy,
            FlowAxis::X,
            sides,
        );
        let b = solve_between_reservoirs(
            inner.view(),
            nx as f64 * dx,
            ny as f64 * dy,
            FlowAxis::X,
            sides,
            &FlowOptions::default(),
        )
        .unwrap();
        assert!(b.converged && b.flux > 0.0);
        // (1.2 / 1e3)³ ≈ 2e-9 relative from the huge columns' finite conductance
        assert!(
            rel(a.flux, b.flux) < 1e-8,
            "{sides:?}: {} vs {}",
            a.flux,
            b.flux
        );
    }
}

#[test]
fn too_few_columns_are_refused() {
    let g = Array2::from_elem((5, 8), 0.3);
    assert!(
        solve_between_isobars(
            g.view(),
            1.0,
            1.0,
            FlowAxis::X,
            SideEdges::NoFlux,
            &FlowOptions::default()
        )
        .is_err()
    );
}
