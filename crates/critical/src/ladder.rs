//! The load ladder: hard-wall solves at reduced loads l = (L − L_c)/L_c around the critical load,
//! warm-started, keeping only a window of the fields around one saddle point (the near-critical
//! scaling study of Dapp & Müser 2015; PHYSICS.md, "Percolation, critical load, near-critical
//! scaling").
//!
//! # The saddle and its frame
//! The fits and figures look at one saddle whose channel axis (the direction along which the
//! height decreases, h''∥ < 0) lies along a grid axis and which sits on a node of the unshifted
//! grid ([`axis_saddle`]): square (0, ½) (channel along x), hexagonal (λ/√3, 0) (along x),
//! triangular (λ/√3, 0) (along y). The window is stored in the saddle's frame: first index
//! along the channel (r∥), second across it (r⊥), the saddle at the centre. Every such saddle is
//! a point of inversion symmetry with mirror lines along both axes, so on the unshifted grid the
//! window is mirror-symmetric and the fits use one half ([`crate::scaling`]).
//!
//! # Warm starts
//! The rungs are solved in ascending load, each from the previous one's pressure; with a coarser
//! level's solutions at the same reduced loads (coarse to fine), from those prolonged instead
//! ([`crate::warm`]). A solve that does not converge is repeated from the previous rung and then
//! cold; the rung records whether it was.

use crate::CriticalError;
use crate::warm;
use contact::{Interaction, Method, Model, Solution, SolverOptions};
use ndarray::{Array2, ArrayView2};
use std::time::Instant;
use surface::{CriticalKind, Surface};

/// The saddle the ladder looks at and its local frame.
#[derive(Clone, Debug, PartialEq)]
pub struct SaddleFrame {
    /// Position (λ).
    pub x: f64,
    /// Position (λ).
    pub y: f64,
    /// Node indices of the saddle.
    pub node: (usize, usize),
    /// Grid axis of the channel: 0 = x, 1 = y.
    pub channel_axis: usize,
    /// Curvature ratio η = −h''∥/h''⊥.
    pub eta: f64,
    /// Saddle height (h0).
    pub height: f64,
}

/// The saddle of `surface` whose channel lies along a grid axis and which sits on a node (the
/// grid must be unshifted). Errors if there is none (a shifted grid).
pub fn axis_saddle(surface: &Surface) -> Result<SaddleFrame, CriticalError> {
    let g = &surface.grid;
    let on_node = |v: f64, d: f64, s: f64| {
        let t = v / d - s;
        ((t - t.round()).abs() < 1e-9).then_some(t.round() as isize)
    };
    for p in surface.critical_points() {
        if p.kind != CriticalKind::Saddle {
            continue;
        }
        let axis = if p.axis[0].abs() > 1.0 - 1e-9 {
            0
        } else if p.axis[1].abs() > 1.0 - 1e-9 {
            1
        } else {
            continue;
        };
        if let (Some(i), Some(j)) = (
            on_node(p.x, g.dx(), g.shift.0),
            on_node(p.y, g.dy(), g.shift.1),
        ) {
            return Ok(SaddleFrame {
                x: p.x,
                y: p.y,
                node: (
                    i.rem_euclid(g.nx as isize) as usize,
                    j.rem_euclid(g.ny as isize) as usize,
                ),
                channel_axis: axis,
                eta: p.eta().unwrap_or(f64::NAN),
                height: p.height,
            });
        }
    }
    Err(CriticalError::Surface(format!(
        "{}: no saddle with its channel along a grid axis on a node of this grid (shift {:?}); \
         the ladder needs the unshifted grid",
        surface.lattice.name(),
        g.shift
    )))
}

/// A window of the fields around the saddle, in its frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Window {
    /// Node spacing along the channel (λ).
    pub d_par: f64,
    /// Node spacing across the channel (λ).
    pub d_perp: f64,
    /// Gap (h0), shape (2 k_par + 1, 2 k_perp + 1), saddle at (k_par, k_perp).
    pub gap: Array2<f64>,
    /// Contact pressure (E* h0/λ), same shape.
    pub pressure: Array2<f64>,
}

