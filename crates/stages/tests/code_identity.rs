//! Code identity in the key (issue 18.2): editing a source changes the keys of exactly the
//! stages whose kind depends on it. The hashing runs on a temporary copy of the workspace's
//! crates, so no real file is edited.

#[path = "../build/scan.rs"]
#[allow(dead_code)]
mod scan;

use orchestrator::Params;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

type Ids = BTreeMap<String, BTreeMap<String, String>>;

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if matches!(name.as_str(), "target" | "tests" | "benches") || name.starts_with('.') {
            continue;
        }
        if e.file_type().unwrap().is_dir() {
            copy_tree(&e.path(), &to.join(&name));
        } else {
            std::fs::copy(e.path(), to.join(&name)).unwrap();
        }
    }
}

fn workspace_copy() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    copy_tree(&crates, &dir.path().join("crates"));
    dir
}

fn ids(root: &Path, overrides: &str) -> Ids {
    let (ids, _) = scan::module_identities(
        &root.join("crates/stages"),
        &scan::parse_overrides(overrides),
    )
    .unwrap();
    ids
}

/// The key of a stage of each kind with the same parameters and inputs: only the code differs.
fn keys(ids: &Ids) -> BTreeMap<String, String> {
    ids.iter()
        .map(|(m, code)| {
            let key =
                orchestrator::plan::stage_key(m, 1, code, &Params::default(), &BTreeMap::new())
                    .unwrap();
            (m.clone(), key)
        })
        .collect()
}

fn changed(a: &Ids, b: &Ids) -> BTreeSet<String> {
    let (ka, kb) = (keys(a), keys(b));
    ka.keys().filter(|m| ka[*m] != kb[*m]).cloned().collect()
}

fn append(path: &Path, text: &str) {
    let mut s = std::fs::read_to_string(path).unwrap();
    s.push_str(text);
    std::fs::write(path, s).unwrap();
}

#[test]
fn code_identity_in_the_key_is_hand_bumped_editing_a_physics_crate_reruns_exactly_its_users() {
    let dir = workspace_copy();
    let before = ids(dir.path(), "");
    append(
        &dir.path().join("crates/reynolds/src/lib.rs"),
        "\n// an edit\n",
    );
    let after = ids(dir.path(), "");
    let users: BTreeSet<String> = before
        .iter()
        .filter(|(_, parts)| parts.contains_key("crate reynolds"))
        .map(|(m, _)| m.clone())
        .collect();
    assert!(
        users.contains("flow"),
        "the flow kind solves Reynolds: {users:?}"
    );
    assert!(!users.contains("surface"), "surfaces need no flow solver");
    assert_eq!(changed(&before, &after), users);
}

#[test]
fn editing_a_stage_module_reruns_the_kinds_that_reach_it_and_no_others() {
    let dir = workspace_copy();
    let before = ids(dir.path(), "");
    append(
        &dir.path().join("crates/kinds/src/sweep.rs"),
        "\n// an edit\n",
    );
    let after = ids(dir.path(), "");
    let users: BTreeSet<String> = before
        .iter()
        .filter(|(_, parts)| parts.contains_key("kinds/src/sweep.rs"))
        .map(|(m, _)| m.clone())
        .collect();
    assert!(
        users.contains("sweep") && users.contains("fig2") && users.contains("fig3"),
        "{users:?}"
    );
    // across crates at module granularity: scenes that read no sweep are not touched
    assert!(
        !users.contains("surface")
            && !users.contains("mock")
            && !users.contains("fig4")
            && !users.contains("convergence"),
        "{users:?}"
    );
    assert_eq!(changed(&before, &after), users);
}

#[test]
fn a_module_folder_is_one_module_whose_every_file_counts() {
    let dir = workspace_copy();
    let before = ids(dir.path(), "");
    assert!(
        before.contains_key("exponents"),
        "the exponents kind (a folder module) has an identity"
    );
    append(
        &dir.path().join("crates/kinds/src/exponents/asymptotic.rs"),
        "\n// an edit\n",
    );
    let after = ids(dir.path(), "");
    let users: BTreeSet<String> = before
        .iter()
        .filter(|(_, parts)| parts.contains_key("kinds/src/exponents/"))
        .map(|(m, _)| m.clone())
        .collect();
    assert!(users.contains("exponents"), "{users:?}");
    assert!(
        !users.contains("sweep") && !users.contains("fig2"),
        "{users:?}"
    );
    assert_eq!(changed(&before, &after), users);
}

