//! The gap at the saddle points and the sub-grid estimate of L_c from its closing.
//!
//! Below L_c the fluid channel through a saddle is open and the gap at the saddle closes as
//! `g_s ∝ (L_c − L)^ζ` (PHYSICS.md). Fitted with L_c free on loads where the channel is resolved
//! by several grid spacings, this locates L_c without the pixel-level bridging that decides the
//! grid's percolation transition.
//!
//! Saddles come from the exact profile ([`surface::Surface::critical_points`]), so on shifted
//! grids they fall between nodes. The gap there is `u(x_s) − h(x_s)`: `h` exact, `u` from Keys'
//! cubic convolution (a = −1/2, third order) over the 4 × 4 nodes around the saddle. A sample is
//! kept only when all 16 nodes are open (no contact): `u` is smooth there, while across a contact
//! line it is only C¹. On a node the interpolation returns the node's own value.

use ndarray::ArrayView2;
use surface::{CriticalKind, Grid, Surface};

/// Saddles of one orientation (their channels are parallel), equivalent by the lattice symmetry.
#[derive(Clone, Debug, PartialEq)]
pub struct SaddleGroup {
    /// Angle of the channel axis (the direction along which the height decreases) in [0°, 180°).
    pub angle_deg: f64,
    /// Saddle positions (λ) in the cell.
    pub points: Vec<(f64, f64)>,
}

/// Groups the saddles of `surface` by channel orientation, sorted by angle.
pub fn saddle_groups(surface: &Surface) -> Vec<SaddleGroup> {
    let mut groups: Vec<SaddleGroup> = Vec::new();
    for p in surface.critical_points() {
        if p.kind != CriticalKind::Saddle {
            continue;
        }
        let mut a = p.axis[1].atan2(p.axis[0]).to_degrees();
        if a < 0.0 {
            a += 180.0;
        }
        if a >= 180.0 - 1e-6 || a.abs() < 1e-9 {
            a = 0.0; // also turns −0° into 0°
        }
        match groups.iter_mut().find(|g| (g.angle_deg - a).abs() < 1e-3) {
            Some(g) => g.points.push((p.x, p.y)),
            None => groups.push(SaddleGroup {
                angle_deg: a,
                points: vec![(p.x, p.y)],
            }),
        }
    }
    groups.sort_by(|a, b| a.angle_deg.total_cmp(&b.angle_deg));
    groups
}

/// Keys' cubic convolution kernel (a = −1/2).
fn keys(t: f64) -> f64 {
    let t = t.abs();
    if t < 1.0 {
        (1.5 * t - 2.5) * t * t + 1.0
    } else if t < 2.0 {
        ((-0.5 * t + 2.5) * t - 4.0) * t + 2.0
    } else {
        0.0
    }
}

/// Gap at the point (x, y) (λ): `u` interpolated from the 4 × 4 surrounding nodes minus the exact
/// height. `None` if any of those nodes is in contact (g = 0).
pub fn gap_at(
    surface: &Surface,
    displacement: ArrayView2<f64>,
    gap: ArrayView2<f64>,
    x: f64,
    y: f64,
) -> Option<f64> {
    let g: &Grid = &surface.grid;
    let (nx, ny) = (g.nx as isize, g.ny as isize);
    let tx = x / g.dx() - g.shift.0;
    let ty = y / g.dy() - g.shift.1;
    let (ix, iy) = (tx.floor(), ty.floor());
    let (fx, fy) = (tx - ix, ty - iy);
    let (ix, iy) = (ix as isize, iy as isize);
    let mut u = 0.0;
    for a in -1..=2isize {
        let wx = keys(fx - a as f64);
        let i = (ix + a).rem_euclid(nx) as usize;
        for b in -1..=2isize {
            let j = (iy + b).rem_euclid(ny) as usize;
            if gap[[i, j]] <= 0.0 {
                return None;
            }
            let wy = keys(fy - b as f64);
            if wx != 0.0 && wy != 0.0 {
                u += wx * wy * displacement[[i, j]];
            }
        }
    }
    Some(u - surface.profile.height(x, y))
}

