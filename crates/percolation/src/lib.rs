//! Cluster labelling, winding (wrapping) detection and contact-area measures on periodic 2-D
//! grids.
//!
//! Masks are `ndarray` views of booleans with shape `(nx, ny)`, first index = x, periodic in both
//! directions (a torus). Node `(i, j)` touches `(i ± 1, j)` and `(i, j ± 1)` through faces
//! ([`Connectivity::Four`]); [`Connectivity::Eight`] adds the four corner neighbours.
//!
//! # Algorithm
//! [`label`] runs one union–find pass (union by size, path compression: linear time up to the
//! inverse Ackermann factor) over the "forward" edges of every `true` node, so every edge of the
//! periodic lattice is visited exactly once (on a 1- or 2-wide grid the periodic multigraph has
//! self-loops or parallel edges; they are kept, which is what the periodic continuation means).
//!
//! Wrapping is found by carrying, for every node, the integer *image offset* to its parent: in the
//! periodically continued plane, node `v` of the cell is represented by one copy, at image
//! `img(v) ∈ Z²` (in periods `(Lx, Ly)`), and `off(v) = img(parent) − img(v)`. An edge `a → b`
//! that crosses the cell boundary `c ∈ {−1, 0, 1}²` times places `b` at `img(a) + c`. If `a` and
//! `b` already share a root, the closed path (edge, then tree back) has net winding
//! `w = c + off*(b) − off*(a)` (`off*` summed to the root); `w ≠ 0` means the cluster wraps. The
//! windings found this way generate all windings of the cluster (they are the fundamental cycles
//! of the spanning forest the union–find builds), so [`Winding`] — the rank and direction of that
//! group — is exact.
//!
//! # Dual connectivities
//! Contact is labelled 8-connected and fluid (non-contact) 4-connected ([`dual_percolation`]);
//! with this matching pair, on the torus, for each axis exactly one holds: the fluid wraps along
//! the axis, or the contact has a closed path that *cuts* that axis (winds around the cell across
//! it with zero net winding along it). Note that "both phases wrap along x" is possible and
//! legitimate: a contact band along x leaves a fluid band along x, and fluid then flows along x.
//! See [`DualPercolation`].

mod area;
mod constriction;
mod winding;

pub use area::{ContactArea, PERIMETER_CORRECTION, contact_area};
pub use constriction::{
    Bottleneck, Constriction, ConstrictionError, MAX_ESSENTIAL_CHECKS, last_constriction,
};
pub use winding::Winding;

use ndarray::{Array2, ArrayView2};

/// Label of nodes that are `false` in the mask (belong to no cluster).
pub const NO_CLUSTER: u32 = u32::MAX;

/// Which neighbours are connected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Connectivity {
    /// Through faces only: `(i ± 1, j)`, `(i, j ± 1)`.
    Four,
    /// Through faces and corners: the four face neighbours and `(i ± 1, j ± 1)`.
    Eight,
}

/// A grid axis; `X` is the first array index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Axis {
    /// First array index.
    X,
    /// Second array index.
    Y,
}

/// One connected cluster of `true` nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cluster {
    /// Number of nodes.
    pub size: usize,
    /// The cluster contains a closed path with non-zero net winding along x (continued
    /// periodically it extends to infinity along x).
    pub wraps_x: bool,
    /// The same along y.
    pub wraps_y: bool,
    /// All the cluster's windings, up to rank and direction.
    pub winding: Winding,
}

impl Cluster {
    /// [`Cluster::wraps_x`] or [`Cluster::wraps_y`].
    pub fn wraps(&self, axis: Axis) -> bool {
        match axis {
            Axis::X => self.wraps_x,
            Axis::Y => self.wraps_y,
        }
    }

    /// The cluster contains a closed path that cuts the cell across `axis` (see
    /// [`Winding::cuts`]): no path of the complementary phase (with the dual connectivity) can
    /// wrap along `axis`.
    pub fn cuts(&self, axis: Axis) -> bool {
        self.winding.cuts(axis)
    }
}

/// Result of [`label`].
#[derive(Clone, Debug, PartialEq)]
pub struct Labelling {
    /// Shape `(nx, ny)`: the cluster index of each node (an index into `clusters`), or
    /// [`NO_CLUSTER`] for `false` nodes. Clusters are numbered 0, 1, … in the order in which their
    /// first node appears in row-major order (`i` outer, `j` inner).
    pub labels: Array2<u32>,
    /// The clusters, indexed by label.
    pub clusters: Vec<Cluster>,
}

