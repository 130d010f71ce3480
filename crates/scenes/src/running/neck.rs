//! The neck rows of `running_exponents.csv` (part of the `running` scene; issue 13,
//! docs/near-critical.md §11–12): running exponents from the lengths of the open neck that
//! `critical::neck_moments` measures on the gap field of every refined rung below p_c, pair by
//! pair of neighbouring rungs that measure the length: υ_eff from the rms width W_2 (`measure` =
//! `neck_width_rms`) and, as a second measure, from the level width at g_s/2
//! (`neck_width_level`); χ_eff **from below** from the rise length to 2 g_s along the channel
//! (`neck_rise_length`).
//!
//! The pairs, their error model (value, grid error, fit error, flags) and the reading of the
//! artefacts are `kinds::refined_neck`'s ([`pairs`], `kinds::refined_neck::read_linked`; the
//! `exponents` kind fits its asymptotic υ and χ from below to the same pairs); this module
//! turns them into rows. `resolution` is the ladder's finest fine spacing (λ), as for the other
//! refined rows.

use super::Row;
use critical::running::{Exponent, RunningRecord};
pub use kinds::refined_neck::{
    NeckLadder, NeckMeasure, NeckPair, NeckSlope, NeckWindow, pairs, slopes,
};

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

    /// Table name (the neck ones: the artefact's dataset names, [`NeckMeasure::name`]).
    pub fn name(self) -> &'static str {
        match self {
            Measure::SaddleGap => "saddle_gap",
            Measure::HalfWidth => "half_width",
            Measure::HalfLength => "half_length",
            Measure::Flux => "flux",
            m => m.neck().expect("the others are neck measures").name(),
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

    /// The measure of a neck length.
    pub fn of_neck(m: NeckMeasure) -> Measure {
        match m {
            NeckMeasure::WidthRms => Measure::NeckWidthRms,
            NeckMeasure::WidthLevel => Measure::NeckWidthLevel,
            NeckMeasure::RiseLength => Measure::NeckRiseLength,
        }
    }

    /// The neck length it is (None: not a neck measure).
    pub fn neck(self) -> Option<NeckMeasure> {
        match self {
            Measure::NeckWidthRms => Some(NeckMeasure::WidthRms),
            Measure::NeckWidthLevel => Some(NeckMeasure::WidthLevel),
            Measure::NeckRiseLength => Some(NeckMeasure::RiseLength),
            _ => None,
        }
    }

    /// The exponent it gives.
    pub fn exponent(self) -> Exponent {
        match self {
            Measure::SaddleGap => Exponent::Zeta,
            Measure::HalfWidth => Exponent::Upsilon,
            Measure::HalfLength => Exponent::Chi,
            Measure::Flux => Exponent::Beta,
            m => m.neck().expect("the others are neck measures").exponent(),
        }
    }

    /// A neck measure.
    pub fn is_neck(self) -> bool {
        self.neck().is_some()
    }
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
            measure: Measure::of_neck(p.measure),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use critical::refined::PairFlag;
    use kinds::refined_neck::{NeckDisc, NeckRung};

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
        p.iter()
            .filter(|x| Measure::of_neck(x.measure) == m)
            .collect()
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
                let want_fit = m.neck().unwrap().bound_coefficient()
                    * (n(LS[k]).powi(-4) + n(LS[k + 1]).powi(-4))
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
