//! Tests of the critical-load search on tiny grids (run in release mode: `cargo test --release
//! -p critical`).

use contact::{Interaction, Method, Model, SolverOptions};
use critical::{
    CriticalOptions, CriticalResult, FlowState, ResolutionOptions, contact_mask, find_critical,
    resolution_study,
};
use ndarray::Array2;
use percolation::Axis;
use surface::{Grid, Lattice, Surface};

fn opts() -> CriticalOptions {
    CriticalOptions {
        saddle_loads: Vec::new(),
        ..Default::default()
    }
}

fn run(lattice: Lattice, n: u32, shift: (f64, f64), o: &CriticalOptions) -> CriticalResult {
    let grid = Grid::new(lattice, n)
        .unwrap()
        .shifted(shift.0, shift.1)
        .unwrap();
    find_critical(&Surface::on_grid(lattice, grid), o, None).unwrap()
}

/// A cold solve at `load`, classified.
fn state_at(surface: &Surface, load: f64) -> FlowState {
    let mut m = Model::new(surface).unwrap();
    let o = SolverOptions {
        method: Method::PolonskyKeer,
        ..Default::default()
    };
    let s = m.solve(Interaction::HardWall, load, &o, None).unwrap();
    assert!(s.stats.converged);
    FlowState::of_gap(s.gap.view()).unwrap()
}

#[test]
fn brackets_enclose_the_transition_and_cold_solves_agree() {
    for lattice in Lattice::ALL {
        for shift in [(0.0, 0.0), (0.3, 0.1)] {
            let r = run(lattice, 5, shift, &opts());
            let s = Surface::on_grid(lattice, r.grid);
            for t in [&r.any, &r.x, &r.y] {
                let b = &t.bracket;
                assert!(b.lo < b.hi && b.rel_width() <= 1e-9, "{lattice}: {b:?}");
                assert!(b.criterion.open(&b.state_lo) && !b.criterion.open(&b.state_hi));
                // Independent cold solves a little further out land on the same sides.
                let below = state_at(&s, b.lo * (1.0 - 1e-6));
                let above = state_at(&s, b.hi * (1.0 + 1e-6));
                assert!(b.criterion.open(&below), "{lattice} {shift:?} {b:?}");
                assert!(!b.criterion.open(&above), "{lattice} {shift:?} {b:?}");
                assert!(
                    t.bridging_nodes() > 0,
                    "the bracket must close the bridging nodes"
                );
            }
            // `any` is the later of the axis transitions, and blocks both axes above it.
            assert!((r.any.l_c() - r.x.l_c().max(r.y.l_c())).abs() <= 1e-9 * r.any.l_c());
            assert!(r.any.bracket.state_hi.blocked_all());
            assert!(r.p_fc_over_l_c() > 1.0);
        }
    }
}

#[test]
fn the_dual_rule_holds_on_solved_states_and_random_masks() {
    // Solved states across the whole load range.
    for lattice in Lattice::ALL {
        let s = Surface::new(lattice, 5).unwrap();
        let mut m = Model::new(&s).unwrap();
        let p_fc = s.p_fc_grid();
        let mut warm = None;
        for k in 1..=40 {
            let load = p_fc * k as f64 / 41.0;
            let sol = m
                .solve(
                    Interaction::HardWall,
                    load,
                    &SolverOptions::default(),
                    warm.as_ref(),
                )
                .unwrap();
            let st = FlowState::of_gap(sol.gap.view()).unwrap();
            for axis in [Axis::X, Axis::Y] {
                assert_ne!(st.fluid(axis), st.blocked(axis), "{lattice} at {load}");
            }
            warm = Some(sol);
        }
    }
    // Random masks of all densities, including 1- and 2-wide grids.
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for trial in 0..3000 {
        let nx = 1 + (next() % 9) as usize;
        let ny = 1 + (next() % 9) as usize;
        let density = (trial % 11) as f64 / 10.0;
        let mask = Array2::from_shape_fn((nx, ny), |_| (next() % 1000) as f64 / 1000.0 < density);
        let st = FlowState::of(mask.view()).unwrap();
        for axis in [Axis::X, Axis::Y] {
            assert_ne!(st.fluid(axis), st.blocked(axis), "{mask:?}");
        }
    }
}