impl Labelling {
    /// Number of clusters.
    pub fn len(&self) -> usize {
        self.clusters.len()
    }

    /// No cluster at all (an all-`false` or empty mask).
    pub fn is_empty(&self) -> bool {
        self.clusters.is_empty()
    }

    /// The cluster containing node `(i, j)`, if the node is `true`.
    /// Panics if `(i, j)` is out of bounds.
    pub fn cluster_at(&self, i: usize, j: usize) -> Option<&Cluster> {
        let l = self.labels[[i, j]];
        (l != NO_CLUSTER).then(|| &self.clusters[l as usize])
    }

    /// Some cluster wraps along `axis`.
    pub fn percolates(&self, axis: Axis) -> bool {
        self.clusters.iter().any(|c| c.wraps(axis))
    }

    /// Some cluster cuts the cell across `axis` (see [`Cluster::cuts`]).
    pub fn cuts(&self, axis: Axis) -> bool {
        self.clusters.iter().any(|c| c.cuts(axis))
    }

    /// Label of the largest cluster (the first one on ties), if any.
    pub fn largest(&self) -> Option<u32> {
        let mut best: Option<(usize, u32)> = None;
        for (l, c) in self.clusters.iter().enumerate() {
            if best.is_none_or(|(s, _)| c.size > s) {
                best = Some((c.size, l as u32));
            }
        }
        best.map(|(_, l)| l)
    }

    /// Mask of the nodes whose cluster satisfies `keep`.
    pub fn mask_where(&self, keep: impl Fn(&Cluster) -> bool) -> Array2<bool> {
        let keep: Vec<bool> = self.clusters.iter().map(keep).collect();
        self.labels.mapv(|l| l != NO_CLUSTER && keep[l as usize])
    }

    /// Mask of the nodes in clusters that wrap along `axis`.
    pub fn wrapping_mask(&self, axis: Axis) -> Array2<bool> {
        self.mask_where(|c| c.wraps(axis))
    }
}

/// Union–find forest with image offsets (see the crate docs).
struct Forest {
    parent: Vec<u32>,
    size: Vec<u32>,
    off: Vec<[i32; 2]>,
}

impl Forest {
    fn new(n: usize) -> Self {
        Forest {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
            off: vec![[0, 0]; n],
        }
    }

    /// Root of `v` and `img(root) − img(v)`; compresses the path.
    fn find(&mut self, v: u32) -> (u32, [i32; 2]) {
        let mut root = v;
        let mut total = [0i32; 2];
        while self.parent[root as usize] != root {
            let o = self.off[root as usize];
            total[0] += o[0];
            total[1] += o[1];
            root = self.parent[root as usize];
        }
        // Second pass: point every node on the path straight at the root.
        let mut u = v;
        let mut rem = total;
        while self.parent[u as usize] != root && u != root {
            let next = self.parent[u as usize];
            let old = self.off[u as usize];
            self.off[u as usize] = rem;
            self.parent[u as usize] = root;
            rem[0] -= old[0];
            rem[1] -= old[1];
            u = next;
        }
        (root, total)
    }

    /// Joins `a` and `b`, where `b` lies at image `img(a) + c`. Returns the net winding of the
    /// closed path if they were already joined (zero if the path does not wind).
    fn union(&mut self, a: u32, b: u32, c: [i32; 2]) -> Option<[i64; 2]> {
        let (ra, oa) = self.find(a);
        let (rb, ob) = self.find(b);
        if ra == rb {
            let w = [
                c[0] as i64 + ob[0] as i64 - oa[0] as i64,
                c[1] as i64 + ob[1] as i64 - oa[1] as i64,
            ];
            return Some(w);
        }
        // img(ra) − img(rb) = oa − c − ob
        let d = [oa[0] - c[0] - ob[0], oa[1] - c[1] - ob[1]];
        let (sa, sb) = (self.size[ra as usize], self.size[rb as usize]);
        if sa >= sb {
            self.parent[rb as usize] = ra;
            self.off[rb as usize] = d;
            self.size[ra as usize] = sa + sb;
        } else {
            self.parent[ra as usize] = rb;
            self.off[ra as usize] = [-d[0], -d[1]];
            self.size[rb as usize] = sa + sb;
        }
        None
    }
}

/// Forward neighbour steps: each undirected lattice edge is generated once from one end.
fn forward_steps(conn: Connectivity) -> &'static [(isize, isize)] {
    match conn {
        Connectivity::Four => &[(1, 0), (0, 1)],
        Connectivity::Eight => &[(1, 0), (0, 1), (1, 1), (1, -1)],
    }
}

