//! Heat-map panels of a periodic 2-D field with a colour bar and overlays.
//!
//! Convention (the pipeline's, see ARCHITECTURE.md): a field has shape (nx, ny), the first
//! index is x, node (i, j) sits at (i·lx/nx, j·ly/ny). The panel shows a window of the plane
//! (by default the cell [0, lx] × [0, ly]) with y upwards, aspect ratio preserved, each device
//! pixel taking the value of the nearest node (periodic images included, so a window may
//! extend beyond the cell). Masked nodes and NaN are drawn in the mask colour (white for
//! contact, g = 0, in the paper's Figure 4).

use anyhow::{Result, ensure};
use ndarray::Array2;
use plotters::prelude::DrawingBackend;

use crate::axes::{Mapping, Scale, ticks};
use crate::canvas::{Canvas, HAlign, Rect, TextOpts, VAlign, clip_polyline};
use crate::style::{
    BLACK, FRAME_WIDTH, LABEL_FONT, MINOR_TICK_LEN, MarkerStyle, Rgb, Stroke, TICK_FONT, TICK_LEN,
    WHITE,
};
use crate::xy::draw_tag;

/// Perceptually uniform colour maps (the full tables of matplotlib's maps, via `colorous`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Colormap {
    /// Dark blue → green → yellow.
    #[default]
    Viridis,
    /// Black → purple → orange → light yellow.
    Magma,
    /// Black → purple → orange → yellow.
    Inferno,
    /// Blue → purple → yellow.
    Plasma,
    /// Colour-blind-safe blue → yellow.
    Cividis,
    /// White → black.
    Greys,
    /// Black → white.
    GreysReversed,
}

impl Colormap {
    /// The colour at t ∈ [0, 1] (clamped).
    pub fn eval(self, t: f64) -> Rgb {
        let t = if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let c = match self {
            Colormap::Viridis => colorous::VIRIDIS.eval_continuous(t),
            Colormap::Magma => colorous::MAGMA.eval_continuous(t),
            Colormap::Inferno => colorous::INFERNO.eval_continuous(t),
            Colormap::Plasma => colorous::PLASMA.eval_continuous(t),
            Colormap::Cividis => colorous::CIVIDIS.eval_continuous(t),
            Colormap::Greys => colorous::GREYS.eval_continuous(t),
            Colormap::GreysReversed => colorous::GREYS.eval_continuous(1.0 - t),
        };
        plotters::style::RGBColor(c.r, c.g, c.b)
    }
}

/// Things drawn over a heat map, in physical coordinates (same units as lx, ly).
#[derive(Debug, Clone, PartialEq)]
pub enum Overlay {
    /// A polyline (e.g. a line through maxima, a contact line); NaN points split it.
    Polyline {
        /// Points.
        points: Vec<(f64, f64)>,
        /// Style (solid, dashed or dotted, colour, width).
        stroke: Stroke,
    },
    /// Markers (minima as white points, saddles as grey stars, …).
    Points {
        /// Positions.
        points: Vec<(f64, f64)>,
        /// Style.
        style: MarkerStyle,
    },
    /// Arrows (a quiver plot): each starts at an origin and has the given vector, both in
    /// physical units.
    Arrows {
        /// Tails.
        origins: Vec<(f64, f64)>,
        /// Vectors.
        vectors: Vec<(f64, f64)>,
        /// Colour.
        color: Rgb,
        /// Shaft width (logical units).
        width: f64,
    },
}

/// Where the colour bar goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColorbarPos {
    /// None.
    None,
    /// Vertical, right of the map.
    #[default]
    Right,
    /// Horizontal, below the map.
    Bottom,
}

