//! The contact solver at the extremes (issue 8): the smallest grid, loads from 1e-8 p_fc to
//! p_fc(1 ± 1e-9), interaction ranges below the grid spacing, γ0 = 0 and γ0 large enough for full
//! contact at zero load, and non-finite input. Each case either passes a physical check or
//! fails with a specific error; none may hang, panic or return a silent wrong number.

use contact::{
    ContactError, Interaction, Lattice, Method, Model, Solution, SolverOptions, Surface,
};

fn model(l: Lattice, n: u32) -> (Surface, Model) {
    let s = Surface::new(l, n).unwrap();
    let m = Model::new(&s).unwrap();
    (s, m)
}

/// The invariants every returned state must satisfy, converged or not: finite fields, gap ≥ 0,
/// the imposed mean pressure, and a converged flag consistent with the reported residuals.
fn sane(sol: &Solution, load: f64, opts: &SolverOptions) {
    assert!(sol.gap.iter().all(|g| g.is_finite() && *g >= 0.0));
    assert!(sol.pressure.iter().all(|p| p.is_finite()));
    assert!(sol.displacement.iter().all(|u| u.is_finite()));
    assert!(sol.energy.is_finite());
    let mean = sol.pressure.mean().unwrap();
    assert!(
        (mean - load).abs() <= 1e-9 * load.abs().max(1e-3),
        "mean pressure {mean} vs imposed {load}"
    );
    if sol.stats.converged {
        assert!(sol.stats.reason.is_none());
        assert!(sol.stats.max_violation <= opts.tol_gap, "{:?}", sol.stats);
    } else {
        assert!(sol.stats.reason.is_some(), "not converged without a reason");
    }
}

#[test]
fn the_smallest_grid_solves_every_model_and_interaction() {
    let opts = SolverOptions::default();
    for l in Lattice::ALL {
        let (s, mut m) = model(l, 3);
        let p = 0.3 * s.p_fc_grid();
        for inter in [
            Interaction::HardWall,
            Interaction::Adhesion {
                gamma0: 0.2,
                rho: 0.04,
            },
            Interaction::Repulsion {
                gamma_r: 0.2,
                rho: 0.04,
            },
        ] {
            let sol = m.solve(inter, p, &opts, None).unwrap();
            sane(&sol, p, &opts);
            assert!(sol.stats.converged, "{l:?} {inter:?}: {:?}", sol.stats);
            assert!(sol.contact_area > 0.0 && sol.contact_area < 1.0);
        }
    }
}

/// At 1e-8 p_fc the whole load sits on the node at the peak: the gap elsewhere is the rigid
/// surface's depth below the peak plus the elastic response, all finite; the solve converges.
#[test]
fn a_load_of_1e_minus_8_p_fc_converges_on_the_peak() {
    let opts = SolverOptions::default();
    for l in Lattice::ALL {
        let (s, mut m) = model(l, 6);
        let p = 1e-8 * s.p_fc_grid();
        let sol = m
            .solve(Interaction::HardWall, p, &opts, None)
            .unwrap_or_else(|e| panic!("{l:?}: {e}"));
        sane(&sol, p, &opts);
        assert!(sol.stats.converged, "{l:?}: {:?}", sol.stats);
        // contact only on the highest nodes (the model's symmetric maxima; the elastic
        // indentation under 1e-8 p_fc is ~1e-6 h0)
        let hmax = s.heights.iter().cloned().fold(f64::MIN, f64::max);
        for (g, h) in sol.gap.iter().zip(&s.heights) {
            assert!(
                *g > 0.0 || *h >= hmax - 1e-4,
                "{l:?}: contact at h = {h} (max {hmax})"
            );
        }
        let imax = s.heights.iter().position(|&h| h == hmax).unwrap();
        assert_eq!(
            sol.gap.as_slice().unwrap()[imax],
            0.0,
            "{l:?}: the peak is in contact"
        );
    }
}

/// p_fc(1 ± 1e-9): above, every node is in contact with non-negative pressure; below, only the
/// deepest troughs may open, by a gap of order 1e-9 h0 (at the tolerance of 1e-10 h0 whether they
/// do is decided by rounding): the solver must converge either way.
#[test]
fn loads_a_billionth_around_full_contact_converge() {
    let opts = SolverOptions::default();
    for l in Lattice::ALL {
        let (s, mut m) = model(l, 5);
        let pfc = s.p_fc_grid();
        let n = s.grid.len() as f64;
        let above = m
            .solve(Interaction::HardWall, pfc * (1.0 + 1e-9), &opts, None)
            .unwrap();
        sane(&above, pfc * (1.0 + 1e-9), &opts);
        assert!(above.stats.converged, "{l:?}: {:?}", above.stats);
        assert_eq!(above.contact_area, 1.0, "{l:?}");
        assert!(above.pressure.iter().all(|&p| p >= 0.0));
        let below = m
            .solve(Interaction::HardWall, pfc * (1.0 - 1e-9), &opts, None)
            .unwrap();
        sane(&below, pfc * (1.0 - 1e-9), &opts);
        assert!(below.stats.converged, "{l:?}: {:?}", below.stats);
        // open only at the deepest troughs (the model's symmetric minima)
        let hmin = s.heights.iter().cloned().fold(f64::MAX, f64::min);
        for (g, h) in below.gap.iter().zip(&s.heights) {
            assert!(
                *g == 0.0 || *h <= hmin + 1e-4,
                "{l:?}: open at h = {h} (min {hmin})"
            );
        }
        assert!(
            below.contact_area >= 1.0 - 16.0 / n,
            "{l:?}: {}",
            below.contact_area
        );
        let gmax = below.gap.iter().cloned().fold(0.0, f64::max);
        assert!(
            gmax < 1e-6,
            "{l:?}: a gap of {gmax} h0 a billionth below p_fc"
        );
    }
}