/// Labels the connected clusters of `true` nodes of a periodic mask and finds which of them wrap.
///
/// Runs in O(N α(N)) time and O(N) memory for N = nx·ny nodes. An empty mask (nx or ny zero)
/// gives an empty labelling. Panics if the grid has `u32::MAX` nodes or more.
pub fn label(mask: ArrayView2<bool>, conn: Connectivity) -> Labelling {
    let (nx, ny) = mask.dim();
    let n = nx * ny;
    assert!(
        n < u32::MAX as usize,
        "grid of {nx} x {ny} nodes is too large: at most {} nodes allowed",
        u32::MAX - 1
    );
    let mut labels = Array2::from_elem((nx, ny), NO_CLUSTER);
    if n == 0 {
        return Labelling {
            labels,
            clusters: Vec::new(),
        };
    }
    let id = |i: usize, j: usize| (i * ny + j) as u32;
    let mut forest = Forest::new(n);
    // Closed-path windings found on the way: (node, winding). Windings do not depend on the
    // base point, so they are attached to clusters at the end.
    let mut windings: Vec<(u32, [i64; 2])> = Vec::new();
    let (nxi, nyi) = (nx as isize, ny as isize);
    for i in 0..nx {
        for j in 0..ny {
            if !mask[[i, j]] {
                continue;
            }
            for &(dx, dy) in forward_steps(conn) {
                let (ti, tj) = (i as isize + dx, j as isize + dy);
                let (ui, uj) = (ti.rem_euclid(nxi) as usize, tj.rem_euclid(nyi) as usize);
                if !mask[[ui, uj]] {
                    continue;
                }
                let c = [ti.div_euclid(nxi) as i32, tj.div_euclid(nyi) as i32];
                if let Some(w) = forest.union(id(i, j), id(ui, uj), c)
                    && w != [0, 0]
                {
                    windings.push((id(i, j), w));
                }
            }
        }
    }
    let mut root_label = vec![NO_CLUSTER; n];
    let mut clusters: Vec<Cluster> = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            if !mask[[i, j]] {
                continue;
            }
            let (r, _) = forest.find(id(i, j));
            let l = &mut root_label[r as usize];
            if *l == NO_CLUSTER {
                *l = clusters.len() as u32;
                clusters.push(Cluster {
                    size: forest.size[r as usize] as usize,
                    wraps_x: false,
                    wraps_y: false,
                    winding: Winding::None,
                });
            }
            labels[[i, j]] = *l;
        }
    }
    for (v, w) in windings {
        let l = labels[[v as usize / ny, v as usize % ny]] as usize;
        clusters[l].winding = clusters[l].winding.with(w[0], w[1]);
    }
    for c in &mut clusters {
        c.wraps_x = c.winding.wraps(Axis::X);
        c.wraps_y = c.winding.wraps(Axis::Y);
    }
    Labelling { labels, clusters }
}

/// Some cluster of `mask` (with connectivity `conn`) wraps along `axis`.
pub fn percolates(mask: ArrayView2<bool>, conn: Connectivity, axis: Axis) -> bool {
    label(mask, conn).percolates(axis)
}

/// Mask of the nodes of `mask` whose cluster wraps along `axis` (e.g. the fluid nodes that can
/// carry a flux along `axis`: every other fluid pool is a dead pond).
pub fn wrapping_mask(mask: ArrayView2<bool>, conn: Connectivity, axis: Axis) -> Array2<bool> {
    label(mask, conn).wrapping_mask(axis)
}

/// Summary of one phase's clusters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PhaseSummary {
    /// Number of clusters.
    pub n_clusters: usize,
    /// Number of nodes of the phase.
    pub n_nodes: usize,
    /// Some cluster wraps along x.
    pub wraps_x: bool,
    /// Some cluster wraps along y.
    pub wraps_y: bool,
    /// Some cluster cuts the cell across x (closed path of winding `(0, m ≠ 0)`).
    pub cuts_x: bool,
    /// Some cluster cuts the cell across y (closed path of winding `(m ≠ 0, 0)`).
    pub cuts_y: bool,
}

impl PhaseSummary {
    /// Summarises a labelling.
    pub fn of(l: &Labelling) -> Self {
        PhaseSummary {
            n_clusters: l.len(),
            n_nodes: l.clusters.iter().map(|c| c.size).sum(),
            wraps_x: l.percolates(Axis::X),
            wraps_y: l.percolates(Axis::Y),
            cuts_x: l.cuts(Axis::X),
            cuts_y: l.cuts(Axis::Y),
        }
    }

