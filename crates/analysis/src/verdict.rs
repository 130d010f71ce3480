//! Verdicts: is a measured value (± 1σ) consistent with a conjectured one? And error propagation
//! through linear identities such as β = 3ζ + υ − χ.
//!
//! # Convention
//! The error is taken as the standard deviation of a Gaussian. The distance is
//! `n_σ = |value − conjecture| / error`; the two-sided probability of a deviation at least that
//! large is `p = erfc(n_σ/√2)`. A value is **consistent** if `n_σ ≤ threshold` (default 2, i.e.
//! the conjecture lies inside the 95.45 % interval); otherwise it is **inconsistent at confidence
//! 1 − p** (e.g. 3σ: 99.73 %). The error bar of an asymptotic estimate includes systematic
//! spreads (fit range and form, [`crate::asymptotic_estimate`]), so the Gaussian reading is an
//! approximation; the verdict text states the number of σ so that the reader can judge.
//!
//! [`linear_combination`] propagates independent 1σ errors in quadrature:
//! `σ² = Σ cᵢ² σᵢ²`. Correlations (e.g. ζ and υ measured on the same solves, sharing L_c) are
//! not included; where they matter the caller should measure the combination directly too (β
//! from the flux), which is what the identity check is for.

use crate::error::{FitError, Result, check_arg};

/// A value with its 1σ error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// The value.
    pub value: f64,
    /// 1σ, ≥ 0.
    pub error: f64,
}

impl Estimate {
    /// A value with its error.
    pub fn new(value: f64, error: f64) -> Self {
        Estimate { value, error }
    }
}

/// `Σ cᵢ xᵢ` with independent errors in quadrature (module docs). Errors: an empty list, or a
/// non-finite coefficient, value or error, or a negative error.
pub fn linear_combination(terms: &[(f64, Estimate)]) -> Result<Estimate> {
    if terms.is_empty() {
        return Err(FitError::TooFewPoints {
            what: "a linear combination",
            got: 0,
            needed: 1,
        });
    }
    for (c, e) in terms {
        check_arg("coefficient", *c, "finite", true)?;
        check_arg("value", e.value, "finite", true)?;
        check_arg("error", e.error, "finite and ≥ 0", e.error >= 0.0)?;
    }
    Ok(Estimate {
        value: terms.iter().map(|(c, e)| c * e.value).sum(),
        error: terms
            .iter()
            .map(|(c, e)| (c * e.error).powi(2))
            .sum::<f64>()
            .sqrt(),
    })
}

/// The scaling identity β = 3ζ + υ − χ with the errors propagated (module docs).
pub fn beta_identity(zeta: Estimate, upsilon: Estimate, chi: Estimate) -> Result<Estimate> {
    linear_combination(&[(3.0, zeta), (1.0, upsilon), (-1.0, chi)])
}

/// The comparison of a measurement with a conjecture.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    /// |value − conjecture| / error.
    pub sigmas: f64,
    /// Two-sided probability of a deviation at least this large: erfc(n_σ/√2).
    pub p_value: f64,
    /// `sigmas ≤ threshold`.
    pub consistent: bool,
    /// The threshold (σ).
    pub threshold: f64,
    /// One line for tables and reports.
    pub text: String,
}

