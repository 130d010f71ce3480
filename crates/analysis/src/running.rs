//! Running (local) exponents of a near-critical power law `y ∝ |l|^x` and their grid errors.
//!
//! # Layout and units
//! A ladder is a slice of [`ScalingPoint`]s `(l, y, σ_y)`: `l` the signed reduced load
//! (L − L_c)/L_c (all points of one ladder on the same side of L_c), `y > 0` the measured
//! quantity (saddle gap, channel width or length, flux; any unit) and `σ_y ≥ 0` the 1σ error of
//! the measurement itself (0 if it has none). Pairs are formed between neighbours in |l|.
//!
//! # What is computed
//! - The **local slope** of a pair of neighbouring rungs, ordered so that `l_hi` is the rung
//!   farther from L_c (larger |l|) and `l_lo` the nearer one:
//!   `x_eff = (ln y_hi − ln y_lo) / (ln |l_hi| − ln |l_lo|)`, exact for a pure power law. With
//!   corrections to scaling `y = A |l|^x (1 + B |l|^ω)` it equals, to first order in B,
//!   `x + ωB · u_ω` with `u_ω = (|l_hi|^ω − |l_lo|^ω)/(ω ln(|l_hi|/|l_lo|))`
//!   ([`RunningSlope::u_omega`]; `u_ω → |l|^ω` at the pair's geometric mean for close rungs).
//!   Its **fit error** propagates the σ_y of both rungs (independent, first order):
//!   `σ_x = sqrt((σ_hi/y_hi)² + (σ_lo/y_lo)²) / |ln(|l_hi|/|l_lo|)|`.
//! - The **grid error** of a pair: `|x_eff(finest) − x_eff(next coarser resolution)|` for the
//!   same two loads ([`running_exponents`]), the change between the two finest resolutions. It is
//!   an estimate of the discretisation error of the finer value, not a bound: it is honest only
//!   while the grid error decreases with the spacing, which the caller checks with a third
//!   resolution where one exists.
//! - A pair whose grid error exceeds `bound` (default [`DEFAULT_GRID_BOUND`] = 0.005), or whose
//!   grid error is unknown (no coarser measurement of the same pair), is **flagged**
//!   ([`SlopeFlag`]): the caller refines further or reports it flagged, never uses it silently.
//!
//! Cost: O(n log n) in the number of rungs (one sort). Exact arithmetic apart from rounding; no
//! approximation but the first-order error propagation.

use crate::error::{FitError, Result, check_arg};

/// Default bound on the grid error of a running exponent (the aim: 0.005).
pub const DEFAULT_GRID_BOUND: f64 = 0.005;

/// One rung of a ladder: a measured quantity at a reduced load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalingPoint {
    /// Signed reduced load (L − L_c)/L_c, ≠ 0.
    pub l: f64,
    /// The measured quantity, > 0.
    pub y: f64,
    /// 1σ error of `y` from the measurement itself, ≥ 0 (0: none known).
    pub sigma: f64,
}

impl ScalingPoint {
    /// A point; see the field docs for the allowed ranges (checked where it is used).
    pub fn new(l: f64, y: f64, sigma: f64) -> Self {
        ScalingPoint { l, y, sigma }
    }
}

/// The local slope of one pair of neighbouring rungs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunningSlope {
    /// The rung farther from L_c (larger |l|), signed.
    pub l_hi: f64,
    /// The rung nearer L_c (smaller |l|), signed.
    pub l_lo: f64,
    /// d ln y / d ln |l| between the two rungs.
    pub value: f64,
    /// 1σ of `value` propagated from the rungs' σ_y.
    pub fit_error: f64,
}

impl RunningSlope {
    /// Geometric mean of |l_hi| and |l_lo|: where the secant slope best approximates the local
    /// derivative (to second order in the log spacing).
    pub fn l_mid(&self) -> f64 {
        (self.l_hi.abs() * self.l_lo.abs()).sqrt()
    }

    /// `(|l_hi|^ω − |l_lo|^ω)/(ω ln(|l_hi|/|l_lo|))`: the regressor against which the slope is
    /// linear, `x_eff = x + ωB u_ω + O(B²)`, for `y = A|l|^x (1 + B|l|^ω)` (module docs).
    pub fn u_omega(&self, omega: f64) -> f64 {
        let (a, b) = (self.l_hi.abs(), self.l_lo.abs());
        (a.powf(omega) - b.powf(omega)) / (omega * (a / b).ln())
    }
}