    /// `wraps_x` or `wraps_y`.
    pub fn wraps(&self, axis: Axis) -> bool {
        match axis {
            Axis::X => self.wraps_x,
            Axis::Y => self.wraps_y,
        }
    }

    /// `cuts_x` or `cuts_y`.
    pub fn cuts(&self, axis: Axis) -> bool {
        match axis {
            Axis::X => self.cuts_x,
            Axis::Y => self.cuts_y,
        }
    }
}

/// Which phase percolates along (wins) a given axis under the dual rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Phase {
    /// The non-contact region (4-connected): open channels.
    Fluid,
    /// The contact region (8-connected).
    Contact,
}

/// Both phases of a contact mask under the dual rule of PHYSICS.md: contact 8-connected, fluid
/// (non-contact) 4-connected.
///
/// For each axis exactly one of these holds (planar duality of the 4/8 matching pair, applied on
/// the cylinder that unrolls the axis; checked by the property tests):
/// - the fluid wraps along the axis (a fluid path winds around the cell along it: flow along the
///   axis is possible), [`DualPercolation::fluid_percolates`];
/// - the contact cuts the axis (a closed contact path winds around the cell across it, with zero
///   net winding along it: every flow path along the axis is blocked),
///   [`DualPercolation::contact_blocks`].
///
/// The same holds with the roles swapped (contact wraps along the axis XOR fluid cuts it).
/// "Wraps along x" alone is not exclusive: a contact band along x leaves a fluid band along x,
/// and both wrap along x.
#[derive(Clone, Debug, PartialEq)]
pub struct DualPercolation {
    /// Contact clusters, 8-connected.
    pub contact: Labelling,
    /// Fluid clusters, 4-connected.
    pub fluid: Labelling,
    /// Summary of `contact`.
    pub contact_summary: PhaseSummary,
    /// Summary of `fluid`.
    pub fluid_summary: PhaseSummary,
}

impl DualPercolation {
    /// Some fluid path winds around the cell along `axis`: a flux along `axis` is possible.
    pub fn fluid_percolates(&self, axis: Axis) -> bool {
        self.fluid_summary.wraps(axis)
    }

    /// Some closed contact path cuts the cell across `axis`: no flux along `axis` is possible.
    /// Exactly one of this and [`DualPercolation::fluid_percolates`] holds.
    pub fn contact_blocks(&self, axis: Axis) -> bool {
        self.contact_summary.cuts(axis)
    }

    /// The phase that percolates along `axis` in the sense of the flow problem: `Fluid` if the
    /// fluid wraps along `axis`, `Contact` if the contact blocks it.
    pub fn percolating_phase(&self, axis: Axis) -> Phase {
        if self.fluid_percolates(axis) {
            Phase::Fluid
        } else {
            Phase::Contact
        }
    }

    /// Mask of the fluid nodes that can carry a flux along `axis` (fluid clusters wrapping along
    /// it); all other fluid nodes are dead ponds.
    pub fn conducting_fluid(&self, axis: Axis) -> Array2<bool> {
        self.fluid.wrapping_mask(axis)
    }
}

