//! `topography`: a user's height file (`.npy`, `.h5`/`.hdf5`, text matrix or `x y z` columns:
//! the readers of `crates/formats`) as a surface artefact.
//!
//! Parameters: `path` (relative to the project root), `lx`, `ly` (cell size; 0 = from the file,
//! which only HDF5 files and `x y z` columns carry), `height_scale` (unit conversion of the
//! heights, default 1), `detrend` (`none` | `mean` | `plane`, default `none`; never silent: the
//! removed plane is stored as attributes `detrend_offset`, `detrend_slope_x`,
//! `detrend_slope_y` and reported as a warning), `columns` (text as `x y z`, default false),
//! `max_nodes` (largest field accepted, checked from the header before the heights are
//! allocated; default 2^26).
//!
//! The file's CONTENT is hashed into the stage key ([`TypedKind::file_inputs`]): editing the
//! file reruns this stage and everything downstream; its BLAKE3 is also stored as attribute
//! `file_blake3`. Artefact: the layout of `selfaffine` ([`crate::selfaffine::write_height_field`]),
//! `source = "topography"`.

use anyhow::{Result, anyhow};
use formats::{Detrend, ReadOptions, TextLayout};
use orchestrator::{
    Inputs, ParamIssue, ParamSpec, ParamType, Params, StageContext, StageReport, TypedKind,
};
use serde::Deserialize;
use std::collections::BTreeMap;
use store::ArtefactWriter;

/// The `topography` stage kind.
pub struct TopographyKind;

/// Bump when the artefact's content changes for the same parameters and file.
pub const CODE_VERSION: u64 = 1;

/// The `topography` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TopographyParams {
    /// The height file, relative to the project root.
    pub path: String,
    /// Cell size along x (0: from the file).
    pub lx: f64,
    /// Cell size along y (0: from the file).
    pub ly: f64,
    /// Factor applied to the heights.
    pub height_scale: f64,
    /// `none`, `mean` or `plane`.
    pub detrend: String,
    /// Text as `x y z` columns.
    pub columns: bool,
    /// Largest number of nodes accepted.
    pub max_nodes: u64,
}

impl TopographyParams {
    /// The readers' options; the error names the parameter.
    pub fn options(&self) -> Result<ReadOptions, ParamIssue> {
        let cell = match (self.lx > 0.0, self.ly > 0.0) {
            (true, true) => Some((self.lx, self.ly)),
            (false, false) => None,
            _ => {
                return Err(ParamIssue::new(
                    "lx",
                    format!(
                        "lx = {}, ly = {}: give both (> 0) or neither (0: the cell size from \
                         the file)",
                        self.lx, self.ly
                    ),
                ));
            }
        };
        let detrend: Detrend = self.detrend.parse().map_err(|_| {
            ParamIssue::new(
                "detrend",
                format!(
                    "\"{}\"; allowed: \"none\", \"mean\", \"plane\"",
                    self.detrend
                ),
            )
        })?;
        Ok(ReadOptions {
            cell,
            height_scale: self.height_scale,
            detrend,
            text_layout: TextLayout::of(self.columns),
            max_nodes: self.max_nodes as usize,
        })
    }
}

/// A lower bound of the bytes of the heights a height file holds, from its size (at plan time,
/// relative to the current folder = the project root): `.npy` and HDF5 store 4 or 8 bytes per
/// node (float32 read as f64 doubles it), so the size less a header bounds them; a text number
/// takes at most ~25 characters, so 8/25 of a text file's size is a lower bound. `None` if the
/// file cannot be read.
pub fn heights_bytes_lower_bound(path: &str) -> Option<u64> {
    let size = std::fs::metadata(path).ok()?.len();
    let ext = std::path::Path::new(path)
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    Some(match ext.as_deref() {
        Some("npy" | "h5" | "hdf5") => size.saturating_sub(4096),
        _ => size / 25 * 8,
    })
}

