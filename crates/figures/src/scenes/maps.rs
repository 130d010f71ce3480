//! Figures 1 and 4: three heat maps side by side (hexagonal, square, triangular).
//!
//! Figure 1 shows the elastic displacement at zero load with adhesion (dark = small
//! displacement = contact) with the surface's lattice drawn over it: lines through height
//! maxima (thin black), lines through minima (thin white) with the minima as white points,
//! saddle points as grey stars, and dotted lines between neighbouring saddles. Figure 4 shows
//! the gap near the percolation threshold (bright = large gap), contact in white.

use std::path::{Path, PathBuf};

use anyhow::{Result, ensure};
use ndarray::Array2;

use crate::canvas::Rect;
use crate::figure::Figure;
use crate::heatmap::{ColorbarPos, Colormap, HeatmapPanel, Overlay};
use crate::style::{BLACK, Marker, MarkerStyle, Model, Rgb, Stroke, WHITE};

/// One model's map and the lattice drawn over it. Coordinates in λ, the cell is
/// [0, lx] × [0, ly]; overlays are given for one cell and repeated periodically over the
/// view.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelMap {
    /// Which model (sets the panel title).
    pub model: Model,
    /// The field, shape (nx, ny), first index x: displacement u (h0) for Figure 1, gap g (h0)
    /// for Figure 4.
    pub field: Array2<f64>,
    /// Cell width (λ): 4/√3 for hexagonal and triangular, 1 for square.
    pub lx: f64,
    /// Cell height (λ): 2 for hexagonal and triangular, 1 for square.
    pub ly: f64,
    /// Window shown (x0, x1, y0, y1) in λ; `None` shows one cell. E.g. (0, 2, 0, 2) for the
    /// square model gives the same physical scale as one hexagonal cell.
    pub view: Option<(f64, f64, f64, f64)>,
    /// Nodes drawn white (contact, g = 0), shape (nx, ny); `None` for no mask.
    pub contact: Option<Array2<bool>>,
    /// Polylines through height maxima (thin black).
    pub maxima_lines: Vec<Vec<(f64, f64)>>,
    /// Polylines through height minima (thin white).
    pub minima_lines: Vec<Vec<(f64, f64)>>,
    /// Minima (white points).
    pub minima: Vec<(f64, f64)>,
    /// Saddle points (grey stars).
    pub saddles: Vec<(f64, f64)>,
    /// Segments between neighbouring saddles (thick dotted).
    pub saddle_links: Vec<Vec<(f64, f64)>>,
}

impl ModelMap {
    /// A map with no overlays.
    pub fn new(model: Model, field: Array2<f64>, lx: f64, ly: f64) -> Self {
        Self {
            model,
            field,
            lx,
            ly,
            view: None,
            contact: None,
            maxima_lines: vec![],
            minima_lines: vec![],
            minima: vec![],
            saddles: vec![],
            saddle_links: vec![],
        }
    }
}

/// Data of Figure 1 or Figure 4.
#[derive(Debug, Clone, PartialEq)]
pub struct ThreeMaps {
    /// The three maps, in the order drawn (normally hexagonal, square, triangular).
    pub maps: Vec<ModelMap>,
    /// Colour-bar label (rich text), e.g. "$u$ / $h$_0".
    pub colorbar_label: String,
    /// One colour range for all three panels (else each its own).
    pub shared_range: bool,
}

/// Colour of the saddle stars.
pub const SADDLE_GREY: Rgb = plotters::style::RGBColor(150, 150, 150);
/// Colour of the saddle–saddle links.
pub const LINK_COLOR: Rgb = plotters::style::RGBColor(120, 200, 255);

fn panel(m: &ModelMap, cmap: Colormap, label: &str, range: Option<(f64, f64)>) -> HeatmapPanel {
    let mut h = HeatmapPanel::new(m.field.clone(), m.lx, m.ly);
    h.view = m.view;
    h.colormap = cmap;
    h.range = range;
    h.mask = m.contact.clone();
    h.mask_color = WHITE;
    h.colorbar = ColorbarPos::Bottom;
    h.colorbar_label = label.into();
    h.title = Some(m.model.title().into());
    h.tile_overlays = true;
    for l in &m.maxima_lines {
        h.overlays.push(Overlay::Polyline {
            points: l.clone(),
            stroke: Stroke::solid(BLACK).width(0.8),
        });
    }
    for l in &m.minima_lines {
        h.overlays.push(Overlay::Polyline {
            points: l.clone(),
            stroke: Stroke::solid(WHITE).width(0.8),
        });
    }
    for l in &m.saddle_links {
        h.overlays.push(Overlay::Polyline {
            points: l.clone(),
            stroke: Stroke::dotted(LINK_COLOR).width(2.0),
        });
    }
    if !m.minima.is_empty() {
        h.overlays.push(Overlay::Points {
            points: m.minima.clone(),
            style: MarkerStyle {
                marker: Marker::Circle,
                size: 4.5,
                fill: Some(WHITE),
                edge: BLACK,
            },
        });
    }
    if !m.saddles.is_empty() {
        h.overlays.push(Overlay::Points {
            points: m.saddles.clone(),
            style: MarkerStyle {
                marker: Marker::Star,
                size: 7.5,
                fill: Some(SADDLE_GREY),
                edge: BLACK,
            },
        });
    }
    h
}

/// Builds a 1 × 3 figure of maps with colour map `cmap`.
pub fn figure(d: &ThreeMaps, cmap: Colormap) -> Result<Figure> {
    ensure!(!d.maps.is_empty(), "no maps to draw");
    for m in &d.maps {
        ensure!(
            m.field.dim().0 > 0 && m.field.dim().1 > 0,
            "{} map is empty",
            m.model.name()
        );
    }
    let shared = if d.shared_range {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for m in &d.maps {
            for ((i, j), &v) in m.field.indexed_iter() {
                let masked = m.contact.as_ref().is_some_and(|c| c[[i, j]]);
                if v.is_finite() && !masked {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
        }
        (hi > lo).then_some((lo, hi))
    } else {
        None
    };
    // column widths from the views' aspect ratios, so that the three maps get one height
    // (one physical scale when the views have one height)
    let h = 400.0;
    let img_h = 272.0;
    let widths: Vec<f64> = d
        .maps
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let (x0, x1, y0, y1) = m.view.unwrap_or((0.0, m.lx, 0.0, m.ly));
            let margin = if k == 0 { 62.0 } else { 40.0 };
            img_h * (x1 - x0) / (y1 - y0) + margin
        })
        .collect();
    let gap = 6.0;
    let w = widths.iter().sum::<f64>() + gap * (widths.len() - 1) as f64;
    let mut f = Figure::new(w.round(), h);
    let cols = Rect::new(0.0, 0.0, w, h).columns(&widths, gap);
    for (k, m) in d.maps.iter().enumerate() {
        let mut p = panel(m, cmap, &d.colorbar_label, shared);
        if k > 0 {
            p.y_label = String::new();
        }
        f.heatmap(cols[k], p);
    }
    Ok(f)
}

/// Figure 1: displacement maps (inferno: dark = small displacement, i.e. contact).
pub fn render_fig1(d: &ThreeMaps, out_stem: &Path) -> Result<Vec<PathBuf>> {
    figure(d, Colormap::Inferno)?.render(out_stem)
}

/// Figure 4: gap maps (viridis: bright = large gap; contact white).
pub fn render_fig4(d: &ThreeMaps, out_stem: &Path) -> Result<Vec<PathBuf>> {
    figure(d, Colormap::Viridis)?.render(out_stem)
}
