//! The `critical` kind's writers (split from crates/kinds/src/critical.rs): every
//! `level/<n>` (attributes, the per-criterion and per-shift records, the saddle samples and the
//! sub-grid fit), the root attributes, the fields and the report statistics. The reader
//! ([`crate::critical::CriticalLevel`]) stays with the kind.

use anyhow::Result;
use critical::{Criterion, CriticalOptions, CriticalResult, LevelSummary, ResolutionStudy};
use formats::records::Record;
use ndarray::Array2;
use orchestrator::StageContext;
use serde_json::json;
use store::{ArtefactWriter, fields};
use surface::{Lattice, Surface};

/// Writes every `level/<n>`; warns on the finest level's sub-grid notes and on retried solves.
pub(crate) fn write_levels(
    ctx: &mut StageContext,
    out: &mut ArtefactWriter,
    study: &ResolutionStudy,
) -> Result<()> {
    let finest_n = study.levels.last().expect("levels").n;
    let mut retries = 0usize;
    for l in &study.levels {
        write_level(out, &format!("level/{}", l.n), l)?;
        retries += l.results.iter().map(|r| r.retries).sum::<usize>();
        // Coarse grids cannot resolve the channel at the sampled loads: only the finest
        // level's sub-grid notes are worth a warning.
        if l.n == finest_n {
            for r in &l.results {
                for note in &r.notes {
                    ctx.warn(format!("n = {}: sub-grid estimate: {note}", l.n));
                }
            }
        }
    }
    if retries > 0 {
        ctx.warn(format!(
            "{retries} contact solves did not converge from their warm start and were repeated \
             from another start (unexpected since the re-open step of Polonsky–Keer: please report)"
        ));
    }
    Ok(())
}

/// Root attributes: the cell, the grids, the options and the finest level's averages.
pub(crate) fn write_root(
    out: &mut ArtefactWriter,
    lattice: Lattice,
    ns: &[u32],
    copts: &CriticalOptions,
    finest: &LevelSummary,
    g: surface::Grid,
) -> Result<()> {
    out.set_cell(g.lx, g.ly)?;
    out.set_attr("lattice", lattice.name())?;
    out.set_attr("ns", json!(ns))?;
    out.set_attr("n", finest.n as i64)?;
    out.set_attr("tol_gap", copts.tol_gap)?;
    out.set_attr("rel_width", copts.rel_width)?;
    out.set_attr("p_fc_exact", lattice.exact().p_fc)?;
    let av = &finest.average;
    out.set_attr("l_c", av.any.l_c.mean)?;
    out.set_attr("a_p_raw", av.any.a_p_raw.mean)?;
    out.set_attr("a_p_corrected", av.any.a_p_corrected.mean)?;
    out.set_attr("p_fc_over_l_c", av.p_fc_over_l_c.mean)?;
    Ok(())
}

/// The fields below and above L_c on the finest grid (`fields = true`).
pub(crate) fn write_fields(
    out: &mut ArtefactWriter,
    lattice: Lattice,
    g: surface::Grid,
    f: &critical::Fields,
) -> Result<()> {
    let s = Surface::on_grid(lattice, g);
    out.write_f64_2d(fields::HEIGHT, s.heights.view())?;
    out.write_f64_2d(fields::GAP, f.below.gap.view())?;
    out.write_f64_2d(fields::DISPLACEMENT, f.below.displacement.view())?;
    out.write_f64_2d(fields::PRESSURE, f.below.pressure.view())?;
    out.write_f64_2d("above/gap", f.above.gap.view())?;
    out.write_f64_2d("above/pressure", f.above.pressure.view())?;
    out.set_attr("load_below", f.below.mean_pressure)?;
    out.set_attr("load_above", f.above.mean_pressure)?;
    out.set_attr("field_shift", json!([g.shift.0, g.shift.1]))?;
    Ok(())
}

/// The stage report's statistics: per level and the total iterations.
pub(crate) fn level_stats(study: &ResolutionStudy) -> serde_json::Value {
    let per_level: Vec<_> = study
        .levels
        .iter()
        .map(|l| {
            json!({
                "n": l.n,
                "solves": l.solves(),
                "iterations": l.iterations(),
                "wall_s": l.wall_s,
                "l_c": l.average.any.l_c.mean,
                "a_p_corrected": l.average.any.a_p_corrected.mean,
            })
        })
        .collect();
    json!({
        "levels": per_level,
        "iterations": study.levels.iter().map(|l| l.iterations()).sum::<usize>(),
    })
}

