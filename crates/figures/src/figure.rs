//! A figure: a canvas size and panels placed on it; rendering to PNG and SVG, published
//! atomically.

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow};
use plotters::prelude::{BitMapBackend, DrawingBackend, IntoDrawingArea, SVGBackend};

use crate::canvas::{BackendKind, Canvas, Rect, TextOpts};
use crate::heatmap::HeatmapPanel;
use crate::style::{PNG_SCALE, WHITE};
use crate::xy::XyPanel;

/// Supersampling factor of the PNG (rendered this many times larger, then averaged down).
pub const SUPERSAMPLE: u32 = 2;

/// One panel of a figure.
#[derive(Debug, Clone, PartialEq)]
pub enum Panel {
    /// An x–y plot.
    Xy(Box<XyPanel>),
    /// A heat map.
    Heatmap(Box<HeatmapPanel>),
    /// Free text (rich text) anchored at the rectangle's top-left corner.
    Text(String, TextOpts),
}

/// A figure of `width` × `height` logical units with panels at given rectangles.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// Width (logical units; [`crate::style::COLUMN_WIDTH`] is one column).
    pub width: f64,
    /// Height (logical units).
    pub height: f64,
    /// Panels and where they go.
    pub panels: Vec<(Rect, Panel)>,
}

impl Figure {
    /// An empty figure.
    pub fn new(width: f64, height: f64) -> Self {
        Self {
            width,
            height,
            panels: Vec::new(),
        }
    }

    /// The whole canvas as a rectangle.
    pub fn bounds(&self) -> Rect {
        Rect::new(0.0, 0.0, self.width, self.height)
    }

    /// Adds an x–y panel.
    pub fn xy(&mut self, r: Rect, p: XyPanel) -> &mut Self {
        self.panels.push((r, Panel::Xy(Box::new(p))));
        self
    }

    /// Adds a heat-map panel.
    pub fn heatmap(&mut self, r: Rect, p: HeatmapPanel) -> &mut Self {
        self.panels.push((r, Panel::Heatmap(Box::new(p))));
        self
    }

    /// Draws every panel on a canvas.
    pub fn draw<DB: DrawingBackend>(&self, c: &Canvas<DB>) -> Result<()> {
        for (r, p) in &self.panels {
            match p {
                Panel::Xy(xy) => {
                    xy.draw(c, *r)?;
                }
                Panel::Heatmap(h) => {
                    h.draw(c, *r)?;
                }
                Panel::Text(t, o) => c.text(t, (r.x, r.y), o)?,
            }
        }
        Ok(())
    }

    /// PNG pixel size.
    pub fn png_size(&self) -> (u32, u32) {
        (
            (self.width * PNG_SCALE).round() as u32,
            (self.height * PNG_SCALE).round() as u32,
        )
    }

    /// Renders the PNG (supersampled, anti-aliased) and returns its bytes.
    pub fn render_png(&self) -> Result<Vec<u8>> {
        let (w, h) = self.png_size();
        let (bw, bh) = (w * SUPERSAMPLE, h * SUPERSAMPLE);
        let mut big = vec![255u8; (bw * bh * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut big, (bw, bh)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
            let c = Canvas::new(&root, PNG_SCALE * SUPERSAMPLE as f64, BackendKind::Bitmap);
            self.draw(&c)?;
            root.present().map_err(|e| anyhow!("{e}"))?;
        }
        let small = downsample(&big, bw, bh, SUPERSAMPLE);
        let mut out = Vec::new();
        {
            use image::ImageEncoder;
            image::codecs::png::PngEncoder::new(&mut out)
                .write_image(&small, w, h, image::ColorType::Rgb8)
                .context("encoding PNG")?;
        }
        Ok(out)
    }

    /// Renders the SVG (same nominal size as the PNG) and returns it.
    pub fn render_svg(&self) -> Result<String> {
        let (w, h) = self.png_size();
        let mut s = String::new();
        {
            let root = SVGBackend::with_string(&mut s, (w, h)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
            let c = Canvas::new(&root, PNG_SCALE, BackendKind::Svg);
            self.draw(&c)?;
            root.present().map_err(|e| anyhow!("{e}"))?;
        }
        Ok(s)
    }

    /// Writes `<out_stem>.png` and `<out_stem>.svg`, each through a temporary file in the
    /// target folder and a rename (a reader never sees a half-written figure). Creates the
    /// folder. Returns the two paths.
    pub fn render(&self, out_stem: &Path) -> Result<Vec<PathBuf>> {
        let png = with_suffix(out_stem, "png");
        let svg = with_suffix(out_stem, "svg");
        let png_bytes = self
            .render_png()
            .with_context(|| format!("rendering {}", png.display()))?;
        let svg_text = self
            .render_svg()
            .with_context(|| format!("rendering {}", svg.display()))?;
        write_atomic(&png, &png_bytes)?;
        write_atomic(&svg, svg_text.as_bytes())?;
        Ok(vec![png, svg])
    }
}

/// `stem` + "." + `ext` (without replacing an existing extension).
pub fn with_suffix(stem: &Path, ext: &str) -> PathBuf {
    let mut s: OsString = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

fn downsample(big: &[u8], bw: u32, bh: u32, f: u32) -> Vec<u8> {
    let (w, h) = (bw / f, bh / f);
    let mut out = vec![0u8; (w * h * 3) as usize];
    let n = f * f;
    for y in 0..h {
        for x in 0..w {
            for ch in 0..3 {
                let mut sum = 0u32;
                for dy in 0..f {
                    for dx in 0..f {
                        sum += big[(((y * f + dy) * bw + x * f + dx) * 3 + ch) as usize] as u32;
                    }
                }
                out[((y * w + x) * 3 + ch) as usize] = ((sum + n / 2) / n) as u8;
            }
        }
    }
    out
}

pub use fsutil::write_atomic;
