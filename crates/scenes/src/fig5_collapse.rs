//! Figure 5's collapse quality (`fig5_collapse.csv`), shared by the `fig5` scene
//! ([`crate::fig5`]).
//!
//! How well the models fall on one master curve, measured on the full-resolution axis gaps of
//! panel (b) in each model's units ([`collapse_rms`]): on the X range all compared curves share
//! (X ≤ 4, where every curve's gap is positive), at [`COLLAPSE_SAMPLES`] evenly spaced X, ln Y
//! of each curve is interpolated linearly, and the rms of ln Y minus its mean over the curves is
//! taken (0: perfect collapse; 0.01: the curves differ by about 1 % rms). Rows: `compare` =
//! "models" (the models' curves at one l), "models, all l" (the quadratic mean of those rows of
//! one side), "rungs" (one model's curves at all its l: how well the per-model rescaling
//! collapses the model itself, the yardstick for the between-model number). Columns `side`
//! ("open" l < 0, "blocked" l > 0), `compare`, `model` ("all" for models), `l` (NaN where
//! pooled), `curves`, `x_lo`, `x_hi`, `samples`, `rms_ln`, `method` ("uniform": the uniform
//! ladders' finest grids; "refined": the refined ladders' finest discretisations, l < 0 only,
//! unflagged rungs, rescaled in the same per-model units from the uniform fits — the same
//! residual where the uniform grids no longer resolve the channel). Stage attributes
//! `collapse_rms_open`, `collapse_rms_blocked` (the uniform "models, all l" values) and
//! `collapse_rms_open_refined` (the refined one; NaN with fewer than two refined models).

use anyhow::Result;
use tables::Table;

/// Points of the rescaled curves compared by [`collapse_rms`].
pub const COLLAPSE_SAMPLES: usize = 50;

/// Largest rescaled distance compared (as panel (b) draws).
const COLLAPSE_X_MAX: f64 = 4.0;

/// The spread of several rescaled curves (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    /// Common X range.
    pub x_lo: f64,
    /// Common X range.
    pub x_hi: f64,
    /// X samples with every curve defined.
    pub samples: usize,
    /// rms of ln Y about its mean over the curves.
    pub rms: f64,
}

/// The rms of ln Y about the curves' mean on their common positive X range (module docs):
/// each curve (X ascending, Y) is cut to its positive tail (after its last Y ≤ 0) and to
/// X ≤ 4. `None` with fewer than two curves or no common range.
pub fn collapse_rms(curves: &[(Vec<f64>, Vec<f64>)]) -> Option<Spread> {
    if curves.len() < 2 {
        return None;
    }
    let tails: Vec<(&[f64], &[f64])> = curves
        .iter()
        .map(|(x, y)| {
            let start = y
                .iter()
                .rposition(|v| !(v.is_finite() && *v > 0.0))
                .map_or(0, |k| k + 1);
            let end = x.partition_point(|v| *v <= COLLAPSE_X_MAX);
            let end = end.max(start);
            (&x[start..end], &y[start..end])
        })
        .collect();
    if tails.iter().any(|t| t.0.len() < 2) {
        return None;
    }
    let x_lo = tails.iter().map(|t| t.0[0]).fold(f64::MIN, f64::max);
    let x_hi = tails
        .iter()
        .map(|t| *t.0.last().expect("≥ 2"))
        .fold(f64::MAX, f64::min);
    if x_hi <= x_lo {
        return None;
    }
    let interp = |x: &[f64], y: &[f64], at: f64| -> f64 {
        let k = x.partition_point(|v| *v <= at).clamp(1, x.len() - 1);
        let t = (at - x[k - 1]) / (x[k] - x[k - 1]);
        y[k - 1].ln() * (1.0 - t) + y[k].ln() * t
    };
    let (mut sum, mut count, mut samples) = (0.0, 0usize, 0usize);
    for s in 0..COLLAPSE_SAMPLES {
        let at = x_lo + (x_hi - x_lo) * s as f64 / (COLLAPSE_SAMPLES - 1) as f64;
        let v: Vec<f64> = tails.iter().map(|t| interp(t.0, t.1, at)).collect();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        sum += v.iter().map(|u| (u - mean).powi(2)).sum::<f64>();
        count += v.len();
        samples += 1;
    }
    Some(Spread {
        x_lo,
        x_hi,
        samples,
        rms: (sum / count as f64).sqrt(),
    })
}

/// One model's full-resolution rescaled axis gaps: (l, distance, gap) per rung.
pub type ModelCurves = (String, Vec<(f64, Vec<f64>, Vec<f64>)>);

/// One row of `fig5_collapse.csv`: side, compare, model, l, curves, spread.
type Row = (String, String, String, f64, usize, Spread);

