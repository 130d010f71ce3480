//! Figure 2's resolution check (scene `fig2_resolution`): the same three load paths (inputs
//! `hardwall`, `adhesion`, `repulsion`) on one or more grids each; writes
//! `fig2_jumps_resolution.csv`, every jump and pull-off of every grid, matched across grids, with
//! the change of its position from the next coarser grid ([`crate::jumptable::table`]); the hard
//! wall has no rows unless something jumps.

use crate::fig2;
use crate::jumptable;
use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::Result;
use orchestrator::{InputSpec, Inputs, Params, StageContext};
use store::ArtefactWriter;

/// The `fig2_resolution` scene.
pub struct Fig2Resolution;

impl Scene for Fig2Resolution {
    fn name(&self) -> &'static str {
        "fig2_resolution"
    }
    fn doc(&self) -> &'static str {
        "Figure 2's jumps matched across grids (table)"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        fig2::resolution_inputs()
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![OutputSpec::table("jumps", "fig2_jumps_resolution.csv")]
    }
    fn render(
        &self,
        _ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        _out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let t = jumptable::table(&fig2::read_resolution(inputs)?);
        Ok(Outputs::new().table("jumps", t))
    }
}
