//! Figure 6's inputs and data, shared by the `figure` and `table` kinds.
//!
//! Inputs:
//! - `flow`: `flow` stages along load paths, one curve each; the model (`lattice`) and γ0 are
//!   read from the artefacts (γ0 = 0: hard wall, drawn solid; γ0 > 0: adhesion, dashed). The
//!   loading branch is drawn, converged points only (flow and contact solves), up to the last
//!   point where the fluid still flows; where an adhesive curve's flow stops inside the path its
//!   last point is marked (the flow stops discontinuously there).
//! - `current` (optional): a `flowmap` stage, the current density near the critical load
//!   (bottom right), shown in a window around the constriction (the node of largest |j|).
//!
//! - `ladder` (optional, any kind): the bottom-left panel, normalised flux against
//!   (L_c − L)/L_c on log–log axes with the fitted slope β, from the near-critical study. This
//!   module only reads it (through the `exponents` kind's readers, [`exponents::read_flux_curve`]
//!   and [`exponents::read_pooled_beta`]); without it the panel stays empty. Contract:
//!   per model, datasets `ladder/<lattice>/distance` ((L_c − L)/L_c > 0) and
//!   `ladder/<lattice>/flux` (normalised flux > 0, same length), optionally
//!   `ladder/<lattice>/flux_err` (1σ); optional root attributes `beta`, `beta_err`,
//!   `beta_prefactor` (the fit Q/Q_0 = prefactor · distance^β drawn over the data). Several
//!   `ladder` artefacts may each hold some of the models; the fit is taken from the first one
//!   that carries `beta` and `beta_prefactor`. Optional, from a run with refined ladders
//!   ([`exponents::read_refined_flux_curve`], [`exponents::read_asymptotic_slope`]): per model
//!   `ladder/<lattice>/refined/{distance, flux}` (the refined ladder's flux in the same
//!   normalisation, drawn as filled diamonds), likewise `ladder/<lattice>/refined_deep/*` (a
//!   deeper refined ladder chained below it, continuing its curve: drawn the same way, filled
//!   diamonds, one curve of the model's points) and the attributes `beta_asymptotic`,
//!   `beta_asymptotic_error`, `beta_asymptotic_distance`, `beta_asymptotic_flux` on
//!   `ladder/<lattice>` (the asymptotic β drawn as a dashed line in the model's colour through
//!   that point, over the whole range drawn).

use crate::scene::{OutputSpec, Outputs, Scene, scene_params};
use anyhow::{Result, bail};
use figures::scenes::fig6::{
    CurrentMap, Fig6Data, FlowCurve, NormalisedFlux, PowerLawFit, SlopeLine,
};
use figures::style::Model;
use kinds::exponents;
use kinds::flow::FlowData;
use kinds::refined_chain::Depth;
use kinds::sweep::Branch as PathBranch;
use orchestrator::{InputSpec, Inputs};
use orchestrator::{ParamSpec, ParamType, Params, StageContext};
use serde_json::{Value, json};
use store::ArtefactWriter;

/// The `flow` input (the one the tables need).
pub fn flow_input() -> InputSpec {
    InputSpec::many("flow", &["flow"])
        .doc("flow stages along load paths (one curve each: model and γ0 from the artefact)")
}

/// The inputs Figure 6's figure takes.
pub fn inputs() -> Vec<InputSpec> {
    vec![
        flow_input(),
        InputSpec::one("current", &["flowmap"])
            .optional()
            .doc("near-critical current density (bottom right)"),
        InputSpec::many("ladder", &[])
            .optional()
            .doc("near-critical flux ladder and β fit (bottom left): `ladder/<lattice>/{distance, flux, flux_err}`, attributes `beta`, `beta_err`, `beta_prefactor`"),
    ]
}

