//! Between the models: the difference of two models' running exponents pair by pair, and
//! whether it vanishes as |l| → 0 (`analysis::difference`). Part of the `running` scene.
//!
//! For every measure (`running_exponents.csv`'s `measure`: first each exponent's own —
//! saddle gap, contact-line half-width, Hertz half-length, flux: the rows and tables as before
//! the neck rows —, then the neck's rms width, level width and rise length, [`MEASURES`]) and
//! every two models, the points are the pairs of neighbouring rungs both models measured
//! usably with that measure: each model's row of that pair without a flag (so with a known
//! grid error ≤ 0.005), from its deepest ladder (deep refined, then refined, then uniform).
//! Δ = value(b) − value(a), its error the grid and fit errors of both in quadrature.
//!
//! Output `model_differences.csv`, one row per measure, model pair and common pair of rungs,
//! descending |l|: `exponent`, `model_a`, `model_b`, `l_hi`, `l_lo` (signed, as in
//! `running_exponents.csv`), `difference` (b − a), `error`, `method_a`, `method_b`,
//! `local_slope` (d ln|Δ| / d ln|l| from the previous row of the same exponent and model pair:
//! the difference's own running exponent ω_eff; NaN on the first row or where Δ changes sign),
//! `local_slope_error`, `measure` (last, so that the columns before it are as they were).
//!
//! Output `universality.csv`, one row per measure, model pair and fit range (the k common
//! pairs of smallest |l|, k = 4 … n; one row with NaNs when there are fewer than 4): `exponent`,
//! `model_a`, `model_b`, `points`, `l_max`, `l_min` (|l| of the range's outer pairs), `offset`,
//! `offset_lo`, `offset_hi` (Δ∞ of Δ = Δ∞ + c|l|^ω and its 2σ profile interval), `omega`,
//! `chi2`, `dof`, `omega_vanishing`, `chi2_vanishing` (Δ = c|l|^ω), `accepted` (the offset fit
//! describes the range: χ²/dof ≤ 3), and for the model pair as a whole `verdict` (Δ∞ = 0 allowed
//! by every accepted range, excluded by every one, neither, or fewer than two accepted ranges)
//! and `bound_lo`, `bound_hi` (the union of the accepted ranges' intervals), `measure` (last).
//! The neck measures' rows come after all others in both tables.

use super::Row;
use super::neck::Measure;
use analysis::{DiffOptions, DiffPoint, DiffVerdict, DifferenceScaling, difference_scaling};
use anyhow::Result;
use critical::running::Exponent;
use kinds::refined_chain::Depth;
use surface::Lattice;
use tables::{ColumnData, Table};

/// Depth of a row's ladder: the deeper, the finer its resolution at small |l|.
fn depth(method: &str) -> u8 {
    if method == Depth::Deep.name() {
        2
    } else if method == Depth::Refined.name() {
        1
    } else {
        0
    }
}

/// One common pair of rungs of two models.
#[derive(Clone, Debug, PartialEq)]
pub struct Common {
    /// The exponent.
    pub exponent: Exponent,
    /// What its rows measure (`running_exponents.csv`'s `measure`).
    pub measure: Measure,
    /// The two models (b − a).
    pub models: (Lattice, Lattice),
    /// The pair's loads (signed, a's row).
    pub l_hi: f64,
    /// The nearer rung.
    pub l_lo: f64,
    /// b − a.
    pub difference: f64,
    /// Grid and fit errors of both in quadrature.
    pub error: f64,
    /// The rows' methods.
    pub methods: (&'static str, &'static str),
}

/// The usable row of each model's pair of one measure: unflagged, the deepest method.
fn usable(rows: &[Row], model: Lattice, measure: Measure) -> Vec<&Row> {
    let mut out: Vec<&Row> = Vec::new();
    for r in rows.iter().filter(|r| {
        r.rec.model == model && r.measure == measure && r.flag.is_empty() && r.rec.value.is_finite()
    }) {
        match out.iter_mut().find(|o| {
            analysis::same_load(o.rec.l_hi, r.rec.l_hi)
                && analysis::same_load(o.rec.l_lo, r.rec.l_lo)
        }) {
            Some(o) if depth(r.method) > depth(o.method) => *o = r,
            Some(_) => {}
            None => out.push(r),
        }
    }
    out.sort_by(|a, b| b.rec.l_hi.abs().total_cmp(&a.rec.l_hi.abs()));
    out
}

