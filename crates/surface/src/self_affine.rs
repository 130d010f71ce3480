//! Self-affine Gaussian random surfaces on periodic 2^n × 2^n grids (Fourier filtering).
//!
//! # Spectrum
//! On an `L × L` cell, wave vectors `q = (2π/L)(kx, ky)` with integer `kx, ky ∈ (−N/2, N/2)`.
//! With `|k| = √(kx² + ky²)` in units of `2π/L` (as the roll-off `q_r` and cutoff `q_s` are
//! given), the PSD is
//!
//! ```text
//! C ∝ 1                          for 1 ≤ |k| < q_r   (flat down to q_0 = 2π/L)
//! C ∝ (|k| / q_r)^(−2(1+H))      for q_r ≤ |k| ≤ q_s
//! C = 0                          for |k| > q_s, for k = 0 and on the Nyquist lines |kx| or |ky| = N/2
//! ```
//!
//! The Nyquist lines are left out because a mode there has no distinct conjugate partner (it
//! would have to be real); `q_s ≤ N/2` keeps the band resolved.
//!
//! # Amplitudes
//! Fourier coefficients (convention of the `spectrum` module, `h = Σ H_k exp(i q·x)`):
//! - [`Amplitudes::Exact`]: `H_k = √C(k) exp(iφ_k)`, `φ_k` uniform in [0, 2π): the PSD of the
//!   realisation equals the model mode by mode (no scatter), the heights are still Gaussian to
//!   a good approximation (a sum of many independent phases);
//! - [`Amplitudes::Gaussian`]: `H_k = √(C(k)/2) (ξ + iζ)`, `ξ, ζ` independent standard normal
//!   (Box–Muller): filtered white noise, a strictly Gaussian random field whose PSD scatters
//!   around the model (exponential distribution per mode).
//!
//! Hermitian symmetry `H_{−k} = conj(H_k)` is imposed exactly by drawing only one coefficient
//! per pair `{k, −k}` (the half-plane `ky > 0`, plus `ky = 0, kx > 0`) and setting the partner
//! to its conjugate, so the synthesised field is real up to rounding of the inverse FFT.
//!
//! # Normalisation
//! The realised coefficients are scaled by one factor so that the requested rms height
//! (`Σ|H|²`) or rms gradient (`Σ|q|²|H|²`) holds exactly for this realisation (to rounding),
//! for either kind of amplitudes. The mean height is zero.
//!
//! # Random numbers
//! ChaCha8 (`rand_chacha::ChaCha8Rng::seed_from_u64(seed)`), a specified, portable stream.
//! Two 64-bit words are drawn per pair of modes for every pair of the grid, in a fixed order
//! (kx-major over the half plane), whether or not the mode lies in the band, on one thread:
//! the random numbers do not depend on the platform, the thread count or the band. A word `w`
//! becomes the uniform `(w >> 11) · 2⁻⁵³ ∈ [0, 1)`. The heights are bit-identical for any
//! thread count on one machine; across machines they can differ in the last bits, as `sin`,
//! `cos`, `ln` come from the platform's maths library and the FFT picks SIMD kernels per CPU.
//!
//! # Cost
//! One complex 2-D inverse FFT: `O(N² log N)` time, 16 bytes per node of scratch plus the
//! heights.

use crate::spectrum::{Spectrum, signed_index};
use crate::{Grid, HeightField, SurfaceError};
use ndarray::Array2;
use num_complex::Complex64;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::{RngCore, SeedableRng};
use std::f64::consts::PI;

/// Fourier amplitudes of a random surface (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Amplitudes {
    /// `|H_k| = √C(k)`, random phases.
    Exact,
    /// Complex Gaussian coefficients of variance `C(k)` (filtered noise).
    Gaussian,
}

/// What the surface is normalised to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Normalisation {
    /// rms height about the mean (length).
    RmsHeight(f64),
    /// rms gradient `√⟨|∇h|²⟩` (dimensionless).
    RmsSlope(f64),
}

/// Parameters of a self-affine random surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelfAffine {
    /// Grid exponent: 2^n × 2^n nodes, n in `N_MIN..=N_MAX`.
    pub n: u32,
    /// Cell side L (the cell is square), finite and > 0.
    pub length: f64,
    /// Hurst exponent H in (0, 1].
    pub hurst: f64,
    /// Roll-off wavenumber in units of 2π/L, `1 ≤ q_r ≤ q_s`.
    pub q_r: f64,
    /// Short-wavelength cutoff in units of 2π/L, `q_s ≤ 2^n / 2`.
    pub q_s: f64,
    /// rms height or rms slope.
    pub normalisation: Normalisation,
    /// Exact or Gaussian amplitudes.
    pub amplitudes: Amplitudes,
    /// Seed of the ChaCha8 stream.
    pub seed: u64,
}

