//! `selfaffine`: a self-affine Gaussian random surface on a periodic 2^n × 2^n grid
//! (`surface::self_affine`: PSD ∝ q^(−2(1+H)) between q_r and q_s, flat below q_r, zero above
//! q_s; ChaCha8 seeded by `seed`).
//!
//! Parameters: `n` (3..=13), `length` (cell side L, default 1), `hurst` (0 < H ≤ 1), `qr`, `qs`
//! (units of 2π/L, 1 ≤ q_r ≤ q_s ≤ 2^n/2), exactly one of `rms_height` and `rms_slope` (> 0; the
//! other left at its default 0 = "not given"), `amplitudes` (`exact` | `gaussian`, default
//! `exact`), `seed` (≥ 0).
//!
//! Artefact ([`write_height_field`], shared with `topography`): the layout of the lattice
//! `surface` artefact where it applies — dataset `height` (nx, ny), root attributes `lx`, `ly`,
//! `nx`, `ny`, `dx`, `dy`, `h_min`, `h_max`, `h_mean`, `h_rms`, `skewness`,
//! `excess_kurtosis`, `p_fc_grid` (−min(K h), the periodic kernel's full-contact pressure) —
//! plus `rms_slope`, `rms_curvature`, `nayak`, `source` and the binned isotropic PSD
//! (`psd/q`, `psd/c`, `psd/count`: [`PsdRow`], read by [`read_psd`]). This kind adds `n`, `hurst`, `qr`, `qs`, `seed` and the PSD
//! slope fitted over q_r…q_s (`psd_slope`) beside the model's −2(1+H) (`psd_slope_model`).

use anyhow::{Result, anyhow};
use formats::records::{Record, read_in};
use orchestrator::{
    Inputs, ParamIssue, ParamSpec, ParamType, Params, StageContext, StageReport, TypedKind,
};
use serde::Deserialize;
use serde_json::json;
use store::{ArtefactWriter, fields};
use surface::HeightField;
use surface::self_affine::{Amplitudes, Normalisation, SelfAffine};
use surface::spectrum::PsdBin;

/// The `selfaffine` stage kind.
pub struct SelfAffineKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 1;

/// Bins of the isotropic PSD stored with a height field (as `surface stats` prints).
pub const PSD_BINS: usize = 24;

/// The `selfaffine` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelfAffineParams {
    /// Grid exponent: 2^n × 2^n nodes.
    pub n: u32,
    /// Cell side L.
    pub length: f64,
    /// Hurst exponent.
    pub hurst: f64,
    /// Roll-off wavenumber (units of 2π/L).
    pub qr: f64,
    /// Short cutoff (units of 2π/L).
    pub qs: f64,
    /// rms height (0: not given).
    pub rms_height: f64,
    /// rms slope (0: not given).
    pub rms_slope: f64,
    /// `exact` or `gaussian`.
    pub amplitudes: String,
    /// Seed of the ChaCha8 stream.
    pub seed: u64,
}

impl SelfAffineParams {
    /// The generator's parameters (after [`TypedKind::check`] passed).
    pub fn generator(&self) -> Result<SelfAffine, ParamIssue> {
        let normalisation = match (self.rms_height > 0.0, self.rms_slope > 0.0) {
            (true, false) => Normalisation::RmsHeight(self.rms_height),
            (false, true) => Normalisation::RmsSlope(self.rms_slope),
            _ => {
                return Err(ParamIssue::new(
                    "rms_height",
                    format!(
                        "rms_height = {} and rms_slope = {}: give exactly one of the two (> 0), \
                         leave the other at 0",
                        self.rms_height, self.rms_slope
                    ),
                ));
            }
        };
        let amplitudes = match self.amplitudes.as_str() {
            "exact" => Amplitudes::Exact,
            "gaussian" => Amplitudes::Gaussian,
            other => {
                return Err(ParamIssue::new(
                    "amplitudes",
                    format!("\"{other}\"; allowed: \"exact\", \"gaussian\""),
                ));
            }
        };
        let g = SelfAffine {
            n: self.n,
            length: self.length,
            hurst: self.hurst,
            q_r: self.qr,
            q_s: self.qs,
            normalisation,
            amplitudes,
            seed: self.seed,
        };
        g.validate().map_err(|e| {
            let key = match &e {
                surface::SurfaceError::Parameter { name, .. } => match *name {
                    "q_r" => "qr",
                    "q_s" => "qs",
                    "rms" if self.rms_height > 0.0 => "rms_height",
                    "rms" => "rms_slope",
                    other => other,
                },
                _ => "n",
            };
            ParamIssue::new(key, e.to_string())
        })?;
        Ok(g)
    }
}

