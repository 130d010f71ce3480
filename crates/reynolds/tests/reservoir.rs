//! Flow between two reservoirs: exact circuits and an independent dense solve.
//!
//! Tolerances: as in `flow.rs`, the flux comes from the dissipation (error quadratic in the
//! solver's), so the exact discrete values are met to rounding (~1e-14); 1e-11 leaves margin for
//! rounding summed over the faces and for the 1e-10 residual target.

use ndarray::Array2;
use reynolds::{
    FlowAxis, FlowOptions, FlowResult, SideEdges, Termination, solve_between_reservoirs,
};

const SIDES: [SideEdges; 2] = [SideEdges::NoFlux, SideEdges::Periodic];

fn run(g: &Array2<f64>, lx: f64, ly: f64, axis: FlowAxis, sides: SideEdges) -> FlowResult {
    let opts = FlowOptions {
        return_fields: true,
        ..FlowOptions::default()
    };
    let r = solve_between_reservoirs(g.view(), lx, ly, axis, sides, &opts).expect("valid input");
    assert!(r.converged, "not converged: {:?}", r.termination);
    r
}

fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

/// Small deterministic generator.
struct Lcg(u64);
impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64)
    }
}

#[test]
fn uniform_gap_gives_g_cubed_and_a_linear_pressure() {
    let (nx, ny) = (16, 8);
    let g = Array2::from_elem((nx, ny), 0.3);
    for sides in SIDES {
        for axis in [FlowAxis::X, FlowAxis::Y] {
            let r = run(&g, 2.0, 0.5, axis, sides);
            assert!(
                rel(r.conductivity, 0.027) < 1e-12,
                "{sides:?} {axis:?}: {}",
                r.conductivity
            );
            // Cross-section fluxes err to first order in the residual (target 1e-10).
            assert!(r.conservation_error < 1e-8, "{}", r.conservation_error);
        }
        // Node (i, j) sits at x = (i + 1/2) dx between p = 1 at x = 0 and p = 0 at x = L; the
        // pressure errs to first order in the residual (target 1e-10 relative).
        let p = run(&g, 2.0, 0.5, FlowAxis::X, sides)
            .fields
            .unwrap()
            .pressure;
        for ((i, _), &v) in p.indexed_iter() {
            assert!(
                (v - (1.0 - (i as f64 + 0.5) / nx as f64)).abs() < 1e-9,
                "{i}: {v}"
            );
        }
    }
}

#[test]
fn gap_varying_along_the_flow_gives_the_harmonic_mean_of_g_cubed() {
    let (nx, ny) = (32, 8);
    let mut rng = Lcg(3);
    let profile: Vec<f64> = (0..nx).map(|_| 0.05 + rng.uniform()).collect();
    let want = nx as f64 / profile.iter().map(|g| 1.0 / g.powi(3)).sum::<f64>();
    for sides in SIDES {
        let g = Array2::from_shape_fn((nx, ny), |(i, _)| profile[i]);
        let r = run(&g, 1.0, 1.0, FlowAxis::X, sides);
        assert!(
            rel(r.conductivity, want) < 1e-11,
            "{sides:?}: {} vs {want}",
            r.conductivity
        );
        let r = run(&g.t().to_owned(), 1.0, 1.0, FlowAxis::Y, sides);
        assert!(rel(r.conductivity, want) < 1e-11);
    }
}

#[test]
fn gap_varying_across_the_flow_gives_the_arithmetic_mean_of_g_cubed() {
    let (nx, ny) = (8, 32);
    let mut rng = Lcg(5);
    let profile: Vec<f64> = (0..ny).map(|_| 0.05 + rng.uniform()).collect();
    let want = profile.iter().map(|g| g.powi(3)).sum::<f64>() / ny as f64;
    for sides in SIDES {
        let g = Array2::from_shape_fn((nx, ny), |(_, j)| profile[j]);
        let r = run(&g, 1.0, 1.0, FlowAxis::X, sides);
        assert!(
            rel(r.conductivity, want) < 1e-11,
            "{sides:?}: {} vs {want}",
            r.conductivity
        );
    }
}

