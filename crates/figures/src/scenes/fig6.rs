//! Figure 6. Top: flux through the interface against load for the three models, γ0 = 0 solid,
//! γ0 > 0 dashed with the end point (where flow stops discontinuously) marked. Bottom left:
//! normalised flux against L_c − L, log–log, with the fitted power law (slope β); the refined
//! ladder's flux continuing the uniform points (filled diamonds in the model's colour) and each
//! model's asymptotic β as a dashed line in its colour through the point at its estimate's
//! smallest distance, over the whole range drawn, its value written in the lower right corner. Bottom
//! right: the Reynolds current density in the critical region (|j| colour-coded, contact
//! white, arrows for the direction).

use std::path::{Path, PathBuf};

use anyhow::{Result, ensure};
use ndarray::Array2;

use crate::axes::Axis;
use crate::canvas::{HAlign, Rect, VAlign};
use crate::figure::Figure;
use crate::heatmap::{ColorbarPos, Colormap, HeatmapPanel, Overlay};
use crate::style::{
    DARK_GREY, Marker, MarkerStyle, Model, Stroke, WHITE, model_color, model_marker,
};
use crate::xy::{Annotation, LegendEntry, LegendPos, Series, XyPanel};

/// Flux against load for one model and one surface energy.
#[derive(Debug, Clone, PartialEq)]
pub struct FlowCurve {
    /// Model (sets the colour).
    pub model: Model,
    /// Surface energy γ0 (E* h0²/λ): 0 is drawn solid, anything else dashed.
    pub gamma0: f64,
    /// Load (units as in `Fig6Data::load_label`), in increasing order.
    pub load: Vec<f64>,
    /// Flux (effective conductivity, units of `Fig6Data::flux_label`).
    pub flux: Vec<f64>,
    /// Mark the last point (where the flow stops discontinuously).
    pub mark_end: bool,
}

/// Normalised flux near the critical load for one model.
#[derive(Debug, Clone, PartialEq)]
pub struct NormalisedFlux {
    /// Model (colour and marker).
    pub model: Model,
    /// Distance to the critical load, L_c − L (> 0).
    pub distance: Vec<f64>,
    /// Normalised flux (> 0).
    pub flux: Vec<f64>,
    /// Optional 1σ errors of the flux.
    pub flux_err: Option<Vec<f64>>,
}

/// A model's asymptotic slope: a dashed line through `through` with slope `exponent`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlopeLine {
    /// Model (colour).
    pub model: Model,
    /// Slope (β).
    pub exponent: f64,
    /// Its 1σ (NaN: not shown).
    pub exponent_err: f64,
    /// A point of the line (distance, normalised flux).
    pub through: (f64, f64),
}

/// A fitted power law y = prefactor · x^exponent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerLawFit {
    /// Exponent (β).
    pub exponent: f64,
    /// Its 1σ error, if known.
    pub exponent_err: Option<f64>,
    /// Prefactor.
    pub prefactor: f64,
}

/// Current density on a periodic cell.
#[derive(Debug, Clone, PartialEq)]
pub struct CurrentMap {
    /// x component of −g³∇p, shape (nx, ny), first index x.
    pub jx: Array2<f64>,
    /// y component.
    pub jy: Array2<f64>,
    /// Gap (h0); nodes with g ≤ 0 are contact and drawn white. Optional.
    pub gap: Option<Array2<f64>>,
    /// Cell width (λ).
    pub lx: f64,
    /// Cell height (λ).
    pub ly: f64,
    /// Window (x0, x1, y0, y1) in λ, e.g. around the saddle; `None`: one cell.
    pub view: Option<(f64, f64, f64, f64)>,
    /// Arrows per side of the view (0 for none).
    pub arrows: usize,
    /// Logarithmic colour scale of |j| (spanning 4 decades below the maximum).
    pub log: bool,
}

/// Data of Figure 6.
#[derive(Debug, Clone, PartialEq)]
pub struct Fig6Data {
    /// Top panel curves.
    pub flow: Vec<FlowCurve>,
    /// Top panel x label (rich text), e.g. "load $L$ / $L$_c".
    pub load_label: String,
    /// Top panel y label.
    pub flux_label: String,
    /// Logarithmic flux axis in the top panel.
    pub flux_log: bool,
    /// Bottom-left data.
    pub normalised: Vec<NormalisedFlux>,
    /// Bottom-left x label, e.g. "($L$_c − $L$)/$L$_c".
    pub distance_label: String,
    /// Fitted power law, drawn over the data's range with a slope label.
    pub fit: Option<PowerLawFit>,
    /// Bottom-left: the refined ladders' flux (same normalisation as `normalised`).
    pub refined: Vec<NormalisedFlux>,
    /// Bottom-left: the models' asymptotic slopes.
    pub slopes: Vec<SlopeLine>,
    /// Bottom-right map.
    pub current: Option<CurrentMap>,
}

fn or(s: &str, d: &str) -> String {
    if s.is_empty() { d.into() } else { s.into() }
}

