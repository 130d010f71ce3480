//! Which saddles to refine: the critical saddles of a model's cell, through which the flow
//! passes near percolation (see the parent module's docs, "Several windows").
//!
//! Near the percolation load the fluid is connected from trough to trough only through the
//! saddles of the lowest pass: a path of the fluid between two troughs must climb over at least
//! one saddle, and the lowest path over the cell climbs to the minimax saddle height. For the
//! single-wavelength models every saddle of the profile has the same height (square: 2 h0,
//! triangular: √(2/3)/2 h0, hexagonal: √(27/2) − √(2/3)/2 h0), so every saddle of the cell
//! carries flow: two per cell for the square model (channels along x and along y), twelve for
//! the triangular and hexagonal cells 4λ/√3 × 2λ (four per channel orientation; channels at 30°,
//! 90°, 150° for the triangular and 0°, 60°, 120° for the hexagonal model, i.e. at 0° and ±60°
//! to one grid axis). The function returns the saddles at the lowest saddle height of the
//! profile (all of them here); a profile with saddles of several heights (none so far) would need
//! the minimax pass of the trough network instead, and is refused rather than guessed.

use surface::{CriticalKind, Grid, Surface};

use super::Window;

/// A saddle that carries flow.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowSaddle {
    /// Position (λ).
    pub x: f64,
    /// Position (λ).
    pub y: f64,
    /// The base-grid node at the saddle, if it lies on one (the unshifted 2^n grids: always).
    pub node: Option<(usize, usize)>,
    /// Angle of the channel axis (the direction along which the height falls) in [0°, 180°).
    pub angle_deg: f64,
    /// Height (h0).
    pub height: f64,
    /// Curvature ratio η = −h''∥/h''⊥.
    pub eta: f64,
}

impl FlowSaddle {
    /// The channel's grid axis (0 = x, 1 = y) if it lies along one (to 1e-6 rad).
    pub fn channel_axis(&self) -> Option<usize> {
        let a = self.angle_deg;
        if a.abs() < 1e-6 || (a - 180.0).abs() < 1e-6 {
            Some(0)
        } else if (a - 90.0).abs() < 1e-6 {
            Some(1)
        } else {
            None
        }
    }

    /// The window of `wx × wy` base cells centred on the saddle.
    pub fn window(&self, grid: &Grid, wx: usize, wy: usize) -> Window {
        Window::centred(grid, self.x, self.y, wx, wy)
    }
}

/// The saddles of `surface`'s cell that carry the flow (module docs), sorted by channel angle
/// and then by position (x, then y). Errors if the profile's saddles are not all of one height
/// (to 1e-9 h0), or if it has none.
pub fn flow_saddles(surface: &Surface) -> Result<Vec<FlowSaddle>, String> {
    let g = &surface.grid;
    let on_node = |v: f64, d: f64, s: f64, n: usize| {
        let t = v / d - s;
        ((t - t.round()).abs() < 1e-9).then(|| (t.round() as isize).rem_euclid(n as isize) as usize)
    };
    let mut out: Vec<FlowSaddle> = surface
        .critical_points()
        .into_iter()
        .filter(|p| p.kind == CriticalKind::Saddle)
        .map(|p| {
            let mut a = p.axis[1].atan2(p.axis[0]).to_degrees();
            if a < 0.0 {
                a += 180.0;
            }
            if a >= 180.0 - 1e-6 || a.abs() < 1e-9 {
                a = 0.0;
            }
            let node = match (
                on_node(p.x, g.dx(), g.shift.0, g.nx),
                on_node(p.y, g.dy(), g.shift.1, g.ny),
            ) {
                (Some(i), Some(j)) => Some((i, j)),
                _ => None,
            };
            FlowSaddle {
                x: p.x,
                y: p.y,
                node,
                angle_deg: a,
                height: p.height,
                eta: p.eta().unwrap_or(f64::NAN),
            }
        })
        .collect();
    if out.is_empty() {
        return Err(format!("{}: no saddle points", surface.lattice.name()));
    }
    let lo = out.iter().map(|s| s.height).fold(f64::INFINITY, f64::min);
    let hi = out
        .iter()
        .map(|s| s.height)
        .fold(f64::NEG_INFINITY, f64::max);
    if hi - lo > 1e-9 {
        return Err(format!(
            "{}: saddles of heights {lo} … {hi} h0; which of them carry the flow needs the \
             minimax pass of the trough network (not implemented)",
            surface.lattice.name()
        ));
    }
    out.sort_by(|a, b| {
        a.angle_deg
            .total_cmp(&b.angle_deg)
            .then(a.x.total_cmp(&b.x))
            .then(a.y.total_cmp(&b.y))
    });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use surface::Lattice;

    /// Square: two saddles, channels along x and y. Triangular and hexagonal: twelve, four per
    /// channel orientation, one orientation along a grid axis and two at ±60° to it; all on
    /// nodes of the unshifted 2^n grid, with η = 1, 1/3, 3.
    #[test]
    fn the_flow_saddles_are_every_saddle_of_the_cell() {
        let sq = flow_saddles(&Surface::new(Lattice::Square, 5).unwrap()).unwrap();
        let got: Vec<(f64, Option<(usize, usize)>)> =
            sq.iter().map(|s| (s.angle_deg.round(), s.node)).collect();
        // (0, ½): channel along x; (½, 0): along y
        assert_eq!(got, [(0.0, Some((0, 16))), (90.0, Some((16, 0)))]);
        for (l, angles, eta, axis) in [
            (Lattice::Triangular, [30.0, 90.0, 150.0], 1.0 / 3.0, 1),
            (Lattice::Hexagonal, [0.0, 60.0, 120.0], 3.0, 0),
        ] {
            let s = Surface::new(l, 5).unwrap();
            let f = flow_saddles(&s).unwrap();
            assert_eq!(f.len(), 12, "{l}");
            for (k, want) in angles.iter().enumerate() {
                let group = &f[4 * k..4 * k + 4];
                assert!(
                    group.iter().all(|s| (s.angle_deg - want).abs() < 1e-6),
                    "{l}: {group:?}"
                );
            }
            // one orientation along a grid axis, the other two at ±60° to it
            let along: Vec<usize> = f.iter().filter_map(|s| s.channel_axis()).collect();
            assert_eq!(along, vec![axis; 4], "{l}");
            assert!(
                f.iter()
                    .all(|s| s.node.is_some() && (s.eta - eta).abs() < 1e-9)
            );
            // every saddle on its node: the sampled height there is the saddle height
            for p in &f {
                let (i, j) = p.node.unwrap();
                assert!((s.heights[[i, j]] - p.height).abs() < 1e-12, "{l}: {p:?}");
                let (x, y) = s.grid.position(i, j);
                assert!((x - p.x).abs() < 1e-12 && (y - p.y).abs() < 1e-12);
            }
            // the twelve are distinct nodes
            let mut nodes: Vec<(usize, usize)> = f.iter().map(|p| p.node.unwrap()).collect();
            nodes.sort();
            nodes.dedup();
            assert_eq!(nodes.len(), 12);
        }
    }
}
