//! Reading and writing height fields (measured or generated topographies).
//!
//! # Formats
//! - `.npy` ([`npy`]): a 2-D `float64` or `float32` array, C or Fortran order (via
//!   `ndarray-npy`). No metadata: the cell size must be given ([`ReadOptions::cell`]).
//! - HDF5, `.h5`/`.hdf5` ([`h5`]): the project's layout, a 2-D numeric dataset `height` of shape
//!   `(nx, ny)` and root attributes `lx`, `ly`.
//! - Plain text, any other extension ([`text`]): a matrix of heights (one line per x index,
//!   whitespace- or comma-separated) or `x y z` columns on a regular grid
//!   ([`TextLayout`]); `#` starts a comment.
//!
//! # Conventions
//! Arrays have shape `(nx, ny)`, the first index x, as everywhere in the project; node `(i, j)`
//! sits at `(i dx, j dy)` of a periodic `lx × ly` cell, `lx = nx dx`. Heights are multiplied by
//! [`ReadOptions::height_scale`] (a unit conversion) and lengths are in the units of the cell
//! size.
//!
//! # What is refused
//! Every error names the file and what is wrong ([`FormatError`]): missing cell size, NaN or
//! infinite heights (missing points; their position is given), empty or 1-D data, ragged
//! matrices, non-uniform or incomplete `x y z` grids, unknown element types, and fields larger
//! than [`ReadOptions::max_nodes`] — checked from the header, the HDF5 metadata or the file size
//! before the heights are allocated, with the memory they would need.
//!
//! Also the contact solutions and gap fields the CLI and the compute kinds exchange through
//! artefacts and JSON ([`solution`], [`gapfile`]).
//!
//! Detrending ([`Detrend`]) is an explicit option; what was removed is reported in
//! [`Reading::removed`], never done silently.

pub mod gapfile;
pub mod h5;
pub mod npy;
pub mod records;
pub mod solution;
pub mod text;

use ndarray::Array2;
use std::path::Path;
use surface::{Grid, HeightField};

/// Default largest field: 2^13 × 2^13 nodes (512 MiB as `f64`), the largest grid the project
/// computes on.
pub const DEFAULT_MAX_NODES: usize = 1 << 26;

/// A file that cannot be read as a height field.
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    /// The file could not be opened, read or written.
    #[error("`{path}`: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The content is not an acceptable height field.
    #[error("`{path}`: {what}")]
    Invalid {
        /// The file.
        path: String,
        /// What is wrong and what is allowed.
        what: String,
    },
}

impl FormatError {
    pub(crate) fn invalid(path: &Path, what: impl Into<String>) -> Self {
        FormatError::Invalid {
            path: path.display().to_string(),
            what: what.into(),
        }
    }

    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        FormatError::Io {
            path: path.display().to_string(),
            source,
        }
    }
}

/// Optional mean-plane removal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Detrend {
    /// Heights as read.
    #[default]
    None,
    /// Subtract the mean height.
    Mean,
    /// Subtract the least-squares plane `a + b x + c y`.
    Plane,
}

impl Detrend {
    /// Every variant with its name (`none`, `mean`, `plane`), as parameters and flags spell it.
    pub const ALL: [(Detrend, &'static str); 3] = [
        (Detrend::None, "none"),
        (Detrend::Mean, "mean"),
        (Detrend::Plane, "plane"),
    ];
}

impl std::str::FromStr for Detrend {
    type Err = String;
    /// `none`, `mean` or `plane`; the error names the value and the allowed ones.
    fn from_str(s: &str) -> Result<Self, String> {
        Detrend::ALL
            .iter()
            .find(|(_, name)| *name == s)
            .map(|(d, _)| *d)
            .ok_or_else(|| format!("{s:?}: allowed none, mean, plane"))
    }
}

/// Layout of a plain-text file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TextLayout {
    /// One line per x index, one column per y index.
    #[default]
    Matrix,
    /// Three columns `x y z` on a regular grid, any order of the points.
    Columns,
}

