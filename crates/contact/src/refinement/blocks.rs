//! The composite operator applied blockwise, without the fine lattice (see the parent module's
//! docs, "Blockwise application").
//!
//! Write the composite pressure as p = H v + d: H v the bilinear interpolant of nodal values v
//! on every base node (the coarse unknowns outside R, the fine unknowns at R's base nodes), d
//! the fine remainder on R (zero at R's base nodes; zero outside R, where p = H v exactly). The
//! unknowns map to (v, d) by a bijection T, and ½ pᵀ G p splits into
//! - vᵀ C v, C = Hᵀ G H: a circulant on the base grid (hats are translates by a base period),
//!   its spectrum an alias sum over the f² fine modes of each base mode (exact, setup only);
//! - zᵀ G z − v_Eᵀ C v_E with z = H v_E + d, v_E the nodal values on the base nodes within
//!   `margin` base cells of R (set E): z lives on a box of fine nodes around R, so G z is a
//!   zero-padded FFT on the box with the real-space table of G (exact);
//! - 2 dᵀ (G H v_F) on R, v_F the nodal values outside E: the field of hats at least `margin`
//!   cells from R's base nodes. Its exact values at base nodes are C' v_F (C' the circulant
//!   (G ∗ hat) sampled on the base lattice, alias sum as for C); on R's fine nodes it is
//!   interpolated from them (tensor cubic Lagrange over the base nodes R ± 1 cell). This is the
//!   only approximation, and it keeps one energy (the transposed block uses the adjoint
//!   interpolation), so the operator stays symmetric.
//!
//! The same machinery with G replaced by the fine stiffness K_f is the Galerkin preconditioner
//! Pᵀ K_f P ([`super::Preconditioner::Galerkin`]; the default two-level one needs no box,
//! [`super::twolevel`]).

use crate::free_kernel::FreeKernel;
use crate::spectral::Spectral;
use rayon::prelude::*;
use rustfft::FftPlanner;

/// A fine-lattice circulant given by its spectrum (eigenvalue per fine mode).
#[derive(Debug, Clone, Copy)]
pub(crate) enum Kernel {
    /// G_f: 1/k(q), zero at q = 0.
    Compliance,
    /// K_f: k(q) = |q|/2 (E* = 1), zero at q = 0.
    Stiffness,
}

/// Geometry of the fine lattice and the window.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Geometry {
    pub nx: usize,
    pub ny: usize,
    pub lx: f64,
    pub ly: f64,
    pub f: usize,
    pub i0: usize,
    pub j0: usize,
    pub wx: usize,
    pub wy: usize,
    pub margin: usize,
    /// Points of the Lagrange interpolation of the far field per axis (even, ≥ 2).
    pub order: usize,
}

impl Geometry {
    fn fine(&self) -> (usize, usize) {
        (self.nx * self.f, self.ny * self.f)
    }
    /// Fine nodes of R per side.
    pub fn region(&self) -> (usize, usize) {
        (self.wx * self.f + 1, self.wy * self.f + 1)
    }
    /// Fine nodes of the box per side, and its first node relative to R's.
    fn boxed(&self) -> (usize, usize, isize) {
        let (f, m) = (self.f, self.margin);
        (
            (self.wx + 2 * m + 2) * f - 1,
            (self.wy + 2 * m + 2) * f - 1,
            -(((m + 1) * f) as isize) + 1,
        )
    }
    pub(crate) fn base(&self, rel_i: isize, rel_j: isize) -> usize {
        let i = (self.i0 as isize + rel_i).rem_euclid(self.nx as isize) as usize;
        let j = (self.j0 as isize + rel_j).rem_euclid(self.ny as isize) as usize;
        i * self.ny + j
    }
    fn eigen(&self, kernel: Kernel, kx: usize, ky: usize) -> f64 {
        let (fx, fy) = self.fine();
        let sx = if kx <= fx / 2 {
            kx as f64
        } else {
            kx as f64 - fx as f64
        };
        let sy = if ky <= fy / 2 {
            ky as f64
        } else {
            ky as f64 - fy as f64
        };
        let tau = 2.0 * std::f64::consts::PI;
        let k = 0.5 * (tau * sx / self.lx).hypot(tau * sy / self.ly);
        if k == 0.0 {
            0.0
        } else {
            match kernel {
                Kernel::Compliance => 1.0 / k,
                Kernel::Stiffness => k,
            }
        }
    }
}

