//! General nonlinear least squares through `rmpfit` (MPFIT, Levenberg–Marquardt).

use crate::error::{FitError, Result, check_finite, check_xy};
use crate::fit::{ErrorScale, FitResult, FitStatus};
use rmpfit::{MPConfig, MPError, MPFitter, MPMaxFev, MPPar, MPResult, MPSuccess};

/// Constraints on one parameter of a nonlinear fit.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ParamSpec {
    /// Hold the parameter at its starting value.
    pub fixed: bool,
    /// Lower bound, if any.
    pub lower: Option<f64>,
    /// Upper bound, if any.
    pub upper: Option<f64>,
}

impl ParamSpec {
    /// A free, unbounded parameter.
    pub const FREE: ParamSpec = ParamSpec {
        fixed: false,
        lower: None,
        upper: None,
    };
    /// A fixed parameter.
    pub const FIXED: ParamSpec = ParamSpec {
        fixed: true,
        lower: None,
        upper: None,
    };
    /// A free parameter bounded below.
    pub fn at_least(lower: f64) -> Self {
        ParamSpec {
            fixed: false,
            lower: Some(lower),
            upper: None,
        }
    }
}

/// Options of [`nonlinear_fit`].
#[derive(Clone, Debug, PartialEq)]
pub struct NonlinearOptions {
    /// Per-parameter constraints; empty means all free. Otherwise one entry per parameter.
    pub params: Vec<ParamSpec>,
    /// Error-bar convention.
    pub scale: ErrorScale,
    /// Maximum Levenberg–Marquardt iterations.
    pub max_iter: usize,
    /// Maximum model evaluations over all points (each evaluation computes all residuals).
    pub max_evaluations: usize,
    /// Relative tolerance on χ² and on the parameters (MPFIT's `ftol` and `xtol`).
    pub tol: f64,
    /// Names of the parameters (for [`FitResult::names`]); empty gives `p0, p1, …`.
    pub names: Vec<&'static str>,
}

impl Default for NonlinearOptions {
    fn default() -> Self {
        NonlinearOptions {
            params: Vec::new(),
            scale: ErrorScale::Auto,
            max_iter: 500,
            max_evaluations: 20_000,
            tol: 1e-10,
            names: Vec::new(),
        }
    }
}

struct Problem<'a, F> {
    model: F,
    x: &'a [f64],
    y: &'a [f64],
    w: Vec<f64>,
    pars: Vec<MPPar>,
    config: MPConfig,
}

impl<F: Fn(f64, &[f64]) -> f64> MPFitter for Problem<'_, F> {
    fn eval(&mut self, params: &[f64], deviates: &mut [f64]) -> MPResult<()> {
        for (((d, &x), &y), &w) in deviates.iter_mut().zip(self.x).zip(self.y).zip(&self.w) {
            *d = (y - (self.model)(x, params)) * w;
        }
        Ok(())
    }

    fn number_of_points(&self) -> usize {
        self.x.len()
    }

    fn config(&self) -> &MPConfig {
        &self.config
    }

    fn parameters(&self) -> &[MPPar] {
        &self.pars
    }
}

fn mp_error_text(e: &MPError) -> String {
    match e {
        MPError::Input => "invalid input (MPFIT Input)".into(),
        MPError::Nan => "the model produced non-finite values at the trial parameters".into(),
        MPError::Empty => "no data points".into(),
        MPError::NoFree => "no free parameters".into(),
        MPError::InitBounds => "a starting value lies outside its bounds".into(),
        MPError::Bounds => "inconsistent bounds (lower > upper)".into(),
        MPError::DoF => "fewer points than free parameters".into(),
        MPError::Eval => "the model evaluation failed".into(),
    }
}