impl Window {
    /// Half-size in nodes along the channel.
    pub fn k_par(&self) -> usize {
        self.gap.nrows() / 2
    }
    /// Half-size in nodes across the channel.
    pub fn k_perp(&self) -> usize {
        self.gap.ncols() / 2
    }
    /// r∥ of row `a` (λ).
    pub fn r_par(&self, a: usize) -> f64 {
        (a as f64 - self.k_par() as f64) * self.d_par
    }
    /// r⊥ of column `b` (λ).
    pub fn r_perp(&self, b: usize) -> f64 {
        (b as f64 - self.k_perp() as f64) * self.d_perp
    }
    /// Gap at the saddle node (h0).
    pub fn saddle_gap(&self) -> f64 {
        self.gap[[self.k_par(), self.k_perp()]]
    }
}

/// Cuts the window of half-size `half` (λ, in both directions, at least 2 nodes) around the
/// saddle out of a pair of nodal fields (periodic).
pub fn extract_window(
    frame: &SaddleFrame,
    grid: &surface::Grid,
    gap: ArrayView2<f64>,
    pressure: ArrayView2<f64>,
    half: f64,
) -> Window {
    let (d_par, d_perp) = if frame.channel_axis == 0 {
        (grid.dx(), grid.dy())
    } else {
        (grid.dy(), grid.dx())
    };
    let kmax = |n: usize| (n / 2).saturating_sub(1).max(1);
    let (n_par, n_perp) = if frame.channel_axis == 0 {
        (grid.nx, grid.ny)
    } else {
        (grid.ny, grid.nx)
    };
    let k_par = ((half / d_par).ceil() as usize).clamp(2, kmax(n_par));
    let k_perp = ((half / d_perp).ceil() as usize).clamp(2, kmax(n_perp));
    let (i0, j0) = (frame.node.0 as isize, frame.node.1 as isize);
    let (nx, ny) = (grid.nx as isize, grid.ny as isize);
    let at = |f: ArrayView2<f64>, a: usize, b: usize| {
        let (da, db) = (a as isize - k_par as isize, b as isize - k_perp as isize);
        let (di, dj) = if frame.channel_axis == 0 {
            (da, db)
        } else {
            (db, da)
        };
        f[[
            (i0 + di).rem_euclid(nx) as usize,
            (j0 + dj).rem_euclid(ny) as usize,
        ]]
    };
    let shape = (2 * k_par + 1, 2 * k_perp + 1);
    Window {
        d_par,
        d_perp,
        gap: Array2::from_shape_fn(shape, |(a, b)| at(gap, a, b)),
        pressure: Array2::from_shape_fn(shape, |(a, b)| at(pressure, a, b)),
    }
}

/// Options of [`solve_ladder`].
#[derive(Clone, Debug, PartialEq)]
pub struct LadderOptions {
    /// Polonsky–Keer tolerance on the constraint violation (h0).
    pub tol_gap: f64,
    /// Iteration cap per solve.
    pub max_iter: usize,
    /// Half-size of the stored window around the saddle (λ).
    pub window: f64,
}

impl Default for LadderOptions {
    fn default() -> Self {
        LadderOptions {
            tol_gap: 1e-10,
            max_iter: 200_000,
            window: 0.15,
        }
    }
}

/// One rung of the ladder.
#[derive(Clone, Debug, PartialEq)]
pub struct Rung {
    /// Reduced load (L − L_c)/L_c.
    pub l: f64,
    /// Load (mean pressure, E* h0/λ).
    pub load: f64,
    /// Contact area fraction.
    pub contact_area: f64,
    /// The window around the saddle.
    pub window: Window,
    /// Polonsky–Keer iterations (all attempts).
    pub iterations: usize,
    /// The final solve converged.
    pub converged: bool,
    /// The first solve did not converge and was repeated from another start.
    pub retried: bool,
    /// Wall time (s).
    pub wall_s: f64,
}

