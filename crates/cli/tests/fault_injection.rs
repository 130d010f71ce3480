//! Fault injection on the real binary with the smoke params (seconds): random byte flips in
//! cache files, a foreign artefact under another stage's name, truncated files, an output path
//! that cannot be written, an index that cannot be saved, a killed run. Each case either
//! recomputes and ends with tables and figures byte-identical to an undisturbed run, or fails
//! naming the stage and the file; never exit 0 with a wrong or missing output (issue 18).
//!
//! A read-only folder is simulated by a folder standing where a file must be written: that
//! fails for root too (CI containers often run as root, which ignores permissions). A full disk
//! needs a size-limited mount, which needs privileges; the write error it causes takes the same
//! paths as the one injected here.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;

use common::project;

fn saddleflow(root: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_saddleflow"))
        .args(args)
        .arg("-C")
        .arg(root)
        .args(["--params", "params/smoke.toml"])
        .output()
        .expect("the binary runs")
}

fn run(root: &Path) -> Output {
    saddleflow(root, &["run", "-j", "2"])
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn ok(o: &Output) {
    assert!(o.status.success(), "run failed:\n{}", text(o));
}

/// Every table and figure: relative path → bytes.
fn outputs(root: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    for d in ["results/tables", "figures"] {
        for e in std::fs::read_dir(root.join(d)).unwrap().flatten() {
            if e.path().is_file() {
                out.insert(
                    format!("{d}/{}", e.file_name().to_string_lossy()),
                    std::fs::read(e.path()).unwrap(),
                );
            }
        }
    }
    out
}

/// `extremes.csv` records each solve's wall time (column `wall_s`), which no recomputation
/// reproduces; every other byte of it must match, so only that column is dropped.
fn without_wall_times(name: &str, bytes: &[u8]) -> Vec<u8> {
    if !name.ends_with("extremes.csv") {
        return bytes.to_vec();
    }
    let text = String::from_utf8_lossy(bytes);
    let header: Vec<&str> = text.lines().next().unwrap_or("").split(',').collect();
    let Some(col) = header.iter().position(|h| *h == "wall_s") else {
        return bytes.to_vec();
    };
    text.lines()
        .map(|l| {
            // the columns up to `wall_s` hold no commas (the last one, quoted, may)
            let mut cells: Vec<&str> = l.splitn(col + 2, ',').collect();
            if cells.len() > col {
                cells.remove(col);
            }
            cells.join(",") + "\n"
        })
        .collect::<String>()
        .into_bytes()
}

fn same_outputs(root: &Path, want: &BTreeMap<String, Vec<u8>>, case: &str) {
    let got = outputs(root);
    assert_eq!(
        got.keys().collect::<Vec<_>>(),
        want.keys().collect::<Vec<_>>(),
        "{case}"
    );
    for (k, v) in want {
        assert!(
            without_wall_times(k, &got[k]) == without_wall_times(k, v),
            "{case}: `{k}` differs from the undisturbed run"
        );
    }
}

/// Cache files, sorted.
fn cache_files(root: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for k in std::fs::read_dir(root.join("results/cache"))
        .unwrap()
        .flatten()
    {
        if k.path().is_dir() {
            v.extend(k.path().read_dir().unwrap().flatten().map(|e| e.path()));
        }
    }
    v.retain(|p| p.extension().is_some_and(|x| x == "h5"));
    v.sort();
    v
}

/// A small deterministic generator (64-bit LCG): the cases are reproducible.
struct Lcg(u64);
impl Lcg {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 33) as usize) % n.max(1)
    }
}

/// After a damaging case: the rerun either succeeds with identical outputs and a clean status,
/// or fails naming a stage and a cache file.
fn recovers(root: &Path, want: &BTreeMap<String, Vec<u8>>, case: &str) {
    let o = run(root);
    if !o.status.success() {
        let t = text(&o);
        assert!(
            t.contains("stage `") && t.contains("results/cache/"),
            "{case}: a failure must name the stage and the file:\n{t}"
        );
        return;
    }
    same_outputs(root, want, case);
    let st = text(&saddleflow(root, &["status"]));
    assert!(
        !st.contains("DAMAGED") && !st.contains("INVALID") && !st.contains("missing"),
        "{case}: after the rerun everything is cached:\n{st}"
    );
}