formats::record! {
    /// One shift's bracket of a criterion's transition (`level/<n>/<criterion>/*`).
    #[derive(Clone, Debug, PartialEq)]
    pub struct TransitionRow {
        /// Highest load bisected as percolating.
        pub lo: f64,
        /// Lowest load bisected as blocked.
        pub hi: f64,
        /// Raw contact area at `lo`.
        pub a_p_raw: f64,
        /// Perimeter-corrected contact area at `lo`.
        pub a_p_corrected: f64,
        /// Contact nodes at `lo`.
        pub contact_lo: usize,
        /// Contact nodes at `hi`.
        pub contact_hi: usize,
        /// Perimeter edges at `lo`.
        pub perimeter_lo: usize,
        /// Perimeter edges at `hi`.
        pub perimeter_hi: usize,
    }
}

impl TransitionRow {
    fn of(t: &critical::Transition) -> Self {
        TransitionRow {
            lo: t.bracket.lo,
            hi: t.bracket.hi,
            a_p_raw: t.a_p_raw(),
            a_p_corrected: t.a_p_corrected(),
            contact_lo: t.area_lo.n_contact,
            contact_hi: t.area_hi.n_contact,
            perimeter_lo: t.area_lo.n_perimeter_edges,
            perimeter_hi: t.area_hi.n_perimeter_edges,
        }
    }
}

formats::record! {
    /// One sub-grid shift of a level (`level/<n>/shifts/*`).
    #[derive(Clone, Debug, PartialEq)]
    pub struct ShiftRow {
        /// Shift along x (grid spacings).
        pub sx: f64,
        /// Shift along y.
        pub sy: f64,
        /// Full-contact pressure of the shifted grid.
        pub p_fc: f64,
        /// Wall time (s).
        pub wall_s: f64,
        /// Contact solves of the bisection.
        pub probes: usize,
        /// Polonsky–Keer iterations.
        pub iterations: usize,
    }
}

impl ShiftRow {
    fn of(r: &CriticalResult) -> Self {
        ShiftRow {
            sx: r.grid.shift.0,
            sy: r.grid.shift.1,
            p_fc: r.p_fc,
            wall_s: r.wall_s,
            probes: r.probes,
            iterations: r.iterations,
        }
    }
}

formats::record! {
    /// The sub-grid fit of one saddle direction (`level/<n>/subgrid/*`).
    #[derive(Clone, Debug, PartialEq)]
    pub struct SubgridFit {
        /// Direction (degrees).
        pub angle_deg: f64,
        /// Sub-grid L_c.
        pub l_c: f64,
        /// Its error.
        pub l_c_error: f64,
        /// ζ from the saddle gap.
        pub zeta: f64,
        /// Its error.
        pub zeta_error: f64,
        /// Points in the fit.
        pub points: usize,
    }
}

impl SubgridFit {
    fn of(f: &critical::SaddleFit) -> Self {
        SubgridFit {
            angle_deg: f.angle_deg,
            l_c: f.l_c.0,
            l_c_error: f.l_c.1,
            zeta: f.zeta.0,
            zeta_error: f.zeta.1,
            points: f.points,
        }
    }
}

formats::record! {
    /// One saddle direction sampled (`level/<n>/saddle/angle_deg`; the columns of
    /// `saddle/gap`).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct SaddleDirection {
        /// Direction (degrees).
        pub angle_deg: f64,
    }
}

formats::record! {
    /// One load sample of the saddle gap (`level/<n>/saddle/*`; the rows of `saddle/gap`).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct SaddleSampleRow {
        /// Load (E* h0/λ).
        pub load: f64,
        /// Reduced load (L − L_c)/L_c.
        pub reduced: f64,
        /// Contact area fraction.
        pub area: f64,
    }
}