/// A heat-map panel.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatmapPanel {
    /// Field values, shape (nx, ny), first index x.
    pub field: Array2<f64>,
    /// Cell width (physical units).
    pub lx: f64,
    /// Cell height (physical units).
    pub ly: f64,
    /// Window shown, (x0, x1, y0, y1); `None`: the cell [0, lx] × [0, ly].
    pub view: Option<(f64, f64, f64, f64)>,
    /// Colour map.
    pub colormap: Colormap,
    /// Colour range (values outside are clamped); `None`: the unmasked finite values' extent.
    pub range: Option<(f64, f64)>,
    /// Logarithmic colour scale (non-positive values are masked).
    pub log: bool,
    /// Nodes drawn in `mask_color` (e.g. contact), shape (nx, ny).
    pub mask: Option<Array2<bool>>,
    /// Colour of masked and NaN nodes.
    pub mask_color: Rgb,
    /// Overlays, drawn in order.
    pub overlays: Vec<Overlay>,
    /// Overlays are given for one cell: repeat them by the periods (lx, 0) and (0, ly) to
    /// cover the view.
    pub tile_overlays: bool,
    /// x-axis label (rich text); empty for none.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// Draw tick marks and tick labels.
    pub show_ticks: bool,
    /// Colour-bar placement.
    pub colorbar: ColorbarPos,
    /// Colour-bar label (rich text).
    pub colorbar_label: String,
    /// Title above the map.
    pub title: Option<String>,
    /// Panel tag ("(a)").
    pub tag: Option<String>,
}

impl HeatmapPanel {
    /// A panel with defaults: viridis, automatic range, white mask, axes labelled x / y
    /// (in λ), colour bar right.
    pub fn new(field: Array2<f64>, lx: f64, ly: f64) -> Self {
        Self {
            field,
            lx,
            ly,
            view: None,
            colormap: Colormap::Viridis,
            range: None,
            log: false,
            mask: None,
            mask_color: WHITE,
            overlays: Vec::new(),
            tile_overlays: false,
            x_label: "$x$ / $λ$".into(),
            y_label: "$y$ / $λ$".into(),
            show_ticks: true,
            colorbar: ColorbarPos::Right,
            colorbar_label: String::new(),
            title: None,
            tag: None,
        }
    }

    fn validate(&self) -> Result<()> {
        let (nx, ny) = self.field.dim();
        ensure!(nx > 0 && ny > 0, "heat map field is empty");
        ensure!(
            self.lx > 0.0 && self.ly > 0.0,
            "heat map cell size must be positive"
        );
        if let Some(m) = &self.mask {
            ensure!(
                m.dim() == (nx, ny),
                "heat map mask has shape {:?}, field {:?}",
                m.dim(),
                (nx, ny)
            );
        }
        if let Some((x0, x1, y0, y1)) = self.view {
            ensure!(x1 > x0 && y1 > y0, "heat map view window is empty");
        }
        Ok(())
    }

    fn masked(&self, i: usize, j: usize) -> bool {
        let v = self.field[[i, j]];
        !v.is_finite() || (self.log && v <= 0.0) || self.mask.as_ref().is_some_and(|m| m[[i, j]])
    }

