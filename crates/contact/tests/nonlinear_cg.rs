//! The nonlinear-CG minimiser against FIRE on the quasi-static branches of Figures 2 and 3
//! (square model, small grids), and the branch safeguard: jumps are found from the solved
//! states by the sweep's own detector ([`analysis::detect_jumps`] on the contact area), not by
//! either minimiser.

use analysis::{JumpOptions, detect_jumps};
use contact::path::{Branch, Control, PathSpec, sweep};
use contact::{Interaction, Lattice, Method, Model, SolverOptions, Surface};

const RHO: f64 = 0.04;
/// Both minimisers stop on the same force residual (E* h0/λ), judged by the same `residuals()`.
const TOL_FORCE: f64 = 1e-10;

/// One solved point: the control value, the scalars and the displacement field.
struct Point {
    branch: Branch,
    x: f64,
    area: f64,
    mean_gap: f64,
    energy: f64,
    u: Vec<f64>,
    iterations: usize,
}

fn run(model: &mut Model, method: Method, inter: Interaction, spec: &PathSpec) -> Vec<Point> {
    let opts = SolverOptions {
        tol_force: TOL_FORCE,
        method,
        ..SolverOptions::default()
    };
    let strength_path = matches!(spec.control, Control::Strength { .. });
    let mut points = Vec::new();
    let result = sweep(model, inter, spec, &opts, |pt, sol| {
        assert!(
            pt.converged,
            "{method:?} at {:?} step {}: {:?}",
            pt.branch, pt.step, sol.stats
        );
        points.push(Point {
            branch: pt.branch,
            x: if strength_path { pt.strength } else { pt.load },
            area: pt.contact_area,
            mean_gap: pt.mean_gap,
            energy: pt.energy,
            u: sol.displacement.iter().copied().collect(),
            iterations: pt.iterations,
        });
    })
    .unwrap();
    assert!(result.ended.is_empty(), "{method:?}: {:?}", result.ended);
    points
}

/// Control values at which the area jumps on `branch` (the value after the jump), by the
/// sweep's detector. On these 32² grids lattice trapping moves the area in steps of a few nodes
/// (≤ 12 of 1024, about 1 % of the area's range); the floor of 5 % of the range keeps those out
/// and leaves the physical jumps (contact formation, coalescence, full contact, its reopening).
fn jumps(points: &[Point], branch: Branch) -> Vec<f64> {
    let on: Vec<&Point> = points.iter().filter(|p| p.branch == branch).collect();
    let x: Vec<f64> = on.iter().map(|p| p.x).collect();
    let a: Vec<f64> = on.iter().map(|p| p.area).collect();
    let opts = JumpOptions {
        min_rel_size: 0.05,
        ..JumpOptions::default()
    };
    detect_jumps(&x, &a, &opts)
        .unwrap()
        .iter()
        .map(|j| on[j.index + 1].x)
        .collect()
}

/// max |u(r) − u(−r)| on an n × n grid, −r the node inverted through the origin node (a symmetry
/// of every model's sampling).
fn inversion_defect(u: &[f64]) -> f64 {
    let n = (u.len() as f64).sqrt() as usize;
    let mut d = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            d = d.max((u[i * n + j] - u[((n - i) % n) * n + (n - j) % n]).abs());
        }
    }
    d
}

