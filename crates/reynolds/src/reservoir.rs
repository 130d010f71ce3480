//! Flow between two reservoirs, for gap fields that are not periodic (a measured patch).
//!
//! # Geometry
//! With the flow along the first axis (the caller transposes for y): node `(i, j)` is the centre
//! of a `dx × dy` control volume, the inlet reservoir (pressure `ΔP = 1`) lies along the edge
//! `x = 0` half a cell before the first column, the outlet (pressure 0) along `x = nx dx` half a
//! cell after the last. A node of the first or last column is coupled to its reservoir through
//! the half cell with its own conductance, `2 g³ dy/dx`. The faces across the edge `x = nx dx ≡
//! 0` of the periodic layout carry nothing. The side edges ([`SideEdges`]) are either closed
//! (no flux across `y = 0` and `y = ny dy`) or periodic.
//!
//! # What is exact
//! The series resistance of a column of the grid is `Σ_i dx / g³_i` (the harmonic face
//! conductances and the two half-cell reservoir faces add up to exactly that), so a gap varying
//! only along the flow gives `K = 1 / ⟨1/g³⟩` over the nodes, and a gap varying only across it
//! `K = ⟨g³⟩`, exactly for the discrete problem; a uniform gap gives `g³`.
//!
//! # Pools
//! Only fluid clusters (4-connected) that touch both the first and the last column carry flow:
//! the others (closed ponds and dead ends attached to one reservoir only) are at a uniform
//! pressure and are removed before solving, as the periodic solver removes clusters that do not
//! wind around the cell. Clusters are labelled by the `percolation` crate on the mask padded with
//! a column of solid (and, for closed sides, a row), which breaks the periodic wrap there.
//!
//! # Operator and gauge
//! The reservoir faces make the operator a grounded Laplacian (couplings to the outside held at
//! zero): the same multigrid and conjugate gradients as the periodic cell, with the ground
//! carried through the Galerkin products (see the `multigrid` module). The unknown is
//! `u = p − ΔP` up to and including the cut column `c_j` of each row (the cut of least
//! conductance through the interior x-face columns, as for the periodic cell: a staircase, see
//! the `finite_volume` module) and `u = p` after it: both reservoirs are at `u = 0` and the
//! drop enters only through the cut's faces, e.g. `p_c − p_{c+1} = u_c − u_{c+1} + ΔP`. Near a
//! closing constriction the cut falls on it, so `u` stays near zero in the well-conducting ponds
//! on both sides, where double precision must resolve tiny pressure differences (with
//! `u = p` the ponds at the inlet would sit at `u ≈ 1` and their rounding noise would swamp a
//! flux 10⁻⁹ of their conductance). The flux is the dissipation
//! `Σ_faces s (Δp)² / ΔP` including the reservoir faces, and its certification compares it with
//! the flux through all `nx + 1` cross-sections (inlet faces, interior columns, outlet faces).

use ndarray::{Array2, ArrayView2, s};

/// The edges parallel to the flow.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SideEdges {
    /// Closed walls: no flux across them.
    NoFlux,
    /// Periodic across the flow (a strip of an infinite periodic seal).
    Periodic,
}

/// Fluid nodes (4-connected) in clusters touching both the first and the last column.
pub(crate) fn spanning_mask(fluid: ArrayView2<bool>, sides: SideEdges) -> Array2<bool> {
    let (nx, ny) = fluid.dim();
    let pad_y = usize::from(sides == SideEdges::NoFlux);
    let mut padded = Array2::from_elem((nx + 1, ny + pad_y), false);
    padded.slice_mut(s![..nx, ..ny]).assign(&fluid);
    let l = percolation::label(padded.view(), percolation::Connectivity::Four);
    let mut at_inlet = vec![false; l.len()];
    let mut at_outlet = vec![false; l.len()];
    for j in 0..ny {
        for (i, touches) in [(0, &mut at_inlet), (nx - 1, &mut at_outlet)] {
            let c = l.labels[[i, j]];
            if c != percolation::NO_CLUSTER {
                touches[c as usize] = true;
            }
        }
    }
    Array2::from_shape_fn((nx, ny), |(i, j)| {
        let c = l.labels[[i, j]];
        c != percolation::NO_CLUSTER && at_inlet[c as usize] && at_outlet[c as usize]
    })
}

/// Removes the couplings across the periodic edges that the reservoir problem does not have:
/// the x-faces from the last column to the first, and for closed sides the y-faces from the
/// last row to the first.
pub(crate) fn cut_edges(e: &mut [f64], n: &mut [f64], nx: usize, ny: usize, sides: SideEdges) {
    e[(nx - 1) * ny..].fill(0.0);
    if sides == SideEdges::NoFlux {
        for i in 0..nx {
            n[i * ny + ny - 1] = 0.0;
        }
    }
}

/// The ground couplings of the whole grid: the inlet couplings on the first column, the outlet
/// ones on the last.
pub(crate) fn ground(inlet: &[f64], outlet: &[f64], nx: usize, ny: usize) -> Vec<f64> {
    let mut g = vec![0.0; nx * ny];
    g[..ny].copy_from_slice(inlet);
    for (a, &b) in g[(nx - 1) * ny..].iter_mut().zip(outlet) {
        *a += b;
    }
    g
}
