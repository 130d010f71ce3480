//! Figure 2: relative contact area against mean pressure for the square model, with hard-wall
//! repulsion, exponential adhesion and Gaussian repulsion; loading branches red, unloading
//! blue, arrows along each branch in the direction it was traversed. Adhesion is drawn solid,
//! repulsion dashed, the hard wall dash-dotted; detected jumps are marked with open circles.

use std::path::{Path, PathBuf};

use anyhow::{Result, ensure};

use crate::axes::Axis;
use crate::canvas::{HAlign, Rect, VAlign};
use crate::figure::Figure;
use crate::style::{BLUE, COLUMN_WIDTH, DARK_GREY, Dash, GREY, Marker, MarkerStyle, RED, Stroke};
use crate::xy::{Annotation, LegendEntry, LegendPos, Series, XyPanel};

/// One quasi-static branch of a load path, points in the order they were computed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Branch {
    /// Mean pressure p̄ = L/(Lx Ly) at each step (E* h0/λ).
    pub pressure: Vec<f64>,
    /// Relative contact area at each step (dimensionless, 0..1).
    pub area: Vec<f64>,
    /// Detected jumps: index i means the state jumped between points i and i + 1.
    pub jumps: Vec<usize>,
}

impl Branch {
    fn validate(&self, what: &str) -> Result<()> {
        ensure!(
            self.pressure.len() == self.area.len(),
            "{what}: {} pressures but {} areas",
            self.pressure.len(),
            self.area.len()
        );
        for &j in &self.jumps {
            ensure!(
                j + 1 < self.area.len(),
                "{what}: jump index {j} out of range"
            );
        }
        Ok(())
    }
}

/// Loading and unloading branches of one interaction.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LoadLoop {
    /// Increasing load (drawn red).
    pub loading: Branch,
    /// Decreasing load (drawn blue).
    pub unloading: Branch,
}

/// Data of Figure 2.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Fig2Data {
    /// Hard-wall repulsion only (no hysteresis expected).
    pub hard_wall: LoadLoop,
    /// Exponential adhesion γ(g) = −γ0 exp(−g/ρ).
    pub adhesion: LoadLoop,
    /// Gaussian repulsion γ(g) = γr exp(−g²/2ρ²).
    pub repulsion: LoadLoop,
    /// Legend text for the adhesion curves (rich text), e.g. "adhesion, $γ$_0 = 0.2";
    /// empty for the default.
    pub adhesion_label: String,
    /// Legend text for the repulsion curves; empty for the default.
    pub repulsion_label: String,
    /// Full-contact pressure p_fc (E* h0/λ), drawn as a vertical reference line if given.
    pub p_fc: Option<f64>,
    /// Percolation contact area a_p, drawn as a horizontal reference line if given.
    pub a_p: Option<f64>,
    /// Logarithmic area axis (10⁻³ … 1; zero areas are not drawn): shows the small-area
    /// hysteresis of contact formation.
    pub log_area: bool,
    /// Pressure range shown; `None` fits the data.
    pub pressure_range: Option<(f64, f64)>,
}

/// Line style of each interaction.
pub const HARD_WALL_DASH: Dash = Dash::DashDot;
/// Adhesion: solid.
pub const ADHESION_DASH: Dash = Dash::Solid;
/// Repulsion: dashed.
pub const REPULSION_DASH: Dash = Dash::Dashed;

fn branch_series(b: &Branch, color: crate::style::Rgb, dash: Dash, width: f64) -> Vec<Series> {
    let mut v = vec![
        Series::line(
            b.pressure.clone(),
            b.area.clone(),
            Stroke::solid(color).dash(dash).width(width),
        )
        .arrows(if b.pressure.len() >= 2 { 2 } else { 0 }),
    ];
    if !b.jumps.is_empty() {
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for &j in &b.jumps {
            x.extend([b.pressure[j], b.pressure[j + 1]]);
            y.extend([b.area[j], b.area[j + 1]]);
        }
        v.push(Series::points(
            x,
            y,
            MarkerStyle::open(Marker::Circle, color).size(5.5),
        ));
    }
    v
}