/// Hat weight 1 − |a|/f.
pub(crate) fn hat(a: isize, f: usize) -> f64 {
    1.0 - a.unsigned_abs() as f64 / f as f64
}

/// Lagrange weights at t ∈ [0, 1) for the `order` nodes 1 − order/2 ..= order/2.
fn lagrange(t: f64, order: usize) -> Vec<f64> {
    let x = |k: usize| k as f64 + 1.0 - (order / 2) as f64;
    (0..order)
        .map(|k| {
            (0..order)
                .filter(|&m| m != k)
                .map(|m| (t - x(m)) / (x(k) - x(m)))
                .product()
        })
        .collect()
}

/// Real-space table t[dx·(by+1) + dy] = kernel(dx, dy) of the fine circulant for 0 ≤ dx ≤ bx,
/// 0 ≤ dy ≤ by (the kernel is even in each coordinate). Two passes of 1-D transforms; the work
/// array holds (F_x/2 + 1) × (by + 1) values, never the fine lattice.
pub(crate) fn table(g: &Geometry, kernel: Kernel, bx: usize, by: usize) -> Vec<f64> {
    let (fx, fy) = g.fine();
    let (bx, by) = (bx.min(fx - 1), by.min(fy - 1));
    let half = fx / 2 + 1;
    let fft_y = FftPlanner::<f64>::new().plan_fft_forward(fy);
    let mut rows = vec![0.0; half * (by + 1)];
    rows.par_chunks_mut(by + 1)
        .enumerate()
        .for_each(|(kx, out)| {
            let mut buf: Vec<num_complex::Complex64> = (0..fy)
                .map(|ky| num_complex::Complex64::new(g.eigen(kernel, kx, ky), 0.0))
                .collect();
            fft_y.process(&mut buf);
            for (o, c) in out.iter_mut().zip(&buf) {
                *o = c.re;
            }
        });
    let fft_x = FftPlanner::<f64>::new().plan_fft_forward(fx);
    let norm = (fx * fy) as f64;
    let cols: Vec<Vec<f64>> = (0..=by)
        .into_par_iter()
        .map(|dy| {
            let mut buf: Vec<num_complex::Complex64> = (0..fx)
                .map(|kx| {
                    let k = if kx < half { kx } else { fx - kx };
                    num_complex::Complex64::new(rows[k * (by + 1) + dy], 0.0)
                })
                .collect();
            fft_x.process(&mut buf);
            buf[..=bx].iter().map(|c| c.re / norm).collect()
        })
        .collect();
    let mut t = vec![0.0; (bx + 1) * (by + 1)];
    for (dy, col) in cols.iter().enumerate() {
        for (dx, v) in col.iter().enumerate() {
            t[dx * (by + 1) + dy] = *v;
        }
    }
    t
}

/// Half spectra (natural layout, normalised for [`Spectral`]) of C = Hᵀ K H,
/// C' = (K ∗ hat) sampled on the base lattice and K itself sampled on the base lattice: alias
/// sums over the f² fine modes of each base mode.
pub(crate) fn alias_spectra(g: &Geometry, kernel: Kernel) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (f, nx, ny) = (g.f, g.nx, g.ny);
    let (fx, fy) = g.fine();
    let phi = |k: usize, n: usize| -> f64 {
        if k == 0 {
            return f as f64;
        }
        let th = std::f64::consts::PI * k as f64 / n as f64;
        let r = (f as f64 * th).sin() / th.sin();
        r * r / f as f64
    };
    let px: Vec<f64> = (0..fx).map(|k| phi(k, fx)).collect();
    let py: Vec<f64> = (0..fy).map(|k| phi(k, fy)).collect();
    let m = ny / 2 + 1;
    let norm = (f * f * nx * ny) as f64;
    let triples: Vec<(f64, f64, f64)> = (0..nx * m)
        .into_par_iter()
        .map(|idx| {
            let (a, b) = (idx / m, idx % m);
            let (mut c, mut cp, mut pt) = (0.0, 0.0, 0.0);
            for mx in 0..f {
                let kx = a + nx * mx;
                for my in 0..f {
                    let ky = b + ny * my;
                    let e = g.eigen(kernel, kx, ky);
                    let h = px[kx] * py[ky];
                    c += h * h * e;
                    cp += h * e;
                    pt += e;
                }
            }
            (c / norm, cp / norm, pt / norm)
        })
        .collect();
    let mut out = (Vec::new(), Vec::new(), Vec::new());
    for (c, cp, pt) in triples {
        out.0.push(c);
        out.1.push(cp);
        out.2.push(pt);
    }
    out
}

