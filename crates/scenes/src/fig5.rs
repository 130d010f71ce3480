//! The near-critical scenes, shared by the `figure` and `table` kinds: Figure 5 and the exponent
//! tables. (Figure 6's bottom-left panel takes the `exponents` stage as its `ladder` input:
//! crates/stages/src/exponents.rs.)
//!
//! # Figure 5 (`fig5`; inputs `ladder`: one per model, `exponents`; optional `refined`)
//! From each model's finest ladder grid, in each model's own units: lengths along the channel
//! in units of the blocked half-length `A_χ |l|^χ`, across it in units of the open half-width
//! `A_υ |l|^υ`, gaps in units of the saddle gap `A_ζ |l|^ζ` (A and the exponents from that
//! model's fits). So every model's curves at every l share the points the fits pin down (the
//! saddle gap 1, the contact line at ±1 across the open channel, the bridge's end at ±1 along the
//! blocked one) and the collapse shows whether the shapes between them agree. The paper chose
//! the square model's units at |l| = 0.01 for all models instead; with per-model units the
//! models fall on one master curve per sign of l. At l = 0 the same units without the |l|
//! factors are used: the critical contact line r⊥ ∝ r∥^{υ/χ} is invariant under the rescaling.
//! Rungs whose width (l < 0) or length (l > 0) could not be measured are left out, as they are
//! of the fits.
//! (a) contact lines (blue l < 0, green l = 0, red l > 0); (b) the gap on the channel axis
//! against the distance from the saddle, one marker per model, one colour per l. A model without all
//! three fits (too coarse a grid) is left out, with a warning. The paper's analytic approximations (black lines) are not drawn.
//! With `refined` inputs (`refined_ladder` stages, one per model) panel (b) also shows, as
//! filled markers, the axis gaps of the refined ladder's finest discretisation
//! (`kinds::refined_ladder::read_profiles`: the fine window around the saddle) at its rungs
//! below p_c(D) that are unflagged and open, in the same per-model units (from the uniform
//! fits where they exist, else the refined ladder's own power-law fits over its unflagged
//! rungs, with a warning; l from the refined discretisation's own p_c): the collapse at the
//! small |l| the uniform grids do not resolve. Panel (a) has no refined contact lines. With
//! `deep` inputs (the pipeline's `refined_deep_*`, chained below the refined ones) a model's
//! chain ordered by depth (`kinds::refined_chain::chain_of`): each deeper ladder adds the same
//! profiles at the rungs the ones before it do not give, in its own units (the same uniform fits
//! where they exist), drawn and tabulated as refined.
//!
//! # Collapse quality (`fig5_collapse.csv`)
//! In [`crate::fig5_collapse`].
//!
//! # Tables (`exponents`; input `exponents`)
//! - `exponents.csv`: per model and exponent, the window fit, the asymptotic estimate and the
//!   verdict: columns and rows in `kinds::exponents::table`.
//! - `ladder_measurements.csv`: per model, grid and rung: `model`, `n`, `l`, `saddle_gap`,
//!   `half_width`, `half_width_error`, `half_length`, `half_length_error`, `flux` (Q along the
//!   saddle's channel for a unit pressure drop across the cell), `conductivity` (K along the
//!   channel) and `conductivity_across` (K along the other grid axis: equal to `conductivity`
//!   in the continuum, so their ratio shows the grid's anisotropy).

pub use crate::fig5_collapse::{
    COLLAPSE_SAMPLES, ModelCurves, Spread, collapse_rms, collapse_table,
};
use crate::scene::{OutputSpec, Outputs, Scene};
use analysis::same_load;
use anyhow::Result;
use critical::ladder::Window;
use critical::refined::Measured;
use critical::scaling::{axis_gap, contact_lines, fit_exponent};
use figures::scenes::fig5::{ContactLine, Fig5Data, GapProfile};
use figures::style::Model;
use kinds::exponents::{self, ModelExponents, NAMES};
use kinds::ladder::LadderData;
use kinds::refined_chain::{Linked, chain_of};
use kinds::refined_ladder::{RefinedData, RefinedProfile, read_profiles};
use orchestrator::{InputSpec, Inputs};
use orchestrator::{Params, StageContext};
use store::ArtefactReader;
use store::ArtefactWriter;
use surface::Lattice;
use tables::Table;

