//! `constriction`: the last constriction of a surface near its fluid percolation load and β
//! (issue 15) — the physics is `critical::constriction`: L_c by bisection, a 1-2-5 ladder of
//! distances d = (L_c − L)/L_c below it, at every rung the certified flux along the axis that
//! closes last and the last constriction (node, gap, η of heights and gap, pressure-drop
//! fraction), running exponents and the β window fit.
//!
//! Input `surface`: any height-field artefact (dataset `height`, attributes `lx`, `ly`: the
//! `surface`, `selfaffine` and `topography` kinds); periodic cell only. Its `seed`, `hurst`,
//! `qr`, `qs` attributes (a `selfaffine` surface) are copied as provenance of the realisation
//! (NaN where absent).
//!
//! Optional input `leakage`: a `leakage` stage of the same surface with `percolation = true`.
//! Its percolation brackets (any, x, y: the same transitions, boundary, winding criterion and
//! contact solver, to its coarser `rel_width`) seed the bisection of L_c instead of the
//! expansion from 0.3 p_fc (`critical::constriction`, "Seeded bracket"). It is used only if it
//! is periodic, on the surface's grid, with the surface's p_fc (a fingerprint of the heights)
//! and seed; the seed's ends are re-solved and must be open at lo, blocked at hi. Otherwise the
//! stage warns and brackets from scratch. L_c then agrees with the unseeded stage's to
//! `rel_width` (not bit for bit).
//!
//! # Parameters
//! `d_max`, `d_min` (the 1-2-5 ladder between them; default 5e-2 … 1e-4), `min_width` (2),
//! `affine_radius` (8), `min_contact_changes` (1), `window` (2), `tol_gap` (1e-10),
//! `rel_width` (1e-9), `flow_tol` (1e-10): see `critical::constriction::ConstrictionOptions`.
//!
//! # Artefact
//! - root attributes (one realisation, [`SUMMARY`] order): `seed`, `hurst`, `qr`, `qs`, `p_fc`,
//!   `l_c`, `l_c_lo`, `l_c_hi`, `l_c_x`, `l_c_y`, `a_p_raw`, `a_p_corrected`, `axis` (0 = x,
//!   1 = y), `node_i`, `node_j`, `x`, `y`, `gap`, `eta_height`, `eta_gap` (NaN where contact is
//!   within the stencil: `eta_gap_status` says why), `eta_gap_nearest` and `eta_gap_nearest_d`
//!   (η of the gap at the rung nearest L_c where it is defined, on the same constriction, and
//!   that rung's d; NaN if none), `drop_fraction`, `drop_axial`, `beta`, `beta_err`, `beta_points`,
//!   `gap_exponent`, `gap_exponent_err`, `n_rungs`, `n_resolved`, `wall_s`;
//!   also `lx`, `ly`, `nx`, `ny`, and the string `eta_gap_status` ([`eta_gap_status`]:
//!   `eighth`, `second`, `contact_in_3x3`, `stencil_error`, or `no_constriction`);
//! - `rungs/<column>` ([`RUNG_COLUMNS`], among them `eta_gap`), largest d first;
//! - `running/beta/{d_hi,d_lo,value,error}` and `running/gap/…`;
//! - `map/gap`: the gap just below L_c (the bracket's lower end).

use anyhow::{Result, anyhow};
use critical::bracket::{BracketSeed, SeedOutcome};
use critical::constriction::{
    ConstrictionOptions, ConstrictionRung, ConstrictionStudy, RunningSlope, constriction_study,
    ladder_125,
};
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, ParamType, StageContext, StageReport, TypedKind,
};
use percolation::Axis;
use serde::Deserialize;
use serde_json::json;
use std::collections::BTreeMap;
use store::{ArtefactReader, ArtefactWriter};

/// The `constriction` stage kind.
pub struct ConstrictionKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 3;

/// The kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstrictionParams {
    /// Largest distance of the ladder.
    pub d_max: f64,
    /// Smallest distance of the ladder.
    pub d_min: f64,
    /// Throat width (nodes) for a resolved rung.
    pub min_width: usize,
    /// Half-size of the square of the affine-regime check (nodes).
    pub affine_radius: usize,
    /// Contact changes needed in it.
    pub min_contact_changes: usize,
    /// Half-size of the pressure-drop square (nodes).
    pub window: usize,
    /// Polonsky–Keer tolerance (h0).
    pub tol_gap: f64,
    /// Relative bracket width of L_c.
    pub rel_width: f64,
    /// Reynolds relative residual.
    pub flow_tol: f64,
}

