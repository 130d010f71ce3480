//! Round trips and refusals on small files in a temporary directory.

use formats::{Detrend, FormatError, ReadOptions, TextLayout, h5, npy, read};
use ndarray::{Array1, Array2, ShapeBuilder};
use ndarray_npy::WriteNpyExt;
use std::fs::File;
use std::path::{Path, PathBuf};
use surface::{Grid, HeightField, Lattice, Surface};

fn with_cell(lx: f64, ly: f64) -> ReadOptions {
    ReadOptions {
        cell: Some((lx, ly)),
        ..ReadOptions::default()
    }
}

fn error(path: &Path, options: &ReadOptions) -> String {
    let e: FormatError = read(path, options).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains(&path.display().to_string()),
        "the error must name the file: {msg}"
    );
    msg
}

fn write_npy<T: ndarray_npy::WritableElement, D: ndarray::Dimension>(
    path: &PathBuf,
    a: &ndarray::Array<T, D>,
) {
    a.write_npy(File::create(path).unwrap()).unwrap();
}

#[test]
fn lattices_round_trip_bit_for_bit_through_npy_and_hdf5() {
    let dir = tempfile::tempdir().unwrap();
    for l in Lattice::ALL {
        let f = HeightField::from(&Surface::new(l, 4).unwrap());
        let (lx, ly) = l.cell();
        let p = dir.path().join(format!("{l}.npy"));
        npy::write(&p, &f).unwrap();
        let r = read(&p, &with_cell(lx, ly)).unwrap();
        assert_eq!(r.field, f);
        assert!(r.removed.is_none());
        let p = dir.path().join(format!("{l}.h5"));
        h5::write(&p, &f).unwrap();
        let r = read(&p, &ReadOptions::default()).unwrap();
        assert_eq!(r.field, f, "{l}: the cell comes from the attributes");
    }
}

#[test]
fn npy_float32_and_fortran_order_are_read_in_logical_order() {
    let dir = tempfile::tempdir().unwrap();
    let logical = |i: usize, j: usize| (10 * i + j) as f64 * 0.5;
    let fortran = Array2::from_shape_fn((4, 6).f(), |(i, j)| logical(i, j));
    let p = dir.path().join("f.npy");
    write_npy(&p, &fortran);
    let single = Array2::from_shape_fn((4, 6), |(i, j)| logical(i, j) as f32);
    let q = dir.path().join("s.npy");
    write_npy(&q, &single);
    for path in [p, q] {
        let h = read(&path, &with_cell(1.0, 1.5)).unwrap().field.heights;
        assert_eq!(h, Array2::from_shape_fn((4, 6), |(i, j)| logical(i, j)));
    }
}

#[test]
fn bad_npy_files_are_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("profile.npy");
    write_npy(&p, &Array1::<f64>::zeros(16));
    assert!(error(&p, &with_cell(1.0, 1.0)).contains("1 dimension"));
    let p = dir.path().join("int.npy");
    write_npy(&p, &Array2::<i32>::zeros((4, 4)));
    assert!(error(&p, &with_cell(1.0, 1.0)).contains("element type"));
    let p = dir.path().join("hole.npy");
    let mut h = Array2::<f64>::zeros((4, 4));
    h[[2, 3]] = f64::NAN;
    write_npy(&p, &h);
    let msg = error(&p, &with_cell(1.0, 1.0));
    assert!(msg.contains("(2, 3)") && msg.contains("missing"), "{msg}");
    let p = dir.path().join("ok.npy");
    write_npy(&p, &Array2::<f64>::zeros((4, 4)));
    assert!(error(&p, &ReadOptions::default()).contains("cell size"));
    let p = dir.path().join("empty.npy");
    write_npy(&p, &Array2::<f64>::zeros((0, 4)));
    assert!(error(&p, &with_cell(1.0, 1.0)).contains("shape (0, 4)"));
}

#[test]
fn fields_above_the_limit_are_refused_with_their_memory_cost() {
    let dir = tempfile::tempdir().unwrap();
    let f = HeightField::new(
        Grid::periodic(64, 64, 1.0, 1.0).unwrap(),
        Array2::zeros((64, 64)),
    )
    .unwrap();
    let small = ReadOptions {
        cell: Some((1.0, 1.0)),
        max_nodes: 1000,
        ..ReadOptions::default()
    };
    for name in ["big.npy", "big.h5"] {
        let p = dir.path().join(name);
        if name.ends_with("npy") {
            npy::write(&p, &f).unwrap();
        } else {
            h5::write(&p, &f).unwrap();
        }
        let msg = error(&p, &small);
        assert!(msg.contains("4096 nodes") && msg.contains("GiB"), "{msg}");
    }
    let p = dir.path().join("big.txt");
    let line = vec!["0.5"; 64].join(" ");
    std::fs::write(&p, vec![line; 64].join("\n")).unwrap();
    let msg = error(&p, &small);
    assert!(msg.contains("more than 1000 values by line 16"), "{msg}");
}