/// Inputs of the `fig5` scene.
pub fn inputs() -> Vec<InputSpec> {
    vec![
        InputSpec::many("ladder", &["ladder"]).doc("one `ladder` stage per model"),
        InputSpec::one("exponents", &["exponents"]).doc("the exponents fitted to those ladders"),
        InputSpec::many("refined", &["refined_ladder"])
            .optional()
            .doc("one `refined_ladder` stage per model (optional): its finest axis-gap profiles (l < 0, unflagged) join panel (b) and fig5_collapse.csv as `refined`"),
        InputSpec::many("deep", &["refined_ladder"])
            .optional()
            .doc("one deeper `refined_ladder` stage per model (optional; the pipeline's `refined_deep_*`): its profiles at the rungs the `refined` one lacks join the refined ones"),
    ]
}

/// Inputs of the `exponents` table scene.
pub fn exponent_inputs() -> Vec<InputSpec> {
    vec![InputSpec::one("exponents", &["exponents"]).doc("the near-critical exponents")]
}

fn model_of(name: &str) -> Result<Model> {
    Model::ALL
        .into_iter()
        .find(|m| m.name() == name)
        .ok_or_else(|| anyhow::anyhow!("unknown lattice `{name}`"))
}

/// Exponent and prefactor for the rescaling; `None` (and a warning) without a fit.
fn scale(e: &ModelExponents, k: usize, warn: &mut Vec<String>) -> Option<(f64, f64)> {
    let x = e.exponents[k];
    if x.value.is_finite() && x.prefactor.is_finite() && x.prefactor > 0.0 {
        Some((x.value, x.prefactor))
    } else {
        warn.push(format!(
            "{}: no {} fit (grid too coarse for the channel); the model is left out of Figure 5",
            e.lattice,
            exponents::symbol(NAMES[k])
        ));
        None
    }
}

/// Exponents and prefactors of one model's rescaling (module docs): lengths along the channel
/// in `a_c |l|^chi`, across in `a_u |l|^upsilon`, gaps in `a_z |l|^zeta`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Units {
    /// ζ.
    pub zeta: f64,
    /// Prefactor of the saddle gap.
    pub a_z: f64,
    /// υ.
    pub upsilon: f64,
    /// Prefactor of the open half-width.
    pub a_u: f64,
    /// χ.
    pub chi: f64,
    /// Prefactor of the blocked half-length.
    pub a_c: f64,
}

/// One rung rescaled: its contact lines (r∥, r⊥) and the gap on the channel axis (distance,
/// gap) in the model's units at |l| (without the |l| factors at l = 0).
#[allow(clippy::type_complexity)]
pub fn rescale_rung(w: &Window, l: f64, u: &Units) -> (Vec<(f64, f64)>, Vec<f64>, Vec<f64>) {
    let al = l.abs();
    let (sx, sy, sg) = if l == 0.0 {
        (u.a_c, u.a_u, u.a_z)
    } else {
        (
            u.a_c * al.powf(u.chi),
            u.a_u * al.powf(u.upsilon),
            u.a_z * al.powf(u.zeta),
        )
    };
    let line = contact_lines(w)
        .into_iter()
        .map(|(x, y)| (x / sx, y / sy))
        .collect();
    let (dist, gap) = axis_gap(w);
    (
        line,
        dist.iter().map(|x| x / sx).collect(),
        gap.iter().map(|g| g / sg).collect(),
    )
}

