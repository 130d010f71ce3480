//! Cell-centred finite-volume discretisation of `div(g³ ∇p) = 0` on the periodic cell, with the
//! flow along the first axis (the caller transposes for flow along y).
//!
//! Node `(i, j)` (row-major index `i * ny + j`) is the centre of a `dx × dy` control volume. The
//! face between `(i, j)` and `(i + 1, j)` has conductance `c = H(g³_ij, g³_{i+1,j})`, the harmonic
//! mean (zero if either node is in contact), and carries the volume flux `c (p_ij − p_{i+1,j}) dy
//! / dx`; its coupling in the linear system is `s = c dy/dx` (and `c dx/dy` for y-faces).
//!
//! # The pressure drop and the cut
//! The pressure is `p = −x ΔP / L + φ` with `φ` periodic. It is represented by an unknown `u`
//! that is periodic except across one *cut*: a closed line of faces that winds once around the
//! cell across the flow, given by one column `c_j` per node row `j` ([`Cut`]). Node `(i, j)` lies
//! downstream of the cut if `i > c_j` (`H_ij = 1`, else 0), and `u = p + ΔP H` there; the drop
//! across a face `a → b` is `p_a − p_b = u_a − u_b + o_ab ΔP` with the offset
//! `o_ab = H_b − H_a` (plus one on the x-faces that wrap around the cell), i.e. `+1` on the
//! x-face `(c_j, j) → (c_j + 1, j)` of every row and `±1` on the y-faces between rows `j` and
//! `j + 1` where the cut steps from `c_j` to `c_{j+1}`. Any cut gives the same physics (moving
//! it adds ΔP to `u` on the nodes it passes); the solver puts it where the total conductance of
//! its faces is least ([`cut_path`], a shortest path through the rows). Near a closing
//! constriction that is the constriction itself, so the unknown is nearly uniform (and held
//! near zero by the multigrid gauge) in the well-conducting ponds, where floating-point values
//! must resolve tiny pressure differences, and the right-hand side `b` (the cut's ±sΔP) is
//! small, of the size of the flux.
//!
//! Until 2026-11-26 (#12) the cut was one straight column of x-faces (the column of least total
//! conductance). On the square cell that column runs through the saddles, but on the hexagonal
//! one (channels at 0°, 60°, 120°) every column crosses a wide pond: on 512² at l = −0.05 along
//! x the least column's ‖b‖ was 7.8e7 times the flux, so a relative residual of 1e-10 left the
//! flux wrong by ~1e-2 and the solve had to go on (tightened tolerances, iterative refinement)
//! to relative residuals of 1e-18 … 1e-25: 40–113 iterations where the square cell takes 8–10.

use crate::stencil::REDUCE_BLOCK;
use ndarray::{Array2, ArrayView2};
use rayon::prelude::*;

/// Harmonic mean of two conductances, 0 if either is 0; no overflow or underflow for any
/// positive finite inputs whose mean is representable.
#[inline]
pub(crate) fn harmonic_mean(a: f64, b: f64) -> f64 {
    if a > 0.0 && b > 0.0 {
        (2.0 * a) * (b / (a + b))
    } else {
        0.0
    }
}

/// The discrete problem: the 5-point operator on the flowing (kept) nodes, with couplings
/// `e = c dy/dx` on x-faces (node to `i + 1`) and `n = c dx/dy` on y-faces (node to `j + 1`),
/// and the cut column (see the module docs), or reservoirs.
pub(crate) struct Assembly<'a> {
    pub nx: usize,
    pub ny: usize,
    pub e: &'a [f64],
    pub n: &'a [f64],
    pub cut: &'a Cut,
    /// Reservoirs instead of a periodic cell: the x-faces across the cell edge (column
    /// `nx − 1`) have zero couplings and the cut lies in `0..nx − 1` (see the `reservoir`
    /// module for the gauge).
    pub reservoirs: Option<Reservoirs<'a>>,
}