/// The bottom-left panel's data from the `ladder` inputs (contract in the module docs).
#[derive(Clone, Debug, Default)]
pub struct LadderPanel {
    /// The normalised-flux points per model (uniform ladders).
    pub points: Vec<NormalisedFlux>,
    /// The pooled power-law fit, if any.
    pub fit: Option<PowerLawFit>,
    /// The refined ladders' flux per model, same normalisation.
    pub refined: Vec<NormalisedFlux>,
    /// The models' asymptotic slopes.
    pub slopes: Vec<SlopeLine>,
}

/// The bottom-left panel's data from the `ladder` inputs (contract in the module docs).
pub fn read_ladder(inputs: &Inputs) -> Result<LadderPanel> {
    let mut points = Vec::new();
    let mut fit = None;
    let mut refined = Vec::new();
    let mut slopes = Vec::new();
    for r in inputs.all("ladder") {
        let file = r.path().display();
        for m in Model::ALL {
            for depth in Depth::ALL {
                if let Some(c) = exponents::read_refined_flux_curve(r, m.name(), depth)? {
                    let g = format!("ladder/{}/{}", m.name(), depth.name());
                    refined.push(log_log_flux(&file, &g, m, &c, None)?);
                }
            }
            if let Some(s) = exponents::read_asymptotic_slope(r, m.name())? {
                slopes.push(SlopeLine {
                    model: m,
                    exponent: s.beta,
                    exponent_err: s.error,
                    through: s.through,
                });
            }
            let Some(curve) = exponents::read_flux_curve(r, m.name())? else {
                continue;
            };
            let g = format!("ladder/{}", m.name());
            points.push(log_log_flux(&file, &g, m, &curve.points, curve.flux_err)?);
        }
        if fit.is_none()
            && let Some((exponent, exponent_err, prefactor)) = exponents::read_pooled_beta(r)?
        {
            fit = Some(PowerLawFit {
                exponent,
                exponent_err,
                prefactor,
            });
        }
    }
    Ok(LadderPanel {
        points,
        fit,
        refined,
        slopes,
    })
}

/// A normalised flux curve of group `g` of `file` for the log–log panel: an error naming the
/// first point whose distance or flux is not > 0.
fn log_log_flux(
    file: &impl std::fmt::Display,
    g: &str,
    model: Model,
    points: &[exponents::FluxPoint],
    flux_err: Option<Vec<f64>>,
) -> Result<NormalisedFlux> {
    if let Some(k) = points
        .iter()
        .position(|p| !(p.distance > 0.0 && p.flux > 0.0))
    {
        let p = points[k];
        bail!(
            "`{file}`: {g} point {k} has distance {} and flux {}; both must be > 0 \
             (log–log panel)",
            p.distance,
            p.flux
        );
    }
    Ok(NormalisedFlux {
        model,
        distance: points.iter().map(|p| p.distance).collect(),
        flux: points.iter().map(|p| p.flux).collect(),
        flux_err,
    })
}

/// The model of a lattice name.
pub fn model(lattice: &str) -> Result<Model> {
    Model::ALL
        .into_iter()
        .find(|m| m.name() == lattice)
        .ok_or_else(|| anyhow::anyhow!("unknown lattice `{lattice}`"))
}

/// Reads the flow inputs, sorted by model (hexagonal, square, triangular) then γ0.
pub fn read_flows(inputs: &Inputs) -> Result<Vec<FlowData>> {
    let mut v = Vec::new();
    for r in inputs.all("flow") {
        let d = FlowData::read(r)?;
        if d.interaction == "repulsion" {
            bail!(
                "`{}` is a flow along a repulsive path; Figure 6 shows the hard wall and \
                 adhesion",
                r.path().display()
            );
        }
        v.push(d);
    }
    if v.is_empty() {
        bail!("Figure 6 needs at least one `flow` input");
    }
    v.sort_by(|a, b| {
        let key = |d: &FlowData| Model::ALL.iter().position(|m| m.name() == d.lattice);
        key(a).cmp(&key(b)).then(a.gamma0.total_cmp(&b.gamma0))
    });
    Ok(v)
}