/// Labels a contact mask under the dual rule (contact 8-connected, fluid 4-connected) and reports
/// both phases' wrapping and cutting along x and y. `contact[[i, j]]` is `true` where the surfaces
/// touch.
pub fn dual_percolation(contact: ArrayView2<bool>) -> DualPercolation {
    let fluid_mask = contact.mapv(|c| !c);
    let c = label(contact, Connectivity::Eight);
    let f = label(fluid_mask.view(), Connectivity::Four);
    DualPercolation {
        contact_summary: PhaseSummary::of(&c),
        fluid_summary: PhaseSummary::of(&f),
        contact: c,
        fluid: f,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    fn mask(rows: &[&str]) -> Array2<bool> {
        // rows[j] is the line at y = j, characters along x.
        let ny = rows.len();
        let nx = rows[0].len();
        Array2::from_shape_fn((nx, ny), |(i, j)| rows[j].as_bytes()[i] == b'#')
    }

    #[test]
    fn empty_and_trivial() {
        let m = Array2::<bool>::from_elem((0, 5), false);
        assert!(label(m.view(), Connectivity::Four).is_empty());
        let m = Array2::<bool>::from_elem((3, 4), false);
        let l = label(m.view(), Connectivity::Eight);
        assert!(l.is_empty() && l.labels.iter().all(|&v| v == NO_CLUSTER));
        let m = Array2::<bool>::from_elem((3, 4), true);
        let l = label(m.view(), Connectivity::Four);
        assert_eq!(l.len(), 1);
        assert_eq!(l.clusters[0].size, 12);
        assert_eq!(l.clusters[0].winding, Winding::Plane);
        let m = Array2::<bool>::from_elem((1, 1), true);
        let l = label(m.view(), Connectivity::Four);
        assert_eq!(l.clusters[0].winding, Winding::Plane);
    }

    #[test]
    fn bands_and_diagonals() {
        let band = mask(&["......", "######", "######", "......"]);
        let l = label(band.view(), Connectivity::Four);
        assert_eq!(l.len(), 1);
        assert_eq!(l.clusters[0].winding, Winding::Line { p: 1, q: 0 });
        assert!(l.clusters[0].wraps_x && !l.clusters[0].wraps_y);
        assert!(l.clusters[0].cuts(Axis::Y) && !l.clusters[0].cuts(Axis::X));

        // A diagonal stripe crossing the seams: 8-connected it wraps along (1, 1), 4-connected
        // it falls apart into single nodes.
        let diag = mask(&["#...", ".#..", "..#.", "...#"]);
        let l8 = label(diag.view(), Connectivity::Eight);
        assert_eq!(l8.len(), 1);
        assert_eq!(l8.clusters[0].winding, Winding::Line { p: 1, q: 1 });
        let l4 = label(diag.view(), Connectivity::Four);
        assert_eq!(l4.len(), 4);
        assert!(!l4.percolates(Axis::X) && !l4.percolates(Axis::Y));
        // Anti-diagonal.
        let anti = mask(&["...#", "..#.", ".#..", "#..."]);
        let l8 = label(anti.view(), Connectivity::Eight);
        assert_eq!(l8.clusters[0].winding, Winding::Line { p: 1, q: -1 });
    }

    #[test]
    fn seam_only_connection() {
        // Two halves joined only through the periodic seam in x: one cluster, no wrapping.
        let m = mask(&["#....#", "#....#", "......"]);
        let l = label(m.view(), Connectivity::Four);
        assert_eq!(l.len(), 1);
        assert_eq!(l.clusters[0].size, 4);
        assert_eq!(l.clusters[0].winding, Winding::None);
        // A staircase of slope 1/2 that closes only through both seams.
        let s = mask(&["##....", "..##..", "....##"]);
        let l8 = label(s.view(), Connectivity::Eight);
        assert_eq!(l8.len(), 1);
        assert_eq!(l8.clusters[0].winding, Winding::Line { p: 1, q: 1 });
        let l4 = label(s.view(), Connectivity::Four);
        assert_eq!(l4.len(), 3);
    }

    #[test]
    fn dual_rule_on_bands() {
        let band = mask(&["......", "######", "######", "......"]);
        let d = dual_percolation(band.view());
        // Both wrap along x (they are parallel bands) ...
        assert!(d.contact_summary.wraps_x && d.fluid_summary.wraps_x);
        // ... fluid flows along x, the contact blocks y.
        assert!(d.fluid_percolates(Axis::X) && !d.contact_blocks(Axis::X));
        assert!(!d.fluid_percolates(Axis::Y) && d.contact_blocks(Axis::Y));
        assert_eq!(d.percolating_phase(Axis::X), Phase::Fluid);
        assert_eq!(d.percolating_phase(Axis::Y), Phase::Contact);
        assert_eq!(
            d.conducting_fluid(Axis::X).iter().filter(|&&b| b).count(),
            12
        );
        assert_eq!(
            d.conducting_fluid(Axis::Y).iter().filter(|&&b| b).count(),
            0
        );
    }

    #[test]
    fn corner_touching_patches_block_under_dual_rule() {
        // Square patches touching at corners (checkerboard of 2x2 blocks): contact 8-connected
        // wraps both ways, fluid 4-connected is cut into pools.
        let m = mask(&["##..", "##..", "..##", "..##"]);
        let d = dual_percolation(m.view());
        assert_eq!(d.contact.len(), 1);
        assert_eq!(d.contact.clusters[0].winding, Winding::Plane);
        assert_eq!(d.fluid.len(), 2);
        assert!(!d.fluid_percolates(Axis::X) && !d.fluid_percolates(Axis::Y));
        assert!(d.contact_blocks(Axis::X) && d.contact_blocks(Axis::Y));
        assert_eq!(d.fluid.largest(), Some(0));
    }
}
