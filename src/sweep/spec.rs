//! Sweep specification: the JSON document that names the models, the scenario,
//! the numerics and the parameter grid of a sweep (DESIGN.md §6).
//!
//! Loading goes through three gates, each reporting the JSON path of the
//! offending value and the reason:
//! 1. JSON syntax (line and column);
//! 2. the JSON Schema `schemas/sweep.schema.json` (draft 2020-12, compiled once);
//! 3. serde deserialization into [`SweepSpec`] (`deny_unknown_fields`) followed by
//!    [`SweepSpec::validate`], which re-checks every constraint of the schema
//!    (so specs built in code are held to the same rules) plus the ones a schema
//!    cannot express (zipped axes of equal length, range ordering, …).

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use serde::{Deserialize, Deserializer, Serialize};
use serde_json::{Map, Value};

/// JSON Schema's `integer` accepts `2.0`; accept it here too so that a schema-valid spec
/// never fails in serde (whose errors carry no JSON path).
fn integral_u32(v: f64) -> Result<u32, String> {
    if v.fract() == 0.0 && (0.0..=f64::from(u32::MAX)).contains(&v) {
        Ok(v as u32)
    } else {
        Err(format!("{v} is not an integer in 0..=4294967295"))
    }
}

fn de_u32<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    integral_u32(f64::deserialize(d)?).map_err(serde::de::Error::custom)
}

fn de_opt_u32<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u32>, D::Error> {
    Option::<f64>::deserialize(d)?
        .map(integral_u32)
        .transpose()
        .map_err(serde::de::Error::custom)
}

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
    #[error("sweep spec is not valid JSON (line {line}, column {column}): {message}")]
    Syntax {
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
    fn one(path: impl Into<String>, reason: impl Into<String>) -> Self {
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

/// A complete sweep specification (see `schemas/sweep.schema.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// Sweep name (`[A-Za-z0-9][A-Za-z0-9_.-]*`), default output directory `results/<name>`.
    pub name: String,
    /// Free text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Impeller and casing models.
    pub models: Models,
    /// Loading scenario (typed fields + pass-through).
    pub scenario: Scenario,
    /// Numerical settings (typed fields + pass-through).
    #[serde(default)]
    pub numerics: Numerics,
    /// Parameter grid.
    pub grid: Grid,
}

/// The two structural models of a sweep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Models {
    /// Impeller model.
    pub impeller: ModelSource,
    /// Casing model.
    pub casing: CasingSource,
}

/// Where a component model comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ModelSource {
    /// Built-in parametric model; the object holds geometry overrides, passed through.
    Builtin(Map<String, Value>),
    /// Reduced-order model file; a relative path is relative to the spec file's directory
    /// (see [`SweepSpec::resolve_paths`]).
    Rom(PathBuf),
}

/// Where the casing model comes from: like [`ModelSource`], or a rigid distorted casing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum CasingSource {
    /// Built-in parametric casing; geometry overrides, passed through.
    Builtin(Map<String, Value>),
    /// Reduced-order model file.
    Rom(PathBuf),
    /// Rigid casing with an n-lobe radial distortion.
    Rigid(RigidCasing),
}

/// Rigid casing with a static n-lobe distortion r(θ) = r₀ − a cos(n θ).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidCasing {
    /// Number of lobes n ≥ 1.
    #[serde(deserialize_with = "de_u32")]
    pub lobes: u32,
    /// Distortion amplitude a (m), ≥ 0.
    pub amplitude_m: f64,
    /// Tabulated gap function: radius offset Δr(θ_i) (m, positive = larger clearance) at
    /// N ≥ 3 equally spaced angles θ_i = 2πi/N, added to the lobes (amplitude 0 for a purely
    /// tabulated casing); N becomes the casing spline's circumferential resolution.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gap_offsets_m: Option<Vec<f64>>,
}

