//! The neck lengths of the refined kinds' artefacts (issue 13, docs/near-critical.md §11–12):
//! per discretisation, every rung's reduced load, open fine nodes across the neck
//! (`neck_nodes`), flag and the three lengths `critical::refined::NeckRecord` records
//! (`neck_width_rms`, `neck_width_level`, `neck_rise_length`, λ, NaN where not measured), which
//! `refined_ladder::write_rungs` writes beside the rung records of a `refined_ladder` artefact
//! (`d/<i>/*`) and of a `refined_window` artefact (`rungs/*`); and their running pairs with the
//! refined ladders' error model ([`pairs`]), as the `running` scene's neck rows and the
//! `exponents` kind's asymptotic υ and χ from below
//! (`crate::exponents::asymptotic::estimate_neck`) take them.
//!
//! A reader and pure functions only: kept apart from `refined_ladder` and `refined_window` so
//! that those compute kinds' code identities (and their expensive caches) stay as they are. An
//! artefact written before the neck lengths were stored has no such datasets: the readers then
//! return `None` (the caller says so), never zeros.
//!
//! # The running pairs ([`pairs`]; the refined rows' error model, `crate::refined_ladder`)
//! Per neck length ([`NeckMeasure`]): υ_eff from the rms width W_2 (`neck_width_rms`) and, as a
//! second measure, from the level width at g_s/2 (`neck_width_level`); χ_eff **from below** from
//! the rise length to 2 g_s along the channel (`neck_rise_length`); pair by pair of
//! neighbouring rungs below p_c that measure the length:
//! - `value`: Δ ln y / Δ ln|l| on the ladder's finest discretisation D (the first with the most
//!   levels, [`finest`]), y the length.
//! - `grid_error`: the largest of |value − value on the discretisation with one level fewer
//!   (same margin)|, |value − value on the margin check (same level, other margin)| if the
//!   ladder has one, and |Δw| of a window check that covers the ladder (input `window`, the
//!   change at the check's level from the larger window, `crate::refined_window::fold`); NaN
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
//!   `crate::refined_window::level_slopes`).

use crate::refined_chain::Linked;
use crate::refined_ladder::{GRID_BOUND, RefinedRungRow};
use crate::refined_window::{Slope, WindowCheck, fold, window_change};
use analysis::ScalingPoint;
use anyhow::{Result, anyhow};
use critical::refined::{LadderPair, Measured, PairFlag, grid_error};
use critical::running::Exponent;
use formats::records::read_in;
use store::ArtefactReader;

/// The neck datasets beside a rung record, in [`NeckRung::lengths`] order (the names of
/// [`NeckMeasure::ALL`]).
pub const NECK_DATASETS: [&str; 3] = ["neck_width_rms", "neck_width_level", "neck_rise_length"];

/// A neck length (module docs): the quantity whose logarithmic slope against |l| a neck pair is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NeckMeasure {
    /// υ: the neck's rms width W_2 from the gap field.
    WidthRms,
    /// υ: the neck's width at g_s/2 from the gap field.
    WidthLevel,
    /// χ from below: the rise length to 2 g_s along the channel.
    RiseLength,
}

impl NeckMeasure {
    /// Every neck length, in [`NECK_DATASETS`] order.
    pub const ALL: [NeckMeasure; 3] = [
        NeckMeasure::WidthRms,
        NeckMeasure::WidthLevel,
        NeckMeasure::RiseLength,
    ];

    /// Index into [`NeckRung::lengths`] and [`NECK_DATASETS`].
    pub fn column(self) -> usize {
        match self {
            NeckMeasure::WidthRms => 0,
            NeckMeasure::WidthLevel => 1,
            NeckMeasure::RiseLength => 2,
        }
    }

    /// The artefact's dataset name (also the `measure` of the tables' neck rows).
    pub fn name(self) -> &'static str {
        NECK_DATASETS[self.column()]
    }

    /// The exponent it gives (υ for the widths, χ from below for the rise length).
    pub fn exponent(self) -> Exponent {
        match self {
            NeckMeasure::WidthRms | NeckMeasure::WidthLevel => Exponent::Upsilon,
            NeckMeasure::RiseLength => Exponent::Chi,
        }
    }

    /// The relative error law's coefficient c of c n^−4 (module docs).
    pub fn bound_coefficient(self) -> f64 {
        match self {
            NeckMeasure::WidthRms => 0.6,
            _ => 0.65,
        }
    }
}

