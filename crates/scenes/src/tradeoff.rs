//! Speed against accuracy across fidelity presets: every headline number ([`kinds::headline`])
//! of every cached stage, for each params file (cheapest first), with its error against the
//! finest preset's value and the cost of producing it (wall time and peak memory of the stage
//! and everything upstream, from the provenance records). Backs `saddleflow tradeoff`, which
//! writes the figure, the CSV and Markdown tables and the README's trade table.
//!
//! The reference of a quantity is its value in the last preset that has it (the finest; for an
//! extrapolated quantity, its extrapolation). The reference's own error is its error bar. A
//! preset "reaches the paper's error bar" when its error against the reference is within the
//! paper's error bar for that quantity.

use anyhow::{Context, Result, bail};
use figures::scenes::tradeoff::{TradeoffCurve, TradeoffData};
use kinds::headline::{self, Headline};
use orchestrator::{Plan, Registry, Workspace};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use tables::Table;

/// One headline number as one preset produced it.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// Preset (params file stem).
    pub preset: String,
    /// Stage that reported it.
    pub stage: String,
    /// The number.
    pub headline: Headline,
    /// Wall time of the stage and all its upstream stages (s).
    pub cost_s: f64,
    /// Largest peak resident memory over those stages (MiB; NaN if not recorded).
    pub peak_mib: f64,
}

/// An entry judged against its quantity's reference.
#[derive(Debug, Clone, PartialEq)]
pub struct Assessed {
    /// The entry.
    pub entry: Entry,
    /// Whether this is the reference (finest preset) of its quantity.
    pub reference: bool,
    /// |value − reference| (for the reference: its own error bar, NaN if none).
    pub error: f64,
    /// `error` / |reference|.
    pub relative_error: f64,
    /// `error` ≤ the paper's error bar, if the paper gives one.
    pub reaches_paper_error: Option<bool>,
}

/// Position of preset `p` in `presets` (unknown presets last).
fn preset_rank(presets: &[String], p: &str) -> usize {
    presets.iter().position(|q| q == p).unwrap_or(usize::MAX)
}

impl Assessed {
    /// "yes" / "no": whether the paper's error bar is reached; empty if unknown.
    fn verdict(&self) -> String {
        match self.reaches_paper_error {
            Some(true) => "yes".into(),
            Some(false) => "no".into(),
            None => String::new(),
        }
    }
}

/// Reads the headline numbers of every cached stage of `pipeline` with each params file.
pub fn collect(
    registry: &Registry,
    ws: &Workspace,
    pipeline: &Path,
    params: &[PathBuf],
) -> Result<Vec<Entry>> {
    let mut out = Vec::new();
    for p in params {
        let preset = p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let plan = Plan::load(registry, pipeline, Some(p))
            .with_context(|| format!("{} with {}", pipeline.display(), p.display()))?;
        for s in &plan.stages {
            let Ok(r) = ws.open_entry(s) else {
                continue;
            };
            let list = headline::read(&r)
                .with_context(|| format!("stage `{}` ({})", s.name, ws.artefact_of(s).display()))?;
            if list.is_empty() {
                continue;
            }
            let (cost_s, peak_mib) = cost(&plan, ws, &s.name)?;
            for h in list {
                out.push(Entry {
                    preset: preset.clone(),
                    stage: s.name.clone(),
                    headline: h,
                    cost_s,
                    peak_mib,
                });
            }
        }
    }
    Ok(out)
}

/// Wall time summed and peak memory maximised over a stage and its upstream closure.
fn cost(plan: &Plan, ws: &Workspace, name: &str) -> Result<(f64, f64)> {
    let mut seen = BTreeSet::new();
    let mut todo = vec![name.to_string()];
    let (mut wall, mut peak) = (0.0, f64::NAN);
    while let Some(n) = todo.pop() {
        if !seen.insert(n.clone()) {
            continue;
        }
        let s = plan
            .stage(&n)
            .with_context(|| format!("unknown stage `{n}`"))?;
        let prov = ws
            .open_entry(s)
            .and_then(|r| r.provenance())
            .with_context(|| format!("upstream stage `{n}` is not in the cache"))?;
        wall += prov.wall_s;
        if let Some(m) = prov.stats.get("peak_rss_mib").and_then(|v| v.as_f64()) {
            peak = if peak.is_nan() { m } else { peak.max(m) };
        }
        todo.extend(s.inputs.values().flatten().cloned());
    }
    Ok((wall, peak))
}

