//! Axes: scales, ranges, tick positions and tick labels.

use crate::text::fmt_num;

/// Linear or logarithmic (base 10) axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scale {
    /// Linear.
    #[default]
    Linear,
    /// Base-10 logarithmic; non-positive values are not drawn.
    Log,
}

/// One axis of an x–y panel.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Axis {
    /// Label (rich text, see [`crate::text`]).
    pub label: String,
    /// Scale.
    pub scale: Scale,
    /// Range; `None` fits the data with a small margin.
    pub range: Option<(f64, f64)>,
    /// Major tick positions; `None` chooses them.
    pub ticks: Option<Vec<f64>>,
}

impl Axis {
    /// A linear axis with the given label.
    pub fn linear(label: &str) -> Self {
        Self {
            label: label.into(),
            ..Self::default()
        }
    }
    /// A logarithmic axis with the given label.
    pub fn log(label: &str) -> Self {
        Self {
            label: label.into(),
            scale: Scale::Log,
            ..Self::default()
        }
    }
    /// Same, with a fixed range.
    pub fn range(mut self, lo: f64, hi: f64) -> Self {
        self.range = Some((lo, hi));
        self
    }
    /// Same, with fixed major ticks.
    pub fn ticks(mut self, t: Vec<f64>) -> Self {
        self.ticks = Some(t);
        self
    }
}

/// A tick: position and, for major ticks, a label (rich text).
#[derive(Debug, Clone, PartialEq)]
pub struct Tick {
    /// Data value.
    pub value: f64,
    /// Label; `None` for a minor tick.
    pub label: Option<String>,
}

/// Maps data values to [0, 1] along an axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mapping {
    /// Scale.
    pub scale: Scale,
    /// Lower end (data units).
    pub lo: f64,
    /// Upper end (data units).
    pub hi: f64,
}

impl Mapping {
    /// The fraction of the axis at which `v` lies (NaN for non-positive values on a log axis).
    pub fn frac(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Linear => (v - self.lo) / (self.hi - self.lo),
            Scale::Log => {
                if v > 0.0 {
                    (v.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
                } else {
                    f64::NAN
                }
            }
        }
    }
    /// The data value at fraction `f`.
    pub fn value(&self, f: f64) -> f64 {
        match self.scale {
            Scale::Linear => self.lo + f * (self.hi - self.lo),
            Scale::Log => 10f64.powf(self.lo.log10() + f * (self.hi.log10() - self.lo.log10())),
        }
    }
}

/// The range to use for `values` on an axis of `scale` when none is given: the data's extent
/// with 4 % margins (in log space for log axes); a degenerate extent is widened.
pub fn auto_range(values: impl IntoIterator<Item = f64>, scale: Scale) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for v in values {
        if v.is_finite() && (scale == Scale::Linear || v > 0.0) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    match scale {
        Scale::Linear => {
            if !lo.is_finite() {
                return (0.0, 1.0);
            }
            if hi - lo <= f64::EPSILON * hi.abs().max(1e-300) {
                let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
                return (lo - d, hi + d);
            }
            let m = 0.04 * (hi - lo);
            (lo - m, hi + m)
        }
        Scale::Log => {
            if !lo.is_finite() {
                return (0.1, 10.0);
            }
            let (a, b) = (lo.log10(), hi.log10());
            if b - a < 1e-9 {
                return (lo / 2.0, hi * 2.0);
            }
            let m = 0.04 * (b - a);
            (10f64.powf(a - m), 10f64.powf(b + m))
        }
    }
}

/// A "nice" step near `raw`: 1, 2 or 5 times a power of ten.
pub fn nice_step(raw: f64) -> f64 {
    let e = raw.log10().floor();
    let p = 10f64.powf(e);
    let m = raw / p;
    let nice = if m < 1.5 {
        1.0
    } else if m < 3.2 {
        2.0
    } else if m < 7.0 {
        5.0
    } else {
        10.0
    };
    nice * p
}

fn decimals_for(step: f64) -> usize {
    let mut d = 0usize;
    while d < 10
        && ((step * 10f64.powi(d as i32)).round() - step * 10f64.powi(d as i32)).abs() > 1e-6
    {
        d += 1;
    }
    d
}

