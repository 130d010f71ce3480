//! Figure 3: relative contact area against surface energy γ0 at zero load for the three
//! models; increasing γ0 solid, decreasing γ0 dashed, arrows along each branch, jumps marked
//! with the model's open marker; γ_p and γ_fc optionally marked by the model's filled marker
//! on the γ0 axis.

use std::path::{Path, PathBuf};

use anyhow::{Result, ensure};

use crate::axes::Axis;
use crate::canvas::Rect;
use crate::figure::Figure;
use crate::style::{
    COLUMN_WIDTH, DARK_GREY, Dash, MarkerStyle, Model, Stroke, model_color, model_marker,
};
use crate::xy::{Annotation, LegendEntry, LegendPos, Series, XyPanel};

/// One branch of a γ0 path, in the order computed (each step warm-started).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GammaBranch {
    /// Surface energy γ0 (E* h0²/λ).
    pub gamma0: Vec<f64>,
    /// Relative contact area (0..1).
    pub area: Vec<f64>,
    /// Jumps: index i means a jump between points i and i + 1.
    pub jumps: Vec<usize>,
}

/// Both branches of one model.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelGammaPath {
    /// Model.
    pub model: Model,
    /// Increasing γ0.
    pub increasing: GammaBranch,
    /// Decreasing γ0.
    pub decreasing: GammaBranch,
    /// Coalescence (percolation) surface energy γ_p, marked if given.
    pub gamma_p: Option<f64>,
    /// Full-contact surface energy γ_fc, marked if given.
    pub gamma_fc: Option<f64>,
}

/// Data of Figure 3.
#[derive(Debug, Clone, PartialEq)]
pub struct Fig3Data {
    /// One entry per model (normally hexagonal, square, triangular).
    pub paths: Vec<ModelGammaPath>,
    /// Logarithmic γ0 axis (requires γ0 > 0; recommended: γ_fc/γ_p spans two decades).
    pub log_gamma: bool,
}

fn check(b: &GammaBranch, what: &str) -> Result<()> {
    ensure!(
        b.gamma0.len() == b.area.len(),
        "{what}: {} γ0 values but {} areas",
        b.gamma0.len(),
        b.area.len()
    );
    ensure!(
        b.jumps.iter().all(|&j| j + 1 < b.area.len()),
        "{what}: jump index out of range"
    );
    Ok(())
}

/// Builds Figure 3 (one column).
pub fn figure(d: &Fig3Data) -> Result<Figure> {
    let gl = "surface energy $γ$_0 / ($E$^*$h$_0^2/$λ$)";
    let mut p = XyPanel::new(
        if d.log_gamma {
            Axis::log(gl)
        } else {
            Axis::linear(gl)
        },
        Axis::linear("relative contact area $a$").range(0.0, 1.04),
    );
    for path in &d.paths {
        check(
            &path.increasing,
            &format!("{} increasing", path.model.name()),
        )?;
        check(
            &path.decreasing,
            &format!("{} decreasing", path.model.name()),
        )?;
        let col = model_color(path.model);
        for (b, dash) in [
            (&path.decreasing, Dash::Dashed),
            (&path.increasing, Dash::Solid),
        ] {
            p.series.push(
                Series::line(
                    b.gamma0.clone(),
                    b.area.clone(),
                    Stroke::solid(col).dash(dash),
                )
                .arrows(if b.gamma0.len() > 1 { 2 } else { 0 }),
            );
            let (mut x, mut y) = (vec![], vec![]);
            for &j in &b.jumps {
                x.extend([b.gamma0[j], b.gamma0[j + 1]]);
                y.extend([b.area[j], b.area[j + 1]]);
            }
            if !x.is_empty() {
                p.series.push(Series::points(
                    x,
                    y,
                    MarkerStyle::open(model_marker(path.model), col).size(6.0),
                ));
            }
        }
        for g in [path.gamma_p, path.gamma_fc].into_iter().flatten() {
            p.annotations.push(Annotation::Marker {
                at: (g, 0.0),
                style: MarkerStyle::filled(model_marker(path.model), col).size(7.0),
            });
        }
        p.legend_extra.push(LegendEntry {
            label: path.model.name().into(),
            stroke: Some(Stroke::solid(col)),
            marker: Some(MarkerStyle::open(model_marker(path.model), col).size(6.0)),
        });
    }
    p.legend_extra.push(LegendEntry {
        label: "increasing $γ$_0".into(),
        stroke: Some(Stroke::solid(DARK_GREY)),
        marker: None,
    });
    p.legend_extra.push(LegendEntry {
        label: "decreasing $γ$_0".into(),
        stroke: Some(Stroke::dashed(DARK_GREY)),
        marker: None,
    });
    if d.paths
        .iter()
        .any(|p| p.gamma_p.is_some() || p.gamma_fc.is_some())
    {
        p.legend_extra.push(LegendEntry {
            label: "$γ$_p, $γ$_{fc} (on the axis)".into(),
            stroke: None,
            marker: Some(MarkerStyle::filled(crate::style::Marker::Circle, DARK_GREY).size(6.0)),
        });
    }
    p.legend = LegendPos::TopLeft;
    let mut f = Figure::new(COLUMN_WIDTH, 360.0);
    f.xy(Rect::new(0.0, 0.0, COLUMN_WIDTH, 360.0), p);
    Ok(f)
}

/// Renders Figure 3 to `<out_stem>.png` and `.svg`.
pub fn render(d: &Fig3Data, out_stem: &Path) -> Result<Vec<PathBuf>> {
    figure(d)?.render(out_stem)
}
