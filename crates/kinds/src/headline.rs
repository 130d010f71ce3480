//! Headline numbers: the results of the study a stage reports (a_p and L_c per model, the
//! exponents, γ_fc/γ_p, ...), with their error bars and the paper's values. They are stored as
//! the JSON attribute `headline` of the stage's artefact (a list of [`Headline`]) and collected
//! across fidelity presets by `saddleflow tradeoff`, which measures each number's error against
//! its cost.
//!
//! A quantity's `name` identifies it across presets and must not depend on the fidelity (e.g.
//! "a_p square (corrected)", not "a_p square n=9").

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use store::{ArtefactReader, ArtefactWriter};

/// The artefact attribute holding the list.
pub const ATTR: &str = "headline";

/// One headline number.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Headline {
    /// Name of the quantity, the same at every fidelity.
    pub name: String,
    /// The value.
    pub value: f64,
    /// Its error bar (one standard error, or the extrapolation's error), `None` if unknown.
    pub error: Option<f64>,
    /// The paper's value, if it gives one.
    pub paper: Option<f64>,
    /// The paper's error bar, if it gives one.
    pub paper_error: Option<f64>,
}

impl Headline {
    /// A value with an error bar (non-finite errors become `None`), no paper value.
    pub fn new(name: impl Into<String>, value: f64, error: f64) -> Self {
        Self {
            name: name.into(),
            value,
            error: error.is_finite().then_some(error),
            paper: None,
            paper_error: None,
        }
    }

    /// Adds the paper's value and error bar (non-finite ones are left out).
    pub fn paper(mut self, value: f64, error: f64) -> Self {
        self.paper = value.is_finite().then_some(value);
        self.paper_error = error.is_finite().then_some(error);
        self
    }
}

/// Stores `list` as the artefact's `headline` attribute (non-finite values are left out: they
/// are no result).
pub fn write(out: &mut ArtefactWriter, list: &[Headline]) -> Result<()> {
    let kept: Vec<&Headline> = list.iter().filter(|h| h.value.is_finite()).collect();
    out.set_attr(ATTR, serde_json::to_value(kept)?)
}

/// The artefact's headline numbers (empty if it has none).
pub fn read(r: &ArtefactReader) -> Result<Vec<Headline>> {
    if !r.has_attr(ATTR) {
        return Ok(Vec::new());
    }
    serde_json::from_value(r.attr_json(ATTR)?).context("attribute `headline`")
}