    /// The colour range used: `range` or the extent of the unmasked finite values.
    pub fn color_range(&self) -> (f64, f64) {
        if let Some(r) = self.range {
            return r;
        }
        let (nx, ny) = self.field.dim();
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for i in 0..nx {
            for j in 0..ny {
                if !self.masked(i, j) {
                    let v = self.field[[i, j]];
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
        }
        if !lo.is_finite() {
            return if self.log { (0.1, 1.0) } else { (0.0, 1.0) };
        }
        if hi <= lo {
            return if self.log {
                (lo / 2.0, lo * 2.0)
            } else {
                (lo - 0.5, hi + 0.5)
            };
        }
        (lo, hi)
    }

    fn view(&self) -> (f64, f64, f64, f64) {
        self.view.unwrap_or((0.0, self.lx, 0.0, self.ly))
    }

    fn t_of(&self, v: f64, lo: f64, hi: f64) -> f64 {
        if self.log {
            (v.log10() - lo.log10()) / (hi.log10() - lo.log10())
        } else {
            (v - lo) / (hi - lo)
        }
    }

    /// Translations applied to the overlays: (0, 0) only, or every period shift whose copy
    /// can reach the view.
    fn overlay_shifts(&self) -> Vec<(f64, f64)> {
        if !self.tile_overlays {
            return vec![(0.0, 0.0)];
        }
        let (x0, x1, y0, y1) = self.view();
        let mut bx = (f64::INFINITY, f64::NEG_INFINITY);
        let mut by = (f64::INFINITY, f64::NEG_INFINITY);
        let mut grow = |p: &(f64, f64)| {
            if p.0.is_finite() && p.1.is_finite() {
                bx = (bx.0.min(p.0), bx.1.max(p.0));
                by = (by.0.min(p.1), by.1.max(p.1));
            }
        };
        for ov in &self.overlays {
            match ov {
                Overlay::Polyline { points, .. } | Overlay::Points { points, .. } => {
                    points.iter().for_each(&mut grow)
                }
                Overlay::Arrows {
                    origins, vectors, ..
                } => {
                    origins.iter().for_each(&mut grow);
                    origins
                        .iter()
                        .zip(vectors)
                        .for_each(|(o, v)| grow(&(o.0 + v.0, o.1 + v.1)));
                }
            }
        }
        if !bx.0.is_finite() {
            return vec![];
        }
        let kx0 = ((x0 - bx.1) / self.lx).floor() as i64;
        let kx1 = ((x1 - bx.0) / self.lx).ceil() as i64;
        let ky0 = ((y0 - by.1) / self.ly).floor() as i64;
        let ky1 = ((y1 - by.0) / self.ly).ceil() as i64;
        let mut v = Vec::new();
        for kx in kx0..=kx1 {
            for ky in ky0..=ky1 {
                v.push((kx as f64 * self.lx, ky as f64 * self.ly));
            }
        }
        v
    }

    fn draw_overlays<DB: DrawingBackend>(
        &self,
        c: &Canvas<DB>,
        img: &Rect,
        to: &dyn Fn((f64, f64)) -> (f64, f64),
    ) -> Result<()> {
        let img = *img;
        for ov in &self.overlays {
            match ov {
                Overlay::Polyline { points, stroke } => {
                    let pts: Vec<(f64, f64)> = points.iter().map(|&p| to(p)).collect();
                    for piece in clip_polyline(&pts, &img) {
                        c.polyline(&piece, stroke)?;
                    }
                }
                Overlay::Points { points, style } => {
                    for &p in points {
                        let q = to(p);
                        if img.inset(-0.5, -0.5, -0.5, -0.5).contains(q) {
                            c.marker(q, style)?;
                        }
                    }
                }
                Overlay::Arrows {
                    origins,
                    vectors,
                    color,
                    width,
                } => {
                    for (&o, &v) in origins.iter().zip(vectors) {
                        let p = to(o);
                        let q = to((o.0 + v.0, o.1 + v.1));
                        if img.contains(p) {
                            let len = ((q.0 - p.0).powi(2) + (q.1 - p.1).powi(2)).sqrt();
                            c.arrow(p, q, *color, *width, (len * 0.45).clamp(2.5, 5.0))?;
                        }
                    }
                }
            }
        }

        Ok(())
    }

    /// Draws the panel into `outer`; returns the image rectangle.
    pub fn draw<DB: DrawingBackend>(&self, c: &Canvas<DB>, outer: Rect) -> Result<Rect> {
        self.validate()?;
        let (x0, x1, y0, y1) = self.view();
        let (lo, hi) = self.color_range();
        let mx = Mapping {
            scale: Scale::Linear,
            lo: x0,
            hi: x1,
        };
        let my = Mapping {
            scale: Scale::Linear,
            lo: y0,
            hi: y1,
        };
        let xt = if self.show_ticks {
            ticks(&mx, 4, None)
        } else {
            vec![]
        };
        let yt = if self.show_ticks {
            ticks(&my, 4, None)
        } else {
            vec![]
        };
        let cm = Mapping {
            scale: if self.log { Scale::Log } else { Scale::Linear },
            lo,
            hi,
        };
        let ct = ticks(&cm, 4, None);
        let ctw = ct
            .iter()
            .filter_map(|t| t.label.as_ref())
            .map(|l| c.text_width(l, TICK_FONT))
            .fold(0.0, f64::max);

        // margins
        let ytw = yt
            .iter()
            .filter_map(|t| t.label.as_ref())
            .map(|l| c.text_width(l, TICK_FONT))
            .fold(0.0, f64::max);
        let mut left = 3.0;
        if !self.y_label.is_empty() {
            left += LABEL_FONT * 1.05 + 5.0;
        }
        if self.show_ticks {
            left += ytw + 5.0;
        }
        let mut bottom = 3.0;
        if self.show_ticks {
            bottom += TICK_FONT * 1.15 + 4.0;
        }
        if !self.x_label.is_empty() {
            bottom += LABEL_FONT * 1.2 + 4.0;
        }
        let mut top = if self.title.is_some() {
            LABEL_FONT * 1.7
        } else {
            TICK_FONT * 0.7
        };
        if self.tag.is_some() && self.title.is_none() {
            top = top.max(crate::style::TAG_FONT * 1.25);
        }
        let mut right = 6.0;
        let bar = 9.0;
        let bar_gap = 8.0;
        match self.colorbar {
            ColorbarPos::Right => {
                right += bar_gap + bar + 4.0 + ctw + 3.0;
                if !self.colorbar_label.is_empty() {
                    right += LABEL_FONT * 1.05 + 4.0;
                }
            }
            ColorbarPos::Bottom => {
                bottom += bar_gap + bar + 4.0 + TICK_FONT * 1.15;
                if !self.colorbar_label.is_empty() {
                    bottom += LABEL_FONT * 1.2 + 2.0;
                }
                right = right.max(ctw / 2.0 + 3.0);
            }
            ColorbarPos::None => {}
        }
        let avail = outer.inset(left, top, right, bottom);
        // top-aligned, so that maps side by side line up
        let mut img = avail.fit_aspect((x1 - x0) / (y1 - y0));
        img.y = avail.y;

        // the map
        let (nx, ny) = self.field.dim();
        let (dx, dy) = (self.lx / nx as f64, self.ly / ny as f64);
        // one colour per node, looked up per device pixel
        let lut: Vec<Rgb> = (0..nx * ny)
            .map(|k| {
                let (i, j) = (k / ny, k % ny);
                if self.masked(i, j) {
                    self.mask_color
                } else {
                    self.colormap.eval(self.t_of(self.field[[i, j]], lo, hi))
                }
            })
            .collect();
        c.image(img, |u, v| {
            let x = x0 + u * (x1 - x0);
            let y = y1 - v * (y1 - y0);
            let i = ((x / dx).round() as i64).rem_euclid(nx as i64) as usize;
            let j = ((y / dy).round() as i64).rem_euclid(ny as i64) as usize;
            lut[i * ny + j]
        })?;

        // overlays
        let to = |p: (f64, f64)| {
            (
                img.x + (p.0 - x0) / (x1 - x0) * img.w,
                img.bottom() - (p.1 - y0) / (y1 - y0) * img.h,
            )
        };
        let shifts = self.overlay_shifts();
        for (sx, sy) in shifts {
            let to = |p: (f64, f64)| to((p.0 + sx, p.1 + sy));
            self.draw_overlays(c, &img, &to)?;
        }

        // frame and ticks
        let frame = Stroke::solid(BLACK).width(FRAME_WIDTH);
        c.rect(img, None, Some((BLACK, FRAME_WIDTH)))?;
        let opts = TextOpts::new(TICK_FONT);
        for t in &xt {
            let f = mx.frac(t.value);
            if !(0.0..=1.0 + 1e-9).contains(&f) {
                continue;
            }
            let x = img.x + f * img.w;
            let len = if t.label.is_some() {
                TICK_LEN
            } else {
                MINOR_TICK_LEN
            };
            c.polyline(&[(x, img.bottom()), (x, img.bottom() + len)], &frame)?;
            if let Some(l) = &t.label {
                c.text(
                    l,
                    (x, img.bottom() + len + 2.0),
                    &opts.align(HAlign::Center, VAlign::Top),
                )?;
            }
        }
        for t in &yt {
            let f = my.frac(t.value);
            if !(0.0..=1.0 + 1e-9).contains(&f) {
                continue;
            }
            let y = img.bottom() - f * img.h;
            let len = if t.label.is_some() {
                TICK_LEN
            } else {
                MINOR_TICK_LEN
            };
            c.polyline(&[(img.x, y), (img.x - len, y)], &frame)?;
            if let Some(l) = &t.label {
                c.text(
                    l,
                    (img.x - len - 2.0, y),
                    &opts.align(HAlign::Right, VAlign::Center),
                )?;
            }
        }
        let label_opts = TextOpts::new(LABEL_FONT);
        let mut below = img.bottom() + 3.0;
        if self.show_ticks {
            below += TICK_FONT * 1.15 + 4.0;
        }
        if !self.x_label.is_empty() {
            c.text(
                &self.x_label,
                (img.x + img.w / 2.0, below),
                &label_opts.align(HAlign::Center, VAlign::Top),
            )?;
            below += LABEL_FONT * 1.2 + 4.0;
        }
        if !self.y_label.is_empty() {
            let xl = img.x - left + 3.0;
            c.text(
                &self.y_label,
                (xl, img.y + img.h / 2.0),
                &label_opts.rotated().align(HAlign::Center, VAlign::Top),
            )?;
        }
        if let Some(t) = &self.title {
            c.text(
                t,
                (img.x + img.w / 2.0, img.y - 6.0),
                &label_opts.align(HAlign::Center, VAlign::Bottom),
            )?;
        }
        if let Some(t) = &self.tag {
            draw_tag(c, Rect::new(img.x - left + 1.0, outer.y, 10.0, 10.0), t)?;
        }

        // colour bar
        let cmap = self.colormap;
        match self.colorbar {
            ColorbarPos::None => {}
            ColorbarPos::Right => {
                let r = Rect::new(img.right() + bar_gap, img.y, bar, img.h);
                c.image(r, |_, v| cmap.eval(1.0 - v))?;
                c.rect(r, None, Some((BLACK, FRAME_WIDTH)))?;
                for t in &ct {
                    let f = cm.frac(t.value);
                    if !(-1e-9..=1.0 + 1e-9).contains(&f) {
                        continue;
                    }
                    let y = r.bottom() - f * r.h;
                    let len = if t.label.is_some() { 3.0 } else { 1.8 };
                    c.polyline(&[(r.right(), y), (r.right() - len, y)], &frame)?;
                    if let Some(l) = &t.label {
                        c.text(
                            l,
                            (r.right() + 4.0, y),
                            &opts.align(HAlign::Left, VAlign::Center),
                        )?;
                    }
                }
                if !self.colorbar_label.is_empty() {
                    c.text(
                        &self.colorbar_label,
                        (r.right() + 4.0 + ctw + 3.0, r.y + r.h / 2.0),
                        &label_opts.rotated().align(HAlign::Center, VAlign::Top),
                    )?;
                }
            }
            ColorbarPos::Bottom => {
                let r = Rect::new(img.x, below + bar_gap - 3.0, img.w, bar);
                c.image(r, |u, _| cmap.eval(u))?;
                c.rect(r, None, Some((BLACK, FRAME_WIDTH)))?;
                for t in &ct {
                    let f = cm.frac(t.value);
                    if !(-1e-9..=1.0 + 1e-9).contains(&f) {
                        continue;
                    }
                    let x = r.x + f * r.w;
                    let len = if t.label.is_some() { 3.0 } else { 1.8 };
                    c.polyline(&[(x, r.bottom()), (x, r.bottom() - len)], &frame)?;
                    if let Some(l) = &t.label {
                        c.text(
                            l,
                            (x, r.bottom() + 3.0),
                            &opts.align(HAlign::Center, VAlign::Top),
                        )?;
                    }
                }
                if !self.colorbar_label.is_empty() {
                    c.text(
                        &self.colorbar_label,
                        (r.x + r.w / 2.0, r.bottom() + 4.0 + TICK_FONT * 1.15),
                        &label_opts.align(HAlign::Center, VAlign::Top),
                    )?;
                }
            }
        }
        Ok(img)
    }
}
