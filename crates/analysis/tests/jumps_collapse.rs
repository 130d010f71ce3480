//! Jump detection and scaling collapse.

mod common;

use analysis::*;
use common::Rng;

fn grid(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
        .collect()
}

#[test]
fn finds_a_synthetic_jump() {
    // Contact area vs load with a coalescence jump between points 30 and 31.
    let x = grid(0.0, 1.0, 60);
    let y: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, &t)| 0.1 + 0.3 * t + if i > 30 { 0.08 } else { 0.0 })
        .collect();
    let j = detect_jumps(&x, &y, &JumpOptions::default()).unwrap();
    assert_eq!(j.len(), 1, "{j:?}");
    assert_eq!(j[0].index, 30);
    assert!((j[0].size - (0.08 + 0.3 / 59.0)).abs() < 1e-12);
    // Downward jump on an unloading branch, uneven steps, two jumps in adjacent steps.
    let mut rng = Rng::new(21);
    let mut x = vec![0.0];
    for _ in 0..80 {
        let last = *x.last().unwrap();
        x.push(last + 0.005 + 0.02 * rng.uniform());
    }
    let y: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            let mut v = (1.0 + t).ln();
            if i > 40 {
                v -= 0.2;
            }
            if i > 41 {
                v -= 0.1;
            }
            v
        })
        .collect();
    let j = detect_jumps(&x, &y, &JumpOptions::default()).unwrap();
    let idx: Vec<usize> = j.iter().map(|j| j.index).collect();
    assert_eq!(idx, vec![40, 41], "{j:?}");
    assert!(j[0].size < 0.0);
}

#[test]
fn ignores_smooth_curves() {
    let opts = JumpOptions::default();
    // √x from 0, uniform and with a tiny first step.
    let x = grid(0.0, 1.0, 50);
    let y: Vec<f64> = x.iter().map(|t| t.sqrt()).collect();
    assert!(detect_jumps(&x, &y, &opts).unwrap().is_empty());
    let mut x2 = vec![0.0, 1e-6, 2e-6];
    x2.extend(grid(1e-3, 1.0, 40));
    let y2: Vec<f64> = x2.iter().map(|t| t.sqrt()).collect();
    assert!(detect_jumps(&x2, &y2, &opts).unwrap().is_empty());
    // tanh with a resolved width: steps of w and w/2.
    for dx_over_w in [1.0, 0.5, 0.1] {
        let w = 0.01;
        let x: Vec<f64> = (-40..=40)
            .map(|i| i as f64 * dx_over_w * w + 0.3 * w)
            .collect();
        let y: Vec<f64> = x.iter().map(|t| (t / w).tanh()).collect();
        let j = detect_jumps(&x, &y, &opts).unwrap();
        assert!(j.is_empty(), "dx/w = {dx_over_w}: {j:?}");
    }
    // Steep exponential and a parabola with very uneven steps.
    let x = grid(0.0, 5.0, 40);
    let y: Vec<f64> = x.iter().map(|t| (2.0 * t).exp()).collect();
    assert!(detect_jumps(&x, &y, &opts).unwrap().is_empty());
    let x = vec![0.0, 0.001, 0.002, 0.1, 0.101, 0.102, 0.5, 0.501, 1.0];
    let y: Vec<f64> = x.iter().map(|t| t * t - t).collect();
    assert!(detect_jumps(&x, &y, &opts).unwrap().is_empty());
    // Flat with round-off noise.
    let x = grid(0.0, 1.0, 30);
    let y: Vec<f64> = (0..30).map(|i| 1.0 + 1e-17 * (i % 3) as f64).collect();
    assert!(detect_jumps(&x, &y, &opts).unwrap().is_empty());
    // An unresolved tanh (Δx = 5w) is a jump: one step if the transition falls inside a step,
    // two adjacent steps if a sample sits on its flank.
    let w = 0.01;
    let x: Vec<f64> = (-20..=20).map(|i| i as f64 * 5.0 * w + 2.5 * w).collect();
    let y: Vec<f64> = x.iter().map(|t| (t / w).tanh()).collect();
    let j = detect_jumps(&x, &y, &opts).unwrap();
    assert_eq!(j.len(), 1, "{j:?}");
    assert_eq!(j[0].index, 19);
    let x: Vec<f64> = (-20..=20).map(|i| i as f64 * 5.0 * w + 0.5 * w).collect();
    let y: Vec<f64> = x.iter().map(|t| (t / w).tanh()).collect();
    let idx: Vec<usize> = detect_jumps(&x, &y, &opts)
        .unwrap()
        .iter()
        .map(|j| j.index)
        .collect();
    assert_eq!(idx, vec![19, 20]);
}