/// Why a running exponent must not be used as it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SlopeFlag {
    /// The change between the two finest resolutions exceeds the bound.
    GridError {
        /// The grid error.
        error: f64,
        /// The bound.
        bound: f64,
    },
    /// No coarser resolution measured this pair: the grid error is unknown.
    NoCoarse,
    /// The same exponent measured along the other grid axis (β: the flux across, which the
    /// continuum's symmetry makes equal) differs by more than the bound, or was not measured
    /// for this pair (`error` NaN): the discretisation is anisotropic here.
    Anisotropy {
        /// |value along − value across| (NaN if not measured across).
        error: f64,
        /// The bound.
        bound: f64,
    },
}

impl std::fmt::Display for SlopeFlag {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SlopeFlag::GridError { error, bound } => write!(
                f,
                "grid error {error:.2e} exceeds the bound {bound:.2e}: refine further"
            ),
            SlopeFlag::NoCoarse => write!(
                f,
                "no coarser resolution measured this pair: grid error unknown"
            ),
            SlopeFlag::Anisotropy { error, bound } if error.is_nan() => write!(
                f,
                "not measured along the other axis (bound {bound:.2e}): isotropy unchecked"
            ),
            SlopeFlag::Anisotropy { error, bound } => write!(
                f,
                "along and across the grid differ by {error:.2e}, above the bound {bound:.2e}: \
                 the grid is anisotropic here"
            ),
        }
    }
}

/// A running exponent with its two error bars.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunningExponent {
    /// The slope on the finest resolution.
    pub slope: RunningSlope,
    /// |slope(finest) − slope(coarser)| (NaN if unknown).
    pub grid_error: f64,
    /// Set if the value must not be used silently.
    pub flag: Option<SlopeFlag>,
}

/// Checks a ladder and returns it sorted by descending |l| (farthest from L_c first).
fn sorted_ladder(points: &[ScalingPoint]) -> Result<Vec<ScalingPoint>> {
    if points.len() < 2 {
        return Err(FitError::TooFewPoints {
            what: "running exponents (one pair of rungs)",
            got: points.len(),
            needed: 2,
        });
    }
    for (index, p) in points.iter().enumerate() {
        let bad = |what, value, allowed| FitError::OutOfRange {
            what,
            index,
            value,
            allowed,
        };
        if !(p.l.is_finite() && p.l != 0.0) {
            return Err(bad("l", p.l, "finite and ≠ 0 (signed reduced load)"));
        }
        if p.l.signum() != points[0].l.signum() {
            return Err(bad("l", p.l, "on the same side of L_c as l[0]"));
        }
        if !(p.y.is_finite() && p.y > 0.0) {
            return Err(bad("y", p.y, "finite and > 0"));
        }
        if !(p.sigma.is_finite() && p.sigma >= 0.0) {
            return Err(bad("sigma", p.sigma, "finite and ≥ 0"));
        }
    }
    let mut v = points.to_vec();
    v.sort_by(|a, b| b.l.abs().total_cmp(&a.l.abs()));
    if let Some(k) = v.windows(2).position(|w| w[0].l == w[1].l) {
        return Err(FitError::OutOfRange {
            what: "l (sorted by |l|)",
            index: k + 1,
            value: v[k].l,
            allowed: "distinct reduced loads",
        });
    }
    Ok(v)
}

/// The local slopes between neighbouring rungs (module docs), ordered from the rung farthest
/// from L_c inward. Errors: fewer than 2 points, l = 0 or of mixed sign, repeated l, y ≤ 0,
/// σ < 0, or a non-finite value.
pub fn local_slopes(points: &[ScalingPoint]) -> Result<Vec<RunningSlope>> {
    let v = sorted_ladder(points)?;
    Ok(v.windows(2)
        .map(|w| {
            let (hi, lo) = (w[0], w[1]);
            let dl = (hi.l.abs() / lo.l.abs()).ln();
            RunningSlope {
                l_hi: hi.l,
                l_lo: lo.l,
                value: (hi.y / lo.y).ln() / dl,
                fit_error: (hi.sigma / hi.y).hypot(lo.sigma / lo.y) / dl,
            }
        })
        .collect())
}