/// Compares the two paths point by point and their jumps, and returns the summed iterations
/// (ours, FIRE's).
fn compare(label: &str, ours: &[Point], fire: &[Point], step: f64) -> (usize, usize) {
    assert_eq!(ours.len(), fire.len(), "{label}: path lengths");
    for branch in [Branch::Loading, Branch::Unloading] {
        let (jo, jf) = (jumps(ours, branch), jumps(fire, branch));
        assert_eq!(
            jo.len(),
            jf.len(),
            "{label} {branch:?}: jumps at {jo:?} (ours) vs {jf:?} (FIRE)"
        );
        for (a, b) in jo.iter().zip(&jf) {
            // within one path step (relative to the step for geometric strength paths)
            assert!(
                (a - b).abs() <= step * a.abs().max(b.abs()).max(1.0) * 1.0001,
                "{label} {branch:?}: jump at {a} (ours) vs {b} (FIRE)"
            );
        }
    }
    let n = ours[0].u.len() as f64;
    let mut differ = 0usize;
    for (o, f) in ours.iter().zip(fire) {
        // A symmetry change is a branch change too: both minimisers keep the surface's
        // inversion symmetry or both lose it (1e-6: six orders above a converged state's
        // asymmetry, residual 1e-10 over stiffness ≥ π).
        let (so, sf) = (inversion_defect(&o.u), inversion_defect(&f.u));
        assert_eq!(
            so < 1e-6,
            sf < 1e-6,
            "{label} x={}: inversion defect {so:e} (ours) vs {sf:e} (FIRE)",
            o.x
        );
        let du =
            o.u.iter()
                .zip(&f.u)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        // A force residual ≤ 1e-10 bounds the displacement error by 1e-10 over the smallest
        // eigenvalue of the Hessian on the free nodes; on a stable branch that is the elastic
        // k_min = π less the interaction's softening, so two converged states of one branch differ
        // by ~1e-10: 1e-7 leaves three orders for states close to an instability, where the
        // Hessian softens. States on different branches differ by O(ρ) = 0.04 h0 or more.
        if du > 1e-7 {
            // another metastable state of the discrete problem: lattice trapping, a few nodes
            differ += 1;
            assert!(
                (o.area - f.area).abs() <= 12.5 / n,
                "{label} x={}: area {} vs {} (more than lattice trapping)",
                o.x,
                o.area,
                f.area
            );
            continue;
        }
        assert!(
            (o.area - f.area).abs() <= 1.5 / n,
            "{label} x={}: area {} vs {}",
            o.x,
            o.area,
            f.area
        );
        assert!((o.mean_gap - f.mean_gap).abs() <= 1e-7, "{label} x={}", o.x);
        // energy: first order in the residual at a minimum, so far below the field tolerance
        assert!((o.energy - f.energy).abs() <= 1e-10, "{label} x={}", o.x);
    }
    // Measured: 6 of 79 (adhesion), 4 of 59 (repulsion), 0 of 39 (strength) points differ.
    assert!(
        differ * 10 <= ours.len(),
        "{label}: {differ} of {} points in other metastable states",
        ours.len()
    );
    (
        ours.iter().map(|p| p.iterations).sum(),
        fire.iter().map(|p| p.iterations).sum(),
    )
}

fn square(n: u32) -> (Surface, Model) {
    let s = Surface::new(Lattice::Square, n).unwrap();
    let m = Model::new(&s).unwrap();
    (s, m)
}

fn load_path(p_fc: f64, step: f64, to: f64) -> PathSpec {
    let k = (to / step).round() as usize;
    PathSpec {
        control: Control::Load {
            values: (0..=k).map(|i| p_fc * (0.0025 + step * i as f64)).collect(),
        },
        reverse: true,
        extension: Vec::new(),
        refine: Default::default(),
    }
}

/// Figure 2, adhesion: loading and unloading through patch coalescence (≈ 0.13 p_fc), full
/// contact (≈ 0.66) and its reopening (≈ 0.2 on unloading).
#[test]
fn agrees_with_fire_on_the_adhesive_load_path() {
    let (s, mut m) = square(5);
    let step = 0.02;
    let spec = load_path(s.p_fc_grid(), step, 0.8);
    let inter = Interaction::Adhesion {
        gamma0: 0.2,
        rho: RHO,
    };
    let ours = run(&mut m, Method::NonlinearCg, inter, &spec);
    let fire = run(&mut m, Method::Fire, inter, &spec);
    let (io, if_) = compare("adhesion", &ours, &fire, step * s.p_fc_grid());
    assert!(io < if_, "iterations {io} (ours) vs {if_} (FIRE)");
    // the path has the hysteresis the figure shows: full contact reopens with a jump
    assert!(!jumps(&fire, Branch::Unloading).is_empty());
}

/// Figure 2, repulsion: contact forms through the barrier, patches coalesce.
#[test]
fn agrees_with_fire_on_the_repulsive_load_path() {
    let (s, mut m) = square(5);
    let step = 0.02;
    let spec = load_path(s.p_fc_grid(), step, 0.6);
    let inter = Interaction::Repulsion {
        gamma_r: 0.2,
        rho: RHO,
    };
    let ours = run(&mut m, Method::NonlinearCg, inter, &spec);
    let fire = run(&mut m, Method::Fire, inter, &spec);
    let (io, if_) = compare("repulsion", &ours, &fire, step * s.p_fc_grid());
    assert!(io < if_, "iterations {io} (ours) vs {if_} (FIRE)");
}

/// Figure 3: γ0 path at zero load, increasing and decreasing (geometric steps), up to γ0 ≈ 0.87:
/// beyond γ0 ≈ 1 the cohesive zone ρ²E*/γ0 is below a twentieth of the 32² grid spacing and
/// the discrete problem has many trapped states (the two minimisers then part by up to 40
/// nodes of contact).
#[test]
fn agrees_with_fire_on_the_strength_path_at_zero_load() {
    let (_, mut m) = square(5);
    let ratio = 1.25f64;
    let values: Vec<f64> = (0..=20).map(|i| 0.01 * ratio.powi(i)).collect();
    let spec = PathSpec {
        control: Control::Strength { load: 0.0, values },
        reverse: true,
        extension: Vec::new(),
        refine: Default::default(),
    };
    let inter = Interaction::Adhesion {
        gamma0: 0.01,
        rho: RHO,
    };
    let ours = run(&mut m, Method::NonlinearCg, inter, &spec);
    let fire = run(&mut m, Method::Fire, inter, &spec);
    let (io, if_) = compare("strength", &ours, &fire, ratio - 1.0);
    assert!(io < if_, "iterations {io} (ours) vs {if_} (FIRE)");
    assert!(!jumps(&fire, Branch::Loading).is_empty());
}

