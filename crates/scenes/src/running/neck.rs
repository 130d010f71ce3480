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

    /// Each neck pair becomes one row: its exponent and measure, loads, value, grid and fit
    /// errors and flag passed through, the ladder's input name and finest spacing (the pairs
    /// themselves are `kinds::refined_neck`'s, tested there).
    #[test]
    fn neck_pairs_become_rows_with_their_exponent_and_measure() {
        let pair = |measure, value, flag: &str| NeckPair {
            measure,
            slope: NeckSlope {
                l_hi: -0.01,
                l_lo: -0.005,
                value,
                fit_error: 1e-4,
                flag: String::new(),
            },
            error_levels: 2e-3,
            error_margin: f64::NAN,
            window_change: f64::NAN,
            grid_error: 2e-3,
            flag: flag.to_string(),
            spacing: 1e-4,
        };
        let p = [
            pair(NeckMeasure::WidthRms, 0.46, ""),
            pair(NeckMeasure::WidthLevel, 0.45, ""),
            pair(NeckMeasure::RiseLength, 0.58, "grid error unknown"),
        ];
        let r = rows(surface::Lattice::Square, &p, "refined", 1e-4);
        assert_eq!(r.len(), 3);
        let want = [
            (Exponent::Upsilon, "neck_width_rms"),
            (Exponent::Upsilon, "neck_width_level"),
            (Exponent::Chi, "neck_rise_length"),
        ];
        for ((row, pair), (e, name)) in r.iter().zip(&p).zip(want) {
            assert_eq!(row.rec.exponent, e);
            assert_eq!(row.measure.name(), name);
            assert!(row.measure.is_neck());
            assert_eq!((row.rec.l_hi, row.rec.l_lo), (-0.01, -0.005));
            assert_eq!(row.rec.value, pair.slope.value);
            assert_eq!(row.rec.grid_error, 2e-3);
            assert_eq!(row.rec.fit_error, 1e-4);
            assert_eq!(row.rec.resolution, 1e-4);
            assert_eq!(row.flag, pair.flag);
            assert_eq!(row.method, "refined");
        }
    }
}