/// Loading scenario. `duration_s` and `lobes` are typed; every other field is
/// kept in `extra` and handed to the simulator unchanged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scenario {
    /// Simulated time (s), > 0.
    pub duration_s: f64,
    /// Number of lobes of the casing distortion, ≥ 1.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "de_opt_u32"
    )]
    pub lobes: Option<u32>,
    /// Pass-through fields.
    #[serde(flatten)]
    pub extra: Map<String, Value>,
}

/// Numerical settings. `time_step_s` is typed (used for the work estimate);
/// every other field is passed through.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Numerics {
    /// Time step h (s), > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_step_s: Option<f64>,
    /// Pass-through fields.
    #[serde(flatten)]
    pub extra: Map<String, Value>,
}

/// The parameter grid. Axes are crossed (full factorial) except those named in `zip`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    /// Rotation speeds Ω.
    pub speed: SpeedAxis,
    /// Coulomb friction coefficients μ ≥ 0.
    pub friction: Vec<f64>,
    /// Clearances (m) ≥ 0; absent = the model's own clearance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clearance_m: Option<Vec<f64>>,
    /// Abradable coating axes; absent = the model's nominal coating.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coating: Option<CoatingGrid>,
    /// Axes varied together (element-wise) instead of crossed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub zip: Vec<AxisName>,
}

/// Unit of the speed axis values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpeedUnit {
    /// rad/s.
    RadS,
    /// Revolutions per minute (× 2π/60 → rad/s).
    Rpm,
    /// Dimensionless, × `reference_rad_s`.
    Normalized,
}

/// Rotation speed axis: exactly one of `values` or `range`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedAxis {
    /// Unit of `values` / `range`.
    pub unit: SpeedUnit,
    /// Reference speed (rad/s) for `unit = normalized`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_rad_s: Option<f64>,
    /// Explicit speeds, > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values: Option<Vec<f64>>,
    /// Evenly spaced speeds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<Range>,
}

/// `count` values evenly spaced from `start` to `stop` inclusive.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Range {
    /// First value (> 0).
    pub start: f64,
    /// Last value (> 0, ≥ start).
    pub stop: f64,
    /// Number of values ≥ 1 (1 gives `start` only, which must then equal `stop`).
    #[serde(deserialize_with = "de_u32")]
    pub count: u32,
}

/// Coating property axes; each is either absolute values or scale factors on
/// the model's nominal value (the simulator resolves scale factors).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoatingGrid {
    /// Young's modulus E (Pa or scale).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub young: Option<CoatingAxis>,
    /// Plastic (hardening) modulus K (Pa or scale).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hardening: Option<CoatingAxis>,
    /// Yield stress σ_Y (Pa or scale).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yield_stress: Option<CoatingAxis>,
    /// Thickness e_abr (m or scale).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thickness: Option<CoatingAxis>,
}

/// A coating axis: absolute values (SI) or scale factors (dimensionless).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum CoatingAxis {
    /// Absolute values (Pa for moduli and stress, m for thickness), > 0.
    Values(Vec<f64>),
    /// Factors on the model's nominal value, > 0.
    Scale(Vec<f64>),
}

impl CoatingAxis {
    /// Number of values on the axis.
    pub fn len(&self) -> usize {
        match self {
            CoatingAxis::Values(v) | CoatingAxis::Scale(v) => v.len(),
        }
    }
    /// True when the axis has no value.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Names of the grid axes (as written in `grid.zip`), in canonical order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum AxisName {
    /// Rotation speed.
    #[serde(rename = "speed")]
    Speed,
    /// Friction coefficient.
    #[serde(rename = "friction")]
    Friction,
    /// Clearance.
    #[serde(rename = "clearance_m")]
    Clearance,
    /// Coating Young's modulus.
    #[serde(rename = "coating.young")]
    CoatingYoung,
    /// Coating hardening modulus.
    #[serde(rename = "coating.hardening")]
    CoatingHardening,
    /// Coating yield stress.
    #[serde(rename = "coating.yield_stress")]
    CoatingYieldStress,
    /// Coating thickness.
    #[serde(rename = "coating.thickness")]
    CoatingThickness,
}

