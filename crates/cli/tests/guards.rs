//! The command line's guards (issue 18, items 3, 6, 7, 9 and 14), through the real binary: output
//! paths that are not regular files, outputs equal to inputs, missing folders, thread counts,
//! tolerances and loads outside their physical range, a closed stdout, interruption, and the
//! small messages. Each test is named after the defect it guards against.

mod common;

use ndarray::Array2;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use store::ArtefactWriter;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_saddleflow"))
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("the binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A failed run with a clear message (no panic) whose stderr contains every one of `words`.
fn fails_with(o: &Output, words: &[&str]) {
    let e = stderr(o);
    assert!(!o.status.success(), "should fail; stderr:\n{e}");
    assert_eq!(o.status.code(), Some(1), "a clear error, not a panic:\n{e}");
    assert!(!e.contains("panicked"), "{e}");
    for w in words {
        assert!(e.contains(w), "stderr lacks {w:?}:\n{e}");
    }
}

/// A small hard-wall solve (2^3 × 2^3 nodes) writing to `out`.
fn solve_to(out: &Path) -> Output {
    bin()
        .args(["solve", "--lattice", "square", "--n", "3"])
        .args(["--pressure", "0.3", "--relative", "--out"])
        .arg(out)
        .output()
        .unwrap()
}

/// Names of our temporary files (`.NAME.tmp-PID-N`) in `dir`.
fn temps_in(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect()
}

/// A gap file: a uniform gap `g` on a 16 × 16 unit cell, with one closed node.
fn gap_file(dir: &Path, name: &str, g: f64) -> PathBuf {
    let mut gap = Array2::from_elem((16, 16), g);
    gap[[3, 4]] = 0.0;
    let path = dir.join(name);
    let mut w = ArtefactWriter::create(&path).unwrap();
    w.set_cell(1.0, 1.0).unwrap();
    w.write_f64_2d("gap", gap.view()).unwrap();
    w.publish().unwrap()
}

fn mkfifo(p: &Path) -> bool {
    Command::new("mkfifo")
        .arg(p)
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
fn refuses_symlink_as_out() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("precious.txt");
    std::fs::write(&target, "keep me").unwrap();
    let link = dir.path().join("out.h5");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    fails_with(&solve_to(&link), &["--out", "symbolic link"]);
    assert!(link.symlink_metadata().unwrap().file_type().is_symlink());
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep me");
    assert!(temps_in(dir.path()).is_empty());
}

#[test]
fn refuses_device_as_out() {
    let dir = tempfile::tempdir().unwrap();
    // our own device node (as /dev/null: char 1:3) where mknod is allowed, so that a regression
    // cannot replace a real device; /dev/null itself is checked too, before any work is done
    let dev = dir.path().join("null");
    let own = Command::new("mknod")
        .arg(&dev)
        .args(["c", "1", "3"])
        .status()
        .is_ok_and(|s| s.success());
    if own {
        fails_with(&solve_to(&dev), &["--out", "device"]);
        use std::os::unix::fs::FileTypeExt;
        assert!(dev.metadata().unwrap().file_type().is_char_device());
        assert!(temps_in(dir.path()).is_empty());
    }
    fails_with(&solve_to(Path::new("/dev/null")), &["--out", "device"]);
}

#[test]
fn refuses_fifo_as_out() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.h5");
    if !mkfifo(&fifo) {
        eprintln!("mkfifo unavailable: skipped");
        return;
    }
    fails_with(&solve_to(&fifo), &["--out", "FIFO"]);
    use std::os::unix::fs::FileTypeExt;
    assert!(fifo.metadata().unwrap().file_type().is_fifo());
}

#[test]
fn refuses_directory_as_out_and_leaves_no_temp() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("results.h5");
    std::fs::create_dir(&sub).unwrap();
    fails_with(&solve_to(&sub), &["--out", "directory"]);
    assert!(sub.is_dir());
    assert!(
        temps_in(dir.path()).is_empty(),
        "{:?}",
        temps_in(dir.path())
    );
}

#[test]
fn refuses_missing_folder_for_out() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("no/such/dir/x.h5");
    fails_with(&solve_to(&out), &["--out", "no/such/dir", "does not exist"]);
    assert!(!dir.path().join("no").exists(), "no folder may be created");
}

