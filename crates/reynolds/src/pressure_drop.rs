//! The fraction of the total pressure drop taken by a small window around a point of the cell
//! (the last constriction, paper's conclusion: near sealing most of the fluid pressure drops at a
//! single critical constriction).
//!
//! # Definition
//! The flow solution ([`crate::solve`]) carries the unit mean drop `ΔP = 1` per period along the
//! flow axis; its pressure is `p = −s ΔP / L + φ` with `s` the coordinate along the flow and `φ`
//! periodic ([`crate::FlowFields::pressure`]). A [`Window`] centred on node `(c_s, c_t)` (`s` along
//! the flow, `t` across) spans the `2w + 1` nodes `c_s − w ..= c_s + w` along the flow and the
//! `2W + 1` nodes `c_t − W ..= c_t + W` across. Its upstream face lies half-way between the node
//! columns `c_s − w − 1` and `c_s − w`, its downstream face half-way between `c_s + w` and
//! `c_s + w + 1`; the pressure on a face is the mean, over the window's cross-positions where
//! both nodes are flowing, of the two nodes' pressures (the finite-volume face value, exact for a
//! linear pressure). Then
//!
//! `fraction = (p_upstream − p_downstream) / ΔP`,
//!
//! with the pressure continued across the cell boundary (`p(s + L) = p(s) − ΔP`), so the window
//! may straddle it. A uniform channel gives the window's length fraction `(2w + 1) / n_s`; a
//! closing constriction inside the window drives it to 1 (every other face's share of the
//! resistance vanishes against the constriction's).
//!
//! # Approximation
//! The face mean is unweighted across the window: it is the face's pressure only where the
//! pressure is uniform across the window, which holds in the ponds on either side of a closing
//! constriction; in an open channel it is the mean over the chosen cross-section. Cost:
//! `O(w + W)` reads, after the solve.

use crate::{FlowAxis, FlowError, FlowOptions, FlowResult, solve};
use ndarray::ArrayView2;
use std::fmt;

/// A window around a node; see the module docs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    /// Centre node `(i, j)` (first index x).
    pub centre: (usize, usize),
    /// `w`: nodes on each side of the centre along the flow.
    pub half_length: usize,
    /// `W`: nodes on each side of the centre across the flow.
    pub half_width: usize,
}

/// The pressure drop across a window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PressureDrop {
    /// `(p_upstream − p_downstream) / ΔP`.
    pub fraction: f64,
    /// Pressure on the upstream face (continued across the boundary; `ΔP = 1` per period).
    pub upstream: f64,
    /// Pressure on the downstream face.
    pub downstream: f64,
    /// The window's length fraction `(2w + 1) / n_s`: what a uniform channel gives.
    pub length_fraction: f64,
    /// Cross-positions averaged on the upstream face (both nodes flowing).
    pub upstream_samples: usize,
    /// Cross-positions averaged on the downstream face.
    pub downstream_samples: usize,
}

/// Invalid input to [`pressure_drop_fraction`].
#[derive(Clone, Debug, PartialEq)]
pub enum PressureDropError {
    /// The window's centre lies outside the grid.
    Centre {
        /// The centre.
        centre: (usize, usize),
        /// Grid shape.
        shape: (usize, usize),
    },
    /// `2 half_length + 2` must not exceed the nodes along the flow, `2 half_width + 1` the
    /// nodes across.
    Size {
        /// The window.
        half_length: usize,
        /// The window.
        half_width: usize,
        /// Nodes along the flow.
        along: usize,
        /// Nodes across.
        across: usize,
    },
    /// No flowing node pair on a face of the window (the window is not on the flowing fluid).
    NoFlow {
        /// `"upstream"` or `"downstream"`.
        face: &'static str,
    },
    /// The flow solve failed or was not requested with fields.
    Flow(FlowError),
}

impl fmt::Display for PressureDropError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PressureDropError::Centre { centre, shape } => write!(
                f,
                "window centre {centre:?} outside the grid of shape {shape:?}"
            ),
            PressureDropError::Size {
                half_length,
                half_width,
                along,
                across,
            } => write!(
                f,
                "window half_length {half_length}, half_width {half_width}: need \
                 2 half_length + 2 <= {along} (nodes along the flow) and \
                 2 half_width + 1 <= {across} (nodes across)"
            ),
            PressureDropError::NoFlow { face } => {
                write!(f, "no flowing node pair on the window's {face} face")
            }
            PressureDropError::Flow(e) => write!(f, "flow solve: {e}"),
        }
    }
}

