//! The conjugate direction of the original method (Polonsky & Keer 1999): conjugate gradients on
//! the gap itself, t = g + β t_old on the contact set S, with β = Σ_S g²/Σ_S g_old². One
//! transform pair per iteration (r = G t, built as the transform reads t).

use super::passes::{L, line_row};
use super::{Conjugacy, Direction};
use crate::compliance::Compliance;

/// The direction t on S (0 off it), r = G t and the line-search sums. `norm` = Σ_S g² of this
/// iteration's gap g = σU − h − shift, `count` = |S|, `m` the mean of the old direction on S
/// (removed so that Σ_S t = 0 and the step keeps the load).
#[allow(clippy::too_many_arguments)]
pub(super) fn direction<K: Compliance>(
    kernel: &mut K,
    t: &mut [f64],
    r: &mut [f64],
    (u, p, h): (&[f64], &[f64], &[f64]),
    (sigma, shift): (f64, f64),
    (norm, count, m): (f64, f64, f64),
    cg: &mut Conjugacy,
) -> Direction {
    let (_, ny) = kernel.shape();
    // (g_old = 0 when the gap was exactly uniform on the contact set, e.g. a single node)
    let beta = cg.beta(norm);
    let ([st, sgt, _, _], _, [sr, srt, _, _]) = kernel.apply_fused(
        false,
        t,
        |i, t| {
            let o = i * ny..(i + 1) * ny;
            direction_row(
                t,
                &u[o.clone()],
                &p[o.clone()],
                &h[o],
                sigma,
                shift,
                beta,
                m,
            )
        },
        Some(r),
        |i, t, r| line_row(r, t, &p[i * ny..(i + 1) * ny]),
    );
    Direction {
        st,
        sgt,
        sr,
        srt,
        free_count: count,
    }
}

/// Pass B over one row: the conjugate direction (true units) t = g + β (t − m) on S, 0 off it,
/// with g = σU − h − shift and m the mean of the old t on S (so that Σ_S t = 0 and the step
/// keeps the load); returns Σ t and Σ g t.
#[allow(clippy::too_many_arguments)]
fn direction_row(
    t: &mut [f64],
    u: &[f64],
    p: &[f64],
    h: &[f64],
    sigma: f64,
    shift: f64,
    beta: f64,
    m: f64,
) -> [f64; 4] {
    let (mut st, mut sgt) = ([0.0; L], [0.0; L]);
    let node =
        |l: usize, t: &mut f64, u: f64, p: f64, h: f64, st: &mut [f64; L], sgt: &mut [f64; L]| {
            let g = sigma * u - h - shift;
            let tj = if p > 0.0 { g + beta * (*t - m) } else { 0.0 };
            *t = tj;
            st[l] += tj;
            sgt[l] += g * tj;
        };
    let mut tc = t.chunks_exact_mut(L);
    let (mut uc, mut pc, mut hc) = (u.chunks_exact(L), p.chunks_exact(L), h.chunks_exact(L));
    for (((t, u), p), h) in (&mut tc).zip(&mut uc).zip(&mut pc).zip(&mut hc) {
        for l in 0..L {
            node(l, &mut t[l], u[l], p[l], h[l], &mut st, &mut sgt);
        }
    }
    let (t, u, p, h) = (
        tc.into_remainder(),
        uc.remainder(),
        pc.remainder(),
        hc.remainder(),
    );
    for l in 0..t.len() {
        node(l, &mut t[l], u[l], p[l], h[l], &mut st, &mut sgt);
    }
    [st.iter().sum(), sgt.iter().sum(), 0.0, 0.0]
}