/// The common pairs of `a` and `b` for `measure`, descending |l|.
pub fn common(rows: &[Row], measure: Measure, a: Lattice, b: Lattice) -> Vec<Common> {
    let rb = usable(rows, b, measure);
    usable(rows, a, measure)
        .into_iter()
        .filter_map(|x| {
            let y = rb.iter().find(|y| {
                analysis::same_load(x.rec.l_hi, y.rec.l_hi)
                    && analysis::same_load(x.rec.l_lo, y.rec.l_lo)
            })?;
            Some(Common {
                exponent: measure.exponent(),
                measure,
                models: (a, b),
                l_hi: x.rec.l_hi,
                l_lo: x.rec.l_lo,
                difference: y.rec.value - x.rec.value,
                error: x.error().hypot(y.error()),
                methods: (x.method, y.method),
            })
        })
        .collect()
}

/// The analysis of one model pair's common pairs.
pub struct Pair {
    /// The common pairs, descending |l|.
    pub common: Vec<Common>,
    /// Its difference scaling.
    pub scaling: DifferenceScaling,
}

/// The measures analysed, in table order: each exponent's own (the rows before the neck
/// rows: saddle gap, contact-line half-width, Hertz half-length, flux), then the neck's.
pub const MEASURES: [Measure; 7] = [
    Measure::SaddleGap,
    Measure::HalfWidth,
    Measure::HalfLength,
    Measure::Flux,
    Measure::NeckWidthRms,
    Measure::NeckWidthLevel,
    Measure::NeckRiseLength,
];

/// Every measure and model pair of `rows` (models ordered square, triangular, hexagonal:
/// Δ = the later one's exponent − the earlier one's).
pub fn analyse(rows: &[Row]) -> Result<Vec<Pair>> {
    const ORDER: [&str; 3] = ["square", "triangular", "hexagonal"];
    let rank = |m: &Lattice| ORDER.iter().position(|n| *n == m.name()).unwrap_or(3);
    let mut models: Vec<Lattice> = Vec::new();
    for r in rows {
        if !models.contains(&r.rec.model) {
            models.push(r.rec.model);
        }
    }
    models.sort_by_key(rank);
    let mut out = Vec::new();
    for &m in &MEASURES {
        for (i, &a) in models.iter().enumerate() {
            for &b in &models[i + 1..] {
                let common = common(rows, m, a, b);
                let points: Vec<DiffPoint> = common
                    .iter()
                    .map(|c| DiffPoint {
                        l: (c.l_hi * c.l_lo).abs().sqrt(),
                        value: c.difference,
                        error: c.error,
                    })
                    .collect();
                let scaling = difference_scaling(&points, &DiffOptions::default())?;
                out.push(Pair { common, scaling });
            }
        }
    }
    Ok(out)
}

/// `model_differences.csv` (module docs).
pub fn differences_table(pairs: &[Pair]) -> Result<Table> {
    let rows: Vec<(&Common, f64, f64)> = pairs
        .iter()
        .flat_map(|p| {
            // the scaling's points and slopes run by descending |l|, as `common` does
            let slopes = &p.scaling.local;
            p.common.iter().enumerate().map(move |(i, c)| {
                let s = (i > 0).then(|| slopes.get(i - 1)).flatten();
                (
                    c,
                    s.map_or(f64::NAN, |s| s.slope),
                    s.map_or(f64::NAN, |s| s.error),
                )
            })
        })
        .collect();
    let mut t = Table::new();
    let s = |f: fn(&Common) -> String| ColumnData::Str(rows.iter().map(|r| f(r.0)).collect());
    let v = |f: fn(&(&Common, f64, f64)) -> f64| ColumnData::F64(rows.iter().map(f).collect());
    t.push("exponent", s(|c| c.exponent.name().to_string()))?;
    t.push("model_a", s(|c| c.models.0.name().to_string()))?;
    t.push("model_b", s(|c| c.models.1.name().to_string()))?;
    t.push("l_hi", v(|r| r.0.l_hi))?;
    t.push("l_lo", v(|r| r.0.l_lo))?;
    t.push("difference", v(|r| r.0.difference))?;
    t.push("error", v(|r| r.0.error))?;
    t.push("method_a", s(|c| c.methods.0.to_string()))?;
    t.push("method_b", s(|c| c.methods.1.to_string()))?;
    t.push("local_slope", v(|r| r.1))?;
    t.push("local_slope_error", v(|r| r.2))?;
    t.push("measure", s(|c| c.measure.name().to_string()))?;
    Ok(t)
}

