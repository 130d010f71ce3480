//! `exponents.csv`: one row per model and exponent, built from one column spec ([`COLUMNS`]).
//!
//! Rows per model: `zeta`, `upsilon`, `chi`, `beta` (from the flux), `zeta_lc_free` (the window
//! fit with L_c free; no asymptotic estimate), `beta_identity` (3ζ + υ − χ, window and
//! asymptotic), `beta_minus_identity` (β − (3ζ + υ − χ), expected 0: the `paper` column holds
//! 0, no conjecture, no verdict); then (appended, session #11) the asymptotic estimates from the
//! refined ladders' neck lengths ([`super::asymptotic::estimate_neck`], [`super::NECK_ROWS`]):
//! `upsilon_neck` (υ from the neck's rms width), `chi_below` (χ from below, the neck's rise
//! length), and `beta_identity_neck` (3ζ + υ − χ of the asymptotic ζ and those two). The neck
//! rows have no window fit (the uniform ladders measure no neck lengths: `value` … `points`
//! NaN or 0, `deviation` NaN); their `paper`, `conjectured` and verdict rule are υ's, χ's and β's.
//!
//! Columns: `model`, `exponent`; the window fit (0.002 ≤ |l| ≤ 0.02, [`super::WINDOW`]):
//! `value`, `fit_error`, `grid_spread`, `error`, `n` (grid of the value), `points`; the paper:
//! `paper`, `paper_error`, `deviation` (window value − paper), `deviation_sigma` (in `error`);
//! the conjecture `conjectured`, `conjectured_value`; the asymptotic estimate
//! ([`super::asymptotic`]): `asymptotic_<field>` for each of [`Asymptotic::FIELDS`];
//! `asymptotic_sigma` ((asymptotic − conjecture)/asymptotic error) and `verdict` (the rule in
//! [`super::asymptotic`]); then (appended, issue 13's refined ladder) `asymptotic_method`
//! (which ladder the asymptotic estimate used: `uniform`, or `uniform+refined below |l| = …`
//! where the model's refined ladder took over, and `+refined_deep below |l| = …` where a deep
//! refined ladder chained below it took over, [`super::asymptotic::estimate_combined`]) and
//! the uniform-only estimate as it was before the refined ladder fed the fit:
//! `uniform_asymptotic_value`, `uniform_asymptotic_error`, `uniform_asymptotic_l_min`. The neck
//! rows' `asymptotic_method` names the measure and the ladders
//! (`neck_width_rms: refined from |l| = 5e-2+refined_deep below |l| = 5e-4`, or
//! `neck_width_rms: none`); `beta_identity_neck`'s joins its three parts' (`3ζ + υ − χ: …; …; …`).
//! The identity rows' `asymptotic_l_min` is the largest of their parts' (the depth rule,
//! [`super::asymptotic::verdict`]).

use super::asymptotic::{Asymptotic, verdict};
use super::{CONJECTURED, Exponent, ModelExponents, NAMES, NECK_ROWS, PAPER};
use tables::{ColumnData, Table};

/// One row of the table.
#[derive(Clone, Debug)]
pub struct Row {
    /// Model name.
    pub model: String,
    /// Row name (module docs).
    pub exponent: String,
    /// The window fit.
    pub window: Exponent,
    /// The paper's value and error (NaN: none).
    pub paper: (f64, f64),
    /// Index of the conjecture and verdict rule ([`NAMES`] order), if any.
    pub conjecture: Option<usize>,
    /// The asymptotic estimate (combined ladder).
    pub asymptotic: Asymptotic,
    /// The uniform-only asymptotic estimate.
    pub uniform: Asymptotic,
    /// Which ladder `asymptotic` used (empty for rows without an estimate of their own).
    pub method: String,
}

/// A column's cells of one row.
pub enum Cell {
    /// A float.
    F(fn(&Row) -> f64),
    /// An integer.
    I(fn(&Row) -> i64),
    /// Text.
    S(fn(&Row) -> String),
}

