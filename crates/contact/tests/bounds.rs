//! Physical bounds on the solver's parameters and the meaning of `converged` (issue 18, item 6):
//! tolerances above their physical bounds and loads outside the range doubles can represent are
//! refused with the range; a state that violates the constraints is never reported converged,
//! whatever the minimiser claims.

use contact::{
    ContactError, Interaction, Lattice, Minimizer, Model, SolveStats, SolverOptions, State,
    Surface, TOL_FORCE_MAX, TOL_GAP_MAX, pressure_max,
};

fn model(l: Lattice, n: u32) -> (Surface, Model) {
    let s = Surface::new(l, n).unwrap();
    let m = Model::new(&s).unwrap();
    (s, m)
}

/// A minimiser that does nothing and claims convergence after 0 iterations.
struct Claims(&'static str);

impl Minimizer for Claims {
    fn name(&self) -> &'static str {
        self.0
    }
    fn relax(
        &self,
        _: &mut Model,
        _: Interaction,
        _: f64,
        _: &SolverOptions,
        _: &mut State,
    ) -> Result<SolveStats, ContactError> {
        Ok(SolveStats {
            method: self.0,
            iterations: 0,
            converged: true,
            reason: None,
            max_violation: 0.0,
            force_residual: 0.0,
            wall_s: 0.0,
            trace: Vec::new(),
        })
    }
}

#[test]
fn never_converged_after_zero_iterations_on_a_violating_state() {
    let (s, mut m) = model(Lattice::Square, 4);
    let p = 0.3 * s.p_fc_grid();
    let opts = SolverOptions::default();
    // the cold start is a flat body on the highest node under a uniform pressure: every other node
    // is open yet pushed, violating the constraints by up to the height range (4 h0) and the
    // force balance by p̄
    for (name, measure) in [
        ("polonsky-keer", "constraint violation"),
        ("fire", "force residual"),
    ] {
        let sol = m
            .solve_with(&Claims(name), Interaction::HardWall, p, &opts, None)
            .unwrap();
        assert!(!sol.stats.converged, "{name}: {:?}", sol.stats);
        let why = sol.stats.reason.as_ref().unwrap().to_string();
        assert!(
            why.contains(measure) && why.contains("not a solution"),
            "{why}"
        );
    }
}

#[test]
fn refuses_tolerance_above_physical_bound() {
    let (s, mut m) = model(Lattice::Square, 4);
    let p = 0.3 * s.p_fc_grid();
    for (opts, name) in [
        (
            SolverOptions {
                tol_gap: 2.0,
                ..Default::default()
            },
            "tol_gap",
        ),
        (
            SolverOptions {
                tol_force: 2.0 * TOL_FORCE_MAX,
                ..Default::default()
            },
            "tol_force",
        ),
        (
            SolverOptions {
                tol_gap: f64::NAN,
                ..Default::default()
            },
            "tol_gap",
        ),
    ] {
        let e = m
            .solve(Interaction::HardWall, p, &opts, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains(name) && e.contains("≤ 1e-3"), "{e}");
    }
    // at the bound the solve runs and meets it
    let opts = SolverOptions {
        tol_gap: TOL_GAP_MAX,
        ..Default::default()
    };
    let sol = m.solve(Interaction::HardWall, p, &opts, None).unwrap();
    assert!(sol.stats.converged && sol.stats.iterations > 0);
    assert!(sol.stats.max_violation <= TOL_GAP_MAX);
}

#[test]
fn refuses_unrepresentable_pressure() {
    let (s, mut m) = model(Lattice::Square, 4);
    let opts = SolverOptions::default();
    let max = pressure_max(opts.tol_gap, 1.0);
    // π 1e-10 / 2.22e-16 on the unit cell
    assert!((max / 1.415e6 - 1.0).abs() < 1e-3, "{max}");
    for p in [1e300, 2.0 * max] {
        let e = m.solve(Interaction::HardWall, p, &opts, None).unwrap_err();
        assert!(matches!(e, ContactError::Pressure { .. }), "{e}");
        assert!(e.to_string().contains("|p̄| ≤ 1.415e6"), "{e}");
    }
    let e = m
        .solve(Interaction::HardWall, 1e-300 * s.p_fc_grid(), &opts, None)
        .unwrap_err();
    assert!(e.to_string().contains("p̄ ≥ 1e-60"), "{e}");
    // adhesion may pull: tiny and zero loads stay allowed, huge ones do not
    let adh = Interaction::Adhesion {
        gamma0: 0.2,
        rho: 0.04,
    };
    let e = m.solve(adh, -1e300, &opts, None).unwrap_err();
    assert!(matches!(e, ContactError::Pressure { .. }), "{e}");
    assert!(m.solve(adh, 1e-300, &opts, None).is_ok());
}

/// The upper bound is where rounding of the pressure alone reaches the tolerance: just inside it
/// (for a looser tolerance, so that the load is 1e9 p_fc) the solve still converges, to full
/// contact. The measured violation floor is 0.16 ε p̄, half the bound's 0.32 ε p̄.
#[test]
fn loads_just_inside_the_upper_bound_converge() {
    let (_, mut m) = model(Lattice::Square, 4);
    let opts = SolverOptions {
        tol_gap: 1e-6,
        ..Default::default()
    };
    let p = 0.9 * pressure_max(opts.tol_gap, 1.0);
    let sol = m.solve(Interaction::HardWall, p, &opts, None).unwrap();
    assert!(sol.stats.converged, "{:?}", sol.stats);
    assert_eq!(sol.contact_area, 1.0);
    // and at the lower bound the load rests on the highest node alone
    let sol = m
        .solve(
            Interaction::HardWall,
            2.0 * contact::PRESSURE_MIN,
            &opts,
            None,
        )
        .unwrap();
    assert!(sol.stats.converged, "{:?}", sol.stats);
    assert_eq!(sol.contact_area, 1.0 / 256.0);
}
