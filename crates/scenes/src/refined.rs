//! The refined ladder (scene `refined`): the running exponents ζ_eff (saddle gap), υ_eff (open
//! half-width), χ_eff (blocked half-length, l > 0) and β_eff (flux, `critical::refined_flow`)
//! below the uniform grids' reach, from one
//! `refined_ladder` stage per model (`kinds::refined_ladder`, `critical::refined`) and, optional,
//! one deeper one per model (input `deep`, the pipeline's `refined_deep_*`: chained below the
//! first, docs/near-critical.md). The same pairs enter `running_exponents.csv`
//! (scene `running`, `method` = `refined` or `refined_deep`). Both tables end in a `method`
//! column: `refined` or `refined_deep`, the input the row comes from (rows of `refined` first).
//!
//! Outputs (`results/tables/`):
//! - `refined_running.csv`: per model and neighbouring pair of rungs of the finest
//!   discretisation: `model`, `exponent` ("zeta", "upsilon", "chi", "beta"), `l_hi`, `l_lo` (signed; from that
//!   discretisation's own p_c), `value`, `grid_error` (the largest of `error_levels`, the change
//!   from the next coarser level, `error_margin`, the change from the margin check, and, with a
//!   window check, |`window_change`|; NaN if one of them is unknown), `fit_error`, `resolution` (finest fine spacing, λ), `error_levels`,
//!   `error_margin`, `flag` (empty, or why the value must not be used silently: grid error above
//!   0.005 or unknown, a rung whose window is too small or whose solve did not converge, a pair
//!   over which the window's contact set did not change, a window change above 0.005 or unknown),
//!   `window_change` (with a window check, input `window`, `kinds::refined_window`: Δw, the
//!   running exponent at the check's level with the check's larger window minus with the
//!   ladder's, signed; its magnitude is part of `grid_error`; NaN if unknown or not checked),
//!   `method`. The first eight columns are those of `running_exponents.csv`.
//! - `refined_rungs.csv`: every rung of every discretisation: `model`, `levels` (k), `margin`,
//!   `spacing` (λ), `p_c_over_p_fc` (the discretisation's own p_c over the base grid's p_fc),
//!   `l`, `saddle_gap` (h0), `contact_area`, `neck_nodes` (open fine nodes across the channel
//!   through the saddle), `iterations`, `flag` (the wall times stay in the stages' artefacts:
//!   a table is the same on every recomputation), then `half_width`, `half_width_error` (l < 0:
//!   the open channel's r_c and its fit's 1σ, λ) and `half_length`, `half_length_error` (l > 0:
//!   the blocked channel's a), `conductance`, `conductance_error` (l < 0: the flux of
//!   `critical::refined_flow`, square: the cell's conductivity along the channel, triangular and
//!   hexagonal: the refined saddle's two-terminal window conductance; its 1σ from the solver
//!   tolerance), NaN where not measured.

use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::Result;
use kinds::refined_chain::Linked;
use kinds::refined_ladder::{RefinedData, RefinedPair};
use orchestrator::{InputSpec, Inputs, Params, StageContext};
use store::ArtefactWriter;
use tables::Table;

/// The `refined` scene.
pub struct Refined;

/// `refined_running.csv` (module docs).
pub fn running_table(data: &[Linked]) -> Table {
    let pairs = || {
        data.iter()
            .flat_map(|l| l.data.running.iter().map(move |p| (&l.data, p)))
    };
    let f =
        |g: fn(&(&RefinedData, &RefinedPair)) -> f64| pairs().map(|p| g(&p)).collect::<Vec<f64>>();
    Table::new()
        .with_str("model", pairs().map(|(d, _)| d.lattice.name()))
        .with_str("exponent", pairs().map(|(_, p)| p.exponent.name()))
        .with_f64("l_hi", f(|(_, p)| p.row.l_hi))
        .with_f64("l_lo", f(|(_, p)| p.row.l_lo))
        .with_f64("value", f(|(_, p)| p.row.value))
        .with_f64("grid_error", f(|(_, p)| p.row.grid_error))
        .with_f64("fit_error", f(|(_, p)| p.row.fit_error))
        .with_f64("resolution", f(|(d, _)| d.spacing))
        .with_f64("error_levels", f(|(_, p)| p.row.error_levels))
        .with_f64("error_margin", f(|(_, p)| p.row.error_margin))
        .with_str("flag", pairs().map(|(_, p)| p.flag.clone()))
        .with_f64(
            "window_change",
            data.iter()
                .flat_map(|l| l.window_change.iter().copied())
                .collect::<Vec<f64>>(),
        )
        .with_str(
            "method",
            data.iter()
                .flat_map(|l| l.data.running.iter().map(move |_| l.depth.name())),
        )
}

