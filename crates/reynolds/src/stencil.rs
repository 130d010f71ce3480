//! Periodic 5- and 9-point operators in "Laplacian" (flux) form, their products and their
//! symmetric Gauss–Seidel smoothing.
//!
//! An operator on an `nx × ny` periodic grid (row-major, index `i * ny + j`, `i` along x) is
//! stored by its non-negative couplings ("conductances") only: `e[k]` couples node `k = (i, j)`
//! with `(i + 1, j)`, `n[k]` with `(i, j + 1)`, and for 9-point operators `ne[k]` with
//! `(i + 1, j + 1)` and `se[k]` with `(i + 1, j − 1)` (indices periodic). The operator is
//!
//! ```text
//! (A x)_k = Σ_{faces (k, m)} s_km (x_k − x_m)
//! ```
//!
//! so its rows sum to zero exactly (the constant is in its null space) and its diagonal is the
//! sum of the couplings. Products are evaluated in this difference ("flux") form: a difference of
//! two nearly equal values is exact in floating point, so the residual of a nearly uniform
//! pressure in a highly conducting pond carries no rounding noise of the size of the pressure
//! itself. Nodes with zero diagonal are inactive (contact, removed pools): they stay zero.
//!
//! An operator may also have a *ground*: a non-negative coupling `g[k]` of node `k` to a node
//! held at zero outside the grid (a reservoir at fixed pressure), `(A x)_k += g_k x_k`. Its
//! diagonal is then the sum of the couplings plus `g_k`; with a non-zero ground every connected
//! component touching it is positive definite.

use rayon::prelude::*;

/// Grids with fewer nodes than this are processed on the calling thread (no rayon overhead).
const PARALLEL_MIN: usize = 1 << 14;
/// Block length of the deterministic parallel reductions.
pub(crate) const REDUCE_BLOCK: usize = 1 << 14;

/// A periodic 5-point (`ne`, `se` empty) or 9-point operator in flux form.
#[derive(Clone, Debug)]
pub(crate) struct Stencil {
    pub nx: usize,
    pub ny: usize,
    pub e: Vec<f64>,
    pub n: Vec<f64>,
    pub ne: Vec<f64>,
    pub se: Vec<f64>,
    /// Sum of the couplings of each node.
    pub diag: Vec<f64>,
    /// `1 / diag`, zero for inactive nodes.
    pub inv_diag: Vec<f64>,
    /// Coupling of each node to the grounded outside (empty: none).
    pub ground: Vec<f64>,
}

#[inline(always)]
fn wrap_prev(j: usize, n: usize) -> usize {
    if j == 0 { n - 1 } else { j - 1 }
}

#[inline(always)]
fn wrap_next(j: usize, n: usize) -> usize {
    if j + 1 == n { 0 } else { j + 1 }
}

impl Stencil {
    /// A 5-point operator from its `e` and `n` couplings.
    pub fn five_point(nx: usize, ny: usize, e: Vec<f64>, n: Vec<f64>) -> Self {
        let mut s = Stencil {
            nx,
            ny,
            e,
            n,
            ne: Vec::new(),
            se: Vec::new(),
            diag: Vec::new(),
            inv_diag: Vec::new(),
            ground: Vec::new(),
        };
        s.finish();
        s
    }

    /// The operator with a ground coupling per node (see the module docs; empty: none).
    pub fn with_ground(mut self, ground: Vec<f64>) -> Self {
        debug_assert!(ground.is_empty() || ground.len() == self.len());
        self.ground = ground;
        self.finish();
        self
    }

    /// A 9-point operator from its four coupling arrays.
    pub fn nine_point(
        nx: usize,
        ny: usize,
        e: Vec<f64>,
        n: Vec<f64>,
        ne: Vec<f64>,
        se: Vec<f64>,
    ) -> Self {
        let mut s = Stencil {
            nx,
            ny,
            e,
            n,
            ne,
            se,
            diag: Vec::new(),
            inv_diag: Vec::new(),
            ground: Vec::new(),
        };
        s.finish();
        s
    }

