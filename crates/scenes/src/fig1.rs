//! Figure 1's inputs and data: the elastic displacement at zero load with exponential adhesion
//! for the hexagonal, square and triangular models side by side (the square model on 2 × 2
//! cells, so that the panels share one physical scale), with the lattice of each surface drawn
//! over it from its exact critical points ([`crate::fig4::lattice_map`]): lines through the
//! height maxima (black) and minima (white, minima as white points), saddle points as grey
//! stars and dotted lines between neighbouring saddles.
//!
//! Inputs `hexagonal`, `square`, `triangular`: zero-load adhesive `sweep`s with
//! `control = "strength"` that stored the fields at the figure's γ0 (`fields_at`); the figure
//! takes the increasing-γ0 branch's state at γ0 (adhesion switched on quasi-statically, as in
//! Figure 3; the same stages serve both figures).
//!
//! The field shown is the displacement of the elastic surface towards the substrate,
//! ⟨u⟩ − u (u the elastic surface's height, `contact::elastic`): smallest (dark) where the
//! substrate pushes the surface up, i.e. at contact, largest in the adhesive necks just
//! outside the contact lines, and nearly flat over the troughs.

use crate::fig3::{MODELS, check};
use crate::scene::{OutputSpec, Outputs, Scene, scene_params};
use anyhow::{Result, bail};
use figures::scenes::maps::ThreeMaps;
use orchestrator::{InputSpec, Inputs};
use orchestrator::{ParamSpec, ParamType, Params, StageContext};
use store::ArtefactReader;
use store::ArtefactWriter;

/// The inputs of Figure 1.
pub fn inputs() -> Vec<InputSpec> {
    MODELS
        .iter()
        .map(|m| {
            InputSpec::one(m, &["sweep"]).doc(&format!(
                "zero-load adhesive γ0 sweep of the {m} model with fields stored at the figure's γ0"
            ))
        })
        .collect()
}

/// The displacement field stored on the increasing-γ0 branch at `gamma0` (within 1e-9
/// relative), and the contact area there.
pub fn displacement_at(r: &ArtefactReader, gamma0: f64) -> Result<(ndarray::Array2<f64>, f64)> {
    // no `fields` group: nothing stored
    let groups = r.members("fields").unwrap_or_default();
    let mut found = Vec::new();
    for g in groups.iter().filter(|g| g.starts_with("loading_")) {
        let s = r.attr_f64_at(&format!("fields/{g}"), "strength")?;
        found.push(s);
        if (s - gamma0).abs() <= 1e-9 * gamma0.abs().max(1e-12) {
            let u = r.read_f64_2d(&format!("fields/{g}/displacement"))?;
            let a = r.attr_f64_at(&format!("fields/{g}"), "contact_area")?;
            return Ok((u, a));
        }
    }
    bail!(
        "`{}` has no fields at γ0 = {gamma0} on the increasing branch (stored at {found:?}): put {gamma0} on the sweep's path and in its `fields_at`",
        r.path().display()
    )
}

/// Figure 1's maps from the inputs, and the contact area of each panel.
pub fn data(inputs: &Inputs, gamma0: f64) -> Result<(ThreeMaps, Vec<f64>)> {
    let mut maps = Vec::new();
    let mut areas = Vec::new();
    for m in MODELS {
        let r = inputs.one(m)?;
        let d = kinds::sweep::SweepData::read(r)?;
        check(&d, m, m)?;
        let (u, area) = displacement_at(r, gamma0)?;
        let mean = u.mean().unwrap_or(0.0);
        let field = u.mapv(|v| mean - v);
        let lattice: surface::Lattice = m.parse()?;
        maps.push(crate::fig4::lattice_map(lattice, d.n as u32, field, true)?);
        areas.push(area);
    }
    Ok((
        ThreeMaps {
            maps,
            colorbar_label: "displacement towards the substrate ⟨$u$⟩ − $u$ / $h$_0".into(),
            shared_range: false,
        },
        areas,
    ))
}

/// The `fig1` scene: elastic displacement at zero load with adhesion for the three models
/// (inputs `hexagonal`, `square`, `triangular`: zero-load γ0 `sweep`s with fields at `gamma0`),
/// lattice overlays from the surfaces' critical points; attribute `gamma0`, dataset
/// `contact_area` (per panel).
pub struct Fig1;

/// Figure 1's parameters.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig1Params {
    /// The surface energy γ0 (E* h0²/λ) whose state is shown.
    pub gamma0: f64,
}

impl Scene for Fig1 {
    fn name(&self) -> &'static str {
        "fig1"
    }
    fn doc(&self) -> &'static str {
        "Figure 1: elastic displacement at zero load with adhesion, three models"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn fields_read(&self) -> u64 {
        1
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("gamma0", ParamType::positive())
                .default(0.2)
                .doc("the surface energy γ0 (E* h0²/λ) whose state is shown"),
        ]
    }
    fn parse_typed(&self, params: &Params) -> Result<()> {
        scene_params::<Fig1Params>(self.name(), params).map(drop)
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        inputs()
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![OutputSpec::figure("figure", "fig1")]
    }
    fn render(
        &self,
        _ctx: &mut StageContext,
        params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let g = scene_params::<Fig1Params>(self.name(), params)?.gamma0;
        let (maps, areas) = data(inputs, g)?;
        out.set_attr("gamma0", g)?;
        out.write_f64_1d("contact_area", &areas)?;
        let fig = figures::scenes::maps::figure(&maps, figures::heatmap::Colormap::Inferno)?;
        Ok(Outputs::new().figure("figure", fig))
    }
}
