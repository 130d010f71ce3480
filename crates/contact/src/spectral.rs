//! Periodic 2-D convolution with a diagonal Fourier multiplier, on real fields.
//!
//! Fields are row-major `nx × ny` slices (first index x). A convolution is: a real-to-complex FFT
//! along each row (y, contiguous) into the half spectrum `nx × (ny/2 + 1)`; then, for each block
//! of `BLOCK` spectral columns, gather the block into a contiguous buffer, FFT along x, multiply,
//! inverse FFT along x and scatter back (one gather/scatter per convolution and the multiply done
//! while the block is in cache, instead of separate forward, multiply and inverse passes over the
//! whole spectrum); then a complex-to-real FFT along each row. The only full-size work array is
//! the half spectrum (≈ one f64 per node). Rows and column blocks are spread over rayon threads
//! when the grid is large enough to pay for it; the arithmetic does not depend on the number of
//! threads, so results are bit-identical for any pool size.
//!
//! Multipliers are stored in the column-block order the fused pass reads them in (spectral
//! column outer, x-wave index inner); [`Spectral::multiplier`] builds one from the natural
//! half-spectrum layout.
//!
//! [`Spectral::convolve_fused`] additionally lets the caller prepare each input row just before
//! it is transformed and reduce over each output row right after it is produced, while both are
//! in cache: the Polonsky–Keer iteration uses it to fold its vector passes into the transform.
//!
//! The column pass (session #13). perf of a cold draft showed `Map::next` at 8.5 % of all
//! samples: the whole per-block closure, inlined into ndarray's iterator. About 40 % of it was
//! the multiply with its quadratic-form sum (a sequential chain of additions, also paid by the
//! plain convolutions, which discard the sum), the rest the copies, mostly the strided stores of
//! the gather (a row's 8 values go to 8 lines `nx` values apart; the 8-column buffer is 32 KiB on
//! 256², the whole L1 of this machine), not bounds checks or the iterator. Now the block's rows
//! are taken once as slices and copied in tiles of 4 rows × 8 columns (`TILE`: one whole cache
//! line per column of the buffer), and the quadratic form is summed only by
//! [`Spectral::convolve_fused`] (in the same order as before). Bit-identical (the bench hashes
//! the output bits): `cargo bench -p contact --bench spectral`, one thread, µs per
//! `ElasticKernel::stress`, before → after, two alternations at load 6–7: 64² 35.2, 35.1 →
//! 33.6, 33.4; 128² 84.1, 84.5 → 80.6, 80.3; 256² 316.7, 311.3 → 301.6, 310.4; 512² 1701, 1613
//! → 1393, 1425. Not faster: 4-column blocks (the buffer in L1 on 256²; the quadratic form's
//! grouping would change too). What is left is the transforms themselves (rustfft and realfft:
//! ≈ 75 % of a convolution on 256²).

use ndarray::{ArrayViewMut2, Axis};
use num_complex::Complex64;
use rayon::prelude::*;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// Spectral columns per block in the x pass (8 complex values = two cache lines per row). It also
/// fixes how [`Spectral::convolve_fused`] groups the sum of its quadratic form.
const BLOCK: usize = 8;
/// Grids with fewer nodes than this run single-threaded (thread hand-off costs more than it saves).
pub const PARALLEL_MIN_NODES: usize = 1 << 14;

/// Per-row partial sums returned by the callbacks of [`Spectral::convolve_fused`].
pub type RowSums = [f64; 4];

/// One row of a row pass: (index, (spectrum row, field row)) and its partial-sum slot.
type RowJob<'a, F> = ((usize, (&'a mut [Complex64], F)), &'a mut RowSums);

fn add(a: RowSums, b: RowSums) -> RowSums {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
}

