//! The smallest eigenvalue of the preconditioned operator, from the conjugate-gradient
//! coefficients (the Lanczos connection).
//!
//! `k` steps of preconditioned CG on `A x = b` with step lengths `α_j` and direction updates
//! `β_j` (`p_{j+1} = z_{j+1} + β_j p_j`) are `k` steps of the Lanczos process on `M A` (`M` the
//! preconditioner), whose tridiagonal matrix `T_k` is
//!
//! ```text
//! T[0][0] = 1/α_0,   T[j][j] = 1/α_j + β_{j−1}/α_{j−1} (j ≥ 1),   T[j][j+1]² = β_j/α_j²
//! ```
//!
//! (Golub & Van Loan, *Matrix Computations*, §11.3; Meurant, *The Lanczos and Conjugate
//! Gradient Algorithms*, ch. 2). Its eigenvalues (Ritz values) interlace with those of `M A`:
//! the smallest one lies at or above `λ_min(M A)` and approaches it as the Krylov space grows
//! into the slow direction. Near a closing constriction that slow direction is the pressure
//! difference between the ponds on either side of the throat, which is the very component the
//! flux depends on, so CG brings it in early.
//!
//! Why it matters here: [`crate::FlowResult::flux_error_estimate`] estimates the energy norm of
//! the pressure error, `rᵀ A⁻¹ r`, through the preconditioner, `rᵀ M r`. For `M` and `A`
//! symmetric positive (semi-)definite, `rᵀ A⁻¹ r ≤ rᵀ M r / λ_min(M A)` on `A`'s range, and a
//! V-cycle that does not capture the near-null mode of a weak throat underestimates
//! `rᵀ A⁻¹ r` by up to `1/λ_min`.
//!
//! The eigenvalue is found by bisection on Sturm counts (the number of negative pivots of
//! `T − x I` in its LDLᵀ factorisation), started from Gershgorin's bounds: ~60 counts of `O(k)`
//! each (more when the bounds span many decades), a few microseconds for the hundred-odd steps of a flow solve.

/// Accumulates CG coefficients into the Lanczos tridiagonal of one Krylov sequence (reset at a
/// restart, which starts a new sequence) and keeps the smallest Ritz value over the sequences
/// already closed.
#[derive(Clone, Debug, Default)]
pub(crate) struct Ritz {
    diag: Vec<f64>,
    off_sq: Vec<f64>,
    /// `(α_last, β_last)` of the open sequence: the next diagonal entry needs `β/α`.
    last: Option<(f64, Option<f64>)>,
    closed_min: Option<f64>,
}

impl Ritz {
    /// A CG step with step length `alpha` (the direction update that follows it is recorded by
    /// [`Ritz::direction`]).
    pub fn step(&mut self, alpha: f64) {
        let d = match self.last {
            None => 1.0 / alpha,
            Some((a_prev, Some(b_prev))) => 1.0 / alpha + b_prev / a_prev,
            // a step without the direction update between: the sequence was broken (not reached
            // by Pcg, which always updates or restarts); start a new one
            Some((_, None)) => {
                self.close();
                1.0 / alpha
            }
        };
        self.diag.push(d);
        self.last = Some((alpha, None));
    }

    /// The direction update `β` after the last step.
    pub fn direction(&mut self, beta: f64) {
        if let Some((alpha, b)) = &mut self.last
            && b.is_none()
        {
            *b = Some(beta);
            self.off_sq.push(beta / (*alpha * *alpha));
        }
    }

    /// Ends the current Krylov sequence (a restart from the true residual).
    pub fn close(&mut self) {
        self.closed_min = smaller(self.closed_min, self.open_min());
        self.diag.clear();
        self.off_sq.clear();
        self.last = None;
    }

    /// Smallest Ritz value over every sequence so far (None before the first step).
    pub fn smallest(&self) -> Option<f64> {
        smaller(self.closed_min, self.open_min())
    }

    fn open_min(&self) -> Option<f64> {
        if self.diag.is_empty() {
            return None;
        }
        let k = self.diag.len();
        Some(smallest_eigenvalue(&self.diag, &self.off_sq[..k - 1]))
    }
}

/// The smaller of two Ritz values, either possibly absent; NaN (a non-finite tridiagonal) counts
/// as absent.
pub(crate) fn smaller(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a.filter(|v| !v.is_nan()), b.filter(|v| !v.is_nan())) {
        (Some(x), Some(y)) => Some(x.min(y)),
        (x, y) => x.or(y),
    }
}

