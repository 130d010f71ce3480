//! Test support: a fixed-seed generator (SplitMix64 + Box–Muller) and a Monte-Carlo check of
//! reported error bars.
#![allow(dead_code)]

use analysis::FitResult;

/// SplitMix64 (Steele, Lea & Flood 2014): tiny, fast, deterministic for a given seed.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// Runs `m` noisy replicates of a fit and checks, for every parameter with a non-zero error:
/// - the first replicate lies within 4σ of the truth;
/// - the mean reported σ is within a factor 2 of the Monte-Carlo spread (std of the estimates);
/// - the fraction of replicates within 1σ of the truth (the coverage) is within [0.55, 0.80]
///   (68.3% expected; the binomial std for m = 300 is 0.027, so this allows ±4.5 std);
/// - the bias |mean − truth| is below 0.35 of the spread (nonlinear estimators are biased at
///   O(σ²); this catches gross bias, not the statistical O(σ/√m)).
///
/// Returns the per-parameter (mean σ, MC spread, coverage) for the record.
pub fn monte_carlo(
    name: &str,
    truth: &[f64],
    m: usize,
    seed: u64,
    mut fit: impl FnMut(&mut Rng) -> FitResult,
) -> Vec<(f64, f64, f64)> {
    let mut rng = Rng::new(seed);
    let k = truth.len();
    let mut est = vec![Vec::with_capacity(m); k];
    let mut sig = vec![Vec::with_capacity(m); k];
    for rep in 0..m {
        let f = fit(&mut rng);
        assert!(
            f.status.converged,
            "{name}: replicate {rep} did not converge: {:?}",
            f.status
        );
        for i in 0..k {
            est[i].push(f.params[i]);
            sig[i].push(f.errors[i]);
            if rep == 0 && f.errors[i] > 0.0 {
                assert!(
                    (f.params[i] - truth[i]).abs() < 4.0 * f.errors[i],
                    "{name}: {} = {} ± {} vs truth {}",
                    f.names[i],
                    f.params[i],
                    f.errors[i],
                    truth[i]
                );
            }
        }
    }
    let mut out = Vec::new();
    for i in 0..k {
        let mean_sigma = sig[i].iter().sum::<f64>() / m as f64;
        if mean_sigma == 0.0 {
            out.push((0.0, 0.0, 1.0));
            continue;
        }
        let mean = est[i].iter().sum::<f64>() / m as f64;
        let spread =
            (est[i].iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (m as f64 - 1.0)).sqrt();
        let cover = est[i]
            .iter()
            .zip(&sig[i])
            .filter(|(e, s)| (*e - truth[i]).abs() < **s)
            .count() as f64
            / m as f64;
        eprintln!(
            "{name}: param {i}: truth {:.6e}, mean {mean:.6e}, MC spread {spread:.3e}, mean sigma \
             {mean_sigma:.3e} (ratio {:.3}), 1-sigma coverage {cover:.3}",
            truth[i],
            mean_sigma / spread
        );
        let ratio = mean_sigma / spread;
        assert!(
            (0.5..=2.0).contains(&ratio),
            "{name}: param {i}: sigma/spread = {ratio}"
        );
        assert!(
            (0.55..=0.80).contains(&cover),
            "{name}: param {i}: coverage {cover}"
        );
        assert!(
            (mean - truth[i]).abs() < 0.35 * spread,
            "{name}: param {i}: bias {} vs spread {spread}",
            mean - truth[i]
        );
        out.push((mean_sigma, spread, cover));
    }
    out
}
