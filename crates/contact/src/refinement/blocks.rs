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
    /// The wave-number component τ s/l of every fine mode index 0..n along one axis (s the
    /// signed index: k, or k − n above n/2), as [`Geometry::eigen`] computes it.
    fn wave_numbers(n: usize, l: f64) -> Vec<f64> {
        let tau = 2.0 * std::f64::consts::PI;
        (0..n)
            .map(|k| {
                let s = if k <= n / 2 {
                    k as f64
                } else {
                    k as f64 - n as f64
                };
                tau * s / l
            })
            .collect()
    }
    /// The kernel's eigenvalue at the fine mode with wave-number components (qx, qy) (from
    /// [`Geometry::wave_numbers`]; bit for bit [`Geometry::eigen`]).
    #[inline]
    fn eigen_q(kernel: Kernel, qx: f64, qy: f64) -> f64 {
        let k = 0.5 * qx.hypot(qy);
        if k == 0.0 {
            0.0
        } else {
            match kernel {
                Kernel::Compliance => 1.0 / k,
                Kernel::Stiffness => k,
            }
        }
    }
    /// The kernel's eigenvalue at the fine mode (kx, ky) (the reference of the tables' and alias
    /// sums' inner loops, which take the wave numbers per axis).
    #[cfg(test)]
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
        Self::eigen_q(kernel, tau * sx / self.lx, tau * sy / self.ly)
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
/// array holds (F_x/2 + 1) × (by + 1) values, never the fine lattice. The eigenvalues of a row
/// come from per-axis wave numbers, the upper half of the row mirrored from the lower (the
/// kernel is even, and so is each rounded step: s and −s give the same bits), so each
/// distinct eigenvalue is evaluated once; the values are bit for bit those of the direct
/// evaluation (test `the_fast_setup_is_bitwise_the_direct_one`).
pub(crate) fn table(g: &Geometry, kernel: Kernel, bx: usize, by: usize) -> Vec<f64> {
    let (fx, fy) = g.fine();
    let (bx, by) = (bx.min(fx - 1), by.min(fy - 1));
    let half = fx / 2 + 1;
    let qx = Geometry::wave_numbers(fx, g.lx);
    let qy = Geometry::wave_numbers(fy, g.ly);
    let fft_y = FftPlanner::<f64>::new().plan_fft_forward(fy);
    let mut rows = vec![0.0; half * (by + 1)];
    rows.par_chunks_mut(by + 1).enumerate().for_each_init(
        || vec![num_complex::Complex64::new(0.0, 0.0); fy],
        |buf, (kx, out)| {
            let q = qx[kx];
            for ky in 0..=fy / 2 {
                buf[ky] = num_complex::Complex64::new(Geometry::eigen_q(kernel, q, qy[ky]), 0.0);
            }
            for ky in fy / 2 + 1..fy {
                buf[ky] = buf[fy - ky];
            }
            fft_y.process(buf);
            for (o, c) in out.iter_mut().zip(buf.iter()) {
                *o = c.re;
            }
        },
    );
    x_pass(&rows, (fx, fy), bx, by)
}

/// The second pass of [`table`]: the x transforms of the rows (kx ≤ F_x/2, the upper half
/// mirrored), normalised, cut to 0 ≤ dx ≤ bx and laid out t[dx·(by+1) + dy].
fn x_pass(rows: &[f64], (fx, fy): (usize, usize), bx: usize, by: usize) -> Vec<f64> {
    let half = fx / 2 + 1;
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

/// The alias sums of one kernel (half spectra, natural layout, normalised for [`Spectral`]):
/// C = Hᵀ K H, C' = (K ∗ hat) sampled on the base lattice, and K itself sampled on the base
/// lattice ([`alias_spectra`]).
#[derive(Debug, Clone)]
pub(crate) struct AliasSpectra {
    pub c: Vec<f64>,
    pub cp: Vec<f64>,
    pub pt: Vec<f64>,
}

/// The hat's spectral factor φ(k) = sin²(fπk/n) / (f sin²(πk/n)) (f at k = 0) for every fine
/// mode k < n of an axis of n fine nodes.
fn hat_factors(f: usize, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| {
            if k == 0 {
                return f as f64;
            }
            let th = std::f64::consts::PI * k as f64 / n as f64;
            let r = (f as f64 * th).sin() / th.sin();
            r * r / f as f64
        })
        .collect()
}

