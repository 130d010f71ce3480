//! The last constriction and β on an ensemble of isotropic self-affine surfaces (issue 15, draft
//! ensemble): per seed L_c, a_p, the constriction (position, gap, η of heights and of the gap),
//! the pressure-drop fraction at it just below L_c, β (window fit and running values); then the
//! ensemble mean ± standard error (and sd), and the correlation of β with η. One JSON line per
//! seed on stdout, then a summary line; progress on stderr.
//!
//! ```sh
//! cargo run --release -p critical --example random_constrictions -- N SEED_FIRST SEED_LAST \
//!     [D_MIN [MIN_WIDTH [Q_S [SUB [HURST]]]]]
//! ```
//! `SUB` > 0: the surface generated on 2^N × 2^N is sampled at every 2^SUB-th node (the same
//! continuum surface on a coarser grid while q_s stays below the coarse Nyquist wavenumber): a
//! resolution study of β on the same surfaces.
//! H = HURST (default 0.8), q_r = 2, q_s = Q_S (default 64; units of 2π/L), rms slope 1, exact amplitudes, periodic; L_c to
//! 1e-9 relative; ladder 5e-2 … D_MIN (1-2-5, default 1e-4); rungs with a throat narrower than
//! MIN_WIDTH nodes (default 2) are not used.

use critical::constriction::{ConstrictionOptions, constriction_study, ladder_125};
use surface::Amplitudes;

mod common;
use analysis::sample::{mean_sd_sem, pearson};
use common::{EnsembleSurface, Positional};

fn j(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        "null".into()
    }
}

fn main() {
    let args = Positional::from_env();
    let (n, seeds) = args.grid_and_seeds("9");
    let d_min: f64 = args.get(3, "1e-4", "D_MIN");
    let min_width: usize = args.get(4, "2", "MIN_WIDTH");
    let q_s: f64 = args.get(5, "64", "Q_S");
    let sub: u32 = args.get(6, "0", "SUB");
    let hurst: f64 = args.get(7, "0.8", "HURST");
    let opts = ConstrictionOptions {
        ladder: ladder_125(5e-2, d_min),
        min_width,
        ..Default::default()
    };
    let surfaces = EnsembleSurface {
        n,
        hurst,
        q_s,
        amplitudes: Amplitudes::Exact,
        sub,
    };
    let t0 = std::time::Instant::now();
    let mut rows: Vec<[f64; 6]> = Vec::new(); // a_p, eta_h, eta_g, beta, beta_err, drop
    for seed in seeds {
        let field = surfaces.generate(seed);
        let s = match constriction_study(&field, &opts) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("seed {seed}: {e}");
                continue;
            }
        };
        let c = s.at_l_c.constriction.as_ref();
        let eta_h = c.and_then(|c| c.height).map_or(f64::NAN, |h| h.eta);
        let eta_g = c.and_then(|c| c.gap_curvature).map_or(f64::NAN, |g| g.eta);
        let drop = s.at_l_c.drop.unwrap_or(f64::NAN);
        let (beta, beta_err, pts) = s
            .beta_fit
            .map_or((f64::NAN, f64::NAN, 0), |f| (f.value, f.error, f.points));
        let running: Vec<String> = s
            .running_beta
            .iter()
            .map(|r| format!("[{}, {}, {}]", r.l_hi.abs(), r.l_lo.abs(), j(r.value)))
            .collect();
        let rungs: Vec<String> = s
            .rungs
            .iter()
            .map(|r| {
                let c = r.constriction.as_ref();
                format!(
                    "{{\"d\": {}, \"flux\": {}, \"gap\": {}, \"node\": {}, \"width\": {}, \"drop\": {}, \"resolved\": {}}}",
                    r.d,
                    j(r.flux),
                    j(c.map_or(f64::NAN, |c| c.gap)),
                    c.map_or("null".into(), |c| format!("[{}, {}]", c.node.0, c.node.1)),
                    c.map_or(0, |c| c.width_nodes),
                    j(r.drop.unwrap_or(f64::NAN)),
                    r.resolved
                )
            })
            .collect();
        println!(
            "{{\"n\": {n}, \"sub\": {sub}, \"hurst\": {hurst}, \"q_s\": {q_s}, \"seed\": {seed}, \"l_c\": {}, \"l_c_over_p_fc\": {}, \"a_p_raw\": {}, \
             \"axis\": \"{:?}\", \"node\": {}, \"constriction_gap\": {}, \"eta_height\": {}, \"eta_gap\": {}, \
             \"drop_at_l_c\": {}, \"beta\": {}, \"beta_err\": {}, \"beta_points\": {pts}, \
             \"gap_exponent\": {}, \"running_beta\": [{}], \"rungs\": [{}], \"wall_s\": {}}}",
            s.l_c,
            s.l_c / s.p_fc,
            s.a_p_raw,
            s.axis,
            c.map_or("null".into(), |c| format!("[{}, {}]", c.node.0, c.node.1)),
            j(c.map_or(f64::NAN, |c| c.gap)),
            j(eta_h),
            j(eta_g),
            j(drop),
            j(beta),
            j(beta_err),
            j(s.gap_fit.map_or(f64::NAN, |f| f.value)),
            running.join(", "),
            rungs.join(", "),
            s.wall_s
        );
        eprintln!(
            "seed {seed}: L_c/p_fc = {:.5}, a_p = {:.4}, η_h = {eta_h:.3}, drop = {drop:.3}, β = {beta:.3} ± {beta_err:.3} ({pts} rungs), {:.0} s",
            s.l_c / s.p_fc,
            s.a_p_raw,
            s.wall_s
        );
        rows.push([s.a_p_raw, eta_h, eta_g, beta, beta_err, drop]);
    }
    let col = |k: usize| -> Vec<f64> {
        rows.iter()
            .map(|r| r[k])
            .filter(|v| v.is_finite())
            .collect()
    };
    let stat = |k: usize| {
        let v = col(k);
        let (m, sd, e, count) = mean_sd_sem(&v);
        format!("[{}, {}, {}, {count}]", j(m), j(e), j(sd))
    };
    let both: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r[1].is_finite() && r[3].is_finite())
        .map(|r| (r[1].ln(), r[3]))
        .collect();
    let (x, y): (Vec<f64>, Vec<f64>) = both.iter().copied().unzip();
    let corr = if x.len() > 2 {
        pearson(&x, &y)
    } else {
        f64::NAN
    };
    println!(
        "{{\"summary\": true, \"n\": {n}, \"seeds\": {}, \"stat\": \"[mean, sem, sd, count]\", \"a_p_raw\": {}, \
         \"eta_height\": {}, \"eta_gap\": {}, \"beta\": {}, \"drop_at_l_c\": {}, \
         \"corr_beta_ln_eta_height\": {}, \"wall_s\": {}}}",
        rows.len(),
        stat(0),
        stat(1),
        stat(2),
        stat(3),
        stat(5),
        j(corr),
        t0.elapsed().as_secs_f64()
    );
}
