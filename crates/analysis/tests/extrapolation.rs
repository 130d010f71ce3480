//! Extrapolation to zero grid spacing: exact on exact data, honest error bars on noisy data,
//! the subset spread catches a missing higher-order term, clean failures.

mod common;

use analysis::*;
use common::{Rng, monte_carlo};

#[test]
fn fixed_order_exact_and_noisy() {
    // a_p-like: v(h) = 0.40185 − 0.31 h, h = 2^-5 … 2^-9.
    let h: Vec<f64> = (5..=9).map(|n| 2f64.powi(-n)).collect();
    let v: Vec<f64> = h.iter().map(|x| 0.40185 - 0.31 * x).collect();
    let e = extrapolate_to_zero(&h, &v, None, Order::Fixed(1.0), ErrorScale::Auto).unwrap();
    assert!((e.v0 - 0.40185).abs() < 1e-14);
    assert!(e.v0_subset_spread.unwrap() < 1e-13);
    assert_eq!(e.subsets.len(), 5);

    // Noise 1e-5 on every value, σ known: the fit error is honest (coverage of v0 and c).
    let s = vec![1e-5; h.len()];
    monte_carlo("extrapolation, p = 1", &[0.40185, -0.31], 300, 11, |rng| {
        let vn: Vec<f64> = v
            .iter()
            .zip(&s)
            .map(|(a, b)| a + b * rng.normal())
            .collect();
        let e = extrapolate_to_zero(&h, &vn, Some(&s), Order::Fixed(1.0), ErrorScale::Absolute)
            .unwrap();
        assert!(e.v0_error >= e.v0_fit_error);
        e.fit
    });
}

#[test]
fn free_order() {
    let h: Vec<f64> = (3..=9).map(|n| 2f64.powi(-n)).collect();
    let v: Vec<f64> = h.iter().map(|x| 1.2 + 0.5 * x.powf(1.5)).collect();
    let e = extrapolate_to_zero(&h, &v, None, Order::Free, ErrorScale::Auto).unwrap();
    assert!(
        (e.v0 - 1.2).abs() < 1e-9 && (e.order - 1.5).abs() < 1e-6,
        "{e:?}"
    );
    let s = vec![2e-5; h.len()];
    monte_carlo("extrapolation, free p", &[1.2, 0.5, 1.5], 300, 12, |rng| {
        let vn: Vec<f64> = v
            .iter()
            .zip(&s)
            .map(|(a, b)| a + b * rng.normal())
            .collect();
        extrapolate_to_zero(&h, &vn, Some(&s), Order::Free, ErrorScale::Absolute)
            .unwrap()
            .fit
    });
}

#[test]
fn subset_spread_flags_a_missing_term() {
    // True v = v0 + c h + d h²; fitted with p = 1 only. The fit error (scaled by χ²) and the
    // leave-one-out spread must together cover the true v0.
    let h: Vec<f64> = (3..=7).map(|n| 2f64.powi(-n)).collect();
    let v: Vec<f64> = h.iter().map(|x| 0.67323 - 0.2 * x + 3.0 * x * x).collect();
    let e = extrapolate_to_zero(&h, &v, None, Order::Fixed(1.0), ErrorScale::Auto).unwrap();
    let spread = e.v0_subset_spread.unwrap();
    assert!(spread > 0.0);
    assert!(
        (e.v0 - 0.67323).abs() < 2.0 * e.v0_error,
        "v0 = {} ± {} (fit {}, spread {spread})",
        e.v0,
        e.v0_error,
        e.v0_fit_error
    );
    // The quadratic model is exact here.
    let e2 = extrapolate_to_zero(&h, &v, None, Order::Free, ErrorScale::Auto).unwrap();
    assert!(e2.v0_error < e.v0_error);
}