    pub fn is_five_point(&self) -> bool {
        self.ne.is_empty()
    }

    pub fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// The eight couplings of node `(i, j)`: `[W, E, S, N, SW, NE, SE, NW]`.
    #[inline]
    pub fn couplings(&self, i: usize, j: usize) -> [f64; 8] {
        let (nx, ny) = (self.nx, self.ny);
        let im = wrap_prev(i, nx);
        let jm = wrap_prev(j, ny);
        let jp = wrap_next(j, ny);
        let k = i * ny + j;
        let w = self.e[im * ny + j];
        let e = self.e[k];
        let s = self.n[i * ny + jm];
        let n = self.n[k];
        if self.is_five_point() {
            return [w, e, s, n, 0.0, 0.0, 0.0, 0.0];
        }
        let sw = self.ne[im * ny + jm];
        let ne = self.ne[k];
        let se = self.se[k];
        let nw = self.se[im * ny + jp];
        [w, e, s, n, sw, ne, se, nw]
    }

    fn finish(&mut self) {
        let (nx, ny) = (self.nx, self.ny);
        let mut diag = vec![0.0; nx * ny];
        let compute = |(i, row): (usize, &mut [f64])| {
            for (j, d) in row.iter_mut().enumerate() {
                *d = self.couplings(i, j).iter().sum::<f64>()
                    + self.ground.get(i * ny + j).copied().unwrap_or(0.0);
            }
        };
        if nx * ny >= PARALLEL_MIN {
            diag.par_chunks_mut(ny).enumerate().for_each(compute);
        } else {
            diag.chunks_mut(ny).enumerate().for_each(compute);
        }
        self.inv_diag = diag
            .iter()
            .map(|&d| if d > 0.0 { 1.0 / d } else { 0.0 })
            .collect();
        self.diag = diag;
    }

