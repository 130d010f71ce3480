//! The `sweep` kind's parameters, parsed once into [`SweepParams`] (see the [`crate::sweep`]
//! module doc for what each means), and the load-path segments `path` and
//! `reverse_extension` are written in.
//!
//! The solver settings `tol_force`, `max_iter` and `method` are the shared ones of
//! [`crate::solver`]; `tol_gap` keeps the sweep's own range (any positive value: its paths
//! include the tiny tolerances of the resolution studies) and default.

use crate::solver::{self, SolverParams};
use contact::{Interaction, Method};
use orchestrator::{ParamIssue, ParamSpec, ParamType};
use serde::Deserialize;
use serde_json::{Value, json};
use std::fmt;

/// Largest number of points a path may have.
pub const MAX_POINTS: usize = 100_000;

/// The interaction on top of the hard wall, by name (`interaction`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Law {
    /// No interaction beyond the hard wall.
    Hardwall,
    /// γ = −γ0 e^(−g/ρ).
    Adhesion,
    /// γ = γr e^(−g²/2ρ²).
    Repulsion,
}

/// What a path varies (`control`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ControlKind {
    /// The mean pressure.
    Load,
    /// γ0 or γr at the fixed `load`.
    Strength,
}

/// The unit of loads (`unit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
pub enum LoadUnit {
    /// The grid's full-contact pressure p_fc.
    #[serde(rename = "p_fc")]
    PFc,
    /// E* h0/λ.
    #[serde(rename = "absolute")]
    Absolute,
}

macro_rules! names {
    ($t:ty { $($v:ident = $s:literal),+ }) => {
        impl $t {
            /// Every value, in the order of the parameter's allowed list.
            pub const ALL: &'static [$t] = &[$(<$t>::$v),+];
            /// The name in pipeline files and artefacts.
            pub fn name(self) -> &'static str {
                match self { $(<$t>::$v => $s),+ }
            }
            fn names() -> Vec<&'static str> {
                Self::ALL.iter().map(|x| x.name()).collect()
            }
        }
        impl fmt::Display for $t {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }
        impl std::str::FromStr for $t {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                Self::ALL.iter().copied().find(|x| x.name() == s).ok_or_else(|| {
                    format!("`{s}`: allowed {}", Self::names().join(", "))
                })
            }
        }
    };
}
names!(Law { Hardwall = "hardwall", Adhesion = "adhesion", Repulsion = "repulsion" });
names!(ControlKind { Load = "load", Strength = "strength" });
names!(LoadUnit { PFc = "p_fc", Absolute = "absolute" });

/// The `sweep` kind's parameters (one field per [`specs`] entry).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepParams {
    /// Interaction on top of the hard wall.
    pub interaction: Law,
    /// Adhesion: γ0 (E* h0²/λ).
    pub gamma0: f64,
    /// Repulsion: γr (E* h0²/λ).
    pub gamma_r: f64,
    /// Interaction range ρ (h0).
    pub rho: f64,
    /// What the path varies.
    pub control: ControlKind,
    /// Unit of loads.
    pub unit: LoadUnit,
    /// Forward branch: segments (checked by [`SweepParams::forward`]).
    pub path: Value,
    /// Retrace the path backwards.
    pub reverse: bool,
    /// Segments continuing the reverse branch (checked by [`SweepParams::extension`]).
    pub reverse_extension: Value,
    /// Strength control: the fixed mean pressure (in `unit`).
    pub load: f64,
    /// Minimiser.
    #[serde(deserialize_with = "solver::from_str")]
    pub method: Method,
    /// Constraint-violation tolerance (h0).
    pub tol_gap: f64,
    /// Force-residual tolerance (E* h0/λ).
    pub tol_force: f64,
    /// Iteration cap per point.
    pub max_iter: usize,
    /// Jump detector: size over the neighbours' trend.
    pub jump_ratio: f64,
    /// Jump detector: neighbour steps on each side.
    pub jump_window: usize,
    /// Area difference that makes a hysteresis loop.
    pub loop_tolerance: f64,
    /// Control values at which full fields are stored.
    pub fields_at: Vec<f64>,
    /// Store the fields of every point.
    pub fields_all: bool,
    /// Warn when ρ²E*/γ spans fewer grid spacings.
    pub min_zone_spacings: f64,
    /// Bisection levels of every step that jumps ([`contact::path::Refinement::depth`]).
    pub refine_jumps: u32,
    /// Area change that makes a step a jump ([`contact::path::Refinement::area_jump`]).
    pub refine_area: f64,
}