/// The near field of one window: its box with the zero-padded kernel and the base nodes
/// within `margin` cells of it.
struct Near {
    g: Geometry,
    rx: usize,
    ry: usize,
    bx: usize,
    by: usize,
    origin: isize,
    /// Zero-padded convolution on the box.
    boxk: FreeKernel,
    /// Base nodes within `margin` cells of R.
    in_e: Vec<bool>,
}

/// One window's intermediate results of an application.
struct Part {
    /// G z on the box.
    gz: Vec<f64>,
    /// C v_F (F: base nodes outside E).
    c_vf: Vec<f64>,
    /// C' v_F.
    cp_vf: Vec<f64>,
    /// Sᵀ Πᵀ d: the remainder's adjoint interpolation onto base nodes.
    w: Vec<f64>,
}

/// One kernel's blockwise operator for one or several windows (see the module docs).
pub(crate) struct Blocks {
    near: Vec<Near>,
    spectral: Spectral,
    c: Vec<f64>,
    cp: Vec<f64>,
    /// The kernel sampled on the base lattice (point to point), for the remainders of two
    /// windows (only with several windows).
    cpp: Option<Vec<f64>>,
    /// Interpolation weights per fine offset in a cell (0..f).
    lag: Vec<Vec<f64>>,
    /// The kernel at offset 0.
    pub point: f64,
}

impl Blocks {
    /// For the windows `gs` (one [`Geometry`] each, same lattice, margin and order; checked by
    /// the caller to keep every window's R outside the other windows' margins).
    pub fn new(gs: &[Geometry], kernel: Kernel) -> Self {
        let g0 = gs[0];
        let boxes: Vec<(usize, usize, isize)> = gs.iter().map(|g| g.boxed()).collect();
        let bx_max = boxes.iter().map(|b| b.0).max().expect("a window");
        let by_max = boxes.iter().map(|b| b.1).max().expect("a window");
        let t = table(&g0, kernel, bx_max, by_max);
        let stride = by_max.min(g0.ny * g0.f - 1) + 1;
        let near = gs
            .iter()
            .zip(&boxes)
            .map(|(&g, &(bx, by, origin))| {
                let (rx, ry) = g.region();
                let boxk = FreeKernel::from_green(bx, by, |i, j| {
                    t[i.unsigned_abs() * stride + j.unsigned_abs()]
                });
                let m = g.margin as isize;
                let mut in_e = vec![false; g.nx * g.ny];
                for ei in -m..=g.wx as isize + m {
                    for ej in -m..=g.wy as isize + m {
                        in_e[g.base(ei, ej)] = true;
                    }
                }
                Near {
                    g,
                    rx,
                    ry,
                    bx,
                    by,
                    origin,
                    boxk,
                    in_e,
                }
            })
            .collect();
        let (c, cp, pt) = alias_spectra(&g0, kernel);
        let spectral = Spectral::new(g0.nx, g0.ny);
        let c = spectral.multiplier(&c);
        let cp = spectral.multiplier(&cp);
        let cpp = (gs.len() > 1).then(|| spectral.multiplier(&pt));
        let lag = (0..g0.f)
            .map(|s| lagrange(s as f64 / g0.f as f64, g0.order))
            .collect();
        Blocks {
            near,
            lag,
            point: t[0],
            spectral,
            c,
            cp,
            cpp,
        }
    }

