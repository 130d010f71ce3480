//! Near-critical scaling measured on the ladder's windows ([`crate::ladder`]): the channel's
//! width below L_c, its blocked length above, contact lines and gap profiles, and the exponent
//! fits (PHYSICS.md: g(l, x, y) = |l|^ζ g±(x/|l|^χ, y/|l|^υ), x along the channel).
//!
//! - Open channel (l < 0): on the line across the channel through the saddle (r∥ = 0) the
//!   contact pressure rises from the contact line as `F = A √(r⊥ − r_c)`
//!   ([`analysis::fit_sqrt_onset`]); fitted to the loaded nodes within `span · r_c` of the
//!   line (at least `min_nodes`), it locates r_c below grid resolution ([`open_half_width`]).
//!   The width is 2 r_c.
//! - Blocked channel (l > 0): on the channel axis (r⊥ = 0) the pressure of the contact bridge is
//!   Hertzian, `p0 √(1 − (r∥/a)²)` ([`analysis::fit_hertz`], centre held at the saddle); the
//!   blocked length is 2a ([`blocked_half_length`]).
//! - Exponents: power laws `y = A |l|^e` fitted in log–log ([`fit_exponent`]).
//!
//! The window is mirror-symmetric about both axes on the unshifted grid; the fits use the
//! r > 0 halves and check that the other half agrees.

use crate::ladder::Window;
use analysis::{ErrorScale, FitResult};

/// A contact-line position from a fit, with its 1σ error.
#[derive(Clone, Debug, PartialEq)]
pub struct EdgeFit {
    /// Distance of the contact line from the saddle (λ).
    pub r: f64,
    /// 1σ from the fit.
    pub r_error: f64,
    /// Nodes fitted.
    pub points: usize,
    /// χ²/dof of the fit (unit weights).
    pub reduced_chi2: f64,
}

fn edge_from(f: &FitResult, name: &str, points: usize) -> EdgeFit {
    let (r, e) = f.get(name).unwrap_or((f64::NAN, f64::NAN));
    EdgeFit {
        r,
        r_error: e,
        points,
        reduced_chi2: f.reduced_chi2(),
    }
}

/// Options of [`open_half_width`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeOptions {
    /// Fit the loaded nodes within `span · r` of the contact line (r its distance from the
    /// saddle), so that the fitted range scales with the channel.
    pub span: f64,
    /// But at least this many nodes (≥ 3).
    pub min_nodes: usize,
}

impl Default for EdgeOptions {
    fn default() -> Self {
        EdgeOptions {
            span: 0.5,
            min_nodes: 3,
        }
    }
}

/// The half-width r_c of the open channel (l < 0): a square-root onset fitted to the pressure on
/// the line r∥ = 0 across the channel, on the r⊥ > 0 side (see the module docs).
///
/// Errors: the saddle node is in contact, no loaded node on the line inside the window, or the
/// fit fails.
pub fn open_half_width(w: &Window, opts: &EdgeOptions) -> Result<EdgeFit, String> {
    let (a, c) = (w.k_par(), w.k_perp());
    if w.pressure[[a, c]] > 0.0 {
        return Err("the saddle node is in contact: the channel is closed".into());
    }
    let row = w.pressure.row(a);
    let b1 = (c + 1..row.len())
        .find(|&b| row[b] > 0.0)
        .ok_or("no contact on the line across the channel inside the window; enlarge `window`")?;
    let r_edge = w.r_perp(b1) - 0.5 * w.d_perp;
    let reach = r_edge * (1.0 + opts.span);
    let mut r = Vec::new();
    let mut f = Vec::new();
    for b in b1..row.len() {
        if row[b] <= 0.0 || (w.r_perp(b) > reach && r.len() >= opts.min_nodes.max(3)) {
            break;
        }
        r.push(w.r_perp(b));
        f.push(row[b]);
    }
    if r.len() < opts.min_nodes.max(3) {
        return Err(format!(
            "only {} loaded nodes beyond the contact line inside the window (at least {} needed)",
            r.len(),
            opts.min_nodes.max(3)
        ));
    }
    let fit = analysis::fit_sqrt_onset(&r, &f, None, ErrorScale::ReducedChi2)
        .map_err(|e| format!("square-root onset fit: {e}"))?;
    Ok(edge_from(&fit, "r_c", r.len()))
}