/// Figure 5's data (see the module docs); the second value lists warnings, the third every
/// drawn model's full-resolution rescaled axis gaps from the uniform ladders, the fourth from
/// the refined ones (for [`collapse_table`]).
#[allow(clippy::type_complexity)]
pub fn fig5_data(
    inputs: &Inputs,
) -> Result<(Fig5Data, Vec<String>, Vec<ModelCurves>, Vec<ModelCurves>)> {
    let ex = exponents::read(inputs.one("exponents")?)?;
    let mut warn = Vec::new();
    let mut d = Fig5Data {
        contact_axes: (
            "$r$_∥ / ($A$_χ |$l$|^{$χ$})".into(),
            "$r$_⊥ / ($A$_υ |$l$|^{$υ$})".into(),
        ),
        gap_axes: (
            "$r$_∥ / ($A$_χ |$l$|^{$χ$})".into(),
            "$g$ / ($A$_ζ |$l$|^{$ζ$})".into(),
        ),
        ..Default::default()
    };
    let mut ladders: Vec<LadderData> = inputs
        .all("ladder")
        .iter()
        .map(LadderData::read)
        .collect::<Result<_>>()?;
    ladders.sort_by_key(|l| Model::ALL.iter().position(|m| m.name() == l.lattice.name()));
    let mut curves = Vec::new();
    for lad in &ladders {
        let name = lad.lattice.name();
        let Some(e) = ex.iter().find(|e| e.lattice == name) else {
            warn.push(format!(
                "{name}: not in the `exponents` input; left out of Figure 5"
            ));
            continue;
        };
        let Some(units) = units_of(e, &mut warn) else {
            continue;
        };
        let level = lad.levels.last().expect("read checks");
        let mut mine = Vec::new();
        for r in &level.rungs {
            if !r.converged || !measured(e, level.n, r.l) {
                continue;
            }
            let (line, dist, gap) = rescale_rung(&r.window, r.l, &units);
            let pts = clip_line(line);
            if pts.iter().any(|p| !p.0.is_nan()) {
                d.contact_lines.push(ContactLine {
                    l: r.l,
                    points: pts,
                });
            }
            if r.l != 0.0 {
                mine.push((r.l, dist.clone(), gap.clone()));
                let (x, y) = thin_profile(&dist, &gap);
                d.profiles.push(GapProfile {
                    model: model_of(name)?,
                    l: r.l,
                    distance: x,
                    gap: y,
                });
            }
        }
        curves.push((name.to_string(), mine));
    }
    let refined = refined_curves(inputs, &ex, &mut d, &mut warn)?;
    Ok((d, warn, curves, refined))
}