fn bad(name: &'static str, value: impl ToString, allowed: &'static str) -> SurfaceError {
    SurfaceError::Parameter {
        name,
        value: value.to_string(),
        allowed,
    }
}

impl SelfAffine {
    /// Checks every parameter; the error names the parameter, its value and the allowed range.
    pub fn validate(&self) -> Result<(), SurfaceError> {
        if !(crate::N_MIN..=crate::N_MAX).contains(&self.n) {
            return Err(SurfaceError::GridExponent(self.n));
        }
        if !(self.length.is_finite() && self.length > 0.0) {
            return Err(bad("length", self.length, "finite and > 0"));
        }
        if !(self.hurst > 0.0 && self.hurst <= 1.0) {
            return Err(bad("hurst", self.hurst, "0 < H ≤ 1"));
        }
        let half = (1u64 << self.n) as f64 / 2.0;
        if !(self.q_r >= 1.0 && self.q_r.is_finite()) {
            return Err(bad("q_r", self.q_r, "1 ≤ q_r ≤ q_s (units of 2π/L)"));
        }
        if !(self.q_s >= self.q_r && self.q_s <= half) {
            return Err(bad(
                "q_s",
                format!("{} (q_r = {}, N/2 = {half})", self.q_s, self.q_r),
                "q_r ≤ q_s ≤ N/2 (units of 2π/L)",
            ));
        }
        let target = match self.normalisation {
            Normalisation::RmsHeight(v) | Normalisation::RmsSlope(v) => v,
        };
        if !(target.is_finite() && target > 0.0) {
            return Err(bad("rms", target, "finite and > 0"));
        }
        Ok(())
    }

    /// The model PSD shape at `|k|` (units of 2π/L), up to the normalisation.
    pub fn shape(&self, k: f64) -> f64 {
        if k < 1.0 || k > self.q_s {
            0.0
        } else if k < self.q_r {
            1.0
        } else {
            (k / self.q_r).powf(-2.0 * (1.0 + self.hurst))
        }
    }

