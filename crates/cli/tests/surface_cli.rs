//! Your own surface in, leakage out: `surface generate | stats`, `solve --surface`,
//! `leakage`, `critical --surface` (issue 14). Small grids, seconds.

use ndarray::Array2;
use serde_json::Value;
use std::path::{Path, PathBuf};
use surface::{HeightField, Lattice, Surface};

mod common;

use common::run;

fn ok(args: &[&str]) -> Value {
    let (success, v, err) = run(args);
    assert!(success, "saddleflow {args:?} failed:\n{err}");
    v
}

fn fails(args: &[&str]) -> String {
    let (success, _, err) = run(args);
    assert!(!success, "saddleflow {args:?} should fail");
    err
}

/// `surface generate --out <out>` with `opts` over the tests' defaults; its JSON summary.
fn generate(out: &Path, opts: &[(&str, &str)]) -> Value {
    let (success, v, err) = common::generate(out, opts);
    assert!(success, "surface generate {opts:?} failed:\n{err}");
    v
}

/// `surface generate` that must fail; its stderr.
fn generate_fails(out: &Path, opts: &[(&str, &str)]) -> String {
    let (success, _, err) = common::generate(out, opts);
    assert!(!success, "surface generate {opts:?} should fail");
    err
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn num(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing in {v}"))
}

fn pressure_field(path: &Path) -> Array2<f64> {
    let f = hdf5::File::open(path).unwrap();
    f.dataset("pressure").unwrap().read_2d::<f64>().unwrap()
}

/// The three lattices written to .npy and HDF5 and read back through `--surface` give the same
/// contact area and pressure field as `--lattice` (periodic kernel). The heights go through both
/// formats bit for bit and the model is built from the same grid, so the solves are the same
/// computation: 1e-12 leaves room only for rounding, none for a different problem.
#[test]
fn lattices_through_files_equal_the_lattice_path() {
    let dir = tempfile::tempdir().unwrap();
    for lattice in Lattice::ALL {
        let n = 5;
        let surf = Surface::new(lattice, n).unwrap();
        let field = HeightField::from(&surf);
        let load = format!("{:?}", 0.3 * surf.p_fc_grid());
        let (lx, ly) = (format!("{:?}", surf.grid.lx), format!("{:?}", surf.grid.ly));
        let name = lattice.name();
        let npy = dir.path().join(format!("{name}.npy"));
        let h5 = dir.path().join(format!("{name}.h5"));
        formats::npy::write(&npy, &field).unwrap();
        formats::h5::write(&h5, &field).unwrap();
        let out_l = dir.path().join(format!("{name}-lattice.h5"));
        let want = ok(&[
            "solve",
            "--lattice",
            name,
            "--n",
            "5",
            "--pressure",
            &load,
            "--threads",
            "1",
            "--out",
            s(&out_l),
        ]);
        let p_want = pressure_field(&out_l);
        for (file, extra) in [
            (&npy, vec!["--lx", lx.as_str(), "--ly", ly.as_str()]),
            (&h5, vec![]),
        ] {
            let out_s = dir.path().join(format!("{name}-surface.h5"));
            let mut args = vec![
                "solve",
                "--surface",
                s(file),
                "--pressure",
                &load,
                "--threads",
                "1",
                "--out",
                s(&out_s),
            ];
            args.extend(extra);
            let got = ok(&args);
            assert!(
                (num(&got, "contact_area") - num(&want, "contact_area")).abs() <= 1e-12,
                "{name} {}: {got} vs {want}",
                file.display()
            );
            assert_eq!(got["converged"], true);
            let p_got = pressure_field(&out_s);
            let worst = p_got
                .iter()
                .zip(&p_want)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(
                worst <= 1e-12,
                "{name} {}: pressure differs by {worst}",
                file.display()
            );
            // the file path reports the same p_fc (−min K h) as the closed form, to rounding
            assert!((num(&got, "p_fc") - num(&want, "p_fc")).abs() < 1e-12 * num(&want, "p_fc"));
        }
    }
}

/// generate → stats: the statistics printed at generation are those of the file read back, in
/// every format (text is written with round-tripping `{:e}` numbers).
#[test]
fn generate_then_stats_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let keys = [
        "rms_height",
        "rms_slope",
        "rms_curvature",
        "nayak",
        "skewness",
        "excess_kurtosis",
        "min",
        "max",
    ];
    for ext in ["h5", "npy", "txt"] {
        let out = dir.path().join(format!("s.{ext}"));
        let g = generate(
            &out,
            &[("--rms-height", "0.5"), ("--seed", "11"), ("--length", "2")],
        );
        // the requested rms to rounding, and the PSD slope near −2(1 + H) (±0.05 is the issue's
        // target on larger grids; exact amplitudes follow the power law mode by mode)
        assert!((num(&g, "rms_height") - 0.5).abs() < 1e-12);
        assert!((num(&g, "psd_slope") + 3.6).abs() < 0.1, "{g}");
        let mut args = vec!["surface", "stats", s(&out)];
        if ext != "h5" {
            args.extend(["--lx", "2", "--ly", "2"]);
        }
        let st = ok(&args);
        for k in keys {
            let (a, b) = (num(&g, k), num(&st, k));
            assert!(
                (a - b).abs() <= 1e-12 * a.abs().max(1.0),
                "{ext} {k}: {a} vs {b}"
            );
        }
        assert_eq!(num(&st, "lx"), 2.0);
    }
    // same seed, same surface; another seed, another surface
    let a = dir.path().join("a.npy");
    let b = dir.path().join("b.npy");
    for (p, seed) in [(&a, "11"), (&b, "12")] {
        generate(
            p,
            &[("--rms-height", "0.5"), ("--seed", seed), ("--length", "2")],
        );
    }
    let first = std::fs::read(dir.path().join("s.npy")).unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), first);
    assert_ne!(std::fs::read(&b).unwrap(), first);
}