/// The largest height field upstream of a stage, in bytes (f64 per node): 8 × 4^n for any grid
/// exponent `n`/`ns` upstream, or a `topography` file's lower bound (its string `path`).
pub fn upstream_field_bytes(inputs: &BTreeMap<String, Vec<Params>>) -> Option<u64> {
    fn walk(v: &serde_json::Value, best: &mut Option<u64>) {
        let Some(o) = v.as_object() else { return };
        if let Some(b) = o
            .get("path")
            .and_then(|p| p.as_str())
            .and_then(heights_bytes_lower_bound)
        {
            *best = Some(best.map_or(b, |x| x.max(b)));
        }
        for list in o
            .get(orchestrator::UPSTREAM)
            .and_then(|u| u.as_object())
            .into_iter()
            .flat_map(|u| u.values())
        {
            for p in list.as_array().into_iter().flatten() {
                walk(p, best);
            }
        }
    }
    let mut best =
        orchestrator::upstream_max(inputs, &["n", "ns"]).map(crate::surface::field_bytes);
    for p in inputs.values().flatten() {
        let mut b = None;
        walk(&p.to_value(), &mut b);
        if let Some(b) = b {
            best = Some(best.map_or(b, |x| x.max(b)));
        }
    }
    best
}

impl TypedKind for TopographyKind {
    type Params = TopographyParams;
    fn name(&self) -> &str {
        "topography"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "a user's height file (.npy, .h5, text) as a surface artefact; its content is in the key"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("path", ParamType::string())
                .doc("height file (.npy, .h5/.hdf5, else text), relative to the project root"),
            ParamSpec::new("lx", ParamType::non_negative())
                .default(0.0)
                .doc("cell size along x (0: from the file)"),
            ParamSpec::new("ly", ParamType::non_negative())
                .default(0.0)
                .doc("cell size along y (0: from the file)"),
            ParamSpec::new("height_scale", ParamType::positive())
                .default(1.0)
                .doc("factor applied to the heights (unit conversion)"),
            ParamSpec::new("detrend", ParamType::one_of(&["none", "mean", "plane"]))
                .default("none")
                .doc("mean-plane removal (reported, never silent)"),
            ParamSpec::new("columns", ParamType::Bool)
                .default(false)
                .doc("text file as x y z columns on a regular grid"),
            ParamSpec::new("max_nodes", ParamType::int_range(4, 1 << 30))
                .default(formats::DEFAULT_MAX_NODES as i64)
                .doc("largest field accepted (checked before allocating)"),
        ]
    }
    fn check(&self, params: &TopographyParams) -> Result<(), ParamIssue> {
        if params.path.trim().is_empty() {
            return Err(ParamIssue::new("path", "empty; give the height file"));
        }
        params.options().map(drop)
    }
    /// The heights read (a lower bound from the file's size).
    fn memory_estimate(
        &self,
        params: &Params,
        _inputs: &BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        heights_bytes_lower_bound(params.str("path").ok()?)
    }
    fn file_inputs(&self, params: &TopographyParams) -> Vec<String> {
        vec![params.path.clone()]
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &TopographyParams,
        _inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let path = ctx.root.join(&params.path);
        let options = params.options().map_err(|e| anyhow!("{e}"))?;
        let hash = store::canonical::hash_file(&path)
            .map_err(|e| anyhow!("`{}` (parameter `path`): {e}", path.display()))?;
        let reading = formats::read(&path, &options)
            .map_err(|e| anyhow!("stage `{}`, parameter `path`: {e}", ctx.stage))?;
        ctx.progress(0.5, "read");
        if let Some(p) = reading.removed {
            ctx.warn(format!(
                "`{}`: detrend = \"{}\" removed the plane {:e} + {:e} x + {:e} y",
                params.path, params.detrend, p.offset, p.slope_x, p.slope_y
            ));
            out.set_attr("detrend_offset", p.offset)?;
            out.set_attr("detrend_slope_x", p.slope_x)?;
            out.set_attr("detrend_slope_y", p.slope_y)?;
        }
        let mut stats = crate::selfaffine::write_height_field(out, &reading.field, "topography")?;
        out.set_attr("file_blake3", hash.as_str())?;
        out.set_attr("detrend", params.detrend.as_str())?;
        out.set_attr("height_scale", params.height_scale)?;
        stats["file_blake3"] = serde_json::json!(hash);
        ctx.progress(1.0, "written");
        Ok(StageReport::with_stats(stats))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn params(path: &str, extra: serde_json::Value) -> TopographyParams {
        let mut v = json!({"path": path, "lx": 0.0, "ly": 0.0, "height_scale": 1.0,
            "detrend": "none", "columns": false, "max_nodes": 1 << 26});
        for (k, x) in extra.as_object().unwrap() {
            v[k] = x.clone();
        }
        serde_json::from_value(v).unwrap()
    }

    fn run(dir: &std::path::Path, p: &TopographyParams) -> Result<store::ArtefactReader> {
        let out_path = dir.join("out.h5");
        let mut w = ArtefactWriter::create(&out_path)?;
        let mut ctx = StageContext::detached("topo", dir);
        TopographyKind.run(&mut ctx, p, &Inputs::new(Default::default()), &mut w)?;
        w.publish()?;
        store::ArtefactReader::open(&out_path)
    }

    /// A text matrix is read with the given cell and scale, detrended by the plane that was
    /// added (recovered to rounding: 1e-12 on heights of order 1), in the surface layout.
    #[test]
    fn a_text_matrix_is_read_scaled_and_detrended() {
        let dir = tempfile::tempdir().unwrap();
        let (nx, ny) = (8usize, 6usize);
        // a checkerboard (even nx, ny) has no least-squares slope of its own
        let base = |i: usize, j: usize| if (i + j).is_multiple_of(2) { 0.1 } else { -0.1 };
        let mut text = String::from("# heights in µm\n");
        for i in 0..nx {
            let row: Vec<String> = (0..ny)
                .map(|j| format!("{}", base(i, j) + 0.3 + 0.02 * i as f64 - 0.01 * j as f64))
                .collect();
            text += &(row.join(" ") + "\n");
        }
        std::fs::write(dir.path().join("h.txt"), text).unwrap();
        let p = params(
            "h.txt",
            json!({"lx": 2.0, "ly": 1.5, "height_scale": 2.0, "detrend": "plane"}),
        );
        let r = run(dir.path(), &p).unwrap();
        let h = r.read_f64_2d("height").unwrap();
        assert_eq!(h.dim(), (nx, ny));
        assert_eq!(r.cell().unwrap(), (2.0, 1.5));
        assert_eq!(r.attr_str("source").unwrap(), "topography");
        // the plane's slope in the file's units times the scale, per unit length (dx = 2/8)
        let sx = r.attr_f64("detrend_slope_x").unwrap();
        assert!((sx - 2.0 * 0.02 / 0.25).abs() < 1e-12, "{sx}");
        assert!(r.attr_str("file_blake3").unwrap().len() == 64);
        assert!(h.iter().all(|v| v.is_finite()));
    }

    /// Missing cell size, NaN heights and a missing file: each error names the file.
    #[test]
    fn bad_files_are_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.txt"), "1 2\n3 4\n").unwrap();
        let e = format!(
            "{:#}",
            run(dir.path(), &params("m.txt", json!({}))).err().unwrap()
        );
        assert!(e.contains("m.txt") && e.contains("cell size"), "{e}");
        std::fs::write(dir.path().join("n.txt"), "1 nan\n3 4\n").unwrap();
        let e = format!(
            "{:#}",
            run(dir.path(), &params("n.txt", json!({"lx": 1.0, "ly": 1.0})))
                .err()
                .unwrap()
        );
        assert!(e.contains("n.txt") && e.contains("nan"), "{e}");
        let e = format!(
            "{:#}",
            run(dir.path(), &params("gone.npy", json!({})))
                .err()
                .unwrap()
        );
        assert!(e.contains("gone.npy"), "{e}");
        // one of lx, ly alone is refused at check time, naming lx
        let e = TopographyKind
            .check(&params("m.txt", json!({"lx": 1.0})))
            .unwrap_err()
            .to_string();
        assert!(e.contains("`lx`") && e.contains("both"), "{e}");
    }
}