/// One curve: the loading branch's usable points up to the last flowing one. Returns the curve
/// (without `mark_end` decided), whether the flow stops inside the path, the indices used and
/// the number of points left out (non-converged).
pub struct Curve {
    /// Indices into the flow data, path order, flowing points only.
    pub idx: Vec<usize>,
    /// The flow stops inside the path: some usable point after the last flowing one is blocked.
    pub stops: bool,
    /// The first blocked point after the last flowing one, if any.
    pub blocked: Option<usize>,
    /// Points of the branch left out because a solve did not converge.
    pub left_out: usize,
}

/// The curve of one flow artefact's loading branch.
pub fn curve(d: &FlowData) -> Curve {
    let (usable, left_out) = d.usable(PathBranch::Loading);
    let mut idx = Vec::new();
    let mut blocked = None;
    for &k in &usable {
        if d.points[k].percolating {
            if blocked.is_some() {
                // the fluid flows again after a blocked point: keep the first flowing stretch
                break;
            }
            idx.push(k);
        } else if !idx.is_empty() && blocked.is_none() {
            blocked = Some(k);
        }
    }
    Curve {
        stops: blocked.is_some(),
        idx,
        blocked,
        left_out,
    }
}

/// Figure 6's data from its inputs; statistics for the stage report.
pub fn data(
    ctx: &mut StageContext,
    inputs: &Inputs,
    params: &Fig6Params,
) -> Result<(Fig6Data, Value)> {
    let flows = read_flows(inputs)?;
    let unit = params.load_unit.as_str();
    let mut curves = Vec::new();
    let mut stats = Vec::new();
    for d in &flows {
        let c = curve(d);
        let m = model(&d.lattice)?;
        let what = format!(
            "{} {}",
            d.lattice,
            if d.gamma0 == 0.0 {
                "hard wall".to_string()
            } else {
                format!("γ0 = {}", d.gamma0)
            }
        );
        if c.left_out > 0 {
            ctx.warn(format!(
                "{what}: {} points whose flow or contact solve did not converge are left out",
                c.left_out
            ));
        }
        if !c.stops {
            ctx.warn(format!(
                "{what}: the flow does not stop inside the load path (extend the path past \
                 where it stops)"
            ));
        }
        if c.idx.is_empty() {
            ctx.warn(format!("{what}: no flowing point to draw"));
            continue;
        }
        let p = &d.points;
        let scale = |k: usize| {
            if unit == "p_fc" {
                p[k].load / d.p_fc
            } else {
                p[k].load
            }
        };
        let last = *c.idx.last().expect("non-empty");
        stats.push(json!({
            "lattice": d.lattice, "gamma0": d.gamma0, "n": d.n, "axis": d.axis,
            "points": c.idx.len(), "left_out": c.left_out,
            "load_last_flowing": p[last].load,
            "load_first_blocked": c.blocked.map(|k| p[k].load),
            "conductivity_first": p[c.idx[0]].conductivity,
            "conductivity_last_flowing": p[last].conductivity,
            "contact_area_last_flowing": p[last].contact_area,
            "contact_area_first_blocked": c.blocked.map(|k| p[k].contact_area),
            "p_fc": d.p_fc,
        }));
        curves.push(FlowCurve {
            model: m,
            gamma0: d.gamma0,
            load: c.idx.iter().map(|&k| scale(k)).collect(),
            flux: c.idx.iter().map(|&k| p[k].conductivity).collect(),
            mark_end: d.gamma0 != 0.0 && c.stops,
        });
    }
    let current = match inputs.all("current") {
        [r] => Some(current_map(r, params)?),
        _ => None,
    };
    let panel = read_ladder(inputs)?;
    let data = Fig6Data {
        flow: curves,
        load_label: if unit == "p_fc" {
            "load $L$ / $p$_fc".into()
        } else {
            "load $L$ / ($E$^*$h$_0/$λ$)".into()
        },
        flux_label: "conductivity $K$ / $h$_0^3".into(),
        flux_log: params.flux_log,
        normalised: panel.points,
        distance_label: "($L$_c − $L$)/$L$_c".into(),
        fit: panel.fit,
        refined: panel.refined,
        slopes: panel.slopes,
        current,
    };
    Ok((data, json!({ "curves": stats })))
}

