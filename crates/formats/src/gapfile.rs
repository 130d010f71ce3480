//! Gap fields read from HDF5 files for Reynolds flow, whoever wrote them, and flow results as
//! JSON: shared by `saddleflow flow` and the `flow` stage kind.
//!
//! The input contract (ARCHITECTURE.md, "HDF5 files"): a 2-D numeric dataset (default `gap`) of
//! shape `(nx, ny)`, the first index being x, and root attributes `lx`, `ly` (numbers > 0, the
//! periodic cell). Gaps must be finite and ≥ 0; 0 marks contact. Integer or `f32` datasets and
//! attributes are converted to `f64` by HDF5; an attribute stored as a one-element array (as
//! `h5py` does for `attrs["lx"] = [1.0]`) is accepted too.

use anyhow::{Result, anyhow, bail};
use ndarray::Array2;
use reynolds::{FlowAxis, FlowResult, Termination};
use serde_json::{Value, json};
use store::ArtefactReader;

/// A validated gap field with its cell.
#[derive(Clone, Debug)]
pub struct GapField {
    /// Gap, shape `(nx, ny)`, first index x; finite, ≥ 0.
    pub gap: Array2<f64>,
    /// Cell size along x.
    pub lx: f64,
    /// Cell size along y.
    pub ly: f64,
}

/// Parses `x` or `y`.
pub fn parse_axis(s: &str) -> Result<FlowAxis> {
    match s {
        "x" | "X" => Ok(FlowAxis::X),
        "y" | "Y" => Ok(FlowAxis::Y),
        other => bail!("axis `{other}`: allowed values are x, y"),
    }
}

/// `"x"` or `"y"`.
pub fn axis_name(a: FlowAxis) -> &'static str {
    match a {
        FlowAxis::X => "x",
        FlowAxis::Y => "y",
    }
}

/// A short lower-case name of a termination (`converged`, `roundoff_limited`, ...).
pub fn termination_name(t: Termination) -> &'static str {
    match t {
        Termination::Converged => "converged",
        Termination::RoundoffLimited => "roundoff_limited",
        Termination::NotPercolating => "not_percolating",
        Termination::IterationCap => "iteration_cap",
        Termination::Stagnation => "stagnation",
        Termination::ResidualGrowth => "residual_growth",
        Termination::Breakdown => "breakdown",
    }
}

/// Every termination, in [`termination_name`]'s order.
pub const TERMINATIONS: [Termination; 7] = [
    Termination::Converged,
    Termination::RoundoffLimited,
    Termination::NotPercolating,
    Termination::IterationCap,
    Termination::Stagnation,
    Termination::ResidualGrowth,
    Termination::Breakdown,
];

/// The termination of a [`termination_name`].
pub fn parse_termination(s: &str) -> Result<Termination> {
    TERMINATIONS
        .into_iter()
        .find(|&t| termination_name(t) == s)
        .ok_or_else(|| {
            let names: Vec<&str> = TERMINATIONS.into_iter().map(termination_name).collect();
            anyhow::anyhow!("termination `{s}`: allowed {}", names.join(", "))
        })
}

/// Reads a numeric root attribute that must be a finite number > 0 (a scalar or a one-element
/// array).
fn cell_attr(r: &ArtefactReader, name: &str) -> Result<f64> {
    let file = r.path().display();
    let attr = r.hdf5().attr(name).map_err(|_| {
        let present = r.attr_names("").unwrap_or_default();
        anyhow!(
            "`{file}`: root attribute `{name}` is missing; a gap file needs root attributes `lx` \
             and `ly` (the periodic cell size, numbers > 0){}",
            if present.is_empty() {
                " (the file has no root attributes)".to_string()
            } else {
                format!(" (root attributes present: {})", present.join(", "))
            }
        )
    })?;
    let v: Vec<f64> = attr.read_raw::<f64>().map_err(|_| {
        anyhow!("`{file}`: root attribute `{name}` is not a number; allowed: a number > 0")
    })?;
    let [x] = v[..] else {
        bail!(
            "`{file}`: root attribute `{name}` has {} values; allowed: one number > 0",
            v.len()
        );
    };
    if !(x.is_finite() && x > 0.0) {
        bail!("`{file}`: root attribute `{name}` = {x:?}; allowed: a finite number > 0");
    }
    Ok(x)
}

