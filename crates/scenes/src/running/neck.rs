//! The neck rows of `running_exponents.csv` (part of the `running` scene; issue 13,
//! docs/near-critical.md §11–12): running exponents from the lengths of the open neck that
//! `critical::neck_moments` measures on the gap field of every refined rung below p_c
//! (`kinds::refined_neck`), pair by pair of neighbouring rungs that measure the length:
//! - υ_eff from the rms width W_2 (`measure` = `neck_width_rms`) and, as a second measure, from
//!   the level width at g_s/2 (`neck_width_level`);
//! - χ_eff **from below** from the rise length to 2 g_s along the channel (`neck_rise_length`).
//!
//! # Error model (the refined rows', `kinds::refined_ladder`)
//! - `value`: Δ ln y / Δ ln|l| on the ladder's finest discretisation D (the first with the most
//!   levels), y the length.
//! - `grid_error`: the largest of |value − value on the discretisation with one level fewer
//!   (same margin)|, |value − value on the margin check (same level, other margin)| if the
//!   ladder has one, and |Δw| of a window check that covers the ladder (input `window`, the
//!   change at the check's level from the larger window, `kinds::refined_window::fold`); NaN
//!   (unknown) if any of these is unknown: a comparison discretisation lacks the pair or has a
//!   rung of it flagged.
//! - `fit_error`: the estimator's numerical bound (§11, measured on a synthetic neck over 40
//!   contact-line positions: relative e = 0.6 n^−4 for W_2, 0.65 n^−4 for the level width and
//!   the rise length) at both rungs, propagated to the slope as a bound:
//!   (e_hi + e_lo) / ln(|l_hi|/|l_lo|) (added, not in quadrature: a worst case, not a 1σ).
//!   n, the open nodes from the saddle to the edge the estimator resolves: for the widths
//!   (neck_nodes − 1)/2 with `neck_nodes` the stored open fine nodes across the channel through
//!   the saddle (the run is centred on the saddle node; an asymmetric run has one shorter side,
//!   which the artefact does not keep), for the rise length its own length over the fine spacing
//!   (nodes from the saddle to the crossing).
//! - `flag` (first reason): a flagged rung of the pair (`rung l = …: window too small / solve
//!   not converged / saddle closed`, as stored); the window's contact set unchanged between the
//!   two rungs (taken from the stored ζ pairs of the same D: every ζ pair between the two
//!   rungs says so; a set that changes and changes back between non-neighbouring rungs is not
//!   seen: the artefact keeps no contact sets); grid error unknown or above 0.005; then the
//!   window check's flag (`window change unknown / … > 5e-3`). A comparison pair counts only if
//!   neither of its rungs is flagged (its contact set is not stored: not checked there, as in
//!   `kinds::refined_window::level_slopes`).
//!
//! `resolution` is the ladder's finest fine spacing (λ), as for the other refined rows.

use super::Row;
use critical::refined::PairFlag;
use critical::running::{Exponent, RunningRecord};
use kinds::refined_neck::{NeckDisc, NeckRung};
use kinds::refined_window::{Slope, fold, window_change};

/// The grid-error bound (0.005), as for every running row.
pub const GRID_BOUND: f64 = kinds::refined_ladder::GRID_BOUND;

/// What a row of `running_exponents.csv` measures (column `measure`; module docs of
/// `running`): the quantity whose logarithmic slope against |l| the row's value is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Measure {
    /// ζ: the saddle gap.
    SaddleGap,
    /// υ: the open half-width r_c from the contact-line (square-root onset) fit.
    HalfWidth,
    /// χ from above: the blocked half-length a from the Hertz fit.
    HalfLength,
    /// β: the flux (conductivity or the neck's conductance).
    Flux,
    /// υ: the neck's rms width W_2 from the gap field.
    NeckWidthRms,
    /// υ: the neck's width at g_s/2 from the gap field.
    NeckWidthLevel,
    /// χ from below: the rise length to 2 g_s along the channel.
    NeckRiseLength,
}

