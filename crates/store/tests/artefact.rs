//! Round trips, validity probes and reproducible bytes of HDF5 artefacts.

use ndarray::Array2;
use serde_json::json;
use store::{ArtefactReader, ArtefactWriter, Provenance, fields};

fn sample(path: &std::path::Path, prov: &Provenance) -> std::path::PathBuf {
    let mut w = ArtefactWriter::create(path).unwrap();
    w.set_cell(1.0, 2.0).unwrap();
    w.set_attr("n", 3i64).unwrap();
    w.set_attr("count", 7u64).unwrap();
    w.set_attr("flag", true).unwrap();
    w.set_attr("lattice", "square").unwrap();
    w.set_attr("meta", json!({"b": 1, "a": [1.5, "x"]}))
        .unwrap();
    let gap = Array2::from_shape_fn((4, 8), |(i, j)| i as f64 * 10.0 + j as f64);
    w.write_f64_2d(fields::GAP, gap.view()).unwrap();
    w.write_f64_1d("branch/loading/area", &[0.1, 0.2, 0.3])
        .unwrap();
    w.write_i64_1d("branch/loading/iterations", &[5, 6, 7])
        .unwrap();
    w.write_strings("labels", &["hard wall", "adhésion"])
        .unwrap();
    w.write_string("doc", "{\"long\": true}").unwrap();
    w.create_group("empty/group").unwrap();
    w.set_attr_at("branch/loading", "direction", "up").unwrap();
    w.set_attr_at("gap", "unit", "h0").unwrap();
    w.write_provenance(prov).unwrap();
    w.publish().unwrap()
}

fn prov() -> Provenance {
    let mut p = Provenance::new("ab".repeat(32), "surface", 3, json!({"n": 3, "tol": 1e-8}));
    p.inputs.insert("surface".into(), vec!["cd".repeat(32)]);
    p.wall_s = 1.25;
    p.stats = json!({"iterations": 12, "residual": 1e-11});
    p.warnings = vec!["rho below grid spacing".into()];
    p.created_utc = "2026-01-02T03:04:05Z".into();
    p.host = "testhost".into();
    p
}

#[test]
fn round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let path = sample(&dir.path().join("sub/a.h5"), &prov());
    assert!(ArtefactReader::is_valid(&path));
    let r = ArtefactReader::open_complete(&path).unwrap();
    assert_eq!(r.cell().unwrap(), (1.0, 2.0));
    assert_eq!(r.attr_i64("n").unwrap(), 3);
    assert_eq!(r.attr_f64("n").unwrap(), 3.0);
    assert_eq!(r.attr_u64("count").unwrap(), 7);
    assert!(r.attr_bool("flag").unwrap());
    assert_eq!(r.attr_str("lattice").unwrap(), "square");
    assert_eq!(
        r.attr_json("meta").unwrap(),
        json!({"a": [1.5, "x"], "b": 1})
    );
    let gap = r.read_f64_2d("gap").unwrap();
    assert_eq!(gap.dim(), (4, 8));
    assert_eq!(gap[[3, 5]], 35.0);
    assert_eq!(
        r.read_f64_1d("branch/loading/area").unwrap(),
        vec![0.1, 0.2, 0.3]
    );
    assert_eq!(
        r.read_i64_1d("/branch/loading/iterations").unwrap(),
        vec![5, 6, 7]
    );
    assert_eq!(
        r.read_strings("labels").unwrap(),
        vec!["hard wall", "adhésion"]
    );
    assert_eq!(r.read_string("doc").unwrap(), "{\"long\": true}");
    assert_eq!(r.attr_str_at("branch/loading", "direction").unwrap(), "up");
    assert_eq!(r.attr_str_at("gap", "unit").unwrap(), "h0");
    assert!(r.members("empty").unwrap().contains(&"group".to_string()));
    assert_eq!(r.provenance().unwrap(), prov());
    assert!(r.attr_f64("missing").is_err());
    assert!(r.read_f64_2d("missing").is_err());
    // no temporaries left behind: the artefact and its whole-file checksum
    let mut names: Vec<String> = std::fs::read_dir(dir.path().join("sub"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names.len(), 2, "{names:?}");
    assert!(names[1].ends_with(".h5.b3"), "{names:?}");
}