/// Couplings of the first and last node columns to an inlet reservoir at pressure `ΔP`
/// (before column 0) and an outlet reservoir at pressure 0 (after column `nx − 1`), each `ny`
/// long: `2 g³ dy/dx` (the reservoir edge is half a cell from the node centre).
pub(crate) struct Reservoirs<'a> {
    pub inlet: &'a [f64],
    pub outlet: &'a [f64],
}

/// Couplings `(inlet, outlet)` of the kept nodes of the first and last columns to the
/// reservoirs: the conductance `g³` of the node over the half cell `dx/2`, times `dy`.
pub(crate) fn reservoir_couplings(
    g3: &[f64],
    keep: ArrayView2<bool>,
    dx: f64,
    dy: f64,
) -> (Vec<f64>, Vec<f64>) {
    let (nx, ny) = keep.dim();
    let at = |i: usize| -> Vec<f64> {
        (0..ny)
            .map(|j| {
                if keep[[i, j]] {
                    2.0 * g3[i * ny + j] * dy / dx
                } else {
                    0.0
                }
            })
            .collect()
    };
    (at(0), at(nx - 1))
}

/// The cut (see the module docs): its column `c_j` in every node row `j`; node `(i, j)` is
/// downstream of it if `i > c_j`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Cut {
    pub column: Vec<usize>,
}

impl Cut {
    /// `H_ij`: node `(i, j)` lies downstream of the cut.
    #[inline]
    pub fn downstream(&self, i: usize, j: usize) -> bool {
        i > self.column[j]
    }

    /// Offset `o` of the x-face `(i, j) → (i + 1, j)`: 1 on the cut, else 0.
    #[inline]
    pub fn offset_x(&self, i: usize, j: usize) -> f64 {
        if self.column[j] == i { 1.0 } else { 0.0 }
    }

    /// Offset `o = H(i, j + 1) − H(i, j)` of the y-face `(i, j) → (i, j + 1)` (rows periodic).
    #[inline]
    pub fn offset_y(&self, i: usize, j: usize) -> f64 {
        let jp = if j + 1 == self.column.len() { 0 } else { j + 1 };
        let (here, next) = (self.column[j], self.column[jp]);
        if next < i && i <= here {
            1.0
        } else if here < i && i <= next {
            -1.0
        } else {
            0.0
        }
    }
}