impl ConstrictionParams {
    /// The library's options.
    pub fn options(&self) -> ConstrictionOptions {
        ConstrictionOptions {
            tol_gap: self.tol_gap,
            rel_width: self.rel_width,
            ladder: ladder_125(self.d_max, self.d_min),
            min_width: self.min_width,
            affine_radius: self.affine_radius,
            min_contact_changes: self.min_contact_changes,
            window_half_length: self.window,
            flow: reynolds::FlowOptions {
                tolerance: self.flow_tol,
                ..Default::default()
            },
            keep_gap: true,
            ..Default::default()
        }
    }
}

/// One per-rung column: name and value.
pub struct RungColumn {
    /// Dataset name under `rungs/`.
    pub name: &'static str,
    /// The value of a rung.
    pub get: fn(&ConstrictionRung) -> f64,
}

fn flag(b: bool) -> f64 {
    if b { 1.0 } else { 0.0 }
}

fn cgap(r: &ConstrictionRung) -> f64 {
    r.constriction.as_ref().map_or(f64::NAN, |c| c.gap)
}

/// The per-rung columns.
pub const RUNG_COLUMNS: [RungColumn; 14] = [
    RungColumn {
        name: "d",
        get: |r| r.d,
    },
    RungColumn {
        name: "load",
        get: |r| r.load,
    },
    RungColumn {
        name: "contact_area",
        get: |r| r.contact_area,
    },
    RungColumn {
        name: "flux",
        get: |r| r.flux,
    },
    RungColumn {
        name: "flux_error",
        get: |r| r.flux_error,
    },
    RungColumn {
        name: "gap",
        get: cgap,
    },
    RungColumn {
        name: "eta_gap",
        get: |r| {
            r.constriction
                .as_ref()
                .and_then(|c| c.gap_curvature)
                .map_or(f64::NAN, |g| g.eta)
        },
    },
    RungColumn {
        name: "node_i",
        get: |r| {
            r.constriction
                .as_ref()
                .map_or(f64::NAN, |c| c.node.0 as f64)
        },
    },
    RungColumn {
        name: "node_j",
        get: |r| {
            r.constriction
                .as_ref()
                .map_or(f64::NAN, |c| c.node.1 as f64)
        },
    },
    RungColumn {
        name: "width_nodes",
        get: |r| {
            r.constriction
                .as_ref()
                .map_or(f64::NAN, |c| c.width_nodes as f64)
        },
    },
    RungColumn {
        name: "drop_fraction",
        get: |r| r.drop.unwrap_or(f64::NAN),
    },
    RungColumn {
        name: "contact_changes",
        get: |r| r.contact_changes as f64,
    },
    RungColumn {
        name: "same_constriction",
        get: |r| flag(r.same_constriction),
    },
    RungColumn {
        name: "resolved",
        get: |r| flag(r.resolved),
    },
];

/// The per-realisation summary attributes, in table order.
pub const SUMMARY: [&str; 32] = [
    "seed",
    "hurst",
    "qr",
    "qs",
    "p_fc",
    "l_c",
    "l_c_lo",
    "l_c_hi",
    "l_c_x",
    "l_c_y",
    "a_p_raw",
    "a_p_corrected",
    "axis",
    "node_i",
    "node_j",
    "x",
    "y",
    "gap",
    "eta_height",
    "eta_gap",
    "eta_gap_nearest",
    "eta_gap_nearest_d",
    "drop_fraction",
    "drop_axial",
    "beta",
    "beta_err",
    "beta_points",
    "gap_exponent",
    "gap_exponent_err",
    "n_rungs",
    "n_resolved",
    "wall_s",
];

/// How `eta_gap` was measured or why it is NaN: the stencil (`eighth`, `second`), or
/// `contact_in_3x3` (a throat whose neighbours touch: the gap is only C¹ across a contact line,
/// no curvature), `stencil_error`, `no_constriction` (the fluid does not wind just below L_c).
pub fn eta_gap_status(s: &ConstrictionStudy) -> &'static str {
    s.at_l_c
        .constriction
        .as_ref()
        .map_or("no_constriction", |c| c.gap_curvature_status.code())
}