    /// `y = A x` (flux form).
    #[cfg(test)]
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.residual_impl(None, x, y);
    }

    /// `y = A x` (flux form); returns `x · y` (deterministic order).
    pub fn apply_dot(&self, x: &[f64], y: &mut [f64]) -> f64 {
        self.residual_impl(None, x, y);
        dot(x, y)
    }

    /// `r = b − A x` (flux form).
    pub fn residual(&self, b: &[f64], x: &[f64], r: &mut [f64]) {
        self.residual_impl(Some(b), x, r);
    }

    fn residual_impl(&self, b: Option<&[f64]>, x: &[f64], out: &mut [f64]) {
        let (nx, ny) = (self.nx, self.ny);
        let row = |(i, o): (usize, &mut [f64])| {
            let im = wrap_prev(i, nx);
            let ip = wrap_next(i, nx);
            let xc = &x[i * ny..(i + 1) * ny];
            let xp = &x[im * ny..(im + 1) * ny];
            let xn = &x[ip * ny..(ip + 1) * ny];
            let e = &self.e[i * ny..(i + 1) * ny];
            let ew = &self.e[im * ny..(im + 1) * ny];
            let n = &self.n[i * ny..(i + 1) * ny];
            // (A x)_j for one node, with explicit in-row neighbours jm, jp.
            let five = |j: usize, jm: usize, jp: usize| {
                let v = xc[j];
                e[j] * (v - xn[j])
                    + ew[j] * (v - xp[j])
                    + n[j] * (v - xc[jp])
                    + n[jm] * (v - xc[jm])
            };
            if self.is_five_point() {
                o[0] = five(0, ny - 1, 1);
                o[ny - 1] = five(ny - 1, ny - 2, 0);
                // Interior: shifted slices, no wrap-around, vectorisable.
                let m = ny - 2;
                let it = o[1..ny - 1]
                    .iter_mut()
                    .zip(&xc[1..ny - 1])
                    .zip(xc[..m].iter().zip(&xc[2..]))
                    .zip(xn[1..ny - 1].iter().zip(&xp[1..ny - 1]))
                    .zip(e[1..ny - 1].iter().zip(&ew[1..ny - 1]))
                    .zip(n[1..ny - 1].iter().zip(&n[..m]));
                for (((((o, &v), (&xs, &xnn)), (&xe, &xw)), (&ee, &ww)), (&nn, &ss)) in it {
                    *o = ee * (v - xe) + ww * (v - xw) + nn * (v - xnn) + ss * (v - xs);
                }
            } else {
                let ne = &self.ne[i * ny..(i + 1) * ny];
                let nep = &self.ne[im * ny..(im + 1) * ny];
                let se = &self.se[i * ny..(i + 1) * ny];
                let sep = &self.se[im * ny..(im + 1) * ny];
                for j in 0..ny {
                    let jm = wrap_prev(j, ny);
                    let jp = wrap_next(j, ny);
                    let v = xc[j];
                    o[j] = five(j, jm, jp)
                        + ne[j] * (v - xn[jp])
                        + nep[jm] * (v - xp[jm])
                        + se[j] * (v - xn[jm])
                        + sep[jp] * (v - xp[jp]);
                }
            }
            if !self.ground.is_empty() {
                for ((o, &g), &v) in o.iter_mut().zip(&self.ground[i * ny..(i + 1) * ny]).zip(xc) {
                    *o += g * v;
                }
            }
            if let Some(b) = b {
                for (o, &b) in o.iter_mut().zip(&b[i * ny..(i + 1) * ny]) {
                    *o = b - *o;
                }
            }
        };
        if nx * ny >= PARALLEL_MIN {
            out.par_chunks_mut(ny).enumerate().for_each(row);
        } else {
            out.chunks_mut(ny).enumerate().for_each(row);
        }
    }

    /// One symmetric-ordering Gauss–Seidel sweep on `A x = b`, in place.
    ///
    /// The rows are cut into an even number of blocks (`bounds`); blocks of the same parity are
    /// never adjacent, so all even blocks are relaxed at once, then all odd ones. Within a block
    /// the order is lexicographic. `forward == false` runs the exact reverse ordering (odd
    /// blocks first, each backwards), so a forward pre-sweep and a backward post-sweep make a
    /// symmetric multigrid cycle. The ordering is fixed by `bounds`, not by the number of
    /// threads: results do not depend on the thread count.
    ///
    /// `zero_start` (forward sweeps only): `x` is taken as zero on entry and its contents are
    /// never read, which saves clearing and reading it.
    pub fn gauss_seidel(
        &self,
        b: &[f64],
        x: &mut [f64],
        bounds: &[usize],
        forward: bool,
        zero_start: bool,
    ) {
        let (nx, ny) = (self.nx, self.ny);
        let nblocks = bounds.len() - 1;
        debug_assert!(nblocks >= 2 && nblocks.is_multiple_of(2));
        debug_assert!(forward || !zero_start);
        let parities: [usize; 2] = if forward { [0, 1] } else { [1, 0] };
        for (half, parity) in parities.into_iter().enumerate() {
            // In a zero-start sweep the blocks relaxed first see zero neighbours.
            let zero_halo = zero_start && half == 0;
            // Halo rows of the blocks of this parity: copies of the neighbouring rows, which
            // belong to blocks of the other parity and do not change in this half-sweep.
            let halos: Vec<(Vec<f64>, Vec<f64>)> = (0..nblocks)
                .map(|k| {
                    if k % 2 != parity || zero_halo {
                        return (Vec::new(), Vec::new());
                    }
                    let lo = wrap_prev(bounds[k], nx);
                    let hi = bounds[k + 1] % nx;
                    (
                        x[lo * ny..(lo + 1) * ny].to_vec(),
                        x[hi * ny..(hi + 1) * ny].to_vec(),
                    )
                })
                .collect();
            let mut parts: Vec<(usize, &mut [f64])> = Vec::with_capacity(nblocks);
            let mut rest: &mut [f64] = x;
            for k in 0..nblocks {
                let (head, tail) = rest.split_at_mut((bounds[k + 1] - bounds[k]) * ny);
                if k % 2 == parity {
                    parts.push((k, head));
                }
                rest = tail;
            }
            let relax = |(k, part): (usize, &mut [f64])| {
                let (lo, hi) = if zero_halo {
                    (None, None)
                } else {
                    (Some(halos[k].0.as_slice()), Some(halos[k].1.as_slice()))
                };
                self.relax_block(b, part, bounds[k], lo, hi, forward, zero_start);
            };
            if nx * ny >= PARALLEL_MIN {
                parts.into_par_iter().for_each(relax);
            } else {
                parts.into_iter().for_each(relax);
            }
        }
    }

    /// Relaxes the rows of one block (`part`, starting at grid row `r0`). `halo_lo`/`halo_hi`:
    /// the rows below and above the block (`None`: zero).
    #[allow(clippy::too_many_arguments)]
    fn relax_block(
        &self,
        b: &[f64],
        part: &mut [f64],
        r0: usize,
        halo_lo: Option<&[f64]>,
        halo_hi: Option<&[f64]>,
        forward: bool,
        zero_start: bool,
    ) {
        let (nx, ny) = (self.nx, self.ny);
        let rows = part.len() / ny;
        let mut t = vec![0.0; ny];
        for step in 0..rows {
            let local = if forward { step } else { rows - 1 - step };
            let i = r0 + local;
            let (before, after) = part.split_at_mut(local * ny);
            let (cur, after) = after.split_at_mut(ny);
            let prev: Option<&[f64]> = if local > 0 {
                Some(&before[(local - 1) * ny..])
            } else {
                halo_lo
            };
            // Rows not yet relaxed in a zero-start sweep are zero.
            let next: Option<&[f64]> = if local + 1 < rows {
                if zero_start { None } else { Some(&after[..ny]) }
            } else {
                halo_hi
            };
            let im = wrap_prev(i, nx);
            let row = i * ny..(i + 1) * ny;
            let rowm = im * ny..(im + 1) * ny;
            let coef = RowCoefficients {
                b: &b[row.clone()],
                e: &self.e[row.clone()],
                ew: &self.e[rowm.clone()],
                n: &self.n[row.clone()],
                inv: &self.inv_diag[row.clone()],
                nine: (!self.is_five_point()).then(|| {
                    (
                        &self.ne[row.clone()],
                        &self.ne[rowm.clone()],
                        &self.se[row.clone()],
                        &self.se[rowm.clone()],
                    )
                }),
            };
            relax_row(&coef, cur, prev, next, &mut t, forward, zero_start);
        }
    }
}