/// Smallest eigenvalue of the symmetric tridiagonal matrix with diagonal `d` and squared
/// off-diagonal `e2` (`e2.len() == d.len() − 1`), by bisection on Sturm counts to a relative
/// width of a few ε. Non-finite entries give NaN.
pub(crate) fn smallest_eigenvalue(d: &[f64], e2: &[f64]) -> f64 {
    let n = d.len();
    assert!(
        n >= 1 && e2.len() + 1 == n,
        "tridiagonal of {n} with {} off-diagonals",
        e2.len()
    );
    if d.iter().chain(e2).any(|v| !v.is_finite()) {
        return f64::NAN;
    }
    // Gershgorin: every eigenvalue lies in [min_i d_i − r_i, max_i d_i + r_i].
    let e = |i: usize| e2[i].max(0.0).sqrt();
    let radius =
        |i: usize| (if i > 0 { e(i - 1) } else { 0.0 }) + (if i + 1 < n { e(i) } else { 0.0 });
    let mut lo = (0..n)
        .map(|i| d[i] - radius(i))
        .fold(f64::INFINITY, f64::min);
    let mut hi = (0..n)
        .map(|i| d[i] + radius(i))
        .fold(f64::NEG_INFINITY, f64::max);
    // hi: an upper bound of the smallest eigenvalue is the smallest diagonal entry
    hi = hi.min(d.iter().copied().fold(f64::INFINITY, f64::min));
    for _ in 0..400 {
        let mid = 0.5 * (lo + hi);
        if !(lo < mid && mid < hi) || hi - lo <= 2.0 * f64::EPSILON * lo.abs().max(hi.abs()) {
            break;
        }
        if below(d, e2, mid) >= 1 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Number of eigenvalues below `x` (negative pivots of `T − x I`).
fn below(d: &[f64], e2: &[f64], x: f64) -> usize {
    let mut count = 0;
    let mut q = d[0] - x;
    for i in 0..d.len() {
        if i > 0 {
            // a zero pivot is perturbed to the smallest safe magnitude (standard in `dstebz`)
            let prev = if q == 0.0 {
                f64::EPSILON * x.abs().max(f64::MIN_POSITIVE)
            } else {
                q
            };
            q = d[i] - x - e2[i - 1] / prev;
        }
        if q < 0.0 {
            count += 1;
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Oracle: the 1D Dirichlet Laplacian tridiag(−1, 2, −1) of size n has the eigenvalues
    /// 2 − 2 cos(kπ/(n+1)), k = 1 … n.
    #[test]
    fn smallest_eigenvalue_of_the_discrete_laplacian() {
        for n in [1usize, 2, 5, 40, 300] {
            let d = vec![2.0; n];
            let e2 = vec![1.0; n - 1];
            let exact = 2.0 - 2.0 * (std::f64::consts::PI / (n + 1) as f64).cos();
            let got = smallest_eigenvalue(&d, &e2);
            assert!(
                (got - exact).abs() <= 1e-12 * exact.max(1e-3),
                "n = {n}: {got} vs {exact}"
            );
        }
    }

    /// Oracle: a scaled Laplacian spanning 30 decades keeps its relative accuracy.
    #[test]
    fn tiny_eigenvalues_keep_their_relative_accuracy() {
        for s in [1e-30, 1e-10, 1e10] {
            let n = 7;
            let d = vec![2.0 * s; n];
            let e2 = vec![s * s; n - 1];
            let exact = s * (2.0 - 2.0 * (std::f64::consts::PI / (n + 1) as f64).cos());
            let got = smallest_eigenvalue(&d, &e2);
            assert!((got / exact - 1.0).abs() < 1e-12, "{s}: {got} vs {exact}");
        }
    }

    /// Plain CG (M = I) on a diagonal matrix with known eigenvalues: after n steps in exact
    /// arithmetic the Ritz values are the eigenvalues, so the smallest Ritz value from the CG
    /// coefficients must be λ_min; before that it lies above it (interlacing).
    #[test]
    fn cg_coefficients_give_the_ritz_values() {
        let lambda = [0.02, 0.3, 0.7, 1.0, 1.9, 4.0];
        let n = lambda.len();
        let b = [1.0, -0.5, 0.8, 0.3, -1.1, 0.6];
        let mut x = vec![0.0; n];
        let mut r = b.to_vec();
        let mut p = r.clone();
        let mut rho: f64 = r.iter().map(|v| v * v).sum();
        let mut ritz = Ritz::default();
        let mut history = Vec::new();
        for _ in 0..n {
            let q: Vec<f64> = (0..n).map(|i| lambda[i] * p[i]).collect();
            let alpha = rho / p.iter().zip(&q).map(|(a, b)| a * b).sum::<f64>();
            ritz.step(alpha);
            history.push(ritz.smallest().unwrap());
            for i in 0..n {
                x[i] += alpha * p[i];
                r[i] -= alpha * q[i];
            }
            let rho_new: f64 = r.iter().map(|v| v * v).sum();
            let beta = rho_new / rho;
            rho = rho_new;
            ritz.direction(beta);
            for i in 0..n {
                p[i] = r[i] + beta * p[i];
            }
        }
        let last = *history.last().unwrap();
        assert!((last / lambda[0] - 1.0).abs() < 1e-8, "{history:?}");
        for w in history.windows(2) {
            assert!(w[1] <= w[0] * (1.0 + 1e-12), "not decreasing: {history:?}");
        }
        assert!(history[0] > 2.0 * lambda[0], "{history:?}");
        // a restart closes the sequence: the minimum is kept
        ritz.close();
        ritz.step(1.0);
        assert_eq!(ritz.smallest(), Some(last.min(1.0)));
    }
}