/// The cut of least total conductance among the cuts with one x-face per row: columns `c_j` in
/// `0..columns` minimising `Σ_j e(c_j, j) + Σ_j Σ_{i between c_j and c_{j+1}} n(i, j)` (the
/// x-faces on the cut plus the y-faces it crosses stepping from row to row, rows periodic).
///
/// A shortest path through the rows (dynamic programming; the step cost `|P_j(c) − P_j(c')|`,
/// `P_j` the running sum of row `j`'s y-couplings, is minimised by one forward and one
/// backward pass per row): O(columns × rows). The closing step from the last row to the first
/// is included by a second pass that fixes the starting column at the first (open) pass's,
/// unless the open path closes across contact only (then it is the least cut of all); if the
/// cheapest straight column costs less, it is the cut. So the cut is the least through its own
/// start or a straight column, never dearer than any straight column (not necessarily the
/// global least). Cost at 2048²: 0.16–0.2 s on random couplings (two passes and the transposed
/// copies of `e` and `n`), ~0.1 s of set-up on the flow benchmark. Contact
/// (zero couplings) costs nothing, so the cut runs through contact patches and the narrowest
/// throats.
pub(crate) fn cut_path(e: &[f64], n: &[f64], ny: usize, columns: usize) -> Cut {
    // Row-major copies (`[j * columns + c]`): the passes walk along rows, which the couplings'
    // layout (`[c * ny + j]`) would make strided.
    let transpose = |a: &[f64]| -> Vec<f64> {
        let mut t = vec![0.0; columns * ny];
        for c0 in (0..columns).step_by(32) {
            let c1 = (c0 + 32).min(columns);
            for j in 0..ny {
                for c in c0..c1 {
                    t[j * columns + c] = a[c * ny + j];
                }
            }
        }
        t
    };
    let (et, nt) = (transpose(e), transpose(n));
    // from[j * columns + c]: the column of row j − 1 the best path to (c, j) came from.
    let mut from = vec![0u32; columns * ny];
    let mut pass = |start: Option<usize>| -> (Vec<usize>, f64) {
        // cost[c]: least cost of a path through rows 0..=j ending at column c of row j.
        let mut cost: Vec<f64> = (0..columns)
            .map(|c| match start {
                Some(s) if s != c => f64::INFINITY,
                _ => et[c],
            })
            .collect();
        let mut arg: Vec<u32> = vec![0; columns];
        for j in 1..=ny {
            // Step across the y-faces between rows j − 1 and j (for j = ny: back to row 0).
            let step = &nt[(j - 1) * columns..j * columns];
            arg.iter_mut().enumerate().for_each(|(c, a)| *a = c as u32);
            // (selects, not branches: the comparisons are unpredictable)
            let (mut run, mut from_c) = (cost[0], arg[0]);
            for c in 1..columns {
                let v = run + step[c];
                let take = v < cost[c];
                run = if take { v } else { cost[c] };
                from_c = if take { from_c } else { arg[c] };
                cost[c] = run;
                arg[c] = from_c;
            }
            let (mut run, mut from_c) = (cost[columns - 1], arg[columns - 1]);
            for c in (0..columns - 1).rev() {
                let v = run + step[c + 1];
                let take = v < cost[c];
                run = if take { v } else { cost[c] };
                from_c = if take { from_c } else { arg[c] };
                cost[c] = run;
                arg[c] = from_c;
            }
            if j == ny {
                break;
            }
            from[j * columns..(j + 1) * columns].copy_from_slice(&arg);
            for (c, x) in cost.iter_mut().zip(&et[j * columns..(j + 1) * columns]) {
                *c += x;
            }
        }
        // Back at row 0: at the starting column (closed), or, with no start, at whichever
        // column is cheapest (a path that need not close, whose start the closed passes use).
        let end = start
            .unwrap_or_else(|| (0..columns).fold(0, |b, c| if cost[c] < cost[b] { c } else { b }));
        let (mut c, total) = (arg[end] as usize, cost[end]);
        let mut path = vec![0usize; ny];
        for jj in (0..ny).rev() {
            path[jj] = c;
            if jj > 0 {
                c = from[jj * columns + c] as usize;
            }
        }
        (path, total)
    };
    // Closed through the first pass's start, or the cheapest straight column if that is
    // cheaper (so the cut is never dearer than any column).
    let (first, _) = pass(None);
    let mut sums = vec![0.0; columns];
    for row in et.chunks(columns) {
        sums.iter_mut().zip(row).for_each(|(s, x)| *s += x);
    }
    let straight = (0..columns).fold(0, |b, c| if sums[c] < sums[b] { c } else { b });
    // The cheapest open path closes for free (its last row steps back to its first column
    // across contact only): it is the least cut of all, and the closed pass is not needed.
    let step_cost = |j: usize, from: usize, to: usize| -> f64 {
        (from.min(to) + 1..=from.max(to))
            .map(|i| nt[j * columns + i])
            .sum()
    };
    let closing = step_cost(ny - 1, first[ny - 1], first[0]);
    let (a, cost_a) = if closing == 0.0 {
        let cost = (0..ny)
            .map(|j| et[j * columns + first[j]] + step_cost(j, first[j], first[(j + 1) % ny]))
            .sum();
        (first, cost)
    } else {
        pass(Some(first[0]))
    };
    let column = if cost_a <= sums[straight] {
        a
    } else {
        vec![straight; ny]
    };
    Cut { column }
}

