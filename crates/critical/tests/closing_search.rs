//! The p_c search (`critical::refined::find_closing_load`, module docs "The p_c search") on
//! synthetic gap laws: every search returns a valid bracket; the aimed search never takes more
//! probes than bisection from the same start and fewer than the first secant search.
use critical::refined::{RefinedOptions, Search, find_closing_load_seeded};

/// A deterministic pseudo-random number in [−1, 1] for a load (the solver's noise in g: it
/// depends on the load and the warm start; a hash of the load's bits stands in for both).
fn noise(p: f64) -> f64 {
    let mut x = p.to_bits() ^ 0x9e37_79b9_7f4a_7c15;
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
    x ^= x >> 33;
    x = x.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    x ^= x >> 33;
    (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

const PC: f64 = 0.2286050839617;

/// The gap laws g(δ), δ = 1 − p/p_c: pure power laws a = 1 … 1.3 (prefactor 0.37 p_c: the
/// square model's measured affine slope, 64² base, k = 3), a power law turning affine below
/// 1e-6 (a discretisation's frozen contact set), and one with the solver's noise on top.
fn laws() -> Vec<(String, Box<dyn Fn(f64) -> f64>)> {
    let mut v: Vec<(String, Box<dyn Fn(f64) -> f64>)> = Vec::new();
    for a in [1.0, 1.1, 1.2, 1.3] {
        v.push((
            format!("power a = {a}"),
            Box::new(move |d: f64| 0.37 * d.powf(a)),
        ));
    }
    v.push((
        "1.2 with correction".into(),
        Box::new(|d: f64| 0.37 * d.powf(1.2) * (1.0 + 4.0 * d.powf(0.3))),
    ));
    let affine = |d: f64| {
        let s = 1e-6f64;
        if d < s {
            0.37 * d * s.powf(0.2)
        } else {
            0.37 * d.powf(1.2)
        }
    };
    v.push(("affine below 1e-6".into(), Box::new(affine)));
    v
}

struct Case {
    /// Relative offset of the guess from p_c.
    offset: f64,
    width: f64,
    /// A warm-up solve 1 % below the guess given as a seed.
    seeded: bool,
}

const CASES: [Case; 4] = [
    // the first D: the periodic base grid's p_c, 3e-5 above (256² base), width 2e-4
    Case {
        offset: 3e-5,
        width: 2e-4,
        seeded: true,
    },
    // the next D from the previous D's p_c (256² base: 3.8e-7 either way), width 2e-6
    Case {
        offset: 3.8e-7,
        width: 2e-6,
        seeded: true,
    },
    Case {
        offset: -3.8e-7,
        width: 2e-6,
        seeded: true,
    },
    // a miss: the guess further off than the width (the search steps down)
    Case {
        offset: 5e-6,
        width: 2e-6,
        seeded: true,
    },
];

/// (probes, lo, hi) of one search on `g` (g(p) > 0 open).
fn search(
    g: &dyn Fn(f64) -> f64,
    case: &Case,
    method: Search,
    noise_gap: f64,
) -> (usize, f64, f64) {
    let opts = RefinedOptions {
        search: method,
        tol_gap: noise_gap.max(1e-13),
        ..Default::default()
    };
    let guess = PC * (1.0 + case.offset);
    let gap = |p: f64| g(p) + noise_gap * noise(p);
    let p0 = guess * (1.0 - case.width.max(1e-2));
    let seed = if case.seeded {
        vec![(p0, gap(p0))]
    } else {
        vec![]
    };
    let c = find_closing_load_seeded(&mut |p| Ok(gap(p)), guess, case.width, &seed, &opts).unwrap();
    assert!(
        c.lo < c.hi && c.hi / c.lo - 1.0 <= opts.rel_tol,
        "{method:?}: {c:?}"
    );
    assert!(gap(c.lo) > 0.0 && gap(c.hi) <= 0.0, "{method:?}: {c:?}");
    (c.probes, c.lo, c.hi)
}

#[test]
fn aimed_search_counts() {
    let mut total = [0usize; 3];
    for (name, law) in laws() {
        let g = |p: f64| if p < PC { law(1.0 - p / PC) } else { 0.0 };
        for case in &CASES {
            let mut n = [0; 3];
            for (i, m) in [Search::Aimed, Search::Secant, Search::Bisection]
                .into_iter()
                .enumerate()
            {
                let (k, lo, hi) = search(&g, case, m, 0.0);
                assert!(lo < PC && PC <= hi, "{name} {m:?}: [{lo}, {hi}]");
                n[i] = k;
                total[i] += k;
            }
            eprintln!(
                "{name:>22}, offset {:+.1e} width {:.0e}: aimed {} secant {} bisection {}",
                case.offset, case.width, n[0], n[1], n[2]
            );
        }
    }
    eprintln!("total {total:?}");
}

#[test]
fn debug_trace() {
    for (name, law) in laws().into_iter().skip(4).take(1) {
        for case in [&CASES[0], &CASES[1]] {
            let guess = PC * (1.0 + case.offset);
            let g = |p: f64| if p < PC { law(1.0 - p / PC) } else { 0.0 };
            let p0 = guess * (1.0 - case.width.max(1e-2));
            let opts = RefinedOptions::default();
            eprintln!("== {name} {:e}", case.offset);
            let c = find_closing_load_seeded(
                &mut |p| {
                    let v = g(p);
                    eprintln!("  δ {:+.4e} g {:.3e}", 1.0 - p / PC, v);
                    Ok(v)
                },
                guess,
                case.width,
                &[(p0, g(p0))],
                &opts,
            )
            .unwrap();
            eprintln!("  {c:?}");
        }
    }
}