/// The `sweep` kind's parameter specs (types, ranges, defaults, docs).
pub fn specs() -> Vec<ParamSpec> {
    let floats = || ParamType::Array {
        elem: Box::new(ParamType::float()),
        min_len: 0,
        max_len: None,
    };
    vec![
        ParamSpec::new("interaction", ParamType::one_of(&Law::names()))
            .doc("interaction on top of the hard wall"),
        ParamSpec::new("gamma0", ParamType::non_negative())
            .default(0.2)
            .doc("adhesion: surface energy γ0 (E* h0²/λ)"),
        ParamSpec::new("gamma_r", ParamType::non_negative())
            .default(0.2)
            .doc("repulsion: barrier energy γr (E* h0²/λ)"),
        ParamSpec::new("rho", ParamType::positive())
            .default(0.04)
            .doc("interaction range ρ (h0)"),
        ParamSpec::new("control", ParamType::one_of(&ControlKind::names()))
            .default("load")
            .doc("what the path varies: the mean pressure, or γ0/γr at fixed `load`"),
        ParamSpec::new("unit", ParamType::one_of(&LoadUnit::names()))
            .default("p_fc")
            .doc("unit of loads: the grid's full-contact pressure, or E* h0/λ"),
        ParamSpec::new("path", ParamType::Any)
            .doc("forward branch: segments { from, to, steps | step }"),
        ParamSpec::new("reverse", ParamType::Bool)
            .default(true)
            .doc("retrace the path backwards after the forward branch"),
        ParamSpec::new("reverse_extension", ParamType::Any)
            .default(json!([]))
            .doc("segments { to, steps | step } continuing the reverse branch below the path's start"),
        ParamSpec::new("load", ParamType::float())
            .default(0.0)
            .doc("strength control: the fixed mean pressure (in `unit`)"),
        solver::method_spec().doc("minimiser (auto: Polonsky–Keer for the hard wall; nonlinear CG for adhesion and repulsion where the grid resolves the cohesive zone, FIRE where it does not)"),
        // the shared spec with the sweep's own documented range: any positive tolerance (the
        // shared spec caps it at contact::TOL_GAP_MAX, which the solver checks at run time)
        ParamSpec {
            ty: ParamType::positive(),
            ..solver::tol_gap_spec()
        },
        solver::tol_force_spec(),
        solver::max_iter_spec("max_iter"),
        ParamSpec::new(
            "jump_ratio",
            ParamType::Float {
                min: Some(1.0),
                min_exclusive: true,
                max: None,
                max_exclusive: false,
            },
        )
        .default(5.0)
        .doc("a jump is this many times larger than its neighbours' trend"),
        ParamSpec::new("jump_window", ParamType::int_range(1, 20))
            .default(2)
            .doc("neighbour steps on each side for the jump detector"),
        ParamSpec::new("loop_tolerance", ParamType::non_negative())
            .default(0.02)
            .doc("branches whose areas differ by more than this (or in topology) form a hysteresis loop"),
        ParamSpec::new("fields_at", floats())
            .default(json!([]))
            .doc("control values at which the full fields of each branch are stored"),
        ParamSpec::new("fields_all", ParamType::Bool)
            .default(false)
            .doc("store the fields of every point (what a flux-against-load curve needs)"),
        ParamSpec::new("min_zone_spacings", ParamType::non_negative())
            .default(4.0)
            .doc("warn when ρ²E*/γ spans fewer grid spacings"),
        ParamSpec::new(
            "refine_jumps",
            ParamType::int_range(0, contact::path::REFINE_DEPTH_MAX as i64),
        )
        .default(0)
        .doc("bisect every step that jumps (topology or area change) this many times from the earlier state: jumps located within step/2^refine_jumps (0: off)"),
        ParamSpec::new(
            "refine_area",
            ParamType::Float {
                min: Some(0.0),
                min_exclusive: true,
                max: Some(1.0),
                max_exclusive: false,
            },
        )
        .default(0.02)
        .doc("a step whose relative contact area changes by more than this is a jump (for refine_jumps; a change of topology always is)"),
    ]
}

