//! Plain-text height files: a matrix (one line per x index, values separated by whitespace or
//! commas) or `x y z` columns on a regular grid. Blank lines and everything after `#` are
//! ignored. Numbers are parsed by the standard library (`f64::from_str`).
//!
//! Missing points (an empty field between commas, `nan`, `inf`) are refused with their line and
//! column. The text is read line by line and reading stops with an error once more than
//! [`ReadOptions::max_nodes`] values have been seen, so a huge file is refused before its
//! heights are held in memory.
//!
//! `x y z` columns: the distinct x and y values must each be equally spaced (relative
//! deviation of any step from the mean step ≤ 1e-6) and every grid point must occur exactly
//! once; the cell is `(nx dx, ny dy)`, and a cell given in [`ReadOptions::cell`] must agree with
//! it to 1e-9.

use crate::{FormatError, ReadOptions, TextLayout, check_size};
use ndarray::Array2;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

/// Relative tolerance on equal grid spacing of `x y z` columns.
const SPACING_TOLERANCE: f64 = 1e-6;

/// Heights and, if the file defines it, the cell `(lx, ly)`.
pub type HeightsAndCell = (Array2<f64>, Option<(f64, f64)>);

/// Reads heights, and for `x y z` columns the cell from the grid spacing.
pub fn read(path: &Path, options: &ReadOptions) -> Result<HeightsAndCell, FormatError> {
    let rows = parse(path, options.max_nodes)?;
    if rows.is_empty() {
        return Err(FormatError::invalid(path, "no numbers: the file is empty"));
    }
    match options.text_layout {
        TextLayout::Matrix => {
            let ny = rows[0].1.len();
            if let Some((line, r)) = rows.iter().find(|(_, r)| r.len() != ny) {
                return Err(FormatError::invalid(
                    path,
                    format!(
                        "line {line} has {} values but the first data line has {ny}: a height \
                         matrix needs the same number of values on every line",
                        r.len()
                    ),
                ));
            }
            let nx = rows.len();
            let flat: Vec<f64> = rows.into_iter().flat_map(|(_, r)| r).collect();
            let h = Array2::from_shape_vec((nx, ny), flat).expect("shape checked");
            Ok((h, None))
        }
        TextLayout::Columns => columns(path, &rows, options.cell).map(|(h, c)| (h, Some(c))),
    }
}

/// Data lines as (line number, values); refuses missing or non-finite values.
fn parse(path: &Path, max_nodes: usize) -> Result<Vec<(usize, Vec<f64>)>, FormatError> {
    let file = File::open(path).map_err(|e| FormatError::io(path, e))?;
    let mut rows = Vec::new();
    let mut count = 0u128;
    for (k, line) in BufReader::new(file).lines().enumerate() {
        let line = line.map_err(|e| FormatError::io(path, e))?;
        let n = k + 1;
        let data = line.split('#').next().unwrap_or("").trim();
        if data.is_empty() {
            continue;
        }
        let tokens: Vec<&str> = if data.contains(',') {
            data.split(',').map(str::trim).collect()
        } else {
            data.split_whitespace().collect()
        };
        let mut values = Vec::with_capacity(tokens.len());
        for (c, t) in tokens.iter().enumerate() {
            let v: f64 = t.parse().map_err(|_| {
                FormatError::invalid(
                    path,
                    format!(
                        "line {n}, column {}: {t:?} is not a number (missing points are not \
                         allowed)",
                        c + 1
                    ),
                )
            })?;
            if !v.is_finite() {
                return Err(FormatError::invalid(
                    path,
                    format!(
                        "line {n}, column {}: {t} is not a finite height (missing points are \
                         not allowed)",
                        c + 1
                    ),
                ));
            }
            values.push(v);
        }
        count += values.len() as u128;
        check_size(
            path,
            count,
            &format!("more than {max_nodes} values by line {n}"),
            max_nodes,
        )?;
        rows.push((n, values));
    }
    Ok(rows)
}

/// Sorted distinct values and the mean step; checks equal spacing.
fn axis(path: &Path, name: &str, mut v: Vec<f64>) -> Result<(Vec<f64>, f64), FormatError> {
    v.sort_by(f64::total_cmp);
    v.dedup();
    if v.len() < 2 {
        return Err(FormatError::invalid(
            path,
            format!(
                "the {name} column has {} distinct value(s); a surface needs ≥ 2",
                v.len()
            ),
        ));
    }
    let step = (v[v.len() - 1] - v[0]) / (v.len() - 1) as f64;
    for w in v.windows(2) {
        let d = w[1] - w[0];
        if (d - step).abs() > SPACING_TOLERANCE * step {
            return Err(FormatError::invalid(
                path,
                format!(
                    "non-uniform {name} spacing: step {d} between {name} = {} and {} differs \
                     from the mean step {step}; allowed: a regular grid",
                    w[0], w[1]
                ),
            ));
        }
    }
    Ok((v, step))
}

fn columns(
    path: &Path,
    rows: &[(usize, Vec<f64>)],
    cell: Option<(f64, f64)>,
) -> Result<(Array2<f64>, (f64, f64)), FormatError> {
    if let Some((line, r)) = rows.iter().find(|(_, r)| r.len() != 3) {
        return Err(FormatError::invalid(
            path,
            format!(
                "line {line} has {} values; x y z columns need exactly 3",
                r.len()
            ),
        ));
    }
    let (xs, dx) = axis(path, "x", rows.iter().map(|r| r.1[0]).collect())?;
    let (ys, dy) = axis(path, "y", rows.iter().map(|r| r.1[1]).collect())?;
    let (nx, ny) = (xs.len(), ys.len());
    if rows.len() != nx * ny {
        return Err(FormatError::invalid(
            path,
            format!(
                "{} points for a grid of {nx} × {ny} distinct x, y values: every grid point \
                 must occur exactly once",
                rows.len()
            ),
        ));
    }
    let mut h = Array2::from_elem((nx, ny), f64::NAN);
    for (line, r) in rows {
        let i = ((r[0] - xs[0]) / dx).round() as usize;
        let j = ((r[1] - ys[0]) / dy).round() as usize;
        if !h[[i, j]].is_nan() {
            return Err(FormatError::invalid(
                path,
                format!(
                    "line {line}: point (x, y) = ({}, {}) occurs twice",
                    r[0], r[1]
                ),
            ));
        }
        h[[i, j]] = r[2];
    }
    let grid_cell = (nx as f64 * dx, ny as f64 * dy);
    if let Some((lx, ly)) = cell {
        let off = |a: f64, b: f64| (a - b).abs() > 1e-9 * b;
        if off(lx, grid_cell.0) || off(ly, grid_cell.1) {
            return Err(FormatError::invalid(
                path,
                format!(
                    "the given cell {lx} × {ly} disagrees with the grid of the x y columns, \
                     {} × {} (nx dx × ny dy)",
                    grid_cell.0, grid_cell.1
                ),
            ));
        }
    }
    Ok((h, grid_cell))
}
