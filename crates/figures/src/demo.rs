//! Synthetic data for tests, examples and the pipeline's smoke runs: plausible shapes, no
//! physics. Every scene has a `figN()` constructor here.

use crate::scenes::fig2::{Branch, Fig2Data, LoadLoop};

fn linspace(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| a + (b - a) * k as f64 / (n - 1) as f64)
        .collect()
}

/// A contact-area curve that rises like the square model's, saturating at p_fc.
fn area_curve(p: f64, p_fc: f64, shift: f64) -> f64 {
    let x = ((p + shift) / p_fc).clamp(0.0, 1.0);
    (x.powf(0.75) * 0.97 + 0.03 * x).min(1.0)
}

fn branch(ps: Vec<f64>, f: impl Fn(f64) -> f64, jumps: Vec<usize>) -> Branch {
    let area = ps.iter().map(|&p| f(p)).collect();
    Branch {
        pressure: ps,
        area,
        jumps,
    }
}

/// Figure 2 data: hard wall without hysteresis, adhesion and repulsion with two loops each.
pub fn fig2() -> Fig2Data {
    let pfc = 2.0 * std::f64::consts::PI;
    let n = 60;
    let up = linspace(0.0, pfc * 1.05, n);
    let down: Vec<f64> = up.iter().rev().copied().collect();
    let hw = |p: f64| area_curve(p, pfc, 0.0);
    // adhesion: more area at a given load; a jump around a ≈ 0.4 on loading, later on unloading
    let adh_up = |p: f64| {
        let a = area_curve(p, pfc, 0.6);
        if a > 0.36 && a < 0.46 { 0.36 } else { a }
    };
    let adh_down = |p: f64| {
        let a = area_curve(p, pfc, 0.9);
        if a < 0.06 {
            0.0
        } else if a < 0.42 && a > 0.33 {
            0.46
        } else {
            a
        }
    };
    let rep_up = |p: f64| {
        let a = area_curve(p, pfc, -0.4);
        if a < 0.05 {
            0.0
        } else if a > 0.35 && a < 0.44 {
            0.35
        } else {
            a
        }
    };
    let rep_down = |p: f64| area_curve(p, pfc, -0.25);
    let jumps_of = |ps: &[f64], f: &dyn Fn(f64) -> f64| -> Vec<usize> {
        (0..ps.len() - 1)
            .filter(|&i| (f(ps[i + 1]) - f(ps[i])).abs() > 0.06)
            .collect()
    };
    let mk = |ps: &Vec<f64>, f: &dyn Fn(f64) -> f64| {
        let j = jumps_of(ps, f);
        branch(ps.clone(), f, j)
    };
    let mut adhesion_down = linspace(-0.9, pfc * 1.05, n);
    adhesion_down.reverse();
    Fig2Data {
        hard_wall: LoadLoop {
            loading: branch(up.clone(), hw, vec![]),
            unloading: branch(down.clone(), hw, vec![]),
        },
        adhesion: LoadLoop {
            loading: mk(&up, &adh_up),
            unloading: mk(&adhesion_down, &adh_down),
        },
        repulsion: LoadLoop {
            loading: mk(&up, &rep_up),
            unloading: mk(&down, &rep_down),
        },
        adhesion_label: "adhesion, $γ$_0 = 0.2, $ρ$ = 0.04".into(),
        repulsion_label: String::new(),
        p_fc: Some(pfc),
        a_p: Some(0.40185),
        log_area: false,
        pressure_range: None,
    }
}

use ndarray::Array2;

use crate::scenes::convergence::{ConvergenceData, ConvergenceSeries};
use crate::scenes::fig3::{Fig3Data, GammaBranch, ModelGammaPath};
use crate::scenes::fig5::{ContactLine, Fig5Data, GapProfile};
use crate::scenes::fig6::{
    CurrentMap, Fig6Data, FlowCurve, NormalisedFlux, PowerLawFit, SlopeLine,
};
use crate::scenes::maps::{ModelMap, ThreeMaps};
use crate::scenes::tradeoff::{TradeoffCurve, TradeoffData};
use crate::style::Model;

