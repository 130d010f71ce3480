//! Drawing in logical units on any plotters backend: lines with dashes, polygons, markers,
//! arrows, rich text and raster images.
//!
//! plotters works in integer device pixels; a [`Canvas`] multiplies logical coordinates by
//! its scale and rounds at the last moment, so the same drawing code produces the
//! supersampled PNG and the SVG. Text goes through [`crate::text`]'s small markup (italic
//! math, sub- and superscripts) and is placed by its baseline, the same way on both backends.

use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::element::{BitMapElement, Circle, PathElement, Polygon};
use plotters::prelude::{DrawingArea, DrawingBackend};
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{
    Color, FontDesc, FontFamily, FontStyle, FontTransform, ShapeStyle, TextStyle,
};

use crate::style::{Dash, FONT_FAMILY, MarkerStyle, Rgb, Stroke, WHITE};
use crate::text::{Run, parse};

/// Which backend a canvas draws on (text metrics differ slightly between them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackendKind {
    /// Raster (PNG).
    Bitmap,
    /// Vector (SVG).
    Svg,
}

/// A rectangle in logical units, origin at the top left, y downwards.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// Left edge.
    pub x: f64,
    /// Top edge.
    pub y: f64,
    /// Width.
    pub w: f64,
    /// Height.
    pub h: f64,
}

impl Rect {
    /// A rectangle from its top-left corner and size.
    pub fn new(x: f64, y: f64, w: f64, h: f64) -> Self {
        Self { x, y, w, h }
    }
    /// Right edge.
    pub fn right(&self) -> f64 {
        self.x + self.w
    }
    /// Bottom edge.
    pub fn bottom(&self) -> f64 {
        self.y + self.h
    }
    /// Shrinks by the given margins.
    pub fn inset(&self, left: f64, top: f64, right: f64, bottom: f64) -> Self {
        Self::new(
            self.x + left,
            self.y + top,
            (self.w - left - right).max(1.0),
            (self.h - top - bottom).max(1.0),
        )
    }
    /// Splits into columns with the given relative widths and gaps between them.
    pub fn columns(&self, weights: &[f64], gap: f64) -> Vec<Rect> {
        let total: f64 = weights.iter().sum();
        let free = self.w - gap * (weights.len().saturating_sub(1)) as f64;
        let mut x = self.x;
        weights
            .iter()
            .map(|w| {
                let r = Rect::new(x, self.y, free * w / total, self.h);
                x += r.w + gap;
                r
            })
            .collect()
    }
    /// Splits into rows with the given relative heights and gaps between them.
    pub fn rows(&self, weights: &[f64], gap: f64) -> Vec<Rect> {
        let total: f64 = weights.iter().sum();
        let free = self.h - gap * (weights.len().saturating_sub(1)) as f64;
        let mut y = self.y;
        weights
            .iter()
            .map(|w| {
                let r = Rect::new(self.x, y, self.w, free * w / total);
                y += r.h + gap;
                r
            })
            .collect()
    }
    /// The largest rectangle of the given aspect ratio (width / height) centred in this one.
    pub fn fit_aspect(&self, aspect: f64) -> Self {
        if self.w / self.h > aspect {
            let w = self.h * aspect;
            Self::new(self.x + (self.w - w) / 2.0, self.y, w, self.h)
        } else {
            let h = self.w / aspect;
            Self::new(self.x, self.y + (self.h - h) / 2.0, self.w, h)
        }
    }
    /// True when the point lies inside (edges included).
    pub fn contains(&self, p: (f64, f64)) -> bool {
        p.0 >= self.x && p.0 <= self.right() && p.1 >= self.y && p.1 <= self.bottom()
    }
}

/// Horizontal text alignment relative to the anchor point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HAlign {
    /// Text starts at the anchor.
    Left,
    /// Text is centred on the anchor.
    Center,
    /// Text ends at the anchor.
    Right,
}

/// Vertical text alignment relative to the anchor point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VAlign {
    /// Anchor at the top of the ascenders.
    Top,
    /// Anchor at half the capital height.
    Center,
    /// Anchor on the baseline.
    Baseline,
    /// Anchor at the bottom of the descenders.
    Bottom,
}

