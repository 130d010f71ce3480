//! Extrapolation to zero grid spacing.
//!
//! # Model and error bar
//! A quantity computed at grid spacings `h₁ … hₙ` is fitted by `v(h) = v0 + c·h^p` (least
//! squares, weighted if σ is given), with `p` given ([`Order::Fixed`], e.g. 1 for a contact area
//! whose error is the perimeter, 2 for a smooth quantity) or fitted ([`Order::Free`]).
//! The error bar of `v0` combines two parts in quadrature:
//! - the **fit error** `σ_fit`: 1σ of `v0` from the fit covariance (scaled as the [`ErrorScale`]
//!   says; with no degree of freedom and no σ it is NaN, not zero);
//! - the **subset spread** `σ_sub = maxᵢ |v0⁽⁻ⁱ⁾ − v0|`, the largest change of `v0` when any one
//!   resolution is left out (leave-one-out refits; only when every such subset still determines
//!   the model, i.e. n − 1 ≥ number of fitted parameters). It measures how much the answer
//!   depends on which resolutions are used — in particular on higher-order terms that the model
//!   lacks and that are largest at the coarsest grids. The maximum rather than the jackknife
//!   standard deviation is deliberate: with 3–6 resolutions a conservative bound is more honest.
//!
//! `σ_total = sqrt(σ_fit² + σ_sub²)`.
//!
//! # Richardson extrapolation
//! For two resolutions and a known order p, the exact two-point solution of `v = v0 + c h^p` is
//! `v0 = (h₂^p v₁ − h₁^p v₂)/(h₂^p − h₁^p)` (for a refinement ratio r = h₁/h₂:
//! `v0 = v₂ + (v₂ − v₁)/(r^p − 1)`); its error from independent σ₁, σ₂ is
//! `sqrt(w₁² σ₁² + w₂² σ₂²)` with the weights `w` of the formula.
//! For three resolutions the order is solved from
//! `(v₁ − v₂)/(v₂ − v₃) = (h₁^p − h₂^p)/(h₂^p − h₃^p)` (bisection; monotone convergence needed),
//! then `c = (v₁ − v₂)/(h₁^p − h₂^p)` and `v0 = v₃ − c h₃^p`; σ propagated linearly by central
//! differences.

use crate::error::{FitError, Result, check_xy};
use crate::fit::{ErrorScale, FitResult};
use crate::linear::linear_least_squares;
use crate::nonlinear::{NonlinearOptions, ParamSpec, nonlinear_fit};

/// Order of the leading error term `c·h^p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Order {
    /// `p` known.
    Fixed(f64),
    /// `p` fitted (bounded below by 0.01; start from a profile over p ∈ [0.2, 6]).
    Free,
}

/// A leave-one-out refit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubsetEstimate {
    /// Index (into the input) of the resolution left out.
    pub omitted: usize,
    /// `v0` without it.
    pub v0: f64,
}

/// Result of [`extrapolate_to_zero`].
#[derive(Clone, Debug, PartialEq)]
pub struct Extrapolation {
    /// Extrapolated value at h = 0.
    pub v0: f64,
    /// 1σ of `v0` from the fit covariance (NaN if undetermined: no σ and no degree of freedom).
    pub v0_fit_error: f64,
    /// `maxᵢ |v0⁽⁻ⁱ⁾ − v0|` over the leave-one-out refits; `None` with too few resolutions.
    pub v0_subset_spread: Option<f64>,
    /// `sqrt(v0_fit_error² + v0_subset_spread²)` (the spread counts as 0 when `None`).
    pub v0_error: f64,
    /// Order p (given or fitted).
    pub order: f64,
    /// 1σ of p (0 when given).
    pub order_error: f64,
    /// Coefficient c of the leading term.
    pub c: f64,
    /// 1σ of c.
    pub c_error: f64,
    /// The full fit, parameters `["v0", "c"]` or `["v0", "c", "p"]`.
    pub fit: FitResult,
    /// The leave-one-out refits that succeeded.
    pub subsets: Vec<SubsetEstimate>,
}

fn fit_once(
    h: &[f64],
    v: &[f64],
    sigma: Option<&[f64]>,
    order: Order,
    scale: ErrorScale,
) -> Result<FitResult> {
    let ones = vec![1.0; h.len()];
    match order {
        Order::Fixed(p) => {
            let hp: Vec<f64> = h.iter().map(|x| x.powf(p)).collect();
            let mut f = linear_least_squares(&[&ones, &hp], v, sigma, scale)?;
            f.names = vec!["v0", "c"];
            Ok(f)
        }
        Order::Free => {
            let mut best: Option<(f64, [f64; 3])> = None;
            for k in 0..=116 {
                let p = 0.2 + 0.05 * k as f64;
                let hp: Vec<f64> = h.iter().map(|x| x.powf(p)).collect();
                if let Ok(f) = linear_least_squares(&[&ones, &hp], v, sigma, ErrorScale::Absolute)
                    && best.is_none_or(|(b, _)| f.chi2 < b)
                {
                    best = Some((f.chi2, [f.params[0], f.params[1], p]));
                }
            }
            let (_, start) = best.ok_or_else(|| {
                FitError::NoInitialGuess("no trial order gave a determined fit".into())
            })?;
            let opts = NonlinearOptions {
                params: vec![ParamSpec::FREE, ParamSpec::FREE, ParamSpec::at_least(0.01)],
                scale,
                names: vec!["v0", "c", "p"],
                ..Default::default()
            };
            nonlinear_fit(
                |x, q| q[0] + q[1] * x.powf(q[2]),
                h,
                v,
                sigma,
                &start,
                &opts,
            )
        }
    }
}