/// Writes a height field in the layout of the `surface` artefact (see the module docs) with its
/// statistics and binned isotropic PSD; `source` names the kind that made it.
pub fn write_height_field(
    out: &mut ArtefactWriter,
    field: &HeightField,
    source: &str,
) -> Result<serde_json::Value> {
    let g = &field.grid;
    let st = field.statistics();
    let sp = field.spectrum();
    let ss = sp.statistics();
    let psd = sp.isotropic_psd(PSD_BINS);
    let p_fc = critical::leakage::full_contact_pressure(field);
    out.set_cell(g.lx, g.ly)?;
    out.set_attr("source", source)?;
    crate::surface::write_grid_and_moments(out, g, &st)?;
    out.set_attr("rms_slope", ss.rms_slope)?;
    out.set_attr("rms_curvature", ss.rms_curvature)?;
    out.set_attr("nayak", ss.nayak)?;
    out.set_attr("p_fc_grid", p_fc)?;
    out.write_f64_2d(fields::HEIGHT, field.heights.view())?;
    let rows: Vec<PsdRow> = psd
        .iter()
        .map(|b| PsdRow {
            q: b.q,
            c: b.c,
            count: b.count,
        })
        .collect();
    PsdRow::write(&rows, out, "psd")?;
    Ok(json!({
        "nodes": g.nx * g.ny,
        "h_rms": st.rms,
        "rms_slope": ss.rms_slope,
        "nayak": ss.nayak,
        "p_fc_grid": p_fc,
    }))
}

/// Reads any height-field artefact (`surface`, `selfaffine`, `topography`: dataset `height`
/// and root attributes `lx`, `ly`) back as a field on a periodic grid.
pub fn read_height_field(r: &store::ArtefactReader) -> Result<HeightField> {
    let heights = r.read_f64_2d(fields::HEIGHT)?;
    let (lx, ly) = r.cell()?;
    let (nx, ny) = heights.dim();
    let grid = surface::Grid::periodic(nx, ny, lx, ly).map_err(|e| anyhow!("{e}"))?;
    HeightField::new(grid, heights).map_err(|e| anyhow!("{e}"))
}

formats::record! {
    /// One bin of the isotropic PSD of a height-field artefact (`psd/*`).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct PsdRow {
        /// Mean |q| of the bin's wave vectors (1/length).
        pub q: f64,
        /// Mean PSD C(q) over them (length⁴).
        pub c: f64,
        /// Number of wave vectors.
        pub count: usize,
    }
}

/// The binned isotropic PSD of a height-field artefact (`selfaffine`, `topography`).
pub fn read_psd(r: &store::ArtefactReader) -> Result<Vec<PsdBin>> {
    let rows: Vec<PsdRow> = read_in(r, "psd")?;
    Ok(rows
        .into_iter()
        .map(|b| PsdBin {
            q: b.q,
            c: b.c,
            count: b.count,
        })
        .collect())
}

impl TypedKind for SelfAffineKind {
    type Params = SelfAffineParams;
    fn name(&self) -> &str {
        "selfaffine"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "a self-affine random surface on a periodic 2^n × 2^n grid, with statistics and PSD"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new(
                "n",
                ParamType::int_range(surface::N_MIN as i64, surface::N_MAX as i64),
            )
            .doc("grid exponent: 2^n × 2^n nodes"),
            ParamSpec::new("length", ParamType::positive())
                .default(1.0)
                .doc("cell side L"),
            ParamSpec::new(
                "hurst",
                ParamType::Float {
                    min: Some(0.0),
                    min_exclusive: true,
                    max: Some(1.0),
                    max_exclusive: false,
                },
            )
            .doc("Hurst exponent H: PSD ∝ q^(−2(1+H)) over qr…qs"),
            ParamSpec::new(
                "qr",
                ParamType::Float {
                    min: Some(1.0),
                    min_exclusive: false,
                    max: None,
                    max_exclusive: false,
                },
            )
            .doc("roll-off wavenumber (units of 2π/L), 1 ≤ qr ≤ qs"),
            ParamSpec::new(
                "qs",
                ParamType::Float {
                    min: Some(1.0),
                    min_exclusive: false,
                    max: None,
                    max_exclusive: false,
                },
            )
            .doc("short-wavelength cutoff (units of 2π/L), qr ≤ qs ≤ 2^n/2"),
            ParamSpec::new("rms_height", ParamType::non_negative())
                .default(0.0)
                .doc("rms height (0: not given; give exactly one of rms_height, rms_slope)"),
            ParamSpec::new("rms_slope", ParamType::non_negative())
                .default(0.0)
                .doc("rms slope √⟨|∇h|²⟩ (0: not given)"),
            ParamSpec::new("amplitudes", ParamType::one_of(&["exact", "gaussian"]))
                .default("exact")
                .doc("exact amplitudes with random phases, or Gaussian (filtered noise)"),
            ParamSpec::new("seed", ParamType::int_range(0, i64::MAX))
                .doc("seed of the ChaCha8 stream"),
        ]
    }
    fn check(&self, params: &SelfAffineParams) -> Result<(), ParamIssue> {
        params.generator().map(drop)
    }
    /// Heights plus the complex spectrum (16 bytes per node) during synthesis.
    fn memory_estimate(
        &self,
        params: &Params,
        _inputs: &std::collections::BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        params
            .i64("n")
            .ok()
            .map(|n| 3 * crate::surface::field_bytes(n))
    }
    fn cost(&self, params: &SelfAffineParams) -> f64 {
        // a few FFTs; weight by nodes relative to a 512² contact solve
        4f64.powi(params.n as i32) / 4f64.powi(9) * 0.05
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &SelfAffineParams,
        _inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let g = params.generator().map_err(|e| anyhow!("{e}"))?;
        let field = g.generate().map_err(|e| anyhow!("{e}"))?;
        ctx.progress(0.5, "generated");
        let mut stats = write_height_field(out, &field, "selfaffine")?;
        let bins = field.spectrum().isotropic_psd(PSD_BINS);
        let q0 = 2.0 * std::f64::consts::PI / params.length;
        let slope = surface::spectrum::psd_slope(&bins, params.qr * q0, params.qs * q0);
        out.set_attr("n", params.n as i64)?;
        out.set_attr("hurst", params.hurst)?;
        out.set_attr("qr", params.qr)?;
        out.set_attr("qs", params.qs)?;
        out.set_attr("seed", params.seed as i64)?;
        out.set_attr("amplitudes", params.amplitudes.as_str())?;
        out.set_attr("psd_slope", slope)?;
        out.set_attr("psd_slope_model", -2.0 * (1.0 + params.hurst))?;
        stats["psd_slope"] = json!(slope);
        ctx.progress(1.0, "written");
        Ok(StageReport::with_stats(stats))
    }
}

