//! The flow window's truncation of the neck (issue 13, docs/near-critical.md §5g): a flag on
//! the refined ladders' β pairs whose flux is the refined saddle's own two-terminal
//! conductance (`critical::refined_flow`, `flux_method = saddle_window`: triangular and
//! hexagonal) where the flow window is too short for the neck, so that the pair measures a
//! truncated neck and not β.
//!
//! # Why
//! The saddle-window conductance is the flux between two isobaric lines across the channel, a
//! fixed number of base cells apart (the refined window less `trim_along` at each end). Its
//! exponent is β only if the neck fits between them. The neck's length grows with |l| (the rise
//! length to 2 g_s scales as |l|^χ), so at the large-|l| end of a ladder the window cuts it
//! off, the cut grows with |l| and the running exponent comes out too large. On the paper
//! preset's triangular 256² refined ladder (window 16, flow window 8 base cells along the
//! channel, half-length 0.0313 λ) the neck's β exceeds 3ζ + υ − χ by 0.152, 0.050, 0.007 at
//! 0.02→0.01, 0.01→0.005, 0.005→0.002 and the uniform 2048² cell's β by 0.150, 0.051, 0.017,
//! where the identity and the cell's β agree to 1e-3 (§5g).
//!
//! # The model ([`excess`])
//! Near the saddle the gap across the channel is parabolic, g(x, y) ≈ g_c(x) − a y², so the
//! open width is ∝ g_c^{1/2} and the conductance per unit length of channel ∝ ∫ g³ dy ∝
//! g_c^{7/2}. Along the channel g_c(x) = g_s (1 + (x/ℓ)²) with ℓ the rise length to 2 g_s (the
//! stored `neck_rise_length`). The two-terminal resistance between isobars at ±L is then
//! R ∝ ℓ g_s^{−7/2} F(L/ℓ) with
//! F(u) = ∫_{−u}^{u} (1 + t²)^{−7/2} dt = 2u (8u⁴ + 20u² + 15) / (15 (1 + u²)^{5/2}),
//! F(∞) = 16/15. With u = L/ℓ at each rung, the window's running exponent exceeds the untruncated
//! one by −Δ ln F(u) / Δ ln|l| between the two rungs. No parameter is fitted: ℓ is measured and
//! L is the window's. On the triangular ladder above the model gives 0.141, 0.045, 0.008, 0.0007
//! against the measured 0.152, 0.050, 0.007, −0.002 (β_neck − (3ζ + υ − χ)).
//!
//! # The flag ([`assess`], [`apply`])
//! A pair is flagged when the model's excess is above the refined ladders' grid bound
//! ([`GRID_BOUND`], 0.005), as a pair whose grid error is above it. Where a rung has no rise
//! length (not measured: the neck too short for the estimator at small |l|, or the rung
//! flagged), the nearest rung at larger |l| that has one bounds u from below (ℓ shrinks with
//! |l|), and the excess is bounded by taking the other rung's F at its bound or at F(∞); a pair
//! with no rise length at or above either rung is flagged as unknown. Square ladders measure the
//! cell's conductivity by series replacement (`flux_method = series`), which has no such
//! truncation: they are not assessed.
//!
//! The flag is applied where the ladders are read for the tables and fits ([`read_flagged`]:
//! `exponents`, the `running`, `refined` and `fig5` scenes), not in the `refined_ladder` kind: its artefact and
//! code identity stay as they are.

use crate::refined_chain::Linked;
use crate::refined_ladder::{GRID_BOUND, RefinedData};
use crate::refined_neck::{NeckDisc, NeckMeasure, finest, read_ladder};
use anyhow::{Result, anyhow};
use critical::refined::Measured;
use store::ArtefactReader;
use surface::{Lattice, Surface};

/// The `flux_method` whose conductance is the saddle window's (assessed here).
pub const SADDLE_WINDOW: &str = "saddle_window";

/// F(u) = ∫_{−u}^{u} (1 + t²)^{−7/2} dt (module docs); F(∞) = 16/15.
pub fn window_integral(u: f64) -> f64 {
    if u.is_infinite() && u > 0.0 {
        return 16.0 / 15.0;
    }
    let s = 1.0 + u * u;
    2.0 * u * (8.0 * u.powi(4) + 20.0 * u * u + 15.0) / (15.0 * s * s * s.sqrt())
}