/// Channels separated by contact walls along the flow, each with its own profile along x
/// (the same on its rows, so nothing flows across): series within a channel, parallel between
/// channels, `K = (1/ny) Σ_rows 1 / ⟨1/g³⟩_row`.
#[test]
fn channels_in_parallel_each_a_series_circuit() {
    let (nx, ny) = (16, 16);
    let mut rng = Lcg(11);
    let profiles: Vec<Vec<f64>> = (0..4)
        .map(|_| (0..nx).map(|_| 0.1 + rng.uniform()).collect())
        .collect();
    // Rows 0..3 channel 0, row 3 wall, 4..7 channel 1, row 7 wall, ...
    let g = Array2::from_shape_fn(
        (nx, ny),
        |(i, j)| {
            if j % 4 == 3 { 0.0 } else { profiles[j / 4][i] }
        },
    );
    let want: f64 = (0..ny)
        .filter(|j| j % 4 != 3)
        .map(|j| nx as f64 / profiles[j / 4].iter().map(|g| g.powi(-3)).sum::<f64>())
        .sum::<f64>()
        / ny as f64;
    for sides in SIDES {
        let r = run(&g, 1.0, 1.0, FlowAxis::X, sides);
        assert!(
            rel(r.conductivity, want) < 1e-11,
            "{sides:?}: {} vs {want}",
            r.conductivity
        );
        assert_eq!(r.removed_nodes, 0);
    }
}

#[test]
fn dead_ends_and_ponds_are_removed_and_a_closed_seal_has_zero_flux() {
    let (nx, ny) = (16, 8);
    // An open channel on rows 0..3 (walls on rows 3 and 7), a dead end on rows 4..7 blocked at
    // its outlet end, and the reference with the dead end filled.
    let open = |i: usize, j: usize| j < 3 || (j > 3 && j < 7 && i < nx - 2);
    let g = Array2::from_shape_fn((nx, ny), |(i, j)| if open(i, j) { 0.5 } else { 0.0 });
    let filled = Array2::from_shape_fn((nx, ny), |(_, j)| if j < 3 { 0.5 } else { 0.0 });
    for sides in [SideEdges::NoFlux, SideEdges::Periodic] {
        let a = run(&g, 1.0, 1.0, FlowAxis::X, sides);
        let b = run(&filled, 1.0, 1.0, FlowAxis::X, sides);
        assert_eq!(a.removed_nodes, 3 * (nx - 2));
        assert!(rel(a.flux, b.flux) < 1e-12 && rel(b.conductivity, 0.125 * 3.0 / 8.0) < 1e-12);
    }
    // A contact line across the flow closes the seal.
    let closed = Array2::from_shape_fn((nx, ny), |(i, _)| if i == 5 { 0.0 } else { 0.5 });
    let r = run(&closed, 1.0, 1.0, FlowAxis::X, SideEdges::Periodic);
    assert_eq!(r.termination, Termination::NotPercolating);
    assert_eq!(r.flux, 0.0);
    // Periodic sides matter: a diagonal channel that leaves through y = ly and comes back at
    // y = 0 only connects the reservoirs when the sides are periodic.
    let diagonal =
        Array2::from_shape_fn(
            (nx, ny),
            |(i, j)| {
                if (j + ny - i % ny) % ny < 2 { 0.5 } else { 0.0 }
            },
        );
    let periodic = run(&diagonal, 1.0, 1.0, FlowAxis::X, SideEdges::Periodic);
    let closed_sides = run(&diagonal, 1.0, 1.0, FlowAxis::X, SideEdges::NoFlux);
    assert!(periodic.percolating && !closed_sides.percolating);
}

/// The discrete problem assembled densely from its definition (harmonic face conductances,
/// half-cell reservoir faces, the kept nodes connected to both reservoirs found by flooding)
/// and solved by Gaussian elimination with partial pivoting; the flux is what enters from the
/// inlet.
fn dense_reservoir_flux(g: &Array2<f64>, lx: f64, ly: f64, periodic_sides: bool) -> f64 {
    let (nx, ny) = g.dim();
    let (dx, dy) = (lx / nx as f64, ly / ny as f64);
    let c = |i: usize, j: usize| {
        if g[[i, j]] > 0.0 {
            g[[i, j]].powi(3)
        } else {
            0.0
        }
    };
    let h = |a: f64, b: f64| {
        if a > 0.0 && b > 0.0 {
            2.0 * a * b / (a + b)
        } else {
            0.0
        }
    };
    let mut faces = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            if i + 1 < nx {
                faces.push((
                    i * ny + j,
                    (i + 1) * ny + j,
                    h(c(i, j), c(i + 1, j)) * dy / dx,
                ));
            }
            if j + 1 < ny || periodic_sides {
                let jp = (j + 1) % ny;
                faces.push((i * ny + j, i * ny + jp, h(c(i, j), c(i, jp)) * dx / dy));
            }
        }
    }
    // Flood from each reservoir through open faces.
    let flood = |start: usize| {
        let mut seen = vec![false; nx * ny];
        let mut stack: Vec<usize> = (0..ny)
            .map(|j| start * ny + j)
            .filter(|&k| g[[k / ny, k % ny]] > 0.0)
            .collect();
        for &k in &stack {
            seen[k] = true;
        }
        while let Some(k) = stack.pop() {
            for &(a, b, s) in &faces {
                for (p, q) in [(a, b), (b, a)] {
                    if p == k && s > 0.0 && !seen[q] {
                        seen[q] = true;
                        stack.push(q);
                    }
                }
            }
        }
        seen
    };
    let (from_in, from_out) = (flood(0), flood(nx - 1));
    let keep: Vec<bool> = (0..nx * ny).map(|k| from_in[k] && from_out[k]).collect();
    let m = nx * ny;
    let mut a = vec![vec![0.0; m + 1]; m];
    for &(p, q, s) in &faces {
        if keep[p] && keep[q] {
            a[p][p] += s;
            a[q][q] += s;
            a[p][q] -= s;
            a[q][p] -= s;
        }
    }
    let inlet = |j: usize| {
        if keep[j] {
            2.0 * c(0, j) * dy / dx
        } else {
            0.0
        }
    };
    for j in 0..ny {
        a[j][j] += inlet(j);
        a[j][m] += inlet(j);
        let k = (nx - 1) * ny + j;
        if keep[k] {
            a[k][k] += 2.0 * c(nx - 1, j) * dy / dx;
        }
    }
    for k in 0..m {
        if !keep[k] {
            a[k][k] = 1.0;
        }
    }
    for col in 0..m {
        let piv = (col..m)
            .max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))
            .unwrap();
        a.swap(col, piv);
        for row in col + 1..m {
            let f = a[row][col] / a[col][col];
            if f != 0.0 {
                for t in col..=m {
                    a[row][t] -= f * a[col][t];
                }
            }
        }
    }
    let mut p = vec![0.0; m];
    for row in (0..m).rev() {
        let s: f64 = (row + 1..m).map(|t| a[row][t] * p[t]).sum();
        p[row] = (a[row][m] - s) / a[row][row];
    }
    (0..ny).map(|j| inlet(j) * (1.0 - p[j])).sum()
}

