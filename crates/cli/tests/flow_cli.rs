//! `saddleflow flow`: exact cases, foreign HDF5 files, specific errors, and the round trip from
//! `saddleflow solve --out`.

use ndarray::Array2;
use serde_json::Value;
use std::path::{Path, PathBuf};
use store::{ArtefactReader, ArtefactWriter};

mod common;

use common::run;

fn flow(file: &Path, extra: &[&str]) -> (bool, Value, String) {
    let mut args = vec!["flow", "--gap", file.to_str().unwrap()];
    args.extend_from_slice(extra);
    run(&args)
}

/// A gap file written by the store crate (a saddleflow artefact).
fn ours(dir: &Path, name: &str, gap: &Array2<f64>, lx: f64, ly: f64) -> PathBuf {
    let path = dir.join(name);
    let mut w = ArtefactWriter::create(&path).unwrap();
    w.set_cell(lx, ly).unwrap();
    w.write_f64_2d("gap", gap.view()).unwrap();
    w.publish().unwrap()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn uniform_gap_gives_g_cubed_on_either_axis() {
    let dir = tempfile::tempdir().unwrap();
    let g = 0.3;
    let f = ours(
        dir.path(),
        "u.h5",
        &Array2::from_elem((32, 16), g),
        2.0,
        1.0,
    );
    for axis in ["x", "y"] {
        let (ok, j, err) = flow(&f, &["--axis", axis]);
        assert!(ok, "{err}");
        assert!(
            rel(j["conductivity"].as_f64().unwrap(), g * g * g) < 1e-12,
            "{j}"
        );
        // flux = K ΔP L_cross / L_flow with ΔP = 1
        let (lf, lc) = if axis == "x" { (2.0, 1.0) } else { (1.0, 2.0) };
        assert!(rel(j["flux"].as_f64().unwrap(), g * g * g * lc / lf) < 1e-12);
        assert_eq!(j["percolating"], true);
        assert_eq!(j["converged"], true);
        assert_eq!(j["termination"], "converged");
        assert_eq!(j["axis"], axis);
        assert_eq!((j["nx"].as_u64(), j["ny"].as_u64()), (Some(32), Some(16)));
        assert_eq!((j["lx"].as_f64(), j["ly"].as_f64()), (Some(2.0), Some(1.0)));
        for k in [
            "iterations",
            "residual",
            "conservation_error",
            "wall_s",
            "contact_fraction",
        ] {
            assert!(j[k].is_number(), "{k} missing in {j}");
        }
        assert!(j["residual"].as_f64().unwrap() <= 1e-10);
    }
}

#[test]
fn blocked_field_has_zero_flux_and_does_not_percolate() {
    let dir = tempfile::tempdir().unwrap();
    // a contact line across x at i = 5 blocks flow along x but not along y
    let gap = Array2::from_shape_fn((16, 16), |(i, _)| if i == 5 { 0.0 } else { 0.5 });
    let f = ours(dir.path(), "b.h5", &gap, 1.0, 1.0);
    let (ok, j, err) = flow(&f, &["--axis", "x"]);
    assert!(ok, "{err}");
    assert_eq!(j["flux"].as_f64(), Some(0.0));
    assert_eq!(j["conductivity"].as_f64(), Some(0.0));
    assert_eq!(j["percolating"], false);
    assert_eq!(j["converged"], true);
    assert_eq!(j["termination"], "not_percolating");
    let (ok, j, _) = flow(&f, &["--axis", "y"]);
    assert!(ok);
    assert_eq!(j["percolating"], true);
    // across the flow the channels add in parallel: K = ⟨g³⟩
    assert!(rel(j["conductivity"].as_f64().unwrap(), 0.125 * 15.0 / 16.0) < 1e-10);
    // all contact
    let f = ours(dir.path(), "c.h5", &Array2::zeros((8, 8)), 1.0, 1.0);
    let (ok, j, _) = flow(&f, &[]);
    assert!(ok);
    assert_eq!(
        (j["flux"].as_f64(), &j["percolating"]),
        (Some(0.0), &Value::Bool(false))
    );
}

#[test]
fn foreign_hdf5_file_is_accepted() {
    // written with the plain hdf5 library: f32 gap, integer lx, ly as a one-element array, no
    // provenance and no complete mark
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("foreign.h5");
    {
        let f = hdf5::File::create(&path).unwrap();
        let n = 64;
        let gap = Array2::from_shape_fn((n, n), |(i, _)| {
            (1.0 + 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos()) as f32
        });
        f.new_dataset_builder()
            .with_data(&gap)
            .create("gap")
            .unwrap();
        f.new_attr::<i32>()
            .create("lx")
            .unwrap()
            .write_scalar(&1)
            .unwrap();
        f.new_attr::<f64>()
            .shape(1)
            .create("ly")
            .unwrap()
            .write_raw(&[2.0])
            .unwrap();
        f.new_dataset_builder()
            .with_data(&[1, 2, 3])
            .create("unrelated")
            .unwrap();
    }
    assert!(!ArtefactReader::open(&path).unwrap().is_complete());
    let (ok, j, err) = flow(&path, &["--axis", "x"]);
    assert!(ok, "{err}");
    // gap varying along the flow: series, K = 1/⟨g⁻³⟩ (discrete, from the f32 values)
    let r = ArtefactReader::open(&path).unwrap();
    let g = r.read_f64_2d("gap").unwrap();
    let mean_inv: f64 = g.column(0).iter().map(|v| v.powi(-3)).sum::<f64>() / 64.0;
    // the harmonic-mean face conductance makes the discrete value differ from 1/⟨g⁻³⟩ at
    // O(dx²); 64 nodes per wavelength keep it below 1e-3
    assert!(
        rel(j["conductivity"].as_f64().unwrap(), 1.0 / mean_inv) < 1e-3,
        "{j}"
    );
    assert_eq!(j["ly"].as_f64(), Some(2.0));
}

fn expect_error(path: &Path, args: &[&str], needles: &[&str]) {
    let (ok, _, err) = flow(path, args);
    assert!(!ok, "{} should fail", path.display());
    let name = path.file_name().unwrap().to_str().unwrap();
    assert!(err.contains(name), "error names the file: {err}");
    for n in needles {
        assert!(err.contains(n), "error should contain {n:?}: {err}");
    }
}

#[test]
fn bad_files_give_specific_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let write = |name: &str, build: &dyn Fn(&hdf5::File)| {
        let p = d.join(name);
        let f = hdf5::File::create(&p).unwrap();
        build(&f);
        p
    };
    let attrs = |f: &hdf5::File, which: &[&str]| {
        for a in which {
            f.new_attr::<f64>()
                .create(*a)
                .unwrap()
                .write_scalar(&1.0)
                .unwrap();
        }
    };
    let ones = Array2::<f64>::ones((8, 8));
    let p = write("no_gap.h5", &|f| {
        f.new_dataset_builder()
            .with_data(&ones)
            .create("height")
            .unwrap();
        attrs(f, &["lx", "ly"]);
    });
    expect_error(&p, &[], &["no dataset `/gap`", "height", "2-D"]);
    let p = write("no_ly.h5", &|f| {
        f.new_dataset_builder()
            .with_data(&ones)
            .create("gap")
            .unwrap();
        attrs(f, &["lx"]);
    });
    expect_error(&p, &[], &["attribute `ly` is missing", "lx", "> 0"]);
    let p = write("rank3.h5", &|f| {
        f.new_dataset_builder()
            .with_data(&ndarray::Array3::<f64>::ones((4, 4, 4)))
            .create("gap")
            .unwrap();
        attrs(f, &["lx", "ly"]);
    });
    expect_error(&p, &[], &["`/gap` has rank 3", "allowed: rank 2"]);
    let p = write("nan.h5", &|f| {
        let mut g = ones.clone();
        g[[2, 5]] = f64::NAN;
        f.new_dataset_builder().with_data(&g).create("gap").unwrap();
        attrs(f, &["lx", "ly"]);
    });
    expect_error(&p, &[], &["`/gap`", "NaN at index (2, 5)", "≥ 0"]);
    let p = write("negative.h5", &|f| {
        let mut g = ones.clone();
        g[[1, 1]] = -0.5;
        f.new_dataset_builder().with_data(&g).create("gap").unwrap();
        attrs(f, &["lx", "ly"]);
    });
    expect_error(
        &p,
        &[],
        &["`/gap`", "-0.5 is negative at index (1, 1)", "≥ 0"],
    );
    let p = write("bad_lx.h5", &|f| {
        f.new_dataset_builder()
            .with_data(&ones)
            .create("gap")
            .unwrap();
        f.new_attr::<f64>()
            .create("lx")
            .unwrap()
            .write_scalar(&0.0)
            .unwrap();
        attrs(f, &["ly"]);
    });
    expect_error(&p, &[], &["attribute `lx` = 0", "> 0"]);
    // a named dataset that is missing
    expect_error(
        &p,
        &["--dataset", "fields/gap"],
        &["no dataset `/fields/gap`"],
    );
    // not HDF5 at all
    let p = d.join("text.h5");
    std::fs::write(&p, "not hdf5").unwrap();
    expect_error(&p, &[], &["not a readable HDF5 file"]);
}

