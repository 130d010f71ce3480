//! Hysteresis between the forward and reverse branches of a quasi-static path, and what a jump
//! on a path is.
//!
//! A **loop** is a run of consecutive control values, common to both branches, at which the
//! branches are in different states: different topology (contact or none, fluid percolating or
//! not, full contact or not) or contact areas differing by more than a tolerance. Two states at
//! one control value are two equilibria: the branches are bistable there, and each must jump
//! where it rejoins the other — the forward branch at the loop's upper end, the reverse branch at
//! its lower end ([`LoopEnd`]).

/// One solved point of a branch as the loop finder sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BranchState {
    /// Control value (mean pressure or interaction strength).
    pub x: f64,
    /// Relative contact area.
    pub area: f64,
    /// Whether the fluid percolates (along either axis).
    pub fluid: bool,
}

impl BranchState {
    /// (in contact, fluid percolates, full contact).
    fn topology(&self) -> (bool, bool, bool) {
        (self.area > 0.0, self.fluid, self.area >= 1.0)
    }
}

/// A change of state between two consecutive states of a branch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transition {
    /// Control values before and after.
    pub x: (f64, f64),
    /// Relative contact areas before and after.
    pub area: (f64, f64),
}

impl Transition {
    /// The midpoint of the bracket.
    pub fn mid(&self) -> f64 {
        0.5 * (self.x.0 + self.x.1)
    }
}

/// The first step of `states` from a state without `what` to one with it.
pub fn first_change(
    states: &[BranchState],
    what: impl Fn(&BranchState) -> bool,
) -> Option<Transition> {
    states.windows(2).find_map(|w| {
        let (a, b) = (&w[0], &w[1]);
        (!what(a) && what(b)).then_some(Transition {
            x: (a.x, b.x),
            area: (a.area, b.area),
        })
    })
}

/// The topological thresholds of a path (Figure 3's γ_p and γ_fc on a γ0 path): each a bracket
/// between two consecutive states, the instability lying in between.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Thresholds {
    /// Forward branch: the fluid stops percolating while in contact (contact percolation, γ_p).
    pub coalescence: Option<Transition>,
    /// Forward branch: the area reaches 1 (γ_fc).
    pub full_contact: Option<Transition>,
    /// Reverse branch: the fluid percolates again.
    pub break_up: Option<Transition>,
    /// Reverse branch: the area leaves 1.
    pub trough_opening: Option<Transition>,
}

