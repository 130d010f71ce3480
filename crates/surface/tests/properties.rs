//! Every entry of PHYSICS.md's property table, computed from the sampled surfaces and from the
//! exact critical points, against the closed forms.

use surface::{CriticalKind, Grid, Lattice, Surface};

/// The sampled moments of a trigonometric polynomial are exact (to rounding) once the grid
/// resolves the product of four modes: on 2^5 nodes the fourth moment's highest harmonic (4 × 2
/// waves per cell along each axis) lies below the Nyquist index, so the tolerance is rounding only.
const EXACT: f64 = 1e-12;

#[test]
fn sampled_moments_match_the_property_table() {
    for l in Lattice::ALL {
        let s = Surface::new(l, 5).unwrap();
        let st = s.statistics();
        let ex = l.exact();
        assert!(
            (st.mean - ex.mean).abs() < EXACT,
            "{l} mean {} vs {}",
            st.mean,
            ex.mean
        );
        assert!((st.rms - 1.0).abs() < EXACT, "{l} rms {}", st.rms);
        assert!(
            (st.skewness - ex.skewness).abs() < EXACT,
            "{l} skewness {}",
            st.skewness
        );
        assert!(
            (st.excess_kurtosis - ex.excess_kurtosis).abs() < EXACT,
            "{l} kurtosis {}",
            st.excess_kurtosis
        );
    }
}

#[test]
#[allow(clippy::approx_constant)] // the table's printed digits, not 2π
fn paper_values_of_skewness_kurtosis_and_extrema() {
    let s23 = (2.0f64 / 3.0).sqrt();
    let table = [
        // lattice, max, mean = trough depth, saddle height, skewness, excess kurtosis, p_fc, eta
        (
            Lattice::Hexagonal,
            3.6742,
            2.4495,
            3.2660,
            -s23,
            -0.5,
            7.69530,
            3.0,
        ),
        (Lattice::Square, 4.0, 2.0, 2.0, 0.0, -0.75, 6.28319, 1.0),
        (
            Lattice::Triangular,
            3.6742,
            1.2247,
            0.4082,
            s23,
            -0.5,
            3.84765,
            1.0 / 3.0,
        ),
    ];
    for (l, max, mean, saddle, skew, kurt, p_fc, eta) in table {
        let ex = l.exact();
        // The table prints 4–6 significant digits.
        assert!((ex.max - max).abs() < 1e-4, "{l} max");
        assert!(
            (ex.mean - mean).abs() < 1e-4 && (ex.trough_depth - mean).abs() < 1e-4,
            "{l} mean"
        );
        assert!(
            (ex.saddle_height - saddle).abs() < 1e-4,
            "{l} saddle height"
        );
        assert!((ex.skewness - skew).abs() < 1e-12 && (ex.excess_kurtosis - kurt).abs() < 1e-12);
        assert!((ex.p_fc - p_fc).abs() < 1e-5, "{l} p_fc {}", ex.p_fc);
        assert!((ex.eta - eta).abs() < 1e-12, "{l} eta");
    }
}

#[test]
fn critical_points_have_the_documented_positions_heights_and_curvature_ratio() {
    let r3 = 3f64.sqrt();
    for l in Lattice::ALL {
        let s = Surface::new(l, 6).unwrap();
        let cps = s.critical_points();
        let count = |k| cps.iter().filter(|p| p.kind == k).count();
        let (nmax, nmin, nsad) = (
            count(CriticalKind::Maximum),
            count(CriticalKind::Minimum),
            count(CriticalKind::Saddle),
        );
        // A Morse function on the torus: #max − #saddle + #min = 0.
        assert_eq!(nmax + nmin, nsad, "{l}: Euler characteristic");
        let ex = l.exact();
        let (expect_max, expect_min, expect_sad) = match l {
            Lattice::Square => (1, 1, 2),
            Lattice::Triangular => (4, 8, 12),
            Lattice::Hexagonal => (8, 4, 12),
        };
        assert_eq!(
            (nmax, nmin, nsad),
            (expect_max, expect_min, expect_sad),
            "{l}"
        );
        for p in &cps {
            match p.kind {
                CriticalKind::Maximum => assert!((p.height - ex.max).abs() < 1e-10, "{l} {p:?}"),
                CriticalKind::Minimum => assert!(p.height.abs() < 1e-10, "{l} {p:?}"),
                CriticalKind::Saddle => {
                    assert!((p.height - ex.saddle_height).abs() < 1e-10, "{l} {p:?}");
                    assert!((p.eta().unwrap() - ex.eta).abs() < 1e-10, "{l} eta {p:?}");
                }
            }
        }
        // Documented positions (PHYSICS.md) are among those found.
        let has = |kind, x: f64, y: f64| {
            cps.iter()
                .any(|p| p.kind == kind && (p.x - x).abs() < 1e-9 && (p.y - y).abs() < 1e-9)
        };
        match l {
            Lattice::Square => {
                assert!(has(CriticalKind::Maximum, 0.0, 0.0));
                assert!(has(CriticalKind::Minimum, 0.5, 0.5));
                assert!(has(CriticalKind::Saddle, 0.5, 0.0) && has(CriticalKind::Saddle, 0.0, 0.5));
            }
            Lattice::Triangular | Lattice::Hexagonal => {
                let (hi, lo) = if l == Lattice::Triangular {
                    (CriticalKind::Maximum, CriticalKind::Minimum)
                } else {
                    (CriticalKind::Minimum, CriticalKind::Maximum)
                };
                assert!(
                    has(hi, 0.0, 0.0) && has(hi, 1.0 / r3, 1.0),
                    "{l} maxima of h_t"
                );
                assert!(
                    has(lo, 1.0 / r3, 1.0 / 3.0) && has(lo, 0.0, 2.0 / 3.0),
                    "{l} minima of h_t"
                );
                assert!(has(CriticalKind::Saddle, 1.0 / r3, 0.0));
                assert!(has(CriticalKind::Saddle, 0.5 / r3, 0.5));
            }
        }
    }
}

#[test]
fn every_saddle_falls_on_a_grid_node_for_power_of_two_grids() {
    for l in Lattice::ALL {
        for n in [3, 4, 7] {
            let g = Grid::new(l, n).unwrap();
            let s = Surface::on_grid(l, g);
            for p in s
                .critical_points()
                .iter()
                .filter(|p| p.kind == CriticalKind::Saddle)
            {
                let fi = p.x / g.dx();
                let fj = p.y / g.dy();
                assert!(
                    (fi - fi.round()).abs() < 1e-9 && (fj - fj.round()).abs() < 1e-9,
                    "{l} n={n} {p:?}"
                );
            }
        }
    }
}

#[test]
fn grid_full_contact_pressure_is_the_continuum_value_where_the_trough_is_on_the_grid() {
    // Square and hexagonal troughs sit on nodes: the grid p_fc equals π t̄ exactly.
    for l in [Lattice::Square, Lattice::Hexagonal] {
        let s = Surface::new(l, 4).unwrap();
        assert!((s.p_fc_grid() - l.exact().p_fc).abs() < 1e-12, "{l}");
    }
    // The triangular troughs (y = λ/3) fall between nodes: the grid value is smaller and converges.
    let d = |n| {
        Lattice::Triangular.exact().p_fc - Surface::new(Lattice::Triangular, n).unwrap().p_fc_grid()
    };
    assert!(d(4) > 0.0 && d(6) > 0.0 && d(6) < d(4));
}
