//! Scaling collapse: rescaling near-critical curves by powers of the reduced load, a collapse
//! quality measure, and the exponents that minimise it.
//!
//! Near the critical load the gap obeys `g(l, x, y) = |l|^ζ G(x/|l|^χ, y/|l|^υ)`. A family of
//! curves `yₗ(x)` (one per reduced load l) collapses with exponents `(a, b)` if the rescaled curves
//! `Y = y/|l|^b` against `X = x/|l|^a` lie on one master curve.
//!
//! # Quality measure
//! For every ordered pair of curves (i, j), i ≠ j, and every point `(Xᵢₖ, Yᵢₖ)` of curve i that
//! lies inside the X range of curve j, curve j is interpolated linearly at `Xᵢₖ` (`Ŷⱼ`). Then
//!
//! `S(a, b) = sqrt( Σ (Yᵢₖ − Ŷⱼ)² / Σ ((|Yᵢₖ| + |Ŷⱼ|)/2)² )`,
//!
//! the rms spread of the curves about each other's interpolants relative to the rms size of the
//! curves: invariant under a common rescaling of Y, so it cannot be lowered by shrinking all
//! curves. Pairs without overlap do not count; with no overlap at all S = +∞. Sampling that puts
//! the points of all curves at the same X for the right exponents makes S exactly 0 there;
//! otherwise linear interpolation leaves an O(ΔX²·Y'') floor.
//!
//! # Error estimate of the optimal exponents
//! Treating the spread at the optimum as the noise of the points (as a fit scaled by the reduced
//! χ² does), `Q(θ) = N·S²(θ)/S²_min` behaves like a χ² with N = half the number of compared
//! points (each pair is compared both ways). The 1σ errors are from its curvature,
//! `cov = 2 H⁻¹` with `H` the finite-difference Hessian of Q. Points of one curve are
//! correlated and the comparisons are not independent, so read these as estimates of the
//! sensitivity, not rigorous standard errors; they are NaN for a perfect collapse (S_min ≈ 0) or
//! a non-convex optimum.

use crate::error::{FitError, Result, check_arg, check_finite};

/// One curve of a family, at reduced load `l` (only |l| enters the rescaling).
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    /// Reduced load (non-zero).
    pub l: f64,
    /// Abscissae, strictly increasing.
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
}

/// `(x/|l|^x_exp, y/|l|^y_exp)` of one curve.
pub fn rescale_curve(curve: &Curve, x_exp: f64, y_exp: f64) -> (Vec<f64>, Vec<f64>) {
    let al = curve.l.abs();
    let (fx, fy) = (al.powf(-x_exp), al.powf(-y_exp));
    (
        curve.x.iter().map(|v| v * fx).collect(),
        curve.y.iter().map(|v| v * fy).collect(),
    )
}

/// Rescales gap-field samples `g(l, x, y)` to the master-function variables:
/// `(x/|l|^χ, y/|l|^υ, g/|l|^ζ)`. Errors on lengths that differ, non-finite input or `l = 0`.
#[allow(clippy::type_complexity)]
pub fn rescale_gap_samples(
    l: f64,
    x: &[f64],
    y: &[f64],
    g: &[f64],
    chi: f64,
    upsilon: f64,
    zeta: f64,
) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    check_arg("l", l, "finite and non-zero", l != 0.0)?;
    for (name, v) in [("chi", chi), ("upsilon", upsilon), ("zeta", zeta)] {
        check_arg(name, v, "finite", true)?;
    }
    for (what, v) in [("y", y), ("g", g)] {
        if v.len() != x.len() {
            return Err(FitError::LengthMismatch {
                what,
                got: v.len(),
                expected: x.len(),
            });
        }
    }
    check_finite("x", x)?;
    check_finite("y", y)?;
    check_finite("g", g)?;
    let al = l.abs();
    let s = |v: &[f64], e: f64| -> Vec<f64> {
        let f = al.powf(-e);
        v.iter().map(|t| t * f).collect()
    };
    Ok((s(x, chi), s(y, upsilon), s(g, zeta)))
}