/// The truncated window's running exponent minus the untruncated one between rungs at reduced
/// loads `l_hi`, `l_lo` (|l_hi| > |l_lo|) where the window's half-length over the rise length is
/// `u_hi`, `u_lo` (module docs). Positive where the neck is cut more at `l_hi`.
pub fn excess(u_hi: f64, u_lo: f64, l_hi: f64, l_lo: f64) -> f64 {
    -(window_integral(u_hi).ln() - window_integral(u_lo).ln()) / (l_hi.abs().ln() - l_lo.abs().ln())
}

/// The flow window's half-length along the channel (λ) of a refined ladder of `lattice` on a
/// 2^`base` grid with a refined window of `window` base cells: the window less
/// `critical::refined_flow::trim_along` base cells at each end, as
/// `critical::refined_flow::FluxSetup::new` sets it, along the grid axis of the channel of
/// `critical::ladder::axis_saddle`.
pub fn flow_half_length(lattice: Lattice, base: u32, window: u32) -> Result<f64> {
    if window < 7 {
        return Err(anyhow!(
            "window = {window} base cells: the refined flux needs ≥ 7 (critical::refined_flow)"
        ));
    }
    let s = Surface::new(lattice, base)?;
    let frame = critical::ladder::axis_saddle(&s)?;
    let cell = if frame.channel_axis == 0 {
        s.grid.dx()
    } else {
        s.grid.dy()
    };
    let trim = critical::refined_flow::trim_along(window as usize);
    Ok((window as usize - 2 * trim) as f64 * cell / 2.0)
}

/// The truncation of one β pair.
#[derive(Clone, Debug, PartialEq)]
pub struct Truncation {
    /// Window half-length over the rise length at l_hi (a lower bound if `bound`; NaN unknown).
    pub u_hi: f64,
    /// The same at l_lo (a lower bound if `bound`; NaN unknown).
    pub u_lo: f64,
    /// The model's excess (an upper bound if `bound`; NaN unknown).
    pub excess: f64,
    /// Whether a rise length was missing and the excess is a bound.
    pub bound: bool,
}

impl Truncation {
    /// The flag text if the pair must not be used (module docs), else None.
    pub fn flag(&self, half: f64) -> Option<String> {
        if !self.excess.is_finite() {
            return Some(format!(
                "neck truncation unknown: no rise length at or above l_hi (flow window half-length {half:.3e} λ)"
            ));
        }
        (self.excess > GRID_BOUND).then(|| {
            format!(
                "neck truncated by the flow window: model excess {}{:.2e} > {GRID_BOUND:.2e} (window half-length {:.2} and {:.2} rise lengths, {half:.3e} λ)",
                if self.bound { "≤ " } else { "" },
                self.excess,
                self.u_hi,
                self.u_lo
            )
        })
    }
}

/// The truncation of the pair (l_hi, l_lo) from the rise lengths `rise` ((l, length) of every
/// rung below p_c, NaN where not measured) and the flow window's half-length `half` (module
/// docs).
pub fn truncation(rise: &[(f64, f64)], half: f64, l_hi: f64, l_lo: f64) -> Truncation {
    // u at `l`, or a lower bound from the nearest rung at larger |l| with a rise length
    let u_at = |l: f64| -> (f64, bool) {
        let exact = rise
            .iter()
            .find(|(x, y)| analysis::same_load(*x, l) && y.is_finite() && *y > 0.0);
        if let Some((_, y)) = exact {
            return (half / y, false);
        }
        let above = rise
            .iter()
            .filter(|(x, y)| x.abs() > l.abs() && y.is_finite() && *y > 0.0)
            .min_by(|a, b| a.0.abs().total_cmp(&b.0.abs()));
        match above {
            Some((_, y)) => (half / y, true),
            None => (f64::NAN, true),
        }
    };
    let (u_hi, b_hi) = u_at(l_hi);
    let (u_lo, b_lo) = u_at(l_lo);
    let excess = match (b_hi, b_lo) {
        (false, false) => excess(u_hi, u_lo, l_hi, l_lo),
        // F(u_lo) ≤ F(∞), F(u_hi) ≥ F(its lower bound): the excess is at most this
        _ if u_hi.is_finite() => excess(u_hi, f64::INFINITY, l_hi, l_lo).max(0.0),
        _ => f64::NAN,
    };
    Truncation {
        u_hi,
        u_lo,
        excess,
        bound: b_hi || b_lo,
    }
}