const S3: f64 = 1.732_050_807_568_877_2;

/// Cell size (λ) of a model.
pub fn cell(m: Model) -> (f64, f64) {
    match m {
        Model::Square => (1.0, 1.0),
        _ => (4.0 / S3, 2.0),
    }
}

/// Height h(x, y) / h0 of a model (the formulas of PHYSICS.md).
pub fn height(m: Model, x: f64, y: f64) -> f64 {
    use std::f64::consts::PI;
    let tri = || {
        (2.0f64 / 3.0).sqrt()
            * (1.5 + 2.0 * (S3 * PI * x).cos() * (PI * y).cos() + (2.0 * PI * y).cos())
    };
    match m {
        Model::Square => 2.0 + (2.0 * PI * x).cos() + (2.0 * PI * y).cos(),
        Model::Triangular => tri(),
        Model::Hexagonal => 13.5f64.sqrt() - tri(),
    }
}

fn grid(m: Model, n: usize, f: impl Fn(f64, f64) -> f64) -> Array2<f64> {
    let (lx, ly) = cell(m);
    Array2::from_shape_fn((n, n), |(i, j)| {
        f(i as f64 * lx / n as f64, j as f64 * ly / n as f64)
    })
}

/// Lattice overlays of one cell: (maxima lines, minima lines, minima, saddles, saddle links).
#[allow(clippy::type_complexity)]
pub fn lattice(
    m: Model,
) -> (
    Vec<Vec<(f64, f64)>>,
    Vec<Vec<(f64, f64)>>,
    Vec<(f64, f64)>,
    Vec<(f64, f64)>,
    Vec<Vec<(f64, f64)>>,
) {
    if m == Model::Square {
        return (
            vec![vec![(0.0, 0.0), (1.0, 0.0)], vec![(0.0, 0.0), (0.0, 1.0)]],
            vec![vec![(0.5, 0.5), (1.5, 0.5)], vec![(0.5, 0.5), (0.5, 1.5)]],
            vec![(0.5, 0.5)],
            vec![(0.5, 0.0), (0.0, 0.5)],
            vec![vec![
                (0.5, 0.0),
                (1.0, 0.5),
                (0.5, 1.0),
                (0.0, 0.5),
                (0.5, 0.0),
            ]],
        );
    }
    // triangular lattice of the triangular model's maxima
    let a = 2.0 / S3;
    let tmax = [(0.0, 0.0), (a, 0.0), (a / 2.0, 1.0), (1.5 * a, 1.0)];
    let dirs = [(a, 0.0), (a / 2.0, 1.0), (-a / 2.0, 1.0)];
    let tri_edges: Vec<Vec<(f64, f64)>> = tmax
        .iter()
        .flat_map(|&p| dirs.iter().map(move |d| vec![p, (p.0 + d.0, p.1 + d.1)]))
        .collect();
    let up = |p: (f64, f64)| (p.0 + a / 2.0, p.1 + 1.0 / 3.0);
    let down = |p: (f64, f64)| (p.0, p.1 + 2.0 / 3.0);
    let tmin: Vec<(f64, f64)> = tmax.iter().flat_map(|&p| [up(p), down(p)]).collect();
    // honeycomb edges from each up-triangle centre to its three neighbours
    let honey: Vec<Vec<(f64, f64)>> = tmax
        .iter()
        .flat_map(|&p| {
            let c = up(p);
            [
                (c.0 - a / 2.0, c.1 + 1.0 / 3.0),
                (c.0 + a / 2.0, c.1 + 1.0 / 3.0),
                (c.0, c.1 - 2.0 / 3.0),
            ]
            .into_iter()
            .map(move |q| vec![c, q])
        })
        .collect();
    let saddles: Vec<(f64, f64)> = tmax
        .iter()
        .flat_map(|&p| dirs.iter().map(move |d| (p.0 + d.0 / 2.0, p.1 + d.1 / 2.0)))
        .collect();
    let c = up(tmax[0]);
    let around: Vec<(f64, f64)> = vec![
        (c.0, c.1 - 1.0 / 3.0),
        (c.0 + a / 4.0, c.1 + 1.0 / 6.0),
        (c.0 - a / 4.0, c.1 + 1.0 / 6.0),
        (c.0, c.1 - 1.0 / 3.0),
    ];
    match m {
        Model::Triangular => (tri_edges, honey, tmin, saddles, vec![around]),
        _ => (honey, tri_edges, tmax.to_vec(), saddles, vec![around]),
    }
}

