//! The chain of refined ladders per model as the stages that read them take it (`exponents`,
//! scenes `running`, `refined`, `fig6` through `exponents`): each model's `refined_ladder`
//! artefacts from the inputs `refined` (the pipeline's `refined_ladder_*`) and `deep` (its
//! `refined_deep_*`: a second discretisation per model for the deepest rungs), ordered by depth
//! for `critical::refined::chained_ladder` (docs/near-critical.md, "The chain of refined
//! ladders").
//! Kept apart from `refined_ladder` so that its compute kind's code identity stays that of the
//! ladder itself.

use crate::refined_ladder::RefinedData;
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
    /// The ladder.
    pub data: RefinedData,
}

/// The `refined` and then the `deep` inputs (either may be absent), at most one of each per
/// model; the artefacts as read, in input order.
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
            out.push((Linked { depth, data }, r));
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