/// One rung's neck data as stored.
#[derive(Clone, Debug, PartialEq)]
pub struct NeckRung {
    /// Reduced load from the discretisation's own p_c (signed).
    pub l: f64,
    /// Open fine nodes across the channel through the saddle (`RefinedRungRow::neck_nodes`).
    pub neck_nodes: usize,
    /// The rung's flag (empty: unflagged), as stored in `<at>/flag`.
    pub flag: String,
    /// rms width W_2, level width, rise length (λ; [`NECK_DATASETS`] order), NaN where not
    /// measured.
    pub lengths: [f64; 3],
}

/// One discretisation's rungs with their neck data.
#[derive(Clone, Debug, PartialEq)]
pub struct NeckDisc {
    /// Refinement levels k.
    pub levels: u32,
    /// Margin (base cells).
    pub margin: u32,
    /// Fine spacing (λ).
    pub spacing: f64,
    /// Its rungs, as stored (ascending l).
    pub rungs: Vec<NeckRung>,
}

/// The rungs at `at` (`d/<i>` or `rungs`) with their neck data; `None` if the artefact has no
/// neck datasets there (written before they were stored).
pub fn read_rungs(r: &ArtefactReader, at: &str) -> Result<Option<Vec<NeckRung>>> {
    if NECK_DATASETS
        .iter()
        .any(|n| !r.has_dataset(&format!("{at}/{n}")))
    {
        return Ok(None);
    }
    let rows: Vec<RefinedRungRow> = read_in(r, at)?;
    let flags = r.read_strings(&format!("{at}/flag"))?;
    let mut cols = Vec::with_capacity(3);
    for name in NECK_DATASETS {
        cols.push(r.read_f64_1d(&format!("{at}/{name}"))?);
    }
    for (len, what) in [(flags.len(), "flag")]
        .into_iter()
        .chain(NECK_DATASETS.iter().zip(&cols).map(|(n, c)| (c.len(), *n)))
    {
        if len != rows.len() {
            return Err(anyhow!(
                "{}: {at}/{what}: {len} values for {} rungs (allowed: one per rung)",
                r.path().display(),
                rows.len()
            ));
        }
    }
    Ok(Some(
        rows.iter()
            .enumerate()
            .map(|(k, row)| NeckRung {
                l: row.l,
                neck_nodes: row.neck_nodes,
                flag: flags[k].clone(),
                lengths: [cols[0][k], cols[1][k], cols[2][k]],
            })
            .collect(),
    ))
}

/// Every discretisation of a `refined_ladder` artefact (`d/<i>`, in the order of
/// `refined_ladder::RefinedData::read`: coarse to fine, then the margin check); `None` if one
/// lacks the neck datasets.
pub fn read_ladder(r: &ArtefactReader) -> Result<Option<Vec<NeckDisc>>> {
    let mut names = r.members("d")?;
    names.sort_by_key(|n| n.parse::<usize>().unwrap_or(usize::MAX));
    let mut out = Vec::with_capacity(names.len());
    for name in names {
        let at = format!("d/{name}");
        let Some(rungs) = read_rungs(r, &at)? else {
            return Ok(None);
        };
        out.push(NeckDisc {
            levels: r.attr_i64_at(&at, "levels")? as u32,
            margin: r.attr_i64_at(&at, "margin")? as u32,
            spacing: r.attr_f64_at(&at, "spacing")?,
            rungs,
        });
    }
    Ok(Some(out))
}

