//! x–y panels: linear or log axes, several series (lines, dashes, markers, error bars, shaded
//! bands, direction arrows), reference lines, annotations, power-law lines with slope labels,
//! and a legend.

use anyhow::Result;
use plotters::prelude::DrawingBackend;

use crate::axes::{Axis, Mapping, Scale, Tick, auto_range, ticks};
use crate::canvas::{Canvas, HAlign, Rect, TextOpts, VAlign, clip_polyline};
use crate::style::{
    ANNOTATION_FONT, BLACK, FRAME_WIDTH, LABEL_FONT, LEGEND_FONT, LIGHT_GREY, MINOR_TICK_LEN,
    MarkerStyle, Rgb, Stroke, TAG_FONT, TICK_FONT, TICK_LEN, WHITE,
};

/// One data series. Non-finite values leave gaps; on log axes non-positive values too.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend text (rich text); `None` keeps the series out of the legend.
    pub label: Option<String>,
    /// x values (data units).
    pub x: Vec<f64>,
    /// y values (data units), same length as `x`.
    pub y: Vec<f64>,
    /// Symmetric 1σ error of y, drawn as a bar with caps.
    pub y_err: Option<Vec<f64>>,
    /// Symmetric error of x.
    pub x_err: Option<Vec<f64>>,
    /// Line style; `None` draws no line.
    pub stroke: Option<Stroke>,
    /// Marker at every point; `None` draws none.
    pub marker: Option<MarkerStyle>,
    /// Number of arrow heads along the line, pointing in the order of the points
    /// (e.g. the direction in which a load path was traversed). They sit at arc-length
    /// fractions (k + 0.4)/n, so a branch traversed back over the same curve gets its heads
    /// elsewhere.
    pub arrows: usize,
    /// Shaded band (lower, upper y at each x), drawn in the line colour, translucent.
    pub band: Option<(Vec<f64>, Vec<f64>)>,
}

impl Series {
    /// A line through the points.
    pub fn line(x: Vec<f64>, y: Vec<f64>, stroke: Stroke) -> Self {
        Self {
            x,
            y,
            stroke: Some(stroke),
            ..Self::default()
        }
    }
    /// Markers only.
    pub fn points(x: Vec<f64>, y: Vec<f64>, marker: MarkerStyle) -> Self {
        Self {
            x,
            y,
            marker: Some(marker),
            ..Self::default()
        }
    }
    /// Same, with a legend label.
    pub fn label(mut self, l: &str) -> Self {
        self.label = Some(l.into());
        self
    }
    /// Same, with markers.
    pub fn marker(mut self, m: MarkerStyle) -> Self {
        self.marker = Some(m);
        self
    }
    /// Same, with y error bars.
    pub fn y_err(mut self, e: Vec<f64>) -> Self {
        self.y_err = Some(e);
        self
    }
    /// Same, with `n` direction arrows.
    pub fn arrows(mut self, n: usize) -> Self {
        self.arrows = n;
        self
    }
    /// Same, with a shaded band.
    pub fn band(mut self, lower: Vec<f64>, upper: Vec<f64>) -> Self {
        self.band = Some((lower, upper));
        self
    }
    fn color(&self) -> Rgb {
        self.stroke
            .map(|s| s.color)
            .or(self.marker.map(|m| m.edge))
            .unwrap_or(BLACK)
    }
}

