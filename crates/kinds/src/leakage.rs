//! `leakage`: leakage against load on any surface artefact (`surface`, `selfaffine`,
//! `topography`: dataset `height` and attributes `lx`, `ly`) — the physics is
//! `critical::leakage`.
//!
//! # Parameters
//! - `loads` (list, > 0): mean pressures of the warm-started hard-wall load path, as fractions
//!   of the full-contact pressure p_fc = −min(K h) when `relative` (default true), else in
//!   E* h0/λ;
//! - `boundary` (`periodic` | `free`, default `periodic`), `sides` (`noflux` | `periodic`, the
//!   edges parallel to the flow of a free patch; default `noflux`);
//! - `tol_gap` (Polonsky–Keer constraint violation, default 1e-10), `flow_tol` (relative
//!   residual of the Reynolds solves, default 1e-10);
//! - `percolation` (default true): bracket the load at which the fluid stops percolating by
//!   bisection (`critical::leakage::percolation_load`) to a relative width `rel_width`
//!   (default 1e-6);
//! - `map_load` (default 0 = none; relative like `loads`): a load at which the gap and
//!   pressure fields are stored (the contact/gap map of the figures).
//!
//! # Artefact
//! - root attributes `boundary`, `sides`, `nx`, `ny`, `lx`, `ly`, `p_fc`, `n_points`,
//!   `surface_seed` and `surface_source` (copied from the input's `seed`, `source` if present),
//!   `n_flow_unconverged`, `last_percolating_load`, `first_sealed_load` (NaN if none);
//! - `points/<column>`, one entry per load, ascending: the columns of [`POINT_COLUMNS`] (one
//!   spec for writing, reading and the tables);
//! - `percolation/<criterion>/` (`any`, `x`, `y`) with attributes `load_lo`, `load_hi`
//!   (fluid percolating at `lo`, blocked at `hi`), `load` (midpoint; for `any` the paper's
//!   L_p), `area_lo`, `area_hi`, `a_p` (raw, mean of the ends), `a_p_corrected`;
//!   `percolation` attributes `probes`, `iterations`, `retries`;
//! - `map/gap`, `map/pressure` with attributes `load`, `contact_area`, `mean_gap`.

use anyhow::{Result, anyhow, bail};
use critical::bracket::BracketSeed;
use critical::leakage::{
    Boundary, LeakageOptions, LeakagePoint, PercolationLoad, PercolationOptions, SideEdges,
};
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, ParamType, StageContext, StageReport, TypedKind,
};
use serde::Deserialize;
use serde_json::json;
use std::collections::BTreeMap;
use store::{ArtefactReader, ArtefactWriter};
use surface::HeightField;

/// The `leakage` stage kind.
pub struct LeakageKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 1;

/// Kinds whose artefacts are height fields.
pub const SURFACE_KINDS: [&str; 3] = ["surface", "selfaffine", "topography"];

/// One column of the per-load table: its name, a flag column (stored as u8, 0/1) or a number,
/// and how it is computed from a point and p_fc.
pub struct PointColumn {
    /// Dataset name under `points/` and CSV header.
    pub name: &'static str,
    /// Stored as u8 (0/1) when true.
    pub flag: bool,
    /// The value of a point (flags as 0.0/1.0).
    pub get: fn(&LeakagePoint, f64) -> f64,
}

const fn col(name: &'static str, get: fn(&LeakagePoint, f64) -> f64) -> PointColumn {
    PointColumn {
        name,
        flag: false,
        get,
    }
}

const fn flag(name: &'static str, get: fn(&LeakagePoint, f64) -> f64) -> PointColumn {
    PointColumn {
        name,
        flag: true,
        get,
    }
}

fn b(x: bool) -> f64 {
    if x { 1.0 } else { 0.0 }
}