impl SweepParams {
    /// The interaction (its strength is replaced along a strength path).
    pub fn interaction(&self) -> Interaction {
        match self.interaction {
            Law::Hardwall => Interaction::HardWall,
            Law::Adhesion => Interaction::Adhesion {
                gamma0: self.gamma0,
                rho: self.rho,
            },
            Law::Repulsion => Interaction::Repulsion {
                gamma_r: self.gamma_r,
                rho: self.rho,
            },
        }
    }
    /// The refinement of steps that jump.
    pub fn refinement(&self) -> contact::path::Refinement {
        contact::path::Refinement {
            depth: self.refine_jumps,
            area_jump: self.refine_area,
        }
    }
    /// The solver settings.
    pub fn solver(&self) -> SolverParams {
        SolverParams {
            tol_gap: self.tol_gap,
            tol_force: self.tol_force,
            max_iter: self.max_iter,
            method: self.method,
        }
    }
    /// The forward values of `path` (in `unit`), checked.
    pub fn forward(&self) -> Result<Vec<f64>, ParamIssue> {
        let segs = parse_segments("path", &self.path, true, None)?;
        Ok(expand(&segs, 0.0, true))
    }
    /// The reverse extension's values (in `unit`), below the forward branch's start.
    pub fn extension(&self, start: f64) -> Result<Vec<f64>, ParamIssue> {
        let segs = parse_segments(
            "reverse_extension",
            &self.reverse_extension,
            false,
            Some(start),
        )?;
        Ok(expand(&segs, start, false))
    }
    /// Cross-parameter checks (the plan has checked each parameter's type and range).
    pub fn check(&self) -> Result<(), ParamIssue> {
        let fwd = self.forward()?;
        let ext = self.extension(fwd[0])?;
        let adhesion = self.interaction == Law::Adhesion;
        if self.control == ControlKind::Strength {
            if self.interaction == Law::Hardwall {
                return Err(issue(
                    "control",
                    "\"strength\" needs interaction \"adhesion\" or \"repulsion\" (the hard wall has no strength)",
                ));
            }
            if let Some(v) = fwd.iter().chain(&ext).find(|&&v| v < 0.0) {
                return Err(issue("path", format!("strengths must be ≥ 0, found {v}")));
            }
            if self.load <= 0.0 && !adhesion {
                return Err(issue(
                    "load",
                    format!(
                        "{}: without adhesion the fixed load must be > 0 (no equilibrium otherwise)",
                        self.load
                    ),
                ));
            }
        } else if !adhesion && let Some(v) = fwd.iter().chain(&ext).find(|&&v| v <= 0.0) {
            return Err(issue(
                if fwd.contains(v) {
                    "path"
                } else {
                    "reverse_extension"
                },
                format!(
                    "load {v}: without adhesion every load must be > 0 (under force control a non-positive load has no equilibrium)"
                ),
            ));
        }
        if !self.reverse && !ext.is_empty() {
            return Err(issue(
                "reverse_extension",
                "needs `reverse = true` (it continues the reverse branch)",
            ));
        }
        if self.method.hard_wall_only() && self.interaction != Law::Hardwall {
            return Err(issue(
                "method",
                format!(
                    "\"{}\" solves the hard wall only; use \"fire\", \"nonlinear-cg\" or \"auto\"",
                    self.method
                ),
            ));
        }
        Ok(())
    }
}