#[test]
fn tiny_and_bad_paths() {
    let opts = JumpOptions::default();
    assert!(detect_jumps(&[], &[], &opts).unwrap().is_empty());
    assert!(detect_jumps(&[0.0], &[1.0], &opts).unwrap().is_empty());
    assert!(
        detect_jumps(&[0.0, 1.0], &[0.0, 100.0], &opts)
            .unwrap()
            .is_empty()
    );
    let j = detect_jumps(&[0.0, 1.0, 2.0], &[0.0, 0.0, 10.0], &opts).unwrap();
    assert_eq!(j.len(), 1);
    assert_eq!(j[0].index, 1);
    assert!(
        detect_jumps(&[0.0, 1.0, 2.0], &[0.0, 1.0, 2.0], &opts)
            .unwrap()
            .is_empty()
    );
    // Repeated x (a vertical step at fixed load) and constant y.
    assert_eq!(
        detect_jumps(
            &[0.0, 0.1, 0.2, 0.2, 0.3, 0.4],
            &[0.0, 0.01, 0.02, 0.5, 0.51, 0.52],
            &opts
        )
        .unwrap()
        .len(),
        1
    );
    assert!(
        detect_jumps(&[0.0, 1.0, 2.0], &[1.0, 1.0, 1.0], &opts)
            .unwrap()
            .is_empty()
    );
    assert!(matches!(
        detect_jumps(&[0.0, 1.0], &[0.0], &opts),
        Err(FitError::LengthMismatch { .. })
    ));
    assert!(detect_jumps(&[0.0, f64::NAN, 1.0], &[0.0, 1.0, 2.0], &opts).is_err());
    let bad = JumpOptions { ratio: 0.5, ..opts };
    assert!(matches!(
        detect_jumps(&[0.0, 1.0, 2.0], &[0.0, 1.0, 2.0], &bad),
        Err(FitError::InvalidArgument { name: "ratio", .. })
    ));
}

fn master(x: f64) -> f64 {
    // A master curve with a scale (a pure power law would make the exponents degenerate).
    (1.0 + 0.5 * x) * (-x * x).exp() + 0.2
}

const LS: [f64; 4] = [-0.002, -0.005, -0.01, -0.02];

fn family(a: f64, b: f64, aligned: bool, rng: &mut Rng) -> Vec<Curve> {
    LS.iter()
        .enumerate()
        .map(|(k, &l)| {
            let s = l.abs().powf(a);
            let xs: Vec<f64> = if aligned {
                // The same rescaled abscissae X for every curve.
                grid(-2.5, 2.5, 41).iter().map(|x| x * s).collect()
            } else {
                // Each curve on its own grid, offset, over a range that differs per curve.
                let (lo, hi) = (-2.5 + 0.3 * k as f64, 2.0 + 0.2 * k as f64);
                let off = rng.uniform() * 0.05;
                grid(lo + off, hi + off, 60).iter().map(|x| x * s).collect()
            };
            let ys = xs.iter().map(|x| l.abs().powf(b) * master(x / s)).collect();
            Curve { l, x: xs, y: ys }
        })
        .collect()
}

