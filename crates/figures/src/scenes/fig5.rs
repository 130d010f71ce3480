//! Figure 5: (a) contact-line shapes near the saddle below (blue), at (green) and above (red)
//! the critical load, collapsed by the scaling; (b) the gap on the symmetry axis against the
//! distance from the saddle, rescaled, one marker shape per model and one colour per reduced
//! load l (open markers: uniform grids; filled: locally refined discretisations, optional);
//! analytic approximations as black lines.

use std::path::{Path, PathBuf};

use anyhow::{Result, ensure};

use crate::axes::Axis;
use crate::canvas::Rect;
use crate::figure::Figure;
use crate::style::{BLACK, BLUE, GREEN, MarkerStyle, Model, RED, Rgb, Stroke, mix, model_marker};
use crate::xy::{LegendEntry, LegendPos, Series, XyPanel};

/// One contact line (the boundary of a contact patch near the saddle point).
#[derive(Debug, Clone, PartialEq)]
pub struct ContactLine {
    /// Reduced load l = (L − L_c)/L_c (sets the colour by its sign; 0 is "at").
    pub l: f64,
    /// Points along the line in rescaled coordinates (x/|l|^χ, y/|l|^υ; or plain λ units
    /// at l = 0), NaN separates pieces.
    pub points: Vec<(f64, f64)>,
}

/// Gap along the symmetry axis for one model and one reduced load.
#[derive(Debug, Clone, PartialEq)]
pub struct GapProfile {
    /// Model (sets the marker).
    pub model: Model,
    /// Reduced load l (sets the colour).
    pub l: f64,
    /// Rescaled distance from the saddle point.
    pub distance: Vec<f64>,
    /// Rescaled gap.
    pub gap: Vec<f64>,
}

/// Data of Figure 5.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Fig5Data {
    /// Panel (a) curves.
    pub contact_lines: Vec<ContactLine>,
    /// Panel (a) analytic approximations (black lines).
    pub contact_analytic: Vec<Vec<(f64, f64)>>,
    /// Panel (a) axis labels (rich text); empty for defaults.
    pub contact_axes: (String, String),
    /// Panel (b) data.
    pub profiles: Vec<GapProfile>,
    /// Panel (b) data from locally refined discretisations (filled markers; empty: none).
    pub refined_profiles: Vec<GapProfile>,
    /// Panel (b) analytic curves (black lines), as (distance, gap) points.
    pub gap_analytic: Vec<Vec<(f64, f64)>>,
    /// Panel (b) axis labels (rich text); empty for defaults.
    pub gap_axes: (String, String),
}

/// Colour of a contact line by the sign of l.
pub fn sign_color(l: f64) -> Rgb {
    if l < 0.0 {
        BLUE
    } else if l > 0.0 {
        RED
    } else {
        GREEN
    }
}

/// Colour of reduced load `l` among the distinct values `all` (sorted): blues for l < 0
/// (darker for larger |l|), reds for l > 0, green for 0.
pub fn load_color(l: f64, all: &[f64]) -> Rgb {
    let same_sign: Vec<f64> = all
        .iter()
        .copied()
        .filter(|v| v.signum() == l.signum() && *v != 0.0)
        .collect();
    if l == 0.0 {
        return GREEN;
    }
    let rank = same_sign.iter().filter(|v| v.abs() < l.abs()).count();
    let t = if same_sign.len() > 1 {
        rank as f64 / (same_sign.len() - 1) as f64
    } else {
        1.0
    };
    let base = if l < 0.0 { BLUE } else { RED };
    // from light to full colour
    mix(
        mix(base, crate::style::WHITE, 0.6),
        mix(base, BLACK, 0.25),
        t,
    )
}

fn fmt_l(l: f64) -> String {
    format!(
        "$l$ = {}",
        crate::text::fmt_num(l, if l.abs() < 0.01 { 3 } else { 2 })
    )
}

fn or<'a>(s: &'a str, d: &'a str) -> &'a str {
    if s.is_empty() { d } else { s }
}

