//! A TOML document as a tree whose every value and key remembers its `file:line:col`, so that
//! files that `extends` others can be deep-merged and templates expanded without losing the
//! place each value was written.
//!
//! Layout: [`Node`] is a value with its [`Origin`]; tables keep their keys in written order.
//! Cost: one pass over the parsed document per file; merging is linear in the keys.
//! Exact: integers are 64-bit, floats are `f64` as TOML defines them; dates are rejected
//! (no stage needs them), as are `nan` and `inf` (a parameter must be a finite number).

use super::{ConfigError, ConfigErrors, Origin, Source};
use std::path::{Path, PathBuf};
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// A key of a table, with where it is written.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Key {
    pub name: String,
    pub origin: Origin,
}

/// A value with where it is written.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Node {
    pub v: Val,
    pub origin: Origin,
}

/// The value of a [`Node`].
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Val {
    Str(String),
    Int(i64),
    Float(f64),
    Bool(bool),
    Array(Vec<Node>),
    Table(Vec<(Key, Node)>),
}

impl Node {
    /// "a string", "a table", … for error messages.
    pub fn type_name(&self) -> &'static str {
        match &self.v {
            Val::Str(_) => "a string",
            Val::Int(_) => "an integer",
            Val::Float(_) => "a float",
            Val::Bool(_) => "a boolean",
            Val::Array(_) => "an array",
            Val::Table(_) => "a table",
        }
    }

    /// The entries if this is a table.
    pub fn table(&self) -> Option<&[(Key, Node)]> {
        match &self.v {
            Val::Table(t) => Some(t),
            _ => None,
        }
    }

    /// The value as JSON (what stage kinds validate).
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::Value;
        match &self.v {
            Val::Str(s) => Value::String(s.clone()),
            Val::Int(i) => Value::from(*i),
            // finite by construction (see `from_toml`)
            Val::Float(x) => serde_json::Number::from_f64(*x).map_or(Value::Null, Value::Number),
            Val::Bool(b) => Value::Bool(*b),
            Val::Array(a) => Value::Array(a.iter().map(Node::to_json).collect()),
            Val::Table(t) => Value::Object(
                t.iter()
                    .map(|(k, v)| (k.name.clone(), v.to_json()))
                    .collect(),
            ),
        }
    }

    /// Sets `context` on every origin in the tree (keys included).
    pub fn set_context(&mut self, context: &std::sync::Arc<str>) {
        self.origin.context = Some(context.clone());
        match &mut self.v {
            Val::Array(a) => a.iter_mut().for_each(|x| x.set_context(context)),
            Val::Table(t) => {
                for (k, x) in t.iter_mut() {
                    k.origin.context = Some(context.clone());
                    x.set_context(context);
                }
            }
            _ => {}
        }
    }
}

/// Converts a parsed TOML value; dates, non-finite floats and integers beyond 64 bits are
/// errors (reported, replaced by `false` so that the other errors are still found).
pub(crate) fn from_toml(
    src: &Source,
    v: &Spanned<DeValue<'_>>,
    errs: &mut Vec<ConfigError>,
) -> Node {
    let origin = src.at(v);
    let v = match v.get_ref() {
        DeValue::String(s) => Val::Str(s.to_string()),
        DeValue::Integer(i) => match i64::from_str_radix(i.as_str(), i.radix()) {
            Ok(x) => Val::Int(x),
            Err(_) => {
                errs.push(ConfigError::at(
                    &origin,
                    format!("integer {i} does not fit 64 bits"),
                ));
                Val::Bool(false)
            }
        },
        DeValue::Float(f) => {
            let x: f64 = f.as_str().parse().unwrap_or(f64::NAN);
            if x.is_finite() {
                Val::Float(x)
            } else {
                errs.push(ConfigError::at(
                    &origin,
                    format!("`{f}`: only finite numbers are allowed (no nan or inf)"),
                ));
                Val::Bool(false)
            }
        }
        DeValue::Boolean(b) => Val::Bool(*b),
        DeValue::Datetime(d) => {
            errs.push(ConfigError::at(
                &origin,
                format!("dates are not supported (found {d}); write a string"),
            ));
            Val::Bool(false)
        }
        DeValue::Array(a) => Val::Array(a.iter().map(|x| from_toml(src, x, errs)).collect()),
        DeValue::Table(t) => Val::Table(table_from_toml(src, t, errs)),
    };
    Node { v, origin }
}

