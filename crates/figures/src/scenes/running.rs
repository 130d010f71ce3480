//! The running-exponent figure: one panel per exponent (ζ, υ, χ, β in a 2 × 2 grid), the local
//! slope between neighbouring ladder rungs against |l| (log axis, the pair's geometric mean),
//! one colour and marker per model (the refined ladder's pairs: diamonds in the model's colour,
//! joined by a dashed line; a deeper refined ladder's, chained below it: diamonds joined by a
//! dotted line, "(deep)" in the legend; the pairs from the neck's gap field (υ: rms width, χ:
//! rise length, from below; `neck` curves): stars in the model's colour joined by a
//! dash-dotted line, "(neck)" or "(neck, deep)" in the legend), error bars grid error ⊕ fit
//! error, flagged pairs (grid error above the bound or unknown) drawn hollow, the paper's value as a grey band (its error;
//! a dashed line when it gives none) and the conjecture as a dotted black line.

use std::path::{Path, PathBuf};

use anyhow::{Result, ensure};

use crate::axes::Axis;
use crate::canvas::Rect;
use crate::figure::Figure;
use crate::style::{
    BLACK, COLUMN_WIDTH, Dash, GREY, LIGHT_GREY, Marker, MarkerStyle, Model, Stroke, model_color,
    model_marker,
};
use crate::xy::{Annotation, LegendPos, Series, XyPanel};

/// One running exponent: a pair of rungs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunningPoint {
    /// Geometric mean of the pair's |l|.
    pub l_mid: f64,
    /// Local slope.
    pub value: f64,
    /// 1σ drawn as the error bar (grid ⊕ fit).
    pub error: f64,
    /// Not to be used silently: drawn hollow.
    pub flagged: bool,
}

/// One model's running exponents of one panel (from one ladder: uniform or refined).
#[derive(Debug, Clone, PartialEq)]
pub struct RunningCurve {
    /// The model.
    pub model: Model,
    /// From the refined ladder: diamonds and a dashed line instead of the model's marker.
    pub refined: bool,
    /// From a deeper refined ladder (the pipeline's `refined_deep_*`, chained below the refined
    /// one): diamonds too (with `refined`), a dotted line, "(deep)" in the legend.
    pub deep: bool,
    /// From the neck's gap field (rms width, rise length) instead of the contact line: stars
    /// and a dash-dotted line, "(neck)" in the legend (with `deep`: "(neck, deep)").
    pub neck: bool,
    /// Its pairs (any order; drawn by ascending |l|).
    pub points: Vec<RunningPoint>,
}

/// One exponent's panel.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunningPanel {
    /// y label (rich text), e.g. "local slope ζ_eff".
    pub label: String,
    /// The paper's value and error (error NaN: a line, value NaN: nothing).
    pub paper: (f64, f64),
    /// The conjecture and its label (e.g. "6/5").
    pub conjecture: Option<(f64, String)>,
    /// The models.
    pub curves: Vec<RunningCurve>,
}

/// Data of the running-exponent figure.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunningData {
    /// The panels, drawn row by row, two per row, tagged (a), (b), ...
    pub panels: Vec<RunningPanel>,
}

