//! Critical points (maxima, minima, saddles) of a periodic trigonometric profile.
//!
//! Found by Newton's method on ∇h = 0 from a lattice of seeds covering the cell, then wrapped into
//! the cell, de-duplicated and classified by the Hessian's eigenvalues. Because the profiles are
//! exact sums of cosines, the positions are exact to rounding, whatever grid the contact solver
//! uses; nothing is placed by hand.

use crate::TrigSurface;

/// Type of a critical point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CriticalKind {
    /// Local maximum of the height.
    Maximum,
    /// Local minimum (a trough).
    Minimum,
    /// Saddle point.
    Saddle,
}

/// A critical point of the height profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalPoint {
    /// Kind.
    pub kind: CriticalKind,
    /// Position x in [0, lx) (λ).
    pub x: f64,
    /// Position y in [0, ly) (λ).
    pub y: f64,
    /// Height (h0).
    pub height: f64,
    /// Hessian eigenvalues, smaller first (h0/λ²).
    pub curvatures: [f64; 2],
    /// Unit eigenvector of the smaller eigenvalue. At a saddle this is the direction along which
    /// the height decreases, i.e. the axis of the fluid channel through the saddle (h''∥ < 0).
    pub axis: [f64; 2],
}

impl CriticalPoint {
    /// Curvature ratio η = −h''∥ / h''⊥ at a saddle (None for maxima and minima).
    pub fn eta(&self) -> Option<f64> {
        (self.kind == CriticalKind::Saddle).then(|| -self.curvatures[0] / self.curvatures[1])
    }
}

/// Symmetric 2×2 eigen-decomposition: eigenvalues ascending, unit eigenvector of the smaller one.
pub(crate) fn eigen(h: [[f64; 2]; 2]) -> ([f64; 2], [f64; 2]) {
    let (a, b, d) = (h[0][0], h[0][1], h[1][1]);
    let mean = 0.5 * (a + d);
    let r = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    let (lo, hi) = (mean - r, mean + r);
    // (h − lo I) v = 0: v ∝ (b, lo − a) or (lo − d, b), whichever is better conditioned.
    let v = if (a - lo).abs() > (d - lo).abs() {
        [-b, a - lo]
    } else {
        [d - lo, -b]
    };
    let norm = v[0].hypot(v[1]);
    let v = if norm > 0.0 {
        [v[0] / norm, v[1] / norm]
    } else {
        [1.0, 0.0]
    };
    ([lo, hi], v)
}

/// All critical points of `s` in its cell, sorted by kind then position.
pub fn find(s: &TrigSurface) -> Vec<CriticalPoint> {
    // Seeds: a lattice fine enough that every basin of Newton's method around a critical point of a
    // single-wavelength surface contains seeds (spacing ≪ λ/4).
    let k = s.k_max().max(1e-12);
    let per = |l: f64| ((l * k / (2.0 * std::f64::consts::PI)) * 12.0).ceil() as usize + 4;
    let (mx, my) = (per(s.lx), per(s.ly));
    let mut found: Vec<CriticalPoint> = Vec::new();
    let scale = 1.0 / (k * k);
    for a in 0..mx {
        for b in 0..my {
            let (mut x, mut y) = (
                (a as f64 + 0.5) * s.lx / mx as f64,
                (b as f64 + 0.5) * s.ly / my as f64,
            );
            let mut converged = false;
            for _ in 0..60 {
                let g = s.gradient(x, y);
                let h = s.hessian(x, y);
                let det = h[0][0] * h[1][1] - h[0][1] * h[0][1];
                if det.abs() < 1e-14 * k.powi(4) {
                    break;
                }
                let dx = (h[1][1] * g[0] - h[0][1] * g[1]) / det;
                let dy = (h[0][0] * g[1] - h[0][1] * g[0]) / det;
                // Damp long steps: Newton should only polish within a basin.
                let len = dx.hypot(dy);
                let lim = 0.25 / k;
                let f = if len > lim { lim / len } else { 1.0 };
                x -= f * dx;
                y -= f * dy;
                if len < 1e-14 * s.lx.max(s.ly) {
                    converged = true;
                    break;
                }
            }
            let g = s.gradient(x, y);
            if !converged && g[0].hypot(g[1]) > 1e-10 * k {
                continue;
            }
            let x = x.rem_euclid(s.lx);
            let y = y.rem_euclid(s.ly);
            let wrap = |d: f64, l: f64| d - l * (d / l).round();
            if found
                .iter()
                .any(|p| wrap(p.x - x, s.lx).hypot(wrap(p.y - y, s.ly)) < 1e-7)
            {
                continue;
            }
            let (curv, axis) = eigen(s.hessian(x, y));
            if curv[0].abs() < 1e-9 / scale || curv[1].abs() < 1e-9 / scale {
                continue; // degenerate: not a Morse critical point
            }
            let kind = if curv[1] < 0.0 {
                CriticalKind::Maximum
            } else if curv[0] > 0.0 {
                CriticalKind::Minimum
            } else {
                CriticalKind::Saddle
            };
            // Snap coordinates that are within rounding of the cell border back to 0.
            let snap = |v: f64, l: f64| if (l - v).abs() < 1e-9 * l { 0.0 } else { v };
            let (x, y) = (snap(x, s.lx), snap(y, s.ly));
            found.push(CriticalPoint {
                kind,
                x,
                y,
                height: s.height(x, y),
                curvatures: curv,
                axis,
            });
        }
    }
    found.sort_by(|a, b| {
        (a.kind, a.x, a.y)
            .partial_cmp(&(b.kind, b.x, b.y))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    found
}
