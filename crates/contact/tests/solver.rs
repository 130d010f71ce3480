//! Exact and independent checks of the contact solver (small grids; run in release mode).

use contact::fire::Fire;
use contact::polonsky_keer::PolonskyKeer;
use contact::{ContactError, Interaction, Lattice, Method, Model, SolverOptions, Surface};
use std::f64::consts::PI;
use surface::CriticalKind;

const ADHESION: Interaction = Interaction::Adhesion {
    gamma0: 0.2,
    rho: 0.04,
};
const REPULSION: Interaction = Interaction::Repulsion {
    gamma_r: 0.2,
    rho: 0.04,
};

fn model(l: Lattice, n: u32) -> (Surface, Model) {
    let s = Surface::new(l, n).unwrap();
    let m = Model::new(&s).unwrap();
    (s, m)
}

/// Full contact is reached exactly at p_fc = π(h̄ − min h) (PHYSICS.md): just below it one
/// trough stays open, just above it every node is closed, and the pressure is then the exact
/// full-contact field p̄ + π(h − h̄).
#[test]
fn full_contact_pressure_is_exact_for_every_model_and_grid() {
    for l in Lattice::ALL {
        for n in [5, 6] {
            let (s, mut m) = model(l, n);
            let p_fc = s.p_fc_grid();
            let opts = SolverOptions::default();
            let below = m
                .solve(Interaction::HardWall, p_fc * (1.0 - 1e-4), &opts, None)
                .unwrap();
            assert!(below.stats.converged, "{l} n={n}: {:?}", below.stats);
            assert!(
                below.contact_area < 1.0,
                "{l} n={n}: a = {} below p_fc",
                below.contact_area
            );
            let above = m
                .solve(Interaction::HardWall, p_fc * (1.0 + 1e-4), &opts, None)
                .unwrap();
            assert!(above.stats.converged);
            assert_eq!(above.contact_area, 1.0, "{l} n={n}: a below 1 above p_fc");
            let mean_h = s.statistics().mean;
            for (p, h) in above.pressure.iter().zip(s.heights.iter()) {
                let exact = p_fc * (1.0 + 1e-4) + PI * (h - mean_h);
                // Rounding of two FFTs on pressures of order p_fc.
                assert!(
                    (p - exact).abs() < 1e-10 * p_fc,
                    "{l} n={n}: {p} vs {exact}"
                );
            }
        }
    }
}

/// A small load on a peak is a Hertz contact with the peak's curvature radius R (from the exact
/// Hessian; every peak of the three models is isotropic): central pressure
/// p0 = 3F/(2πa²) with a = (3FR/4E*)^{1/3}. At a = 0.06λ the cosine peak departs from the
/// parabola by (2πa)²/12 ≈ 1.2 % in height at the contact edge, which shifts p0 by well under 1 %;
/// the grid (a/dx ≈ 15) adds less. So 1 % is the tolerance, and the F^{1/3} scaling must hold to
/// the same accuracy.
#[test]
fn small_loads_on_a_peak_follow_hertz() {
    for l in Lattice::ALL {
        let (s, mut m) = model(l, 8);
        let cps = s.critical_points();
        let peaks: Vec<_> = cps
            .iter()
            .filter(|c| c.kind == CriticalKind::Maximum)
            .collect();
        let peak = peaks[0];
        assert!((peak.curvatures[0] - peak.curvatures[1]).abs() < 1e-9 * peak.curvatures[0].abs());
        let r = -1.0 / peak.curvatures[0];
        let cell = s.grid.lx * s.grid.ly;
        let (i, j) = (
            (peak.x / s.grid.dx()).round() as usize,
            (peak.y / s.grid.dy()).round() as usize,
        );
        let mut central = Vec::new();
        for a in [0.03, 0.06] {
            let force = 4.0 * a * a * a / (3.0 * r);
            let sol = m
                .solve(
                    Interaction::HardWall,
                    force * peaks.len() as f64 / cell,
                    &SolverOptions::default(),
                    None,
                )
                .unwrap();
            assert!(sol.stats.converged);
            let p0 = 3.0 * force / (2.0 * PI * a * a);
            let pc = sol.pressure[[i % s.grid.nx, j % s.grid.ny]];
            assert!(
                (pc / p0 - 1.0).abs() < 0.01,
                "{l} a={a}: p(0) = {pc}, Hertz {p0}"
            );
            central.push(pc);
        }
        // Eight times the load doubles the central pressure.
        assert!(
            (central[1] / central[0] - 2.0).abs() < 0.02,
            "{l}: {central:?}"
        );
    }
}

