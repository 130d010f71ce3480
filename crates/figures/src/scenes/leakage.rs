//! Figures of a user's surface (scene `leakage`): the surface (height map and isotropic PSD
//! with the fitted slope and, for a generated surface, the requested −2(1+H)), the contact and
//! gap map at a chosen load, and leakage (conductivity along x and y) against load on a log
//! axis with the fluid percolation load marked.
//!
//! Units: lengths along the surface in the cell's units, heights and gaps in the height unit,
//! loads as fractions of p_fc (the periodic full-contact pressure).

use anyhow::{Result, ensure};
use ndarray::Array2;

use crate::axes::Axis;
use crate::canvas::Rect;
use crate::figure::Figure;
use crate::heatmap::{Colormap, HeatmapPanel};
use crate::style::{BLACK, BLUE, GREY, Marker, MarkerStyle, RED, Stroke, WHITE};
use crate::xy::{Annotation, LegendPos, Series, XyPanel};

/// The surface: heights and its binned isotropic PSD.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceFig {
    /// Heights, shape (nx, ny), first index x.
    pub height: Array2<f64>,
    /// Cell size.
    pub lx: f64,
    /// Cell size.
    pub ly: f64,
    /// PSD bins: wavenumber q (rad per length) and C(q).
    pub psd_q: Vec<f64>,
    /// C(q) per bin.
    pub psd_c: Vec<f64>,
    /// Fitted slope over `fit_range` (log C against log q).
    pub fitted_slope: f64,
    /// q range of the fit.
    pub fit_range: (f64, f64),
    /// The requested slope −2(1+H) of a generated surface.
    pub model_slope: Option<f64>,
}

/// The contact and gap map at one load.
#[derive(Debug, Clone, PartialEq)]
pub struct MapFig {
    /// Gap, shape (nx, ny); contact where ≤ 0 (drawn white).
    pub gap: Array2<f64>,
    /// Cell size.
    pub lx: f64,
    /// Cell size.
    pub ly: f64,
    /// The load (fraction of p_fc).
    pub load_over_p_fc: f64,
    /// Contact area at that load.
    pub contact_area: f64,
}

/// Leakage against load.
#[derive(Debug, Clone, PartialEq)]
pub struct LeakageFig {
    /// Loads (fractions of p_fc), ascending.
    pub load: Vec<f64>,
    /// Conductivity along x (a uniform gap g gives g³); 0 where sealed (not drawn on the log
    /// axis).
    pub conductivity_x: Vec<f64>,
    /// Conductivity along y.
    pub conductivity_y: Vec<f64>,
    /// The fluid percolation load (fraction of p_fc) and a_p there, if bracketed.
    pub percolation: Option<(f64, f64)>,
}

/// Height map (a) and PSD (b).
pub fn surface_figure(d: &SurfaceFig) -> Result<Figure> {
    ensure!(
        d.psd_q.len() == d.psd_c.len() && !d.psd_q.is_empty(),
        "PSD: {} wavenumbers and {} values",
        d.psd_q.len(),
        d.psd_c.len()
    );
    let (w, h) = (820.0, 380.0);
    let cols = Rect::new(0.0, 0.0, w, h).columns(&[1.0, 1.1], 16.0);
    let mut f = Figure::new(w, h);
    let mut m = HeatmapPanel::new(d.height.clone(), d.lx, d.ly);
    m.colormap = Colormap::Viridis;
    m.x_label = "$x$".into();
    m.y_label = "$y$".into();
    m.colorbar_label = "$h$".into();
    m.tag = Some("(a)".into());
    f.heatmap(cols[0], m);
    let mut p = XyPanel::new(Axis::log("$q$"), Axis::log("$C$($q$)"));
    let keep: Vec<usize> = (0..d.psd_q.len()).filter(|&i| d.psd_c[i] > 0.0).collect();
    let (q, c): (Vec<f64>, Vec<f64>) = keep.iter().map(|&i| (d.psd_q[i], d.psd_c[i])).unzip();
    p.series.push(
        Series::points(
            q.clone(),
            c.clone(),
            MarkerStyle::filled(Marker::Circle, BLUE),
        )
        .label("binned PSD"),
    );
    // both lines through the PSD's value nearest the fit range's geometric middle
    let mid = (d.fit_range.0 * d.fit_range.1).sqrt();
    if let Some(k) =
        (0..q.len()).min_by(|&a, &b| (q[a] / mid).ln().abs().total_cmp(&(q[b] / mid).ln().abs()))
    {
        p.annotations.push(Annotation::PowerLaw {
            x_range: d.fit_range,
            through: (q[k], c[k]),
            exponent: d.fitted_slope,
            stroke: Stroke::solid(RED),
            label: Some(format!("fit {:.3}", d.fitted_slope)),
        });
        if let Some(s) = d.model_slope {
            p.annotations.push(Annotation::PowerLaw {
                x_range: d.fit_range,
                through: (q[k], c[k] * 3.0),
                exponent: s,
                stroke: Stroke::dashed(BLACK),
                label: Some(format!("−2(1+$H$) = {s:.2}")),
            });
        }
    }
    p.legend = LegendPos::BottomLeft;
    p.tag = Some("(b)".into());
    f.xy(cols[1], p);
    Ok(f)
}