/// A planned 2-D real FFT for one grid size, with its half-spectrum work array.
pub struct Spectral {
    nx: usize,
    ny: usize,
    m: usize,
    r2c: Arc<dyn RealToComplex<f64>>,
    c2r: Arc<dyn ComplexToReal<f64>>,
    fwd: Arc<dyn Fft<f64>>,
    inv: Arc<dyn Fft<f64>>,
    spec: Vec<Complex64>,
    /// Per-row partial sums (reduced in row order, so independent of the thread count).
    sums: Vec<RowSums>,
}

impl Spectral {
    /// Plans transforms for an `nx × ny` grid (both even).
    pub fn new(nx: usize, ny: usize) -> Self {
        let mut rp = RealFftPlanner::<f64>::new();
        let mut cp = FftPlanner::<f64>::new();
        let m = ny / 2 + 1;
        Spectral {
            nx,
            ny,
            m,
            r2c: rp.plan_fft_forward(ny),
            c2r: rp.plan_fft_inverse(ny),
            fwd: cp.plan_fft_forward(nx),
            inv: cp.plan_fft_inverse(nx),
            spec: vec![Complex64::new(0.0, 0.0); nx * m],
            sums: vec![[0.0; 4]; nx],
        }
    }

    /// Number of complex values along y in the half spectrum (`ny/2 + 1`).
    pub fn half_len(&self) -> usize {
        self.m
    }

    /// Whether this grid is processed by several threads (large grid, pool of more than one).
    pub fn parallel(&self) -> bool {
        self.nx * self.ny >= PARALLEL_MIN_NODES && rayon::current_num_threads() > 1
    }

    /// Converts a multiplier from the natural half-spectrum layout (`nx × (ny/2+1)`, x-wave index
    /// outer) into the internal order used by [`Spectral::convolve_with`].
    pub fn multiplier(&self, half_spectrum: &[f64]) -> Vec<f64> {
        assert_eq!(half_spectrum.len(), self.nx * self.m, "multiplier length");
        let mut out = vec![0.0; half_spectrum.len()];
        for b in 0..self.m {
            for a in 0..self.nx {
                out[b * self.nx + a] = half_spectrum[a * self.m + b];
            }
        }
        out
    }

    /// `output = IFFT(multiplier ⊙ FFT(input))`, where `multiplier` has the natural half-spectrum
    /// layout (`nx × (ny/2+1)`, x-wave index outer) and already includes the 1/(nx·ny)
    /// normalisation. Converts the multiplier on every call: for repeated use convert it once
    /// with [`Spectral::multiplier`] and call [`Spectral::convolve_with`].
    pub fn convolve(&mut self, input: &[f64], multiplier: &[f64], output: &mut [f64]) {
        let mult = self.multiplier(multiplier);
        self.convolve_with(input, &mult, output);
    }

    /// In-place version of [`Spectral::convolve`].
    pub fn convolve_in_place(&mut self, field: &mut [f64], multiplier: &[f64]) {
        let mult = self.multiplier(multiplier);
        self.convolve_with_in_place(field, &mult);
    }

    /// `output = IFFT(multiplier ⊙ FFT(input))` with a multiplier from [`Spectral::multiplier`].
    pub fn convolve_with(&mut self, input: &[f64], multiplier: &[f64], output: &mut [f64]) {
        assert_eq!(input.len(), self.nx * self.ny, "field length");
        self.forward(input.len(), |i, buf| {
            buf.copy_from_slice(&input[i * buf.len()..(i + 1) * buf.len()]);
            [0.0; 4]
        });
        self.columns(multiplier, false);
        self.inverse(output, |_, _| [0.0; 4]);
    }

    /// In-place version of [`Spectral::convolve_with`].
    pub fn convolve_with_in_place(&mut self, field: &mut [f64], multiplier: &[f64]) {
        self.convolve_fused(field, |_, _| [0.0; 4], multiplier, None, |_, _, _| [0.0; 4]);
    }

