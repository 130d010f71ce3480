//! The `exponents` artefact's attributes and datasets (layout in the parent module's docs):
//! writing the per-grid fits and measurements, reading everything back, and the grouping of
//! per-rung warnings.

use super::asymptotic::Asymptotic;
use super::{Exponent, LevelMeasure, ModelExponents, NAMES};
use anyhow::Result;
use critical::scaling::ExponentFit;
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

pub(super) fn write_measure(out: &mut ArtefactWriter, at: &str, m: &LevelMeasure) -> Result<()> {
    out.set_attr_at(at, "n", m.n as i64)?;
    out.write_f64_1d(&format!("{at}/l_open"), &m.l_open)?;
    out.write_f64_1d(&format!("{at}/load_open"), &m.load_open)?;
    out.write_f64_1d(&format!("{at}/saddle_gap"), &m.saddle_gap)?;
    let (w, we): (Vec<f64>, Vec<f64>) = m.half_width.iter().copied().unzip();
    out.write_f64_1d(&format!("{at}/half_width"), &w)?;
    out.write_f64_1d(&format!("{at}/half_width_error"), &we)?;
    out.write_f64_1d(&format!("{at}/flux"), &m.flux)?;
    out.write_f64_1d(&format!("{at}/l_blocked"), &m.l_blocked)?;
    let (a, ae): (Vec<f64>, Vec<f64>) = m.half_length.iter().copied().unzip();
    out.write_f64_1d(&format!("{at}/half_length"), &a)?;
    out.write_f64_1d(&format!("{at}/half_length_error"), &ae)?;
    Ok(())
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
            let la = format!("{at}/level/{lv}");
            let f = |k: &str| r.read_f64_1d(&format!("{la}/{k}"));
            let zip = |a: Vec<f64>, b: Vec<f64>| a.into_iter().zip(b).collect::<Vec<_>>();
            levels.push(LevelMeasure {
                n: r.attr_i64_at(&la, "n")? as u32,
                l_open: f("l_open")?,
                load_open: f("load_open")?,
                saddle_gap: f("saddle_gap")?,
                half_width: zip(f("half_width")?, f("half_width_error")?),
                flux: f("flux")?,
                l_blocked: f("l_blocked")?,
                half_length: zip(f("half_length")?, f("half_length_error")?),
            });
        }
        levels.sort_by_key(|l| l.n);
        let mut asymptotic = [Asymptotic::NONE; 4];
        for (k, nm) in NAMES.iter().enumerate() {
            asymptotic[k] = Asymptotic::read(r, &at, nm)?;
        }
        out.push(ModelExponents {
            exponents: exps,
            asymptotic,
            beta_identity_asymptotic: Asymptotic::read(r, &at, "beta_identity")?,
            zeta_lc_free: (a("zeta_lc_free")?, a("zeta_lc_free_error")?),
            beta_identity: (a("beta_identity")?, a("beta_identity_error")?),
            eta: a("eta")?,
            levels,
            lattice: name,
        });
    }
    Ok(out)
}