/// The truncation of every β pair of `data` (None for the other pairs, and for every pair of a
/// ladder whose flux is not the saddle window's), from its finest discretisation's rise lengths
/// `discs` and its window on a 2^`base` grid; also the flow window's half-length.
pub fn assess(
    data: &RefinedData,
    discs: &[NeckDisc],
    base: u32,
) -> Result<(f64, Vec<Option<Truncation>>)> {
    if data.flux_method != SADDLE_WINDOW {
        return Ok((f64::NAN, vec![None; data.running.len()]));
    }
    let half = flow_half_length(data.lattice, base, data.window)?;
    let col = NeckMeasure::RiseLength.column();
    let rise: Vec<(f64, f64)> = finest(discs)
        .map(|d| {
            d.rungs
                .iter()
                .filter(|r| r.l < 0.0)
                .map(|r| (r.l, r.lengths[col]))
                .collect()
        })
        .unwrap_or_default();
    let out = data
        .running
        .iter()
        .map(|p| {
            (p.exponent == Measured::Flux && p.row.l_hi < 0.0)
                .then(|| truncation(&rise, half, p.row.l_hi, p.row.l_lo))
        })
        .collect();
    Ok((half, out))
}

/// The refined ladders of `inputs` as `refined_chain::read_linked` reads them, with the β
/// pairs that the flow window truncates flagged ([`apply`]): what every reader of the refined
/// ladders' running pairs takes (`exponents`; the `running`, `refined` and `fig5` scenes).
pub fn read_flagged(inputs: &orchestrator::Inputs) -> Result<Vec<(Linked, &ArtefactReader)>> {
    let mut linked = crate::refined_chain::read_linked(inputs)?;
    apply(&mut linked)?;
    Ok(linked)
}