#[test]
fn identical_content_gives_identical_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let a = sample(&dir.path().join("a.h5"), &prov());
    std::thread::sleep(std::time::Duration::from_millis(1100));
    let b = sample(&dir.path().join("b.h5"), &prov());
    assert_eq!(std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
}

#[test]
fn truncated_missing_garbage_and_unmarked_files_are_invalid() {
    let dir = tempfile::tempdir().unwrap();
    let path = sample(&dir.path().join("a.h5"), &prov());
    let bytes = std::fs::read(&path).unwrap();
    for cut in [0, 8, 100, bytes.len() / 2, bytes.len() - 1] {
        let t = dir.path().join(format!("t{cut}.h5"));
        std::fs::write(&t, &bytes[..cut]).unwrap();
        assert!(
            !ArtefactReader::is_valid(&t),
            "truncated at {cut} counted as valid"
        );
    }
    assert!(!ArtefactReader::is_valid(dir.path().join("nope.h5")));
    assert!(!ArtefactReader::is_valid(dir.path()));
    let g = dir.path().join("garbage.h5");
    std::fs::write(&g, b"this is not hdf5 at all").unwrap();
    assert!(!ArtefactReader::is_valid(&g));

    // a file written by someone else (no complete mark) opens, but is not a valid artefact
    let foreign = dir.path().join("foreign.h5");
    {
        let f = hdf5::File::create(&foreign).unwrap();
        f.new_attr::<f64>()
            .create("lx")
            .unwrap()
            .write_scalar(&1.0)
            .unwrap();
        f.new_attr::<f64>()
            .create("ly")
            .unwrap()
            .write_scalar(&1.0)
            .unwrap();
        f.new_dataset_builder()
            .with_data(&Array2::<f64>::ones((2, 2)))
            .create("gap")
            .unwrap();
    }
    assert!(!ArtefactReader::is_valid(&foreign));
    let r = ArtefactReader::open(&foreign).unwrap();
    assert!(!r.is_complete());
    assert_eq!(r.cell().unwrap(), (1.0, 1.0));
    assert!(ArtefactReader::open_complete(&foreign).is_err());
}

#[test]
fn dropped_writer_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.h5");
    {
        let mut w = ArtefactWriter::create(&path).unwrap();
        w.write_f64_1d("x", &[1.0]).unwrap();
        assert!(w.temp_path().exists());
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn publish_replaces_an_existing_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.h5");
    std::fs::write(&path, b"old junk").unwrap();
    let mut w = ArtefactWriter::create(&path).unwrap();
    w.set_attr("v", 2i64).unwrap();
    w.publish().unwrap();
    assert_eq!(
        ArtefactReader::open(&path).unwrap().attr_i64("v").unwrap(),
        2
    );
}

#[test]
fn command_provenance_key_is_stable() {
    let a = Provenance::for_command("solve", 1, json!({"p": 0.1, "n": 5})).unwrap();
    let b = Provenance::for_command("solve", 1, json!({"n": 5, "p": 1e-1})).unwrap();
    assert_eq!(a.key, b.key);
    assert!(store::is_key(&a.key));
}

fn open_fds_to(path: &std::path::Path) -> usize {
    let Ok(rd) = std::fs::read_dir("/proc/self/fd") else {
        return 0;
    };
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    rd.flatten()
        .filter_map(|e| std::fs::read_link(e.path()).ok())
        .filter(|t| t.to_string_lossy().contains(&name))
        .count()
}

#[test]
fn no_file_stays_open_after_publish_or_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = sample(&dir.path().join("fds.h5"), &prov());
    assert_eq!(open_fds_to(&path), 0, "the writer left the file open");
    {
        let r = ArtefactReader::open_complete(&path).unwrap();
        assert_eq!(r.attr_f64("lx").unwrap(), 1.0);
        let _ = r.provenance().unwrap();
        let _ = r.read_f64_2d("gap").unwrap();
    }
    assert_eq!(open_fds_to(&path), 0, "the reader left the file open");
    assert!(ArtefactReader::is_valid(&path));
    assert_eq!(open_fds_to(&path), 0, "is_valid left the file open");
}

/// Overwrites the first occurrence of `from` in the file with `to` (same length).
fn patch(path: &std::path::Path, from: &[u8], to: &[u8]) {
    let mut bytes = std::fs::read(path).unwrap();
    let at = bytes
        .windows(from.len())
        .position(|w| w == from)
        .expect("pattern in file");
    bytes[at..at + to.len()].copy_from_slice(to);
    std::fs::write(path, bytes).unwrap();
}