/// Two reduced loads (or distances to L_c) are the same rung: equal to a relative 1e-9 (the
/// ladders' loads are parameters written in decimal; this tells them apart from rounding of
/// products such as p_c (1 + l) without merging neighbouring rungs, which differ by ≥ 2×).
pub fn same_load(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

/// Running exponents of the finest resolution `fine`, each with its grid error against the
/// next coarser resolution `coarse` (the same pair of loads, matched to a relative 1e-9) and
/// flagged as the module docs say. `coarse = None` flags every pair ([`SlopeFlag::NoCoarse`]).
/// Errors: those of [`local_slopes`] for either ladder, or a bound that is not finite and > 0.
pub fn running_exponents(
    fine: &[ScalingPoint],
    coarse: Option<&[ScalingPoint]>,
    bound: f64,
) -> Result<Vec<RunningExponent>> {
    check_arg("bound", bound, "finite and > 0", bound > 0.0)?;
    let fine = local_slopes(fine)?;
    let coarse = coarse.map(local_slopes).transpose()?.unwrap_or_default();
    Ok(fine
        .into_iter()
        .map(|s| {
            let c = coarse
                .iter()
                .find(|c| same_load(c.l_hi, s.l_hi) && same_load(c.l_lo, s.l_lo));
            let grid_error = c.map_or(f64::NAN, |c| (s.value - c.value).abs());
            let flag = match c {
                None => Some(SlopeFlag::NoCoarse),
                Some(_) if grid_error > bound => Some(SlopeFlag::GridError {
                    error: grid_error,
                    bound,
                }),
                Some(_) => None,
            };
            RunningExponent {
                slope: s,
                grid_error,
                flag,
            }
        })
        .collect())
}

/// The rungs of `fine` that an asymptotic fit may use: from the largest |l| inward, up to the
/// first pair that [`running_exponents`] flags (its nearer rung and everything beyond it left
/// out), sorted by descending |l|. Stopping at the first flag rather than skipping flagged pairs
/// is deliberate: grid errors grow towards L_c, and a rung after a flagged pair is suspect even
/// if its own pair passes. Errors as [`running_exponents`].
pub fn grid_converged_rungs(
    fine: &[ScalingPoint],
    coarse: Option<&[ScalingPoint]>,
    bound: f64,
) -> Result<Vec<ScalingPoint>> {
    let pairs = running_exponents(fine, coarse, bound)?;
    let keep = 1 + pairs.iter().take_while(|p| p.flag.is_none()).count();
    let mut v = sorted_ladder(fine)?;
    v.truncate(keep);
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default ladder: |l| = 5e-2 … 1e-5 in a 1-2-5 sequence.
    fn ladder() -> Vec<f64> {
        let mut v = Vec::new();
        for d in [1e-2, 1e-3, 1e-4] {
            v.extend([5.0 * d, 2.0 * d, d]);
        }
        v.extend([5e-5, 2e-5, 1e-5]);
        v
    }

    #[test]
    fn pure_power_law_has_flat_slopes() {
        // exact up to rounding: ln y differs by x ln(|l_hi|/|l_lo|) exactly
        let pts: Vec<ScalingPoint> = ladder()
            .iter()
            .map(|&a| ScalingPoint::new(-a, 0.7 * a.powf(1.2), 0.0))
            .collect();
        let s = local_slopes(&pts).unwrap();
        assert_eq!(s.len(), 11);
        for r in &s {
            assert!((r.value - 1.2).abs() < 1e-12, "{r:?}");
            assert_eq!(r.fit_error, 0.0);
            assert!(
                r.l_hi < r.l_lo && r.l_lo < 0.0,
                "signed, l_hi farther from L_c"
            );
        }
        assert_eq!((s[0].l_hi, s[0].l_lo), (-5e-2, -2e-2));
    }

    #[test]
    fn corrections_make_the_slope_run_as_predicted() {
        // y = A|l|^x (1 + B|l|^ω): the secant slope is x + ωB u_ω to first order in B; the
        // remainder is O(B² |l|^2ω) = O(0.3² · 0.05) ≈ 5e-3 at the largest |l|, ≪ ωB u_ω
        let (x, b, w) = (1.2, 0.3, 0.5);
        let pts: Vec<ScalingPoint> = ladder()
            .iter()
            .map(|&a| ScalingPoint::new(-a, a.powf(x) * (1.0 + b * a.powf(w)), 0.0))
            .collect();
        for s in local_slopes(&pts).unwrap() {
            let first = x + w * b * s.u_omega(w);
            let bound = (b * s.l_hi.abs().powf(w)).powi(2);
            assert!((s.value - first).abs() < bound, "{s:?}: {first}");
            assert!(s.value > x, "a positive B makes the slope larger than x");
        }
    }

    #[test]
    fn fit_error_propagates_sigma() {
        // one rung with 1 % relative error, the other exact, spaced by a factor 2.5 in |l|
        let pts = [
            ScalingPoint::new(-5e-3, 2.0, 0.02),
            ScalingPoint::new(-2e-3, 1.0, 0.0),
        ];
        let s = local_slopes(&pts).unwrap()[0];
        assert!((s.fit_error - 0.01 / 2.5f64.ln()).abs() < 1e-15);
        assert!((s.value - 2f64.ln() / 2.5f64.ln()).abs() < 1e-15);
        // and it is the standard deviation of the slope under that noise (finite differences)
        let dy = 1e-6;
        let up = local_slopes(&[ScalingPoint::new(-5e-3, 2.0 + dy, 0.0), pts[1]]).unwrap()[0];
        assert!(((up.value - s.value) / dy * 0.02 - s.fit_error).abs() < 1e-8);
    }

    #[test]
    fn grid_error_is_the_change_between_resolutions_and_flags() {
        let ls = [-1e-2, -5e-3, -2e-3, -1e-3];
        let fine: Vec<ScalingPoint> = ls
            .iter()
            .map(|&l: &f64| ScalingPoint::new(l, l.abs().powf(1.2), 0.0))
            .collect();
        // the coarse grid's slope deviates by d = 0.001, 0.004, 0.009 on the three pairs (a
        // discretisation error growing towards L_c): build it by integrating ln y pair by pair
        let d = [0.001, 0.004, 0.009];
        let mut coarse = vec![fine[0]];
        for k in 0..3 {
            let step = (ls[k] / ls[k + 1]).ln();
            let y = coarse[k].y * (-(1.2 + d[k]) * step).exp();
            coarse.push(ScalingPoint::new(ls[k + 1], y, 0.0));
        }
        let r = running_exponents(&fine, Some(&coarse), DEFAULT_GRID_BOUND).unwrap();
        for (e, d) in r.iter().zip(d) {
            assert!((e.grid_error - d).abs() < 1e-12, "{e:?}");
        }
        assert!(r[0].flag.is_none() && r[1].flag.is_none());
        assert_eq!(
            r[2].flag,
            Some(SlopeFlag::GridError {
                error: r[2].grid_error,
                bound: DEFAULT_GRID_BOUND
            })
        );
        // without a coarse grid everything is flagged; a missing pair is flagged too
        let r = running_exponents(&fine, None, DEFAULT_GRID_BOUND).unwrap();
        assert!(r.iter().all(|e| e.flag == Some(SlopeFlag::NoCoarse)));
        let r = running_exponents(&fine, Some(&fine[..3]), DEFAULT_GRID_BOUND).unwrap();
        assert_eq!(r[2].flag, Some(SlopeFlag::NoCoarse));
        assert!(r[2].grid_error.is_nan() && r[0].grid_error == 0.0 && r[0].flag.is_none());
        // the usable rungs stop before the first flagged pair: here the third (l = −2e-3 → −1e-3)
        let keep = grid_converged_rungs(&fine, Some(&coarse), DEFAULT_GRID_BOUND).unwrap();
        assert_eq!(
            keep.iter().map(|p| p.l).collect::<Vec<_>>(),
            vec![-1e-2, -5e-3, -2e-3]
        );
        assert_eq!(
            grid_converged_rungs(&fine, None, DEFAULT_GRID_BOUND)
                .unwrap()
                .len(),
            1
        );
    }

    #[test]
    fn bad_input_names_the_problem() {
        let ok = ScalingPoint::new(-1e-2, 1.0, 0.0);
        let err = |p: ScalingPoint| local_slopes(&[ok, p]).unwrap_err().to_string();
        assert!(err(ScalingPoint::new(1e-3, 1.0, 0.0)).contains("same side"));
        assert!(err(ScalingPoint::new(0.0, 1.0, 0.0)).contains("≠ 0"));
        assert!(err(ScalingPoint::new(-1e-3, 0.0, 0.0)).contains("y[1]"));
        assert!(err(ScalingPoint::new(-1e-3, 1.0, -1.0)).contains("sigma"));
        assert!(err(ok).contains("distinct"));
        assert!(local_slopes(&[ok]).is_err());
        assert!(running_exponents(&[ok, ScalingPoint::new(-1e-3, 1.0, 0.0)], None, 0.0).is_err());
    }
}