/// Judges every entry against the last preset (in `presets` order) that has its quantity.
pub fn assess(entries: &[Entry], presets: &[String]) -> Vec<Assessed> {
    let rank = |p: &str| preset_rank(presets, p);
    let mut reference: BTreeMap<&str, &Entry> = BTreeMap::new();
    for e in entries {
        let slot = reference.entry(e.headline.name.as_str()).or_insert(e);
        if rank(&e.preset) >= rank(&slot.preset) {
            *slot = e;
        }
    }
    entries
        .iter()
        .map(|e| {
            let r = reference[e.headline.name.as_str()];
            let is_ref = std::ptr::eq(r, e);
            let error = if is_ref {
                r.headline.error.unwrap_or(f64::NAN)
            } else {
                (e.headline.value - r.headline.value).abs()
            };
            Assessed {
                entry: e.clone(),
                reference: is_ref,
                error,
                relative_error: error / r.headline.value.abs(),
                reaches_paper_error: e
                    .headline
                    .paper_error
                    .filter(|_| error.is_finite())
                    .map(|pe| error <= pe),
            }
        })
        .collect()
}

/// The assessed entries as a table (one row per quantity and preset).
pub fn table(rows: &[Assessed]) -> Result<Table> {
    let f = |g: &dyn Fn(&Assessed) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
    let opt = |x: Option<f64>| x.unwrap_or(f64::NAN);
    Ok(Table::new()
        .with_str(
            "quantity",
            rows.iter().map(|r| r.entry.headline.name.clone()),
        )
        .with_str("preset", rows.iter().map(|r| r.entry.preset.clone()))
        .with_f64("value", f(&|r| r.entry.headline.value))
        .with_f64("error_bar", f(&|r| opt(r.entry.headline.error)))
        .with_bool("reference", rows.iter().map(|r| r.reference))
        .with_f64("error_vs_reference", f(&|r| r.error))
        .with_f64("relative_error", f(&|r| r.relative_error))
        .with_f64("paper", f(&|r| opt(r.entry.headline.paper)))
        .with_f64("paper_error", f(&|r| opt(r.entry.headline.paper_error)))
        .with_str("reaches_paper_error", rows.iter().map(Assessed::verdict))
        .with_f64("cost_s", f(&|r| r.entry.cost_s))
        .with_f64("peak_mib", f(&|r| r.entry.peak_mib))
        .with_str("stage", rows.iter().map(|r| r.entry.stage.clone())))
}

/// The rows sorted by quantity, then preset in `presets` order.
pub fn sorted(mut rows: Vec<Assessed>, presets: &[String]) -> Vec<Assessed> {
    let rank = |p: &str| preset_rank(presets, p);
    rows.sort_by(|a, b| {
        (a.entry.headline.name.as_str(), rank(&a.entry.preset))
            .cmp(&(b.entry.headline.name.as_str(), rank(&b.entry.preset)))
    });
    rows
}

/// The README's trade table: quantity, preset, value, error against the finest preset (for
/// the finest: its own error bar), the paper's value ± error, whether the paper's error bar is
/// reached, cost and peak memory.
pub fn summary_table(rows: &[Assessed]) -> Table {
    let f = |g: &dyn Fn(&Assessed) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
    let opt = |x: Option<f64>| x.unwrap_or(f64::NAN);
    Table::new()
        .with_str(
            "quantity",
            rows.iter().map(|r| r.entry.headline.name.clone()),
        )
        .with_str(
            "preset",
            rows.iter().map(|r| {
                if r.reference {
                    format!("{} (reference)", r.entry.preset)
                } else {
                    r.entry.preset.clone()
                }
            }),
        )
        .with_f64("value", f(&|r| r.entry.headline.value))
        .with_f64("error", f(&|r| r.error))
        .with_f64("paper", f(&|r| opt(r.entry.headline.paper)))
        .with_f64("paper error bar", f(&|r| opt(r.entry.headline.paper_error)))
        .with_str("within it", rows.iter().map(Assessed::verdict))
        .with_f64("cost (s)", f(&|r| r.entry.cost_s))
        .with_f64("peak (MiB)", f(&|r| r.entry.peak_mib))
}