/// One segment of a path: values from `from` (the previous end if `None`) to `to` in `steps`
/// equal steps.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// Start (only the first segment of a forward path gives it).
    pub from: Option<f64>,
    /// End (included).
    pub to: f64,
    /// Number of equal steps.
    pub steps: usize,
}

fn issue(key: &str, msg: impl Into<String>) -> ParamIssue {
    ParamIssue::new(key, msg)
}

/// Parses a list of segments. `forward`: the first segment must give `from` and values
/// increase; otherwise (`reverse_extension`) `from` is not allowed and values decrease from
/// `start`.
pub fn parse_segments(
    key: &str,
    v: &Value,
    forward: bool,
    start: Option<f64>,
) -> Result<Vec<Segment>, ParamIssue> {
    let items = v.as_array().ok_or_else(|| {
        issue(
            key,
            "expected an array of segments like { from = 0.01, to = 0.5, steps = 20 } or { to = 1.0, step = 0.02 }",
        )
    })?;
    if forward && items.is_empty() {
        return Err(issue(key, "the path needs at least one segment"));
    }
    let mut segs = Vec::new();
    let mut prev_end = start;
    let mut total = 0usize;
    for (i, item) in items.iter().enumerate() {
        let at = |m: String| issue(key, format!("segment {i}: {m}"));
        let t = item.as_object().ok_or_else(|| {
            at(format!(
                "expected a table like {{ to = 0.5, steps = 20 }}, found {}",
                orchestrator::schema::describe(item)
            ))
        })?;
        for k in t.keys() {
            if !["from", "to", "steps", "step"].contains(&k.as_str()) {
                return Err(at(format!(
                    "unknown key `{k}`; allowed: from, to, steps, step"
                )));
            }
        }
        let num = |k: &str| -> Result<Option<f64>, ParamIssue> {
            match t.get(k) {
                None => Ok(None),
                Some(x) => match x.as_f64() {
                    Some(f) if f.is_finite() => Ok(Some(f)),
                    _ => Err(at(format!(
                        "`{k}` must be a finite number, found {}",
                        orchestrator::schema::describe(x)
                    ))),
                },
            }
        };
        let from = num("from")?;
        let to = num("to")?.ok_or_else(|| at("`to` is required".into()))?;
        let from_eff = match (from, prev_end) {
            (Some(f), None) => f,
            (None, Some(p)) => p,
            (Some(f), Some(p)) => {
                if !forward {
                    return Err(at(format!(
                        "`from` is not allowed here: the extension starts where the forward path starts ({p})"
                    )));
                }
                if (f - p).abs() > 1e-12 * (1.0 + p.abs()) {
                    return Err(at(format!(
                        "`from` = {f} but the previous segment ends at {p}; omit `from` after the first segment"
                    )));
                }
                p
            }
            (None, None) => return Err(at("the first segment needs `from`".into())),
        };
        let span = to - from_eff;
        if forward && span <= 0.0 {
            return Err(at(format!(
                "`to` = {to} must be greater than the segment's start {from_eff} (a path increases)"
            )));
        }
        if !forward && span >= 0.0 {
            return Err(at(format!(
                "`to` = {to} must be below the segment's start {from_eff} (the extension continues downwards)"
            )));
        }
        let steps = match (t.get("steps"), num("step")?) {
            (Some(_), Some(_)) => return Err(at("give `steps` or `step`, not both".into())),
            (None, None) => return Err(at("give `steps` (a count) or `step` (a size)".into())),
            (Some(s), None) => match s.as_i64() {
                Some(s) if s >= 1 => s as usize,
                _ => {
                    return Err(at(format!(
                        "`steps` must be an integer ≥ 1, found {}",
                        orchestrator::schema::describe(s)
                    )));
                }
            },
            (None, Some(step)) => {
                if step <= 0.0 {
                    return Err(at(format!("`step` must be > 0, found {step:?}")));
                }
                let n = (span.abs() / step - 1e-9).ceil();
                if n > MAX_POINTS as f64 {
                    return Err(at(format!(
                        "`step` = {step:?} gives {n:.3e} points; at most {MAX_POINTS} are allowed"
                    )));
                }
                (n as usize).max(1)
            }
        };
        total += steps;
        if total > MAX_POINTS {
            return Err(at(format!("the path has more than {MAX_POINTS} points")));
        }
        segs.push(Segment {
            from: if i == 0 && forward {
                Some(from_eff)
            } else {
                None
            },
            to,
            steps,
        });
        prev_end = Some(to);
    }
    Ok(segs)
}

