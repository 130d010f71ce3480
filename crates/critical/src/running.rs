//! Running exponents from the load ladder: the ladder's rungs ([`crate::ladder::Rung`]) measured
//! as in [`crate::scaling`] and turned into local slopes between neighbouring rungs, each with
//! its grid error (the change between the two finest resolutions) and its fit error, as records
//! of the running-exponent table (columns [`RunningRecord::COLUMNS`]).
//!
//! # Measurements per rung ([`measure`])
//! - ζ (l < 0): the gap at the saddle node. Its error is the contact solver's tolerance on the
//!   constraint violation (`gap_sigma`, the ladder's `tol_gap`): an estimate of how well a
//!   converged Polonsky–Keer solve fixes the gap, not a bound.
//! - υ (l < 0): the open channel's half-width r_c, square-root onset of the pressure across the
//!   channel ([`crate::scaling::open_half_width`]), with that fit's 1σ.
//! - χ (l > 0): the blocked channel's half-length a, Hertzian pressure along the channel axis
//!   ([`crate::scaling::blocked_half_length`]), with that fit's 1σ.
//! - β (l < 0): the flux is not part of a rung (it comes from the flow solve on the full gap);
//!   the caller builds its [`analysis::ScalingPoint`]s directly.
//!
//! Rungs whose solve did not converge or whose measurement fails are left out with a note; the
//! pairs are then formed between the remaining neighbours (a missing rung widens a pair, which
//! the record's l_hi, l_lo show).
//!
//! # Records ([`running_records`])
//! The finest resolution gives the values; the next coarser one, the grid error of each pair
//! (matched by its two loads). A pair whose grid error exceeds the bound, or that the coarser
//! grid did not measure, keeps its value but carries a flag ([`analysis::SlopeFlag`]): it is
//! never to be used silently. `resolution` is the finest grid spacing in λ (the smaller of the
//! two spacings of the window). Formulas: [`analysis::running`].
//!
//! # Isotropy (β)
//! The flux is also measured along the other grid axis ([`Resolution::across`]). The models'
//! conductivity tensor is isotropic in the continuum: the square cell by its four-fold symmetry
//! (K_x = K_y exactly on its square grids too), the hexagonal and triangular cells by their
//! three-fold one (a symmetric 2-tensor invariant under a 120° rotation is a multiple of the
//! identity), so β along and across must agree. Their grids are rectangular and meet the
//! saddles at 0° and ±60° differently: the difference of the two running exponents on the finest
//! grid is a discretisation error the grid-to-grid change need not show (both grids can be
//! anisotropic alike). A pair's grid error is therefore the larger of the two, and a pair whose
//! anisotropy exceeds the bound, or that was not measured across, is flagged
//! ([`SlopeFlag::Anisotropy`]).
//!
//! # Asymptotic estimate ([`asymptotic`])
//! The finest grid's rungs up to the first flagged pair (grid error or anisotropy), fitted with
//! corrections to scaling ([`analysis::corrections`]).

use crate::ladder::Rung;
use crate::scaling::{EdgeOptions, blocked_half_length, open_half_width};
use analysis::{
    AsymptoticError, AsymptoticEstimate, AsymptoticOptions, RunningExponent, ScalingPoint,
    SlopeFlag, asymptotic_estimate, grid_converged_rungs, running_exponents,
};
use surface::Lattice;

/// The near-critical exponents (PHYSICS.md: g = |l|^ζ g±(x/|l|^χ, y/|l|^υ), R ∝ |l|^−β).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Exponent {
    /// Saddle gap, l < 0.
    Zeta,
    /// Open-channel width, l < 0.
    Upsilon,
    /// Blocked-channel length, l > 0.
    Chi,
    /// Flux, l < 0.
    Beta,
}

impl Exponent {
    /// All four, in table order.
    pub const ALL: [Exponent; 4] = [
        Exponent::Zeta,
        Exponent::Upsilon,
        Exponent::Chi,
        Exponent::Beta,
    ];

    /// Table name.
    pub fn name(self) -> &'static str {
        match self {
            Exponent::Zeta => "zeta",
            Exponent::Upsilon => "upsilon",
            Exponent::Chi => "chi",
            Exponent::Beta => "beta",
        }
    }

    /// Whether the exponent is measured above L_c (l > 0) rather than below.
    pub fn above_critical(self) -> bool {
        self == Exponent::Chi
    }
}

/// Options of [`measure`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasureOptions {
    /// 1σ of the saddle gap (h0): the contact solver's tolerance (module docs).
    pub gap_sigma: f64,
    /// Square-root onset fit of the open width.
    pub edge: EdgeOptions,
}