/// Extrapolates `v(h)` to `h = 0` with the model `v0 + c h^p`; see the module docs for the
/// error bar.
///
/// Errors: h ≤ 0 or repeated, fewer than 2 resolutions (3 for a free order), non-finite input,
/// σ ≤ 0, a fixed order ≤ 0.
pub fn extrapolate_to_zero(
    h: &[f64],
    v: &[f64],
    sigma: Option<&[f64]>,
    order: Order,
    scale: ErrorScale,
) -> Result<Extrapolation> {
    let k = match order {
        Order::Fixed(p) => {
            crate::error::check_arg("order p", p, "finite and > 0", p > 0.0)?;
            2
        }
        Order::Free => 3,
    };
    check_xy("an extrapolation in grid spacing", h, v, sigma, k)?;
    if let Some(index) = h.iter().position(|&x| x <= 0.0) {
        return Err(FitError::OutOfRange {
            what: "h",
            index,
            value: h[index],
            allowed: "> 0 (a grid spacing)",
        });
    }
    for i in 0..h.len() {
        if h[..i].contains(&h[i]) {
            return Err(FitError::OutOfRange {
                what: "h",
                index: i,
                value: h[i],
                allowed: "distinct from the other grid spacings",
            });
        }
    }
    let n = h.len();
    let resolved = scale.resolve(sigma.is_some());
    let no_dof = n == k;
    // With no degree of freedom the reduced χ² is undefined: fit with the covariance as is and
    // report the fit error only if σ says what it is.
    let fit_scale = if no_dof {
        ErrorScale::Absolute
    } else {
        resolved
    };
    let fit = fit_once(h, v, sigma, order, fit_scale)?;
    let v0 = fit.params[0];
    let v0_fit_error = if no_dof && (sigma.is_none() || resolved == ErrorScale::ReducedChi2) {
        f64::NAN
    } else {
        fit.errors[0]
    };
    let mut subsets = Vec::new();
    if n > k {
        for omit in 0..n {
            let keep: Vec<usize> = (0..n).filter(|&i| i != omit).collect();
            let hs: Vec<f64> = keep.iter().map(|&i| h[i]).collect();
            let vs: Vec<f64> = keep.iter().map(|&i| v[i]).collect();
            let ss: Option<Vec<f64>> = sigma.map(|s| keep.iter().map(|&i| s[i]).collect());
            if let Ok(f) = fit_once(&hs, &vs, ss.as_deref(), order, ErrorScale::Absolute)
                && f.params[0].is_finite()
            {
                subsets.push(SubsetEstimate {
                    omitted: omit,
                    v0: f.params[0],
                });
            }
        }
    }
    let v0_subset_spread = (!subsets.is_empty()).then(|| {
        subsets
            .iter()
            .map(|s| (s.v0 - v0).abs())
            .fold(0.0, f64::max)
    });
    let v0_error = v0_fit_error.hypot(v0_subset_spread.unwrap_or(0.0));
    let (order_value, order_error) = match order {
        Order::Fixed(p) => (p, 0.0),
        Order::Free => (fit.params[2], fit.errors[2]),
    };
    Ok(Extrapolation {
        v0,
        v0_fit_error,
        v0_subset_spread,
        v0_error,
        order: order_value,
        order_error,
        c: fit.params[1],
        c_error: fit.errors[1],
        fit,
        subsets,
    })
}

/// Result of Richardson extrapolation.
#[derive(Clone, Debug, PartialEq)]
pub struct Richardson {
    /// Extrapolated value.
    pub v0: f64,
    /// 1σ of `v0` propagated from the inputs' σ (`None` without σ).
    pub v0_error: Option<f64>,
    /// Order used (given for pairs, solved for triples).
    pub order: f64,
    /// 1σ of the order (triples with σ only).
    pub order_error: Option<f64>,
    /// Coefficient c of `v = v0 + c h^p`.
    pub c: f64,
}

fn check_spacings(h: &[f64]) -> Result<()> {
    crate::error::check_finite("h", h)?;
    for (i, &x) in h.iter().enumerate() {
        if x <= 0.0 || h[..i].contains(&x) {
            return Err(FitError::OutOfRange {
                what: "h",
                index: i,
                value: x,
                allowed: "> 0 and distinct",
            });
        }
    }
    Ok(())
}

