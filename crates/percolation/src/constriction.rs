//! The last constriction of a gap field: the bottleneck of the widest fluid path around the cell.
//!
//! # Object
//! Fluid is where the gap `g > 0`, 4-connected and periodic (the project's convention, see the
//! crate docs). For a threshold `t`, the fluid `{g ≥ t}` winds around the cell along an axis for
//! all `t` up to the *maximin gap* `g*`: the largest, over closed fluid paths with non-zero net
//! winding along the axis, of the smallest gap on the path. The node where that minimum sits is
//! the last constriction: closing it (lowering its gap, as a load increase does) is what stops the
//! percolation first.
//!
//! # Method (exact)
//! Kruskal-style widest path: nodes with `g > 0` are switched on in order of decreasing gap (ties
//! by row-major index), each joined to its switched-on face neighbours in the union–find of the
//! crate root, which carries the image offsets and therefore the winding of every cluster. The
//! first node after which a cluster winds along the axis is the bottleneck; its gap is `g*`.
//! Cost `O(N log N)` for the sort plus near-linear union–find, `N = nx·ny`.
//!
//! # Ties
//! On symmetric fields (the lattices) several nodes share the level `g*` up to rounding of the
//! samples, and which of them completes the winding is an accident of the order. So the result
//! also lists every *tied* node — `|g − g*| ≤ δ = tie_tolerance · max g` — that belongs to the
//! cluster of `{g ≥ g* − δ}` winding along the axis, with two flags:
//! - *junction*: the node's tie cluster (4-connected tied nodes) joins two clusters of the
//!   strictly wider fluid `U = {g > g* + δ}` or closes a new winding of one — a pass. Needed
//!   because a level set can contain whole lines: with `g = c − h` the level through the saddles
//!   of all three lattices is a set of straight lines (for the square model the diagonals
//!   `x ± y = λ/2`), so every node on them is tied; on the square lattice only the crossings —
//!   the saddles — join troughs. On the triangular and hexagonal lattices the lines include the
//!   grid rows `y = λ/2, 3λ/2`, 4-connected tie clusters through the saddles that do join
//!   troughs: there a 4-connected path at the maximin level must run along them (from the
//!   saddles whose channel is at 30° to x, the x step lies exactly on the level line), so the
//!   junctions are the saddles plus those rows. [`Constriction::bottlenecks`] are the junctions.
//! - *essential*: closing the node alone stops the winding. On the square lattice along x this
//!   singles out the saddle whose channel runs along x; on the triangular and hexagonal lattices
//!   no single saddle is essential (the channels form a network).
//!
//! The junction flags take one linear pass over the tied nodes after building the union–find of
//! `U`. The essential flags cost one labelling per tied node and are only computed for at most
//! [`MAX_ESSENTIAL_CHECKS`] tied nodes. On a generic (random) field there are no ties: the only tied
//! node is the completing one, a junction and essential.

use crate::{Axis, Connectivity, Forest, Winding, label};
use ndarray::{Array2, ArrayView2};
use std::fmt;

/// Tied nodes beyond this number get no essential flag (one labelling each).
pub const MAX_ESSENTIAL_CHECKS: usize = 256;

/// Invalid input to [`last_constriction`].
#[derive(Clone, Debug, PartialEq)]
pub enum ConstrictionError {
    /// A gap value is NaN or infinite.
    NonFinite {
        /// First index.
        i: usize,
        /// Second index.
        j: usize,
        /// The value.
        value: f64,
    },
    /// The cell size must be positive and finite.
    CellSize {
        /// Cell side along x.
        lx: f64,
        /// Cell side along y.
        ly: f64,
    },
    /// `tie_tolerance` must lie in [0, 1e-3].
    TieTolerance(f64),
}

impl fmt::Display for ConstrictionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConstrictionError::NonFinite { i, j, value } => {
                write!(f, "gap value {value} at index ({i}, {j}) is not finite")
            }
            ConstrictionError::CellSize { lx, ly } => {
                write!(f, "cell size {lx} x {ly} must be positive and finite")
            }
            ConstrictionError::TieTolerance(t) => {
                write!(f, "tie_tolerance {t} must lie in [0, 1e-3]")
            }
        }
    }
}