/// A small self-affine surface artefact written by this kind, for other kinds' tests.
#[cfg(test)]
pub(crate) fn test_surface(dir: &std::path::Path, n: u32, seed: u64) -> store::ArtefactReader {
    let p: SelfAffineParams = serde_json::from_value(serde_json::json!({"n": n, "length": 1.0,
        "hurst": 0.8, "qr": 2.0, "qs": 8.0, "rms_height": 0.0, "rms_slope": 1.0,
        "amplitudes": "exact", "seed": seed}))
    .unwrap();
    let path = dir.join("s.h5");
    let mut w = store::ArtefactWriter::create(&path).unwrap();
    let mut ctx = StageContext::detached("s", dir);
    SelfAffineKind
        .run(&mut ctx, &p, &Inputs::new(Default::default()), &mut w)
        .unwrap();
    w.publish().unwrap();
    store::ArtefactReader::open(&path).unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;
    use orchestrator::StageKind;
    use orchestrator::Typed;
    use orchestrator::schema::validate_params;

    fn params(extra: serde_json::Value) -> Result<SelfAffineParams, String> {
        let mut given = json!({"n": 6, "hurst": 0.8, "qr": 2.0, "qs": 16.0, "seed": 3});
        for (k, v) in extra.as_object().unwrap() {
            given[k] = v.clone();
        }
        let kind = Typed(SelfAffineKind);
        let filled = validate_params(&kind.params(), given.as_object().unwrap())
            .map_err(|e| format!("{e:?}"))?;
        let p = Params(filled);
        kind.check(&p).map_err(|e| e.to_string())?;
        p.parse().map_err(|e| e.to_string())
    }

    #[test]
    fn exactly_one_normalisation_is_required_and_named() {
        let e = params(json!({})).unwrap_err();
        assert!(e.contains("rms_height") && e.contains("exactly one"), "{e}");
        let e = params(json!({"rms_height": 1.0, "rms_slope": 1.0})).unwrap_err();
        assert!(e.contains("exactly one"), "{e}");
        assert!(params(json!({"rms_slope": 1.0})).is_ok());
    }

    #[test]
    fn a_cutoff_above_nyquist_is_refused_naming_qs() {
        let e = params(json!({"rms_slope": 1.0, "qs": 40.0})).unwrap_err();
        assert!(e.contains("`qs`") && e.contains("40"), "{e}");
    }

    /// The artefact holds what the generator makes (same heights for the same seed), its rms
    /// slope as requested (to rounding: 1e-12 relative, the generator's own guarantee), and
    /// reads back through [`read_height_field`] and the lattice `surface` reader's layout.
    #[test]
    fn artefact_round_trips_the_generated_surface() {
        let dir = tempfile::tempdir().unwrap();
        let p = params(json!({"rms_slope": 0.5})).unwrap();
        let path = dir.path().join("s.h5");
        let mut w = ArtefactWriter::create(&path).unwrap();
        let mut ctx = StageContext::detached("s", dir.path());
        let inputs = Inputs::new(Default::default());
        SelfAffineKind.run(&mut ctx, &p, &inputs, &mut w).unwrap();
        w.publish().unwrap();
        let r = store::ArtefactReader::open(&path).unwrap();
        let field = read_height_field(&r).unwrap();
        let direct = p.generator().unwrap().generate().unwrap();
        assert_eq!(field.heights, direct.heights);
        let slope = r.attr_f64("rms_slope").unwrap();
        assert!((slope - 0.5).abs() < 1e-12 * 0.5, "{slope}");
        assert_eq!(r.attr_i64("nx").unwrap(), 64);
        assert!(r.attr_f64("p_fc_grid").unwrap() > 0.0);
        let psd = read_psd(&r).unwrap();
        assert!(!psd.is_empty() && psd.iter().all(|b| b.q > 0.0 && b.count > 0));
    }
}
