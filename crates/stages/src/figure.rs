//! `figure`: renders one of the paper's figures from its input stages, as PNG and SVG side
//! outputs (`<output>.png`, `<output>.svg`; `output` defaults to `figures/<scene>`).
//!
//! Scenes:
//! - `fig2`: relative contact area against mean pressure, square model, hard wall, adhesion
//!   and repulsion (inputs `hardwall`, `adhesion`, `repulsion`: load-controlled `sweep`s);
//!   loading red, unloading blue, detected jumps circled, p_fc marked. `log_area = true` draws
//!   the area on a log axis (shows the small-area hysteresis). Points that did not converge
//!   are left out, with a warning.
//! - `fig6`: flux (effective conductivity) against load for the three models, hard wall solid
//!   and adhesion dashed with the point where its flow stops marked; the near-critical current
//!   density; the near-critical flux ladder when a `ladder` input provides it (inputs and
//!   contract: [`crate::fig6`]). `load_unit` (`absolute` or `p_fc`), `flux_log`,
//!   `map_half_width` (λ, 0: the whole cell) and `map_arrows` adjust it.
//! - `fig4`: gap maps just below the percolation threshold for the three models, contact white,
//!   bright = large gap, arranged as Figure 1 (inputs `hexagonal`, `square`, `triangular`:
//!   `critical` stages stored with fields; see [`crate::fig4`]).
//! - `convergence`: against grid spacing for the three models, with the extrapolations to zero
//!   spacing and their 1σ bands, stacked: (a) perimeter-corrected a_p minus the paper's value
//!   (the paper's error bars at zero spacing), (b) the same on the three finest grids, (c) raw
//!   a_p minus the paper's, (d) L_c relative to its extrapolation (inputs `hexagonal`,
//!   `square`, `triangular`: `resolution` stages; see [`crate::resolution`]).
//! - `fig5`: Figure 5, near-critical contact lines and axis gaps collapsed by the scaling
//!   (inputs `ladder`, one per model, and `exponents`; crates/stages/src/fig5.rs).
//! - `fig1`: elastic displacement at zero load with adhesion for the three models (inputs
//!   `hexagonal`, `square`, `triangular`: zero-load γ0 `sweep`s with fields at `gamma0`,
//!   default 0.2), lattice overlays from the surfaces' critical points ([`fig1`]); attribute
//!   `gamma0`, dataset `contact_area` (per panel).
//! - `fig3`: relative contact area against γ0 at zero load, increasing and decreasing γ0, the
//!   three models (inputs: one or more zero-load γ0 `sweep`s per model; the finest grid is
//!   drawn), jumps marked, γ_p and γ_fc on the axis ([`fig3`]).
//!
//! Artefact: attributes `scene`; fig2: `points_plotted`, `points_left_out`; fig3:
//! `points_left_out`; fig6: `points_plotted`, `curves` (the figure files themselves are kept
//! inside the artefact by the engine, as every side output).

use crate::fig5;
use crate::sweep::SweepData;
use crate::{fig1, fig2, fig3, fig4, fig6, resolution};
use anyhow::Result;
use figures::Colormap;
use figures::scenes::fig2::{Branch, Fig2Data, LoadLoop};
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, ParamType, Params, StageContext, StageKind,
    StageReport,
};
use serde_json::json;
use store::ArtefactWriter;

/// The `figure` stage kind.
pub struct FigureKind;

/// Bump when the figures change for the same inputs.
pub const CODE_VERSION: u64 = 1;

/// Scenes this kind renders.
pub const SCENES: &[&str] = &[
    "fig1",
    "fig2",
    "fig3",
    "fig4",
    "fig5",
    "fig6",
    "convergence",
];

/// The `convergence` scene's panels, top to bottom: quantity and how many of the finest grids
/// (`None`: all).
pub const CONVERGENCE_PANELS: [(&str, Option<usize>); 4] = [
    ("a_p_corrected", None),
    ("a_p_corrected", Some(3)),
    ("a_p_raw", None),
    ("l_c", None),
];

/// The output stem (`figures/<scene>` unless `output` is given).
fn stem(params: &Params) -> String {
    match params.str("output") {
        Ok(s) if !s.is_empty() => s.to_string(),
        _ => format!("figures/{}", params.str("scene").unwrap_or("figure")),
    }
}

/// Checks a side-output path: relative, inside the project, no `..`.
pub fn check_relative(key: &str, path: &str) -> Result<(), ParamIssue> {
    let p = std::path::Path::new(path);
    if p.is_absolute()
        || p.components()
            .any(|c| !matches!(c, std::path::Component::Normal(_)))
    {
        return Err(ParamIssue::new(
            key,
            format!(
                "\"{path}\": allowed a relative path inside the project without `.` or `..` (e.g. \"figures/fig2\")"
            ),
        ));
    }
    Ok(())
}

