//! Named values, `{name}` references and `matrix` templates of a pipeline file, expanded into
//! concrete stages before anything else looks at them.
//!
//! - `[values]` names a value once (a load path, a list of lattices, a table of inputs); a
//!   string `"{name}"` anywhere in a stage or scene is replaced by that value (any type),
//!   `"{name.field}"` takes a field of a table value (`"{rows.0}"`: an array element), and a
//!   reference inside a longer string (`"surface_{lattice}"`) splices in a string or integer.
//!   `{{` and `}}` write literal braces. Values may refer to other values (a cycle is an error).
//! - A stage with `matrix = { a = [...], b = [...] }` is a template: one concrete stage per
//!   combination (the Cartesian product), named by its `name` pattern,
//!   with the matrix variables in scope like named values (they shadow them). A matrix with one
//!   variable is a foreach.
//! - In a table, the key `"<<"` merges in a table (or a list of tables, later ones winning):
//!   keys written beside it win (YAML's merge key; shallow).
//!
//! Everything is expanded here, so keys, dry-run reasons and errors are per concrete stage;
//! every value of an instance carries the context "template `T`, instance `I`", which errors
//! print after their `file:line:col`. Cost: linear in the size of the expanded pipeline.

use super::tree::{Key, Node, Val};
use super::{ConfigError, Located, Origin, valid_name};
use crate::util::did_you_mean;
use serde_json::Value;
use std::collections::BTreeMap;
use std::sync::Arc;

/// The settings a matrix variable may take (`matrix.seed = "$ensemble_seeds"`): a template is
/// expanded once the preset is known, so that a preset sets how many instances there are.
pub(crate) struct MatrixSettings<'a> {
    /// Setting values: the preset's (checked), or, before a preset is known, the declared
    /// defaults.
    pub values: &'a BTreeMap<String, Located<Value>>,
    /// Every declared setting (for "unknown setting" errors).
    pub declared: Vec<&'a str>,
    /// Whether `values` are a preset's. If not, a template whose matrix takes a setting without
    /// a default is left pending (no instances, no error) until the preset is known.
    pub preset: bool,
    /// Set when some matrix took a setting (the pipeline must be expanded again per preset).
    pub used: bool,
}

/// The key that merges a table into the one it is written in.
pub(crate) const MERGE_KEY: &str = "<<";

/// The named values: resolved on first use (so that values may refer to values).
pub(crate) struct Values<'a> {
    raw: &'a [(Key, Node)],
    done: BTreeMap<String, Node>,
    stack: Vec<String>,
}

impl<'a> Values<'a> {
    /// The values of a `[values]` table (empty if there is none).
    pub fn new(raw: &'a [(Key, Node)]) -> Self {
        Self {
            raw,
            done: BTreeMap::new(),
            stack: Vec::new(),
        }
    }

    /// Resolves every value (reporting errors even in values no stage uses).
    pub fn resolve_all(&mut self, errs: &mut Vec<ConfigError>) {
        for (k, v) in self.raw {
            if let Err(e) = self.get(&k.name, v) {
                errs.push(e);
            }
        }
    }

    fn names(&self) -> impl Iterator<Item = &str> {
        self.raw.iter().map(|(k, _)| k.name.as_str())
    }

    /// The value at `path` (`name` or `name.field.0`), its references resolved; `None` if no
    /// value has the path's first name. Only the part the path names is resolved, so that a
    /// field may refer to a sibling (`{fig6.hardwall}` inside `fig6.cases`).
    fn get(&mut self, path: &str, at: &Node) -> Result<Option<Node>, ConfigError> {
        if let Some(v) = self.done.get(path) {
            return Ok(Some(v.clone()));
        }
        let mut parts = path.split('.');
        let head = parts.next().unwrap_or("");
        let raw = self.raw;
        let Some((key, node)) = raw.iter().find(|(k, _)| k.name == head) else {
            return Ok(None);
        };
        if let Some(i) = self.stack.iter().position(|s| s == path) {
            let mut cycle = self.stack[i..].to_vec();
            cycle.push(path.to_string());
            return Err(ConfigError::at(
                &key.origin,
                format!(
                    "named values refer to each other in a cycle: {}",
                    cycle.join(" → ")
                ),
            ));
        }
        self.stack.push(path.to_string());
        let out = self.walk(node, head, parts, path, at);
        self.stack.pop();
        let out = out?;
        self.done.insert(path.to_string(), out.clone());
        Ok(Some(out))
    }

