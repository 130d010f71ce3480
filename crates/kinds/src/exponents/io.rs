//! The `exponents` artefact's attributes and datasets (layout in the parent module's docs):
//! writing the per-grid fits and measurements, reading everything back, and the grouping of
//! per-rung warnings.

use super::asymptotic::Asymptotic;
use super::{Exponent, LevelMeasure, ModelExponents, NAMES, NECK_ROWS};
use crate::refined_chain::Depth;
use anyhow::{Result, bail};
use critical::scaling::ExponentFit;
use formats::records::{Record, read_in};
use store::{ArtefactReader, ArtefactWriter};

/// Groups notes of the form "n = N, l = L: reason" by reason: "reason (n = N: l = L1, L2; ...)".
/// Other notes pass unchanged.
pub(super) fn group_notes(notes: &[String]) -> Vec<String> {
    let mut groups: Vec<(String, Vec<(String, String)>)> = Vec::new();
    let mut out = Vec::new();
    for note in notes {
        let parsed = note.strip_prefix("n = ").and_then(|rest| {
            let (n, rest) = rest.split_once(", l = ")?;
            let (l, reason) = rest.split_once(": ")?;
            Some((n.to_string(), l.to_string(), reason.to_string()))
        });
        match parsed {
            Some((n, l, reason)) => match groups.iter_mut().find(|g| g.0 == reason) {
                Some(g) => g.1.push((n, l)),
                None => groups.push((reason, vec![(n, l)])),
            },
            None => out.push(note.clone()),
        }
    }
    for (reason, at) in groups {
        let mut by_n: Vec<(String, Vec<String>)> = Vec::new();
        for (n, l) in at {
            match by_n.iter_mut().find(|b| b.0 == n) {
                Some(b) => b.1.push(l),
                None => by_n.push((n, vec![l])),
            }
        }
        let list: Vec<String> = by_n
            .iter()
            .map(|(n, ls)| format!("n = {n}: l = {}", ls.join(", ")))
            .collect();
        out.insert(0, format!("{reason} ({})", list.join("; ")));
    }
    out
}

pub(super) fn write_fit(
    out: &mut ArtefactWriter,
    at: &str,
    name: &str,
    f: Option<&ExponentFit>,
) -> Result<()> {
    let g = |v: fn(&ExponentFit) -> f64| f.map_or(f64::NAN, v);
    out.set_attr_at(at, name, g(|f| f.value))?;
    out.set_attr_at(at, &format!("{name}_fit_error"), g(|f| f.error))?;
    out.set_attr_at(at, &format!("{name}_prefactor"), g(|f| f.prefactor))?;
    out.set_attr_at(
        at,
        &format!("{name}_points"),
        f.map_or(0, |f| f.points as i64),
    )?;
    Ok(())
}

formats::record! {
    /// One rung below L_c of a grid's measurements (`model/<lattice>/level/<n>/*`).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct OpenRow {
        /// Reduced load l < 0.
        pub l_open: f64,
        /// Load (E* h0/λ).
        pub load_open: f64,
        /// Gap at the saddle node (h0).
        pub saddle_gap: f64,
        /// Open half-width r_c (λ).
        pub half_width: f64,
        /// Its fit error.
        pub half_width_error: f64,
        /// Flux (NaN where the fluid does not percolate).
        pub flux: f64,
        /// Conductivity along the channel (NaN where the fluid does not percolate).
        pub conductivity: f64,
        /// Conductivity along the other grid axis (NaN where the fluid does not percolate).
        pub conductivity_across: f64,
    }
}

formats::record! {
    /// One rung above L_c of a grid's measurements (same group as [`OpenRow`]).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct BlockedRow {
        /// Reduced load l > 0.
        pub l_blocked: f64,
        /// Blocked half-length a (λ).
        pub half_length: f64,
        /// Its fit error.
        pub half_length_error: f64,
    }
}

pub(super) fn write_measure(out: &mut ArtefactWriter, at: &str, m: &LevelMeasure) -> Result<()> {
    out.set_attr_at(at, "n", m.n as i64)?;
    let open: Vec<OpenRow> = (0..m.l_open.len())
        .map(|k| OpenRow {
            l_open: m.l_open[k],
            load_open: m.load_open[k],
            saddle_gap: m.saddle_gap[k],
            half_width: m.half_width[k].0,
            half_width_error: m.half_width[k].1,
            flux: m.flux[k],
            conductivity: m.conductivity[k].0,
            conductivity_across: m.conductivity[k].1,
        })
        .collect();
    OpenRow::write(&open, out, at)?;
    let blocked: Vec<BlockedRow> = (m.l_blocked.iter().zip(&m.half_length))
        .map(
            |(&l_blocked, &(half_length, half_length_error))| BlockedRow {
                l_blocked,
                half_length,
                half_length_error,
            },
        )
        .collect();
    BlockedRow::write(&blocked, out, at)
}

