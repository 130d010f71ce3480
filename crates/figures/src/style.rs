//! The one shared style: fonts, sizes, colours, line styles and markers.
//!
//! All lengths are in *logical units*: a one-column figure is [`COLUMN_WIDTH`] wide. The PNG is
//! written at [`PNG_SCALE`] device pixels per logical unit (supersampled twice for
//! anti-aliasing), the SVG at the same nominal size. Font sizes are in logical units per em.
//!
//! Colours follow the paper: red for loading / increasing, blue for unloading / decreasing; the
//! three models hexagonal, square, triangular are always drawn in this order with
//! [`model_color`] and [`model_marker`].

use std::sync::Once;

use plotters::style::{FontStyle, RGBColor, register_font};

/// Font family name under which the embedded DejaVu fonts are registered. It is written
/// verbatim into the SVG's `font-family` attribute, so it is a CSS list with a generic
/// fallback.
pub const FONT_FAMILY: &str = "DejaVu Sans, sans-serif";

static DEJAVU_SANS: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
static DEJAVU_SANS_OBLIQUE: &[u8] = include_bytes!("../assets/DejaVuSans-Oblique.ttf");
static DEJAVU_SANS_BOLD: &[u8] = include_bytes!("../assets/DejaVuSans-Bold.ttf");

/// Registers the embedded fonts with plotters (idempotent, cheap after the first call).
pub fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let fonts = [
            (FontStyle::Normal, DEJAVU_SANS),
            (FontStyle::Italic, DEJAVU_SANS_OBLIQUE),
            (FontStyle::Oblique, DEJAVU_SANS_OBLIQUE),
            (FontStyle::Bold, DEJAVU_SANS_BOLD),
        ];
        for (style, bytes) in fonts {
            if register_font(FONT_FAMILY, style, bytes).is_err() {
                panic!("embedded DejaVu font does not parse");
            }
        }
    });
}

/// Width of a one-column figure (logical units).
pub const COLUMN_WIDTH: f64 = 480.0;
/// Device pixels per logical unit in the PNG (and SVG user units per logical unit).
pub const PNG_SCALE: f64 = 2.5;

/// Tick-label font size (em, logical units).
pub const TICK_FONT: f64 = 12.0;
/// Axis-label font size.
pub const LABEL_FONT: f64 = 13.5;
/// Legend font size.
pub const LEGEND_FONT: f64 = 11.0;
/// Annotation font size.
pub const ANNOTATION_FONT: f64 = 11.5;
/// Panel tag ("(a)") font size.
pub const TAG_FONT: f64 = 14.0;

/// Default data line width.
pub const LINE_WIDTH: f64 = 1.6;
/// Frame and tick line width.
pub const FRAME_WIDTH: f64 = 0.9;
/// Major tick length (drawn inwards).
pub const TICK_LEN: f64 = 5.0;
/// Minor tick length.
pub const MINOR_TICK_LEN: f64 = 2.8;
/// Default marker size (diameter of the circumscribed circle).
pub const MARKER_SIZE: f64 = 6.5;

/// An opaque colour.
pub type Rgb = RGBColor;

/// Loading / increasing branch.
pub const RED: Rgb = RGBColor(214, 39, 40);
/// Unloading / decreasing branch.
pub const BLUE: Rgb = RGBColor(31, 100, 180);
/// "At" (e.g. at the critical load).
pub const GREEN: Rgb = RGBColor(44, 160, 44);
/// Text, frames.
pub const BLACK: Rgb = RGBColor(0, 0, 0);
/// Background.
pub const WHITE: Rgb = RGBColor(255, 255, 255);
/// Neutral grey (saddle stars, reference lines).
pub const GREY: Rgb = RGBColor(128, 128, 128);
/// Light grey (legend frame).
pub const LIGHT_GREY: Rgb = RGBColor(190, 190, 190);
/// Dark grey (hard-wall curves, fits).
pub const DARK_GREY: Rgb = RGBColor(60, 60, 60);

/// A qualitative cycle for curves that have no meaning-bound colour.
pub const CYCLE: [Rgb; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(90, 90, 90),
];

/// The three surface models, in the paper's order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Model {
    /// Honeycomb lattice of maxima.
    Hexagonal,
    /// Square lattice.
    Square,
    /// Triangular lattice of maxima.
    Triangular,
}