fn key_of(path: &std::path::Path) -> String {
    ArtefactReader::open(path)
        .unwrap()
        .provenance()
        .unwrap()
        .key
}

#[test]
fn cache_contents_are_never_verified_a_value_overwritten_in_place_is_damaged() {
    // issue 18.1: 8 bytes of a contact area overwritten; the file still opens as HDF5 and is
    // marked complete, so only the content digest can tell.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.h5");
    let mut w = ArtefactWriter::create(&path).unwrap();
    w.write_f64_1d("points/contact_area", &[0.1, 0.4678, 0.7])
        .unwrap();
    w.write_provenance(&prov()).unwrap();
    w.publish().unwrap();
    let key = key_of(&path);
    assert_eq!(store::digest::check(&path, &key), store::Integrity::Valid);
    patch(&path, &0.4678f64.to_le_bytes(), &0.9f64.to_le_bytes());
    let r = ArtefactReader::open_complete(&path).unwrap();
    assert_eq!(r.read_f64_1d("points/contact_area").unwrap()[1], 0.9);
    let verdict = store::digest::check(&path, &key);
    assert!(
        matches!(&verdict, store::Integrity::Damaged(m) if m.contains("damaged") && m.contains("a.h5")),
        "{verdict:?}"
    );
    assert!(ArtefactReader::open_verified(&path, &key).is_err());
}

#[test]
fn cache_contents_are_never_verified_an_attribute_edit_is_damaged() {
    let dir = tempfile::tempdir().unwrap();
    let path = sample(&dir.path().join("a.h5"), &prov());
    let key = key_of(&path);
    assert!(store::digest::check(&path, &key).is_valid());
    patch(&path, b"square", b"squaRe");
    assert!(matches!(
        store::digest::check(&path, &key),
        store::Integrity::Damaged(_)
    ));
}

#[test]
fn cache_contents_are_never_verified_a_foreign_artefact_is_damaged() {
    // issue 18.1: another stage's valid artefact copied under this key's name
    let dir = tempfile::tempdir().unwrap();
    let mine = sample(&dir.path().join("mine.h5"), &prov());
    let mut other = prov();
    other.key = "ef".repeat(32);
    let theirs = sample(&dir.path().join("theirs.h5"), &other);
    let key = key_of(&mine);
    std::fs::copy(&theirs, &mine).unwrap();
    let verdict = store::digest::check(&mine, &key);
    assert!(
        matches!(&verdict, store::Integrity::Damaged(m) if m.contains("foreign")),
        "{verdict:?}"
    );
}

#[test]
fn truncated_and_missing_entries_are_invalid_or_missing_not_damaged() {
    let dir = tempfile::tempdir().unwrap();
    let path = sample(&dir.path().join("a.h5"), &prov());
    let key = key_of(&path);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    assert!(matches!(
        store::digest::check(&path, &key),
        store::Integrity::Invalid(_)
    ));
    assert_eq!(
        store::digest::check(&dir.path().join("none.h5"), &key),
        store::Integrity::Missing
    );
}

#[test]
fn the_digest_does_not_depend_on_write_order() {
    // fixed order: names sorted, so the same content written in another order hashes alike
    let dir = tempfile::tempdir().unwrap();
    let digest = |order: bool, name: &str| {
        let path = dir.path().join(name);
        let mut w = ArtefactWriter::create(&path).unwrap();
        if order {
            w.set_attr("a", 1.0).unwrap();
            w.set_attr("b", "x").unwrap();
            w.write_f64_1d("g/x", &[1.0]).unwrap();
            w.write_i64_1d("g/y", &[2]).unwrap();
        } else {
            w.write_i64_1d("g/y", &[2]).unwrap();
            w.set_attr("b", "x").unwrap();
            w.write_f64_1d("g/x", &[1.0]).unwrap();
            w.set_attr("a", 1.0).unwrap();
        }
        let p = w.publish().unwrap();
        ArtefactReader::open(&p)
            .unwrap()
            .attr_str(store::CONTENT_ATTR)
            .unwrap()
    };
    let (a, b) = (digest(true, "a.h5"), digest(false, "b.h5"));
    assert_eq!(a, b);
    assert!(store::is_key(&a));
}
