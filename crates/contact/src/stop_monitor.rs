//! The stop rules every minimiser shares besides convergence and its iteration cap: a solve
//! stops as **stagnant** when its residual has not improved by 1 % for a window of iterations,
//! and on **residual growth** when the residual exceeds a factor times max(best so far,
//! tolerance). Each minimiser chooses its window and factor (they differ in how noisy their
//! residuals are); the rules themselves are written once here.

use crate::StopReason;

/// Watches a minimiser's residual from one iteration to the next.
#[derive(Clone, Copy, Debug)]
pub(crate) struct StopMonitor {
    best: f64,
    best_iter: usize,
    window: usize,
    growth: f64,
}

impl StopMonitor {
    /// Stagnant after `window` iterations without a 1 % improvement; diverging above
    /// `growth` × max(best, tolerance).
    pub(crate) fn new(window: usize, growth: f64) -> Self {
        Self {
            best: f64::INFINITY,
            best_iter: 0,
            window,
            growth,
        }
    }

    /// Records the residual of iteration `iteration`; `Some(reason)` when the solve must stop.
    pub(crate) fn check(
        &mut self,
        residual: f64,
        iteration: usize,
        tol: f64,
    ) -> Option<StopReason> {
        if residual < 0.99 * self.best {
            self.best = residual;
            self.best_iter = iteration;
        } else if iteration - self.best_iter > self.window {
            return Some(StopReason::Stagnation);
        }
        if residual > self.growth * self.best.max(tol) {
            return Some(StopReason::ResidualGrowth);
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stagnation_after_the_window_and_growth_beyond_the_factor() {
        let mut m = StopMonitor::new(3, 1e3);
        assert_eq!(m.check(1.0, 0, 1e-10), None);
        // 0.995 is not a 1 % improvement: iterations 1..=3 stay within the window
        for it in 1..=3 {
            assert_eq!(m.check(0.995, it, 1e-10), None);
        }
        assert_eq!(m.check(0.995, 4, 1e-10), Some(StopReason::Stagnation));
        let mut m = StopMonitor::new(100, 1e3);
        assert_eq!(m.check(1e-6, 0, 1e-10), None);
        assert_eq!(m.check(2e-3, 1, 1e-10), Some(StopReason::ResidualGrowth));
        // the tolerance bounds the reference from below
        let mut m = StopMonitor::new(100, 1e3);
        assert_eq!(m.check(1e-12, 0, 1e-6), None);
        assert_eq!(m.check(5e-4, 1, 1e-6), None);
    }
}