/// The half-length a of the blocked channel (l > 0): a Hertzian profile fitted to the contact
/// pressure along the channel axis (r⊥ = 0), over the loaded run through the saddle.
///
/// Errors: the saddle node is open, the run reaches the window's edge, fewer than 3 loaded
/// nodes, or the fit fails.
pub fn blocked_half_length(w: &Window) -> Result<EdgeFit, String> {
    let (a, c) = (w.k_par(), w.k_perp());
    let col = w.pressure.column(c);
    if col[a] <= 0.0 {
        return Err("the saddle node is open: the channel is not blocked".into());
    }
    let mut lo = a;
    while lo > 0 && col[lo - 1] > 0.0 {
        lo -= 1;
    }
    let mut hi = a;
    while hi + 1 < col.len() && col[hi + 1] > 0.0 {
        hi += 1;
    }
    if lo == 0 || hi + 1 == col.len() {
        return Err(
            "the contact along the channel axis reaches the window's edge; enlarge `window`".into(),
        );
    }
    if hi - lo + 1 < 3 {
        return Err(format!(
            "only {} loaded nodes along the channel axis (at least 3 needed)",
            hi - lo + 1
        ));
    }
    let x: Vec<f64> = (lo..=hi).map(|k| w.r_par(k)).collect();
    let p: Vec<f64> = (lo..=hi).map(|k| col[k]).collect();
    let fit = analysis::fit_hertz(&x, &p, None, Some(0.0), ErrorScale::ReducedChi2)
        .map_err(|e| format!("Hertz fit: {e}"))?;
    Ok(edge_from(&fit, "a", x.len()))
}

/// Where p² (linear in the distance to a contact line, since p ∝ √d) extrapolates to zero
/// between a loaded node at `r1` (pressure `p1`) and the next node inward of it at `r2`
/// (`p2`, loaded too, or NaN if there is none): the edge lies within one spacing `d` of r1 on the
/// open side `dir` (±1). Without `p2`, half a spacing.
fn edge_between(r1: f64, p1: f64, r2: f64, p2: f64, d: f64, dir: f64) -> f64 {
    let half = r1 + dir * 0.5 * d;
    if p2.is_nan() || p2 <= 0.0 {
        return half;
    }
    let slope = (p2 * p2 - p1 * p1) / (r2 - r1); // d(p²)/dr
    if slope == 0.0 {
        return half;
    }
    let r0 = r1 - p1 * p1 / slope;
    let (a, b) = if dir > 0.0 {
        (r1, r1 + d)
    } else {
        (r1 - d, r1)
    };
    r0.clamp(a, b)
}