/// Decorations in data coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum Annotation {
    /// Vertical reference line across the panel, with an optional label at its top.
    VLine {
        /// Position.
        x: f64,
        /// Style.
        stroke: Stroke,
        /// Label (rich text).
        label: Option<String>,
    },
    /// Horizontal reference line, with an optional label at its right end.
    HLine {
        /// Position.
        y: f64,
        /// Style.
        stroke: Stroke,
        /// Label (rich text).
        label: Option<String>,
    },
    /// A straight arrow (head at `to`).
    Arrow {
        /// Tail.
        from: (f64, f64),
        /// Head.
        to: (f64, f64),
        /// Colour.
        color: Rgb,
    },
    /// Text at a data point.
    Text {
        /// Anchor.
        at: (f64, f64),
        /// Rich text.
        text: String,
        /// Horizontal alignment.
        h: HAlign,
        /// Vertical alignment.
        v: VAlign,
        /// Colour.
        color: Rgb,
    },
    /// The power law y = y₀ (x/x₀)^exponent over `x_range` (a straight line on log–log axes;
    /// on linear axes a curve), labelled beside its middle, e.g. "slope 3.45".
    PowerLaw {
        /// x interval drawn.
        x_range: (f64, f64),
        /// (x₀, y₀), a point on the line.
        through: (f64, f64),
        /// Exponent (slope on log–log axes).
        exponent: f64,
        /// Style.
        stroke: Stroke,
        /// Label (rich text).
        label: Option<String>,
    },
    /// A polyline in data coordinates (e.g. a fit), not in the legend.
    Polyline {
        /// Points.
        points: Vec<(f64, f64)>,
        /// Style.
        stroke: Stroke,
    },
    /// A single marker.
    Marker {
        /// Position.
        at: (f64, f64),
        /// Style.
        style: MarkerStyle,
    },
}

/// Where the legend goes (inside the plot area).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum LegendPos {
    /// No legend.
    None,
    /// Top left corner.
    TopLeft,
    /// Top right corner.
    #[default]
    TopRight,
    /// Top edge, centred.
    TopCenter,
    /// Bottom left corner.
    BottomLeft,
    /// Bottom right corner.
    BottomRight,
    /// Top-left corner of the legend box at this fraction of the plot area (0,0 top left).
    At(f64, f64),
}

/// A legend line that is not tied to a series (e.g. "loading" in red).
#[derive(Debug, Clone, PartialEq)]
pub struct LegendEntry {
    /// Text (rich text).
    pub label: String,
    /// Line sample.
    pub stroke: Option<Stroke>,
    /// Marker sample.
    pub marker: Option<MarkerStyle>,
}

/// An x–y panel.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct XyPanel {
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// Data, drawn in order.
    pub series: Vec<Series>,
    /// Decorations, drawn after the data.
    pub annotations: Vec<Annotation>,
    /// Legend placement.
    pub legend: LegendPos,
    /// Legend entries after those of the labelled series.
    pub legend_extra: Vec<LegendEntry>,
    /// Number of legend columns (0 or 1: one column).
    pub legend_columns: usize,
    /// Panel tag such as "(a)", drawn bold at the top left outside the frame.
    pub tag: Option<String>,
    /// Title above the plot area.
    pub title: Option<String>,
}

/// Where an x–y panel's plot area ended up, to place overlays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlotGeometry {
    /// Plot area (inside the frame).
    pub area: Rect,
    /// x mapping.
    pub x: Mapping,
    /// y mapping.
    pub y: Mapping,
}

impl PlotGeometry {
    /// Logical position of a data point (may lie outside `area`).
    pub fn to_canvas(&self, p: (f64, f64)) -> (f64, f64) {
        (
            self.area.x + self.x.frac(p.0) * self.area.w,
            self.area.bottom() - self.y.frac(p.1) * self.area.h,
        )
    }
}

fn mapping(axis: &Axis, values: impl IntoIterator<Item = f64>) -> Mapping {
    let (lo, hi) = axis.range.unwrap_or_else(|| auto_range(values, axis.scale));
    Mapping {
        scale: axis.scale,
        lo,
        hi,
    }
}

impl XyPanel {
    /// An empty panel with these axes.
    pub fn new(x: Axis, y: Axis) -> Self {
        Self {
            x,
            y,
            ..Self::default()
        }
    }

