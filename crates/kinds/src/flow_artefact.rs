//! The `flow` artefact's records: written by [`crate::flow`], read back by [`FlowData::read`]
//! (Figure 6 reads through it). The layout is described in the [`crate::flow`] module doc; each
//! table is one [`formats::record!`] declaration.

use anyhow::{Context, Result};
use contact::path::Branch;
use formats::records::read_in;
use reynolds::FlowResult;
pub use reynolds::Termination;
use store::ArtefactReader;

formats::record! {
    /// One solved point (`points/*`): the sweep point's state and the flow solve.
    #[derive(Clone, Debug, PartialEq)]
    pub struct FlowPoint {
        /// Index of the point in the sweep's `points/*`.
        pub sweep_index: usize,
        /// Branch of the path.
        pub branch: Branch,
        /// Step in the planned path.
        pub step: i64,
        /// Mean pressure (E* h0/λ).
        pub load: f64,
        /// γ0 or γr (0 for the hard wall).
        pub strength: f64,
        /// Relative contact area.
        pub contact_area: f64,
        /// The contact solve converged.
        pub contact_converged: bool,
        /// Volume flux through the cell for a unit pressure drop.
        pub flux: f64,
        /// Effective conductivity (a uniform gap g gives g³).
        pub conductivity: f64,
        /// Fluid winds along the axis.
        pub percolating: bool,
        /// The flow solve converged.
        pub converged: bool,
        /// How the flow solve ended.
        pub termination: Termination,
        /// Preconditioned CG iterations.
        pub iterations: usize,
        /// True relative residual.
        pub residual: f64,
        /// Rounding floor of the residual.
        pub residual_floor: f64,
        /// Dissipation of the pressure's rounding noise, relative to the flux.
        pub flux_rounding_error: f64,
        /// Largest disagreement between cross-section fluxes.
        pub conservation_error: f64,
        /// Estimate of the flux's error.
        pub flux_error_estimate: f64,
        /// Nodes that carry flow.
        pub flowing_nodes: usize,
        /// Nodes removed as dead-end pools.
        pub removed_nodes: usize,
        /// Wall time of the solve (s).
        pub wall_s: f64,
    }
}

impl FlowPoint {
    /// The flow solve `res` at the `sweep_index`-th sweep point `p`.
    pub fn new(sweep_index: usize, p: &crate::sweep::Point, res: &FlowResult) -> Self {
        FlowPoint {
            sweep_index,
            branch: p.branch,
            step: p.step,
            load: p.load,
            strength: p.strength,
            contact_area: p.contact_area,
            contact_converged: p.converged,
            flux: res.flux,
            conductivity: res.conductivity,
            percolating: res.percolating,
            converged: res.converged,
            termination: res.termination,
            iterations: res.iterations,
            residual: res.relative_residual,
            residual_floor: res.residual_floor,
            flux_rounding_error: res.flux_rounding_error,
            conservation_error: res.conservation_error,
            flux_error_estimate: res.flux_error_estimate,
            flowing_nodes: res.flowing_nodes,
            removed_nodes: res.removed_nodes,
            wall_s: res.wall_seconds,
        }
    }
}

formats::record! {
    /// Where the flow stops or starts between two consecutive solved points of a branch
    /// (`stops/*`).
    #[derive(Clone, Debug, PartialEq)]
    pub struct FlowStop {
        /// Branch.
        pub branch: Branch,
        /// The flowing point (index into `points/*`).
        pub index_flowing: usize,
        /// The blocked point.
        pub index_blocked: usize,
        /// Load of the flowing point (E* h0/λ).
        pub load_flowing: f64,
        /// Load of the blocked point.
        pub load_blocked: f64,
        /// Conductivity of the flowing point.
        pub conductivity_flowing: f64,
        /// Contact area of the flowing point.
        pub contact_area_flowing: f64,
        /// Contact area of the blocked point.
        pub contact_area_blocked: f64,
    }
}

impl FlowStop {
    /// The stop between the flowing point `f` and the blocked point `b` of `points`.
    pub fn new(points: &[FlowPoint], f: usize, b: usize) -> Self {
        FlowStop {
            branch: points[f].branch,
            index_flowing: f,
            index_blocked: b,
            load_flowing: points[f].load,
            load_blocked: points[b].load,
            conductivity_flowing: points[f].conductivity,
            contact_area_flowing: points[f].contact_area,
            contact_area_blocked: points[b].contact_area,
        }
    }
}

/// Where the flow stops or starts along each branch, between consecutive solved points.
pub fn find_stops(points: &[FlowPoint]) -> Vec<FlowStop> {
    let mut stops = Vec::new();
    for br in [Branch::Loading, Branch::Unloading] {
        let idx: Vec<usize> = (0..points.len())
            .filter(|&i| points[i].branch == br)
            .collect();
        for w in idx.windows(2) {
            let (a, b) = (&points[w[0]], &points[w[1]]);
            if a.percolating != b.percolating {
                let (f, bl) = if a.percolating {
                    (w[0], w[1])
                } else {
                    (w[1], w[0])
                };
                stops.push(FlowStop::new(points, f, bl));
            }
        }
    }
    stops
}

/// A `flow` artefact, read back (for the scenes).
#[derive(Clone, Debug, PartialEq)]
pub struct FlowData {
    /// Surface model.
    pub lattice: String,
    /// hardwall, adhesion or repulsion.
    pub interaction: String,
    /// γ0 (0 unless adhesion).
    pub gamma0: f64,
    /// Full-contact pressure of the grid.
    pub p_fc: f64,
    /// Flow axis.
    pub axis: String,
    /// Grid exponent.
    pub n: i64,
    /// The solved points in path order.
    pub points: Vec<FlowPoint>,
    /// Where the flow stops or starts.
    pub stops: Vec<FlowStop>,
}

impl FlowData {
    /// Reads a `flow` artefact.
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let ctx = || format!("reading flow artefact `{}`", r.path().display());
        (|| -> Result<Self> {
            Ok(FlowData {
                lattice: r.attr_str("lattice")?,
                interaction: r.attr_str("interaction")?,
                gamma0: r.attr_f64("gamma0")?,
                p_fc: r.attr_f64("p_fc")?,
                axis: r.attr_str("axis")?,
                n: r.attr_i64("n")?,
                points: read_in(r, "points")?,
                stops: read_in(r, "stops")?,
            })
        })()
        .with_context(ctx)
    }

    /// Indices of the points of `branch` whose flow and contact solves converged, in path
    /// order; and how many of the branch's points were left out.
    pub fn usable(&self, branch: Branch) -> (Vec<usize>, usize) {
        let all: Vec<usize> = (0..self.points.len())
            .filter(|&k| self.points[k].branch == branch)
            .collect();
        let ok: Vec<usize> = all
            .iter()
            .copied()
            .filter(|&k| self.points[k].converged && self.points[k].contact_converged)
            .collect();
        let left_out = all.len() - ok.len();
        (ok, left_out)
    }
}