fn conj(r: &Row) -> f64 {
    r.conjecture.map_or(f64::NAN, |k| CONJECTURED[k].0)
}

fn judged(r: &Row) -> (String, f64) {
    r.conjecture
        .map_or((String::new(), f64::NAN), |k| verdict(&r.asymptotic, k))
}

/// The columns before the asymptotic fields.
pub const COLUMNS: [(&str, Cell); 12] = [
    ("model", Cell::S(|r| r.model.clone())),
    ("exponent", Cell::S(|r| r.exponent.clone())),
    ("value", Cell::F(|r| r.window.value)),
    ("fit_error", Cell::F(|r| r.window.fit_error)),
    ("grid_spread", Cell::F(|r| r.window.grid_spread)),
    ("error", Cell::F(|r| r.window.error)),
    ("n", Cell::I(|r| r.window.n as i64)),
    ("points", Cell::I(|r| r.window.points as i64)),
    ("paper", Cell::F(|r| r.paper.0)),
    ("paper_error", Cell::F(|r| r.paper.1)),
    (
        "conjectured",
        Cell::S(|r| {
            r.conjecture
                .map_or(String::new(), |k| CONJECTURED[k].1.into())
        }),
    ),
    ("conjectured_value", Cell::F(conj)),
];

/// The columns after the asymptotic fields.
pub const TAIL: [(&str, Cell); 4] = [
    ("deviation", Cell::F(|r| r.window.value - r.paper.0)),
    (
        "deviation_sigma",
        Cell::F(|r| (r.window.value - r.paper.0) / r.window.error),
    ),
    ("asymptotic_sigma", Cell::F(|r| judged(r).1)),
    ("verdict", Cell::S(|r| judged(r).0)),
];

/// The columns appended last (module docs): the method and the uniform-only estimate.
pub const APPENDED: [(&str, Cell); 4] = [
    ("asymptotic_method", Cell::S(|r| r.method.clone())),
    ("uniform_asymptotic_value", Cell::F(|r| r.uniform.value)),
    ("uniform_asymptotic_error", Cell::F(|r| r.uniform.error)),
    ("uniform_asymptotic_l_min", Cell::F(|r| r.uniform.l_min)),
];

/// The rows of one model (module docs).
pub fn rows(e: &ModelExponents) -> Vec<Row> {
    let row = |name: &str, window: Exponent, k: Option<usize>, a: Asymptotic| Row {
        model: e.lattice.clone(),
        exponent: name.into(),
        window,
        paper: k.map_or((f64::NAN, f64::NAN), |k| PAPER[k]),
        conjecture: k,
        asymptotic: a,
        uniform: Asymptotic::NONE,
        method: String::new(),
    };
    let mut out: Vec<Row> = NAMES
        .iter()
        .enumerate()
        .map(|(k, nm)| Row {
            uniform: e.uniform_asymptotic[k],
            method: e.asymptotic_method[k].clone(),
            ..row(nm, e.exponents[k], Some(k), e.asymptotic[k])
        })
        .collect();
    let z = e.get("zeta");
    out.push(row(
        "zeta_lc_free",
        Exponent {
            value: e.zeta_lc_free.0,
            fit_error: e.zeta_lc_free.1,
            grid_spread: f64::NAN,
            error: e.zeta_lc_free.1,
            ..z
        },
        Some(0),
        Asymptotic::NONE,
    ));
    let methods: Vec<&str> = e.asymptotic_method[..3]
        .iter()
        .map(String::as_str)
        .collect();
    out.push(Row {
        uniform: e.beta_identity_uniform,
        method: if methods.iter().all(|m| *m == "uniform") {
            "uniform".into()
        } else {
            format!("3ζ + υ − χ: {}", methods.join("; "))
        },
        ..row(
            "beta_identity",
            Exponent {
                value: e.beta_identity.0,
                fit_error: f64::NAN,
                grid_spread: f64::NAN,
                error: e.beta_identity.1,
                ..z
            },
            Some(3),
            e.beta_identity_asymptotic,
        )
    });
    let b = e.get("beta");
    let (ab, ai) = (e.asymptotic[3], e.beta_identity_asymptotic);
    let mut diff = row(
        "beta_minus_identity",
        Exponent {
            value: b.value - e.beta_identity.0,
            fit_error: f64::NAN,
            grid_spread: f64::NAN,
            error: b.error.hypot(e.beta_identity.1),
            ..b
        },
        None,
        Asymptotic::of(ab.value - ai.value, ab.error.hypot(ai.error)),
    );
    diff.paper = (0.0, f64::NAN);
    out.push(diff);
    // the neck rows (module docs): no window fit (the uniform ladders measure no neck lengths)
    for (k, (name, _, x)) in NECK_ROWS.iter().enumerate() {
        out.push(Row {
            method: e.neck_method[k].clone(),
            ..row(name, Exponent::NONE, Some(*x), e.neck_asymptotic[k])
        });
    }
    let methods = [
        &e.asymptotic_method[0],
        &e.neck_method[0],
        &e.neck_method[1],
    ];
    out.push(Row {
        method: format!("3ζ + υ − χ: {}", methods.map(String::as_str).join("; ")),
        ..row(
            "beta_identity_neck",
            Exponent::NONE,
            Some(3),
            e.beta_identity_neck,
        )
    });
    out
}

