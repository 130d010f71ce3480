//! Lengths of the open neck from the gap field itself (issue 13): moments and level crossings
//! of g on the saddle's window ([`crate::ladder::Window`], also the refined ladder's fine
//! window, [`crate::refined::Refinement::saddle_window`]), for υ and χ below p_c.
//!
//! # Why
//! [`crate::scaling::open_half_width`] places the contact line by a square-root fit to the few
//! loaded nodes beyond it; its running υ jumps by 0.01–0.05 between refinement levels
//! (docs/near-critical.md §5b). In the scaling regime the gap near the saddle is
//! `g(x, y) ≈ |l|^ζ G(x/|l|^χ, y/|l|^υ)` (x = r∥ along the channel, y = r⊥ across; PHYSICS.md),
//! so every length built from g by a rule that commutes with this rescaling (uses only ratios
//! of gaps and positions) scales as |l|^χ or |l|^υ. Integrals and crossings of smooth parts of
//! g are far less grid-sensitive than the position of a contact line.
//!
//! # The estimators (all in λ, on the rung's window, saddle at the centre)
//! - [`across_rms`] (υ): on the line r∥ = 0, over the open run through the saddle,
//!   `W_p² = Σ g^p y² / Σ g^p`. Near the contact lines g ∝ d^{3/2} (d the distance from the
//!   line), so the summand vanishes like d^{3p/2}: the node sum (the trapezoidal rule, the
//!   summand being 0 beyond the run) has the endpoint error of that singularity,
//!   O((h/W)^{3p/2 + 1}) relative, with an amplitude that oscillates with the contact line's
//!   position between nodes. For G ∝ (1 − Y²)^{3/2}: `W_p = |l|^υ / √(3p + 3)`.
//! - [`across_level_width`] (υ): the distance from the saddle across the channel at which g
//!   falls to `fraction · g_s`, from a cubic through the four nearest open nodes (error
//!   O((h/W)⁴) where g is smooth, i.e. away from the contact line).
//! - [`along_rise_length`] (χ from below): the distance along the channel axis at which g rises
//!   to `factor · g_s`, interpolated the same way. Both sides of the saddle are measured and
//!   averaged (on the unshifted grid they agree by symmetry; their difference is reported).
//!
//! The scale covariance is what the oracle tests check: a synthetic field with known (ζ, χ, υ)
//! and a correction to scaling gives its exponents back; the same field at two spacings gives
//! the same lengths to the stated discretisation error.

use crate::ladder::Window;

/// Why an estimator has no value on a window.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NeckError {
    /// An option outside its allowed range.
    #[error("invalid {name} = {value}: allowed {allowed}")]
    Option {
        /// Name.
        name: &'static str,
        /// Value.
        value: f64,
        /// Allowed range in words.
        allowed: &'static str,
    },
    /// The saddle node is in contact.
    #[error("the saddle node is closed (gap {gap:e} h0): the channel is blocked, no open neck")]
    Closed {
        /// Gap at the saddle node (h0).
        gap: f64,
    },
    /// The structure the estimator reads extends to the window's edge.
    #[error(
        "{what} reaches the window's edge ({nodes} nodes from the saddle, {length:.3e} λ): enlarge the window"
    )]
    WindowTooSmall {
        /// What reached the edge.
        what: &'static str,
        /// Nodes from the saddle to the edge.
        nodes: usize,
        /// Distance (λ).
        length: f64,
    },
    /// Too few open nodes to resolve the neck.
    #[error("only {found} open nodes {what} (at least {needed} needed)")]
    TooFewNodes {
        /// Where.
        what: &'static str,
        /// Found.
        found: usize,
        /// Needed.
        needed: usize,
    },
}

/// The open run across the channel through the saddle: (first, last) column of the run, or the
/// error if the saddle is closed or the run reaches the window's edge.
fn open_run_across(w: &Window, min_nodes: usize) -> Result<(usize, usize), NeckError> {
    let (a, c) = (w.k_par(), w.k_perp());
    let row = w.gap.row(a);
    if row[c] <= 0.0 {
        return Err(NeckError::Closed { gap: row[c] });
    }
    let mut lo = c;
    while lo > 0 && row[lo - 1] > 0.0 {
        lo -= 1;
    }
    let mut hi = c;
    while hi + 1 < row.len() && row[hi + 1] > 0.0 {
        hi += 1;
    }
    if lo == 0 || hi + 1 == row.len() {
        return Err(NeckError::WindowTooSmall {
            what: "the open channel across the saddle (no contact line inside)",
            nodes: c,
            length: w.r_perp(row.len() - 1),
        });
    }
    let side = (c - lo).min(hi - c);
    if side < min_nodes {
        return Err(NeckError::TooFewNodes {
            what: "on a side of the saddle across the channel",
            found: side,
            needed: min_nodes,
        });
    }
    Ok((lo, hi))
}