/// The summary values of a study ([`SUMMARY`] order, the surface's four first).
pub fn summary(s: &ConstrictionStudy, surface: [f64; 4]) -> Vec<f64> {
    let c = s.at_l_c.constriction.as_ref();
    let nan = f64::NAN;
    let fit = |f: &Option<critical::scaling::ExponentFit>| {
        f.as_ref()
            .map_or((nan, nan, 0.0), |f| (f.value, f.error, f.points as f64))
    };
    let (beta, beta_err, beta_points) = fit(&s.beta_fit);
    let (ge, ge_err, _) = fit(&s.gap_fit);
    // η of the gap at the rung nearest L_c where it is defined (and the throat is the one at L_c)
    let near = s
        .rungs
        .iter()
        .filter(|r| r.same_constriction)
        .filter_map(|r| Some((r.d, r.constriction.as_ref()?.gap_curvature?.eta)))
        .min_by(|a, b| a.0.total_cmp(&b.0));
    let mut v = surface.to_vec();
    v.extend([
        s.p_fc,
        s.l_c,
        s.bracket.0,
        s.bracket.1,
        s.l_c_x,
        s.l_c_y,
        s.a_p_raw,
        s.a_p_corrected,
        if s.axis == Axis::X { 0.0 } else { 1.0 },
        c.map_or(nan, |c| c.node.0 as f64),
        c.map_or(nan, |c| c.node.1 as f64),
        c.map_or(nan, |c| c.x),
        c.map_or(nan, |c| c.y),
        c.map_or(nan, |c| c.gap),
        c.and_then(|c| c.height).map_or(nan, |h| h.eta),
        c.and_then(|c| c.gap_curvature).map_or(nan, |h| h.eta),
        near.map_or(nan, |r| r.1),
        near.map_or(nan, |r| r.0),
        s.at_l_c.drop.unwrap_or(nan),
        s.at_l_c.drop_axial.map_or(nan, |d| d.fraction),
        beta,
        beta_err,
        beta_points,
        ge,
        ge_err,
        s.rungs.len() as f64,
        s.resolved().count() as f64,
        s.wall_s,
    ]);
    v
}