/// A gap map panel as both random-surface scenes draw it: magma, contact (g ≤ 0) white, axes
/// $x$, $y$ in cell units, colour bar "gap $g$".
pub fn gap_panel(gap: &Array2<f64>, lx: f64, ly: f64) -> HeatmapPanel {
    let mut m = HeatmapPanel::new(gap.clone(), lx, ly);
    m.colormap = Colormap::Magma;
    m.mask = Some(gap.mapv(|g| g <= 0.0));
    m.mask_color = WHITE;
    m.x_label = "$x$".into();
    m.y_label = "$y$".into();
    m.colorbar_label = "gap $g$".into();
    m
}

/// A figure of one x–y panel filling `w × h`, the legend at `legend`.
pub fn single_panel(w: f64, h: f64, mut p: XyPanel, legend: LegendPos) -> Figure {
    let mut f = Figure::new(w, h);
    p.legend = legend;
    f.xy(Rect::new(0.0, 0.0, w, h), p);
    f
}

/// Gap map with the contact in white.
pub fn map_figure(d: &MapFig) -> Result<Figure> {
    let (w, h) = (460.0, 420.0);
    let mut f = Figure::new(w, h);
    let mut m = gap_panel(&d.gap, d.lx, d.ly);
    m.title = Some(format!(
        "$p$/$p$_{{fc}} = {:.3}, contact area {:.3}",
        d.load_over_p_fc, d.contact_area
    ));
    f.heatmap(Rect::new(0.0, 0.0, w, h), m);
    Ok(f)
}

/// Conductivity along x and y against load (log), the percolation load marked.
pub fn leakage_figure(d: &LeakageFig) -> Result<Figure> {
    ensure!(
        d.load.len() == d.conductivity_x.len() && d.load.len() == d.conductivity_y.len(),
        "leakage: {} loads, {} and {} conductivities",
        d.load.len(),
        d.conductivity_x.len(),
        d.conductivity_y.len()
    );
    let mut p = XyPanel::new(
        Axis::linear("load $p$/$p$_{fc}"),
        Axis::log("conductivity (uniform gap $g$: $g$^3)"),
    );
    p.series.push(
        Series::line(
            d.load.clone(),
            d.conductivity_x.clone(),
            Stroke::solid(BLUE),
        )
        .marker(MarkerStyle::filled(Marker::Circle, BLUE))
        .label("along $x$"),
    );
    p.series.push(
        Series::line(
            d.load.clone(),
            d.conductivity_y.clone(),
            Stroke::dashed(RED),
        )
        .marker(MarkerStyle::open(Marker::Square, RED))
        .label("along $y$"),
    );
    if let Some((l, a)) = d.percolation {
        p.annotations.push(Annotation::VLine {
            x: l,
            stroke: Stroke::dotted(GREY).width(1.4),
            label: Some(format!("$L$_p = {l:.4}, $a$_p = {a:.3}")),
        });
    }
    Ok(single_panel(520.0, 400.0, p, LegendPos::BottomLeft))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_three_figures_render() {
        let n = 16;
        let height = Array2::from_shape_fn((n, n), |(i, j)| ((i * 3 + j) % 7) as f64 * 0.1);
        let s = SurfaceFig {
            height: height.clone(),
            lx: 1.0,
            ly: 1.0,
            psd_q: vec![6.0, 12.0, 25.0, 50.0],
            psd_c: vec![1.0, 0.1, 0.01, 0.0],
            fitted_slope: -3.6,
            fit_range: (12.0, 50.0),
            model_slope: Some(-3.6),
        };
        assert!(!surface_figure(&s).unwrap().render_svg().unwrap().is_empty());
        let m = MapFig {
            gap: height.mapv(|h| (h - 0.2).max(0.0)),
            lx: 1.0,
            ly: 1.0,
            load_over_p_fc: 0.2,
            contact_area: 0.3,
        };
        assert!(!map_figure(&m).unwrap().render_svg().unwrap().is_empty());
        let l = LeakageFig {
            load: vec![0.05, 0.1, 0.3],
            conductivity_x: vec![1e-2, 1e-3, 0.0],
            conductivity_y: vec![2e-2, 1e-3, 0.0],
            percolation: Some((0.2, 0.42)),
        };
        assert!(!leakage_figure(&l).unwrap().render_svg().unwrap().is_empty());
        let bad = LeakageFig {
            conductivity_y: vec![],
            ..l
        };
        assert!(leakage_figure(&bad).is_err());
    }
}
