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
//! that is periodic except across one *cut*: the column of x-faces between node columns `c` and
//! `c + 1`, where the physical drop is `p_c − p_{c+1} = u_c − u_{c+1} + ΔP`. Any column gives the
//! same physics (moving the cut adds ΔP to `u` on the columns it passes); the solver puts it on
//! the column with the smallest total conductance. Near a closing constriction that is the
//! constriction itself, so the unknown is nearly uniform (and held near zero by the multigrid
//! gauge) in the well-conducting ponds, where floating-point values must resolve tiny pressure
//! differences, and the right-hand side `b` (the cut's ±sΔP) is small, of the size of the flux.

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
    pub cut: usize,
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

/// The cut column: the x-face column of least total conductance.
pub(crate) fn cut_column(e: &[f64], ny: usize) -> usize {
    let column_sum: Vec<f64> = e.par_chunks(ny).map(|r| r.iter().sum()).collect();
    let mut cut = 0;
    for (i, &s) in column_sum.iter().enumerate() {
        if s < column_sum[cut] {
            cut = i;
        }
    }
    cut
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

        let c = self.cut;
        let cp = (c + 1) % nx;
        for j in 0..ny {
            let s = self.e[c * ny + j] * dp;
            b[c * ny + j] -= s;
            b[cp * ny + j] += s;
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
                if i == self.cut { d + dp } else { d }
            }
            // Exact sums of the large parts: across the cut hi jumps by ≈ −ΔP, and the rounding
            // of hi_k − hi_m + ΔP (ε ΔP) would swamp the drop that the pair resolves.
            Some(lo) => {
                let (s, mut err) = two_sum(u.hi[k], -u.hi[m]);
                let s = if i == self.cut {
                    let (s2, e2) = two_sum(s, dp);
                    err += e2;
                    s2
                } else {
                    s
                };
                s + (err + (lo[k] - lo[m]))
            }
        }
    }

    #[inline]
    fn drop_y(&self, u: Unknown, i: usize, j: usize) -> f64 {
        let ny = self.ny;
        let jp = if j + 1 == ny { 0 } else { j + 1 };
        let (k, m) = (i * ny + j, i * ny + jp);
        match u.lo {
            Some(lo) => {
                let (s, err) = two_sum(u.hi[k], -u.hi[m]);
                s + (err + (lo[k] - lo[m]))
            }
            None => u.hi[k] - u.hi[m],
        }
    }

    /// The fluxes through the four faces of node `(i, j)` (reservoir faces included).
    #[inline]
    fn faces(&self, u: Unknown, dp: f64, i: usize, j: usize) -> Faces {
        let (nx, ny) = (self.nx, self.ny);
        let im = if i == 0 { nx - 1 } else { i - 1 };
        let jm = if j == 0 { ny - 1 } else { j - 1 };
        let k = i * ny + j;
        let (dxe, dyn_) = (self.drop_x(u, i, j, dp), self.drop_y(u, i, j));
        let mut f = Faces {
            east: self.e[k] * dxe,
            west: self.e[im * ny + j] * self.drop_x(u, im, j, dp),
            north: self.n[k] * dyn_,
            south: self.n[i * ny + jm] * self.drop_y(u, i, jm),
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
                    p[[i, j]] = u.value(k) + if i <= self.cut { dp } else { 0.0 };
                } else if flowing[k] {
                    let v = u.value(k) - if i > self.cut { dp } else { 0.0 };
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
        let jy = |i: usize, j: usize| self.n[i * ny + j] * self.drop_y(u, i, j) / dx;
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
