//! Two-level preconditioners of the composite problem (see the parent module's docs,
//! "Preconditioner").
//!
//! The solver works in force variables r = W q (W = Pᵀ1) and needs M ≈ A'⁻¹ =
//! W (Pᵀ G P)⁻¹ W. Both preconditioners here are additive subspace corrections of Pᵀ G P in
//! the composite coordinates q:
//!
//! B = J_c C⁻¹ J_cᵀ + J_r K_R J_rᵀ,  M = W B W,
//!
//! - J_c maps nodal values v on every base node to the composite coordinates of the bilinear
//!   field H v (v itself at the coarse unknowns, its interpolant on R's fine nodes); C = Hᵀ G H
//!   is the base-grid circulant of the hats (alias sum, exact), so the coarse space is solved
//!   exactly, by one FFT pair on the base grid;
//! - J_r embeds fine nodal values on R; K_R is the fine stiffness K_f restricted to R (its
//!   real-space table, a zero-padded FFT on R alone, no margin): the analogue of the uniform
//!   solve's preconditioner on the window.
//!
//! `Additive` lets the fine space hold every fine node of R (the two spaces overlap by the
//! smooth fields on R, so M over-weights those by up to 2); `Hierarchical` leaves out R's base
//! nodes (the fine space is the hierarchical surplus d of the blockwise operator, the spaces
//! are disjoint and B is the block-diagonal inverse in the (v, d) basis).
//!
//! Neither needs the box with margins nor the fine lattice: per application one base-grid FFT
//! pair, one FFT pair on twice R's sides rounded up to 2^a 3^b 5^c ([`super::blocks::Padded`]) and
//! passes over R.

use super::blocks::{Geometry, Kernel, Padded, hat, table};
use crate::spectral::Spectral;

/// One window's fine space.
struct FineSpace {
    g: Geometry,
    rx: usize,
    ry: usize,
    /// K_f's table on R, applied by zero-padded FFT (on [`super::blocks::smooth`] sides).
    fine: Padded,
    /// The fine nodes of R that belong to the fine space (their scale; 0 outside it).
    in_fine: Vec<f64>,
}

/// The additive two-level preconditioner (see the module docs).
pub(crate) struct TwoLevel {
    spectral: Spectral,
    /// 1/C on the base grid (zero at the mean mode), as a [`Spectral`] multiplier.
    cinv: Vec<f64>,
    /// One fine space per window (R and the windows' fine unknowns in order).
    spaces: Vec<FineSpace>,
}

impl TwoLevel {
    /// For the windows `gs` whose fine regions are `regions` (rx × ry each, R's fine nodes; at most
    /// the fine lattice) and whose unknowns have the weights `weight` (rx × ry each, in order). The fine
    /// space holds every node of each R (with `hierarchical` none of R's base nodes); the base
    /// nodes on R's edge, whose basis function also carries the coarse hats next to R (weight
    /// w > 1), enter it scaled by 1/w, so that W B W gives them the fine diagonal K_f(0) rather
    /// than w² K_f(0) (up to f⁴/4 too stiff; measured: leaving them out of the fine space, or
    /// not scaling them, costs up to 3× the iterations, see the parent module's docs). The
    /// windows' fine spaces are disjoint and uncoupled (block diagonal). `c` is the hats'
    /// compliance spectrum C ([`super::blocks::alias_spectra`] of `gs[0]`, shared with the
    /// blockwise operator).
    pub fn new(
        gs: &[Geometry],
        regions: &[(usize, usize)],
        weights: &[&[f64]],
        hierarchical: bool,
        c: &[f64],
    ) -> Self {
        let g = gs[0];
        let nb = (g.nx * g.ny) as f64;
        // `c` includes the 1/(nx ny) of the inverse transform: eigenvalue λ = c nb, and the
        // inverse's multiplier is 1/(λ nb). The mean mode (index 0) is zero up to the rounding
        // of its aliases' hat factors sin(f π m)/sin(π m) (~1e-32): left at zero, as K(0) = 0.
        let inv: Vec<f64> = c
            .iter()
            .enumerate()
            .map(|(k, &m)| {
                if k > 0 && m > 0.0 {
                    1.0 / (m * nb * nb)
                } else {
                    0.0
                }
            })
            .collect();
        let spectral = Spectral::new(g.nx, g.ny);
        let cinv = spectral.multiplier(&inv);
        let rx_max = regions.iter().map(|r| r.0).max().expect("a window");
        let ry_max = regions.iter().map(|r| r.1).max().expect("a window");
        let t = table(&g, Kernel::Stiffness, rx_max, ry_max);
        // (the table holds offsets up to the fine period − 1; a region spanning the period
        // reaches offset = period, which is offset 0)
        let (fx, fy) = (g.nx * g.f, g.ny * g.f);
        let stride = ry_max.min(fy - 1) + 1;
        let spaces = gs
            .iter()
            .zip(regions)
            .zip(weights)
            .map(|((&g, &(rx, ry)), weight)| FineSpace {
                g,
                rx,
                ry,
                fine: Padded::new(rx, ry, |i, j| {
                    t[(i.unsigned_abs() % fx) * stride + j.unsigned_abs() % fy]
                }),
                in_fine: (0..rx * ry)
                    .map(|k| {
                        let base = (k / ry).is_multiple_of(g.f) && (k % ry).is_multiple_of(g.f);
                        if hierarchical && base {
                            0.0
                        } else {
                            1.0 / weight[k]
                        }
                    })
                    .collect(),
            })
            .collect();
        TwoLevel {
            spectral,
            cinv,
            spaces,
        }
    }