    fn data_x(&self) -> Vec<f64> {
        let mut v: Vec<f64> = Vec::new();
        for s in &self.series {
            v.extend(&s.x);
            if let Some(e) = &s.x_err {
                v.extend(s.x.iter().zip(e).flat_map(|(x, e)| [x - e, x + e]));
            }
        }
        v
    }

    fn data_y(&self) -> Vec<f64> {
        let mut v: Vec<f64> = Vec::new();
        for s in &self.series {
            v.extend(&s.y);
            if let Some(e) = &s.y_err {
                v.extend(s.y.iter().zip(e).flat_map(|(y, e)| [y - e, y + e]));
            }
            if let Some((lo, hi)) = &s.band {
                v.extend(lo);
                v.extend(hi);
            }
        }
        v
    }

    /// Resolved mappings (ranges) of both axes.
    pub fn mappings(&self) -> (Mapping, Mapping) {
        (
            mapping(&self.x, self.data_x()),
            mapping(&self.y, self.data_y()),
        )
    }

    /// Draws the panel into `outer` (axes, labels and all) and returns the plot geometry.
    pub fn draw<DB: DrawingBackend>(&self, c: &Canvas<DB>, outer: Rect) -> Result<PlotGeometry> {
        let (mx, my) = self.mappings();
        let xt = ticks(&mx, 5, self.x.ticks.as_deref());
        let yt = ticks(&my, 5, self.y.ticks.as_deref());
        // a tag sits above the plot area, level with the title line
        let room = if self.tag.is_some() && self.title.is_none() {
            outer.inset(0.0, TAG_FONT * 0.75, 0.0, 0.0)
        } else {
            outer
        };
        let area = plot_area(
            c,
            room,
            &xt,
            &yt,
            &self.x.label,
            &self.y.label,
            self.title.is_some(),
        );
        let g = PlotGeometry { area, x: mx, y: my };
        c.rect(area, Some(WHITE), None)?;
        self.draw_data(c, &g)?;
        self.draw_annotations(c, &g)?;
        draw_frame(c, &g, &xt, &yt)?;
        draw_axis_labels(c, outer, &g, &self.x.label, &self.y.label)?;
        if let Some(t) = &self.title {
            c.text(
                t,
                (area.x + area.w / 2.0, area.y - 6.0),
                &TextOpts::new(LABEL_FONT).align(HAlign::Center, VAlign::Bottom),
            )?;
        }
        if let Some(t) = &self.tag {
            draw_tag(c, outer, t)?;
        }
        self.draw_legend(c, &g)?;
        Ok(g)
    }