impl TypedKind for ConstrictionKind {
    type Params = ConstrictionParams;
    /// Lower bound: heights, displacement, pressure and gap of the contact solve, the gap kept
    /// at L_c and the Reynolds pressure on the surface's grid (`n` of a `selfaffine` input; a
    /// topography's size is not in its parameters: unknown).
    fn memory_estimate(
        &self,
        _params: &orchestrator::Params,
        inputs: &BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        let n = orchestrator::upstream_max(inputs, &["n"])?;
        Some(6 * crate::surface::field_bytes(n))
    }
    fn name(&self) -> &str {
        "constriction"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "the last constriction of a surface near its fluid percolation load: L_c, a 1-2-5 ladder below it, flux, constriction gap, η and pressure-drop fraction per rung, running β and the β fit"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("d_max", ParamType::float_range(1e-8, 0.5))
                .default(5e-2)
                .doc("largest distance d = (L_c − L)/L_c of the 1-2-5 ladder"),
            ParamSpec::new("d_min", ParamType::float_range(1e-8, 0.5))
                .default(1e-4)
                .doc("smallest distance of the ladder"),
            ParamSpec::new("min_width", ParamType::int_range(1, 64))
                .default(2)
                .doc("nodes the throat must be wide for a rung to count"),
            ParamSpec::new("affine_radius", ParamType::int_range(0, 256))
                .default(8)
                .doc("half-size (nodes) of the square of the affine-regime check"),
            ParamSpec::new("min_contact_changes", ParamType::int_range(0, 1_000_000))
                .default(1)
                .doc(
                    "contact changes in that square (against L_c) for a rung to count; 0: no check",
                ),
            ParamSpec::new("window", ParamType::int_range(1, 64))
                .default(2)
                .doc("half-size (nodes) of the pressure-drop square at the throat"),
            crate::solver::tol_gap_spec(),
            ParamSpec::new("rel_width", ParamType::float_range(1e-12, 1e-3))
                .default(1e-9)
                .doc("relative bracket width of L_c"),
            ParamSpec::new("flow_tol", ParamType::float_range(1e-14, 1e-3))
                .default(1e-10)
                .doc("relative residual of the Reynolds solves"),
        ]
    }
    fn check(&self, p: &ConstrictionParams) -> Result<(), ParamIssue> {
        if p.d_min > p.d_max || ladder_125(p.d_max, p.d_min).is_empty() {
            return Err(ParamIssue::new(
                "d_min",
                format!(
                    "d_min = {} with d_max = {}: allowed d_min ≤ d_max with a member of the \
                     1-2-5 sequence between them",
                    p.d_min, p.d_max
                ),
            ));
        }
        Ok(())
    }
    fn inputs(&self, _params: &ConstrictionParams) -> Vec<InputSpec> {
        vec![
            InputSpec::one("surface", &crate::leakage::SURFACE_KINDS)
                .doc("the height field (periodic)"),
            InputSpec::one("leakage", &["leakage"]).optional().doc(
                "a leakage stage of the same surface whose percolation brackets seed L_c's \
                 bisection (verified by solves; ignored with a warning if not valid)",
            ),
        ]
    }
    fn cost(&self, params: &ConstrictionParams) -> f64 {
        40.0 + ladder_125(params.d_max, params.d_min).len() as f64
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &ConstrictionParams,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let r = inputs.one("surface")?;
        let field = crate::selfaffine::read_height_field(r)?;
        let provenance = ["seed", "hurst", "qr", "qs"].map(|k| {
            r.attr_f64(k)
                .or_else(|_| r.attr_i64(k).map(|v| v as f64))
                .unwrap_or(f64::NAN)
        });
        let mut opts = params.options();
        if !inputs.all("leakage").is_empty() {
            match leakage_seed(inputs.one("leakage")?, &field, r) {
                Ok(seed) => opts.seed = Some(seed),
                Err(why) => ctx.warn(format!(
                    "input `leakage` not used as a seed ({why}): L_c bracketed from scratch"
                )),
            }
        }
        let s = constriction_study(&field, &opts).map_err(|e| anyhow!("input `surface`: {e}"))?;
        ctx.progress(0.9, "ladder solved");
        for n in &s.notes {
            ctx.warn(n.clone());
        }
        let g = &field.grid;
        out.set_cell(g.lx, g.ly)?;
        out.set_attr("nx", g.nx as i64)?;
        out.set_attr("ny", g.ny as i64)?;
        let values = summary(&s, provenance);
        for (k, v) in SUMMARY.iter().zip(&values) {
            out.set_attr(k, *v)?;
        }
        out.set_attr("eta_gap_status", eta_gap_status(&s))?;
        for c in &RUNG_COLUMNS {
            let v: Vec<f64> = s.rungs.iter().map(|r| (c.get)(r)).collect();
            out.write_f64_1d(&format!("rungs/{}", c.name), &v)?;
        }
        for (name, slopes) in [("beta", &s.running_beta), ("gap", &s.running_gap)] {
            write_slopes(out, &format!("running/{name}"), slopes)?;
        }
        if let Some(gap) = &s.gap_at_l_c {
            out.write_f64_2d("map/gap", gap.view())?;
        }
        ctx.progress(1.0, "written");
        let get = |k: &str| values[SUMMARY.iter().position(|n| *n == k).expect("a summary key")];
        Ok(StageReport::with_stats(json!({
            "l_c": s.l_c,
            "a_p_raw": s.a_p_raw,
            "beta": get("beta"),
            "beta_err": get("beta_err"),
            "eta_height": get("eta_height"),
            "n_resolved": get("n_resolved"),
            "probes": s.probes,
            "seed": match &s.seed {
                SeedOutcome::Unseeded => "none",
                SeedOutcome::Used { .. } => "used",
                SeedOutcome::Rejected { .. } => "rejected",
            },
        })))
    }
}

