//! The refined ζ ladder (`critical::refined`) on tiny grids: p_c(D) against the uniform fine
//! grid, the secant search against bisection, a too-small window flagged, running ζ of known
//! data.
use contact::refinement::EdgeRuns;
use critical::ladder::axis_saddle;
use critical::refined::{
    Discretisation, PairFlag, RefinedOptions, RefinedRung, Refinement, RungFlag, Search,
    find_closing_load, periodic_closing_load, running_zeta,
};
use surface::{Lattice, Surface};

fn d(base_log2: u32, window: usize, margin: usize) -> Discretisation {
    Discretisation {
        lattice: Lattice::Square,
        base_log2,
        levels: 2,
        window,
        margin,
    }
}

/// The secant search finds the closing load of known gap laws to the tolerance, in fewer probes
/// than bisection: a power law with a correction (exponent 1.2 → 1.5 far out) and one that
/// turns affine near p_c (the frozen contact set of a discretisation).
#[test]
fn the_secant_search_finds_known_closing_loads() {
    let pc = 0.7312345678901;
    type Law = fn(f64) -> f64;
    let laws: [(&str, Law); 2] = [
        ("power law with correction", |d| {
            1.3 * d.powf(1.2) * (1.0 + 4.0 * d.powf(0.3))
        }),
        ("affine below 1e-6", |d| {
            if d < 1e-6 {
                0.8 * d * 1e-6f64.powf(0.2)
            } else {
                0.8 * d.powf(1.2)
            }
        }),
    ];
    for (name, law) in laws {
        let mut counts = Vec::new();
        for search in [Search::Secant, Search::Bisection] {
            let opts = RefinedOptions {
                search,
                ..Default::default()
            };
            let c = find_closing_load(
                &mut |p| Ok(if p < pc { law(1.0 - p / pc) } else { 0.0 }),
                pc * (1.0 + 3e-4),
                1e-3,
                &opts,
            )
            .unwrap();
            assert!(c.lo < pc && pc <= c.hi, "{name} {search:?}: {c:?}");
            assert!(c.hi / c.lo - 1.0 <= 1e-11, "{name}: {c:?}");
            counts.push(c.probes);
        }
        eprintln!(
            "{name}: probes secant {}, bisection {}",
            counts[0], counts[1]
        );
        assert!(
            (counts[0] as f64) < 0.6 * counts[1] as f64,
            "{name}: {counts:?}"
        );
    }
}

/// p_c(D) of the 64² base refined twice in a window of 16² base cells (margin 8) against the
/// uniform 256² grid's closing load, and the secant against bisection on D itself.
#[test]
fn refined_p_c_matches_the_uniform_fine_grid_and_bisection() {
    let fine = Surface::new(Lattice::Square, 8).unwrap();
    let frame = axis_saddle(&fine).unwrap();
    let opts = RefinedOptions::default();
    let uni = periodic_closing_load(&fine, &frame, None, &opts).unwrap();
    let coarse = Surface::new(Lattice::Square, 6).unwrap();
    let cf = axis_saddle(&coarse).unwrap();
    let base = periodic_closing_load(&coarse, &cf, None, &opts).unwrap();
    let mut r = Refinement::new(d(6, 16, 8), &opts).unwrap();
    let sec = r.critical_load(Some(base.p_c()), 1e-3).unwrap();
    let mut rb = Refinement::new(
        d(6, 16, 8),
        &RefinedOptions {
            search: Search::Bisection,
            ..opts.clone()
        },
    )
    .unwrap();
    let bis = rb.critical_load(Some(base.p_c()), 1e-3).unwrap();
    let rel = |a: f64| a / uni.p_c() - 1.0;
    eprintln!(
        "p_c rel to uniform 256²: refined {:+.3e} (secant {} probes, bisection {} probes, differ {:.2e}), base 64² {:+.3e}",
        rel(sec.p_c()),
        sec.probes,
        bis.probes,
        sec.p_c() / bis.p_c() - 1.0,
        rel(base.p_c())
    );
    assert!((sec.p_c() / bis.p_c() - 1.0).abs() < 1e-10);
    assert!(sec.probes < bis.probes);
    assert!(rel(sec.p_c()).abs() < rel(base.p_c()).abs());
    assert!(rel(sec.p_c()).abs() < TOL_PC, "{:e}", rel(sec.p_c()));
}

