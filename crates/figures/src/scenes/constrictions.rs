//! Figures of the last constriction on random surfaces (scene `random_constrictions`, issue
//! 15): the gap map just below L_c with the constriction marked and a zoom on it; the flux
//! against the distance d = (L_c − L)/L_c (log–log) for all realisations beside the three
//! lattices' own ladder flux, every curve normalised at its value at d = 5e-2 ([`D_REF`]; at its
//! largest d if it has none), with the paper's β = 3.45 and the one-node value 3 as reference
//! slopes; β against η of the constriction; a_p against the Hurst exponent.
//!
//! Realisations come in groups (one per surface spectrum: H, q_s), coloured alike.
//!
//! Units: lengths along the surface in the cell's units, gaps in the height unit.

use anyhow::{Result, ensure};
use ndarray::Array2;

use super::leakage::{gap_panel, single_panel};
use crate::axes::Axis;
use crate::canvas::Rect;
use crate::figure::Figure;
use crate::heatmap::Overlay;
use crate::style::{
    BLACK, CYCLE, GREY, Marker, MarkerStyle, Model, RED, Stroke, model_color, model_marker,
};
use crate::xy::{Annotation, LegendPos, Series, XyPanel};

/// The paper's β of an isolated saddle (Dapp & Müser 2015).
pub const PAPER_BETA: f64 = 3.45;

/// The distance at which every flux curve is normalised (the largest rung of every ladder but
/// the smoke preset's lattices').
pub const D_REF: f64 = 5e-2;

/// The gap map just below L_c.
#[derive(Debug, Clone, PartialEq)]
pub struct MapFig {
    /// Gap, shape (nx, ny); contact where ≤ 0 (white).
    pub gap: Array2<f64>,
    /// Cell size.
    pub lx: f64,
    /// Cell size.
    pub ly: f64,
    /// The constriction's position.
    pub at: (f64, f64),
    /// Half-size of the zoom (cell units).
    pub zoom: f64,
    /// Title (seed, L_c, η).
    pub title: String,
}

/// One realisation's flux ladder.
#[derive(Debug, Clone, PartialEq)]
pub struct FluxCurve {
    /// Index into [`FluxFig::groups`].
    pub group: usize,
    /// Distances d, descending.
    pub d: Vec<f64>,
    /// Flux (any unit; normalised in the figure).
    pub flux: Vec<f64>,
    /// The rung was used in the fits.
    pub resolved: Vec<bool>,
}

/// One lattice's ladder flux below L_c (the finest grid of its `ladder` stage).
#[derive(Debug, Clone, PartialEq)]
pub struct LatticeCurve {
    /// The model.
    pub model: Model,
    /// Distances d = −l > 0.
    pub d: Vec<f64>,
    /// Flux along the saddle's channel.
    pub flux: Vec<f64>,
}

/// The flux figure's data.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FluxFig {
    /// Group labels (rich text), e.g. "$H$ = 0.8, $q$_s = 8".
    pub groups: Vec<String>,
    /// Every realisation.
    pub curves: Vec<FluxCurve>,
    /// The lattices' ladders (may be empty).
    pub lattices: Vec<LatticeCurve>,
}

/// β against η.
#[derive(Debug, Clone, PartialEq)]
pub struct BetaEtaFig {
    /// Group labels.
    pub groups: Vec<String>,
    /// Group of each realisation.
    pub group: Vec<usize>,
    /// η of the heights at the constriction.
    pub eta: Vec<f64>,
    /// β (a fit per realisation).
    pub beta: Vec<f64>,
    /// Its 1σ (NaN: none).
    pub beta_err: Vec<f64>,
    /// The y axis' label (which fit).
    pub beta_label: String,
}

/// a_p against H, one series per q_s.
#[derive(Debug, Clone, PartialEq)]
pub struct ApSeries {
    /// Label, e.g. "$q$_s = 8".
    pub label: String,
    /// Hurst exponents, ascending.
    pub hurst: Vec<f64>,
    /// Mean a_p at each.
    pub mean: Vec<f64>,
    /// Its standard error.
    pub sem: Vec<f64>,
    /// Every realisation: (H, a_p).
    pub points: Vec<(f64, f64)>,
}

/// The colour of group `k`.
pub fn group_color(k: usize) -> crate::style::Rgb {
    CYCLE[k % CYCLE.len()]
}