/// Diagonal coupling rows of a 9-point operator: `ne`, `ne` of the row below, `se`, `se` of
/// the row below.
type DiagonalRows<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a [f64]);

/// The coefficient rows a row relaxation needs.
struct RowCoefficients<'a> {
    b: &'a [f64],
    e: &'a [f64],
    /// `e` of the row below (couplings to the west).
    ew: &'a [f64],
    n: &'a [f64],
    inv: &'a [f64],
    /// `ne`, `ne` of the row below, `se`, `se` of the row below.
    nine: Option<DiagonalRows<'a>>,
}

/// Gauss–Seidel on one row: `x_j ← (b_j + Σ_m s_jm x_m) / d_j`, in the row's order.
///
/// Everything that does not depend on the values updated earlier in the same row is summed
/// first into `t` (a vectorisable pass); the sequential recurrence then has one multiply and
/// one add on its critical path. (Not `mul_add`: without `-C target-cpu` supporting FMA it
/// compiles to a call into a software routine.)
fn relax_row(
    c: &RowCoefficients,
    cur: &mut [f64],
    prev: Option<&[f64]>,
    next: Option<&[f64]>,
    t: &mut [f64],
    forward: bool,
    zero_start: bool,
) {
    let ny = cur.len();
    let (b, e, ew, n, inv) = (c.b, c.e, c.ew, c.n, c.inv);
    let t = &mut t[..ny];
    t.copy_from_slice(b);
    if let Some(nx_) = next {
        for ((t, &e), &x) in t.iter_mut().zip(e).zip(&nx_[..ny]) {
            *t += e * x;
        }
    }
    if let Some(pv) = prev {
        for ((t, &w), &x) in t.iter_mut().zip(ew).zip(&pv[..ny]) {
            *t += w * x;
        }
    }
    if let Some((ne, nep, se, sep)) = c.nine {
        // NE: next[j+1] via ne[j]; SE: next[j−1] via se[j]; SW: prev[j−1] via nep[j−1];
        // NW: prev[j+1] via sep[j+1].
        if let Some(nx_) = next {
            for j in 0..ny {
                let (jm, jp) = (wrap_prev(j, ny), wrap_next(j, ny));
                t[j] += ne[j] * nx_[jp] + se[j] * nx_[jm];
            }
        }
        if let Some(pv) = prev {
            for j in 0..ny {
                let (jm, jp) = (wrap_prev(j, ny), wrap_next(j, ny));
                t[j] += nep[jm] * pv[jm] + sep[jp] * pv[jp];
            }
        }
    }
    // In-row couplings: x_j ↔ x_{j+1} through n[j]; x_j ↔ x_{j−1} through n[j−1].
    if forward {
        // Not yet updated: x_{j+1} for j < ny−1, and x_{ny−1} seen from j = 0.
        if !zero_start {
            for j in 0..ny - 1 {
                t[j] += n[j] * cur[j + 1];
            }
            t[0] += n[ny - 1] * cur[ny - 1];
        }
        cur[0] = t[0] * inv[0];
        for j in 1..ny - 1 {
            let a = n[j - 1] * inv[j];
            cur[j] = a * cur[j - 1] + t[j] * inv[j];
        }
        let j = ny - 1;
        cur[j] = (t[j] + n[j - 1] * cur[j - 1] + n[j] * cur[0]) * inv[j];
    } else {
        // Not yet updated: x_{j−1} for j > 0, and x_0 seen from j = ny−1.
        for j in 1..ny {
            t[j] += n[j - 1] * cur[j - 1];
        }
        t[ny - 1] += n[ny - 1] * cur[0];
        let last = ny - 1;
        cur[last] = t[last] * inv[last];
        for j in (1..ny - 1).rev() {
            let a = n[j] * inv[j];
            cur[j] = a * cur[j + 1] + t[j] * inv[j];
        }
        cur[0] = (t[0] + n[0] * cur[1] + n[ny - 1] * cur[ny - 1]) * inv[0];
    }
}