/// One branch of a sweep as a figure draws it (see [`converged_branch`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ConvergedBranch {
    /// Control value of each converged point.
    pub x: Vec<f64>,
    /// Relative contact area of each converged point.
    pub area: Vec<f64>,
    /// Jumps: index i means a jump between converged points i and i + 1.
    pub jumps: Vec<usize>,
    /// Points left out (did not converge).
    pub left_out: usize,
}

/// One branch of a sweep for a figure: the control values (`x` of each point) and areas of its
/// converged points, the jumps re-indexed to them, and how many points were left out.
pub fn converged_branch(
    d: &SweepData,
    name: &str,
    x: &dyn Fn(&crate::sweep::Point) -> f64,
) -> ConvergedBranch {
    let all = d.branch_indices(name);
    let idx: Vec<usize> = all
        .iter()
        .copied()
        .filter(|&k| d.points[k].converged)
        .collect();
    let jumps = d
        .jumps
        .iter()
        .filter(|j| j.branch == name)
        .filter_map(|j| {
            let pos = idx.iter().position(|&k| k == j.index)?;
            (idx.get(pos + 1) == Some(&j.index_after)).then_some(pos)
        })
        .collect();
    ConvergedBranch {
        x: idx.iter().map(|&k| x(&d.points[k])).collect(),
        area: idx.iter().map(|&k| d.points[k].contact_area).collect(),
        jumps,
        left_out: all.len() - idx.len(),
    }
}

/// One load branch of a sweep for Figure 2.
fn branch(d: &SweepData, name: &str) -> (Branch, usize) {
    let b = converged_branch(d, name, &|p| p.load);
    (
        Branch {
            pressure: b.x,
            area: b.area,
            jumps: b.jumps,
        },
        b.left_out,
    )
}

fn load_loop(d: &SweepData) -> (LoadLoop, usize) {
    let (loading, a) = branch(d, "loading");
    let (unloading, b) = branch(d, "unloading");
    (LoadLoop { loading, unloading }, a + b)
}