/// The units of a refined ladder's profiles: per exponent the uniform fit of the `exponents`
/// input (as panel (b)'s open markers) where it has one, else the refined ladder's own power-law
/// fit over its finest discretisation's unflagged rungs (ζ: saddle gap, χ: blocked half-length;
/// `critical::scaling::fit_exponent`), with a warning naming it; `None` (and a warning) if an
/// exponent has neither.
fn refined_units(
    rd: &RefinedData,
    e: Option<&ModelExponents>,
    warn: &mut Vec<String>,
) -> Option<Units> {
    let name = rd.lattice.name();
    let unflagged: Vec<f64> = rd.finest().map_or(Vec::new(), |f| {
        f.rungs
            .iter()
            .filter(|(_, flag)| flag.is_empty())
            .map(|(r, _)| r.l)
            .collect()
    });
    let mut pick = |k: usize, m: Measured| -> Option<(f64, f64)> {
        if let Some(x) = e.map(|e| e.exponents[k])
            && x.value.is_finite()
            && x.prefactor.is_finite()
            && x.prefactor > 0.0
        {
            return Some((x.value, x.prefactor));
        }
        let (l, y): (Vec<f64>, Vec<f64>) = rd
            .points(m)
            .iter()
            .filter(|p| unflagged.contains(&p.l))
            .map(|p| (p.l, p.y))
            .unzip();
        let sym = exponents::symbol(NAMES[k]);
        // two points (no degree of freedom, which the fit refuses): the power law through them
        let fit = fit_exponent(&l, &y).or_else(|err| match (l.as_slice(), y.as_slice()) {
            ([l0, l1], [y0, y1]) if l0 != l1 && *y0 > 0.0 && *y1 > 0.0 => {
                let value = (y1 / y0).ln() / (l1.abs() / l0.abs()).ln();
                Ok(critical::scaling::ExponentFit {
                    value,
                    error: f64::NAN,
                    prefactor: y0 / l0.abs().powf(value),
                    points: 2,
                })
            }
            _ => Err(err),
        });
        match fit {
            Ok(f) if f.value.is_finite() && f.prefactor.is_finite() && f.prefactor > 0.0 => {
                warn.push(format!(
                    "{name}: no uniform {sym} fit; the refined profiles use the refined ladder's own ({} rungs: {sym} = {:.4})",
                    f.points, f.value
                ));
                Some((f.value, f.prefactor))
            }
            _ => {
                warn.push(format!(
                    "{name}: no {sym} fit, uniform or refined; the refined profiles are left out of Figure 5"
                ));
                None
            }
        }
    };
    let (zeta, a_z) = pick(0, Measured::SaddleGap)?;
    let (upsilon, a_u) = pick(1, Measured::OpenHalfWidth)?;
    let (chi, a_c) = pick(2, Measured::BlockedHalfLength)?;
    Some(Units {
        zeta,
        a_z,
        upsilon,
        a_u,
        chi,
        a_c,
    })
}

/// The refined ladders' finest axis-gap profiles (`kinds::refined_ladder::read_profiles`) of the
/// rungs below p_c(D) that are unflagged and open, rescaled in the model's units from the
/// uniform fits (module docs): added to `d.refined_profiles` (thinned) and returned in full.
fn refined_curves(
    inputs: &Inputs,
    ex: &[ModelExponents],
    d: &mut Fig5Data,
    warn: &mut Vec<String>,
) -> Result<Vec<ModelCurves>> {
    let mut out: Vec<ModelCurves> = Vec::new();
    let linked = kinds::neck_truncation::read_flagged(inputs)?;
    let profiles_of: Vec<Vec<RefinedProfile>> = linked
        .iter()
        .map(|(_, r)| read_profiles(r))
        .collect::<Result<_>>()?;
    let all: Vec<Linked> = linked.into_iter().map(|(l, _)| l).collect();
    let mut lattices: Vec<Lattice> = Vec::new();
    for l in &all {
        if !lattices.contains(&l.data.lattice) {
            lattices.push(l.data.lattice);
        }
    }
    lattices.sort_by_key(|lat| Model::ALL.iter().position(|m| m.name() == lat.name()));
    for lattice in lattices {
        let name = lattice.name();
        let mut mine = Vec::new();
        // the model's chain by depth: a deeper link adds the rungs the ones before it lack
        for link in chain_of(&all, lattice) {
            let k = all
                .iter()
                .position(|x| std::ptr::eq(x, link))
                .expect("a link of `all`");
            let taken: Vec<f64> = mine.iter().map(|(l, _, _)| *l).collect();
            refined_link_curves(&link.data, &profiles_of[k], ex, taken, d, warn, &mut mine)?;
        }
        out.push((name.to_string(), mine));
    }
    Ok(out)
}