/// Polonsky–Keer and FIRE solve the same hard-wall problem to the same state.
#[test]
fn minimisers_agree_on_the_hard_wall_problem() {
    for l in [Lattice::Square, Lattice::Triangular] {
        let (s, mut m) = model(l, 5);
        let p = 0.2 * s.p_fc_grid();
        let pk = m
            .solve_with(
                &PolonskyKeer::default(),
                Interaction::HardWall,
                p,
                &SolverOptions {
                    tol_gap: 1e-12,
                    ..Default::default()
                },
                None,
            )
            .unwrap();
        let fire = m
            .solve_with(
                &Fire::default(),
                Interaction::HardWall,
                p,
                &SolverOptions {
                    tol_force: 1e-10,
                    ..Default::default()
                },
                None,
            )
            .unwrap();
        assert!(pk.stats.converged && fire.stats.converged);
        // A force residual of 1e-10 against stiffnesses ≥ k_min = π/L leaves gap errors below
        // ~1e-10·L/π; pressures agree to the force residual times a few.
        let dg = pk
            .gap
            .iter()
            .zip(fire.gap.iter())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let dp = pk
            .pressure
            .iter()
            .zip(fire.pressure.iter())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(dg < 1e-9, "{l}: gaps differ by {dg}");
        assert!(dp < 1e-8, "{l}: pressures differ by {dp}");
        assert_eq!(pk.contact_area, fire.contact_area, "{l}");
        assert!(
            (pk.energy - fire.energy).abs() < 1e-12 * pk.energy.abs(),
            "{l}: {} vs {}",
            pk.energy,
            fire.energy
        );
    }
}

/// With strict descent on, the energy of FIRE's accepted states never increases (beyond the
/// rounding slack of 64 ulp of the mean absolute energy term, ~1e-13 here), for every
/// interaction; and strict and inertial FIRE end in the same state. Polonsky–Keer's iterates are
/// infeasible until convergence, so its objective is not monotone; its final energy must equal
/// FIRE's.
#[test]
fn energy_never_increases_during_relaxation() {
    let (s, mut m) = model(Lattice::Square, 5);
    let cases = [
        (Interaction::HardWall, 0.2 * s.p_fc_grid()),
        (ADHESION, 0.0),
        (ADHESION, 0.5),
        (REPULSION, 0.5),
    ];
    for (inter, p) in cases {
        let opts = SolverOptions {
            method: Method::Fire,
            trace: true,
            ..Default::default()
        };
        let strict = Fire {
            monotone: true,
            ..Fire::default()
        };
        let a = m.solve_with(&strict, inter, p, &opts, None).unwrap();
        assert!(a.stats.converged, "{inter:?}: {:?}", a.stats.reason);
        let tr = &a.stats.trace;
        assert!(tr.len() > 10);
        for w in tr.windows(2) {
            assert!(
                w[1] <= w[0] + 1e-12 * (1.0 + w[0].abs()),
                "{inter:?} p={p}: energy rose {} → {}",
                w[0],
                w[1]
            );
        }
        let b = m
            .solve_with(&Fire::default(), inter, p, &opts, None)
            .unwrap();
        assert!(b.stats.converged);
        assert!(
            (a.energy - b.energy).abs() < 1e-10,
            "{inter:?}: {} vs {}",
            a.energy,
            b.energy
        );
        // The inertial run may rise transiently, but never ends above where it started.
        assert!(b.energy <= b.stats.trace[0]);
    }
}