    /// Applies Tᵀ Ĝ T to the unknowns: `fine` the fine nodes of every window's R in order
    /// (each rx × ry, row-major) and `v` the nodal values on every base node (R's base nodes
    /// carrying the fine unknown there). Returns the gradient on the windows' fine unknowns
    /// (with their base nodes' coarse terms added, same layout) and on every base node (only
    /// the nodes outside every R are used by the caller).
    pub fn apply(&mut self, fine: &[f64], v: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let nb = v.len();
        let mut parts = Vec::with_capacity(self.near.len());
        let mut off = 0;
        for near in &mut self.near {
            let n = near.rx * near.ry;
            let d = near.remainder(&fine[off..off + n], v);
            let gz = near.box_field(&d, v);
            let vf: Vec<f64> = v
                .iter()
                .zip(&near.in_e)
                .map(|(x, e)| if *e { 0.0 } else { *x })
                .collect();
            let mut cp_vf = vec![0.0; nb];
            self.spectral.convolve_with(&vf, &self.cp, &mut cp_vf);
            let mut c_vf = vec![0.0; nb];
            self.spectral.convolve_with(&vf, &self.c, &mut c_vf);
            let w = near.adjoint(&self.lag, &d, nb);
            parts.push(Part { gz, c_vf, cp_vf, w });
            off += n;
        }
        let mut c_v = vec![0.0; nb];
        self.spectral.convolve_with(v, &self.c, &mut c_v);
        let cp_w: Vec<Vec<f64>> = parts
            .iter()
            .map(|p| {
                let mut o = vec![0.0; nb];
                self.spectral.convolve_with(&p.w, &self.cp, &mut o);
                o
            })
            .collect();
        // remainders of the other windows, as point sources at base nodes (adjoint
        // interpolation), their field sampled at base nodes
        if let Some(cpp) = &self.cpp {
            let total: Vec<f64> = (0..nb)
                .map(|k| parts.iter().map(|p| p.w[k]).sum::<f64>())
                .collect();
            for p in parts.iter_mut() {
                let others: Vec<f64> = total.iter().zip(&p.w).map(|(t, w)| t - w).collect();
                let mut field = vec![0.0; nb];
                self.spectral.convolve_with(&others, cpp, &mut field);
                for (a, b) in p.cp_vf.iter_mut().zip(&field) {
                    *a += b;
                }
            }
        }
        // Hᵀ G z on each window's E
        let hgz: Vec<Vec<f64>> = self
            .near
            .iter()
            .zip(&parts)
            .map(|(near, p)| near.hat_field(&p.gz, nb))
            .collect();
        // g_v: one window's E: C v_F + Hᵀ G z (+ the other windows' far remainders);
        // outside every E: C v + C' Sᵀ Πᵀ d of every window; in several windows' E (their
        // margins overlap): C v + Σ (Hᵀ G z − C v_E) over those, far terms of the rest
        let mut gv = vec![0.0; nb];
        for (k, g) in gv.iter_mut().enumerate() {
            let inside: Vec<usize> = (0..parts.len()).filter(|&w| self.near[w].in_e[k]).collect();
            let far = |skip: &dyn Fn(usize) -> bool| -> f64 {
                (0..parts.len())
                    .filter(|&w| !skip(w))
                    .map(|w| cp_w[w][k])
                    .sum()
            };
            *g = match inside[..] {
                [] => {
                    if parts.len() == 1 {
                        c_v[k] + cp_w[0][k]
                    } else {
                        c_v[k] + far(&|_| false)
                    }
                }
                [a] => {
                    let s = parts[a].c_vf[k] + hgz[a][k];
                    if parts.len() == 1 {
                        s
                    } else {
                        s + far(&|w| w == a)
                    }
                }
                _ => {
                    let near: f64 = inside
                        .iter()
                        .map(|&w| hgz[w][k] - (c_v[k] - parts[w].c_vf[k]))
                        .sum();
                    c_v[k] + near + far(&|w| inside.contains(&w))
                }
            };
        }
        let mut out = Vec::with_capacity(fine.len());
        for (near, p) in self.near.iter().zip(&parts) {
            out.extend(near.gradient(&self.lag, p, &gv));
        }
        (out, gv)
    }
}