/// One refined ladder's profiles (module docs) for [`refined_curves`]: its unflagged open rungs
/// below p_c(D) whose l is not in `taken` (an earlier link of the chain has it), rescaled in its
/// units, appended to `mine` and (thinned) to `d.refined_profiles`.
fn refined_link_curves(
    rd: &RefinedData,
    profiles: &[RefinedProfile],
    ex: &[ModelExponents],
    taken: Vec<f64>,
    d: &mut Fig5Data,
    warn: &mut Vec<String>,
    mine: &mut Vec<(f64, Vec<f64>, Vec<f64>)>,
) -> Result<()> {
    {
        let name = rd.lattice.name();
        if profiles.is_empty() {
            warn.push(format!(
                "{name}: the refined ladder stores no axis-gap profiles (written before kinds::refined_ladder CODE_VERSION 6); left out of Figure 5"
            ));
            return Ok(());
        }
        let Some(u) = refined_units(rd, ex.iter().find(|e| e.lattice == name), warn) else {
            return Ok(());
        };
        let usable = |l: f64| {
            rd.finest().is_some_and(|f| {
                f.rungs
                    .iter()
                    .any(|(r, flag)| r.l == l && flag.is_empty() && r.saddle_gap > 0.0)
            })
        };
        for (l, dist, gap) in profiles.iter().cloned() {
            if l >= 0.0 || !usable(l) || taken.iter().any(|&t| same_load(t, l)) {
                continue;
            }
            let (sx, sg) = (u.a_c * l.abs().powf(u.chi), u.a_z * l.abs().powf(u.zeta));
            let x: Vec<f64> = dist.iter().map(|v| v / sx).collect();
            let y: Vec<f64> = gap.iter().map(|v| v / sg).collect();
            let (tx, ty) = thin_profile(&x, &y);
            d.refined_profiles.push(GapProfile {
                model: model_of(name)?,
                l,
                distance: tx,
                gap: ty,
            });
            mine.push((l, x, y));
        }
    }
    Ok(())
}

/// A model's units from its fits of ζ, υ, χ; `None` (with warnings) without all three.
fn units_of(e: &ModelExponents, warn: &mut Vec<String>) -> Option<Units> {
    let (Some((zeta, a_z)), Some((ups, a_u)), Some((chi, a_c))) =
        (scale(e, 0, warn), scale(e, 1, warn), scale(e, 2, warn))
    else {
        return None;
    };
    Some(Units {
        zeta,
        a_z,
        upsilon: ups,
        a_u,
        chi,
        a_c,
    })
}

/// Rungs whose width (l < 0) or length (l > 0) could not be measured on grid n (channel below
/// the grid's resolution) are left out, as they are of the fits.
fn measured(e: &ModelExponents, n: u32, l: f64) -> bool {
    let m = e.levels.iter().find(|m| m.n == n);
    let ok =
        |ls: &[f64], v: &[(f64, f64)]| ls.iter().zip(v).any(|(x, v)| *x == l && v.0.is_finite());
    m.is_some_and(|m| {
        if l < 0.0 {
            ok(&m.l_open, &m.half_width)
        } else if l > 0.0 {
            ok(&m.l_blocked, &m.half_length)
        } else {
            true
        }
    })
}

/// A rescaled contact line cut to the drawn box |X|, |Y| ≤ 3, with one NaN break wherever it
/// leaves the box (or is already broken).
fn clip_line(line: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    const X_MAX: f64 = 3.0;
    let mut pts = Vec::new();
    for (px, py) in line {
        if px.is_nan() || px.abs() > X_MAX || py.abs() > X_MAX {
            if pts.last().is_some_and(|p: &(f64, f64)| !p.0.is_nan()) {
                pts.push((f64::NAN, f64::NAN));
            }
        } else {
            pts.push((px, py));
        }
    }
    pts
}

/// Panel (b)'s markers: the axis gap up to distance 4, at most about 30 points.
fn thin_profile(dist: &[f64], gap: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let keep: Vec<usize> = (0..dist.len()).filter(|&k| dist[k] <= 4.0).collect();
    let stride = keep.len().div_ceil(30).max(1);
    keep.iter()
        .step_by(stride)
        .map(|&k| (dist[k], gap[k]))
        .unzip()
}

/// `exponents.csv` (columns and rows: `kinds::exponents::table`).
pub fn exponent_table(r: &ArtefactReader) -> Result<Table> {
    exponents::table::table(&exponents::read(r)?)
}