#[test]
fn fault_injection_byte_flips_foreign_artefacts_and_truncation() {
    let dir = project();
    let root = dir.path();
    ok(&run(root));
    let want = outputs(root);
    let files = cache_files(root);
    assert!(files.len() > 20, "{files:?}");

    // every artefact was stamped verified at its publication: the first rerun re-reads none
    // (the flips below show that a stamp does not hide a change)
    let o = run(root);
    ok(&o);
    assert!(
        text(&o).contains(" 0 verifications "),
        "the first no-op rerun re-hashed artefacts:\n{}",
        text(&o)
    );

    // 16-byte flips at random places of 8 random cache files
    let mut rng = Lcg(18);
    for round in 0..8 {
        let f = &files[rng.below(files.len())];
        let mut b = std::fs::read(f).unwrap();
        let at = rng.below(b.len() - 16);
        for x in &mut b[at..at + 16] {
            *x ^= 0x5a;
        }
        std::fs::write(f, b).unwrap();
        // a flip that touched no data (free space, layout) may leave the entry valid: then
        // the content is intact, which `recovers` checks through the outputs
        recovers(root, &want, &format!("flip {round} in {}", f.display()));
    }

    // a foreign artefact: one critical study copied over another's name
    let crit: Vec<&PathBuf> = files
        .iter()
        .filter(|p| p.parent().unwrap().ends_with("critical"))
        .collect();
    assert!(crit.len() >= 2, "{crit:?}");
    std::fs::copy(crit[0], crit[1]).unwrap();
    let st = text(&saddleflow(root, &["status"]));
    assert!(st.contains("DAMAGED"), "{st}");
    recovers(root, &want, "foreign artefact");

    // truncation of three files
    for f in [&files[0], &files[files.len() / 2], &files[files.len() - 1]] {
        let b = std::fs::read(f).unwrap();
        std::fs::write(f, &b[..b.len() / 3]).unwrap();
    }
    recovers(root, &want, "truncation");
}

#[test]
fn fault_injection_unwritable_outputs_unsaved_index_and_a_killed_run() {
    let dir = project();
    let root = dir.path();
    ok(&run(root));
    let want = outputs(root);

    // a declared output that cannot be written: the run fails naming stage and file
    let csv = root.join("results/tables/fig2.csv");
    std::fs::remove_file(&csv).unwrap();
    std::fs::create_dir(&csv).unwrap();
    let o = run(root);
    assert!(
        !o.status.success(),
        "exit 0 with fig2.csv missing:\n{}",
        text(&o)
    );
    let t = text(&o);
    assert!(t.contains("fig2.csv") && t.contains("stage `"), "{t}");
    std::fs::remove_dir(&csv).unwrap();
    ok(&run(root));
    same_outputs(root, &want, "output rewritten from the cache");

    // the index cannot be saved: the run's results and summary still come, the warning after
    std::fs::remove_dir_all(root.join("results/cache")).unwrap();
    std::fs::create_dir_all(root.join("results/cache/index.json/x")).unwrap();
    let o = run(root);
    ok(&o);
    let t = String::from_utf8_lossy(&o.stderr).into_owned();
    let counts = t.find(" ran, ").expect("the counts are printed");
    let warning = t
        .find("cannot write the cache index")
        .expect("the warning is printed");
    assert!(counts < warning, "the summary comes first:\n{t}");
    same_outputs(root, &want, "index not saved");
    std::fs::remove_dir_all(root.join("results/cache/index.json")).unwrap();

    // a run killed midway, then rerun
    std::fs::remove_dir_all(root.join("results/cache")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_saddleflow"))
        .args(["run", "-j", "2", "-C"])
        .arg(root)
        .args(["--params", "params/smoke.toml"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(800));
    child.kill().unwrap();
    child.wait().unwrap();
    ok(&run(root));
    same_outputs(root, &want, "killed run");
}