impl Measure {
    /// The neck measures, in table order.
    pub const NECK: [Measure; 3] = [
        Measure::NeckWidthRms,
        Measure::NeckWidthLevel,
        Measure::NeckRiseLength,
    ];

    /// Table name (the neck ones: the artefact's dataset names).
    pub fn name(self) -> &'static str {
        match self {
            Measure::SaddleGap => "saddle_gap",
            Measure::HalfWidth => "half_width",
            Measure::HalfLength => "half_length",
            Measure::Flux => "flux",
            Measure::NeckWidthRms => "neck_width_rms",
            Measure::NeckWidthLevel => "neck_width_level",
            Measure::NeckRiseLength => "neck_rise_length",
        }
    }

    /// The measure of the rows that existed before the neck rows (one per exponent).
    pub fn of(e: Exponent) -> Measure {
        match e {
            Exponent::Zeta => Measure::SaddleGap,
            Exponent::Upsilon => Measure::HalfWidth,
            Exponent::Chi => Measure::HalfLength,
            Exponent::Beta => Measure::Flux,
        }
    }

    /// The exponent it gives.
    pub fn exponent(self) -> Exponent {
        match self {
            Measure::SaddleGap => Exponent::Zeta,
            Measure::HalfWidth | Measure::NeckWidthRms | Measure::NeckWidthLevel => {
                Exponent::Upsilon
            }
            Measure::HalfLength | Measure::NeckRiseLength => Exponent::Chi,
            Measure::Flux => Exponent::Beta,
        }
    }

    /// A neck measure.
    pub fn is_neck(self) -> bool {
        Measure::NECK.contains(&self)
    }

    /// Index into `NeckRung::lengths` (neck measures only).
    fn column(self) -> usize {
        match self {
            Measure::NeckWidthRms => 0,
            Measure::NeckWidthLevel => 1,
            _ => 2,
        }
    }

    /// The relative error law's coefficient c of c n^−4 (module docs).
    pub fn bound_coefficient(self) -> f64 {
        match self {
            Measure::NeckWidthRms => 0.6,
            _ => 0.65,
        }
    }
}

/// One measured rung: (l, length, n of the error law, rung flag).
#[derive(Clone, Debug, PartialEq)]
struct Point<'a> {
    l: f64,
    y: f64,
    n: f64,
    flag: &'a str,
}

/// The rungs of `d` below p_c that measure `m` (a finite positive length), by descending |l|.
fn points(d: &NeckDisc, m: Measure) -> Vec<Point<'_>> {
    let mut p: Vec<Point> = d
        .rungs
        .iter()
        .filter(|r| r.l < 0.0)
        .filter_map(|r: &NeckRung| {
            let y = r.lengths[m.column()];
            (y.is_finite() && y > 0.0).then(|| Point {
                l: r.l,
                y,
                n: if m == Measure::NeckRiseLength {
                    y / d.spacing
                } else {
                    (r.neck_nodes as f64 - 1.0) / 2.0
                },
                flag: r.flag.as_str(),
            })
        })
        .collect();
    p.sort_by(|a, b| b.l.abs().total_cmp(&a.l.abs()));
    p
}

/// One neighbouring pair of one discretisation: the slope, its propagated bound, and its own
/// flag (a flagged rung; empty: usable).
#[derive(Clone, Debug, PartialEq)]
pub struct NeckSlope {
    /// The rung farther from p_c (signed).
    pub l_hi: f64,
    /// The nearer one.
    pub l_lo: f64,
    /// Δ ln y / Δ ln |l|.
    pub value: f64,
    /// (e_hi + e_lo) / ln(|l_hi|/|l_lo|), e = c n^−4 (module docs).
    pub fit_error: f64,
    /// `rung l = …: …` of the first flagged rung (empty: none).
    pub flag: String,
}