impl Default for MeasureOptions {
    fn default() -> Self {
        MeasureOptions {
            gap_sigma: 1e-10,
            edge: EdgeOptions::default(),
        }
    }
}

/// One grid's measurements of one exponent's quantity.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Resolution {
    /// Finest grid spacing (λ).
    pub spacing: f64,
    /// The rungs' measurements, on one side of L_c.
    pub points: Vec<ScalingPoint>,
    /// The same quantity measured along the other grid axis at the same rungs (β: the flux
    /// across), or empty. The continuum answer is the same (module docs, "Isotropy").
    pub across: Vec<ScalingPoint>,
}

/// Measures `exponent`'s quantity on every rung on its side of L_c (module docs); failures are
/// left out with a line in `notes`. Errors for [`Exponent::Beta`] (not measurable from a rung)
/// and when no rung is on the exponent's side.
pub fn measure(
    rungs: &[Rung],
    exponent: Exponent,
    opts: &MeasureOptions,
    notes: &mut Vec<String>,
) -> Result<Resolution, String> {
    if exponent == Exponent::Beta {
        return Err(
            "β: the flux is not part of a ladder rung; build its points from the flow solves"
                .into(),
        );
    }
    let side: Vec<&Rung> = rungs
        .iter()
        .filter(|r| (r.l > 0.0) == exponent.above_critical() && r.l != 0.0)
        .collect();
    let Some(first) = side.first() else {
        return Err(format!(
            "{}: no rung with l {} 0",
            exponent.name(),
            if exponent.above_critical() { ">" } else { "<" }
        ));
    };
    let spacing = first.window.d_par.min(first.window.d_perp);
    let mut points = Vec::with_capacity(side.len());
    for r in side {
        if !r.converged {
            notes.push(format!(
                "{}, l = {}: solve not converged",
                exponent.name(),
                r.l
            ));
            continue;
        }
        let m = match exponent {
            Exponent::Zeta => {
                let g = r.window.saddle_gap();
                (g > 0.0)
                    .then_some((g, opts.gap_sigma))
                    .ok_or_else(|| "the saddle node is closed".to_string())
            }
            Exponent::Upsilon => open_half_width(&r.window, &opts.edge).map(|e| (e.r, e.r_error)),
            Exponent::Chi => blocked_half_length(&r.window).map(|e| (e.r, e.r_error)),
            Exponent::Beta => unreachable!("rejected above"),
        };
        match m {
            // a fit with no degree of freedom has no error: record none (σ = 0)
            Ok((y, s)) => points.push(ScalingPoint::new(
                r.l,
                y,
                if s.is_finite() { s } else { 0.0 },
            )),
            Err(e) => notes.push(format!("{}, l = {}: {e}", exponent.name(), r.l)),
        }
    }
    Ok(Resolution {
        spacing,
        points,
        across: Vec::new(),
    })
}

/// One row of the running-exponent table.
#[derive(Clone, Debug, PartialEq)]
pub struct RunningRecord {
    /// Model.
    pub model: Lattice,
    /// Exponent.
    pub exponent: Exponent,
    /// The rung farther from L_c (larger |l|), signed.
    pub l_hi: f64,
    /// The rung nearer L_c, signed.
    pub l_lo: f64,
    /// Local slope d ln y / d ln|l| on the finest resolution (for β the flux's: Q ∝ 1/R ∝
    /// |l|^β, so the slope is β itself).
    pub value: f64,
    /// |value − value on the next coarser resolution| (NaN if unknown); with a measurement
    /// across ([`Resolution::across`]) the larger of that and |value − value across| on the
    /// finest resolution (module docs, "Isotropy").
    pub grid_error: f64,
    /// 1σ propagated from the measurements.
    pub fit_error: f64,
    /// Finest grid spacing (λ).
    pub resolution: f64,
    /// Why the value must not be used silently, if so.
    pub flag: Option<SlopeFlag>,
}

impl RunningRecord {
    /// The table's columns, in order.
    pub const COLUMNS: [&'static str; 8] = [
        "model",
        "exponent",
        "l_hi",
        "l_lo",
        "value",
        "grid_error",
        "fit_error",
        "resolution",
    ];
}

/// The finest and the next finest of several grids' measurements (any order).
fn finest_two(levels: &[Resolution]) -> analysis::Result<(&Resolution, Option<&Resolution>)> {
    let mut order: Vec<&Resolution> = levels.iter().collect();
    order.sort_by(|a, b| a.spacing.total_cmp(&b.spacing));
    match order.first() {
        Some(f) => Ok((f, order.get(1).copied())),
        None => Err(analysis::FitError::TooFewPoints {
            what: "running exponents (grids)",
            got: 0,
            needed: 1,
        }),
    }
}

