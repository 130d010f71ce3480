//! The shared contact-solver parameters (`tol_gap`, `tol_force`, `max_iter`, `method`) of the
//! kinds that run [`contact`] solves, and serde helpers for typed parameters.
//!
//! Each parameter's [`ParamSpec`] (type, range, doc, default) is written once here; a kind lists
//! the ones it exposes, under their usual names, and keeps flat fields of the same names in its
//! parameter struct (serde's `deny_unknown_fields` does not work together with
//! `#[serde(flatten)]`, so there is no nested table). It builds a [`SolverParams`] from those
//! fields (the ones it does not expose keep [`contact::SolverOptions::default`]'s values), and
//! [`SolverParams::options`] is the one conversion to [`contact::SolverOptions`].
//!
//! The ranges are [`contact::SolverOptions::validate`]'s: `0 < tol_gap ≤ TOL_GAP_MAX`,
//! `0 < tol_force ≤ TOL_FORCE_MAX`, so the plan rejects exactly what the solver would.

use contact::{Method, SolverOptions};
use orchestrator::{ParamSpec, ParamType};
use serde::{Deserialize, Deserializer};
use std::fmt::Display;
use std::str::FromStr;

/// Deserialises a string through the target type's [`FromStr`] (lattices, solver methods,
/// flow axes), so there is one list of names, the type's own.
pub fn from_str<'de, D, T>(d: D) -> Result<T, D::Error>
where
    D: Deserializer<'de>,
    T: FromStr,
    T::Err: Display,
{
    let s = String::deserialize(d)?;
    s.parse().map_err(serde::de::Error::custom)
}

/// The canonical names of [`contact::Method`] (each parses through its `FromStr`; aliases such
/// as `pk` are not offered in pipeline files).
pub const METHOD_NAMES: [&str; 5] = [
    "auto",
    "polonsky-keer",
    "polonsky-keer-plain",
    "fire",
    "nonlinear-cg",
];

/// A float in `(0, max]`.
fn up_to(max: f64) -> ParamType {
    ParamType::Float {
        min: Some(0.0),
        min_exclusive: true,
        max: Some(max),
        max_exclusive: false,
    }
}

/// `tol_gap`: the bound on the constraint violation (h0); default
/// [`SolverOptions::default`]'s.
pub fn tol_gap_spec() -> ParamSpec {
    ParamSpec::new("tol_gap", up_to(contact::TOL_GAP_MAX))
        .default(SolverOptions::default().tol_gap)
        .doc("contact: tolerance on the constraint violation (h0); Polonsky–Keer stops on it")
}

/// `tol_force`: the bound on the force-balance residual (E* h0/λ).
pub fn tol_force_spec() -> ParamSpec {
    ParamSpec::new("tol_force", up_to(contact::TOL_FORCE_MAX))
        .default(SolverOptions::default().tol_force)
        .doc("contact: tolerance on the force residual (E* h0/λ); FIRE stops on it")
}

/// The contact solver's iteration cap, under the name `name` (`max_iter`, or
/// `max_iter_contact` in kinds whose `max_iter` is the flow solver's).
pub fn max_iter_spec(name: &str) -> ParamSpec {
    ParamSpec::new(name, ParamType::int_range(1, 100_000_000))
        .default(SolverOptions::default().max_iter as i64)
        .doc("contact: iteration cap per solve")
}

/// `method`: the minimiser, one of [`METHOD_NAMES`].
pub fn method_spec() -> ParamSpec {
    ParamSpec::new("method", ParamType::one_of(&METHOD_NAMES))
        .default("auto")
        .doc("contact: minimiser (polonsky-keer variants: hard wall only)")
}

/// The contact solver's parameters, converted to [`SolverOptions`] in one place.
#[derive(Clone, Debug, PartialEq)]
pub struct SolverParams {
    /// See [`SolverOptions::tol_gap`].
    pub tol_gap: f64,
    /// See [`SolverOptions::tol_force`].
    pub tol_force: f64,
    /// See [`SolverOptions::max_iter`].
    pub max_iter: usize,
    /// See [`SolverOptions::method`].
    pub method: Method,
}

impl Default for SolverParams {
    fn default() -> Self {
        let o = SolverOptions::default();
        Self {
            tol_gap: o.tol_gap,
            tol_force: o.tol_force,
            max_iter: o.max_iter,
            method: o.method,
        }
    }
}

impl SolverParams {
    /// With `tol_gap`, the rest at their defaults.
    pub fn tol_gap(tol_gap: f64) -> Self {
        Self {
            tol_gap,
            ..Self::default()
        }
    }
    /// The solver options (no trace).
    pub fn options(&self) -> SolverOptions {
        SolverOptions {
            tol_gap: self.tol_gap,
            tol_force: self.tol_force,
            max_iter: self.max_iter,
            method: self.method,
            trace: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn method_names_parse_to_distinct_methods() {
        let m: Vec<Method> = METHOD_NAMES.iter().map(|s| s.parse().unwrap()).collect();
        for (i, a) in m.iter().enumerate() {
            assert!(!m[i + 1..].contains(a), "{} twice", METHOD_NAMES[i]);
        }
        assert_eq!(m[0], Method::default());
    }

    #[test]
    fn specs_accept_their_defaults_and_the_solver_the_ranges() {
        for s in [
            tol_gap_spec(),
            tol_force_spec(),
            max_iter_spec("max_iter"),
            method_spec(),
        ] {
            let d = s.default.clone().unwrap();
            assert!(s.ty.check(&d).is_ok(), "{}: default {d}", s.name);
        }
        // the upper ends of the ranges are accepted by the solver, and just above rejected
        assert!(
            tol_gap_spec()
                .ty
                .check(&json!(contact::TOL_GAP_MAX))
                .is_ok()
        );
        assert!(
            tol_gap_spec()
                .ty
                .check(&json!(2.0 * contact::TOL_GAP_MAX))
                .is_err()
        );
        assert!(tol_gap_spec().ty.check(&json!(0.0)).is_err());
        let o = SolverParams {
            tol_gap: contact::TOL_GAP_MAX,
            tol_force: contact::TOL_FORCE_MAX,
            ..SolverParams::default()
        }
        .options();
        assert!(o.validate().is_ok());
        assert_eq!(SolverParams::default().options(), SolverOptions::default());
    }

    #[test]
    fn from_str_names_the_bad_value() {
        #[derive(Deserialize, Debug)]
        #[serde(deny_unknown_fields)]
        struct P {
            #[serde(deserialize_with = "from_str")]
            lattice: surface::Lattice,
        }
        let p: P = serde_json::from_value(json!({"lattice": "hexagonal"})).unwrap();
        assert_eq!(p.lattice, surface::Lattice::Hexagonal);
        let e = serde_json::from_value::<P>(json!({"lattice": "hexagon"}))
            .unwrap_err()
            .to_string();
        assert!(e.contains("hexagon"), "{e}");
    }
}
