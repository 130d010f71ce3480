//! Averaging over sub-grid shifts of the surface relative to the grid.
//!
//! On one grid, a_p counts nodes and L_c depends on where the saddles fall relative to the nodes;
//! both jump as the surface slides by a fraction of a spacing. Every quantity is periodic in the
//! shift (s_x, s_y) with period one spacing, so its shift average is an integral over the unit
//! square. All three models are mirror-symmetric (h(−x, y) = h(x, −y) = h(x, y)), and mirroring
//! the grid maps the shift s to 1 − s: every quantity is even about s = 0 and s = ½ in each
//! component, and the fundamental domain is [0, ½]². [`shift_set`] samples it with the m × m
//! midpoint rule `((i + ½)/(2m), (j + ½)/(2m))`, which by the mirror images is the 2m × 2m
//! half-offset trapezoid rule on the unit square: exact for every Fourier component of the shift
//! dependence below frequency 2m in each direction. `m = 0` is the unshifted grid alone (saddles
//! on nodes).

use crate::{
    Criterion, CriticalError, CriticalOptions, CriticalResult, find_critical, warm::warm_start_from,
};
use contact::Solution;
use rayon::prelude::*;
use surface::{Grid, Lattice, Surface};

/// The shifts (in grid spacings, each in [0, ½)) of the m × m midpoint rule (module docs); `m = 0`
/// gives the unshifted grid `[(0, 0)]`. Ordered x-major.
pub fn shift_set(m: usize) -> Vec<(f64, f64)> {
    if m == 0 {
        return vec![(0.0, 0.0)];
    }
    let at = |i: usize| (i as f64 + 0.5) / (2 * m) as f64;
    (0..m)
        .flat_map(|i| (0..m).map(move |j| (at(i), at(j))))
        .collect()
}

/// Mean, standard deviation and standard error of a set of values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stat {
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (0 for one value).
    pub std: f64,
    /// `std / sqrt(count)`: the scale of the averaging noise.
    pub sem: f64,
    /// Number of values.
    pub count: usize,
}

impl Stat {
    /// Statistics of `v` (NaN mean for an empty slice).
    pub fn of(v: &[f64]) -> Self {
        let n = v.len();
        let mean = v.iter().sum::<f64>() / n as f64;
        let std = if n > 1 {
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        Stat {
            mean,
            std,
            sem: std / (n as f64).sqrt(),
            count: n,
        }
    }
}

/// Shift averages of one transition.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransitionAverage {
    /// L_c (E* h0/λ).
    pub l_c: Stat,
    /// Raw a_p.
    pub a_p_raw: Stat,
    /// Perimeter-corrected a_p.
    pub a_p_corrected: Stat,
}

/// Shift averages on one grid exponent.
#[derive(Clone, Debug, PartialEq)]
pub struct ShiftAverage {
    /// The `any` transition (the paper's L_c).
    pub any: TransitionAverage,
    /// Flow along x blocked.
    pub x: TransitionAverage,
    /// Flow along y blocked.
    pub y: TransitionAverage,
    /// Sub-grid L_c over the shifts that gave one (E* h0/λ).
    pub l_c_subgrid: Option<Stat>,
    /// Sub-grid ζ over the shifts that gave one.
    pub zeta: Option<Stat>,
    /// p_fc of the sampled surfaces (E* h0/λ; shift-dependent only where the trough falls
    /// between nodes).
    pub p_fc: Stat,
    /// p_fc / L_c per shift.
    pub p_fc_over_l_c: Stat,
}

impl ShiftAverage {
    /// The average of a criterion.
    pub fn transition(&self, c: Criterion) -> &TransitionAverage {
        match c {
            Criterion::Any => &self.any,
            Criterion::X => &self.x,
            Criterion::Y => &self.y,
        }
    }

    /// Averages over results on shifted grids.
    pub fn of(results: &[CriticalResult]) -> Self {
        let tr = |c: Criterion| {
            let f = |g: &dyn Fn(&CriticalResult) -> f64| {
                Stat::of(&results.iter().map(g).collect::<Vec<_>>())
            };
            TransitionAverage {
                l_c: f(&|r| r.transition(c).l_c()),
                a_p_raw: f(&|r| r.transition(c).a_p_raw()),
                a_p_corrected: f(&|r| r.transition(c).a_p_corrected()),
            }
        };
        let sub: Vec<f64> = results
            .iter()
            .filter_map(|r| r.subgrid.as_ref().map(|s| s.l_c))
            .collect();
        let zeta: Vec<f64> = results
            .iter()
            .filter_map(|r| r.subgrid.as_ref().map(|s| s.zeta))
            .collect();
        ShiftAverage {
            any: tr(Criterion::Any),
            x: tr(Criterion::X),
            y: tr(Criterion::Y),
            l_c_subgrid: (!sub.is_empty()).then(|| Stat::of(&sub)),
            zeta: (!zeta.is_empty()).then(|| Stat::of(&zeta)),
            p_fc: Stat::of(&results.iter().map(|r| r.p_fc).collect::<Vec<_>>()),
            p_fc_over_l_c: Stat::of(
                &results
                    .iter()
                    .map(|r| r.p_fc_over_l_c())
                    .collect::<Vec<_>>(),
            ),
        }
    }
}