/// `universality.csv` (module docs).
pub fn universality_table(pairs: &[Pair]) -> Result<Table> {
    struct R<'a> {
        exponent: &'static str,
        measure: &'static str,
        models: (&'static str, &'static str),
        fit: Option<&'a analysis::RangeFit>,
        verdict: DiffVerdict,
        bound: (f64, f64),
    }
    let mut rows = Vec::new();
    for p in pairs {
        let Some(c) = p.common.first() else {
            continue;
        };
        let head = |fit| R {
            exponent: c.exponent.name(),
            measure: c.measure.name(),
            models: (c.models.0.name(), c.models.1.name()),
            fit,
            verdict: p.scaling.verdict,
            bound: p.scaling.bound,
        };
        if p.scaling.ranges.is_empty() {
            rows.push(head(None));
        }
        rows.extend(p.scaling.ranges.iter().map(|f| head(Some(f))));
    }
    let mut t = Table::new();
    let f = |g: fn(&analysis::RangeFit) -> f64| {
        ColumnData::F64(rows.iter().map(|r| r.fit.map_or(f64::NAN, g)).collect())
    };
    let s = |g: fn(&R) -> String| ColumnData::Str(rows.iter().map(g).collect());
    t.push("exponent", s(|r| r.exponent.to_string()))?;
    t.push("model_a", s(|r| r.models.0.to_string()))?;
    t.push("model_b", s(|r| r.models.1.to_string()))?;
    let int = |g: fn(&analysis::RangeFit) -> usize| {
        ColumnData::I64(
            rows.iter()
                .map(|r| r.fit.map_or(0, |f| g(f) as i64))
                .collect(),
        )
    };
    t.push("points", int(|f| f.points))?;
    t.push("l_max", f(|f| f.l_max))?;
    t.push("l_min", f(|f| f.l_min))?;
    t.push("offset", f(|f| f.offset))?;
    t.push("offset_lo", f(|f| f.offset_lo))?;
    t.push("offset_hi", f(|f| f.offset_hi))?;
    t.push("omega", f(|f| f.omega))?;
    t.push("chi2", f(|f| f.chi2))?;
    t.push("dof", int(|f| f.dof))?;
    t.push("omega_vanishing", f(|f| f.omega_vanishing))?;
    t.push("chi2_vanishing", f(|f| f.chi2_vanishing))?;
    t.push(
        "accepted",
        s(|r| r.fit.map_or(String::new(), |f| f.accepted.to_string())),
    )?;
    t.push("verdict", s(|r| r.verdict.text().to_string()))?;
    t.push(
        "bound_lo",
        ColumnData::F64(rows.iter().map(|r| r.bound.0).collect()),
    )?;
    t.push(
        "bound_hi",
        ColumnData::F64(rows.iter().map(|r| r.bound.1).collect()),
    )?;
    t.push("measure", s(|r| r.measure.to_string()))?;
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use critical::running::RunningRecord;

    fn row(model: Lattice, l: (f64, f64), value: f64, flag: &str, method: &'static str) -> Row {
        Row {
            rec: RunningRecord {
                model,
                exponent: Exponent::Zeta,
                l_hi: l.0,
                l_lo: l.1,
                value,
                grid_error: 1e-3,
                fit_error: f64::NAN,
                resolution: 1e-3,
                flag: None,
            },
            flag: flag.to_string(),
            method,
            measure: Measure::SaddleGap,
        }
    }

    /// The deepest unflagged row of each model's pair is used, b − a, flagged rows never; a pair
    /// only one model measured is left out.
    #[test]
    fn common_pairs_take_each_models_deepest_usable_row() {
        let (sq, tri) = (Lattice::Square, Lattice::Triangular);
        let (p1, p2, p3) = ((-0.01, -0.005), (-0.005, -0.002), (-0.002, -0.001));
        let rows = vec![
            row(sq, p1, 1.20, "", "uniform"),
            row(sq, p1, 1.21, "", "refined"),
            row(tri, p1, 1.30, "", "uniform"),
            row(sq, p2, 1.19, "", "uniform"),
            row(tri, p2, 1.28, "grid error 7e-3 > 5e-3", "refined"),
            row(tri, p2, 1.27, "", "uniform"),
            row(sq, p3, 1.18, "", "refined_deep"),
            row(tri, p3, 9.99, "window change", "refined_deep"),
        ];
        let c = common(&rows, Measure::SaddleGap, sq, tri);
        assert_eq!(c.len(), 2, "{c:?}");
        assert!((c[0].difference - (1.30 - 1.21)).abs() < 1e-12);
        assert_eq!(c[0].methods, ("refined", "uniform"));
        assert!((c[1].difference - (1.27 - 1.19)).abs() < 1e-12);
        assert!(
            (c[0].error - 2f64.sqrt() * 1e-3).abs() < 1e-15,
            "grid errors in quadrature"
        );
        let pairs = analyse(&rows).unwrap();
        // seven measures (four exponents' own, three of the neck), one model pair each
        assert_eq!(pairs.len(), 7);
        assert_eq!(pairs[0].scaling.verdict, DiffVerdict::TooFewPoints);
        let t = differences_table(&pairs).unwrap();
        assert_eq!(t.n_rows(), 2);
        let u = universality_table(&pairs).unwrap();
        assert_eq!(
            u.n_rows(),
            1,
            "one row (no fit) for ζ; none for exponents without points"
        );
    }
}
