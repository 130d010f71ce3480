//! Bracketing and bisection in load for the percolation transitions, generic over how a load is
//! probed (so the logic is testable without a contact solver).
//!
//! Three transitions are bracketed at once, one per [`Criterion`]: fluid percolation along x,
//! along y, and along any axis. One probe (a contact solve) classifies its load for all three, so
//! the brackets share probes while they overlap. Each bracket `[lo, hi]` has been *probed at both
//! ends*: the fluid percolates (by that criterion) at `lo` and is blocked at `hi`. Percolation is
//! assumed monotone in load (contact grows with load for the hard wall); a probe that contradicts
//! an existing bracket end is reported as [`CriticalError::NonMonotone`] rather than silently
//! ignored.

use crate::{CriticalError, FlowState};

/// Which percolation transition a bracket locates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Criterion {
    /// Fluid wraps along x below, contact cuts x above.
    X,
    /// Fluid wraps along y below, contact cuts y above.
    Y,
    /// Fluid wraps along some axis below; contact cuts both axes above: the load at which the
    /// fluid stops percolating altogether (the paper's L_c). It is the larger of the x and y
    /// transitions.
    Any,
}

impl Criterion {
    /// All three, in the order stored in results.
    pub const ALL: [Criterion; 3] = [Criterion::Any, Criterion::X, Criterion::Y];

    /// Whether the fluid percolates by this criterion in `s`.
    pub fn open(self, s: &FlowState) -> bool {
        match self {
            Criterion::X => s.fluid_x,
            Criterion::Y => s.fluid_y,
            Criterion::Any => s.fluid_any(),
        }
    }

    /// "x", "y" or "any".
    pub fn name(self) -> &'static str {
        match self {
            Criterion::X => "x",
            Criterion::Y => "y",
            Criterion::Any => "any",
        }
    }
}

/// Evaluates the flow state at a load; keeps whatever it needs for warm starts.
pub trait Prober {
    /// Solves at `load` (E* h0/λ) and classifies the result.
    fn probe(&mut self, load: f64) -> Result<FlowState, CriticalError>;
    /// The loads still needed as bracket ends; the prober may drop anything else it stored.
    fn keep(&mut self, _loads: &[f64]) {}
}

/// A bracket whose ends were both probed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bracket {
    /// Criterion.
    pub criterion: Criterion,
    /// Largest probed load at which the fluid percolates (E* h0/λ).
    pub lo: f64,
    /// Smallest probed load at which it is blocked (E* h0/λ).
    pub hi: f64,
    /// Flow state at `lo`.
    pub state_lo: FlowState,
    /// Flow state at `hi`.
    pub state_hi: FlowState,
}

impl Bracket {
    /// Midpoint (E* h0/λ).
    pub fn mid(&self) -> f64 {
        0.5 * (self.lo + self.hi)
    }
    /// `(hi − lo)/hi`.
    pub fn rel_width(&self) -> f64 {
        (self.hi - self.lo) / self.hi
    }
}

/// Options of [`bracket_transitions`].
#[derive(Clone, Debug, PartialEq)]
pub struct SearchOptions {
    /// First load probed (E* h0/λ), > 0.
    pub guess: f64,
    /// Relative step of the first expansion when a bracket end is missing; it doubles on every
    /// further expansion (downward steps are capped at a factor 1/4).
    pub guess_width: f64,
    /// Target `(hi − lo)/hi` of every bracket.
    pub rel_width: f64,
    /// Smallest load the search may probe (E* h0/λ), > 0.
    pub load_min: f64,
    /// Largest load the search may probe (E* h0/λ): at full contact every axis is blocked.
    pub load_max: f64,
    /// Cap on the number of probes.
    pub max_probes: usize,
}

#[derive(Clone, Copy, Debug)]
struct End {
    load: f64,
    state: FlowState,
}

#[derive(Clone, Copy, Debug)]
struct Open {
    lo: Option<End>,
    hi: Option<End>,
}

/// Brackets the three transitions of [`Criterion::ALL`] to `opts.rel_width`, returning them in
/// that order, and the number of probes used.
pub fn bracket_transitions(
    prober: &mut dyn Prober,
    opts: &SearchOptions,
) -> Result<([Bracket; 3], usize), CriticalError> {
    bracket_transitions_seeded(prober, opts, None).map(|(b, probes, _)| (b, probes))
}