/// `refined_rungs.csv` (module docs).
pub fn rungs_table(data: &[Linked]) -> Table {
    let rows: Vec<_> = data
        .iter()
        .flat_map(|l| {
            l.data
                .levels
                .iter()
                .flat_map(move |lv| lv.rungs.iter().map(move |r| (&l.data, lv, r)))
        })
        .collect();
    let methods: Vec<&str> = data
        .iter()
        .flat_map(|l| {
            l.data
                .levels
                .iter()
                .flat_map(move |lv| lv.rungs.iter().map(move |_| l.depth.name()))
        })
        .collect();
    let f = |g: &dyn Fn(&(_, _, _)) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
    Table::new()
        .with_str("model", rows.iter().map(|(d, _, _)| d.lattice.name()))
        .with_i64("levels", rows.iter().map(|(_, lv, _)| lv.levels as i64))
        .with_i64("margin", rows.iter().map(|(_, lv, _)| lv.margin as i64))
        .with_f64("spacing", f(&|(_, lv, _)| lv.spacing))
        .with_f64("p_c_over_p_fc", f(&|(d, lv, _)| lv.p_c / d.p_fc))
        .with_f64("l", f(&|(_, _, r)| r.0.l))
        .with_f64("saddle_gap", f(&|(_, _, r)| r.0.saddle_gap))
        .with_f64("contact_area", f(&|(_, _, r)| r.0.contact_area))
        .with_i64(
            "neck_nodes",
            rows.iter().map(|(_, _, r)| r.0.neck_nodes as i64),
        )
        .with_i64(
            "iterations",
            rows.iter().map(|(_, _, r)| r.0.iterations as i64),
        )
        .with_str("flag", rows.iter().map(|(_, _, r)| r.1.clone()))
        .with_f64("half_width", f(&|(_, _, r)| r.0.half_width))
        .with_f64("half_width_error", f(&|(_, _, r)| r.0.half_width_error))
        .with_f64("half_length", f(&|(_, _, r)| r.0.half_length))
        .with_f64("half_length_error", f(&|(_, _, r)| r.0.half_length_error))
        .with_f64("conductance", f(&|(_, _, r)| r.0.conductance))
        .with_f64("conductance_error", f(&|(_, _, r)| r.0.conductance_error))
        .with_str("method", methods)
}

impl Scene for Refined {
    fn name(&self) -> &'static str {
        "refined"
    }
    fn doc(&self) -> &'static str {
        "the running ζ, υ, χ, β below the uniform grids' reach from locally refined ladders (tables refined_running.csv and refined_rungs.csv)"
    }
    fn code_version(&self) -> u64 {
        4
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        vec![
            InputSpec::many("refined", &["refined_ladder"])
                .doc("one `refined_ladder` stage per model"),
            InputSpec::many("deep", &["refined_ladder"])
                .optional()
                .doc("one deeper `refined_ladder` stage per model (optional; the pipeline's `refined_deep_*`): `method` = `refined_deep`"),
            InputSpec::many("window", &["refined_window"])
                .optional()
                .doc("window checks (optional; the pipeline's `refined_deep_window_*`): each folds its window change into the grid error and flags of the ladder it checks (kinds::refined_window)"),
        ]
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::table("running", "refined_running.csv"),
            OutputSpec::table("rungs", "refined_rungs.csv"),
        ]
    }
    fn render(
        &self,
        ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        _out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let data: Vec<Linked> = kinds::neck_truncation::read_flagged(inputs)?
            .into_iter()
            .map(|(l, _)| l)
            .collect();
        let flagged = data
            .iter()
            .flat_map(|l| &l.data.running)
            .filter(|p| !p.flag.is_empty())
            .count();
        if flagged > 0 {
            ctx.warn(format!(
                "{flagged} running-exponent pairs flagged (see the `flag` column of refined_running.csv)"
            ));
        }
        Ok(Outputs::new()
            .table("running", running_table(&data))
            .table("rungs", rungs_table(&data)))
    }
}
