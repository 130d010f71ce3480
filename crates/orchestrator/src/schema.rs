//! Parameter schemas of stage kinds: types, ranges, defaults, validation.
//!
//! A stage kind declares its parameters as a list of [`ParamSpec`]s. Validation
//! ([`validate_params`]) rejects unknown names (listing the known ones), wrong types and
//! out-of-range values, coerces integers where floats are expected, and fills in every default,
//! so that the cache key sees the complete parameter set.

use serde_json::{Map, Number, Value};
use std::fmt;

/// The type and allowed range of one parameter.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamType {
    /// A 64-bit signed integer, optionally bounded (inclusive).
    Int {
        /// Smallest allowed value.
        min: Option<i64>,
        /// Largest allowed value.
        max: Option<i64>,
    },
    /// A finite 64-bit float, optionally bounded (inclusive or exclusive). TOML integers are
    /// accepted and converted.
    Float {
        /// Lower bound.
        min: Option<f64>,
        /// Whether the lower bound itself is excluded.
        min_exclusive: bool,
        /// Upper bound.
        max: Option<f64>,
        /// Whether the upper bound itself is excluded.
        max_exclusive: bool,
    },
    /// `true` or `false`.
    Bool,
    /// A string, optionally one of a fixed set.
    Str {
        /// The allowed values (`None`: any string).
        allowed: Option<Vec<String>>,
    },
    /// An array whose elements all have one type.
    Array {
        /// Element type.
        elem: Box<ParamType>,
        /// Minimal length.
        min_len: usize,
        /// Maximal length.
        max_len: Option<usize>,
    },
    /// Any TOML/JSON value, not checked (the kind's own `check` should).
    Any,
}

impl ParamType {
    /// An unbounded integer.
    pub fn int() -> Self {
        Self::Int {
            min: None,
            max: None,
        }
    }
    /// An integer in `min..=max`.
    pub fn int_range(min: i64, max: i64) -> Self {
        Self::Int {
            min: Some(min),
            max: Some(max),
        }
    }
    /// An unbounded finite float.
    pub fn float() -> Self {
        Self::Float {
            min: None,
            min_exclusive: false,
            max: None,
            max_exclusive: false,
        }
    }
    /// A float > 0.
    pub fn positive() -> Self {
        Self::Float {
            min: Some(0.0),
            min_exclusive: true,
            max: None,
            max_exclusive: false,
        }
    }
    /// A float ≥ 0.
    pub fn non_negative() -> Self {
        Self::Float {
            min: Some(0.0),
            min_exclusive: false,
            max: None,
            max_exclusive: false,
        }
    }
    /// A float in `[min, max]`.
    pub fn float_range(min: f64, max: f64) -> Self {
        Self::Float {
            min: Some(min),
            min_exclusive: false,
            max: Some(max),
            max_exclusive: false,
        }
    }
    /// Any string.
    pub fn string() -> Self {
        Self::Str { allowed: None }
    }
    /// One of the given strings.
    pub fn one_of(values: &[&str]) -> Self {
        Self::Str {
            allowed: Some(values.iter().map(|s| s.to_string()).collect()),
        }
    }
    /// A non-empty array of `elem`.
    pub fn array_of(elem: ParamType) -> Self {
        Self::Array {
            elem: Box::new(elem),
            min_len: 1,
            max_len: None,
        }
    }