/// The per-load columns, in table order.
pub const POINT_COLUMNS: [PointColumn; 16] = [
    col("load", |p, _| p.load),
    col("load_over_p_fc", |p, p_fc| p.load / p_fc),
    col("contact_area", |p, _| p.area.raw),
    col("contact_area_corrected", |p, _| p.area.corrected),
    col("mean_gap", |p, _| p.mean_gap),
    col("flux_x", |p, _| p.flow_x.flux),
    col("flux_y", |p, _| p.flow_y.flux),
    col("conductivity_x", |p, _| p.flow_x.conductivity),
    col("conductivity_y", |p, _| p.flow_y.conductivity),
    flag("fluid_percolates_x", |p, _| b(p.state.fluid_x)),
    flag("fluid_percolates_y", |p, _| b(p.state.fluid_y)),
    flag("contact_blocks_x", |p, _| b(p.state.blocked_x)),
    flag("contact_blocks_y", |p, _| b(p.state.blocked_y)),
    flag("flow_converged", |p, _| {
        b(p.flow_x.converged && p.flow_y.converged)
    }),
    col("iterations", |p, _| p.iterations as f64),
    col("max_violation", |p, _| p.max_violation),
];

/// The `leakage` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LeakageParams {
    /// Loads (fractions of p_fc when `relative`).
    pub loads: Vec<f64>,
    /// Loads relative to p_fc.
    pub relative: bool,
    /// `periodic` or `free`.
    pub boundary: String,
    /// `noflux` or `periodic`.
    pub sides: String,
    /// Constraint tolerance (h0).
    pub tol_gap: f64,
    /// Reynolds relative residual.
    pub flow_tol: f64,
    /// Bracket the percolation load.
    pub percolation: bool,
    /// Relative bracket width.
    pub rel_width: f64,
    /// Load of the stored fields (0: none).
    pub map_load: f64,
}

impl LeakageParams {
    /// The boundary named by `boundary` and `sides`.
    pub fn boundary(&self) -> Result<Boundary, ParamIssue> {
        let sides = match self.sides.as_str() {
            "noflux" => SideEdges::NoFlux,
            "periodic" => SideEdges::Periodic,
            o => {
                return Err(ParamIssue::new(
                    "sides",
                    format!("\"{o}\"; allowed: noflux, periodic"),
                ));
            }
        };
        match self.boundary.as_str() {
            "periodic" => Ok(Boundary::Periodic),
            "free" => Ok(Boundary::Free { sides }),
            o => Err(ParamIssue::new(
                "boundary",
                format!("\"{o}\"; allowed: periodic, free"),
            )),
        }
    }
}

/// The side edges' name of a boundary (`none` for periodic).
pub fn sides_name(b: Boundary) -> &'static str {
    match b {
        Boundary::Periodic => "none",
        Boundary::Free {
            sides: SideEdges::NoFlux,
        } => "noflux",
        Boundary::Free {
            sides: SideEdges::Periodic,
        } => "periodic",
    }
}

