//! Every fit recovers known parameters from noisy synthetic data with honest error bars
//! (Monte-Carlo checks in `common::monte_carlo`), and fails cleanly on degenerate input.

mod common;

use analysis::*;
use common::{Rng, monte_carlo};

const M: usize = 300;

/// Noise on the loaded samples only (true value > 0), as in a hard-wall contact, where the
/// pressure outside the contact is exactly zero.
fn noisy_loaded(rng: &mut Rng, clean: &[f64], sigma: &[f64]) -> Vec<f64> {
    clean
        .iter()
        .zip(sigma)
        .map(|(&c, s)| if c > 0.0 { c + s * rng.normal() } else { 0.0 })
        .collect()
}

fn noisy(rng: &mut Rng, clean: &[f64], sigma: &[f64]) -> Vec<f64> {
    clean
        .iter()
        .zip(sigma)
        .map(|(c, s)| c + s * rng.normal())
        .collect()
}

#[test]
fn straight_line_weighted_and_unweighted() {
    let x: Vec<f64> = (0..15).map(|i| -1.0 + i as f64 * 0.2).collect();
    let clean: Vec<f64> = x.iter().map(|t| 0.7 - 1.3 * t).collect();
    // Heteroscedastic, known σ: Absolute errors.
    let s: Vec<f64> = (0..15).map(|i| 0.01 + 0.004 * i as f64).collect();
    monte_carlo("line, weighted", &[0.7, -1.3], M, 1, |rng| {
        linear_fit(&x, &noisy(rng, &clean, &s), Some(&s), ErrorScale::Absolute).unwrap()
    });
    // Unknown σ: errors from the residual scatter.
    let s = vec![0.05; 15];
    monte_carlo("line, reduced chi2", &[0.7, -1.3], M, 2, |rng| {
        linear_fit(&x, &noisy(rng, &clean, &s), None, ErrorScale::Auto).unwrap()
    });
}

#[test]
fn power_law_in_log_log() {
    let x: Vec<f64> = (0..12).map(|i| 0.002 * 1.5f64.powi(i)).collect();
    let clean: Vec<f64> = x.iter().map(|t| 2.5 * t.powf(1.2)).collect();
    let s: Vec<f64> = clean.iter().map(|c| 0.02 * c).collect();
    monte_carlo("power law", &[2.5, 1.2], M, 3, |rng| {
        power_law_fit(&x, &noisy(rng, &clean, &s), Some(&s), ErrorScale::Absolute).unwrap()
    });
}

#[test]
fn generic_nonlinear() {
    let x: Vec<f64> = (0..25).map(|i| i as f64 * 0.15).collect();
    let truth = [3.0, 1.5, 0.1];
    let clean: Vec<f64> = x
        .iter()
        .map(|t| truth[0] * (-truth[1] * t).exp() + truth[2])
        .collect();
    let s = vec![0.03; x.len()];
    for (scale, sig, seed) in [
        (ErrorScale::Absolute, Some(&s[..]), 4),
        (ErrorScale::ReducedChi2, None, 5),
    ] {
        monte_carlo("exp decay", &truth, M, seed, |rng| {
            let opts = NonlinearOptions {
                scale,
                ..Default::default()
            };
            nonlinear_fit(
                |t, p| p[0] * (-p[1] * t).exp() + p[2],
                &x,
                &noisy(rng, &clean, &s),
                sig,
                &[1.0, 1.0, 0.0],
                &opts,
            )
            .unwrap()
        });
    }
}

#[test]
fn contact_line_sqrt_onset_sub_grid() {
    // Grid spacing h = 1/128, contact line at r_c = 0.3137 (between nodes 40 and 41).
    let h = 1.0 / 128.0;
    let (a, rc) = (2.0, 0.3137);
    let r: Vec<f64> = (36..58).map(|i| i as f64 * h).collect();
    let clean: Vec<f64> = r.iter().map(|&t| sqrt_onset(t, a, rc)).collect();
    let s = vec![0.01; r.len()];
    let stats = monte_carlo("sqrt onset", &[a, rc], M, 6, |rng| {
        fit_sqrt_onset(
            &r,
            &noisy_loaded(rng, &clean, &s),
            Some(&s),
            ErrorScale::Absolute,
        )
        .unwrap()
    });
    // Sub-grid: r_c to a small fraction of the grid spacing.
    assert!(stats[1].1 < 0.1 * h, "r_c spread {} vs h {h}", stats[1].1);
    // Noise-free data: exact to round-off.
    let f = fit_sqrt_onset(&r, &clean, None, ErrorScale::Auto).unwrap();
    assert!(
        (f.params[1] - rc).abs() < 1e-9 && (f.params[0] - a).abs() < 1e-8,
        "{f:?}"
    );
    // Only the contact side (all F > 0).
    let rr: Vec<f64> = r.iter().copied().filter(|&t| t > rc).collect();
    let ff: Vec<f64> = rr.iter().map(|&t| sqrt_onset(t, a, rc)).collect();
    let f = fit_sqrt_onset(&rr, &ff, None, ErrorScale::Auto).unwrap();
    assert!((f.params[1] - rc).abs() < 1e-9);
}

