//! One `ladder` input of the `exponents` stage (and its model's optional `refined_ladder`): the
//! per-grid fits, the flux curve, the combined and asymptotic exponents, their attributes under
//! `model/<name>` and the report's statistics (split from the stage's `run`).

use super::asymptotic::{self, Asymptotic};
use super::io::{
    AsymptoticSlope, FluxPoint, write_asymptotic_slope, write_fit, write_measure,
    write_refined_flux_curve,
};
use super::{
    Exponent, NAMES, NECK_ROWS, PAPER, combine, group_notes, identity, level_fits, measure,
    normalised_flux, symbol,
};
use crate::headline::Headline;
use crate::ladder::LadderData;
use crate::refined_chain::{Depth, Linked};
use crate::refined_neck::NeckLadder;
use analysis::same_load;
use anyhow::Result;
use critical::refined::Measured;
use critical::scaling::{EdgeOptions, ExponentFit};
use orchestrator::StageContext;
use serde_json::{Value, json};
use store::ArtefactWriter;

/// Per exponent, the (grid, fit) of every level.
type PerLevel = [Vec<(u32, Option<ExponentFit>)>; 4];

/// A model's chain of refined ladders (ordered by depth) and, per link, its neck ladder (None:
/// no neck lengths in its artefact).
pub(super) type Chain<'a, 'b> = (&'a [&'a Linked], &'a [(Depth, Option<&'a NeckLadder<'b>>)]);

/// Fits, writes and reports one model's ladder (the asymptotic estimates with its refined
/// ladders, if given, and from their neck lengths); appends its headlines and its finest grid's
/// normalised flux curve; returns its report statistics.
pub(super) fn run_model(
    ctx: &mut StageContext,
    out: &mut ArtefactWriter,
    d: &LadderData,
    (chain, neck_chain): Chain<'_, '_>,
    opts: &EdgeOptions,
    heads: &mut Vec<Headline>,
    flux_points: &mut Vec<(Vec<f64>, Vec<f64>)>,
) -> Result<Value> {
    let name = d.lattice.name();
    let at = format!("model/{name}");
    let mut notes = Vec::new();
    let (per, zeta_free) = fit_levels(out, &at, d, opts, &mut notes)?;
    let curve = write_flux(out, d, opts, flux_points)?;
    let ex: Vec<Exponent> = per.iter().map(|p| combine(p)).collect();
    write_exponents(out, &at, &ex)?;
    for (k, e) in ex.iter().enumerate() {
        let (pv, pe) = PAPER[k];
        heads.push(Headline::new(format!("{} {name}", NAMES[k]), e.value, e.error).paper(pv, pe));
    }
    let (asy, uni, junctions) = asymptotics(out, &at, d, chain, &mut notes)?;
    write_figure_flux(out, d, chain, &curve, &junctions[3], &asy[3], &mut notes)?;
    let asy_identity = asymptotic::identity(&asy[0], &asy[1], &asy[2]);
    asy_identity.write(out, &at, "beta_identity")?;
    asymptotic::identity(&uni[0], &uni[1], &uni[2]).write(out, &at, "beta_identity_uniform")?;
    let neck = neck_asymptotics(out, &at, neck_chain, &mut notes)?;
    let neck_identity = asymptotic::identity(&asy[0], &neck[0], &neck[1]);
    neck_identity.write(out, &at, "beta_identity_neck")?;
    let (bi, be) = identity(&ex[0], &ex[1], &ex[2]);
    out.set_attr_at(&at, "beta_identity", bi)?;
    out.set_attr_at(&at, "beta_identity_error", be)?;
    out.set_attr_at(&at, "zeta_lc_free", zeta_free.0)?;
    out.set_attr_at(&at, "zeta_lc_free_error", zeta_free.1)?;
    out.set_attr_at(&at, "l_c_fit", zeta_free.2)?;
    out.set_attr_at(&at, "eta", d.eta)?;
    for note in group_notes(&notes) {
        ctx.warn(format!("{name}: {note}"));
    }
    Ok(json!({
        "zeta": [ex[0].value, ex[0].error],
        "upsilon": [ex[1].value, ex[1].error],
        "chi": [ex[2].value, ex[2].error],
        "beta": [ex[3].value, ex[3].error],
        "beta_identity": [bi, be],
        "zeta_lc_free": [zeta_free.0, zeta_free.1],
        "asymptotic": {
            "zeta": [asy[0].value, asy[0].error],
            "upsilon": [asy[1].value, asy[1].error],
            "chi": [asy[2].value, asy[2].error],
            "beta": [asy[3].value, asy[3].error],
            "beta_identity": [asy_identity.value, asy_identity.error],
            "upsilon_neck": [neck[0].value, neck[0].error],
            "chi_below": [neck[1].value, neck[1].error],
            "beta_identity_neck": [neck_identity.value, neck_identity.error],
        },
        "uniform_asymptotic": {
            "zeta": [uni[0].value, uni[0].error],
            "upsilon": [uni[1].value, uni[1].error],
            "chi": [uni[2].value, uni[2].error],
            "beta": [uni[3].value, uni[3].error],
        },
    }))
}

