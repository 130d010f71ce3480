//! Sample statistics of an ensemble (one value per realisation): mean, sample standard
//! deviation and standard error, Pearson correlation, ordinary least-squares slope. Non-finite
//! values (a realisation that has no value) are left out, pairwise for the two-sample ones.

/// Mean, sample sd (n − 1; NaN for one value) and sem of the finite values, and their count.
pub fn mean_sd_sem(v: &[f64]) -> (f64, f64, f64, usize) {
    let v: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    let n = v.len() as f64;
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN, 0);
    }
    let m = v.iter().sum::<f64>() / n;
    if v.len() < 2 {
        return (m, f64::NAN, f64::NAN, 1);
    }
    let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    (m, sd, sd / n.sqrt(), v.len())
}

/// The values are not all equal (a constant has no correlation and no slope; its computed
/// spread is rounding, not zero).
fn spread(v: &[f64]) -> bool {
    v.iter().any(|x| *x != v[0])
}

/// Pearson correlation of the pairs where both are finite (NaN with fewer than 3, or if either
/// is constant).
pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let (x, y): (Vec<f64>, Vec<f64>) = a
        .iter()
        .zip(b)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (*x, *y))
        .unzip();
    if x.len() < 3 || !spread(&x) || !spread(&y) {
        return f64::NAN;
    }
    let (mx, sx, _, _) = mean_sd_sem(&x);
    let (my, sy, _, _) = mean_sd_sem(&y);
    let n = x.len() as f64;
    x.iter()
        .zip(&y)
        .map(|(a, b)| (a - mx) * (b - my))
        .sum::<f64>()
        / ((n - 1.0) * sx * sy)
}

/// Least-squares slope of y on x over the finite pairs and its standard error (NaN with fewer
/// than 3 pairs or no spread in x).
pub fn ols_slope(x: &[f64], y: &[f64]) -> (f64, f64) {
    let (x, y): (Vec<f64>, Vec<f64>) = x
        .iter()
        .zip(y)
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(a, b)| (*a, *b))
        .unzip();
    let n = x.len();
    if n < 3 || !spread(&x) {
        return (f64::NAN, f64::NAN);
    }
    let (mx, _, _, _) = mean_sd_sem(&x);
    let (my, _, _, _) = mean_sd_sem(&y);
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    let b = x
        .iter()
        .zip(&y)
        .map(|(a, c)| (a - mx) * (c - my))
        .sum::<f64>()
        / sxx;
    let rss: f64 = x
        .iter()
        .zip(&y)
        .map(|(a, c)| (c - my - b * (a - mx)).powi(2))
        .sum();
    (b, (rss / (n as f64 - 2.0) / sxx).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Oracles: mean 2, sd 1, sem 1/√3 of (1, 2, 3); a perfect linear relation correlates 1,
    /// an anti-linear one −1; NaN is skipped.
    #[test]
    fn statistics_and_correlation() {
        let (m, sd, sem, n) = mean_sd_sem(&[1.0, 2.0, f64::NAN, 3.0]);
        assert_eq!((m, n), (2.0, 3));
        assert!((sd - 1.0).abs() < 1e-15 && (sem - 1.0 / 3f64.sqrt()).abs() < 1e-15);
        assert!(mean_sd_sem(&[0.3]).1.is_nan());
        let a = [1.0, 2.0, 4.0, 7.0];
        let b: Vec<f64> = a.iter().map(|x| 3.0 - 2.0 * x).collect();
        assert!((pearson(&a, &b) + 1.0).abs() < 1e-12);
        assert!((pearson(&a, &a) - 1.0).abs() < 1e-12);
        assert!(pearson(&a[..2], &b[..2]).is_nan());
        // an exact line: slope −2 with zero error; scatter (0,0),(1,1),(2,0),(3,1): slope 0.2,
        // residual sum 0.8 over 2 degrees of freedom and Σ(x − x̄)² = 5: error √(0.4/5)
        let (s, e) = ols_slope(&a, &b);
        assert!((s + 2.0).abs() < 1e-12 && e.abs() < 1e-12, "{s} {e}");
        let (s, e) = ols_slope(&[0.0, 1.0, 2.0, 3.0], &[0.0, 1.0, 0.0, 1.0]);
        assert!((s - 0.2).abs() < 1e-12 && (e - (0.4f64 / 5.0).sqrt()).abs() < 1e-12);
        // one H only (0.8 three times: its rounded spread is not zero): no slope, no correlation
        assert!(ols_slope(&[0.8, 0.8, 0.8], &[0.0, 1.0, 2.0]).0.is_nan());
        assert!(pearson(&[0.8, 0.8, 0.8], &[0.0, 1.0, 2.0]).is_nan());
    }
}