    fn draw_data<DB: DrawingBackend>(&self, c: &Canvas<DB>, g: &PlotGeometry) -> Result<()> {
        let a = g.area;
        for s in &self.series {
            if let Some((lo, hi)) = &s.band {
                // one polygon per run of finite points
                let pts: Vec<((f64, f64), (f64, f64))> =
                    s.x.iter()
                        .zip(lo.iter().zip(hi))
                        .map(|(&x, (&l, &h))| (g.to_canvas((x, l)), g.to_canvas((x, h))))
                        .collect();
                let finite = |p: &((f64, f64), (f64, f64))| {
                    [p.0.0, p.0.1, p.1.0, p.1.1].iter().all(|v| v.is_finite())
                };
                for run in pts.split(|p| !finite(p)).filter(|r| r.len() >= 2) {
                    let mut poly: Vec<(f64, f64)> = run.iter().map(|p| clamp(p.0, &a)).collect();
                    poly.extend(run.iter().rev().map(|p| clamp(p.1, &a)));
                    c.fill_polygon_alpha(&poly, s.color(), 0.18)?;
                }
            }
        }
        for s in &self.series {
            let pts: Vec<(f64, f64)> =
                s.x.iter()
                    .zip(&s.y)
                    .map(|(&x, &y)| g.to_canvas((x, y)))
                    .collect();
            if let Some(st) = &s.stroke {
                for piece in clip_polyline(&pts, &a) {
                    c.polyline(&piece, st)?;
                }
                if s.arrows > 0 {
                    draw_direction_arrows(c, &pts, &a, s.arrows, st)?;
                }
            }
            let col = s.color();
            let cap = 2.2;
            if let Some(e) = &s.y_err {
                for ((&x, &y), &e) in s.x.iter().zip(&s.y).zip(e) {
                    if !(e.is_finite() && e > 0.0) {
                        continue;
                    }
                    let p = g.to_canvas((x, y - e));
                    let q = g.to_canvas((x, y + e));
                    let p = if p.1.is_finite() {
                        p
                    } else {
                        (q.0, a.bottom())
                    };
                    for piece in clip_polyline(&[p, q], &a) {
                        c.polyline(&piece, &Stroke::solid(col).width(0.9))?;
                    }
                    for end in [p, q] {
                        if a.contains(end) {
                            c.polyline(
                                &[(end.0 - cap, end.1), (end.0 + cap, end.1)],
                                &Stroke::solid(col).width(0.9),
                            )?;
                        }
                    }
                }
            }
            if let Some(e) = &s.x_err {
                for ((&x, &y), &e) in s.x.iter().zip(&s.y).zip(e) {
                    if !(e.is_finite() && e > 0.0) {
                        continue;
                    }
                    let p = g.to_canvas((x - e, y));
                    let q = g.to_canvas((x + e, y));
                    for piece in clip_polyline(&[p, q], &a) {
                        c.polyline(&piece, &Stroke::solid(col).width(0.9))?;
                    }
                }
            }
            if let Some(m) = &s.marker {
                for &p in &pts {
                    if p.0.is_finite() && p.1.is_finite() && a.contains(p) {
                        c.marker(p, m)?;
                    }
                }
            }
        }
        Ok(())
    }