#[test]
fn refuses_input_as_fields() {
    let dir = tempfile::tempdir().unwrap();
    let f = gap_file(dir.path(), "f.h5", 0.3);
    let before = std::fs::read(&f).unwrap();
    // the same path, and the same file reached through a symbolic link to its folder
    let alias = dir.path().join("alias");
    std::os::unix::fs::symlink(dir.path(), &alias).unwrap();
    for out in [f.clone(), alias.join("f.h5")] {
        let o = bin()
            .args(["flow", "--gap"])
            .arg(&f)
            .arg("--fields")
            .arg(&out)
            .output()
            .unwrap();
        fails_with(&o, &["--fields", "same file as the input --gap"]);
    }
    assert_eq!(std::fs::read(&f).unwrap(), before, "the input is intact");
    // a distinct output works, and a regular file there is replaced
    let out = dir.path().join("fields.h5");
    std::fs::write(&out, "old").unwrap();
    let o = bin()
        .args(["flow", "--gap"])
        .arg(&f)
        .arg("--fields")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_ne!(std::fs::read(&out).unwrap(), b"old");
    assert!(temps_in(dir.path()).is_empty());
}

#[test]
fn refuses_unbounded_threads() {
    let dir = tempfile::tempdir().unwrap();
    let f = gap_file(dir.path(), "f.h5", 0.3);
    let f = f.to_str().unwrap();
    let solve = [
        "solve",
        "--lattice",
        "square",
        "--n",
        "3",
        "--pressure",
        "1",
    ];
    let flow = ["flow", "--gap", f];
    let critical = ["critical", "--lattice", "square", "--n", "3"];
    for cmd in [&solve[..], &flow[..], &critical[..]] {
        for t in ["100000", "0"] {
            let t0 = std::time::Instant::now();
            let o = bin().args(cmd).args(["--threads", t]).output().unwrap();
            fails_with(&o, &["--threads", t, "allowed 1..="]);
            // refused before any thread is spawned (was over a minute for 100000)
            assert!(t0.elapsed().as_secs_f64() < 30.0);
        }
        let o = bin().args(cmd).args(["--threads", "1"]).output().unwrap();
        assert!(o.status.success(), "{cmd:?}: {}", stderr(&o));
    }
}

#[test]
fn refuses_tolerance_above_physical_bound() {
    let o = run(&[
        "solve",
        "--lattice",
        "square",
        "--n",
        "5",
        "--pressure",
        "0.3",
        "--relative",
        "--tol",
        "2",
    ]);
    fails_with(&o, &["--tol", "tol_gap = 2.0", "1e-3"]);
    let o = run(&["critical", "--lattice", "square", "--n", "4", "--tol", "5"]);
    fails_with(&o, &["--tol 5.0", "1e-3"]);
    // at the bound itself the solve runs, converges and is near the tight answer (0.526 on this
    // grid: a violation of at most 1e-3 h0 moves only nodes whose gap is within it)
    let o = run(&[
        "solve",
        "--lattice",
        "square",
        "--n",
        "5",
        "--pressure",
        "0.3",
        "--relative",
        "--tol",
        "1e-3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["converged"], true);
    assert!(j["iterations"].as_u64().unwrap() > 0);
    assert!(j["max_violation"].as_f64().unwrap() <= 1e-3);
    let area = j["contact_area"].as_f64().unwrap();
    assert!((area - 0.5263671875).abs() < 0.02, "{area}");
}

#[test]
fn refuses_unrepresentable_pressure() {
    let base = ["solve", "--lattice", "square", "--n", "5", "--pressure"];
    // huge: names the bound and why (was "residual stagnated: the tolerance ...")
    let o = bin().args(base).arg("1e300").output().unwrap();
    fails_with(&o, &["--pressure 1e300", "|p̄| ≤", "rounding"]);
    assert!(!stderr(&o).contains("stagnated"));
    // tiny (was area 1.0 beside "numerical breakdown")
    let o = bin()
        .args(base)
        .args(["1e-300", "--relative"])
        .output()
        .unwrap();
    fails_with(&o, &["--pressure 1e-300", "p̄ ≥ 1e-60"]);
    assert!(!stderr(&o).contains("breakdown"));
    // just inside both bounds the solves converge: one node carries a tiny load; full contact
    // under a large one
    let o = bin()
        .args(base)
        .args(["1e-50", "--relative"])
        .output()
        .unwrap();
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["converged"], true, "{}", stderr(&o));
    assert_eq!(j["contact_area"].as_f64(), Some(1.0 / 1024.0));
    let o = bin().args(base).arg("1e5").output().unwrap();
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["converged"], true, "{}", stderr(&o));
    assert_eq!(j["contact_area"].as_f64(), Some(1.0));
}