/// How to read a file.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// Cell size `(lx, ly)`. Required for `.npy` and text matrices; for HDF5 it replaces the
    /// file's `lx`, `ly`; for `x y z` columns it must agree with the grid spacing.
    pub cell: Option<(f64, f64)>,
    /// Factor applied to the heights (unit conversion), finite and > 0. Default 1.
    pub height_scale: f64,
    /// Mean-plane removal. Default none.
    pub detrend: Detrend,
    /// Layout of text files. Default matrix.
    pub text_layout: TextLayout,
    /// Largest number of nodes accepted. Default [`DEFAULT_MAX_NODES`].
    pub max_nodes: usize,
}

impl TextLayout {
    /// `Columns` if the file holds `x y z` columns, else `Matrix`.
    pub fn of(columns: bool) -> TextLayout {
        if columns {
            TextLayout::Columns
        } else {
            TextLayout::Matrix
        }
    }
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            cell: None,
            height_scale: 1.0,
            detrend: Detrend::None,
            text_layout: TextLayout::Matrix,
            max_nodes: DEFAULT_MAX_NODES,
        }
    }
}

/// The plane removed by detrending, `a + b x + c y` (heights in the scaled units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Offset `a` (height at the origin).
    pub offset: f64,
    /// Slope `b` along x.
    pub slope_x: f64,
    /// Slope `c` along y.
    pub slope_y: f64,
}

/// A height field read from a file.
#[derive(Debug, Clone, PartialEq)]
pub struct Reading {
    /// The field (grid and heights).
    pub field: HeightField,
    /// What detrending removed (`None` if [`Detrend::None`]).
    pub removed: Option<Plane>,
}

/// Reads `path`, choosing the format by extension (`.npy`; `.h5`, `.hdf5`; anything else as
/// text).
pub fn read(path: &Path, options: &ReadOptions) -> Result<Reading, FormatError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let (heights, cell) = match ext.as_deref() {
        Some("npy") => (npy::read(path, options)?, None),
        Some("h5" | "hdf5") => {
            let (h, cell) = h5::read(path, options)?;
            (h, Some(cell))
        }
        _ => text::read(path, options)?,
    };
    finish(path, heights, cell, options)
}

/// Checks the options and the data, applies the unit scale and the detrending.
fn finish(
    path: &Path,
    mut heights: Array2<f64>,
    file_cell: Option<(f64, f64)>,
    options: &ReadOptions,
) -> Result<Reading, FormatError> {
    let s = options.height_scale;
    if !(s.is_finite() && s > 0.0) {
        return Err(FormatError::invalid(
            path,
            format!("height scale {s}: allowed a finite number > 0"),
        ));
    }
    let (nx, ny) = heights.dim();
    if nx < 2 || ny < 2 {
        return Err(FormatError::invalid(
            path,
            format!(
                "the heights have shape ({nx}, {ny}); allowed: a 2-D field with at least 2 \
                 nodes along each axis (1-D profiles and empty data are not surfaces)"
            ),
        ));
    }
    if let Some(((i, j), v)) = heights.indexed_iter().find(|(_, v)| !v.is_finite()) {
        return Err(FormatError::invalid(
            path,
            format!(
                "height {v} at node ({i}, {j}) (first index x): missing or non-finite points \
                 are not allowed; fill or crop them first"
            ),
        ));
    }
    let (lx, ly) = options.cell.or(file_cell).ok_or_else(|| {
        FormatError::invalid(
            path,
            "the cell size is not in the file: give it (lx, ly) explicitly",
        )
    })?;
    let grid =
        Grid::periodic(nx, ny, lx, ly).map_err(|e| FormatError::invalid(path, e.to_string()))?;
    if s != 1.0 {
        heights.mapv_inplace(|v| v * s);
    }
    let removed = detrend(&mut heights, &grid, options.detrend);
    let field =
        HeightField::new(grid, heights).map_err(|e| FormatError::invalid(path, e.to_string()))?;
    Ok(Reading { field, removed })
}