/// The per-grid fits (`model/<name>/level/<n>/*`) and ζ with L_c free (the last grid with
/// enough open samples): (ζ, its error, the fitted L_c).
fn fit_levels(
    out: &mut ArtefactWriter,
    at: &str,
    d: &LadderData,
    opts: &EdgeOptions,
    notes: &mut Vec<String>,
) -> Result<(PerLevel, (f64, f64, f64))> {
    let mut per: [Vec<(u32, Option<ExponentFit>)>; 4] = Default::default();
    let mut zeta_free = (f64::NAN, f64::NAN, f64::NAN);
    for lv in &d.levels {
        let m = measure(lv, opts, notes);
        let fits = level_fits(&m);
        let la = format!("{at}/level/{}", lv.n);
        for (k, f) in fits.into_iter().enumerate() {
            write_fit(out, &la, NAMES[k], f.as_ref().ok())?;
            if let Err(e) = &f {
                notes.push(format!("n = {}: no {} fit: {e}", lv.n, symbol(NAMES[k])));
            }
            per[k].push((lv.n, f.ok()));
        }
        // ζ with L_c free (needs 4 open samples: 3 parameters and one dof)
        let (ld, gd): (Vec<f64>, Vec<f64>) = m
            .load_open
            .iter()
            .zip(&m.saddle_gap)
            .filter(|(_, g)| g.is_finite())
            .map(|(l, g)| (*l, *g))
            .unzip();
        if ld.len() >= 4
            && let Ok(f) =
                analysis::fit_saddle_gap(&ld, &gd, None, analysis::ErrorScale::ReducedChi2)
        {
            let z = f.get("zeta").unwrap_or((f64::NAN, f64::NAN));
            let lc = f.get("L_c").map_or(f64::NAN, |v| v.0);
            out.set_attr_at(&la, "zeta_lc_free", z.0)?;
            out.set_attr_at(&la, "zeta_lc_free_error", z.1)?;
            out.set_attr_at(&la, "l_c_fit", lc)?;
            out.set_attr_at(&la, "l_c", lv.l_c)?;
            zeta_free = (z.0, z.1, lc);
        }
        write_measure(out, &la, &m)?;
    }
    Ok((per, zeta_free))
}

/// The finest grid's normalised flux curve (`ladder/<name>/*`), kept for the pooled β;
/// returned (empty if none).
fn write_flux(
    out: &mut ArtefactWriter,
    d: &LadderData,
    opts: &EdgeOptions,
    flux_points: &mut Vec<(Vec<f64>, Vec<f64>)>,
) -> Result<Vec<FluxPoint>> {
    let name = d.lattice.name();
    let mut points = Vec::new();
    if let Some(lv) = d.levels.last() {
        let (x, y) = normalised_flux(&measure(lv, opts, &mut Vec::new()));
        if !x.is_empty() {
            points = (x.iter().zip(&y))
                .map(|(&distance, &flux)| FluxPoint { distance, flux })
                .collect();
            super::io::write_flux_curve(out, name, &points)?;
            flux_points.push((x, y));
        }
    }
    Ok(points)
}