/// Row bounds of an even number (≥ 2) of nearly equal blocks for [`Stencil::gauss_seidel`].
pub(crate) fn block_bounds(nx: usize) -> Vec<usize> {
    // About 64 rows per block, at most 32 blocks, always an even number ≥ 2.
    let mut nb = (nx / 64).clamp(2, 32);
    if nb % 2 == 1 {
        nb -= 1;
    }
    let nb = nb.min(nx - nx % 2).max(2);
    (0..=nb).map(|k| k * nx / nb).collect()
}

/// Deterministic parallel dot product (fixed blocks, summed in order).
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    if a.len() < PARALLEL_MIN {
        return a.iter().zip(b).map(|(x, y)| x * y).sum();
    }
    let partial: Vec<f64> = a
        .par_chunks(REDUCE_BLOCK)
        .zip(b.par_chunks(REDUCE_BLOCK))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum())
        .collect();
    partial.iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_stencil(nx: usize, ny: usize, nine: bool, seed: u64) -> Stencil {
        let mut next = crate::test_uniform(seed);
        let mut gen_vec = |_: ()| (0..nx * ny).map(|_| next()).collect::<Vec<f64>>();
        let e = gen_vec(());
        let n = gen_vec(());
        if nine {
            let ne = gen_vec(());
            let se = gen_vec(());
            Stencil::nine_point(nx, ny, e, n, ne, se)
        } else {
            Stencil::five_point(nx, ny, e, n)
        }
    }

    /// Dense matrix of the operator, built independently from the coupling definitions.
    fn dense(s: &Stencil) -> Vec<Vec<f64>> {
        let (nx, ny) = (s.nx, s.ny);
        let nn = nx * ny;
        let mut a = vec![vec![0.0; nn]; nn];
        let mut add = |p: usize, q: usize, c: f64| {
            a[p][p] += c;
            a[q][q] += c;
            a[p][q] -= c;
            a[q][p] -= c;
        };
        for i in 0..nx {
            for j in 0..ny {
                let k = i * ny + j;
                add(k, ((i + 1) % nx) * ny + j, s.e[k]);
                add(k, i * ny + (j + 1) % ny, s.n[k]);
                if !s.is_five_point() {
                    add(k, ((i + 1) % nx) * ny + (j + 1) % ny, s.ne[k]);
                    add(k, ((i + 1) % nx) * ny + (j + ny - 1) % ny, s.se[k]);
                }
            }
        }
        for (k, &g) in s.ground.iter().enumerate() {
            a[k][k] += g;
        }
        a
    }

    #[test]
    fn apply_matches_dense_and_gauss_seidel_is_symmetric() {
        for &(nx, ny, nine, grounded) in &[
            (4, 6, false, false),
            (6, 4, true, false),
            (2, 4, true, false),
            (8, 8, true, false),
            (4, 6, false, true),
            (8, 8, true, true),
        ] {
            let mut s = random_stencil(nx, ny, nine, 7 + nx as u64);
            if grounded {
                // A ground on the first and last rows, as reservoirs at both ends give.
                let ground = (0..nx * ny)
                    .map(|k| {
                        if k < ny || k >= (nx - 1) * ny {
                            0.5 + (k % 3) as f64
                        } else {
                            0.0
                        }
                    })
                    .collect();
                s = s.with_ground(ground);
            }
            let a = dense(&s);
            let nn = nx * ny;
            let x: Vec<f64> = (0..nn).map(|k| ((k * 37) % 11) as f64 - 5.0).collect();
            let mut y = vec![0.0; nn];
            s.apply(&x, &mut y);
            for p in 0..nn {
                let want: f64 = (0..nn).map(|q| a[p][q] * x[q]).sum();
                assert!(
                    (y[p] - want).abs() < 1e-12 * (1.0 + want.abs()),
                    "{nx}x{ny}"
                );
                assert!((s.diag[p] - a[p][p]).abs() < 1e-12);
            }
            // The smoother matrix: S = (forward sweep then backward sweep applied to b with
            // x = 0) must be symmetric for CG preconditioning.
            let bounds = block_bounds(nx);
            let mut sm = vec![vec![0.0; nn]; nn];
            for q in 0..nn {
                let mut b = vec![0.0; nn];
                b[q] = 1.0;
                // A zero-start sweep must not read x: give it garbage.
                let zero_start = q % 2 == 0;
                let mut x = vec![if zero_start { f64::NAN } else { 0.0 }; nn];
                s.gauss_seidel(&b, &mut x, &bounds, true, zero_start);
                s.gauss_seidel(&b, &mut x, &bounds, false, false);
                for p in 0..nn {
                    sm[p][q] = x[p];
                }
            }
            for p in 0..nn {
                for q in 0..nn {
                    assert!(
                        (sm[p][q] - sm[q][p]).abs() < 1e-12 * (1.0 + sm[p][q].abs()),
                        "asymmetric smoother {nx}x{ny} at ({p},{q})"
                    );
                }
            }
        }
    }

    #[test]
    fn bounds_are_even_and_cover() {
        for nx in 2..300 {
            let b = block_bounds(nx);
            assert_eq!(b[0], 0);
            assert_eq!(*b.last().unwrap(), nx);
            assert!((b.len() - 1).is_multiple_of(2) && b.len() >= 3);
            assert!(b.windows(2).all(|w| w[1] > w[0]));
        }
    }
}