/// Value of the collapse quality measure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CollapseQuality {
    /// The relative spread S (see the module docs); +∞ without any overlap.
    pub spread: f64,
    /// Number of (point, other curve) comparisons.
    pub n_compared: usize,
    /// Number of ordered curve pairs that overlap.
    pub n_pairs: usize,
}

fn validate(curves: &[Curve]) -> Result<()> {
    if curves.len() < 2 {
        return Err(FitError::TooFewPoints {
            what: "a scaling collapse (curves)",
            got: curves.len(),
            needed: 2,
        });
    }
    for c in curves {
        check_arg("l", c.l, "finite and non-zero", c.l != 0.0)?;
        crate::error::check_xy("a collapse curve", &c.x, &c.y, None, 2)?;
        check_finite("x", &c.x)?;
        if let Some(k) = c.x.windows(2).position(|w| w[1] <= w[0]) {
            return Err(FitError::OutOfRange {
                what: "x",
                index: k + 1,
                value: c.x[k + 1],
                allowed: "strictly increasing along each curve",
            });
        }
    }
    Ok(())
}

fn interp(x: &[f64], y: &[f64], t: f64) -> f64 {
    // x strictly increasing, x[0] <= t <= x[last].
    let k = x.partition_point(|&v| v <= t).clamp(1, x.len() - 1);
    let (x0, x1) = (x[k - 1], x[k]);
    let w = (t - x0) / (x1 - x0);
    y[k - 1] + w * (y[k] - y[k - 1])
}

fn quality_unchecked(curves: &[Curve], a: f64, b: f64) -> CollapseQuality {
    let scaled: Vec<(Vec<f64>, Vec<f64>)> = curves.iter().map(|c| rescale_curve(c, a, b)).collect();
    let (mut num, mut den) = (0.0, 0.0);
    let (mut n, mut pairs) = (0usize, 0usize);
    for (i, (xi, yi)) in scaled.iter().enumerate() {
        for (j, (xj, yj)) in scaled.iter().enumerate() {
            if i == j {
                continue;
            }
            let (lo, hi) = (xj[0], xj[xj.len() - 1]);
            let before = n;
            for (&t, &v) in xi.iter().zip(yi) {
                if t < lo || t > hi {
                    continue;
                }
                let w = interp(xj, yj, t);
                num += (v - w) * (v - w);
                let m = 0.5 * (v.abs() + w.abs());
                den += m * m;
                n += 1;
            }
            pairs += (n > before) as usize;
        }
    }
    let spread = if n == 0 || den.is_nan() || den <= 0.0 {
        f64::INFINITY
    } else {
        (num / den).sqrt()
    };
    CollapseQuality {
        spread: if spread.is_finite() {
            spread
        } else {
            f64::INFINITY
        },
        n_compared: n,
        n_pairs: pairs,
    }
}

/// Collapse quality of `curves` rescaled with exponents `(x_exp, y_exp)`; see the module docs.
///
/// Errors: fewer than 2 curves, a curve with fewer than 2 points, x not strictly increasing,
/// non-finite values, `l = 0`.
pub fn collapse_quality(curves: &[Curve], x_exp: f64, y_exp: f64) -> Result<CollapseQuality> {
    validate(curves)?;
    check_arg("x_exp", x_exp, "finite", true)?;
    check_arg("y_exp", y_exp, "finite", true)?;
    Ok(quality_unchecked(curves, x_exp, y_exp))
}

/// Options of [`optimise_collapse`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CollapseOptions {
    /// Starting (or fixed) x exponent.
    pub x_exp: f64,
    /// Starting (or fixed) y exponent.
    pub y_exp: f64,
    /// Optimise the x exponent.
    pub fit_x: bool,
    /// Optimise the y exponent.
    pub fit_y: bool,
    /// Initial simplex size in exponent units.
    pub step: f64,
    /// Stop when the simplex is smaller than this (exponent units).
    pub tol: f64,
    /// Maximum evaluations of the quality measure.
    pub max_evaluations: usize,
}