/// The percolation brackets of a `leakage` artefact as a seed for `field`, or why they cannot
/// be one: no percolation group, another boundary, grid, full-contact pressure or seed than the
/// surface's.
fn leakage_seed(
    leak: &ArtefactReader,
    field: &surface::HeightField,
    surf: &ArtefactReader,
) -> Result<BracketSeed, String> {
    let e = |e: anyhow::Error| e.to_string();
    let boundary = leak.attr_str("boundary").map_err(e)?;
    if boundary != "periodic" {
        return Err(format!(
            "boundary = {boundary}: the constriction's criterion is the periodic winding"
        ));
    }
    let g = &field.grid;
    let (nx, ny) = (
        leak.attr_i64("nx").map_err(e)?,
        leak.attr_i64("ny").map_err(e)?,
    );
    let (lx, ly) = leak.cell().map_err(e)?;
    if (nx, ny, lx, ly) != (g.nx as i64, g.ny as i64, g.lx, g.ly) {
        return Err(format!(
            "grid {nx} × {ny}, cell {lx} × {ly}; the surface's is {} × {}, {} × {}",
            g.nx, g.ny, g.lx, g.ly
        ));
    }
    // p_fc = −min(K h) is a fingerprint of the heights: the same function on the same heights
    // is bit-identical; 1e-12 relative admits FFT rounding only, another surface differs at O(1)
    let (p_leak, p_here) = (
        leak.attr_f64("p_fc").map_err(e)?,
        critical::leakage::full_contact_pressure(field),
    );
    let same = (p_leak - p_here).abs() <= 1e-12 * p_here.abs(); // false for NaN
    if !same {
        return Err(format!(
            "p_fc = {p_leak:e}, the surface's is {p_here:e}: another surface"
        ));
    }
    if let (Ok(a), Ok(b)) = (leak.attr_i64("surface_seed"), surf.attr_i64("seed"))
        && a != b
    {
        return Err(format!("surface_seed = {a}, the surface's seed is {b}"));
    }
    crate::leakage::percolation_brackets(leak)
        .map_err(e)?
        .ok_or_else(|| "no percolation brackets (percolation = false)".to_string())
}

fn write_slopes(out: &mut ArtefactWriter, at: &str, s: &[RunningSlope]) -> Result<()> {
    out.write_f64_1d(
        &format!("{at}/d_hi"),
        &s.iter().map(|r| r.l_hi.abs()).collect::<Vec<_>>(),
    )?;
    out.write_f64_1d(
        &format!("{at}/d_lo"),
        &s.iter().map(|r| r.l_lo.abs()).collect::<Vec<_>>(),
    )?;
    out.write_f64_1d(
        &format!("{at}/value"),
        &s.iter().map(|r| r.value).collect::<Vec<_>>(),
    )?;
    out.write_f64_1d(
        &format!("{at}/error"),
        &s.iter().map(|r| r.fit_error).collect::<Vec<_>>(),
    )?;
    Ok(())
}

/// Running exponents read back.
#[derive(Clone, Debug, Default)]
pub struct SlopesRead {
    /// Farther rung's distance.
    pub d_hi: Vec<f64>,
    /// Nearer rung's distance.
    pub d_lo: Vec<f64>,
    /// Local slope.
    pub value: Vec<f64>,
    /// Its 1σ from the measurements.
    pub error: Vec<f64>,
}

/// A `constriction` artefact read back.
#[derive(Clone, Debug)]
pub struct ConstrictionRead {
    /// [`SUMMARY`] by name.
    pub summary: BTreeMap<String, f64>,
    /// [`eta_gap_status`].
    pub eta_gap_status: String,
    /// `rungs/*` by column name.
    pub rungs: BTreeMap<String, Vec<f64>>,
    /// Running β.
    pub running_beta: SlopesRead,
    /// Running gap exponent.
    pub running_gap: SlopesRead,
    /// The gap just below L_c.
    pub gap: Option<ndarray::Array2<f64>>,
    /// Cell size.
    pub cell: (f64, f64),
}