    fn walk<'p>(
        &mut self,
        node: &Node,
        head: &str,
        parts: impl Iterator<Item = &'p str>,
        path: &str,
        at: &Node,
    ) -> Result<Node, ConfigError> {
        let mut node = node.clone();
        let mut walked = head.to_string();
        for part in parts {
            if let Val::Str(_) = node.v {
                // a reference to another value: resolve it before stepping into it
                node = self.resolve(&node)?;
            }
            node = step(&node, part, &walked, path, at)?;
            walked = format!("{walked}.{part}");
        }
        self.resolve(&node)
    }

    fn resolve(&mut self, node: &Node) -> Result<Node, ConfigError> {
        let mut errs = Vec::new();
        let out = subst_with(node, &[], self, &mut errs);
        match errs.into_iter().next() {
            Some(e) => Err(e),
            None => Ok(out),
        }
    }
}

/// The field (or array element) `part` of `node`, which the reference `path` reached as
/// `walked`.
fn step(node: &Node, part: &str, walked: &str, path: &str, at: &Node) -> Result<Node, ConfigError> {
    let next = match &node.v {
        Val::Table(t) => t.iter().find(|(k, _)| k.name == part).map(|(_, v)| v),
        Val::Array(a) => part.parse::<usize>().ok().and_then(|i| a.get(i)),
        _ => None,
    };
    next.cloned().ok_or_else(|| {
        let has = match &node.v {
            Val::Table(t) => format!(
                "its fields: {}",
                t.iter()
                    .map(|(k, _)| k.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Val::Array(a) => format!("it is an array of {} elements (index from 0)", a.len()),
            _ => format!("it is {}", node.type_name()),
        };
        ConfigError::at(
            &at.origin,
            format!("`{{{path}}}`: `{walked}` has no field `{part}`; {has}"),
        )
    })
}

/// One reference `{a.b.0}` looked up in `vars`, then `values`.
fn lookup(
    path: &str,
    at: &Node,
    vars: &[(String, Node)],
    values: &mut Values<'_>,
) -> Result<Node, ConfigError> {
    let mut parts = path.split('.');
    let head = parts.next().unwrap_or("");
    if let Some((_, v)) = vars.iter().find(|(n, _)| n == head) {
        let mut node = v.clone();
        let mut walked = head.to_string();
        for part in parts {
            node = step(&node, part, &walked, path, at)?;
            walked = format!("{walked}.{part}");
        }
        return Ok(node);
    }
    if let Some(v) = values.get(path, at)? {
        return Ok(v);
    }
    let mut names: Vec<&str> = vars.iter().map(|(n, _)| n.as_str()).collect();
    names.extend(values.names());
    let hint = did_you_mean(head, &names)
        .map(|s| format!("did you mean `{{{s}}}`? "))
        .unwrap_or_default();
    Err(ConfigError::at(
        &at.origin,
        format!(
            "unknown name `{{{head}}}`; {hint}known: {} (matrix variables and [values]; write `{{{{` for a literal brace)",
            if names.is_empty() {
                "none".into()
            } else {
                names.join(", ")
            }
        ),
    ))
}

/// The pieces of a string: literal text and `{reference}`s.
enum Piece {
    Text(String),
    Ref(String),
}

fn pieces(s: &str) -> Result<Vec<Piece>, String> {
    let mut out = Vec::new();
    let mut text = String::new();
    let mut chars = s.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '{' if chars.peek() == Some(&'{') => {
                chars.next();
                text.push('{');
            }
            '}' if chars.peek() == Some(&'}') => {
                chars.next();
                text.push('}');
            }
            '{' => {
                let name: String = chars.by_ref().take_while(|&c| c != '}').collect();
                let ok = !name.is_empty()
                    && name.split('.').all(|p| {
                        valid_name(p) || (!p.is_empty() && p.chars().all(|c| c.is_ascii_digit()))
                    });
                if !ok {
                    return Err(format!(
                        "`{{{name}` in \"{s}\" is not a reference `{{name}}` or `{{name.field}}` (write `{{{{` and `}}}}` for literal braces)"
                    ));
                }
                if !text.is_empty() {
                    out.push(Piece::Text(std::mem::take(&mut text)));
                }
                out.push(Piece::Ref(name));
            }
            '}' => {
                return Err(format!(
                    "unmatched `}}` in \"{s}\" (write `}}}}` for a literal brace)"
                ));
            }
            c => text.push(c),
        }
    }
    if !text.is_empty() || out.is_empty() {
        out.push(Piece::Text(text));
    }
    Ok(out)
}