/// The rms half-width `W_p = (Σ g^p y² / Σ g^p)^{1/2}` (λ) of the open run across the channel
/// through the saddle (module docs), `power` = p ≥ 1. Needs at least `min_nodes` open nodes on
/// each side of the saddle and the contact lines inside the window.
pub fn across_rms(w: &Window, power: f64, min_nodes: usize) -> Result<f64, NeckError> {
    if !(power.is_finite() && power >= 1.0) {
        return Err(NeckError::Option {
            name: "power",
            value: power,
            allowed: "p ≥ 1 (finite)",
        });
    }
    let (lo, hi) = open_run_across(w, min_nodes)?;
    let row = w.gap.row(w.k_par());
    let (mut s0, mut s2) = (0.0, 0.0);
    for b in lo..=hi {
        let wt = row[b].powf(power);
        let y = w.r_perp(b);
        s0 += wt;
        s2 += wt * y * y;
    }
    Ok((s2 / s0).sqrt())
}

/// Where the cubic through the samples (t_k, v_k), k = 0..4 (t ascending), crosses `target`
/// between t_1 and t_2 (v_1, v_2 on either side of it; bisection to 1e-14 of the interval).
fn cubic_crossing(t: [f64; 4], v: [f64; 4], target: f64) -> f64 {
    let p = |x: f64| {
        let mut s = 0.0;
        for i in 0..4 {
            let mut li = 1.0;
            for j in 0..4 {
                if i != j {
                    li *= (x - t[j]) / (t[i] - t[j]);
                }
            }
            s += v[i] * li;
        }
        s - target
    };
    let (mut a, mut b) = (t[1], t[2]);
    let (mut fa, fb) = (p(a), p(b));
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    if fa.signum() == fb.signum() {
        // the cubic strays outside the interval's end values: linear interpolation instead
        return t[1] + (target - v[1]) / (v[2] - v[1]) * (t[2] - t[1]);
    }
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        let fm = p(m);
        if fm == 0.0 || (b - a) < 1e-14 * (t[2] - t[1]) {
            return m;
        }
        if fm.signum() == fa.signum() {
            a = m;
            fa = fm;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// Along a line of gaps `v` (index `c` the saddle, stepping `dir` = ±1, spacing `d`): the
/// distance from the saddle at which v first crosses `target` (from the saddle's side), by the
/// cubic through the four nodes around the crossing. `None` if it is not crossed before the
/// line's second-to-last node (the cubic needs a node beyond the crossing).
fn crossing(v: &[f64], c: usize, dir: isize, d: f64, target: f64) -> Option<f64> {
    let at = |k: isize| -> Option<f64> {
        let i = c as isize + dir * k;
        (i >= 0 && (i as usize) < v.len()).then(|| v[i as usize])
    };
    let above = v[c] > target;
    let mut k = 1isize;
    loop {
        let x = at(k)?;
        if (x > target) != above || x == target {
            break;
        }
        k += 1;
    }
    // crossing between k − 1 and k; stencil k − 2 … k + 1 (k − 2 = −1 is the mirror side)
    let vals = [at(k - 2)?, at(k - 1)?, at(k)?, at(k + 1)?];
    let t = [
        (k - 2) as f64 * d,
        (k - 1) as f64 * d,
        k as f64 * d,
        (k + 1) as f64 * d,
    ];
    Some(cubic_crossing(t, vals, target))
}

/// A length measured on both sides of the saddle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoSided {
    /// Mean of the two sides (λ).
    pub value: f64,
    /// |difference| of the two sides (λ): 0 on a mirror-symmetric window.
    pub asymmetry: f64,
}

/// The distance across the channel from the saddle at which the gap on r∥ = 0 falls to
/// `fraction · g_s` (0 < fraction < 1), both sides averaged (module docs). The crossing must
/// lie inside the open run with a node beyond it, and the run must have `min_nodes` nodes on
/// each side.
pub fn across_level_width(
    w: &Window,
    fraction: f64,
    min_nodes: usize,
) -> Result<TwoSided, NeckError> {
    if !(fraction > 0.0 && fraction < 1.0) {
        return Err(NeckError::Option {
            name: "fraction",
            value: fraction,
            allowed: "0 < fraction < 1 (of the saddle gap)",
        });
    }
    let (lo, hi) = open_run_across(w, min_nodes)?;
    let row: Vec<f64> = w.gap.row(w.k_par()).to_vec();
    let c = w.k_perp();
    let target = fraction * row[c];
    let mut sides = [0.0; 2];
    for (s, dir) in [1isize, -1].into_iter().enumerate() {
        let r = crossing(&row, c, dir, w.d_perp, target);
        // a crossing beyond the last open node cannot happen (g = 0 there < target), so None
        // means the stencil's outer node is outside the window
        sides[s] = r.ok_or(NeckError::WindowTooSmall {
            what: "the level crossing across the channel (its stencil)",
            nodes: if dir > 0 { hi - c } else { c - lo },
            length: w.r_perp(row.len() - 1),
        })?;
    }
    Ok(TwoSided {
        value: 0.5 * (sides[0] + sides[1]),
        asymmetry: (sides[0] - sides[1]).abs(),
    })
}

/// The distance along the channel axis (r⊥ = 0) from the saddle at which the gap rises to
/// `factor · g_s` (factor > 1), both sides averaged (module docs). Needs the crossing at least
/// `min_nodes` nodes from the saddle and a node beyond it inside the window.
pub fn along_rise_length(w: &Window, factor: f64, min_nodes: usize) -> Result<TwoSided, NeckError> {
    if !(factor.is_finite() && factor > 1.0) {
        return Err(NeckError::Option {
            name: "factor",
            value: factor,
            allowed: "factor > 1 (of the saddle gap, finite)",
        });
    }
    let (a, c) = (w.k_par(), w.k_perp());
    let col: Vec<f64> = w.gap.column(c).to_vec();
    if col[a] <= 0.0 {
        return Err(NeckError::Closed { gap: col[a] });
    }
    let target = factor * col[a];
    let mut sides = [0.0; 2];
    for (s, dir) in [1isize, -1].into_iter().enumerate() {
        let r = crossing(&col, a, dir, w.d_par, target).ok_or(NeckError::WindowTooSmall {
            what: "the rise of the gap along the channel axis",
            nodes: a,
            length: w.r_par(col.len() - 1),
        })?;
        let nodes = (r / w.d_par).floor() as usize;
        if nodes < min_nodes {
            return Err(NeckError::TooFewNodes {
                what: "along the channel axis before the gap rises to factor · g_s",
                found: nodes,
                needed: min_nodes,
            });
        }
        sides[s] = r;
    }
    Ok(TwoSided {
        value: 0.5 * (sides[0] + sides[1]),
        asymmetry: (sides[0] - sides[1]).abs(),
    })
}

/// Options of [`neck_lengths`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeckOptions {
    /// Power p of the weight g^p of [`across_rms`] (default 2: endpoint error (h/W)^4 instead
    /// of (h/W)^{5/2} for p = 1; module docs).
    pub power: f64,
    /// Level of [`across_level_width`], a fraction of g_s (default ½).
    pub fraction: f64,
    /// Level of [`along_rise_length`], a multiple of g_s (default 2).
    pub factor: f64,
    /// Fewest open nodes from the saddle to the contact line (across) or to the crossing
    /// (along) (default 3).
    pub min_nodes: usize,
}