/// Reads and validates the gap field at `dataset` of `r` and the cell (`lx`, `ly`). Errors name
/// the file, the dataset or attribute, the offending value and what is allowed.
pub fn read_gap(r: &ArtefactReader, dataset: &str) -> Result<GapField> {
    let file = r.path().display();
    let ds = dataset.trim_start_matches('/');
    if !r.has_dataset(ds) {
        let present: Vec<String> = r
            .members("")
            .unwrap_or_default()
            .into_iter()
            .filter(|m| r.has_dataset(m))
            .collect();
        bail!(
            "`{file}` has no dataset `/{ds}`; a gap file needs a 2-D numeric dataset `/{ds}` of \
             shape (nx, ny), first index x{}",
            if present.is_empty() {
                " (the file has no datasets at its root)".to_string()
            } else {
                format!(" (root datasets present: {})", present.join(", "))
            }
        );
    }
    let shape = r.shape(ds)?;
    if shape.len() != 2 {
        bail!(
            "`{file}`: dataset `/{ds}` has rank {} (shape {shape:?}); allowed: rank 2, shape \
             (nx, ny) with the first index x",
            shape.len()
        );
    }
    let (nx, ny) = (shape[0], shape[1]);
    if !(4..=16384).contains(&nx) || !(4..=16384).contains(&ny) {
        bail!("`{file}`: dataset `/{ds}` has shape ({nx}, {ny}); allowed: each side in 4..=16384");
    }
    let gap = r
        .hdf5()
        .dataset(ds)
        .and_then(|d| d.read_2d::<f64>())
        .map_err(|e| {
            anyhow!(
                "`{file}`: dataset `/{ds}` cannot be read as numbers ({e}); allowed: a 2-D \
                 integer or floating-point dataset"
            )
        })?;
    let lx = cell_attr(r, "lx")?;
    let ly = cell_attr(r, "ly")?;
    check_gap_values(&gap).map_err(|m| anyhow!("`{file}`: dataset `/{ds}`: {m}"))?;
    Ok(GapField { gap, lx, ly })
}

/// Checks that every gap is finite and ≥ 0; the message names the first offending node and
/// counts the others.
pub fn check_gap_values(gap: &Array2<f64>) -> std::result::Result<(), String> {
    let mut first: Option<((usize, usize), f64)> = None;
    let mut count = 0usize;
    for (ij, &v) in gap.indexed_iter() {
        if !(v.is_finite() && v >= 0.0) {
            count += 1;
            if first.is_none() {
                first = Some((ij, v));
            }
        }
    }
    match first {
        None => Ok(()),
        Some(((i, j), v)) => Err(format!(
            "{} at index ({i}, {j}){}; allowed: finite gaps ≥ 0 (0 marks contact)",
            if v.is_nan() {
                "value NaN".to_string()
            } else if !v.is_finite() {
                format!("value {v} is not finite")
            } else {
                format!(
                    "value {} is negative",
                    if v > -1e-3 {
                        format!("{v:e}")
                    } else {
                        format!("{v:?}")
                    }
                )
            },
            if count > 1 {
                format!(" and {} other invalid value(s)", count - 1)
            } else {
                String::new()
            }
        )),
    }
}

/// The gaps of a field against what double precision can represent in a flow solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GapRange {
    /// Nodes with g > 0.
    pub open_nodes: usize,
    /// Open nodes whose cube, the local conductivity g³, is not a normal double
    /// (0 < g < ∛(f64::MIN_POSITIVE) ≈ 2.8e-103 h0): the flow solver treats a zero cube as contact
    /// and computes with a subnormal one at reduced precision.
    pub underflow_nodes: usize,
    /// The largest gap (h0).
    pub max_gap: f64,
}

/// Bounds on the largest gap of a field for a flow solve (h0): the solver's residual norms square
/// the conductivities g³, so g⁶ must be a normal double, g ∈ [MIN_POSITIVE^(1/6),
/// MAX^(1/6)] ≈ [5.3e-52, 2.4e51]. Measured on a 16² field of varied gaps: the largest gap
/// 9e-51 and 9e29 solve exactly (K/g³ unchanged), 3e-61 and 3e59 end with a NaN residual.
pub fn max_gap_range() -> (f64, f64) {
    (f64::MIN_POSITIVE.powf(1.0 / 6.0), f64::MAX.powf(1.0 / 6.0))
}