/// Font ascent above the baseline, in em (DejaVu Sans).
pub const ASCENT: f64 = 0.76;
/// Font descent below the baseline, in em.
pub const DESCENT: f64 = 0.24;
/// Capital height, in em.
pub const CAP_HEIGHT: f64 = 0.73;
/// plotters' ab_glyph size is the ascent–descent height, not the em: DejaVu's is 1.164 em.
const PLOTTERS_SIZE_PER_EM: f64 = 2384.0 / 2048.0;

/// How to draw a piece of text.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextOpts {
    /// Font size (em, logical units).
    pub size: f64,
    /// Colour.
    pub color: Rgb,
    /// Bold (upright) instead of regular.
    pub bold: bool,
    /// Rotated by 90° counter-clockwise (reads bottom to top), as a y-axis label.
    pub rotated: bool,
    /// Horizontal alignment (along the text direction).
    pub h: HAlign,
    /// Vertical alignment (across the text direction).
    pub v: VAlign,
}

impl TextOpts {
    /// Black regular text of the given size, anchored at its left baseline.
    pub fn new(size: f64) -> Self {
        Self {
            size,
            color: crate::style::BLACK,
            bold: false,
            rotated: false,
            h: HAlign::Left,
            v: VAlign::Baseline,
        }
    }
    /// Same, with another alignment.
    pub fn align(mut self, h: HAlign, v: VAlign) -> Self {
        self.h = h;
        self.v = v;
        self
    }
    /// Same, with another colour.
    pub fn color(mut self, c: Rgb) -> Self {
        self.color = c;
        self
    }
    /// Same, bold.
    pub fn bold(mut self) -> Self {
        self.bold = true;
        self
    }
    /// Same, rotated to read bottom to top.
    pub fn rotated(mut self) -> Self {
        self.rotated = true;
        self
    }
}

/// A drawing surface in logical units over a plotters drawing area.
pub struct Canvas<'a, DB: DrawingBackend> {
    area: &'a DrawingArea<DB, Shift>,
    s: f64,
    kind: BackendKind,
}

fn err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("drawing failed: {e}")
}

impl<'a, DB: DrawingBackend> Canvas<'a, DB> {
    /// A canvas drawing on `area` with `scale` device pixels per logical unit.
    pub fn new(area: &'a DrawingArea<DB, Shift>, scale: f64, kind: BackendKind) -> Self {
        crate::style::register_fonts();
        Self {
            area,
            s: scale,
            kind,
        }
    }

    /// Device pixels per logical unit.
    pub fn scale(&self) -> f64 {
        self.s
    }

    fn dev(&self, p: (f64, f64)) -> (i32, i32) {
        ((p.0 * self.s).round() as i32, (p.1 * self.s).round() as i32)
    }

    fn width_px(&self, w: f64) -> u32 {
        ((w * self.s).round() as u32).max(1)
    }

    /// Strokes a polyline. Non-finite points split it into pieces.
    pub fn polyline(&self, pts: &[(f64, f64)], stroke: &Stroke) -> Result<()> {
        for piece in pts
            .split(|p| !(p.0.is_finite() && p.1.is_finite()))
            .filter(|p| p.len() >= 2)
        {
            match stroke.dash {
                Dash::Solid => self.solid(piece, stroke.color, stroke.width)?,
                Dash::Dotted => self.dotted(piece, stroke)?,
                Dash::Dashed => {
                    let w = stroke.width;
                    self.dashed(piece, stroke, &[(4.5 * w).max(5.0), (2.0 * w).max(3.2)])?
                }
                Dash::DashDot => {
                    let w = stroke.width;
                    self.dashed(
                        piece,
                        stroke,
                        &[
                            (4.5 * w).max(5.0),
                            (1.8 * w).max(2.5),
                            w,
                            (1.8 * w).max(2.5),
                        ],
                    )?
                }
                Dash::Custom(on, off) => self.dashed(piece, stroke, &[on, off])?,
            }
        }
        Ok(())
    }

    fn solid(&self, pts: &[(f64, f64)], color: Rgb, width: f64) -> Result<()> {
        let dev: Vec<(i32, i32)> = pts.iter().map(|&p| self.dev(p)).collect();
        let style = ShapeStyle {
            color: color.to_rgba(),
            filled: false,
            stroke_width: self.width_px(width),
        };
        self.area.draw(&PathElement::new(dev, style)).map_err(err)?;
        // round caps and joins for thick lines (plotters draws butt ends)
        if width * self.s >= 3.0 {
            let r = width / 2.0;
            for &p in [pts[0], pts[pts.len() - 1]].iter() {
                self.disc(p, r, color)?;
            }
        }
        Ok(())
    }

