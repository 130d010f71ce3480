//! Figure 6's tables, built from the `flow` artefacts' records ([`kinds::flow_artefact`]): the
//! record columns keep their artefact names; the per-artefact columns (model, γ0, axis, grid)
//! and the loads over p_fc are added around them.

use anyhow::Result;
use kinds::flow::FlowData;
use kinds::flow_artefact::{FlowPoint, FlowStop};
use orchestrator::Inputs;

/// Figure 6's tables:
/// - `fig6.csv`, one row per flow point of every input: `lattice`, `gamma0`, `branch`, `load`
///   (E* h0/λ), `load_over_p_fc`, `contact_area`, `conductivity`, `flux`, `percolating`,
///   `converged` (flow), `contact_converged`, `termination`, `iterations`, `residual`,
///   `conservation_error`, `axis`, `n`;
/// - `fig6_stops.csv`, one row per place where the flow stops (or starts) between two points
///   of a path: `lattice`, `gamma0`, `branch`, `load_flowing`, `load_blocked` (E* h0/λ),
///   `load_flowing_over_p_fc`, `load_blocked_over_p_fc`, `conductivity_flowing`,
///   `contact_area_flowing`, `contact_area_blocked`.
pub fn tables(inputs: &Inputs) -> Result<(tables::Table, tables::Table)> {
    use kinds::record_table::append;
    use tables::Table;
    let flows: Vec<FlowData> = inputs
        .all("flow")
        .iter()
        .map(FlowData::read)
        .collect::<Result<_>>()?;
    // per row: the flow it belongs to
    let of_points: Vec<&FlowData> = flows
        .iter()
        .flat_map(|d| d.points.iter().map(move |_| d))
        .collect();
    let of_stops: Vec<&FlowData> = flows
        .iter()
        .flat_map(|d| d.stops.iter().map(move |_| d))
        .collect();
    let points: Vec<FlowPoint> = flows.iter().flat_map(|d| d.points.clone()).collect();
    let stops: Vec<FlowStop> = flows.iter().flat_map(|d| d.stops.clone()).collect();
    let zip = |f: &dyn Fn(&FlowData, usize) -> f64, of: &[&FlowData]| -> Vec<f64> {
        of.iter().enumerate().map(|(k, d)| f(d, k)).collect()
    };
    let t = Table::new()
        .with_str("lattice", of_points.iter().map(|d| d.lattice.clone()))
        .with_f64("gamma0", of_points.iter().map(|d| d.gamma0));
    let t = append(t, &points, &["branch", "load"]).with_f64(
        "load_over_p_fc",
        zip(&|d, k| points[k].load / d.p_fc, &of_points),
    );
    let points_table = append(
        t,
        &points,
        &[
            "contact_area",
            "conductivity",
            "flux",
            "percolating",
            "converged",
            "contact_converged",
            "termination",
            "iterations",
            "residual",
            "conservation_error",
        ],
    )
    .with_str("axis", of_points.iter().map(|d| d.axis.clone()))
    .with_i64("n", of_points.iter().map(|d| d.n));
    let t = Table::new()
        .with_str("lattice", of_stops.iter().map(|d| d.lattice.clone()))
        .with_f64("gamma0", of_stops.iter().map(|d| d.gamma0));
    let t = append(t, &stops, &["branch", "load_flowing", "load_blocked"])
        .with_f64(
            "load_flowing_over_p_fc",
            zip(&|d, k| stops[k].load_flowing / d.p_fc, &of_stops),
        )
        .with_f64(
            "load_blocked_over_p_fc",
            zip(&|d, k| stops[k].load_blocked / d.p_fc, &of_stops),
        );
    let stops_table = append(
        t,
        &stops,
        &[
            "conductivity_flowing",
            "contact_area_flowing",
            "contact_area_blocked",
        ],
    );
    Ok((points_table, stops_table))
}