/// A module `m.rs` with its submodules in `m/` (the layout without `mod.rs`: the running
/// scene's `running.rs` and `running/differences.rs`): an edit to a submodule file changes the
/// module's identity, labelled by `m.rs`.
#[test]
fn a_modules_submodule_folder_counts_as_part_of_the_module() {
    let dir = workspace_copy();
    let before = ids(dir.path(), "");
    let sub = dir.path().join("crates/scenes/src/running/differences.rs");
    assert!(
        sub.is_file(),
        "the running scene keeps a submodule in running/"
    );
    append(&sub, "\n// an edit\n");
    let after = ids(dir.path(), "");
    let users: BTreeSet<String> = before
        .iter()
        .filter(|(_, parts)| parts.contains_key("scenes/src/running.rs"))
        .map(|(m, _)| m.clone())
        .collect();
    assert!(users.contains("running"), "{users:?}");
    assert_eq!(changed(&before, &after), users);
}

/// A folder module's part is labelled by its folder (`kinds/src/exponents/`), not as a file
/// that does not exist, and an override names it by that label.
#[test]
fn a_folder_module_is_labelled_by_its_folder_and_overrides_match_that_label() {
    let dir = workspace_copy();
    let before = ids(dir.path(), "");
    let parts = &before["exponents"];
    assert!(parts.contains_key("kinds/src/exponents/"), "{parts:?}");
    assert!(parts.contains_key("kinds/src/ladder.rs"), "{parts:?}");
    assert!(!parts.contains_key("kinds/src/exponents.rs"), "{parts:?}");
    let was = parts["kinds/src/exponents/"].clone();
    append(
        &dir.path().join("crates/kinds/src/exponents/mod.rs"),
        "\n// a comment\n",
    );
    let now = ids(dir.path(), "")["exponents"]["kinds/src/exponents/"].clone();
    assert_ne!(now, was);
    let pinned = ids(dir.path(), &format!("kinds/src/exponents/ {now} {was}\n"));
    assert!(changed(&before, &pinned).is_empty());
}

#[test]
fn an_override_keeps_the_identity_across_an_edit_known_not_to_change_results() {
    let dir = workspace_copy();
    let before = ids(dir.path(), "");
    let was = before["surface"]["crate surface"].clone();
    let lib = dir.path().join("crates/surface/src/lib.rs");
    append(&lib, "\n// a comment\n");
    let edited = ids(dir.path(), "");
    let now = edited["surface"]["crate surface"].clone();
    assert_ne!(now, was);
    let pinned = ids(dir.path(), &format!("crate surface {now} {was}\n"));
    assert!(changed(&before, &pinned).is_empty());
    // a further edit escapes the override
    append(&lib, "\n// a real change\n");
    let (later, stale) = scan::module_identities(
        &dir.path().join("crates/stages"),
        &scan::parse_overrides(&format!("crate surface {now} {was}\n")),
    )
    .unwrap();
    assert!(changed(&before, &later).contains("surface"));
    assert_eq!(stale, ["crate surface"]);
}

#[test]
fn the_engine_is_no_part_of_a_kind_identity_and_every_kind_has_one() {
    let reg = stages::registry();
    for name in reg.names() {
        let code = reg.code_identity(name);
        assert!(
            ["kinds", "scenes"].iter().any(|c| {
                code.contains_key(&format!("{c}/src/{name}.rs"))
                    || code.contains_key(&format!("{c}/src/{name}/"))
            }),
            "kind `{name}`: {code:?}"
        );
        assert!(
            !code
                .keys()
                .any(|p| p == "crate orchestrator" || p == "crate fsutil")
        );
    }
    assert!(reg.code_identity("sweep").contains_key("crate contact"));
}

#[test]
fn module_references_are_found_in_paths_and_use_lists() {
    let src =
        "use crate::{io::{a, b}, sweep};\nlet x = crate::fig4::f();\nuse super::*;\nmy_crate::x";
    let refs = scan::module_refs(src);
    for m in ["io", "sweep", "fig4", "a", "b"] {
        assert!(refs.contains(m), "{m}: {refs:?}");
    }
    assert!(scan::names_crate("use contact::Solver;", "contact"));
    assert!(!scan::names_crate("use my_contact::Solver;", "contact"));
}
