//! `.npy` files (NumPy's binary format) through `ndarray-npy`: 2-D little- or big-endian
//! `float64`/`float32`, C or Fortran order. The header is read first, so the shape and element
//! type are checked (and the size refused) before the data is allocated.

use crate::{FormatError, ReadOptions, check_size};
use ndarray::{Array2, ArrayD, Ix2};
use ndarray_npy::npy::header::Header;
use ndarray_npy::{ReadNpyExt, WriteNpyExt};
use std::fs::File;
use std::io::{BufReader, BufWriter, Seek, SeekFrom};
use std::path::Path;
use surface::HeightField;

/// Reads the heights of a 2-D `float64`/`float32` `.npy` file.
pub fn read(path: &Path, options: &ReadOptions) -> Result<Array2<f64>, FormatError> {
    let file = File::open(path).map_err(|e| FormatError::io(path, e))?;
    let mut reader = BufReader::new(file);
    let header = Header::from_reader(&mut reader)
        .map_err(|e| FormatError::invalid(path, format!("not a readable .npy file: {e}")))?;
    let shape = &header.shape;
    if shape.len() != 2 {
        return Err(FormatError::invalid(
            path,
            format!(
                "the array has {} dimension(s), shape {shape:?}; allowed: a 2-D array of \
                 heights, shape (nx, ny) with the first index x",
                shape.len()
            ),
        ));
    }
    let nodes = shape[0] as u128 * shape[1] as u128;
    check_size(path, nodes, &format!("shape {shape:?}"), options.max_nodes)?;
    let descr = header.type_descriptor.to_string();
    reader
        .seek(SeekFrom::Start(0))
        .map_err(|e| FormatError::io(path, e))?;
    let wrong = |e: ndarray_npy::ReadNpyError| {
        FormatError::invalid(path, format!("cannot read the {descr} data: {e}"))
    };
    let is = |kinds: &[&str]| kinds.iter().any(|k| descr.contains(k));
    let data: Array2<f64> = if is(&["f8"]) {
        let a = ArrayD::<f64>::read_npy(reader).map_err(wrong)?;
        a.into_dimensionality::<Ix2>()
            .map_err(|e| FormatError::invalid(path, e.to_string()))?
    } else if is(&["f4"]) {
        let a = ArrayD::<f32>::read_npy(reader).map_err(wrong)?;
        a.into_dimensionality::<Ix2>()
            .map_err(|e| FormatError::invalid(path, e.to_string()))?
            .mapv(f64::from)
    } else {
        return Err(FormatError::invalid(
            path,
            format!("element type {descr}; allowed: float64 or float32"),
        ));
    };
    Ok(data.as_standard_layout().into_owned())
}

/// Writes the heights as a C-order `float64` `.npy` file (the cell size is not stored: the
/// format has no place for it).
pub fn write(path: &Path, field: &HeightField) -> Result<(), FormatError> {
    let file = File::create(path).map_err(|e| FormatError::io(path, e))?;
    field
        .heights
        .as_standard_layout()
        .write_npy(BufWriter::new(file))
        .map_err(|e| FormatError::invalid(path, format!("cannot write: {e}")))
}