fn write_level(out: &mut ArtefactWriter, at: &str, l: &LevelSummary) -> Result<()> {
    let results = &l.results;
    let av = &l.average;
    let g = results[0].grid;
    let attr = |out: &mut ArtefactWriter, k: &str, v: f64| out.set_attr_at(at, k, v);
    out.set_attr_at(at, "n", l.n as i64)?;
    out.set_attr_at(at, "nx", g.nx as i64)?;
    out.set_attr_at(at, "ny", g.ny as i64)?;
    attr(out, "h", l.h)?;
    out.set_attr_at(at, "shift_rule", shift_rule(&l.shifts) as i64)?;
    attr(out, "p_fc", av.p_fc.mean)?;
    for c in Criterion::ALL {
        let t = av.transition(c);
        let sfx = suffix(c);
        for (name, s) in [
            ("l_c", t.l_c),
            ("a_p_raw", t.a_p_raw),
            ("a_p_corrected", t.a_p_corrected),
        ] {
            attr(out, &format!("{name}{sfx}"), s.mean)?;
            attr(out, &format!("{name}{sfx}_sem"), s.sem)?;
        }
        let rows: Vec<TransitionRow> = results
            .iter()
            .map(|r| TransitionRow::of(r.transition(c)))
            .collect();
        TransitionRow::write(&rows, out, &format!("{at}/{}", c.name()))?;
    }
    attr(out, "p_fc_over_l_c", av.p_fc_over_l_c.mean)?;
    attr(out, "p_fc_over_l_c_sem", av.p_fc_over_l_c.sem)?;
    let shifts: Vec<ShiftRow> = results.iter().map(ShiftRow::of).collect();
    ShiftRow::write(&shifts, out, &format!("{at}/shifts"))?;
    out.set_attr_at(
        at,
        "probes",
        results.iter().map(|r| r.probes as i64).sum::<i64>(),
    )?;
    out.set_attr_at(at, "iterations", l.iterations() as i64)?;
    out.set_attr_at(
        at,
        "retries",
        results.iter().map(|r| r.retries as i64).sum::<i64>(),
    )?;
    attr(out, "wall_s", l.wall_s)?;
    write_saddle(out, at, &results[0])
}

/// The saddle samples and the sub-grid fit of one shift (`<at>/saddle/*`, `<at>/subgrid/*`,
/// attributes `l_c_subgrid`, `zeta` and their errors).
fn write_saddle(out: &mut ArtefactWriter, at: &str, r0: &CriticalResult) -> Result<()> {
    let attr = |out: &mut ArtefactWriter, k: &str, v: f64| out.set_attr_at(at, k, v);
    let directions: Vec<SaddleDirection> = (r0.groups.iter())
        .map(|g| SaddleDirection {
            angle_deg: g.angle_deg,
        })
        .collect();
    SaddleDirection::write(&directions, out, &format!("{at}/saddle"))?;
    let samples: Vec<SaddleSampleRow> = (r0.samples.iter())
        .map(|s| SaddleSampleRow {
            load: s.load,
            reduced: s.reduced,
            area: s.area,
        })
        .collect();
    SaddleSampleRow::write(&samples, out, &format!("{at}/saddle"))?;
    let gaps = Array2::from_shape_fn((r0.samples.len(), r0.groups.len()), |(i, k)| {
        r0.samples[i].gap[k].unwrap_or(f64::NAN)
    });
    out.write_f64_2d(&format!("{at}/saddle/gap"), gaps.view())?;
    let fits = r0
        .subgrid
        .as_ref()
        .map(|s| s.fits.clone())
        .unwrap_or_default();
    let fits: Vec<SubgridFit> = fits.iter().map(SubgridFit::of).collect();
    SubgridFit::write(&fits, out, &format!("{at}/subgrid"))?;
    let sub = r0.subgrid.as_ref();
    attr(out, "l_c_subgrid", sub.map_or(f64::NAN, |s| s.l_c))?;
    attr(
        out,
        "l_c_subgrid_error",
        sub.map_or(f64::NAN, |s| s.l_c_error),
    )?;
    attr(out, "zeta", sub.map_or(f64::NAN, |s| s.zeta))?;
    attr(out, "zeta_error", sub.map_or(f64::NAN, |s| s.zeta_error))?;
    Ok(())
}

fn suffix(c: Criterion) -> &'static str {
    match c {
        Criterion::Any => "",
        Criterion::X => "_x",
        Criterion::Y => "_y",
    }
}

/// The m of a shift set from [`critical::shift_set`] (0 for the unshifted grid).
fn shift_rule(shifts: &[(f64, f64)]) -> usize {
    if shifts == [(0.0, 0.0)] {
        0
    } else {
        (shifts.len() as f64).sqrt().round() as usize
    }
}