#[test]
fn two_points_is_richardson() {
    let h = [0.02, 0.01];
    let v = [1.0 + 0.3 * 0.02, 1.0 + 0.3 * 0.01 + 1e-6];
    let e = extrapolate_to_zero(&h, &v, None, Order::Fixed(1.0), ErrorScale::Auto).unwrap();
    let r = richardson_pair(h, v, 1.0, None).unwrap();
    assert!((e.v0 - r.v0).abs() < 1e-13);
    // No degree of freedom and no σ: the fit error is undetermined, not zero.
    assert!(e.v0_fit_error.is_nan() && e.v0_subset_spread.is_none());
    let s = [1e-6, 1e-6];
    let e = extrapolate_to_zero(&h, &v, Some(&s), Order::Fixed(1.0), ErrorScale::Absolute).unwrap();
    let r = richardson_pair(h, v, 1.0, Some(s)).unwrap();
    assert!((e.v0_fit_error - r.v0_error.unwrap()).abs() < 1e-15);
}

#[test]
fn richardson_triple_error_propagation() {
    // Monte Carlo of the propagated error of the triple formula.
    let h = [0.04, 0.02, 0.01];
    let f = |x: f64| 0.17826 + 0.4 * x.powf(1.3);
    let s = [2e-6; 3];
    let mut rng = Rng::new(13);
    let (mut est, mut sig) = (Vec::new(), Vec::new());
    for _ in 0..400 {
        let v = [
            f(h[0]) + s[0] * rng.normal(),
            f(h[1]) + s[1] * rng.normal(),
            f(h[2]) + s[2] * rng.normal(),
        ];
        let r = richardson_triple(h, v, Some(s)).unwrap();
        est.push(r.v0);
        sig.push(r.v0_error.unwrap());
    }
    let (mean, spread) = mean_std(&est).unwrap();
    let msig = sig.iter().sum::<f64>() / sig.len() as f64;
    eprintln!("triple: mean {mean}, spread {spread:.3e}, mean sigma {msig:.3e}");
    assert!((0.5..2.0).contains(&(msig / spread)));
    assert!((mean - 0.17826).abs() < 4.0 * spread / 20.0);
}

#[test]
fn degenerate_inputs() {
    let ok = [0.1, 0.05, 0.025];
    let v = [1.0, 1.1, 1.2];
    assert!(matches!(
        extrapolate_to_zero(&[0.1], &[1.0], None, Order::Fixed(1.0), ErrorScale::Auto),
        Err(FitError::TooFewPoints { .. })
    ));
    assert!(matches!(
        extrapolate_to_zero(
            &[0.1, 0.05],
            &[1.0, 1.1],
            None,
            Order::Free,
            ErrorScale::Auto
        ),
        Err(FitError::TooFewPoints { .. })
    ));
    assert!(matches!(
        extrapolate_to_zero(
            &[0.1, 0.0, 0.02],
            &v,
            None,
            Order::Fixed(1.0),
            ErrorScale::Auto
        ),
        Err(FitError::OutOfRange {
            what: "h",
            index: 1,
            ..
        })
    ));
    assert!(matches!(
        extrapolate_to_zero(
            &[0.1, 0.05, 0.1],
            &v,
            None,
            Order::Fixed(1.0),
            ErrorScale::Auto
        ),
        Err(FitError::OutOfRange {
            what: "h",
            index: 2,
            ..
        })
    ));
    assert!(matches!(
        extrapolate_to_zero(
            &ok,
            &[1.0, f64::NAN, 1.0],
            None,
            Order::Fixed(1.0),
            ErrorScale::Auto
        ),
        Err(FitError::NonFinite { .. })
    ));
    assert!(matches!(
        extrapolate_to_zero(&ok, &v, None, Order::Fixed(-1.0), ErrorScale::Auto),
        Err(FitError::InvalidArgument {
            name: "order p",
            ..
        })
    ));
    assert!(richardson_triple([0.1, 0.05, 0.025], [1.0, 1.5, 1.0], None).is_err());
}
