//! Leakage against load on a user's surface (scene `surface_leakage`; not `leakage`, the
//! compute kind's name: kinds and scenes share one namespace): the surface (height map and
//! isotropic PSD with the fitted slope and, for a generated surface, the requested −2(1+H)),
//! the contact/gap map at the `leakage` stage's `map_load`, and the conductivity along x and y
//! against load (log axis) with the fluid percolation load L_p marked.
//!
//! Inputs: `surface` (a `surface`, `selfaffine` or `topography` stage) and `leakage` (the
//! `leakage` stage on it, with `map_load > 0`).
//!
//! Outputs: figures `leakage_surface`, `leakage_map`, `leakage`; table `leakage.csv`, one row
//! per load with the columns of `kinds::leakage::POINT_COLUMNS` (`load`, `load_over_p_fc`,
//! `contact_area`, `contact_area_corrected`, `mean_gap`, `flux_x`, `flux_y`, `conductivity_x`,
//! `conductivity_y`, `fluid_percolates_x|y`, `contact_blocks_x|y`, `flow_converged`,
//! `iterations`, `max_violation`). The PSD slope is fitted over q_r…q_s for a generated surface,
//! else over the bins between 2 × the smallest and half the largest wavenumber.

use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::{Result, bail};
use figures::scenes::leakage::{
    LeakageFig, MapFig, SurfaceFig, leakage_figure, map_figure, surface_figure,
};
use kinds::leakage::{LeakageRead, SURFACE_KINDS};
use orchestrator::{InputSpec, Inputs, Params, StageContext};
use serde_json::json;
use store::{ArtefactReader, ArtefactWriter};
use surface::spectrum::psd_slope;

/// The `surface_leakage` scene.
pub struct SurfaceLeakage;

/// The binned PSD of a height-field artefact, the fit range and the requested slope.
pub fn surface_data(r: &ArtefactReader) -> Result<SurfaceFig> {
    let field = kinds::selfaffine::read_height_field(r)?;
    let bins = kinds::selfaffine::read_psd(r)?;
    let q: Vec<f64> = bins.iter().map(|b| b.q).collect();
    let c: Vec<f64> = bins.iter().map(|b| b.c).collect();
    let (q_lo, q_hi) = match (r.attr_f64("qr"), r.attr_f64("qs")) {
        (Ok(qr), Ok(qs)) => {
            let q0 = 2.0 * std::f64::consts::PI / field.grid.lx;
            (qr * q0, qs * q0)
        }
        _ => {
            let (lo, hi) = q
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
            (2.0 * lo, 0.5 * hi)
        }
    };
    Ok(SurfaceFig {
        height: field.heights,
        lx: field.grid.lx,
        ly: field.grid.ly,
        psd_q: q,
        psd_c: c,
        fitted_slope: psd_slope(&bins, q_lo, q_hi),
        fit_range: (q_lo, q_hi),
        model_slope: r.attr_f64("psd_slope_model").ok(),
    })
}

impl Scene for SurfaceLeakage {
    fn name(&self) -> &'static str {
        "surface_leakage"
    }
    fn doc(&self) -> &'static str {
        "a user's surface: height map and PSD, contact/gap map, leakage against load with L_p (figures, table)"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn fields_read(&self) -> u64 {
        3
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        vec![
            InputSpec::one("surface", &SURFACE_KINDS).doc("the height field"),
            InputSpec::one("leakage", &["leakage"]).doc("the leakage stage on it (map_load > 0)"),
        ]
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::figure("surface", "leakage_surface"),
            OutputSpec::figure("map", "leakage_map"),
            OutputSpec::figure("leakage", "leakage"),
            OutputSpec::table("points", "leakage.csv"),
        ]
    }
    fn render(
        &self,
        _ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        _out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let s = surface_data(inputs.one("surface")?)?;
        let l = LeakageRead::read(inputs.one("leakage")?)?;
        let Some((gap, _pressure, load)) = &l.map else {
            bail!("input `leakage` has no gap map: set `map_load` > 0 in the leakage stage");
        };
        let m = MapFig {
            gap: gap.clone(),
            lx: s.lx,
            ly: s.ly,
            load_over_p_fc: load / l.p_fc,
            contact_area: gap.iter().filter(|g| **g <= 0.0).count() as f64 / gap.len() as f64,
        };
        let percolation = l
            .percolation
            .as_ref()
            .map(|p| (p["any"].load / l.p_fc, p["any"].a_p));
        let lf = LeakageFig {
            load: l.column("load_over_p_fc")?.to_vec(),
            conductivity_x: l.column("conductivity_x")?.to_vec(),
            conductivity_y: l.column("conductivity_y")?.to_vec(),
            percolation,
        };
        Ok(Outputs::new()
            .figure("surface", surface_figure(&s)?)
            .figure("map", map_figure(&m)?)
            .figure("leakage", leakage_figure(&lf)?)
            .table("points", l.table())
            .with_stats(json!({
                "psd_slope": s.fitted_slope,
                "psd_slope_model": s.model_slope,
                "l_p_over_p_fc": percolation.map(|p| p.0),
                "a_p": percolation.map(|p| p.1),
            })))
    }
}