/// Flags every β pair of the saddle-window ladders of `linked` (as `refined_chain::read_linked`
/// returns them) that the flow window truncates (module docs), where it has no flag yet; a
/// ladder without stored rise lengths gets "neck truncation unknown" on its β pairs.
fn apply(linked: &mut [(Linked, &ArtefactReader)]) -> Result<()> {
    for (link, r) in linked.iter_mut() {
        if link.data.flux_method != SADDLE_WINDOW {
            continue;
        }
        let base = r.attr_i64("base")? as u32;
        let discs = read_ladder(r)?.unwrap_or_default();
        let (half, per_pair) = assess(&link.data, &discs, base)?;
        for (p, t) in link.data.running.iter_mut().zip(per_pair) {
            if let Some(t) = t
                && p.flag.is_empty()
                && let Some(f) = t.flag(half)
            {
                p.flag = f;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// F against a composite Simpson rule of (1 + t²)^{−7/2}.
    #[test]
    fn window_integral_is_the_integral() {
        let f = |t: f64| (1.0 + t * t).powf(-3.5);
        for u in [0.01, 0.3, 1.0, 2.5, 7.0] {
            let n = 20_000;
            let h = 2.0 * u / n as f64;
            let mut s = f(-u) + f(u);
            for k in 1..n {
                s += if k % 2 == 1 { 4.0 } else { 2.0 } * f(-u + k as f64 * h);
            }
            let simpson = s * h / 3.0;
            assert!(
                (window_integral(u) - simpson).abs() < 1e-12,
                "u = {u}: {} vs {simpson}",
                window_integral(u)
            );
        }
        assert!((window_integral(1e6) - 16.0 / 15.0).abs() < 1e-12);
        assert_eq!(window_integral(f64::INFINITY), 16.0 / 15.0);
    }

    /// The model's excess against the running exponent of the window conductance computed
    /// directly: a neck g_c(x) = g_s (1 + (x/ℓ)²) with g_s = |l|^ζ and ℓ = ℓ0 |l|^χ, conductance
    /// per length ∝ g_c^{7/2}, integrated numerically between fixed isobars at ±L.
    #[test]
    fn excess_is_the_truncated_window_slope() {
        let (zeta, chi, l0, half) = (1.2, 0.6, 0.5, 0.03);
        let conductance = |l: f64| {
            let gs = l.abs().powf(zeta);
            let ell = l0 * l.abs().powf(chi);
            let n = 40_000;
            let h = 2.0 * half / n as f64;
            let r = |x: f64| (gs * (1.0 + (x / ell).powi(2))).powf(-3.5);
            let mut s = r(-half) + r(half);
            for k in 1..n {
                s += if k % 2 == 1 { 4.0 } else { 2.0 } * r(-half + k as f64 * h);
            }
            1.0 / (s * h / 3.0)
        };
        let full = 3.5 * zeta - chi;
        for (l_hi, l_lo) in [(-0.02, -0.01), (-0.01, -0.005), (-0.005, -0.002)] {
            let slope = (conductance(l_hi).ln() - conductance(l_lo).ln())
                / (l_hi.abs().ln() - l_lo.abs().ln());
            let u = |l: f64| half / (l0 * f64::abs(l).powf(chi));
            let e = excess(u(l_hi), u(l_lo), l_hi, l_lo);
            assert!(e > 0.0);
            assert!(
                (slope - full - e).abs() < 1e-9,
                "{l_hi}→{l_lo}: slope {slope}, full {full}, excess {e}"
            );
        }
        // a long window: no excess
        assert!(excess(50.0, 80.0, -0.002, -0.001).abs() < 1e-9);
    }

    /// Missing rise lengths: bounded from the rung above; none above: unknown (flagged).
    #[test]
    fn missing_rise_lengths_give_a_bound_or_unknown() {
        let rise = [
            (-0.02, 0.04),
            (-0.01, 0.027),
            (-0.005, f64::NAN),
            (-0.002, f64::NAN),
        ];
        let half = 0.03;
        let t = truncation(&rise, half, -0.02, -0.01);
        assert!(!t.bound);
        assert!((t.u_hi - 0.75).abs() < 1e-12);
        assert!(t.flag(half).is_some(), "{t:?}");
        // l_lo missing: bounded by u_lo = ∞
        let t = truncation(&rise, half, -0.01, -0.005);
        assert!(t.bound);
        assert!(t.excess >= excess(half / 0.027, half / 0.027 * 1.5, -0.01, -0.005));
        // both missing: u_hi bounded from −0.01
        let t = truncation(&rise, half, -0.005, -0.002);
        assert!(t.bound && (t.u_hi - half / 0.027).abs() < 1e-12);
        // nothing at or above: unknown
        let t = truncation(&[(-0.01, f64::NAN)], half, -0.01, -0.005);
        assert!(t.excess.is_nan());
        assert!(t.flag(half).unwrap().contains("unknown"));
        // a short neck: no flag
        let t = truncation(&[(-1e-3, 1e-3), (-5e-4, 7e-4)], half, -1e-3, -5e-4);
        assert!(t.flag(half).is_none(), "{t:?}");
    }

    /// The triangular cell's channel runs along y (docs/near-critical.md §7), the hexagonal
    /// one's along x; a 16-cell window on 2^8 keeps 8 cells.
    #[test]
    fn flow_half_length_follows_the_channel_axis() {
        let tri = flow_half_length(Lattice::Triangular, 8, 16).unwrap();
        assert!((tri - 8.0 * 2.0 / 256.0 / 2.0).abs() < 1e-12, "{tri}");
        let hex = flow_half_length(Lattice::Hexagonal, 10, 32).unwrap();
        let lx = 4.0 / 3f64.sqrt();
        assert!((hex - 16.0 * lx / 1024.0 / 2.0).abs() < 1e-12, "{hex}");
        assert!(flow_half_length(Lattice::Square, 8, 6).is_err());
    }
}