/// A starting bracket `(lo, hi)` per criterion, in [`Criterion::ALL`] order (any, x, y), taken
/// from another search on the same field and criterion (E* h0/λ). It is a guess only: the
/// search probes its ends itself before it narrows it ([`bracket_transitions_seeded`]).
pub type BracketSeed = [(f64, f64); 3];

/// What became of a [`BracketSeed`].
#[derive(Clone, Debug, PartialEq)]
pub enum SeedOutcome {
    /// No seed was given.
    Unseeded,
    /// Every end was confirmed by a probe (lo open, hi blocked for its criterion): the search
    /// narrowed the seed's brackets and skipped the expansion from the guess.
    Used {
        /// Probes spent on the seed's ends.
        probes: usize,
    },
    /// The seed was not valid: the search bracketed from its guess as without a seed (the
    /// probes of the seed's ends, if any, are still used: they are probes of this search).
    Rejected {
        /// Which criterion and end failed, and how.
        reason: String,
    },
}

/// Why a seed cannot be used before any probe (ends not finite, not ordered, out of range).
fn seed_shape_issue(seed: &BracketSeed, opts: &SearchOptions) -> Option<String> {
    Criterion::ALL.iter().zip(seed).find_map(|(c, &(lo, hi))| {
        let ok = lo.is_finite()
            && hi.is_finite()
            && lo >= opts.load_min
            && hi <= opts.load_max
            && lo < hi;
        (!ok).then(|| {
            format!(
                "criterion {}: seed bracket [{lo:e}, {hi:e}] is not an ordered bracket within \
                 [load_min, load_max] = [{:e}, {:e}]",
                c.name(),
                opts.load_min,
                opts.load_max
            )
        })
    })
}

