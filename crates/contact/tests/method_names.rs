//! `contact::Method` names: the one list ([`Method::ALL`]) that parameter lists (the sweep's
//! `method`) are built from; every name parses back to its method, aliases included.

use contact::Method;

#[test]
fn every_method_round_trips_through_its_name() {
    for m in Method::ALL {
        assert_eq!(m.name().parse::<Method>().unwrap(), m);
        assert_eq!(m.to_string(), m.name());
    }
    let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
    assert_eq!(
        names,
        [
            "auto",
            "polonsky-keer",
            "polonsky-keer-plain",
            "fire",
            "nonlinear-cg"
        ]
    );
    for (alias, m) in [
        ("pk", Method::PolonskyKeer),
        ("pk-plain", Method::PolonskyKeerPlain),
        ("ncg", Method::NonlinearCg),
    ] {
        assert_eq!(alias.parse::<Method>().unwrap(), m);
    }
    let err = "cg".parse::<Method>().unwrap_err().to_string();
    assert!(err.contains("nonlinear-cg"), "{err}");
    assert!(Method::PolonskyKeerPlain.hard_wall_only() && !Method::NonlinearCg.hard_wall_only());
}