impl Near {
    /// d = p_R − I_R v.
    fn remainder(&self, fine: &[f64], v: &[f64]) -> Vec<f64> {
        let ry = self.ry;
        let mut d = vec![0.0; self.rx * ry];
        d.par_chunks_mut(ry).enumerate().for_each(|(a, row)| {
            for (b, x) in row.iter_mut().enumerate() {
                *x = fine[a * ry + b] - self.bilinear(v, None, a as isize, b as isize);
            }
        });
        d
    }

    /// G z on the box, z = H v_E + d.
    fn box_field(&mut self, d: &[f64], v: &[f64]) -> Vec<f64> {
        let (rx, ry, bx, by, o) = (self.rx, self.ry, self.bx, self.by, self.origin);
        let mut z = vec![0.0; bx * by];
        {
            let this = &*self;
            let mask = Some(&this.in_e[..]);
            z.par_chunks_mut(by).enumerate().for_each(|(u, row)| {
                let a = u as isize + o;
                for (w, x) in row.iter_mut().enumerate() {
                    let b = w as isize + o;
                    let mut s = this.bilinear(v, mask, a, b);
                    if a >= 0 && (a as usize) < rx && b >= 0 && (b as usize) < ry {
                        s += d[a as usize * ry + b as usize];
                    }
                    *x = s;
                }
            });
        }
        let mut gz = vec![0.0; bx * by];
        crate::compliance::Compliance::displacement(&mut self.boxk, &z, &mut gz);
        gz
    }

    /// w = Sᵀ Πᵀ d on every base node (zero off the stencil's base nodes): the adjoint of the
    /// Lagrange interpolation from base nodes R ± order/2 onto R's fine nodes.
    fn adjoint(&self, lag: &[Vec<f64>], d: &[f64], nb: usize) -> Vec<f64> {
        let (rx, ry, fu, pp) = (self.rx, self.ry, self.g.f, self.g.order);
        let lo = 1 - (pp / 2) as isize;
        let sx = self.g.wx + pp;
        let mut bx_ = vec![0.0; sx * ry];
        for a in 0..rx {
            let (ca, wa) = (a / fu, &lag[a % fu]);
            for (p, wp) in wa.iter().enumerate() {
                if *wp != 0.0 {
                    let dst = &mut bx_[(ca + p) * ry..(ca + p + 1) * ry];
                    for (x, dv) in dst.iter_mut().zip(&d[a * ry..(a + 1) * ry]) {
                        *x += wp * dv;
                    }
                }
            }
        }
        let mut w = vec![0.0; nb];
        for is in 0..sx {
            for b in 0..ry {
                let (cb, wb) = (b / fu, &lag[b % fu]);
                let val = bx_[is * ry + b];
                for (q, wq) in wb.iter().enumerate() {
                    if *wq != 0.0 {
                        w[self.g.base(is as isize + lo, (cb + q) as isize + lo)] += wq * val;
                    }
                }
            }
        }
        w
    }

    /// Hᵀ G z on the base nodes of E (NaN elsewhere).
    fn hat_field(&self, gz: &[f64], nb: usize) -> Vec<f64> {
        let (by, o) = (self.by, self.origin);
        let f = self.g.f as isize;
        let m = self.g.margin as isize;
        let mut out = vec![f64::NAN; nb];
        for ei in -m..=self.g.wx as isize + m {
            for ej in -m..=self.g.wy as isize + m {
                let mut s = 0.0;
                for da in 1 - f..f {
                    let u = (ei * f + da - o) as usize;
                    let line = &gz[u * by..(u + 1) * by];
                    let mut sa = 0.0;
                    for db in 1 - f..f {
                        sa += hat(db, self.g.f) * line[(ej * f + db - o) as usize];
                    }
                    s += hat(da, self.g.f) * sa;
                }
                out[self.g.base(ei, ej)] = s;
            }
        }
        out
    }