    /// Convolution with callbacks, all rows visited in parallel when [`Spectral::parallel`]:
    ///
    /// 1. for every row `i`, `prepare(i, row)` may rewrite row `i` of `input` in place; the row
    ///    as it then is, is transformed. `input` keeps the prepared values;
    /// 2. the spectrum is multiplied by `multiplier` (from [`Spectral::multiplier`]);
    /// 3. for every row `i`, the inverse transform is written to row `i` of `output` (of `input`
    ///    itself if `output` is `None`), then `finish(i, input_row, output_row)` is called with
    ///    the prepared input row (an empty slice in place, where it has been overwritten).
    ///
    /// Returns the sums over rows, in row order, of what `prepare` and `finish` return, and the
    /// quadratic form `Σ_x input(x) · output(x)` taken in Fourier space while the spectrum is
    /// multiplied (Parseval: `Σ_q multiplier(q) |input^(q)|²`), known before any output row.
    pub fn convolve_fused<P, F>(
        &mut self,
        input: &mut [f64],
        prepare: P,
        multiplier: &[f64],
        output: Option<&mut [f64]>,
        finish: F,
    ) -> (RowSums, f64, RowSums)
    where
        P: Fn(usize, &mut [f64]) -> RowSums + Sync,
        F: Fn(usize, &[f64], &mut [f64]) -> RowSums + Sync,
    {
        let (nx, ny) = (self.nx, self.ny);
        assert_eq!(input.len(), nx * ny, "field length");
        let parallel = self.parallel();
        // Forward rows: prepare in place, then transform a copy (r2c overwrites its input).
        {
            let (r2c, m) = (&self.r2c, self.m);
            let row = |((i, (out, inp)), sum): RowJob<&mut [f64]>,
                       (buf, scratch): &mut (Vec<f64>, Vec<Complex64>)| {
                *sum = prepare(i, inp);
                buf.copy_from_slice(inp);
                r2c.process_with_scratch(buf, out, scratch)
                    .expect("r2c lengths are planned");
            };
            let init = || (vec![0.0; ny], r2c.make_scratch_vec());
            if parallel {
                self.spec
                    .par_chunks_mut(m)
                    .zip(input.par_chunks_mut(ny))
                    .enumerate()
                    .zip(self.sums.par_iter_mut())
                    .with_min_len(8)
                    .for_each_init(init, |s, x| row(x, s));
            } else {
                let mut s = init();
                self.spec
                    .chunks_mut(m)
                    .zip(input.chunks_mut(ny))
                    .enumerate()
                    .zip(self.sums.iter_mut())
                    .for_each(|x| row(x, &mut s));
            }
        }
        let before = self.sums.iter().fold([0.0; 4], |a, &b| add(a, b));
        let quadratic = self.columns(multiplier, true);
        let after = match output {
            Some(out) => {
                assert_eq!(out.len(), nx * ny, "field length");
                let inp: &[f64] = input;
                self.inverse(out, |i, row| finish(i, &inp[i * ny..(i + 1) * ny], row))
            }
            None => self.inverse(input, |i, row| finish(i, &[], row)),
        };
        (before, quadratic, after)
    }

    /// Forward row transforms: `fill(i, buf)` writes row `i` into `buf`.
    fn forward(&mut self, len: usize, fill: impl Fn(usize, &mut [f64]) -> RowSums + Sync) {
        assert_eq!(len, self.nx * self.ny, "field length");
        let (r2c, ny, m) = (&self.r2c, self.ny, self.m);
        let row = |(i, out): (usize, &mut [Complex64]),
                   (buf, scratch): &mut (Vec<f64>, Vec<Complex64>)| {
            fill(i, buf);
            r2c.process_with_scratch(buf, out, scratch)
                .expect("r2c lengths are planned");
        };
        let init = || (vec![0.0; ny], r2c.make_scratch_vec());
        if self.parallel() {
            self.spec
                .par_chunks_mut(m)
                .enumerate()
                .with_min_len(8)
                .for_each_init(init, |s, x| row(x, s));
        } else {
            let mut s = init();
            self.spec
                .chunks_mut(m)
                .enumerate()
                .for_each(|x| row(x, &mut s));
        }
    }