/// The square model is symmetric under x → −x, y → −y and x ↔ y; the triangular and hexagonal
/// models under x → −x and y → −y. Their solutions must be too.
#[test]
fn symmetric_surfaces_give_symmetric_solutions() {
    for l in Lattice::ALL {
        for inter in [Interaction::HardWall, ADHESION] {
            let (s, mut m) = model(l, 6);
            let p = 0.3 * s.p_fc_grid();
            let sol = m.solve(inter, p, &SolverOptions::default(), None).unwrap();
            assert!(sol.stats.converged);
            let g = &sol.gap;
            let n = s.grid.nx;
            let mut worst = 0.0f64;
            for i in 0..n {
                for j in 0..n {
                    let v = g[[i, j]];
                    worst = worst
                        .max((v - g[[(n - i) % n, j]]).abs())
                        .max((v - g[[i, (n - j) % n]]).abs());
                    if l == Lattice::Square {
                        worst = worst.max((v - g[[j, i]]).abs());
                    }
                }
            }
            // PK: gap within tol_gap; FIRE: force residual 1e-8 over stiffness ≥ π → 1e-8.
            assert!(worst < 1e-8, "{l} {inter:?}: asymmetry {worst}");
        }
    }
}

#[test]
fn adhesion_holds_contact_at_zero_and_small_tensile_load() {
    // JKR pull-off of one square-model peak: 1.5 π γ0 R ≈ 0.024 per cell; −0.005 is well inside.
    for p in [0.0, -0.005] {
        let (_, mut m) = model(Lattice::Square, 6);
        let sol = m
            .solve(ADHESION, p, &SolverOptions::default(), None)
            .unwrap();
        assert!(sol.stats.converged, "p={p}: {:?}", sol.stats.reason);
        assert!(sol.contact_area > 0.01, "p={p}: a = {}", sol.contact_area);
        // Adhesive necks: tensile pressure somewhere.
        assert!(sol.pressure.iter().any(|&v| v < 0.0));
    }
    // Far beyond pull-off there is no equilibrium: a clear error, not a number.
    let (_, mut m) = model(Lattice::Square, 5);
    match m.solve(ADHESION, -1.0, &SolverOptions::default(), None) {
        Err(ContactError::Detached { .. }) => {}
        other => panic!("expected detachment, got {other:?}"),
    }
}

#[test]
fn gaussian_repulsion_keeps_a_small_load_out_of_contact() {
    let (_, mut m) = model(Lattice::Square, 6);
    let sol = m
        .solve(REPULSION, 0.05, &SolverOptions::default(), None)
        .unwrap();
    assert!(sol.stats.converged);
    assert_eq!(sol.contact_area, 0.0);
    assert!(sol.gap.iter().all(|&g| g > 0.0));
    // The repulsive pressures carry the load: their mean is the imposed pressure.
    let mean = sol.pressure.mean().unwrap();
    assert!((mean - 0.05).abs() < 1e-12);
}

#[test]
fn warm_start_from_the_solution_converges_at_once() {
    for inter in [Interaction::HardWall, ADHESION] {
        let (s, mut m) = model(Lattice::Hexagonal, 6);
        let p = 0.1 * s.p_fc_grid();
        let opts = SolverOptions::default();
        let a = m.solve(inter, p, &opts, None).unwrap();
        let b = m.solve(inter, p, &opts, Some(&a)).unwrap();
        assert!(b.stats.converged);
        assert!(
            b.stats.iterations <= 2,
            "{inter:?}: {} iterations from the solution",
            b.stats.iterations
        );
        assert!((a.energy - b.energy).abs() < 1e-12);
    }
}