/// Figure 6's extended flux panel (module docs of [`super`]): each refined ladder's flux of the
/// chain continuing the curve before it (`ladder/<name>/<depth>/*`: the first link the uniform
/// curve at its junction, each further one the previous link's curve at its own) and the
/// asymptotic β's slope.
fn write_figure_flux(
    out: &mut ArtefactWriter,
    d: &LadderData,
    chain: &[&Linked],
    uniform: &[FluxPoint],
    junctions: &[(Depth, f64)],
    beta: &Asymptotic,
    notes: &mut Vec<String>,
) -> Result<()> {
    let name = d.lattice.name();
    let links: Vec<(Depth, Vec<analysis::ScalingPoint>)> = chain
        .iter()
        .map(|l| (l.depth, l.data.points(Measured::Flux)))
        .collect();
    let curves = chained_flux_curves(uniform, &links, junctions, notes);
    for (depth, c, _) in &curves {
        if !c.is_empty() {
            write_refined_flux_curve(out, name, *depth, c)?;
        }
    }
    if beta.value.is_finite() && beta.l_min.is_finite() {
        let at = |c: &[FluxPoint]| {
            c.iter()
                .find(|p| same_load(p.distance, beta.l_min))
                .copied()
        };
        // the deepest link whose part of the estimate's ladder holds l_min (below its
        // junction); else the uniform curve
        let below = |j: Option<f64>| j.is_some_and(|j| beta.l_min < j * (1.0 - 1e-9));
        let p = match curves.iter().rev().find(|c| below(c.2)) {
            Some(c) => at(&c.1),
            None => at(uniform),
        };
        if let Some(p) = p {
            write_asymptotic_slope(
                out,
                name,
                &AsymptoticSlope {
                    beta: beta.value,
                    error: beta.error,
                    through: (p.distance, p.flux),
                },
            )?;
        }
    }
    Ok(())
}

/// Per link of a chain (depth, flux points), its normalised flux curve continuing the curve
/// before it ([`refined_flux_curve`]: the first link the uniform curve, each further one the
/// previous link's, at the link's junction in `junctions` if it has one there, else at the
/// largest shared distance), with that junction (|l|). A link whose curve is empty (no shared
/// rung) ends the list (with a note; it is returned, empty): a later link could not continue it.
pub fn chained_flux_curves(
    uniform: &[FluxPoint],
    links: &[(Depth, Vec<analysis::ScalingPoint>)],
    junctions: &[(Depth, f64)],
    notes: &mut Vec<String>,
) -> Vec<(Depth, Vec<FluxPoint>, Option<f64>)> {
    let mut curves: Vec<(Depth, Vec<FluxPoint>, Option<f64>)> = Vec::new();
    for (depth, rpoints) in links {
        let junction = junctions
            .iter()
            .find(|(dp, _)| dp == depth)
            .map(|&(_, j)| j.abs());
        let before = curves.last().map_or(uniform, |c| c.1.as_slice());
        let curve = refined_flux_curve(before, rpoints, junction);
        if !rpoints.is_empty() && curve.is_empty() {
            notes.push(format!(
                "Figure 6: the {} flux shares no rung with the {} curve: not drawn",
                depth.name(),
                curves.last().map_or("uniform", |c| c.0.name())
            ));
        }
        let drawn = !curve.is_empty();
        curves.push((*depth, curve, junction));
        if !drawn {
            break;
        }
    }
    curves
}

/// The refined flux `refined` (l < 0, any order) as a normalised curve continuing `uniform`
/// (ascending distance): multiplied so that it equals the uniform curve at distance `junction`
/// if given and shared, else at the largest distance both share; empty without a shared rung.
/// Ascending distance.
pub fn refined_flux_curve(
    uniform: &[FluxPoint],
    refined: &[analysis::ScalingPoint],
    junction: Option<f64>,
) -> Vec<FluxPoint> {
    let shared = |x: f64| {
        let u = uniform.iter().find(|p| same_load(p.distance, x))?;
        let r = refined.iter().find(|p| same_load(p.l.abs(), x))?;
        Some(u.flux / r.y)
    };
    let scale = junction.and_then(shared).or_else(|| {
        let mut d: Vec<f64> = uniform.iter().map(|p| p.distance).collect();
        d.sort_by(|a, b| b.total_cmp(a));
        d.into_iter().find_map(shared)
    });
    let Some(s) = scale else {
        return Vec::new();
    };
    let mut c: Vec<FluxPoint> = refined
        .iter()
        .filter(|p| p.l < 0.0 && p.y > 0.0)
        .map(|p| FluxPoint {
            distance: p.l.abs(),
            flux: p.y * s,
        })
        .collect();
    c.sort_by(|a, b| a.distance.total_cmp(&b.distance));
    c
}