fn three_maps(n: usize, gap: bool) -> ThreeMaps {
    let maps = Model::ALL
        .iter()
        .map(|&m| {
            let hmax = if m == Model::Square {
                4.0
            } else {
                13.5f64.sqrt()
            };
            let level = hmax * 0.72;
            let field = if gap {
                grid(m, n, |x, y| (level - height(m, x, y)).max(0.0))
            } else {
                grid(m, n, |x, y| {
                    let h = height(m, x, y);
                    if h > level {
                        h
                    } else {
                        level + (h - level) * 0.35
                    }
                })
            };
            let (lx, ly) = cell(m);
            let mut mm = ModelMap::new(m, field.clone(), lx, ly);
            if m == Model::Square {
                mm.view = Some((0.0, 2.0, 0.0, 2.0));
            }
            if gap {
                mm.contact = Some(field.mapv(|g| g <= 0.0));
            } else {
                // dark = small displacement: show the displacement of the elastic body,
                // largest where it is pushed furthest (demo only)
                mm.field = field.mapv(|u| hmax - u);
            }
            let (maxl, minl, mins, sad, links) = lattice(m);
            mm.maxima_lines = maxl;
            mm.minima_lines = minl;
            mm.minima = mins;
            mm.saddles = sad;
            mm.saddle_links = links;
            mm
        })
        .collect();
    ThreeMaps {
        maps,
        colorbar_label: if gap {
            "$g$ / $h$_0".into()
        } else {
            "$u$ / $h$_0".into()
        },
        shared_range: false,
    }
}

/// Figure 1 data on n × n grids.
pub fn fig1(n: usize) -> ThreeMaps {
    three_maps(n, false)
}

/// Figure 4 data on n × n grids.
pub fn fig4(n: usize) -> ThreeMaps {
    three_maps(n, true)
}

/// Figure 3 data.
pub fn fig3() -> Fig3Data {
    let mk = |m: Model, gp: f64, gfc: f64| {
        let g: Vec<f64> = (0..50)
            .map(|k| 1e-3 * 10f64.powf(3.0 * k as f64 / 49.0))
            .collect();
        let area = |g: f64, hyst: f64| {
            let lg = g.log10();
            if g * hyst > gfc {
                1.0
            } else if g * hyst > gp {
                0.45 + 0.4 * (lg - gp.log10()) / (gfc.log10() - gp.log10()).max(1e-9)
            } else {
                0.03 + 0.3 * ((lg + 3.0) / (gp.log10() + 3.0)).powi(2)
            }
        };
        let inc_a: Vec<f64> = g.iter().map(|&x| area(x, 1.0)).collect();
        let mut dec_g = g.clone();
        dec_g.reverse();
        let dec_a: Vec<f64> = dec_g.iter().map(|&x| area(x, 1.6)).collect();
        let jumps = |a: &[f64]| {
            (0..a.len() - 1)
                .filter(|&i| (a[i + 1] - a[i]).abs() > 0.08)
                .collect::<Vec<_>>()
        };
        ModelGammaPath {
            model: m,
            increasing: GammaBranch {
                gamma0: g.clone(),
                jumps: jumps(&inc_a),
                area: inc_a,
            },
            decreasing: GammaBranch {
                gamma0: dec_g,
                jumps: jumps(&dec_a),
                area: dec_a,
            },
            gamma_p: Some(gp),
            gamma_fc: Some(gfc),
        }
    };
    Fig3Data {
        paths: vec![
            mk(Model::Hexagonal, 0.004, 0.54),
            mk(Model::Square, 0.02, 0.3),
            mk(Model::Triangular, 0.1, 0.1),
        ],
        log_gamma: true,
    }
}