    fn draw_annotations<DB: DrawingBackend>(&self, c: &Canvas<DB>, g: &PlotGeometry) -> Result<()> {
        let a = g.area;
        let small = TextOpts::new(ANNOTATION_FONT);
        for ann in &self.annotations {
            match ann {
                Annotation::VLine { x, stroke, label } => {
                    let sx = g.to_canvas((*x, g.y.lo)).0;
                    if sx.is_finite() && sx >= a.x && sx <= a.right() {
                        c.polyline(&[(sx, a.y), (sx, a.bottom())], stroke)?;
                        if let Some(l) = label {
                            c.text(
                                l,
                                (sx + 3.0, a.y + 4.0),
                                &small.color(stroke.color).align(HAlign::Left, VAlign::Top),
                            )?;
                        }
                    }
                }
                Annotation::HLine { y, stroke, label } => {
                    let sy = g.to_canvas((g.x.lo, *y)).1;
                    if sy.is_finite() && sy >= a.y && sy <= a.bottom() {
                        c.polyline(&[(a.x, sy), (a.right(), sy)], stroke)?;
                        if let Some(l) = label {
                            c.text(
                                l,
                                (a.right() - 4.0, sy - 3.0),
                                &small
                                    .color(stroke.color)
                                    .align(HAlign::Right, VAlign::Bottom),
                            )?;
                        }
                    }
                }
                Annotation::Arrow { from, to, color } => {
                    let p = g.to_canvas(*from);
                    let q = g.to_canvas(*to);
                    if p.0.is_finite() && q.0.is_finite() && p.1.is_finite() && q.1.is_finite() {
                        c.arrow(p, q, *color, 1.1, 7.0)?;
                    }
                }
                Annotation::Text {
                    at,
                    text,
                    h,
                    v,
                    color,
                } => {
                    let p = g.to_canvas(*at);
                    if p.0.is_finite() && p.1.is_finite() {
                        c.text(text, p, &small.color(*color).align(*h, *v))?;
                    }
                }
                Annotation::PowerLaw {
                    x_range,
                    through,
                    exponent,
                    stroke,
                    label,
                } => {
                    let n = 64;
                    let pts: Vec<(f64, f64)> = (0..=n)
                        .map(|k| {
                            let f = k as f64 / n as f64;
                            let x = match g.x.scale {
                                Scale::Log => x_range.0 * (x_range.1 / x_range.0).powf(f),
                                Scale::Linear => x_range.0 + (x_range.1 - x_range.0) * f,
                            };
                            let y = through.1 * (x / through.0).powf(*exponent);
                            g.to_canvas((x, y))
                        })
                        .collect();
                    for piece in clip_polyline(&pts, &a) {
                        c.polyline(&piece, stroke)?;
                    }
                    if let Some(l) = label {
                        let mid = pts[n / 2];
                        let d = (
                            pts[n / 2 + 1].0 - pts[n / 2 - 1].0,
                            pts[n / 2 + 1].1 - pts[n / 2 - 1].1,
                        );
                        let len = (d.0 * d.0 + d.1 * d.1).sqrt().max(1e-9);
                        // normal pointing up (negative screen y)
                        let mut nrm = (d.1 / len, -d.0 / len);
                        if nrm.1 > 0.0 {
                            nrm = (-nrm.0, -nrm.1);
                        }
                        let off = 5.0;
                        let p = (mid.0 + nrm.0 * off, mid.1 + nrm.1 * off);
                        let h = if nrm.0 < -0.3 {
                            HAlign::Right
                        } else if nrm.0 > 0.3 {
                            HAlign::Left
                        } else {
                            HAlign::Center
                        };
                        c.text(l, p, &small.color(stroke.color).align(h, VAlign::Bottom))?;
                    }
                }
                Annotation::Polyline { points, stroke } => {
                    let pts: Vec<(f64, f64)> = points.iter().map(|&p| g.to_canvas(p)).collect();
                    for piece in clip_polyline(&pts, &a) {
                        c.polyline(&piece, stroke)?;
                    }
                }
                Annotation::Marker { at, style } => {
                    let p = g.to_canvas(*at);
                    if p.0.is_finite() && p.1.is_finite() && a.contains(p) {
                        c.marker(p, style)?;
                    }
                }
            }
        }
        Ok(())
    }

    fn legend_entries(&self) -> Vec<LegendEntry> {
        let mut v: Vec<LegendEntry> = self
            .series
            .iter()
            .filter_map(|s| {
                s.label.as_ref().map(|l| LegendEntry {
                    label: l.clone(),
                    stroke: s.stroke,
                    marker: s.marker,
                })
            })
            .collect();
        v.extend(self.legend_extra.iter().cloned());
        v
    }

    fn draw_legend<DB: DrawingBackend>(&self, c: &Canvas<DB>, g: &PlotGeometry) -> Result<()> {
        let entries = self.legend_entries();
        if entries.is_empty() || self.legend == LegendPos::None {
            return Ok(());
        }
        draw_legend(
            c,
            &g.area,
            self.legend,
            self.legend_columns.max(1),
            &entries,
        )
    }
}