/// Fits `y ≈ model(x, p)` by weighted nonlinear least squares (MPFIT), starting from `p0`.
///
/// Returns parameters, 1σ errors and covariance (scaled as `opts.scale` says, see
/// [`ErrorScale`]), χ², dof = points − free parameters, and the solver status. A fit that stops
/// at the iteration limit is returned with `status.converged == false`: check it.
///
/// Errors: input validation (lengths, non-finite values, σ ≤ 0, fewer points than free
/// parameters, bad constraints), a model that is not finite at `p0`, or MPFIT refusing the
/// problem.
pub fn nonlinear_fit<F: Fn(f64, &[f64]) -> f64>(
    model: F,
    x: &[f64],
    y: &[f64],
    sigma: Option<&[f64]>,
    p0: &[f64],
    opts: &NonlinearOptions,
) -> Result<FitResult> {
    let k = p0.len();
    if k == 0 {
        return Err(FitError::InvalidArgument {
            name: "number of parameters",
            value: 0.0,
            allowed: "at least 1",
        });
    }
    check_finite("p0", p0)?;
    let specs: Vec<ParamSpec> = if opts.params.is_empty() {
        vec![ParamSpec::FREE; k]
    } else if opts.params.len() == k {
        opts.params.clone()
    } else {
        return Err(FitError::LengthMismatch {
            what: "opts.params",
            got: opts.params.len(),
            expected: k,
        });
    };
    if !opts.names.is_empty() && opts.names.len() != k {
        return Err(FitError::LengthMismatch {
            what: "opts.names",
            got: opts.names.len(),
            expected: k,
        });
    }
    let n_free = specs.iter().filter(|s| !s.fixed).count();
    if n_free == 0 {
        return Err(FitError::InvalidArgument {
            name: "number of free parameters",
            value: 0.0,
            allowed: "at least 1",
        });
    }
    check_xy("a nonlinear fit", x, y, sigma, n_free)?;
    for (i, s) in specs.iter().enumerate() {
        if let (Some(lo), Some(hi)) = (s.lower, s.upper)
            && lo > hi
        {
            return Err(FitError::InvalidArgument {
                name: "lower bound (greater than the upper bound)",
                value: lo,
                allowed: "<= the upper bound",
            });
        }
        let v = p0[i];
        if s.lower.is_some_and(|lo| v < lo) || s.upper.is_some_and(|hi| v > hi) {
            return Err(FitError::InvalidArgument {
                name: "p0 (outside its bounds)",
                value: v,
                allowed: "within the parameter's bounds",
            });
        }
    }
    for (i, &xi) in x.iter().enumerate() {
        let v = model(xi, p0);
        if !v.is_finite() {
            return Err(FitError::NonFinite {
                what: "model(x, p0)",
                index: i,
                value: v,
            });
        }
    }
    let pars: Vec<MPPar> = specs
        .iter()
        .map(|s| {
            let mut p = MPPar::new();
            p.fixed = s.fixed;
            if let Some(lo) = s.lower {
                p.limited_low = true;
                p.limit_low = lo;
            }
            if let Some(hi) = s.upper {
                p.limited_up = true;
                p.limit_up = hi;
            }
            p
        })
        .collect();
    let mut config = MPConfig::new();
    config.max_iter = opts.max_iter;
    config.max_fev = MPMaxFev::Limited(opts.max_evaluations.max(1));
    config.ftol = opts.tol;
    config.xtol = opts.tol;
    let mut problem = Problem {
        model,
        x,
        y,
        w: crate::linear::weights(sigma, x.len()),
        pars,
        config,
    };
    let mut params = p0.to_vec();
    let st = problem
        .mpfit(&mut params)
        .map_err(|e| FitError::Solver(mp_error_text(&e)))?;
    let converged = !matches!(st.success, MPSuccess::NotDone | MPSuccess::MaxIter);
    let cov: Vec<Vec<f64>> = (0..k)
        .map(|i| (0..k).map(|j| st.covar[i * k + j]).collect())
        .collect();
    let status = FitStatus {
        converged,
        iterations: st.n_iter,
        evaluations: st.n_fev,
        pegged: st.n_pegged,
        message: format!("{}", st.success),
    };
    let names = if opts.names.is_empty() {
        const P: [&str; 10] = ["p0", "p1", "p2", "p3", "p4", "p5", "p6", "p7", "p8", "p9"];
        (0..k).map(|i| P.get(i).copied().unwrap_or("p")).collect()
    } else {
        opts.names.clone()
    };
    FitResult::assemble(
        names,
        params,
        cov,
        st.best_norm,
        x.len() - n_free,
        n_free,
        opts.scale,
        sigma.is_some(),
        status,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exponential_decay_exact() {
        let x: Vec<f64> = (0..20).map(|i| i as f64 * 0.2).collect();
        let y: Vec<f64> = x.iter().map(|t| 3.0 * (-1.5 * t).exp() + 0.1).collect();
        let f = nonlinear_fit(
            |t, p| p[0] * (-p[1] * t).exp() + p[2],
            &x,
            &y,
            Some(&[0.01; 20]),
            &[1.0, 1.0, 0.0],
            &NonlinearOptions::default(),
        )
        .unwrap();
        assert!(f.status.converged, "{:?}", f.status);
        for (p, t) in f.params.iter().zip([3.0, 1.5, 0.1]) {
            assert!((p - t).abs() < 1e-7, "{p} vs {t}");
        }
        assert_eq!(f.dof, 17);
        assert_eq!(f.error_scale, ErrorScale::Absolute);
    }

    #[test]
    fn fixed_parameter_and_bad_inputs() {
        let x = [1.0, 2.0, 3.0, 4.0];
        let y = [2.0, 4.1, 5.9, 8.0];
        let opts = NonlinearOptions {
            params: vec![ParamSpec::FIXED, ParamSpec::FREE],
            ..Default::default()
        };
        let f = nonlinear_fit(|t, p| p[0] + p[1] * t, &x, &y, None, &[0.0, 1.0], &opts).unwrap();
        assert_eq!(f.params[0], 0.0);
        assert_eq!(f.errors[0], 0.0);
        assert_eq!(f.dof, 3);
        assert!(
            nonlinear_fit(
                |t, p| p[0] * t,
                &x[..0],
                &y[..0],
                None,
                &[1.0],
                &Default::default()
            )
            .is_err()
        );
        assert!(matches!(
            nonlinear_fit(
                |t, p| p[0] / (t - 2.0),
                &x,
                &y,
                None,
                &[1.0],
                &Default::default()
            ),
            Err(FitError::NonFinite {
                what: "model(x, p0)",
                index: 1,
                ..
            })
        ));
        let opts = NonlinearOptions {
            params: vec![ParamSpec::at_least(1.0)],
            ..Default::default()
        };
        assert!(nonlinear_fit(|t, p| p[0] * t, &x, &y, None, &[0.0], &opts).is_err());
    }
}