fn top_panel(d: &Fig6Data) -> Result<XyPanel> {
    let flux_label = or(&d.flux_label, "flux $Q$");
    let mut p = XyPanel::new(
        Axis::linear(&or(&d.load_label, "load $L$")),
        if d.flux_log {
            Axis::log(&flux_label)
        } else {
            Axis::linear(&flux_label)
        },
    );
    let mut models: Vec<Model> = vec![];
    let mut adhesive = false;
    for c in &d.flow {
        ensure!(
            c.load.len() == c.flux.len(),
            "flow curve ({}): lengths differ",
            c.model.name()
        );
        let col = model_color(c.model);
        let st = if c.gamma0 == 0.0 {
            Stroke::solid(col)
        } else {
            adhesive = true;
            Stroke::dashed(col)
        };
        p.series
            .push(Series::line(c.load.clone(), c.flux.clone(), st));
        if c.mark_end
            && let (Some(&x), Some(&y)) = (c.load.last(), c.flux.last())
        {
            p.annotations.push(Annotation::Marker {
                at: (x, y),
                style: MarkerStyle::filled(model_marker(c.model), col).size(7.0),
            });
        }
        if !models.contains(&c.model) {
            models.push(c.model);
        }
    }
    models.sort_by_key(|m| Model::ALL.iter().position(|x| x == m));
    for m in models {
        p.legend_extra.push(LegendEntry {
            label: m.name().into(),
            stroke: Some(Stroke::solid(model_color(m))),
            marker: None,
        });
    }
    p.legend_extra.push(LegendEntry {
        label: "$γ$_0 = 0".into(),
        stroke: Some(Stroke::solid(DARK_GREY)),
        marker: None,
    });
    if adhesive {
        let g: Vec<f64> = d
            .flow
            .iter()
            .map(|c| c.gamma0)
            .filter(|&g| g != 0.0)
            .collect();
        let label = if g.iter().all(|&x| x == g[0]) {
            format!("$γ$_0 = {}", g[0])
        } else {
            "$γ$_0 > 0".into()
        };
        p.legend_extra.push(LegendEntry {
            label,
            stroke: Some(Stroke::dashed(DARK_GREY)),
            marker: None,
        });
    }
    p.legend = LegendPos::TopRight;
    p.legend_columns = 2;
    Ok(p)
}

fn bottom_left(d: &Fig6Data) -> Result<XyPanel> {
    let mut p = XyPanel::new(
        Axis::log(&or(&d.distance_label, "$L$_c − $L$")),
        Axis::log("$Q$ / $Q$_0"),
    );
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    let mut y_lo = f64::INFINITY;
    for n in d.normalised.iter().chain(&d.refined) {
        y_lo = n
            .flux
            .iter()
            .copied()
            .filter(|y| *y > 0.0)
            .fold(y_lo, f64::min);
    }
    for (set, what, style) in [
        (&d.normalised, "normalised", None),
        (&d.refined, "refined", Some(Marker::Diamond)),
    ] {
        for n in set {
            ensure!(
                n.distance.len() == n.flux.len(),
                "{what} flux ({}): lengths differ",
                n.model.name()
            );
            let col = model_color(n.model);
            // uniform rungs open in the model's marker, refined rungs filled diamonds
            let marker = match style {
                None => MarkerStyle::open(model_marker(n.model), col).size(5.5),
                Some(m) => MarkerStyle::filled(m, col).size(4.5),
            };
            let mut s = Series::points(n.distance.clone(), n.flux.clone(), marker);
            if let Some(e) = &n.flux_err {
                s = s.y_err(e.clone());
            }
            p.series.push(s);
            for &x in &n.distance {
                if x > 0.0 {
                    lo = lo.min(x);
                    hi = hi.max(x);
                }
            }
        }
    }
    for (k, sl) in d.slopes.iter().enumerate() {
        if !(sl.through.0 > 0.0 && sl.through.1 > 0.0 && hi > lo) {
            continue;
        }
        let label = if sl.exponent_err.is_finite() {
            format!(
                "{}: $β$_∞ = {} ± {}",
                sl.model.name(),
                crate::text::fmt_num(sl.exponent, 2),
                crate::text::fmt_num(sl.exponent_err, 2)
            )
        } else {
            format!(
                "{}: $β$_∞ = {}",
                sl.model.name(),
                crate::text::fmt_num(sl.exponent, 2)
            )
        };
        p.annotations.push(Annotation::PowerLaw {
            x_range: (lo.min(sl.through.0), hi.max(sl.through.0)),
            through: sl.through,
            exponent: sl.exponent,
            stroke: Stroke::dashed(model_color(sl.model)).width(1.0),
            label: None,
        });
        // the lower right corner is empty on a rising log–log curve: one line per model
        p.annotations.push(Annotation::Text {
            at: (hi, y_lo * 10f64.powf(0.9 * k as f64)),
            text: label,
            h: HAlign::Right,
            v: VAlign::Bottom,
            color: model_color(sl.model),
        });
    }
    if d.normalised.is_empty() && d.refined.is_empty() {
        // the near-critical study provides this panel; say so instead of leaving it blank
        p.x = p.x.clone().range(0.1, 10.0);
        p.y = p.y.clone().range(0.1, 10.0);
        p.annotations.push(Annotation::Text {
            at: (1.0, 1.0),
            text: "no near-critical flux data".into(),
            h: HAlign::Center,
            v: VAlign::Center,
            color: DARK_GREY,
        });
    }
    if let Some(fit) = d.fit
        && hi > lo
    {
        let label = match fit.exponent_err {
            Some(e) => format!(
                "$β$ = {} ± {}",
                crate::text::fmt_num(fit.exponent, 2),
                crate::text::fmt_num(e, 2)
            ),
            None => format!("$β$ = {}", crate::text::fmt_num(fit.exponent, 2)),
        };
        let x0 = (lo * hi).sqrt();
        p.annotations.push(Annotation::PowerLaw {
            x_range: (lo, hi),
            through: (x0, fit.prefactor * x0.powf(fit.exponent)),
            exponent: fit.exponent,
            stroke: Stroke::solid(DARK_GREY).width(1.0),
            label: Some(label),
        });
    }
    p.legend = LegendPos::None;
    Ok(p)
}