/// Figure 5 data.
pub fn fig5() -> Fig5Data {
    let ls = [-0.02, -0.01, -0.005, 0.0, 0.005, 0.01, 0.02];
    let contact_lines = ls
        .iter()
        .map(|&l| {
            let pts = (0..=80)
                .map(|k| {
                    let t = -3.0 + 6.0 * k as f64 / 80.0;
                    let w = if l < 0.0 {
                        1.0 + 0.3 * t * t
                    } else if l > 0.0 {
                        (0.3 * t * t - 0.2).max(-1.0)
                    } else {
                        0.3 * t * t
                    };
                    (t, w + 0.04 * (l * 100.0))
                })
                .collect();
            ContactLine { l, points: pts }
        })
        .collect();
    let mut profiles = vec![];
    for &m in &Model::ALL {
        for &l in &[-0.02, -0.01, -0.005] {
            let r: Vec<f64> = (0..12).map(|k| k as f64 * 0.25).collect();
            let off = match m {
                Model::Hexagonal => 0.03,
                Model::Square => 0.0,
                Model::Triangular => -0.03,
            };
            let g = r.iter().map(|x| 1.0 + 0.5 * x * x + off + l).collect();
            profiles.push(GapProfile {
                model: m,
                l,
                distance: r,
                gap: g,
            });
        }
    }
    Fig5Data {
        contact_lines,
        contact_analytic: vec![
            (0..=40)
                .map(|k| {
                    let t = -3.0 + 6.0 * k as f64 / 40.0;
                    (t, 0.3 * t * t)
                })
                .collect(),
        ],
        profiles,
        refined_profiles: Vec::new(),
        gap_analytic: vec![
            (0..=40)
                .map(|k| {
                    let x = 2.75 * k as f64 / 40.0;
                    (x, 1.0 + 0.5 * x * x)
                })
                .collect(),
        ],
        ..Fig5Data::default()
    }
}