/// A warm start that interpolates two converged solutions just below and just above a change of
/// the contact set is uniform in gap on its contact set but penetrates next to it: there is no
/// descent direction on the contact set at the first step. Polonsky–Keer must re-open the
/// penetrating nodes and converge (it used to stop after 2 iterations as "stagnated"), to the
/// same state as a cold solve (the hard-wall problem is convex: one solution).
#[test]
fn a_warm_start_penetrating_outside_its_contact_set_converges() {
    let (_, mut m) = model(Lattice::Square, 6);
    let opts = SolverOptions {
        method: Method::PolonskyKeer,
        ..Default::default()
    };
    let (la, lb) = (1.436834681907683, 1.4369476317293879);
    let lm = 0.5 * (la + lb);
    let a = m.solve(Interaction::HardWall, la, &opts, None).unwrap();
    let b = m.solve(Interaction::HardWall, lb, &opts, None).unwrap();
    assert!(a.stats.converged && b.stats.converged);
    let mut w = a.clone();
    w.pressure
        .zip_mut_with(&b.pressure, |p, q| *p = 0.5 * (*p + q));
    let warm = m.solve(Interaction::HardWall, lm, &opts, Some(&w)).unwrap();
    let cold = m.solve(Interaction::HardWall, lm, &opts, None).unwrap();
    assert!(
        warm.stats.converged,
        "{:?} after {} iterations, violation {:e}",
        warm.stats.reason, warm.stats.iterations, warm.stats.max_violation
    );
    assert!(warm.stats.max_violation <= opts.tol_gap);
    let dg = warm
        .gap
        .iter()
        .zip(&cold.gap)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    // both satisfy the constraints to 1e-10 h0; the solution is unique
    assert!(
        dg < 1e-8,
        "warm and cold solutions differ by {dg:e} h0: warm a {} it {} mean p {} viol {:e} min gap {:e} min p {:e}; cold a {} it {} mean p {} mean gap {} vs {}",
        warm.contact_area,
        warm.stats.iterations,
        warm.pressure.mean().unwrap(),
        warm.stats.max_violation,
        warm.gap.iter().cloned().fold(f64::INFINITY, f64::min),
        warm.pressure.iter().cloned().fold(f64::INFINITY, f64::min),
        cold.contact_area,
        cold.stats.iterations,
        cold.pressure.mean().unwrap(),
        warm.mean_gap,
        cold.mean_gap
    );
    assert_eq!(warm.contact_area, cold.contact_area);
}

#[test]
fn every_result_reports_its_convergence() {
    let (s, mut m) = model(Lattice::Square, 6);
    let opts = SolverOptions {
        max_iter: 3,
        ..Default::default()
    };
    let sol = m
        .solve(Interaction::HardWall, 0.3 * s.p_fc_grid(), &opts, None)
        .unwrap();
    assert!(!sol.stats.converged);
    assert_eq!(sol.stats.iterations, 3);
    let why = sol.stats.reason.as_ref().unwrap().to_string();
    assert!(
        why.contains("iteration cap") && why.contains("max_iter"),
        "{why}"
    );
    assert!(sol.stats.max_violation > opts.tol_gap);
}

#[test]
fn bad_input_gives_clear_errors() {
    let e = "hexagon".parse::<Lattice>().unwrap_err().to_string();
    assert!(e.contains("hexagon") && e.contains("square"), "{e}");
    let e = Surface::new(Lattice::Square, 14).unwrap_err().to_string();
    assert!(e.contains("14") && e.contains("3..=13"), "{e}");
    let (_, mut m) = model(Lattice::Square, 4);
    let o = SolverOptions::default();
    let msg = |r: Result<contact::Solution, ContactError>| r.unwrap_err().to_string();
    let e = msg(m.solve(
        Interaction::Adhesion {
            gamma0: 0.2,
            rho: 0.0,
        },
        0.1,
        &o,
        None,
    ));
    assert!(e.contains("rho = 0") && e.contains("> 0"), "{e}");
    let e = msg(m.solve(
        Interaction::Adhesion {
            gamma0: -0.1,
            rho: 0.04,
        },
        0.1,
        &o,
        None,
    ));
    assert!(e.contains("gamma0 = -0.1") && e.contains("≥ 0"), "{e}");
    for bad in [f64::NAN, f64::INFINITY] {
        let e = msg(m.solve(Interaction::HardWall, bad, &o, None));
        assert!(e.contains("pressure") && e.contains("finite"), "{e}");
    }
    let e = msg(m.solve(Interaction::HardWall, 0.0, &o, None));
    assert!(e.contains("pressure = 0") && e.contains("> 0"), "{e}");
    let e = msg(m.solve_with(&PolonskyKeer::default(), ADHESION, 0.1, &o, None));
    assert!(e.contains("polonsky-keer") && e.contains("fire"), "{e}");
    let e = msg(m.solve(
        Interaction::HardWall,
        0.1,
        &SolverOptions {
            tol_gap: -1.0,
            ..o.clone()
        },
        None,
    ));
    assert!(e.contains("tol_gap"), "{e}");
    let mut h = Surface::new(Lattice::Square, 3).unwrap();
    h.heights[[2, 5]] = f64::NAN;
    let e = Model::new(&h).err().unwrap().to_string();
    assert!(e.contains("(2, 5)") && e.contains("NaN"), "{e}");
    // a warm start with a NaN is refused, not propagated into a "converged" NaN state
    let mut w = m.solve(Interaction::HardWall, 0.1, &o, None).unwrap();
    w.pressure[[1, 2]] = f64::NAN;
    let e = msg(m.solve(Interaction::HardWall, 0.1, &o, Some(&w)));
    assert!(
        e.contains("warm start") && e.contains("pressure") && e.contains("NaN"),
        "{e}"
    );
}