/// The running exponents of one model and exponent from its measurements on several grids
/// (any order): values from the finest spacing, grid errors against the next finest, flagged
/// above `bound` (module docs). One grid only: every pair is flagged (grid error unknown).
/// Errors: no grid, or invalid measurements ([`analysis::running_exponents`]).
pub fn running_records(
    model: Lattice,
    exponent: Exponent,
    levels: &[Resolution],
    bound: f64,
) -> analysis::Result<Vec<RunningRecord>> {
    let (fine, coarse) = finest_two(levels)?;
    let iso = isotropy(fine, bound)?;
    Ok(
        running_exponents(&fine.points, coarse.map(|c| c.points.as_slice()), bound)?
            .into_iter()
            .enumerate()
            .map(|(k, r)| {
                let mut rec = RunningRecord {
                    model,
                    exponent,
                    l_hi: r.slope.l_hi,
                    l_lo: r.slope.l_lo,
                    value: r.slope.value,
                    grid_error: r.grid_error,
                    fit_error: r.slope.fit_error,
                    resolution: fine.spacing,
                    flag: r.flag,
                };
                if let Some(a) = iso.as_ref().map(|v| v[k]) {
                    rec.grid_error = rec.grid_error.max(a.grid_error);
                    if rec.flag.is_none() && a.flag.is_some() {
                        rec.flag = Some(SlopeFlag::Anisotropy {
                            error: a.grid_error,
                            bound,
                        });
                    }
                }
                rec
            })
            .collect(),
    )
}

/// The finest grid's running exponents compared with the same measured across (module docs,
/// "Isotropy"), pair by pair in the order of [`running_exponents`]; `None` if not measured
/// across. A pair missing across has a NaN error and a flag.
fn isotropy(fine: &Resolution, bound: f64) -> analysis::Result<Option<Vec<RunningExponent>>> {
    if fine.across.is_empty() {
        return Ok(None);
    }
    // too few points across to form a pair: every pair unmeasured across
    let across = (fine.across.len() >= 2).then_some(fine.across.as_slice());
    Ok(Some(running_exponents(&fine.points, across, bound)?))
}