/// Half spectra (natural layout, normalised for [`Spectral`]) of C = Hᵀ K H,
/// C' = (K ∗ hat) sampled on the base lattice and K itself sampled on the base lattice: alias
/// sums over the f² fine modes of each base mode.
///
/// Cost: f² N_base/2 terms of a multiply and three adds, plus f² N_base/4 eigenvalues (a
/// hypot and a division). The wave numbers and hat factors are tabulated per axis; the base
/// modes a and n_x − a (a ≠ 0, n_x/2) share their aliases' eigenvalues (the alias m of one is
/// the alias f − 1 − m of the other with the opposite signed index, which rounds to the same
/// bits), so one block of f² eigenvalues serves both, each summed in its own alias order.
/// The sums are bit for bit those of the direct loop over the fine modes (test
/// `the_fast_setup_is_bitwise_the_direct_one`), so results do not change.
pub(crate) fn alias_spectra(g: &Geometry, kernel: Kernel) -> AliasSpectra {
    let (f, nx, ny) = (g.f, g.nx, g.ny);
    let (fx, fy) = g.fine();
    let (px, py) = (hat_factors(f, fx), hat_factors(f, fy));
    let qx = Geometry::wave_numbers(fx, g.lx);
    let qy = Geometry::wave_numbers(fy, g.ly);
    let m = ny / 2 + 1;
    let norm = (f * f * nx * ny) as f64;
    // one base row a (and its mirror nx − a): (a, its triples, the mirror's triples)
    type Rows = (usize, Vec<[f64; 3]>, Option<Vec<[f64; 3]>>);
    let rows: Vec<Rows> = (0..=nx / 2)
        .into_par_iter()
        .map(|a| {
            let mirror = (a != 0 && 2 * a != nx).then_some(nx - a);
            let mut e = vec![0.0; f * f];
            let (mut own, mut other) = (Vec::with_capacity(m), Vec::with_capacity(m));
            for b in 0..m {
                for mx in 0..f {
                    let q = qx[a + nx * mx];
                    for my in 0..f {
                        e[mx * f + my] = Geometry::eigen_q(kernel, q, qy[b + ny * my]);
                    }
                }
                let sums = |kx0: usize, rev: bool| -> [f64; 3] {
                    let (mut c, mut cp, mut pt) = (0.0, 0.0, 0.0);
                    for mx in 0..f {
                        let hx = px[kx0 + nx * mx];
                        let row = if rev { f - 1 - mx } else { mx };
                        let er = &e[row * f..(row + 1) * f];
                        for (my, &e) in er.iter().enumerate() {
                            let h = hx * py[b + ny * my];
                            c += h * h * e;
                            cp += h * e;
                            pt += e;
                        }
                    }
                    [c / norm, cp / norm, pt / norm]
                };
                own.push(sums(a, false));
                if let Some(am) = mirror {
                    other.push(sums(am, true));
                }
            }
            (a, own, mirror.map(|_| other))
        })
        .collect();
    let mut out = AliasSpectra {
        c: vec![0.0; nx * m],
        cp: vec![0.0; nx * m],
        pt: vec![0.0; nx * m],
    };
    let mut put = |a: usize, t: &[[f64; 3]]| {
        for (b, v) in t.iter().enumerate() {
            out.c[a * m + b] = v[0];
            out.cp[a * m + b] = v[1];
            out.pt[a * m + b] = v[2];
        }
    };
    for (a, own, other) in &rows {
        put(*a, own);
        if let Some(o) = other {
            put(nx - a, o);
        }
    }
    out
}

/// The smallest 2^a 3^b 5^c ≥ n: a side whose FFT has only small radices (the boxes' natural
/// sides, (w + 2 margin + 2) 2^k − 1 and w 2^k + 1, padded to twice themselves are often twice
/// a large prime, e.g. 2 · 463 at w = 32, margin 12, k = 3, which rustfft transforms by Rader's
/// algorithm at several times the cost per node).
pub(crate) fn smooth(n: usize) -> usize {
    let mut best = usize::MAX;
    let mut p5 = 1;
    while p5 < 2 * n {
        let mut p35 = p5;
        while p35 < 2 * n {
            let mut m = p35;
            while m < n {
                m *= 2;
            }
            best = best.min(m);
            p35 *= 3;
        }
        p5 *= 5;
    }
    best
}

/// The zero-padded (free) convolution of an nx × ny block with an even kernel, computed on a
/// block of [`smooth`] sides ≥ nx × ny with the kernel cut to offsets below nx, ny (the
/// offsets between two nodes of the block; farther entries never meet a nonzero source that
/// lands on the block, so the result on the block is the same convolution, to rounding).
pub(crate) struct Padded {
    kernel: FreeKernel,
    nx: usize,
    ny: usize,
    py: usize,
    input: Vec<f64>,
    output: Vec<f64>,
}

impl Padded {
    /// For the kernel `green(di, dj)` (|di| < nx, |dj| < ny), even in each coordinate.
    pub fn new(nx: usize, ny: usize, green: impl Fn(isize, isize) -> f64) -> Self {
        let (px, py) = (smooth(nx), smooth(ny));
        let kernel = FreeKernel::from_green(px, py, |i, j| {
            if i.unsigned_abs() < nx && j.unsigned_abs() < ny {
                green(i, j)
            } else {
                0.0
            }
        });
        Padded {
            kernel,
            nx,
            ny,
            py,
            input: vec![0.0; px * py],
            output: vec![0.0; px * py],
        }
    }