/// Results on every shift of a set, and their averages.
#[derive(Clone, Debug)]
pub struct ShiftStudy {
    /// Model.
    pub lattice: Lattice,
    /// Grid exponent.
    pub n: u32,
    /// One result per shift, in the order of the shifts.
    pub results: Vec<CriticalResult>,
    /// Averages over the shifts.
    pub average: ShiftAverage,
    /// Wall time of the whole set (s).
    pub wall_s: f64,
}

/// Runs [`find_critical`] on the 2^n grid at every shift (in parallel on the current rayon
/// pool). `warm[i]`, if given, warm-starts shift i (any grid of the same cell); `guesses[i]`
/// overrides `opts.guess` for shift i. The saddle gaps (`opts.saddle_loads`) are sampled on the
/// first shift only unless `sample_all`: the sub-grid estimate barely depends on the shift, and
/// each sample costs a full solve.
pub fn find_critical_shifted(
    lattice: Lattice,
    n: u32,
    shifts: &[(f64, f64)],
    opts: &CriticalOptions,
    warm: Option<&[Solution]>,
    guesses: Option<&[f64]>,
    sample_all: bool,
) -> Result<ShiftStudy, CriticalError> {
    if shifts.is_empty() {
        return Err(CriticalError::param("shifts", 0.0, "at least one shift"));
    }
    let t0 = std::time::Instant::now();
    let base = Grid::new(lattice, n).map_err(|e| CriticalError::Surface(e.to_string()))?;
    let results: Result<Vec<CriticalResult>, CriticalError> = shifts
        .par_iter()
        .enumerate()
        .map(|(i, &(sx, sy))| {
            let grid = base
                .shifted(sx, sy)
                .map_err(|e| CriticalError::Surface(e.to_string()))?;
            let s = Surface::on_grid(lattice, grid);
            let mut o = opts.clone();
            if i > 0 && !sample_all {
                o.saddle_loads.clear();
            }
            if let Some(g) = guesses.and_then(|g| g.get(i)) {
                o.guess = Some(*g);
            }
            let w = warm
                .and_then(|w| w.get(i))
                .map(|w| warm_start_from(w, &grid));
            find_critical(&s, &o, w.as_ref())
        })
        .collect();
    let results = results?;
    Ok(ShiftStudy {
        lattice,
        n,
        average: ShiftAverage::of(&results),
        results,
        wall_s: t0.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shift_sets_cover_the_fundamental_domain() {
        assert_eq!(shift_set(0), vec![(0.0, 0.0)]);
        assert_eq!(shift_set(1), vec![(0.25, 0.25)]);
        let s = shift_set(2);
        assert_eq!(
            s,
            vec![
                (0.125, 0.125),
                (0.125, 0.375),
                (0.375, 0.125),
                (0.375, 0.375)
            ]
        );
        for m in 1..6 {
            let s = shift_set(m);
            assert_eq!(s.len(), m * m);
            assert!(
                s.iter()
                    .all(|&(x, y)| (0.0..0.5).contains(&x) && (0.0..0.5).contains(&y))
            );
            // the mean of cos(2π k s) over the mirrored set vanishes for 0 < k < 2m
            for k in 1..2 * m {
                let mean: f64 = s
                    .iter()
                    .map(|&(x, _)| (2.0 * std::f64::consts::PI * k as f64 * x).cos())
                    .sum::<f64>()
                    / s.len() as f64;
                assert!(mean.abs() < 1e-12, "m = {m}, k = {k}: {mean}");
            }
        }
    }

    #[test]
    fn stats() {
        let s = Stat::of(&[1.0, 2.0, 3.0]);
        assert_eq!((s.mean, s.std, s.count), (2.0, 1.0, 3));
        assert!((s.sem - 1.0 / 3f64.sqrt()).abs() < 1e-15);
        assert_eq!(Stat::of(&[4.0]).std, 0.0);
    }
}
