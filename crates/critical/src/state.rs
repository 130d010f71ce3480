//! The percolation state of one contact solution along both axes, with the dual rule checked.

use crate::CriticalError;
use ndarray::{Array2, ArrayView2};
use percolation::{Axis, dual_percolation};

/// Which phase spans the periodic cell along each axis.
///
/// Contact is labelled 8-connected and fluid 4-connected (PHYSICS.md). Along each axis exactly one
/// of "the fluid wraps along it" and "the contact has a closed path cutting it" holds; [`FlowState::of`]
/// checks this and fails with [`CriticalError::DualRule`] otherwise, so a state never reports the
/// fluid percolating and the contact blocking along the same axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlowState {
    /// Some 4-connected fluid cluster wraps along x: fluid can flow along x.
    pub fluid_x: bool,
    /// Some 4-connected fluid cluster wraps along y.
    pub fluid_y: bool,
    /// Some 8-connected contact cluster cuts the cell across x: flow along x is blocked.
    pub blocked_x: bool,
    /// The same across y.
    pub blocked_y: bool,
}

impl FlowState {
    /// Classifies a contact mask (`true` = contact, shape (nx, ny), periodic).
    pub fn of(contact: ArrayView2<bool>) -> Result<Self, CriticalError> {
        let d = dual_percolation(contact);
        let s = FlowState {
            fluid_x: d.fluid_percolates(Axis::X),
            fluid_y: d.fluid_percolates(Axis::Y),
            blocked_x: d.contact_blocks(Axis::X),
            blocked_y: d.contact_blocks(Axis::Y),
        };
        for axis in [Axis::X, Axis::Y] {
            if s.fluid(axis) == s.blocked(axis) {
                return Err(CriticalError::DualRule {
                    axis: axis_name(axis),
                    fluid: s.fluid(axis),
                    blocked: s.blocked(axis),
                });
            }
        }
        Ok(s)
    }

    /// Classifies a gap field: contact where the gap is exactly zero (the hard-wall solver sets
    /// it so on its contact set).
    pub fn of_gap(gap: ArrayView2<f64>) -> Result<Self, CriticalError> {
        Self::of(contact_mask(gap).view())
    }

    /// The fluid wraps along `axis`.
    pub fn fluid(&self, axis: Axis) -> bool {
        match axis {
            Axis::X => self.fluid_x,
            Axis::Y => self.fluid_y,
        }
    }

    /// The contact cuts the cell across `axis` (blocks flow along it).
    pub fn blocked(&self, axis: Axis) -> bool {
        match axis {
            Axis::X => self.blocked_x,
            Axis::Y => self.blocked_y,
        }
    }

    /// The fluid percolates along at least one axis (the "total" criterion is not met).
    pub fn fluid_any(&self) -> bool {
        self.fluid_x || self.fluid_y
    }

    /// The contact blocks both axes: no fluid path spans the cell in any direction.
    pub fn blocked_all(&self) -> bool {
        self.blocked_x && self.blocked_y
    }
}

/// Contact mask of a gap field: `g <= 0` (exactly 0 at contact nodes of a hard-wall solution).
pub fn contact_mask(gap: ArrayView2<f64>) -> Array2<bool> {
    gap.mapv(|g| g <= 0.0)
}

/// "x" or "y".
pub fn axis_name(axis: Axis) -> &'static str {
    match axis {
        Axis::X => "x",
        Axis::Y => "y",
    }
}