/// Checks that a gap field's flow is representable in double precision: refuses a field whose
/// largest gap is outside [`max_gap_range`] (its flow would come out as NaN, or as zero with
/// `percolating: false` once every cube underflows, when it is merely out of range), and counts
/// the open nodes whose conductivity underflows (the caller warns).
pub fn check_gap_range(gap: &Array2<f64>) -> Result<GapRange> {
    let (low, high) = max_gap_range();
    let max_gap = gap.iter().copied().fold(0.0, f64::max);
    let open_nodes = gap.iter().filter(|&&g| g > 0.0).count();
    let cube_min = f64::MIN_POSITIVE.cbrt();
    let underflow_nodes = gap.iter().filter(|&&g| g > 0.0 && g < cube_min).count();
    if max_gap > high {
        bail!(
            "the largest gap {max_gap:?} h0 exceeds {high:.2e}: the squares of the local \
             conductivities g³, which the flow solver forms, overflow double precision; allowed: \
             a largest gap in [{low:.2e}, {high:.2e}] (rescale the field: the conductivity scales \
             as g³)"
        );
    }
    if open_nodes > 0 && max_gap < low {
        bail!(
            "the largest gap {max_gap:?} h0 is below {low:.2e}: the local conductivities g³ \
             ({}) underflow double precision in the flow solver; allowed: a largest gap in \
             [{low:.2e}, {high:.2e}] (rescale the field: the conductivity scales as g³)",
            if underflow_nodes == open_nodes {
                "every one of them is 0 in doubles".to_string()
            } else {
                "and their squares".to_string()
            }
        );
    }
    Ok(GapRange {
        open_nodes,
        underflow_nodes,
        max_gap,
    })
}

/// The scalar results of a flow solve as JSON (what `saddleflow flow` prints, and each point of
/// the `flow` stage's statistics).
pub fn flow_json(res: &FlowResult) -> Value {
    json!({
        "conductivity": res.conductivity,
        "flux": res.flux,
        "percolating": res.percolating,
        "converged": res.converged,
        "termination": termination_name(res.termination),
        "iterations": res.iterations,
        "residual": res.relative_residual,
        "residual_floor": res.residual_floor,
        "flux_rounding_error": res.flux_rounding_error,
        "conservation_error": res.conservation_error,
        "flux_error_estimate": res.flux_error_estimate,
        "flowing_nodes": res.flowing_nodes,
        "removed_nodes": res.removed_nodes,
        "levels": res.levels,
        "wall_s": res.wall_seconds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gap_values_are_checked() {
        let mut g = Array2::from_elem((4, 4), 0.5);
        assert!(check_gap_values(&g).is_ok());
        g[[1, 2]] = -1e-3;
        g[[3, 3]] = f64::NAN;
        let e = check_gap_values(&g).unwrap_err();
        assert!(e.contains("(1, 2)") && e.contains("negative"), "{e}");
        assert!(e.contains("1 other"), "{e}");
        g[[1, 2]] = 0.0;
        let e = check_gap_values(&g).unwrap_err();
        assert!(e.contains("NaN") && e.contains("(3, 3)"), "{e}");
    }

    #[test]
    fn gap_range_is_checked() {
        let (low, high) = max_gap_range();
        // (2.2e-308)^(1/6) and (1.8e308)^(1/6)
        assert!((low / 5.30e-52 - 1.0).abs() < 1e-2, "{low}");
        assert!((high / 2.37e51 - 1.0).abs() < 1e-2, "{high}");
        let mut g = Array2::from_elem((4, 4), 0.5);
        g[[0, 0]] = 0.0;
        g[[1, 1]] = 1e-104;
        let r = check_gap_range(&g).unwrap();
        assert_eq!((r.open_nodes, r.underflow_nodes, r.max_gap), (15, 1, 0.5));
        let e = check_gap_range(&g.mapv(|x| x * 1e-200)).unwrap_err();
        assert!(e.to_string().contains("0 in doubles"), "{e}");
        let e = check_gap_range(&g.mapv(|x| x * 1e-60)).unwrap_err();
        assert!(e.to_string().contains("underflow"), "{e}");
        let e = check_gap_range(&g.mapv(|x| x * 1e60)).unwrap_err();
        assert!(e.to_string().contains("overflow"), "{e}");
        // all closed: nothing to represent, the solver reports no percolation
        assert!(check_gap_range(&Array2::zeros((4, 4))).is_ok());
    }

    #[test]
    fn axes_parse() {
        assert_eq!(parse_axis("x").unwrap(), FlowAxis::X);
        assert_eq!(parse_axis("y").unwrap(), FlowAxis::Y);
        assert!(format!("{}", parse_axis("z").unwrap_err()).contains("allowed values are x, y"));
    }
}
