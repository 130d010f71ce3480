//! The chain of refined ladders per model as the stages that read them take it (`exponents`,
//! scenes `running`, `refined`, `fig6` through `exponents`): each model's `refined_ladder`
//! artefacts from the inputs `refined` (the pipeline's `refined_ladder_*`) and `deep` (its
//! `refined_deep_*`: a second discretisation per model for the deepest rungs), ordered by depth
//! for `critical::refined::chained_ladder` (docs/near-critical.md, "The chain of refined
//! ladders").
//! Kept apart from `refined_ladder` so that its compute kind's code identity stays that of the
//! ladder itself.
//!
//! The input `window` (the pipeline's `refined_deep_window_*`, `crate::refined_window`) holds
//! window checks: each is applied to the ladder it checks (same model, base, window, and a
//! discretisation at its level and margin), whose running pairs then carry the window change
//! in their grid error and flag ([`Linked::window_change`]).

use crate::refined_ladder::RefinedData;
use crate::refined_window::{WindowCheck, apply};
use anyhow::{Result, anyhow};
use store::ArtefactReader;
use surface::Lattice;

/// Which input of the stages that read refined ladders (`exponents`, scenes `running`,
/// `refined`, `fig5`) a ladder came from: `refined` (the pipeline's `refined_ladder_*` stages)
/// or `deep` (its `refined_deep_*` stages: a second discretisation per model for the deepest
/// rungs, chained below the first; docs/near-critical.md). Tables name it in their
/// `method` column ([`Depth::name`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Depth {
    /// Input `refined`.
    Refined,
    /// Input `deep`.
    Deep,
}

impl Depth {
    /// Both, in input order.
    pub const ALL: [Depth; 2] = [Depth::Refined, Depth::Deep];

    /// Table name (`refined`, `refined_deep`).
    pub fn name(self) -> &'static str {
        match self {
            Depth::Refined => "refined",
            Depth::Deep => "refined_deep",
        }
    }

    /// The input that carries it (`refined`, `deep`).
    pub fn input(self) -> &'static str {
        match self {
            Depth::Refined => "refined",
            Depth::Deep => "deep",
        }
    }
}

/// A refined ladder and the input it came from.
#[derive(Clone, Debug)]
pub struct Linked {
    /// Its input.
    pub depth: Depth,
    /// The ladder (with a window check, its running pairs' grid errors and flags include the
    /// window change: `crate::refined_window::apply`).
    pub data: RefinedData,
    /// Per pair of `data.running`: the window change Δw (the running exponent at the check's
    /// level with the larger window minus with the ladder's; NaN: unknown or not checked).
    pub window_change: Vec<f64>,
    /// The check's window (base cells), if a window check was applied.
    pub window_check: Option<u32>,
}

impl Linked {
    /// A ladder from `depth` without a window check.
    pub fn new(depth: Depth, data: RefinedData) -> Self {
        let window_change = vec![f64::NAN; data.running.len()];
        Linked {
            depth,
            data,
            window_change,
            window_check: None,
        }
    }
}

/// The `refined` and then the `deep` inputs (either may be absent), at most one of each per
/// model; the artefacts as read, in input order. Each window check of the input `window`
/// (optional) is applied to every ladder it checks (`crate::refined_window::apply`); a check
/// that matches no ladder, or two checks of one ladder, are errors.
pub fn read_linked(inputs: &orchestrator::Inputs) -> Result<Vec<(Linked, &ArtefactReader)>> {
    let mut out: Vec<(Linked, &ArtefactReader)> = Vec::new();
    for depth in Depth::ALL {
        for r in inputs.all(depth.input()) {
            let data = RefinedData::read(r)?;
            if out
                .iter()
                .any(|(x, _)| x.depth == depth && x.data.lattice == data.lattice)
            {
                return Err(anyhow!(
                    "two `{}` inputs for the {} model; give at most one per model",
                    depth.input(),
                    data.lattice.name()
                ));
            }
            out.push((Linked::new(depth, data), r));
        }
    }
    for w in inputs.all("window") {
        let check = WindowCheck::read(w)?;
        let mut matched = false;
        for (link, r) in out.iter_mut() {
            let base = r.attr_i64("base")? as u32;
            if !check.checks(&link.data, base) {
                continue;
            }
            if let Some(other) = link.window_check {
                return Err(anyhow!(
                    "{}: the {} `{}` ladder already has a window check (window {other}); give at most one per ladder",
                    check.describe(),
                    link.data.lattice.name(),
                    link.depth.input()
                ));
            }
            link.window_change = apply(&mut link.data, &check)?;
            link.window_check = Some(check.window_check);
            matched = true;
        }
        if !matched {
            return Err(anyhow!(
                "{} ({}): checks no `refined` or `deep` input (none of that model with base 2^{}, window {} and a discretisation at k = {} with margin {}); the window check's keys must be the checked ladder's",
                check.describe(),
                w.path().display(),
                check.base,
                check.window,
                check.level,
                check.margin
            ));
        }
    }
    Ok(out)
}

/// The chain of refined ladders of model `lattice` (`critical::refined::chained_ladder`),
/// ordered by depth: the coarser finest spacing first (the shallower discretisation), equal
/// spacings in input order (`refined` before `deep`).
pub fn chain_of(all: &[Linked], lattice: Lattice) -> Vec<&Linked> {
    let mut v: Vec<&Linked> = all.iter().filter(|x| x.data.lattice == lattice).collect();
    // stable: ties keep the input order
    v.sort_by(|a, b| b.data.spacing.total_cmp(&a.data.spacing));
    v
}