/// The running pairs of `m` between neighbouring measuring rungs of `d`.
pub fn slopes(d: &NeckDisc, m: Measure) -> Vec<NeckSlope> {
    let c = m.bound_coefficient();
    points(d, m)
        .windows(2)
        .map(|w| {
            let (a, b) = (&w[0], &w[1]);
            let span = (a.l.abs() / b.l.abs()).ln();
            let flag = [a, b]
                .iter()
                .find(|x| !x.flag.is_empty())
                .map_or(String::new(), |x| format!("rung l = {:e}: {}", x.l, x.flag));
            NeckSlope {
                l_hi: a.l,
                l_lo: b.l,
                value: (a.y / b.y).ln() / span,
                fit_error: c * (a.n.powi(-4) + b.n.powi(-4)) / span,
                flag,
            }
        })
        .collect()
}

fn as_slopes(s: &[NeckSlope]) -> Vec<Slope> {
    s.iter()
        .map(|p| Slope {
            l_hi: p.l_hi,
            l_lo: p.l_lo,
            value: p.value,
            flag: p.flag.clone(),
        })
        .collect()
}

/// The window check of a ladder as the neck rows take it.
#[derive(Clone, Copy, Debug)]
pub enum NeckWindow<'a> {
    /// No window check covers the ladder: no window term.
    None,
    /// The check's own discretisation (`kinds::refined_neck::read_window`: the larger window at
    /// the check's level and margin, which it is compared with).
    Check(&'a NeckDisc),
    /// A check covers the ladder but has no neck lengths (written before they were stored):
    /// the window change is unknown at every pair.
    Unknown,
}

/// A refined ladder's neck data (`kinds::refined_neck::read_ladder`) with what the neck rows
/// need beside it.
#[derive(Clone, Debug)]
pub struct NeckLadder<'a> {
    /// Every discretisation, as stored (coarse to fine, then the margin check).
    pub discs: &'a [NeckDisc],
    /// The finest D's stored ζ pairs (l_hi, l_lo, flag): their "contact set unchanged" flags.
    pub zeta: Vec<(f64, f64, String)>,
    /// Its window check.
    pub window: NeckWindow<'a>,
}

/// One neck pair of the finest discretisation with its error terms.
#[derive(Clone, Debug, PartialEq)]
pub struct NeckPair {
    /// Which length.
    pub measure: Measure,
    /// The pair on the finest D.
    pub slope: NeckSlope,
    /// |change from one level fewer| (NaN: unknown).
    pub error_levels: f64,
    /// |change from the margin check| (NaN: unknown or no margin check).
    pub error_margin: f64,
    /// Δw of the window check (NaN: unknown or none).
    pub window_change: f64,
    /// The grid error (module docs).
    pub grid_error: f64,
    /// Empty, or why it must not be used silently (module docs).
    pub flag: String,
    /// The finest D's fine spacing (λ).
    pub spacing: f64,
}

/// Whether the window's contact set was unchanged between `hi` and `lo` by the stored ζ pairs:
/// the ζ pairs from `hi` to `lo` chain without a gap and every one is flagged for it.
fn frozen(zeta: &[(f64, f64, String)], hi: f64, lo: f64) -> bool {
    let tag = PairFlag::Frozen.to_string();
    let Some(start) = zeta.iter().position(|z| analysis::same_load(z.0, hi)) else {
        return false;
    };
    let mut at = hi;
    for z in &zeta[start..] {
        if !analysis::same_load(z.0, at) || z.2 != tag {
            return false;
        }
        at = z.1;
        if analysis::same_load(at, lo) {
            return true;
        }
    }
    false
}