impl StageKind for FigureKind {
    /// Lower bound: the fields a scene reads whole (fig1: a displacement, fig4: a gap, fig6:
    /// the gap and two current components) on the finest upstream grid; the other scenes read
    /// per-point data only (kB): 0.
    fn memory_estimate(
        &self,
        params: &Params,
        inputs: &std::collections::BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        let fields = match params.str("scene").ok()? {
            "fig1" | "fig4" => 1,
            "fig6" => 3,
            _ => return Some(0),
        };
        let n = orchestrator::upstream_max(inputs, &["n", "ns"])?;
        Some(fields * crate::surface::field_bytes(n))
    }
    fn name(&self) -> &str {
        "figure"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "renders a figure of the paper (PNG and SVG side outputs) from its input stages"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("scene", ParamType::one_of(SCENES)).doc("which figure"),
            ParamSpec::new("log_area", ParamType::Bool)
                .default(false)
                .doc("fig2: logarithmic area axis"),
            ParamSpec::new("load_unit", ParamType::one_of(&["absolute", "p_fc"]))
                .default("absolute")
                .doc("fig6: load axis in E* h0/λ or in units of each model's p_fc"),
            ParamSpec::new("flux_log", ParamType::Bool)
                .default(true)
                .doc("fig6: logarithmic flux axis"),
            ParamSpec::new("map_half_width", ParamType::non_negative())
                .default(0.3)
                .doc("fig6: half width (λ) of the current map's window around its largest |j| (0: the whole cell)"),
            ParamSpec::new("map_arrows", ParamType::int_range(0, 60))
                .default(12)
                .doc("fig6: arrows per side of the current map (0: none)"),
            ParamSpec::new("gamma0", ParamType::positive())
                .default(0.2)
                .doc("fig1: the surface energy γ0 (E* h0²/λ) whose state is shown"),
            ParamSpec::new("output", ParamType::string())
                .default("")
                .doc("output stem relative to the project root (default figures/<scene>)"),
        ]
    }
    fn check(&self, params: &Params) -> Result<(), ParamIssue> {
        check_relative("output", &stem(params))
    }
    fn inputs(&self, params: &Params) -> Vec<InputSpec> {
        match params.str("scene") {
            Ok("fig1") => fig1::inputs(),
            Ok("fig2") => fig2::inputs(),
            Ok("fig6") => fig6::inputs(),
            Ok("fig3") => fig3::inputs(),
            Ok("fig4") => fig4::inputs(),
            Ok("convergence") => resolution::scene_inputs(),
            Ok("fig5") => fig5::inputs(),
            _ => Vec::new(),
        }
    }
    fn side_outputs(&self, params: &Params) -> Vec<String> {
        let s = stem(params);
        vec![format!("{s}.png"), format!("{s}.svg")]
    }
    fn cost(&self, _params: &Params) -> f64 {
        0.05
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let scene = params.str("scene")?;
        let mut scene_stats = serde_json::Value::Null;
        let fig = match scene {
            "fig2" => {
                let sweeps = fig2::read(inputs)?;
                let mut loops = Vec::new();
                let mut plotted = 0usize;
                let mut left_out = 0usize;
                for d in &sweeps {
                    let (l, bad) = load_loop(d);
                    if bad > 0 {
                        ctx.warn(format!(
                            "{bad} non-converged points of the {} sweep are left out of the figure",
                            d.interaction
                        ));
                    }
                    plotted += l.loading.area.len() + l.unloading.area.len();
                    left_out += bad;
                    loops.push(l);
                }
                let label = |d: &SweepData, what: &str, sym: &str, key: &str| -> Result<String> {
                    let r = inputs.one(&d.interaction)?;
                    Ok(format!(
                        "{what}, {sym} = {}, $ρ$ = {}",
                        r.attr_f64(key)?,
                        r.attr_f64("rho")?
                    ))
                };
                let data = Fig2Data {
                    adhesion_label: label(&sweeps[1], "exponential adhesion", "$γ$_0", "gamma0")?,
                    repulsion_label: label(&sweeps[2], "Gaussian repulsion", "$γ$_r", "gamma_r")?,
                    hard_wall: loops[0].clone(),
                    adhesion: loops[1].clone(),
                    repulsion: loops[2].clone(),
                    p_fc: Some(sweeps[0].p_fc),
                    a_p: None,
                    log_area: params.bool("log_area")?,
                    pressure_range: None,
                };
                out.set_attr("points_plotted", plotted as i64)?;
                out.set_attr("points_left_out", left_out as i64)?;
                figures::scenes::fig2::figure(&data)?
            }
            "fig6" => {
                let (data, stats) = fig6::data(ctx, inputs, params)?;
                let plotted: usize = data.flow.iter().map(|c| c.load.len()).sum();
                out.set_attr("points_plotted", plotted as i64)?;
                out.set_attr("curves", stats.clone())?;
                scene_stats = stats;
                figures::scenes::fig6::figure(&data)?
            }
            "fig1" => {
                let g = params.f64("gamma0")?;
                let (maps, areas) = fig1::data(inputs, g)?;
                out.set_attr("gamma0", g)?;
                out.write_f64_1d("contact_area", &areas)?;
                figures::scenes::maps::figure(&maps, figures::heatmap::Colormap::Inferno)?
            }
            "fig3" => {
                let models = fig3::read(inputs)?;
                let (data, left_out) = fig3::data(&models);
                if left_out > 0 {
                    ctx.warn(format!(
                        "{left_out} non-converged points of the finest sweeps are left out of the figure"
                    ));
                }
                out.set_attr("points_left_out", left_out as i64)?;
                figures::scenes::fig3::figure(&data)?
            }
            "fig4" => figures::scenes::maps::figure(&fig4::data(inputs)?, Colormap::Viridis)?,
            "convergence" => {
                let panels = CONVERGENCE_PANELS
                    .iter()
                    .map(|(q, k)| resolution::convergence_data(inputs, q, *k))
                    .collect::<Result<Vec<_>>>()?;
                figures::scenes::convergence::stacked(&panels)?
            }
            "fig5" => {
                let (data, warnings) = fig5::fig5_data(inputs)?;
                for w in warnings {
                    ctx.warn(w);
                }
                out.set_attr("contact_lines", data.contact_lines.len() as i64)?;
                out.set_attr("profiles", data.profiles.len() as i64)?;
                figures::scenes::fig5::figure(&data)?
            }
            other => anyhow::bail!("scene `{other}`: allowed {}", SCENES.join(", ")),
        };
        ctx.progress(0.3, "drawing");
        let png = fig.render_png()?;
        let svg = fig.render_svg()?;
        let s = stem(params);
        let (png_bytes, svg_bytes) = (png.len(), svg.len());
        ctx.emit_file(&format!("{s}.png"), png);
        ctx.emit_file(&format!("{s}.svg"), svg.into_bytes());
        out.set_attr("scene", scene)?;
        ctx.progress(1.0, "rendered");
        Ok(StageReport::with_stats(json!({
            "png_bytes": png_bytes,
            "svg_bytes": svg_bytes,
            "scene": scene_stats,
        })))
    }
}