/// Runs the binary with a stdout pipe whose reading end is closed before it starts (so every
/// write meets a closed pipe, whatever the timing); returns its exit status and stderr.
fn with_closed_stdout(cmd: &mut Command) -> (std::process::ExitStatus, String) {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = cmd
        .stdout(writer)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
        .wait_with_output()
        .unwrap();
    (
        out.status,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn closed_stdout_ends_quietly() {
    use std::os::unix::process::ExitStatusExt;
    // a direct command: one JSON line after the solve
    let (status, err) = with_closed_stdout(bin().args([
        "solve",
        "--lattice",
        "square",
        "--n",
        "4",
        "--pressure",
        "0.3",
        "--relative",
    ]));
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe"),
        "{err}"
    );
    assert_eq!(
        status.signal(),
        Some(13),
        "ended by SIGPIPE, as Unix filters do: {status:?}"
    );
    // a pipeline command: the plan of the smoke preset
    let dir = common::project();
    let (status, err) = with_closed_stdout(bin().args(["run", "-C"]).arg(dir.path()).args([
        "--params",
        "params/smoke.toml",
        "--dry-run",
    ]));
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe"),
        "{err}"
    );
    assert_ne!(status.code(), Some(101), "{status:?}: {err}");
}

#[test]
fn interrupted_solve_says_interrupted() {
    use std::os::unix::process::ExitStatusExt;
    // a search that runs for many seconds on this grid (interrupted at once)
    let child = bin()
        .args([
            "critical",
            "--lattice",
            "square",
            "--n",
            "10",
            "--threads",
            "1",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // the handler is installed before the watcher thread starts: wait for a second thread
    // (Linux /proc; elsewhere half a second), so that the signal cannot beat the handler
    let tasks = format!("/proc/{}/task", child.id());
    let t0 = std::time::Instant::now();
    while t0.elapsed().as_secs_f64() < 10.0 {
        match std::fs::read_dir(&tasks).map(|rd| rd.count()) {
            Ok(n) if n >= 2 => break,
            Ok(_) => std::thread::sleep(std::time::Duration::from_millis(10)),
            Err(_) => {
                std::thread::sleep(std::time::Duration::from_millis(500));
                break;
            }
        }
    }
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("interrupted (SIGINT)"), "{err}");
    assert_eq!(
        out.status.signal(),
        Some(2),
        "ends by the signal: {:?}",
        out.status
    );
}

#[test]
fn hard_wall_warns_that_interaction_parameters_are_ignored() {
    let o = run(&[
        "solve",
        "--lattice",
        "square",
        "--n",
        "3",
        "--pressure",
        "0.3",
        "--relative",
        "--gamma0",
        "0.5",
        "--rho",
        "0.1",
    ]);
    assert!(o.status.success());
    let e = stderr(&o);
    assert!(e.contains("--gamma0 and --rho ignored"), "{e}");
    // no warning when they are not given, nor when they are used
    let o = run(&[
        "solve",
        "--lattice",
        "square",
        "--n",
        "3",
        "--pressure",
        "0.3",
        "--relative",
    ]);
    assert!(!stderr(&o).contains("ignored"));
}

#[test]
fn flow_states_gap_underflow() {
    let dir = tempfile::tempdir().unwrap();
    // every open gap 3e-201: g³ = 0 in doubles (was reported as `percolating: false`)
    let f = gap_file(dir.path(), "tiny.h5", 3e-201);
    let o = bin().args(["flow", "--gap"]).arg(&f).output().unwrap();
    fails_with(&o, &["underflow", "rescale"]);
    // a largest gap whose conductivity is normal but whose square is not (NaN residual before)
    let f = gap_file(dir.path(), "small.h5", 3e-61);
    let o = bin().args(["flow", "--gap"]).arg(&f).output().unwrap();
    fails_with(&o, &["underflow", "allowed: a largest gap in"]);
    // and overflow
    for g in [3e59, 1e200] {
        let f = gap_file(dir.path(), "huge.h5", g);
        let o = bin().args(["flow", "--gap"]).arg(&f).output().unwrap();
        fails_with(&o, &["overflow"]);
    }
    // within range a uniform gap g gives K = g³ (one closed node lowers it slightly)
    let f = gap_file(dir.path(), "ok.h5", 1e-20);
    let o = bin().args(["flow", "--gap"]).arg(&f).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["underflow_nodes"], 0);
    let k = j["conductivity"].as_f64().unwrap();
    assert!(k > 0.9e-60 && k < 1e-60, "{k}");
}

#[test]
fn critical_echoes_the_rel_width_reached() {
    let o = run(&[
        "critical",
        "--lattice",
        "square",
        "--n",
        "4",
        "--saddle-loads",
        "none",
        "--rel-width",
        "1e-30",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["rel_width"].as_f64(), Some(1e-30));
    let reached = j["rel_width_reached"].as_f64().unwrap();
    // a bracket of doubles is at least one spacing wide: ε/2 to ε relative
    assert!((f64::EPSILON / 2.0..1e-14).contains(&reached), "{reached}");
    assert!(stderr(&o).contains("not reached"), "{}", stderr(&o));
}