#[test]
fn square_model_is_symmetric_under_swapping_x_and_y() {
    // h(x, y) = h(y, x): the grid shifted by (a, b) is the transpose of the one shifted by (b, a).
    let a = run(Lattice::Square, 5, (0.3, 0.1), &opts());
    let b = run(Lattice::Square, 5, (0.1, 0.3), &opts());
    let close = |u: f64, v: f64| (u - v).abs() <= 2e-9 * u.abs();
    assert!(
        close(a.any.l_c(), b.any.l_c()),
        "{} {}",
        a.any.l_c(),
        b.any.l_c()
    );
    assert!(close(a.x.l_c(), b.y.l_c()) && close(a.y.l_c(), b.x.l_c()));
    assert_eq!(a.any.area_lo.n_contact, b.any.area_lo.n_contact);
    assert_eq!(a.x.area_hi.n_contact, b.y.area_hi.n_contact);
    // The shifted grid breaks the symmetry between the axes themselves.
    assert!(!close(a.x.l_c(), a.y.l_c()));
    // Unshifted, the axes coincide.
    let u = run(Lattice::Square, 6, (0.0, 0.0), &opts());
    assert!(close(u.x.l_c(), u.y.l_c()));
    // The same with the transposed height field given explicitly.
    let s = Surface::new(Lattice::Square, 5).unwrap();
    let grid = s.grid.shifted(0.3, 0.1).unwrap();
    let s1 = Surface::on_grid(Lattice::Square, grid);
    let mut t = s1.clone();
    t.heights = s1.heights.t().to_owned();
    t.grid = s.grid.shifted(0.1, 0.3).unwrap();
    let rt = find_critical(&t, &opts(), None).unwrap();
    assert!(close(rt.x.l_c(), a.y.l_c()) && close(rt.y.l_c(), a.x.l_c()));
}

/// Reference values from `examples/dense_reference.rs` (dense compliance matrix summed over wave
/// vectors, exact LCP solution by block principal pivoting, BFS percolation, bisection to 1e-12),
/// computed once on the 2^5 grids: (lattice, shift, [(criterion, L_c, contact nodes below, above,
/// perimeter faces below, above)]).
#[allow(clippy::type_complexity)]
const DENSE_REFERENCE: &[(Lattice, (f64, f64), [(f64, usize, usize, usize, usize); 3])] = &[
    (
        Lattice::Hexagonal,
        (0.0, 0.0),
        [
            (0.2514454729968, 208, 212, 256, 256),
            (0.2514454729968, 208, 212, 256, 256),
            (0.2435930068415, 200, 208, 224, 256),
        ],
    ),
    (
        Lattice::Square,
        (0.0, 0.0),
        [
            (1.4385398896234, 433, 435, 124, 124),
            (1.4385398896234, 433, 435, 124, 124),
            (1.4385398896234, 433, 435, 124, 124),
        ],
    ),
    (
        Lattice::Square,
        (0.3, 0.1),
        [
            (1.4427050572550, 423, 424, 124, 124),
            (1.4427050572550, 423, 424, 124, 124),
            (1.4368827128726, 418, 419, 124, 124),
        ],
    ),
    (
        Lattice::Triangular,
        (0.0, 0.0),
        [
            (2.7408020431005, 708, 716, 240, 240),
            (2.7408020431005, 708, 716, 240, 240),
            (2.7408020431005, 708, 716, 240, 240),
        ],
    ),
];