fn subst_str(
    s: &str,
    at: &Node,
    vars: &[(String, Node)],
    values: &mut Values<'_>,
) -> Result<Node, ConfigError> {
    let pieces = pieces(s).map_err(|m| ConfigError::at(&at.origin, m))?;
    if let [Piece::Ref(path)] = pieces.as_slice() {
        return lookup(path, at, vars, values);
    }
    let mut out = String::new();
    for p in pieces {
        match p {
            Piece::Text(t) => out.push_str(&t),
            Piece::Ref(path) => {
                let v = lookup(&path, at, vars, values)?;
                match &v.v {
                    Val::Str(x) => out.push_str(x),
                    Val::Int(i) => out.push_str(&i.to_string()),
                    _ => {
                        return Err(ConfigError::at(
                            &at.origin,
                            format!(
                                "`{{{path}}}` is {} (written at {}): only a string or an integer can be part of a longer string",
                                v.type_name(),
                                v.origin
                            ),
                        ));
                    }
                }
            }
        }
    }
    Ok(Node {
        v: Val::Str(out),
        origin: at.origin.clone(),
    })
}

/// `node` with every reference replaced and every `"<<"` merged.
fn subst_with(
    node: &Node,
    vars: &[(String, Node)],
    values: &mut Values<'_>,
    errs: &mut Vec<ConfigError>,
) -> Node {
    let v = match &node.v {
        Val::Str(s) => match subst_str(s, node, vars, values) {
            Ok(x) => return x,
            Err(e) => {
                errs.push(e);
                return node.clone();
            }
        },
        Val::Array(a) => Val::Array(
            a.iter()
                .map(|x| subst_with(x, vars, values, errs))
                .collect(),
        ),
        Val::Table(t) => {
            let mut base: Vec<(Key, Node)> = Vec::new();
            let mut own: Vec<(Key, Node)> = Vec::new();
            for (k, x) in t {
                let x = subst_with(x, vars, values, errs);
                if k.name == MERGE_KEY {
                    merge_into(&mut base, &x, errs);
                } else {
                    own.push((k.clone(), x));
                }
            }
            for (k, x) in own {
                base.retain(|(b, _)| b.name != k.name);
                base.push((k, x));
            }
            Val::Table(base)
        }
        other => other.clone(),
    };
    Node {
        v,
        origin: node.origin.clone(),
    }
}

fn merge_into(base: &mut Vec<(Key, Node)>, x: &Node, errs: &mut Vec<ConfigError>) {
    match &x.v {
        Val::Table(t) => {
            for (k, v) in t {
                base.retain(|(b, _)| b.name != k.name);
                base.push((k.clone(), v.clone()));
            }
        }
        Val::Array(a) => a.iter().for_each(|y| merge_into(base, y, errs)),
        _ => errs.push(ConfigError::at(
            &x.origin,
            format!(
                "`\"{MERGE_KEY}\"` merges a table (or a list of tables) into this one, found {}",
                x.type_name()
            ),
        )),
    }
}

/// Replaces references to named values in a plain stage or scene.
pub(crate) fn subst_values(
    node: &Node,
    values: &mut Values<'_>,
    errs: &mut Vec<ConfigError>,
) -> Node {
    subst_with(node, &[], values, errs)
}