    /// Inverse row transforms of the spectrum into `output` (normalisation is in the
    /// multiplier), then `finish(i, row)` on each output row; returns the row-ordered sum.
    fn inverse(
        &mut self,
        output: &mut [f64],
        finish: impl Fn(usize, &mut [f64]) -> RowSums + Sync,
    ) -> RowSums {
        let (ny, m) = (self.ny, self.m);
        let c2r = &self.c2r;
        let row = |((i, (inp, out)), sum): RowJob<&mut [f64]>, scratch: &mut Vec<Complex64>| {
            // The DC and Nyquist bins of a real signal's spectrum are real; remove rounding noise.
            inp[0].im = 0.0;
            inp[m - 1].im = 0.0;
            c2r.process_with_scratch(inp, out, scratch)
                .expect("c2r lengths are planned");
            *sum = finish(i, out);
        };
        if self.parallel() {
            self.spec
                .par_chunks_mut(m)
                .zip(output.par_chunks_mut(ny))
                .enumerate()
                .zip(self.sums.par_iter_mut())
                .with_min_len(8)
                .for_each_init(|| c2r.make_scratch_vec(), |s, x| row(x, s));
        } else {
            let mut s = c2r.make_scratch_vec();
            self.spec
                .chunks_mut(m)
                .zip(output.chunks_mut(ny))
                .enumerate()
                .zip(self.sums.iter_mut())
                .for_each(|x| row(x, &mut s));
        }
        self.sums.iter().fold([0.0; 4], |a, &b| add(a, b))
    }

    /// For every block of `BLOCK` spectral columns: gather, FFT along x, multiply, inverse FFT
    /// along x, scatter back. With `quadratic`, returns `Σ_q multiplier(q) |F(q)|²` over the full
    /// spectrum (the half spectrum's columns other than 0 and ny/2 stand for two), summed block
    /// by block in block order; without, 0 (the plain convolutions do not use it, and its
    /// sequential sum cost as much as the multiply itself).
    fn columns(&mut self, multiplier: &[f64], quadratic: bool) -> f64 {
        let (nx, m) = (self.nx, self.m);
        assert_eq!(multiplier.len(), nx * m, "multiplier length");
        let (fwd, inv) = (&self.fwd, &self.inv);
        let parallel = self.parallel();
        let mut view = ArrayViewMut2::from_shape((nx, m), &mut self.spec).expect("shape");
        let scratch_len = fwd
            .get_inplace_scratch_len()
            .max(inv.get_inplace_scratch_len());
        let init = || {
            (
                vec![Complex64::new(0.0, 0.0); BLOCK * nx],
                vec![Complex64::new(0.0, 0.0); scratch_len],
            )
        };
        let block = |(k, mut cols): (usize, ArrayViewMut2<Complex64>),
                     (buf, scratch): &mut (Vec<Complex64>, Vec<Complex64>)| {
            let b = cols.ncols();
            let buf = &mut buf[..b * nx];
            // The block's rows as slices, taken once per block (an ndarray row view per row
            // and per pass cost more than the copy of its b values).
            let mut rows: Vec<&mut [Complex64]> = cols
                .rows_mut()
                .into_iter()
                .map(|row| {
                    row.into_slice()
                        .expect("rows of a column block are contiguous")
                })
                .collect();
            gather(&rows, buf, nx);
            fwd.process_with_scratch(buf, scratch);
            let mult = &multiplier[k * BLOCK * nx..(k * BLOCK + b) * nx];
            let mut sum = 0.0;
            for (c, (col, mult)) in buf
                .chunks_exact_mut(nx)
                .zip(mult.chunks_exact(nx))
                .enumerate()
            {
                if quadratic {
                    let j = k * BLOCK + c;
                    let twice = if j == 0 || j == m - 1 { 1.0 } else { 2.0 };
                    let mut q = 0.0;
                    for (v, &w) in col.iter_mut().zip(mult) {
                        q += w * v.norm_sqr();
                        *v *= w;
                    }
                    sum += twice * q;
                } else {
                    for (v, &w) in col.iter_mut().zip(mult) {
                        *v *= w;
                    }
                }
            }
            inv.process_with_scratch(buf, scratch);
            scatter(buf, &mut rows, nx);
            sum
        };
        let quadratics: Vec<f64> = if parallel {
            view.axis_chunks_iter_mut(Axis(1), BLOCK)
                .into_par_iter()
                .enumerate()
                .map_init(init, |s, x| block(x, s))
                .collect()
        } else {
            let mut s = init();
            view.axis_chunks_iter_mut(Axis(1), BLOCK)
                .enumerate()
                .map(|x| block(x, &mut s))
                .collect()
        };
        quadratics.iter().sum()
    }
}