impl TypedKind for LeakageKind {
    type Params = LeakageParams;
    fn name(&self) -> &str {
        "leakage"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "leakage against load on a surface: area, gap, flux, percolation per load; the percolation load and a_p"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("loads", ParamType::array_of(ParamType::positive()))
                .doc("loads of the path (fractions of p_fc when relative)"),
            ParamSpec::new("relative", ParamType::Bool)
                .default(true)
                .doc("loads and map_load as fractions of p_fc = −min(K h)"),
            ParamSpec::new("boundary", ParamType::one_of(&["periodic", "free"]))
                .default("periodic")
                .doc("periodic cell, or a free patch (flow between reservoirs)"),
            ParamSpec::new("sides", ParamType::one_of(&["noflux", "periodic"]))
                .default("noflux")
                .doc("free boundary: the edges parallel to the flow"),
            crate::solver::tol_gap_spec(),
            ParamSpec::new("flow_tol", ParamType::float_range(1e-14, 0.5))
                .default(1e-10)
                .doc("relative residual of the Reynolds solves"),
            ParamSpec::new("percolation", ParamType::Bool)
                .default(true)
                .doc("bracket the fluid percolation load by bisection"),
            ParamSpec::new("rel_width", ParamType::float_range(1e-12, 0.1))
                .default(1e-6)
                .doc("relative width of the percolation brackets"),
            ParamSpec::new("map_load", ParamType::non_negative())
                .default(0.0)
                .doc("load at which gap and pressure are stored (0: none)"),
        ]
    }
    fn check(&self, params: &LeakageParams) -> Result<(), ParamIssue> {
        params.boundary().map(drop)
    }
    /// Heights, gap, pressure and displacement of the surface upstream (lower bound; the
    /// solver's FFT buffers come on top).
    fn memory_estimate(
        &self,
        _params: &orchestrator::Params,
        inputs: &BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        crate::topography::upstream_field_bytes(inputs).map(|b| 4 * b)
    }
    fn inputs(&self, _params: &LeakageParams) -> Vec<InputSpec> {
        vec![InputSpec::one("surface", &SURFACE_KINDS).doc("the height field")]
    }
    fn cost(&self, params: &LeakageParams) -> f64 {
        params.loads.len() as f64 + if params.percolation { 20.0 } else { 0.0 }
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &LeakageParams,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let surf = inputs.one("surface")?;
        let field = crate::selfaffine::read_height_field(surf)?;
        let boundary = params.boundary().map_err(|e| anyhow!("{e}"))?;
        let p_fc = critical::leakage::full_contact_pressure(&field);
        if !(p_fc.is_finite() && p_fc > 0.0) {
            bail!(
                "input `surface`: full-contact pressure {p_fc:e}: a flat surface has no leakage path"
            );
        }
        let scale = if params.relative { p_fc } else { 1.0 };
        let loads: Vec<f64> = params.loads.iter().map(|l| l * scale).collect();
        let opts = LeakageOptions {
            tol_gap: params.tol_gap,
            flow: reynolds::FlowOptions {
                tolerance: params.flow_tol,
                ..Default::default()
            },
            ..Default::default()
        };
        let path = critical::leakage::leakage_path(&field, boundary, &loads, &opts)?;
        ctx.progress(0.4, "load path solved");
        write_header(out, surf, &field.grid, boundary, p_fc, path.points.len())?;
        write_path(ctx, out, &path.points, p_fc)?;
        let mut stats = json!({"points": path.points.len(), "wall_s_path": path.wall_s});
        if params.percolation {
            let popts = PercolationOptions {
                tol_gap: params.tol_gap,
                rel_width: params.rel_width,
                ..Default::default()
            };
            let pl = critical::leakage::percolation_load(&field, boundary, &popts)?;
            write_percolation(out, &pl)?;
            stats["probes"] = json!(pl.probes);
            stats["a_p"] = json!(0.5 * (pl.any.area_lo.raw + pl.any.area_hi.raw));
            ctx.progress(0.8, "percolation load bracketed");
        }
        if params.map_load > 0.0 {
            write_map(
                out,
                &field,
                boundary,
                params.map_load * scale,
                params.tol_gap,
            )?;
        }
        ctx.progress(1.0, "written");
        Ok(StageReport::with_stats(stats))
    }
}

/// Root attributes: the cell, the boundary, the grid, p_fc and which surface.
fn write_header(
    out: &mut ArtefactWriter,
    surf: &ArtefactReader,
    g: &surface::Grid,
    boundary: Boundary,
    p_fc: f64,
    n_points: usize,
) -> Result<()> {
    out.set_cell(g.lx, g.ly)?;
    out.set_attr("boundary", boundary.name())?;
    out.set_attr("sides", sides_name(boundary))?;
    out.set_attr("nx", g.nx as i64)?;
    out.set_attr("ny", g.ny as i64)?;
    out.set_attr("p_fc", p_fc)?;
    out.set_attr("n_points", n_points as i64)?;
    // which surface: a generated one's seed (for ensembles), the kind that made it
    if let Ok(seed) = surf.attr_i64("seed") {
        out.set_attr("surface_seed", seed)?;
    }
    if let Ok(source) = surf.attr_str("source") {
        out.set_attr("surface_source", source.as_str())?;
    }
    Ok(())
}