/// A grid's measurements as read back from `<la>/*`.
fn read_measure(r: &ArtefactReader, la: &str) -> Result<LevelMeasure> {
    let open: Vec<OpenRow> = read_in(r, la)?;
    let blocked: Vec<BlockedRow> = read_in(r, la)?;
    Ok(LevelMeasure {
        n: r.attr_i64_at(la, "n")? as u32,
        l_open: open.iter().map(|o| o.l_open).collect(),
        load_open: open.iter().map(|o| o.load_open).collect(),
        saddle_gap: open.iter().map(|o| o.saddle_gap).collect(),
        half_width: open
            .iter()
            .map(|o| (o.half_width, o.half_width_error))
            .collect(),
        flux: open.iter().map(|o| o.flux).collect(),
        conductivity: open
            .iter()
            .map(|o| (o.conductivity, o.conductivity_across))
            .collect(),
        l_blocked: blocked.iter().map(|b| b.l_blocked).collect(),
        half_length: blocked
            .iter()
            .map(|b| (b.half_length, b.half_length_error))
            .collect(),
    })
}

formats::record! {
    /// One point of a model's normalised flux curve (`ladder/<lattice>/*`, Figure 6's
    /// bottom-left panel).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct FluxPoint {
        /// (L_c − L)/L_c.
        pub distance: f64,
        /// Flux normalised by its value at the largest distance.
        pub flux: f64,
    }
}

/// A model's normalised flux curve as read back.
#[derive(Clone, Debug, PartialEq)]
pub struct FluxCurve {
    /// The points, as written.
    pub points: Vec<FluxPoint>,
    /// 1σ of the flux per point: an optional column `flux_err` (this kind does not write it;
    /// a hand-made input of Figure 6 may).
    pub flux_err: Option<Vec<f64>>,
}

/// The group of a model's flux curve.
fn flux_group(lattice: &str) -> String {
    format!("ladder/{lattice}")
}

pub(super) fn write_flux_curve(
    out: &mut ArtefactWriter,
    lattice: &str,
    points: &[FluxPoint],
) -> Result<()> {
    FluxPoint::write(points, out, &flux_group(lattice))
}

/// The flux curve of model `lattice` (`None` if the artefact has none for it).
pub fn read_flux_curve(r: &ArtefactReader, lattice: &str) -> Result<Option<FluxCurve>> {
    let g = flux_group(lattice);
    if !r.has_dataset(&format!("{g}/distance")) {
        return Ok(None);
    }
    let points: Vec<FluxPoint> = read_in(r, &g)?;
    let err = format!("{g}/flux_err");
    let flux_err = if r.has_dataset(&err) {
        let e = r.read_f64_1d(&err)?;
        if e.len() != points.len() {
            bail!(
                "`{}`: `{err}` has {} entries, `{g}/distance` has {}",
                r.path().display(),
                e.len(),
                points.len()
            );
        }
        Some(e)
    } else {
        None
    };
    Ok(Some(FluxCurve { points, flux_err }))
}

/// The group of a model's refined flux curve of one link of the chain
/// (`ladder/<lattice>/refined`, `ladder/<lattice>/refined_deep`).
fn refined_flux_group(lattice: &str, depth: Depth) -> String {
    format!("ladder/{lattice}/{}", depth.name())
}

/// A refined ladder's flux of one model, normalised to continue the curve before it in the
/// chain (`ladder/<lattice>/<depth>/*`, module docs of [`super`]).
pub(super) fn write_refined_flux_curve(
    out: &mut ArtefactWriter,
    lattice: &str,
    depth: Depth,
    points: &[FluxPoint],
) -> Result<()> {
    FluxPoint::write(points, out, &refined_flux_group(lattice, depth))
}

/// The refined flux curve of model `lattice` from the input `depth` (`None` if the artefact
/// has none for it).
pub fn read_refined_flux_curve(
    r: &ArtefactReader,
    lattice: &str,
    depth: Depth,
) -> Result<Option<Vec<FluxPoint>>> {
    let g = refined_flux_group(lattice, depth);
    if !r.has_dataset(&format!("{g}/distance")) {
        return Ok(None);
    }
    Ok(Some(read_in(r, &g)?))
}

/// A model's asymptotic β drawn in Figure 6: the slope, its 1σ and a point (distance,
/// normalised flux) the line goes through (the smallest distance of the estimate's rungs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AsymptoticSlope {
    /// β as l → 0.
    pub beta: f64,
    /// Its 1σ.
    pub error: f64,
    /// A point of the line (distance, normalised flux).
    pub through: (f64, f64),
}

