//! Direct solver for the coarsest multigrid level: symmetric Gaussian elimination in
//! Laplacian form ("GTH" style), with one node per connected component held at zero.
//!
//! The matrix is given by its couplings `s_ij` (off-diagonal entries `−s_ij`, zero row sums). The
//! Schur complement of a Laplacian is again a Laplacian, so elimination only updates couplings,
//! `s_ij += s_ik s_kj / d_k`, and every pivot is recomputed as the sum of the remaining couplings
//! of its node, `d_k = Σ_j s_kj`, never as a difference. With non-negative couplings all
//! arithmetic is on positive numbers, so a pond joined to the rest by a throat whose conductance
//! is 10^-30 of its own still gets a pivot with full relative accuracy (a plain Cholesky would
//! compute it as `1 − (1 − 10^-30)` = rounding noise).
//!
//! The operator is singular (constants on each connected component); the component's
//! strongest node is held at zero, which gives the solution of a consistent system with that
//! gauge (a symmetric generalised inverse: the multigrid cycle stays symmetric).

/// Grid index of an unknown that is not a grid node: the grounded outside (a reservoir held
/// at zero). Its component is pinned at it, its right-hand side is zero and its value is not
/// written back.
pub(crate) const OUTSIDE: usize = usize::MAX;

/// Factorised coarsest-level operator.
#[derive(Clone, Debug)]
pub(crate) struct DenseElimination {
    /// Grid index of each unknown of the dense system.
    nodes: Vec<usize>,
    /// Elimination order (positions in `nodes`); the pinned nodes are not in it.
    order: Vec<usize>,
    /// For each eliminated position `k` (in `order`), the multipliers `s_ik / d_k` for all later
    /// positions `i` (row of length `m`), and the pivot.
    mult: Vec<Vec<f64>>,
    pivot: Vec<f64>,
}

impl DenseElimination {
    /// Factorises the operator with dense couplings `s` (size `m × m`, symmetric, zero diagonal)
    /// between the unknowns, which sit at grid indices `nodes`.
    pub fn new(nodes: Vec<usize>, mut s: Vec<Vec<f64>>) -> Self {
        let m = nodes.len();
        // Connected components (through non-zero couplings) and one pin per component: the
        // node with the largest total coupling.
        let mut comp = vec![usize::MAX; m];
        let mut pins = Vec::new();
        for start in 0..m {
            if comp[start] != usize::MAX {
                continue;
            }
            let c = pins.len();
            let mut stack = vec![start];
            comp[start] = c;
            let mut best = (start, f64::NEG_INFINITY);
            while let Some(p) = stack.pop() {
                // The outside node, if in this component, is its pin.
                let d: f64 = if nodes[p] == OUTSIDE {
                    f64::INFINITY
                } else {
                    s[p].iter().map(|v| v.abs()).sum()
                };
                if d > best.1 {
                    best = (p, d);
                }
                for q in 0..m {
                    if s[p][q] != 0.0 && comp[q] == usize::MAX {
                        comp[q] = c;
                        stack.push(q);
                    }
                }
            }
            pins.push(best.0);
        }
        let mut is_pin = vec![false; m];
        for &p in &pins {
            is_pin[p] = true;
        }
        let order: Vec<usize> = (0..m).filter(|&p| !is_pin[p]).collect();
        let mut alive = vec![true; m];
        let mut mult = Vec::with_capacity(order.len());
        let mut pivot = Vec::with_capacity(order.len());
        for &k in &order {
            alive[k] = false;
            let d: f64 = (0..m).filter(|&j| alive[j]).map(|j| s[k][j]).sum();
            let mut row = vec![0.0; m];
            if d > 0.0 {
                for i in 0..m {
                    if alive[i] && s[k][i] != 0.0 {
                        row[i] = s[k][i] / d;
                    }
                }
                // Schur complement: couplings between the remaining neighbours of k.
                let nbrs: Vec<usize> = (0..m).filter(|&i| row[i] != 0.0).collect();
                for (a, &i) in nbrs.iter().enumerate() {
                    for &j in &nbrs[a + 1..] {
                        let add = s[k][i] * row[j];
                        s[i][j] += add;
                        s[j][i] += add;
                    }
                }
            }
            mult.push(row);
            pivot.push(d);
        }
        DenseElimination {
            nodes,
            order,
            mult,
            pivot,
        }
    }

    /// Solves `A x = b` for the unknowns (reads `b` and writes `x` at the grid indices); the
    /// pinned nodes get zero.
    pub fn solve(&self, b: &[f64], x: &mut [f64]) {
        let m = self.nodes.len();
        let mut y: Vec<f64> = self
            .nodes
            .iter()
            .map(|&g| if g == OUTSIDE { 0.0 } else { b[g] })
            .collect();
        // Forward: eliminating k adds (s_ik / d_k) y_k to every later i.
        for (t, &k) in self.order.iter().enumerate() {
            let yk = y[k];
            if yk != 0.0 {
                for i in 0..m {
                    let l = self.mult[t][i];
                    if l != 0.0 {
                        y[i] += l * yk;
                    }
                }
            }
        }
        let mut sol = vec![0.0; m];
        for (t, &k) in self.order.iter().enumerate().rev() {
            let d = self.pivot[t];
            if d > 0.0 {
                let acc: f64 = (0..m).map(|i| self.mult[t][i] * sol[i]).sum();
                sol[k] = y[k] / d + acc;
            }
        }
        for (p, &g) in self.nodes.iter().enumerate() {
            if g != OUTSIDE {
                x[g] = sol[p];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_singular_laplacian_with_a_weak_link() {
        // Two triangles joined by a 1e-30 link, plus an isolated pair.
        let m = 8;
        let mut s = vec![vec![0.0; m]; m];
        let mut link = |a: usize, b: usize, c: f64| {
            s[a][b] = c;
            s[b][a] = c;
        };
        link(0, 1, 1.0);
        link(1, 2, 2.0);
        link(0, 2, 0.5);
        link(3, 4, 1.5);
        link(4, 5, 1.0);
        link(3, 5, 1.0);
        link(2, 3, 1e-30);
        link(6, 7, 3.0);
        let a = s.clone();
        let nodes: Vec<usize> = (0..m).collect();
        let f = DenseElimination::new(nodes, s);
        // Consistent right-hand side: the weak link carries a flux 1e-30 from node 2 to node 3,
        // so the pressure drops by exactly 1 across it. A plain Cholesky factorisation would
        // compute the pivot of the weak link as 1 - (1 - 1e-30), i.e. as rounding noise.
        let mut b = vec![0.0; m];
        b[0] = 1e-30;
        b[5] = -1e-30;
        b[6] = 0.25;
        b[7] = -0.25;
        let mut x = vec![0.0; m];
        f.solve(&b, &mut x);
        let drop = x[2] - x[3];
        assert!((drop - 1.0).abs() < 1e-12, "{drop}");
        // Residuals on the pinned side (values near 0, so representable to 1e-46) and in the
        // separate pair. The far triangle sits near -1, where a residual of 1e-30 is below the
        // resolution of its values, so it is checked through the drop above.
        for p in [0, 1, 2, 6, 7] {
            let ax: f64 = (0..m).map(|q| a[p][q] * (x[p] - x[q])).sum();
            assert!(
                (ax - b[p]).abs() < 1e-12 * b[p].abs().max(1e-30),
                "row {p}: {ax} vs {}",
                b[p]
            );
        }
        assert!((x[6] - x[7] - 1.0 / 12.0).abs() < 1e-15);
    }
}
