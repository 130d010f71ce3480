//! The winding content of a cluster: which net windings its closed paths can have.

use crate::Axis;

/// The set of net windings `(w_x, w_y)` (in periods of the cell) of the closed paths inside one
/// cluster.
///
/// That set is a subgroup of Z²; for percolation only its *directions* matter, so it is stored
/// up to its rank:
/// - [`Winding::None`]: every closed path has zero net winding (the cluster is a bounded island
///   in the periodically continued plane);
/// - [`Winding::Line`]: all windings are integer multiples of one direction `(p, q)` (a stripe:
///   in the periodically continued plane the cluster is a set of parallel infinite strands along
///   `(p·Lx, q·Ly)`);
/// - [`Winding::Plane`]: two independent windings (the continued cluster is connected across the
///   whole plane; only isolated pools of the other phase remain).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Winding {
    /// No closed path winds around the cell.
    #[default]
    None,
    /// All windings are parallel to `(p, q)`; stored primitive (`gcd(|p|, |q|) = 1`) with
    /// `p > 0`, or `p == 0` and `q > 0`.
    Line {
        /// Winding along x of the primitive direction.
        p: i32,
        /// Winding along y of the primitive direction.
        q: i32,
    },
    /// Two independent windings.
    Plane,
}

fn gcd(mut a: i64, mut b: i64) -> i64 {
    a = a.abs();
    b = b.abs();
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}

impl Winding {
    /// The winding content after also admitting the closed-path winding `(wx, wy)`.
    /// A zero vector changes nothing.
    pub fn with(self, wx: i64, wy: i64) -> Winding {
        if wx == 0 && wy == 0 {
            return self;
        }
        match self {
            Winding::Plane => Winding::Plane,
            Winding::None => {
                let g = gcd(wx, wy);
                let (mut p, mut q) = (wx / g, wy / g);
                if p < 0 || (p == 0 && q < 0) {
                    p = -p;
                    q = -q;
                }
                // |p| ≤ |wx| and |q| ≤ |wy|; windings are bounded by the grid size, which fits
                // in u32, but a saturating conversion keeps this total.
                Winding::Line {
                    p: p.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
                    q: q.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
                }
            }
            Winding::Line { p, q } => {
                let cross = p as i64 * wy - q as i64 * wx;
                if cross == 0 { self } else { Winding::Plane }
            }
        }
    }

    /// The winding content of the union of two clusters' path sets (used when merging).
    pub fn merge(self, other: Winding) -> Winding {
        match other {
            Winding::None => self,
            Winding::Plane => Winding::Plane,
            Winding::Line { p, q } => self.with(p as i64, q as i64),
        }
    }

    /// Some closed path has a non-zero net winding along `axis`: continued periodically, the
    /// cluster extends to infinity along that axis (for the fluid: it can carry a flux along it).
    pub fn wraps(self, axis: Axis) -> bool {
        match self {
            Winding::None => false,
            Winding::Plane => true,
            Winding::Line { p, q } => match axis {
                Axis::X => p != 0,
                Axis::Y => q != 0,
            },
        }
    }

    /// Some closed path winds around the cell *across* `axis` with zero net winding along it,
    /// i.e. has winding `(0, m)` (for `Axis::X`) or `(m, 0)` (for `Axis::Y`) with `m ≠ 0`.
    /// Such a closed curve cuts the cell into slabs normal to `axis`: no path of the dual phase
    /// can wind along `axis`. For the contact phase this is "blocks flow along `axis`".
    pub fn cuts(self, axis: Axis) -> bool {
        match self {
            Winding::None => false,
            Winding::Plane => true,
            Winding::Line { p, q } => match axis {
                Axis::X => p == 0,
                Axis::Y => q == 0,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_line_and_rank() {
        let w = Winding::None.with(-2, 0);
        assert_eq!(w, Winding::Line { p: 1, q: 0 });
        assert_eq!(w.with(3, 0), w);
        assert_eq!(w.with(0, 1), Winding::Plane);
        let d = Winding::None.with(-3, -3);
        assert_eq!(d, Winding::Line { p: 1, q: 1 });
        assert!(d.wraps(Axis::X) && d.wraps(Axis::Y));
        assert!(!d.cuts(Axis::X) && !d.cuts(Axis::Y));
        let v = Winding::None.with(0, -5);
        assert_eq!(v, Winding::Line { p: 0, q: 1 });
        assert!(v.cuts(Axis::X) && !v.cuts(Axis::Y) && v.wraps(Axis::Y) && !v.wraps(Axis::X));
        assert_eq!(d.merge(v), Winding::Plane);
        assert_eq!(Winding::None.merge(d), d);
        assert_eq!(d.with(0, 0), d);
    }
}
