//! Figures of the last constriction on random surfaces (scene `random_constrictions`, issue
//! 15): the gap map just below L_c with the constriction marked and a zoom on it; the flux
//! against the distance d = (L_c − L)/L_c (log–log) for all realisations, normalised at their
//! largest d, with the paper's β = 3.45 and the one-node value 3 as reference slopes; β against
//! η of the constriction.
//!
//! Units: lengths along the surface in the cell's units, gaps in the height unit.

use anyhow::{Result, ensure};
use ndarray::Array2;

use crate::axes::Axis;
use crate::canvas::Rect;
use crate::figure::Figure;
use crate::heatmap::{Colormap, HeatmapPanel, Overlay};
use crate::style::{BLACK, BLUE, GREY, Marker, MarkerStyle, RED, Stroke, WHITE};
use crate::xy::{Annotation, LegendPos, Series, XyPanel};

/// The paper's β of an isolated saddle (Dapp & Müser 2015).
pub const PAPER_BETA: f64 = 3.45;

/// The gap map just below L_c.
#[derive(Debug, Clone, PartialEq)]
pub struct MapFig {
    /// Gap, shape (nx, ny); contact where ≤ 0 (white).
    pub gap: Array2<f64>,
    /// Cell size.
    pub lx: f64,
    /// Cell size.
    pub ly: f64,
    /// The constriction's position.
    pub at: (f64, f64),
    /// Half-size of the zoom (cell units).
    pub zoom: f64,
    /// Title (seed, L_c, η).
    pub title: String,
}

/// One realisation's flux ladder.
#[derive(Debug, Clone, PartialEq)]
pub struct FluxCurve {
    /// Label (the seed).
    pub label: String,
    /// Distances d, descending.
    pub d: Vec<f64>,
    /// Flux (any unit; normalised in the figure).
    pub flux: Vec<f64>,
    /// The rung was used in the fits.
    pub resolved: Vec<bool>,
}

/// β against η.
#[derive(Debug, Clone, PartialEq)]
pub struct BetaEtaFig {
    /// η of the heights at the constriction.
    pub eta: Vec<f64>,
    /// β window fit.
    pub beta: Vec<f64>,
    /// Its 1σ (NaN: none).
    pub beta_err: Vec<f64>,
}

/// Full map (a) and the zoom on the constriction (b), the constriction marked.
pub fn map_figure(d: &MapFig) -> Result<Figure> {
    ensure!(d.zoom > 0.0, "zoom {} must be > 0", d.zoom);
    let (w, h) = (860.0, 420.0);
    let cols = Rect::new(0.0, 0.0, w, h).columns(&[1.0, 1.0], 16.0);
    let mut f = Figure::new(w, h);
    let marker = Overlay::Points {
        points: vec![d.at],
        style: MarkerStyle::open(Marker::Circle, RED),
    };
    let panel = |view: Option<(f64, f64, f64, f64)>, tag: &str| {
        let mut m = HeatmapPanel::new(d.gap.clone(), d.lx, d.ly);
        m.colormap = Colormap::Magma;
        m.mask = Some(d.gap.mapv(|g| g <= 0.0));
        m.mask_color = WHITE;
        m.x_label = "$x$".into();
        m.y_label = "$y$".into();
        m.colorbar_label = "gap $g$".into();
        m.view = view;
        m.tile_overlays = true;
        m.overlays.push(marker.clone());
        m.tag = Some(tag.into());
        m
    };
    let mut a = panel(None, "(a)");
    a.title = Some(d.title.clone());
    f.heatmap(cols[0], a);
    let z = d.zoom;
    let mut b = panel(
        Some((d.at.0 - z, d.at.0 + z, d.at.1 - z, d.at.1 + z)),
        "(b)",
    );
    b.log = true;
    b.colorbar_label = "gap $g$ (log)".into();
    f.heatmap(cols[1], b);
    Ok(f)
}