fn write_npy(path: &Path, a: &ndarray::ArrayD<f64>) {
    use ndarray_npy::WriteNpyExt;
    a.write_npy(std::fs::File::create(path).unwrap()).unwrap();
}

/// Bad inputs give clear errors naming the file and what is wrong, before any solve.
#[test]
fn bad_surfaces_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let check = |file: &PathBuf, extra: &[&str], want: &[&str]| {
        for cmd in [
            vec!["surface", "stats", s(file)],
            vec!["solve", "--surface", s(file), "--pressure", "0.1"],
            vec!["leakage", "--surface", s(file), "--loads", "0.1"],
            vec!["critical", "--surface", s(file)],
        ] {
            let mut args = cmd.clone();
            args.extend_from_slice(extra);
            let err = fails(&args);
            assert!(
                err.contains(s(file)),
                "{args:?}: the file is not named:\n{err}"
            );
            for w in want {
                assert!(err.contains(w), "{args:?}: `{w}` missing:\n{err}");
            }
        }
    };
    let cell = ["--lx", "1", "--ly", "1"];
    // NaN at a node
    let mut h = Array2::<f64>::zeros((8, 8));
    h[[2, 3]] = f64::NAN;
    let nan = d.join("nan.npy");
    write_npy(&nan, &h.into_dyn());
    check(&nan, &cell, &["NaN", "(2, 3)"]);
    // 1-D
    let one = d.join("one.npy");
    write_npy(&one, &ndarray::Array1::<f64>::zeros(16).into_dyn());
    check(&one, &cell, &["1 dimension", "2-D"]);
    // empty text
    let empty = d.join("empty.txt");
    std::fs::write(&empty, "# nothing here\n").unwrap();
    check(&empty, &cell, &["empty"]);
    // non-uniform x y z columns
    let xyz = d.join("xyz.txt");
    let mut t = String::new();
    for x in [0.0, 0.1, 0.3, 0.4] {
        for y in [0.0, 0.25, 0.5, 0.75] {
            t.push_str(&format!("{x} {y} 0.0\n"));
        }
    }
    std::fs::write(&xyz, t).unwrap();
    check(&xyz, &["--columns"], &["spac"]);
    // missing cell size for .npy
    let fine = d.join("fine.npy");
    write_npy(&fine, &Array2::<f64>::zeros((8, 8)).into_dyn());
    check(&fine, &[], &["cell size"]);
    // too large for --max-nodes: refused from the header with the memory it would need
    check(
        &fine,
        &["--lx", "1", "--ly", "1", "--max-nodes", "10"],
        &["GiB", "64 nodes"],
    );
    // a grid beyond the largest: refused with its memory cost before anything is allocated
    let err = generate_fails(&d.join("big.h5"), &[("--n", "14"), ("--qs", "64")]);
    assert!(err.contains("--n 14") && err.contains("GiB"), "{err}");
    // a parameter out of range names the option
    let err = generate_fails(&d.join("h.h5"), &[("--hurst", "1.5")]);
    assert!(err.contains("--hurst") && err.contains("1.5"), "{err}");
    assert!(!d.join("h.h5").exists() && !d.join("big.h5").exists());
}

