//! Independent reference values for the tests: L_c and the contact counts at the percolation
//! threshold on a tiny grid, computed without the contact crate, the percolation crate or FFTs.
//!
//! - Heights from the formulas of PHYSICS.md (not the surface crate).
//! - Compliance as a dense circulant matrix, summed directly over the grid's wave vectors:
//!   G(Δi, Δj) = (1/N) Σ_{q ≠ 0} cos(q·Δr) / (|q| E*/2).
//! - The hard-wall problem as a linear complementarity problem, solved exactly by block principal
//!   pivoting (Júdice & Pires 1994) with dense Cholesky factorisations: contact set S, pressures
//!   p_S and rigid approach d from G_SS p_S + d = h_S, Σ p_S = N p̄; S updated until p_S ≥ 0 and
//!   g ≥ 0 off S (after three block steps without fewer infeasible variables, single pivots on the
//!   largest infeasible index, Murty's finite rule).
//! - Fluid percolation by breadth-first search in the unfolded plane (not union–find): a fluid
//!   cluster wraps along x when BFS reaches some node at two images differing along x.
//! - Bisection in load to relative width 1e-12, starting from a scan of 60 loads in (0, p_fc).
//!
//! `cargo run --release -p critical --example dense_reference -- N [SX SY [MODEL]]` prints, per
//! model, the three transitions (any, x, y) on the 2^N grid shifted by (SX, SY) spacings: bracket,
//! contact nodes and perimeter faces at both ends.

use std::f64::consts::PI;

#[derive(Clone, Copy, PartialEq)]
enum Model {
    Hexagonal,
    Square,
    Triangular,
}

fn cell(m: Model) -> (f64, f64) {
    match m {
        Model::Square => (1.0, 1.0),
        _ => (4.0 / 3f64.sqrt(), 2.0),
    }
}

fn height(m: Model, x: f64, y: f64) -> f64 {
    let tri = (2.0f64 / 3.0).sqrt()
        * (1.5 + 2.0 * (3f64.sqrt() * PI * x).cos() * (PI * y).cos() + (2.0 * PI * y).cos());
    match m {
        Model::Square => 2.0 + (2.0 * PI * x).cos() + (2.0 * PI * y).cos(),
        Model::Triangular => tri,
        Model::Hexagonal => 13.5f64.sqrt() - tri,
    }
}

struct Problem {
    nx: usize,
    ny: usize,
    h: Vec<f64>,
    /// Circulant compliance by offset (di, dj).
    g: Vec<f64>,
}

impl Problem {
    fn new(m: Model, n: u32, shift: (f64, f64)) -> Self {
        let (nx, ny) = (1usize << n, 1usize << n);
        let (lx, ly) = cell(m);
        let h = (0..nx * ny)
            .map(|k| {
                let x = ((k / ny) as f64 + shift.0) * lx / nx as f64;
                let y = ((k % ny) as f64 + shift.1) * ly / ny as f64;
                height(m, x, y)
            })
            .collect();
        let nn = (nx * ny) as f64;
        let mut g = vec![0.0; nx * ny];
        for di in 0..nx {
            for dj in 0..ny {
                let mut s = 0.0;
                for a in 0..nx {
                    let ia = if a <= nx / 2 {
                        a as f64
                    } else {
                        a as f64 - nx as f64
                    };
                    for b in 0..ny {
                        let ib = if b <= ny / 2 {
                            b as f64
                        } else {
                            b as f64 - ny as f64
                        };
                        if a == 0 && b == 0 {
                            continue;
                        }
                        let (qx, qy) = (2.0 * PI * ia / lx, 2.0 * PI * ib / ly);
                        let k = 0.5 * qx.hypot(qy);
                        let phase = 2.0
                            * PI
                            * (a as f64 * di as f64 / nx as f64 + b as f64 * dj as f64 / ny as f64);
                        s += phase.cos() / k;
                    }
                }
                g[di * ny + dj] = s / nn;
            }
        }
        Problem { nx, ny, h, g }
    }

    fn gij(&self, i: usize, j: usize) -> f64 {
        let (ai, aj) = (i / self.ny, i % self.ny);
        let (bi, bj) = (j / self.ny, j % self.ny);
        let di = (ai + self.nx - bi) % self.nx;
        let dj = (aj + self.ny - bj) % self.ny;
        self.g[di * self.ny + dj]
    }