#[test]
fn random_gaps_with_contact_match_an_independent_dense_solve() {
    let mut rng = Lcg(17);
    for (case, &(nx, ny)) in [(8usize, 8usize), (16, 8), (8, 16), (16, 16)]
        .iter()
        .enumerate()
    {
        let g = Array2::from_shape_fn((nx, ny), |_| {
            let u = rng.uniform();
            if u < 0.25 { 0.0 } else { 0.05 + u }
        });
        for sides in SIDES {
            let r = run(&g, 1.5, 0.75, FlowAxis::X, sides);
            let want = dense_reservoir_flux(&g, 1.5, 0.75, sides == SideEdges::Periodic);
            if want == 0.0 {
                assert!(!r.percolating && r.flux == 0.0, "case {case}");
            } else {
                assert!(
                    rel(r.flux, want) < 1e-10,
                    "case {case} {sides:?}: {} vs {want}",
                    r.flux
                );
                assert!(r.conservation_error < 1e-8, "{}", r.conservation_error);
            }
        }
    }
}

/// Near a closing constriction: g = max(0, ε + cos 2πx + cos 2πy), ε = 1e-6, nodes at
/// x = i/n. Column n/2 (x = 1/2) has a single fluid node, the saddle (n/2, 0) with g = ε, g³ ≈
/// 1e-18: the flux is that of its two faces in series, `1 / (1/h(a, b₋) + 1/h(a, b₊))` (h the
/// harmonic mean, a = g³ of the throat, b± of its x-neighbours), up to the resistance of the
/// ponds, < 16 faces of g³ > 1e-4, i.e. < 2e-13 of the throat's. The gauge keeps the ponds near
/// u = 0, so the cross-section fluxes agree with the dissipation flux (with u = p the inlet pond
/// would sit at 1 and its rounding, 1e-16 × its conductance, would swamp a flux of 1e-18; the
/// dense oracle above, which computes the flux as s (1 − p), fails here for that reason).
#[test]
fn near_critical_constrictions_stay_conservative() {
    let n = 16;
    let tau = std::f64::consts::TAU;
    let g = Array2::from_shape_fn((n, n), |(i, j)| {
        let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
        (1e-6 + (tau * x).cos() + (tau * y).cos()).max(0.0)
    });
    assert_eq!((0..n).filter(|&j| g[[n / 2, j]] > 0.0).count(), 1);
    let h = |a: f64, b: f64| 2.0 * a * b / (a + b);
    let a = g[[n / 2, 0]].powi(3);
    let (bm, bp) = (g[[n / 2 - 1, 0]].powi(3), g[[n / 2 + 1, 0]].powi(3));
    let want = 1.0 / (1.0 / h(a, bm) + 1.0 / h(a, bp));
    for sides in SIDES {
        let r = run(&g, 1.0, 1.0, FlowAxis::X, sides);
        assert!(
            r.percolating && r.conservation_error < 1e-6,
            "{sides:?}: {r:?}"
        );
        assert!(rel(r.flux, want) < 1e-10, "{sides:?}: {} vs {want}", r.flux);
    }
}