/// Tolerance of p_c(D) against the uniform fine grid (relative). Measured here: +5.4e-6 (the
/// composite discretisation's floor on a 64² base, +6.1e-6 in `contact::refinement`'s docs,
/// plus the blockwise far field's −7e-7 at margin 8); the base grid alone is +3.0e-4. 1.5e-5
/// is that floor with a factor ~2.5, and 20× below the base grid's error, so a refinement that
/// stops working fails.
const TOL_PC: f64 = 1.5e-5;

/// A window of 2² base cells near percolation is flagged (its edge lies in the open channel
/// or cuts the neck); one of 8² is not at l = −2e-2 … −5e-3.
#[test]
fn a_too_small_window_is_flagged() {
    let opts = RefinedOptions {
        rel_tol: 1e-8,
        ..Default::default()
    };
    let mut flags = Vec::new();
    for (w, m) in [(2, 8), (8, 8)] {
        let mut r = Refinement::new(d(5, w, m), &opts).unwrap();
        let pc = r
            .critical_load(Some(0.2286 * r.p_fc()), 1e-2)
            .unwrap()
            .p_c();
        let rungs = r
            .ladder(pc, &[-2e-2, -1e-2, -5e-3], &mut |_, _| {})
            .unwrap();
        for g in &rungs {
            eprintln!(
                "window {w}: l {:e} edge {:?} flag {:?}",
                g.l, g.edge, g.flag
            );
        }
        flags.push(rungs.iter().map(|g| g.flag.is_some()).collect::<Vec<_>>());
    }
    assert_eq!(flags[0], [true, true, true]);
    assert_eq!(flags[1], [false, false, false]);
}

fn rung(l: f64, g: f64, hash: u64, flag: Option<RungFlag>) -> RefinedRung {
    RefinedRung {
        l,
        load: 1.0 + l,
        saddle_gap: g,
        contact_area: 0.5,
        iterations: 1,
        wall_s: 0.0,
        edge: EdgeRuns {
            crossings: 4,
            narrowest_open: Some(3.0),
            narrowest_contact: Some(3.0),
            all_contact: false,
        },
        window_contact: hash as usize,
        neck_nodes: 10,
        contact_hash: hash,
        flag,
    }
}

/// Running ζ of a known power law is its exponent; the grid errors are the changes of the
/// comparison ladders' slopes; flagged and frozen rungs flag their pairs.
#[test]
fn running_zeta_of_known_data() {
    let ls = [-1e-2, -5e-3, -2e-3, -1e-3];
    let fine: Vec<RefinedRung> = ls
        .iter()
        .enumerate()
        .map(|(k, &l)| rung(l, 0.7 * l.abs().powf(1.2), k as u64, None))
        .collect();
    // coarser: exponent 1.203; margin: 1.199 and the last rung frozen
    let coarser: Vec<RefinedRung> = ls
        .iter()
        .enumerate()
        .map(|(k, &l)| rung(l, 0.7 * l.abs().powf(1.203), k as u64, None))
        .collect();
    let margin: Vec<RefinedRung> = ls
        .iter()
        .enumerate()
        .map(|(k, &l)| rung(l, 0.7 * l.abs().powf(1.199), k.min(2) as u64, None))
        .collect();
    let z = running_zeta(&fine, Some(&coarser), Some(&margin), 0.0035, 1e-13);
    assert_eq!(z.len(), 3);
    for s in &z[..2] {
        assert!((s.value - 1.2).abs() < 1e-12, "{s:?}");
        assert!((s.error_levels - 0.003).abs() < 1e-12);
        assert!((s.error_margin - 0.001).abs() < 1e-12);
        assert!((s.grid_error - 0.003).abs() < 1e-12 && s.flag.is_none());
    }
    // the margin ladder's last pair is frozen: not a comparison, so the grid error is unknown
    assert!(z[2].error_margin.is_nan() && z[2].flag == Some(PairFlag::Unknown));
    // a frozen or flagged rung of the finest ladder flags its pairs
    let mut f2 = fine.clone();
    f2[3].contact_hash = f2[2].contact_hash;
    f2[0].flag = Some(RungFlag::NotConverged);
    let z = running_zeta(&f2, Some(&coarser), Some(&coarser), 0.0035, 1e-13);
    assert!(matches!(z[0].flag, Some(PairFlag::Rung(l, _)) if l == -1e-2));
    assert_eq!(z[2].flag, Some(PairFlag::Frozen));
    // the bound: 0.003 > 0.002 flags
    let z = running_zeta(&fine, Some(&coarser), Some(&coarser), 0.002, 1e-13);
    assert!(matches!(z[0].flag, Some(PairFlag::GridError { .. })));
}