#[test]
fn tiny_grids_match_an_independent_dense_solver() {
    for (lattice, shift, refs) in DENSE_REFERENCE {
        let r = run(*lattice, 5, *shift, &opts());
        for (t, (l_c, c_lo, c_hi, e_lo, e_hi)) in [&r.any, &r.x, &r.y].iter().zip(refs) {
            // The dense reference is exact to rounding; Polonsky–Keer resolves contact to
            // tol_gap = 1e-10 h0, i.e. the transition to about 1e-9 relative.
            let rel = (t.l_c() - l_c).abs() / l_c;
            assert!(
                rel < 3e-9,
                "{lattice} {shift:?}: {} vs {l_c} ({rel:.1e})",
                t.l_c()
            );
            assert_eq!(
                (
                    t.area_lo.n_contact,
                    t.area_hi.n_contact,
                    t.area_lo.n_perimeter_edges,
                    t.area_hi.n_perimeter_edges
                ),
                (*c_lo, *c_hi, *e_lo, *e_hi),
                "{lattice} {shift:?}"
            );
        }
    }
}

#[test]
fn saddle_gap_fit_gives_a_sub_grid_estimate_near_the_bisected_load() {
    let o = CriticalOptions {
        saddle_loads: vec![-0.03, -0.02, -0.0125, -0.008, -0.005],
        ..Default::default()
    };
    let r = run(Lattice::Square, 7, (0.0, 0.0), &o);
    let sub = r
        .subgrid
        .as_ref()
        .expect("square n = 7 resolves the channel");
    assert_eq!(r.samples.len(), 5);
    // Continuum-like closing: ζ near 6/5 and L_c within 0.1 % of the grid's transition.
    assert!((sub.zeta - 1.2).abs() < 0.1, "{sub:?}");
    assert!(
        (sub.l_c - r.l_c()).abs() < 1e-3 * r.l_c(),
        "{sub:?} vs {}",
        r.l_c()
    );
    // The samples are below L_c with open, decreasing saddle gaps.
    let g: Vec<f64> = r.samples.iter().map(|s| s.gap[0].unwrap()).collect();
    assert!(g.windows(2).all(|w| w[0] < w[1]), "{g:?}"); // ordered closest to L_c first
    assert!(r.samples.iter().all(|s| s.load < r.any.bracket.lo));
}

#[test]
fn resolution_study_runs_coarse_to_fine_and_extrapolates() {
    let mut o = ResolutionOptions::new(vec![5, 6, 7], 1);
    o.critical.saddle_loads.clear();
    let s = resolution_study(Lattice::Square, &o).unwrap();
    assert_eq!(s.levels.len(), 3);
    assert!(s.levels.iter().all(|l| l.shifts == vec![(0.25, 0.25)]));
    let (a, e) = s.get("a_p_raw").unwrap().value().unwrap();
    assert!(
        (a - 0.40185).abs() < 0.02 && e.is_finite() && e > 0.0,
        "{a} ± {e}"
    );
    let (l, _) = s.get("l_c").unwrap().value().unwrap();
    assert!((l - 1.4364).abs() < 0.01, "{l}");
    let (r, _) = s.p_fc_over_l_c().unwrap();
    assert!((r - 2.0 * std::f64::consts::PI / l).abs() < 1e-12);
    assert!(s.fields.is_some());
    let bad = ResolutionOptions::new(vec![6, 5], 0);
    assert!(resolution_study(Lattice::Square, &bad).is_err());
}

#[test]
fn invalid_options_are_rejected_with_their_values() {
    let s = Surface::new(Lattice::Square, 4).unwrap();
    let mut o = opts();
    o.rel_width = 2.0;
    let e = find_critical(&s, &o, None).unwrap_err().to_string();
    assert!(e.contains("rel_width") && e.contains('2'), "{e}");
    let mut o = opts();
    o.saddle_loads = vec![0.01];
    let e = find_critical(&s, &o, None).unwrap_err().to_string();
    assert!(e.contains("saddle_loads") && e.contains("0.01"), "{e}");
    let mut o = opts();
    o.tol_gap = f64::NAN;
    assert!(find_critical(&s, &o, None).is_err());
}

#[test]
fn contact_mask_is_the_zero_gap_set() {
    let g = Array2::from_shape_vec((2, 2), vec![0.0, 1e-300, 0.5, 0.0]).unwrap();
    let m = contact_mask(g.view());
    assert_eq!(
        m.iter().copied().collect::<Vec<_>>(),
        vec![true, false, false, true]
    );
}