#[test]
fn collapse_is_exact_on_collapsing_data() {
    let (a, b) = (0.6, 1.2);
    let mut rng = Rng::new(31);
    let c = family(a, b, true, &mut rng);
    let q = collapse_quality(&c, a, b).unwrap();
    assert!(q.spread < 1e-14, "{q:?}");
    assert_eq!(q.n_pairs, 12);
    // Wrong exponents are detected.
    for (da, db) in [
        (0.05, 0.0),
        (-0.05, 0.0),
        (0.0, 0.05),
        (0.0, -0.05),
        (0.02, 0.02),
    ] {
        let w = collapse_quality(&c, a + da, b + db).unwrap();
        assert!(w.spread > 1e-3, "({da}, {db}): {w:?}");
    }
    let fit = optimise_collapse(&c, &CollapseOptions::default()).unwrap();
    assert!(
        (fit.x_exp - a).abs() < 1e-5 && (fit.y_exp - b).abs() < 1e-5,
        "{fit:?}"
    );
    assert!(fit.quality.spread < 1e-6);
}

#[test]
fn collapse_recovers_exponents_from_unaligned_noisy_data() {
    let (a, b) = (0.45, 1.2);
    let mut rng = Rng::new(32);
    let mut c = family(a, b, false, &mut rng);
    // 0.1% multiplicative noise.
    for curve in &mut c {
        for y in &mut curve.y {
            *y *= 1.0 + 1e-3 * rng.normal();
        }
    }
    let fit = optimise_collapse(&c, &CollapseOptions::default()).unwrap();
    eprintln!("collapse: {fit:?}");
    assert!(fit.converged);
    assert!(
        (fit.x_exp - a).abs() < 4.0 * fit.x_exp_error + 1e-3,
        "{fit:?}"
    );
    assert!(
        (fit.y_exp - b).abs() < 4.0 * fit.y_exp_error + 1e-3,
        "{fit:?}"
    );
    assert!(fit.x_exp_error > 0.0 && fit.x_exp_error < 0.02);
    assert!(fit.y_exp_error > 0.0 && fit.y_exp_error < 0.02);
    // Holding one exponent fixed.
    let opts = CollapseOptions {
        y_exp: b,
        fit_y: false,
        ..Default::default()
    };
    let fit = optimise_collapse(&c, &opts).unwrap();
    assert_eq!(fit.y_exp, b);
    assert_eq!(fit.y_exp_error, 0.0);
    assert!((fit.x_exp - a).abs() < 5e-3, "{fit:?}");
}

#[test]
fn collapse_helpers_and_bad_input() {
    let curve = Curve {
        l: -0.01,
        x: vec![0.1, 0.2],
        y: vec![1.0, 2.0],
    };
    let (x, y) = rescale_curve(&curve, 0.5, 1.0);
    assert!((x[0] - 1.0).abs() < 1e-12 && (y[1] - 200.0).abs() < 1e-9);
    let (x, y, g) = rescale_gap_samples(0.01, &[0.1], &[0.01], &[0.001], 0.6, 0.45, 1.2).unwrap();
    assert!((x[0] - 0.1 / 0.01f64.powf(0.6)).abs() < 1e-12);
    assert!((y[0] - 0.01 / 0.01f64.powf(0.45)).abs() < 1e-12);
    assert!((g[0] - 0.001 / 0.01f64.powf(1.2)).abs() < 1e-12);
    assert!(rescale_gap_samples(0.0, &[0.1], &[0.1], &[0.1], 0.6, 0.45, 1.2).is_err());
    assert!(matches!(
        collapse_quality(std::slice::from_ref(&curve), 0.5, 1.0),
        Err(FitError::TooFewPoints { .. })
    ));
    let unsorted = Curve {
        l: 0.02,
        x: vec![0.2, 0.1],
        y: vec![1.0, 2.0],
    };
    assert!(matches!(
        collapse_quality(&[curve.clone(), unsorted], 0.5, 1.0),
        Err(FitError::OutOfRange {
            what: "x",
            index: 1,
            ..
        })
    ));
    let far = Curve {
        l: 0.02,
        x: vec![100.0, 200.0],
        y: vec![1.0, 2.0],
    };
    let q = collapse_quality(&[curve.clone(), far.clone()], 0.5, 1.0).unwrap();
    assert!(q.spread.is_infinite() && q.n_compared == 0);
    assert!(matches!(
        optimise_collapse(&[curve, far], &CollapseOptions::default()),
        Err(FitError::NoInitialGuess(_))
    ));
}