/// One panel; `neck_labels_only`: label only the neck curves (the panel that carries their
/// legend, [`figure`]).
fn panel(d: &RunningPanel, x_range: (f64, f64), neck_labels_only: bool) -> XyPanel {
    // y range: every value, the paper's band and the conjecture, 8 % margin; error bars may
    // leave it (flagged pairs can carry huge ones that would squash the rest)
    let mut ys: Vec<f64> = d
        .curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.value))
        .collect();
    ys.extend([d.paper.0 - d.paper.1, d.paper.0 + d.paper.1, d.paper.0]);
    ys.extend(d.conjecture.as_ref().map(|c| c.0));
    ys.retain(|y| y.is_finite());
    let (y_lo, y_hi) = ys.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &y| {
        (a.0.min(y), a.1.max(y))
    });
    let pad = 0.08 * (y_hi - y_lo).max(0.02);
    let y_axis = if ys.is_empty() {
        Axis::linear(&d.label)
    } else {
        Axis::linear(&d.label).range(y_lo - pad, y_hi + pad)
    };
    let mut p = XyPanel::new(Axis::log("|$l$|").range(x_range.0, x_range.1), y_axis);
    let (pv, pe) = d.paper;
    if pv.is_finite() {
        let x = vec![x_range.0, x_range.1];
        let line = Series::line(x.clone(), vec![pv; 2], Stroke::dashed(GREY).width(1.0));
        let line = if pe.is_finite() {
            line.band(vec![pv - pe; 2], vec![pv + pe; 2])
        } else {
            line
        };
        p.series.push(if neck_labels_only {
            line
        } else {
            line.label("paper")
        });
    }
    if let Some((v, label)) = &d.conjecture {
        p.annotations.push(Annotation::HLine {
            y: *v,
            stroke: Stroke::dotted(BLACK).width(1.1),
            label: Some(label.clone()),
        });
    }
    for c in &d.curves {
        let mut pts = c.points.clone();
        pts.sort_by(|a, b| a.l_mid.total_cmp(&b.l_mid));
        let col = model_color(c.model);
        let m = if c.neck {
            Marker::Star
        } else if c.refined {
            Marker::Diamond
        } else {
            model_marker(c.model)
        };
        let (x, y): (Vec<f64>, Vec<f64>) = pts.iter().map(|p| (p.l_mid, p.value)).unzip();
        let line_col = crate::style::mix(col, LIGHT_GREY, 0.4);
        p.series.push(Series::line(
            x,
            y,
            if c.neck {
                Stroke::solid(line_col).dash(Dash::DashDot).width(0.8)
            } else if c.deep {
                Stroke::dotted(line_col).width(0.8)
            } else if c.refined {
                Stroke::dashed(line_col).width(0.8)
            } else {
                Stroke::solid(line_col).width(0.8)
            },
        ));
        for flagged in [false, true] {
            let sel: Vec<&RunningPoint> = pts.iter().filter(|p| p.flagged == flagged).collect();
            let style = if flagged {
                MarkerStyle::open(m, col)
            } else {
                MarkerStyle::filled(m, col)
            };
            let mut s = Series::points(
                sel.iter().map(|p| p.l_mid).collect(),
                sel.iter().map(|p| p.value).collect(),
                style.size(5.0),
            )
            .y_err(sel.iter().map(|p| p.error).collect());
            if !flagged && (c.neck || !neck_labels_only) {
                s = s.label(&if c.neck {
                    format!(
                        "{} (neck{})",
                        c.model.title(),
                        if c.deep { ", deep" } else { "" }
                    )
                } else if c.deep {
                    format!("{} (deep)", c.model.title())
                } else if c.refined {
                    format!("{} (refined)", c.model.title())
                } else {
                    c.model.title().to_string()
                });
            }
            p.series.push(s);
        }
    }
    p.legend = LegendPos::None;
    p
}