/// The contact lines in the window, as (r∥, r⊥) points (λ), pieces separated by NaN.
///
/// Channel open at the saddle (l ≤ 0): for every row r∥ the first loaded node on either side of
/// the axis, the edge placed by [`edge_between`] — two curves r⊥ = ±w(r∥)/2. Channel blocked
/// (l > 0): for every column r⊥ the end of the loaded run through r∥ = 0 — two curves
/// r∥ = ±f(r⊥); columns whose run reaches the window's edge are left out.
pub fn contact_lines(w: &Window) -> Vec<(f64, f64)> {
    let (kp, kq) = (w.k_par(), w.k_perp());
    let p = &w.pressure;
    let mut out = Vec::new();
    if p[[kp, kq]] <= 0.0 {
        for dir in [1.0f64, -1.0] {
            if !out.is_empty() {
                out.push((f64::NAN, f64::NAN));
            }
            for a in 0..p.nrows() {
                let row = p.row(a);
                let found = if dir > 0.0 {
                    (kq + 1..row.len()).find(|&b| row[b] > 0.0)
                } else {
                    (0..kq).rev().find(|&b| row[b] > 0.0)
                };
                match found {
                    Some(b) if row[kq] <= 0.0 => {
                        let b2 = if dir > 0.0 { b + 1 } else { b.wrapping_sub(1) };
                        let (r2, p2) = match row.get(b2) {
                            Some(v) => (w.r_perp(b2), *v),
                            None => (f64::NAN, f64::NAN),
                        };
                        let r = edge_between(w.r_perp(b), row[b], r2, p2, w.d_perp, -dir);
                        out.push((w.r_par(a), r));
                    }
                    _ => {
                        if out.last().is_some_and(|q| !q.0.is_nan()) {
                            out.push((f64::NAN, f64::NAN));
                        }
                    }
                }
            }
        }
    } else {
        for dir in [1.0f64, -1.0] {
            if !out.is_empty() {
                out.push((f64::NAN, f64::NAN));
            }
            for b in 0..p.ncols() {
                let col = p.column(b);
                if col[kp] <= 0.0 {
                    if out.last().is_some_and(|q| !q.0.is_nan()) {
                        out.push((f64::NAN, f64::NAN));
                    }
                    continue;
                }
                // last loaded node of the run from the axis outward
                let mut a = kp;
                let inside = |a: usize| a < col.len() && col[a] > 0.0;
                loop {
                    let next = if dir > 0.0 { a + 1 } else { a.wrapping_sub(1) };
                    if next >= col.len() || !inside(next) {
                        break;
                    }
                    a = next;
                }
                if a == 0 || a + 1 == col.len() {
                    // the run reaches the window's edge: the line lies outside
                    if out.last().is_some_and(|q| !q.0.is_nan()) {
                        out.push((f64::NAN, f64::NAN));
                    }
                    continue;
                }
                let inner = if dir > 0.0 { a.wrapping_sub(1) } else { a + 1 };
                let (r2, p2) = match col.get(inner) {
                    Some(v) => (w.r_par(inner), *v),
                    None => (f64::NAN, f64::NAN),
                };
                let r = edge_between(w.r_par(a), col[a], r2, p2, w.d_par, dir);
                out.push((r, w.r_perp(b)));
            }
        }
    }
    while out.last().is_some_and(|q| q.0.is_nan()) {
        out.pop();
    }
    out
}

/// The gap along the channel axis (r⊥ = 0) from the saddle outward: (r∥ ≥ 0, g).
pub fn axis_gap(w: &Window) -> (Vec<f64>, Vec<f64>) {
    let (kp, kq) = (w.k_par(), w.k_perp());
    (kp..w.gap.nrows())
        .map(|a| (w.r_par(a), w.gap[[a, kq]]))
        .unzip()
}

/// A power law `y = A |l|^e` fitted in log–log (errors scaled by the reduced χ²).
#[derive(Clone, Debug, PartialEq)]
pub struct ExponentFit {
    /// Exponent e.
    pub value: f64,
    /// 1σ from the fit (NaN with no degree of freedom).
    pub error: f64,
    /// Prefactor A.
    pub prefactor: f64,
    /// Points fitted.
    pub points: usize,
}

