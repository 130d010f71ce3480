//! Provenance: where an artefact came from. Written by every pipeline stage into the group
//! `/provenance` of its artefact, one attribute per field (JSON-valued fields as JSON strings),
//! so `h5dump -g /provenance` or h5py show it without this code.

use crate::artefact::{ArtefactReader, ArtefactWriter};
use crate::canonical;
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;

/// The HDF5 group holding provenance attributes.
pub const PROVENANCE_GROUP: &str = "provenance";

/// The saddleflow version that wrote an artefact (the workspace version).
pub const SADDLEFLOW_VERSION: &str = env!("CARGO_PKG_VERSION");

/// A side output (figure, CSV table) a stage published next to its artefact.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SideOutput {
    /// Path relative to the project root, with `/` separators (e.g. `figures/fig2.png`).
    pub path: String,
    /// BLAKE3 of its bytes (hex).
    pub blake3: String,
    /// Size in bytes.
    pub bytes: u64,
}

/// Where an artefact came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// The stage key (64 hex digits).
    pub key: String,
    /// The stage kind (`surface`, `sweep`, ...), or the command for direct commands (`solve`).
    pub kind: String,
    /// The kind's code version (bumped when its results change).
    pub code_version: u64,
    /// Canonical parameters with every default filled in.
    pub params: Value,
    /// Input name → keys of the input stages (a list: an input may take several stages).
    pub inputs: BTreeMap<String, Vec<String>>,
    /// Wall time of the stage's `run`, seconds.
    pub wall_s: f64,
    /// Solver statistics (iterations, residuals, ...), free-form JSON.
    pub stats: Value,
    /// Warnings the stage raised.
    pub warnings: Vec<String>,
    /// Side outputs published with the artefact.
    pub side_outputs: Vec<SideOutput>,
    /// Creation time, UTC, ISO-8601 (`2026-11-05T14:03:27Z`).
    pub created_utc: String,
    /// Host name of the machine that computed it.
    pub host: String,
    /// saddleflow version.
    pub saddleflow_version: String,
}

impl Provenance {
    /// A provenance record for a direct command (e.g. `saddleflow solve --out`): the key is the
    /// BLAKE3 of `{kind, code_version, params}` in canonical JSON; time, host and version are
    /// filled in; wall time and statistics are left for the caller.
    pub fn for_command(kind: &str, code_version: u64, params: Value) -> Result<Self> {
        let key = canonical::hash_json(&serde_json::json!({
            "kind": kind,
            "code_version": code_version,
            "params": params,
            "inputs": {},
        }))?;
        Ok(Self::new(key, kind, code_version, params))
    }

    /// A record with the given identity, empty statistics, the current time and host.
    pub fn new(key: String, kind: &str, code_version: u64, params: Value) -> Self {
        Self {
            key,
            kind: kind.to_string(),
            code_version,
            params,
            inputs: BTreeMap::new(),
            wall_s: 0.0,
            stats: Value::Object(Default::default()),
            warnings: Vec::new(),
            side_outputs: Vec::new(),
            created_utc: fsutil::utc_now_iso8601(),
            host: fsutil::host_name(),
            saddleflow_version: SADDLEFLOW_VERSION.to_string(),
        }
    }

    /// Writes the record as attributes of `/provenance`.
    pub fn write_to(&self, w: &mut ArtefactWriter) -> Result<()> {
        let g = PROVENANCE_GROUP;
        w.set_attr_at(g, "key", self.key.as_str())?;
        w.set_attr_at(g, "kind", self.kind.as_str())?;
        w.set_attr_at(g, "code_version", self.code_version)?;
        w.set_attr_at(g, "params", canonical::canonical_json(&self.params)?)?;
        w.set_attr_at(g, "inputs", serde_json::to_value(&self.inputs)?)?;
        w.set_attr_at(g, "wall_s", self.wall_s)?;
        w.set_attr_at(g, "stats", self.stats.clone())?;
        w.set_attr_at(g, "warnings", serde_json::to_value(&self.warnings)?)?;
        w.set_attr_at(g, "side_outputs", serde_json::to_value(&self.side_outputs)?)?;
        w.set_attr_at(g, "created_utc", self.created_utc.as_str())?;
        w.set_attr_at(g, "host", self.host.as_str())?;
        w.set_attr_at(g, "saddleflow_version", self.saddleflow_version.as_str())?;
        Ok(())
    }

    /// Reads the record back from `/provenance`.
    pub fn read_from(r: &ArtefactReader) -> Result<Self> {
        let g = PROVENANCE_GROUP;
        let ctx = || format!("`{}`: bad or missing provenance", r.path().display());
        (|| -> Result<Self> {
            Ok(Self {
                key: r.attr_str_at(g, "key")?,
                kind: r.attr_str_at(g, "kind")?,
                code_version: r.attr_i64_at(g, "code_version")? as u64,
                params: r.attr_json_at(g, "params")?,
                inputs: serde_json::from_value(r.attr_json_at(g, "inputs")?)?,
                wall_s: r.attr_f64_at(g, "wall_s")?,
                stats: r.attr_json_at(g, "stats")?,
                warnings: serde_json::from_value(r.attr_json_at(g, "warnings")?)?,
                side_outputs: serde_json::from_value(r.attr_json_at(g, "side_outputs")?)?,
                created_utc: r.attr_str_at(g, "created_utc")?,
                host: r.attr_str_at(g, "host")?,
                saddleflow_version: r.attr_str_at(g, "saddleflow_version")?,
            })
        })()
        .with_context(ctx)
    }
}
