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

/// The gap of a neck closing to `eps` at the middle of an `a × b` window along x (flow along
/// x): `max(0, ε + cos 2πy − cos 2πx)`, x, y ∈ [−1/2, 1/2] from end line to end line.
fn neck(a: usize, b: usize, eps: f64) -> Array2<f64> {
    let tau = std::f64::consts::TAU;
    Array2::from_shape_fn((a, b), |(i, j)| {
        let x = i as f64 / (a - 1) as f64 - 0.5;
        let y = j as f64 / (b - 1) as f64 - 0.5;
        (eps + (tau * y).cos() - (tau * x).cos()).max(0.0)
    })
}

/// Windows with an odd number of unknown columns between the isobars and an odd number of
/// nodes across (513 × 993 nodes: 511 × 993 unknowns, the size of the fine flow window of
/// `critical::window_flow` at window 64, k = 4) get the full multigrid hierarchy (the odd
/// sides are padded, see the `multigrid` module) and converge in about as many iterations as
/// small windows. Before session #14 such grids were not coarsened at all (one level, relaxed
/// by Gauss–Seidel), and on this neck the iteration ended `Stagnation` after 32 iterations at
/// a relative residual of 1.0e-2 (docs/near-critical.md §5j).
///
/// Oracles: a gap varying only along the flow has the exact conductance of its faces in series
/// (the same neck profile, so conductances span 1e-9 … 8); the two-dimensional neck must
/// converge by the solver's own checks (true residual, every cross-section's flux) and give the
/// same flux when transposed (flow along y: the padding then acts on the other index).
#[test]
fn odd_windows_are_coarsened_and_a_near_closing_neck_converges() {
    let (a, b, eps) = (513usize, 993usize, 1e-3);
    let (lx, ly) = (1.0, 2.0);
    let opts = FlowOptions::default();
    // one-dimensional neck: the series sum of its faces, node to node
    let gx: Vec<f64> = (0..a)
        .map(|i| {
            let x = i as f64 / (a - 1) as f64 - 0.5;
            eps + 1.0 - (std::f64::consts::TAU * x).cos()
        })
        .collect();
    let dx = lx / a as f64;
    let series: f64 = (0..a - 1)
        .map(|i| dx / h(gx[i].powi(3), gx[i + 1].powi(3)))
        .sum();
    let want = (a - 1) as f64 * dx / series;
    let g1 = Array2::from_shape_fn((a, b), |(i, _)| gx[i]);
    let r =
        solve_between_isobars(g1.view(), lx, ly, FlowAxis::X, SideEdges::NoFlux, &opts).unwrap();
    assert!(
        r.converged,
        "1D neck: {:?}, {} iterations",
        r.termination, r.iterations
    );
    assert!(
        rel(r.conductivity, want) < 1e-11,
        "1D neck: {} vs {want}",
        r.conductivity
    );
    assert!(r.levels >= 8, "1D neck: {} levels", r.levels);
    assert!(r.iterations <= 20, "1D neck: {} iterations", r.iterations);
    // two-dimensional neck, along x and transposed along y
    let g = neck(a, b, eps);
    let x = solve_between_isobars(g.view(), lx, ly, FlowAxis::X, SideEdges::NoFlux, &opts).unwrap();
    let gt = g.t().as_standard_layout().to_owned();
    let y =
        solve_between_isobars(gt.view(), ly, lx, FlowAxis::Y, SideEdges::NoFlux, &opts).unwrap();
    for (r, what) in [(&x, "along x"), (&y, "transposed, along y")] {
        assert!(
            r.converged && r.termination == reynolds::Termination::Converged,
            "neck {what}: {:?} after {} iterations, relative residual {:e}",
            r.termination,
            r.iterations,
            r.relative_residual
        );
        assert!(r.levels >= 8, "neck {what}: {} levels", r.levels);
        assert!(
            r.iterations <= 25,
            "neck {what}: {} iterations",
            r.iterations
        );
    }
    // the dissipation flux errs quadratically in the solver's error: both meet 1e-10
    assert!(
        rel(x.flux, y.flux) < 1e-12,
        "neck: {} along x, {} transposed",
        x.flux,
        y.flux
    );
}