/// The column names, in order.
pub fn column_names() -> Vec<String> {
    let head = COLUMNS.iter().map(|c| c.0.to_string());
    let mid = Asymptotic::FIELDS
        .iter()
        .map(|f| format!("asymptotic_{}", f.0));
    head.chain(mid)
        .chain(TAIL.iter().chain(&APPENDED).map(|c| c.0.into()))
        .collect()
}

/// `exponents.csv` of every model (module docs).
pub fn table(ex: &[ModelExponents]) -> anyhow::Result<Table> {
    let rows: Vec<Row> = ex.iter().flat_map(rows).collect();
    let mut t = Table::new();
    let cell = |c: &Cell| match c {
        Cell::F(f) => ColumnData::F64(rows.iter().map(f).collect()),
        Cell::I(f) => ColumnData::I64(rows.iter().map(f).collect()),
        Cell::S(f) => ColumnData::Str(rows.iter().map(f).collect()),
    };
    for (name, c) in &COLUMNS {
        t.push(*name, cell(c))?;
    }
    for (name, get, _) in Asymptotic::FIELDS {
        let v = rows.iter().map(|r| get(&r.asymptotic)).collect();
        t.push(format!("asymptotic_{name}"), ColumnData::F64(v))?;
    }
    for (name, c) in TAIL.iter().chain(&APPENDED) {
        t.push(*name, cell(c))?;
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model with every estimate `value ± 0.004` reaching |l| = 1e-5 (so only the numbers
    /// decide the verdicts).
    fn model() -> ModelExponents {
        let a = |v: f64| Asymptotic {
            l_min: 1e-5,
            stat_error: 1e-3,
            range_spread: 1e-3,
            ..Asymptotic::of(v, 0.004)
        };
        let w = |v: f64| Exponent {
            value: v,
            error: 0.01,
            ..Exponent::NONE
        };
        ModelExponents {
            lattice: "square".into(),
            exponents: [w(1.21), w(0.46), w(0.61), w(3.5)],
            asymptotic: [a(1.2), Asymptotic::NONE, Asymptotic::NONE, a(3.45)],
            uniform_asymptotic: [Asymptotic::NONE; 4],
            asymptotic_method: [
                "uniform+refined below |l| = 1e-3".into(),
                "uniform".into(),
                "uniform".into(),
                "uniform".into(),
            ],
            beta_identity_uniform: Asymptotic::NONE,
            beta_identity_asymptotic: Asymptotic::NONE,
            neck_asymptotic: [a(0.47), a(0.58)],
            neck_method: [
                "neck_width_rms: refined from |l| = 5e-2".into(),
                "neck_rise_length: refined from |l| = 5e-2".into(),
            ],
            beta_identity_neck: super::super::asymptotic::identity(&a(1.2), &a(0.47), &a(0.58)),
            zeta_lc_free: (1.2, 0.01),
            beta_identity: (3.45, 0.03),
            eta: 1.0,
            levels: Vec::new(),
        }
    }

    /// The rows in the documented order (the neck rows and their identity last, after the
    /// rows that existed before them), the columns in the documented order, and the neck rows'
    /// cells: no window fit, the paper's and the conjectured υ and χ, their estimates, method
    /// and verdicts.
    #[test]
    fn the_table_has_the_neck_rows_and_columns_in_order() {
        let t = table(&[model()]).unwrap();
        let rows = t.str("exponent").unwrap();
        assert_eq!(
            rows,
            [
                "zeta",
                "upsilon",
                "chi",
                "beta",
                "zeta_lc_free",
                "beta_identity",
                "beta_minus_identity",
                "upsilon_neck",
                "chi_below",
                "beta_identity_neck"
            ]
        );
        let names: Vec<String> = t.columns().iter().map(|c| c.name.clone()).collect();
        let want = [
            "model",
            "exponent",
            "value",
            "fit_error",
            "grid_spread",
            "error",
            "n",
            "points",
            "paper",
            "paper_error",
            "conjectured",
            "conjectured_value",
            "asymptotic_value",
            "asymptotic_error",
            "asymptotic_stat_error",
            "asymptotic_range_spread",
            "asymptotic_form_spread",
            "asymptotic_origin_spread",
            "asymptotic_origin_fits",
            "asymptotic_omega",
            "asymptotic_points",
            "asymptotic_l_min",
            "deviation",
            "deviation_sigma",
            "asymptotic_sigma",
            "verdict",
            "asymptotic_method",
            "uniform_asymptotic_value",
            "uniform_asymptotic_error",
            "uniform_asymptotic_l_min",
        ];
        assert_eq!(names, want);
        assert_eq!(names, column_names());
        let (value, conj) = (t.f64("value").unwrap(), t.str("conjectured").unwrap());
        let (asy, verdict) = (
            t.f64("asymptotic_value").unwrap(),
            t.str("verdict").unwrap(),
        );
        let method = t.str("asymptotic_method").unwrap();
        assert!(value[7..].iter().all(|v| v.is_nan()));
        assert_eq!(&conj[7..], ["9/20", "3/5", "69/20"]);
        assert_eq!(t.f64("paper").unwrap()[7], 0.45);
        assert_eq!((asy[7], asy[8]), (0.47, 0.58));
        // 3·1.2 + 0.47 − 0.58 = 3.49
        assert!((asy[9] - 3.49).abs() < 1e-12);
        // υ 0.47 ± 0.004: +5σ; χ 0.58 ± 0.004: −5σ; the identity ± 0.004·√11: +3.0σ
        assert!(
            verdict[7].starts_with("not consistent with 9/20 (+5.0σ)"),
            "{}",
            verdict[7]
        );
        assert!(
            verdict[8].starts_with("not consistent with 3/5 (-5.0σ)"),
            "{}",
            verdict[8]
        );
        assert!(
            verdict[9].starts_with("not consistent with 69/20 (+3.0σ)"),
            "{}",
            verdict[9]
        );
        assert_eq!(method[7], "neck_width_rms: refined from |l| = 5e-2");
        assert_eq!(
            method[9],
            "3ζ + υ − χ: uniform+refined below |l| = 1e-3; neck_width_rms: refined from |l| = 5e-2; neck_rise_length: refined from |l| = 5e-2"
        );
    }
}