    /// The gradient on R's fine unknowns: g_d = (G z)|_R + Π (far field at base nodes), and
    /// on R's base nodes g_v − I_Rᵀ g_d added (Tᵀ).
    fn gradient(&self, lag: &[Vec<f64>], p: &Part, gv: &[f64]) -> Vec<f64> {
        let (rx, ry, by, o) = (self.rx, self.ry, self.by, self.origin);
        let f = self.g.f as isize;
        let (fu, pp) = (self.g.f, self.g.order);
        let lo = 1 - (pp / 2) as isize;
        let sx = self.g.wx + pp;
        let (gz, far) = (&p.gz, &p.cp_vf);
        let mut ay = vec![0.0; sx * ry];
        ay.par_chunks_mut(ry).enumerate().for_each(|(is, row)| {
            for (b, x) in row.iter_mut().enumerate() {
                let (cb, wb) = (b / fu, &lag[b % fu]);
                let mut acc = 0.0;
                for (q, wq) in wb.iter().enumerate() {
                    if *wq != 0.0 {
                        acc += wq * far[self.g.base(is as isize + lo, (cb + q) as isize + lo)];
                    }
                }
                *x = acc;
            }
        });
        let mut gd = vec![0.0; rx * ry];
        gd.par_chunks_mut(ry).enumerate().for_each(|(a, row)| {
            let (ca, wa) = (a / fu, &lag[a % fu]);
            for (b, x) in row.iter_mut().enumerate() {
                let mut acc = 0.0;
                for (q, wq) in wa.iter().enumerate() {
                    if *wq != 0.0 {
                        acc += wq * ay[(ca + q) * ry + b];
                    }
                }
                let (u, t) = ((a as isize - o) as usize, (b as isize - o) as usize);
                *x = gz[u * by + t] + acc;
            }
        });
        // Tᵀ: fine unknowns get g_d; R's base nodes add g_v − I_Rᵀ g_d
        let mut out = gd.clone();
        for ci in 0..=self.g.wx as isize {
            for cj in 0..=self.g.wy as isize {
                let mut s = 0.0;
                for da in 1 - f..f {
                    let a = ci * f + da;
                    if a < 0 || a as usize >= rx {
                        continue;
                    }
                    for db in 1 - f..f {
                        let b = cj * f + db;
                        if b < 0 || b as usize >= ry {
                            continue;
                        }
                        s += hat(da, self.g.f)
                            * hat(db, self.g.f)
                            * gd[a as usize * ry + b as usize];
                    }
                }
                let k = (ci * f) as usize * ry + (cj * f) as usize;
                out[k] += gv[self.g.base(ci, cj)] - s;
            }
        }
        out
    }

    /// Bilinear interpolant of base values `v` (masked by `mask` if given) at the fine node
    /// (a, b) relative to R's first node.
    fn bilinear(&self, v: &[f64], mask: Option<&[bool]>, a: isize, b: isize) -> f64 {
        let f = self.g.f as isize;
        let (ca, sa, cb, sb) = (
            a.div_euclid(f),
            a.rem_euclid(f),
            b.div_euclid(f),
            b.rem_euclid(f),
        );
        let mut s = 0.0;
        for (di, wi) in [(0, 1.0 - sa as f64 / f as f64), (1, sa as f64 / f as f64)] {
            if wi == 0.0 {
                continue;
            }
            for (dj, wj) in [(0, 1.0 - sb as f64 / f as f64), (1, sb as f64 / f as f64)] {
                if wj == 0.0 {
                    continue;
                }
                let k = self.g.base(ca + di, cb + dj);
                if mask.is_none_or(|m| m[k]) {
                    s += wi * wj * v[k];
                }
            }
        }
        s
    }
}