impl std::error::Error for ConstrictionError {}

/// One node of the gap field at the maximin level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bottleneck {
    /// First index (x).
    pub i: usize,
    /// Second index (y).
    pub j: usize,
    /// Position `x = i lx / nx` (unshifted grid; add the caller's sub-grid shift).
    pub x: f64,
    /// Position `y = j ly / ny`.
    pub y: f64,
    /// The local gap.
    pub gap: f64,
    /// The node's tie cluster (its 4-connected set of tied nodes) joins two different clusters
    /// of the strictly wider fluid `{g > g* + δ}`, or closes a new winding of one: the node is
    /// a pass between wider regions, not a point on the rim of one (see the module docs).
    /// Always computed (linear time); `None` only for a completing node outside the tied list,
    /// which does not happen.
    pub junction: Option<bool>,
    /// Closing this node alone stops the winding along the axis; `None` when not checked (more
    /// than [`MAX_ESSENTIAL_CHECKS`] tied nodes).
    pub essential: Option<bool>,
}

/// The last constriction along one axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Constriction {
    /// The axis along which the fluid winds.
    pub axis: Axis,
    /// The maximin gap `g*` (the gap of [`Constriction::completing`]).
    pub gap: f64,
    /// The node whose switching-on completed the winding (decreasing gap, ties by row-major
    /// index).
    pub completing: Bottleneck,
    /// All tied nodes of the winding cluster at the maximin level (see the module docs), in
    /// row-major order; contains `completing`.
    pub tied: Vec<Bottleneck>,
}

impl Constriction {
    /// The tied nodes whose closing alone stops the winding.
    pub fn essential(&self) -> impl Iterator<Item = &Bottleneck> {
        self.tied.iter().filter(|b| b.essential == Some(true))
    }

    /// The bottlenecks: the tied nodes that are junctions (or not checked), the passes at the
    /// maximin level. On the square lattice with `g = c − h` these are exactly the saddle nodes;
    /// on the triangular and hexagonal ones the saddles plus the tied rows through them (module
    /// docs). On a generic field, the completing node alone.
    pub fn bottlenecks(&self) -> impl Iterator<Item = &Bottleneck> {
        self.tied.iter().filter(|b| b.junction != Some(false))
    }
}

/// Finds the last constriction of the gap field `gap` (shape `(nx, ny)`, first index x, periodic
/// `lx × ly` cell) for fluid winding along `axis`; `None` if the fluid `{g > 0}` does not wind
/// along it. `tie_tolerance` (relative to the largest gap, in [0, 1e-3]) decides which nodes
/// count as tied with the bottleneck; `1e-12` absorbs rounding of sampled trigonometric fields.
/// For computed (deformed) gaps use 0: their ties are not structural, and near L_c the
/// bottleneck's gap can itself fall below any tolerance relative to the largest gap, which would
/// then tie it with every nearly closed node.
pub fn last_constriction(
    gap: ArrayView2<f64>,
    lx: f64,
    ly: f64,
    axis: Axis,
    tie_tolerance: f64,
) -> Result<Option<Constriction>, ConstrictionError> {
    if !(lx.is_finite() && ly.is_finite() && lx > 0.0 && ly > 0.0) {
        return Err(ConstrictionError::CellSize { lx, ly });
    }
    if !(0.0..=1e-3).contains(&tie_tolerance) {
        return Err(ConstrictionError::TieTolerance(tie_tolerance));
    }
    if let Some(((i, j), &value)) = gap.indexed_iter().find(|(_, v)| !v.is_finite()) {
        return Err(ConstrictionError::NonFinite { i, j, value });
    }
    let (nx, ny) = gap.dim();
    let Some(v) = completing_node(gap, axis) else {
        return Ok(None);
    };
    let g_star = gap[[v / ny, v % ny]];
    let g_max = gap.iter().copied().fold(0.0, f64::max);
    let delta = tie_tolerance * g_max;
    let node = |i: usize, j: usize, junction: Option<bool>, essential: Option<bool>| Bottleneck {
        i,
        j,
        x: i as f64 * lx / nx as f64,
        y: j as f64 * ly / ny as f64,
        gap: gap[[i, j]],
        junction,
        essential,
    };
    let tied = tied_nodes(gap, axis, g_star, delta);
    let junctions = junctions(gap, g_star, delta);
    let check = tied.len() <= MAX_ESSENTIAL_CHECKS;
    let mut fluid = gap.mapv(|g| g > 0.0 && g >= g_star - delta);
    let tied: Vec<Bottleneck> = tied
        .into_iter()
        .map(|(i, j)| {
            let essential = check.then(|| {
                fluid[[i, j]] = false;
                let stops = !label(fluid.view(), Connectivity::Four).percolates(axis);
                fluid[[i, j]] = true;
                stops
            });
            let junction = Some(junctions[[i, j]]);
            node(i, j, junction, essential)
        })
        .collect();
    let (ci, cj) = (v / ny, v % ny);
    let completing = tied
        .iter()
        .find(|b| (b.i, b.j) == (ci, cj))
        .copied()
        .unwrap_or_else(|| node(ci, cj, None, None));
    Ok(Some(Constriction {
        axis,
        gap: g_star,
        completing,
        tied,
    }))
}