fn bottom_right(m: &CurrentMap) -> Result<HeatmapPanel> {
    ensure!(
        m.jx.dim() == m.jy.dim(),
        "current map: jx {:?} and jy {:?} differ",
        m.jx.dim(),
        m.jy.dim()
    );
    let mag = ndarray::Zip::from(&m.jx)
        .and(&m.jy)
        .map_collect(|a, b| (a * a + b * b).sqrt());
    let max = mag
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let mut h = HeatmapPanel::new(mag.clone(), m.lx, m.ly);
    h.view = m.view;
    h.colormap = Colormap::Magma;
    h.log = m.log && max > 0.0;
    if h.log {
        h.range = Some((max * 1e-4, max));
    }
    if let Some(g) = &m.gap {
        ensure!(g.dim() == m.jx.dim(), "current map: gap has another shape");
        h.mask = Some(g.mapv(|v| v <= 0.0));
    }
    h.mask_color = WHITE;
    h.colorbar = ColorbarPos::Right;
    h.colorbar_label = "|$j$|".into();
    if m.arrows > 0 && max > 0.0 {
        let (x0, x1, y0, y1) = m.view.unwrap_or((0.0, m.lx, 0.0, m.ly));
        let (nx, ny) = m.jx.dim();
        let n = m.arrows;
        let step = ((x1 - x0) / n as f64).min((y1 - y0) / n as f64);
        let (mut origins, mut vectors) = (vec![], vec![]);
        let kx = ((x1 - x0) / step).round().max(1.0) as usize;
        let ky = ((y1 - y0) / step).round().max(1.0) as usize;
        for a in 0..kx {
            for b in 0..ky {
                let x = x0 + (a as f64 + 0.5) * (x1 - x0) / kx as f64;
                let y = y0 + (b as f64 + 0.5) * (y1 - y0) / ky as f64;
                let i = ((x / m.lx * nx as f64).round() as i64).rem_euclid(nx as i64) as usize;
                let j = ((y / m.ly * ny as f64).round() as i64).rem_euclid(ny as i64) as usize;
                let v = mag[[i, j]];
                if !(v.is_finite() && v > 1e-3 * max) {
                    continue;
                }
                // length grows weakly with |j| so that weak currents still show a direction
                let len = 0.85 * step * (v / max).powf(0.3).max(0.5);
                let (ux, uy) = (m.jx[[i, j]] / v, m.jy[[i, j]] / v);
                origins.push((x - ux * len / 2.0, y - uy * len / 2.0));
                vectors.push((ux * len, uy * len));
            }
        }
        h.overlays.push(Overlay::Arrows {
            origins,
            vectors,
            color: plotters::style::RGBColor(120, 220, 255),
            width: 0.9,
        });
    }
    Ok(h)
}

/// Builds Figure 6: a wide top panel and two panels below.
pub fn figure(d: &Fig6Data) -> Result<Figure> {
    let (w, h) = (620.0, 640.0);
    let rows = Rect::new(0.0, 0.0, w, h).rows(&[0.47, 0.53], 10.0);
    let mut f = Figure::new(w, h);
    let mut top = top_panel(d)?;
    top.tag = Some("(a)".into());
    f.xy(rows[0], top);
    let bottom = rows[1].columns(&[0.85, 1.15], 12.0);
    let mut bl = bottom_left(d)?;
    bl.tag = Some("(b)".into());
    f.xy(bottom[0], bl);
    if let Some(m) = &d.current {
        let mut br = bottom_right(m)?;
        br.tag = Some("(c)".into());
        f.heatmap(bottom[1], br);
    }
    Ok(f)
}

/// Renders Figure 6 to `<out_stem>.png` and `.svg`.
pub fn render(d: &Fig6Data, out_stem: &Path) -> Result<Vec<PathBuf>> {
    figure(d)?.render(out_stem)
}
