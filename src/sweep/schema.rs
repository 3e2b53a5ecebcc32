//! The published contract of a sweep spec, `schemas/sweep.schema.json`: the schema itself,
//! the check of a JSON document against it (unknown fields named with the closest valid
//! one), and the error types every spec check reports through (JSON pointer + reason).

use std::fmt;
use std::path::PathBuf;
use std::sync::OnceLock;

use serde_json::Value;

/// The JSON Schema of a sweep spec (also shipped as `schemas/sweep.schema.json`).
pub const SWEEP_SCHEMA: &str = include_str!("../../schemas/sweep.schema.json");

/// One problem found in a spec: JSON pointer of the offending value (`/grid/friction/0`)
/// and a human-readable reason.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SpecIssue {
    /// JSON pointer (RFC 6901) into the spec; empty for the document root.
    pub path: String,
    /// Why the value is rejected.
    pub reason: String,
}

impl fmt::Display for SpecIssue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let path = if self.path.is_empty() {
            "/"
        } else {
            &self.path
        };
        write!(f, "{path}: {}", self.reason)
    }
}

/// Why a sweep spec could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    /// The spec file could not be read.
    #[error("cannot read sweep spec {path}: {source}")]
    Io {
        /// File that failed.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The text is not JSON.
    #[error(
        "sweep spec {}is not valid JSON (line {line}, column {column}): {message}",
        file.as_ref().map(|f| format!("{} ", f.display())).unwrap_or_default()
    )]
    Syntax {
        /// The spec file, when the text was read from one.
        file: Option<PathBuf>,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// Parser message.
        message: String,
    },
    /// The JSON is well-formed but violates the schema or a semantic rule.
    #[error("sweep spec is invalid:\n{}", .0.iter().map(|i| format!("  {i}")).collect::<Vec<_>>().join("\n"))]
    Invalid(Vec<SpecIssue>),
}

impl SpecError {
    /// One issue at JSON pointer `path`.
    pub(crate) fn one(path: impl Into<String>, reason: impl Into<String>) -> Self {
        SpecError::Invalid(vec![SpecIssue {
            path: path.into(),
            reason: reason.into(),
        }])
    }

    /// The individual issues (empty for I/O and syntax errors).
    pub fn issues(&self) -> &[SpecIssue] {
        match self {
            SpecError::Invalid(v) => v,
            _ => &[],
        }
    }
}

/// The sweep schema as JSON, parsed once. It is a compile-time constant checked by a unit
/// test, so a failure here is a build defect, not a user error.
fn schema_value() -> &'static Value {
    static SCHEMA: OnceLock<Value> = OnceLock::new();
    SCHEMA.get_or_init(|| {
        serde_json::from_str(SWEEP_SCHEMA).expect("embedded sweep schema is valid JSON")
    })
}

fn schema_validator() -> &'static jsonschema::Validator {
    static VALIDATOR: OnceLock<jsonschema::Validator> = OnceLock::new();
    VALIDATOR.get_or_init(|| {
        jsonschema::draft202012::new(schema_value()).expect("embedded sweep schema compiles")
    })
}

/// Checks a JSON value against the sweep schema; returns every violation with its path.
/// Unknown fields are reported once each, with the closest valid name
/// (`unknown_fields`) instead of the schema's generic message.
pub fn validate_against_schema(value: &Value) -> Result<(), SpecError> {
    let mut issues = unknown_fields(value, schema_value());
    issues.extend(
        schema_validator()
            .iter_errors(value)
            .filter(|e| {
                !matches!(
                    e.kind(),
                    jsonschema::error::ValidationErrorKind::AdditionalProperties { .. }
                )
            })
            .map(|e| SpecIssue {
                path: e.instance_path().as_str().to_string(),
                reason: format!("{e}{}", enum_hint(&e)),
            }),
    );
    if issues.is_empty() {
        Ok(())
    } else {
        Err(SpecError::Invalid(issues))
    }
}

/// For a string outside an `enum` of strings (a misspelled `peak_of` column or unit), the
/// closest allowed value: `, did you mean `max_blade_te_radial_m`?`; else nothing.
fn enum_hint(e: &jsonschema::ValidationError<'_>) -> String {
    let jsonschema::error::ValidationErrorKind::Enum { options } = e.kind() else {
        return String::new();
    };
    let (Some(word), Some(options)) = (e.instance().as_str(), options.as_array()) else {
        return String::new();
    };
    did_you_mean(word, options.iter().filter_map(Value::as_str))
        .map(|best| format!(", did you mean `{best}`?"))
        .unwrap_or_default()
}

/// Rewrites every integral number written as a float (`2.0`, `1e3`) as an integer, in place.
/// JSON Schema counts such a number as an `integer` (the schema accepts `"row": 2.0`), so the
/// typed parse must read it as one too; a float field reads the same value either way. Numbers
/// beyond the 64-bit integer range stay floats (and an integer field then reports them).
pub(crate) fn integral_floats_as_integers(value: &mut Value) {
    match value {
        Value::Number(n) if n.is_f64() => {
            let x = n.as_f64().unwrap_or(f64::NAN);
            // 2^64 and −2^63 are exact in f64; the bounds keep the casts exact.
            let int = if x.fract() != 0.0 {
                None
            } else if (0.0..18_446_744_073_709_551_616.0).contains(&x) {
                Some(serde_json::Number::from(x as u64))
            } else if (-9_223_372_036_854_775_808.0..0.0).contains(&x) {
                Some(serde_json::Number::from(x as i64))
            } else {
                None
            };
            if let Some(i) = int {
                *n = i;
            }
        }
        Value::Array(a) => a.iter_mut().for_each(integral_floats_as_integers),
        Value::Object(m) => m.values_mut().for_each(integral_floats_as_integers),
        _ => {}
    }
}