/// The combined exponents' attributes under `at`.
fn write_exponents(out: &mut ArtefactWriter, at: &str, ex: &[Exponent]) -> Result<()> {
    for (k, e) in ex.iter().enumerate() {
        let nm = NAMES[k];
        out.set_attr_at(at, nm, e.value)?;
        out.set_attr_at(at, &format!("{nm}_fit_error"), e.fit_error)?;
        out.set_attr_at(at, &format!("{nm}_grid_spread"), e.grid_spread)?;
        out.set_attr_at(at, &format!("{nm}_error"), e.error)?;
        out.set_attr_at(at, &format!("{nm}_n"), e.n as i64)?;
        out.set_attr_at(at, &format!("{nm}_points"), e.points as i64)?;
        out.set_attr_at(at, &format!("{nm}_prefactor"), e.prefactor)?;
    }
    Ok(())
}

/// Per exponent: the combined estimate, the uniform-only one, the combined ladder's junctions.
type Asymptotics = ([Asymptotic; 4], [Asymptotic; 4], [Vec<(Depth, f64)>; 4]);

/// The asymptotic estimates from the combined ladder and from the uniform one alone (written
/// under `at` as `<e>_asymptotic_*`, `<e>_uniform_asymptotic_*` and `<e>_asymptotic_method`);
/// a failed one is NONE with a note. Also where each link of each combined ladder took over.
fn asymptotics(
    out: &mut ArtefactWriter,
    at: &str,
    d: &LadderData,
    chain: &[&Linked],
    notes: &mut Vec<String>,
) -> Result<Asymptotics> {
    let mut asy = [Asymptotic::NONE; 4];
    let mut uni = [Asymptotic::NONE; 4];
    let mut junctions: [Vec<(Depth, f64)>; 4] = Default::default();
    for k in 0..4 {
        let e = asymptotic::which(k);
        let levels = asymptotic::resolutions(d, e, notes);
        let uniform = asymptotic::estimate(&levels);
        let (est, how) = asymptotic::estimate_combined(d.lattice, e, &levels, chain);
        match (&est, &uniform) {
            (Err(why), _) => notes.push(format!("no asymptotic {}: {why}", symbol(NAMES[k]))),
            (Ok(_), Err(why)) if how.rungs.1 > 0 => notes.push(format!(
                "no uniform-only asymptotic {} (the refined ladder gives one): {why}",
                symbol(NAMES[k])
            )),
            _ => {}
        }
        asy[k] = est.unwrap_or(Asymptotic::NONE);
        uni[k] = uniform.unwrap_or(Asymptotic::NONE);
        if let Some(n) = &how.note {
            notes.push(format!(
                "{}: refined ladder not used: {n}",
                symbol(NAMES[k])
            ));
        }
        asy[k].write(out, at, NAMES[k])?;
        uni[k].write(out, at, &format!("{}_uniform", NAMES[k]))?;
        junctions[k] = how.junctions.clone();
        out.set_attr_at(at, &format!("{}_asymptotic_method", NAMES[k]), how.method)?;
    }
    Ok((asy, uni, junctions))
}