#[test]
fn hertz_profile_free_and_fixed_centre() {
    let h = 1.0 / 128.0;
    let (p0, a, x0) = (1.5, 0.1234, 0.0171);
    let x: Vec<f64> = (-26..=26).map(|i| i as f64 * h).collect();
    let clean: Vec<f64> = x.iter().map(|&t| hertz_profile(t, p0, a, x0)).collect();
    let s = vec![0.01; x.len()];
    monte_carlo("hertz", &[p0, a, x0], M, 7, |rng| {
        fit_hertz(
            &x,
            &noisy_loaded(rng, &clean, &s),
            Some(&s),
            None,
            ErrorScale::Absolute,
        )
        .unwrap()
    });
    let clean0: Vec<f64> = x.iter().map(|&t| hertz_profile(t, p0, a, 0.0)).collect();
    monte_carlo("hertz, fixed centre", &[p0, a, 0.0], M, 8, |rng| {
        fit_hertz(
            &x,
            &noisy_loaded(rng, &clean0, &s),
            Some(&s),
            Some(0.0),
            ErrorScale::Absolute,
        )
        .unwrap()
    });
    let f = fit_hertz(&x, &clean, None, None, ErrorScale::Auto).unwrap();
    for (v, t) in f.params.iter().zip([p0, a, x0]) {
        assert!((v - t).abs() < 1e-9, "{f:?}");
    }
}

#[test]
fn saddle_gap_with_free_critical_load() {
    let (a, lc, zeta) = (3.0, 0.5, 1.2);
    let load: Vec<f64> = (0..12)
        .map(|i| lc * (1.0 - 1e-3 * 10f64.powf(2.0 * i as f64 / 11.0)))
        .collect();
    let clean: Vec<f64> = load.iter().map(|&l| saddle_gap(l, a, lc, zeta)).collect();
    let s: Vec<f64> = clean.iter().map(|g| 0.01 * g).collect();
    monte_carlo("saddle gap", &[a, lc, zeta], M, 9, |rng| {
        fit_saddle_gap(
            &load,
            &noisy(rng, &clean, &s),
            Some(&s),
            ErrorScale::Absolute,
        )
        .unwrap()
    });
    let f = fit_saddle_gap(&load, &clean, None, ErrorScale::Auto).unwrap();
    assert!(
        (f.params[1] - lc).abs() < 1e-10 && (f.params[2] - zeta).abs() < 1e-7,
        "{f:?}"
    );
    assert_eq!(f.status.pegged, 0);
}

#[test]
fn power_law_with_offset() {
    let (y0, a, beta) = (0.4, -0.3, 0.8);
    let x: Vec<f64> = (1..=20).map(|i| 0.05 * i as f64).collect();
    let clean: Vec<f64> = x.iter().map(|t| y0 + a * t.powf(beta)).collect();
    let s = vec![0.002; x.len()];
    monte_carlo("power law + offset", &[y0, a, beta], M, 10, |rng| {
        fit_power_law_offset(&x, &noisy(rng, &clean, &s), Some(&s), ErrorScale::Absolute).unwrap()
    });
}

#[test]
fn degenerate_model_inputs_fail_cleanly() {
    let x = [0.1, 0.2, 0.3, 0.4];
    let zero = [0.0; 4];
    assert!(matches!(
        fit_sqrt_onset(&x, &[0.0, 0.0, 0.0, 1.0], None, ErrorScale::Auto),
        Err(FitError::TooFewPoints { got: 1, .. })
    ));
    assert!(matches!(
        fit_sqrt_onset(&x, &[1.0, 0.9, 0.8, 0.7], None, ErrorScale::Auto),
        Err(FitError::NoInitialGuess(_))
    ));
    assert!(matches!(
        fit_hertz(&x, &zero, None, None, ErrorScale::Auto),
        Err(FitError::TooFewPoints { .. })
    ));
    assert!(matches!(
        fit_hertz(&x, &[0.1, f64::NAN, 0.2, 0.1], None, None, ErrorScale::Auto),
        Err(FitError::NonFinite {
            what: "y",
            index: 1,
            ..
        })
    ));
    assert!(matches!(
        fit_hertz(
            &x,
            &[0.1, 0.2, 0.2, 0.1],
            None,
            Some(f64::INFINITY),
            ErrorScale::Auto
        ),
        Err(FitError::InvalidArgument { name: "x0", .. })
    ));
    assert!(matches!(
        fit_saddle_gap(&x, &[1.0, 0.5, 0.0, 0.0], None, ErrorScale::Auto),
        Err(FitError::TooFewPoints { got: 2, .. })
    ));
    assert!(matches!(
        fit_saddle_gap(&[0.3; 4], &[1.0, 0.9, 0.8, 0.7], None, ErrorScale::Auto),
        Err(FitError::NoInitialGuess(_))
    ));
    assert!(matches!(
        fit_power_law_offset(&[0.0, 1.0, 2.0, 3.0], &x, None, ErrorScale::Auto),
        Err(FitError::OutOfRange {
            what: "x",
            index: 0,
            ..
        })
    ));
    assert!(matches!(
        fit_power_law_offset(&[1.0, 2.0], &[1.0, 2.0], None, ErrorScale::Auto),
        Err(FitError::TooFewPoints { .. })
    ));
    // Exactly determined but reduced-chi2 errors requested: no degree of freedom.
    let e = fit_power_law_offset(
        &[1.0, 2.0, 3.0],
        &[1.0, 2.5, 4.7],
        None,
        ErrorScale::ReducedChi2,
    );
    assert!(matches!(e, Err(FitError::TooFewPoints { .. })), "{e:?}");
}