#[test]
fn warm_start_from_its_own_solution_converges_at_once() {
    assert_eq!(
        "nonlinear-cg".parse::<Method>().unwrap(),
        Method::NonlinearCg
    );
    let (s, mut m) = square(6);
    let opts = SolverOptions {
        tol_force: TOL_FORCE,
        method: Method::NonlinearCg,
        ..SolverOptions::default()
    };
    for inter in [
        Interaction::Adhesion {
            gamma0: 0.2,
            rho: RHO,
        },
        Interaction::Repulsion {
            gamma_r: 0.2,
            rho: RHO,
        },
    ] {
        let p = 0.1 * s.p_fc_grid();
        let a = m.solve(inter, p, &opts, None).unwrap();
        assert!(a.stats.converged, "{inter:?}: {:?}", a.stats);
        let b = m.solve(inter, p, &opts, Some(&a)).unwrap();
        assert!(
            b.stats.converged && b.stats.iterations <= 1,
            "{:?}",
            b.stats
        );
        assert!((a.energy - b.energy).abs() < 1e-12);
    }
}

#[test]
fn far_beyond_pull_off_the_surfaces_separate_with_a_clear_error() {
    let (_, mut m) = square(5);
    let opts = SolverOptions {
        method: Method::NonlinearCg,
        ..SolverOptions::default()
    };
    let inter = Interaction::Adhesion {
        gamma0: 0.2,
        rho: RHO,
    };
    match m.solve(inter, -1.0, &opts, None) {
        Err(contact::ContactError::Detached { .. }) => {}
        other => panic!("expected detachment, got {other:?}"),
    }
}

/// Without a finite-range part the problem is the convex hard wall: the same state as the
/// Polonsky–Keer solver (an independent method in the pressure, stopping on the gap).
#[test]
fn agrees_with_polonsky_keer_on_the_hard_wall() {
    let (s, mut m) = square(6);
    let p = 0.1 * s.p_fc_grid();
    let solve = |m: &mut Model, method| {
        let opts = SolverOptions {
            tol_force: TOL_FORCE,
            method,
            ..SolverOptions::default()
        };
        m.solve(Interaction::HardWall, p, &opts, None).unwrap()
    };
    let ours = solve(&mut m, Method::NonlinearCg);
    let pk = solve(&mut m, Method::PolonskyKeer);
    assert!(ours.stats.converged && pk.stats.converged);
    assert_eq!(ours.contact_area, pk.contact_area);
    // gaps agree to the tolerances: violation 1e-10 (PK), residual 1e-10 over stiffness ≥ π
    let du = ours
        .gap
        .iter()
        .zip(pk.gap.iter())
        .fold(0.0f64, |d, (a, b)| d.max((a - b).abs()));
    assert!(du < 1e-8, "max gap difference {du:e}");
}

/// `Method::Auto` takes nonlinear CG for adhesion and repulsion where the cohesive zone ρ²E*/γ
/// spans at least `NCG_MIN_ZONE_SPACINGS` grid spacings, FIRE below (many lattice-trapped states:
/// which one a warm start reaches depends on the minimiser), Polonsky–Keer for the hard wall.
#[test]
fn auto_chooses_by_the_resolution_of_the_cohesive_zone() {
    let (s, mut m) = square(6);
    let dx = 1.0 / 64.0;
    let p = 0.1 * s.p_fc_grid();
    let opts = SolverOptions {
        tol_force: 1e-8,
        ..SolverOptions::default()
    };
    // γ just above and below the threshold: zone = ρ²/γ = the threshold ± 1 %
    let at = RHO * RHO / (contact::NCG_MIN_ZONE_SPACINGS * dx);
    let cases = [
        (Interaction::HardWall, "polonsky-keer"),
        (
            Interaction::Adhesion {
                gamma0: at / 1.01,
                rho: RHO,
            },
            "nonlinear-cg",
        ),
        (
            Interaction::Adhesion {
                gamma0: at * 1.01,
                rho: RHO,
            },
            "fire",
        ),
        (
            Interaction::Repulsion {
                gamma_r: at / 1.01,
                rho: RHO,
            },
            "nonlinear-cg",
        ),
        (
            Interaction::Repulsion {
                gamma_r: at * 1.01,
                rho: RHO,
            },
            "fire",
        ),
    ];
    for (inter, want) in cases {
        assert_eq!(m.resolves_cohesive_zone(inter), want != "fire", "{inter:?}");
        let sol = m.solve(inter, p, &opts, None).unwrap();
        assert_eq!(sol.stats.method, want, "{inter:?}");
        assert!(sol.stats.converged, "{inter:?}: {:?}", sol.stats);
    }
}

