//! `saddleflow tradeoff`: every headline number's error against its cost across fidelity
//! presets (see `stages::tradeoff`). Reads the cache only (run the presets first; `just
//! tradeoff` does both). Writes `figures/tradeoff.{png,svg}`, `results/tables/tradeoff.csv` and
//! `.md`, prints the Markdown table, and with `--readme FILE` replaces the block between
//! `<!-- tradeoff:begin -->` and `<!-- tradeoff:end -->` in FILE.

use anyhow::{Context, Result, bail};
use stages::orchestrator::Workspace;
use stages::scenes::tradeoff;
use std::collections::BTreeSet;
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
    /// Let `--readme` replace the table even when presets it lists have no numbers in the
    /// cache now (the new table would have fewer presets).
    #[arg(long)]
    allow_fewer_presets: bool,
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
    if let Some(readme) = &a.readme {
        let text = std::fs::read_to_string(readme)
            .with_context(|| format!("cannot read `{}`", readme.display()))?;
        let found: BTreeSet<String> = entries.iter().map(|e| e.preset.clone()).collect();
        check_no_shrink(&text, &found, a.allow_fewer_presets)
            .with_context(|| format!("`{}`", readme.display()))?;
    }
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

/// The presets of the table between the markers: the second cell of each Markdown row (header
/// and rule excluded), without a " (reference)" suffix.
fn presets_in_block(text: &str) -> BTreeSet<String> {
    let (Some(b), Some(e)) = (text.find(BEGIN), text.find(END)) else {
        return BTreeSet::new();
    };
    if e < b {
        return BTreeSet::new();
    }
    text[b + BEGIN.len()..e]
        .lines()
        .filter(|l| l.trim_start().starts_with('|'))
        .skip(2)
        .filter_map(|l| l.split('|').nth(2))
        .map(|c| c.trim().trim_end_matches("(reference)").trim().to_string())
        .filter(|c| !c.is_empty())
        .collect()
}

/// Refuses to replace a table listing presets that have no numbers now, unless allowed: a
/// missing cache must not silently shrink a measured table.
fn check_no_shrink(text: &str, found: &BTreeSet<String>, allow: bool) -> Result<()> {
    let dropped: Vec<String> = presets_in_block(text).difference(found).cloned().collect();
    if dropped.is_empty() || allow {
        return Ok(());
    }
    bail!(
        "the trade table lists preset(s) {} that have no headline numbers in the cache now; replacing it would drop them. Run those presets first (`just tradeoff`), or pass --allow-fewer-presets",
        dropped.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn readme(presets: &[&str]) -> String {
        let mut s = format!("intro\n{BEGIN}\n| quantity | preset | value |\n|---|---|---|\n");
        for p in presets {
            s.push_str(&format!("| L_c square | {p} | 0.1 |\n"));
        }
        s + END + "\nrest\n"
    }

    #[test]
    fn tradeoff_readme_drops_presets_it_cannot_find_is_refused() {
        let text = readme(&["smoke", "draft", "paper (reference)"]);
        assert_eq!(
            presets_in_block(&text),
            ["draft", "paper", "smoke"].map(String::from).into()
        );
        let only_smoke: BTreeSet<String> = ["smoke".to_string()].into();
        let err = check_no_shrink(&text, &only_smoke, false).unwrap_err();
        assert!(format!("{err}").contains("draft, paper"), "{err}");
        check_no_shrink(&text, &only_smoke, true).unwrap();
        let all: BTreeSet<String> = ["smoke", "draft", "paper", "reference"]
            .map(String::from)
            .into();
        check_no_shrink(&text, &all, false).unwrap();
    }
}