/// The rows of one method's curves (module docs) and its pooled between-model rms per side.
fn collapse_rows(models: &[ModelCurves]) -> (Vec<Row>, [f64; 2]) {
    let mut rows: Vec<Row> = Vec::new();
    let mut pooled = [f64::NAN; 2];
    for (k, side) in ["open", "blocked"].into_iter().enumerate() {
        let on_side = |l: f64| if k == 0 { l < 0.0 } else { l > 0.0 };
        let mut ls: Vec<f64> = models
            .iter()
            .flat_map(|m| m.1.iter().map(|c| c.0))
            .filter(|l| on_side(*l))
            .collect();
        ls.sort_by(|a, b| b.abs().total_cmp(&a.abs()));
        ls.dedup();
        let mut per_l = Vec::new();
        for l in ls {
            let cs: Vec<(Vec<f64>, Vec<f64>)> = models
                .iter()
                .filter_map(|m| m.1.iter().find(|c| c.0 == l))
                .map(|c| (c.1.clone(), c.2.clone()))
                .collect();
            if let Some(sp) = collapse_rms(&cs) {
                per_l.push(sp.rms);
                rows.push((side.into(), "models".into(), "all".into(), l, cs.len(), sp));
            }
        }
        if !per_l.is_empty() {
            let q = (per_l.iter().map(|r| r * r).sum::<f64>() / per_l.len() as f64).sqrt();
            pooled[k] = q;
            let sp = Spread {
                x_lo: f64::NAN,
                x_hi: f64::NAN,
                samples: per_l.len() * COLLAPSE_SAMPLES,
                rms: q,
            };
            let n = rows.last().map_or(0, |r| r.4);
            rows.push((
                side.into(),
                "models, all l".into(),
                "all".into(),
                f64::NAN,
                n,
                sp,
            ));
        }
        for (name, curves) in models {
            let cs: Vec<(Vec<f64>, Vec<f64>)> = curves
                .iter()
                .filter(|c| on_side(c.0))
                .map(|c| (c.1.clone(), c.2.clone()))
                .collect();
            if let Some(sp) = collapse_rms(&cs) {
                rows.push((
                    side.into(),
                    "rungs".into(),
                    name.clone(),
                    f64::NAN,
                    cs.len(),
                    sp,
                ));
            }
        }
    }
    (rows, pooled)
}

/// `fig5_collapse.csv` (module docs): the uniform ladders' rows, then the refined ladders'
/// (`method` "uniform", "refined"), and each method's pooled between-model rms per side
/// (open, blocked): `[uniform, refined]`.
pub fn collapse_table(
    uniform: &[ModelCurves],
    refined: &[ModelCurves],
) -> Result<(Table, [[f64; 2]; 2])> {
    let (mut rows, pu) = collapse_rows(uniform);
    let n_uniform = rows.len();
    let (r, pr) = collapse_rows(refined);
    rows.extend(r);
    let method = (0..rows.len()).map(|k| if k < n_uniform { "uniform" } else { "refined" });
    let t = Table::new()
        .with_str("side", rows.iter().map(|r| r.0.clone()))
        .with_str("compare", rows.iter().map(|r| r.1.clone()))
        .with_str("model", rows.iter().map(|r| r.2.clone()))
        .with_f64("l", rows.iter().map(|r| r.3))
        .with_i64("curves", rows.iter().map(|r| r.4 as i64))
        .with_f64("x_lo", rows.iter().map(|r| r.5.x_lo))
        .with_f64("x_hi", rows.iter().map(|r| r.5.x_hi))
        .with_i64("samples", rows.iter().map(|r| r.5.samples as i64))
        .with_f64("rms_ln", rows.iter().map(|r| r.5.rms))
        .with_str("method", method.map(String::from));
    Ok((t, [pu, pr]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collapse_rms_is_zero_for_equal_curves_and_measures_a_known_offset() {
        // two curves y = 1 + x² on different samplings: linear interpolation of ln y leaves an
        // O(Δx² (ln y)'') floor: Δx = 0.01, (ln y)'' ≤ 2 → ≤ 1e-4 rms
        let x1: Vec<f64> = (0..=400).map(|k| k as f64 * 0.01).collect();
        let x2: Vec<f64> = (0..=300).map(|k| k as f64 * 0.0133).collect();
        let f = |x: &f64| 1.0 + x * x;
        let c1 = (x1.clone(), x1.iter().map(f).collect::<Vec<_>>());
        let c2 = (x2.clone(), x2.iter().map(f).collect::<Vec<_>>());
        let r = collapse_rms(&[c1.clone(), c2.clone()]).unwrap();
        assert!(r.rms < 1e-4, "{r:?}");
        assert!((r.x_lo - 0.0).abs() < 1e-12 && (r.x_hi - 3.99).abs() < 1e-12);
        // a curve 10 % higher: ln differs by ln 1.1, each curve is ln(1.1)/2 from the mean
        let c3 = (
            x1.clone(),
            x1.iter().map(|x| 1.1 * f(x)).collect::<Vec<_>>(),
        );
        let r = collapse_rms(&[c1.clone(), c3]).unwrap();
        assert!((r.rms - 1.1f64.ln() / 2.0).abs() < 1e-4, "{r:?}");
        // the blocked side: zeros (the bridge) are cut, the common positive tail compared
        let z = (
            x1.clone(),
            x1.iter()
                .map(|x| if *x < 1.0 { 0.0 } else { f(x) })
                .collect(),
        );
        let r = collapse_rms(&[z, c2]).unwrap();
        assert!(r.x_lo >= 1.0 && r.rms < 1e-4, "{r:?}");
        // nothing in common: none
        let far = (vec![5.0, 6.0], vec![1.0, 1.0]);
        assert!(collapse_rms(&[c1, far]).is_none());
    }
}
