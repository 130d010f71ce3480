//! The neck lengths of the refined kinds' artefacts as the `running` scene reads them (issue 13,
//! docs/near-critical.md §11–12): per discretisation, every rung's reduced load, open fine nodes
//! across the neck (`neck_nodes`), flag and the three lengths `critical::refined::NeckRecord`
//! records (`neck_width_rms`, `neck_width_level`, `neck_rise_length`, λ, NaN where not
//! measured), which `refined_ladder::write_rungs` writes beside the rung records of a
//! `refined_ladder` artefact (`d/<i>/*`) and of a `refined_window` artefact (`rungs/*`).
//!
//! A reader only: kept apart from `refined_ladder` and `refined_window` so that those compute
//! kinds' code identities (and their expensive caches) stay as they are. An artefact written
//! before the neck lengths were stored has no such datasets: the readers then return `None`
//! (the caller says so), never zeros.

use crate::refined_ladder::RefinedRungRow;
use anyhow::{Result, anyhow};
use formats::records::read_in;
use store::ArtefactReader;

/// The neck datasets beside a rung record, in [`NeckRung::lengths`] order.
pub const NECK_DATASETS: [&str; 3] = ["neck_width_rms", "neck_width_level", "neck_rise_length"];

/// One rung's neck data as stored.
#[derive(Clone, Debug, PartialEq)]
pub struct NeckRung {
    /// Reduced load from the discretisation's own p_c (signed).
    pub l: f64,
    /// Open fine nodes across the channel through the saddle (`RefinedRungRow::neck_nodes`).
    pub neck_nodes: usize,
    /// The rung's flag (empty: unflagged), as stored in `<at>/flag`.
    pub flag: String,
    /// rms width W_2, level width, rise length (λ; [`NECK_DATASETS`] order), NaN where not
    /// measured.
    pub lengths: [f64; 3],
}

/// One discretisation's rungs with their neck data.
#[derive(Clone, Debug, PartialEq)]
pub struct NeckDisc {
    /// Refinement levels k.
    pub levels: u32,
    /// Margin (base cells).
    pub margin: u32,
    /// Fine spacing (λ).
    pub spacing: f64,
    /// Its rungs, as stored (ascending l).
    pub rungs: Vec<NeckRung>,
}

/// The rungs at `at` (`d/<i>` or `rungs`) with their neck data; `None` if the artefact has no
/// neck datasets there (written before they were stored).
pub fn read_rungs(r: &ArtefactReader, at: &str) -> Result<Option<Vec<NeckRung>>> {
    if NECK_DATASETS
        .iter()
        .any(|n| !r.has_dataset(&format!("{at}/{n}")))
    {
        return Ok(None);
    }
    let rows: Vec<RefinedRungRow> = read_in(r, at)?;
    let flags = r.read_strings(&format!("{at}/flag"))?;
    let mut cols = Vec::with_capacity(3);
    for name in NECK_DATASETS {
        cols.push(r.read_f64_1d(&format!("{at}/{name}"))?);
    }
    for (len, what) in [(flags.len(), "flag")]
        .into_iter()
        .chain(NECK_DATASETS.iter().zip(&cols).map(|(n, c)| (c.len(), *n)))
    {
        if len != rows.len() {
            return Err(anyhow!(
                "{}: {at}/{what}: {len} values for {} rungs (allowed: one per rung)",
                r.path().display(),
                rows.len()
            ));
        }
    }
    Ok(Some(
        rows.iter()
            .enumerate()
            .map(|(k, row)| NeckRung {
                l: row.l,
                neck_nodes: row.neck_nodes,
                flag: flags[k].clone(),
                lengths: [cols[0][k], cols[1][k], cols[2][k]],
            })
            .collect(),
    ))
}

/// Every discretisation of a `refined_ladder` artefact (`d/<i>`, in the order of
/// `refined_ladder::RefinedData::read`: coarse to fine, then the margin check); `None` if one
/// lacks the neck datasets.
pub fn read_ladder(r: &ArtefactReader) -> Result<Option<Vec<NeckDisc>>> {
    let mut names = r.members("d")?;
    names.sort_by_key(|n| n.parse::<usize>().unwrap_or(usize::MAX));
    let mut out = Vec::with_capacity(names.len());
    for name in names {
        let at = format!("d/{name}");
        let Some(rungs) = read_rungs(r, &at)? else {
            return Ok(None);
        };
        out.push(NeckDisc {
            levels: r.attr_i64_at(&at, "levels")? as u32,
            margin: r.attr_i64_at(&at, "margin")? as u32,
            spacing: r.attr_f64_at(&at, "spacing")?,
            rungs,
        });
    }
    Ok(Some(out))
}

/// The one discretisation of a `refined_window` artefact (`rungs/*`: level `level`, margin
/// `margin`, the check's window and spacing); `None` without neck datasets.
pub fn read_window(r: &ArtefactReader) -> Result<Option<NeckDisc>> {
    let Some(rungs) = read_rungs(r, "rungs")? else {
        return Ok(None);
    };
    Ok(Some(NeckDisc {
        levels: r.attr_i64("level")? as u32,
        margin: r.attr_i64("margin")? as u32,
        spacing: r.attr_f64("spacing")?,
        rungs,
    }))
}
