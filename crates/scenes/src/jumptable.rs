//! Jump positions at several grid sizes, as one table: the resolution check of the adhesion and
//! repulsion scenes (Figures 2 and 3).
//!
//! Every jump of every sweep is one row. A jump is matched across grids by (group, branch,
//! event, ordinal): the k-th jump with that event on that branch of that group (interaction
//! for Figure 2, model for Figure 3), else by the nearest jump in the same direction on the
//! same branch. `change_from_coarser` is the jump position's midpoint minus the matched jump's
//! midpoint on the next coarser grid of the group (NaN if the coarser grid has no jump on that
//! branch): converging positions have shrinking changes. Pull-offs (a
//! branch that ended because the surfaces separated) are rows with event `pull-off`.

use kinds::sweep::SweepData;
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
    /// The force-residual tolerance the sweep was solved to (E* h0/λ; its `tol_force`
    /// parameter from the artefact's provenance), NaN if the artefact does not say.
    pub tol_force: f64,
}

impl GridSweep {
    /// Reads a sweep artefact.
    pub fn read(r: &store::ArtefactReader) -> anyhow::Result<Self> {
        Ok(GridSweep {
            data: SweepData::read(r)?,
            rho: r.attr_f64("rho")?,
            dx: r.attr_f64("dx")?,
            tol_force: r
                .provenance()
                .ok()
                .and_then(|p| p.params.get("tol_force").and_then(|v| v.as_f64()))
                .unwrap_or(f64::NAN),
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
/// a coarse hard-wall grid), `change_from_coarser` (x_mid minus the matched jump's x_mid on the
/// next coarser grid), `matched` (`event`: same event, branch and ordinal; `nearest: <event>`:
/// the nearest jump in the same direction on that branch; empty: none).
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
                    j.branch.name(),
                    &j.event,
                    (
                        s.x(j.load_before, j.strength_before),
                        s.x(j.load_after, j.strength_after),
                    ),
                    j.area(),
                    j.strength_before.max(j.strength_after),
                    j.ratio,
                    &j.detector.to_string(),
                );
                control.push(d.control.clone());
            }
            for e in &d.ended {
                let last = d.branch_indices(e.branch).last().map(|&k| &d.points[k]);
                push(
                    &mut rows,
                    e.branch.name(),
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
    let (change, matched) = match_coarser(&rows);
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
        .with_str("matched", matched)
}

/// Per row, the matched jump on the next coarser grid of the group: the same event with the
/// same ordinal on the same branch, else the nearest jump in the same direction on that branch
/// (the event's name can differ between grids, e.g. `coalescence` on one and `area jump (up)`
/// on a coarser one where the fluid still percolates along one axis). Returns x_mid minus the
/// match's x_mid and how it matched.
fn match_coarser(rows: &[Row]) -> (Vec<f64>, Vec<String>) {
    let mid = |r: &Row| 0.5 * (r.x.0 + r.x.1);
    let up = |r: &Row| r.area.1 > r.area.0;
    rows.iter()
        .map(|r| {
            let Some(nc) = rows
                .iter()
                .filter(|c| c.group == r.group && c.n < r.n)
                .map(|c| c.n)
                .max()
            else {
                return (f64::NAN, String::new());
            };
            let coarser = || {
                rows.iter()
                    .filter(move |c| c.group == r.group && c.n == nc && c.branch == r.branch)
            };
            if let Some(c) = coarser().find(|c| (&c.event, c.ordinal) == (&r.event, r.ordinal)) {
                return (mid(r) - mid(c), "event".to_string());
            }
            coarser()
                .filter(|c| up(c) == up(r) && c.event != "pull-off" && r.event != "pull-off")
                .min_by(|a, b| (mid(a) - mid(r)).abs().total_cmp(&(mid(b) - mid(r)).abs()))
                .map_or((f64::NAN, String::new()), |c| {
                    (mid(r) - mid(c), format!("nearest: {}", c.event))
                })
        })
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;
    use kinds::sweep::{JumpRow, Loop};

    fn jump(branch: &str, event: &str, x: (f64, f64), area: (f64, f64)) -> JumpRow {
        JumpRow {
            branch: branch.parse().unwrap(),
            index: 0,
            index_after: 1,
            load_before: x.0 * 2.0,
            load_after: x.1 * 2.0,
            strength_before: 0.2,
            strength_after: 0.2,
            area_before: area.0,
            area_after: area.1,
            ratio: 10.0,
            event: event.into(),
            detector: kinds::sweep::Detector::Trend,
        }
    }

    fn grid(n: i64, jumps: Vec<JumpRow>, loops: Vec<Loop>) -> GridSweep {
        GridSweep {
            data: SweepData {
                interaction: "adhesion".into(),
                control: "load".into(),
                p_fc: 2.0,
                lattice: "square".into(),
                n,
                points: vec![],
                jumps,
                loops,
                ended: vec![],
                thresholds: Default::default(),
            },
            rho: 0.04,
            dx: 1.0 / (1 << n) as f64,
            tol_force: 1e-8,
        }
    }

    #[test]
    fn jumps_are_matched_across_grids() {
        let coarse = grid(
            4,
            vec![
                jump("loading", "area jump (up)", (0.30, 0.32), (0.3, 0.4)),
                jump("unloading", "break-up", (0.20, 0.18), (0.4, 0.3)),
            ],
            vec![Loop {
                x: (0.36, 0.6),
                max_area_difference: 0.1,
                x_at_max: 0.5,
            }],
        );
        let fine = grid(
            5,
            vec![
                jump("loading", "coalescence", (0.28, 0.30), (0.3, 0.45)),
                jump("unloading", "break-up", (0.19, 0.17), (0.42, 0.3)),
                jump("unloading", "contact loss", (0.02, 0.01), (0.01, 0.0)),
            ],
            vec![],
        );
        // given fine first: rows come out coarse to fine
        let t = table(&[("adhesion".into(), vec![fine, coarse])]);
        assert_eq!(t.i64("n").unwrap(), [4, 4, 5, 5, 5]);
        let (ch, m) = (
            t.f64("change_from_coarser").unwrap(),
            t.str("matched").unwrap(),
        );
        assert!(ch[0].is_nan() && ch[1].is_nan() && m[0].is_empty());
        // coalescence ↔ the coarse grid's upward jump on loading (by proximity)
        assert!((ch[2] - (0.29 - 0.31)).abs() < 1e-12 && m[2] == "nearest: area jump (up)");
        // break-up ↔ break-up (same event)
        assert!((ch[3] - (0.18 - 0.19)).abs() < 1e-12 && m[3] == "event");
        // contact loss ↔ the only downward unloading jump of the coarse grid
        assert!((ch[4] - (0.015 - 0.19)).abs() < 1e-12, "{}", ch[4]);
        // loads in units of p_fc (= 2 here), zone in grid spacings (ρ²/γ/dx = 0.008 · 16)
        assert_eq!(t.f64("x_before").unwrap()[0], 0.30);
        assert!((t.f64("zone_spacings").unwrap()[0] - 0.128).abs() < 1e-12);
        // the coarse grid's loop [0.36, 0.6] E* h0/λ is 0.18–0.3 p_fc: both its jumps touch it
        // (the upward one at its upper end); the fine grid has no loop
        let il = t.bool("in_loop").unwrap();
        assert_eq!(il, [true, true, false, false, false]);
    }
}