/// The concrete stages of one `[stages.NAME]` entry: itself (references replaced) or, if it
/// has a `matrix`, one instance per combination of the matrix variables.
pub(crate) fn expand_stage(
    key: &Key,
    decl: &Node,
    values: &mut Values<'_>,
    settings: &mut MatrixSettings<'_>,
    errs: &mut Vec<ConfigError>,
) -> Vec<(Key, Node)> {
    let Some(t) = decl.table() else {
        return vec![(key.clone(), decl.clone())];
    };
    let matrix = t.iter().find(|(k, _)| k.name == "matrix");
    let name = t.iter().find(|(k, _)| k.name == "name");
    let Some((mkey, matrix)) = matrix else {
        if let Some((nk, _)) = name {
            errs.push(ConfigError::at(
                &nk.origin,
                format!(
                    "stage `{}`: `name` names the instances of a template; it needs a `matrix` (or drop `name`: the table's name is the stage's)",
                    key.name
                ),
            ));
        }
        return vec![(key.clone(), subst_values(decl, values, errs))];
    };
    let tname = &key.name;
    let Some(axes) = matrix_axes(tname, mkey, matrix, values, settings, errs) else {
        return Vec::new();
    };
    let Some((_, pattern)) = name else {
        errs.push(ConfigError::at(
            &key.origin,
            format!(
                "template `{tname}` has a `matrix`, so it needs `name = \"...\"` naming each instance with the matrix variables ({})",
                axes.iter().map(|(n, _)| format!("{{{n}}}")).collect::<Vec<_>>().join(", ")
            ),
        ));
        return Vec::new();
    };
    let body: Vec<(Key, Node)> = t
        .iter()
        .filter(|(k, _)| k.name != "matrix" && k.name != "name")
        .cloned()
        .collect();
    let body = Node {
        v: Val::Table(body),
        origin: decl.origin.clone(),
    };
    let mut out: Vec<(Key, Node)> = Vec::new();
    for vars in product(&axes) {
        let before = errs.len();
        let inst = subst_with(pattern, &vars, values, errs);
        if errs.len() > before {
            // the same mistake in every instance: report it once, for the template
            add_context(&mut errs[before..], &format!("template `{tname}`").into());
            return Vec::new();
        }
        let inst = match inst.v {
            Val::Str(s) => s,
            _ => {
                errs.push(ConfigError::at(
                    &pattern.origin,
                    format!("template `{tname}`: `name` must give a string (a pattern like \"{tname}_{{var}}\")"),
                ));
                return Vec::new();
            }
        };
        if let Some((prev, _)) = out.iter().find(|(k, _)| k.name == inst) {
            errs.push(ConfigError::at(
                &pattern.origin,
                format!(
                    "template `{tname}`: two instances are named `{}`: the `name` pattern must use every matrix variable that varies ({})",
                    prev.name,
                    axes.iter().map(|(n, _)| format!("{{{n}}}")).collect::<Vec<_>>().join(", ")
                ),
            ));
            return Vec::new();
        }
        let context: Arc<str> = format!("template `{tname}`, instance `{inst}`").into();
        let before = errs.len();
        let mut node = subst_with(&body, &vars, values, errs);
        add_context(&mut errs[before..], &context);
        node.set_context(&context);
        let mut origin = key.origin.clone();
        origin.context = Some(context);
        out.push((Key { name: inst, origin }, node));
    }
    out
}

/// Marks errors as found in a template (or one of its instances), unless they already say so.
fn add_context(errs: &mut [ConfigError], context: &Arc<str>) {
    for o in errs.iter_mut().filter_map(|e| e.origin.as_mut()) {
        o.context.get_or_insert_with(|| context.clone());
    }
}

/// The matrix variables and their values.
fn matrix_axes(
    tname: &str,
    mkey: &Key,
    matrix: &Node,
    values: &mut Values<'_>,
    settings: &mut MatrixSettings<'_>,
    errs: &mut Vec<ConfigError>,
) -> Option<Vec<(String, Vec<Node>)>> {
    let before = errs.len();
    let matrix = subst_values(matrix, values, errs);
    let Some(t) = matrix.table() else {
        errs.push(ConfigError::at(
            &matrix.origin,
            format!(
                "template `{tname}`: `matrix` must be a table of variables and their values, like `matrix = {{ lattice = [\"square\", \"hexagonal\"] }}`, found {}",
                matrix.type_name()
            ),
        ));
        return None;
    };
    if t.is_empty() {
        errs.push(ConfigError::at(
            &mkey.origin,
            format!("template `{tname}`: `matrix` is empty: give it at least one variable"),
        ));
    }
    let mut axes = Vec::new();
    let mut pending = false;
    for (k, v) in t {
        if !valid_name(&k.name) || k.name.contains('-') {
            errs.push(ConfigError::at(
                &k.origin,
                format!(
                    "template `{tname}`: invalid matrix variable `{}`: use ASCII letters, digits and `_`, starting with a letter or `_`",
                    k.name
                ),
            ));
            continue;
        }
        if let Val::Str(s) = &v.v
            && let Some(name) = s.strip_prefix('$').filter(|n| !n.starts_with('$'))
        {
            match setting_axis(tname, &k.name, name, v, settings) {
                Ok(Some(vals)) => axes.push((k.name.clone(), vals)),
                Ok(None) => pending = true,
                Err(e) => errs.push(e),
            }
            continue;
        }
        match &v.v {
            Val::Array(a) if !a.is_empty() => axes.push((k.name.clone(), a.clone())),
            _ => errs.push(ConfigError::at(
                &v.origin,
                format!(
                    "template `{tname}`: matrix variable `{}` must be a non-empty array of its values, found {}",
                    k.name,
                    if matches!(v.v, Val::Array(_)) { "an empty array" } else { v.type_name() }
                ),
            )),
        }
    }
    // a pending template (its setting has no default and no preset is known yet) has no
    // instances until the preset is
    (errs.len() == before && !pending).then_some(axes)
}

