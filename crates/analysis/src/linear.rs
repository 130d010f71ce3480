//! Linear least squares (Householder QR), straight lines, polynomials, power laws in log–log,
//! weighted means.

use crate::error::{FitError, Result, check_finite, check_xy};
use crate::fit::{ErrorScale, FitResult, FitStatus};

/// Solution of a weighted linear least-squares problem.
pub(crate) struct LsqSolution {
    pub params: Vec<f64>,
    /// `(Aᵀ W A)⁻¹`, unscaled.
    pub cov: Vec<Vec<f64>>,
    pub chi2: f64,
}

/// Minimises `Σᵢ wᵢ² (yᵢ − Σⱼ cols[j][i] pⱼ)²` by Householder QR of the weighted, column-
/// normalised design matrix. `w` are the inverse standard deviations.
pub(crate) fn solve_lsq(cols: &[Vec<f64>], y: &[f64], w: &[f64]) -> Result<LsqSolution> {
    let m = y.len();
    let k = cols.len();
    if m < k {
        return Err(FitError::TooFewPoints {
            what: "a linear model",
            got: m,
            needed: k,
        });
    }
    // Weighted, normalised columns (column-major).
    let mut a: Vec<Vec<f64>> = Vec::with_capacity(k);
    let mut scale = Vec::with_capacity(k);
    for (j, c) in cols.iter().enumerate() {
        let col: Vec<f64> = c.iter().zip(w).map(|(v, wi)| v * wi).collect();
        let norm = col.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm == 0.0 || !norm.is_finite() {
            return Err(FitError::Singular(format!(
                "column {j} of the design matrix is zero or not finite"
            )));
        }
        a.push(col.iter().map(|v| v / norm).collect());
        scale.push(norm);
    }
    let mut b: Vec<f64> = y.iter().zip(w).map(|(v, wi)| v * wi).collect();
    // Householder QR, in place: a[j][j..] holds R's diagonal-and-below work.
    let mut r = vec![vec![0.0; k]; k];
    for j in 0..k {
        let alpha = a[j][j..].iter().map(|v| v * v).sum::<f64>().sqrt();
        let alpha = if a[j][j] > 0.0 { -alpha } else { alpha };
        let mut v: Vec<f64> = a[j][j..].to_vec();
        v[0] -= alpha;
        let vnorm2: f64 = v.iter().map(|t| t * t).sum();
        if vnorm2 > 0.0 {
            for col in a.iter_mut().skip(j) {
                let d: f64 = v.iter().zip(&col[j..]).map(|(p, q)| p * q).sum::<f64>();
                let f = 2.0 * d / vnorm2;
                for (t, vi) in col[j..].iter_mut().zip(&v) {
                    *t -= f * vi;
                }
            }
            let d: f64 = v.iter().zip(&b[j..]).map(|(p, q)| p * q).sum::<f64>();
            let f = 2.0 * d / vnorm2;
            for (t, vi) in b[j..].iter_mut().zip(&v) {
                *t -= f * vi;
            }
        }
        for i in 0..=j {
            r[i][j] = a[j][i];
        }
    }
    let rmax = (0..k).map(|i| r[i][i].abs()).fold(0.0, f64::max);
    for i in 0..k {
        if r[i][i].is_nan() || r[i][i].abs() <= 1e-12 * rmax {
            return Err(FitError::Singular(format!(
                "the design matrix has dependent columns (rank < {k}); parameter {i} is not \
                 determined by the data"
            )));
        }
    }
    // Back substitution: R p' = (Qᵀ b)[..k].
    let mut ps = vec![0.0; k];
    for i in (0..k).rev() {
        let s: f64 = (i + 1..k).map(|j| r[i][j] * ps[j]).sum();
        ps[i] = (b[i] - s) / r[i][i];
    }
    // R⁻¹ (upper triangular), then (RᵀR)⁻¹ = R⁻¹ R⁻ᵀ.
    let mut rinv = vec![vec![0.0; k]; k];
    for i in 0..k {
        rinv[i][i] = 1.0 / r[i][i];
        for j in (i + 1)..k {
            let s: f64 = (i..j).map(|l| rinv[i][l] * r[l][j]).sum();
            rinv[i][j] = -s / r[j][j];
        }
    }
    let mut cov = vec![vec![0.0; k]; k];
    for i in 0..k {
        for j in 0..k {
            let s: f64 = (i.max(j)..k).map(|l| rinv[i][l] * rinv[j][l]).sum();
            cov[i][j] = s / (scale[i] * scale[j]);
        }
    }
    let params: Vec<f64> = ps.iter().zip(&scale).map(|(p, s)| p / s).collect();
    let chi2 = (0..m)
        .map(|i| {
            let f: f64 = (0..k).map(|j| cols[j][i] * params[j]).sum();
            let d = (y[i] - f) * w[i];
            d * d
        })
        .sum();
    Ok(LsqSolution { params, cov, chi2 })
}