/// Flux / flux at the largest d against d (log–log), every realisation; resolved rungs filled.
pub fn flux_figure(curves: &[FluxCurve]) -> Result<Figure> {
    let (w, h) = (560.0, 440.0);
    let mut f = Figure::new(w, h);
    let mut p = XyPanel::new(
        Axis::log("$d$ = ($L$_c − $L$)/$L$_c"),
        Axis::log("flux / flux($d$_{max})"),
    );
    let colors = [BLUE, RED, BLACK, GREY];
    let (mut dmin, mut dmax) = (f64::INFINITY, 0.0f64);
    for (k, c) in curves.iter().enumerate() {
        ensure!(
            c.d.len() == c.flux.len() && c.d.len() == c.resolved.len(),
            "{}: {} distances, {} fluxes, {} flags",
            c.label,
            c.d.len(),
            c.flux.len(),
            c.resolved.len()
        );
        let Some(k0) = (0..c.d.len())
            .filter(|&i| c.flux[i] > 0.0 && c.flux[i].is_finite())
            .max_by(|&a, &b| c.d[a].total_cmp(&c.d[b]))
        else {
            continue;
        };
        let q0 = c.flux[k0];
        let pts: Vec<(f64, f64, bool)> = (0..c.d.len())
            .filter(|&i| c.flux[i] > 0.0 && c.flux[i].is_finite())
            .map(|i| (c.d[i], c.flux[i] / q0, c.resolved[i]))
            .collect();
        for &(x, _, _) in &pts {
            dmin = dmin.min(x);
            dmax = dmax.max(x);
        }
        let color = colors[k % colors.len()];
        let (x, y): (Vec<f64>, Vec<f64>) = pts.iter().map(|p| (p.0, p.1)).unzip();
        p.series
            .push(Series::line(x, y, Stroke::solid(color).width(0.8)).label(&c.label));
        let (xr, yr): (Vec<f64>, Vec<f64>) = pts.iter().filter(|p| p.2).map(|p| (p.0, p.1)).unzip();
        if !xr.is_empty() {
            p.series.push(Series::points(
                xr,
                yr,
                MarkerStyle::filled(Marker::Circle, color),
            ));
        }
    }
    if dmax > dmin {
        p.annotations.push(Annotation::PowerLaw {
            x_range: (dmin, dmax),
            through: (dmax, 3.0),
            exponent: PAPER_BETA,
            stroke: Stroke::dashed(BLACK),
            label: Some(format!("paper β = {PAPER_BETA}")),
        });
        p.annotations.push(Annotation::PowerLaw {
            x_range: (dmin, dmax),
            through: (dmax, 0.3),
            exponent: 3.0,
            stroke: Stroke::dotted(GREY),
            label: Some("one-node throat: 3".into()),
        });
    }
    p.legend = LegendPos::BottomRight;
    f.xy(Rect::new(0.0, 0.0, w, h), p);
    Ok(f)
}

/// β (window fit, 1σ bars) against η of the constriction's heights, the paper's β marked.
pub fn beta_eta_figure(d: &BetaEtaFig) -> Result<Figure> {
    ensure!(
        d.eta.len() == d.beta.len() && d.beta.len() == d.beta_err.len(),
        "{} η, {} β, {} errors",
        d.eta.len(),
        d.beta.len(),
        d.beta_err.len()
    );
    let keep: Vec<usize> = (0..d.eta.len())
        .filter(|&i| d.eta[i] > 0.0 && d.beta[i].is_finite())
        .collect();
    let (w, h) = (520.0, 400.0);
    let mut f = Figure::new(w, h);
    let mut p = XyPanel::new(Axis::log("η = −$h$''_∥/$h$''_⊥"), Axis::linear("β"));
    let x: Vec<f64> = keep.iter().map(|&i| d.eta[i]).collect();
    let y: Vec<f64> = keep.iter().map(|&i| d.beta[i]).collect();
    let e: Vec<f64> = keep
        .iter()
        .map(|&i| {
            if d.beta_err[i].is_finite() {
                d.beta_err[i]
            } else {
                0.0
            }
        })
        .collect();
    if !x.is_empty() {
        p.series.push(
            Series::points(x, y, MarkerStyle::filled(Marker::Circle, BLUE))
                .y_err(e)
                .label("realisations"),
        );
    }
    p.annotations.push(Annotation::HLine {
        y: PAPER_BETA,
        stroke: Stroke::dashed(BLACK),
        label: Some(format!("paper {PAPER_BETA}")),
    });
    p.annotations.push(Annotation::HLine {
        y: 3.0,
        stroke: Stroke::dotted(GREY),
        label: Some("3".into()),
    });
    p.legend = LegendPos::TopLeft;
    f.xy(Rect::new(0.0, 0.0, w, h), p);
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_three_figures_render() {
        let n = 16;
        let gap = Array2::from_shape_fn((n, n), |(i, j)| {
            (((i * 3 + j) % 7) as f64 * 0.1 - 0.2).max(0.0)
        });
        let m = MapFig {
            gap,
            lx: 1.0,
            ly: 1.0,
            at: (0.5, 0.25),
            zoom: 0.1,
            title: "seed 1".into(),
        };
        assert!(!map_figure(&m).unwrap().render_svg().unwrap().is_empty());
        assert!(map_figure(&MapFig { zoom: 0.0, ..m }).is_err());
        let c = FluxCurve {
            label: "1".into(),
            d: vec![5e-2, 2e-2, 1e-2],
            flux: vec![1e-9, 1e-10, 1e-11],
            resolved: vec![true, true, false],
        };
        assert!(
            !flux_figure(std::slice::from_ref(&c))
                .unwrap()
                .render_svg()
                .unwrap()
                .is_empty()
        );
        let bad = FluxCurve {
            flux: vec![1.0],
            ..c
        };
        assert!(flux_figure(&[bad]).is_err());
        let b = BetaEtaFig {
            eta: vec![0.5, 1.0, 2.0],
            beta: vec![3.0, 3.3, f64::NAN],
            beta_err: vec![0.1, f64::NAN, 0.2],
        };
        assert!(
            !beta_eta_figure(&b)
                .unwrap()
                .render_svg()
                .unwrap()
                .is_empty()
        );
    }
}