/// A normalised point: its index in the curve, d, flux / flux(d_ref).
pub type NormPoint = (usize, f64, f64);

/// `(index, d, flux / flux(d_ref))` of the positive finite points, and the d used as
/// reference: [`D_REF`] if the curve has it (to 1e-9 relative), else its largest d.
pub fn normalise(d: &[f64], flux: &[f64]) -> Option<(Vec<NormPoint>, f64)> {
    let ok: Vec<usize> = (0..d.len().min(flux.len()))
        .filter(|&i| flux[i] > 0.0 && flux[i].is_finite() && d[i] > 0.0)
        .collect();
    let k0 = ok
        .iter()
        .copied()
        .find(|&i| (d[i] / D_REF - 1.0).abs() < 1e-9)
        .or_else(|| ok.iter().copied().max_by(|&a, &b| d[a].total_cmp(&d[b])))?;
    let q0 = flux[k0];
    Some((ok.iter().map(|&i| (i, d[i], flux[i] / q0)).collect(), d[k0]))
}

/// Full map (a) and the zoom on the constriction (b), the constriction marked.
pub fn map_figure(d: &MapFig) -> Result<Figure> {
    ensure!(d.zoom > 0.0, "zoom {} must be > 0", d.zoom);
    let (w, h) = (860.0, 420.0);
    let cols = Rect::new(0.0, 0.0, w, h).columns(&[1.0, 1.0], 16.0);
    let mut f = Figure::new(w, h);
    let marker = Overlay::Points {
        points: vec![d.at],
        style: MarkerStyle::open(Marker::Circle, RED),
    };
    let panel = |view: Option<(f64, f64, f64, f64)>, tag: &str| {
        let mut m = gap_panel(&d.gap, d.lx, d.ly);
        m.view = view;
        m.tile_overlays = true;
        m.overlays.push(marker.clone());
        m.tag = Some(tag.into());
        m
    };
    let mut a = panel(None, "(a)");
    a.title = Some(d.title.clone());
    f.heatmap(cols[0], a);
    let z = d.zoom;
    let mut b = panel(
        Some((d.at.0 - z, d.at.0 + z, d.at.1 - z, d.at.1 + z)),
        "(b)",
    );
    b.log = true;
    b.colorbar_label = "gap $g$ (log)".into();
    f.heatmap(cols[1], b);
    Ok(f)
}

/// Flux / flux at [`D_REF`] against d (log–log): every realisation (thin lines in its group's
/// colour, resolved rungs filled), the lattices' ladders (thick, their markers), reference
/// slopes.
pub fn flux_figure(d: &FluxFig) -> Result<Figure> {
    let mut p = XyPanel::new(
        Axis::log("$d$ = ($L$_c − $L$)/$L$_c"),
        Axis::log("flux / flux($d$ = 0.05)"),
    );
    let (mut dmin, mut dmax) = (f64::INFINITY, 0.0f64);
    let mut labelled = vec![false; d.groups.len()];
    for (k, c) in d.curves.iter().enumerate() {
        ensure!(
            c.d.len() == c.flux.len() && c.d.len() == c.resolved.len(),
            "realisation {k}: {} distances, {} fluxes, {} flags",
            c.d.len(),
            c.flux.len(),
            c.resolved.len()
        );
        ensure!(
            c.group < d.groups.len(),
            "realisation {k}: group {} of {}",
            c.group,
            d.groups.len()
        );
        let Some((pts, _)) = normalise(&c.d, &c.flux) else {
            continue;
        };
        for &(_, x, _) in &pts {
            dmin = dmin.min(x);
            dmax = dmax.max(x);
        }
        let color = group_color(c.group);
        let (x, y): (Vec<f64>, Vec<f64>) = pts.iter().map(|p| (p.1, p.2)).unzip();
        let mut line = Series::line(x, y, Stroke::solid(color).width(0.7));
        if !labelled[c.group] {
            line = line.label(&d.groups[c.group]);
            labelled[c.group] = true;
        }
        p.series.push(line);
        let (xr, yr): (Vec<f64>, Vec<f64>) = pts
            .iter()
            .filter(|p| c.resolved[p.0])
            .map(|p| (p.1, p.2))
            .unzip();
        if !xr.is_empty() {
            p.series.push(Series::points(
                xr,
                yr,
                MarkerStyle::filled(Marker::Circle, color).size(3.5),
            ));
        }
    }
    for l in &d.lattices {
        ensure!(
            l.d.len() == l.flux.len(),
            "{}: {} distances, {} fluxes",
            l.model.name(),
            l.d.len(),
            l.flux.len()
        );
        let Some((pts, d0)) = normalise(&l.d, &l.flux) else {
            continue;
        };
        let (x, y): (Vec<f64>, Vec<f64>) = pts.iter().map(|p| (p.1, p.2)).unzip();
        let color = model_color(l.model);
        let note = if (d0 / D_REF - 1.0).abs() < 1e-9 {
            String::new()
        } else {
            format!(" (at $d$ = {d0})")
        };
        p.series.push(
            Series::line(x, y, Stroke::dashed(color).width(2.2))
                .marker(MarkerStyle::open(model_marker(l.model), color))
                .label(&format!("{} lattice{note}", l.model.title())),
        );
    }
    if dmax > dmin {
        p.annotations.push(Annotation::PowerLaw {
            x_range: (dmin, dmax),
            through: (dmax, 3.0),
            exponent: PAPER_BETA,
            stroke: Stroke::dashed(BLACK),
            label: Some(format!("paper β = {PAPER_BETA}")),
        });
        p.annotations.push(Annotation::PowerLaw {
            x_range: (dmin, dmax),
            through: (dmax, 0.3),
            exponent: 3.0,
            stroke: Stroke::dotted(GREY),
            label: Some("one-node throat: 3".into()),
        });
    }
    Ok(single_panel(600.0, 460.0, p, LegendPos::BottomRight))
}

