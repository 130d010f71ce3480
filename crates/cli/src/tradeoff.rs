//! `saddleflow tradeoff`: every headline number's error against its cost across fidelity
//! presets (see `stages::tradeoff`). Reads the cache only (run the presets first; `just
//! tradeoff` does both). Writes `figures/tradeoff.{png,svg}`, `results/tables/tradeoff.csv` and
//! `.md`, prints the Markdown table, and with `--readme FILE` replaces the block between
//! `<!-- tradeoff:begin -->` and `<!-- tradeoff:end -->` in FILE.

use anyhow::{Context, Result, bail};
use stages::orchestrator::Workspace;
use stages::tradeoff;
use std::path::{Path, PathBuf};

/// Arguments of `saddleflow tradeoff`.
#[derive(clap::Args)]
pub struct Args {
    /// Pipeline file.
    #[arg(long, default_value = "pipeline/paper.toml")]
    pipeline: PathBuf,
    /// Params files, cheapest first; a quantity's reference is its value in the last one that
    /// has it.
    #[arg(long = "params", num_args = 1.., default_values = ["params/smoke.toml", "params/draft.toml", "params/paper.toml", "params/reference.toml"])]
    params: Vec<PathBuf>,
    /// Run as if started in DIR (the project root).
    #[arg(short = 'C', long = "root", value_name = "DIR")]
    root: Option<PathBuf>,
    /// Also replace the trade table in this Markdown file (between its markers).
    #[arg(long)]
    readme: Option<PathBuf>,
}

const BEGIN: &str = "<!-- tradeoff:begin (written by `saddleflow tradeoff`) -->";
const END: &str = "<!-- tradeoff:end -->";

pub fn run(a: Args) -> Result<()> {
    if let Some(r) = &a.root {
        std::env::set_current_dir(r).with_context(|| format!("cannot enter `{}`", r.display()))?;
    }
    let ws = Workspace::new(Path::new("."));
    let entries = tradeoff::collect(&stages::registry(), &ws, &a.pipeline, &a.params)?;
    if entries.is_empty() {
        bail!(
            "no headline numbers in the cache for {} with {}: run the presets first (`just tradeoff`)",
            a.pipeline.display(),
            a.params
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let presets: Vec<String> = a
        .params
        .iter()
        .map(|p| {
            p.file_stem()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    let rows = tradeoff::sorted(tradeoff::assess(&entries, &presets), &presets);
    let table = tradeoff::table(&rows)?;
    tables::write_csv(&table, Path::new("results/tables/tradeoff.csv"))?;
    let md = tradeoff::summary_table(&rows).to_markdown(tables::FloatFormat::Significant(4));
    store::fsutil::write_atomic(Path::new("results/tables/tradeoff.md"), md.as_bytes())?;
    let data = tradeoff::figure_data(&rows);
    if data.curves.is_empty() {
        eprintln!("no quantity has a measurable error yet (one preset only?): figure not drawn");
    } else {
        let fig = figures::scenes::tradeoff::figure(&data)?;
        store::fsutil::write_atomic(Path::new("figures/tradeoff.png"), &fig.render_png()?)?;
        store::fsutil::write_atomic(
            Path::new("figures/tradeoff.svg"),
            fig.render_svg()?.as_bytes(),
        )?;
    }
    if let Some(readme) = &a.readme {
        let text = std::fs::read_to_string(readme)
            .with_context(|| format!("cannot read `{}`", readme.display()))?;
        let new = tradeoff::replace_block(&text, BEGIN, END, &md)
            .with_context(|| format!("`{}`", readme.display()))?;
        store::fsutil::write_atomic(readme, new.as_bytes())?;
    }
    println!("{md}");
    Ok(())
}