/// The saddle gaps at one load.
#[derive(Clone, Debug, PartialEq)]
pub struct SaddleSample {
    /// Load (mean pressure, E* h0/λ).
    pub load: f64,
    /// Reduced load `(L − L_c)/L_c` relative to the grid's bisected L_c.
    pub reduced: f64,
    /// Per group (same order as [`saddle_groups`]): mean gap over the group's saddles (h0), or
    /// `None` when a saddle's interpolation stencil touches contact.
    pub gap: Vec<Option<f64>>,
    /// Contact area (raw) at this load.
    pub area: f64,
}

/// Mean interpolated gap over each group's saddles.
pub fn sample_groups(
    surface: &Surface,
    groups: &[SaddleGroup],
    displacement: ArrayView2<f64>,
    gap: ArrayView2<f64>,
) -> Vec<Option<f64>> {
    groups
        .iter()
        .map(|grp| {
            let mut sum = 0.0;
            for &(x, y) in &grp.points {
                sum += gap_at(surface, displacement, gap, x, y)?;
            }
            Some(sum / grp.points.len() as f64)
        })
        .collect()
}

/// Fit of `g_s = A (L_c − L)^ζ` for one saddle group.
#[derive(Clone, Debug, PartialEq)]
pub struct SaddleFit {
    /// Channel angle of the group (degrees).
    pub angle_deg: f64,
    /// Number of samples used (open stencils).
    pub points: usize,
    /// Fitted L_c (E* h0/λ) and its 1σ error (from the fit, scaled by the reduced χ²).
    pub l_c: (f64, f64),
    /// Fitted exponent ζ and 1σ error.
    pub zeta: (f64, f64),
    /// Amplitude A and 1σ error.
    pub amplitude: (f64, f64),
    /// χ²/dof (unit weights: the misfit of the model in h0²).
    pub reduced_chi2: f64,
    /// Parameters stuck at a bound (L_c pegged at the largest sampled load means the data do
    /// not determine it).
    pub pegged: usize,
}

/// The sub-grid estimate: per-group fits and their combination.
#[derive(Clone, Debug, PartialEq)]
pub struct Subgrid {
    /// One fit per saddle group that had enough samples.
    pub fits: Vec<SaddleFit>,
    /// Mean of the groups' L_c (E* h0/λ).
    pub l_c: f64,
    /// Its error: the largest group fit error combined in quadrature with half the spread of
    /// the groups' values (they estimate the same continuum L_c).
    pub l_c_error: f64,
    /// Mean of the groups' ζ.
    pub zeta: f64,
    /// Error of ζ, formed like `l_c_error`.
    pub zeta_error: f64,
}