/// Face couplings `(e, n)` from `g³` on the nodes marked `keep` (all others are decoupled).
pub(crate) fn couplings(
    g3: &[f64],
    keep: ArrayView2<bool>,
    dx: f64,
    dy: f64,
) -> (Vec<f64>, Vec<f64>) {
    let (nx, ny) = keep.dim();
    let (rx, ry) = (dy / dx, dx / dy);
    let keep = keep.as_standard_layout();
    let keep = keep.as_slice().expect("standard layout");
    let mut e = vec![0.0; nx * ny];
    let mut n = vec![0.0; nx * ny];
    e.par_chunks_mut(ny)
        .zip(n.par_chunks_mut(ny))
        .enumerate()
        .for_each(|(i, (er, nr))| {
            let ip = (i + 1) % nx;
            for j in 0..ny {
                let k = i * ny + j;
                if !keep[k] {
                    continue;
                }
                let kx = ip * ny + j;
                let jp = (j + 1) % ny;
                let ky = i * ny + jp;
                if keep[kx] {
                    er[j] = harmonic_mean(g3[k], g3[kx]) * rx;
                }
                if keep[ky] {
                    nr[j] = harmonic_mean(g3[k], g3[ky]) * ry;
                }
            }
        });
    (e, n)
}

impl Assembly<'_> {
    /// The right-hand side for a pressure drop `dp` across the cell: `−s dp` on the upstream
    /// node of every cut face and `+s dp` on the downstream one.
    pub fn rhs(&self, dp: f64) -> Vec<f64> {
        let (nx, ny) = (self.nx, self.ny);
        let mut b = vec![0.0; nx * ny];

        for j in 0..ny {
            let c = self.cut.column[j];
            let cp = (c + 1) % nx;
            let s = self.e[c * ny + j] * dp;
            b[c * ny + j] -= s;
            b[cp * ny + j] += s;
            // The y-faces the cut crosses between rows j and j + 1.
            let jp = (j + 1) % ny;
            let next = self.cut.column[jp];
            for i in c.min(next) + 1..=c.max(next) {
                let s = self.n[i * ny + j] * self.cut.offset_y(i, j) * dp;
                b[i * ny + j] -= s;
                b[i * ny + jp] += s;
            }
        }
        b
    }

    /// Physical pressure drop `p_ij − p_{i+1,j}` across x-face `(i, j)` for the unknown `u`
    /// (plus `lo`, see [`Unknown`]).
    #[inline]
    fn drop_x(&self, u: Unknown, i: usize, j: usize, dp: f64) -> f64 {
        let ny = self.ny;
        let ip = if i + 1 == self.nx { 0 } else { i + 1 };
        let (k, m) = (i * ny + j, ip * ny + j);
        match u.lo {
            None => {
                let d = u.hi[k] - u.hi[m];
                if self.cut.column[j] == i { d + dp } else { d }
            }
            Some(lo) => offset_drop(
                u.hi[k],
                u.hi[m],
                lo[k] - lo[m],
                self.cut.offset_x(i, j) * dp,
            ),
        }
    }

    /// Physical pressure drop `p_ij − p_{i,j+1}` across y-face `(i, j)`.
    #[inline]
    fn drop_y(&self, u: Unknown, i: usize, j: usize, dp: f64) -> f64 {
        let ny = self.ny;
        let jp = if j + 1 == ny { 0 } else { j + 1 };
        let (k, m) = (i * ny + j, i * ny + jp);
        let offset = self.cut.offset_y(i, j) * dp;
        match u.lo {
            Some(lo) => offset_drop(u.hi[k], u.hi[m], lo[k] - lo[m], offset),
            None => {
                let d = u.hi[k] - u.hi[m];
                if offset != 0.0 { d + offset } else { d }
            }
        }
    }

    /// The fluxes through the four faces of node `(i, j)` (reservoir faces included).
    #[inline]
    fn faces(&self, u: Unknown, dp: f64, i: usize, j: usize) -> Faces {
        let (nx, ny) = (self.nx, self.ny);
        let im = if i == 0 { nx - 1 } else { i - 1 };
        let jm = if j == 0 { ny - 1 } else { j - 1 };
        let k = i * ny + j;
        let (dxe, dyn_) = (self.drop_x(u, i, j, dp), self.drop_y(u, i, j, dp));
        let mut f = Faces {
            east: self.e[k] * dxe,
            west: self.e[im * ny + j] * self.drop_x(u, im, j, dp),
            north: self.n[k] * dyn_,
            south: self.n[i * ny + jm] * self.drop_y(u, i, jm, dp),
            drop_east: dxe,
            drop_north: dyn_,
            inlet: None,
            outlet: None,
        };
        if let Some(r) = &self.reservoirs {
            if i == 0 {
                // p = u + ΔP on the inlet side of the cut: the drop from the inlet (ΔP) to the
                // node is −u.
                let (s, d) = (r.inlet[j], -u.value(k));
                f.west = s * d;
                f.inlet = Some((s, d));
            }
            if i + 1 == nx {
                let (s, d) = (r.outlet[j], u.value(k));
                f.east = s * d;
                f.outlet = Some((s, d));
            }
        }
        f
    }

    /// The net outflow of every node, `A u − b` (zero for the exact solution).
    pub fn net_outflow(&self, u: Unknown, dp: f64) -> Vec<f64> {
        let ny = self.ny;
        let mut out = vec![0.0; self.nx * ny];
        out.par_chunks_mut(ny).enumerate().for_each(|(i, row)| {
            for (j, o) in row.iter_mut().enumerate() {
                let f = self.faces(u, dp, i, j);
                *o = (f.east - f.west) + (f.north - f.south);
            }
        });
        out
    }

    /// Post-processing of a solution `u` for pressure drop `dp`.
    pub fn evaluate(&self, u: &[f64], dp: f64) -> Evaluation {
        self.evaluate_split(Unknown::single(u), dp)
    }

    /// [`Assembly::evaluate`] of an unknown held in two parts ([`Unknown`]).
    pub fn evaluate_split(&self, u: Unknown, dp: f64) -> Evaluation {
        let (nx, ny) = (self.nx, self.ny);
        // Per row i: dissipation of its x- and y-faces, flux through its x-face column and the
        // rounding noise of that flux, squared residual (the net outflow of each node, computed
        // face by face), its rounding floor, and the dissipation of rounding noise; with
        // reservoirs also the flux through the inlet faces and its noise (row 0 only). The
        // outlet faces count as the x-face column of the last row.
        let rows: Vec<[f64; 8]> = (0..nx)
            .into_par_iter()
            .map(|i| {
                let im = if i == 0 { nx - 1 } else { i - 1 };
                let ip = if i + 1 == nx { 0 } else { i + 1 };
                let mut acc = [0.0; 8];
                for j in 0..ny {
                    let jm = if j == 0 { ny - 1 } else { j - 1 };
                    let jp = if j + 1 == ny { 0 } else { j + 1 };
                    let k = i * ny + j;
                    let f = self.faces(u, dp, i, j);
                    // Reservoir faces: their coupling and the rounding noise of their drop.
                    let (mut ground, mut face_noise) = (0.0, 0.0);
                    if let Some((s, d)) = f.inlet {
                        acc[0] += f.west * d;
                        acc[6] += f.west;
                        acc[7] += s * u.noise(k);
                        ground += s;
                        face_noise += s * u.noise(k).powi(2);
                    }
                    if let Some((s, d)) = f.outlet {
                        acc[0] += f.east * d;
                        acc[2] += s * u.noise(k);
                        ground += s;
                        face_noise += s * u.noise(k).powi(2);
                    }
                    acc[0] += self.e[k] * f.drop_east * f.drop_east + f.north * f.drop_north;
                    acc[1] += f.east;
                    // Rounding u to doubles perturbs a face's drop by ≈ ε(|u_k| + |u_m|).
                    let ne = u.noise(k) + u.noise(ip * ny + j);
                    let nn = u.noise(k) + u.noise(i * ny + jp);
                    acc[2] += self.e[k] * ne;
                    // Net outflow; zero for the exact solution.
                    let r = (f.east - f.west) + (f.north - f.south);
                    acc[3] += r * r;
                    // Residual that rounding u_k to the nearest double alone can cause.
                    let d =
                        self.e[k] + self.e[im * ny + j] + self.n[k] + self.n[i * ny + jm] + ground;
                    let f = d * u.noise(k);
                    acc[4] += f * f;
                    acc[5] += self.e[k] * ne * ne + self.n[k] * nn * nn + face_noise;
                }
                acc
            })
            .collect();
        let sum = |t: usize| rows.iter().map(|r| r[t]).sum::<f64>();
        let mut column_flux: Vec<f64> = rows.iter().map(|r| r[1]).collect();
        let mut column_noise: Vec<f64> = rows.iter().map(|r| r[2]).collect();
        if self.reservoirs.is_some() {
            column_flux.push(sum(6));
            column_noise.push(sum(7));
        }
        Evaluation {
            flux: sum(0) / dp,
            column_flux,
            column_noise,
            residual_norm: sum(3).sqrt(),
            rounding_floor: ROUNDING_SAFETY * sum(4).sqrt(),
            flux_rounding: sum(5) / dp,
        }
    }

    /// Pressure (with the linear drop restored and the periodic part of zero mean over the
    /// flowing nodes; NaN elsewhere) and node-centred current densities `−g³ ∇p`.
    pub fn fields(
        &self,
        u: Unknown,
        dp: f64,
        dx: f64,
        dy: f64,
        flowing: &[bool],
    ) -> (Array2<f64>, Array2<f64>, Array2<f64>) {
        let (nx, ny) = (self.nx, self.ny);
        let lx = dx * nx as f64;
        let mut p = Array2::from_elem((nx, ny), f64::NAN);
        let mut mean = 0.0;
        let mut count = 0usize;
        let reservoirs = self.reservoirs.is_some();
        for i in 0..nx {
            for j in 0..ny {
                let k = i * ny + j;
                if flowing[k] && reservoirs {
                    p[[i, j]] = u.value(k) + if self.cut.downstream(i, j) { 0.0 } else { dp };
                } else if flowing[k] {
                    let v = u.value(k) - if self.cut.downstream(i, j) { dp } else { 0.0 };
                    p[[i, j]] = v;
                    // Periodic part φ = p + x ΔP / L with x = i dx.
                    mean += v + (i as f64) * dx * dp / lx;
                    count += 1;
                }
            }
        }
        if count > 0 {
            let shift = mean / count as f64;
            p.mapv_inplace(|v| v - shift);
        }
        // Face current densities: flux / face length; with reservoirs the first column's west
        // faces and the last column's east faces are the reservoir faces.
        let jx = |i: usize, j: usize| self.e[i * ny + j] * self.drop_x(u, i, j, dp) / dy;
        let jy = |i: usize, j: usize| self.n[i * ny + j] * self.drop_y(u, i, j, dp) / dx;
        let west = |i: usize, j: usize| match &self.reservoirs {
            Some(r) if i == 0 => -r.inlet[j] * u.value(j) / dy,
            _ => jx((i + nx - 1) % nx, j),
        };
        let east = |i: usize, j: usize| match &self.reservoirs {
            Some(r) if i + 1 == nx => r.outlet[j] * u.value(i * ny + j) / dy,
            _ => jx(i, j),
        };
        let cx = Array2::from_shape_fn((nx, ny), |(i, j)| 0.5 * (east(i, j) + west(i, j)));
        let cy = Array2::from_shape_fn((nx, ny), |(i, j)| {
            0.5 * (jy(i, j) + jy(i, (j + ny - 1) % ny))
        });
        (p, cx, cy)
    }
}