impl std::error::Error for PressureDropError {}

/// The fraction of the pressure drop across `window` in the pressure field `pressure` of a flow
/// solution along `axis` (unit drop per period, NaN off the flowing fluid).
pub fn pressure_drop_fraction(
    pressure: ArrayView2<f64>,
    axis: FlowAxis,
    window: &Window,
) -> Result<PressureDrop, PressureDropError> {
    let shape = pressure.dim();
    let (ci, cj) = window.centre;
    if ci >= shape.0 || cj >= shape.1 {
        return Err(PressureDropError::Centre {
            centre: window.centre,
            shape,
        });
    }
    // Work in (along, across) coordinates.
    let (p, (cs, ct)) = match axis {
        FlowAxis::X => (pressure, (ci, cj)),
        FlowAxis::Y => (pressure.reversed_axes(), (cj, ci)),
    };
    let (ns, nt) = p.dim();
    let (w, ww) = (window.half_length, window.half_width);
    if 2 * w + 2 > ns || 2 * ww + 1 > nt {
        return Err(PressureDropError::Size {
            half_length: w,
            half_width: ww,
            along: ns,
            across: nt,
        });
    }
    // Pressure at the unwrapped column `s`, cross-position `t` (ΔP = 1 per period).
    let at = |s: isize, t: isize| {
        let (n, m) = (ns as isize, nt as isize);
        p[[s.rem_euclid(n) as usize, t.rem_euclid(m) as usize]] - s.div_euclid(n) as f64
    };
    // Mean face pressure between columns `s` and `s + 1`.
    let face = |s: isize, name: &'static str| {
        let (mut sum, mut count) = (0.0, 0usize);
        for t in ct as isize - ww as isize..=ct as isize + ww as isize {
            let (a, b) = (at(s, t), at(s + 1, t));
            if a.is_finite() && b.is_finite() {
                sum += 0.5 * (a + b);
                count += 1;
            }
        }
        if count == 0 {
            Err(PressureDropError::NoFlow { face: name })
        } else {
            Ok((sum / count as f64, count))
        }
    };
    let (cs, w) = (cs as isize, w as isize);
    let (upstream, upstream_samples) = face(cs - w - 1, "upstream")?;
    let (downstream, downstream_samples) = face(cs + w, "downstream")?;
    Ok(PressureDrop {
        fraction: upstream - downstream,
        upstream,
        downstream,
        length_fraction: (2 * w + 1) as f64 / ns as f64,
        upstream_samples,
        downstream_samples,
    })
}