impl AxisName {
    /// All axes in canonical order (speed varies fastest in the job order).
    pub const ALL: [AxisName; 7] = [
        AxisName::Speed,
        AxisName::Friction,
        AxisName::Clearance,
        AxisName::CoatingYoung,
        AxisName::CoatingHardening,
        AxisName::CoatingYieldStress,
        AxisName::CoatingThickness,
    ];

    /// JSON pointer of the axis' value list inside the spec.
    pub fn pointer(self) -> &'static str {
        match self {
            AxisName::Speed => "/grid/speed",
            AxisName::Friction => "/grid/friction",
            AxisName::Clearance => "/grid/clearance_m",
            AxisName::CoatingYoung => "/grid/coating/young",
            AxisName::CoatingHardening => "/grid/coating/hardening",
            AxisName::CoatingYieldStress => "/grid/coating/yield_stress",
            AxisName::CoatingThickness => "/grid/coating/thickness",
        }
    }
}

impl fmt::Display for AxisName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            AxisName::Speed => "speed",
            AxisName::Friction => "friction",
            AxisName::Clearance => "clearance_m",
            AxisName::CoatingYoung => "coating.young",
            AxisName::CoatingHardening => "coating.hardening",
            AxisName::CoatingYieldStress => "coating.yield_stress",
            AxisName::CoatingThickness => "coating.thickness",
        };
        f.write_str(s)
    }
}

fn schema_validator() -> &'static jsonschema::Validator {
    static VALIDATOR: OnceLock<jsonschema::Validator> = OnceLock::new();
    VALIDATOR.get_or_init(|| {
        // The schema is a compile-time constant checked by a unit test, so failure here
        // is a build defect, not a user error.
        let schema: Value =
            serde_json::from_str(SWEEP_SCHEMA).expect("embedded sweep schema is valid JSON");
        jsonschema::draft202012::new(&schema).expect("embedded sweep schema compiles")
    })
}

/// Checks a JSON value against the sweep schema; returns every violation with its path.
pub fn validate_against_schema(value: &Value) -> Result<(), SpecError> {
    let issues: Vec<SpecIssue> = schema_validator()
        .iter_errors(value)
        .map(|e| SpecIssue {
            path: e.instance_path().as_str().to_string(),
            reason: e.to_string(),
        })
        .collect();
    if issues.is_empty() {
        Ok(())
    } else {
        Err(SpecError::Invalid(issues))
    }
}