/// Fits `y = A |l|^e` to the pairs with finite, positive `y`. Errors with fewer than 2.
pub fn fit_exponent(l: &[f64], y: &[f64]) -> Result<ExponentFit, String> {
    let (x, y): (Vec<f64>, Vec<f64>) = l
        .iter()
        .zip(y)
        .filter(|(l, y)| y.is_finite() && **y > 0.0 && **l != 0.0)
        .map(|(l, y)| (l.abs(), *y))
        .unzip();
    if x.len() < 2 {
        return Err(format!("{} usable points, at least 2 needed", x.len()));
    }
    let f = analysis::power_law_fit(&x, &y, None, ErrorScale::ReducedChi2)
        .map_err(|e| e.to_string())?;
    let (a, _) = f.get("A").unwrap_or((f64::NAN, f64::NAN));
    let (e, s) = f.get("beta").unwrap_or((f64::NAN, f64::NAN));
    Ok(ExponentFit {
        value: e,
        error: if f.dof == 0 { f64::NAN } else { s },
        prefactor: a,
        points: x.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    /// A window with a synthetic open channel: p = A √(|r⊥| − r_c) outside |r⊥| < r_c.
    fn open_window(r_c: f64, d: f64, k: usize) -> Window {
        let shape = (2 * k + 1, 2 * k + 1);
        let p = Array2::from_shape_fn(shape, |(_, b)| {
            let r = (b as f64 - k as f64) * d;
            2.0 * (r.abs() - r_c).max(0.0).sqrt()
        });
        Window {
            d_par: d,
            d_perp: d,
            gap: p.mapv(|v| if v > 0.0 { 0.0 } else { 1.0 }),
            pressure: p,
        }
    }

    #[test]
    fn sqrt_onset_locates_the_contact_line_below_the_spacing() {
        for r_c in [0.0123, 0.0171, 0.031] {
            let w = open_window(r_c, 0.004, 20);
            let e = open_half_width(&w, &EdgeOptions::default()).unwrap();
            assert!((e.r - r_c).abs() < 1e-9, "{} vs {r_c}", e.r);
            // the contact lines are straight at r⊥ = ±r_c; p² is linear, so exactly placed
            let pts = contact_lines(&w);
            assert!(
                pts.iter()
                    .filter(|p| !p.0.is_nan())
                    .all(|p| (p.1.abs() - r_c).abs() < 1e-9)
            );
        }
    }

    #[test]
    fn hertz_locates_the_bridge_end() {
        let (a0, d, k) = (0.0234, 0.002, 20);
        let p = Array2::from_shape_fn((2 * k + 1, 2 * k + 1), |(a, _)| {
            let x = (a as f64 - k as f64) * d;
            analysis::hertz_profile(x, 3.0, a0, 0.0)
        });
        let w = Window {
            d_par: d,
            d_perp: d,
            gap: p.mapv(|v| if v > 0.0 { 0.0 } else { 1.0 }),
            pressure: p,
        };
        let e = blocked_half_length(&w).unwrap();
        assert!((e.r - a0).abs() < 1e-8, "{}", e.r);
        // p² = p0² (1 − x²/a²) is not linear in x, but near the edge it is to first order
        let pts = contact_lines(&w);
        assert!(
            pts.iter()
                .filter(|p| !p.0.is_nan())
                .all(|p| (p.0.abs() - a0).abs() < 0.2 * d)
        );
        // too small a window
        let small = Window {
            gap: w.gap.slice(ndarray::s![10..31, ..]).to_owned(),
            pressure: w.pressure.slice(ndarray::s![10..31, ..]).to_owned(),
            ..w.clone()
        };
        assert!(blocked_half_length(&small).unwrap_err().contains("window"));
    }

    #[test]
    fn exponent_fit_recovers_a_noisy_power_law() {
        // deterministic ±0.5 % "noise": the fitted exponent stays within its error bar's
        // reach of the truth, and the error bar is not absurdly small or large
        let l = [-0.002, -0.005, -0.01, -0.02];
        let noise = [0.004, -0.005, 0.003, -0.002];
        let y: Vec<f64> = l
            .iter()
            .zip(noise)
            .map(|(l, n): (&f64, f64)| 0.7 * l.abs().powf(1.2) * (1.0 + n))
            .collect();
        let f = fit_exponent(&l, &y).unwrap();
        assert!((f.value - 1.2).abs() < 3.0 * f.error, "{f:?}");
        assert!(f.error > 1e-4 && f.error < 0.02, "{f:?}");
        let exact: Vec<f64> = l.iter().map(|l| 0.7 * l.abs().powf(0.45)).collect();
        let f = fit_exponent(&l, &exact).unwrap();
        assert!((f.value - 0.45).abs() < 1e-12 && (f.prefactor - 0.7).abs() < 1e-12);
        assert!(fit_exponent(&l[..1], &exact[..1]).is_err());
    }

    #[test]
    fn exponent_error_bars_cover_the_truth_as_often_as_they_should() {
        // 400 ladders with 1 % Gaussian noise on y = A |l|^0.45: with 4 points and 2 degrees of
        // freedom the errors (scaled by the reduced χ²) are Student-t distributed, so ±1σ covers
        // the true exponent in 57.7 % of the cases (±0.025 for 400 trials at 2σ ≈ 0.05)
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let l = [-0.002, -0.005, -0.01, -0.02];
        let (mut covered, trials) = (0, 400);
        for _ in 0..trials {
            let y: Vec<f64> = l
                .iter()
                .map(|l: &f64| {
                    let g = (-2.0 * (1.0 - uniform()).ln()).sqrt()
                        * (2.0 * std::f64::consts::PI * uniform()).cos();
                    0.3 * l.abs().powf(0.45) * (1.0 + 0.01 * g)
                })
                .collect();
            let f = fit_exponent(&l, &y).unwrap();
            if (f.value - 0.45).abs() <= f.error {
                covered += 1;
            }
        }
        let rate = covered as f64 / trials as f64;
        assert!((0.5..0.66).contains(&rate), "coverage {rate}");
    }
}
