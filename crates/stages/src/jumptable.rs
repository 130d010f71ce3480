//! Jump positions at several grid sizes, as one table: the resolution check of the adhesion and
//! repulsion scenes (Figures 2 and 3).
//!
//! Every jump of every sweep is one row. A jump is matched across grids by (group, branch,
//! event, ordinal): the k-th jump with that event on that branch of that group (interaction
//! for Figure 2, model for Figure 3). `change_from_coarser` is the jump position's midpoint
//! minus the matched jump's midpoint on the next coarser grid of the group (empty if the
//! coarser grid has no such jump): converging positions have shrinking changes. Pull-offs (a
//! branch that ended because the surfaces separated) are rows with event `pull-off`.

use crate::sweep::SweepData;
use std::collections::BTreeMap;
use tables::Table;

/// One sweep and what the table needs from its artefact besides [`SweepData`].
#[derive(Clone, Debug)]
pub struct GridSweep {
    /// The sweep.
    pub data: SweepData,
    /// Interaction range ρ (h0).
    pub rho: f64,
    /// Grid spacing (λ).
    pub dx: f64,
}

impl GridSweep {
    /// Reads a sweep artefact.
    pub fn read(r: &store::ArtefactReader) -> anyhow::Result<Self> {
        Ok(GridSweep {
            data: SweepData::read(r)?,
            rho: r.attr_f64("rho")?,
            dx: r.attr_f64("dx")?,
        })
    }

    /// The cohesive-zone length ρ²E*/γ at strength `gamma` in grid spacings (∞ for γ = 0).
    pub fn zone_spacings(&self, gamma: f64) -> f64 {
        if gamma > 0.0 {
            self.rho * self.rho / gamma / self.dx
        } else {
            f64::INFINITY
        }
    }

    /// The control value of a point: load over p_fc, or the strength.
    fn x(&self, load: f64, strength: f64) -> f64 {
        if self.data.control == "strength" {
            strength
        } else {
            load / self.data.p_fc
        }
    }
}

struct Row {
    group: String,
    n: i64,
    dx: f64,
    branch: String,
    event: String,
    ordinal: i64,
    x: (f64, f64),
    area: (f64, f64),
    ratio: f64,
    detector: String,
    zone: f64,
    in_loop: bool,
}