/// The four face neighbours of node `(i, j)` on the periodic `nx × ny` grid, each with the
/// number of cell boundaries crossed `c ∈ {−1, 0, 1}²` (the neighbour's image offset).
fn neighbours(i: usize, j: usize, nx: usize, ny: usize) -> [((usize, usize), [i32; 2]); 4] {
    let (nxi, nyi) = (nx as isize, ny as isize);
    [(1isize, 0isize), (-1, 0), (0, 1), (0, -1)].map(|(dx, dy)| {
        let (ti, tj) = (i as isize + dx, j as isize + dy);
        (
            (ti.rem_euclid(nxi) as usize, tj.rem_euclid(nyi) as usize),
            [ti.div_euclid(nxi) as i32, tj.div_euclid(nyi) as i32],
        )
    })
}

/// A union–find over switched-on nodes that keeps the winding content of every cluster.
struct Growing {
    nx: usize,
    ny: usize,
    on: Vec<bool>,
    forest: Forest,
    /// Winding content of each root.
    winding: Vec<Winding>,
}

impl Growing {
    fn new(nx: usize, ny: usize) -> Self {
        let n = nx * ny;
        assert!(
            n < u32::MAX as usize,
            "grid of {nx} x {ny} nodes is too large: at most {} nodes allowed",
            u32::MAX - 1
        );
        Growing {
            nx,
            ny,
            on: vec![false; n],
            forest: Forest::new(n),
            winding: vec![Winding::None; n],
        }
    }

    /// Switches node `v` on, joins it to its switched-on face neighbours and returns the winding
    /// content of its cluster.
    fn switch_on(&mut self, v: u32) -> Winding {
        let (i, j) = (v as usize / self.ny, v as usize % self.ny);
        self.on[v as usize] = true;
        let mut w = self.winding[v as usize];
        for ((ui, uj), c) in neighbours(i, j, self.nx, self.ny) {
            let u = (ui * self.ny + uj) as u32;
            if !self.on[u as usize] {
                continue;
            }
            let (ra, _) = self.forest.find(v);
            let (rb, _) = self.forest.find(u);
            let merged = self.winding[ra as usize].merge(self.winding[rb as usize]);
            w = match self.forest.union(v, u, c) {
                Some(cycle) => merged.with(cycle[0], cycle[1]),
                None => merged,
            };
            let (r, _) = self.forest.find(v);
            self.winding[r as usize] = w;
        }
        w
    }
}

/// The flat index of the node whose switching-on (by decreasing gap) first makes a cluster wind
/// along `axis`, if the fluid winds at all.
fn completing_node(gap: ArrayView2<f64>, axis: Axis) -> Option<usize> {
    let (nx, ny) = gap.dim();
    let flat: Vec<f64> = gap.iter().copied().collect();
    let mut order: Vec<u32> = (0..flat.len() as u32)
        .filter(|&v| flat[v as usize] > 0.0)
        .collect();
    // Decreasing gap, ties by index: a stable sort of a row-major list.
    order.sort_by(|&a, &b| flat[b as usize].total_cmp(&flat[a as usize]));
    let mut grid = Growing::new(nx, ny);
    order
        .into_iter()
        .find(|&v| grid.switch_on(v).wraps(axis))
        .map(|v| v as usize)
}