/// `ladder_measurements.csv` (module docs).
pub fn measurement_table(r: &ArtefactReader) -> Result<Table> {
    let ex = exponents::read(r)?;
    let mut c: (Vec<String>, Vec<i64>, Vec<f64>) = (vec![], vec![], vec![]);
    let mut v: [Vec<f64>; 8] = Default::default();
    for e in &ex {
        for lv in &e.levels {
            for k in 0..lv.l_open.len() {
                c.0.push(e.lattice.clone());
                c.1.push(lv.n as i64);
                c.2.push(lv.l_open[k]);
                let row = [
                    lv.saddle_gap[k],
                    lv.half_width[k].0,
                    lv.half_width[k].1,
                    f64::NAN,
                    f64::NAN,
                    lv.flux[k],
                    lv.conductivity[k].0,
                    lv.conductivity[k].1,
                ];
                for (col, x) in v.iter_mut().zip(row) {
                    col.push(x);
                }
            }
            for k in 0..lv.l_blocked.len() {
                c.0.push(e.lattice.clone());
                c.1.push(lv.n as i64);
                c.2.push(lv.l_blocked[k]);
                let row = [
                    f64::NAN,
                    f64::NAN,
                    f64::NAN,
                    lv.half_length[k].0,
                    lv.half_length[k].1,
                    f64::NAN,
                    f64::NAN,
                    f64::NAN,
                ];
                for (col, x) in v.iter_mut().zip(row) {
                    col.push(x);
                }
            }
        }
    }
    let [g, w, we, a, ae, q, k, ka] = v;
    Ok(Table::new()
        .with_str("model", c.0)
        .with_i64("n", c.1)
        .with_f64("l", c.2)
        .with_f64("saddle_gap", g)
        .with_f64("half_width", w)
        .with_f64("half_width_error", we)
        .with_f64("half_length", a)
        .with_f64("half_length_error", ae)
        .with_f64("flux", q)
        .with_f64("conductivity", k)
        .with_f64("conductivity_across", ka))
}

/// The `fig5` scene: Figure 5 (near-critical contact lines and axis gaps collapsed by the
/// scaling; inputs `ladder`, one per model, and `exponents`, optional `refined`) and the tables
/// `exponents.csv`, `ladder_measurements.csv` and `fig5_collapse.csv` (see the module docs).
/// Attributes `contact_lines`, `profiles`, `refined_profiles`.
pub struct Fig5;