    /// The Fourier coefficients of the realisation (exactly Hermitian, normalised).
    pub fn spectrum(&self) -> Result<Spectrum, SurfaceError> {
        self.validate()?;
        let nn = 1usize << self.n;
        let half = nn / 2;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut uniform = move || (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        let mut h = Array2::from_elem((nn, nn), Complex64::default());
        for i in 0..nn {
            for j in 0..=half {
                let (kx, ky) = (signed_index(i, nn), signed_index(j, nn));
                // One coefficient per pair {k, −k}: the half plane ky > 0, plus ky = 0, kx > 0.
                if !(ky > 0 || (ky == 0 && kx > 0)) {
                    continue;
                }
                let (u1, u2) = (uniform(), uniform());
                if kx.unsigned_abs() as usize == half || ky.unsigned_abs() as usize == half {
                    continue;
                }
                let c = self.shape((kx as f64).hypot(ky as f64));
                if c == 0.0 {
                    continue;
                }
                let z = match self.amplitudes {
                    Amplitudes::Exact => Complex64::from_polar(c.sqrt(), 2.0 * PI * u1),
                    Amplitudes::Gaussian => {
                        // Box–Muller: √(−2 ln u) e^{2πi v} is complex standard normal with
                        // E|z|² = 2; 1 − u1 ∈ (0, 1] keeps the logarithm finite.
                        let r = (-2.0 * (1.0 - u1).ln()).sqrt();
                        Complex64::from_polar((c / 2.0).sqrt() * r, 2.0 * PI * u2)
                    }
                };
                h[[i, j]] = z;
                h[[(nn - i) % nn, (nn - j) % nn]] = z.conj();
            }
        }
        let mut spectrum = Spectrum {
            coefficients: h,
            lx: self.length,
            ly: self.length,
        };
        let stats = spectrum.statistics();
        let scale = match self.normalisation {
            Normalisation::RmsHeight(r) => r / stats.rms_height,
            Normalisation::RmsSlope(s) => s / stats.rms_slope,
        };
        if !scale.is_finite() {
            return Err(bad(
                "q_s",
                self.q_s,
                "a band q_r..q_s that contains at least one grid wave vector",
            ));
        }
        spectrum.coefficients.mapv_inplace(|z| z * scale);
        Ok(spectrum)
    }

    /// The realisation as a height field on the periodic `L × L` grid.
    pub fn generate(&self) -> Result<HeightField, SurfaceError> {
        let spectrum = self.spectrum()?;
        let heights = spectrum.synthesise().mapv(|z| z.re);
        let nn = 1usize << self.n;
        let grid = Grid::periodic(nn, nn, self.length, self.length)?;
        HeightField::new(grid, heights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::psd_slope;

    fn params(hurst: f64, amplitudes: Amplitudes) -> SelfAffine {
        SelfAffine {
            n: 8,
            length: 2.0,
            hurst,
            q_r: 4.0,
            q_s: 64.0,
            normalisation: Normalisation::RmsHeight(0.25),
            amplitudes,
            seed: 42,
        }
    }

    /// PSD slope over q_r..q_s within ±0.05 of −2(1+H). Exact amplitudes follow the power law
    /// mode by mode (the fit only sees the bin averaging); Gaussian ones scatter by ~1/√count
    /// per bin, with hundreds to thousands of modes per bin on a 256² grid.
    #[test]
    fn psd_slope_matches_the_hurst_exponent() {
        for amplitudes in [Amplitudes::Exact, Amplitudes::Gaussian] {
            for hurst in [0.3, 0.5, 0.8] {
                let p = params(hurst, amplitudes);
                let field = p.generate().unwrap();
                let bins = field.spectrum().isotropic_psd(24);
                let q0 = 2.0 * PI / p.length;
                let slope = psd_slope(&bins, p.q_r * q0, p.q_s * q0);
                let want = -2.0 * (1.0 + hurst);
                eprintln!("{amplitudes:?} H = {hurst}: PSD slope {slope:.4} (want {want})");
                assert!(
                    (slope - want).abs() < 0.05,
                    "{amplitudes:?} H = {hurst}: slope {slope}, want {want}"
                );
            }
        }
    }

    #[test]
    fn rms_height_and_slope_are_as_requested() {
        for amplitudes in [Amplitudes::Exact, Amplitudes::Gaussian] {
            let mut p = params(0.8, amplitudes);
            let h = p.generate().unwrap();
            // Real-space rms of the grid values (independent of the spectral sum).
            let st = h.statistics();
            assert!((st.rms - 0.25).abs() < 1e-12 * 0.25, "{}", st.rms);
            assert!(st.mean.abs() < 1e-14, "{}", st.mean);
            p.normalisation = Normalisation::RmsSlope(0.1);
            let s = p.generate().unwrap().spectrum().statistics();
            assert!((s.rms_slope - 0.1).abs() < 1e-12 * 0.1, "{}", s.rms_slope);
        }
    }

    #[test]
    fn coefficients_are_hermitian_and_the_field_is_real() {
        for amplitudes in [Amplitudes::Exact, Amplitudes::Gaussian] {
            let s = params(0.5, amplitudes).spectrum().unwrap();
            let nn = s.coefficients.nrows();
            for ((i, j), z) in s.coefficients.indexed_iter() {
                assert_eq!(*z, s.coefficients[[(nn - i) % nn, (nn - j) % nn]].conj());
            }
            let field = s.synthesise();
            let rms = 0.25;
            let worst = field.iter().map(|z| z.im.abs()).fold(0.0, f64::max);
            // Rounding of a 65536-point inverse FFT of O(rms) values: ~1e-16 × rms × log N.
            assert!(worst < 1e-13 * rms, "imaginary part {worst}");
        }
    }

    #[test]
    fn same_seed_same_surface_other_seed_other_surface() {
        let p = params(0.8, Amplitudes::Gaussian);
        let a = p.generate().unwrap();
        let b = p.generate().unwrap();
        assert_eq!(a.heights, b.heights);
        let c = SelfAffine { seed: 43, ..p }.generate().unwrap();
        assert!(a.heights != c.heights);
        // The stream does not depend on the band: a mode inside both bands keeps its phase.
        let wide = SelfAffine { q_s: 100.0, ..p }.spectrum().unwrap();
        let narrow = p.spectrum().unwrap();
        let (x, y) = (wide.coefficients[[3, 5]], narrow.coefficients[[3, 5]]);
        assert!((x.arg() - y.arg()).abs() < 1e-12, "{x} vs {y}");
    }

    #[test]
    fn bad_parameters_are_named() {
        let p = params(0.8, Amplitudes::Exact);
        let msg = |p: SelfAffine| p.validate().unwrap_err().to_string();
        assert!(msg(SelfAffine { hurst: 1.5, ..p }).contains("hurst"));
        assert!(msg(SelfAffine { q_s: 200.0, ..p }).contains("q_s"));
        assert!(msg(SelfAffine { q_r: 0.5, ..p }).contains("q_r"));
        assert!(msg(SelfAffine { n: 20, ..p }).contains("20"));
        let e = msg(SelfAffine {
            normalisation: Normalisation::RmsSlope(-1.0),
            ..p
        });
        assert!(e.contains("rms") && e.contains("-1"), "{e}");
    }
}