/// The unknown `u` of an iterate, held either as one double per node or, after iterative
/// refinement (see `reynolds::solve`), as an unevaluated sum `hi + lo` of two (a double-double
/// value: `lo` carries the digits below `hi`'s rounding). Every drop is formed as
/// `(hi_k − hi_m) + (lo_k − lo_m)`, so pressure differences far below the rounding of the pond
/// pressures `hi` survive.
#[derive(Clone, Copy)]
pub(crate) struct Unknown<'a> {
    pub hi: &'a [f64],
    pub lo: Option<&'a [f64]>,
}

impl<'a> Unknown<'a> {
    /// One double per node.
    pub fn single(u: &'a [f64]) -> Self {
        Unknown { hi: u, lo: None }
    }

    /// `hi + lo`.
    pub fn split(hi: &'a [f64], lo: &'a [f64]) -> Self {
        Unknown { hi, lo: Some(lo) }
    }

    /// The node's value (rounded to one double).
    #[inline]
    fn value(&self, k: usize) -> f64 {
        match self.lo {
            Some(lo) => self.hi[k] + lo[k],
            None => self.hi[k],
        }
    }

    /// How far rounding can put the node's represented value from the one intended: ε|u_k| for
    /// one double; ε|lo_k| + ε²|hi_k| for a sum (after renormalisation |lo_k| ≤ ε|hi_k|/2).
    #[inline]
    fn noise(&self, k: usize) -> f64 {
        const EPS: f64 = f64::EPSILON;
        match self.lo {
            Some(lo) => EPS * lo[k].abs() + EPS * EPS * self.hi[k].abs(),
            None => EPS * self.hi[k].abs(),
        }
    }
}