impl Thresholds {
    /// The names of the thresholds, in [`Thresholds::all`]'s order.
    pub const NAMES: [&'static str; 4] =
        ["coalescence", "full_contact", "break_up", "trough_opening"];

    /// The thresholds of the `forward` and `reverse` branches (their converged states, in path
    /// order).
    pub fn of(forward: &[BranchState], reverse: &[BranchState]) -> Self {
        let coalesced = |s: &BranchState| s.area > 0.0 && !s.fluid;
        let full = |s: &BranchState| s.area >= 1.0;
        Thresholds {
            coalescence: first_change(forward, coalesced),
            full_contact: first_change(forward, full),
            break_up: first_change(reverse, |s| !coalesced(s)),
            trough_opening: first_change(reverse, |s| !full(s)),
        }
    }

    /// Every threshold with its name ([`Thresholds::NAMES`]).
    pub fn all(&self) -> [(&'static str, Option<Transition>); 4] {
        let n = Self::NAMES;
        [
            (n[0], self.coalescence),
            (n[1], self.full_contact),
            (n[2], self.break_up),
            (n[3], self.trough_opening),
        ]
    }

    /// Sets the threshold called `name`; false for an unknown name.
    pub fn set(&mut self, name: &str, t: Transition) -> bool {
        let slot = match name {
            "coalescence" => &mut self.coalescence,
            "full_contact" => &mut self.full_contact,
            "break_up" => &mut self.break_up,
            "trough_opening" => &mut self.trough_opening,
            _ => return false,
        };
        *slot = Some(t);
        true
    }

    /// full_contact/coalescence (γ_fc/γ_p) with its bracket (lower, upper): exactly 1 if both
    /// are the same step (one instability).
    pub fn ratio(&self) -> Option<(f64, f64, f64)> {
        let (p, fc) = (self.coalescence?, self.full_contact?);
        if p == fc {
            return Some((1.0, 1.0, 1.0));
        }
        Some((fc.mid() / p.mid(), fc.x.0 / p.x.1, fc.x.1 / p.x.0))
    }
}

/// A hysteresis loop between the branches.
#[derive(Clone, Debug, PartialEq)]
pub struct Loop {
    /// Smallest and largest control value where the branches differ.
    pub x: (f64, f64),
    /// Largest |area(reverse) − area(forward)| in the loop.
    pub max_area_difference: f64,
    /// Where it is largest (the first such control value).
    pub x_at_max: f64,
}

/// An end of a loop, where a branch jumps back onto the other: between positions `before` and
/// `after` (= before + 1) of that branch's slice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoopEnd {
    /// On the forward branch (at the loop's upper end) or the reverse one (at its lower end).
    pub forward: bool,
    /// Position before the jump.
    pub before: usize,
    /// Position after it.
    pub after: usize,
}

/// Finds the loops between `forward` (control increasing) and `reverse` (decreasing) branch
/// states, compared at equal control values (bit-equal: the reverse branch retraces the forward
/// values), and the loops' ends in loop order (forward end first). A loop reaching the end of
/// the common range (e.g. the reverse branch continues below the forward branch's start) gets no
/// end there. Areas differing by more than `tolerance` (or in topology) make a loop.
pub fn find_loops(
    forward: &[BranchState],
    reverse: &[BranchState],
    tolerance: f64,
) -> (Vec<Loop>, Vec<LoopEnd>) {
    // position on the reverse branch of each control value (the last one if repeated)
    let reverse_at: std::collections::HashMap<u64, usize> = reverse
        .iter()
        .enumerate()
        .map(|(j, s)| (s.x.to_bits(), j))
        .collect();
    // (forward position, reverse position) at common control values, in forward order
    let common: Vec<(usize, usize)> = forward
        .iter()
        .enumerate()
        .filter_map(|(i, s)| reverse_at.get(&s.x.to_bits()).map(|&j| (i, j)))
        .collect();
    let differ = |&(i, j): &(usize, usize)| {
        let (a, b) = (&forward[i], &reverse[j]);
        a.topology() != b.topology() || (a.area - b.area).abs() > tolerance
    };
    let (mut loops, mut ends) = (Vec::new(), Vec::new());
    let mut k = 0;
    while k < common.len() {
        if !differ(&common[k]) {
            k += 1;
            continue;
        }
        let c0 = k;
        while k + 1 < common.len() && differ(&common[k + 1]) {
            k += 1;
        }
        let c1 = k;
        let (mut dmax, mut xmax) = (0.0f64, f64::NAN);
        for &(i, j) in &common[c0..=c1] {
            let diff = (reverse[j].area - forward[i].area).abs();
            if diff > dmax || xmax.is_nan() {
                dmax = diff;
                xmax = forward[i].x;
            }
        }
        loops.push(Loop {
            x: (forward[common[c0].0].x, forward[common[c1].0].x),
            max_area_difference: dmax,
            x_at_max: xmax,
        });
        // forward branch: from the loop's top to the next common value (branches agree there)
        if let Some(&(next, _)) = common.get(c1 + 1) {
            let i = common[c1].0;
            if next == i + 1 {
                ends.push(LoopEnd {
                    forward: true,
                    before: i,
                    after: next,
                });
            }
        }
        // reverse branch: from the loop's bottom to the next common value below
        if c0 > 0 {
            let (j, next) = (common[c0].1, common[c0 - 1].1);
            if next == j + 1 {
                ends.push(LoopEnd {
                    forward: false,
                    before: j,
                    after: next,
                });
            }
        }
        k += 1;
    }
    (loops, ends)
}

/// What a jump is, from the areas on either side, the direction, and whether the fluid
/// percolates before and after (along either axis):
/// - `contact formation` / `contact loss`: the area leaves or reaches zero;
/// - `full contact` / `trough opening`: the area reaches or leaves one;
/// - `coalescence` / `break-up`: the fluid stops or starts percolating (contact patches merge
///   across the saddles, or the contact network tears);
/// - `area jump (up)` / `area jump (down)`: anything else.
pub fn classify(
    area_before: f64,
    area_after: f64,
    fluid_before: bool,
    fluid_after: bool,
) -> &'static str {
    let up = area_after > area_before;
    if area_before == 0.0 && up {
        "contact formation"
    } else if area_after == 0.0 && !up {
        "contact loss"
    } else if area_after == 1.0 && up {
        "full contact"
    } else if area_before == 1.0 && !up {
        "trough opening"
    } else if fluid_before && !fluid_after {
        "coalescence"
    } else if !fluid_before && fluid_after {
        "break-up"
    } else if up {
        "area jump (up)"
    } else {
        "area jump (down)"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn states(x: &[f64], area: &[f64], fluid: &[bool]) -> Vec<BranchState> {
        (0..x.len())
            .map(|k| BranchState {
                x: x[k],
                area: area[k],
                fluid: fluid[k],
            })
            .collect()
    }

    #[test]
    fn classification() {
        assert_eq!(classify(0.0, 0.1, true, true), "contact formation");
        assert_eq!(classify(0.1, 0.0, true, true), "contact loss");
        assert_eq!(classify(0.9, 1.0, true, false), "full contact");
        assert_eq!(classify(1.0, 0.5, false, false), "trough opening");
        assert_eq!(classify(0.35, 0.43, true, false), "coalescence");
        assert_eq!(classify(0.41, 0.32, false, true), "break-up");
        assert_eq!(classify(0.2, 0.3, true, true), "area jump (up)");
        assert_eq!(classify(0.3, 0.2, true, true), "area jump (down)");
    }

    /// A bistable window: loading stays low until x = 3 and jumps at 3 → 4, unloading stays
    /// high down to x = 2 and jumps at 2 → 1. The loop is x ∈ [2, 3], its ends are those jumps.
    #[test]
    fn a_bistable_window_is_one_loop_with_two_ends() {
        let x = [1.0, 2.0, 3.0, 4.0, 5.0];
        let f = states(&x, &[0.1, 0.2, 0.3, 0.8, 0.9], &[true; 5]);
        let rx = [5.0, 4.0, 3.0, 2.0, 1.0];
        let r = states(&rx, &[0.9, 0.8, 0.65, 0.6, 0.1], &[true; 5]);
        let (loops, ends) = find_loops(&f, &r, 0.02);
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].x, (2.0, 3.0));
        assert!((loops[0].max_area_difference - 0.4).abs() < 1e-12);
        assert_eq!(loops[0].x_at_max, 2.0);
        assert_eq!(
            ends,
            [
                LoopEnd {
                    forward: true,
                    before: 2,
                    after: 3
                },
                LoopEnd {
                    forward: false,
                    before: 3,
                    after: 4
                },
            ]
        );
    }

    /// Within the tolerance and with the same topology the branches agree; a topology change
    /// alone (fluid percolation) makes a loop even with equal areas; a loop that reaches the
    /// end of the common range has no end there.
    #[test]
    fn tolerance_topology_and_open_ends() {
        let x = [1.0, 2.0, 3.0];
        let f = states(&x, &[0.1, 0.2, 0.3], &[true, true, true]);
        let r = states(&[3.0, 2.0, 1.0], &[0.31, 0.21, 0.11], &[true, true, true]);
        let (loops, ends) = find_loops(&f, &r, 0.02);
        assert!(loops.is_empty() && ends.is_empty());
        let r = states(&[3.0, 2.0, 1.0], &[0.3, 0.2, 0.1], &[true, false, false]);
        let (loops, ends) = find_loops(&f, &r, 0.02);
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].x, (1.0, 2.0));
        assert_eq!(loops[0].max_area_difference, 0.0);
        // the loop starts at the first common value: only the forward end, 2 → 3
        assert_eq!(
            ends,
            [LoopEnd {
                forward: true,
                before: 1,
                after: 2
            }]
        );
    }

    /// Only bit-equal control values are compared; a gap in the common values (a point missing
    /// on one branch) gives no end across it.
    #[test]
    fn ends_need_neighbouring_positions() {
        let f = states(&[1.0, 2.0, 3.0, 4.0], &[0.1, 0.2, 0.6, 0.7], &[true; 4]);
        // the reverse branch lacks x = 3 (e.g. an unconverged point left out)
        let r = states(&[4.0, 2.0, 1.0], &[0.7, 0.5, 0.1], &[true; 3]);
        let (loops, ends) = find_loops(&f, &r, 0.02);
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].x, (2.0, 2.0));
        // forward: 2 → 4 are not neighbours on the forward branch (3 lies between): no end;
        // reverse: the position of x = 2 is 1, of x = 1 is 2: an end
        assert_eq!(
            ends,
            [LoopEnd {
                forward: false,
                before: 1,
                after: 2
            }]
        );
    }

    fn branch_of(v: &[(f64, f64, bool)]) -> Vec<BranchState> {
        v.iter()
            .map(|&(x, area, fluid)| BranchState { x, area, fluid })
            .collect()
    }

    #[test]
    fn thresholds_bracket_coalescence_and_full_contact() {
        let up = branch_of(&[
            (0.1, 0.1, true),
            (0.2, 0.2, true),
            (0.3, 0.45, false),
            (0.4, 0.5, false),
            (0.5, 1.0, false),
        ]);
        let down = branch_of(&[
            (0.4, 1.0, false),
            (0.3, 1.0, false),
            (0.2, 0.3, true),
            (0.1, 0.1, true),
        ]);
        let t = Thresholds::of(&up, &down);
        assert_eq!(t.coalescence.unwrap().x, (0.2, 0.3));
        assert_eq!(t.coalescence.unwrap().area, (0.2, 0.45));
        assert_eq!(t.full_contact.unwrap().x, (0.4, 0.5));
        // decreasing: full contact is left and the fluid percolates again in the same step
        assert_eq!(t.trough_opening.unwrap().x, (0.3, 0.2));
        assert_eq!(t.break_up.unwrap().x, (0.3, 0.2));
        let (r, lo, hi) = t.ratio().unwrap();
        assert!((r - 0.45 / 0.25).abs() < 1e-12);
        assert!((lo - 0.4 / 0.3).abs() < 1e-12 && (hi - 0.5 / 0.2).abs() < 1e-12);
        // set() by name rebuilds the same thresholds
        let mut back = Thresholds::default();
        for (name, tr) in t.all() {
            assert!(back.set(name, tr.unwrap()));
        }
        assert_eq!(back, t);
        assert!(!back.set("coalesence", t.coalescence.unwrap()));
    }

    #[test]
    fn straight_to_full_contact_is_one_instability() {
        let up = branch_of(&[(0.1, 0.05, true), (0.2, 0.1, true), (0.3, 1.0, false)]);
        let t = Thresholds::of(&up, &[]);
        assert_eq!(t.coalescence, t.full_contact);
        assert_eq!(t.ratio(), Some((1.0, 1.0, 1.0)));
        // nothing on a branch that never coalesces
        let t = Thresholds::of(&up[..2], &[]);
        assert!(t.coalescence.is_none() && t.full_contact.is_none() && t.ratio().is_none());
    }
}