/// Every neck pair of `ladder`'s finest discretisation for every neck measure (module docs);
/// empty without discretisations.
pub fn pairs(ladder: &NeckLadder) -> Vec<NeckPair> {
    let discs = ladder.discs;
    let Some(k) = discs.iter().map(|d| d.levels).max() else {
        return Vec::new();
    };
    let fine = discs
        .iter()
        .find(|d| d.levels == k)
        .expect("the maximum is one of them");
    let coarser = discs
        .iter()
        .filter(|d| d.margin == fine.margin && d.levels < k)
        .max_by_key(|d| d.levels);
    let margin = discs
        .iter()
        .find(|d| d.levels == k && d.margin != fine.margin);
    // the checked D at the check's level and margin (None: no check, or no such D: every
    // window change unknown, as for a check without neck lengths)
    let checked = match ladder.window {
        NeckWindow::Check(c) => discs
            .iter()
            .find(|d| d.levels == c.levels && d.margin == c.margin)
            .map(|d| (d, c)),
        _ => None,
    };
    let checked_at_all = !matches!(ladder.window, NeckWindow::None);
    let mut out = Vec::new();
    for m in Measure::NECK {
        let other = |d: Option<&NeckDisc>| d.map(|d| as_slopes(&slopes(d, m)));
        let (co, ma) = (other(coarser), other(margin));
        let change = |set: &Option<Vec<Slope>>, s: &NeckSlope| {
            set.as_ref()
                .and_then(|v| {
                    v.iter()
                        .find(|c| {
                            analysis::same_load(c.l_hi, s.l_hi)
                                && analysis::same_load(c.l_lo, s.l_lo)
                        })
                        .filter(|c| c.usable())
                        .map(|c| (s.value - c.value).abs())
                })
                .unwrap_or(f64::NAN)
        };
        let win = checked.map(|(d, c)| (as_slopes(&slopes(d, m)), as_slopes(&slopes(c, m))));
        for s in slopes(fine, m) {
            let el = change(&co, &s);
            let em = change(&ma, &s);
            let grid = if el.is_nan() || (margin.is_some() && em.is_nan()) {
                f64::NAN
            } else {
                el.max(if em.is_nan() { 0.0 } else { em })
            };
            let mut flag = if !s.flag.is_empty() {
                s.flag.clone()
            } else if frozen(&ladder.zeta, s.l_hi, s.l_lo) {
                PairFlag::Frozen.to_string()
            } else if grid.is_nan() {
                PairFlag::Unknown.to_string()
            } else if grid > GRID_BOUND {
                PairFlag::GridError {
                    error: grid,
                    bound: GRID_BOUND,
                }
                .to_string()
            } else {
                String::new()
            };
            let (mut grid_error, mut dw) = (grid, f64::NAN);
            if checked_at_all {
                if let Some((checked, check)) = &win {
                    dw = window_change(checked, check, s.l_hi, s.l_lo);
                }
                (grid_error, flag) = fold(grid, &flag, dw, GRID_BOUND);
            }
            out.push(NeckPair {
                measure: m,
                error_levels: el,
                error_margin: em,
                window_change: dw,
                grid_error,
                flag,
                spacing: fine.spacing,
                slope: s,
            });
        }
    }
    out
}