/// The load path: `points/*`, the unconverged-flow count and warnings, the last percolating
/// and first sealed loads.
fn write_path(
    ctx: &mut StageContext,
    out: &mut ArtefactWriter,
    points: &[LeakagePoint],
    p_fc: f64,
) -> Result<()> {
    let unconverged = write_points(out, points, p_fc)?;
    out.set_attr("n_flow_unconverged", unconverged as i64)?;
    for p in points
        .iter()
        .filter(|p| !(p.flow_x.converged && p.flow_y.converged))
    {
        ctx.warn(format!(
            "load {:e}: a Reynolds solve did not converge",
            p.load
        ));
    }
    let open = points
        .iter()
        .filter(|p| p.state.fluid_any())
        .map(|p| p.load);
    let sealed = points.iter().find(|p| !p.state.fluid_any()).map(|p| p.load);
    out.set_attr(
        "last_percolating_load",
        open.reduce(f64::max).unwrap_or(f64::NAN),
    )?;
    out.set_attr("first_sealed_load", sealed.unwrap_or(f64::NAN))?;
    Ok(())
}

/// Writes `points/*` from [`POINT_COLUMNS`]; returns the number of points whose flow did not
/// converge.
fn write_points(out: &mut ArtefactWriter, points: &[LeakagePoint], p_fc: f64) -> Result<usize> {
    for c in &POINT_COLUMNS {
        let v: Vec<f64> = points.iter().map(|p| (c.get)(p, p_fc)).collect();
        let path = format!("points/{}", c.name);
        if c.flag {
            out.write_u8_1d(&path, &v.iter().map(|&x| x as u8).collect::<Vec<_>>())?;
        } else {
            out.write_f64_1d(&path, &v)?;
        }
    }
    Ok(points
        .iter()
        .filter(|p| !(p.flow_x.converged && p.flow_y.converged))
        .count())
}

/// The percolation brackets `(load_lo, load_hi)` of a `leakage` artefact in
/// `critical::Criterion::ALL` order (any, x, y), or None if it has none (`percolation = false`).
pub fn percolation_brackets(r: &ArtefactReader) -> Result<Option<BracketSeed>> {
    if r.attr_i64_at("percolation", "probes").is_err() {
        return Ok(None);
    }
    let end = |c: &str, k: &str| r.attr_f64_at(&format!("percolation/{c}"), k);
    let mut out = [(f64::NAN, f64::NAN); 3];
    for (o, c) in out.iter_mut().zip(critical::Criterion::ALL) {
        *o = (end(c.name(), "load_lo")?, end(c.name(), "load_hi")?);
    }
    Ok(Some(out))
}

fn write_percolation(out: &mut ArtefactWriter, pl: &PercolationLoad) -> Result<()> {
    out.create_group("percolation")?;
    out.set_attr_at("percolation", "probes", pl.probes as i64)?;
    out.set_attr_at("percolation", "iterations", pl.iterations as i64)?;
    out.set_attr_at("percolation", "retries", pl.retries as i64)?;
    for (name, t) in [("any", &pl.any), ("x", &pl.x), ("y", &pl.y)] {
        let g = format!("percolation/{name}");
        out.create_group(&g)?;
        let (lo, hi) = (t.bracket.lo, t.bracket.hi);
        out.set_attr_at(&g, "load_lo", lo)?;
        out.set_attr_at(&g, "load_hi", hi)?;
        out.set_attr_at(&g, "load", 0.5 * (lo + hi))?;
        out.set_attr_at(&g, "area_lo", t.area_lo.raw)?;
        out.set_attr_at(&g, "area_hi", t.area_hi.raw)?;
        out.set_attr_at(&g, "a_p", 0.5 * (t.area_lo.raw + t.area_hi.raw))?;
        out.set_attr_at(
            &g,
            "a_p_corrected",
            0.5 * (t.area_lo.corrected + t.area_hi.corrected),
        )?;
    }
    Ok(())
}