/// The asymptotic exponent (l → 0, corrections to scaling; [`analysis::asymptotic_estimate`])
/// from the finest grid's rungs that are grid-converged against the next finest
/// ([`analysis::grid_converged_rungs`]: up to the first running exponent whose grid error
/// exceeds `bound`). Errors: no grid, invalid measurements, or no fit window that constrains the
/// exponent (the error lists every fit tried and why it was rejected).
pub fn asymptotic(
    levels: &[Resolution],
    bound: f64,
    opts: &AsymptoticOptions,
) -> Result<AsymptoticEstimate, AsymptoticError> {
    let (fine, coarse) = finest_two(levels)?;
    let mut rungs = grid_converged_rungs(&fine.points, coarse.map(|c| c.points.as_slice()), bound)?;
    if let Some(iso) = isotropy(fine, bound)? {
        // both lists run from the largest |l|: keep the rungs before the first anisotropic pair
        let isotropic = 1 + iso.iter().take_while(|p| p.flag.is_none()).count();
        rungs.truncate(isotropic);
    }
    asymptotic_estimate(&rungs, opts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ladder::Window;
    use ndarray::Array2;

    /// A rung whose window is built from a pressure field `p(r∥, r⊥)` on spacing `d`
    /// (half-size `k` nodes); the gap is 1 where p = 0 except at the saddle, where it is `g_s`.
    fn rung(l: f64, d: f64, k: usize, g_s: f64, p: impl Fn(f64, f64) -> f64) -> Rung {
        let shape = (2 * k + 1, 2 * k + 1);
        let r = |i: usize| (i as f64 - k as f64) * d;
        let pressure = Array2::from_shape_fn(shape, |(a, b)| p(r(a), r(b)));
        let mut gap = pressure.mapv(|v| if v > 0.0 { 0.0 } else { 1.0 });
        gap[[k, k]] = g_s;
        Rung {
            l,
            load: 1.0 + l,
            contact_area: 0.4,
            window: Window {
                d_par: d,
                d_perp: d,
                gap,
                pressure,
            },
            iterations: 1,
            converged: true,
            retried: false,
            wall_s: 0.0,
        }
    }

    const LS: [f64; 4] = [0.02, 0.01, 0.005, 0.002];

    /// Rungs of synthetic windows with a known scaling of all three quantities on spacing `d`:
    /// saddle gap 0.3|l|^1.2, open half-width 0.2|l|^0.45 (square-root onset across the
    /// channel), blocked half-length 0.3 l^0.6 (Hertzian along the channel).
    fn ladder(d: f64, k: usize) -> Vec<Rung> {
        let mut v = Vec::new();
        for &a in &LS {
            let r_c = 0.2 * a.powf(0.45);
            v.push(rung(-a, d, k, 0.3 * a.powf(1.2), |_, r| {
                2.0 * (r.abs() - r_c).max(0.0).sqrt()
            }));
            let h = 0.3 * a.powf(0.6);
            v.push(rung(a, d, k, 0.0, |x, r| {
                if r == 0.0 {
                    analysis::hertz_profile(x, 3.0, h, 0.0)
                } else {
                    0.0
                }
            }));
        }
        v
    }

    #[test]
    fn synthetic_windows_give_their_exponents_on_both_grids() {
        // the edge fits recover r_c and a to ~1e-8 absolute on these windows (scaling.rs tests),
        // i.e. ≤ 1e-5 relative at the smallest edges (3e-3 λ): over ln 2 … ln 2.5 that moves a
        // slope by ≤ 3e-5, the tolerance; the saddle gap is read exactly (1e-12)
        let fine = ladder(0.002, 40);
        let coarse = ladder(0.004, 20);
        let opts = MeasureOptions::default();
        for (e, want, tol) in [
            (Exponent::Zeta, 1.2, 1e-12),
            (Exponent::Upsilon, 0.45, 3e-5),
            (Exponent::Chi, 0.6, 3e-5),
        ] {
            let mut notes = Vec::new();
            let levels = [
                measure(&coarse, e, &opts, &mut notes).unwrap(),
                measure(&fine, e, &opts, &mut notes).unwrap(),
            ];
            assert!(notes.is_empty(), "{notes:?}");
            assert_eq!(levels[1].points.len(), 4);
            let recs = running_records(Lattice::Square, e, &levels, 0.005).unwrap();
            assert_eq!(recs.len(), 3, "{e:?}");
            let sign = if e.above_critical() { 1.0 } else { -1.0 };
            for (r, w) in recs.iter().zip(LS.windows(2)) {
                assert_eq!((r.l_hi, r.l_lo), (sign * w[0], sign * w[1]));
                assert!((r.value - want).abs() < tol, "{e:?}: {r:?}");
                assert!(r.grid_error < 2.0 * tol && r.flag.is_none(), "{r:?}");
                assert_eq!(r.resolution, 0.002);
                assert!(r.fit_error.is_finite() && r.fit_error >= 0.0);
            }
        }
    }

    #[test]
    fn asymptotic_estimate_stops_at_the_first_flagged_pair() {
        // saddle gaps 0.3|l|^1.2 (1 + 0.8|l|^0.5) on the 12-rung ladder; the coarse grid
        // agrees down to |l| = 1e-3 and then drifts by +2 % per rung (a discretisation error
        // growing towards L_c): the slopes' grid errors there are ln(1.02)/ln(2…2.5) ≥ 0.02, so
        // the fit uses the 6 rungs 5e-2 … 1e-3 (1.7 decades), and on those exact data the direct
        // fit returns ζ = 1.2 to its tolerance (1e-8; analysis::corrections tests)
        let ls = [
            5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5,
        ];
        let g = |a: f64| 0.3 * a.powf(1.2) * (1.0 + 0.8 * a.sqrt());
        let pts = |drift: f64| -> Vec<ScalingPoint> {
            ls.iter()
                .enumerate()
                .map(|(k, &a)| {
                    let d = (1.0 + drift).powi(k.saturating_sub(5) as i32);
                    ScalingPoint::new(-a, g(a) * d, 0.0)
                })
                .collect()
        };
        let levels = [
            Resolution {
                spacing: 1.0 / 2048.0,
                points: pts(0.0),
                across: Vec::new(),
            },
            Resolution {
                spacing: 1.0 / 1024.0,
                points: pts(0.02),
                across: Vec::new(),
            },
        ];
        let e = asymptotic(&levels, 0.005, &AsymptoticOptions::default()).unwrap();
        assert_eq!(e.variants[e.reference].outcome.as_ref().unwrap().points, 6);
        assert!((e.value - 1.2).abs() < 1e-8, "{e:?}");
        let recs = running_records(Lattice::Square, Exponent::Zeta, &levels, 0.005).unwrap();
        assert_eq!(recs.iter().filter(|r| r.flag.is_some()).count(), 6);
        assert!(recs[5].flag.is_some() && recs[4].flag.is_none());
    }

    /// β along and across: equal fluxes change nothing; a flux across that drifts from the
    /// one along near L_c (an anisotropic grid) widens the grid error to the difference of the
    /// two slopes, flags those pairs and ends the asymptotic fit before them, even where the
    /// two grids agree with each other (both anisotropic alike).
    #[test]
    fn anisotropy_widens_grid_errors_and_ends_the_asymptotic_fit() {
        let ls = [
            5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5,
        ];
        let q = |a: f64| a.powf(3.45) * (1.0 + 0.5 * a.sqrt());
        // across: ×1.1 per rung from the 7th (|l| = 5e-4) on, so the slopes differ by
        // ln 1.1 / ln(2 … 2.5) ≥ 0.10 from the pair 1e-3 → 5e-4 on
        let pts = |drift: f64| -> Vec<ScalingPoint> {
            ls.iter()
                .enumerate()
                .map(|(k, &a)| {
                    ScalingPoint::new(
                        -a,
                        q(a) * (1.0 + drift).powi(k.saturating_sub(5) as i32),
                        0.0,
                    )
                })
                .collect()
        };
        let level = |spacing: f64, across: Vec<ScalingPoint>| Resolution {
            spacing,
            points: pts(0.0),
            across,
        };
        // isotropic: the records are those without the check
        let plain = running_records(
            Lattice::Square,
            Exponent::Beta,
            &[level(1.0, Vec::new()), level(2.0, Vec::new())],
            0.005,
        )
        .unwrap();
        let iso = running_records(
            Lattice::Square,
            Exponent::Beta,
            &[level(1.0, pts(0.0)), level(2.0, Vec::new())],
            0.005,
        )
        .unwrap();
        assert_eq!(plain, iso);
        assert!(plain.iter().all(|r| r.flag.is_none()));
        let levels = [level(1.0, pts(0.1)), level(2.0, Vec::new())];
        let recs = running_records(Lattice::Triangular, Exponent::Beta, &levels, 0.005).unwrap();
        assert!(recs[..5].iter().all(|r| r.flag.is_none()), "{recs:?}");
        for r in &recs[5..] {
            assert!(
                matches!(r.flag, Some(SlopeFlag::Anisotropy { error, .. }) if error > 0.1),
                "{r:?}"
            );
            assert!(r.grid_error > 0.1);
        }
        let e = asymptotic(&levels, 0.005, &AsymptoticOptions::default()).unwrap();
        assert_eq!(e.variants[e.reference].outcome.as_ref().unwrap().points, 6);
        // a pair not measured across is flagged with a NaN error
        let short = [level(1.0, pts(0.0)[..3].to_vec()), level(2.0, Vec::new())];
        let recs = running_records(Lattice::Hexagonal, Exponent::Beta, &short, 0.005).unwrap();
        assert!(recs[..2].iter().all(|r| r.flag.is_none()));
        assert!(matches!(
            recs[2].flag,
            Some(SlopeFlag::Anisotropy { error, .. }) if error.is_nan()
        ));
    }

    #[test]
    fn failed_rungs_are_noted_and_pairs_widen_and_single_grids_flag() {
        let mut rungs = ladder(0.002, 40);
        // close the saddle at l = −0.01 and mark l = −0.005 unconverged
        rungs[2].window.gap[[40, 40]] = 0.0;
        rungs[4].converged = false;
        let mut notes = Vec::new();
        let m = measure(
            &rungs,
            Exponent::Zeta,
            &MeasureOptions::default(),
            &mut notes,
        )
        .unwrap();
        assert_eq!(m.points.len(), 2);
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(
            notes[0].contains("-0.01: the saddle node is closed"),
            "{notes:?}"
        );
        assert!(notes[1].contains("not converged"), "{notes:?}");
        let recs = running_records(Lattice::Hexagonal, Exponent::Zeta, &[m], 0.005).unwrap();
        assert_eq!((recs[0].l_hi, recs[0].l_lo), (-0.02, -0.002));
        assert_eq!(recs[0].flag, Some(SlopeFlag::NoCoarse));
        assert!(recs[0].grid_error.is_nan());
        let mut notes = Vec::new();
        assert!(
            measure(
                &rungs,
                Exponent::Beta,
                &MeasureOptions::default(),
                &mut notes
            )
            .is_err()
        );
        assert!(running_records(Lattice::Square, Exponent::Zeta, &[], 0.005).is_err());
        assert_eq!(RunningRecord::COLUMNS.len(), 8);
    }
}
