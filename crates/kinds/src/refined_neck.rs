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

#[cfg(test)]
mod tests {
    use super::*;
    use formats::records::Record;
    use store::ArtefactWriter;

    fn rung(l: f64, neck_nodes: usize) -> RefinedRungRow {
        RefinedRungRow {
            l,
            load: 1.0,
            saddle_gap: 1e-3,
            contact_area: 0.5,
            iterations: 10,
            wall_s: 0.1,
            neck_nodes,
            flagged: false,
            half_width: f64::NAN,
            half_width_error: f64::NAN,
            half_length: f64::NAN,
            half_length_error: f64::NAN,
            conductance: f64::NAN,
            conductance_error: f64::NAN,
        }
    }

    /// Writes `d/0` (with neck datasets of `n` values each, or none) and `d/1` (with them),
    /// the layout of `refined_ladder::write_rungs`.
    fn artefact(dir: &std::path::Path, neck: Option<usize>) -> std::path::PathBuf {
        let path = dir.join("r.h5");
        let mut w = ArtefactWriter::create(&path).unwrap();
        let rows = [rung(-0.01, 21), rung(-0.005, 15)];
        for (i, levels) in [(0, 2i64), (1, 3)] {
            let at = format!("d/{i}");
            RefinedRungRow::write(&rows, &mut w, &at).unwrap();
            w.write_strings(&format!("{at}/flag"), &["", "solve not converged"])
                .unwrap();
            let n = if i == 0 { neck } else { Some(2) };
            if let Some(n) = n {
                for (k, name) in NECK_DATASETS.iter().enumerate() {
                    let v: Vec<f64> = (0..n).map(|j| (k * 10 + j) as f64).collect();
                    w.write_f64_1d(&format!("{at}/{name}"), &v).unwrap();
                }
            }
            w.set_attr_at(&at, "levels", levels).unwrap();
            w.set_attr_at(&at, "margin", 8i64).unwrap();
            w.set_attr_at(&at, "spacing", 1e-3 / levels as f64).unwrap();
        }
        w.publish().unwrap();
        path
    }

    /// The stored rungs come back with their lengths; an artefact without the neck datasets
    /// reads as `None` (not zeros); a dataset of the wrong length is an error naming the file
    /// and dataset.
    #[test]
    fn reads_the_neck_datasets_or_says_they_are_absent() {
        let dir = tempfile::tempdir().unwrap();
        let p = artefact(dir.path(), Some(2));
        let d = read_ladder(&ArtefactReader::open(&p).unwrap())
            .unwrap()
            .unwrap();
        assert_eq!(d.len(), 2);
        assert_eq!((d[1].levels, d[1].margin), (3, 8));
        assert_eq!(d[0].rungs[1].lengths, [1.0, 11.0, 21.0]);
        assert_eq!(d[0].rungs[1].flag, "solve not converged");
        assert_eq!(d[0].rungs[0].neck_nodes, 21);
        std::fs::remove_file(&p).unwrap();
        let p = artefact(dir.path(), None);
        assert!(
            read_ladder(&ArtefactReader::open(&p).unwrap())
                .unwrap()
                .is_none()
        );
        std::fs::remove_file(&p).unwrap();
        let p = artefact(dir.path(), Some(3));
        let e = read_ladder(&ArtefactReader::open(&p).unwrap())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("r.h5")
                && e.contains("d/0/neck_width_rms")
                && e.contains("3 values for 2 rungs"),
            "{e}"
        );
    }
}
