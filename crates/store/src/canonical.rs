//! Canonical JSON and BLAKE3 keys.
//!
//! Cache keys must not depend on how a value was spelled, on map order or on the platform. The
//! canonical form defined here is valid, compact JSON:
//!
//! - objects: keys sorted by their UTF-8 bytes, no whitespace anywhere;
//! - strings: JSON escapes as `serde_json` writes them (`"`, `\`, control characters);
//! - integers (JSON numbers that fit `i64` or `u64`): plain decimal, e.g. `7`, `-3`;
//! - floats: the shortest decimal that round-trips to the same `f64`, in scientific notation with
//!   a lowercase `e` and no `+`, exactly as Rust's `{:e}` prints it: `0.1`, `1e-1` and `0.10`
//!   all render as `1e-1`; `100.0` as `1e2`; `1.5` as `1.5e0`. `-0.0` renders as `0e0`.
//!   Non-finite floats have no JSON form and are rejected.
//! - integers and floats stay distinct (`1` and `1e0` differ): stage parameter schemas coerce
//!   every value to its declared type before hashing, so a float parameter written as `1` in a
//!   TOML file is hashed as `1e0`.
//!
//! A key is the BLAKE3 hash of a canonical JSON document, written as 64 lowercase hex digits.

use serde_json::Value;
use std::fmt::Write as _;

/// Errors of canonicalisation.
#[derive(Debug, thiserror::Error)]
pub enum CanonicalError {
    /// A float that is NaN or infinite (JSON has no form for it).
    #[error("non-finite number at `{path}`: canonical JSON has no form for NaN or infinity")]
    NonFinite {
        /// JSON-pointer-like path of the offending value.
        path: String,
    },
}

/// Renders `value` as canonical JSON (see the module docs).
pub fn canonical_json(value: &Value) -> Result<String, CanonicalError> {
    let mut out = String::with_capacity(128);
    write_value(&mut out, value, &mut String::new())?;
    Ok(out)
}

/// Renders one `f64` the canonical way (`{:e}`, `-0` folded into `0`). Panics never; returns
/// `None` for NaN and infinities.
pub fn canonical_f64(x: f64) -> Option<String> {
    if !x.is_finite() {
        return None;
    }
    let x = if x == 0.0 { 0.0 } else { x };
    Some(format!("{x:e}"))
}

fn write_value(out: &mut String, value: &Value, path: &mut String) -> Result<(), CanonicalError> {
    match value {
        Value::Null => out.push_str("null"),
        Value::Bool(b) => out.push_str(if *b { "true" } else { "false" }),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                let _ = write!(out, "{i}");
            } else if let Some(u) = n.as_u64() {
                let _ = write!(out, "{u}");
            } else {
                let f = n.as_f64().unwrap_or(f64::NAN);
                match canonical_f64(f) {
                    Some(s) => out.push_str(&s),
                    None => return Err(CanonicalError::NonFinite { path: path.clone() }),
                }
            }
        }
        Value::String(s) => write_str(out, s),
        Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                let len = path.len();
                let _ = write!(path, "/{i}");
                write_value(out, item, path)?;
                path.truncate(len);
            }
            out.push(']');
        }
        Value::Object(map) => {
            // Sort explicitly: serde_json's map keeps insertion order when some crate in the
            // build enables its `preserve_order` feature.
            let mut entries: Vec<(&String, &Value)> = map.iter().collect();
            entries.sort_by(|a, b| a.0.as_bytes().cmp(b.0.as_bytes()));
            out.push('{');
            for (i, (k, v)) in entries.into_iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                write_str(out, k);
                out.push(':');
                let len = path.len();
                let _ = write!(path, "/{k}");
                write_value(out, v, path)?;
                path.truncate(len);
            }
            out.push('}');
        }
    }
    Ok(())
}

fn write_str(out: &mut String, s: &str) {
    // serde_json's string escaping is canonical enough: it escapes exactly `"`, `\` and
    // control characters, and never escapes non-ASCII.
    match serde_json::to_string(s) {
        Ok(q) => out.push_str(&q),
        Err(_) => out.push_str("\"\""), // unreachable: strings always serialise
    }
}

/// BLAKE3 of a canonical JSON rendering, as 64 lowercase hex digits.
pub fn hash_json(value: &Value) -> Result<String, CanonicalError> {
    Ok(hash_bytes(canonical_json(value)?.as_bytes()))
}

/// BLAKE3 of raw bytes, as 64 lowercase hex digits.
pub fn hash_bytes(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

/// BLAKE3 of a file's content (streamed), as 64 lowercase hex digits. Its time counts in
/// [`crate::clock`] ([`crate::clock::Purpose::File`]).
pub fn hash_file(path: &std::path::Path) -> std::io::Result<String> {
    let timer = crate::clock::Timer::start(crate::clock::Purpose::File);
    let mut hasher = blake3::Hasher::new();
    let mut file = std::fs::File::open(path)?;
    let bytes = std::io::copy(&mut file, &mut hasher)?;
    timer.done(bytes);
    Ok(hasher.finalize().to_hex().to_string())
}

/// Whether `s` looks like a key: 64 lowercase hex digits.
pub fn is_key(s: &str) -> bool {
    s.len() == 64 && s.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn floats_are_normalised() {
        let a: Value = serde_json::from_str(r#"{"b": 0.1, "a": [1e-1, 100.0, -0.0]}"#).unwrap();
        let b: Value = serde_json::from_str(r#"{"a": [0.10, 1e2, 0.0], "b": 1E-1}"#).unwrap();
        assert_eq!(
            canonical_json(&a).unwrap(),
            r#"{"a":[1e-1,1e2,0e0],"b":1e-1}"#
        );
        assert_eq!(hash_json(&a).unwrap(), hash_json(&b).unwrap());
    }

    #[test]
    fn integers_and_floats_differ() {
        assert_ne!(
            hash_json(&json!(1)).unwrap(),
            hash_json(&json!(1.0)).unwrap()
        );
        assert_eq!(
            canonical_json(&json!(u64::MAX)).unwrap(),
            u64::MAX.to_string()
        );
    }

    #[test]
    fn keys_sorted_nested_and_strings_escaped() {
        let v = json!({"z": {"y": 1, "x": "a\"b\\c\n"}, "a": null, "é": true});
        assert_eq!(
            canonical_json(&v).unwrap(),
            r#"{"a":null,"z":{"x":"a\"b\\c\n","y":1},"é":true}"#
        );
    }

    #[test]
    fn key_shape() {
        let k = hash_json(&json!({"kind": "surface"})).unwrap();
        assert!(is_key(&k));
        assert!(!is_key("abc"));
        assert!(!is_key(&k.to_uppercase()));
    }
}
