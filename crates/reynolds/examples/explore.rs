use ndarray::Array2;
use reynolds::*;
const TAU: f64 = std::f64::consts::TAU;
struct Lcg(u64);
impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64)
    }
}
fn smooth_random(nx: usize, ny: usize, seed: u64, modes: usize) -> Array2<f64> {
    let mut rng = Lcg(seed);
    let waves: Vec<(f64, f64, f64, f64)> = (0..modes)
        .map(|_| {
            let kx = (rng.uniform() * 5.0).floor() - 2.0;
            let ky = (rng.uniform() * 5.0).floor() - 2.0;
            (kx, ky, rng.uniform() * TAU, rng.uniform())
        })
        .collect();
    Array2::from_shape_fn((nx, ny), |(i, j)| {
        let (x, y) = (i as f64 / nx as f64, j as f64 / ny as f64);
        waves
            .iter()
            .map(|&(kx, ky, ph, a)| a * (TAU * (kx * x + ky * y) + ph).cos())
            .sum()
    })
}
fn main() {
    for seed in 10..16u64 {
        for off in [-0.3, 0.0, 0.3, 0.6, 0.8] {
            let n = 64;
            let u = smooth_random(n, n, seed, 8);
            let g = u.mapv(|v| (v + off).max(0.0));
            let r = solve(g.view(), 1.0, 1.0, FlowAxis::X, &FlowOptions::default()).unwrap();
            println!(
                "seed {seed} off {off}: perc {} removed {} flowing {} it {} conv {:?}",
                r.percolating, r.removed_nodes, r.flowing_nodes, r.iterations, r.termination
            );
        }
    }
    // 30 decades, band field
    for &n in &[64usize, 128, 256] {
        let s = smooth_random(n, n, 21, 6);
        let c = smooth_random(n, n, 22, 6);
        let g = Array2::from_shape_fn((n, n), |(i, j)| {
            let y = j as f64 / n as f64;
            let t = (0.5 * (1.0 - (TAU * y).cos()) + 0.1 * s[[i, j]]).clamp(0.0, 1.0);
            if c[[i, j]] < -1.0 {
                0.0
            } else {
                10f64.powf(-10.0 * t)
            }
        });
        for axis in [FlowAxis::X, FlowAxis::Y] {
            let r = solve(g.view(), 1.0, 1.0, axis, &FlowOptions::default()).unwrap();
            println!(
                "30dec n {n} {axis:?}: K {:e} it {} {:?} res {:e} cons {:e} removed {}",
                r.conductivity,
                r.iterations,
                r.termination,
                r.relative_residual,
                r.conservation_error,
                r.removed_nodes
            );
        }
    }
}
