//! What the examples share: the random-surface examples' (`selfaffine_ap`,
//! `random_constrictions`) positional arguments `N SEED_FIRST SEED_LAST [...]`, the ensemble's
//! surface (isotropic self-affine, q_r = 2, rms slope 1, periodic, optionally sampled on a
//! coarser grid) and the ensemble statistics; the refinement examples' (`window_flow`,
//! `multi_window`) `key=value` arguments. Not an example itself (a directory without
//! `main.rs`).

#![allow(dead_code)] // each example uses part of it

use std::fmt::Display;
use std::str::FromStr;
use surface::{Amplitudes, HeightField, Normalisation, SelfAffine};

/// One `key=value` command-line argument.
pub struct KeyValue {
    /// Before the first `=`.
    pub key: String,
    /// After it.
    pub value: String,
}

impl KeyValue {
    /// The process's arguments; one without `=` panics naming it.
    pub fn from_env() -> Vec<KeyValue> {
        std::env::args()
            .skip(1)
            .map(|arg| {
                let (key, value) = arg
                    .split_once('=')
                    .unwrap_or_else(|| panic!("argument {arg:?}: expected key=value"));
                KeyValue {
                    key: key.to_string(),
                    value: value.to_string(),
                }
            })
            .collect()
    }

    /// Panics naming the argument and `why`.
    pub fn bad(&self, why: &dyn Display) -> ! {
        panic!("{} = {:?}: {why}", self.key, self.value)
    }

    /// The value parsed as `T`; a bad one panics naming the argument.
    pub fn parse<T: FromStr>(&self) -> T
    where
        T::Err: Display,
    {
        self.value.parse().unwrap_or_else(|e| self.bad(&e))
    }

    /// The value as a comma-separated list of `T`.
    pub fn list<T: FromStr>(&self) -> Vec<T>
    where
        T::Err: Display,
    {
        self.value
            .split(',')
            .map(|v| v.trim().parse().unwrap_or_else(|e| self.bad(&e)))
            .collect()
    }

    /// `none` as None, else the value parsed as `T`.
    pub fn optional<T: FromStr>(&self) -> Option<T>
    where
        T::Err: Display,
    {
        (self.value != "none").then(|| self.parse())
    }
}

/// Positional command-line arguments; a missing one takes its default.
pub struct Positional(Vec<String>);

impl Positional {
    /// The process's arguments.
    pub fn from_env() -> Self {
        Positional(std::env::args().skip(1).collect())
    }

    /// Argument `k` (from 0) parsed as `T`, `default` when absent; a bad value exits naming it.
    pub fn get<T: FromStr>(&self, k: usize, default: &str, name: &str) -> T {
        let s = self.0.get(k).map_or(default, |s| s.as_str());
        s.parse().unwrap_or_else(|_| {
            eprintln!("argument {} ({name}): cannot parse `{s}`", k + 1);
            std::process::exit(2)
        })
    }

    /// The first three: grid exponent N, first and last seed.
    pub fn grid_and_seeds(&self, n_default: &str) -> (u32, std::ops::RangeInclusive<u64>) {
        let n = self.get(0, n_default, "N: grid exponent");
        let first = self.get(1, "1", "SEED_FIRST");
        let last = self.get(2, "8", "SEED_LAST");
        (n, first..=last)
    }
}

/// The ensemble's surfaces: H, q_r = 2, q_s (units of 2π/L), rms slope 1 (the hard-wall
/// threshold area and exponents do not depend on the normalisation), generated on 2^n × 2^n and,
/// with `sub` > 0, sampled at every 2^sub-th node (the same continuum surface on a coarser
/// grid, exact while q_s stays below the coarse grid's Nyquist wavenumber 2^(n−sub−1)).
pub struct EnsembleSurface {
    /// Grid exponent of the generator.
    pub n: u32,
    /// Hurst exponent.
    pub hurst: f64,
    /// Short cutoff (units of 2π/L).
    pub q_s: f64,
    /// Amplitudes of the modes.
    pub amplitudes: Amplitudes,
    /// Sampling: every 2^sub-th node.
    pub sub: u32,
}

impl EnsembleSurface {
    /// The realisation of `seed`.
    pub fn generate(&self, seed: u64) -> HeightField {
        let field = SelfAffine {
            n: self.n,
            length: 1.0,
            hurst: self.hurst,
            q_r: 2.0,
            q_s: self.q_s,
            normalisation: Normalisation::RmsSlope(1.0),
            amplitudes: self.amplitudes,
            seed,
        }
        .generate()
        .expect("surface");
        if self.sub == 0 {
            return field;
        }
        let step = 1usize << self.sub;
        let nn = (1usize << self.n) / step;
        let heights = field
            .heights
            .slice(ndarray::s![..;step, ..;step])
            .to_owned();
        let grid = surface::Grid::periodic(nn, nn, 1.0, 1.0).expect("grid");
        HeightField::new(grid, heights).expect("field")
    }
}
