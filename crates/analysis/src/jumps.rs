//! Detection of discontinuities (jumps) on a quasi-static path `(xᵢ, yᵢ)`.
//!
//! # Criterion
//! Step `k` goes from point `k` to `k + 1`: `Δxₖ`, `Δyₖ`, slope `sₖ = Δyₖ/Δxₖ`. Its neighbours
//! are the steps `k − w … k + w` other than `k` (`w` = [`JumpOptions::window`]). Two predictions
//! of the step size from the neighbours:
//! - from their slopes, `T_slope = median|sₘ| · |Δxₖ|` (the smooth trend carried over the
//!   step's own width: robust to uneven load steps);
//! - from their sizes, `T_size = median|Δyₘ|` (robust to singular-but-continuous behaviour such
//!   as √x at 0 sampled with a tiny first step, where slopes vary wildly but steps do not).
//!
//! Step `k` is a jump when `|Δyₖ| > ratio · max(T_slope, T_size)` — it is much larger than
//! *both* predictions — and `|Δyₖ| > min_rel_size · (max y − min y)` (a floor against round-off
//! on flat stretches). The median makes one jumpy neighbour harmless, so two jumps in adjacent
//! steps are both found away from the ends; at the very ends, with only one or two neighbours,
//! adjacent jumps can mask each other.
//!
//! Smooth curves stay below the threshold as long as they are resolved: for `tanh(x/w)` sampled
//! at `Δx = w` the central step is ≈ 3.5 times the median of its neighbours, for `√x` sampled
//! uniformly from 0 the first step is ≈ 2.7 times its neighbours; the default `ratio = 5` leaves
//! room for both.

use crate::error::{FitError, Result};

/// Options of [`detect_jumps`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JumpOptions {
    /// A jump is at least this many times larger than both neighbour predictions (> 1).
    pub ratio: f64,
    /// Neighbour steps considered on each side (≥ 1).
    pub window: usize,
    /// Floor: a jump is also larger than this fraction of the path's y range.
    pub min_rel_size: f64,
}

impl Default for JumpOptions {
    fn default() -> Self {
        JumpOptions {
            ratio: 5.0,
            window: 2,
            min_rel_size: 1e-6,
        }
    }
}

/// One detected discontinuity between points `index` and `index + 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jump {
    /// Index of the point before the jump.
    pub index: usize,
    /// x before and after.
    pub x: (f64, f64),
    /// y before and after.
    pub y: (f64, f64),
    /// Signed jump size `y[index + 1] − y[index]`.
    pub size: f64,
    /// The larger of the two neighbour predictions of `|Δy|` for this step.
    pub trend: f64,
    /// `|size| / trend` (infinite if the trend is zero).
    pub ratio: f64,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Finds the jumps of a path `(x, y)` (in path order; x need not be monotone or evenly spaced).
///
/// Paths with fewer than 3 points have no neighbour trend to compare with and give no jumps.
/// Errors: lengths differ, non-finite values, `ratio ≤ 1`, `window = 0`, `min_rel_size < 0`.
pub fn detect_jumps(x: &[f64], y: &[f64], opts: &JumpOptions) -> Result<Vec<Jump>> {
    crate::error::check_arg("ratio", opts.ratio, "finite and > 1", opts.ratio > 1.0)?;
    crate::error::check_arg(
        "min_rel_size",
        opts.min_rel_size,
        "finite and >= 0",
        opts.min_rel_size >= 0.0,
    )?;
    if opts.window == 0 {
        return Err(FitError::InvalidArgument {
            name: "window",
            value: 0.0,
            allowed: ">= 1",
        });
    }
    crate::error::check_xy("jump detection", x, y, None, 0)?;
    let n = x.len();
    if n < 3 {
        return Ok(Vec::new());
    }
    let (ymin, ymax) = y
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let floor = opts.min_rel_size * (ymax - ymin);
    let dx: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let dy: Vec<f64> = y.windows(2).map(|w| w[1] - w[0]).collect();
    let slope: Vec<f64> = dx
        .iter()
        .zip(&dy)
        .map(|(&a, &b)| {
            if a != 0.0 {
                (b / a).abs()
            } else if b == 0.0 {
                0.0
            } else {
                f64::INFINITY
            }
        })
        .collect();
    let m = dy.len();
    let mut jumps = Vec::new();
    let mut nb_slope = Vec::with_capacity(2 * opts.window);
    let mut nb_size = Vec::with_capacity(2 * opts.window);
    for k in 0..m {
        let size = dy[k].abs();
        if size == 0.0 || size <= floor {
            continue;
        }
        nb_slope.clear();
        nb_size.clear();
        let lo = k.saturating_sub(opts.window);
        let hi = (k + opts.window).min(m - 1);
        for j in (lo..=hi).filter(|&j| j != k) {
            nb_slope.push(slope[j]);
            nb_size.push(dy[j].abs());
        }
        let t_slope = median(&mut nb_slope) * dx[k].abs();
        let t_size = median(&mut nb_size);
        let trend = t_slope.max(t_size);
        // NaN (∞ · 0) counts as "no prediction": not a jump.
        if trend.is_nan() {
            continue;
        }
        if size > opts.ratio * trend {
            jumps.push(Jump {
                index: k,
                x: (x[k], x[k + 1]),
                y: (y[k], y[k + 1]),
                size: dy[k],
                trend,
                ratio: if trend > 0.0 {
                    size / trend
                } else {
                    f64::INFINITY
                },
            });
        }
    }
    Ok(jumps)
}