fn write_map(
    out: &mut ArtefactWriter,
    field: &HeightField,
    boundary: Boundary,
    load: f64,
    tol_gap: f64,
) -> Result<()> {
    let elastic = match boundary {
        Boundary::Periodic => contact::free_kernel::Boundary::Periodic,
        Boundary::Free { .. } => contact::free_kernel::Boundary::Free,
    };
    let mut model = contact::Model::with_boundary(field.grid, field.heights.view(), elastic)?;
    let opts = contact::SolverOptions {
        tol_gap,
        method: contact::Method::PolonskyKeer,
        ..Default::default()
    };
    let sol = model.solve(contact::Interaction::HardWall, load, &opts, None)?;
    if !sol.stats.converged {
        bail!("map_load {load:e}: the contact solve did not converge");
    }
    out.write_f64_2d("map/gap", sol.gap.view())?;
    out.write_f64_2d("map/pressure", sol.pressure.view())?;
    out.set_attr_at("map", "load", load)?;
    out.set_attr_at("map", "contact_area", sol.contact_area)?;
    out.set_attr_at("map", "mean_gap", sol.mean_gap)?;
    Ok(())
}

/// The percolation bracket of one criterion, read back.
#[derive(Clone, Debug, PartialEq)]
pub struct PercolationRead {
    /// Load where the fluid still percolates.
    pub load_lo: f64,
    /// Load where it is blocked.
    pub load_hi: f64,
    /// Midpoint.
    pub load: f64,
    /// Raw contact area at the threshold (mean of the ends).
    pub a_p: f64,
    /// Perimeter-corrected.
    pub a_p_corrected: f64,
}

/// A `leakage` artefact read back.
#[derive(Clone, Debug)]
pub struct LeakageRead {
    /// Full-contact pressure.
    pub p_fc: f64,
    /// `points/*` by column name (flags as 0.0/1.0), in [`POINT_COLUMNS`] order.
    pub points: BTreeMap<String, Vec<f64>>,
    /// `any`, `x`, `y` brackets, if the percolation load was computed.
    pub percolation: Option<BTreeMap<String, PercolationRead>>,
    /// The input surface's seed (a generated surface).
    pub seed: Option<i64>,
    /// Gap and pressure at the map load, with the load.
    pub map: Option<(ndarray::Array2<f64>, ndarray::Array2<f64>, f64)>,
}