/// Parses and validates a spec from JSON text (schema, serde, semantic checks).
/// Relative ROM paths are left as written; see [`SweepSpec::resolve_paths`].
pub fn parse_spec(text: &str) -> Result<SweepSpec, SpecError> {
    let value: Value = serde_json::from_str(text).map_err(|e| SpecError::Syntax {
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    spec_from_value(value)
}

/// Validates a JSON value (schema, serde, semantic checks) and converts it into a spec.
pub fn spec_from_value(value: Value) -> Result<SweepSpec, SpecError> {
    validate_against_schema(&value)?;
    let spec: SweepSpec =
        serde_json::from_value(value).map_err(|e| SpecError::one("", e.to_string()))?;
    spec.validate()?;
    Ok(spec)
}

/// Reads, validates and returns a spec file; relative ROM paths are resolved against
/// the file's directory.
pub fn load_spec(path: &Path) -> Result<SweepSpec, SpecError> {
    let text = std::fs::read_to_string(path).map_err(|source| SpecError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut spec = parse_spec(&text)?;
    if let Some(dir) = path.parent() {
        spec.resolve_paths(dir);
    }
    Ok(spec)
}

fn check_list(
    issues: &mut Vec<SpecIssue>,
    pointer: &str,
    values: &[f64],
    allow_zero: bool,
    what: &str,
) {
    if values.is_empty() {
        issues.push(SpecIssue {
            path: pointer.to_string(),
            reason: format!("{what} list is empty"),
        });
    }
    for (i, &v) in values.iter().enumerate() {
        let ok = v.is_finite() && if allow_zero { v >= 0.0 } else { v > 0.0 };
        if !ok {
            let bound = if allow_zero {
                "must be finite and ≥ 0"
            } else {
                "must be finite and > 0"
            };
            issues.push(SpecIssue {
                path: format!("{pointer}/{i}"),
                reason: format!("{v} is not a valid {what}: {bound}"),
            });
        }
    }
}

impl SweepSpec {
    /// Checks every rule of the schema that the type system does not enforce, plus the
    /// cross-field rules (equal lengths of zipped axes, range ordering, reference speed).
    /// Returns all problems at once, each with its JSON path.
    pub fn validate(&self) -> Result<(), SpecError> {
        let mut issues = Vec::new();
        let name_ok =
            !self.name.is_empty()
                && self.name.len() <= 128
                && self.name.chars().enumerate().all(|(i, c)| {
                    c.is_ascii_alphanumeric() || (i > 0 && matches!(c, '_' | '.' | '-'))
                });
        if !name_ok {
            issues.push(SpecIssue {
                path: "/name".into(),
                reason: format!(
                    "{:?} is not a valid sweep name ([A-Za-z0-9][A-Za-z0-9_.-]*, ≤ 128 chars)",
                    self.name
                ),
            });
        }
        if let ModelSource::Rom(p) = &self.models.impeller
            && p.as_os_str().is_empty()
        {
            issues.push(SpecIssue {
                path: "/models/impeller/rom".into(),
                reason: "empty path".into(),
            });
        }
        match &self.models.casing {
            CasingSource::Rom(p) if p.as_os_str().is_empty() => issues.push(SpecIssue {
                path: "/models/casing/rom".into(),
                reason: "empty path".into(),
            }),
            CasingSource::Rigid(r) => {
                if r.lobes == 0 {
                    issues.push(SpecIssue {
                        path: "/models/casing/rigid/lobes".into(),
                        reason: "0 is less than the minimum of 1".into(),
                    });
                }
                if !(r.amplitude_m.is_finite() && r.amplitude_m >= 0.0) {
                    issues.push(SpecIssue {
                        path: "/models/casing/rigid/amplitude_m".into(),
                        reason: format!("{} must be finite and ≥ 0", r.amplitude_m),
                    });
                }
                if let Some(o) = &r.gap_offsets_m
                    && (o.len() < 3 || o.iter().any(|v| !v.is_finite()))
                {
                    issues.push(SpecIssue {
                        path: "/models/casing/rigid/gap_offsets_m".into(),
                        reason: format!("needs at least 3 finite values, got {}", o.len()),
                    });
                }
            }
            _ => {}
        }
        if !(self.scenario.duration_s.is_finite() && self.scenario.duration_s > 0.0) {
            issues.push(SpecIssue {
                path: "/scenario/duration_s".into(),
                reason: format!("{} must be finite and > 0", self.scenario.duration_s),
            });
        }
        if self.scenario.lobes == Some(0) {
            issues.push(SpecIssue {
                path: "/scenario/lobes".into(),
                reason: "0 is less than the minimum of 1".into(),
            });
        }
        if let Some(h) = self.numerics.time_step_s
            && !(h.is_finite() && h > 0.0)
        {
            issues.push(SpecIssue {
                path: "/numerics/time_step_s".into(),
                reason: format!("{h} must be finite and > 0"),
            });
        }
        self.validate_speed(&mut issues);
        check_list(
            &mut issues,
            "/grid/friction",
            &self.grid.friction,
            true,
            "friction coefficient",
        );
        if let Some(c) = &self.grid.clearance_m {
            check_list(&mut issues, "/grid/clearance_m", c, true, "clearance");
        }
        if let Some(c) = &self.grid.coating {
            let axes = [
                ("young", &c.young),
                ("hardening", &c.hardening),
                ("yield_stress", &c.yield_stress),
                ("thickness", &c.thickness),
            ];
            if axes.iter().all(|(_, a)| a.is_none()) {
                issues.push(SpecIssue {
                    path: "/grid/coating".into(),
                    reason: "coating grid names no property".into(),
                });
            }
            for (name, axis) in axes {
                match axis {
                    Some(CoatingAxis::Values(v)) => check_list(
                        &mut issues,
                        &format!("/grid/coating/{name}/values"),
                        v,
                        false,
                        "coating value",
                    ),
                    Some(CoatingAxis::Scale(v)) => check_list(
                        &mut issues,
                        &format!("/grid/coating/{name}/scale"),
                        v,
                        false,
                        "scale factor",
                    ),
                    None => {}
                }
            }
        }
        self.validate_zip(&mut issues);
        if issues.is_empty() {
            Ok(())
        } else {
            Err(SpecError::Invalid(issues))
        }
    }

    fn validate_speed(&self, issues: &mut Vec<SpecIssue>) {
        let s = &self.grid.speed;
        match (&s.values, &s.range) {
            (Some(v), None) => check_list(issues, "/grid/speed/values", v, false, "speed"),
            (None, Some(r)) => {
                for (field, v) in [("start", r.start), ("stop", r.stop)] {
                    if !(v.is_finite() && v > 0.0) {
                        issues.push(SpecIssue {
                            path: format!("/grid/speed/range/{field}"),
                            reason: format!("{v} is not a valid speed: must be finite and > 0"),
                        });
                    }
                }
                if r.count == 0 {
                    issues.push(SpecIssue {
                        path: "/grid/speed/range/count".into(),
                        reason: "0 is less than the minimum of 1".into(),
                    });
                }
                if r.stop < r.start {
                    issues.push(SpecIssue {
                        path: "/grid/speed/range".into(),
                        reason: format!("stop {} is below start {}", r.stop, r.start),
                    });
                }
                if r.count == 1 && r.stop != r.start {
                    issues.push(SpecIssue {
                        path: "/grid/speed/range".into(),
                        reason: "count 1 requires start == stop".into(),
                    });
                }
            }
            _ => issues.push(SpecIssue {
                path: "/grid/speed".into(),
                reason: "give exactly one of `values` or `range`".into(),
            }),
        }
        match (s.unit, s.reference_rad_s) {
            (SpeedUnit::Normalized, None) => issues.push(SpecIssue {
                path: "/grid/speed".into(),
                reason: "\"reference_rad_s\" is a required property for unit \"normalized\"".into(),
            }),
            (_, Some(r)) if !(r.is_finite() && r > 0.0) => issues.push(SpecIssue {
                path: "/grid/speed/reference_rad_s".into(),
                reason: format!("{r} must be finite and > 0"),
            }),
            _ => {}
        }
    }

    fn validate_zip(&self, issues: &mut Vec<SpecIssue>) {
        let zip = &self.grid.zip;
        if zip.is_empty() {
            return;
        }
        if zip.len() < 2 {
            issues.push(SpecIssue {
                path: "/grid/zip".into(),
                reason: "zip needs at least 2 axes".into(),
            });
        }
        let mut first_len: Option<(AxisName, usize)> = None;
        for (i, &axis) in zip.iter().enumerate() {
            if zip[..i].contains(&axis) {
                issues.push(SpecIssue {
                    path: format!("/grid/zip/{i}"),
                    reason: format!("axis {axis} is listed twice"),
                });
                continue;
            }
            match self.grid.axis_len(axis) {
                None => issues.push(SpecIssue {
                    path: format!("/grid/zip/{i}"),
                    reason: format!("axis {axis} is not present in the grid"),
                }),
                Some(n) => match first_len {
                    None => first_len = Some((axis, n)),
                    Some((a0, n0)) if n0 != n => issues.push(SpecIssue {
                        path: format!("/grid/zip/{i}"),
                        reason: format!(
                            "zipped axes need equal lengths: {a0} has {n0} values, {axis} has {n}"
                        ),
                    }),
                    _ => {}
                },
            }
        }
    }

    /// Makes relative ROM paths relative to `base` (the spec file's directory).
    pub fn resolve_paths(&mut self, base: &Path) {
        if let ModelSource::Rom(p) = &mut self.models.impeller
            && p.is_relative()
        {
            *p = base.join(&*p);
        }
        if let CasingSource::Rom(p) = &mut self.models.casing
            && p.is_relative()
        {
            *p = base.join(&*p);
        }
    }
}

impl SpeedAxis {
    /// The speeds in rad/s (range: `start + i (stop − start)/(count − 1)`).
    /// Assumes a validated spec.
    pub fn values_rad_s(&self) -> Vec<f64> {
        let raw: Vec<f64> = match (&self.values, &self.range) {
            (Some(v), _) => v.clone(),
            (None, Some(r)) => {
                let n = r.count as usize;
                if n <= 1 {
                    vec![r.start]
                } else {
                    (0..n)
                        .map(|i| {
                            // Endpoints exactly as written; interior points by interpolation.
                            if i + 1 == n {
                                r.stop
                            } else {
                                r.start + (r.stop - r.start) * i as f64 / (n - 1) as f64
                            }
                        })
                        .collect()
                }
            }
            (None, None) => Vec::new(),
        };
        let factor = match self.unit {
            SpeedUnit::RadS => 1.0,
            SpeedUnit::Rpm => std::f64::consts::TAU / 60.0,
            SpeedUnit::Normalized => self.reference_rad_s.unwrap_or(f64::NAN),
        };
        raw.into_iter().map(|v| v * factor).collect()
    }

    /// Number of speeds on the axis.
    pub fn len(&self) -> usize {
        match (&self.values, &self.range) {
            (Some(v), _) => v.len(),
            (None, Some(r)) => r.count as usize,
            _ => 0,
        }
    }

    /// True when the axis has no speed.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl Grid {
    /// Length of an axis, or `None` when the axis is absent from the grid.
    pub fn axis_len(&self, axis: AxisName) -> Option<usize> {
        let coating = |f: fn(&CoatingGrid) -> &Option<CoatingAxis>| {
            self.coating
                .as_ref()
                .and_then(|c| f(c).as_ref())
                .map(CoatingAxis::len)
        };
        match axis {
            AxisName::Speed => Some(self.speed.len()),
            AxisName::Friction => Some(self.friction.len()),
            AxisName::Clearance => self.clearance_m.as_ref().map(Vec::len),
            AxisName::CoatingYoung => coating(|c| &c.young),
            AxisName::CoatingHardening => coating(|c| &c.hardening),
            AxisName::CoatingYieldStress => coating(|c| &c.yield_stress),
            AxisName::CoatingThickness => coating(|c| &c.thickness),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> Value {
        serde_json::json!({
            "name": "t",
            "models": {"impeller": {"builtin": {}}, "casing": {"rigid": {"lobes": 2, "amplitude_m": 1e-4}}},
            "scenario": {"duration_s": 0.1, "lobes": 2, "ramp_s": 0.05},
            "numerics": {"time_step_s": 1e-5, "tolerance": 1e-9},
            "grid": {"speed": {"unit": "rpm", "values": [600.0, 1200.0]}, "friction": [0.0, 0.15]}
        })
    }

    fn issues_of(v: Value) -> Vec<String> {
        spec_from_value(v)
            .unwrap_err()
            .issues()
            .iter()
            .map(ToString::to_string)
            .collect()
    }

    #[test]
    fn embedded_schema_compiles_and_base_is_valid() {
        let spec = spec_from_value(base()).unwrap();
        assert_eq!(spec.scenario.extra["ramp_s"], serde_json::json!(0.05));
        assert_eq!(spec.numerics.extra["tolerance"], serde_json::json!(1e-9));
        // 600 rpm = 10 rev/s = 20π rad/s.
        let w = spec.grid.speed.values_rad_s();
        assert!((w[0] - 20.0 * std::f64::consts::PI).abs() < 1e-12);
        // Round trip through serde keeps pass-through fields.
        let back = spec_from_value(serde_json::to_value(&spec).unwrap()).unwrap();
        assert_eq!(back, spec);
    }

    #[test]
    fn negative_friction_names_path_and_reason() {
        let mut v = base();
        v["grid"]["friction"] = serde_json::json!([-0.1]);
        let issues = issues_of(v);
        assert!(
            issues
                .iter()
                .any(|i| i == "/grid/friction/0: -0.1 is less than the minimum of 0"),
            "{issues:?}"
        );
    }

    #[test]
    fn semantic_validation_duplicates_schema_rules() {
        // A spec built in code (no schema pass) is held to the same rules.
        let mut spec = spec_from_value(base()).unwrap();
        spec.grid.friction = vec![0.1, -0.2];
        spec.grid.speed.values = Some(vec![]);
        let err = spec.validate().unwrap_err();
        let paths: Vec<&str> = err.issues().iter().map(|i| i.path.as_str()).collect();
        assert!(paths.contains(&"/grid/friction/1"), "{paths:?}");
        assert!(paths.contains(&"/grid/speed/values"), "{paths:?}");
    }

    #[test]
    fn unknown_field_wrong_type_empty_grid() {
        let mut v = base();
        v["grid"]["frction"] = serde_json::json!([0.1]);
        let i = issues_of(v);
        assert!(
            i.iter()
                .any(|s| s.starts_with("/grid: ") && s.contains("frction")),
            "{i:?}"
        );

        let mut v = base();
        v["scenario"]["duration_s"] = serde_json::json!("long");
        let i = issues_of(v);
        assert!(
            i.iter()
                .any(|s| s.starts_with("/scenario/duration_s: ") && s.contains("number")),
            "{i:?}"
        );

        let mut v = base();
        v["grid"]["speed"]["values"] = serde_json::json!([]);
        let i = issues_of(v);
        assert!(
            i.iter().any(|s| s.starts_with("/grid/speed/values: ")),
            "{i:?}"
        );

        let mut v = base();
        v["grid"]["speed"]["values"] = serde_json::json!([0.0]);
        let i = issues_of(v);
        assert!(
            i.iter().any(|s| s.starts_with("/grid/speed/values/0: ")),
            "{i:?}"
        );
    }

    #[test]
    fn zip_rules() {
        let mut v = base();
        v["grid"]["zip"] = serde_json::json!(["speed", "friction"]);
        v["grid"]["friction"] = serde_json::json!([0.1, 0.2, 0.3]);
        let i = issues_of(v);
        assert!(
            i.iter()
                .any(|s| s.starts_with("/grid/zip/1: zipped axes need equal lengths")),
            "{i:?}"
        );

        let mut v = base();
        v["grid"]["zip"] = serde_json::json!(["speed", "clearance_m"]);
        let i = issues_of(v);
        assert!(i.iter().any(|s| s.contains("not present")), "{i:?}");
    }

    #[test]
    fn normalized_needs_reference_and_range_expands() {
        let mut v = base();
        v["grid"]["speed"] = serde_json::json!({"unit": "normalized", "range": {"start": 0.5, "stop": 1.5, "count": 3}});
        assert!(!issues_of(v.clone()).is_empty());
        v["grid"]["speed"]["reference_rad_s"] = serde_json::json!(100.0);
        let spec = spec_from_value(v).unwrap();
        assert_eq!(spec.grid.speed.values_rad_s(), vec![50.0, 100.0, 150.0]);
    }

    #[test]
    fn integral_floats_accepted_like_the_schema() {
        let mut v = base();
        v["scenario"]["lobes"] = serde_json::json!(3.0);
        v["grid"]["speed"] = serde_json::json!({"unit": "rad_s", "range": {"start": 1.0, "stop": 2.0, "count": 2.0}});
        let s = spec_from_value(v.clone()).unwrap();
        assert_eq!(
            (s.scenario.lobes, s.grid.speed.range.unwrap().count),
            (Some(3), 2)
        );
        v["scenario"]["lobes"] = serde_json::json!(2.5);
        let i = issues_of(v);
        assert!(
            i.iter().any(|s| s.starts_with("/scenario/lobes: ")),
            "{i:?}"
        );
    }

    #[test]
    fn bad_json_reports_line() {
        let e = parse_spec("{\n \"name\": \"x\",\n}").unwrap_err();
        assert!(matches!(e, SpecError::Syntax { line: 3, .. }), "{e}");
    }
}