/// Builds Figure 2 (one column, 480 × 360 logical units).
pub fn figure(d: &Fig2Data) -> Result<Figure> {
    for (name, l) in [
        ("hard wall", &d.hard_wall),
        ("adhesion", &d.adhesion),
        ("repulsion", &d.repulsion),
    ] {
        l.loading.validate(&format!("{name} loading"))?;
        l.unloading.validate(&format!("{name} unloading"))?;
    }
    let mut x = Axis::linear("mean pressure $p$ / ($E$^*$h$_0/$λ$)");
    x.range = d.pressure_range;
    let y = if d.log_area {
        Axis::log("relative contact area $a$").range(1e-3, 1.3)
    } else {
        Axis::linear("relative contact area $a$").range(0.0, 1.02)
    };
    let mut p = XyPanel::new(x, y);
    // hard wall first (underneath), thinner; unloading before loading so red stays visible
    for (l, dash, w) in [
        (&d.hard_wall, HARD_WALL_DASH, 1.3),
        (&d.repulsion, REPULSION_DASH, 1.5),
        (&d.adhesion, ADHESION_DASH, 1.5),
    ] {
        p.series.extend(branch_series(&l.unloading, BLUE, dash, w));
        p.series.extend(branch_series(&l.loading, RED, dash, w));
    }
    if let Some(pfc) = d.p_fc {
        p.annotations.push(Annotation::VLine {
            x: pfc,
            stroke: Stroke::dotted(GREY).width(1.0),
            label: None,
        });
        p.annotations.push(Annotation::Text {
            at: (pfc, if d.log_area { 0.1 } else { 0.6 }),
            text: "$p$_{fc} ".into(),
            h: HAlign::Right,
            v: VAlign::Bottom,
            color: GREY,
        });
    }
    if let Some(ap) = d.a_p {
        p.annotations.push(Annotation::HLine {
            y: ap,
            stroke: Stroke::dotted(GREY).width(1.0),
            label: Some("$a$_p".into()),
        });
    }
    let lab = |s: &str, default: &str| {
        if s.is_empty() {
            default.to_string()
        } else {
            s.to_string()
        }
    };
    p.legend = LegendPos::BottomRight;
    p.legend_extra = vec![
        LegendEntry {
            label: "loading".into(),
            stroke: Some(Stroke::solid(RED)),
            marker: None,
        },
        LegendEntry {
            label: "unloading".into(),
            stroke: Some(Stroke::solid(BLUE)),
            marker: None,
        },
        LegendEntry {
            label: "hard wall".into(),
            stroke: Some(Stroke::solid(DARK_GREY).dash(HARD_WALL_DASH).width(1.3)),
            marker: None,
        },
        LegendEntry {
            label: lab(&d.adhesion_label, "exponential adhesion"),
            stroke: Some(Stroke::solid(DARK_GREY).dash(ADHESION_DASH)),
            marker: None,
        },
        LegendEntry {
            label: lab(&d.repulsion_label, "Gaussian repulsion"),
            stroke: Some(Stroke::solid(DARK_GREY).dash(REPULSION_DASH)),
            marker: None,
        },
    ];
    let has_jumps = [&d.hard_wall, &d.adhesion, &d.repulsion]
        .iter()
        .any(|l| !l.loading.jumps.is_empty() || !l.unloading.jumps.is_empty());
    if has_jumps {
        p.legend_extra.push(LegendEntry {
            label: "jump".into(),
            stroke: None,
            marker: Some(MarkerStyle::open(Marker::Circle, DARK_GREY).size(5.5)),
        });
    }
    let mut f = Figure::new(COLUMN_WIDTH, 360.0);
    f.xy(Rect::new(0.0, 0.0, COLUMN_WIDTH, 360.0), p);
    Ok(f)
}

/// Renders Figure 2 to `<out_stem>.png` and `<out_stem>.svg`.
pub fn render(d: &Fig2Data, out_stem: &Path) -> Result<Vec<PathBuf>> {
    figure(d)?.render(out_stem)
}