/// The values of a list of segments starting at `start` (the first segment's `from` if it has
/// one); `include_start` adds the start itself.
pub fn expand(segs: &[Segment], start: f64, include_start: bool) -> Vec<f64> {
    let mut out = Vec::new();
    let mut a = segs.first().and_then(|s| s.from).unwrap_or(start);
    if include_start {
        out.push(a);
    }
    for s in segs {
        for k in 1..=s.steps {
            out.push(if k == s.steps {
                s.to
            } else {
                a + (s.to - a) * k as f64 / s.steps as f64
            });
        }
        a = s.to;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_expand_with_refinement() {
        let v = json!([{"from": 0.0, "to": 0.1, "steps": 2}, {"to": 0.2, "step": 0.025}]);
        let segs = parse_segments("path", &v, true, None).unwrap();
        let x = expand(&segs, 0.0, true);
        let want = [0.0, 0.05, 0.1, 0.125, 0.15, 0.175, 0.2];
        assert_eq!(x.len(), want.len());
        for (a, b) in x.iter().zip(want) {
            assert!((a - b).abs() < 1e-15, "{x:?}");
        }
        // the extension continues downwards from the start
        let e = parse_segments(
            "reverse_extension",
            &json!([{"to": -0.02, "steps": 2}]),
            false,
            Some(0.0),
        )
        .unwrap();
        assert_eq!(expand(&e, 0.0, false), [-0.01, -0.02]);
    }

    #[test]
    fn segment_errors_say_what_is_allowed() {
        let bad = |v: Value, fwd: bool| {
            parse_segments("path", &v, fwd, if fwd { None } else { Some(0.0) })
                .unwrap_err()
                .to_string()
        };
        assert!(bad(json!([{"to": 1.0, "steps": 2}]), true).contains("needs `from`"));
        assert!(bad(json!([{"from": 1.0, "to": 0.5, "steps": 2}]), true).contains("greater than"));
        assert!(bad(json!([{"from": 0.0, "to": 1.0}]), true).contains("`steps`"));
        assert!(
            bad(
                json!([{"from": 0.0, "to": 1.0, "steps": 2, "step": 0.1}]),
                true
            )
            .contains("not both")
        );
        assert!(
            bad(json!([{"from": 0.0, "to": 1.0, "stepz": 2}]), true)
                .contains("unknown key `stepz`")
        );
        assert!(
            bad(
                json!([{"from": 0.0, "to": 1.0, "steps": 2}, {"from": 2.0, "to": 3.0, "steps": 1}]),
                true
            )
            .contains("previous segment ends at 1")
        );
        assert!(bad(json!([{"to": 0.5, "steps": 2}]), false).contains("below"));
        assert!(bad(json!([]), true).contains("at least one"));
        assert!(bad(json!([{"from": 0.0, "to": 1.0, "step": 1e-9}]), true).contains("at most"));
    }
}