impl ConstrictionRead {
    /// Reads a `constriction` artefact.
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let mut summary = BTreeMap::new();
        for k in SUMMARY {
            summary.insert(k.to_string(), r.attr_f64(k)?);
        }
        let mut rungs = BTreeMap::new();
        for c in &RUNG_COLUMNS {
            rungs.insert(
                c.name.to_string(),
                r.read_f64_1d(&format!("rungs/{}", c.name))?,
            );
        }
        let slopes = |at: &str| -> Result<SlopesRead> {
            Ok(SlopesRead {
                d_hi: r.read_f64_1d(&format!("{at}/d_hi"))?,
                d_lo: r.read_f64_1d(&format!("{at}/d_lo"))?,
                value: r.read_f64_1d(&format!("{at}/value"))?,
                error: r.read_f64_1d(&format!("{at}/error"))?,
            })
        };
        let gap = if r.has_dataset("map/gap") {
            Some(r.read_f64_2d("map/gap")?)
        } else {
            None
        };
        Ok(ConstrictionRead {
            summary,
            eta_gap_status: r.attr_str("eta_gap_status")?,
            rungs,
            running_beta: slopes("running/beta")?,
            running_gap: slopes("running/gap")?,
            gap,
            cell: r.cell()?,
        })
    }

    /// A summary value (NaN if unknown).
    pub fn get(&self, k: &str) -> f64 {
        self.summary.get(k).copied().unwrap_or(f64::NAN)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn surface(dir: &std::path::Path) -> ArtefactReader {
        crate::selfaffine::test_surface(dir, 6, 3)
    }

    fn params(v: serde_json::Value) -> ConstrictionParams {
        let mut d = json!({"d_max": 5e-2, "d_min": 1e-3, "min_width": 2, "affine_radius": 8,
            "min_contact_changes": 1, "window": 2, "tol_gap": 1e-10, "rel_width": 1e-9,
            "flow_tol": 1e-10});
        for (k, x) in v.as_object().unwrap() {
            d[k] = x.clone();
        }
        serde_json::from_value(d).unwrap()
    }

    /// The artefact holds what `critical::constriction` computes on the same field, bit for
    /// bit (the kind only adapts), and the surface's seed.
    #[test]
    fn artefact_matches_the_physics_crate() {
        let dir = tempfile::tempdir().unwrap();
        let s = surface(dir.path());
        let field = crate::selfaffine::read_height_field(&s).unwrap();
        let inputs = Inputs::new(BTreeMap::from([("surface".to_string(), vec![s])]));
        let p = params(json!({}));
        let path = dir.path().join("c.h5");
        let mut w = ArtefactWriter::create(&path).unwrap();
        let mut ctx = StageContext::detached("c", dir.path());
        ConstrictionKind.run(&mut ctx, &p, &inputs, &mut w).unwrap();
        w.publish().unwrap();
        let r = ConstrictionRead::read(&ArtefactReader::open(&path).unwrap()).unwrap();
        let direct = constriction_study(&field, &p.options()).unwrap();
        assert_eq!(r.get("seed"), 3.0);
        assert_eq!(r.get("l_c"), direct.l_c);
        assert_eq!(r.get("a_p_raw"), direct.a_p_raw);
        let flux: Vec<f64> = direct.rungs.iter().map(|q| q.flux).collect();
        assert_eq!(r.rungs["flux"], flux);
        assert_eq!(r.rungs["d"], vec![5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3]);
        let c = direct.at_l_c.constriction.as_ref().unwrap();
        assert_eq!(r.get("node_i"), c.node.0 as f64);
        assert_eq!(r.get("drop_fraction"), direct.at_l_c.drop.unwrap());
        // η of the gap: a value exactly when the status names a stencil
        assert_eq!(r.eta_gap_status, c.gap_curvature_status.code());
        assert_eq!(
            r.get("eta_gap").is_finite(),
            matches!(r.eta_gap_status.as_str(), "eighth" | "second"),
            "{}",
            r.eta_gap_status
        );
        // the nearest defined η of the gap: the rung at eta_gap_nearest_d carries it, and no
        // nearer rung on the same constriction has one
        let (dn, en) = (r.get("eta_gap_nearest_d"), r.get("eta_gap_nearest"));
        let rung_eta = &r.rungs["eta_gap"];
        for (k, d) in r.rungs["d"].iter().enumerate() {
            let same = r.rungs["same_constriction"][k] > 0.5;
            if *d == dn {
                assert_eq!(rung_eta[k], en);
            } else if same && (dn.is_nan() || *d < dn) {
                assert!(rung_eta[k].is_nan(), "d = {d}: η_g = {}", rung_eta[k]);
            }
        }
        assert_eq!(
            r.get("n_resolved"),
            direct.rungs.iter().filter(|q| q.resolved).count() as f64
        );
        assert_eq!(r.running_beta.value.len(), direct.running_beta.len());
        assert_eq!(r.gap.as_ref().unwrap().dim(), (64, 64));
    }

    /// A `leakage` stage of `s` (percolation brackets to 1e-4, as at draft).
    fn leakage_of(dir: &std::path::Path, s: ArtefactReader) -> ArtefactReader {
        let p: crate::leakage::LeakageParams = serde_json::from_value(json!({"loads": [0.1],
            "relative": true, "boundary": "periodic", "sides": "noflux", "tol_gap": 1e-10,
            "flow_tol": 1e-10, "percolation": true, "rel_width": 1e-4, "map_load": 0.0}))
        .unwrap();
        let path = dir.join("l.h5");
        let mut w = ArtefactWriter::create(&path).unwrap();
        let inputs = Inputs::new(BTreeMap::from([("surface".to_string(), vec![s])]));
        let mut ctx = StageContext::detached("l", dir);
        crate::leakage::LeakageKind
            .run(&mut ctx, &p, &inputs, &mut w)
            .unwrap();
        w.publish().unwrap();
        ArtefactReader::open(&path).unwrap()
    }

    /// Runs the kind; the artefact, the report's stats and the warnings.
    fn run(
        dir: &std::path::Path,
        name: &str,
        inputs: Vec<(&str, ArtefactReader)>,
    ) -> (ConstrictionRead, serde_json::Value, Vec<String>) {
        let inputs = Inputs::new(
            inputs
                .into_iter()
                .map(|(k, r)| (k.to_string(), vec![r]))
                .collect(),
        );
        let path = dir.join(format!("{name}.h5"));
        let mut w = ArtefactWriter::create(&path).unwrap();
        let mut ctx = StageContext::detached(name, dir);
        let rep = ConstrictionKind
            .run(&mut ctx, &params(json!({})), &inputs, &mut w)
            .unwrap();
        w.publish().unwrap();
        let r = ConstrictionRead::read(&ArtefactReader::open(&path).unwrap()).unwrap();
        (r, rep.stats, ctx.warnings().to_vec())
    }

    /// With the leakage of the same surface as input, L_c (and its single-axis transitions) is
    /// the unseeded one to rel_width = 1e-9 with fewer contact solves; a leakage of another
    /// surface is refused with a warning naming p_fc and changes nothing, bit for bit.
    #[test]
    fn a_leakage_of_the_same_surface_seeds_l_c() {
        let (d1, d2) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let s = surface(d1.path());
        let again = || ArtefactReader::open(d1.path().join("s.h5")).unwrap();
        let leak = leakage_of(d1.path(), again());
        let other = leakage_of(d2.path(), crate::selfaffine::test_surface(d2.path(), 6, 4));
        let (plain, st_plain, _) = run(d1.path(), "plain", vec![("surface", again())]);
        let (seeded, st_seeded, w) = run(
            d1.path(),
            "seeded",
            vec![("surface", again()), ("leakage", leak)],
        );
        assert_eq!(st_plain["seed"], "none");
        assert_eq!(st_seeded["seed"], "used", "{w:?}");
        assert!(
            st_seeded["probes"].as_u64() < st_plain["probes"].as_u64(),
            "{st_seeded} vs {st_plain}"
        );
        // both brackets hold the transition and are ≤ 1e-9 wide (relative): the midpoints
        // differ by at most 1e-9 of the upper end
        let hi = plain.get("l_c_hi").max(seeded.get("l_c_hi"));
        for k in ["l_c", "l_c_x", "l_c_y"] {
            let (a, b) = (seeded.get(k), plain.get(k));
            assert!((a - b).abs() <= 1e-9 * hi, "{k}: {a} vs {b}");
        }
        let (wrong, st_wrong, w) =
            run(d1.path(), "wrong", vec![("surface", s), ("leakage", other)]);
        assert_eq!(st_wrong["seed"], "none");
        assert!(
            w.iter()
                .any(|m| m.contains("not used as a seed") && m.contains("p_fc")),
            "{w:?}"
        );
        for k in SUMMARY.iter().filter(|k| **k != "wall_s") {
            let (a, b) = (wrong.get(k), plain.get(k));
            assert!(a == b || (a.is_nan() && b.is_nan()), "{k}: {a} vs {b}");
        }
    }

    #[test]
    fn empty_ladder_names_the_parameter() {
        let e = ConstrictionKind
            .check(&params(json!({"d_max": 1e-3, "d_min": 1e-2})))
            .unwrap_err()
            .to_string();
        assert!(e.contains("d_min"), "{e}");
        let e = ConstrictionKind
            .check(&params(json!({"d_max": 4e-3, "d_min": 3e-3})))
            .unwrap_err()
            .to_string();
        assert!(e.contains("1-2-5"), "{e}");
    }
}