/// Fits every group with at least 4 open samples (3 parameters and one degree of freedom).
/// Returns `None` when no group could be fitted; the reasons are in the second value.
pub fn fit_subgrid(
    groups: &[SaddleGroup],
    samples: &[SaddleSample],
) -> (Option<Subgrid>, Vec<String>) {
    let mut fits = Vec::new();
    let mut notes = Vec::new();
    for (k, g) in groups.iter().enumerate() {
        let (load, gap): (Vec<f64>, Vec<f64>) = samples
            .iter()
            .filter_map(|s| s.gap[k].filter(|v| *v > 0.0).map(|v| (s.load, v)))
            .unzip();
        if load.len() < 4 {
            notes.push(format!(
                "saddles at {:.1}°: only {} open samples, at least 4 needed for a fit",
                g.angle_deg,
                load.len()
            ));
            continue;
        }
        match analysis::fit_saddle_gap(&load, &gap, None, analysis::ErrorScale::ReducedChi2) {
            Ok(f) => {
                let get = |n: &str| f.get(n).unwrap_or((f64::NAN, f64::NAN));
                fits.push(SaddleFit {
                    angle_deg: g.angle_deg,
                    points: load.len(),
                    l_c: get("L_c"),
                    zeta: get("zeta"),
                    amplitude: get("A"),
                    reduced_chi2: f.reduced_chi2(),
                    pegged: f.status.pegged,
                });
            }
            Err(e) => notes.push(format!("saddles at {:.1}°: fit failed: {e}", g.angle_deg)),
        }
    }
    if fits.is_empty() {
        return (None, notes);
    }
    let combine = |v: &[(f64, f64)]| {
        let mean = v.iter().map(|p| p.0).sum::<f64>() / v.len() as f64;
        let lo = v.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
        let hi = v.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
        let fit = v.iter().map(|p| p.1).fold(0.0, f64::max);
        (mean, fit.hypot(0.5 * (hi - lo)))
    };
    let (l_c, l_c_error) = combine(&fits.iter().map(|f| f.l_c).collect::<Vec<_>>());
    let (zeta, zeta_error) = combine(&fits.iter().map(|f| f.zeta).collect::<Vec<_>>());
    (
        Some(Subgrid {
            fits,
            l_c,
            l_c_error,
            zeta,
            zeta_error,
        }),
        notes,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;
    use surface::Lattice;

    #[test]
    fn groups_have_the_lattice_orientations() {
        let sq = saddle_groups(&Surface::new(Lattice::Square, 4).unwrap());
        let angles: Vec<f64> = sq.iter().map(|g| g.angle_deg.round()).collect();
        assert_eq!(angles, vec![0.0, 90.0]);
        assert!(sq.iter().all(|g| g.points.len() == 1));
        // Four maxima per hexagonal-family cell, so four saddles of each orientation. The
        // triangular model's channels cross the bonds of its triangular lattice of maxima
        // (bonds at 0°, 60°, 120°); the hexagonal model's channels are turned by 90°.
        for (l, want) in [
            (Lattice::Triangular, [30.0, 90.0, 150.0]),
            (Lattice::Hexagonal, [0.0, 60.0, 120.0]),
        ] {
            let g = saddle_groups(&Surface::new(l, 4).unwrap());
            let angles: Vec<f64> = g.iter().map(|g| g.angle_deg.round()).collect();
            assert_eq!(angles, want.to_vec(), "{l}");
            assert!(g.iter().all(|g| g.points.len() == 4), "{l}");
        }
    }

    #[test]
    fn interpolation_is_exact_on_nodes_and_accurate_between() {
        // A smooth "displacement" u = h + 1 + 0.1 cos(2πx): the gap is 1 + 0.1 cos(2πx).
        for shift in [(0.0, 0.0), (0.3, 0.7)] {
            let grid = Grid::new(Lattice::Square, 6)
                .unwrap()
                .shifted(shift.0, shift.1)
                .unwrap();
            let s = Surface::on_grid(Lattice::Square, grid);
            let u = Array2::from_shape_fn((grid.nx, grid.ny), |(i, j)| {
                let (x, _) = grid.position(i, j);
                s.heights[[i, j]] + 1.0 + 0.1 * (2.0 * std::f64::consts::PI * x).cos()
            });
            let g = Array2::from_elem(u.dim(), 1.0);
            let (x, y) = grid.position(5, 9);
            let v = gap_at(&s, u.view(), g.view(), x, y).unwrap();
            let exact = 1.0 + 0.1 * (2.0 * std::f64::consts::PI * x).cos();
            assert!((v - exact).abs() < 1e-12, "{v} vs {exact}");
            let (x, y) = (0.5, 0.0);
            let v = gap_at(&s, u.view(), g.view(), x, y).unwrap();
            // cubic convolution: error O(dx³ |h'''|) with dx = 1/64
            assert!((v - 0.9).abs() < 1e-3, "{v}");
            // a contact node in the stencil voids the sample
            let mut gc = g.clone();
            let (i, j) = (((0.5 / grid.dx()) - shift.0).floor() as usize, 0usize);
            gc[[i, j]] = 0.0;
            assert!(gap_at(&s, u.view(), gc.view(), x, y).is_none());
        }
    }

    #[test]
    fn fit_recovers_a_synthetic_power_law() {
        let groups = vec![SaddleGroup {
            angle_deg: 90.0,
            points: vec![(0.5, 0.0)],
        }];
        let l_c = 1.234;
        let samples: Vec<SaddleSample> = [0.05, 0.03, 0.02, 0.01, 0.005, 0.003]
            .iter()
            .map(|&d| {
                let load = l_c * (1.0 - d);
                SaddleSample {
                    load,
                    reduced: -d,
                    gap: vec![Some(0.7 * (l_c - load).powf(1.2))],
                    area: 0.4,
                }
            })
            .collect();
        let (sub, notes) = fit_subgrid(&groups, &samples);
        let sub = sub.unwrap();
        assert!(notes.is_empty());
        assert!((sub.l_c - l_c).abs() < 1e-9, "{sub:?}");
        assert!((sub.zeta - 1.2).abs() < 1e-7);
    }
}