/// Marks the tied nodes (`|g − g*| ≤ δ`, `g > 0`) whose tie cluster is a junction of the wider
/// fluid `U = {g > g* + δ}`: it touches two or more clusters of `U`, or adding it to the one it
/// touches changes that cluster's winding. Linear time: each tie cluster is walked once,
/// placing its nodes in the periodically continued plane relative to its first node; every
/// second route to a node or to the touched root is a closed path whose winding is tested.
fn junctions(gap: ArrayView2<f64>, g_star: f64, delta: f64) -> Array2<bool> {
    let (nx, ny) = gap.dim();
    let tie = gap.mapv(|g| g > 0.0 && (g - g_star).abs() <= delta);
    let mut wide = Growing::new(nx, ny);
    for (v, &g) in gap.iter().enumerate() {
        if g > g_star + delta {
            wide.switch_on(v as u32);
        }
    }
    let mut junction = Array2::from_elem((nx, ny), false);
    // Image position of each visited tie node relative to its cluster's first node.
    let mut pos: Vec<Option<[i64; 2]>> = vec![None; nx * ny];
    for start in 0..nx * ny {
        if !tie[[start / ny, start % ny]] || pos[start].is_some() {
            continue;
        }
        pos[start] = Some([0, 0]);
        let mut members = vec![start];
        let mut stack = vec![start];
        // The touched root, the image of that root as first reached, and the content.
        let mut root: Option<(u32, [i64; 2])> = None;
        let mut content = Winding::None;
        let mut several = false;
        while let Some(a) = stack.pop() {
            let pa = pos[a].expect("visited");
            for ((ui, uj), c) in neighbours(a / ny, a % ny, nx, ny) {
                let u = ui * ny + uj;
                let pu = [pa[0] + c[0] as i64, pa[1] + c[1] as i64];
                if tie[[ui, uj]] {
                    match pos[u] {
                        None => {
                            pos[u] = Some(pu);
                            members.push(u);
                            stack.push(u);
                        }
                        Some(q) => content = content.with(pu[0] - q[0], pu[1] - q[1]),
                    }
                } else if wide.on[u] {
                    let (r, off) = wide.forest.find(u as u32);
                    let img = [pu[0] + off[0] as i64, pu[1] + off[1] as i64];
                    match root {
                        None => root = Some((r, img)),
                        Some((r0, _)) if r0 != r => several = true,
                        Some((_, first)) => {
                            content = content.with(img[0] - first[0], img[1] - first[1])
                        }
                    }
                }
            }
        }
        // Without a touched root the tie cluster is a junction if it winds by itself.
        let before = root.map_or(Winding::None, |(r, _)| wide.winding[r as usize]);
        let is_junction = several || before.merge(content) != before;
        for v in members {
            junction[[v / ny, v % ny]] = is_junction;
        }
    }
    junction
}