/// β (1σ bars) against η of the constriction's heights, one colour per group, the
/// paper's β marked.
pub fn beta_eta_figure(d: &BetaEtaFig) -> Result<Figure> {
    let n = d.eta.len();
    ensure!(
        d.beta.len() == n && d.beta_err.len() == n && d.group.len() == n,
        "{n} η, {} β, {} errors, {} groups",
        d.beta.len(),
        d.beta_err.len(),
        d.group.len()
    );
    ensure!(
        d.group.iter().all(|&g| g < d.groups.len()),
        "a group index ≥ {}",
        d.groups.len()
    );
    let mut p = XyPanel::new(
        Axis::log("η = −$h$''_∥/$h$''_⊥"),
        Axis::linear(&d.beta_label),
    );
    for (g, label) in d.groups.iter().enumerate() {
        let keep: Vec<usize> = (0..n)
            .filter(|&i| d.group[i] == g && d.eta[i] > 0.0 && d.beta[i].is_finite())
            .collect();
        if keep.is_empty() {
            continue;
        }
        let x: Vec<f64> = keep.iter().map(|&i| d.eta[i]).collect();
        let y: Vec<f64> = keep.iter().map(|&i| d.beta[i]).collect();
        let e: Vec<f64> = keep
            .iter()
            .map(|&i| {
                if d.beta_err[i].is_finite() {
                    d.beta_err[i]
                } else {
                    0.0
                }
            })
            .collect();
        p.series.push(
            Series::points(x, y, MarkerStyle::filled(Marker::Circle, group_color(g)))
                .y_err(e)
                .label(label),
        );
    }
    p.annotations.push(Annotation::HLine {
        y: PAPER_BETA,
        stroke: Stroke::dashed(BLACK),
        label: Some(format!("paper {PAPER_BETA}")),
    });
    p.annotations.push(Annotation::HLine {
        y: 3.0,
        stroke: Stroke::dotted(GREY),
        label: Some("3".into()),
    });
    Ok(single_panel(540.0, 420.0, p, LegendPos::TopRight))
}