    /// Checks and normalises `v` (integers become floats where floats are expected). The error
    /// is a sentence fragment saying what was wrong.
    pub fn check(&self, v: &Value) -> Result<Value, String> {
        match self {
            Self::Any => Ok(v.clone()),
            Self::Bool => v
                .as_bool()
                .map(Value::Bool)
                .ok_or_else(|| format!("expected {self}, found {}", describe(v))),
            Self::Int { min, max } => {
                let i = match v {
                    Value::Number(n) if n.is_i64() => n.as_i64().unwrap_or_default(),
                    Value::Number(n) if n.is_u64() => {
                        return Err(format!("{n} does not fit a 64-bit integer"));
                    }
                    _ => return Err(format!("expected {self}, found {}", describe(v))),
                };
                if min.is_some_and(|m| i < m) || max.is_some_and(|m| i > m) {
                    return Err(format!("{i} is out of range: expected {self}"));
                }
                Ok(Value::from(i))
            }
            Self::Float {
                min,
                min_exclusive,
                max,
                max_exclusive,
            } => {
                let x = match v {
                    Value::Number(n) => n.as_f64().unwrap_or(f64::NAN),
                    _ => return Err(format!("expected {self}, found {}", describe(v))),
                };
                if !x.is_finite() {
                    return Err(format!("{x} is not finite: expected {self}"));
                }
                let below = min.is_some_and(|m| if *min_exclusive { x <= m } else { x < m });
                let above = max.is_some_and(|m| if *max_exclusive { x >= m } else { x > m });
                if below || above {
                    return Err(format!("{x} is out of range: expected {self}"));
                }
                Ok(Number::from_f64(x)
                    .map(Value::Number)
                    .unwrap_or(Value::Null))
            }
            Self::Str { allowed } => {
                let s = v
                    .as_str()
                    .ok_or_else(|| format!("expected {self}, found {}", describe(v)))?;
                if let Some(a) = allowed
                    && !a.iter().any(|x| x == s)
                {
                    return Err(format!("\"{s}\" is not allowed: expected {self}"));
                }
                Ok(Value::String(s.to_string()))
            }
            Self::Array {
                elem,
                min_len,
                max_len,
            } => {
                let items = v
                    .as_array()
                    .ok_or_else(|| format!("expected {self}, found {}", describe(v)))?;
                if items.len() < *min_len || max_len.is_some_and(|m| items.len() > m) {
                    return Err(format!(
                        "an array of {} elements is not allowed: expected {self}",
                        items.len()
                    ));
                }
                items
                    .iter()
                    .enumerate()
                    .map(|(i, x)| elem.check(x).map_err(|e| format!("element {i}: {e}")))
                    .collect::<Result<Vec<_>, _>>()
                    .map(Value::Array)
            }
        }
    }
}

impl fmt::Display for ParamType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Any => write!(f, "any value"),
            Self::Bool => write!(f, "a boolean (true or false)"),
            Self::Int { min, max } => match (min, max) {
                (Some(a), Some(b)) => write!(f, "an integer in {a}..={b}"),
                (Some(a), None) => write!(f, "an integer ≥ {a}"),
                (None, Some(b)) => write!(f, "an integer ≤ {b}"),
                (None, None) => write!(f, "an integer"),
            },
            Self::Float {
                min,
                min_exclusive,
                max,
                max_exclusive,
            } => {
                let lo = |m: f64| format!("{} {m}", if *min_exclusive { ">" } else { "≥" });
                let hi = |m: f64| format!("{} {m}", if *max_exclusive { "<" } else { "≤" });
                match (min, max) {
                    (Some(a), Some(b)) => write!(
                        f,
                        "a number in {}{a}, {b}{}",
                        if *min_exclusive { "(" } else { "[" },
                        if *max_exclusive { ")" } else { "]" }
                    ),
                    (Some(a), None) => write!(f, "a number {}", lo(*a)),
                    (None, Some(b)) => write!(f, "a number {}", hi(*b)),
                    (None, None) => write!(f, "a finite number"),
                }
            }
            Self::Str { allowed: None } => write!(f, "a string"),
            Self::Str { allowed: Some(a) } => {
                let list: Vec<String> = a.iter().map(|s| format!("\"{s}\"")).collect();
                write!(f, "one of {}", list.join(", "))
            }
            Self::Array {
                elem,
                min_len,
                max_len,
            } => {
                write!(f, "an array of {elem}")?;
                match (min_len, max_len) {
                    (0, None) => Ok(()),
                    (1, None) => write!(f, " (non-empty)"),
                    (a, None) => write!(f, " (at least {a} elements)"),
                    (a, Some(b)) if a == b => write!(f, " ({a} elements)"),
                    (a, Some(b)) => write!(f, " ({a} to {b} elements)"),
                }
            }
        }
    }
}

/// Short description of a JSON value's type and value, for error messages.
pub fn describe(v: &Value) -> String {
    match v {
        Value::Null => "nothing".into(),
        Value::Bool(b) => format!("the boolean {b}"),
        Value::Number(n) if n.is_f64() => format!("the float {n}"),
        Value::Number(n) => format!("the integer {n}"),
        Value::String(s) => format!("the string \"{s}\""),
        Value::Array(_) => "an array".into(),
        Value::Object(_) => "a table".into(),
    }
}

/// One parameter of a stage kind.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamSpec {
    /// Its name in the pipeline file's `params` table.
    pub name: String,
    /// Type and range.
    pub ty: ParamType,
    /// Default (`None`: required).
    pub default: Option<Value>,
    /// One line of documentation.
    pub doc: String,
}