/// Ticks for an axis over `(lo, hi)`: about `target` labelled major ticks plus unlabelled
/// minor ticks; `explicit` major positions override the choice.
pub fn ticks(m: &Mapping, target: usize, explicit: Option<&[f64]>) -> Vec<Tick> {
    let (lo, hi) = (m.lo.min(m.hi), m.lo.max(m.hi));
    let inside = |v: f64| v >= lo - 1e-9 * (hi - lo).abs() && v <= hi + 1e-9 * (hi - lo).abs();
    if let Some(ex) = explicit {
        let d = ex
            .windows(2)
            .map(|w| decimals_for((w[1] - w[0]).abs()))
            .max()
            .unwrap_or(1);
        return ex
            .iter()
            .filter(|v| inside(**v))
            .map(|&v| Tick {
                value: v,
                label: Some(match m.scale {
                    Scale::Linear => fmt_num(v, d),
                    Scale::Log => log_label(v),
                }),
            })
            .collect();
    }
    match m.scale {
        Scale::Linear => {
            let step = nice_step((hi - lo) / target.max(1) as f64);
            let mant = step / 10f64.powf(step.log10().floor());
            let minor_div = if (mant - 2.0).abs() < 1e-9 { 4.0 } else { 5.0 };
            let d = decimals_for(step);
            let big = hi.abs().max(lo.abs());
            // very large or small labels: factor out a power of ten
            let mut out = Vec::new();
            let minor = step / minor_div;
            let k0 = (lo / minor).ceil() as i64;
            let k1 = (hi / minor).floor() as i64;
            for k in k0..=k1 {
                let v = k as f64 * minor;
                let major_k = (v / step).round();
                if ((v / step) - major_k).abs() < 1e-6 {
                    let v = major_k * step;
                    let label = if big >= 1e5 || (big < 1e-3 && big > 0.0) {
                        crate::text::fmt_sig(v, 3)
                    } else {
                        fmt_num(v, d)
                    };
                    out.push(Tick {
                        value: v,
                        label: Some(label),
                    });
                } else {
                    out.push(Tick {
                        value: v,
                        label: None,
                    });
                }
            }
            out
        }
        Scale::Log => {
            let (a, b) = (lo.log10(), hi.log10());
            let d0 = a.ceil() as i32;
            let d1 = b.floor() as i32;
            let decades = (b - a).max(1e-9);
            let mut out = Vec::new();
            if d1 - d0 >= 1 {
                let every = ((d1 - d0 + 1) as f64 / 7.0).ceil().max(1.0) as i32;
                for e in (a.floor() as i32)..=(b.ceil() as i32) {
                    let v = 10f64.powi(e);
                    if inside(v) {
                        out.push(Tick {
                            value: v,
                            label: (e.rem_euclid(every) == 0).then(|| log_label(v)),
                        });
                    }
                    if decades <= 6.5 {
                        for k in 2..10 {
                            let w = k as f64 * v;
                            if inside(w) {
                                out.push(Tick {
                                    value: w,
                                    label: None,
                                });
                            }
                        }
                    }
                }
            } else {
                // less than two decades visible: label 1, 2, 5 (or all) multiples
                let labelled: &[i32] = if decades < 0.7 {
                    &[1, 2, 3, 4, 5, 6, 7, 8, 9]
                } else {
                    &[1, 2, 5]
                };
                for e in (a.floor() as i32)..=(b.ceil() as i32) {
                    for k in 1..10 {
                        let w = k as f64 * 10f64.powi(e);
                        if inside(w) {
                            let lab = labelled.contains(&k).then(|| {
                                if (-3..=4).contains(&e) {
                                    fmt_num(w, (-e).max(0) as usize)
                                } else {
                                    format!("{k}×10^{{{}}}", fmt_num(e as f64, 0))
                                }
                            });
                            out.push(Tick {
                                value: w,
                                label: lab,
                            });
                        }
                    }
                }
            }
            out
        }
    }
}

/// "10^{n}" markup for a power of ten.
fn log_label(v: f64) -> String {
    let e = v.log10().round() as i32;
    if (v / 10f64.powi(e) - 1.0).abs() < 1e-9 {
        format!("10^{{{}}}", fmt_num(e as f64, 0))
    } else {
        crate::text::fmt_sig(v, 2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(t: &[Tick]) -> Vec<String> {
        t.iter().filter_map(|t| t.label.clone()).collect()
    }

    #[test]
    fn linear_ticks() {
        let m = Mapping {
            scale: Scale::Linear,
            lo: -0.04,
            hi: 1.04,
        };
        let t = ticks(&m, 5, None);
        assert_eq!(labels(&t), ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        assert_eq!(nice_step(0.204), 0.2);
        assert_eq!(nice_step(3.5), 5.0);
        assert!(t.iter().any(|t| t.label.is_none()));
        let m = Mapping {
            scale: Scale::Linear,
            lo: -3.0,
            hi: 7.0,
        };
        assert_eq!(labels(&ticks(&m, 5, None)), ["−2", "0", "2", "4", "6"]);
    }

    #[test]
    fn log_ticks() {
        let m = Mapping {
            scale: Scale::Log,
            lo: 1e-3,
            hi: 2.0,
        };
        let t = ticks(&m, 5, None);
        assert_eq!(labels(&t), ["10^{−3}", "10^{−2}", "10^{−1}", "10^{0}"]);
        assert!(t.iter().any(|t| t.value == 2.0));
        let m = Mapping {
            scale: Scale::Log,
            lo: 0.15,
            hi: 0.9,
        };
        assert_eq!(labels(&ticks(&m, 5, None)), ["0.2", "0.5"]);
        assert!((m.frac(m.value(0.3)) - 0.3).abs() < 1e-12);
    }

    #[test]
    fn ranges() {
        assert_eq!(auto_range([1.0, 1.0], Scale::Linear), (0.9, 1.1));
        let (lo, hi) = auto_range([0.0, 10.0, f64::NAN], Scale::Linear);
        assert!((lo + 0.4).abs() < 1e-12 && (hi - 10.4).abs() < 1e-12);
        let (lo, hi) = auto_range([-1.0, 0.01, 100.0], Scale::Log);
        assert!(lo < 0.01 && lo > 0.005 && hi > 100.0 && hi < 200.0);
    }
}
