//! Figure 2's inputs, shared by the `figure` and `table` kinds: three load-controlled `sweep`
//! stages on the square model, one per interaction, given as the inputs `hardwall`, `adhesion`
//! and `repulsion`.

use crate::jumptable::GridSweep;
use crate::sweep::SweepData;
use anyhow::{Result, bail};
use orchestrator::{InputSpec, Inputs};

/// The interactions of Figure 2, in the order of its inputs.
pub const INTERACTIONS: [&str; 3] = ["hardwall", "adhesion", "repulsion"];

/// The inputs Figure 2's kinds take.
pub fn inputs() -> Vec<InputSpec> {
    INTERACTIONS
        .iter()
        .map(|i| {
            InputSpec::one(i, &["sweep"]).doc(&format!("load-controlled {i} sweep (square model)"))
        })
        .collect()
}

/// Reads the three sweeps (hard wall, adhesion, repulsion) and checks that each is a load path
/// of the interaction its input is named after, all on the same grid.
pub fn read(inputs: &Inputs) -> Result<Vec<SweepData>> {
    let mut out = Vec::new();
    for name in INTERACTIONS {
        let r = inputs.one(name)?;
        let d = SweepData::read(r)?;
        if d.interaction != name {
            bail!(
                "input `{name}` holds the {} sweep (`{}`); it must be the {name} sweep",
                d.interaction,
                r.path().display()
            );
        }
        if d.control != "load" {
            bail!(
                "input `{name}` varies the {}; Figure 2 needs a load path (control = \"load\")",
                d.control
            );
        }
        out.push(d);
    }
    if let Some(d) = out
        .iter()
        .find(|d| (d.n, &d.lattice) != (out[0].n, &out[0].lattice))
    {
        bail!(
            "the sweeps are on different surfaces: {} n = {} (hardwall) and {} n = {} ({})",
            out[0].lattice,
            out[0].n,
            d.lattice,
            d.n,
            d.interaction
        );
    }
    Ok(out)
}

/// The inputs of Figure 2's resolution check: the same three sweeps on one or more grids each.
pub fn resolution_inputs() -> Vec<InputSpec> {
    INTERACTIONS
        .iter()
        .map(|i| {
            InputSpec::many(i, &["sweep"]).doc(&format!(
                "load-controlled {i} sweeps (square model), one per grid"
            ))
        })
        .collect()
}

/// Reads the resolution check's sweeps: per interaction, its sweeps coarse to fine, each a
/// load path of that interaction on the square model, at most one per grid.
pub fn read_resolution(inputs: &Inputs) -> Result<Vec<(String, Vec<GridSweep>)>> {
    let mut out = Vec::new();
    for name in INTERACTIONS {
        let mut v = Vec::new();
        for r in inputs.all(name) {
            let s = GridSweep::read(r)?;
            if s.data.interaction != name || s.data.control != "load" {
                bail!(
                    "input `{name}` (`{}`) holds the {} sweep varying the {}; it must be a {name} load path",
                    r.path().display(),
                    s.data.interaction,
                    s.data.control
                );
            }
            if s.data.lattice != "square" {
                bail!(
                    "input `{name}` is on the {} model; Figure 2 is the square model",
                    s.data.lattice
                );
            }
            v.push(s);
        }
        if v.is_empty() {
            bail!("input `{name}`: no sweep given");
        }
        v.sort_by_key(|s| s.data.n);
        if let Some(w) = v.windows(2).find(|w| w[0].data.n == w[1].data.n) {
            bail!(
                "input `{name}`: two sweeps on the same grid (n = {}); give one per grid",
                w[0].data.n
            );
        }
        out.push((name.to_string(), v));
    }
    Ok(out)
}