/// The neck pairs as rows of `running_exponents.csv` (`method` the ladder's input name,
/// `resolution` the ladder's finest spacing `spacing`).
pub fn rows(
    model: surface::Lattice,
    pairs: &[NeckPair],
    method: &'static str,
    spacing: f64,
) -> Vec<Row> {
    pairs
        .iter()
        .map(|p| Row {
            rec: RunningRecord {
                model,
                exponent: p.measure.exponent(),
                l_hi: p.slope.l_hi,
                l_lo: p.slope.l_lo,
                value: p.slope.value,
                grid_error: p.grid_error,
                fit_error: p.slope.fit_error,
                resolution: spacing,
                flag: None,
            },
            flag: p.flag.clone(),
            method,
            measure: p.measure,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const LS: [f64; 5] = [-0.02, -0.01, -0.005, -0.002, 0.01];
    const UPS: f64 = 0.45;
    const CHI: f64 = 0.58;

    /// A synthetic discretisation: widths A|l|^(υ + du), rise B|l|^(χ + dc) (a pure power law
    /// per discretisation: every slope exact), `neck_nodes` from the rms width over the spacing
    /// (2 W/h + 1, as a neck of half-width W would hold), flags per rung.
    fn disc(levels: u32, margin: u32, du: f64, dc: f64, flags: &[(f64, &str)]) -> NeckDisc {
        let spacing = 1e-3 / f64::from(1u32 << levels);
        NeckDisc {
            levels,
            margin,
            spacing,
            rungs: LS
                .iter()
                .map(|&l| {
                    let below = l < 0.0;
                    let w = if below {
                        0.3 * l.abs().powf(UPS + du)
                    } else {
                        f64::NAN
                    };
                    NeckRung {
                        l,
                        neck_nodes: if below {
                            (2.0 * w / spacing).round() as usize + 1
                        } else {
                            0
                        },
                        flag: flags
                            .iter()
                            .find(|f| f.0 == l)
                            .map_or(String::new(), |f| f.1.to_string()),
                        lengths: [
                            w,
                            0.8 * w,
                            if below {
                                0.5 * l.abs().powf(CHI + dc)
                            } else {
                                f64::NAN
                            },
                        ],
                    }
                })
                .collect(),
        }
    }

    fn ladder<'a>(discs: &'a [NeckDisc], window: NeckWindow<'a>) -> NeckLadder<'a> {
        NeckLadder {
            discs,
            zeta: Vec::new(),
            window,
        }
    }

    fn of(p: &[NeckPair], m: Measure) -> Vec<&NeckPair> {
        p.iter().filter(|x| x.measure == m).collect()
    }

    /// Two levels and a margin check with known slope changes: the finest level's exponents
    /// back exactly, the grid error the larger of the two changes, the fit error the bound
    /// propagated from the stored node counts, no flag.
    #[test]
    fn synthetic_ladder_gives_exponents_grid_and_fit_errors() {
        let discs = [
            disc(1, 5, 0.002, -0.003, &[]),
            disc(2, 5, 0.0, 0.0, &[]),
            disc(2, 7, -0.001, 0.004, &[]),
        ];
        let p = pairs(&ladder(&discs, NeckWindow::None));
        // three pairs below p_c per measure; the rung above p_c measures nothing
        assert_eq!(p.len(), 9);
        for (m, want, grid) in [
            (Measure::NeckWidthRms, UPS, 0.002),
            (Measure::NeckWidthLevel, UPS, 0.002),
            (Measure::NeckRiseLength, CHI, 0.004),
        ] {
            let v = of(&p, m);
            assert_eq!(v.len(), 3, "{m:?}");
            for (k, x) in v.iter().enumerate() {
                assert_eq!((x.slope.l_hi, x.slope.l_lo), (LS[k], LS[k + 1]));
                assert!((x.slope.value - want).abs() < 1e-12, "{m:?} {x:?}");
                assert!((x.grid_error - grid).abs() < 1e-12, "{m:?} {x:?}");
                assert!(x.flag.is_empty(), "{x:?}");
                assert!(x.window_change.is_nan());
                assert_eq!(x.spacing, discs[1].spacing);
                // the bound: c (n_hi^-4 + n_lo^-4) / ln(|l_hi|/|l_lo|), n from the finest D
                let n = |l: f64| {
                    let r = discs[1].rungs.iter().find(|r| r.l == l).unwrap();
                    if m == Measure::NeckRiseLength {
                        r.lengths[2] / discs[1].spacing
                    } else {
                        (r.neck_nodes as f64 - 1.0) / 2.0
                    }
                };
                let want_fit = m.bound_coefficient() * (n(LS[k]).powi(-4) + n(LS[k + 1]).powi(-4))
                    / (LS[k] / LS[k + 1]).ln();
                assert!((x.slope.fit_error - want_fit).abs() < 1e-15 * want_fit.max(1.0));
                assert!(x.slope.fit_error > 0.0 && x.slope.fit_error < 1e-3);
            }
        }
        let rows = rows(surface::Lattice::Square, &p, "refined", discs[1].spacing);
        assert_eq!(rows.len(), 9);
        assert!(
            rows[..6]
                .iter()
                .all(|r| r.rec.exponent == Exponent::Upsilon)
        );
        assert!(rows[6..].iter().all(|r| r.rec.exponent == Exponent::Chi));
        assert_eq!(rows[0].measure.name(), "neck_width_rms");
    }

    /// Flags: a change above 0.005, a missing comparison (unknown), a flagged rung, a frozen
    /// contact set (from the ζ pairs), and a window check folded in (known Δw; unknown where
    /// the check lacks the pair; a check without neck lengths: every pair unknown).
    #[test]
    fn flags_follow_the_refined_rows() {
        let bad = "solve not converged";
        // the coarser D differs by 0.008 (> 0.005) in υ; its rung at −0.002 is flagged
        let discs = [
            disc(1, 5, 0.008, 0.0, &[(-0.002, bad)]),
            disc(2, 5, 0.0, 0.0, &[(-0.02, bad)]),
        ];
        let mut lad = ladder(&discs, NeckWindow::None);
        lad.zeta = vec![
            (-0.02, -0.01, "x".into()),
            (-0.01, -0.005, PairFlag::Frozen.to_string()),
            (-0.005, -0.002, String::new()),
        ];
        let p = pairs(&lad);
        let rms = of(&p, Measure::NeckWidthRms);
        assert_eq!(rms[0].flag, format!("rung l = {:e}: {bad}", -0.02));
        assert_eq!(rms[1].flag, PairFlag::Frozen.to_string());
        assert!((rms[1].grid_error - 0.008).abs() < 1e-12);
        // the coarser D's pair has a flagged rung: the level change unknown
        assert!(rms[2].grid_error.is_nan());
        assert_eq!(rms[2].flag, "grid error unknown");
        let rise = of(&p, Measure::NeckRiseLength);
        assert!(rise[1].flag.contains("unchanged"));
        assert!(rise[2].flag == "grid error unknown");
        // no flags in the coarser level's υ but a larger change: flagged for the grid error
        let discs = [disc(1, 5, 0.008, 0.0, &[]), disc(2, 5, 0.0, 0.0, &[])];
        let p = pairs(&ladder(&discs, NeckWindow::None));
        assert_eq!(
            of(&p, Measure::NeckWidthRms)[0].flag,
            "grid error 8.00e-3 > 5.00e-3"
        );
        assert!(of(&p, Measure::NeckRiseLength)[0].flag.is_empty());

        // a window check at k = 1 (margin 5): Δw = (υ + 0.003) − (υ + 0.001) = 0.002 folded in;
        // the check lacks the rung −0.002 (not measured there): that pair's Δw unknown
        let discs = [disc(1, 5, 0.001, 0.0, &[]), disc(2, 5, 0.0, 0.0, &[])];
        let mut check = disc(1, 5, 0.003, 0.009, &[]);
        check.rungs[3].lengths = [f64::NAN; 3];
        let p = pairs(&ladder(&discs, NeckWindow::Check(&check)));
        let rms = of(&p, Measure::NeckWidthRms);
        assert!((rms[0].window_change - 0.002).abs() < 1e-12);
        assert!((rms[0].grid_error - 0.002).abs() < 1e-12, "{:?}", rms[0]);
        assert!(rms[0].flag.is_empty());
        assert!(rms[2].window_change.is_nan() && rms[2].grid_error.is_nan());
        assert_eq!(rms[2].flag, "window change unknown");
        let rise = of(&p, Measure::NeckRiseLength);
        assert!((rise[0].window_change - 0.009).abs() < 1e-12);
        assert_eq!(rise[0].flag, "window change 9.00e-3 > 5.00e-3");
        let p = pairs(&ladder(&discs, NeckWindow::Unknown));
        assert!(
            p.iter()
                .all(|x| x.flag == "window change unknown" && x.grid_error.is_nan())
        );
        // one level only: every grid error unknown
        let one = [disc(2, 5, 0.0, 0.0, &[])];
        let p = pairs(&ladder(&one, NeckWindow::None));
        assert!(p.iter().all(|x| x.flag == "grid error unknown"));
        assert!(pairs(&ladder(&[], NeckWindow::None)).is_empty());
    }
}