    /// Pressures and gaps for contact set `s` (sorted node indices) at mean pressure `pbar`.
    fn solve_set(&self, s: &[usize], pbar: f64) -> (Vec<f64>, Vec<f64>) {
        let m = s.len();
        let n = self.nx * self.ny;
        // Cholesky of G_SS
        let mut a = vec![0.0; m * m];
        for r in 0..m {
            for c in 0..=r {
                a[r * m + c] = self.gij(s[r], s[c]);
            }
        }
        for j in 0..m {
            let mut d = a[j * m + j];
            for k in 0..j {
                d -= a[j * m + k] * a[j * m + k];
            }
            assert!(
                d > 0.0,
                "G_SS not positive definite: m = {m}, j = {j}, d = {d}, g0 = {}",
                self.g[0]
            );
            let d = d.sqrt();
            a[j * m + j] = d;
            for i in j + 1..m {
                let mut v = a[i * m + j];
                for k in 0..j {
                    v -= a[i * m + k] * a[j * m + k];
                }
                a[i * m + j] = v / d;
            }
        }
        let solve = |rhs: &[f64]| {
            let mut y = rhs.to_vec();
            for i in 0..m {
                for k in 0..i {
                    y[i] -= a[i * m + k] * y[k];
                }
                y[i] /= a[i * m + i];
            }
            for i in (0..m).rev() {
                for k in i + 1..m {
                    y[i] -= a[k * m + i] * y[k];
                }
                y[i] /= a[i * m + i];
            }
            y
        };
        let hs: Vec<f64> = s.iter().map(|&i| self.h[i]).collect();
        let x_h = solve(&hs);
        let x_1 = solve(&vec![1.0; m]);
        let d = (x_h.iter().sum::<f64>() - n as f64 * pbar) / x_1.iter().sum::<f64>();
        let mut p = vec![0.0; n];
        for (k, &i) in s.iter().enumerate() {
            p[i] = x_h[k] - d * x_1[k];
        }
        let mut gap = vec![0.0; n];
        for i in 0..n {
            let mut u = d;
            for &j in s {
                u += self.gij(i, j) * p[j];
            }
            gap[i] = u - self.h[i];
        }
        for &i in s {
            gap[i] = 0.0;
        }
        (p, gap)
    }

    /// Exact hard-wall solution: returns the contact mask.
    fn contact(&self, pbar: f64, start: &[bool]) -> Vec<bool> {
        let n = self.nx * self.ny;
        let mut set: Vec<bool> = start.to_vec();
        if !set.iter().any(|&b| b) {
            let imax = (0..n)
                .max_by(|&a, &b| self.h[a].total_cmp(&self.h[b]))
                .unwrap();
            set[imax] = true;
        }
        // Block principal pivoting with Júdice–Pires safeguard: while the number of infeasible
        // variables decreases, flip all of them; after 3 steps without a decrease, flip only the
        // one with the largest index (Murty), which terminates.
        let (mut best, mut budget) = (usize::MAX, 3usize);
        let lowest = (0..n)
            .min_by(|&a, &b| self.h[a].total_cmp(&self.h[b]))
            .unwrap();
        for _ in 0..100_000 {
            if set.iter().all(|&b| b) {
                set[lowest] = false; // full contact only at p_fc; the trough opens below it
            }
            let s: Vec<usize> = (0..n).filter(|&i| set[i]).collect();
            let (p, g) = self.solve_set(&s, pbar);
            let tol = 1e-13;
            let bad: Vec<usize> = (0..n)
                .filter(|&i| (set[i] && p[i] < -tol) || (!set[i] && g[i] < -tol))
                .collect();
            if bad.is_empty() {
                return set;
            }
            if bad.len() < best {
                best = bad.len();
                budget = 3;
            } else {
                budget = budget.saturating_sub(1);
            }
            if budget > 0 {
                for &i in &bad {
                    set[i] = !set[i];
                }
            } else {
                let i = *bad.last().unwrap();
                set[i] = !set[i];
            }
        }
        panic!("no convergence at load {pbar}");
    }
}