/// Solves the flow ([`crate::solve`], with fields) and returns it with the pressure-drop fraction
/// across `window`.
pub fn solve_with_pressure_drop(
    gap: ArrayView2<f64>,
    lx: f64,
    ly: f64,
    axis: FlowAxis,
    options: &FlowOptions,
    window: &Window,
) -> Result<(FlowResult, PressureDrop), PressureDropError> {
    let options = FlowOptions {
        return_fields: true,
        ..options.clone()
    };
    let flow = solve(gap, lx, ly, axis, &options).map_err(PressureDropError::Flow)?;
    let pressure = &flow
        .fields
        .as_ref()
        .expect("fields were requested")
        .pressure;
    let drop = pressure_drop_fraction(pressure.view(), axis, window)?;
    Ok((flow, drop))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    fn window(centre: (usize, usize), half_length: usize, half_width: usize) -> Window {
        Window {
            centre,
            half_length,
            half_width,
        }
    }

    fn run(gap: &Array2<f64>, axis: FlowAxis, win: &Window) -> PressureDrop {
        let (flow, drop) =
            solve_with_pressure_drop(gap.view(), 1.0, 1.0, axis, &FlowOptions::default(), win)
                .unwrap();
        assert!(flow.converged);
        drop
    }

    /// A uniform gap has a linear pressure: the window takes its length fraction, also when it
    /// straddles the cell boundary and for flow along y. The solver's relative residual 1e-10
    /// bounds the pressure error far below the 1e-9 tolerance.
    #[test]
    fn uniform_channel_gives_the_length_fraction() {
        let gap = Array2::from_elem((16, 12), 0.7);
        for (axis, win) in [
            (FlowAxis::X, window((8, 5), 1, 2)),
            (FlowAxis::X, window((0, 11), 3, 0)),
            (FlowAxis::Y, window((3, 1), 2, 4)),
        ] {
            let d = run(&gap, axis, &win);
            let n = if axis == FlowAxis::X { 16.0 } else { 12.0 };
            let exact = (2 * win.half_length + 1) as f64 / n;
            assert_eq!(d.length_fraction, exact);
            assert!(
                (d.fraction - exact).abs() < 1e-9,
                "{axis:?}: {}",
                d.fraction
            );
        }
    }

    /// A gap varying only along the flow is a chain of resistors `r = 1/H(g³_s, g³_{s+1})` (H the
    /// harmonic mean): the face pressures follow in closed form, half of each boundary face's drop
    /// plus the drops of the faces inside the window.
    #[test]
    fn one_dimensional_chain_matches_series_resistance() {
        let ns = 16;
        let g: Vec<f64> = (0..ns)
            .map(|s| 0.3 + 0.05 * ((s * 7) % 11) as f64)
            .collect();
        let gap = Array2::from_shape_fn((ns, 8), |(s, _)| g[s]);
        let h = |a: f64, b: f64| 2.0 * a * b / (a + b);
        // r[s]: resistance of the face between s and s + 1 (periodic).
        let r: Vec<f64> = (0..ns)
            .map(|s| 1.0 / h(g[s].powi(3), g[(s + 1) % ns].powi(3)))
            .collect();
        let total: f64 = r.iter().sum();
        for (c, w) in [(5usize, 1usize), (0, 2), (13, 3)] {
            let face = |s: isize| r[s.rem_euclid(ns as isize) as usize];
            let (c, wi) = (c as isize, w as isize);
            let inside: f64 = (c - wi..c + wi).map(face).sum();
            let exact = (0.5 * face(c - wi - 1) + inside + 0.5 * face(c + wi)) / total;
            let d = run(&gap, FlowAxis::X, &window((c as usize, 3), w, 1));
            assert!(
                (d.fraction - exact).abs() < 1e-9,
                "{c}, {w}: {} vs {exact}",
                d.fraction
            );
        }
    }

    /// A channel three nodes wide along x whose column 8 is closed except for one node of gap ε:
    /// a 2-D flow through a throat. The share of the drop outside the window, `1 − fraction`,
    /// is the rest of the channel's resistance over the total, ∝ ε³ as the throat closes.
    #[test]
    fn closing_constriction_takes_the_whole_drop() {
        let mut last = 0.0;
        for eps in [0.3, 0.1, 0.03, 0.01] {
            let gap = Array2::from_shape_fn((16, 16), |(i, j)| match (i, j) {
                (8, 4) => eps,
                (8, _) => 0.0,
                (_, 3..=5) => 1.0,
                _ => 0.0,
            });
            // The window is centred on the last constriction as the percolation crate finds it.
            let c = percolation::last_constriction(gap.view(), 1.0, 1.0, percolation::Axis::X, 0.0)
                .unwrap()
                .unwrap();
            assert_eq!((c.completing.i, c.completing.j, c.gap), (8, 4, eps));
            let d = run(&gap, FlowAxis::X, &window((8, 4), 1, 1));
            let rest = 1.0 - d.fraction;
            assert!(d.fraction > last && rest > 0.0, "eps {eps}: {}", d.fraction);
            // The throat's two faces have resistance ≈ 1/(2ε³) each, 1/ε³ together; the rest
            // of the three-wide channel outside the window, with the spreading into the throat,
            // adds a constant (measured: (1 − fraction)/ε³ = 3.73, 4.31, 4.333, 4.3333 for
            // ε = 0.3 … 0.01, tending to 13/3). So (1 − fraction)/ε³ stays in (3, 5).
            let scaled = rest / eps.powi(3);
            assert!(
                scaled > 3.0 && scaled < 5.0,
                "eps {eps}: (1 - fraction)/eps^3 = {scaled}"
            );
            last = d.fraction;
        }
        assert!(1.0 - last < 2e-5);
    }

    #[test]
    fn bad_windows_are_named() {
        let p = Array2::from_elem((8, 6), 0.0);
        let e = pressure_drop_fraction(p.view(), FlowAxis::X, &window((8, 0), 1, 1)).unwrap_err();
        assert!(e.to_string().contains("(8, 0)"));
        let e = pressure_drop_fraction(p.view(), FlowAxis::Y, &window((0, 0), 3, 1)).unwrap_err();
        assert!(e.to_string().contains("half_length 3") && e.to_string().contains("<= 6"));
        let nan = Array2::from_elem((8, 6), f64::NAN);
        let e = pressure_drop_fraction(nan.view(), FlowAxis::X, &window((4, 3), 1, 1)).unwrap_err();
        assert!(e.to_string().contains("upstream"));
    }
}