/// The nodes with `|g − g*| ≤ δ` in the clusters of `{g ≥ g* − δ, g > 0}` winding along `axis`,
/// row-major.
fn tied_nodes(gap: ArrayView2<f64>, axis: Axis, g_star: f64, delta: f64) -> Vec<(usize, usize)> {
    let fluid: Array2<bool> = gap.mapv(|g| g > 0.0 && g >= g_star - delta);
    let winding = label(fluid.view(), Connectivity::Four).wrapping_mask(axis);
    gap.indexed_iter()
        .filter(|&((i, j), &g)| winding[[i, j]] && (g - g_star).abs() <= delta)
        .map(|(ij, _)| ij)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::percolates;
    use std::f64::consts::PI;

    /// xorshift64*: a tiny deterministic generator for test fields.
    struct Rng(u64);
    impl Rng {
        fn uniform(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The maximin gap by brute force: the largest threshold `t` among the gap values at which
    /// the fluid `{g ≥ t, g > 0}` still winds along `axis`.
    fn brute_force(gap: &Array2<f64>, axis: Axis) -> Option<f64> {
        let mut levels: Vec<f64> = gap.iter().copied().filter(|&g| g > 0.0).collect();
        levels.sort_by(|a, b| b.total_cmp(a));
        levels.into_iter().find(|&t| {
            let m = gap.mapv(|g| g > 0.0 && g >= t);
            percolates(m.view(), Connectivity::Four, axis)
        })
    }

    #[test]
    fn random_fields_match_thresholding() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for trial in 0..300 {
            let (nx, ny) = (6, 4 + trial % 3);
            // A third of the nodes in contact (g = 0), the rest random gaps.
            let gap = Array2::from_shape_fn((nx, ny), |_| {
                let u = rng.uniform();
                if u < 0.33 { 0.0 } else { u }
            });
            for axis in [Axis::X, Axis::Y] {
                let found = last_constriction(gap.view(), 1.0, 1.0, axis, 0.0).unwrap();
                let expected = brute_force(&gap, axis);
                assert_eq!(found.as_ref().map(|c| c.gap), expected, "trial {trial}");
                let Some(c) = found else { continue };
                // Continuous random gaps have no ties: the completing node is the only tied
                // node, and closing it stops the winding (nothing above g* winds).
                assert_eq!(c.tied.len(), 1);
                assert_eq!(c.tied[0], c.completing);
                assert_eq!(c.completing.essential, Some(true));
                assert_eq!(c.completing.junction, Some(true));
                assert_eq!(gap[[c.completing.i, c.completing.j]], c.gap);
            }
        }
    }

    /// A channel along x (rows 3..=5 of a 12 × 10 grid, random gaps in [0.5, 1)) narrowed at
    /// column 7 to gaps 0.3, 0.2, 0.25; contact elsewhere except a wide pool (gap 5) that winds
    /// along y only. The widest x path passes (7, 3) with gap 0.3.
    #[test]
    fn planted_bottleneck() {
        let mut rng = Rng(42);
        let mut gap = Array2::from_shape_fn((12, 10), |(_, j)| {
            if (3..=5).contains(&j) {
                0.5 + 0.5 * rng.uniform()
            } else {
                0.0
            }
        });
        for (j, g) in [(3, 0.3), (4, 0.2), (5, 0.25)] {
            gap[[7, j]] = g;
        }
        for j in 0..10 {
            gap[[1, j]] = 5.0;
        }
        let c = last_constriction(gap.view(), 3.0, 2.5, Axis::X, 1e-12)
            .unwrap()
            .unwrap();
        assert_eq!((c.completing.i, c.completing.j), (7, 3));
        assert_eq!(c.gap, 0.3);
        assert_eq!((c.completing.x, c.completing.y), (7.0 * 0.25, 3.0 * 0.25));
        assert_eq!(c.tied, vec![c.completing]);
        assert_eq!(c.completing.essential, Some(true));
        // Along y the pool column is the widest path: every node of it is tied and essential.
        let c = last_constriction(gap.view(), 3.0, 2.5, Axis::Y, 1e-12)
            .unwrap()
            .unwrap();
        assert_eq!(c.gap, 5.0);
        assert_eq!(c.tied.len(), 10);
        assert!(c.tied.iter().all(|b| b.i == 1 && b.essential == Some(true)));
        // The column is a tie cluster that winds by itself: a junction, though no wider fluid
        // exists.
        assert_eq!(c.bottlenecks().count(), 10);
        // Closing the narrowing stops the x flow.
        for j in 3..=5 {
            gap[[7, j]] = 0.0;
        }
        assert_eq!(
            last_constriction(gap.view(), 3.0, 2.5, Axis::X, 0.0).unwrap(),
            None
        );
    }

    /// The junction flags against their definition evaluated by labelling: for every tie
    /// cluster, count the clusters of `U` it touches, and if one, compare that cluster's winding
    /// with the winding after adding the tie cluster. Quantised random gaps make many ties.
    #[test]
    fn junctions_match_labelling() {
        let mut rng = Rng(7);
        let mut seen = [0usize; 2];
        for trial in 0..400 {
            let (nx, ny) = (5 + trial % 3, 6);
            let gap = Array2::from_shape_fn((nx, ny), |_| (rng.uniform() * 4.0).floor());
            let g_star = 1.0 + (trial % 3) as f64;
            let fast = junctions(gap.view(), g_star, 0.0);
            let tie = gap.mapv(|g| g > 0.0 && g == g_star);
            let mut wide = gap.mapv(|g| g > g_star);
            let ties = label(tie.view(), Connectivity::Four);
            let base = label(wide.view(), Connectivity::Four);
            for t in 0..ties.len() as u32 {
                let members: Vec<(usize, usize)> = ties
                    .labels
                    .indexed_iter()
                    .filter(|&(_, &l)| l == t)
                    .map(|(ij, _)| ij)
                    .collect();
                let mut touched: Vec<u32> = Vec::new();
                for &(i, j) in &members {
                    for ((ui, uj), _) in neighbours(i, j, nx, ny) {
                        let l = base.labels[[ui, uj]];
                        if l != crate::NO_CLUSTER && !touched.contains(&l) {
                            touched.push(l);
                        }
                    }
                }
                let before = touched
                    .first()
                    .map_or(Winding::None, |&l| base.clusters[l as usize].winding);
                for &(i, j) in &members {
                    wide[[i, j]] = true;
                }
                let after = label(wide.view(), Connectivity::Four);
                for &(i, j) in &members {
                    wide[[i, j]] = false;
                }
                let (i, j) = members[0];
                let expected =
                    touched.len() > 1 || after.cluster_at(i, j).map(|c| c.winding) != Some(before);
                for &(i, j) in &members {
                    assert_eq!(fast[[i, j]], expected, "trial {trial}, node ({i}, {j})");
                }
                seen[expected as usize] += 1;
            }
        }
        // Both outcomes occur often (the test is not vacuous).
        assert!(seen[0] > 100 && seen[1] > 100, "{seen:?}");
    }

    #[test]
    fn bad_input_is_named() {
        let mut gap = Array2::from_elem((4, 4), 1.0);
        let e = last_constriction(gap.view(), 0.0, 1.0, Axis::X, 0.0).unwrap_err();
        assert!(e.to_string().contains("cell size 0 x 1"));
        let e = last_constriction(gap.view(), 1.0, 1.0, Axis::X, 0.1).unwrap_err();
        assert!(e.to_string().contains("tie_tolerance 0.1"));
        gap[[2, 3]] = f64::NAN;
        let e = last_constriction(gap.view(), 1.0, 1.0, Axis::X, 0.0).unwrap_err();
        assert!(e.to_string().contains("(2, 3)"));
    }

    /// Heights of the square and triangular models (PHYSICS.md), written out independently of the
    /// surface crate, sampled at `x_i = i lx / n`, `y_j = j ly / n`.
    fn lattice_heights(triangular: bool, n: usize) -> (Array2<f64>, f64, f64) {
        if triangular {
            let (lx, ly) = (4.0 / 3f64.sqrt(), 2.0);
            let a = (2.0f64 / 3.0).sqrt();
            let h = Array2::from_shape_fn((n, n), |(i, j)| {
                let (x, y) = (i as f64 * lx / n as f64, j as f64 * ly / n as f64);
                a * (1.5
                    + 2.0 * (3f64.sqrt() * PI * x).cos() * (PI * y).cos()
                    + (2.0 * PI * y).cos())
            });
            (h, lx, ly)
        } else {
            let h = Array2::from_shape_fn((n, n), |(i, j)| {
                let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                2.0 + (2.0 * PI * x).cos() + (2.0 * PI * y).cos()
            });
            (h, 1.0, 1.0)
        }
    }

    /// Grid nodes of the triangular model's saddles (PHYSICS.md: (λ/√3, 0), (λ/(2√3), λ/2),
    /// and their images under the lattice of maxima, spanned by (2λ/√3, 0) and (λ/√3, λ)). On an
    /// n × n grid of the 4λ/√3 × 2λ cell these are index offsets (n/4, 0), (n/8, n/4),
    /// (−n/8, n/4) (the third bond midpoint) plus (n/2, 0) and (n/4, n/2).
    fn kagome_nodes(n: usize) -> Vec<(usize, usize)> {
        let n = n as isize;
        let mut v: Vec<(usize, usize)> = Vec::new();
        for (mi, mj) in [(n / 4, 0), (n / 8, n / 4), (-n / 8, n / 4)] {
            for a in 0..4 {
                for b in 0..4 {
                    let i = (mi + a * n / 2 + b * n / 4).rem_euclid(n) as usize;
                    let j = (mj + b * n / 2).rem_euclid(n) as usize;
                    if !v.contains(&(i, j)) {
                        v.push((i, j));
                    }
                }
            }
        }
        v.sort();
        v
    }

    /// With `g = c − h` (heights standing in for the gap near L_c, `c` a little above the saddle
    /// height) the maximin gap is `c − h_s` and the bottlenecks (junctions) are exactly the
    /// saddle nodes.
    #[test]
    fn lattice_saddles_are_found() {
        let n = 32;
        // Square: saddles at (λ/2, 0) and (0, λ/2), height 2; along x the channel through
        // (0, λ/2) is the essential one, (λ/2, 0) is tied but runs across the flow.
        let (h, lx, ly) = lattice_heights(false, n);
        let g = h.mapv(|h| (2.1 - h).max(0.0));
        for (axis, along, across) in [
            (Axis::X, (0, n / 2), (n / 2, 0)),
            (Axis::Y, (n / 2, 0), (0, n / 2)),
        ] {
            let c = last_constriction(g.view(), lx, ly, axis, 1e-12)
                .unwrap()
                .unwrap();
            assert!((c.gap - 0.1).abs() < 1e-14, "{}", c.gap);
            // The level line h = 2 through the saddles is the pair of straight diagonals
            // x ± y = λ/2 (cos 2πx + cos 2πy = 0): every node on them is tied with the saddles
            // (to rounding), and only the saddle along the flow is essential.
            let nodes: Vec<_> = c.tied.iter().map(|b| (b.i, b.j)).collect();
            assert!(nodes.contains(&along) && nodes.contains(&across));
            assert!(
                nodes
                    .iter()
                    .all(|&(i, j)| (i + j) % n == n / 2 || (i + n - j) % n == n / 2)
            );
            assert_eq!(nodes.len(), 2 * n - 2); // the diagonals cross at the two saddles
            let ess: Vec<_> = c.essential().map(|b| (b.i, b.j)).collect();
            assert_eq!(ess, vec![along]);
            let mut passes: Vec<_> = c.bottlenecks().map(|b| (b.i, b.j)).collect();
            passes.sort();
            let mut saddles = vec![along, across];
            saddles.sort();
            assert_eq!(passes, saddles);
        }
        // Triangular (saddle height √(1/6)) and hexagonal (√(27/2) − √(1/6)): the saddles are
        // the same 12 nodes; the channels form a network, no single saddle is essential. The
        // level lines through the saddles include the grid rows y = λ/2 and 3λ/2 (h_t = √(1/6)
        // on them exactly): those rows are 4-connected tie clusters joining troughs, so the
        // maximin is degenerate along them and they count as passes too. This is forced by the
        // grid: at the saddles (λ/(2√3), λ/2) the channel runs at 30° to x, and the x step lies
        // exactly on the level line (curvatures (3, −1)·k²/2 → −¾·1 + ¼·3 = 0), so a 4-connected
        // path at the maximin level leaves those saddles only along the rows.
        let (ht, lx, ly) = lattice_heights(true, n);
        let hs_t = (1.0f64 / 6.0).sqrt();
        let hexagonal = ht.mapv(|h| 13.5f64.sqrt() - h);
        let hs_h = 13.5f64.sqrt() - hs_t;
        for (h, hs) in [(&ht, hs_t), (&hexagonal, hs_h)] {
            let g = h.mapv(|h| (hs + 0.05 - h).max(0.0));
            for axis in [Axis::X, Axis::Y] {
                let c = last_constriction(g.view(), lx, ly, axis, 1e-12)
                    .unwrap()
                    .unwrap();
                assert!((c.gap - 0.05).abs() < 1e-13, "{}", c.gap);
                let passes: Vec<_> = c.bottlenecks().map(|b| (b.i, b.j)).collect();
                let saddles = kagome_nodes(n);
                assert!(saddles.iter().all(|s| passes.contains(s)));
                assert!(
                    passes
                        .iter()
                        .all(|&(i, j)| saddles.contains(&(i, j)) || j % (n / 2) == n / 4)
                );
                assert_eq!(c.essential().count(), 0);
            }
        }
    }
}
