//! The conjugate direction of the preconditioned method (Vollebregt 2014): the gradient on the
//! free set F (the contact set and the nodes the last step found penetrating) is mapped by the
//! stiffness K = G⁻¹, z = K g_F, restricted to F with its mean removed, and conjugated with
//! β = ⟨g, z⟩/⟨g_old, z_old⟩. Two transform pairs per iteration: z = K g_F (with ⟨g, z⟩ from
//! Parseval), then r = G t.

use super::passes::{L, free, line_row};
use super::{Conjugacy, Direction};
use crate::compliance::Compliance;

/// The direction t on F (0 off it), r = G t and the line-search sums, with z the buffer of
/// K g_F; `m` is the mean of the old direction on the contact set.
#[allow(clippy::too_many_arguments)]
pub(super) fn direction<K: Compliance>(
    kernel: &mut K,
    z: &mut [f64],
    t: &mut [f64],
    r: &mut [f64],
    (u, p, h): (&[f64], &[f64], &[f64]),
    (sigma, shift): (f64, f64),
    m: f64,
    weights: Option<&[f64]>,
    cg: &mut Conjugacy,
) -> Direction {
    let (_, ny) = kernel.shape();
    if let Some(w) = weights {
        return direction_weighted(kernel, z, t, r, (u, p, h), (sigma, shift), w, cg);
    }
    // z = K g on the free set F (g zero off it), and δ = ⟨g, z − m_z⟩_F from Parseval.
    let ([sg_t, sg, free_count, _], quadratic, [sz, _, _, _]) =
        stiffness_of_gap(kernel, z, t, (u, p, h), sigma, shift);
    let mz = sz / free_count;
    let delta = quadratic - mz * sg;
    let beta = cg.beta(delta);
    let zz: &[f64] = z;
    // Σ_F g t = ⟨g, z − m_z⟩ + β ⟨g, t_old − m⟩.
    let sgt = delta + beta * (sg_t - m * sg);
    direction_response(kernel, t, r, p, sgt, free_count, |i, t| {
        let o = i * ny..(i + 1) * ny;
        direction_preconditioned_row(t, &zz[o.clone()], &p[o], mz, beta, m)
    })
}

/// Pass C (the direction t on F, written by `row`, which returns Σ t of its row) fused with the
/// second transform pair, r = G t, and the line-search sums ([`line_row`]): the second half of
/// both directions (unweighted and weighted), `sgt` = Σ_F g t and |F| as they computed them.
fn direction_response<K: Compliance, P>(
    kernel: &mut K,
    t: &mut [f64],
    r: &mut [f64],
    p: &[f64],
    sgt: f64,
    free_count: f64,
    row: P,
) -> Direction
where
    P: Fn(usize, &mut [f64]) -> [f64; 4] + Sync,
{
    let (_, ny) = kernel.shape();
    let ([st, _, _, _], _, [sr, srt, _, _]) =
        kernel.apply_fused(false, t, row, Some(r), |i, t, r| {
            line_row(r, t, &p[i * ny..(i + 1) * ny])
        });
    Direction {
        st,
        sgt,
        sr,
        srt,
        free_count,
    }
}

/// z = K g with g = σU − h − `shift` on the free set F (0 off it), by rows ([`gradient_row`]):
/// returns (Σ g t_old, Σ g, |F|), ⟨g, z⟩ from Parseval, and (Σ_F z) — the first transform pair
/// of both directions (unweighted and weighted).
fn stiffness_of_gap<K: Compliance>(
    kernel: &mut K,
    z: &mut [f64],
    t: &[f64],
    (u, p, h): (&[f64], &[f64], &[f64]),
    sigma: f64,
    shift: f64,
) -> ([f64; 4], f64, [f64; 4]) {
    let (_, ny) = kernel.shape();
    kernel.apply_fused(
        true,
        z,
        |i, row| {
            let o = i * ny..(i + 1) * ny;
            gradient_row(
                row,
                &u[o.clone()],
                &p[o.clone()],
                &h[o.clone()],
                &t[o],
                sigma,
                shift,
            )
        },
        None,
        |i, _, z| [masked_sum(z, &p[i * ny..(i + 1) * ny]), 0.0, 0.0, 0.0],
    )
}

/// Pass B over one row (preconditioned): writes the gap on the free set F (the contact set and
/// the nodes marked penetrating), g = σU − h − shift on F and 0 off it, into `row` (the input
/// of the stiffness transform); returns Σ g t and Σ g for the old direction t, and |F|.
fn gradient_row(
    row: &mut [f64],
    u: &[f64],
    p: &[f64],
    h: &[f64],
    t: &[f64],
    sigma: f64,
    shift: f64,
) -> [f64; 4] {
    let (mut sgt, mut sg, mut count) = ([0.0; L], [0.0; L], [0.0; L]);
    for (k, row) in row.chunks_mut(L).enumerate() {
        for (l, out) in row.iter_mut().enumerate() {
            let j = k * L + l;
            let on = free(p[j]);
            let g = if on { sigma * u[j] - h[j] - shift } else { 0.0 };
            *out = g;
            sgt[l] += g * t[j];
            sg[l] += g;
            count[l] += if on { 1.0 } else { 0.0 };
        }
    }
    [sgt.iter().sum(), sg.iter().sum(), count.iter().sum(), 0.0]
}

