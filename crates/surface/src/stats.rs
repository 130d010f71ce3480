//! Moments of a height field.

use ndarray::ArrayView2;

/// Statistics of sampled heights (h0 units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Statistics {
    /// Smallest height.
    pub min: f64,
    /// Largest height.
    pub max: f64,
    /// Mean height.
    pub mean: f64,
    /// Root-mean-square deviation from the mean.
    pub rms: f64,
    /// Skewness ⟨(h − h̄)³⟩ / rms³.
    pub skewness: f64,
    /// Excess kurtosis ⟨(h − h̄)⁴⟩ / rms⁴ − 3.
    pub excess_kurtosis: f64,
}

impl Statistics {
    /// Statistics of a height field (two passes: mean, then central moments).
    pub fn of(h: ArrayView2<f64>) -> Self {
        let n = h.len() as f64;
        let (mut min, mut max, mut sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
        for &v in h.iter() {
            min = min.min(v);
            max = max.max(v);
            sum += v;
        }
        let mean = sum / n;
        let (mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0);
        for &v in h.iter() {
            let d = v - mean;
            let d2 = d * d;
            m2 += d2;
            m3 += d2 * d;
            m4 += d2 * d2;
        }
        let (m2, m3, m4) = (m2 / n, m3 / n, m4 / n);
        let rms = m2.sqrt();
        Statistics {
            min,
            max,
            mean,
            rms,
            skewness: m3 / (m2 * rms),
            excess_kurtosis: m4 / (m2 * m2) - 3.0,
        }
    }

    /// Mean trough depth t̄ = mean − min.
    pub fn trough_depth(&self) -> f64 {
        self.mean - self.min
    }
}