/// The fluxes out of a node through its faces (`west`, `south` into it), the drops across its
/// own east and north faces, and its reservoir faces' (coupling, drop).
struct Faces {
    east: f64,
    west: f64,
    north: f64,
    south: f64,
    drop_east: f64,
    drop_north: f64,
    inlet: Option<(f64, f64)>,
    outlet: Option<(f64, f64)>,
}

/// `(hi_k − hi_m + offset) + dlo` with the large parts summed exactly: across the cut hi jumps
/// by ≈ −ΔP, and the rounding of hi_k − hi_m + ΔP (ε ΔP) would swamp the drop that the pair
/// `hi + lo` resolves.
#[inline]
fn offset_drop(hk: f64, hm: f64, dlo: f64, offset: f64) -> f64 {
    let (s, mut err) = two_sum(hk, -hm);
    let s = if offset != 0.0 {
        let (s2, e2) = two_sum(s, offset);
        err += e2;
        s2
    } else {
        s
    };
    s + (err + dlo)
}

/// `a + b` as the rounded sum and its exact rounding error (Knuth's two-sum).
#[inline]
pub(crate) fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// What [`Assembly::evaluate`] measures.
pub(crate) struct Evaluation {
    /// Flux from the dissipation, `Σ s (Δp)² / ΔP`.
    pub flux: f64,
    /// Flux through each x-face column (the cross-sections perpendicular to the flow).
    pub column_flux: Vec<f64>,
    /// Rounding noise of each column flux, `Σ s ε (|u_k| + |u_m|)`.
    pub column_noise: Vec<f64>,
    /// Dissipation (as a flux) of the pressure's rounding noise, `Σ s ε² (|u_k| + |u_m|)² / ΔP`:
    /// the resolution of the dissipation flux in double precision.
    pub flux_rounding: f64,
    /// `‖b − A u‖₂`, computed as the net outflow of each node.
    pub residual_norm: f64,
    /// The residual norm below which rounding of the unknowns themselves dominates:
    /// `c ε ‖D |u|‖₂` (`D` the diagonal, `ε` the machine epsilon, `c` = [`ROUNDING_SAFETY`]).
    pub rounding_floor: f64,
}

