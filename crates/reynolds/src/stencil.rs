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
        };
        s.finish();
        s
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
                *d = self.couplings(i, j).iter().sum();
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
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.residual_impl(None, x, y);
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
            if self.is_five_point() {
                for j in 0..ny {
                    let jm = wrap_prev(j, ny);
                    let jp = wrap_next(j, ny);
                    let v = xc[j];
                    let ax = e[j] * (v - xn[j])
                        + ew[j] * (v - xp[j])
                        + n[j] * (v - xc[jp])
                        + n[jm] * (v - xc[jm]);
                    o[j] = match b {
                        Some(b) => b[i * ny + j] - ax,
                        None => ax,
                    };
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
                    let ax = e[j] * (v - xn[j])
                        + ew[j] * (v - xp[j])
                        + n[j] * (v - xc[jp])
                        + n[jm] * (v - xc[jm])
                        + ne[j] * (v - xn[jp])
                        + nep[jm] * (v - xp[jm])
                        + se[j] * (v - xn[jm])
                        + sep[jp] * (v - xp[jp]);
                    o[j] = match b {
                        Some(b) => b[i * ny + j] - ax,
                        None => ax,
                    };
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
    pub fn gauss_seidel(&self, b: &[f64], x: &mut [f64], bounds: &[usize], forward: bool) {
        let (nx, ny) = (self.nx, self.ny);
        let nblocks = bounds.len() - 1;
        debug_assert!(nblocks >= 2 && nblocks % 2 == 0);
        let parities: [usize; 2] = if forward { [0, 1] } else { [1, 0] };
        for parity in parities {
            // Halo rows of the blocks of this parity: copies of the neighbouring rows, which
            // belong to blocks of the other parity and do not change in this half-sweep.
            let halos: Vec<(Vec<f64>, Vec<f64>)> = (0..nblocks)
                .map(|k| {
                    if k % 2 != parity {
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
                let (lo, hi) = (&halos[k].0, &halos[k].1);
                self.relax_block(b, part, bounds[k], bounds[k + 1], lo, hi, forward);
            };
            if nx * ny >= PARALLEL_MIN {
                parts.into_par_iter().for_each(relax);
            } else {
                parts.into_iter().for_each(relax);
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn relax_block(
        &self,
        b: &[f64],
        part: &mut [f64],
        r0: usize,
        r1: usize,
        halo_lo: &[f64],
        halo_hi: &[f64],
        forward: bool,
    ) {
        let (nx, ny) = (self.nx, self.ny);
        let rows = r1 - r0;
        for step in 0..rows {
            let local = if forward { step } else { rows - 1 - step };
            let i = r0 + local;
            let (before, after) = part.split_at_mut(local * ny);
            let (cur, after) = after.split_at_mut(ny);
            let prev: &[f64] = if local > 0 {
                &before[(local - 1) * ny..]
            } else {
                halo_lo
            };
            let next: &[f64] = if local + 1 < rows {
                &after[..ny]
            } else {
                halo_hi
            };
            let im = wrap_prev(i, nx);
            let row = i * ny..(i + 1) * ny;
            let rowm = im * ny..(im + 1) * ny;
            let bb = &b[row.clone()];
            let e = &self.e[row.clone()];
            let ew = &self.e[rowm.clone()];
            let n = &self.n[row.clone()];
            let inv = &self.inv_diag[row.clone()];
            if self.is_five_point() {
                let update = |cur: &mut [f64], j: usize| {
                    let jm = wrap_prev(j, ny);
                    let jp = wrap_next(j, ny);
                    let s =
                        bb[j] + e[j] * next[j] + ew[j] * prev[j] + n[j] * cur[jp] + n[jm] * cur[jm];
                    cur[j] = s * inv[j];
                };
                if forward {
                    for j in 0..ny {
                        update(cur, j);
                    }
                } else {
                    for j in (0..ny).rev() {
                        update(cur, j);
                    }
                }
            } else {
                let ne = &self.ne[row.clone()];
                let nep = &self.ne[rowm.clone()];
                let se = &self.se[row];
                let sep = &self.se[rowm];
                let update = |cur: &mut [f64], j: usize| {
                    let jm = wrap_prev(j, ny);
                    let jp = wrap_next(j, ny);
                    let s = bb[j]
                        + e[j] * next[j]
                        + ew[j] * prev[j]
                        + n[j] * cur[jp]
                        + n[jm] * cur[jm]
                        + ne[j] * next[jp]
                        + nep[jm] * prev[jm]
                        + se[j] * next[jm]
                        + sep[jp] * prev[jp];
                    cur[j] = s * inv[j];
                };
                if forward {
                    for j in 0..ny {
                        update(cur, j);
                    }
                } else {
                    for j in (0..ny).rev() {
                        update(cur, j);
                    }
                }
            }
        }
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
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64) / ((1u64 << 53) as f64)
        };
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
        a
    }

    #[test]
    fn apply_matches_dense_and_gauss_seidel_is_symmetric() {
        for &(nx, ny, nine) in &[(4, 6, false), (6, 4, true), (2, 4, true), (8, 8, true)] {
            let s = random_stencil(nx, ny, nine, 7 + nx as u64);
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
                let mut x = vec![0.0; nn];
                s.gauss_seidel(&b, &mut x, &bounds, true);
                s.gauss_seidel(&b, &mut x, &bounds, false);
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
            assert!((b.len() - 1) % 2 == 0 && b.len() >= 3);
            assert!(b.windows(2).all(|w| w[1] > w[0]));
        }
    }
}