/// Draws a legend box with `entries` inside `area` at `pos`.
pub fn draw_legend<DB: DrawingBackend>(
    c: &Canvas<DB>,
    area: &Rect,
    pos: LegendPos,
    columns: usize,
    entries: &[LegendEntry],
) -> Result<()> {
    let f = LEGEND_FONT;
    let row_h = f * 1.42;
    let sample = 22.0;
    let pad = 5.0;
    let rows = entries.len().div_ceil(columns);
    let col_w: Vec<f64> = (0..columns)
        .map(|k| {
            entries
                .iter()
                .skip(k * rows)
                .take(rows)
                .map(|e| c.text_width(&e.label, f))
                .fold(0.0, f64::max)
                + sample
                + 6.0
        })
        .collect();
    let w = col_w.iter().sum::<f64>() + pad * 2.0 + 8.0 * (columns - 1) as f64;
    let h = rows as f64 * row_h + pad * 2.0 - (row_h - f * 1.1);
    let m = 6.0;
    let (x, y) = match pos {
        LegendPos::None => return Ok(()),
        LegendPos::TopLeft => (area.x + m, area.y + m),
        LegendPos::TopRight => (area.right() - m - w, area.y + m),
        LegendPos::TopCenter => (area.x + (area.w - w) / 2.0, area.y + m),
        LegendPos::BottomLeft => (area.x + m, area.bottom() - m - h),
        LegendPos::BottomRight => (area.right() - m - w, area.bottom() - m - h),
        LegendPos::At(fx, fy) => (area.x + fx * area.w, area.y + fy * area.h),
    };
    c.rect(Rect::new(x, y, w, h), Some(WHITE), Some((LIGHT_GREY, 0.6)))?;
    let mut cx = x + pad;
    for (k, chunk) in entries.chunks(rows).enumerate() {
        for (r, e) in chunk.iter().enumerate() {
            let cy = y + pad + f * 0.55 + r as f64 * row_h;
            if let Some(st) = &e.stroke {
                c.polyline(&[(cx, cy), (cx + sample, cy)], st)?;
            }
            if let Some(mk) = &e.marker {
                c.marker((cx + sample / 2.0, cy), mk)?;
            }
            c.text(
                &e.label,
                (cx + sample + 5.0, cy),
                &TextOpts::new(f).align(HAlign::Left, VAlign::Center),
            )?;
        }
        cx += col_w[k] + 8.0;
    }
    Ok(())
}

fn clamp(p: (f64, f64), a: &Rect) -> (f64, f64) {
    (p.0.clamp(a.x, a.right()), p.1.clamp(a.y, a.bottom()))
}

/// Arrow heads at `n` evenly spaced arc-length positions of the visible line.
fn draw_direction_arrows<DB: DrawingBackend>(
    c: &Canvas<DB>,
    pts: &[(f64, f64)],
    a: &Rect,
    n: usize,
    st: &Stroke,
) -> Result<()> {
    let pieces = clip_polyline(pts, a);
    let seglen = |p: (f64, f64), q: (f64, f64)| ((q.0 - p.0).powi(2) + (q.1 - p.1).powi(2)).sqrt();
    let total: f64 = pieces
        .iter()
        .flat_map(|p| p.windows(2).map(|w| seglen(w[0], w[1])))
        .sum();
    if total <= 0.0 {
        return Ok(());
    }
    let head = (4.5 * st.width).max(7.0);
    for k in 0..n {
        let target = total * (k as f64 + 0.4) / n as f64;
        let mut acc = 0.0;
        'outer: for piece in &pieces {
            for w in piece.windows(2) {
                let l = seglen(w[0], w[1]);
                if acc + l >= target && l > 0.0 {
                    let f = (target - acc) / l;
                    let d = (w[1].0 - w[0].0, w[1].1 - w[0].1);
                    let tip = (
                        w[0].0 + d.0 * f + d.0 / l * head * 0.5,
                        w[0].1 + d.1 * f + d.1 / l * head * 0.5,
                    );
                    c.arrow_head(tip, d, head, st.color)?;
                    break 'outer;
                }
                acc += l;
            }
        }
    }
    Ok(())
}