pub(crate) fn weights(sigma: Option<&[f64]>, n: usize) -> Vec<f64> {
    match sigma {
        Some(s) => s.iter().map(|v| 1.0 / v).collect(),
        None => vec![1.0; n],
    }
}

/// General linear least squares: `y ≈ Σⱼ pⱼ · columns[j]`, with optional standard deviations σ
/// of `y`. Parameter names are `p0, p1, …`.
///
/// Errors: `columns` empty or of the wrong length, fewer points than parameters, non-finite
/// values, σ ≤ 0, dependent columns, or `ReducedChi2` scaling with no degree of freedom.
pub fn linear_least_squares(
    columns: &[&[f64]],
    y: &[f64],
    sigma: Option<&[f64]>,
    scale: ErrorScale,
) -> Result<FitResult> {
    const NAMES: [&str; 8] = ["p0", "p1", "p2", "p3", "p4", "p5", "p6", "p7"];
    if columns.is_empty() || columns.len() > NAMES.len() {
        return Err(FitError::InvalidArgument {
            name: "number of columns",
            value: columns.len() as f64,
            allowed: "between 1 and 8",
        });
    }
    for c in columns {
        check_xy("a linear model", c, y, sigma, columns.len())?;
    }
    let cols: Vec<Vec<f64>> = columns.iter().map(|c| c.to_vec()).collect();
    let sol = solve_lsq(&cols, y, &weights(sigma, y.len()))?;
    let k = columns.len();
    FitResult::assemble(
        NAMES[..k].to_vec(),
        sol.params,
        sol.cov,
        sol.chi2,
        y.len() - k,
        k,
        scale,
        sigma.is_some(),
        FitStatus::linear(),
    )
}

/// Straight line `y = a + b x`: parameters `["intercept", "slope"]`.
///
/// With σ the fit is weighted; errors follow `scale` (see [`ErrorScale`]). Needs ≥ 2 points
/// with distinct x (≥ 3 for `ReducedChi2`, which `Auto` picks without σ).
pub fn linear_fit(
    x: &[f64],
    y: &[f64],
    sigma: Option<&[f64]>,
    scale: ErrorScale,
) -> Result<FitResult> {
    check_xy("a straight line", x, y, sigma, 2)?;
    let ones = vec![1.0; x.len()];
    let mut f = linear_least_squares(&[&ones, x], y, sigma, scale)?;
    f.names = vec!["intercept", "slope"];
    Ok(f)
}

/// Polynomial `y = Σₖ cₖ xᵏ`, k = 0..=degree (degree ≤ 7): parameters `p0 … p{degree}`.
pub fn polynomial_fit(
    x: &[f64],
    y: &[f64],
    sigma: Option<&[f64]>,
    degree: usize,
    scale: ErrorScale,
) -> Result<FitResult> {
    if degree > 7 {
        return Err(FitError::InvalidArgument {
            name: "degree",
            value: degree as f64,
            allowed: "at most 7",
        });
    }
    check_xy("a polynomial", x, y, sigma, degree + 1)?;
    // The QR solver normalises the columns; for high degrees over a wide x range, centre x first.
    let cols: Vec<Vec<f64>> = (0..=degree)
        .map(|k| x.iter().map(|v| v.powi(k as i32)).collect())
        .collect();
    let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
    linear_least_squares(&refs, y, sigma, scale)
}

/// Power law `y = A x^β`, fitted as a straight line `ln y = ln A + β ln x`.
///
/// Parameters `["A", "beta"]`. With σ (of y), the log-space weights are `y/σ` (first-order error
/// propagation, valid for σ ≪ y). The errors of `A` are linearised: `σ_A = A σ_lnA`, and
/// `cov(A, β) = A cov(ln A, β)`; the log-log estimator is biased by O(σ²/y²), negligible for
/// relative noise of a few percent. Requires x > 0 and y > 0 (else
/// [`FitError::OutOfRange`]).
pub fn power_law_fit(
    x: &[f64],
    y: &[f64],
    sigma: Option<&[f64]>,
    scale: ErrorScale,
) -> Result<FitResult> {
    check_xy("a power law", x, y, sigma, 2)?;
    for (what, v) in [("x", x), ("y", y)] {
        if let Some(index) = v.iter().position(|&t| t <= 0.0) {
            return Err(FitError::OutOfRange {
                what,
                index,
                value: v[index],
                allowed: "> 0 for a fit in log-log",
            });
        }
    }
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let ls: Option<Vec<f64>> = sigma.map(|s| s.iter().zip(y).map(|(s, y)| s / y).collect());
    let f = linear_fit(&lx, &ly, ls.as_deref(), scale)?;
    let a = f.params[0].exp();
    let j = [a, 1.0];
    let cov: Vec<Vec<f64>> = (0..2)
        .map(|r| (0..2).map(|c| j[r] * j[c] * f.covariance[r][c]).collect())
        .collect();
    let errors = (0..2).map(|i| cov[i][i].max(0.0).sqrt()).collect();
    Ok(FitResult {
        names: vec!["A", "beta"],
        params: vec![a, f.params[1]],
        errors,
        covariance: cov,
        ..f
    })
}