    fn dashed(&self, pts: &[(f64, f64)], stroke: &Stroke, pattern: &[f64]) -> Result<()> {
        // walk the polyline, switching on/off at the pattern's lengths
        let mut k = 0usize;
        let mut left = pattern[0];
        let mut on = true;
        let mut current: Vec<(f64, f64)> = vec![pts[0]];
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            let seg = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
            let mut t0 = 0.0;
            while seg - t0 > left {
                t0 += left;
                let p = (a.0 + (b.0 - a.0) * t0 / seg, a.1 + (b.1 - a.1) * t0 / seg);
                if on {
                    current.push(p);
                    self.solid(&current, stroke.color, stroke.width)?;
                    current.clear();
                } else {
                    current.clear();
                    current.push(p);
                }
                on = !on;
                k = (k + 1) % pattern.len();
                left = pattern[k];
            }
            left -= seg - t0;
            if on {
                current.push(b);
            } else {
                current.clear();
            }
        }
        if on && current.len() >= 2 {
            self.solid(&current, stroke.color, stroke.width)?;
        }
        Ok(())
    }

    fn dotted(&self, pts: &[(f64, f64)], stroke: &Stroke) -> Result<()> {
        let spacing = (2.4 * stroke.width).max(2.5);
        let r = stroke.width * 0.62;
        let mut carry = 0.0;
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            let seg = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
            let mut t = carry;
            while t <= seg {
                let f = if seg > 0.0 { t / seg } else { 0.0 };
                self.disc(
                    (a.0 + (b.0 - a.0) * f, a.1 + (b.1 - a.1) * f),
                    r,
                    stroke.color,
                )?;
                t += spacing;
            }
            carry = t - seg;
        }
        Ok(())
    }

    /// A filled disc.
    pub fn disc(&self, c: (f64, f64), r: f64, color: Rgb) -> Result<()> {
        let rr = (r * self.s).round().max(1.0) as i32;
        self.area
            .draw(&Circle::new(self.dev(c), rr, color.filled()))
            .map_err(err)
    }

    /// A circle outline.
    pub fn ring(&self, c: (f64, f64), r: f64, color: Rgb, width: f64) -> Result<()> {
        let rr = (r * self.s).round().max(1.0) as i32;
        self.area
            .draw(&Circle::new(
                self.dev(c),
                rr,
                ShapeStyle {
                    color: color.to_rgba(),
                    filled: false,
                    stroke_width: self.width_px(width),
                },
            ))
            .map_err(err)
    }

    /// A filled polygon.
    pub fn fill_polygon(&self, pts: &[(f64, f64)], color: Rgb) -> Result<()> {
        let dev: Vec<(i32, i32)> = pts.iter().map(|&p| self.dev(p)).collect();
        self.area
            .draw(&Polygon::new(dev, color.filled()))
            .map_err(err)
    }

    /// A filled polygon with transparency (`alpha` in 0..1).
    pub fn fill_polygon_alpha(&self, pts: &[(f64, f64)], color: Rgb, alpha: f64) -> Result<()> {
        let dev: Vec<(i32, i32)> = pts.iter().map(|&p| self.dev(p)).collect();
        self.area
            .draw(&Polygon::new(dev, color.mix(alpha).filled()))
            .map_err(err)
    }

    /// A closed polygon outline.
    pub fn stroke_polygon(&self, pts: &[(f64, f64)], color: Rgb, width: f64) -> Result<()> {
        let mut closed = pts.to_vec();
        if let Some(&first) = pts.first() {
            closed.push(first);
        }
        self.solid(&closed, color, width)
    }

    /// An axis-aligned rectangle, filled and/or outlined.
    pub fn rect(&self, r: Rect, fill: Option<Rgb>, edge: Option<(Rgb, f64)>) -> Result<()> {
        let pts = [
            (r.x, r.y),
            (r.right(), r.y),
            (r.right(), r.bottom()),
            (r.x, r.bottom()),
        ];
        if let Some(c) = fill {
            self.fill_polygon(&pts, c)?;
        }
        if let Some((c, w)) = edge {
            self.stroke_polygon(&pts, c, w)?;
        }
        Ok(())
    }

    /// Draws a marker centred at `c`.
    pub fn marker(&self, c: (f64, f64), m: &MarkerStyle) -> Result<()> {
        use crate::style::Marker::*;
        let r = m.size / 2.0;
        let edge_w = if m.fill.is_some() { 0.5 } else { 1.1 };
        let poly = |n: usize, rot: f64, radius: f64| -> Vec<(f64, f64)> {
            (0..n)
                .map(|k| {
                    let a = rot + std::f64::consts::TAU * k as f64 / n as f64;
                    (c.0 + radius * a.cos(), c.1 - radius * a.sin())
                })
                .collect()
        };
        let up = std::f64::consts::FRAC_PI_2;
        let shape: Vec<(f64, f64)> = match m.marker {
            Circle => {
                self.disc(c, r, m.fill.unwrap_or(WHITE))?;
                return self.ring(c, r, m.edge, edge_w);
            }
            Cross | Plus => {
                let rot = if m.marker == Cross {
                    std::f64::consts::FRAC_PI_4
                } else {
                    0.0
                };
                let w = (m.size / 5.0).max(1.0);
                for k in 0..2 {
                    let a = rot + up * k as f64;
                    let (dx, dy) = (r * a.cos(), r * a.sin());
                    self.solid(
                        &[(c.0 - dx, c.1 - dy), (c.0 + dx, c.1 + dy)],
                        m.fill.unwrap_or(m.edge),
                        w,
                    )?;
                }
                return Ok(());
            }
            Square => poly(4, std::f64::consts::FRAC_PI_4, r * 1.05),
            Diamond => poly(4, up, r * 1.1),
            TriangleUp => {
                let mut p = poly(3, up, r * 1.2);
                p.iter_mut().for_each(|q| q.1 += r * 0.2);
                p
            }
            TriangleDown => {
                let mut p = poly(3, -up, r * 1.2);
                p.iter_mut().for_each(|q| q.1 -= r * 0.2);
                p
            }
            Hexagon => poly(6, up, r * 1.05),
            Star => (0..10)
                .map(|k| {
                    let a = up + std::f64::consts::PI * k as f64 / 5.0;
                    let rad = if k % 2 == 0 { r * 1.3 } else { r * 0.55 };
                    (c.0 + rad * a.cos(), c.1 - rad * a.sin())
                })
                .collect(),
        };
        self.fill_polygon(&shape, m.fill.unwrap_or(WHITE))?;
        self.stroke_polygon(&shape, m.edge, edge_w)
    }

    /// A filled arrow head with its tip at `tip`, pointing along `dir` (any length).
    pub fn arrow_head(
        &self,
        tip: (f64, f64),
        dir: (f64, f64),
        size: f64,
        color: Rgb,
    ) -> Result<()> {
        let n = (dir.0 * dir.0 + dir.1 * dir.1).sqrt();
        if n == 0.0 || !n.is_finite() {
            return Ok(());
        }
        let (ux, uy) = (dir.0 / n, dir.1 / n);
        let (px, py) = (-uy, ux);
        let back = (tip.0 - ux * size, tip.1 - uy * size);
        let half = size * 0.42;
        let notch = (tip.0 - ux * size * 0.72, tip.1 - uy * size * 0.72);
        self.fill_polygon(
            &[
                tip,
                (back.0 + px * half, back.1 + py * half),
                notch,
                (back.0 - px * half, back.1 - py * half),
            ],
            color,
        )
    }

    /// A straight arrow from `from` to `to` (head at `to`).
    pub fn arrow(
        &self,
        from: (f64, f64),
        to: (f64, f64),
        color: Rgb,
        width: f64,
        head: f64,
    ) -> Result<()> {
        let d = (to.0 - from.0, to.1 - from.1);
        let n = (d.0 * d.0 + d.1 * d.1).sqrt();
        if n == 0.0 {
            return Ok(());
        }
        let head = head.min(n * 0.6);
        let shaft_end = (to.0 - d.0 / n * head * 0.7, to.1 - d.1 / n * head * 0.7);
        self.solid(&[from, shaft_end], color, width)?;
        self.arrow_head(to, d, head, color)
    }

    fn font(&self, size_px: f64, italic: bool, bold: bool) -> FontDesc<'static> {
        let style = if bold {
            FontStyle::Bold
        } else if italic {
            FontStyle::Italic
        } else {
            FontStyle::Normal
        };
        FontDesc::new(FontFamily::Name(FONT_FAMILY), size_px, style)
    }

    fn run_width(&self, run: &Run, size: f64, bold: bool) -> f64 {
        let px = size * run.scale * PLOTTERS_SIZE_PER_EM * self.s;
        let font = self.font(px, run.italic, bold);
        match font.box_size(&run.text) {
            Ok((w, _)) => w as f64 / self.s,
            // a missing glyph table would be a packaging bug; fall back to an estimate
            Err(_) => run.text.chars().count() as f64 * 0.6 * size * run.scale,
        }
    }

    fn layout(&self, s: &str, size: f64, bold: bool) -> (Vec<(Run, f64)>, f64) {
        let runs = parse(s);
        let mut u = 0.0;
        let mut out = Vec::with_capacity(runs.len());
        let n = runs.len();
        for (k, run) in runs.into_iter().enumerate() {
            let w = self.run_width(&run, size, bold);
            let start = u;
            u += w;
            // italic correction before upright text or a superscript
            if run.italic && k + 1 < n {
                u += 0.06 * size * run.scale;
            }
            out.push((run, start));
        }
        (out, u)
    }

    /// Width of a piece of rich text (logical units).
    pub fn text_width(&self, s: &str, size: f64) -> f64 {
        self.layout(s, size, false).1
    }

    /// Draws rich text (see [`crate::text`]) at `pos`.
    pub fn text(&self, s: &str, pos: (f64, f64), o: &TextOpts) -> Result<()> {
        if s.is_empty() {
            return Ok(());
        }
        let (runs, width) = self.layout(s, o.size, o.bold);
        let u0 = match o.h {
            HAlign::Left => 0.0,
            HAlign::Center => -width / 2.0,
            HAlign::Right => -width,
        };
        let v0 = match o.v {
            VAlign::Top => ASCENT * o.size,
            VAlign::Center => CAP_HEIGHT / 2.0 * o.size,
            VAlign::Baseline => 0.0,
            VAlign::Bottom => -DESCENT * o.size,
        };
        // where plotters puts the baseline below a top-anchored text, per unit of font size
        let k = match self.kind {
            BackendKind::Bitmap => 0.5,
            BackendKind::Svg => 0.76 / PLOTTERS_SIZE_PER_EM,
        };
        let svg_size = match self.kind {
            BackendKind::Bitmap => 1.0,
            BackendKind::Svg => 1.24 / PLOTTERS_SIZE_PER_EM,
        };
        for (run, u) in runs {
            let px = o.size * run.scale * PLOTTERS_SIZE_PER_EM * self.s;
            let u = (u0 + u) * self.s;
            let v = (v0 + run.shift * o.size) * self.s - k * px;
            let (x, y) = if o.rotated {
                (pos.0 * self.s + v, pos.1 * self.s - u)
            } else {
                (pos.0 * self.s + u, pos.1 * self.s + v)
            };
            let font = self.font(px * svg_size, run.italic, o.bold);
            let mut style = TextStyle::from(font)
                .color(&o.color)
                .pos(Pos::new(HPos::Left, VPos::Top));
            if o.rotated {
                style = style.transform(FontTransform::Rotate270);
            }
            // SVG renderers strip leading and trailing blanks of a <text>: draw the trimmed
            // text, shifted by the width of the leading blanks
            let trimmed = run.text.trim_start_matches(' ');
            let lead = run.text.len() - trimmed.len();
            let trimmed = trimmed.trim_end_matches(' ');
            if trimmed.is_empty() {
                continue;
            }
            let shift = if lead > 0 {
                let blank = Run {
                    text: " ".repeat(lead),
                    ..run.clone()
                };
                self.run_width(&blank, o.size, o.bold) * self.s
            } else {
                0.0
            };
            let (x, y) = if o.rotated {
                (x, y - shift)
            } else {
                (x + shift, y)
            };
            self.area
                .draw_text(trimmed, &style, (x.round() as i32, y.round() as i32))
                .map_err(err)?;
        }
        Ok(())
    }

    /// Fills `r` with an image whose colour at relative position (u, v) ∈ [0, 1]², u to the
    /// right and v downwards, is `color(u, v)`; sampled once per device pixel.
    pub fn image(&self, r: Rect, color: impl Fn(f64, f64) -> Rgb) -> Result<()> {
        let (x0, y0) = self.dev((r.x, r.y));
        let (x1, y1) = self.dev((r.right(), r.bottom()));
        let (w, h) = ((x1 - x0).max(1) as u32, (y1 - y0).max(1) as u32);
        let mut buf = vec![0u8; (w * h * 3) as usize];
        for j in 0..h {
            let v = (j as f64 + 0.5) / h as f64;
            for i in 0..w {
                let u = (i as f64 + 0.5) / w as f64;
                let c = color(u, v);
                let k = ((j * w + i) * 3) as usize;
                buf[k] = c.0;
                buf[k + 1] = c.1;
                buf[k + 2] = c.2;
            }
        }
        let elem = BitMapElement::with_owned_buffer((x0, y0), (w, h), buf)
            .ok_or_else(|| anyhow!("image buffer of the wrong size"))?;
        self.area.draw(&elem).map_err(err)
    }
}