impl ParamSpec {
    /// A required parameter.
    pub fn new(name: &str, ty: ParamType) -> Self {
        Self {
            name: name.into(),
            ty,
            default: None,
            doc: String::new(),
        }
    }
    /// With a default value (which makes it optional).
    pub fn default(mut self, v: impl Into<Value>) -> Self {
        self.default = Some(v.into());
        self
    }
    /// With documentation.
    pub fn doc(mut self, doc: &str) -> Self {
        self.doc = doc.into();
        self
    }
}

/// A problem with one parameter, before it is located in a file.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamIssue {
    /// The parameter's name (`None`: the parameter set as a whole).
    pub key: Option<String>,
    /// What is wrong, including what is allowed.
    pub message: String,
    /// Whether the name itself is wrong (report at the key, not at the value).
    pub at_key: bool,
}

impl ParamIssue {
    /// An issue with parameter `key`.
    pub fn new(key: &str, message: impl Into<String>) -> Self {
        Self {
            key: Some(key.into()),
            message: message.into(),
            at_key: false,
        }
    }
}

impl fmt::Display for ParamIssue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.key {
            Some(k) => write!(f, "parameter `{k}`: {}", self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

/// Validates `given` against `specs`: unknown names, types, ranges; fills defaults. Returns all
/// issues, not only the first.
pub fn validate_params(
    specs: &[ParamSpec],
    given: &Map<String, Value>,
) -> Result<Map<String, Value>, Vec<ParamIssue>> {
    let mut out = Map::new();
    let mut issues = Vec::new();
    for (k, _) in given {
        if !specs.iter().any(|s| &s.name == k) {
            let known: Vec<&str> = specs.iter().map(|s| s.name.as_str()).collect();
            let hint = crate::util::did_you_mean(k, &known)
                .map(|s| format!("did you mean `{s}`? "))
                .unwrap_or_default();
            issues.push(ParamIssue {
                at_key: true,
                ..ParamIssue::new(
                    k,
                    format!(
                        "unknown parameter; {hint}allowed: {}",
                        if known.is_empty() {
                            "none".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                )
            });
        }
    }
    for s in specs {
        match given.get(&s.name) {
            Some(v) => match s.ty.check(v) {
                Ok(v) => {
                    out.insert(s.name.clone(), v);
                }
                Err(e) => issues.push(ParamIssue::new(&s.name, e)),
            },
            None => match &s.default {
                Some(d) => {
                    // defaults go through the same normalisation as given values
                    match s.ty.check(d) {
                        Ok(v) => {
                            out.insert(s.name.clone(), v);
                        }
                        Err(e) => issues.push(ParamIssue::new(
                            &s.name,
                            format!("the kind's own default is invalid ({e}): a bug in the kind"),
                        )),
                    }
                }
                None => issues.push(ParamIssue::new(
                    &s.name,
                    format!("missing; it is required: {}", s.ty),
                )),
            },
        }
    }
    if issues.is_empty() {
        Ok(out)
    } else {
        Err(issues)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn specs() -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("n", ParamType::int_range(3, 13)),
            ParamSpec::new("tol", ParamType::positive()).default(1e-8),
            ParamSpec::new("lattice", ParamType::one_of(&["square", "triangular"]))
                .default("square"),
            ParamSpec::new(
                "loads",
                ParamType::array_of(ParamType::float_range(0.0, 1.0)),
            )
            .default(json!([0.5])),
        ]
    }

    #[test]
    fn defaults_and_coercion() {
        let m = json!({"n": 5, "tol": 1}).as_object().unwrap().clone();
        let out = validate_params(&specs(), &m).unwrap();
        assert_eq!(
            Value::Object(out),
            json!({"n": 5, "tol": 1.0, "lattice": "square", "loads": [0.5]})
        );
    }

    #[test]
    fn all_issues_reported() {
        let m = json!({"n": 20, "tol": "x", "latice": "square", "loads": [0.1, 2]})
            .as_object()
            .unwrap()
            .clone();
        let issues = validate_params(&specs(), &m).unwrap_err();
        let text: Vec<String> = issues.iter().map(|i| i.to_string()).collect();
        let all = text.join("\n");
        assert!(
            all.contains("`n`: 20 is out of range: expected an integer in 3..=13"),
            "{all}"
        );
        assert!(
            all.contains("`tol`: expected a number > 0, found the string \"x\""),
            "{all}"
        );
        assert!(
            all.contains("`latice`: unknown parameter; did you mean `lattice`?"),
            "{all}"
        );
        assert!(all.contains("element 1: 2 is out of range"), "{all}");
    }

    #[test]
    fn missing_required() {
        let issues = validate_params(&specs(), &Map::new()).unwrap_err();
        assert_eq!(issues.len(), 1);
        assert!(issues[0].message.contains("required: an integer in 3..=13"));
    }
}