/// A cold start under adhesion runs without the branch safeguard (one range per step near the
/// wall), which bound every step of the approach under load: it must still reach FIRE's state
/// where the grid resolves the cohesive zone (128²: one spacing, where `Method::Auto` starts
/// taking nonlinear CG), at zero, small and large load (the adhesive bench's p̄ = 1.47 is
/// 0.23 p_fc); repulsion (safeguard kept) beside it. Agreement: the same contact nodes within
/// one, mean gap within 1e-7 h0 (both stop at force residual 1e-10; measured: ≤ 1.2e-11). On
/// 64² (half a spacing, FIRE's domain) the two reach different trapped states from a cold
/// start with the safeguard in all five cases (36–152 nodes apart); without it only adhesion
/// at 0.05 p_fc differed (16 nodes).
#[test]
fn cold_starts_reach_fires_state() {
    let (s, mut model) = square(7);
    let p_fc = s.p_fc_grid();
    let nodes = (s.grid.nx * s.grid.ny) as f64;
    let opts = |method| SolverOptions {
        tol_force: TOL_FORCE,
        method,
        ..SolverOptions::default()
    };
    let adhesion = Interaction::Adhesion {
        gamma0: 0.2,
        rho: RHO,
    };
    let repulsion = Interaction::Repulsion {
        gamma_r: 0.2,
        rho: RHO,
    };
    for (inter, frac) in [
        (adhesion, 0.0),
        (adhesion, 0.05),
        (adhesion, 0.3),
        (repulsion, 0.1),
        (repulsion, 0.3),
    ] {
        let p = frac * p_fc;
        let ours = model
            .solve(inter, p, &opts(Method::NonlinearCg), None)
            .unwrap();
        let fire = model.solve(inter, p, &opts(Method::Fire), None).unwrap();
        assert!(
            ours.stats.converged && fire.stats.converged,
            "{inter:?} {frac}"
        );
        let da = (ours.contact_area - fire.contact_area).abs() * nodes;
        let dg = (ours.mean_gap - fire.mean_gap).abs();
        assert!(
            da <= 1.0 && dg <= 1e-7,
            "{inter:?} at {frac} p_fc: area {} vs {} ({da} nodes), mean gap {} vs {}",
            ours.contact_area,
            fire.contact_area,
            ours.mean_gap,
            fire.mean_gap
        );
    }
}

/// The nested cold start (256²: from the solution on 128²) reaches the state of the plain cold
/// start: the same contact nodes and mean gap to the tolerance, at the loads of the adhesive
/// bench (zero, the coalescence region, near full contact).
#[test]
fn nested_cold_start_reaches_the_plain_cold_starts_state() {
    use contact::nonlinear_cg::{NESTED_MIN_NODES, NonlinearCg};
    let (s, mut model) = square(8);
    assert!(s.grid.nx * s.grid.ny >= NESTED_MIN_NODES);
    let nodes = (s.grid.nx * s.grid.ny) as f64;
    let opts = SolverOptions {
        tol_force: TOL_FORCE,
        ..SolverOptions::default()
    };
    let adhesion = Interaction::Adhesion {
        gamma0: 0.2,
        rho: RHO,
    };
    let plain = NonlinearCg {
        nested_min_nodes: usize::MAX,
        ..NonlinearCg::default()
    };
    for p in [0.0, 0.53, 1.47] {
        let a = model
            .solve_with(&NonlinearCg::default(), adhesion, p, &opts, None)
            .unwrap();
        let b = model.solve_with(&plain, adhesion, p, &opts, None).unwrap();
        assert!(a.stats.converged && b.stats.converged, "p̄ = {p}");
        let contact =
            |sol: &contact::Solution| -> Vec<bool> { sol.gap.iter().map(|&g| g == 0.0).collect() };
        let differ = contact(&a)
            .iter()
            .zip(contact(&b))
            .filter(|(x, y)| **x != *y)
            .count();
        // both stop at a force residual of 1e-10: the mean gaps agree to about that over the
        // contact stiffness (rounding and the stopping point, not the start)
        assert!(
            differ == 0 && (a.mean_gap - b.mean_gap).abs() <= 1e-9,
            "p̄ = {p}: {differ} contact nodes differ of {nodes}, mean gap {} vs {}",
            a.mean_gap,
            b.mean_gap
        );
    }
}