#[test]
fn hdf5_needs_height_and_cell() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nocell.h5");
    {
        let f = hdf5::File::create(&p).unwrap();
        f.new_dataset_builder()
            .with_data(&Array2::<f32>::from_elem((4, 4), 0.25))
            .create("height")
            .unwrap();
    }
    assert!(error(&p, &ReadOptions::default()).contains("`lx` is missing"));
    // The cell given explicitly replaces the attributes; f32 data is converted.
    let r = read(&p, &with_cell(2.0, 2.0)).unwrap();
    assert!(r.field.heights.iter().all(|&v| v == 0.25));
    let p = dir.path().join("other.h5");
    {
        let f = hdf5::File::create(&p).unwrap();
        f.new_dataset_builder()
            .with_data(&Array1::<f64>::zeros(8))
            .create("gap")
            .unwrap();
    }
    let msg = error(&p, &ReadOptions::default());
    assert!(
        msg.contains("no dataset `/height`") && msg.contains("gap"),
        "{msg}"
    );
}

#[test]
fn text_matrices_and_columns() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("m.txt");
    std::fs::write(&p, "# heights in µm\n1 2 3\n4 5 6  # last\n\n").unwrap();
    let opt = ReadOptions {
        cell: Some((2.0, 3.0)),
        height_scale: 1e-3,
        ..ReadOptions::default()
    };
    let r = read(&p, &opt).unwrap();
    let want = Array2::from_shape_fn((2, 3), |(i, j)| (3 * i + j + 1) as f64 * 1e-3);
    assert!(
        r.field
            .heights
            .iter()
            .zip(&want)
            .all(|(a, b)| (a - b).abs() < 1e-18)
    );
    // x y z columns in any order; the cell is nx dx × ny dy.
    let p = dir.path().join("xyz.csv");
    let mut text = String::new();
    for &(i, j) in &[(1, 2), (0, 0), (1, 0), (0, 2), (0, 1), (1, 1)] {
        text += &format!("{}, {}, {}\n", 0.5 * i as f64, 0.25 * j as f64, 10 * i + j);
    }
    std::fs::write(&p, &text).unwrap();
    let cols = ReadOptions {
        text_layout: TextLayout::Columns,
        ..ReadOptions::default()
    };
    let r = read(&p, &cols).unwrap();
    assert_eq!((r.field.grid.lx, r.field.grid.ly), (1.0, 0.75));
    assert_eq!(
        r.field.heights,
        Array2::from_shape_fn((2, 3), |(i, j)| (10 * i + j) as f64)
    );
    let detrended = ReadOptions {
        detrend: Detrend::Mean,
        ..cols.clone()
    };
    let r = read(&p, &detrended).unwrap();
    assert_eq!(r.removed.unwrap().offset, 6.0);
}

#[test]
fn bad_text_files_are_refused_with_line_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let case = |name: &str, text: &str, layout: TextLayout| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        let opt = ReadOptions {
            cell: Some((1.0, 1.0)),
            text_layout: layout,
            ..ReadOptions::default()
        };
        error(&p, &opt)
    };
    let m = TextLayout::Matrix;
    let c = TextLayout::Columns;
    assert!(case("missing.csv", "1,2,3\n4,,6\n", m).contains("line 2, column 2"));
    assert!(case("nan.txt", "1 2\nnan 4\n", m).contains("line 2, column 1"));
    assert!(case("ragged.txt", "1 2 3\n4 5\n", m).contains("line 2 has 2 values"));
    assert!(case("empty.txt", "# nothing\n\n", m).contains("empty"));
    assert!(case("row.txt", "1 2 3 4\n", m).contains("1-D"));
    let uneven = "0 0 1\n0 1 1\n1 0 1\n1 1 1\n3 0 1\n3 1 1\n";
    assert!(case("uneven.xyz", uneven, c).contains("non-uniform x spacing"));
    let holey = "0 0 1\n0 1 1\n1 0 1\n";
    assert!(case("holey.xyz", holey, c).contains("exactly once"));
    let twice = "0 0 1\n0 1 1\n1 0 1\n0 0 2\n";
    assert!(case("twice.xyz", twice, c).contains("occurs twice"));
}

/// Detrend modes parse from their names (as the topography kind and `--detrend` spell them);
/// anything else names the value and the allowed ones.
#[test]
fn detrend_names_parse_and_others_are_refused() {
    for (d, name) in Detrend::ALL {
        assert_eq!(name.parse::<Detrend>(), Ok(d));
    }
    assert_eq!(
        "planar".parse::<Detrend>(),
        Err("\"planar\": allowed none, mean, plane".to_string())
    );
}
