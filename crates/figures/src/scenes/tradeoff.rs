//! A generic trade-off figure: error against cost on log–log axes, one curve per quantity,
//! points optionally labelled (e.g. with the grid size), an optional error target.

use std::path::{Path, PathBuf};

use anyhow::{Result, ensure};

use crate::axes::Axis;
use crate::canvas::{HAlign, Rect, VAlign};
use crate::figure::Figure;
use crate::style::{COLUMN_WIDTH, CYCLE, GREY, Marker, MarkerStyle, Stroke};
use crate::xy::{Annotation, LegendPos, Series, XyPanel};

/// One quantity's error–cost curve.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TradeoffCurve {
    /// Legend text (rich text).
    pub label: String,
    /// Cost of each run (e.g. wall time in s), > 0.
    pub cost: Vec<f64>,
    /// Error of each run (e.g. relative error), > 0.
    pub error: Vec<f64>,
    /// Text beside each point (e.g. "256²"); empty for none.
    pub point_labels: Vec<String>,
}

/// Data of a trade-off figure.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TradeoffData {
    /// x label; empty for "wall time (s)".
    pub cost_label: String,
    /// y label; empty for "relative error".
    pub error_label: String,
    /// Curves (colours and markers from the cycle).
    pub curves: Vec<TradeoffCurve>,
    /// Error target, drawn as a horizontal dotted line.
    pub target: Option<f64>,
}

const MARKERS: [Marker; 6] = [
    Marker::Circle,
    Marker::Square,
    Marker::TriangleUp,
    Marker::Diamond,
    Marker::TriangleDown,
    Marker::Hexagon,
];

/// Builds the trade-off figure (one column).
pub fn figure(d: &TradeoffData) -> Result<Figure> {
    let or = |s: &str, def: &str| {
        if s.is_empty() {
            def.to_string()
        } else {
            s.to_string()
        }
    };
    // room on the right for point labels
    let labelled = d
        .curves
        .iter()
        .any(|c| c.point_labels.iter().any(|l| !l.is_empty()));
    let (lo, hi) = crate::axes::auto_range(
        d.curves.iter().flat_map(|c| c.cost.iter().copied()),
        crate::axes::Scale::Log,
    );
    let hi = if labelled {
        hi * (hi / lo).powf(0.12)
    } else {
        hi
    };
    let mut p = XyPanel::new(
        Axis::log(&or(&d.cost_label, "wall time (s)")).range(lo, hi),
        Axis::log(&or(&d.error_label, "relative error")),
    );
    for (k, c) in d.curves.iter().enumerate() {
        ensure!(
            c.cost.len() == c.error.len(),
            "trade-off curve {:?}: lengths differ",
            c.label
        );
        let col = CYCLE[k % CYCLE.len()];
        p.series.push(
            Series::line(
                c.cost.clone(),
                c.error.clone(),
                Stroke::solid(col).width(1.2),
            )
            .marker(MarkerStyle::filled(MARKERS[k % MARKERS.len()], col).size(5.5))
            .label(&c.label),
        );
        for (i, l) in c.point_labels.iter().enumerate() {
            if i < c.cost.len() && !l.is_empty() {
                p.annotations.push(Annotation::Text {
                    at: (c.cost[i], c.error[i]),
                    text: format!("  {l}"),
                    h: HAlign::Left,
                    v: VAlign::Bottom,
                    color: col,
                });
            }
        }
    }
    if let Some(t) = d.target {
        p.annotations.push(Annotation::HLine {
            y: t,
            stroke: Stroke::dotted(GREY).width(1.1),
            label: Some("target".into()),
        });
    }
    // many quantities: beyond 6 curves the legend goes beside the panel
    if d.curves.len() <= 6 {
        p.legend = LegendPos::TopRight;
        let mut f = Figure::new(COLUMN_WIDTH, 360.0);
        f.xy(Rect::new(0.0, 0.0, COLUMN_WIDTH, 360.0), p);
        Ok(f)
    } else {
        let height = (360.0f64).max(40.0 + 19.0 * d.curves.len() as f64);
        p.legend = LegendPos::At(1.04, 0.0);
        let mut f = Figure::new(COLUMN_WIDTH + 300.0, height);
        f.xy(Rect::new(0.0, 0.0, COLUMN_WIDTH, height), p);
        Ok(f)
    }
}

/// Renders the trade-off figure to `<out_stem>.png` and `.svg`.
pub fn render(d: &TradeoffData, out_stem: &Path) -> Result<Vec<PathBuf>> {
    figure(d)?.render(out_stem)
}