/// Rows of a column block handled together by `gather` and `scatter`: four complex values
/// are one 64-byte cache line of a column of the block buffer, written (read) whole.
const TILE: usize = 4;

/// `buf[c·nx + i] = rows[i][c]`: the block's rows into its columns, `TILE` rows at a time, so
/// that each column of the buffer is written in whole cache lines (row by row, the writes of one
/// row went to `b` lines `nx` values apart, 4 KiB apart on 256², which do not stay in L1).
fn gather(rows: &[&mut [Complex64]], buf: &mut [Complex64], nx: usize) {
    let b = buf.len() / nx;
    if b == BLOCK && nx.is_multiple_of(TILE) {
        let mut cols: [&mut [Complex64]; BLOCK] = {
            let mut it = buf.chunks_exact_mut(nx);
            std::array::from_fn(|_| it.next().expect("BLOCK columns"))
        };
        for (t, tile) in rows.chunks_exact(TILE).enumerate() {
            let tile: [&[Complex64; BLOCK]; TILE] =
                std::array::from_fn(|r| (&*tile[r]).try_into().expect("BLOCK values"));
            for (c, col) in cols.iter_mut().enumerate() {
                let dst: &mut [Complex64; TILE] = (&mut col[t * TILE..(t + 1) * TILE])
                    .try_into()
                    .expect("TILE values");
                for r in 0..TILE {
                    dst[r] = tile[r][c];
                }
            }
        }
        return;
    }
    for (t, tile) in rows.chunks(TILE).enumerate() {
        let i0 = t * TILE;
        for (c, col) in buf.chunks_exact_mut(nx).enumerate() {
            for (dst, row) in col[i0..i0 + tile.len()].iter_mut().zip(tile) {
                *dst = row[c];
            }
        }
    }
}