/// Inverse-variance weighted mean and its 1σ error `1/sqrt(Σ 1/σᵢ²)`, plus χ² about the mean.
pub fn weighted_mean(values: &[f64], sigma: &[f64]) -> Result<(f64, f64, f64)> {
    check_xy("a weighted mean", values, values, Some(sigma), 1)?;
    let w: Vec<f64> = sigma.iter().map(|s| 1.0 / (s * s)).collect();
    let sw: f64 = w.iter().sum();
    let mean = values.iter().zip(&w).map(|(v, w)| v * w).sum::<f64>() / sw;
    let chi2 = values
        .iter()
        .zip(&w)
        .map(|(v, w)| (v - mean) * (v - mean) * w)
        .sum();
    Ok((mean, 1.0 / sw.sqrt(), chi2))
}

/// Mean and sample standard deviation (n − 1 in the denominator; NaN for n < 2).
pub fn mean_std(values: &[f64]) -> Result<(f64, f64)> {
    check_finite("values", values)?;
    if values.is_empty() {
        return Err(FitError::TooFewPoints {
            what: "a mean",
            got: 0,
            needed: 1,
        });
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0);
    Ok((mean, var.sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_line_and_known_covariance() {
        // y = 1 + 2x exactly; unweighted with sigma = 1: cov = (XᵀX)⁻¹.
        let x = [0.0, 1.0, 2.0, 3.0];
        let y: Vec<f64> = x.iter().map(|v| 1.0 + 2.0 * v).collect();
        let s = [1.0; 4];
        let f = linear_fit(&x, &y, Some(&s), ErrorScale::Absolute).unwrap();
        assert!((f.params[0] - 1.0).abs() < 1e-13 && (f.params[1] - 2.0).abs() < 1e-13);
        // XᵀX = [[4, 6], [6, 14]], det 20: inverse [[0.7, -0.3], [-0.3, 0.2]].
        assert!((f.covariance[0][0] - 0.7).abs() < 1e-12);
        assert!((f.covariance[0][1] + 0.3).abs() < 1e-12);
        assert!((f.covariance[1][1] - 0.2).abs() < 1e-12);
        assert!(f.chi2 < 1e-20 && f.dof == 2);
    }

    #[test]
    fn polynomial_recovers_quadratic() {
        let x: Vec<f64> = (0..9).map(|i| i as f64 * 0.25 - 1.0).collect();
        let y: Vec<f64> = x.iter().map(|v| 0.5 - v + 3.0 * v * v).collect();
        let f = polynomial_fit(&x, &y, None, 2, ErrorScale::Auto).unwrap();
        for (p, t) in f.params.iter().zip([0.5, -1.0, 3.0]) {
            assert!((p - t).abs() < 1e-12);
        }
    }

    #[test]
    fn degenerate_inputs_fail_cleanly() {
        assert!(matches!(
            linear_fit(&[1.0], &[1.0], None, ErrorScale::Absolute),
            Err(FitError::TooFewPoints {
                got: 1,
                needed: 2,
                ..
            })
        ));
        assert!(matches!(
            linear_fit(&[1.0, 2.0], &[1.0, 2.0], None, ErrorScale::Auto),
            Err(FitError::TooFewPoints { .. })
        ));
        assert!(matches!(
            linear_fit(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0], None, ErrorScale::Auto),
            Err(FitError::Singular(_))
        ));
        assert!(matches!(
            linear_fit(
                &[1.0, f64::NAN, 2.0],
                &[1.0, 2.0, 3.0],
                None,
                ErrorScale::Auto
            ),
            Err(FitError::NonFinite {
                what: "x",
                index: 1,
                ..
            })
        ));
        assert!(matches!(
            linear_fit(&[1.0, 2.0], &[1.0, 2.0, 3.0], None, ErrorScale::Auto),
            Err(FitError::LengthMismatch { .. })
        ));
        assert!(matches!(
            linear_fit(
                &[1.0, 2.0, 3.0],
                &[1.0, 2.0, 3.0],
                Some(&[1.0, 0.0, 1.0]),
                ErrorScale::Auto
            ),
            Err(FitError::OutOfRange {
                what: "sigma",
                index: 1,
                ..
            })
        ));
        let e = power_law_fit(&[1.0, 0.0, 2.0], &[1.0, 2.0, 3.0], None, ErrorScale::Auto);
        assert!(matches!(
            e,
            Err(FitError::OutOfRange {
                what: "x",
                index: 1,
                ..
            })
        ));
        let msg = e.unwrap_err().to_string();
        assert!(msg.contains("x[1] = 0") && msg.contains("> 0"), "{msg}");
        assert!(
            power_law_fit(&[1.0, 2.0, 3.0], &[1.0, -2.0, 3.0], None, ErrorScale::Auto).is_err()
        );
        assert!(weighted_mean(&[1.0, 2.0], &[1.0]).is_err());
        assert!(mean_std(&[]).is_err());
    }
}