/// The values of matrix variable `var` of template `tname`, written `"$name"` at `at`: the
/// setting `name`, which must be a list; an empty one gives the template no instances (a preset
/// that opts out; a required list input then says it needs one). `Ok(None)`: pending (see
/// [`MatrixSettings`]).
fn setting_axis(
    tname: &str,
    var: &str,
    name: &str,
    at: &Node,
    settings: &mut MatrixSettings<'_>,
) -> Result<Option<Vec<Node>>, ConfigError> {
    settings.used = true;
    let Some(v) = settings.values.get(name) else {
        if !settings.preset && settings.declared.contains(&name) {
            return Ok(None);
        }
        let hint = did_you_mean(name, &settings.declared)
            .map(|s| format!("did you mean `${s}`? "))
            .unwrap_or_default();
        return Err(ConfigError::at(
            &at.origin,
            format!(
                "template `{tname}`: matrix variable `{var}` = \"${name}\": unknown setting `{name}`; {hint}settings declared: {} (a matrix variable takes a list-valued setting declared in [settings])",
                if settings.declared.is_empty() {
                    "none".to_string()
                } else {
                    settings.declared.join(", ")
                }
            ),
        ));
    };
    match &v.value {
        Value::Array(a) => Ok(Some(a.iter().map(|x| json_node(x, &v.origin)).collect())),
        other => Err(ConfigError::at(
            &v.origin,
            format!(
                "setting `{name}` = {other}: template `{tname}` (at {}) takes it as the values of its matrix variable `{var}`, so it must be a list (like [1, 2, 3] or {{ from = 1, to = 8 }}; [] for none), found {}",
                at.origin,
                match other {
                    Value::Array(_) => unreachable!("a list is accepted above"),
                    Value::Object(_) => "a table",
                    Value::String(_) => "a string",
                    Value::Bool(_) => "a boolean",
                    Value::Number(_) => "a number",
                    Value::Null => "null",
                }
            ),
        )),
    }
}

/// A setting's (JSON) value as a node written at `origin`.
fn json_node(v: &Value, origin: &Origin) -> Node {
    let v = match v {
        Value::String(s) => Val::Str(s.clone()),
        Value::Number(n) => match n.as_i64() {
            Some(i) => Val::Int(i),
            None => Val::Float(n.as_f64().unwrap_or(f64::NAN)),
        },
        Value::Bool(b) => Val::Bool(*b),
        Value::Array(a) => Val::Array(a.iter().map(|x| json_node(x, origin)).collect()),
        Value::Object(m) => Val::Table(
            m.iter()
                .map(|(k, x)| {
                    let key = Key {
                        name: k.clone(),
                        origin: origin.clone(),
                    };
                    (key, json_node(x, origin))
                })
                .collect(),
        ),
        // settings come from TOML, which has no null
        Value::Null => Val::Str(String::new()),
    };
    Node {
        v,
        origin: origin.clone(),
    }
}

/// Every combination of the axes' values (the first axis varying slowest).
fn product(axes: &[(String, Vec<Node>)]) -> Vec<Vec<(String, Node)>> {
    let mut out: Vec<Vec<(String, Node)>> = vec![Vec::new()];
    for (name, vals) in axes {
        out = out
            .into_iter()
            .flat_map(|prefix| {
                vals.iter().map(move |v| {
                    let mut p = prefix.clone();
                    p.push((name.clone(), v.clone()));
                    p
                })
            })
            .collect();
    }
    out
}