/// The current map of a `flowmap` artefact, in a window around its largest |j|.
fn current_map(r: &store::ArtefactReader, params: &Fig6Params) -> Result<CurrentMap> {
    let jx = r.read_f64_2d(store::fields::CURRENT_X)?;
    let jy = r.read_f64_2d(store::fields::CURRENT_Y)?;
    let gap = r.read_f64_2d(store::fields::GAP)?;
    let (lx, ly) = r.cell()?;
    let (nx, ny) = jx.dim();
    let mut best = (0usize, 0usize, -1.0f64);
    for ((i, j), &a) in jx.indexed_iter() {
        let m = a.hypot(jy[[i, j]]);
        if m.is_finite() && m > best.2 {
            best = (i, j, m);
        }
    }
    let half = params.map_half_width;
    let view = if half > 0.0 {
        let (cx, cy) = (
            best.0 as f64 * lx / nx as f64,
            best.1 as f64 * ly / ny as f64,
        );
        Some((cx - half, cx + half, cy - half, cy + half))
    } else {
        None
    };
    Ok(CurrentMap {
        jx,
        jy,
        gap: Some(gap),
        lx,
        ly,
        view,
        arrows: params.map_arrows,
        log: true,
    })
}

/// The `fig6` scene: flux (effective conductivity) against load for the three models, hard
/// wall solid and adhesion dashed with the point where its flow stops marked; the
/// near-critical current density; the near-critical flux ladder when a `ladder` input provides
/// it; and the tables `fig6.csv`, `fig6_stops.csv` ([`crate::flowtable::tables`]). Attributes `points_plotted`,
/// `curves`.
pub struct Fig6;

/// Figure 6's parameters.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig6Params {
    /// Load axis: `absolute` (E* h0/λ) or `p_fc` (each model's).
    pub load_unit: String,
    /// Logarithmic flux axis.
    pub flux_log: bool,
    /// Half width (λ) of the current map's window (0: the whole cell).
    pub map_half_width: f64,
    /// Arrows per side of the current map.
    pub map_arrows: usize,
}