    /// out = the convolution of `z` (both nx × ny, row-major).
    pub fn apply(&mut self, z: &[f64], out: &mut [f64]) {
        let (ny, py) = (self.ny, self.py);
        for (dst, src) in self.input.chunks_mut(py).zip(z.chunks(ny)) {
            dst[..ny].copy_from_slice(src);
        }
        crate::compliance::Compliance::displacement(
            &mut self.kernel,
            &self.input,
            &mut self.output,
        );
        for (dst, src) in out.chunks_mut(ny).zip(self.output.chunks(py)).take(self.nx) {
            dst.copy_from_slice(&src[..ny]);
        }
    }
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
    boxk: Padded,
    /// Zero-padded convolution of the hats' circulant C on E (a rectangle of ex × ey base
    /// nodes from R's first node − margin): C v_E on E, from which C v_F = C v − C v_E there.
    ek: Padded,
    ex: usize,
    ey: usize,
    /// Base nodes within `margin` cells of R.
    in_e: Vec<bool>,
}

/// One axis of a bilinear stencil: the two base nodes (periodic index along the axis) and
/// their weights.
#[derive(Debug, Clone, Copy)]
struct Stencil {
    node: [usize; 2],
    weight: [f64; 2],
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
    /// Work arrays kept between applications (a fresh base-grid array per term cost page
    /// faults: ~20 % of a solve's CPU time in system time at 1024², k = 3).
    pool: Vec<Vec<f64>>,
    /// C v_F by a base-grid transform (the first design; the reference of the local one).
    #[cfg(test)]
    far_by_base_transform: bool,
}

/// A work array of `n` values `fill` from `pool`: the smallest pooled array that holds n
/// values (so that base-grid, box and window arrays keep to their own sizes and the pool does
/// not grow every array to the box's size), or a new one.
fn take(pool: &mut Vec<Vec<f64>>, n: usize, fill: f64) -> Vec<f64> {
    let best = pool
        .iter()
        .enumerate()
        .filter(|(_, v)| v.capacity() >= n)
        .min_by_key(|(_, v)| v.capacity())
        .map(|(k, _)| k);
    let mut v = match best {
        Some(k) => pool.swap_remove(k),
        None => Vec::with_capacity(n),
    };
    v.clear();
    v.resize(n, fill);
    v
}