/// Safety factor of [`Evaluation::rounding_floor`].
pub(crate) const ROUNDING_SAFETY: f64 = 8.0;

/// Cubes of the gaps (`g ≤ 0` → 0), in row-major order.
pub(crate) fn cubes(gap: ArrayView2<f64>) -> Vec<f64> {
    let gap = gap.as_standard_layout();
    let s = gap.as_slice().expect("standard layout");
    let mut out = vec![0.0; s.len()];
    out.par_chunks_mut(REDUCE_BLOCK)
        .zip(s.par_chunks(REDUCE_BLOCK))
        .for_each(|(o, g)| {
            for (o, &g) in o.iter_mut().zip(g) {
                *o = if g > 0.0 { g * g * g } else { 0.0 };
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cut's cost: its x-faces plus the y-faces it crosses between rows (rows periodic).
    fn cost(e: &[f64], n: &[f64], ny: usize, column: &[usize]) -> f64 {
        (0..ny)
            .map(|j| {
                let (c, next) = (column[j], column[(j + 1) % ny]);
                e[c * ny + j]
                    + (c.min(next) + 1..=c.max(next))
                        .map(|i| n[i * ny + j])
                        .sum::<f64>()
            })
            .sum()
    }

    /// Oracle: every cut with one x-face per row, enumerated, on 5 × 4 grids with random
    /// couplings (zero ones included): `cut_path` is the cheapest of those through its own
    /// starting column (the second pass fixes it) or a straight column, never dearer than any
    /// straight column;
    /// its offsets are those of `H(i, j) = [i > c_j]`.
    #[test]
    fn cut_path_is_the_least_cut_through_its_start_and_beats_every_column() {
        let (nx, ny) = (5usize, 4usize);
        let mut rnd = crate::test_uniform(5);
        for _ in 0..40 {
            let mut coupling = || -> Vec<f64> {
                (0..nx * ny)
                    .map(|_| if rnd() < 0.3 { 0.0 } else { rnd() })
                    .collect()
            };
            let (e, n) = (coupling(), coupling());
            for columns in [nx, nx - 1] {
                let cut = cut_path(&e, &n, ny, columns);
                let got = cost(&e, &n, ny, &cut.column);
                let mut best_from_start = f64::INFINITY;
                for code in 0..columns.pow(ny as u32) {
                    let column: Vec<usize> = (0..ny)
                        .map(|j| code / columns.pow(j as u32) % columns)
                        .collect();
                    if column[0] == cut.column[0] {
                        best_from_start = best_from_start.min(cost(&e, &n, ny, &column));
                    }
                }
                let straight = cut.column.iter().all(|&c| c == cut.column[0]);
                assert!(
                    (got - best_from_start).abs() <= 1e-12 || straight,
                    "{got} vs {best_from_start}"
                );
                for c in 0..columns {
                    assert!(got <= cost(&e, &n, ny, &vec![c; ny]) + 1e-12);
                }
                assert!(cut.column.iter().all(|&c| c < columns));
                let h = |i: usize, j: usize| f64::from(u8::from(cut.downstream(i, j)));
                for i in 0..nx {
                    for j in 0..ny {
                        let wrap = if i + 1 == nx { 1.0 } else { 0.0 };
                        assert_eq!(cut.offset_x(i, j), h((i + 1) % nx, j) - h(i, j) + wrap);
                        assert_eq!(cut.offset_y(i, j), h(i, (j + 1) % ny) - h(i, j));
                    }
                }
            }
        }
    }

    #[test]
    fn harmonic_mean_is_safe_at_the_extremes() {
        assert_eq!(harmonic_mean(1.0, 1.0), 1.0);
        assert_eq!(harmonic_mean(0.0, 1.0), 0.0);
        assert!((harmonic_mean(1e-300, 1e300) - 2e-300).abs() < 1e-310);
        assert!(harmonic_mean(5e-324, 1.0) > 0.0);
        assert!((harmonic_mean(1e300, 1e300) - 1e300).abs() < 1e285);
        assert!((harmonic_mean(2.0, 6.0) - 3.0).abs() < 1e-15);
    }
}