/// a_p against H: every realisation (small open markers) and the mean ± standard error per H
/// (filled, joined), one colour per q_s.
pub fn ap_hurst_figure(series: &[ApSeries]) -> Result<Figure> {
    let mut p = XyPanel::new(Axis::linear("Hurst exponent $H$"), Axis::linear("$a$_p"));
    for (k, s) in series.iter().enumerate() {
        let m = s.hurst.len();
        ensure!(
            s.mean.len() == m && s.sem.len() == m,
            "{}: {m} H, {} means, {} errors",
            s.label,
            s.mean.len(),
            s.sem.len()
        );
        let color = group_color(k);
        let (x, y): (Vec<f64>, Vec<f64>) = s.points.iter().copied().unzip();
        p.series.push(Series::points(
            x,
            y,
            MarkerStyle::open(Marker::Circle, color).size(3.5),
        ));
        let e: Vec<f64> = s
            .sem
            .iter()
            .map(|v| if v.is_finite() { *v } else { 0.0 })
            .collect();
        p.series.push(
            Series::line(s.hurst.clone(), s.mean.clone(), Stroke::solid(color))
                .marker(MarkerStyle::filled(Marker::Square, color))
                .y_err(e)
                .label(&format!("{}: mean ± sem", s.label)),
        );
    }
    Ok(single_panel(520.0, 400.0, p, LegendPos::TopRight))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalisation_is_at_d_ref_or_the_largest_d() {
        let (pts, d0) = normalise(&[0.1, 5e-2, 2e-2], &[8.0, 4.0, 0.0]).unwrap();
        assert_eq!(d0, 5e-2);
        assert_eq!(pts, vec![(0, 0.1, 2.0), (1, 5e-2, 1.0)]);
        let (pts, d0) = normalise(&[2e-2, 1e-2], &[2.0, 1.0]).unwrap();
        assert_eq!(d0, 2e-2);
        assert_eq!(pts[1], (1, 1e-2, 0.5));
        assert!(normalise(&[5e-2], &[0.0]).is_none());
    }

    #[test]
    fn the_four_figures_render() {
        let n = 16;
        let gap = Array2::from_shape_fn((n, n), |(i, j)| {
            (((i * 3 + j) % 7) as f64 * 0.1 - 0.2).max(0.0)
        });
        let m = MapFig {
            gap,
            lx: 1.0,
            ly: 1.0,
            at: (0.5, 0.25),
            zoom: 0.1,
            title: "seed 1".into(),
        };
        assert!(!map_figure(&m).unwrap().render_svg().unwrap().is_empty());
        assert!(map_figure(&MapFig { zoom: 0.0, ..m }).is_err());
        let c = FluxCurve {
            group: 0,
            d: vec![5e-2, 2e-2, 1e-2],
            flux: vec![1e-9, 1e-10, 1e-11],
            resolved: vec![true, true, false],
        };
        let fig = FluxFig {
            groups: vec!["$H$ = 0.8".into()],
            curves: vec![c.clone()],
            lattices: vec![LatticeCurve {
                model: Model::Square,
                d: vec![2e-2, 1e-2],
                flux: vec![1e-3, 1e-4],
            }],
        };
        let svg = flux_figure(&fig).unwrap().render_svg().unwrap();
        assert!(
            svg.contains("Square lattice"),
            "the lattice's curve is drawn"
        );
        let bad = FluxFig {
            curves: vec![FluxCurve {
                flux: vec![1.0],
                ..c.clone()
            }],
            ..fig.clone()
        };
        assert!(flux_figure(&bad).is_err());
        let bad = FluxFig {
            curves: vec![FluxCurve { group: 1, ..c }],
            ..fig
        };
        assert!(flux_figure(&bad).is_err());
        let b = BetaEtaFig {
            groups: vec!["a".into(), "b".into()],
            group: vec![0, 1, 1],
            eta: vec![0.5, 1.0, 2.0],
            beta: vec![3.0, 3.3, f64::NAN],
            beta_err: vec![0.1, f64::NAN, 0.2],
            beta_label: "β".into(),
        };
        assert!(
            !beta_eta_figure(&b)
                .unwrap()
                .render_svg()
                .unwrap()
                .is_empty()
        );
        assert!(
            beta_eta_figure(&BetaEtaFig {
                group: vec![0, 2, 1],
                ..b
            })
            .is_err()
        );
        let a = ApSeries {
            label: "$q$_s = 8".into(),
            hurst: vec![0.5, 0.8],
            mean: vec![0.42, 0.44],
            sem: vec![0.01, f64::NAN],
            points: vec![(0.5, 0.41), (0.5, 0.43), (0.8, 0.44)],
        };
        assert!(
            !ap_hurst_figure(std::slice::from_ref(&a))
                .unwrap()
                .render_svg()
                .unwrap()
                .is_empty()
        );
        assert!(ap_hurst_figure(&[ApSeries { sem: vec![], ..a }]).is_err());
    }
}
