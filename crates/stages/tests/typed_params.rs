//! The `ParamSpec` list of every registered kind equals its typed parameter struct (issue 17,
//! item 3): the validated, defaults-filled parameters of real stages parse into the struct; an
//! extra key fails (the struct denies unknown fields, so a spec without a field cannot hide);
//! every spec's key is needed (dropping it fails as a missing field, so a field without a spec
//! cannot hide either). Kinds still on the untyped interface are listed in `UNTYPED`.

use stages::orchestrator::schema::validate_params;
use stages::orchestrator::{ParamType, Params, Plan, Registry};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Kinds that read their parameters untyped (being rewritten elsewhere).
const UNTYPED: [&str; 0] = [];
/// Kinds whose `tol_gap` keeps its own documented range (any positive value).
const OWN_TOL_GAP_RANGE: [&str; 1] = ["sweep"];
/// Keys the scene adapter adds to every scene (not part of a scene's own struct).
const SCENE_DIRS: [&str; 2] = ["figure_dir", "table_dir"];

fn project_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Some valid value of a parameter type (for kinds no pipeline preset uses).
fn sample(ty: &ParamType) -> serde_json::Value {
    use serde_json::json;
    match ty {
        ParamType::Int { min, max } => json!(min.or(*max).unwrap_or(1)),
        ParamType::Float {
            min,
            min_exclusive,
            max,
            ..
        } => match (min, max) {
            (Some(a), Some(b)) => json!(0.5 * (a + b)),
            (Some(a), None) => json!(if *min_exclusive { a + 1.0 } else { *a }),
            (None, Some(b)) => json!(b - 1.0),
            (None, None) => json!(0.5),
        },
        ParamType::Bool => json!(false),
        ParamType::Str { allowed: Some(a) } => json!(a[0]),
        ParamType::Str { allowed: None } => json!("x"),
        ParamType::Array { elem, min_len, .. } => {
            json!(vec![sample(elem); (*min_len).max(1)])
        }
        ParamType::Any => json!("free"),
    }
}

/// Per kind, the parameters of the smoke plan's stages of that kind; for kinds the smoke plan
/// does not use, one set from the specs' defaults and sample values of the required ones.
fn params_per_kind(reg: &Registry) -> BTreeMap<String, Vec<Params>> {
    let root = project_root();
    let plan = Plan::load(
        reg,
        &root.join("pipeline/paper.toml"),
        Some(&root.join("params/smoke.toml")),
    )
    .expect("the smoke plan loads");
    let mut per: BTreeMap<String, Vec<Params>> = BTreeMap::new();
    for s in &plan.stages {
        per.entry(s.kind.clone())
            .or_default()
            .push(s.params.clone());
    }
    for name in reg.names() {
        if per.contains_key(name) {
            continue;
        }
        let specs = reg.get(name).unwrap().params();
        let given: serde_json::Map<_, _> = specs
            .iter()
            .filter(|s| s.default.is_none())
            .map(|s| (s.name.clone(), sample(&s.ty)))
            .collect();
        let filled = validate_params(&specs, &given)
            .unwrap_or_else(|e| panic!("kind `{name}`: sample parameters rejected: {e:?}"));
        per.insert(name.to_string(), vec![Params(filled)]);
    }
    per
}

#[test]
fn every_kinds_param_specs_equal_its_typed_struct() {
    let reg = stages::registry();
    let scenes: Vec<&str> = stages::scenes::SCENES.iter().map(|s| s.name()).collect();
    let per = params_per_kind(&reg);
    let mut checked = 0;
    for name in reg.names() {
        let kind = reg.get(name).unwrap();
        let sets = &per[name];
        if UNTYPED.contains(&name) {
            assert!(
                kind.parse_typed(&sets[0]).is_none(),
                "`{name}` is typed now"
            );
            continue;
        }
        for p in sets {
            let parse = |q: &Params| {
                kind.parse_typed(q)
                    .unwrap_or_else(|| panic!("kind `{name}` has no typed parameters"))
            };
            parse(p).unwrap_or_else(|e| panic!("kind `{name}`: {e:#}"));
            // an extra key is refused: the struct denies unknown fields
            let mut extra = p.clone();
            extra
                .0
                .insert("no_such_parameter".into(), serde_json::json!(1));
            let e = parse(&extra).expect_err("unknown key accepted").to_string();
            assert!(
                e.contains("no_such_parameter") && e.contains(name),
                "kind `{name}`: {e}"
            );
            // every spec is a field of the struct
            for spec in kind.params() {
                if scenes.contains(&name) && SCENE_DIRS.contains(&spec.name.as_str()) {
                    continue;
                }
                let mut less = p.clone();
                less.0.remove(&spec.name);
                let e = parse(&less)
                    .err()
                    .unwrap_or_else(|| panic!("kind `{name}`: spec `{}` is not a field", spec.name))
                    .to_string();
                assert!(e.contains(&spec.name), "kind `{name}`: {e}");
            }
            checked += 1;
        }
    }
    // the smoke plan alone has dozens of stages
    assert!(checked > 20, "only {checked} parameter sets checked");
}

/// The shared solver parameter is one spec: every kind that declares `tol_gap` declares it
/// identically (range, default, doc), and the default is the solver's.
#[test]
fn tol_gap_is_declared_once() {
    let reg = stages::registry();
    let shared = stages::kinds::solver::tol_gap_spec();
    // 1e-10: the default of every kind's `tol_gap` before the shared spec (another default
    // would change these kinds' cache keys and results)
    assert_eq!(shared.default, Some(serde_json::json!(1e-10)));
    let mut users = Vec::new();
    for name in reg.names() {
        if UNTYPED.contains(&name) {
            continue;
        }
        for s in reg.get(name).unwrap().params() {
            if s.name == "tol_gap" {
                if OWN_TOL_GAP_RANGE.contains(&name) {
                    // the same default and doc, its own range
                    assert_eq!(
                        (&s.default, &s.doc),
                        (&shared.default, &shared.doc),
                        "kind `{name}`"
                    );
                } else {
                    assert_eq!(s, shared, "kind `{name}`");
                }
                users.push(name);
            }
        }
    }
    assert_eq!(
        users,
        [
            "constriction",
            "critical",
            "extremes",
            "flowmap",
            "ladder",
            "leakage",
            "refined_ladder",
            "refined_window",
            "sweep"
        ],
        "kinds with tol_gap"
    );
}
