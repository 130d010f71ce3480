//! Figure 3's resolution study for one model from its sweep artefacts, without the other
//! models' sweeps (the `fig3` scene needs all three): the rows of `fig3_error.csv` for that
//! model, computed by the scene's own code ([`scenes::fig3::Estimate`]).
//!
//! ```text
//! cargo build --release --workspace --examples
//! target/release/examples/fig3_study results/cache/sweep/KEY_MAIN.h5 results/cache/sweep/KEY_CHECK.h5 \
//!     --tight results/cache/sweep/KEY_TIGHT.h5
//! ```
//! The sweeps are those of one model at the main tolerance, one per grid (any order); `--tight`
//! names the tolerance check. The artefacts are the stages' files in `results/cache/sweep/`
//! (`saddleflow status` lists the stages' keys).

use anyhow::{Context, Result, bail};
use scenes::fig3::{Estimate, Quantity, check, check_tight};
use scenes::jumptable::GridSweep;

fn read(path: &str) -> Result<GridSweep> {
    let r = store::ArtefactReader::open(path).with_context(|| format!("opening {path}"))?;
    GridSweep::read(&r).with_context(|| format!("reading {path}"))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut grids, mut tight) = (Vec::new(), None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--tight" {
            let Some(p) = it.next() else {
                bail!("--tight needs a sweep artefact");
            };
            tight = Some(read(p)?);
        } else {
            grids.push(read(a)?);
        }
    }
    let Some(first) = grids.first() else {
        bail!("usage: fig3_study SWEEP.h5... [--tight SWEEP.h5]");
    };
    let model = first.data.lattice.clone();
    for g in &grids {
        check(&g.data, &model, "argument")?;
    }
    if let Some(t) = &tight {
        check(&t.data, &model, "--tight")?;
        check_tight(&grids, t)?;
    }
    let show = |b: Option<scenes::fig3::Bracketed>| {
        b.map_or("not reached".to_string(), |b| {
            format!("{:.4} ({:.4}–{:.4})", b.value, b.lo, b.hi)
        })
    };
    for q in Quantity::ALL {
        let Some(e) = Estimate::of(&model, q, &grids, tight.as_ref()) else {
            continue;
        };
        println!(
            "{model} {}: 2^{} tol {:e}: {}; coarser 2^{}: {} (change {:.4}); tight {:?}: reference {}, tight {} (change {:.4}); error {:.4}; paper {:?}: {}; {}",
            q.name(),
            e.n,
            e.tol_force,
            show(e.finest),
            e.n_coarser.unwrap_or(-1),
            show(e.coarser),
            e.grid().change(),
            e.tight_sweep,
            show(e.tight_reference),
            show(e.tight),
            e.tolerance().change(),
            e.error(),
            e.paper,
            e.paper_verdict(),
            e.convergence()
        );
    }
    Ok(())
}