/// ρ a quarter of the grid spacing: the interaction is not resolved (the CLI and the sweep stage
/// warn), but the solve must stay finite and either converge or say why.
#[test]
fn a_range_below_the_grid_spacing_stays_finite() {
    let (s, mut m) = model(Lattice::Square, 5);
    let dx = s.grid.lx / s.grid.nx as f64;
    let opts = SolverOptions::default();
    for inter in [
        Interaction::Adhesion {
            gamma0: 0.2,
            rho: 0.25 * dx,
        },
        Interaction::Repulsion {
            gamma_r: 0.2,
            rho: 0.25 * dx,
        },
    ] {
        let p = 0.3 * s.p_fc_grid();
        let sol = m.solve(inter, p, &opts, None).unwrap();
        sane(&sol, p, &opts);
        assert!(sol.contact_area > 0.0 && sol.contact_area <= 1.0);
    }
}

/// γ0 = 0 is the hard wall: FIRE on `Adhesion { γ0: 0 }` gives Polonsky–Keer's hard-wall state.
#[test]
fn zero_adhesion_is_the_hard_wall() {
    let (s, mut m) = model(Lattice::Triangular, 5);
    let p = 0.4 * s.p_fc_grid();
    let opts = SolverOptions::default();
    let hw = m.solve(Interaction::HardWall, p, &opts, None).unwrap();
    let fire = m
        .solve(
            Interaction::Adhesion {
                gamma0: 0.0,
                rho: 0.04,
            },
            p,
            &SolverOptions {
                method: Method::Fire,
                ..opts.clone()
            },
            None,
        )
        .unwrap();
    assert!(hw.stats.converged && fire.stats.converged);
    assert_eq!(hw.contact_area, fire.contact_area);
    let dg = hw
        .gap
        .iter()
        .zip(&fire.gap)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(dg < 1e-6, "gaps differ by {dg:e} h0");
}

/// An adhesion strong enough to hold full contact at zero load: once closed (here: a hard-wall
/// state above p_fc as the warm start), the troughs stay shut while their tensile full-contact
/// stress π(h − h̄) ≥ −2π stays below the adhesive stress γ0/ρ = 12.5. (From a cold start the
/// contact line on this coarse grid is trapped by the lattice: ρ²E*/γ0 is 0.1 spacings.)
/// Checks: a = 1, mean pressure 0, and the exact full-contact pressure field π(h − h̄).
#[test]
fn strong_adhesion_keeps_full_contact_at_zero_load() {
    let (s, mut m) = model(Lattice::Square, 5);
    let opts = SolverOptions::default();
    let closed = m
        .solve(Interaction::HardWall, 1.05 * s.p_fc_grid(), &opts, None)
        .unwrap();
    assert_eq!(closed.contact_area, 1.0);
    let sol = m
        .solve(
            Interaction::Adhesion {
                gamma0: 0.5,
                rho: 0.04,
            },
            0.0,
            &opts,
            Some(&closed),
        )
        .unwrap();
    sane(&sol, 0.0, &opts);
    assert!(sol.stats.converged, "{:?}", sol.stats);
    assert_eq!(sol.contact_area, 1.0);
    // full contact: u = h + const, so σ = (q/2) h̃ = π (h − h̄) for h = cos 2πx + cos 2πy
    let hbar = s.heights.mean().unwrap();
    for (p, h) in sol.pressure.iter().zip(&s.heights) {
        assert!(
            (p - std::f64::consts::PI * (h - hbar)).abs() < 1e-6,
            "{p} vs {h}"
        );
    }
}

#[test]
fn non_finite_and_negative_parameters_are_rejected() {
    let (_, mut m) = model(Lattice::Hexagonal, 4);
    let opts = SolverOptions::default();
    let mut err = |inter: Interaction, p: f64| -> String {
        match m.solve(inter, p, &opts, None) {
            Err(e @ ContactError::Parameter { .. }) => e.to_string(),
            other => panic!("{inter:?} at {p}: expected a parameter error, got {other:?}"),
        }
    };
    for (inter, key) in [
        (
            Interaction::Adhesion {
                gamma0: 0.2,
                rho: f64::NAN,
            },
            "rho = NaN",
        ),
        (
            Interaction::Adhesion {
                gamma0: f64::INFINITY,
                rho: 0.04,
            },
            "gamma0 = inf",
        ),
        (
            Interaction::Repulsion {
                gamma_r: -1e-3,
                rho: 0.04,
            },
            "gamma_r = -0.001",
        ),
        (
            Interaction::Repulsion {
                gamma_r: 0.2,
                rho: -0.04,
            },
            "rho = -0.04",
        ),
    ] {
        let e = err(inter, 0.1);
        assert!(e.contains(key), "{e}");
    }
    for p in [f64::NAN, f64::NEG_INFINITY] {
        let e = err(Interaction::HardWall, p);
        assert!(e.contains("pressure"), "{e}");
    }
    for bad in [f64::NAN, 0.0, -1.0] {
        let o = SolverOptions {
            tol_force: bad,
            ..SolverOptions::default()
        };
        let e = m
            .solve(Interaction::HardWall, 0.1, &o, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("tol_force"), "{e}");
    }
}