/// The asymptotic υ and χ from below from the chain's neck lengths ([`NECK_ROWS`],
/// [`asymptotic::estimate_neck`]), written under `at` as `<row>_asymptotic_*` and
/// `<row>_asymptotic_method`; a failed one is NONE with a note.
fn neck_asymptotics(
    out: &mut ArtefactWriter,
    at: &str,
    chain: &[(Depth, Option<&NeckLadder<'_>>)],
    notes: &mut Vec<String>,
) -> Result<[Asymptotic; 2]> {
    let mut est = [Asymptotic::NONE; 2];
    for (k, (name, m, e)) in NECK_ROWS.iter().enumerate() {
        let (a, how) = asymptotic::estimate_neck(*m, chain);
        if let Err(why) = &a {
            notes.push(format!(
                "no asymptotic {} from {}: {why}",
                symbol(NAMES[*e]),
                m.name()
            ));
        }
        if let Some(n) = &how.note {
            notes.push(format!(
                "{} ({}): refined ladder not used: {n}",
                symbol(NAMES[*e]),
                m.name()
            ));
        }
        est[k] = a.unwrap_or(Asymptotic::NONE);
        est[k].write(out, at, name)?;
        out.set_attr_at(at, &format!("{name}_asymptotic_method"), how.method)?;
    }
    Ok(est)
}

#[cfg(test)]
mod tests {
    use super::*;
    use analysis::ScalingPoint;

    /// The synthetic flux law of these tests, |l|^3.45.
    fn law_3_45(a: f64) -> f64 {
        a.powf(3.45)
    }

    /// The uniform flux curve of the law at 2e-3 … 2e-2, normalised at 2e-2.
    fn uniform_flux() -> Vec<FluxPoint> {
        [2e-3, 5e-3, 1e-2, 2e-2]
            .iter()
            .map(|&a| FluxPoint {
                distance: a,
                flux: law_3_45(a) / law_3_45(2e-2),
            })
            .collect()
    }

    #[test]
    fn the_refined_flux_continues_the_uniform_curve() {
        let q = law_3_45;
        let uniform = uniform_flux();
        // another quantity with the same law (2.5 × 0.9 ...), and a rung at l > 0 (left out)
        let refined: Vec<ScalingPoint> = [1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3]
            .iter()
            .map(|&a| ScalingPoint::new(-a, 7.0 * q(a), 0.0))
            .chain([ScalingPoint::new(5e-3, 1.0, 0.0)])
            .collect();
        // at the junction 2e-3 the refined curve equals the uniform one, and so everywhere
        let c = refined_flux_curve(&uniform, &refined, Some(2e-3));
        assert_eq!(c.len(), 6);
        assert_eq!(c[0].distance, 1e-4);
        for p in &c {
            let want = q(p.distance) / q(2e-2);
            assert!((p.flux / want - 1.0).abs() < 1e-12, "{p:?}");
        }
        // without a junction: the largest shared distance (5e-3), the same here
        let c2 = refined_flux_curve(&uniform, &refined, None);
        assert!((c2[0].flux / c[0].flux - 1.0).abs() < 1e-12);
        // a junction that is not shared falls back likewise; no shared rung: nothing
        assert_eq!(refined_flux_curve(&uniform, &refined, Some(3e-3)).len(), 6);
        assert!(refined_flux_curve(&uniform, &refined[..3], None).is_empty());
    }

    /// A chain: the refined flux (7 × the law) from 5e-3, a deep one (0.2 × the law) from
    /// 5e-4; each continues the curve before it at its junction, so both equal the uniform
    /// normalisation everywhere; a deep ladder sharing no rung with the refined curve is not
    /// drawn (a note), and one after an undrawn link is not tried.
    #[test]
    fn the_deep_flux_continues_the_refined_curve() {
        let q = law_3_45;
        let uniform = uniform_flux();
        let law = |f: f64, ls: &[f64]| -> Vec<ScalingPoint> {
            ls.iter()
                .map(|&a| ScalingPoint::new(-a, f * q(a), 0.0))
                .collect()
        };
        let refined = law(7.0, &[5e-4, 1e-3, 2e-3, 5e-3]);
        let deep = law(0.2, &[5e-5, 1e-4, 2e-4, 5e-4]);
        let links = vec![(Depth::Refined, refined.clone()), (Depth::Deep, deep)];
        let junctions = [(Depth::Refined, -2e-3), (Depth::Deep, -5e-4)];
        let mut notes = Vec::new();
        let c = chained_flux_curves(&uniform, &links, &junctions, &mut notes);
        assert!(notes.is_empty(), "{notes:?}");
        assert_eq!(c.len(), 2);
        assert_eq!((c[0].0, c[0].2), (Depth::Refined, Some(2e-3)));
        assert_eq!((c[1].0, c[1].2), (Depth::Deep, Some(5e-4)));
        assert_eq!(c[1].1.len(), 4);
        // two rescalings (7 → 1, 0.2 → 1): the law to rounding
        for p in c.iter().flat_map(|c| &c.1) {
            let want = q(p.distance) / q(2e-2);
            assert!((p.flux / want - 1.0).abs() < 1e-12, "{p:?}");
        }
        // a deep ladder below the refined curve's reach (no shared rung): not drawn, noted
        let far = vec![
            (Depth::Refined, refined.clone()),
            (Depth::Deep, law(0.2, &[5e-5, 1e-4])),
        ];
        let c2 = chained_flux_curves(&uniform, &far, &junctions, &mut notes);
        assert!(c2[1].1.is_empty());
        assert!(notes[0].contains("refined_deep flux shares no rung with the refined curve"));
        // an undrawn first link ends the chain
        let lost = vec![
            (Depth::Refined, law(7.0, &[1e-4, 5e-4])),
            (Depth::Deep, law(0.2, &[5e-5, 1e-4])),
        ];
        assert_eq!(
            chained_flux_curves(&uniform, &lost, &[], &mut notes).len(),
            1
        );
    }
}
