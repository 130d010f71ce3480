//! The common result type of all least-squares fits and the error-bar convention.

/// How the 1σ parameter errors are derived from the covariance.
///
/// The covariance `C = (Jᵀ W J)⁻¹` (with `W = diag(1/σᵢ²)`, `J` the model's Jacobian at the
/// optimum) is the parameter covariance *if the σᵢ are the true standard deviations of the data*.
/// - [`ErrorScale::Absolute`] reports `sqrt(C_ii)`: use it when the σᵢ are known.
/// - [`ErrorScale::ReducedChi2`] reports `sqrt(C_ii · χ²/dof)`: the residual scatter at the
///   optimum sets the noise level. Use it when the σᵢ are unknown or only relative, and for
///   noise-free simulation data, where the "noise" is the misfit of the model.
/// - [`ErrorScale::Auto`] means `Absolute` when σ is given and `ReducedChi2` when it is not (with
///   no σ, unit weights carry no information about the noise).
///
/// `ReducedChi2` needs `dof ≥ 1`; a fit that would need it with `dof = 0` fails with
/// [`crate::FitError::TooFewPoints`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ErrorScale {
    /// `Absolute` with σ, `ReducedChi2` without.
    #[default]
    Auto,
    /// Errors from the covariance as is (σ taken as true standard deviations).
    Absolute,
    /// Errors from the covariance scaled by the reduced χ².
    ReducedChi2,
}

impl ErrorScale {
    /// The concrete choice for data with (`true`) or without (`false`) σ.
    pub fn resolve(self, has_sigma: bool) -> ErrorScale {
        match self {
            ErrorScale::Auto if has_sigma => ErrorScale::Absolute,
            ErrorScale::Auto => ErrorScale::ReducedChi2,
            other => other,
        }
    }
}

/// How an iterative fit ended.
#[derive(Clone, Debug, PartialEq)]
pub struct FitStatus {
    /// The solver reports convergence (χ², parameter or orthogonality criterion met, or no
    /// further improvement possible at machine precision). Always `true` for linear fits.
    pub converged: bool,
    /// Solver iterations (0 for linear fits).
    pub iterations: usize,
    /// Model evaluations (0 for linear fits).
    pub evaluations: usize,
    /// Parameters stuck at a bound (their errors are reported as 0, as MPFIT does).
    pub pegged: usize,
    /// The solver's own word on how it ended.
    pub message: String,
}

impl FitStatus {
    pub(crate) fn linear() -> Self {
        FitStatus {
            converged: true,
            iterations: 0,
            evaluations: 0,
            pegged: 0,
            message: "linear least squares (exact solution)".into(),
        }
    }
}

/// Parameters, 1σ errors and covariance of a least-squares fit.
#[derive(Clone, Debug, PartialEq)]
pub struct FitResult {
    /// Parameter names, in order.
    pub names: Vec<&'static str>,
    /// Best-fit values.
    pub params: Vec<f64>,
    /// 1σ errors: `sqrt(covariance[i][i])` (0 for fixed and pegged parameters).
    pub errors: Vec<f64>,
    /// Parameter covariance, already scaled as `error_scale` says.
    pub covariance: Vec<Vec<f64>>,
    /// `Σ ((yᵢ − f(xᵢ))/σᵢ)²` (σᵢ = 1 without σ).
    pub chi2: f64,
    /// Degrees of freedom: points − free parameters.
    pub dof: usize,
    /// How `errors` were derived (never `Auto`).
    pub error_scale: ErrorScale,
    /// The factor applied to the unscaled covariance: 1 or χ²/dof.
    pub covariance_factor: f64,
    /// How the solver ended.
    pub status: FitStatus,
}

impl FitResult {
    /// `χ²/dof` (NaN for `dof = 0`).
    pub fn reduced_chi2(&self) -> f64 {
        if self.dof == 0 {
            f64::NAN
        } else {
            self.chi2 / self.dof as f64
        }
    }

    /// Value and 1σ error of the parameter called `name`.
    pub fn get(&self, name: &str) -> Option<(f64, f64)> {
        let i = self.names.iter().position(|n| *n == name)?;
        Some((self.params[i], self.errors[i]))
    }

    /// Correlation coefficient of parameters `i` and `j` (NaN if either has zero error).
    pub fn correlation(&self, i: usize, j: usize) -> f64 {
        let d = self.errors[i] * self.errors[j];
        if d > 0.0 {
            self.covariance[i][j] / d
        } else {
            f64::NAN
        }
    }

    /// Builds a result from an unscaled covariance, applying the error-scale convention.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn assemble(
        names: Vec<&'static str>,
        params: Vec<f64>,
        unscaled_cov: Vec<Vec<f64>>,
        chi2: f64,
        dof: usize,
        n_free: usize,
        scale: ErrorScale,
        has_sigma: bool,
        status: FitStatus,
    ) -> crate::Result<FitResult> {
        let scale = scale.resolve(has_sigma);
        let factor = match scale {
            ErrorScale::ReducedChi2 => {
                if dof == 0 {
                    return Err(crate::FitError::TooFewPoints {
                        what: "errors scaled by the reduced chi-square (needs dof >= 1)",
                        got: dof + n_free,
                        needed: n_free + 1,
                    });
                }
                chi2 / dof as f64
            }
            _ => 1.0,
        };
        let covariance: Vec<Vec<f64>> = unscaled_cov
            .into_iter()
            .map(|row| row.into_iter().map(|c| c * factor).collect())
            .collect();
        let errors = (0..params.len())
            .map(|i| covariance[i][i].max(0.0).sqrt())
            .collect();
        Ok(FitResult {
            names,
            params,
            errors,
            covariance,
            chi2,
            dof,
            error_scale: scale,
            covariance_factor: factor,
            status,
        })
    }
}
