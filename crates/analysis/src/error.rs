//! The error type of every fallible routine in this crate, and input validation.

/// Why a fit, extrapolation or statistic could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// Two data arrays that must match in length do not.
    #[error(
        "length mismatch: {what} has {got} entries but {expected} were expected (one per point)"
    )]
    LengthMismatch {
        /// Which array.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The length it must have.
        expected: usize,
    },
    /// Not enough usable points.
    #[error("too few points for {what}: {got} given, at least {needed} needed")]
    TooFewPoints {
        /// What was attempted.
        what: &'static str,
        /// Number of usable points.
        got: usize,
        /// Minimum number.
        needed: usize,
    },
    /// A NaN or infinity in the input.
    #[error("non-finite input: {what}[{index}] = {value}; every value must be finite")]
    NonFinite {
        /// Which array.
        what: &'static str,
        /// Index of the offending entry.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A data value outside the domain the method accepts.
    #[error("{what}[{index}] = {value} is out of range: it must be {allowed}")]
    OutOfRange {
        /// Which array.
        what: &'static str,
        /// Index of the offending entry.
        index: usize,
        /// The value.
        value: f64,
        /// The allowed range, in words.
        allowed: &'static str,
    },
    /// A scalar argument outside its allowed range.
    #[error("invalid argument {name} = {value}: it must be {allowed}")]
    InvalidArgument {
        /// Argument name.
        name: &'static str,
        /// The value.
        value: f64,
        /// The allowed range, in words.
        allowed: &'static str,
    },
    /// The design matrix has (numerically) dependent columns: the parameters are not determined.
    #[error("singular problem: {0}")]
    Singular(String),
    /// No usable starting point could be derived from the data.
    #[error("no initial guess: {0}")]
    NoInitialGuess(String),
    /// The Levenberg–Marquardt solver (MPFIT) refused or failed.
    #[error("nonlinear fit failed: {0}")]
    Solver(String),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, FitError>;

/// Checks that `v` is all finite.
pub(crate) fn check_finite(what: &'static str, v: &[f64]) -> Result<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(FitError::NonFinite {
            what,
            index,
            value: v[index],
        }),
        None => Ok(()),
    }
}

/// Checks lengths and finiteness of `(x, y, sigma)`, positivity of `sigma`, and `n ≥ needed`.
pub(crate) fn check_xy(
    what: &'static str,
    x: &[f64],
    y: &[f64],
    sigma: Option<&[f64]>,
    needed: usize,
) -> Result<()> {
    if y.len() != x.len() {
        return Err(FitError::LengthMismatch {
            what: "y",
            got: y.len(),
            expected: x.len(),
        });
    }
    if let Some(s) = sigma
        && s.len() != x.len()
    {
        return Err(FitError::LengthMismatch {
            what: "sigma",
            got: s.len(),
            expected: x.len(),
        });
    }
    if x.len() < needed {
        return Err(FitError::TooFewPoints {
            what,
            got: x.len(),
            needed,
        });
    }
    check_finite("x", x)?;
    check_finite("y", y)?;
    if let Some(s) = sigma {
        check_finite("sigma", s)?;
        if let Some(index) = s.iter().position(|&v| v <= 0.0) {
            return Err(FitError::OutOfRange {
                what: "sigma",
                index,
                value: s[index],
                allowed: "> 0",
            });
        }
    }
    Ok(())
}

/// Checks that a scalar argument is finite.
pub(crate) fn check_arg(
    name: &'static str,
    value: f64,
    allowed: &'static str,
    ok: bool,
) -> Result<()> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(FitError::InvalidArgument {
            name,
            value,
            allowed,
        })
    }
}