/// (fluid wraps along x, along y) by BFS in the unfolded plane (fluid 4-connected).
fn fluid_wraps(nx: usize, ny: usize, contact: &[bool]) -> (bool, bool) {
    let mut image: Vec<Option<(i64, i64)>> = vec![None; nx * ny];
    let (mut wx, mut wy) = (false, false);
    for start in 0..nx * ny {
        if contact[start] || image[start].is_some() {
            continue;
        }
        image[start] = Some((0, 0));
        let mut queue = std::collections::VecDeque::from([start]);
        while let Some(v) = queue.pop_front() {
            let (i, j) = ((v / ny) as i64, (v % ny) as i64);
            let o = image[v].unwrap();
            for (di, dj) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                let (ti, tj) = (i + di, j + dj);
                let (ui, uj) = (ti.rem_euclid(nx as i64), tj.rem_euclid(ny as i64));
                let w = (ui * ny as i64 + uj) as usize;
                if contact[w] {
                    continue;
                }
                let img = (
                    o.0 + ti.div_euclid(nx as i64),
                    o.1 + tj.div_euclid(ny as i64),
                );
                match image[w] {
                    None => {
                        image[w] = Some(img);
                        queue.push_back(w);
                    }
                    Some(prev) => {
                        wx |= prev.0 != img.0;
                        wy |= prev.1 != img.1;
                    }
                }
            }
        }
    }
    (wx, wy)
}

/// (load below, contact below, load above, contact above).
type Bracket = (f64, Vec<bool>, f64, Vec<bool>);

fn perimeter(nx: usize, ny: usize, c: &[bool]) -> usize {
    let mut e = 0;
    for i in 0..nx {
        for j in 0..ny {
            let v = c[i * ny + j];
            e += (v != c[((i + 1) % nx) * ny + j]) as usize;
            e += (v != c[i * ny + (j + 1) % ny]) as usize;
        }
    }
    e
}

fn main() {
    let arg = |k: usize| std::env::args().nth(k);
    let n: u32 = arg(1).map_or(5, |s| s.parse().unwrap());
    let shift: (f64, f64) = (
        arg(2).map_or(0.0, |s| s.parse().unwrap()),
        arg(3).map_or(0.0, |s| s.parse().unwrap()),
    );
    let only: Option<String> = arg(4);
    for (name, m) in [
        ("hexagonal", Model::Hexagonal),
        ("square", Model::Square),
        ("triangular", Model::Triangular),
    ] {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        let p = Problem::new(m, n, shift);
        let nn = p.nx * p.ny;
        let mean = p.h.iter().sum::<f64>() / nn as f64;
        let min = p.h.iter().copied().fold(f64::INFINITY, f64::min);
        let p_fc = PI * (mean - min);
        let state = |load: f64, start: &[bool]| {
            let c = p.contact(load, start);
            let (fx, fy) = fluid_wraps(p.nx, p.ny, &c);
            (c, [fx || fy, fx, fy])
        };
        // scan
        let mut prev: Option<(f64, Vec<bool>, [bool; 3])> = None;
        let mut brackets: [Option<Bracket>; 3] = [None, None, None];
        let mut start = vec![false; nn];
        for k in 1..=60 {
            let load = p_fc * k as f64 / 61.0;
            let (c, open) = state(load, &start);
            if let Some((l0, c0, o0)) = &prev {
                for t in 0..3 {
                    if o0[t] && !open[t] && brackets[t].is_none() {
                        brackets[t] = Some((*l0, c0.clone(), load, c.clone()));
                    }
                }
            }
            start = c.clone();
            prev = Some((load, c, open));
        }
        println!(
            "{name} n={n} shift=({}, {}) p_fc={p_fc:.15}",
            shift.0, shift.1
        );
        for (t, label) in ["any", "x", "y"].iter().enumerate() {
            let (mut lo, mut clo, mut hi, mut chi) =
                brackets[t].clone().expect("transition in the scan");
            while (hi - lo) / hi > 1e-12 {
                let mid = 0.5 * (lo + hi);
                let (c, open) = state(mid, &clo);
                if open[t] {
                    lo = mid;
                    clo = c;
                } else {
                    hi = mid;
                    chi = c;
                }
            }
            let cnt = |c: &[bool]| c.iter().filter(|&&b| b).count();
            println!(
                "  {label:>3}: L_c = {:.13} [{lo:.15}, {hi:.15}] contact nodes {} / {} perimeter faces {} / {}",
                0.5 * (lo + hi),
                cnt(&clo),
                cnt(&chi),
                perimeter(p.nx, p.ny, &clo),
                perimeter(p.nx, p.ny, &chi)
            );
        }
    }
}