/// Relative error against cost, one curve per quantity, points labelled by preset; points
/// without a positive finite error (e.g. a reference without an error bar) are left out.
pub fn figure_data(rows: &[Assessed]) -> TradeoffData {
    let mut curves: BTreeMap<&str, TradeoffCurve> = BTreeMap::new();
    for r in rows {
        if !(r.relative_error.is_finite() && r.relative_error > 0.0 && r.entry.cost_s > 0.0) {
            continue;
        }
        let c = curves
            .entry(r.entry.headline.name.as_str())
            .or_insert_with(|| TradeoffCurve {
                // names are plain text: escape the label markup
                label: r
                    .entry
                    .headline
                    .name
                    .replace('\\', "\\\\")
                    .replace('_', "\\_")
                    .replace('^', "\\^")
                    .replace('$', "\\$")
                    .replace('{', "\\{")
                    .replace('}', "\\}"),
                ..Default::default()
            });
        c.cost.push(r.entry.cost_s);
        c.error.push(r.relative_error);
        c.point_labels.push(r.entry.preset.clone());
    }
    TradeoffData {
        cost_label: "wall time of the stage and its inputs (s)".into(),
        error_label: "relative error against the finest preset".into(),
        curves: curves
            .into_values()
            .filter(|c| !c.cost.is_empty())
            .collect(),
        target: None,
    }
}

/// Replaces the text between the lines `begin` and `end` (markers kept) with `body`.
pub fn replace_block(text: &str, begin: &str, end: &str, body: &str) -> Result<String> {
    let (Some(b), Some(e)) = (text.find(begin), text.find(end)) else {
        bail!("markers `{begin}` and `{end}` not found");
    };
    if e < b {
        bail!("`{end}` comes before `{begin}`");
    }
    let head = &text[..b + begin.len()];
    let tail = &text[e..];
    Ok(format!("{head}\n{}\n{tail}", body.trim_end()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(preset: &str, name: &str, v: f64, err: Option<f64>) -> Entry {
        Entry {
            preset: preset.into(),
            stage: "s".into(),
            headline: Headline {
                name: name.into(),
                value: v,
                error: err,
                paper: Some(1.0),
                paper_error: Some(0.01),
            },
            cost_s: 1.0,
            peak_mib: 10.0,
        }
    }

    #[test]
    fn errors_are_measured_against_the_finest_preset() {
        let presets: Vec<String> = ["smoke", "draft", "paper"].map(String::from).into();
        let e = vec![
            entry("paper", "a", 1.001, Some(0.002)),
            entry("smoke", "a", 1.1, None),
            entry("draft", "a", 1.005, Some(0.01)),
            entry("draft", "b", 2.0, None),
        ];
        let a = assess(&e, &presets);
        let by = |p: &str, q: &str| {
            a.iter()
                .find(|r| r.entry.preset == p && r.entry.headline.name == q)
                .unwrap()
        };
        assert!(by("paper", "a").reference && !by("draft", "a").reference);
        assert!((by("smoke", "a").error - 0.099).abs() < 1e-12);
        assert!((by("draft", "a").error - 0.004).abs() < 1e-12);
        assert_eq!(by("paper", "a").error, 0.002);
        assert_eq!(by("smoke", "a").reaches_paper_error, Some(false));
        assert_eq!(by("draft", "a").reaches_paper_error, Some(true));
        // a quantity only one preset has is its own reference; without an error bar its error
        // is unknown, and so is whether it reaches the paper's
        assert!(by("draft", "b").reference && by("draft", "b").error.is_nan());
        assert_eq!(by("draft", "b").reaches_paper_error, None);
        let t = table(&a).unwrap();
        assert_eq!(t.n_rows(), 4);
        let s = sorted(a.clone(), &presets);
        let order: Vec<(&str, &str)> = s
            .iter()
            .map(|r| (r.entry.headline.name.as_str(), r.entry.preset.as_str()))
            .collect();
        assert_eq!(
            order,
            [
                ("a", "smoke"),
                ("a", "draft"),
                ("a", "paper"),
                ("b", "draft")
            ]
        );
        let st = summary_table(&s);
        assert_eq!(st.str("preset").unwrap()[2], "paper (reference)");
        let d = figure_data(&a);
        assert_eq!(d.curves.len(), 1, "b has no finite error");
        assert_eq!(d.curves[0].cost.len(), 3);
    }

    #[test]
    fn the_readme_block_is_replaced_between_its_markers() {
        let t = "intro\n<!-- b -->\nold\n<!-- e -->\nrest\n";
        let r = replace_block(t, "<!-- b -->", "<!-- e -->", "new table\n").unwrap();
        assert_eq!(r, "intro\n<!-- b -->\nnew table\n<!-- e -->\nrest\n");
        assert!(replace_block("x", "<!-- b -->", "<!-- e -->", "y").is_err());
    }
}