/// Two-point Richardson extrapolation with known order `p` (see the module docs).
pub fn richardson_pair(
    h: [f64; 2],
    v: [f64; 2],
    order: f64,
    sigma: Option<[f64; 2]>,
) -> Result<Richardson> {
    crate::error::check_arg("order p", order, "finite and > 0", order > 0.0)?;
    check_spacings(&h)?;
    check_xy(
        "Richardson extrapolation",
        &h,
        &v,
        sigma.as_ref().map(|s| &s[..]),
        2,
    )?;
    let (a, b) = (h[0].powf(order), h[1].powf(order));
    let w = [b / (b - a), -a / (b - a)];
    let v0 = w[0] * v[0] + w[1] * v[1];
    Ok(Richardson {
        v0,
        v0_error: sigma.map(|s| (w[0] * s[0]).hypot(w[1] * s[1])),
        order,
        order_error: None,
        c: (v[0] - v[1]) / (a - b),
    })
}

/// Solves the order and v0 of `v = v0 + c h^p` through three points (any order of `h`).
fn triple_solution(h: [f64; 3], v: [f64; 3]) -> Result<(f64, f64, f64)> {
    let mut idx = [0, 1, 2];
    idx.sort_by(|&a, &b| h[b].total_cmp(&h[a])); // coarse first
    let (h1, h2, h3) = (h[idx[0]], h[idx[1]], h[idx[2]]);
    let (v1, v2, v3) = (v[idx[0]], v[idx[1]], v[idx[2]]);
    let d12 = v1 - v2;
    let d23 = v2 - v3;
    let ratio = d12 / d23;
    if ratio.is_nan() || ratio <= 0.0 || !ratio.is_finite() {
        return Err(FitError::NoInitialGuess(format!(
            "the differences v(h1) - v(h2) = {d12:.3e} and v(h2) - v(h3) = {d23:.3e} do not have \
             the same sign: convergence is not monotone, no order can be solved"
        )));
    }
    // f(p) = ((h1/h2)^p − 1)/(1 − (h3/h2)^p) − ratio, increasing from its p → 0 limit.
    let (r1, r3) = (h1 / h2, h3 / h2);
    let f = |p: f64| (r1.powf(p) - 1.0) / (1.0 - r3.powf(p)) - ratio;
    let (mut lo, mut hi) = (1e-6, 60.0);
    if f(lo) > 0.0 || f(hi) < 0.0 {
        return Err(FitError::NoInitialGuess(format!(
            "no order p in [1e-6, 60] reproduces the ratio of differences {ratio:.4}: the data \
             are not in the asymptotic range of v0 + c h^p"
        )));
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let p = 0.5 * (lo + hi);
    let c = d12 / (h1.powf(p) - h2.powf(p));
    Ok((v3 - c * h3.powf(p), p, c))
}

/// Three-point Richardson extrapolation with the order solved from the data (see the module
/// docs). Errors if convergence is not monotone or no order in (0, 60] fits.
pub fn richardson_triple(h: [f64; 3], v: [f64; 3], sigma: Option<[f64; 3]>) -> Result<Richardson> {
    check_spacings(&h)?;
    check_xy(
        "Richardson extrapolation",
        &h,
        &v,
        sigma.as_ref().map(|s| &s[..]),
        3,
    )?;
    let (v0, p, c) = triple_solution(h, v)?;
    let (mut v0_error, mut order_error) = (None, None);
    if let Some(s) = sigma {
        let (mut var_v0, mut var_p) = (0.0, 0.0);
        for i in 0..3 {
            let d = s[i] * 1e-3;
            let (mut up, mut dn) = (v, v);
            up[i] += d;
            dn[i] -= d;
            let (a, b) = (triple_solution(h, up)?, triple_solution(h, dn)?);
            let (g0, gp) = ((a.0 - b.0) / (2.0 * d), (a.1 - b.1) / (2.0 * d));
            var_v0 += (g0 * s[i]).powi(2);
            var_p += (gp * s[i]).powi(2);
        }
        v0_error = Some(var_v0.sqrt());
        order_error = Some(var_p.sqrt());
    }
    Ok(Richardson {
        v0,
        v0_error,
        order: p,
        order_error,
        c,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn richardson_exact() {
        let f = |h: f64| 0.4 + 0.3 * h + 0.0 * h * h;
        let r = richardson_pair([0.1, 0.05], [f(0.1), f(0.05)], 1.0, Some([1e-4, 1e-4])).unwrap();
        assert!((r.v0 - 0.4).abs() < 1e-14 && (r.c - 0.3).abs() < 1e-12);
        // Weights 2 and -1 for halving at first order: σ = sqrt(4 + 1) 1e-4.
        assert!((r.v0_error.unwrap() - 5f64.sqrt() * 1e-4).abs() < 1e-15);
        let g = |h: f64| 1.5 - 0.7 * h.powf(1.7);
        let t = richardson_triple([0.2, 0.1, 0.07], [g(0.2), g(0.1), g(0.07)], None).unwrap();
        assert!(
            (t.v0 - 1.5).abs() < 1e-10 && (t.order - 1.7).abs() < 1e-8,
            "{t:?}"
        );
        assert!(richardson_triple([0.2, 0.1, 0.05], [1.0, 1.1, 1.0], None).is_err());
        assert!(richardson_pair([0.1, 0.1], [1.0, 1.0], 1.0, None).is_err());
    }
}
