//! HDF5 height files in the project's layout: a 2-D numeric dataset `height` of shape
//! `(nx, ny)` (first index x) and root attributes `lx`, `ly` (the periodic cell, numbers > 0;
//! a one-element array is accepted as written by `h5py` for `attrs["lx"] = [1.0]`). Integer and
//! `float32` data are converted to `f64` by HDF5. The shape is read from the metadata and the
//! size checked before the data is read.

use crate::{FormatError, ReadOptions, check_size};
use ndarray::Array2;
use std::path::Path;
use surface::HeightField;

/// Name of the height dataset.
pub const HEIGHT: &str = "height";

/// Reads the heights and the cell `(lx, ly)` (the attributes are required unless
/// [`ReadOptions::cell`] is given).
pub fn read(path: &Path, options: &ReadOptions) -> Result<(Array2<f64>, (f64, f64)), FormatError> {
    let bad = |what: String| FormatError::invalid(path, what);
    let file = hdf5::File::open(path).map_err(|e| bad(format!("not a readable HDF5 file: {e}")))?;
    let ds = file.dataset(HEIGHT).map_err(|_| {
        bad(format!(
            "no dataset `/{HEIGHT}`; a height file needs a 2-D numeric dataset `/{HEIGHT}` of \
             shape (nx, ny), first index x (datasets present: {})",
            file.member_names().unwrap_or_default().join(", ")
        ))
    })?;
    let shape = ds.shape();
    if shape.len() != 2 {
        return Err(bad(format!(
            "dataset `/{HEIGHT}` has shape {shape:?}; allowed: rank 2, shape (nx, ny)"
        )));
    }
    check_size(
        path,
        shape[0] as u128 * shape[1] as u128,
        &format!("dataset `/{HEIGHT}` of shape {shape:?}"),
        options.max_nodes,
    )?;
    let cell = match options.cell {
        Some(c) => c,
        None => (attr(&file, path, "lx")?, attr(&file, path, "ly")?),
    };
    let heights = ds.read_2d::<f64>().map_err(|e| {
        bad(format!(
            "dataset `/{HEIGHT}` cannot be read as numbers: {e}"
        ))
    })?;
    Ok((heights, cell))
}

/// A root attribute that must be one finite number > 0.
fn attr(file: &hdf5::File, path: &Path, name: &str) -> Result<f64, FormatError> {
    let bad = |what: String| FormatError::invalid(path, what);
    let a = file.attr(name).map_err(|_| {
        bad(format!(
            "root attribute `{name}` is missing; a height file needs `lx` and `ly` (the cell \
             size, numbers > 0), or give the cell size explicitly"
        ))
    })?;
    let v: Vec<f64> = a
        .read_raw::<f64>()
        .map_err(|_| bad(format!("root attribute `{name}` is not a number")))?;
    match v[..] {
        [x] if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(bad(format!(
            "root attribute `{name}` = {v:?}; allowed: one finite number > 0"
        ))),
    }
}

/// Writes `height`, `lx`, `ly`.
pub fn write(path: &Path, field: &HeightField) -> Result<(), FormatError> {
    let bad = |e: hdf5::Error| FormatError::invalid(path, format!("cannot write: {e}"));
    let file = hdf5::File::create(path).map_err(bad)?;
    file.new_dataset_builder()
        .with_data(&field.heights.as_standard_layout())
        .create(HEIGHT)
        .map_err(bad)?;
    for (name, v) in [("lx", field.grid.lx), ("ly", field.grid.ly)] {
        file.new_attr::<f64>()
            .create(name)
            .and_then(|a| a.write_scalar(&v))
            .map_err(bad)?;
    }
    Ok(())
}