impl Scene for Fig5 {
    fn name(&self) -> &'static str {
        "fig5"
    }
    fn doc(&self) -> &'static str {
        "Figure 5: near-critical scaling collapse (figure), exponents and ladder measurements (tables)"
    }
    fn code_version(&self) -> u64 {
        3
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        inputs()
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::figure("figure", "fig5"),
            OutputSpec::table("exponents", "exponents.csv"),
            OutputSpec::table("measurements", "ladder_measurements.csv"),
            OutputSpec::table("collapse", "fig5_collapse.csv"),
        ]
    }
    fn render(
        &self,
        ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let (data, warnings, curves, refined) = fig5_data(inputs)?;
        for w in warnings {
            ctx.warn(w);
        }
        out.set_attr("contact_lines", data.contact_lines.len() as i64)?;
        out.set_attr("profiles", data.profiles.len() as i64)?;
        out.set_attr("refined_profiles", data.refined_profiles.len() as i64)?;
        let (collapse, [pooled, pooled_refined]) = collapse_table(&curves, &refined)?;
        out.set_attr("collapse_rms_open", pooled[0])?;
        out.set_attr("collapse_rms_blocked", pooled[1])?;
        out.set_attr("collapse_rms_open_refined", pooled_refined[0])?;
        let r = inputs.one("exponents")?;
        Ok(Outputs::new()
            .figure("figure", figures::scenes::fig5::figure(&data)?)
            .table("exponents", exponent_table(r)?)
            .table("measurements", measurement_table(r)?)
            .table("collapse", collapse))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use analysis::{Curve, collapse_quality};
    use ndarray::Array2;

    /// Windows made to collapse: on grids whose spacings scale as |l|^χ and |l|^υ, the pressure
    /// and gap are |l|-powers times fixed functions of the scaled coordinates X, Y — an open
    /// channel |Y| < 1 + X²/4 for l < 0, a bridge |X| < 1 + Y²/4 for l > 0 (square-root
    /// pressure onsets, as at a contact line).
    fn window(l: f64, u: &Units) -> Window {
        let k = 12;
        let al = l.abs();
        let (dx, dy) = (
            0.1 * u.a_c * al.powf(u.chi),
            0.1 * u.a_u * al.powf(u.upsilon),
        );
        let shape = (2 * k + 1, 2 * k + 1);
        let xy = |a: usize, b: usize| ((a as f64 - k as f64) * 0.1, (b as f64 - k as f64) * 0.1);
        let depth = |a: usize, b: usize| {
            let (x, y) = xy(a, b);
            if l < 0.0 {
                y.abs() - (1.0 + x * x / 4.0)
            } else {
                1.0 + y * y / 4.0 - x.abs()
            }
        };
        let pressure =
            Array2::from_shape_fn(shape, |(a, b)| 3.0 * al * depth(a, b).max(0.0).sqrt());
        let gap = Array2::from_shape_fn(shape, |(a, b)| {
            u.a_z * al.powf(u.zeta) * (-depth(a, b)).max(0.0).powf(1.5)
        });
        Window {
            d_par: dx,
            d_perp: dy,
            gap,
            pressure,
        }
    }

    #[test]
    fn rescaling_collapses_data_made_to_collapse_exactly() {
        let u = Units {
            zeta: 1.2,
            a_z: 0.8,
            upsilon: 0.45,
            a_u: 0.3,
            chi: 0.6,
            a_c: 0.15,
        };
        for sign in [-1.0, 1.0] {
            let ls: Vec<f64> = [0.002, 0.005, 0.01, 0.02]
                .iter()
                .map(|v| sign * v)
                .collect();
            let rescaled: Vec<_> = ls
                .iter()
                .map(|&l| rescale_rung(&window(l, &u), l, &u))
                .collect();
            for r in &rescaled[1..] {
                // identical contact lines and axis gaps, point for point
                assert_eq!(r.0.len(), rescaled[0].0.len());
                for (p, q) in r.0.iter().zip(&rescaled[0].0) {
                    assert!(
                        (p.0.is_nan() && q.0.is_nan())
                            || ((p.0 - q.0).abs() < 1e-9 && (p.1 - q.1).abs() < 1e-9),
                        "{p:?} vs {q:?}"
                    );
                }
                for (g, h) in r.2.iter().zip(&rescaled[0].2) {
                    assert!((g - h).abs() < 1e-9 * h.abs().max(1.0));
                }
            }
            // the collapse measure of the analysis crate agrees: zero spread
            let curves: Vec<Curve> = ls
                .iter()
                .zip(&rescaled)
                .map(|(&l, r)| Curve {
                    l,
                    x: r.1.clone(),
                    y: r.2.clone(),
                })
                .collect();
            let q = collapse_quality(&curves, 0.0, 0.0).unwrap();
            assert!(q.spread < 1e-9, "{q:?}");
            // and wrong exponents do not collapse
            let wrong = Units { zeta: 1.0, ..u };
            let bad: Vec<Curve> = ls
                .iter()
                .map(|&l| {
                    let r = rescale_rung(&window(l, &u), l, &wrong);
                    Curve { l, x: r.1, y: r.2 }
                })
                .collect();
            if sign < 0.0 {
                assert!(collapse_quality(&bad, 0.0, 0.0).unwrap().spread > 0.1);
            }
        }
    }
}