/// The one discretisation of a `refined_window` artefact (`rungs/*`: level `level`, margin
/// `margin`, the check's window and spacing); `None` without neck datasets.
pub fn read_window(r: &ArtefactReader) -> Result<Option<NeckDisc>> {
    let Some(rungs) = read_rungs(r, "rungs")? else {
        return Ok(None);
    };
    Ok(Some(NeckDisc {
        levels: r.attr_i64("level")? as u32,
        margin: r.attr_i64("margin")? as u32,
        spacing: r.attr_f64("spacing")?,
        rungs,
    }))
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
fn measured(d: &NeckDisc, m: NeckMeasure) -> Vec<Point<'_>> {
    let mut p: Vec<Point> = d
        .rungs
        .iter()
        .filter(|r| r.l < 0.0)
        .filter_map(|r: &NeckRung| {
            let y = r.lengths[m.column()];
            (y.is_finite() && y > 0.0).then(|| Point {
                l: r.l,
                y,
                n: if m == NeckMeasure::RiseLength {
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
pub fn slopes(d: &NeckDisc, m: NeckMeasure) -> Vec<NeckSlope> {
    let c = m.bound_coefficient();
    measured(d, m)
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

/// The window check of a ladder as the neck pairs take it.
#[derive(Clone, Copy, Debug)]
pub enum NeckWindow<'a> {
    /// No window check covers the ladder: no window term.
    None,
    /// The check's own discretisation ([`read_window`]: the larger window at the check's level
    /// and margin, which it is compared with).
    Check(&'a NeckDisc),
    /// A check covers the ladder but has no neck lengths (written before they were stored):
    /// the window change is unknown at every pair.
    Unknown,
}

/// A refined ladder's neck data ([`read_ladder`]) with what its neck pairs need beside it.
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
    pub measure: NeckMeasure,
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

/// The finest discretisation (module docs): the first with the most levels; None without one.
pub fn finest(discs: &[NeckDisc]) -> Option<&NeckDisc> {
    let k = discs.iter().map(|d| d.levels).max()?;
    discs.iter().find(|d| d.levels == k)
}

/// Every neck pair of `ladder`'s finest discretisation for every neck measure, in
/// [`NeckMeasure::ALL`] order (module docs); empty without discretisations.
pub fn pairs(ladder: &NeckLadder) -> Vec<NeckPair> {
    let discs = ladder.discs;
    let Some(fine) = finest(discs) else {
        return Vec::new();
    };
    let k = fine.levels;
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
    for m in NeckMeasure::ALL {
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
            let grid = grid_error(el, em, margin.is_some());
            let mut flag = if !s.flag.is_empty() {
                s.flag.clone()
            } else if frozen(&ladder.zeta, s.l_hi, s.l_lo) {
                PairFlag::Frozen.to_string()
            } else {
                PairFlag::grid(grid, GRID_BOUND).map_or_else(String::new, |f| f.to_string())
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

/// The rungs of `ladder`'s finest discretisation below p_c that measure `m`, as the asymptotic
/// fit takes them (signed l, the length, σ = 0: the estimator's bound is a worst case, not a
/// 1σ, so the fits are unweighted and scaled by their misfit, `analysis::corrections`), by
/// descending |l|.
pub fn points(ladder: &NeckLadder, m: NeckMeasure) -> Vec<ScalingPoint> {
    finest(ladder.discs).map_or(Vec::new(), |d| {
        measured(d, m)
            .iter()
            .map(|p| ScalingPoint::new(p.l, p.y, 0.0))
            .collect()
    })
}

/// The neck pairs of `m` in `pairs` as `critical::refined::chained_ladder` takes them: usable
/// where unflagged (module docs: the flag holds the grid error, the window change, the rungs'
/// own flags and a frozen contact set) with a finite value.
pub fn ladder_pairs(pairs: &[NeckPair], m: NeckMeasure) -> Vec<LadderPair> {
    pairs
        .iter()
        .filter(|p| p.measure == m)
        .map(|p| LadderPair {
            l_hi: p.slope.l_hi,
            l_lo: p.slope.l_lo,
            usable: p.flag.is_empty() && p.slope.value.is_finite(),
        })
        .collect()
}

/// A refined ladder's neck data as read ([`read_linked`]): owns what a [`NeckLadder`] borrows.
#[derive(Clone, Debug)]
pub struct LinkedNeck {
    /// Every discretisation ([`read_ladder`]).
    pub discs: Vec<NeckDisc>,
    /// The finest D's stored ζ pairs (l_hi, l_lo, flag), as [`NeckLadder::zeta`].
    pub zeta: Vec<(f64, f64, String)>,
    /// Whether a window check covers the ladder.
    pub checked: bool,
    /// That check's discretisation ([`read_window`]; None: no check, or one without neck
    /// lengths).
    pub check: Option<NeckDisc>,
    /// A note for the stage's warnings (a window check without neck lengths).
    pub note: Option<String>,
}

impl LinkedNeck {
    /// The ladder its pairs are taken from.
    pub fn ladder(&self) -> NeckLadder<'_> {
        NeckLadder {
            discs: &self.discs,
            zeta: self.zeta.clone(),
            window: match (self.checked, &self.check) {
                (false, _) => NeckWindow::None,
                (true, Some(c)) => NeckWindow::Check(c),
                (true, None) => NeckWindow::Unknown,
            },
        }
    }
}

/// The neck data of one refined ladder of a chain (`crate::refined_chain::read_linked`): `r`
/// its artefact, `windows` the window checks' artefacts (input `window`; the one that checks it,
/// if any, gives the window term). `Ok(Err(note))` if its artefact has no neck lengths (written
/// before they were stored): the caller warns.
pub fn read_linked(
    link: &Linked,
    r: &ArtefactReader,
    windows: &[ArtefactReader],
) -> Result<std::result::Result<LinkedNeck, String>> {
    let d = &link.data;
    let Some(discs) = read_ladder(r)? else {
        return Ok(Err(format!(
            "{} `{}` ladder ({}): no neck lengths in the artefact (written before they were stored)",
            d.lattice.name(),
            link.depth.input(),
            r.path().display()
        )));
    };
    let base = r.attr_i64("base")? as u32;
    let mut check = None;
    for w in windows {
        if WindowCheck::read(w)?.checks(d, base) {
            check = Some(w);
        }
    }
    let check_disc = match check {
        Some(w) => read_window(w)?,
        None => None,
    };
    let note = (check.is_some() && check_disc.is_none()).then(|| {
        format!(
            "{} `{}` ladder: its window check has no neck lengths (written before they were stored): every neck pair's window change unknown (flagged)",
            d.lattice.name(),
            link.depth.input()
        )
    });
    Ok(Ok(LinkedNeck {
        discs,
        zeta: d
            .running
            .iter()
            .filter(|p| p.exponent == Measured::SaddleGap)
            .map(|p| (p.row.l_hi, p.row.l_lo, p.flag.clone()))
            .collect(),
        checked: check.is_some(),
        check: check_disc,
        note,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use formats::records::Record;
    use store::ArtefactWriter;

    fn rung(l: f64, neck_nodes: usize) -> RefinedRungRow {
        RefinedRungRow {
            l,
            load: 1.0,
            saddle_gap: 1e-3,
            contact_area: 0.5,
            iterations: 10,
            wall_s: 0.1,
            neck_nodes,
            flagged: false,
            half_width: f64::NAN,
            half_width_error: f64::NAN,
            half_length: f64::NAN,
            half_length_error: f64::NAN,
            conductance: f64::NAN,
            conductance_error: f64::NAN,
        }
    }

    /// Writes `d/0` (with neck datasets of `n` values each, or none) and `d/1` (with them),
    /// the layout of `refined_ladder::write_rungs`.
    fn artefact(dir: &std::path::Path, neck: Option<usize>) -> std::path::PathBuf {
        let path = dir.join("r.h5");
        let mut w = ArtefactWriter::create(&path).unwrap();
        let rows = [rung(-0.01, 21), rung(-0.005, 15)];
        for (i, levels) in [(0, 2i64), (1, 3)] {
            let at = format!("d/{i}");
            RefinedRungRow::write(&rows, &mut w, &at).unwrap();
            w.write_strings(&format!("{at}/flag"), &["", "solve not converged"])
                .unwrap();
            let n = if i == 0 { neck } else { Some(2) };
            if let Some(n) = n {
                for (k, name) in NECK_DATASETS.iter().enumerate() {
                    let v: Vec<f64> = (0..n).map(|j| (k * 10 + j) as f64).collect();
                    w.write_f64_1d(&format!("{at}/{name}"), &v).unwrap();
                }
            }
            w.set_attr_at(&at, "levels", levels).unwrap();
            w.set_attr_at(&at, "margin", 8i64).unwrap();
            w.set_attr_at(&at, "spacing", 1e-3 / levels as f64).unwrap();
        }
        w.publish().unwrap();
        path
    }

    /// The stored rungs come back with their lengths; an artefact without the neck datasets
    /// reads as `None` (not zeros); a dataset of the wrong length is an error naming the file
    /// and dataset.
    #[test]
    fn reads_the_neck_datasets_or_says_they_are_absent() {
        let dir = tempfile::tempdir().unwrap();
        let p = artefact(dir.path(), Some(2));
        let d = read_ladder(&ArtefactReader::open(&p).unwrap())
            .unwrap()
            .unwrap();
        assert_eq!(d.len(), 2);
        assert_eq!((d[1].levels, d[1].margin), (3, 8));
        assert_eq!(d[0].rungs[1].lengths, [1.0, 11.0, 21.0]);
        assert_eq!(d[0].rungs[1].flag, "solve not converged");
        assert_eq!(d[0].rungs[0].neck_nodes, 21);
        std::fs::remove_file(&p).unwrap();
        let p = artefact(dir.path(), None);
        assert!(
            read_ladder(&ArtefactReader::open(&p).unwrap())
                .unwrap()
                .is_none()
        );
        std::fs::remove_file(&p).unwrap();
        let p = artefact(dir.path(), Some(3));
        let e = read_ladder(&ArtefactReader::open(&p).unwrap())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("r.h5")
                && e.contains("d/0/neck_width_rms")
                && e.contains("3 values for 2 rungs"),
            "{e}"
        );
    }

    // the neck pairs and their error model (moved here from the `running` scene with `pairs`)

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

    fn of(p: &[NeckPair], m: NeckMeasure) -> Vec<&NeckPair> {
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
            (NeckMeasure::WidthRms, UPS, 0.002),
            (NeckMeasure::WidthLevel, UPS, 0.002),
            (NeckMeasure::RiseLength, CHI, 0.004),
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
                    if m == NeckMeasure::RiseLength {
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
        let rms = of(&p, NeckMeasure::WidthRms);
        assert_eq!(rms[0].flag, format!("rung l = {:e}: {bad}", -0.02));
        assert_eq!(rms[1].flag, PairFlag::Frozen.to_string());
        assert!((rms[1].grid_error - 0.008).abs() < 1e-12);
        // the coarser D's pair has a flagged rung: the level change unknown
        assert!(rms[2].grid_error.is_nan());
        assert_eq!(rms[2].flag, "grid error unknown");
        let rise = of(&p, NeckMeasure::RiseLength);
        assert!(rise[1].flag.contains("unchanged"));
        assert!(rise[2].flag == "grid error unknown");
        // no flags in the coarser level's υ but a larger change: flagged for the grid error
        let discs = [disc(1, 5, 0.008, 0.0, &[]), disc(2, 5, 0.0, 0.0, &[])];
        let p = pairs(&ladder(&discs, NeckWindow::None));
        assert_eq!(
            of(&p, NeckMeasure::WidthRms)[0].flag,
            "grid error 8.00e-3 > 5.00e-3"
        );
        assert!(of(&p, NeckMeasure::RiseLength)[0].flag.is_empty());

        // a window check at k = 1 (margin 5): Δw = (υ + 0.003) − (υ + 0.001) = 0.002 folded in;
        // the check lacks the rung −0.002 (not measured there): that pair's Δw unknown
        let discs = [disc(1, 5, 0.001, 0.0, &[]), disc(2, 5, 0.0, 0.0, &[])];
        let mut check = disc(1, 5, 0.003, 0.009, &[]);
        check.rungs[3].lengths = [f64::NAN; 3];
        let p = pairs(&ladder(&discs, NeckWindow::Check(&check)));
        let rms = of(&p, NeckMeasure::WidthRms);
        assert!((rms[0].window_change - 0.002).abs() < 1e-12);
        assert!((rms[0].grid_error - 0.002).abs() < 1e-12, "{:?}", rms[0]);
        assert!(rms[0].flag.is_empty());
        assert!(rms[2].window_change.is_nan() && rms[2].grid_error.is_nan());
        assert_eq!(rms[2].flag, "window change unknown");
        let rise = of(&p, NeckMeasure::RiseLength);
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