/// Σ_F z over one row (F the free set, see [`free`]).
fn masked_sum(z: &[f64], p: &[f64]) -> f64 {
    let mut s = [0.0; L];
    for (k, z) in z.chunks(L).enumerate() {
        for (l, &v) in z.iter().enumerate() {
            s[l] += if free(p[k * L + l]) { v } else { 0.0 };
        }
    }
    s.iter().sum()
}

/// Pass C over one row (preconditioned): the direction t = (z − m_z) + β (t − m) on the free set
/// F, 0 off it, with z = K g the preconditioned gradient and m_z, m the means (so Σ_F t = 0);
/// returns Σ t.
fn direction_preconditioned_row(
    t: &mut [f64],
    z: &[f64],
    p: &[f64],
    mz: f64,
    beta: f64,
    m: f64,
) -> [f64; 4] {
    let mut st = [0.0; L];
    for (k, t) in t.chunks_mut(L).enumerate() {
        for (l, t) in t.iter_mut().enumerate() {
            let j = k * L + l;
            let tj = if free(p[j]) {
                (z[j] - mz) + beta * (*t - m)
            } else {
                0.0
            };
            *t = tj;
            st[l] += tj;
        }
    }
    [st.iter().sum(), 0.0, 0.0, 0.0]
}

/// The direction for unknowns that are forces on unequal areas w (the composite operator):
/// t = Q M Qᵀ g on F with the oblique projector Q = I − w 1ᵀ/Σ_F w onto Σ_F t = 0, i.e. the
/// gap's w-weighted mean on F removed before the stiffness (Qᵀ g = g − c, a uniform gap) and the
/// net force of z = M Qᵀ g removed as a uniform *pressure* (force ∝ w) after it; the old
/// direction likewise. Q M Qᵀ is symmetric, so the conjugate gradients stay valid. Removing the
/// mean as a uniform force (Q = I − 1 1ᵀ/|F|, the unweighted path) moves every unknown's force
/// by the same amount: on a fine node (w = 1) that is a pressure 4^k times the one it is on a
/// coarse hat (w = 4^k), so near p_c at k = 5 the coarse hats' mean flooded or emptied the fine
/// window at every step and the iteration cycled (docs/near-critical.md §5k).
#[allow(clippy::too_many_arguments)]
fn direction_weighted<K: Compliance>(
    kernel: &mut K,
    z: &mut [f64],
    t: &mut [f64],
    r: &mut [f64],
    (u, p, h): (&[f64], &[f64], &[f64]),
    (sigma, shift): (f64, f64),
    w: &[f64],
    cg: &mut Conjugacy,
) -> Direction {
    let (_, ny) = kernel.shape();
    // Σ_F w g, Σ_F w and Σ_F t_old, by rows (fixed order).
    let mut sums = [0.0; 3];
    for (i, row) in p.chunks(ny).enumerate() {
        let o = i * ny;
        for (j, &pj) in row.iter().enumerate() {
            if free(pj) {
                let k = o + j;
                sums[0] += w[k] * (sigma * u[k] - h[k] - shift);
                sums[1] += w[k];
                sums[2] += t[k];
            }
        }
    }
    let [swg, sw, stf] = sums;
    let c = swg / sw;
    // z = K ĝ with ĝ = g − c on F (Σ_F w ĝ = 0), 0 off it; δ = ⟨ĝ, z⟩ = ⟨g, Q M Qᵀ g⟩.
    let ([sg_t, _, free_count, _], delta, [sz, _, _, _]) =
        stiffness_of_gap(kernel, z, t, (u, p, h), sigma, shift + c);
    let beta = cg.beta(delta);
    // force per unit area of z and of the old direction on F
    let (mz, m) = (sz / sw, stf / sw);
    let zz: &[f64] = z;
    // ⟨g, t⟩ = ⟨ĝ, t⟩ (Σ_F t = 0) = δ + β ⟨ĝ, t_old⟩ (Σ_F w ĝ = 0).
    let sgt = delta + beta * sg_t;
    direction_response(kernel, t, r, p, sgt, free_count, |i, t| {
        let o = i * ny;
        let mut st = 0.0;
        for (j, t) in t.iter_mut().enumerate() {
            let k = o + j;
            let tj = if free(p[k]) {
                (zz[k] - w[k] * mz) + beta * (*t - w[k] * m)
            } else {
                0.0
            };
            *t = tj;
            st += tj;
        }
        [st, 0.0, 0.0, 0.0]
    })
}