fn table_from_toml(src: &Source, t: &DeTable<'_>, errs: &mut Vec<ConfigError>) -> Vec<(Key, Node)> {
    t.iter()
        .map(|(k, x)| {
            let key = Key {
                name: k.get_ref().to_string(),
                origin: src.at(k),
            };
            (key, from_toml(src, x, errs))
        })
        .collect()
}

fn parse_root(src: &Source) -> Result<Node, ConfigErrors> {
    let root = DeTable::parse(&src.text).map_err(|e| {
        let origin = e.span().map(|s| src.origin(s.start));
        // the toml crate's "duplicate key" does not say which: its span covers the key
        let key = e
            .span()
            .and_then(|s| src.text.get(s))
            .map(str::trim)
            .filter(|k| !k.is_empty() && e.message().starts_with("duplicate key"));
        let message = match key {
            Some(k) => format!("invalid TOML: duplicate key `{k}` (it is set earlier in the file)"),
            None => format!("invalid TOML: {}", e.message()),
        };
        ConfigErrors(vec![ConfigError { origin, message }])
    })?;
    let mut errs = Vec::new();
    let node = Node {
        v: Val::Table(table_from_toml(src, root.get_ref(), &mut errs)),
        origin: src.origin(0),
    };
    if errs.is_empty() {
        Ok(node)
    } else {
        Err(ConfigErrors(errs))
    }
}

/// `over` deep-merged onto `base`: tables merge key by key (recursively), anything else in
/// `over` replaces what `base` has. New keys keep their written order after the base's.
pub(crate) fn deep_merge(base: Node, over: Node) -> Node {
    match (base.v, over.v) {
        (Val::Table(mut b), Val::Table(o)) => {
            for (k, x) in o {
                match b.iter().position(|(bk, _)| bk.name == k.name) {
                    Some(i) => {
                        let (_, old) = b.remove(i);
                        b.insert(i, (k, deep_merge(old, x)));
                    }
                    None => b.push((k, x)),
                }
            }
            Node {
                v: Val::Table(b),
                origin: over.origin,
            }
        }
        (_, v) => Node {
            v,
            origin: over.origin,
        },
    }
}

/// Parses one file as a tree. `text`: the file's text if already known (tests), else it is
/// read. A top-level `extends = "FILE"` (relative to this file's folder) makes this file a
/// deep-merge of its own tables onto FILE's (which may extend another: the chain is followed,
/// and a cycle is an error naming it).
pub(crate) fn load_tree(path: &Path, text: Option<String>) -> Result<Node, ConfigErrors> {
    load_chain(path, text, &mut Vec::new())
}

fn load_chain(
    path: &Path,
    text: Option<String>,
    chain: &mut Vec<PathBuf>,
) -> Result<Node, ConfigErrors> {
    let name = path.to_string_lossy().into_owned();
    let text = match text {
        Some(t) => t,
        None => std::fs::read_to_string(path).map_err(|e| {
            ConfigErrors(vec![ConfigError::plain(format!(
                "cannot read `{name}`: {e}"
            ))])
        })?,
    };
    let src = Source::new(&name, text);
    let mut root = parse_root(&src)?;
    let Val::Table(entries) = &mut root.v else {
        unreachable!("a TOML document is a table")
    };
    let Some(i) = entries.iter().position(|(k, _)| k.name == "extends") else {
        return Ok(root);
    };
    let (_, parent) = entries.remove(i);
    let Val::Str(rel) = &parent.v else {
        return Err(ConfigErrors(vec![ConfigError::at(
            &parent.origin,
            format!(
                "`extends` must be a file name (a string, relative to this file's folder), found {}",
                parent.type_name()
            ),
        )]));
    };
    let parent_path = path.parent().unwrap_or(Path::new("")).join(rel);
    // compare real paths where they exist, so `./a.toml` and `a.toml` are one file
    let id = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    chain.push(id(path));
    if chain.contains(&id(&parent_path)) {
        let mut names: Vec<String> = chain.iter().map(|p| p.display().to_string()).collect();
        names.push(id(&parent_path).display().to_string());
        return Err(ConfigErrors(vec![ConfigError::at(
            &parent.origin,
            format!("`extends` forms a cycle: {}", names.join(" → ")),
        )]));
    }
    if !parent_path.exists() {
        return Err(ConfigErrors(vec![ConfigError::at(
            &parent.origin,
            format!(
                "`extends = \"{rel}\"`: no file `{}` (the name is relative to this file's folder)",
                parent_path.display()
            ),
        )]));
    }
    let base = load_chain(&parent_path, None, chain)?;
    chain.pop();
    Ok(deep_merge(base, root))
}