/// Stands in for rounding noise grown along an unstable mode: lifts one node off its inverted
/// twin by `amount` and stops at the iteration cap.
struct Lopsided {
    amount: f64,
}

impl contact::Minimizer for Lopsided {
    fn name(&self) -> &'static str {
        "lopsided"
    }
    fn relax(
        &self,
        _: &mut Model,
        _: Interaction,
        _: f64,
        opts: &SolverOptions,
        state: &mut contact::State,
    ) -> Result<contact::SolveStats, ContactError> {
        state.u[1] += self.amount;
        Ok(contact::SolveStats {
            method: "lopsided",
            iterations: opts.max_iter,
            converged: false,
            reason: Some(contact::StopReason::IterationCap),
            max_violation: 1.0,
            force_residual: 1.0,
            wall_s: 0.0,
            trace: Vec::new(),
        })
    }
}

/// An unconverged solve whose state broke the inversion symmetry of a symmetric surface and start
/// says so (and what to do); one without symmetry to lose, or that kept it, keeps its own reason;
/// real minimisers stopped early keep the symmetry to rounding, so they are not misdiagnosed.
#[test]
fn lost_symmetry_is_diagnosed_only_where_there_was_symmetry() {
    use contact::StopReason;
    let (s, mut m) = model(Lattice::Triangular, 5);
    let load = 0.3 * s.p_fc_grid();
    let opts = SolverOptions {
        max_iter: 3,
        ..Default::default()
    };
    let run = |m: &mut Model, amount: f64, warm: Option<&contact::Solution>| {
        m.solve_with(&Lopsided { amount }, ADHESION, load, &opts, warm)
            .unwrap()
            .stats
            .reason
            .unwrap()
    };
    match run(&mut m, 1e-3, None) {
        StopReason::LossOfSymmetry { defect } => {
            assert!((defect - 1e-3).abs() < 1e-9, "{defect}");
            let msg = StopReason::LossOfSymmetry { defect }.to_string();
            assert!(msg.contains("instability") && msg.contains("smaller load"));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(run(&mut m, 0.0, None), StopReason::IterationCap);
    // Every model's sampling has the symmetry, so the diagnosis is available for all three.
    for l in Lattice::ALL {
        let (s, mut other) = model(l, 4);
        let r = other
            .solve_with(
                &Lopsided { amount: 1e-3 },
                ADHESION,
                0.3 * s.p_fc_grid(),
                &opts,
                None,
            )
            .unwrap();
        assert!(
            matches!(r.stats.reason, Some(StopReason::LossOfSymmetry { .. })),
            "{l:?}"
        );
    }
    // An asymmetric start has no symmetry to lose.
    let mut warm = m
        .solve(Interaction::HardWall, load, &SolverOptions::default(), None)
        .unwrap();
    warm.displacement[[1, 2]] += 1e-2;
    assert_eq!(run(&mut m, 1e-3, Some(&warm)), StopReason::IterationCap);
    // Real minimisers stopped after a few iterations: symmetric to rounding, reason kept.
    for (inter, method) in [
        (ADHESION, Method::Fire),
        (Interaction::HardWall, Method::PolonskyKeer),
    ] {
        let o = SolverOptions {
            max_iter: 5,
            method,
            ..Default::default()
        };
        let sol = m.solve(inter, load, &o, None).unwrap();
        assert_eq!(
            sol.stats.reason,
            Some(StopReason::IterationCap),
            "{method:?}"
        );
    }
}