/// The inverse of [`gather`]: `rows[i][c] = buf[c·nx + i]`.
fn scatter(buf: &[Complex64], rows: &mut [&mut [Complex64]], nx: usize) {
    let b = buf.len() / nx;
    if b == BLOCK && nx.is_multiple_of(TILE) {
        let cols: [&[Complex64]; BLOCK] = {
            let mut it = buf.chunks_exact(nx);
            std::array::from_fn(|_| it.next().expect("BLOCK columns"))
        };
        for (t, tile) in rows.chunks_exact_mut(TILE).enumerate() {
            let mut it = tile.iter_mut();
            let tile: [&mut [Complex64; BLOCK]; TILE] = std::array::from_fn(|_| {
                let row: &mut [Complex64] = it.next().expect("TILE rows");
                row.try_into().expect("BLOCK values")
            });
            for (c, col) in cols.iter().enumerate() {
                let src: &[Complex64; TILE] = col[t * TILE..(t + 1) * TILE]
                    .try_into()
                    .expect("TILE values");
                for r in 0..TILE {
                    tile[r][c] = src[r];
                }
            }
        }
        return;
    }
    for (t, tile) in rows.chunks_mut(TILE).enumerate() {
        let i0 = t * TILE;
        for (c, col) in buf.chunks_exact(nx).enumerate() {
            for (src, row) in col[i0..i0 + tile.len()].iter().zip(tile.iter_mut()) {
                row[c] = *src;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Direct O(N²) evaluation of the same convolution for a multiplier that depends on the
    /// signed wave indices.
    fn direct(nx: usize, ny: usize, input: &[f64], f: impl Fn(i64, i64) -> f64) -> Vec<f64> {
        let tau = 2.0 * std::f64::consts::PI;
        let wrap = |k: usize, n: usize| {
            if k <= n / 2 {
                k as i64
            } else {
                k as i64 - n as i64
            }
        };
        let mut out = vec![0.0; nx * ny];
        for kx in 0..nx {
            for ky in 0..ny {
                let (mut re, mut im) = (0.0, 0.0);
                for i in 0..nx {
                    for j in 0..ny {
                        let ph = -tau * ((kx * i) as f64 / nx as f64 + (ky * j) as f64 / ny as f64);
                        re += input[i * ny + j] * ph.cos();
                        im += input[i * ny + j] * ph.sin();
                    }
                }
                let w = f(wrap(kx, nx), wrap(ky, ny));
                for i in 0..nx {
                    for j in 0..ny {
                        let ph = tau * ((kx * i) as f64 / nx as f64 + (ky * j) as f64 / ny as f64);
                        out[i * ny + j] += w * (re * ph.cos() - im * ph.sin()) / (nx * ny) as f64;
                    }
                }
            }
        }
        out
    }

    /// On shapes whose column blocks are full and tiled (8 × 16), a full block plus a partial
    /// one (12 × 18: 10 spectral columns) and rows not a multiple of the tile (6 × 20).
    #[test]
    fn matches_a_direct_fourier_sum() {
        for (nx, ny) in [(8, 16), (12, 18), (6, 20)] {
            matches_a_direct_fourier_sum_on(nx, ny);
        }
    }

    fn matches_a_direct_fourier_sum_on(nx: usize, ny: usize) {
        let input: Vec<f64> = (0..nx * ny)
            .map(|k| ((k * 7919) % 97) as f64 / 97.0 - 0.3)
            .collect();
        // A multiplier even in each wave index (as every multiplier here is).
        let f = |a: i64, b: i64| 1.0 + (a * a) as f64 + 0.5 * (b * b) as f64;
        let mut sp = Spectral::new(nx, ny);
        let m = sp.half_len();
        let mult: Vec<f64> = (0..nx * m)
            .map(|k| {
                let (a, b) = (k / m, k % m);
                let a = if a <= nx / 2 {
                    a as i64
                } else {
                    a as i64 - nx as i64
                };
                f(a, b as i64) / (nx * ny) as f64
            })
            .collect();
        let mut out = vec![0.0; nx * ny];
        sp.convolve(&input, &mult, &mut out);
        let want = direct(nx, ny, &input, f);
        for (a, b) in out.iter().zip(&want) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        sp.convolve_in_place(&mut out, &mult);
        let twice = direct(nx, ny, &want, f);
        for (a, b) in out.iter().zip(&twice) {
            assert!((a - b).abs() < 1e-10 * b.abs().max(1.0), "{a} vs {b}");
        }
    }

    #[test]
    fn parallel_and_serial_paths_agree() {
        let (nx, ny) = (256, 128);
        let input: Vec<f64> = (0..nx * ny).map(|k| ((k * 31) % 101) as f64).collect();
        let mut sp = Spectral::new(nx, ny);
        let m = sp.half_len();
        let mult: Vec<f64> = (0..nx * m)
            .map(|k| ((k % 13) as f64 + 1.0) / (nx * ny) as f64)
            .collect();
        let mut par = vec![0.0; nx * ny];
        sp.convolve(&input, &mult, &mut par);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let mut ser = vec![0.0; nx * ny];
        pool.install(|| sp.convolve(&input, &mult, &mut ser));
        assert_eq!(par, ser);
    }

    #[test]
    fn fused_callbacks_see_the_prepared_rows_and_reduce_in_row_order() {
        let (nx, ny) = (128, 256);
        let mut sp = Spectral::new(nx, ny);
        let m = sp.half_len();
        let natural: Vec<f64> = (0..nx * m)
            .map(|k| ((k % 7) as f64 + 1.0) / (nx * ny) as f64)
            .collect();
        let mult = sp.multiplier(&natural);
        let base: Vec<f64> = (0..nx * ny)
            .map(|k| ((k * 13) % 31) as f64 - 15.0)
            .collect();
        // Reference: prepare by hand (x → 2x + row index), then a plain convolution.
        let prepared: Vec<f64> = base
            .iter()
            .enumerate()
            .map(|(k, v)| 2.0 * v + (k / ny) as f64)
            .collect();
        let mut want = vec![0.0; nx * ny];
        sp.convolve(&prepared, &natural, &mut want);
        let mut input = base.clone();
        let mut out = vec![0.0; nx * ny];
        let (before, _, after) = sp.convolve_fused(
            &mut input,
            |i, row| {
                row.iter_mut().for_each(|v| *v = 2.0 * *v + i as f64);
                [row.iter().sum(), 1.0, 0.0, 0.0]
            },
            &mult,
            Some(&mut out),
            |_, inp, row| {
                [
                    inp.iter().zip(row.iter()).map(|(a, b)| a * b).sum(),
                    0.0,
                    0.0,
                    1.0,
                ]
            },
        );
        assert_eq!(input, prepared);
        assert_eq!(out, want);
        assert_eq!(before[1], nx as f64);
        assert_eq!(after[3], nx as f64);
        let dot: f64 = (0..nx)
            .map(|i| {
                (0..ny)
                    .map(|j| prepared[i * ny + j] * want[i * ny + j])
                    .sum::<f64>()
            })
            .sum();
        assert_eq!(after[0], dot);
        let sum: f64 = (0..nx)
            .map(|i| prepared[i * ny..(i + 1) * ny].iter().sum::<f64>())
            .sum();
        assert_eq!(before[0], sum);
        // In place gives the same field.
        let mut field = prepared.clone();
        sp.convolve_with_in_place(&mut field, &mult);
        assert_eq!(field, want);
    }

    /// The quadratic form returned by the fused convolution is Σ input · output, for a
    /// multiplier of the kind the solvers use (a function of |q|, so even in q), on a grid with
    /// nx ≠ ny, to rounding.
    #[test]
    fn quadratic_form_is_the_real_space_inner_product() {
        let (nx, ny) = (64, 32);
        let mut sp = Spectral::new(nx, ny);
        let m = sp.half_len();
        let natural: Vec<f64> = (0..nx * m)
            .map(|k| {
                let (a, b) = ((k / m) as f64, (k % m) as f64);
                let a = a.min(nx as f64 - a);
                (a * a + 3.0 * b * b).sqrt() / (nx * ny) as f64
            })
            .collect();
        let mult = sp.multiplier(&natural);
        let input: Vec<f64> = (0..nx * ny)
            .map(|k| (((k * 29) % 37) as f64 - 18.0) * if k % 5 == 0 { 0.0 } else { 1.0 })
            .collect();
        let mut out = vec![0.0; nx * ny];
        let mut inp = input.clone();
        let (_, quadratic, _) = sp.convolve_fused(
            &mut inp,
            |_, _| [0.0; 4],
            &mult,
            Some(&mut out),
            |_, _, _| [0.0; 4],
        );
        let direct: f64 = input.iter().zip(&out).map(|(a, b)| a * b).sum();
        let scale: f64 = input.iter().zip(&out).map(|(a, b)| (a * b).abs()).sum();
        assert!(
            (quadratic - direct).abs() <= 1e-13 * scale,
            "{quadratic} vs {direct}"
        );
        assert!(direct > 0.0);
    }
}