/// Deserialises a schema-valid spec into its type; a value the type refuses is reported at
/// its JSON pointer (`/scenario/probes/0/node`), like every other spec issue.
pub(crate) fn typed<T: serde::de::DeserializeOwned>(mut value: Value) -> Result<T, SpecError> {
    integral_floats_as_integers(&mut value);
    serde_path_to_error::deserialize(value).map_err(|e| {
        use serde_path_to_error::Segment;
        let pointer: String = e
            .path()
            .iter()
            .filter_map(|seg| match seg {
                Segment::Seq { index } => Some(format!("/{index}")),
                Segment::Map { key } => {
                    Some(format!("/{}", key.replace('~', "~0").replace('/', "~1")))
                }
                Segment::Enum { variant } => Some(format!("/{variant}")),
                Segment::Unknown => None,
            })
            .collect();
        SpecError::one(pointer, e.into_inner().to_string())
    })
}

/// The closest name to `word` among `candidates` (Damerau–Levenshtein distance, so that a
/// swap of two letters counts one edit, at most a third of the word's length and at least
/// 1), or `None` when nothing is close.
pub(crate) fn did_you_mean<'a>(
    word: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    let limit = (word.chars().count() / 3).max(1);
    candidates
        .into_iter()
        .map(|c| (strsim::damerau_levenshtein(word, c), c))
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, _)| d)
        .map(|(_, c)| c)
}

/// Follows a local `$ref` (`#/$defs/name`) of the schema `root`.
pub(crate) fn deref<'a>(schema: &'a Value, root: &'a Value) -> &'a Value {
    match schema.get("$ref").and_then(Value::as_str) {
        Some(r) => r
            .strip_prefix('#')
            .and_then(|p| root.pointer(p))
            .map_or(schema, |s| deref(s, root)),
        None => schema,
    }
}

/// Every field of `value` that the JSON Schema `schema` does not allow (objects with
/// `additionalProperties: false`), with the closest valid name when one is close:
/// `/scenario: unknown field `load_amplitud_m`, did you mean `load_amplitude_m`?`.
pub(crate) fn unknown_fields(value: &Value, schema: &Value) -> Vec<SpecIssue> {
    let mut issues = Vec::new();
    walk(value, schema, schema, "", &mut issues);
    issues
}

fn walk(value: &Value, schema: &Value, root: &Value, path: &str, issues: &mut Vec<SpecIssue>) {
    let schema = deref(schema, root);
    match value {
        Value::Object(map) => {
            let props = schema.get("properties").and_then(Value::as_object);
            let closed = schema.get("additionalProperties") == Some(&Value::Bool(false));
            for (key, v) in map {
                let sub = format!("{path}/{}", key.replace('~', "~0").replace('/', "~1"));
                match props.and_then(|p| p.get(key)) {
                    Some(s) => walk(v, s, root, &sub, issues),
                    None if closed => {
                        let names = props.into_iter().flat_map(|p| p.keys().map(String::as_str));
                        let reason = match did_you_mean(key, names) {
                            Some(best) => {
                                format!("unknown field `{key}`, did you mean `{best}`?")
                            }
                            None => {
                                let all: Vec<&str> = props
                                    .into_iter()
                                    .flat_map(|p| p.keys().map(String::as_str))
                                    .collect();
                                format!("unknown field `{key}`; expected one of {}", all.join(", "))
                            }
                        };
                        issues.push(SpecIssue {
                            path: path.to_string(),
                            reason,
                        });
                    }
                    None => {}
                }
            }
        }
        Value::Array(items) => {
            if let Some(s) = schema.get("items") {
                for (i, v) in items.iter().enumerate() {
                    walk(v, s, root, &format!("{path}/{i}"), issues);
                }
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn did_you_mean_finds_close_names_only() {
        let names = ["load_amplitude_m", "load_ramp_s", "lobes", "duration_s"];
        assert_eq!(
            did_you_mean("load_amplitud_m", names),
            Some("load_amplitude_m")
        );
        assert_eq!(did_you_mean("lobse", names), Some("lobes"));
        assert_eq!(
            did_you_mean("decimaton", ["decimation", "kernel"]),
            Some("decimation")
        );
        assert_eq!(did_you_mean("colour", names), None);
        assert_eq!(did_you_mean("x", names), None);
    }

    #[test]
    fn unknown_fields_follow_refs_and_arrays() {
        let schema = serde_json::json!({
            "type": "object", "additionalProperties": false,
            "properties": {
                "a": {"$ref": "#/$defs/inner"},
                "list": {"type": "array", "items": {"$ref": "#/$defs/inner"}},
                "open": {"type": "object"}
            },
            "$defs": {"inner": {"type": "object", "additionalProperties": false,
                                "properties": {"speed": {}, "count": {}}}}
        });
        let v = serde_json::json!({
            "a": {"sped": 1}, "list": [{"count": 1}, {"cuont": 2}], "open": {"any": 1},
            "zzz": 0
        });
        let got: Vec<String> = unknown_fields(&v, &schema)
            .iter()
            .map(ToString::to_string)
            .collect();
        assert_eq!(got.len(), 3, "{got:?}");
        assert!(got.contains(&"/a: unknown field `sped`, did you mean `speed`?".to_string()));
        assert!(got.contains(&"/list/1: unknown field `cuont`, did you mean `count`?".to_string()));
        assert!(
            got.iter()
                .any(|s| s.starts_with("/: unknown field `zzz`; expected one of"))
        );
    }
}