#[test]
fn solve_out_then_flow_and_fields() {
    let dir = tempfile::tempdir().unwrap();
    let sol = dir.path().join("sq.h5");
    let (ok, s, err) = run(&[
        "solve",
        "--lattice",
        "square",
        "--n",
        "5",
        "--pressure",
        "0.3",
        "--out",
        sol.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert_eq!(s["converged"], true);
    let fields = dir.path().join("flow.h5");
    let (ok, j, err) = flow(&sol, &["--fields", fields.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert_eq!(j["percolating"], true);
    assert_eq!(j["converged"], true);
    let q = j["flux"].as_f64().unwrap();
    assert!(q > 0.0 && q < 16.0, "{j}");
    // the current density integrates to the flux through any cross-section
    let r = ArtefactReader::open_complete(&fields).unwrap();
    let jx = r.read_f64_2d("current_x").unwrap();
    let (nx, ny) = jx.dim();
    assert_eq!((nx, ny), (32, 32));
    for i in [0, 7, 16] {
        let through: f64 = jx.row(i).sum() / ny as f64; // dy = ly/ny, ly = 1
        assert!(rel(through, q) < 1e-6, "row {i}: {through} vs {q}");
    }
    assert!(r.has_dataset("pressure") && r.has_dataset("current_y") && r.has_dataset("gap"));
    assert_eq!(r.provenance().unwrap().kind, "flow");
    // serde_json parses floats to within an ulp (no `float_roundtrip` feature)
    assert!(rel(r.attr_f64("flux").unwrap(), q) < 1e-15);
}