/// The jump table of `groups` (name → sweeps of that group on one or more grids). Columns:
/// `group`, `n`, `dx`, `control` (`load_over_p_fc` or `gamma`), `branch`, `event`, `ordinal`,
/// `x_before`, `x_after`, `x_mid`, `area_before`, `area_after`, `ratio` (jump over its
/// neighbours' trend; NaN for loop ends and pull-offs), `detector`, `zone_spacings`
/// (ρ²E*/γ in grid spacings at the jump's strength; ∞ for the hard wall), `in_loop` (the jump's
/// bracket touches a hysteresis loop between the branches: an instability; a jump outside any
/// loop, at the same place on both branches, is a step of the discrete contact area, e.g. on
/// a coarse hard-wall grid), `change_from_coarser`.
pub fn table(groups: &[(String, Vec<GridSweep>)]) -> Table {
    let mut rows: Vec<Row> = Vec::new();
    let mut control = Vec::new();
    for (group, sweeps) in groups {
        let mut sorted: Vec<&GridSweep> = sweeps.iter().collect();
        sorted.sort_by_key(|s| s.data.n);
        for s in sorted {
            let d = &s.data;
            // hysteresis loops in the table's units (load over p_fc, or strength)
            let loops: Vec<(f64, f64)> = d
                .loops
                .iter()
                .map(|l| {
                    if d.control == "strength" {
                        l.x
                    } else {
                        (l.x.0 / d.p_fc, l.x.1 / d.p_fc)
                    }
                })
                .collect();
            let mut count: BTreeMap<(String, String), i64> = BTreeMap::new();
            let mut push = |rows: &mut Vec<Row>,
                            branch: &str,
                            event: &str,
                            x: (f64, f64),
                            area: (f64, f64),
                            strength: f64,
                            ratio: f64,
                            detector: &str| {
                let (lo, hi) = (x.0.min(x.1), x.0.max(x.1));
                let in_loop = loops.iter().any(|&(a, b)| a <= hi && b >= lo);
                let k = count
                    .entry((branch.to_string(), event.to_string()))
                    .or_insert(0);
                rows.push(Row {
                    group: group.clone(),
                    n: d.n,
                    dx: s.dx,
                    branch: branch.into(),
                    event: event.into(),
                    ordinal: *k,
                    x,
                    area,
                    ratio,
                    detector: detector.into(),
                    zone: if d.interaction == "hardwall" {
                        f64::INFINITY
                    } else {
                        s.zone_spacings(strength)
                    },
                    in_loop,
                });
                *k += 1;
            };
            for j in &d.jumps {
                push(
                    &mut rows,
                    &j.branch,
                    &j.event,
                    (s.x(j.load.0, j.strength.0), s.x(j.load.1, j.strength.1)),
                    j.area,
                    j.strength.0.max(j.strength.1),
                    j.ratio,
                    &j.detector,
                );
                control.push(d.control.clone());
            }
            for e in &d.ended {
                let last = d.branch_indices(&e.branch).last().map(|&k| &d.points[k]);
                push(
                    &mut rows,
                    &e.branch,
                    "pull-off",
                    (
                        last.map_or(f64::NAN, |p| s.x(p.load, p.strength)),
                        s.x(e.load, e.strength),
                    ),
                    (last.map_or(f64::NAN, |p| p.contact_area), 0.0),
                    e.strength,
                    f64::NAN,
                    "solver",
                );
                control.push(d.control.clone());
            }
        }
    }
    let mid = |r: &Row| 0.5 * (r.x.0 + r.x.1);
    // the matched jump on the next coarser grid of the group
    let change: Vec<f64> = rows
        .iter()
        .map(|r| {
            rows.iter()
                .filter(|c| {
                    c.group == r.group
                        && c.n < r.n
                        && (&c.branch, &c.event, c.ordinal) == (&r.branch, &r.event, r.ordinal)
                })
                .max_by_key(|c| c.n)
                .map_or(f64::NAN, |c| mid(r) - mid(c))
        })
        .collect();
    let col = |f: &dyn Fn(&Row) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    let s = |f: &dyn Fn(&Row) -> String| rows.iter().map(f).collect::<Vec<String>>();
    Table::new()
        .with_str("group", s(&|r| r.group.clone()))
        .with_i64("n", rows.iter().map(|r| r.n).collect::<Vec<i64>>())
        .with_f64("dx", col(&|r| r.dx))
        .with_str(
            "control",
            control
                .iter()
                .map(|c| {
                    if c == "strength" {
                        "gamma".to_string()
                    } else {
                        "load_over_p_fc".to_string()
                    }
                })
                .collect::<Vec<String>>(),
        )
        .with_str("branch", s(&|r| r.branch.clone()))
        .with_str("event", s(&|r| r.event.clone()))
        .with_i64(
            "ordinal",
            rows.iter().map(|r| r.ordinal).collect::<Vec<i64>>(),
        )
        .with_f64("x_before", col(&|r| r.x.0))
        .with_f64("x_after", col(&|r| r.x.1))
        .with_f64("x_mid", col(&mid))
        .with_f64("area_before", col(&|r| r.area.0))
        .with_f64("area_after", col(&|r| r.area.1))
        .with_f64("ratio", col(&|r| r.ratio))
        .with_str("detector", s(&|r| r.detector.clone()))
        .with_f64("zone_spacings", col(&|r| r.zone))
        .with_bool(
            "in_loop",
            rows.iter().map(|r| r.in_loop).collect::<Vec<bool>>(),
        )
        .with_f64("change_from_coarser", change)
}