/// Leakage vs load and the percolation load on a small random surface, periodic and free: the
/// path is monotone, the CSV has one row per load, and the threshold from `critical --surface`
/// lies between the path's last percolating and first sealed loads.
#[test]
fn leakage_and_critical_on_a_random_surface() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("r.h5");
    generate(&f, &[("--seed", "5")]);
    for boundary in ["periodic", "free"] {
        let crit = ok(&[
            "critical",
            "--surface",
            s(&f),
            "--boundary",
            boundary,
            "--rel-width",
            "1e-6",
            "--threads",
            "1",
        ]);
        let (l_c, p_fc) = (num(&crit, "l_c"), num(&crit, "p_fc"));
        let a_p = num(&crit, "a_p_raw");
        assert!(a_p > 0.05 && a_p < 0.95, "{crit}");
        let loads: Vec<String> = [0.5, 0.9, 1.1, 2.0]
            .iter()
            .map(|k| format!("{:?}", k * l_c / p_fc))
            .collect();
        let csv = dir.path().join(format!("{boundary}.csv"));
        let v = ok(&[
            "leakage",
            "--surface",
            s(&f),
            "--boundary",
            boundary,
            "--relative",
            "--loads",
            &loads.join(","),
            "--csv",
            s(&csv),
            "--threads",
            "1",
        ]);
        let pts = v["points"].as_array().unwrap();
        assert_eq!(pts.len(), 4);
        for w in pts.windows(2) {
            assert!(num(&w[1], "contact_area") >= num(&w[0], "contact_area"));
            assert!(num(&w[1], "mean_gap") < num(&w[0], "mean_gap"));
            let q = |p: &Value| num(p, "flux_x") + num(p, "flux_y");
            assert!(q(&w[1]) <= q(&w[0]) * (1.0 + 1e-9), "{boundary}: {v}");
        }
        let open = |p: &Value| p["fluid_percolates_x"] == true || p["fluid_percolates_y"] == true;
        assert!(open(&pts[0]) && open(&pts[1]), "{boundary}: {v}");
        assert!(!open(&pts[2]) && !open(&pts[3]), "{boundary}: {v}");
        assert_eq!(num(&pts[3], "flux_x") + num(&pts[3], "flux_y"), 0.0);
        let text = std::fs::read_to_string(&csv).unwrap();
        assert_eq!(text.lines().count(), 5, "{text}");
        assert!(text.starts_with("load,load_over_p_fc,contact_area"));
    }
    // the free boundary works for solve, the hard wall only
    let v = ok(&[
        "solve",
        "--surface",
        s(&f),
        "--boundary",
        "free",
        "--pressure",
        "0.1",
        "--relative",
    ]);
    assert_eq!(v["converged"], true);
    assert_eq!(v["boundary"], "free");
    let err = fails(&[
        "solve",
        "--surface",
        s(&f),
        "--boundary",
        "free",
        "--pressure",
        "0.1",
        "--interaction",
        "adhesion",
    ]);
    assert!(err.contains("hard wall"), "{err}");
    // adhesion on a surface file, periodic
    let v = ok(&[
        "solve",
        "--surface",
        s(&f),
        "--pressure",
        "0.05",
        "--relative",
        "--interaction",
        "adhesion",
        "--gamma0",
        "0.01",
        "--rho",
        "0.05",
    ]);
    assert_eq!(v["interaction"], "adhesion");
}