/// Solves the hard-wall contact of `surface` at loads `L_c (1 + l)` for every `l` of `ls` (any
/// order; solved ascending), warm-starting as the module docs say. `coarse`, if given, holds
/// solutions on a coarser grid of the same cell at the same reduced loads in ascending order.
/// `on_rung` sees each rung with its full solution (to keep it, e.g. as the next level's warm
/// start, or to compute the flow); the rungs are returned in ascending l.
pub fn solve_ladder(
    surface: &Surface,
    frame: &SaddleFrame,
    l_c: f64,
    ls: &[f64],
    opts: &LadderOptions,
    coarse: Option<&[Solution]>,
    on_rung: &mut dyn FnMut(&Rung, &Solution),
) -> Result<Vec<Rung>, CriticalError> {
    if !(l_c.is_finite() && l_c > 0.0) {
        return Err(CriticalError::param("l_c", l_c, "finite and > 0 (E* h0/λ)"));
    }
    if let Some(&l) = ls.iter().find(|l| !(l.is_finite() && **l > -1.0)) {
        return Err(CriticalError::param("ls", l, "reduced loads above −1"));
    }
    let mut ls = ls.to_vec();
    ls.sort_by(f64::total_cmp);
    if let Some(c) = coarse
        && c.len() != ls.len()
    {
        return Err(CriticalError::param(
            "coarse",
            c.len() as f64,
            "one coarse solution per reduced load",
        ));
    }
    let mut model = Model::new(surface).map_err(|e| CriticalError::Solver {
        load: f64::NAN,
        detail: e.to_string(),
    })?;
    let sopts = SolverOptions {
        tol_gap: opts.tol_gap,
        max_iter: opts.max_iter,
        method: Method::PolonskyKeer,
        ..Default::default()
    };
    let mut prev: Option<Solution> = None;
    let mut rungs = Vec::with_capacity(ls.len());
    for (k, &l) in ls.iter().enumerate() {
        let t0 = Instant::now();
        let load = l_c * (1.0 + l);
        let first = coarse.map(|c| warm::warm_start_from(&c[k], &surface.grid));
        let starts: [Option<&Solution>; 3] =
            [first.as_ref().or(prev.as_ref()), prev.as_ref(), None];
        let mut iterations = 0;
        let mut attempts = 0;
        let mut sol = None;
        for (a, start) in starts.iter().enumerate() {
            if a == 1 && (first.is_none() || prev.is_none()) {
                continue; // the same start as attempt 0
            }
            let s = model
                .solve(Interaction::HardWall, load, &sopts, *start)
                .map_err(|e| CriticalError::Solver {
                    load,
                    detail: e.to_string(),
                })?;
            iterations += s.stats.iterations;
            attempts += 1;
            let done = s.stats.converged;
            sol = Some(s);
            if done {
                break;
            }
        }
        let sol = sol.expect("at least one attempt");
        let rung = Rung {
            l,
            load,
            contact_area: sol.contact_area,
            window: extract_window(
                frame,
                &surface.grid,
                sol.gap.view(),
                sol.pressure.view(),
                opts.window,
            ),
            iterations,
            converged: sol.stats.converged,
            retried: attempts > 1,
            wall_s: t0.elapsed().as_secs_f64(),
        };
        on_rung(&rung, &sol);
        rungs.push(rung);
        prev = Some(sol);
    }
    Ok(rungs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use surface::Lattice;

    #[test]
    fn axis_saddles_lie_on_nodes_with_channels_along_grid_axes() {
        for (lat, axis, eta) in [
            (Lattice::Square, 0, 1.0),
            (Lattice::Hexagonal, 0, 3.0),
            (Lattice::Triangular, 1, 1.0 / 3.0),
        ] {
            let s = Surface::new(lat, 5).unwrap();
            let f = axis_saddle(&s).unwrap();
            assert_eq!(f.channel_axis, axis, "{lat}");
            assert!((f.eta - eta).abs() < 1e-9, "{lat}: η = {}", f.eta);
            let (x, y) = s.grid.position(f.node.0, f.node.1);
            assert!((x - f.x).abs() < 1e-12 && (y - f.y).abs() < 1e-12);
            // the height at the node is the saddle height, and it is a saddle of the samples:
            // lower along the channel, higher across
            let h = &s.heights;
            let (i, j) = f.node;
            let n = h.nrows();
            let (ip, jp) = ((i + 1) % n, (j + 1) % n);
            assert!((h[[i, j]] - f.height).abs() < 1e-12);
            let (along, across) = if axis == 0 {
                (h[[ip, j]], h[[i, jp]])
            } else {
                (h[[i, jp]], h[[ip, j]])
            };
            assert!(along < h[[i, j]] && across > h[[i, j]], "{lat}");
        }
        let shifted = Surface::on_grid(
            Lattice::Square,
            surface::Grid::new(Lattice::Square, 4)
                .unwrap()
                .shifted(0.3, 0.3)
                .unwrap(),
        );
        assert!(axis_saddle(&shifted).is_err());
    }

    #[test]
    fn window_is_in_the_saddle_frame() {
        let s = Surface::new(Lattice::Square, 5).unwrap();
        let f = axis_saddle(&s).unwrap();
        // a field that records its node: 1000 i + j
        let field = Array2::from_shape_fn((32, 32), |(i, j)| (1000 * i + j) as f64);
        let w = extract_window(&f, &s.grid, field.view(), field.view(), 0.1);
        assert_eq!((w.k_par(), w.k_perp()), (4, 4));
        let (i, j) = f.node;
        assert_eq!(w.gap[[4, 4]], (1000 * i + j) as f64);
        // the saddle (0, ½) has its channel along x: the first window index runs along x
        // (wrapping at i = 0)
        assert_eq!((i, j), (0, 16));
        assert_eq!(w.gap[[5, 4]], (1000 + j) as f64);
        assert_eq!(w.gap[[3, 4]], (1000 * 31 + j) as f64);
        assert_eq!(w.gap[[4, 6]], (j + 2) as f64);
        assert!((w.r_par(0) + 4.0 / 32.0).abs() < 1e-15);
    }

    #[test]
    fn rungs_are_at_the_loads_they_claim() {
        let s = Surface::new(Lattice::Square, 5).unwrap();
        let f = axis_saddle(&s).unwrap();
        let l_c = 1.4;
        let ls = [0.02, -0.01, -0.02, 0.01];
        let mut seen = Vec::new();
        let rungs = solve_ladder(
            &s,
            &f,
            l_c,
            &ls,
            &LadderOptions::default(),
            None,
            &mut |r, sol| seen.push((r.l, sol.pressure.mean().unwrap())),
        )
        .unwrap();
        let got: Vec<f64> = rungs.iter().map(|r| r.l).collect();
        assert_eq!(got, vec![-0.02, -0.01, 0.01, 0.02]);
        for (r, (l, p)) in rungs.iter().zip(&seen) {
            assert_eq!(r.l, *l);
            assert!(r.converged);
            // the mean of the contact pressure field is the load: (L − L_c)/L_c is the claimed l
            assert!(((p - l_c) / l_c - r.l).abs() < 1e-9, "{p}");
            assert!(((r.load - l_c) / l_c - r.l).abs() < 1e-12);
        }
        // more load, more contact
        assert!(
            rungs
                .windows(2)
                .all(|w| w[1].contact_area >= w[0].contact_area)
        );
        assert!(
            solve_ladder(
                &s,
                &f,
                l_c,
                &[-1.5],
                &LadderOptions::default(),
                None,
                &mut |_, _| {}
            )
            .is_err()
        );
    }
}