const SLOPE_ATTRS: [&str; 4] = [
    "beta_asymptotic",
    "beta_asymptotic_error",
    "beta_asymptotic_distance",
    "beta_asymptotic_flux",
];

pub(super) fn write_asymptotic_slope(
    out: &mut ArtefactWriter,
    lattice: &str,
    s: &AsymptoticSlope,
) -> Result<()> {
    let g = flux_group(lattice);
    let v = [s.beta, s.error, s.through.0, s.through.1];
    for (name, v) in SLOPE_ATTRS.iter().zip(v) {
        out.set_attr_at(&g, name, v)?;
    }
    Ok(())
}

/// The asymptotic β slope of model `lattice` (`None` if not written).
pub fn read_asymptotic_slope(r: &ArtefactReader, lattice: &str) -> Result<Option<AsymptoticSlope>> {
    let g = flux_group(lattice);
    let names = r.attr_names(&g).unwrap_or_default();
    if !names.iter().any(|n| n == SLOPE_ATTRS[0]) {
        return Ok(None);
    }
    let a = |k: usize| r.attr_f64_at(&g, SLOPE_ATTRS[k]);
    Ok(Some(AsymptoticSlope {
        beta: a(0)?,
        error: a(1)?,
        through: (a(2)?, a(3)?),
    }))
}

/// The pooled β fit of all models' flux curves: (β, its 1σ if written, prefactor); `None`
/// when the artefact has none.
pub fn read_pooled_beta(r: &ArtefactReader) -> Result<Option<(f64, Option<f64>, f64)>> {
    if !(r.has_attr("beta") && r.has_attr("beta_prefactor")) {
        return Ok(None);
    }
    let err = if r.has_attr("beta_err") {
        Some(r.attr_f64("beta_err")?)
    } else {
        None
    };
    Ok(Some((
        r.attr_f64("beta")?,
        err,
        r.attr_f64("beta_prefactor")?,
    )))
}

/// Reads an `exponents` artefact: every model, in the artefact's order.
pub fn read(r: &ArtefactReader) -> Result<Vec<ModelExponents>> {
    let models: Vec<String> = serde_json::from_value(r.attr_json("models")?)?;
    let mut out = Vec::new();
    for name in models {
        let at = format!("model/{name}");
        let a = |k: &str| r.attr_f64_at(&at, k);
        let mut exps = [Exponent::NONE; 4];
        for (k, nm) in NAMES.iter().enumerate() {
            exps[k] = Exponent {
                value: a(nm)?,
                fit_error: a(&format!("{nm}_fit_error"))?,
                grid_spread: a(&format!("{nm}_grid_spread"))?,
                error: a(&format!("{nm}_error"))?,
                n: r.attr_i64_at(&at, &format!("{nm}_n"))? as u32,
                points: r.attr_i64_at(&at, &format!("{nm}_points"))? as usize,
                prefactor: a(&format!("{nm}_prefactor"))?,
            };
        }
        let mut levels = Vec::new();
        for lv in r.members(&format!("{at}/level"))? {
            levels.push(read_measure(r, &format!("{at}/level/{lv}"))?);
        }
        levels.sort_by_key(|l| l.n);
        let mut asymptotic = [Asymptotic::NONE; 4];
        let mut uniform_asymptotic = [Asymptotic::NONE; 4];
        let mut asymptotic_method: [String; 4] = Default::default();
        for (k, nm) in NAMES.iter().enumerate() {
            asymptotic[k] = Asymptotic::read(r, &at, nm)?;
            uniform_asymptotic[k] = Asymptotic::read(r, &at, &format!("{nm}_uniform"))?;
            asymptotic_method[k] = r.attr_str_at(&at, &format!("{nm}_asymptotic_method"))?;
        }
        let mut neck_asymptotic = [Asymptotic::NONE; 2];
        let mut neck_method: [String; 2] = Default::default();
        for (k, (nm, _, _)) in NECK_ROWS.iter().enumerate() {
            neck_asymptotic[k] = Asymptotic::read(r, &at, nm)?;
            neck_method[k] = r.attr_str_at(&at, &format!("{nm}_asymptotic_method"))?;
        }
        out.push(ModelExponents {
            exponents: exps,
            asymptotic,
            uniform_asymptotic,
            asymptotic_method,
            beta_identity_uniform: Asymptotic::read(r, &at, "beta_identity_uniform")?,
            beta_identity_asymptotic: Asymptotic::read(r, &at, "beta_identity")?,
            neck_asymptotic,
            neck_method,
            beta_identity_neck: Asymptotic::read(r, &at, "beta_identity_neck")?,
            zeta_lc_free: (a("zeta_lc_free")?, a("zeta_lc_free_error")?),
            beta_identity: (a("beta_identity")?, a("beta_identity_error")?),
            eta: a("eta")?,
            levels,
            lattice: name,
        });
    }
    Ok(out)
}