/// Compares `measured` with `conjecture` (named `label`, e.g. "6/5") at `threshold` σ (module
/// docs). Errors: a non-finite value or conjecture, an error that is not finite and > 0, or a
/// threshold that is not finite and > 0.
pub fn verdict(
    measured: Estimate,
    conjecture: f64,
    label: &str,
    threshold: f64,
) -> Result<Verdict> {
    check_arg("value", measured.value, "finite", true)?;
    check_arg(
        "error",
        measured.error,
        "finite and > 0 (a verdict needs an error bar)",
        measured.error > 0.0,
    )?;
    check_arg("conjecture", conjecture, "finite", true)?;
    check_arg("threshold", threshold, "finite and > 0", threshold > 0.0)?;
    let sigmas = (measured.value - conjecture).abs() / measured.error;
    let p_value = libm::erfc(sigmas / std::f64::consts::SQRT_2);
    let inside = 100.0 * libm::erf(threshold / std::f64::consts::SQRT_2);
    let consistent = sigmas <= threshold;
    let text = if consistent {
        format!(
            "consistent with {label}: {:.4} ± {:.4} is {sigmas:.1}σ away (within {threshold}σ, \
             the {inside:.2} % interval)",
            measured.value, measured.error
        )
    } else {
        // two decimals of the confidence, until they would round to 100 %
        let confidence = if p_value >= 5e-5 {
            format!("{:.2} %", 100.0 * (1.0 - p_value))
        } else {
            "> 99.99 %".to_string()
        };
        format!(
            "inconsistent with {label} at {confidence} confidence (two-sided p = {p_value:.1e}): \
             {:.4} ± {:.4} is {sigmas:.1}σ away (threshold {threshold}σ)",
            measured.value, measured.error
        )
    };
    Ok(Verdict {
        sigmas,
        p_value,
        consistent,
        threshold,
        text,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::SmallRng};

    #[test]
    fn verdict_counts_sigmas_and_states_confidence() {
        let v = verdict(Estimate::new(1.209, 0.005), 1.2, "6/5", 2.0).unwrap();
        assert!((v.sigmas - 1.8).abs() < 1e-9);
        // 1.8σ two-sided: p = erfc(1.8/√2) = 0.0718606 (tables)
        assert!((v.p_value - 0.0718606).abs() < 1e-6, "{}", v.p_value);
        assert!(v.text.contains("95.45 % interval"), "{}", v.text);
        assert!(
            v.consistent && v.text.starts_with("consistent with 6/5"),
            "{}",
            v.text
        );
        let v = verdict(Estimate::new(1.30, 0.02), 1.2, "6/5", 2.0).unwrap();
        assert!((v.sigmas - 5.0).abs() < 1e-9 && !v.consistent);
        // 5σ: 1 − 5.733e-7
        assert!((v.p_value - 5.733e-7).abs() < 1e-9, "{}", v.p_value);
        assert!(
            v.text
                .contains("inconsistent with 6/5 at > 99.99 % confidence (two-sided p = 5.7e-7)"),
            "{}",
            v.text
        );
        let v = verdict(Estimate::new(0.45, 0.01), 0.48, "9/20", 2.0).unwrap();
        assert!(
            v.text
                .contains("at 99.73 % confidence (two-sided p = 2.7e-3)")
                && v.text.contains("3.0σ"),
            "{}",
            v.text
        );
        let e = verdict(Estimate::new(1.2, 0.0), 1.2, "6/5", 2.0).unwrap_err();
        assert!(e.to_string().contains("error = 0"), "{e}");
        assert!(verdict(Estimate::new(1.2, 0.1), f64::NAN, "?", 2.0).is_err());
        assert!(verdict(Estimate::new(1.2, 0.1), 1.2, "?", 0.0).is_err());
    }

    #[test]
    fn beta_identity_propagates_errors() {
        let (z, u, c) = (
            Estimate::new(1.2, 0.004),
            Estimate::new(0.45, 0.003),
            Estimate::new(0.6, 0.005),
        );
        let b = beta_identity(z, u, c).unwrap();
        assert!((b.value - 3.45).abs() < 1e-12);
        // σ² = 9·0.004² + 0.003² + 0.005² = 1.78e-4
        assert!((b.error - 1.78e-4f64.sqrt()).abs() < 1e-15);
        // independent check: the standard deviation of 3ζ + υ − χ over Gaussian samples. With
        // 200 000 samples the sample σ has a relative standard error 1/sqrt(2N) = 0.16 %, so
        // 1 % is > 6 standard errors
        let mut rng = SmallRng::seed_from_u64(7);
        let mut gauss = |e: Estimate| {
            let (a, b): (f64, f64) = (rng.random(), rng.random());
            e.value
                + e.error * (-2.0 * (1.0 - a).ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
        };
        let n = 200_000;
        let s: Vec<f64> = (0..n)
            .map(|_| 3.0 * gauss(z) + gauss(u) - gauss(c))
            .collect();
        let (m, sd) = crate::mean_std(&s).unwrap();
        assert!((m - 3.45).abs() < 5.0 * b.error / (n as f64).sqrt(), "{m}");
        assert!((sd / b.error - 1.0).abs() < 0.01, "{sd} vs {}", b.error);
        assert!(linear_combination(&[]).is_err());
        assert!(beta_identity(Estimate::new(1.2, -0.1), u, c).is_err());
    }
}
