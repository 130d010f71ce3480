//! Refinement of jumps on quasi-static paths ([`contact::path::Refinement`]): a jump is bracketed
//! to step/2^depth, the planned points are unchanged, deeper refinement nests, and FIRE and
//! nonlinear CG locate the jumps of a Figure 2 path with a resolved cohesive zone alike.

use contact::path::{self, Branch, Control, PathPoint, PathResult, PathSpec, Refinement};
use contact::{Interaction, Lattice, Method, Model, Solution, SolverOptions, Surface};

/// In contact, full contact ([`path::contact_topology`]), fluid percolating along x, along y:
/// what the sweep kind tells jumps by.
fn topology(s: &Solution) -> u64 {
    let mask = s.gap.mapv(|g| g == 0.0);
    let d = percolation::dual_percolation(mask.view());
    path::contact_topology(s)
        | (u64::from(d.fluid_percolates(percolation::Axis::X)) << 2)
        | (u64::from(d.fluid_percolates(percolation::Axis::Y)) << 3)
}

/// Figure 2's adhesive load path on the square model's 32² grid with ρ = 0.1: the cohesive zone
/// ρ²E*/γ0 = 0.05 λ spans 1.6 grid spacings (resolved: [`contact::NCG_MIN_ZONE_SPACINGS`]).
const RHO: f64 = 0.1;
const GAMMA0: f64 = 0.2;
const STEP: f64 = 0.05;

fn run(method: Method, depth: u32) -> (PathResult, Vec<u64>, f64) {
    let s = Surface::new(Lattice::Square, 5).unwrap();
    let mut m = Model::new(&s).unwrap();
    let p_fc = s.p_fc_grid();
    let spec = PathSpec {
        control: Control::Load {
            values: (1..=20).map(|k| STEP * k as f64 * p_fc).collect(),
        },
        reverse: true,
        extension: Vec::new(),
        refine: Refinement {
            depth,
            area_jump: 0.02,
        },
    };
    let opts = SolverOptions {
        method,
        ..Default::default()
    };
    let inter = Interaction::Adhesion {
        gamma0: GAMMA0,
        rho: RHO,
    };
    let mut topo = Vec::new();
    let r = path::run_with(&mut m, inter, &spec, &opts, topology, |_, s| {
        topo.push(topology(s));
        Ok::<(), std::convert::Infallible>(())
    })
    .unwrap();
    assert!(
        r.points.iter().all(|p| p.converged),
        "every point converges"
    );
    (r, topo, STEP * p_fc)
}

/// The planned steps (indices of consecutive planned points) whose states jump (topology or
/// area change > 0.02, the refinement's own test).
fn jumping_steps(r: &PathResult, topo: &[u64]) -> Vec<(usize, usize)> {
    let planned: Vec<usize> = (0..r.points.len())
        .filter(|&k| !r.points[k].refined)
        .collect();
    planned
        .windows(2)
        .filter(|w| {
            let (a, b) = (&r.points[w[0]], &r.points[w[1]]);
            topo[w[0]] != topo[w[1]] || (a.contact_area - b.contact_area).abs() > 0.02
        })
        .map(|w| (w[0], w[1]))
        .collect()
}

/// Each refined jump's bracket: (branch, load before, load after).
fn brackets(r: &PathResult) -> Vec<(Branch, f64, f64)> {
    r.refined_jumps
        .iter()
        .map(|j| {
            let (a, b) = (&r.points[j.before], &r.points[j.after]);
            assert_eq!(j.after, j.before + 1);
            assert!(b.refined || !a.refined || b.step == a.step);
            (b.branch, a.load, b.load)
        })
        .collect()
}

/// Up to the first refined step the planned points are those of the unrefined path (bit-equal
/// areas and energies); the first jumping step gets `depth` midpoints at most and brackets its
/// jump to step/2^depth, and a deeper refinement repeats the shallower one's bisection (same
/// warm starts), so its bracket nests inside; every later refined jump is bracketed to the
/// refined width too.
#[test]
fn jumps_are_bracketed_to_the_refined_width() {
    let (plain, topo0, step) = run(Method::Fire, 0);
    let jumps = jumping_steps(&plain, &topo0);
    assert!(
        jumps.len() >= 2,
        "the path jumps on both branches: {jumps:?}"
    );
    let (r3, _, _) = run(Method::Fire, 3);
    let (r5, _, _) = run(Method::Fire, 5);
    // the first jump of the plain path is the first refined step of the refined ones
    let first = jumps[0].1;
    for r in [&r3, &r5] {
        let planned: Vec<&PathPoint> = r.points.iter().filter(|p| !p.refined).collect();
        assert_eq!(planned.len(), plain.points.len());
        for (a, b) in planned.iter().zip(&plain.points).take(first) {
            assert_eq!(
                (a.load, a.contact_area, a.energy),
                (b.load, b.contact_area, b.energy)
            );
        }
        assert_eq!(
            r.points[r.refined_jumps[0].after].step,
            plain.points[first].step
        );
    }
    let (b3, b5) = (brackets(&r3), brackets(&r5));
    assert!(b3.len() >= 2 && b5.len() >= 2, "{b3:?} {b5:?}");
    // the midpoints halve the step exactly up to rounding of the loads (relative 1e-12)
    let tol = 1e-12 * step;
    for (b, depth) in [(&b3, 3), (&b5, 5)] {
        for (_, lo, hi) in b {
            let width = step / f64::from(1u32 << depth);
            assert!(((hi - lo).abs() - width).abs() < tol, "{lo} {hi}");
        }
    }
    let ((_, lo3, hi3), (_, lo5, hi5)) = (b3[0], b5[0]);
    let (l3, h3) = (lo3.min(hi3), lo3.max(hi3));
    assert!(
        (l3 - tol..=h3 + tol).contains(&lo5) && (l3 - tol..=h3 + tol).contains(&hi5),
        "depth 5 bracket {lo5}..{hi5} inside depth 3's {lo3}..{hi3}"
    );
}

/// With the cohesive zone resolved, FIRE and nonlinear CG bracket every jump of the path at the
/// same refined loads: to within one refined width step/2^4 (the minimisers stop at the same
/// force residual, not at the same state, so a jump sitting exactly on a midpoint may fall on
/// either side of it).
#[test]
fn fire_and_nonlinear_cg_bracket_the_same_jumps() {
    let depth = 4;
    let (fire, _, step) = run(Method::Fire, depth);
    let (ncg, _, _) = run(Method::NonlinearCg, depth);
    let (bf, bn) = (brackets(&fire), brackets(&ncg));
    assert!(!bf.is_empty());
    assert_eq!(bf.len(), bn.len(), "FIRE {bf:?}\nNCG {bn:?}");
    let width = step / f64::from(1u32 << depth);
    for (f, n) in bf.iter().zip(&bn) {
        assert_eq!(f.0, n.0);
        let (mf, mn) = (0.5 * (f.1 + f.2), 0.5 * (n.1 + n.2));
        assert!(
            (mf - mn).abs() <= width * (1.0 + 1e-9),
            "FIRE {f:?} NCG {n:?} (width {width})"
        );
    }
}