/// Clips the segment a–b to `r` (Liang–Barsky); `None` when it lies outside.
pub fn clip_segment(a: (f64, f64), b: (f64, f64), r: &Rect) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let mut t0 = 0.0f64;
    let mut t1 = 1.0f64;
    for (p, q) in [
        (-dx, a.0 - r.x),
        (dx, r.right() - a.0),
        (-dy, a.1 - r.y),
        (dy, r.bottom() - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    Some((
        (a.0 + t0 * dx, a.1 + t0 * dy),
        (a.0 + t1 * dx, a.1 + t1 * dy),
    ))
}

/// Clips a polyline to `r`: the pieces inside, in order. Non-finite points split the line.
pub fn clip_polyline(pts: &[(f64, f64)], r: &Rect) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    for w in pts.windows(2) {
        let ok = |p: (f64, f64)| p.0.is_finite() && p.1.is_finite();
        if !(ok(w[0]) && ok(w[1])) {
            if cur.len() >= 2 {
                out.push(std::mem::take(&mut cur));
            }
            cur.clear();
            continue;
        }
        match clip_segment(w[0], w[1], r) {
            Some((p, q)) => {
                if cur.last() != Some(&p) {
                    if cur.len() >= 2 {
                        out.push(std::mem::take(&mut cur));
                    }
                    cur.clear();
                    cur.push(p);
                }
                cur.push(q);
            }
            None => {
                if cur.len() >= 2 {
                    out.push(std::mem::take(&mut cur));
                }
                cur.clear();
            }
        }
    }
    if cur.len() >= 2 {
        out.push(cur);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping() {
        let r = Rect::new(0.0, 0.0, 10.0, 10.0);
        let (p, q) = clip_segment((-5.0, 5.0), (15.0, 5.0), &r).unwrap();
        assert_eq!((p, q), ((0.0, 5.0), (10.0, 5.0)));
        assert!(clip_segment((-5.0, -5.0), (-1.0, 20.0), &r).is_none());
        let pieces = clip_polyline(
            &[
                (1.0, 1.0),
                (2.0, 2.0),
                (20.0, 2.0),
                (3.0, 3.0),
                (f64::NAN, 0.0),
                (4.0, 4.0),
                (5.0, 5.0),
            ],
            &r,
        );
        assert_eq!(pieces.len(), 3);
        assert_eq!(pieces[0], vec![(1.0, 1.0), (2.0, 2.0), (10.0, 2.0)]);
        assert_eq!(pieces[2], vec![(4.0, 4.0), (5.0, 5.0)]);
    }

    #[test]
    fn rect_splits() {
        let r = Rect::new(0.0, 0.0, 100.0, 50.0);
        let c = r.columns(&[1.0, 1.0], 10.0);
        assert_eq!(c[1].x, 55.0);
        assert_eq!(c[0].w, 45.0);
        let f = r.fit_aspect(1.0);
        assert_eq!((f.x, f.w, f.h), (25.0, 50.0, 50.0));
    }
}
