//! Periodic 2-D convolution with a diagonal Fourier multiplier, on real fields.
//!
//! Fields are row-major `nx × ny` slices (first index x). A forward transform is a real-to-complex
//! FFT along each row (y, contiguous) followed by complex FFTs along x, done on blocks of columns
//! gathered into contiguous buffers (no full transpose, so the only full-size work array is the
//! half spectrum, `nx × (ny/2 + 1)` complex values ≈ one f64 per node). Both passes are
//! parallelised with rayon when the grid is large enough to pay for it.

use ndarray::{ArrayViewMut2, Axis};
use num_complex::Complex64;
use rayon::prelude::*;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// Columns gathered per block in the x pass (8 complex values = two cache lines per row).
const BLOCK: usize = 8;
/// Grids with fewer nodes than this run single-threaded (thread hand-off costs more than it saves).
const PARALLEL_MIN_NODES: usize = 1 << 14;

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
        }
    }

    /// Number of complex values along y in the half spectrum (`ny/2 + 1`).
    pub fn half_len(&self) -> usize {
        self.m
    }

    fn parallel(&self) -> bool {
        self.nx * self.ny >= PARALLEL_MIN_NODES && rayon::current_num_threads() > 1
    }

    /// Forward transform of `input` (length nx·ny) into the internal half spectrum, unnormalised.
    fn forward(&mut self, input: &[f64]) {
        assert_eq!(input.len(), self.nx * self.ny, "field length");
        let (ny, m) = (self.ny, self.m);
        let r2c = &self.r2c;
        let row = |(out, inp): (&mut [Complex64], &[f64]),
                   (buf, scratch): &mut (Vec<f64>, Vec<Complex64>)| {
            buf.copy_from_slice(inp);
            r2c.process_with_scratch(buf, out, scratch)
                .expect("r2c lengths are planned");
        };
        let init = || (vec![0.0; ny], r2c.make_scratch_vec());
        if self.parallel() {
            self.spec
                .par_chunks_mut(m)
                .zip(input.par_chunks(ny))
                .with_min_len(8)
                .for_each_init(init, |s, x| row(x, s));
        } else {
            let mut s = init();
            self.spec
                .chunks_mut(m)
                .zip(input.chunks(ny))
                .for_each(|x| row(x, &mut s));
        }
        self.columns(true);
    }

    /// Inverse transform of the internal spectrum into `output`, normalised by 1/(nx·ny). The
    /// spectrum is consumed.
    fn inverse(&mut self, output: &mut [f64]) {
        assert_eq!(output.len(), self.nx * self.ny, "field length");
        self.columns(false);
        let (ny, m) = (self.ny, self.m);
        let c2r = &self.c2r;
        let row = |(inp, out): (&mut [Complex64], &mut [f64]), scratch: &mut Vec<Complex64>| {
            // The DC and Nyquist bins of a real signal's spectrum are real; remove rounding noise.
            inp[0].im = 0.0;
            inp[m - 1].im = 0.0;
            c2r.process_with_scratch(inp, out, scratch)
                .expect("c2r lengths are planned");
        };
        if self.parallel() {
            self.spec
                .par_chunks_mut(m)
                .zip(output.par_chunks_mut(ny))
                .with_min_len(8)
                .for_each_init(|| c2r.make_scratch_vec(), |s, x| row(x, s));
        } else {
            let mut s = c2r.make_scratch_vec();
            self.spec
                .chunks_mut(m)
                .zip(output.chunks_mut(ny))
                .for_each(|x| row(x, &mut s));
        }
    }

    /// FFT along x of every column of the half spectrum, in blocks of `BLOCK` columns.
    fn columns(&mut self, forward: bool) {
        let nx = self.nx;
        let fft = if forward { &self.fwd } else { &self.inv };
        let parallel = self.parallel();
        let mut view = ArrayViewMut2::from_shape((nx, self.m), &mut self.spec).expect("shape");
        let init = || {
            (
                vec![Complex64::new(0.0, 0.0); BLOCK * nx],
                vec![Complex64::new(0.0, 0.0); fft.get_inplace_scratch_len()],
            )
        };
        let block = |mut cols: ArrayViewMut2<Complex64>,
                     (buf, scratch): &mut (Vec<Complex64>, Vec<Complex64>)| {
            let b = cols.ncols();
            for (i, row) in cols.outer_iter().enumerate() {
                for (c, v) in row.iter().enumerate() {
                    buf[c * nx + i] = *v;
                }
            }
            fft.process_with_scratch(&mut buf[..b * nx], scratch);
            for (i, mut row) in cols.outer_iter_mut().enumerate() {
                for (c, v) in row.iter_mut().enumerate() {
                    *v = buf[c * nx + i];
                }
            }
        };
        if parallel {
            view.axis_chunks_iter_mut(Axis(1), BLOCK)
                .into_par_iter()
                .for_each_init(init, |s, cols| block(cols, s));
        } else {
            let mut s = init();
            for cols in view.axis_chunks_iter_mut(Axis(1), BLOCK) {
                block(cols, &mut s);
            }
        }
    }

    /// `output = IFFT(multiplier ⊙ FFT(input))`, where `multiplier` has the half-spectrum layout
    /// (`nx × (ny/2+1)`, x-wave index outer) and already includes the 1/(nx·ny) normalisation.
    /// `input` and `output` may be the same buffer only through [`Spectral::convolve_in_place`].
    pub fn convolve(&mut self, input: &[f64], multiplier: &[f64], output: &mut [f64]) {
        self.forward(input);
        self.multiply(multiplier);
        self.inverse(output);
    }

    /// In-place version of [`Spectral::convolve`].
    pub fn convolve_in_place(&mut self, field: &mut [f64], multiplier: &[f64]) {
        self.forward(field);
        self.multiply(multiplier);
        self.inverse(field);
    }

    fn multiply(&mut self, multiplier: &[f64]) {
        assert_eq!(multiplier.len(), self.spec.len(), "multiplier length");
        if self.parallel() {
            self.spec
                .par_iter_mut()
                .zip(multiplier.par_iter())
                .with_min_len(1 << 12)
                .for_each(|(s, &k)| *s *= k);
        } else {
            self.spec
                .iter_mut()
                .zip(multiplier)
                .for_each(|(s, &k)| *s *= k);
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

    #[test]
    fn matches_a_direct_fourier_sum() {
        let (nx, ny) = (8, 16);
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
}