/// Figure 6 data with an n × n current map.
pub fn fig6(n: usize) -> Fig6Data {
    let lcs = [
        (Model::Hexagonal, 0.25),
        (Model::Square, 1.2),
        (Model::Triangular, 2.7),
    ];
    let mut flow = vec![];
    let mut normalised = vec![];
    for &(m, lc) in &lcs {
        let load: Vec<f64> = (0..40).map(|k| lc * k as f64 / 40.0).collect();
        let q = |l: f64| 0.8 * ((lc - l) / lc).powf(3.45);
        flow.push(FlowCurve {
            model: m,
            gamma0: 0.0,
            flux: load.iter().map(|&l| q(l)).collect(),
            load: load.clone(),
            mark_end: false,
        });
        let cut = (load.len() as f64 * 0.8) as usize;
        flow.push(FlowCurve {
            model: m,
            gamma0: 0.05,
            flux: load[..cut].iter().map(|&l| 0.7 * q(l * 1.1)).collect(),
            load: load[..cut].to_vec(),
            mark_end: true,
        });
        let d: Vec<f64> = (0..8).map(|k| 1e-3 * 2f64.powi(k)).collect();
        let pref = match m {
            Model::Hexagonal => 2.0,
            Model::Square => 1.0,
            Model::Triangular => 0.5,
        };
        normalised.push(NormalisedFlux {
            model: m,
            flux: d.iter().map(|x| pref * x.powf(3.45)).collect(),
            flux_err: Some(d.iter().map(|x| 0.1 * pref * x.powf(3.45)).collect()),
            distance: d,
        });
    }
    let (lx, ly) = (1.0, 1.0);
    let gap = Array2::from_shape_fn((n, n), |(i, j)| {
        let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
        (1.85 - height(Model::Square, x, y)).max(0.0)
    });
    let jx = gap.mapv(|g| g.powi(3));
    let jy = Array2::from_shape_fn((n, n), |(i, j)| {
        let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
        0.3 * gap[[i, j]].powi(3)
            * (2.0 * std::f64::consts::PI * y).sin()
            * (std::f64::consts::PI * x).cos()
    });
    Fig6Data {
        flow,
        load_label: "load $L$ / ($E$^*$h$_0$λ$)".into(),
        flux_label: String::new(),
        flux_log: true,
        normalised,
        distance_label: "($L$_c − $L$)/$L$_c".into(),
        fit: Some(PowerLawFit {
            exponent: 3.45,
            exponent_err: Some(0.05),
            prefactor: 0.6,
        }),
        refined: vec![NormalisedFlux {
            model: Model::Square,
            distance: vec![1e-5, 1e-4, 1e-3],
            flux: vec![1e-5f64.powf(3.4), 1e-4f64.powf(3.4), 1e-3f64.powf(3.45)],
            flux_err: None,
        }],
        slopes: vec![SlopeLine {
            model: Model::Square,
            exponent: 3.4,
            exponent_err: 0.02,
            through: (1e-5, 1e-5f64.powf(3.4)),
        }],
        current: Some(CurrentMap {
            jx,
            jy,
            gap: Some(gap),
            lx,
            ly,
            view: Some((0.2, 0.8, -0.3, 0.3)),
            arrows: 12,
            log: true,
        }),
    }
}

/// Convergence data: a first-order quantity extrapolated to zero spacing.
pub fn convergence() -> ConvergenceData {
    let h: Vec<f64> = [1.0 / 64.0, 1.0 / 128.0, 1.0 / 256.0, 1.0 / 512.0].to_vec();
    let a_inf = 0.40185;
    let value: Vec<f64> = h.iter().map(|x| a_inf + 0.8 * x).collect();
    let fit: Vec<(f64, f64)> = (0..=20)
        .map(|k| {
            let x = h[0] * k as f64 / 20.0;
            (x, a_inf + 0.8 * x)
        })
        .collect();
    let band = fit
        .iter()
        .map(|&(x, y)| (y - 0.0004 - 0.02 * x, y + 0.0004 + 0.02 * x))
        .collect();
    ConvergenceData {
        quantity_label: "contact area at percolation $a$_p".into(),
        spacing_label: String::new(),
        series: vec![ConvergenceSeries {
            label: "square".into(),
            spacing: h,
            error: vec![0.0005; 4],
            value,
            fit,
            fit_band: band,
            extrapolated: Some((a_inf, 0.0004)),
            reference: None,
        }],
        references: vec![(0.40185, "paper: 0.40185(6)".into())],
        reference_label: None,
    }
}

/// Trade-off data: error against wall time for two quantities.
pub fn tradeoff() -> TradeoffData {
    let n = [64usize, 128, 256, 512, 1024];
    let cost: Vec<f64> = n
        .iter()
        .map(|&k| 1e-4 * (k * k) as f64 * (k as f64).log2())
        .collect();
    TradeoffData {
        cost_label: String::new(),
        error_label: String::new(),
        curves: vec![
            TradeoffCurve {
                label: "$a$_p".into(),
                cost: cost.clone(),
                error: n.iter().map(|&k| 0.5 / k as f64).collect(),
                point_labels: n.iter().map(|k| format!("{k}²")).collect(),
            },
            TradeoffCurve {
                label: "$L$_c".into(),
                cost,
                error: n.iter().map(|&k| 2.0 / (k * k) as f64).collect(),
                point_labels: vec![],
            },
        ],
        target: Some(1e-4),
    }
}