/// Removes the mean or the least-squares plane over the nodes `(i dx, j dy)`; returns it.
pub fn detrend(h: &mut Array2<f64>, grid: &Grid, how: Detrend) -> Option<Plane> {
    let (nx, ny) = h.dim();
    let n = (nx * ny) as f64;
    let mean = h.sum() / n;
    let plane = match how {
        Detrend::None => return None,
        Detrend::Mean => Plane {
            offset: mean,
            slope_x: 0.0,
            slope_y: 0.0,
        },
        Detrend::Plane => {
            // On a full rectangular grid the centred coordinates are orthogonal, so the
            // least-squares slopes decouple: b = Σ h (x − x̄) / Σ (x − x̄)².
            let (dx, dy) = (grid.dx(), grid.dy());
            let (xm, ym) = ((nx - 1) as f64 * dx / 2.0, (ny - 1) as f64 * dy / 2.0);
            let (mut sx, mut sy) = (0.0, 0.0);
            for ((i, j), &v) in h.indexed_iter() {
                sx += (v - mean) * (i as f64 * dx - xm);
                sy += (v - mean) * (j as f64 * dy - ym);
            }
            let vx = ny as f64 * (0..nx).map(|i| (i as f64 * dx - xm).powi(2)).sum::<f64>();
            let vy = nx as f64 * (0..ny).map(|j| (j as f64 * dy - ym).powi(2)).sum::<f64>();
            let (b, c) = (sx / vx, sy / vy);
            Plane {
                offset: mean - b * xm - c * ym,
                slope_x: b,
                slope_y: c,
            }
        }
    };
    let (dx, dy) = (grid.dx(), grid.dy());
    for ((i, j), v) in h.indexed_iter_mut() {
        *v -= plane.offset + plane.slope_x * i as f64 * dx + plane.slope_y * j as f64 * dy;
    }
    Some(plane)
}

/// Refuses a field of `nodes` nodes (`bytes_per_node` as stored) above `max_nodes`, naming the
/// memory it would need. Called before anything is allocated.
pub(crate) fn check_size(
    path: &Path,
    nodes: u128,
    what: &str,
    max_nodes: usize,
) -> Result<(), FormatError> {
    if nodes > max_nodes as u128 {
        let gib = nodes as f64 * 8.0 / (1u64 << 30) as f64;
        return Err(FormatError::invalid(
            path,
            format!(
                "{what}: {nodes} nodes would need {gib:.2} GiB as f64 heights; the limit is \
                 {max_nodes} nodes (raise it explicitly to read this file)"
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_detrending_removes_a_tilted_plane_exactly() {
        let grid = Grid::periodic(8, 6, 2.0, 3.0).unwrap();
        let bump = |i: usize, j: usize| ((i * 7 + j * 3) % 5) as f64 * 0.1;
        let mut h = Array2::from_shape_fn((8, 6), |(i, j)| {
            1.5 + 0.3 * i as f64 * grid.dx() - 0.2 * j as f64 * grid.dy() + bump(i, j)
        });
        let mut flat = Array2::from_shape_fn((8, 6), |(i, j)| bump(i, j));
        let p = detrend(&mut h, &grid, Detrend::Plane).unwrap();
        let q = detrend(&mut flat, &grid, Detrend::Plane).unwrap();
        // The fit is linear in h: the tilted field's plane is the bump's plane plus the tilt.
        assert!((p.slope_x - q.slope_x - 0.3).abs() < 1e-12, "{p:?} {q:?}");
        assert!((p.slope_y - q.slope_y + 0.2).abs() < 1e-12);
        assert!((p.offset - q.offset - 1.5).abs() < 1e-12);
        for (a, b) in h.iter().zip(&flat) {
            assert!((a - b).abs() < 1e-12);
        }
        assert!(h.sum().abs() < 1e-12);
        assert!(detrend(&mut h, &grid, Detrend::None).is_none());
    }
}