/// Weights W = Pᵀ1 of the composite unknowns: f² for a coarse hat, 1 for a fine node of R, and
/// 1 + (the hat's mass outside R) for R's base nodes. `fine` is rx × ry.
pub(crate) fn weights(g: &Geometry) -> (Vec<f64>, f64) {
    let (rx, ry) = g.region();
    let f = g.f;
    let edge = |c: usize, w: usize| -> f64 {
        // hat mass inside R along one axis
        if c == 0 || c == w {
            (f as f64 + 1.0) / 2.0
        } else {
            f as f64
        }
    };
    let mut w = vec![1.0; rx * ry];
    for ci in 0..=g.wx {
        for cj in 0..=g.wy {
            let inside = edge(ci, g.wx) * edge(cj, g.wy);
            w[ci * f * ry + cj * f] = 1.0 + (f * f) as f64 - inside;
        }
    }
    (w, (f * f) as f64)
}

/// Hᵀ h on every base node for a height function h(i, j) of the fine lattice node (i, j)
/// (global indices). Streams the fine lattice by fine rows, each fine node evaluated once
/// (memory F_x × ny, not the fine lattice; at k = 6 on a 256² base this is the largest part of
/// the setup: 16 s of 31 when each node was evaluated twice).
pub(crate) fn hat_heights(g: &Geometry, h: &(impl Fn(usize, usize) -> f64 + Sync)) -> Vec<f64> {
    let (fx, fy) = g.fine();
    let f = g.f;
    let (nx, ny) = (g.nx, g.ny);
    // s[fi ny + j] = Σ_db hat(db) h(fi, f j + db)
    let mut rows = vec![0.0; fx * ny];
    rows.par_chunks_mut(ny).enumerate().for_each(|(fi, out)| {
        let line: Vec<f64> = (0..fy).map(|j| h(fi, j)).collect();
        for (j, o) in out.iter_mut().enumerate() {
            let mut sa = 0.0;
            for db in 1 - f as isize..f as isize {
                let fj = ((f * j) as isize + db).rem_euclid(fy as isize) as usize;
                sa += hat(db, f) * line[fj];
            }
            *o = sa;
        }
    });
    (0..nx * ny)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k / ny, k % ny);
            let mut s = 0.0;
            for da in 1 - f as isize..f as isize {
                let fi = ((f * i) as isize + da).rem_euclid(fx as isize) as usize;
                s += hat(da, f) * rows[fi * ny + j];
            }
            s
        })
        .collect()
}