impl Scene for Fig6 {
    fn name(&self) -> &'static str {
        "fig6"
    }
    fn doc(&self) -> &'static str {
        "Figure 6: flux against load, near-critical current density and flux ladder (figure, points and stops tables)"
    }
    fn code_version(&self) -> u64 {
        3
    }
    fn fields_read(&self) -> u64 {
        3
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("load_unit", ParamType::one_of(&["absolute", "p_fc"]))
                .default("absolute")
                .doc("load axis in E* h0/λ or in units of each model's p_fc"),
            ParamSpec::new("flux_log", ParamType::Bool)
                .default(true)
                .doc("logarithmic flux axis"),
            ParamSpec::new("map_half_width", ParamType::non_negative())
                .default(0.3)
                .doc("half width (λ) of the current map's window around its largest |j| (0: the whole cell)"),
            ParamSpec::new("map_arrows", ParamType::int_range(0, 60))
                .default(12)
                .doc("arrows per side of the current map (0: none)"),
        ]
    }
    fn parse_typed(&self, params: &Params) -> Result<()> {
        scene_params::<Fig6Params>(self.name(), params).map(drop)
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        inputs()
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::figure("figure", "fig6"),
            OutputSpec::table("points", "fig6.csv"),
            OutputSpec::table("stops", "fig6_stops.csv"),
        ]
    }
    fn render(
        &self,
        ctx: &mut StageContext,
        params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let params = scene_params::<Fig6Params>(self.name(), params)?;
        let (data, stats) = data(ctx, inputs, &params)?;
        let plotted: usize = data.flow.iter().map(|c| c.load.len()).sum();
        out.set_attr("points_plotted", plotted as i64)?;
        out.set_attr("curves", stats.clone())?;
        let (points, stops) = crate::flowtable::tables(inputs)?;
        Ok(Outputs::new()
            .figure("figure", figures::scenes::fig6::figure(&data)?)
            .table("points", points)
            .table("stops", stops)
            .with_stats(stats))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kinds::flow_artefact::FlowPoint;

    /// The figure renders with the bottom-left panel empty (the near-critical study fills it
    /// later) and without a current map.
    #[test]
    fn renders_without_the_near_critical_panels() {
        let load: Vec<f64> = (1..20).map(|k| 0.1 * k as f64).collect();
        let d = Fig6Data {
            flow: vec![
                FlowCurve {
                    model: Model::Square,
                    gamma0: 0.0,
                    flux: load
                        .iter()
                        .map(|l| (1.5 - l).max(1e-9).powf(3.45))
                        .collect(),
                    load: load.clone(),
                    mark_end: false,
                },
                FlowCurve {
                    model: Model::Square,
                    gamma0: 0.05,
                    flux: load[..12].iter().map(|l| (1.3 - l).powf(3.0)).collect(),
                    load: load[..12].to_vec(),
                    mark_end: true,
                },
            ],
            load_label: "load".into(),
            flux_label: "conductivity".into(),
            flux_log: true,
            normalised: Vec::new(),
            distance_label: String::new(),
            fit: None,
            refined: Vec::new(),
            slopes: Vec::new(),
            current: None,
        };
        let png = figures::scenes::fig6::figure(&d)
            .unwrap()
            .render_png()
            .unwrap();
        assert!(png.len() > 1000);
    }

    fn ladder_inputs(dir: &std::path::Path, write: &dyn Fn(&mut store::ArtefactWriter)) -> Inputs {
        let path = dir.join("ladder.h5");
        let _ = std::fs::remove_file(&path);
        let mut w = store::ArtefactWriter::create(&path).unwrap();
        write(&mut w);
        w.publish().unwrap();
        let r = store::ArtefactReader::open(&path).unwrap();
        Inputs::new([("ladder".to_string(), vec![r])].into_iter().collect())
    }

    /// The `ladder` contract: per-model points (optional errors) and the β fit; models the
    /// artefact does not hold are absent; bad data is an error naming the dataset.
    #[test]
    fn ladder_input_fills_the_bottom_left_panel() {
        let dir = tempfile::tempdir().unwrap();
        let inputs = ladder_inputs(dir.path(), &|w| {
            w.write_f64_1d("ladder/square/distance", &[0.002, 0.01])
                .unwrap();
            w.write_f64_1d("ladder/square/flux", &[1e-9, 3e-7]).unwrap();
            w.write_f64_1d("ladder/square/flux_err", &[1e-10, 2e-8])
                .unwrap();
            w.write_f64_1d("ladder/triangular/distance", &[0.005])
                .unwrap();
            w.write_f64_1d("ladder/triangular/flux", &[2e-8]).unwrap();
            w.set_attr("beta", 3.45).unwrap();
            w.set_attr("beta_err", 0.05).unwrap();
            w.set_attr("beta_prefactor", 0.7).unwrap();
            w.write_f64_1d("ladder/square/refined/distance", &[1e-4, 1e-3])
                .unwrap();
            w.write_f64_1d("ladder/square/refined/flux", &[1e-12, 3e-9])
                .unwrap();
            for (k, v) in [
                ("beta_asymptotic", 3.4),
                ("beta_asymptotic_error", 0.02),
                ("beta_asymptotic_distance", 1e-4),
                ("beta_asymptotic_flux", 1e-12),
            ] {
                w.set_attr_at("ladder/square", k, v).unwrap();
            }
        });
        let LadderPanel {
            points,
            fit,
            refined,
            slopes,
        } = read_ladder(&inputs).unwrap();
        assert_eq!(refined.len(), 1);
        assert_eq!(refined[0].model, Model::Square);
        assert_eq!(refined[0].distance, [1e-4, 1e-3]);
        assert_eq!(refined[0].flux, [1e-12, 3e-9]);
        assert_eq!(
            slopes,
            [SlopeLine {
                model: Model::Square,
                exponent: 3.4,
                exponent_err: 0.02,
                through: (1e-4, 1e-12)
            }]
        );
        assert_eq!(points.len(), 2);
        assert_eq!(points[0].model, Model::Square);
        assert_eq!(points[0].distance, [0.002, 0.01]);
        assert_eq!(points[0].flux, [1e-9, 3e-7]);
        assert_eq!(points[0].flux_err.as_deref(), Some(&[1e-10, 2e-8][..]));
        assert_eq!(points[1].model, Model::Triangular);
        assert_eq!(points[1].flux_err, None);
        let fit = fit.unwrap();
        assert_eq!(
            (fit.exponent, fit.exponent_err, fit.prefactor),
            (3.45, Some(0.05), 0.7)
        );

        let inputs = ladder_inputs(dir.path(), &|w| {
            w.write_f64_1d("ladder/hexagonal/distance", &[0.002, 0.0])
                .unwrap();
            w.write_f64_1d("ladder/hexagonal/flux", &[1e-9, 3e-7])
                .unwrap();
        });
        let e = read_ladder(&inputs).unwrap_err().to_string();
        assert!(e.contains("ladder/hexagonal point 1"), "{e}");
        let inputs = ladder_inputs(dir.path(), &|w| {
            w.write_f64_1d("ladder/hexagonal/distance", &[0.002, 0.01])
                .unwrap();
            w.write_f64_1d("ladder/hexagonal/flux", &[1e-9]).unwrap();
        });
        let e = format!("{:#}", read_ladder(&inputs).unwrap_err());
        assert!(
            e.contains("`ladder/hexagonal/flux` has 1 entries, `ladder/hexagonal/distance` has 2"),
            "{e}"
        );

        let none = Inputs::new(Default::default());
        let p = read_ladder(&none).unwrap();
        assert!(p.points.is_empty() && p.fit.is_none());
        assert!(p.refined.is_empty() && p.slopes.is_empty());
    }

    #[test]
    fn curves_stop_at_the_first_blocked_point() {
        let point = |load: f64, k: f64, percolating: bool, converged: bool| FlowPoint {
            sweep_index: 0,
            branch: PathBranch::Loading,
            step: 0,
            load,
            strength: 0.05,
            contact_area: load,
            contact_converged: true,
            flux: k,
            conductivity: k,
            percolating,
            converged,
            termination: kinds::flow_artefact::Termination::Converged,
            iterations: 1,
            residual: 0.0,
            residual_floor: 0.0,
            flux_rounding_error: 0.0,
            conservation_error: 0.0,
            flux_error_estimate: 0.0,
            flowing_nodes: 1,
            removed_nodes: 0,
            wall_s: 0.0,
        };
        let d = FlowData {
            lattice: "square".into(),
            interaction: "adhesion".into(),
            gamma0: 0.05,
            p_fc: std::f64::consts::TAU,
            axis: "x".into(),
            n: 5,
            points: vec![
                point(0.0, 3.0, true, true),
                point(0.1, 2.0, true, true),
                point(0.2, 1.0, true, false),
                point(0.3, 0.5, true, true),
                point(0.4, 0.0, false, true),
                point(0.5, 0.0, false, true),
            ],
            stops: vec![],
        };
        let c = curve(&d);
        assert_eq!(c.idx, [0, 1, 3]);
        assert_eq!((c.stops, c.blocked, c.left_out), (true, Some(4), 1));
    }
}
