//! The preconditioned Polonsky–Keer solve of the composite (refined) discretisation near p_c at
//! k = 5 (issue 13, docs/near-critical.md §5k): unknowns are forces on areas 1 (fine nodes) and
//! 4^k = 1024 (coarse hats). With the direction's net force removed as a uniform *force* the
//! coarse hats' mean emptied or flooded the fine window at every step and the solve cycled
//! (violation 0.1–0.4 h0 after 400 iterations, cold or warm); removed as a uniform pressure
//! (`preconditioned::direction_weighted`) it converges in under 100 iterations.
//!
//! Oracle: the composite problem is convex, so a state that satisfies its contact conditions is
//! its solution. The returned pressure is checked by the *full* composite operator
//! ([`RefinedModel::new`]: G applied on the fine lattice by one FFT, no blockwise
//! interpolation), which measures the violation of the blockwise solution afresh: started from
//! it with `tol_gap` at the blockwise operator's interpolation error, it must accept it after at
//! most one step, on the same contact set. And the warm and cold solves at the second load reach the same contact set and
//! pressures.

use contact::refinement::{RefineOptions, RefinedModel, Window};
use contact::{Lattice, SolverOptions};
use surface::{CriticalKind, Surface};

/// The saddle with its channel along a grid axis on a node (as critical::ladder::axis_saddle).
fn axis_saddle(s: &Surface) -> (f64, f64) {
    let g = &s.grid;
    let on_node = |v: f64, d: f64, sh: f64| {
        let t = v / d - sh;
        (t - t.round()).abs() < 1e-9
    };
    s.critical_points()
        .into_iter()
        .find(|p| {
            p.kind == CriticalKind::Saddle
                && (p.axis[0].abs() > 1.0 - 1e-9 || p.axis[1].abs() > 1.0 - 1e-9)
                && on_node(p.x, g.dx(), g.shift.0)
                && on_node(p.y, g.dy(), g.shift.1)
        })
        .map(|p| (p.x, p.y))
        .expect("an axis saddle on a node")
}

/// Triangular model, 64² base, k = 5, window 8², margin 5 (82 k unknowns), at 0.7122 and
/// 0.7127 p_fc, both within 1e-3 of this discretisation's p_c (its neck closes between them).
#[test]
fn composite_solve_converges_near_pc_at_k5() {
    let s = Surface::new(Lattice::Triangular, 6).unwrap();
    let (x, y) = axis_saddle(&s);
    let tol = 5e-12;
    let opts = RefineOptions {
        levels: 5,
        window: Window::centred(&s.grid, x, y, 8, 8),
        solver: SolverOptions {
            tol_gap: tol,
            max_iter: 400,
            ..Default::default()
        },
    };
    let mut m = RefinedModel::blockwise(&s, &opts, 5).unwrap();
    let p_fc = s.p_fc_grid();
    let a = m.solve(0.7122 * p_fc, None).unwrap();
    let b = m.solve(0.7127 * p_fc, Some(&a)).unwrap();
    let c = m.solve(0.7127 * p_fc, None).unwrap();
    for (what, r) in [("cold", &a), ("warm", &b), ("cold", &c)] {
        eprintln!(
            "{what}: iterations {} converged {} violation {:.3e} area {}",
            r.stats.iterations, r.stats.converged, r.stats.max_violation, r.contact_area
        );
        // measured: 87, 43, 95 iterations (before: no convergence in 400)
        assert!(r.stats.converged, "{what}: {:?}", r.stats.reason);
        assert!(r.stats.iterations <= 250, "{what}: {}", r.stats.iterations);
    }
    // warm and cold reach the same solution: the same contact set, pressures within what the
    // violation bound allows (k_max δ ≈ π√2 (64·32) · 5e-12 ≈ 5e-8; allow 1e-6 of the load)
    assert_eq!(b.contact_area, c.contact_area);
    let dp = b
        .composite
        .pressure
        .iter()
        .zip(c.composite.pressure.iter())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(dp <= 1e-6 * 0.7127 * p_fc, "pressures differ by {dp}");
    // the full operator, started from the blockwise solution, is within the blockwise
    // interpolation error (margin 5: ~6e-6 of the largest field value) of its own solution after
    // one step (measured 7.1e-7) on the same contact set
    let check = RefineOptions {
        solver: SolverOptions {
            tol_gap: 1e-5,
            max_iter: 1,
            ..Default::default()
        },
        ..opts
    };
    let f = RefinedModel::new(&s, &check)
        .unwrap()
        .solve(0.7127 * p_fc, Some(&c))
        .unwrap();
    eprintln!(
        "full operator on the blockwise solution: violation {:.3e}, iterations {}",
        f.stats.max_violation, f.stats.iterations
    );
    assert!(
        f.stats.converged && f.stats.iterations <= 1,
        "{:?}",
        f.stats
    );
    assert_eq!(f.contact_area, c.contact_area);
}