/// Builds Figure 5 (two panels side by side).
pub fn figure(d: &Fig5Data) -> Result<Figure> {
    for p in d.profiles.iter().chain(&d.refined_profiles) {
        ensure!(
            p.distance.len() == p.gap.len(),
            "gap profile ({}, l = {}): lengths differ",
            p.model.name(),
            p.l
        );
    }
    // (a)
    let mut a = XyPanel::new(
        Axis::linear(or(&d.contact_axes.0, "$x$ / |$l$|^{$χ$}")),
        Axis::linear(or(&d.contact_axes.1, "$y$ / |$l$|^{$υ$}")),
    );
    for pts in &d.contact_analytic {
        let (x, y) = pts.iter().copied().unzip();
        a.series
            .push(Series::line(x, y, Stroke::solid(BLACK).width(1.0)));
    }
    let mut seen = [false; 3];
    for cl in &d.contact_lines {
        let (x, y) = cl.points.iter().copied().unzip();
        let col = sign_color(cl.l);
        let mut s = Series::line(x, y, Stroke::solid(col).width(1.4));
        let k = if cl.l < 0.0 {
            0
        } else if cl.l == 0.0 {
            1
        } else {
            2
        };
        if !seen[k] {
            seen[k] = true;
            s = s.label(["$L$ < $L$_c", "$L$ = $L$_c", "$L$ > $L$_c"][k]);
        }
        a.series.push(s);
    }
    a.legend = LegendPos::TopCenter;
    a.tag = Some("(a)".into());

    // (b)
    let mut ls: Vec<f64> = d
        .profiles
        .iter()
        .chain(&d.refined_profiles)
        .map(|p| p.l)
        .collect();
    ls.sort_by(f64::total_cmp);
    ls.dedup();
    let mut b = XyPanel::new(
        Axis::linear(or(&d.gap_axes.0, "distance / |$l$|^{$χ$}")),
        Axis::linear(or(&d.gap_axes.1, "$g$ / |$l$|^{$ζ$}")),
    );
    for pts in &d.gap_analytic {
        let (x, y) = pts.iter().copied().unzip();
        b.series
            .push(Series::line(x, y, Stroke::solid(BLACK).width(1.0)));
    }
    let mut models: Vec<Model> = Vec::new();
    for p in &d.profiles {
        let col = load_color(p.l, &ls);
        b.series.push(Series::points(
            p.distance.clone(),
            p.gap.clone(),
            MarkerStyle::open(model_marker(p.model), col).size(5.0),
        ));
        if !models.contains(&p.model) {
            models.push(p.model);
        }
    }
    for p in &d.refined_profiles {
        let col = load_color(p.l, &ls);
        b.series.push(Series::points(
            p.distance.clone(),
            p.gap.clone(),
            MarkerStyle::filled(model_marker(p.model), col).size(4.0),
        ));
        if !models.contains(&p.model) {
            models.push(p.model);
        }
    }
    models.sort_by_key(|m| Model::ALL.iter().position(|x| x == m));
    if !d.refined_profiles.is_empty() {
        b.legend_extra.push(LegendEntry {
            label: "filled: refined".into(),
            stroke: None,
            marker: Some(MarkerStyle::filled(crate::style::Marker::Circle, BLACK).size(5.0)),
        });
    }
    for m in models {
        b.legend_extra.push(LegendEntry {
            label: m.name().into(),
            stroke: None,
            marker: Some(MarkerStyle::open(model_marker(m), BLACK).size(6.0)),
        });
    }
    for &l in &ls {
        b.legend_extra.push(LegendEntry {
            label: fmt_l(l),
            stroke: None,
            marker: Some(
                MarkerStyle::filled(crate::style::Marker::Square, load_color(l, &ls)).size(6.0),
            ),
        });
    }
    b.legend = LegendPos::TopLeft;
    b.legend_columns = if b.legend_extra.len() > 6 { 2 } else { 1 };
    b.tag = Some("(b)".into());

    let (w, h) = (900.0, 380.0);
    let cols = Rect::new(0.0, 0.0, w, h).columns(&[1.0, 1.0], 14.0);
    let mut f = Figure::new(w, h);
    f.xy(cols[0], a);
    f.xy(cols[1], b);
    Ok(f)
}

/// Renders Figure 5 to `<out_stem>.png` and `.svg`.
pub fn render(d: &Fig5Data, out_stem: &Path) -> Result<Vec<PathBuf>> {
    figure(d)?.render(out_stem)
}
