//! A generic convergence figure: a quantity against grid spacing with error bars, the fitted
//! extrapolation curve with its uncertainty band, the extrapolated value at zero spacing and an
//! optional reference value (e.g. the paper's).

use std::path::{Path, PathBuf};

use anyhow::{Result, ensure};

use crate::axes::Axis;
use crate::canvas::Rect;
use crate::figure::Figure;
use crate::style::{COLUMN_WIDTH, CYCLE, GREY, Marker, MarkerStyle, Rgb, Stroke};
use crate::xy::{Annotation, LegendEntry, LegendPos, Series, XyPanel};

/// One quantity's convergence data.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ConvergenceSeries {
    /// Legend text (rich text).
    pub label: String,
    /// Grid spacing of each run (λ).
    pub spacing: Vec<f64>,
    /// Measured value at each spacing.
    pub value: Vec<f64>,
    /// 1σ error of each value (empty for none).
    pub error: Vec<f64>,
    /// Fitted extrapolation curve: (spacing, value) points from 0 to the largest spacing.
    pub fit: Vec<(f64, f64)>,
    /// 1σ band of the fit: (lower, upper) at each fit point (empty for none).
    pub fit_band: Vec<(f64, f64)>,
    /// Extrapolated value at zero spacing and its 1σ error.
    pub extrapolated: Option<(f64, f64)>,
    /// A reference value of this series and its 1σ error (e.g. the paper's), drawn at zero
    /// spacing beside the extrapolated value as a cross with an error bar.
    pub reference: Option<(f64, f64)>,
}

/// Data of a convergence figure.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ConvergenceData {
    /// y label (rich text), e.g. "$a$_p".
    pub quantity_label: String,
    /// x label; empty for "grid spacing $Δx$ / $λ$".
    pub spacing_label: String,
    /// Series (colours from the qualitative cycle).
    pub series: Vec<ConvergenceSeries>,
    /// Reference values (value, label), drawn as horizontal dotted lines.
    pub references: Vec<(f64, String)>,
    /// Legend text of the series' own reference values (`ConvergenceSeries::reference`).
    pub reference_label: Option<String>,
}

/// The convergence panel of one quantity.
pub fn panel(d: &ConvergenceData) -> Result<XyPanel> {
    let xl = if d.spacing_label.is_empty() {
        "grid spacing $Δx$ / $λ$"
    } else {
        &d.spacing_label
    };
    let hmax = d
        .series
        .iter()
        .flat_map(|s| s.spacing.iter().copied())
        .fold(0.0, f64::max);
    let mut p = XyPanel::new(
        Axis::linear(xl).range(-0.04 * hmax.max(1e-12), hmax.max(1e-12) * 1.06),
        Axis::linear(&d.quantity_label),
    );
    for (k, s) in d.series.iter().enumerate() {
        ensure!(
            s.spacing.len() == s.value.len(),
            "convergence series {:?}: lengths differ",
            s.label
        );
        ensure!(
            s.error.is_empty() || s.error.len() == s.value.len(),
            "convergence series {:?}: error length differs",
            s.label
        );
        let col: Rgb = CYCLE[k % CYCLE.len()];
        if !s.fit.is_empty() {
            let (x, y): (Vec<f64>, Vec<f64>) = s.fit.iter().copied().unzip();
            let mut line = Series::line(x, y, Stroke::dashed(col).width(1.2));
            if s.fit_band.len() == s.fit.len() {
                let (lo, hi) = s.fit_band.iter().copied().unzip();
                line = line.band(lo, hi);
            }
            p.series.push(line);
        }
        let mut pts = Series::points(
            s.spacing.clone(),
            s.value.clone(),
            MarkerStyle::filled(Marker::Circle, col).size(5.5),
        )
        .label(&s.label);
        if !s.error.is_empty() {
            pts = pts.y_err(s.error.clone());
        }
        p.series.push(pts);
        if let Some((v, e)) = s.extrapolated {
            p.series.push(
                Series::points(
                    vec![0.0],
                    vec![v],
                    MarkerStyle::open(Marker::Diamond, col).size(7.5),
                )
                .y_err(vec![e]),
            );
        }
        if let Some((v, e)) = s.reference {
            // just left of zero spacing, so that it does not hide the extrapolated value
            p.series.push(
                Series::points(
                    vec![-0.02 * hmax.max(1e-12)],
                    vec![v],
                    MarkerStyle::filled(Marker::Cross, col).size(6.5),
                )
                .y_err(vec![e]),
            );
        }
    }
    for (v, label) in &d.references {
        p.annotations.push(Annotation::HLine {
            y: *v,
            stroke: Stroke::dotted(GREY).width(1.1),
            label: Some(label.clone()),
        });
    }
    if d.series.iter().any(|s| s.extrapolated.is_some()) {
        p.legend_extra.push(LegendEntry {
            label: "extrapolated to $Δx$ = 0".into(),
            stroke: None,
            marker: Some(MarkerStyle::open(Marker::Diamond, GREY).size(7.5)),
        });
    }
    if let Some(label) = &d.reference_label
        && d.series.iter().any(|s| s.reference.is_some())
    {
        p.legend_extra.push(LegendEntry {
            label: label.clone(),
            stroke: None,
            marker: Some(MarkerStyle::filled(Marker::Cross, GREY).size(6.5)),
        });
    }
    // the legend goes where the data are not: above the points if they fall with spacing
    let rising = d.series.iter().any(|s| {
        let lo = s
            .spacing
            .iter()
            .zip(&s.value)
            .min_by(|a, b| a.0.total_cmp(b.0));
        let hi = s
            .spacing
            .iter()
            .zip(&s.value)
            .max_by(|a, b| a.0.total_cmp(b.0));
        matches!((lo, hi), (Some(a), Some(b)) if b.1 > a.1)
    });
    p.legend = if rising {
        LegendPos::TopLeft
    } else {
        LegendPos::BottomLeft
    };
    Ok(p)
}

/// Builds the convergence figure (one column).
pub fn figure(d: &ConvergenceData) -> Result<Figure> {
    let mut f = Figure::new(COLUMN_WIDTH, 360.0);
    f.xy(Rect::new(0.0, 0.0, COLUMN_WIDTH, 360.0), panel(d)?);
    Ok(f)
}

/// Several quantities' convergence panels stacked in one column, tagged (a), (b), ..., with
/// the legend in the first panel only (the series are the same in every panel).
pub fn stacked(ds: &[ConvergenceData]) -> Result<Figure> {
    ensure!(!ds.is_empty(), "no convergence panels to draw");
    let h = 300.0;
    let gap = 8.0;
    let total = h * ds.len() as f64 + gap * (ds.len() - 1) as f64;
    let mut f = Figure::new(COLUMN_WIDTH, total);
    let rows = Rect::new(0.0, 0.0, COLUMN_WIDTH, total).rows(&vec![1.0; ds.len()], gap);
    for (k, (d, r)) in ds.iter().zip(rows).enumerate() {
        let mut p = panel(d)?;
        p.tag = Some(format!("({})", (b'a' + k as u8) as char));
        if k > 0 {
            p.legend = LegendPos::None;
        }
        f.xy(r, p);
    }
    Ok(f)
}

/// Renders the convergence figure to `<out_stem>.png` and `.svg`.
pub fn render(d: &ConvergenceData, out_stem: &Path) -> Result<Vec<PathBuf>> {
    figure(d)?.render(out_stem)
}