impl Default for NeckOptions {
    fn default() -> Self {
        NeckOptions {
            power: 2.0,
            fraction: 0.5,
            factor: 2.0,
            min_nodes: 3,
        }
    }
}

/// All three lengths of one window (each its own result: one may fail where another does not).
#[derive(Clone, Debug, PartialEq)]
pub struct NeckLengths {
    /// [`across_rms`] (λ).
    pub across_rms: Result<f64, NeckError>,
    /// [`across_level_width`] (λ).
    pub across_level: Result<TwoSided, NeckError>,
    /// [`along_rise_length`] (λ).
    pub along_rise: Result<TwoSided, NeckError>,
}

/// The three lengths of [`NeckLengths`] on one window.
pub fn neck_lengths(w: &Window, o: &NeckOptions) -> NeckLengths {
    NeckLengths {
        across_rms: across_rms(w, o.power, o.min_nodes),
        across_level: across_level_width(w, o.fraction, o.min_nodes),
        along_rise: along_rise_length(w, o.factor, o.min_nodes),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    /// The synthetic neck g = |l|^ζ cosh X (1 − Y²/s(X)²)₊^{3/2}, X = x/(2 |l|^χ), Y = y/(|l|^υ
    /// (1 + corr |l|^ω)), s(X) = 1 + X²: a hard-wall-like contact line (g ∝ d^{3/2}) at
    /// |Y| = s(X), the neck's narrowest point at X = 0. Continuum values: W_p = |l|^υ (1 + corr
    /// |l|^ω)/√(3p + 3), the level width at fraction f: |l|^υ (1 + …) √(1 − f^{2/3}), the rise
    /// length to c g_s: 2 |l|^χ acosh c.
    const ZETA: f64 = 1.2;
    const CHI: f64 = 0.6;
    const UPS: f64 = 0.45;
    const OMEGA: f64 = 0.5;

    fn field(l: f64, corr: f64, h: f64, k_par: usize, k_perp: usize) -> Window {
        let (lx, ly) = (
            2.0 * l.abs().powf(CHI),
            l.abs().powf(UPS) * (1.0 + corr * l.abs().powf(OMEGA)),
        );
        let g = Array2::from_shape_fn((2 * k_par + 1, 2 * k_perp + 1), |(a, b)| {
            let x = (a as f64 - k_par as f64) * h / lx;
            let y = (b as f64 - k_perp as f64) * h / ly;
            let s = 1.0 + x * x;
            l.abs().powf(ZETA) * x.cosh() * (1.0 - (y / s).powi(2)).max(0.0).powf(1.5)
        });
        Window {
            d_par: h,
            d_perp: h,
            pressure: g.mapv(|v| if v > 0.0 { 0.0 } else { 1.0 }),
            gap: g,
        }
    }

    fn slope(l: [f64; 2], y: [f64; 2]) -> f64 {
        (y[1] / y[0]).ln() / (l[1].abs() / l[0].abs()).ln()
    }

    /// Window half-sizes that hold the neck at `l` with spacing h (3 widths across, 3 rise
    /// lengths along).
    fn sizes(l: f64, h: f64) -> (usize, usize) {
        (
            (6.0 * l.abs().powf(CHI) / h).ceil() as usize + 4,
            (1.5 * l.abs().powf(UPS) / h).ceil() as usize + 4,
        )
    }

    /// Relative discretisation errors of the three lengths on this field, measured over 40
    /// contact-line positions between nodes at each resolution (n = open nodes from the saddle
    /// to the contact line; worst case, 2026-11-26): rms width p = 1: 1.3e-2, 4.5e-3, 2.2e-3,
    /// 1.2e-3, 2.0e-4, 3.5e-5 at n = 4, 6, 8, 10, 20, 40 (≈ 0.4 n^{−5/2}); p = 2: 1.9e-3,
    /// 4.2e-4, 1.4e-4, 5.7e-5, 3.6e-6, 2.3e-7 (≈ 0.6 n^{−4}); level width (f = ½): 4.6e-3,
    /// 5.3e-4, 1.3e-4, 6.4e-5, 4.4e-6, 2.9e-7 (≈ 0.65 n^{−4}). The bounds below are these laws
    /// with a factor 2 of headroom.
    fn bound_rms(p: f64, n: f64) -> f64 {
        if p >= 2.0 {
            1.2 * n.powi(-4)
        } else {
            0.8 * n.powf(-2.5)
        }
    }
    fn bound_level(n: f64) -> f64 {
        1.3 * n.powi(-4)
    }

    #[test]
    fn the_synthetic_neck_gives_its_lengths_back() {
        for &l in &[-1e-2f64, -3e-3, -1e-3] {
            let n = 10.0;
            let h = l.abs().powf(UPS) / n;
            let (kp, kq) = sizes(l, h);
            let w = field(l, 0.0, h, kp, kq);
            let nl = neck_lengths(&w, &NeckOptions::default());
            let ly = l.abs().powf(UPS);
            let rel = |a: f64, b: f64| (a / b - 1.0).abs();
            let rms = nl.across_rms.unwrap();
            assert!(
                rel(rms, ly / 3.0) < bound_rms(2.0, n),
                "l {l}: {rms} vs {}",
                ly / 3.0
            );
            let r1 = across_rms(&w, 1.0, 3).unwrap();
            let want = ly / 6f64.sqrt();
            assert!(rel(r1, want) < bound_rms(1.0, n), "l {l}: {r1} vs {want}");
            let lev = nl.across_level.unwrap();
            let want = ly * (1.0 - 0.5f64.powf(2.0 / 3.0)).sqrt();
            assert!(rel(lev.value, want) < bound_level(n), "{lev:?} vs {want}");
            // the window is mirror-symmetric: both sides agree to rounding
            assert!(lev.asymmetry < 1e-12 * want);
            // the rise is resolved by 2 acosh 2 |l|^χ / h ≥ 33 nodes here: (h/L)⁴-small
            let rise = nl.along_rise.unwrap();
            let want = 2.0 * l.abs().powf(CHI) * 2f64.acosh();
            assert!(rel(rise.value, want) < 1e-5, "{rise:?} vs {want}");
        }
    }

    #[test]
    fn a_ladder_at_fixed_spacing_recovers_the_exponents() {
        // one spacing for the whole ladder, as on a grid: the neck narrows from 63 to 8 nodes
        // (saddle to contact line) between |l| = 1e-2 and 1e-4, the rise length from 66 to 5;
        // running exponents from the 1-2-5 pairs. A slope over a factor ≥ 2 in |l| errs by at
        // most (e₁ + e₂)/ln 2 with e the relative errors at its rungs: ≤ 2 bound(8)/ln 2 =
        // 1.1e-3 (rms, level); the rise at 5 nodes (p. the level-width law, same cubic):
        // 2 × 1.3 × 5^{−4}/ln 2 = 6e-3.
        let ls = [-1e-2, -5e-3, -2e-3, -1e-3, -5e-4, -2e-4, -1e-4];
        let h = 1e-4f64.powf(UPS) / 8.0;
        let o = NeckOptions::default();
        let lens: Vec<NeckLengths> = ls
            .iter()
            .map(|&l| {
                let (kp, kq) = sizes(l, h);
                neck_lengths(&field(l, 0.0, h, kp, kq), &o)
            })
            .collect();
        let tol = 2.0 * bound_level(8.0) / 2f64.ln();
        for k in 0..ls.len() - 1 {
            let pair = [ls[k], ls[k + 1]];
            let u = slope(
                pair,
                [
                    *lens[k].across_rms.as_ref().unwrap(),
                    *lens[k + 1].across_rms.as_ref().unwrap(),
                ],
            );
            let v = slope(
                pair,
                [
                    lens[k].across_level.as_ref().unwrap().value,
                    lens[k + 1].across_level.as_ref().unwrap().value,
                ],
            );
            let c = slope(
                pair,
                [
                    lens[k].along_rise.as_ref().unwrap().value,
                    lens[k + 1].along_rise.as_ref().unwrap().value,
                ],
            );
            assert!((u - UPS).abs() < tol, "υ (rms) {pair:?}: {u}");
            assert!((v - UPS).abs() < tol, "υ (level) {pair:?}: {v}");
            assert!(
                (c - CHI).abs() < 2.0 * 1.3 * 5f64.powi(-4) / 2f64.ln(),
                "χ (rise) {pair:?}: {c}"
            );
        }
    }

    #[test]
    fn a_correction_to_scaling_shows_in_the_running_exponent_as_it_should() {
        // widths ∝ |l|^υ (1 + a |l|^ω): the slope between the two rungs is the exact secant
        // of that law, here 0.024 … 0.0025 above υ; the neck keeps ≥ 10 nodes, so the slope
        // errs by ≤ 2 bound(10)/ln 2 = 3.5e-4
        let a = 0.8;
        let h = 1e-4f64.powf(UPS) / 10.0;
        for pair in [[-1e-2, -5e-3], [-1e-3, -5e-4], [-2e-4, -1e-4]] {
            let w: Vec<f64> = pair
                .iter()
                .map(|&l| {
                    let (kp, kq) = sizes(l, h);
                    across_rms(&field(l, a, h, kp, kq), 2.0, 3).unwrap()
                })
                .collect();
            let got = slope(pair, [w[0], w[1]]);
            let f = |l: f64| l.abs().powf(UPS) * (1.0 + a * l.abs().powf(OMEGA));
            let want = slope(pair, [f(pair[0]), f(pair[1])]);
            assert!(
                (got - want).abs() < 2.0 * bound_rms(2.0, 10.0) / 2f64.ln(),
                "{pair:?}: {got} vs {want}"
            );
            assert!(want - UPS > 2e-3, "the correction is visible: {want}");
        }
    }

    #[test]
    fn two_spacings_give_the_same_lengths() {
        // the same field sampled at h and h/2 (12 and 24 nodes from the saddle to the contact
        // line): each length changes by less than its error bound at 12 nodes
        let l: f64 = -1e-3;
        let n = 12.0;
        let h = l.abs().powf(UPS) / n;
        let mut got = Vec::new();
        for hh in [h, 0.5 * h] {
            let (kp, kq) = sizes(l, hh);
            got.push(neck_lengths(
                &field(l, 0.0, hh, kp, kq),
                &NeckOptions::default(),
            ));
        }
        let rel = |a: f64, b: f64| (a / b - 1.0).abs();
        let r = rel(
            *got[0].across_rms.as_ref().unwrap(),
            *got[1].across_rms.as_ref().unwrap(),
        );
        assert!(r < bound_rms(2.0, n), "rms width: {r:e}");
        let r = rel(
            got[0].across_level.as_ref().unwrap().value,
            got[1].across_level.as_ref().unwrap().value,
        );
        assert!(r < bound_level(n), "level width: {r:e}");
        let r = rel(
            got[0].along_rise.as_ref().unwrap().value,
            got[1].along_rise.as_ref().unwrap().value,
        );
        assert!(r < 1e-5, "rise length: {r:e}");
    }

    #[test]
    fn errors_say_what_is_missing() {
        let l: f64 = -1e-3;
        let h = l.abs().powf(UPS) / 10.0;
        let (kp, kq) = sizes(l, h);
        let w = field(l, 0.0, h, kp, kq);
        // closed saddle
        let mut closed = w.clone();
        closed.gap[[kp, kq]] = 0.0;
        assert!(matches!(
            across_rms(&closed, 1.0, 3),
            Err(NeckError::Closed { .. })
        ));
        assert!(matches!(
            along_rise_length(&closed, 2.0, 3),
            Err(NeckError::Closed { .. })
        ));
        // a window narrower than the neck: no contact line inside
        let narrow = Window {
            gap: w.gap.slice(ndarray::s![.., kq - 5..=kq + 5]).to_owned(),
            pressure: w
                .pressure
                .slice(ndarray::s![.., kq - 5..=kq + 5])
                .to_owned(),
            ..w.clone()
        };
        let e = across_rms(&narrow, 1.0, 3).unwrap_err();
        assert!(matches!(e, NeckError::WindowTooSmall { .. }), "{e}");
        assert!(e.to_string().contains("enlarge the window"));
        // a window shorter than the rise length
        let short = Window {
            gap: w.gap.slice(ndarray::s![kp - 3..=kp + 3, ..]).to_owned(),
            pressure: w
                .pressure
                .slice(ndarray::s![kp - 3..=kp + 3, ..])
                .to_owned(),
            ..w.clone()
        };
        assert!(matches!(
            along_rise_length(&short, 2.0, 3),
            Err(NeckError::WindowTooSmall { .. })
        ));
        // a neck of 2 nodes per side
        let coarse_h = l.abs().powf(UPS) / 2.5;
        let (kp2, kq2) = sizes(l, coarse_h);
        let e = across_rms(&field(l, 0.0, coarse_h, kp2, kq2), 1.0, 3).unwrap_err();
        assert!(matches!(e, NeckError::TooFewNodes { found: 2, .. }), "{e}");
        // options
        assert!(matches!(
            across_rms(&w, 0.5, 3),
            Err(NeckError::Option { .. })
        ));
        assert!(matches!(
            across_level_width(&w, 1.0, 3),
            Err(NeckError::Option { .. })
        ));
        assert!(matches!(
            along_rise_length(&w, 1.0, 3),
            Err(NeckError::Option { .. })
        ));
    }
}