    /// B y for y given on the windows' fine nodes (`y_r`, each rx × ry row-major, in order)
    /// and on the base nodes outside them (`y_out`, every base node, entries of nodes on a
    /// window ignored). Returns B y in the same two parts (the second's entries on the
    /// windows' base nodes are z_v there, unused).
    pub fn apply(&mut self, y_r: &[f64], y_out: &[f64], on_r: &[bool]) -> (Vec<f64>, Vec<f64>) {
        // y_v = J_cᵀ y
        let mut y_v: Vec<f64> = y_out
            .iter()
            .zip(on_r)
            .map(|(y, r)| if *r { 0.0 } else { *y })
            .collect();
        let mut off = 0;
        for sp in &self.spaces {
            let (rx, ry, f) = (sp.rx, sp.ry, sp.g.f);
            let fi = f as isize;
            let y_r = &y_r[off..off + rx * ry];
            for ci in 0..=sp.g.wx as isize {
                for cj in 0..=sp.g.wy as isize {
                    let mut s = 0.0;
                    for da in 1 - fi..fi {
                        let a = ci * fi + da;
                        if a < 0 || a as usize >= rx {
                            continue;
                        }
                        let wa = hat(da, f);
                        let row = &y_r[a as usize * ry..(a as usize + 1) * ry];
                        for db in 1 - fi..fi {
                            let b = cj * fi + db;
                            if b < 0 || b as usize >= ry {
                                continue;
                            }
                            s += wa * hat(db, f) * row[b as usize];
                        }
                    }
                    y_v[sp.g.base(ci, cj)] += s;
                }
            }
            off += rx * ry;
        }
        let mut z_v = vec![0.0; y_v.len()];
        self.spectral.convolve_with(&y_v, &self.cinv, &mut z_v);
        let mut out = Vec::with_capacity(y_r.len());
        let mut off = 0;
        for sp in &mut self.spaces {
            let (rx, ry, f) = (sp.rx, sp.ry, sp.g.f);
            // fine space
            let y_d: Vec<f64> = y_r[off..off + rx * ry]
                .iter()
                .zip(&sp.in_fine)
                .map(|(y, m)| y * m)
                .collect();
            off += rx * ry;
            let mut z_r = vec![0.0; rx * ry];
            sp.fine.apply(&y_d, &mut z_r);
            for (z, m) in z_r.iter_mut().zip(&sp.in_fine) {
                *z *= m;
            }
            // + J_c z_v
            for (a, row) in z_r.chunks_mut(ry).enumerate() {
                let (ca, sa) = ((a / f) as isize, a % f);
                let wa = sa as f64 / f as f64;
                for (b, z) in row.iter_mut().enumerate() {
                    let (cb, sb) = ((b / f) as isize, b % f);
                    let wb = sb as f64 / f as f64;
                    let v = |di: isize, dj: isize| z_v[sp.g.base(ca + di, cb + dj)];
                    let mut s = (1.0 - wa) * (1.0 - wb) * v(0, 0);
                    if sb > 0 {
                        s += (1.0 - wa) * wb * v(0, 1);
                    }
                    if sa > 0 {
                        s += wa * (1.0 - wb) * v(1, 0);
                        if sb > 0 {
                            s += wa * wb * v(1, 1);
                        }
                    }
                    *z += s;
                }
            }
            out.extend(z_r);
        }
        (out, z_v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The coarse solve inverts the hats' circulant C on zero-mean base fields.
    #[test]
    fn the_coarse_solve_inverts_c() {
        let g = Geometry {
            nx: 16,
            ny: 12,
            lx: 1.0,
            ly: 0.8,
            f: 4,
            i0: 3,
            j0: 5,
            wx: 4,
            wy: 3,
            margin: 0,
            order: 8,
        };
        let c = super::super::blocks::alias_spectra(&g, Kernel::Compliance).c;
        let mut t = TwoLevel::new(&[g], &[(17, 13)], &[&[1.0; 17 * 13]], false, &c);
        let cm = t.spectral.multiplier(&c);
        let n = g.nx * g.ny;
        let mut x: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
        let mean = x.iter().sum::<f64>() / n as f64;
        x.iter_mut().for_each(|v| *v -= mean);
        let mut cx = vec![0.0; n];
        t.spectral.convolve_with(&x, &cm, &mut cx);
        let mut back = vec![0.0; n];
        t.spectral.convolve_with(&cx, &t.cinv, &mut back);
        let err = x
            .iter()
            .zip(&back)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        // rounding of 16 × 12 transforms on O(10) values, condition of C ~ 10
        assert!(err < 1e-11, "{err:e}");
    }
}