/// [`bracket_transitions`] starting from `seed` if it is confirmed: its distinct ends are
/// probed first, in ascending load; if every criterion is open at its seed's `lo` and blocked at
/// its `hi`, the expansion from `opts.guess` is skipped and the bisection narrows from there.
/// Otherwise the seed is rejected (the outcome says which end failed) and the search runs from
/// `opts.guess` as without a seed, keeping the probes it made. Either way every bracket
/// returned was probed at both ends by this search: a seed can change the probes, never trust.
pub fn bracket_transitions_seeded(
    prober: &mut dyn Prober,
    opts: &SearchOptions,
    seed: Option<&BracketSeed>,
) -> Result<([Bracket; 3], usize, SeedOutcome), CriticalError> {
    check_options(opts)?;
    let mut b = [Open { lo: None, hi: None }; 3];
    let mut probes = 0usize;
    let mut lowest = f64::INFINITY;
    let mut highest = 0.0f64;

    let visit = |load: f64,
                 b: &mut [Open; 3],
                 probes: &mut usize,
                 prober: &mut dyn Prober|
     -> Result<FlowState, CriticalError> {
        if *probes >= opts.max_probes {
            return Err(CriticalError::TooManyProbes {
                probes: *probes,
                summary: summary(b),
            });
        }
        *probes += 1;
        let state = prober.probe(load)?;
        for (k, c) in Criterion::ALL.iter().enumerate() {
            let o = &mut b[k];
            let end = End { load, state };
            if c.open(&state) {
                if let Some(h) = o.hi
                    && load >= h.load
                {
                    return Err(CriticalError::NonMonotone {
                        criterion: c.name(),
                        open_at: load,
                        blocked_at: h.load,
                    });
                }
                if o.lo.is_none_or(|l| load > l.load) {
                    o.lo = Some(end);
                }
            } else {
                if let Some(l) = o.lo
                    && load <= l.load
                {
                    return Err(CriticalError::NonMonotone {
                        criterion: c.name(),
                        open_at: l.load,
                        blocked_at: load,
                    });
                }
                if o.hi.is_none_or(|h| load < h.load) {
                    o.hi = Some(end);
                }
            }
        }
        let mut keep: Vec<f64> = b
            .iter()
            .flat_map(|o| [o.lo.map(|e| e.load), o.hi.map(|e| e.load)])
            .flatten()
            .collect();
        keep.sort_by(f64::total_cmp);
        keep.dedup();
        prober.keep(&keep);
        Ok(state)
    };

    // 0. The seed's ends, ascending (each probe warm-starts from the one below), then the
    //    check that each criterion is open at its seed's lo and blocked at its hi.
    let mut outcome = SeedOutcome::Unseeded;
    if let Some(seed) = seed {
        outcome = match seed_shape_issue(seed, opts) {
            Some(reason) => SeedOutcome::Rejected { reason },
            None => {
                let mut loads: Vec<f64> = seed.iter().flat_map(|&(lo, hi)| [lo, hi]).collect();
                loads.sort_by(f64::total_cmp);
                loads.dedup();
                let mut states = Vec::with_capacity(loads.len());
                for &load in &loads {
                    let state = visit(load, &mut b, &mut probes, prober)?;
                    states.push((load, state));
                }
                let state_at = |load: f64| states.iter().find(|(l, _)| *l == load).map(|(_, s)| *s);
                let failed = Criterion::ALL.iter().zip(seed).find_map(|(c, &(lo, hi))| {
                    match (state_at(lo), state_at(hi)) {
                        (Some(a), Some(z)) if c.open(&a) && !c.open(&z) => None,
                        (a, z) => Some(format!(
                            "criterion {}: seed bracket [{lo:e}, {hi:e}] probed {} at lo and \
                             {} at hi (expected open, blocked)",
                            c.name(),
                            open_word(*c, a),
                            open_word(*c, z)
                        )),
                    }
                });
                match failed {
                    None => SeedOutcome::Used { probes },
                    Some(reason) => SeedOutcome::Rejected { reason },
                }
            }
        };
    }

    // 1. The guess, then expansions until every criterion has both ends (skipped after a
    //    confirmed seed: every criterion has both ends then).
    let seeded = matches!(outcome, SeedOutcome::Used { .. });
    if !seeded {
        visit(opts.guess, &mut b, &mut probes, prober)?;
        lowest = lowest.min(opts.guess);
        highest = highest.max(opts.guess);
    }
    let mut w_down = opts.guess_width;
    let mut w_up = opts.guess_width;
    loop {
        let need_lo = b.iter().any(|o| o.lo.is_none());
        let need_hi = b.iter().any(|o| o.hi.is_none());
        if !need_lo && !need_hi {
            break;
        }
        if need_lo {
            if lowest <= opts.load_min {
                return Err(CriticalError::NoBracket {
                    side: "below",
                    load: lowest,
                    detail: format!(
                        "the fluid does not percolate even at the smallest allowed load {} ({})",
                        opts.load_min,
                        summary(&b)
                    ),
                });
            }
            let load = (lowest * (1.0 - w_down.min(0.75))).max(opts.load_min);
            visit(load, &mut b, &mut probes, prober)?;
            lowest = load;
            w_down *= 2.0;
        }
        if need_hi && b.iter().any(|o| o.hi.is_none()) {
            if highest >= opts.load_max {
                return Err(CriticalError::NoBracket {
                    side: "above",
                    load: highest,
                    detail: format!(
                        "the fluid still percolates at the largest allowed load {} ({})",
                        opts.load_max,
                        summary(&b)
                    ),
                });
            }
            let load = (highest * (1.0 + w_up)).min(opts.load_max);
            visit(load, &mut b, &mut probes, prober)?;
            highest = load;
            w_up *= 2.0;
        }
    }

    // 2. Bisection of the widest bracket.
    loop {
        let (k, width) = b
            .iter()
            .enumerate()
            .map(|(k, o)| {
                let (lo, hi) = (o.lo.expect("set").load, o.hi.expect("set").load);
                (k, (hi - lo) / hi)
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("three brackets");
        if width <= opts.rel_width {
            break;
        }
        let (lo, hi) = (b[k].lo.expect("set").load, b[k].hi.expect("set").load);
        let mid = 0.5 * (lo + hi);
        if !(mid > lo && mid < hi) {
            break; // adjacent floats: as narrow as f64 allows
        }
        visit(mid, &mut b, &mut probes, prober)?;
    }

    debug_assert!(!seeded || b.iter().all(|o| o.lo.is_some() && o.hi.is_some()));
    let out = Criterion::ALL.map(|c| {
        let o = b[Criterion::ALL
            .iter()
            .position(|x| *x == c)
            .expect("criterion")];
        let (lo, hi) = (o.lo.expect("set"), o.hi.expect("set"));
        Bracket {
            criterion: c,
            lo: lo.load,
            hi: hi.load,
            state_lo: lo.state,
            state_hi: hi.state,
        }
    });
    Ok((out, probes, outcome))
}

fn open_word(c: Criterion, s: Option<FlowState>) -> &'static str {
    match s {
        Some(s) if c.open(&s) => "open",
        Some(_) => "blocked",
        None => "not probed",
    }
}

fn summary(b: &[Open; 3]) -> String {
    Criterion::ALL
        .iter()
        .zip(b)
        .map(|(c, o)| {
            format!(
                "{}: open at {}, blocked at {}",
                c.name(),
                o.lo.map_or("-".into(), |e| format!("{:.9e}", e.load)),
                o.hi.map_or("-".into(), |e| format!("{:.9e}", e.load))
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

fn check_options(o: &SearchOptions) -> Result<(), CriticalError> {
    let pos = |v: f64| v.is_finite() && v > 0.0;
    if !pos(o.load_min) {
        return Err(CriticalError::param(
            "load_min",
            o.load_min,
            "finite and > 0 (E* h0/λ)",
        ));
    }
    if !(pos(o.load_max) && o.load_max > o.load_min) {
        return Err(CriticalError::param(
            "load_max",
            o.load_max,
            "finite and > load_min (E* h0/λ)",
        ));
    }
    if !(pos(o.guess) && o.guess >= o.load_min && o.guess <= o.load_max) {
        return Err(CriticalError::param(
            "guess",
            o.guess,
            "finite, in [load_min, load_max] (E* h0/λ)",
        ));
    }
    if !pos(o.guess_width) {
        return Err(CriticalError::param(
            "guess_width",
            o.guess_width,
            "finite and > 0 (relative)",
        ));
    }
    if !(pos(o.rel_width) && o.rel_width < 1.0) {
        return Err(CriticalError::param(
            "rel_width",
            o.rel_width,
            "in (0, 1) (relative bracket width)",
        ));
    }
    if o.max_probes < 2 {
        return Err(CriticalError::param(
            "max_probes",
            o.max_probes as f64,
            "≥ 2",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic system: fluid along x stops at `cx`, along y at `cy`.
    struct Step {
        cx: f64,
        cy: f64,
        calls: usize,
    }

    impl Prober for Step {
        fn probe(&mut self, load: f64) -> Result<FlowState, CriticalError> {
            self.calls += 1;
            let (fx, fy) = (load < self.cx, load < self.cy);
            Ok(FlowState {
                fluid_x: fx,
                fluid_y: fy,
                blocked_x: !fx,
                blocked_y: !fy,
            })
        }
    }

    fn opts(guess: f64) -> SearchOptions {
        SearchOptions {
            guess,
            guess_width: 0.05,
            rel_width: 1e-9,
            load_min: 1e-6,
            load_max: 10.0,
            max_probes: 500,
        }
    }

    #[test]
    fn brackets_each_axis_and_the_total() {
        for guess in [0.01, 1.3, 1.7, 9.9] {
            let mut s = Step {
                cx: 1.5,
                cy: 1.2,
                calls: 0,
            };
            let (b, probes) = bracket_transitions(&mut s, &opts(guess)).unwrap();
            assert_eq!(probes, s.calls);
            for (br, c) in b.iter().zip([1.5, 1.5, 1.2]) {
                assert!(br.lo < c && c <= br.hi, "{br:?}");
                assert!(br.rel_width() <= 1e-9);
                assert!(br.criterion.open(&br.state_lo) && !br.criterion.open(&br.state_hi));
            }
            assert_eq!(b[0].criterion, Criterion::Any);
            assert!(probes < 150, "{probes}");
        }
    }

    /// A seed from a coarser search of the same system narrows to the same brackets (each
    /// contains the transition and is as narrow as asked, so the midpoints agree to rel_width)
    /// with fewer probes than from the guess.
    #[test]
    fn a_confirmed_seed_narrows_to_the_same_brackets() {
        let step = || Step {
            cx: 1.5,
            cy: 1.2,
            calls: 0,
        };
        let mut coarse_opts = opts(0.3);
        coarse_opts.rel_width = 1e-4;
        let (coarse, _) = bracket_transitions(&mut step(), &coarse_opts).unwrap();
        let seed: BracketSeed = coarse.map(|b| (b.lo, b.hi));
        let (plain, plain_probes) = bracket_transitions(&mut step(), &opts(0.3)).unwrap();
        let mut s = step();
        let (seeded, probes, outcome) =
            bracket_transitions_seeded(&mut s, &opts(0.3), Some(&seed)).unwrap();
        assert_eq!(probes, s.calls);
        // any and x share their bracket: 4 distinct ends
        assert_eq!(outcome, SeedOutcome::Used { probes: 4 });
        for ((a, b), c) in seeded.iter().zip(&plain).zip([1.5, 1.5, 1.2]) {
            assert!(a.lo < c && c <= a.hi && a.rel_width() <= 1e-9, "{a:?}");
            assert!((a.mid() - b.mid()).abs() <= 1e-9 * a.hi, "{a:?} {b:?}");
        }
        assert!(
            probes + 10 < plain_probes,
            "seeded {probes}, plain {plain_probes}"
        );
    }

    /// A seed with both ends on one side of a transition, or not a bracket at all, is rejected
    /// and the search falls back to the guess: the brackets are still right.
    #[test]
    fn a_wrong_seed_is_detected_and_falls_back() {
        let step = || Step {
            cx: 1.5,
            cy: 1.2,
            calls: 0,
        };
        let (plain, plain_probes) = bracket_transitions(&mut step(), &opts(0.3)).unwrap();
        // any: both ends below 1.5 (open at both)
        let below: BracketSeed = [(1.0, 1.1), (1.4, 1.6), (1.1, 1.3)];
        // y: both ends above 1.2 (blocked at both)
        let above: BracketSeed = [(1.4, 1.6), (1.4, 1.6), (1.3, 1.4)];
        for (seed, needle) in [(below, "any"), (above, "criterion y")] {
            let mut s = step();
            let (b, probes, outcome) =
                bracket_transitions_seeded(&mut s, &opts(0.3), Some(&seed)).unwrap();
            let SeedOutcome::Rejected { reason } = outcome else {
                panic!("{needle}: {outcome:?}");
            };
            assert!(reason.contains(needle), "{reason}");
            assert_eq!(probes, s.calls);
            for (a, c) in b.iter().zip([1.5, 1.5, 1.2]) {
                assert!(a.lo < c && c <= a.hi && a.rel_width() <= 1e-9, "{a:?}");
            }
        }
        // not ordered: rejected before any probe, the search is the unseeded one
        let disordered: BracketSeed = [(1.6, 1.4), (1.4, 1.6), (1.1, 1.3)];
        let (b, probes, outcome) =
            bracket_transitions_seeded(&mut step(), &opts(0.3), Some(&disordered)).unwrap();
        assert!(
            matches!(&outcome, SeedOutcome::Rejected { reason } if reason.contains("any")),
            "{outcome:?}"
        );
        assert_eq!((b, probes), (plain, plain_probes));
    }

    #[test]
    fn missing_transitions_are_errors() {
        let mut s = Step {
            cx: 100.0,
            cy: 100.0,
            calls: 0,
        };
        let e = bracket_transitions(&mut s, &opts(1.0)).unwrap_err();
        assert!(
            matches!(e, CriticalError::NoBracket { side: "above", .. }),
            "{e}"
        );
        let mut s = Step {
            cx: 1e-9,
            cy: 1.0,
            calls: 0,
        };
        let e = bracket_transitions(&mut s, &opts(1.0)).unwrap_err();
        assert!(
            matches!(e, CriticalError::NoBracket { side: "below", .. }),
            "{e}"
        );
    }

    /// Fluid along x stops at 2 and along y at 1, but the first probe wrongly reports y blocked.
    struct Flaky(usize);
    impl Prober for Flaky {
        fn probe(&mut self, load: f64) -> Result<FlowState, CriticalError> {
            self.0 += 1;
            let fx = load < 2.0;
            let fy = load < 1.0 && self.0 != 1;
            Ok(FlowState {
                fluid_x: fx,
                fluid_y: fy,
                blocked_x: !fx,
                blocked_y: !fy,
            })
        }
    }

    #[test]
    fn contradicting_probes_are_reported() {
        let r = bracket_transitions(&mut Flaky(0), &opts(0.5));
        assert!(
            matches!(r, Err(CriticalError::NonMonotone { criterion: "y", .. })),
            "{r:?}"
        );
    }

    #[test]
    fn options_are_checked() {
        let mut s = Step {
            cx: 1.0,
            cy: 1.0,
            calls: 0,
        };
        let mut o = opts(1.0);
        o.rel_width = 0.0;
        let e = bracket_transitions(&mut s, &o).unwrap_err().to_string();
        assert!(e.contains("rel_width") && e.contains("(0, 1)"), "{e}");
        let mut o = opts(20.0);
        o.load_max = 10.0;
        assert!(bracket_transitions(&mut s, &o).is_err());
    }
}
