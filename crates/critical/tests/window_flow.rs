//! The flow through a locally refined saddle against the uniform fine grid, each discretisation
//! at its own p_c (square model, 64² base refined ×4 in a 16² region, against the uniform 256²
//! solve; `critical::window_flow::compare`). About 6 s in release mode.
//!
//! Measured (2026-11-25) at l = −1e-2, −5e-3, −2e-3, −1e-3, −5e-4:
//! - saddle gap, refined against uniform: +2.9e-3, +1.0e-3, +9.5e-4, +1.7e-3, +2.0e-3;
//! - K, refined composite against uniform: +8.4e-3, +2.9e-3, +2.8e-3, +5.2e-3, +6.6e-3, i.e.
//!   2.9–3.2 times the gap's error (K ∝ g_s^(β/ζ) with β/ζ ≈ 3): the flow adds no error of its
//!   own; the base grid alone: −0.11, −0.35, −0.48, −0.47, −0.35;
//! - the series replacement applied to the uniform solution itself (the flow method's own
//!   error): −1.2e-5, −1.3e-6, −5.8e-8, −4.6e-9, −3.0e-10;
//! - β_eff between neighbours, refined minus uniform: +7.9e-3, +1.4e-4, −3.5e-3, −1.9e-3 (base
//!   alone +0.45, +0.24, −0.03, −0.29).

use critical::window_flow::{CompareOptions, compare, running};

#[test]
fn the_refined_flux_follows_the_uniform_fine_grid() {
    let o = CompareOptions {
        base_n: 6,
        levels: 2,
        region: 16,
        trim_along: 4,
        trim_across: 1,
        ..CompareOptions::default()
    };
    let c = compare(&o).unwrap();
    let pc_u = c.pc_uniform.unwrap();
    // p_c of the composite contact discretisation: +6.1e-6 (contact::refinement's docs)
    assert!((c.pc_refined / pc_u - 1.0).abs() < 2e-5, "{c:?}");
    let mut ratio_max: f64 = 0.0;
    for r in &c.rows {
        let (k_u, g_u) = (r.k_uniform.unwrap(), r.gap_uniform.unwrap());
        let e_k = r.refined.conductivity / k_u - 1.0;
        let e_g = r.gap_refined / g_u - 1.0;
        let e_method = r.k_uniform_windowed.unwrap() / k_u - 1.0;
        let e_base = r.refined.conductivity_coarse / k_u - 1.0;
        eprintln!(
            "l = {:e}: gap {e_g:+.2e}, K {e_k:+.2e}, method {e_method:+.2e}, base alone {e_base:+.2e}",
            r.l
        );
        // the contact gap's error carried by K ∝ g_s^3 (measured ≤ 8.4e-3; 3.2 × the gap's)
        assert!(e_k.abs() < 1.5e-2, "l = {}: K error {e_k}", r.l);
        ratio_max = ratio_max.max(e_k.abs() / e_g.abs());
        // the flow method alone (measured 1.2e-5 at l = −1e-2, falling ~|l|^3)
        assert!(e_method.abs() < 3e-5 * (r.l / -1e-2).powi(2), "l = {}", r.l);
        // the refinement matters: the base grid alone is 10× further off (measured ≥ 0.11)
        assert!(
            e_base.abs() > 10.0 * e_k.abs(),
            "l = {}: base {e_base}",
            r.l
        );
    }
    // K ∝ g_s^(β/ζ), β/ζ ≈ 3: measured ratios 2.9–3.2
    assert!(ratio_max < 4.0, "K error / gap error up to {ratio_max}");
    let ls: Vec<f64> = c.rows.iter().map(|r| r.l).collect();
    let k_u: Vec<f64> = c.rows.iter().map(|r| r.k_uniform.unwrap()).collect();
    let k_r: Vec<f64> = c.rows.iter().map(|r| r.refined.conductivity).collect();
    for ((b_u, b_r), l) in running(&ls, &k_u).iter().zip(running(&ls, &k_r)).zip(&ls) {
        eprintln!("β_eff from l = {l:e}: uniform {b_u:.5}, refined {b_r:.5}");
        // measured ≤ 7.9e-3
        assert!((b_r - b_u).abs() < 1.5e-2, "l = {l}: {b_r} vs {b_u}");
    }
}