impl Blocks {
    /// For the windows `gs` (one [`Geometry`] each, same lattice, margin and order; checked by
    /// the caller to keep every window's R outside the other windows' margins), with the
    /// kernel's alias sums `alias` ([`alias_spectra`] of `gs[0]`, computed once by the caller
    /// and shared with the preconditioner).
    pub fn new(gs: &[Geometry], kernel: Kernel, alias: &AliasSpectra) -> Self {
        let g0 = gs[0];
        let mut spectral = Spectral::new(g0.nx, g0.ny);
        let c = spectral.multiplier(&alias.c);
        // C in real space (its response to a unit value at base node 0)
        let c_table = {
            let mut delta = vec![0.0; g0.nx * g0.ny];
            delta[0] = 1.0;
            let mut out = vec![0.0; delta.len()];
            spectral.convolve_with(&delta, &c, &mut out);
            out
        };
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
                let boxk = Padded::new(bx, by, |i, j| {
                    t[i.unsigned_abs() * stride + j.unsigned_abs()]
                });
                let (ex, ey) = (g.wx + 2 * g.margin + 1, g.wy + 2 * g.margin + 1);
                let (nx, ny) = (g.nx as isize, g.ny as isize);
                let ek = Padded::new(ex, ey, |i, j| {
                    c_table[(i.rem_euclid(nx) * ny + j.rem_euclid(ny)) as usize]
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
                    ek,
                    ex,
                    ey,
                    in_e,
                }
            })
            .collect();
        let cp = spectral.multiplier(&alias.cp);
        let cpp = (gs.len() > 1).then(|| spectral.multiplier(&alias.pt));
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
            pool: Vec::new(),
            #[cfg(test)]
            far_by_base_transform: false,
        }
    }

    /// Returns a work array (e.g. the base-node gradient of [`Blocks::apply`]) for reuse.
    pub fn recycle(&mut self, v: Vec<f64>) {
        self.pool.push(v);
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
        let pool = &mut self.pool;
        let mut ds = Vec::with_capacity(self.near.len());
        let mut c_v = take(pool, nb, 0.0);
        self.spectral.convolve_with(v, &self.c, &mut c_v);
        for near in &mut self.near {
            let n = near.rx * near.ry;
            let d = near.remainder(&fine[off..off + n], v, take(pool, n, 0.0));
            let gz = near.box_field(&d, v, pool);
            let mut vf = take(pool, nb, 0.0);
            for ((o, x), e) in vf.iter_mut().zip(v).zip(&near.in_e) {
                *o = if *e { 0.0 } else { *x };
            }
            let mut cp_vf = take(pool, nb, 0.0);
            self.spectral.convolve_with(&vf, &self.cp, &mut cp_vf);
            pool.push(vf);
            // C v_F is read on E only: C v − C v_E there (a convolution on E, not a base
            // transform)
            let c_vf = near.far_on_e(v, &c_v, pool);
            #[cfg(test)]
            let c_vf = if self.far_by_base_transform {
                let vf: Vec<f64> = v
                    .iter()
                    .zip(&near.in_e)
                    .map(|(x, e)| if *e { 0.0 } else { *x })
                    .collect();
                let mut c_vf = c_vf;
                self.spectral.convolve_with(&vf, &self.c, &mut c_vf);
                c_vf
            } else {
                c_vf
            };
            let w = near.adjoint(&self.lag, &d, take(pool, nb, 0.0));
            parts.push(Part { gz, c_vf, cp_vf, w });
            ds.push(d);
            off += n;
        }
        let cp_w: Vec<Vec<f64>> = parts
            .iter()
            .map(|p| {
                let mut o = take(pool, nb, 0.0);
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
            .map(|(near, p)| near.hat_field(&p.gz, take(pool, nb, f64::NAN)))
            .collect();
        // g_v: one window's E: C v_F + Hᵀ G z (+ the other windows' far remainders);
        // outside every E: C v + C' Sᵀ Πᵀ d of every window; in several windows' E (their
        // margins overlap): C v + Σ (Hᵀ G z − C v_E) over those, far terms of the rest
        let mut gv = take(pool, nb, 0.0);
        if let ([p], [near]) = (&parts[..], &self.near[..]) {
            // one window: the branches below without the bookkeeping (same sums)
            for (k, g) in gv.iter_mut().enumerate() {
                *g = if near.in_e[k] {
                    p.c_vf[k] + hgz[0][k]
                } else {
                    c_v[k] + cp_w[0][k]
                };
            }
        }
        for (k, g) in gv.iter_mut().enumerate() {
            if parts.len() == 1 {
                break;
            }
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
        for p in parts {
            pool.extend([p.gz, p.c_vf, p.cp_vf, p.w]);
        }
        pool.extend(ds);
        pool.extend(cp_w);
        pool.extend(hgz);
        pool.push(c_v);
        (out, gv)
    }
}

impl Near {
    /// d = p_R − I_R v (into `d`, rx × ry values).
    fn remainder(&self, fine: &[f64], v: &[f64], mut d: Vec<f64>) -> Vec<f64> {
        let ry = self.ry;
        let cols = self.axis(0, ry, self.g.j0, self.g.ny);
        d.par_chunks_mut(ry).enumerate().for_each(|(a, row)| {
            let r = self.axis(a as isize, 1, self.g.i0, self.g.nx)[0];
            for (b, x) in row.iter_mut().enumerate() {
                *x = fine[a * ry + b] - self.bilinear_at(v, None, r, cols[b]);
            }
        });
        d
    }

    /// C v_F on the base nodes of E (NaN elsewhere), as C v − C v_E with C v_E by the
    /// zero-padded convolution on E.
    fn far_on_e(&mut self, v: &[f64], c_v: &[f64], pool: &mut Vec<Vec<f64>>) -> Vec<f64> {
        let (ex, ey, m) = (self.ex, self.ey, self.g.margin as isize);
        let mut ve = take(pool, ex * ey, 0.0);
        for a in 0..ex {
            for b in 0..ey {
                ve[a * ey + b] = v[self.g.base(a as isize - m, b as isize - m)];
            }
        }
        let mut cve = take(pool, ex * ey, 0.0);
        self.ek.apply(&ve, &mut cve);
        let mut out = take(pool, v.len(), f64::NAN);
        for a in 0..ex {
            for b in 0..ey {
                let k = self.g.base(a as isize - m, b as isize - m);
                out[k] = c_v[k] - cve[a * ey + b];
            }
        }
        pool.push(ve);
        pool.push(cve);
        out
    }

    /// G z on the box, z = H v_E + d.
    fn box_field(&mut self, d: &[f64], v: &[f64], pool: &mut Vec<Vec<f64>>) -> Vec<f64> {
        let (rx, ry, bx, by, o) = (self.rx, self.ry, self.bx, self.by, self.origin);
        let mut z = take(pool, bx * by, 0.0);
        {
            let this = &*self;
            let mask = Some(&this.in_e[..]);
            let cols = this.axis(o, by, this.g.j0, this.g.ny);
            z.par_chunks_mut(by).enumerate().for_each(|(u, row)| {
                let a = u as isize + o;
                let r = this.axis(a, 1, this.g.i0, this.g.nx)[0];
                for (w, x) in row.iter_mut().enumerate() {
                    let b = w as isize + o;
                    let mut s = this.bilinear_at(v, mask, r, cols[w]);
                    if a >= 0 && (a as usize) < rx && b >= 0 && (b as usize) < ry {
                        s += d[a as usize * ry + b as usize];
                    }
                    *x = s;
                }
            });
        }
        let mut gz = take(pool, bx * by, 0.0);
        self.boxk.apply(&z, &mut gz);
        pool.push(z);
        gz
    }

    /// w = Sᵀ Πᵀ d on every base node (zero off the stencil's base nodes): the adjoint of the
    /// Lagrange interpolation from base nodes R ± order/2 onto R's fine nodes.
    fn adjoint(&self, lag: &[Vec<f64>], d: &[f64], mut w: Vec<f64>) -> Vec<f64> {
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

    /// Hᵀ G z on the base nodes of E (into `out`, NaN elsewhere).
    fn hat_field(&self, gz: &[f64], mut out: Vec<f64>) -> Vec<f64> {
        let (by, o) = (self.by, self.origin);
        let f = self.g.f as isize;
        let m = self.g.margin as isize;
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

    /// The bilinear stencil along one axis for the `n` fine nodes from `a0` (relative to R's
    /// first node; `first` the first base node of R on this axis, `period` the base nodes):
    /// the two base nodes and their weights, as [`Near::bilinear`] takes them.
    fn axis(&self, a0: isize, n: usize, first: usize, period: usize) -> Vec<Stencil> {
        let f = self.g.f as isize;
        (0..n as isize)
            .map(|t| {
                let a = a0 + t;
                let (ca, sa) = (a.div_euclid(f), a.rem_euclid(f));
                let node = |c: isize| (first as isize + c).rem_euclid(period as isize) as usize;
                Stencil {
                    node: [node(ca), node(ca + 1)],
                    weight: [1.0 - sa as f64 / f as f64, sa as f64 / f as f64],
                }
            })
            .collect()
    }

    /// [`Near::bilinear`] from the row and column stencils ([`Near::axis`]): the same terms
    /// in the same order.
    #[inline]
    fn bilinear_at(&self, v: &[f64], mask: Option<&[bool]>, r: Stencil, c: Stencil) -> f64 {
        let ny = self.g.ny;
        let mut s = 0.0;
        for (i, wi) in r.node.into_iter().zip(r.weight) {
            if wi == 0.0 {
                continue;
            }
            for (j, wj) in c.node.into_iter().zip(c.weight) {
                if wj == 0.0 {
                    continue;
                }
                let k = i * ny + j;
                if mask.is_none_or(|m| m[k]) {
                    s += wi * wj * v[k];
                }
            }
        }
        s
    }

    /// Bilinear interpolant of base values `v` (masked by `mask` if given) at the fine node
    /// (a, b) relative to R's first node (the reference of [`Near::bilinear_at`]).
    #[cfg(test)]
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

/// Heights of the analytic profile on the fine lattice, a row at a time, bit for bit
/// `profile.height` at each node (test `fine_rows_are_the_profile_bit_for_bit`): the node
/// (i, j) lies at ((i/f + s0) dx, (j/f + s1) dy). A wave along an axis (k_y = 0 or k_x = 0)
/// is tabulated per row or per column (its phase k_x x + k_y y rounds to k_x x or k_y y
/// exactly: the other product is a zero); the other waves take their products k_x x and
/// k_y y from per-row and per-column tables and one cosine per node. The waves are summed in
/// the profile's order. The square model then costs two table reads per node instead of two
/// cosines; the triangular and hexagonal ones two cosines instead of three.
pub(crate) struct FineRows<'a> {
    profile: &'a surface::TrigSurface,
    f: usize,
    dx: f64,
    s0: f64,
    /// Per wave and fine column: amp cos(k_y y) (k_x = 0), else k_y y.
    cols: Vec<Vec<f64>>,
}

impl<'a> FineRows<'a> {
    /// The fine lattice of `g` (grid spacings `dx`, `dy`, shift `shift` in base spacings) for
    /// `profile`.
    pub fn new(
        profile: &'a surface::TrigSurface,
        g: &Geometry,
        (dx, dy): (f64, f64),
        shift: (f64, f64),
    ) -> Self {
        let (_, fy) = g.fine();
        let f = g.f;
        let cols = profile
            .modes
            .iter()
            .map(|m| {
                (0..fy)
                    .map(|j| {
                        let y = (j as f64 / f as f64 + shift.1) * dy;
                        if m.kx == 0.0 {
                            m.amp * (m.ky * y).cos()
                        } else {
                            m.ky * y
                        }
                    })
                    .collect()
            })
            .collect();
        FineRows {
            profile,
            f,
            dx,
            s0: shift.0,
            cols,
        }
    }

    /// The heights of fine row `i` into `out` (one value per fine column).
    pub fn row(&self, i: usize, out: &mut [f64]) {
        let x = (i as f64 / self.f as f64 + self.s0) * self.dx;
        // per wave: amp cos(k_x x) (k_y = 0), or k_x x
        let along: Vec<f64> = self
            .profile
            .modes
            .iter()
            .map(|m| {
                if m.kx == 0.0 {
                    0.0
                } else if m.ky == 0.0 {
                    m.amp * (m.kx * x).cos()
                } else {
                    m.kx * x
                }
            })
            .collect();
        let modes = &self.profile.modes;
        for (j, o) in out.iter_mut().enumerate() {
            let sum = modes
                .iter()
                .enumerate()
                .map(|(t, m)| {
                    if m.kx == 0.0 {
                        self.cols[t][j]
                    } else if m.ky == 0.0 {
                        along[t]
                    } else {
                        m.amp * (along[t] + self.cols[t][j]).cos()
                    }
                })
                .sum::<f64>();
            *o = self.profile.offset + sum;
        }
    }
}

/// Hᵀ h on every base node for the heights of the fine lattice, given row by row by `row(i,
/// out)` (fine row i, every fine column; [`FineRows::row`]). Streams the fine lattice by fine
/// rows, each fine node evaluated once (memory F_x × ny, not the fine lattice). The hat
/// weights are tabulated and the periodic wrap taken only at the ends; the sums are those of
/// the direct loop term for term.
pub(crate) fn hat_heights(g: &Geometry, row: &(impl Fn(usize, &mut [f64]) + Sync)) -> Vec<f64> {
    let (fx, fy) = g.fine();
    let f = g.f;
    let (nx, ny) = (g.nx, g.ny);
    let fi_ = f as isize;
    // hat(db) for db = 1 − f ..= f − 1 at index db + f − 1
    let w: Vec<f64> = (1 - fi_..fi_).map(|d| hat(d, f)).collect();
    // s[fi ny + j] = Σ_db hat(db) h(fi, f j + db)
    let mut rows = vec![0.0; fx * ny];
    rows.par_chunks_mut(ny).enumerate().for_each_init(
        || vec![0.0; fy],
        |line, (fi, out)| {
            row(fi, line);
            for (j, o) in out.iter_mut().enumerate() {
                let c = (f * j) as isize;
                let mut sa = 0.0;
                if c + 1 - fi_ >= 0 && c + fi_ - 1 < fy as isize {
                    let seg = &line[(c + 1 - fi_) as usize..(c + fi_) as usize];
                    for (wd, h) in w.iter().zip(seg) {
                        sa += wd * h;
                    }
                } else {
                    for (t, db) in (1 - fi_..fi_).enumerate() {
                        let fj = (c + db).rem_euclid(fy as isize) as usize;
                        sa += w[t] * line[fj];
                    }
                }
                *o = sa;
            }
        },
    );
    (0..nx * ny)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k / ny, k % ny);
            let mut s = 0.0;
            for (t, da) in (1 - fi_..fi_).enumerate() {
                let fi = ((f * i) as isize + da).rem_euclid(fx as isize) as usize;
                s += w[t] * rows[fi * ny + j];
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
        let AliasSpectra { c, cp, pt } = alias_spectra(&g, Kernel::Compliance);
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

#[cfg(test)]
mod reference {
    use super::*;

    /// The direct table (every eigenvalue evaluated, the first design): the oracle of
    /// [`table`].
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
        super::x_pass(&rows, (fx, fy), bx, by)
    }

    /// The direct alias sums (every alias's eigenvalue evaluated, in the order of the first
    /// design): the oracle of [`alias_spectra`].
    pub(crate) fn alias_spectra(g: &Geometry, kernel: Kernel) -> AliasSpectra {
        let (f, nx, ny) = (g.f, g.nx, g.ny);
        let (fx, fy) = g.fine();
        let (px, py) = (super::hat_factors(f, fx), super::hat_factors(f, fy));
        let m = ny / 2 + 1;
        let norm = (f * f * nx * ny) as f64;
        let mut out = AliasSpectra {
            c: Vec::new(),
            cp: Vec::new(),
            pt: Vec::new(),
        };
        for idx in 0..nx * m {
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
            out.c.push(c / norm);
            out.cp.push(cp / norm);
            out.pt.push(pt / norm);
        }
        out
    }

    /// The padded convolution is the unpadded one to rounding, on sides whose doubled FFT
    /// length is twice a prime (the case it is for), and [`smooth`] picks 2^a 3^b 5^c sides.
    #[test]
    fn padded_convolution_is_the_free_one() {
        assert_eq!(
            [
                smooth(1),
                smooth(7),
                smooth(257),
                smooth(463),
                smooth(927),
                smooth(1855)
            ],
            [1, 8, 270, 480, 960, 1875]
        );
        let (nx, ny) = (23, 19);
        let green = |i: isize, j: isize| 1.0 / (0.3 + ((i * i + 2 * j * j) as f64).sqrt());
        let mut free = FreeKernel::from_green(nx, ny, green);
        let mut padded = Padded::new(nx, ny, green);
        let z: Vec<f64> = (0..nx * ny)
            .map(|k| ((k * 7919) % 101) as f64 / 50.0 - 1.0)
            .collect();
        let (mut a, mut b) = (vec![0.0; nx * ny], vec![0.0; nx * ny]);
        crate::compliance::Compliance::displacement(&mut free, &z, &mut a);
        padded.apply(&z, &mut b);
        let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let err = a
            .iter()
            .zip(&b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        // rounding of two FFT pairs of ~10³ nodes on O(10) values
        assert!(err < 1e-13 * scale, "{err:e} of {scale:e}");
    }

    /// C v_F computed on E (C v − C v_E by a convolution on E) is the base-grid transform of
    /// v_F to rounding: the whole blockwise operator, one and two windows.
    #[test]
    fn the_local_far_field_is_the_base_transform() {
        let geometry = |i0, j0| Geometry {
            nx: 48,
            ny: 40,
            lx: 1.0,
            ly: 0.9,
            f: 4,
            i0,
            j0,
            wx: 6,
            wy: 5,
            margin: 5,
            order: 8,
        };
        for gs in [
            vec![geometry(30, 37)],
            vec![geometry(2, 3), geometry(26, 20)],
        ] {
            let alias = alias_spectra(&gs[0], Kernel::Compliance);
            let mut blocks = Blocks::new(&gs, Kernel::Compliance, &alias);
            let nf: usize = gs.iter().map(|g| g.region().0 * g.region().1).sum();
            let nb = gs[0].nx * gs[0].ny;
            let fine: Vec<f64> = (0..nf).map(|k| ((k * 7919) % 97) as f64 / 97.0).collect();
            let v: Vec<f64> = (0..nb).map(|k| ((k * 104729) % 89) as f64 / 89.0).collect();
            let (a_fine, a_v) = blocks.apply(&fine, &v);
            blocks.far_by_base_transform = true;
            let (b_fine, b_v) = blocks.apply(&fine, &v);
            let rel = |a: &[f64], b: &[f64]| {
                let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                a.iter()
                    .zip(b)
                    .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
                    / scale
            };
            let (ef, ev) = (rel(&a_fine, &b_fine), rel(&a_v, &b_v));
            eprintln!(
                "{} window(s): local against base-transform far field {ef:.1e} (fine), {ev:.1e} (base)",
                gs.len()
            );
            // rounding: the local C v_E (a 34² transform) against the base transform's C v_F
            // (48 × 40), both on O(1) values and fields of O(10)
            assert!(ef < 1e-13 && ev < 1e-13, "{ef:e} {ev:e}");
        }
    }

    /// The tabulated bilinear stencils give the direct interpolant's bits on the whole box
    /// (with and without the mask), across the periodic wrap.
    #[test]
    fn tabulated_bilinear_is_the_direct_one() {
        let mut g = kernel_geometry(12, 10, 0.9);
        (g.f, g.i0, g.j0, g.wx, g.wy, g.margin) = (4, 9, 1, 2, 3, 2);
        let t = vec![1.0; 64];
        let (bx, by, origin) = g.boxed();
        let (rx, ry) = g.region();
        let mut in_e = vec![false; g.nx * g.ny];
        for k in (0..in_e.len()).step_by(3) {
            in_e[k] = true;
        }
        let near = Near {
            g,
            rx,
            ry,
            bx,
            by,
            origin,
            ek: Padded::new(2, 2, |_, _| 1.0),
            ex: 2,
            ey: 2,
            boxk: Padded::new(2, 2, |i, j| {
                t[(i.unsigned_abs() * 3 + j.unsigned_abs()) % 64]
            }),
            in_e,
        };
        let v: Vec<f64> = (0..g.nx * g.ny)
            .map(|k| ((k * 7919) % 101) as f64 / 7.0 - 3.0)
            .collect();
        let cols = near.axis(origin, by, g.j0, g.ny);
        for u in 0..bx {
            let a = u as isize + origin;
            let r = near.axis(a, 1, g.i0, g.nx)[0];
            for (w, c) in cols.iter().enumerate() {
                let b = w as isize + origin;
                for mask in [None, Some(&near.in_e[..])] {
                    let (x, y) = (
                        near.bilinear_at(&v, mask, r, *c),
                        near.bilinear(&v, mask, a, b),
                    );
                    assert_eq!(x.to_bits(), y.to_bits(), "({a}, {b})");
                }
            }
        }
    }

    /// The tabulated, mirrored setup gives the same bits as the direct one (so the cached
    /// results of every stage stay valid): alias sums and tables of both kernels, on lattices
    /// with unequal sides and periods, odd and even base sizes' mirrors, f = 2 … 8.
    #[test]
    fn the_fast_setup_is_bitwise_the_direct_one() {
        for (nx, ny, ly, f) in [
            (16, 12, 0.8, 2),
            (12, 20, 1.7, 4),
            (8, 8, 1.0, 8),
            (10, 6, 0.6, 4),
        ] {
            let mut g = kernel_geometry(nx, ny, ly);
            g.f = f;
            for kernel in [Kernel::Compliance, Kernel::Stiffness] {
                let (fast, slow) = (super::alias_spectra(&g, kernel), alias_spectra(&g, kernel));
                for (name, a, b) in [
                    ("C", &fast.c, &slow.c),
                    ("C'", &fast.cp, &slow.cp),
                    ("C''", &fast.pt, &slow.pt),
                ] {
                    assert_eq!(a.len(), b.len());
                    for (k, (x, y)) in a.iter().zip(b.iter()).enumerate() {
                        assert_eq!(
                            x.to_bits(),
                            y.to_bits(),
                            "{name} {kernel:?} {nx}×{ny} f = {f}, mode {k}: {x:e} vs {y:e}"
                        );
                    }
                }
                let (bx, by) = (nx * f / 2 + 3, ny * f - 1);
                let (tf, ts) = (super::table(&g, kernel, bx, by), table(&g, kernel, bx, by));
                assert_eq!(tf.len(), ts.len());
                for (k, (x, y)) in tf.iter().zip(&ts).enumerate() {
                    assert_eq!(
                        x.to_bits(),
                        y.to_bits(),
                        "table {kernel:?} {nx}×{ny} f = {f}, entry {k}"
                    );
                }
            }
        }
    }

    /// The direct Hᵀh (every node through `height`, the hat weights and wrap per term): the
    /// oracle of [`hat_heights`].
    fn hat_heights(g: &Geometry, h: &(impl Fn(usize, usize) -> f64 + Sync)) -> Vec<f64> {
        let (fx, fy) = g.fine();
        let f = g.f;
        let (nx, ny) = (g.nx, g.ny);
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

    /// The fine rows are the profile's heights bit for bit, and so is Hᵀh: every model, a
    /// shifted grid, f = 2, 4 (a change here would change every refined result).
    #[test]
    fn fine_rows_are_the_profile_bit_for_bit() {
        for lattice in surface::Lattice::ALL {
            for (n, f, shift) in [(4, 2, (0.0, 0.0)), (5, 4, (0.25, 0.5)), (4, 8, (0.5, 0.0))] {
                let mut s = surface::Surface::new(lattice, n).expect("grid");
                s.grid.shift = shift;
                let gr = s.grid;
                let mut g = kernel_geometry(gr.nx, gr.ny, gr.ly);
                g.lx = gr.lx;
                g.f = f;
                let (dx, dy) = (gr.dx(), gr.dy());
                let height = |i: usize, j: usize| {
                    s.profile.height(
                        (i as f64 / f as f64 + shift.0) * dx,
                        (j as f64 / f as f64 + shift.1) * dy,
                    )
                };
                let rows = FineRows::new(&s.profile, &g, (dx, dy), shift);
                let (fx, fy) = g.fine();
                let mut line = vec![0.0; fy];
                for i in 0..fx {
                    rows.row(i, &mut line);
                    for (j, h) in line.iter().enumerate() {
                        assert_eq!(
                            h.to_bits(),
                            height(i, j).to_bits(),
                            "{lattice:?} f = {f} node ({i}, {j})"
                        );
                    }
                }
                let fast = super::hat_heights(&g, &|i, out: &mut [f64]| rows.row(i, out));
                let slow = hat_heights(&g, &height);
                for (k, (a, b)) in fast.iter().zip(&slow).enumerate() {
                    assert_eq!(
                        a.to_bits(),
                        b.to_bits(),
                        "{lattice:?} f = {f} Hᵀh at base node {k}"
                    );
                }
            }
        }
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

#[cfg(test)]
mod cost {
    use super::*;

    /// Timing (ignored; `SETUP_K`, default 3, `SETUP_N` base exponent, default 10): the parts
    /// of a blockwise discretisation's setup at the paper preset's deep-ladder geometry (square
    /// model, window 32 base cells around the saddle (1/2, 0), margin 12): the alias sums, the
    /// two real-space tables (G on the box, K on R), Hᵀh over the fine lattice.
    /// `cargo test --release -p contact --lib -- --ignored --nocapture setup_parts`.
    #[test]
    #[ignore]
    fn setup_parts() {
        let env = |k: &str, d: u32| {
            std::env::var(k)
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(d)
        };
        let (levels, n) = (env("SETUP_K", 3), env("SETUP_N", 10));
        let s = surface::Surface::new(surface::Lattice::Square, n).expect("grid");
        let gr = s.grid;
        let w = crate::refinement::Window::centred(&gr, 0.5, 0.0, 32, 32);
        let g = Geometry {
            nx: gr.nx,
            ny: gr.ny,
            lx: gr.lx,
            ly: gr.ly,
            f: 1 << levels,
            i0: w.i0,
            j0: w.j0,
            wx: 32,
            wy: 32,
            margin: 12,
            order: crate::refinement::ORDER,
        };
        // process CPU time (utime + stime, clock ticks of 10 ms): the machine may be shared
        let cpu = || -> f64 {
            let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
            let after = stat.rsplit(')').next().unwrap_or("");
            let f: Vec<f64> = after
                .split_whitespace()
                .skip(11)
                .take(2)
                .filter_map(|v| v.parse().ok())
                .collect();
            f.iter().sum::<f64>() / 100.0
        };
        let time = |name: &str, run: &mut dyn FnMut() -> f64| {
            let (t, c) = (std::time::Instant::now(), cpu());
            let check = run();
            eprintln!(
                "k = {levels}, {}²: {name}: {:.2} s wall, {:.2} CPU-s (check {check:.17e})",
                gr.nx,
                t.elapsed().as_secs_f64(),
                cpu() - c
            );
        };
        time("alias sums", &mut || {
            let a = alias_spectra(&g, Kernel::Compliance);
            a.c.iter().chain(&a.cp).chain(&a.pt).sum()
        });
        let (bx, by, _) = g.boxed();
        time("table G on the box", &mut || {
            table(&g, Kernel::Compliance, bx, by).iter().sum()
        });
        let (rx, ry) = g.region();
        time("table K on R", &mut || {
            table(&g, Kernel::Stiffness, rx, ry).iter().sum()
        });
        let rows = FineRows::new(&s.profile, &g, (gr.dx(), gr.dy()), gr.shift);
        time("H^T h", &mut || {
            hat_heights(&g, &|i, out: &mut [f64]| rows.row(i, out))
                .iter()
                .sum()
        });
    }
}
