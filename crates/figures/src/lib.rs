//! Publication figures of saddleflow: plain data in, PNG and SVG files out.
//!
//! The crate knows no physics. Scene modules ([`scenes`]) take documented data structs (one per
//! figure of Dapp & Müser, EPL 109, 44001 (2015), plus generic convergence and trade-off
//! figures) and build a [`Figure`] from the primitives:
//!
//! - [`xy::XyPanel`]: linear or log axes, series with lines (solid, dashed, dotted),
//!   markers, error bars, bands and direction arrows, reference lines, annotations, power-law
//!   lines with slope labels, legends;
//! - [`heatmap::HeatmapPanel`]: a periodic 2-D field of shape (nx, ny) (first index x) on a
//!   cell lx × ly with its aspect ratio, a perceptually uniform colour map, a mask colour, a
//!   colour bar and overlays (polylines, points, stars, arrows);
//! - layouts: any rectangles ([`canvas::Rect::columns`], [`canvas::Rect::rows`]).
//!
//! [`Figure::render`] writes `<stem>.png` (anti-aliased by supersampling) and `<stem>.svg`,
//! each through a temporary file and a rename. Text uses embedded DejaVu Sans fonts (no system
//! fonts needed) and a small markup for italic math and sub/superscripts ([`text`]).
//! Shared sizes and colours live in [`style`].

pub mod axes;
pub mod canvas;
pub mod demo;
pub mod figure;
pub mod heatmap;
pub mod scenes;
pub mod style;
pub mod text;
pub mod xy;

pub use axes::{Axis, Scale};
pub use canvas::{HAlign, Rect, TextOpts, VAlign};
pub use figure::{Figure, Panel};
pub use heatmap::{ColorbarPos, Colormap, HeatmapPanel, Overlay};
pub use style::{Dash, Marker, MarkerStyle, Model, Stroke};
pub use xy::{Annotation, LegendEntry, LegendPos, Series, XyPanel};