/// Builds the figure (two columns wide, one row per two panels). The legend (models, paper) is
/// in the first panel; that of the neck curves (stars) in the last panel that has them, bottom
/// left, with only their entries; hollow markers are explained in the caption (module docs). The |l| axis
/// spans the points, or 1e-5 … 5e-2 (the ladder) when there are none.
pub fn figure(d: &RunningData) -> Result<Figure> {
    ensure!(!d.panels.is_empty(), "running-exponent figure: no panels");
    let all: Vec<f64> = d
        .panels
        .iter()
        .flat_map(|p| p.curves.iter())
        .flat_map(|c| c.points.iter().map(|p| p.l_mid))
        .filter(|x| x.is_finite() && *x > 0.0)
        .collect();
    // no points at all (e.g. grids too coarse for any measurement): empty panels over the
    // issue's ladder 1e-5 … 5e-2
    let (lo, hi) = if all.is_empty() {
        (1e-5, 5e-2)
    } else {
        (
            all.iter().copied().fold(f64::INFINITY, f64::min),
            all.iter().copied().fold(0.0, f64::max),
        )
    };
    let x_range = (lo / 1.6, hi * 1.6);
    let neck_panel = d
        .panels
        .iter()
        .rposition(|p| p.curves.iter().any(|c| c.neck));
    let n_rows = d.panels.len().div_ceil(2);
    let (w, h, gap) = (2.0 * COLUMN_WIDTH, 300.0, 10.0);
    let total = h * n_rows as f64 + gap * (n_rows - 1) as f64;
    let mut f = Figure::new(w, total);
    let rows = Rect::new(0.0, 0.0, w, total).rows(&vec![1.0; n_rows], gap);
    for (k, d) in d.panels.iter().enumerate() {
        for c in &d.curves {
            ensure!(
                c.points.iter().all(|p| p.l_mid > 0.0),
                "running-exponent figure ({}): |l| must be > 0",
                c.model.name()
            );
        }
        let cell = rows[k / 2].columns(&[1.0, 1.0], gap)[k % 2];
        let neck_legend = k > 0 && Some(k) == neck_panel;
        let mut p = panel(d, x_range, neck_legend);
        p.tag = Some(format!("({})", (b'a' + k as u8) as char));
        if k == 0 {
            p.legend = LegendPos::BottomRight;
        } else if neck_legend {
            p.legend = LegendPos::BottomLeft;
        }
        f.xy(cell, p);
    }
    Ok(f)
}

/// Renders the figure to `<out_stem>.png` and `.svg`.
pub fn render(d: &RunningData, out_stem: &Path) -> Result<Vec<PathBuf>> {
    figure(d)?.render(out_stem)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data() -> RunningData {
        let pt = |l: f64, v: f64, flagged: bool| RunningPoint {
            l_mid: l,
            value: v,
            error: 0.01,
            flagged,
        };
        RunningData {
            panels: vec![
                RunningPanel {
                    label: "$ζ$_eff".into(),
                    paper: (1.2, 0.01),
                    conjecture: Some((1.2, "6/5".into())),
                    curves: vec![
                        RunningCurve {
                            model: Model::Square,
                            refined: false,
                            deep: false,
                            neck: false,
                            points: vec![pt(0.03, 1.22, false), pt(1e-3, 1.18, true)],
                        },
                        RunningCurve {
                            model: Model::Square,
                            refined: true,
                            deep: false,
                            neck: false,
                            points: vec![pt(2e-4, 1.165, false), pt(1.4e-5, 1.155, true)],
                        },
                        RunningCurve {
                            model: Model::Square,
                            refined: true,
                            deep: true,
                            neck: false,
                            points: vec![pt(3e-5, 1.154, false), pt(1.4e-5, 1.153, false)],
                        },
                        RunningCurve {
                            model: Model::Square,
                            refined: true,
                            deep: true,
                            neck: true,
                            points: vec![pt(3e-5, 1.156, false), pt(1.4e-5, 1.157, true)],
                        },
                    ],
                },
                RunningPanel {
                    label: "$β$_eff".into(),
                    paper: (3.45, f64::NAN),
                    conjecture: None,
                    curves: vec![],
                },
            ],
        }
    }

    #[test]
    fn renders_png_and_svg_and_rejects_empty_data() {
        let dir = tempfile::tempdir().unwrap();
        let paths = render(&data(), &dir.path().join("running")).unwrap();
        assert_eq!(paths.len(), 2);
        for p in &paths {
            assert!(std::fs::metadata(p).unwrap().len() > 1000, "{p:?}");
        }
        assert!(figure(&RunningData::default()).is_err());
        // panels without points still draw (a scene must render every declared output)
        let mut empty = data();
        empty.panels[0].curves.clear();
        assert!(figure(&empty).is_ok());
        let mut bad = data();
        bad.panels[0].curves[0].points[0].l_mid = 0.0;
        assert!(figure(&bad).is_err());
    }
}