impl LeakageRead {
    /// Reads a `leakage` artefact.
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let mut points = BTreeMap::new();
        for c in &POINT_COLUMNS {
            let path = format!("points/{}", c.name);
            let v = if c.flag {
                r.read_u8_1d(&path)?.into_iter().map(f64::from).collect()
            } else {
                r.read_f64_1d(&path)?
            };
            points.insert(c.name.to_string(), v);
        }
        let percolation = if r.attr_f64_at("percolation/any", "load").is_ok() {
            let mut m = BTreeMap::new();
            for name in ["any", "x", "y"] {
                let g = format!("percolation/{name}");
                let a = |k: &str| r.attr_f64_at(&g, k);
                m.insert(
                    name.to_string(),
                    PercolationRead {
                        load_lo: a("load_lo")?,
                        load_hi: a("load_hi")?,
                        load: a("load")?,
                        a_p: a("a_p")?,
                        a_p_corrected: a("a_p_corrected")?,
                    },
                );
            }
            Some(m)
        } else {
            None
        };
        let map = if r.has_dataset("map/gap") {
            Some((
                r.read_f64_2d("map/gap")?,
                r.read_f64_2d("map/pressure")?,
                r.attr_f64_at("map", "load")?,
            ))
        } else {
            None
        };
        Ok(Self {
            p_fc: r.attr_f64("p_fc")?,
            seed: r.attr_i64("surface_seed").ok(),
            points,
            percolation,
            map,
        })
    }

    /// A column of `points/*`.
    pub fn column(&self, name: &str) -> Result<&[f64]> {
        self.points
            .get(name)
            .map(Vec::as_slice)
            .ok_or_else(|| anyhow!("leakage artefact: no column `points/{name}`"))
    }

    /// The per-load table (columns of [`POINT_COLUMNS`]; flags as booleans).
    pub fn table(&self) -> tables::Table {
        let mut t = tables::Table::new();
        for c in &POINT_COLUMNS {
            let v = self.points[c.name].clone();
            if c.flag {
                t = t.with_bool(c.name, v.into_iter().map(|x| x != 0.0));
            } else if c.name == "iterations" {
                t = t.with_i64(c.name, v.into_iter().map(|x| x as i64));
            } else {
                t = t.with_f64(c.name, v);
            }
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn surface(dir: &std::path::Path) -> ArtefactReader {
        crate::selfaffine::test_surface(dir, 5, 1)
    }

    fn params(v: serde_json::Value) -> LeakageParams {
        let mut d = json!({"loads": [0.05, 0.2, 0.5], "relative": true, "boundary": "periodic",
            "sides": "noflux", "tol_gap": 1e-10, "flow_tol": 1e-10, "percolation": true,
            "rel_width": 1e-4, "map_load": 0.2});
        for (k, x) in v.as_object().unwrap() {
            d[k] = x.clone();
        }
        serde_json::from_value(d).unwrap()
    }

    /// The stage's artefact holds what `critical::leakage` computes on the same field (the
    /// kind only adapts): the same areas per load and the same percolation bracket, bit for
    /// bit; the threshold lies inside the path's open/sealed loads when both occur; the map's
    /// contact area equals the path's at the same load to the solver tolerance.
    #[test]
    fn artefact_matches_the_physics_crate() {
        let dir = tempfile::tempdir().unwrap();
        let s = surface(dir.path());
        let field = crate::selfaffine::read_height_field(&s).unwrap();
        let inputs = Inputs::new(BTreeMap::from([("surface".to_string(), vec![s])]));
        let p = params(json!({}));
        let path = dir.path().join("l.h5");
        let mut w = ArtefactWriter::create(&path).unwrap();
        let mut ctx = StageContext::detached("l", dir.path());
        LeakageKind.run(&mut ctx, &p, &inputs, &mut w).unwrap();
        w.publish().unwrap();
        let r = LeakageRead::read(&ArtefactReader::open(&path).unwrap()).unwrap();
        let p_fc = critical::leakage::full_contact_pressure(&field);
        let loads: Vec<f64> = p.loads.iter().map(|l| l * p_fc).collect();
        let direct = critical::leakage::leakage_path(
            &field,
            Boundary::Periodic,
            &loads,
            &LeakageOptions::default(),
        )
        .unwrap();
        let areas: Vec<f64> = direct.points.iter().map(|q| q.area.raw).collect();
        assert_eq!(r.column("contact_area").unwrap(), areas.as_slice());
        let perc = r.percolation.as_ref().unwrap();
        let any = &perc["any"];
        assert!(any.load_lo < any.load_hi && any.a_p > 0.0 && any.a_p < 1.0);
        let direct_pl = critical::leakage::percolation_load(
            &field,
            Boundary::Periodic,
            &PercolationOptions {
                rel_width: 1e-4,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(any.load_lo, direct_pl.any.bracket.lo);
        let (gap, _pressure, load) = r.map.as_ref().unwrap();
        assert_eq!(*load, 0.2 * p_fc);
        let map_area = gap.iter().filter(|g| **g <= 0.0).count() as f64 / gap.len() as f64;
        assert_eq!(map_area, areas[1], "the same contact set at the same load");
        assert_eq!(r.table().n_rows(), 3);
        assert_eq!(r.seed, Some(1));
    }

    #[test]
    fn unknown_boundary_names_the_parameter() {
        let e = LeakageKind
            .check(&params(json!({"boundary": "open"})))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("`boundary`") && e.contains("periodic, free"),
            "{e}"
        );
    }
}