/// Pᵀ h on R (rx × ry) of the window `g`, given Hᵀ h on every base node (`hv`,
/// [`hat_heights`]): the heights at R's fine nodes, R's base nodes adding the hat mass outside
/// R.
pub(crate) fn window_heights(
    g: &Geometry,
    h: &(impl Fn(usize, usize) -> f64 + Sync),
    hv: &[f64],
) -> Vec<f64> {
    let (fx, fy) = g.fine();
    let f = g.f;
    let (rx, ry) = g.region();
    let hr: Vec<f64> = (0..rx * ry)
        .map(|k| {
            let (a, b) = (k / ry, k % ry);
            h((g.i0 * f + a) % fx, (g.j0 * f + b) % fy)
        })
        .collect();
    let mut out = hr.clone();
    for ci in 0..=g.wx {
        for cj in 0..=g.wy {
            let mut s = 0.0;
            for da in 1 - f as isize..f as isize {
                let a = (ci * f) as isize + da;
                if a < 0 || a as usize >= rx {
                    continue;
                }
                for db in 1 - f as isize..f as isize {
                    let b = (cj * f) as isize + db;
                    if b < 0 || b as usize >= ry {
                        continue;
                    }
                    s += hat(da, f) * hat(db, f) * hr[a as usize * ry + b as usize];
                }
            }
            out[ci * f * ry + cj * f] += hv[g.base(ci as isize, cj as isize)] - s;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The alias sums are the fine kernel sampled on the base lattice: C'' at base offset Δ is
    /// the real-space table at fine offset f Δ, C' the table convolved with one hat, C with
    /// two (exact up to rounding).
    #[test]
    fn the_alias_sums_are_the_sampled_fine_kernel() {
        let g = kernel_geometry(16, 12, 0.8);
        let (fx, fy) = (g.nx * g.f, g.ny * g.f);
        let t = table(&g, Kernel::Compliance, fx - 1, fy - 1);
        let tk = |i: isize, j: isize| {
            let (i, j) = (
                i.rem_euclid(fx as isize) as usize,
                j.rem_euclid(fy as isize) as usize,
            );
            let (i, j) = (i.min(fx - i), j.min(fy - j));
            t[i * fy + j]
        };
        let (c, cp, pt) = alias_spectra(&g, Kernel::Compliance);
        let mut sp = Spectral::new(g.nx, g.ny);
        let n = g.nx * g.ny;
        let mut e = vec![0.0; n];
        e[0] = 1.0;
        let mut conv = |m: &[f64]| {
            let mut o = vec![0.0; n];
            let mult = sp.multiplier(m);
            sp.convolve_with(&e, &mult, &mut o);
            o
        };
        let (oc, ocp, opt) = (conv(&c), conv(&cp), conv(&pt));
        let f = g.f as isize;
        let mut worst = [0.0f64; 3];
        for (di, dj) in [(0isize, 0isize), (1, 0), (3, 2), (5, 7), (8, 6)] {
            let k = (di as usize) * g.ny + dj as usize;
            let want_pt = tk(f * di, f * dj);
            let mut want_cp = 0.0;
            let mut want_c = 0.0;
            for a in 1 - f..f {
                for b in 1 - f..f {
                    let h = hat(a, g.f) * hat(b, g.f);
                    want_cp += h * tk(f * di + a, f * dj + b);
                    for a2 in 1 - f..f {
                        for b2 in 1 - f..f {
                            let h2 = hat(a2, g.f) * hat(b2, g.f);
                            want_c += h * h2 * tk(f * di + a - a2, f * dj + b - b2);
                        }
                    }
                }
            }
            eprintln!(
                "Δ ({di}, {dj}): point {:.6e} vs {want_pt:.6e}, hat {:.6e} vs {want_cp:.6e}, hats {:.6e} vs {want_c:.6e}",
                opt[k], ocp[k], oc[k]
            );
            worst[0] = worst[0].max((opt[k] - want_pt).abs() / want_pt.abs());
            worst[1] = worst[1].max((ocp[k] - want_cp).abs() / want_cp.abs());
            worst[2] = worst[2].max((oc[k] - want_c).abs() / want_c.abs());
        }
        // rounding of 32 × 24 transforms
        assert!(worst.iter().all(|w| *w < 1e-10), "{worst:?}");
    }
}

/// A geometry for tests of the kernels alone: nx × ny base cells of a 1 × `ly` cell, f = 2, a
/// one-cell window at the origin.
#[cfg(test)]
fn kernel_geometry(nx: usize, ny: usize, ly: f64) -> Geometry {
    Geometry {
        nx,
        ny,
        lx: 1.0,
        ly,
        f: 2,
        i0: 0,
        j0: 0,
        wx: 1,
        wy: 1,
        margin: 0,
        order: 8,
    }
}

#[cfg(test)]
mod ringing {
    use super::*;

    /// Diagnostic (ignored): the fine kernel along x at distance, its smooth part (a local
    /// cubic fit over every f-th node) and the remainder at the other nodes.
    #[test]
    #[ignore]
    fn fine_kernel_has_a_grid_scale_component() {
        let g = kernel_geometry(64, 32, 1.3);
        let (fx, fy) = (g.nx * g.f, g.ny * g.f);
        let t = table(&g, Kernel::Compliance, fx - 1, fy - 1);
        for j in [0usize, 1, 2] {
            let v: Vec<f64> = (40..60).map(|i| t[i * fy + j]).collect();
            // second differences: smooth → slowly varying, grid-scale part → alternating
            let d2: Vec<String> = v
                .windows(3)
                .map(|w| format!("{:+.2e}", w[0] - 2.0 * w[1] + w[2]))
                .collect();
            eprintln!(
                "row j = {j}: G {:.4e} …; second differences {}",
                v[0],
                d2.join(" ")
            );
        }
    }
}
