//! Figure 4's inputs and data: the gap just below the percolation threshold (the fluid still
//! percolates through one-node channels) for the three models, contact white, bright = large
//! gap, arranged as Figure 1 (hexagonal, square, triangular; the square model shown on 2 × 2
//! cells so that the three panels share one physical scale). The lattice is drawn from the
//! exact critical points (`surface::Surface::critical_points`): lines between neighbouring
//! maxima (black) and minima (white), minima as white points and saddle points as grey stars.
//! Figure 1's dotted links between neighbouring saddles are left out here: near the threshold
//! they run along the contact lines and would hide the pinched channels.
//!
//! Inputs `hexagonal`, `square`, `triangular`: `critical` stages stored with `fields = true`
//! (their `gap` dataset is the state just below L_c of the first shift).

use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::{Result, bail};
use figures::scenes::maps::{ModelMap, ThreeMaps};
use figures::style::Model;
use kinds::surface::lattice_from_name;
use orchestrator::{InputSpec, Inputs};
use orchestrator::{Params, StageContext};
use store::ArtefactWriter;
use store::fields;
use surface::{CriticalKind, Grid, Lattice, Surface};

/// The inputs of Figure 4.
pub fn inputs() -> Vec<InputSpec> {
    ["hexagonal", "square", "triangular"]
        .iter()
        .map(|m| {
            InputSpec::one(m, &["critical"]).doc(&format!(
                "critical stage of the {m} model with fields (the gap just below L_c)"
            ))
        })
        .collect()
}

fn model(l: Lattice) -> Model {
    match l {
        Lattice::Hexagonal => Model::Hexagonal,
        Lattice::Square => Model::Square,
        Lattice::Triangular => Model::Triangular,
    }
}

/// Segments between nearest neighbours of a periodic point set (each once, starting inside the
/// cell; the figure tiles them).
fn neighbour_links(points: &[(f64, f64)], lx: f64, ly: f64) -> Vec<Vec<(f64, f64)>> {
    let mut images = Vec::new();
    for &(x, y) in points {
        for a in -1..=1 {
            for b in -1..=1 {
                images.push((x + a as f64 * lx, y + b as f64 * ly));
            }
        }
    }
    let d2 = |p: (f64, f64), q: (f64, f64)| (p.0 - q.0).powi(2) + (p.1 - q.1).powi(2);
    let mut dmin = f64::INFINITY;
    for &p in points {
        for &q in &images {
            let d = d2(p, q);
            if d > 1e-12 {
                dmin = dmin.min(d);
            }
        }
    }
    let mut links = Vec::new();
    for &p in points {
        for &q in &images {
            let d = d2(p, q);
            // each undirected link once: from the lexicographically smaller end
            if d > 1e-12 && d <= dmin * (1.0 + 1e-6) && (q.0, q.1) > (p.0, p.1) {
                links.push(vec![p, q]);
            }
        }
    }
    links
}

/// One model's map with the lattice of its surface drawn over it, for Figures 1 and 4: lines
/// between neighbouring maxima (black) and minima (white), the minima as white points, the
/// saddle points as grey stars and, if `saddle_links`, dotted lines between neighbouring
/// saddles — all from the exact critical points of the surface (`lattice` on the 2^n × 2^n
/// grid of the field). The square model is shown on 2 × 2 cells (one physical scale with the
/// other two). No contact mask.
pub fn lattice_map(
    lattice: Lattice,
    n: u32,
    field: ndarray::Array2<f64>,
    saddle_links: bool,
) -> Result<ModelMap> {
    let grid = Grid::new(lattice, n).map_err(|e| anyhow::anyhow!("{e}"))?;
    let (lx, ly) = lattice.cell();
    if field.dim() != (grid.nx, grid.ny) {
        bail!(
            "the {} field has shape {:?}, the n = {n} grid {:?}",
            lattice.name(),
            field.dim(),
            (grid.nx, grid.ny)
        );
    }
    let cps = Surface::on_grid(lattice, grid).critical_points();
    let pick = |k: CriticalKind| {
        cps.iter()
            .filter(|c| c.kind == k)
            .map(|c| (c.x, c.y))
            .collect::<Vec<_>>()
    };
    let (maxima, minima, saddles) = (
        pick(CriticalKind::Maximum),
        pick(CriticalKind::Minimum),
        pick(CriticalKind::Saddle),
    );
    let mut m = ModelMap::new(model(lattice), field, lx, ly);
    if lattice == Lattice::Square {
        m.view = Some((0.0, 2.0 * lx, 0.0, 2.0 * ly));
    }
    m.maxima_lines = neighbour_links(&maxima, lx, ly);
    m.minima_lines = neighbour_links(&minima, lx, ly);
    if saddle_links {
        m.saddle_links = neighbour_links(&saddles, lx, ly);
    }
    m.minima = minima;
    m.saddles = saddles;
    Ok(m)
}

/// Builds the three maps from the inputs.
pub fn data(inputs: &Inputs) -> Result<ThreeMaps> {
    let mut maps = Vec::new();
    for name in ["hexagonal", "square", "triangular"] {
        let r = inputs.one(name)?;
        let lattice = lattice_from_name(&r.attr_str("lattice")?)?;
        if lattice.name() != name {
            bail!(
                "input `{name}` is a critical stage of the {} model",
                lattice.name()
            );
        }
        if !r.has_dataset(fields::GAP) {
            bail!(
                "input `{name}` ({}) has no fields: run its critical stage with fields = true",
                r.path().display()
            );
        }
        let gap = r.read_f64_2d(fields::GAP)?;
        let contact = gap.mapv(|g| g <= 0.0);
        let mut m = lattice_map(lattice, r.attr_i64("n")? as u32, gap, false)?;
        m.contact = Some(contact);
        maps.push(m);
    }
    Ok(ThreeMaps {
        maps,
        colorbar_label: "$g$ / $h$_0".into(),
        shared_range: false,
    })
}

/// The `fig4` scene: gap maps just below the percolation threshold for the three models,
/// contact white, bright = large gap, arranged as Figure 1 (inputs `hexagonal`, `square`,
/// `triangular`: `critical` stages stored with fields).
pub struct Fig4;

impl Scene for Fig4 {
    fn name(&self) -> &'static str {
        "fig4"
    }
    fn doc(&self) -> &'static str {
        "Figure 4: gap maps just below the percolation threshold, three models"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn fields_read(&self) -> u64 {
        1
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        inputs()
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![OutputSpec::figure("figure", "fig4")]
    }
    fn render(
        &self,
        _ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        _out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let fig = figures::scenes::maps::figure(&data(inputs)?, figures::Colormap::Viridis)?;
        Ok(Outputs::new().figure("figure", fig))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_lattice_links() {
        let l = neighbour_links(&[(0.0, 0.0)], 1.0, 1.0);
        // one point per cell: links to (1, 0) and (0, 1) only
        assert_eq!(l.len(), 2, "{l:?}");
        let s = neighbour_links(&[(0.5, 0.0), (0.0, 0.5)], 1.0, 1.0);
        assert_eq!(s.len(), 4, "{s:?}"); // the diamond around each minimum
    }
}