/// The plot area inside `outer` that leaves room for tick labels, axis labels and a title.
pub fn plot_area<DB: DrawingBackend>(
    c: &Canvas<DB>,
    outer: Rect,
    xt: &[Tick],
    yt: &[Tick],
    x_label: &str,
    y_label: &str,
    title: bool,
) -> Rect {
    let ytw = yt
        .iter()
        .filter_map(|t| t.label.as_ref())
        .map(|l| c.text_width(l, TICK_FONT))
        .fold(0.0, f64::max);
    let last_xw = xt
        .iter()
        .rev()
        .find_map(|t| t.label.as_ref())
        .map(|l| c.text_width(l, TICK_FONT))
        .unwrap_or(0.0);
    let left =
        3.0 + if y_label.is_empty() {
            0.0
        } else {
            LABEL_FONT * 1.05 + 5.0
        } + ytw
            + 5.0;
    let bottom = 4.0
        + TICK_FONT * 1.15
        + if x_label.is_empty() {
            0.0
        } else {
            5.0 + LABEL_FONT * 1.2
        }
        + 2.0;
    let top = if title {
        LABEL_FONT * 1.7
    } else {
        TICK_FONT * 0.7
    };
    let right = (last_xw / 2.0 + 3.0).max(8.0);
    outer.inset(left, top, right, bottom)
}

/// Frame, inward ticks on all four sides, tick labels bottom and left.
pub fn draw_frame<DB: DrawingBackend>(
    c: &Canvas<DB>,
    g: &PlotGeometry,
    xt: &[Tick],
    yt: &[Tick],
) -> Result<()> {
    let a = g.area;
    let frame = Stroke::solid(BLACK).width(FRAME_WIDTH);
    let tick_opts = TextOpts::new(TICK_FONT);
    for t in xt {
        let f = g.x.frac(t.value);
        if !(0.0..=1.0 + 1e-9).contains(&f) {
            continue;
        }
        let x = a.x + f * a.w;
        let len = if t.label.is_some() {
            TICK_LEN
        } else {
            MINOR_TICK_LEN
        };
        c.polyline(&[(x, a.bottom()), (x, a.bottom() - len)], &frame)?;
        c.polyline(&[(x, a.y), (x, a.y + len)], &frame)?;
        if let Some(l) = &t.label {
            c.text(
                l,
                (x, a.bottom() + 4.0),
                &tick_opts.align(HAlign::Center, VAlign::Top),
            )?;
        }
    }
    for t in yt {
        let f = g.y.frac(t.value);
        if !(0.0..=1.0 + 1e-9).contains(&f) {
            continue;
        }
        let y = a.bottom() - f * a.h;
        let len = if t.label.is_some() {
            TICK_LEN
        } else {
            MINOR_TICK_LEN
        };
        c.polyline(&[(a.x, y), (a.x + len, y)], &frame)?;
        c.polyline(&[(a.right(), y), (a.right() - len, y)], &frame)?;
        if let Some(l) = &t.label {
            c.text(
                l,
                (a.x - 5.0, y),
                &tick_opts.align(HAlign::Right, VAlign::Center),
            )?;
        }
    }
    c.rect(a, None, Some((BLACK, FRAME_WIDTH)))
}

/// Axis labels: x centred below the tick labels, y rotated at the left edge of `outer`.
pub fn draw_axis_labels<DB: DrawingBackend>(
    c: &Canvas<DB>,
    outer: Rect,
    g: &PlotGeometry,
    x_label: &str,
    y_label: &str,
) -> Result<()> {
    let a = g.area;
    if !x_label.is_empty() {
        c.text(
            x_label,
            (a.x + a.w / 2.0, outer.bottom() - 2.0),
            &TextOpts::new(LABEL_FONT).align(HAlign::Center, VAlign::Bottom),
        )?;
    }
    if !y_label.is_empty() {
        c.text(
            y_label,
            (outer.x + 3.0, a.y + a.h / 2.0),
            &TextOpts::new(LABEL_FONT)
                .rotated()
                .align(HAlign::Center, VAlign::Top),
        )?;
    }
    Ok(())
}

/// A bold panel tag ("(a)") at the top-left corner of `outer`.
pub fn draw_tag<DB: DrawingBackend>(c: &Canvas<DB>, outer: Rect, tag: &str) -> Result<()> {
    c.text(
        tag,
        (outer.x + 1.0, outer.y + 1.0),
        &TextOpts::new(TAG_FONT)
            .bold()
            .align(HAlign::Left, VAlign::Top),
    )
}