impl Model {
    /// Hexagonal, square, triangular.
    pub const ALL: [Model; 3] = [Model::Hexagonal, Model::Square, Model::Triangular];

    /// Lower-case name, as in file names and tables.
    pub fn name(self) -> &'static str {
        match self {
            Model::Hexagonal => "hexagonal",
            Model::Square => "square",
            Model::Triangular => "triangular",
        }
    }

    /// Capitalised name for legends and titles.
    pub fn title(self) -> &'static str {
        match self {
            Model::Hexagonal => "Hexagonal",
            Model::Square => "Square",
            Model::Triangular => "Triangular",
        }
    }
}

/// The colour of a model (Okabe–Ito orange, bluish green, reddish purple: distinct from the
/// red/blue branch colours and safe for colour-blind readers).
pub fn model_color(m: Model) -> Rgb {
    match m {
        Model::Hexagonal => RGBColor(230, 140, 0),
        Model::Square => RGBColor(0, 150, 110),
        Model::Triangular => RGBColor(150, 70, 160),
    }
}

/// The marker of a model: its lattice's shape.
pub fn model_marker(m: Model) -> Marker {
    match m {
        Model::Hexagonal => Marker::Hexagon,
        Model::Square => Marker::Square,
        Model::Triangular => Marker::TriangleUp,
    }
}

/// Dash patterns.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Dash {
    /// Continuous line.
    #[default]
    Solid,
    /// Dashes of 4.5 line widths (at least 5 units) with 3.2-unit gaps.
    Dashed,
    /// Round dots.
    Dotted,
    /// Dash, dot.
    DashDot,
    /// Custom on/off lengths in logical units, repeated.
    Custom(f64, f64),
}

/// How a line is stroked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stroke {
    /// Colour.
    pub color: Rgb,
    /// Width in logical units.
    pub width: f64,
    /// Dash pattern.
    pub dash: Dash,
}

impl Stroke {
    /// A solid line of the default width.
    pub fn solid(color: Rgb) -> Self {
        Self {
            color,
            width: LINE_WIDTH,
            dash: Dash::Solid,
        }
    }
    /// A dashed line of the default width.
    pub fn dashed(color: Rgb) -> Self {
        Self {
            color,
            width: LINE_WIDTH,
            dash: Dash::Dashed,
        }
    }
    /// A dotted line of the default width.
    pub fn dotted(color: Rgb) -> Self {
        Self {
            color,
            width: LINE_WIDTH,
            dash: Dash::Dotted,
        }
    }
    /// Same, another width.
    pub fn width(mut self, w: f64) -> Self {
        self.width = w;
        self
    }
    /// Same, another dash.
    pub fn dash(mut self, d: Dash) -> Self {
        self.dash = d;
        self
    }
}

/// Point markers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// ●
    Circle,
    /// ■
    Square,
    /// ◆
    Diamond,
    /// ▲
    TriangleUp,
    /// ▼
    TriangleDown,
    /// ⬢ (pointy top)
    Hexagon,
    /// ★ (five points)
    Star,
    /// ×
    Cross,
    /// +
    Plus,
}

/// How a marker is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerStyle {
    /// Shape.
    pub marker: Marker,
    /// Diameter of the circumscribed circle (logical units).
    pub size: f64,
    /// Fill colour; `None` draws an open marker (white inside).
    pub fill: Option<Rgb>,
    /// Edge colour.
    pub edge: Rgb,
}

impl MarkerStyle {
    /// Filled marker of the default size, edge in the same colour.
    pub fn filled(marker: Marker, color: Rgb) -> Self {
        Self {
            marker,
            size: MARKER_SIZE,
            fill: Some(color),
            edge: color,
        }
    }
    /// Open marker (white inside) of the default size.
    pub fn open(marker: Marker, color: Rgb) -> Self {
        Self {
            marker,
            size: MARKER_SIZE,
            fill: None,
            edge: color,
        }
    }
    /// Same, another size.
    pub fn size(mut self, size: f64) -> Self {
        self.size = size;
        self
    }
}

/// Linear interpolation between two colours (t = 0 gives `a`).
pub fn mix(a: Rgb, b: Rgb, t: f64) -> Rgb {
    let t = t.clamp(0.0, 1.0);
    let f = |x: u8, y: u8| (x as f64 + (y as f64 - x as f64) * t).round() as u8;
    RGBColor(f(a.0, b.0), f(a.1, b.1), f(a.2, b.2))
}