impl Default for CollapseOptions {
    fn default() -> Self {
        CollapseOptions {
            x_exp: 0.5,
            y_exp: 1.0,
            fit_x: true,
            fit_y: true,
            step: 0.1,
            tol: 1e-7,
            max_evaluations: 4000,
        }
    }
}

/// Result of [`optimise_collapse`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CollapseFit {
    /// Optimal (or fixed) x exponent.
    pub x_exp: f64,
    /// Its error estimate (module docs; 0 if fixed, NaN if undetermined).
    pub x_exp_error: f64,
    /// Optimal (or fixed) y exponent.
    pub y_exp: f64,
    /// Its error estimate.
    pub y_exp_error: f64,
    /// The quality at the optimum.
    pub quality: CollapseQuality,
    /// Evaluations used.
    pub evaluations: usize,
    /// The simplex shrank below `tol` before `max_evaluations`.
    pub converged: bool,
}

/// Nelder–Mead minimisation of `f` from `x0` with initial step `step`.
fn nelder_mead(
    f: &mut dyn FnMut(&[f64]) -> f64,
    x0: &[f64],
    step: f64,
    tol: f64,
    max_eval: usize,
    evals: &mut usize,
) -> (Vec<f64>, f64, bool) {
    let d = x0.len();
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(d + 1);
    let mut eval = |x: &[f64], evals: &mut usize| {
        *evals += 1;
        let v = f(x);
        if v.is_nan() { f64::INFINITY } else { v }
    };
    simplex.push((x0.to_vec(), eval(x0, evals)));
    for i in 0..d {
        let mut x = x0.to_vec();
        x[i] += step;
        let v = eval(&x, evals);
        simplex.push((x, v));
    }
    let mut converged = false;
    while *evals < max_eval {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let size = simplex[1..]
            .iter()
            .map(|(x, _)| {
                x.iter()
                    .zip(&simplex[0].0)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        if size < tol {
            converged = true;
            break;
        }
        let centroid: Vec<f64> = (0..d)
            .map(|k| simplex[..d].iter().map(|(x, _)| x[k]).sum::<f64>() / d as f64)
            .collect();
        let worst = simplex[d].clone();
        let along = |t: f64| -> Vec<f64> {
            (0..d)
                .map(|k| centroid[k] + t * (worst.0[k] - centroid[k]))
                .collect()
        };
        let xr = along(-1.0);
        let fr = eval(&xr, evals);
        if fr < simplex[0].1 {
            let xe = along(-2.0);
            let fe = eval(&xe, evals);
            simplex[d] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[d - 1].1 {
            simplex[d] = (xr, fr);
        } else {
            let (xc, fc) = if fr < worst.1 {
                let x = along(-0.5);
                let v = eval(&x, evals);
                (x, v)
            } else {
                let x = along(0.5);
                let v = eval(&x, evals);
                (x, v)
            };
            if fc < worst.1.min(fr) {
                simplex[d] = (xc, fc);
            } else {
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    let x: Vec<f64> =
                        s.0.iter()
                            .zip(&best)
                            .map(|(a, b)| b + 0.5 * (a - b))
                            .collect();
                    let v = eval(&x, evals);
                    *s = (x, v);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, v) = simplex.swap_remove(0);
    (x, v, converged)
}

/// Finds the exponents `(x_exp, y_exp)` (either may be held fixed) that minimise the collapse
/// spread, by Nelder–Mead from the given start with one restart from the optimum found; errors
/// as in the module docs.
///
/// Errors: as [`collapse_quality`]; nothing to optimise; non-finite options; no overlap at the
/// start.
pub fn optimise_collapse(curves: &[Curve], opts: &CollapseOptions) -> Result<CollapseFit> {
    validate(curves)?;
    check_arg("x_exp", opts.x_exp, "finite", true)?;
    check_arg("y_exp", opts.y_exp, "finite", true)?;
    check_arg("step", opts.step, "finite and > 0", opts.step > 0.0)?;
    check_arg("tol", opts.tol, "finite and > 0", opts.tol > 0.0)?;
    if !opts.fit_x && !opts.fit_y {
        return Err(FitError::InvalidArgument {
            name: "number of free exponents",
            value: 0.0,
            allowed: "at least 1 (fit_x or fit_y)",
        });
    }
    let start = quality_unchecked(curves, opts.x_exp, opts.y_exp);
    if !start.spread.is_finite() {
        return Err(FitError::NoInitialGuess(
            "the rescaled curves do not overlap at the starting exponents".into(),
        ));
    }
    let free: Vec<usize> = [(0, opts.fit_x), (1, opts.fit_y)]
        .iter()
        .filter(|(_, f)| *f)
        .map(|(i, _)| *i)
        .collect();
    let full = |theta: &[f64]| -> [f64; 2] {
        let mut e = [opts.x_exp, opts.y_exp];
        for (k, &i) in free.iter().enumerate() {
            e[i] = theta[k];
        }
        e
    };
    let mut objective = |theta: &[f64]| {
        let e = full(theta);
        quality_unchecked(curves, e[0], e[1]).spread
    };
    let x0: Vec<f64> = free.iter().map(|&i| [opts.x_exp, opts.y_exp][i]).collect();
    let mut evals = 0;
    let (x1, _, _) = nelder_mead(
        &mut objective,
        &x0,
        opts.step,
        opts.tol,
        opts.max_evaluations / 2,
        &mut evals,
    );
    let (xb, _, converged) = nelder_mead(
        &mut objective,
        &x1,
        opts.step * 0.1,
        opts.tol,
        opts.max_evaluations,
        &mut evals,
    );
    let e = full(&xb);
    let q = quality_unchecked(curves, e[0], e[1]);
    // Error estimate from the curvature of Q = N S² / S²_min.
    let mut errs = [0.0f64; 2];
    let smin2 = q.spread * q.spread;
    if smin2 > 1e-24 && q.n_compared > 0 {
        let n_eff = q.n_compared as f64 / 2.0;
        let qf = |theta: &[f64]| {
            let s = objective(theta);
            n_eff * s * s / smin2
        };
        let d = free.len();
        let h = 1e-3;
        let mut hess = vec![vec![0.0; d]; d];
        let q0 = qf(&xb);
        for a in 0..d {
            for b in a..d {
                let val = if a == b {
                    let mut p = xb.clone();
                    p[a] += h;
                    let up = qf(&p);
                    p[a] -= 2.0 * h;
                    let dn = qf(&p);
                    (up - 2.0 * q0 + dn) / (h * h)
                } else {
                    let mut s = 0.0;
                    for (da, db, sign) in [(h, h, 1.0), (h, -h, -1.0), (-h, h, -1.0), (-h, -h, 1.0)]
                    {
                        let mut p = xb.clone();
                        p[a] += da;
                        p[b] += db;
                        s += sign * qf(&p);
                    }
                    s / (4.0 * h * h)
                };
                hess[a][b] = val;
                hess[b][a] = val;
            }
        }
        let cov: Option<Vec<f64>> = match d {
            1 => (hess[0][0] > 0.0).then(|| vec![2.0 / hess[0][0]]),
            _ => {
                let det = hess[0][0] * hess[1][1] - hess[0][1] * hess[1][0];
                (det > 0.0 && hess[0][0] > 0.0)
                    .then(|| vec![2.0 * hess[1][1] / det, 2.0 * hess[0][0] / det])
            }
        };
        for (k, &i) in free.iter().enumerate() {
            errs[i] = cov.as_ref().map_or(f64::NAN, |c| c[k].sqrt());
        }
    } else {
        for &i in &free {
            errs[i] = f64::NAN;
        }
    }
    Ok(CollapseFit {
        x_exp: e[0],
        x_exp_error: errs[0],
        y_exp: e[1],
        y_exp_error: errs[1],
        quality: q,
        evaluations: evals,
        converged,
    })
}
