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

use serde::{Deserialize, Deserializer, Serialize};
use serde_json::Value;

use crate::analysis::revolutions::RevolutionWindows;
use crate::contact::ImposedGap;
use crate::dynamics::abradable::CoatingMaterial;
pub use crate::dynamics::numerics::{KernelChoice, Numerics};
pub use crate::dynamics::probes::ProbeSpec;
use crate::dynamics::scenario::Rotation;
use crate::model::build::{CasingSpec, ImpellerSpec};
pub use crate::sweep::refine::{MIN_REFINE_TOLERANCE, RefineSpec};
pub use crate::sweep::schema::{SWEEP_SCHEMA, SpecError, SpecIssue, validate_against_schema};

mod rules;

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

fn de_usize<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    de_u32(d).map(|v| v as usize)
}

fn de_opt_u32<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u32>, D::Error> {
    Option::<f64>::deserialize(d)?
        .map(integral_u32)
        .transpose()
        .map_err(serde::de::Error::custom)
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
    /// Loading scenario.
    pub scenario: Scenario,
    /// Numerical settings (the simulator's own type; JSON `time_step_s` = h).
    #[serde(default)]
    pub numerics: Numerics,
    /// Parameter grid.
    pub grid: Grid,
    /// Wall-clock limit (s) of each job: a job still running after it is stopped and recorded
    /// as failed, with the simulated time it reached. Not part of the job ids (it does not
    /// change a finished result). `None`: no limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub job_time_limit_s: Option<f64>,
}

/// The two structural models of a sweep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Models {
    /// Impeller model.
    pub impeller: ModelSource,
    /// Casing model.
    pub casing: CasingSource,
    /// The sense in which the impeller turns about the models' +z axis (default
    /// counter-clockwise). An imported model turns as it is given; the built-in models are
    /// mirrored (y → −y) to turn clockwise, so that their blade lean trails as it does
    /// counter-clockwise.
    #[serde(default, skip_serializing_if = "Rotation::is_default")]
    pub rotation: Rotation,
}

/// Where the impeller model comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ModelSource {
    /// Built-in parametric impeller; every field of the build spec has a default.
    Builtin(Box<ImpellerSpec>),
    /// Reduced-order model file; a relative path is relative to the spec file's directory
    /// (see [`SweepSpec::resolve_paths`]).
    Rom(PathBuf),
}

/// Where the casing model comes from: a built-in or ROM-file flexible casing, or a rigid
/// distorted casing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum CasingSource {
    /// Built-in parametric flexible casing; every field of the build spec has a default.
    Builtin(Box<CasingSpec>),
    /// Reduced-order model file of a flexible casing.
    Rom(PathBuf),
    /// Rigid casing with an n-lobe radial distortion.
    Rigid(RigidCasing),
    /// Rigid casing given as a gap per blade-tip node along a fixed direction, a function of
    /// the node's angle θ = Ω t + φ (the public Rotor 37 benchmark's form).
    ImposedGap(ImposedGap),
}

impl CasingSource {
    /// True for a rigid casing, surface or imposed gaps (no modes, no load, no probes).
    pub fn is_rigid(&self) -> bool {
        matches!(self, CasingSource::Rigid(_) | CasingSource::ImposedGap(_))
    }
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

/// Loading scenario. Fields marked "flexible casing" or "rigid casing" are rejected with
/// the other kind of casing (see [`SweepSpec::validate`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Simulated time (s), > 0.
    pub duration_s: f64,
    /// Number of lobes n ≥ 1 of the casing load (flexible casing; goes with
    /// `load_amplitude_m`). A rigid casing takes its lobes from `models.casing.rigid.lobes`.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "de_opt_u32"
    )]
    pub lobes: Option<u32>,
    /// Static inward radial displacement δ (m) of the n-lobe casing load at its peak
    /// (flexible casing; goes with `lobes`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_amplitude_m: Option<f64>,
    /// End of the load ramp t_f (s), in (0, duration]; the load is released after it.
    /// Default: a quarter of the duration. Needs the load.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_ramp_s: Option<f64>,
    /// Casing contact nodes `[sector, node]` whose radial displacement is recorded
    /// (flexible casing; sector < N, node < M of the casing).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub casing_probes: Vec<[usize; 2]>,
    /// Probes of contact and recovery nodes, one time-series column each, in this order
    /// (see [`ProbeSpec`]; checked against the models by [`crate::sweep::validate::resolve`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub probes: Vec<ProbeSpec>,
    /// Windows (in revolutions, at the end of the run) of the probes' steady figures that
    /// `rubscan simulate` reports: peak-to-peak, mean, dominant frequency and engine order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub revolution_report: Option<RevolutionWindows>,
    /// Fraction of the run, at its end, used as the steady window of the spectra, in (0, 1]
    /// (default 0.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steady_fraction: Option<f64>,
    /// Circumferential stations (≥ 3) of a lobed rigid casing's spline (default 120; rigid
    /// casing without `gap_offsets_m`, whose length sets the stations).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "de_opt_u32"
    )]
    pub rigid_stations: Option<u32>,
    /// Abradable coating on the casing (nominal values; the grid's `coating` axes scale or
    /// replace them). Also switched on, with nominal values, by a `grid.coating` axis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coating: Option<CoatingScenario>,
}

/// Nominal abradable coating of a sweep (paper §4); defaults: [`CoatingMaterial::nominal`],
/// η = 6000.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CoatingScenario {
    /// Young's modulus E (Pa), > 0.
    pub young_pa: f64,
    /// Plastic (hardening) modulus K (Pa), > 0.
    pub hardening_pa: f64,
    /// Yield stress σ_Y (Pa), > 0.
    pub yield_stress_pa: f64,
    /// Thickness e_abr (m), > 0.
    pub thickness_m: f64,
    /// Elements per circumferential row η ≥ 1.
    #[serde(deserialize_with = "de_usize")]
    pub eta: usize,
}

impl Default for CoatingScenario {
    fn default() -> Self {
        let m = CoatingMaterial::nominal();
        Self {
            young_pa: m.young,
            hardening_pa: m.plastic_modulus,
            yield_stress_pa: m.yield_stress,
            thickness_m: m.thickness,
            eta: 6000,
        }
    }
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
    /// Speeds added after the grid where the answer changes (issue 37 item 3); `None`: the
    /// grid's speeds only. Not part of any job's id.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refine: Option<RefineSpec>,
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

/// Parses and validates a spec from JSON text (schema, serde, semantic checks).
/// Relative ROM paths are left as written; see [`SweepSpec::resolve_paths`].
pub fn parse_spec(text: &str) -> Result<SweepSpec, SpecError> {
    let value: Value = serde_json::from_str(text).map_err(|e| SpecError::Syntax {
        file: None,
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    spec_from_value(value)
}

/// Validates a JSON value (schema, serde, semantic checks) and converts it into a spec.
pub fn spec_from_value(value: Value) -> Result<SweepSpec, SpecError> {
    validate_against_schema(&value)?;
    let spec: SweepSpec = crate::sweep::schema::typed(value)?;
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
    // A byte-order mark (some Windows editors write one) is not JSON but says nothing.
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut spec = parse_spec(text).map_err(|e| match e {
        SpecError::Syntax {
            line,
            column,
            message,
            ..
        } => SpecError::Syntax {
            file: Some(path.to_path_buf()),
            line,
            column,
            message,
        },
        e => e,
    })?;
    if let Some(dir) = path.parent() {
        spec.resolve_paths(dir);
    }
    Ok(spec)
}

/// Largest accepted Coulomb friction coefficient μ. Measured sliding coefficients of
/// blade/casing and blade/abradable pairs lie in 0.05–0.8; 2 leaves room for exploratory
/// sweeps while rejecting typos such as `1e6`, whose tangential force would dwarf the normal
/// one and make the run a meaningless (and numerically stiff) stick–slip oscillator.
pub const MAX_FRICTION: f64 = 2.0;

/// Most jobs a sweep may expand into. Its plan, ids and table are held in memory, and a
/// sweep of 10⁵ jobs is already 10⁴ core-hours at a few minutes per job; a grid of 10⁹ is a
/// typo in an axis, refused before anything is allocated.
pub const MAX_JOBS: u64 = 100_000;

/// Most time steps a job may take: 10⁹ steps are about a day at the paper scale's 50–100 µs
/// per step, 10³ times the paper's case studies; a longer job is a unit mistake in
/// `duration_s` or `time_step_s`.
pub const MAX_STEPS_PER_JOB: f64 = 1e9;

/// Most coating elements per circumferential row η: at 10⁶ an element of a 0.2 m casing is
/// 1.3 µm long, finer than any tip motion of a step; the rows' state grows with η.
pub const MAX_COATING_ELEMENTS: usize = 1_000_000;

impl SweepSpec {
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
    /// Number of jobs the grid expands into: the product of its axis lengths, zipped axes
    /// counted once (saturating at `u64::MAX`).
    pub fn job_count(&self) -> u64 {
        let mut zip_seen = false;
        AxisName::ALL
            .iter()
            .filter_map(|&axis| {
                let n = self.axis_len(axis)?;
                if self.zip.contains(&axis) {
                    if zip_seen {
                        return None;
                    }
                    zip_seen = true;
                }
                Some(n as u64)
            })
            .fold(1, u64::saturating_mul)
    }

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
    use crate::contact::{GapDirection, GapProfile};
    use crate::dynamics::numerics::Boundary;
    use std::collections::BTreeSet;

    fn base() -> Value {
        serde_json::json!({
            "name": "t",
            "models": {"impeller": {"builtin": {}}, "casing": {"builtin": {}}},
            "scenario": {"duration_s": 0.1, "lobes": 2, "load_amplitude_m": 1e-4, "load_ramp_s": 0.05},
            "numerics": {"time_step_s": 1e-5, "newton_tolerance": 1e-9},
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
        assert_eq!(spec.scenario.load_ramp_s, Some(0.05));
        assert_eq!(spec.numerics.newton_tolerance, 1e-9);
        assert_eq!(spec.numerics.time_step, Some(1e-5));
        // Unset numerics take the simulator's defaults.
        assert_eq!(spec.numerics.decimation, Numerics::default().decimation);
        // 600 rpm = 10 rev/s = 20π rad/s.
        let w = spec.grid.speed.values_rad_s();
        assert!((w[0] - 20.0 * std::f64::consts::PI).abs() < 1e-12);
        // Round trip through serde keeps every field.
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
        v["numerics"]["decimation"] = serde_json::json!(5.0);
        v["scenario"]["lobes"] = serde_json::json!(3.0);
        v["grid"]["speed"] = serde_json::json!({"unit": "rad_s", "range": {"start": 1.0, "stop": 2.0, "count": 2.0}});
        let s = spec_from_value(v.clone()).unwrap();
        assert_eq!(
            (s.scenario.lobes, s.grid.speed.range.unwrap().count),
            (Some(3), 2)
        );
        assert_eq!(s.numerics.decimation, 5);
        v["scenario"]["lobes"] = serde_json::json!(2.5);
        let i = issues_of(v);
        assert!(
            i.iter().any(|s| s.starts_with("/scenario/lobes: ")),
            "{i:?}"
        );
    }

    fn rigid(v: &mut Value) {
        v["models"]["casing"] = serde_json::json!({"rigid": {"lobes": 2, "amplitude_m": 1e-4}});
        let sc = v["scenario"].as_object_mut().unwrap();
        for k in ["lobes", "load_amplitude_m", "load_ramp_s"] {
            sc.remove(k);
        }
    }

    #[test]
    fn unknown_fields_name_the_closest_valid_field() {
        let mut v = base();
        v["scenario"]["load_amplitud_m"] = serde_json::json!(1e-4);
        v["numerics"]["decimaton"] = serde_json::json!(3);
        v["models"]["impeller"]["builtin"] = serde_json::json!({"geometry": {"n_blade": 4}});
        let i = issues_of(v);
        for want in [
            "/scenario: unknown field `load_amplitud_m`, did you mean `load_amplitude_m`?",
            "/numerics: unknown field `decimaton`, did you mean `decimation`?",
            "/models/impeller/builtin/geometry: unknown field `n_blade`, did you mean `n_blades`?",
        ] {
            assert!(i.iter().any(|s| s == want), "{want} not in {i:?}");
        }
        // Reported once, not again by the schema's generic message.
        assert_eq!(i.len(), 3, "{i:?}");
    }

    #[test]
    fn non_physical_values_are_rejected_with_their_path() {
        for (edit, path, needle) in [
            (
                serde_json::json!({"numerics": {"decimation": 0}}),
                "/numerics/decimation",
                "minimum",
            ),
            (
                serde_json::json!({"numerics": {"time_step_s": 0.0}}),
                "/numerics/time_step_s",
                "",
            ),
            (
                serde_json::json!({"scenario": {"duration_s": -1.0}}),
                "/scenario/duration_s",
                "",
            ),
            (
                serde_json::json!({"grid": {"friction": [1e6]}}),
                "/grid/friction/0",
                "2",
            ),
            (
                serde_json::json!({"scenario": {"load_ramp_s": 0.2}}),
                "/scenario/load_ramp_s",
                "after the end",
            ),
            (
                serde_json::json!({"scenario": {"steady_fraction": 1.5}}),
                "/scenario/steady_fraction",
                "",
            ),
        ] {
            let mut v = base();
            for (section, fields) in edit.as_object().unwrap() {
                for (k, x) in fields.as_object().unwrap() {
                    v[section][k] = x.clone();
                }
            }
            let i = issues_of(v);
            assert!(
                i.iter()
                    .any(|s| s.starts_with(&format!("{path}: ")) && s.contains(needle)),
                "{path}: {i:?}"
            );
        }
        // A spec built in code meets the same bounds (no schema pass).
        let mut spec = spec_from_value(base()).unwrap();
        spec.grid.friction = vec![MAX_FRICTION * 1.5];
        spec.numerics.decimation = 0;
        spec.job_time_limit_s = Some(0.0);
        let mut paths: Vec<String> = spec
            .validate()
            .unwrap_err()
            .issues()
            .iter()
            .map(|i| i.path.clone())
            .collect();
        paths.sort();
        assert_eq!(
            paths,
            [
                "/grid/friction/0",
                "/job_time_limit_s",
                "/numerics/decimation"
            ]
        );
        // The schema says the same of a spec file.
        let mut v = base();
        v["job_time_limit_s"] = serde_json::json!(-5);
        let i = issues_of(v);
        assert!(
            i.iter().any(|s| s.starts_with("/job_time_limit_s: ")),
            "{i:?}"
        );
    }

    #[test]
    fn a_coating_with_a_massless_boundary_is_accepted() {
        let mut v = base();
        v["numerics"]["boundary"] = serde_json::json!("massless");
        v["scenario"]["coating"] = serde_json::json!({});
        assert!(spec_from_value(v).is_ok());
    }

    #[test]
    fn a_mode_cutoff_needs_a_massless_boundary_and_a_positive_frequency() {
        let mut v = base();
        v["numerics"]["mode_cutoff_hz"] = serde_json::json!(5e4);
        assert!(
            spec_from_value(v.clone()).is_ok(),
            "the default boundary is massless"
        );
        v["numerics"]["boundary"] = serde_json::json!("mass");
        let i = issues_of(v.clone());
        assert!(
            i.iter()
                .any(|s| s.starts_with("/numerics/mode_cutoff_hz: a mode cutoff needs")),
            "{i:?}"
        );
        v["numerics"]["boundary"] = serde_json::json!("massless");
        assert!(spec_from_value(v.clone()).is_ok());
        v["numerics"]["mode_cutoff_hz"] = serde_json::json!(-1.0);
        let i = issues_of(v);
        assert!(
            i.iter().any(|s| s.starts_with("/numerics/mode_cutoff_hz")),
            "{i:?}"
        );
    }

    #[test]
    fn options_of_the_other_casing_kind_are_rejected() {
        // Flexible-casing options with a rigid casing.
        for (field, value) in [
            ("lobes", serde_json::json!(2)),
            ("load_amplitude_m", serde_json::json!(1e-4)),
            ("casing_probes", serde_json::json!([[0, 1]])),
        ] {
            let mut v = base();
            rigid(&mut v);
            v["scenario"][field] = value;
            let i = issues_of(v);
            assert!(
                i.iter().any(|s| s.starts_with(&format!(
                    "/scenario/{field}: applies to a flexible casing only"
                ))),
                "{field}: {i:?}"
            );
        }
        let mut v = base();
        rigid(&mut v);
        assert!(spec_from_value(v.clone()).is_ok());
        v["scenario"]["rigid_stations"] = serde_json::json!(60);
        assert!(spec_from_value(v.clone()).is_ok());
        // Rigid-casing options with a flexible casing; a load needs both of its fields.
        let mut v = base();
        v["scenario"]["rigid_stations"] = serde_json::json!(60);
        assert!(
            issues_of(v)
                .iter()
                .any(|s| s.starts_with("/scenario/rigid_stations: applies to a rigid casing only"))
        );
        let mut v = base();
        v["scenario"]
            .as_object_mut()
            .unwrap()
            .remove("load_amplitude_m");
        assert!(
            issues_of(v)
                .iter()
                .any(|s| s.contains("`lobes` needs `load_amplitude_m`"))
        );
        // A ROM impeller's clearance cannot be changed against a flexible casing …
        let mut v = base();
        v["models"]["impeller"] = serde_json::json!({"rom": "x.rom"});
        v["grid"]["clearance_m"] = serde_json::json!([1e-4]);
        assert!(
            issues_of(v.clone())
                .iter()
                .any(|s| s.starts_with("/grid/clearance_m: "))
        );
        // … but places a rigid casing.
        rigid(&mut v);
        assert!(spec_from_value(v).is_ok());
    }

    #[test]
    fn imposed_gap_casing_takes_no_surface_options_and_a_valid_profile() {
        let imposed = |v: &mut Value| {
            v["models"]["casing"] = serde_json::json!({"imposed_gap": {"profile":
                {"gaussian_lobes": {"mean_gap_m": 3.56e-4, "width": 0.15, "lobes": 2}}}});
            for field in ["lobes", "load_amplitude_m", "load_ramp_s"] {
                v["scenario"].as_object_mut().unwrap().remove(field);
            }
        };
        let mut v = base();
        imposed(&mut v);
        let spec = spec_from_value(v.clone()).unwrap();
        assert!(matches!(
            &spec.models.casing,
            CasingSource::ImposedGap(ImposedGap {
                direction: GapDirection::Radial,
                ..
            })
        ));
        // Surface options are rejected, each at its pointer.
        for (path, value) in [
            ("/scenario/coating", serde_json::json!({})),
            ("/scenario/rigid_stations", serde_json::json!(60)),
            ("/scenario/casing_probes", serde_json::json!([[0, 1]])),
        ] {
            let mut w = v.clone();
            w["scenario"][path.rsplit('/').next().unwrap()] = value;
            let i = issues_of(w);
            assert!(
                i.iter().any(|s| s.starts_with(&format!("{path}: "))),
                "{path}: {i:?}"
            );
        }
        let mut w = v.clone();
        w["grid"]["clearance_m"] = serde_json::json!([1e-4]);
        assert!(
            issues_of(w)
                .iter()
                .any(|s| s.starts_with("/grid/clearance_m: "))
        );
        // A profile out of its bounds names it; a misspelled profile field is caught by name.
        let mut w = v.clone();
        w["models"]["casing"]["imposed_gap"]["profile"]["gaussian_lobes"]["width"] =
            serde_json::json!(0.0);
        assert!(
            issues_of(w)
                .iter()
                .any(|s| s.starts_with("/models/casing/imposed_gap/profile"))
        );
        let mut w = v.clone();
        w["models"]["casing"]["imposed_gap"]["profile"] =
            serde_json::json!({"gaussian_lobes": {"mean_gap": 3.56e-4, "width": 0.15, "lobes": 2}});
        let i = issues_of(w);
        assert!(
            i.iter().any(|s| s.contains("did you mean `mean_gap_m`")),
            "{i:?}"
        );
    }

    /// Property paths of the schema (array items as `*`), following `$ref`s; asserts that
    /// every object with properties is closed.
    fn schema_paths(schema: &Value, root: &Value, path: &str, out: &mut BTreeSet<String>) {
        let schema = crate::sweep::schema::deref(schema, root);
        if let Some(props) = schema.get("properties").and_then(Value::as_object) {
            assert_eq!(
                schema.get("additionalProperties"),
                Some(&Value::Bool(false)),
                "{path} is not closed"
            );
            for (k, sub) in props {
                let p = format!("{path}/{k}");
                out.insert(p.clone());
                schema_paths(sub, root, &p, out);
            }
        }
        if let Some(items) = schema.get("items") {
            schema_paths(items, root, &format!("{path}/*"), out);
        }
        for alt in schema
            .get("oneOf")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            schema_paths(alt, root, path, out);
        }
    }

    /// Object-key paths of a JSON value (array items as `*`).
    fn value_paths(v: &Value, path: &str, out: &mut BTreeSet<String>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    let p = format!("{path}/{k}");
                    out.insert(p.clone());
                    value_paths(x, &p, out);
                }
            }
            Value::Array(a) => a
                .iter()
                .for_each(|x| value_paths(x, &format!("{path}/*"), out)),
            _ => {}
        }
    }

    /// Specs that, together, fill every optional field and take every enum variant.
    fn full_specs() -> Vec<SweepSpec> {
        let axis = |scale: bool| {
            Some(if scale {
                CoatingAxis::Scale(vec![1.0])
            } else {
                CoatingAxis::Values(vec![1.0])
            })
        };
        let mut impeller = ImpellerSpec::default();
        let mut casing = CasingSpec::default();
        let a = SweepSpec {
            name: "full".into(),
            description: Some("every field".into()),
            models: Models {
                impeller: ModelSource::Builtin(Box::new(impeller.clone())),
                casing: CasingSource::Builtin(Box::new(casing.clone())),
                rotation: Rotation::Clockwise,
            },
            scenario: Scenario {
                duration_s: 0.1,
                lobes: Some(2),
                load_amplitude_m: Some(1e-4),
                load_ramp_s: Some(0.01),
                casing_probes: vec![[0, 1]],
                probes: vec![ProbeSpec {
                    node: Some(1353),
                    point: Some("leading_edge_mid_span".into()),
                    contact_node: Some(188),
                    blade: Some(0),
                    sector: Some(0),
                    row: Some(0),
                    quantity: crate::dynamics::probes::ProbeQuantity::Displacement,
                    component: Some(crate::dynamics::probes::ProbeComponent::Y),
                }],
                revolution_report: Some(RevolutionWindows {
                    peak_to_peak: 5.0,
                    mean_and_spectrum: 20.0,
                }),
                steady_fraction: Some(0.5),
                rigid_stations: Some(60),
                coating: Some(CoatingScenario::default()),
            },
            numerics: Numerics::default(),
            grid: Grid {
                speed: SpeedAxis {
                    unit: SpeedUnit::RadS,
                    reference_rad_s: None,
                    values: Some(vec![1.0, 2.0]),
                    range: None,
                    refine: Some(RefineSpec {
                        tolerance_rad_s: 0.1,
                        max_jobs: 4,
                        boundary: false,
                        peak_of: Some("max_blade_te_radial_m".into()),
                    }),
                },
                friction: vec![0.1],
                clearance_m: Some(vec![1e-4]),
                coating: Some(CoatingGrid {
                    young: axis(false),
                    hardening: axis(true),
                    yield_stress: axis(false),
                    thickness: axis(true),
                }),
                zip: vec![AxisName::Speed, AxisName::Friction],
            },
            job_time_limit_s: Some(3600.0),
        };
        let mut b = a.clone();
        impeller.damping = crate::model::rom::Damping::Rayleigh {
            alpha: 1.0,
            beta: 1e-6,
        };
        casing.damping = impeller.damping;
        impeller.geometry.blade_lean_deg = -20.0;
        impeller.prestress = crate::model::build::Prestress::StressStiffening;
        impeller.blade_modes = 10;
        b.models.impeller = ModelSource::Builtin(Box::new(impeller));
        b.models.casing = CasingSource::Builtin(Box::new(casing));
        b.grid.speed = SpeedAxis {
            unit: SpeedUnit::Normalized,
            reference_rad_s: Some(100.0),
            values: None,
            range: Some(Range {
                start: 1.0,
                stop: 2.0,
                count: 2,
            }),
            refine: None,
        };
        b.grid.coating = Some(CoatingGrid {
            young: axis(true),
            hardening: axis(false),
            yield_stress: axis(true),
            thickness: axis(false),
        });
        let mut c = a.clone();
        c.models.impeller = ModelSource::Rom("x.rom".into());
        c.models.casing = CasingSource::Rigid(RigidCasing {
            lobes: 2,
            amplitude_m: 1e-4,
            gap_offsets_m: Some(vec![0.0; 3]),
        });
        let mut d = a.clone();
        d.models.casing = CasingSource::Rom("c.rom".into());
        let mut e = c.clone();
        e.models.casing = CasingSource::ImposedGap(ImposedGap {
            profile: GapProfile::GaussianLobes {
                mean_gap: 3.56e-4,
                width: 0.15,
                lobes: 2,
            },
            direction: GapDirection::Radial,
        });
        let mut f = e.clone();
        f.models.casing = CasingSource::ImposedGap(ImposedGap {
            profile: GapProfile::Tabulated {
                gaps: vec![1e-4; 3],
            },
            direction: GapDirection::PerNode(vec![[1.0, 0.0, 0.0]]),
        });
        f.numerics.boundary = Boundary::Massless;
        f.numerics.mode_cutoff_hz = Some(5e4);
        f.numerics.stop_on_runaway = false;
        f.numerics.time_step = Some(2e-6);
        vec![a, b, c, d, e, f]
    }

    #[test]
    fn schema_and_types_agree_field_by_field() {
        let schema: Value = serde_json::from_str(SWEEP_SCHEMA).unwrap();
        let mut in_schema = BTreeSet::new();
        schema_paths(&schema, &schema, "", &mut in_schema);
        let mut in_types = BTreeSet::new();
        for spec in full_specs() {
            let v = serde_json::to_value(&spec).unwrap();
            // Every serialized spec is valid against the schema and reads back identical.
            validate_against_schema(&v).unwrap_or_else(|e| panic!("{e}"));
            let back: SweepSpec = serde_json::from_value(v.clone()).unwrap();
            assert_eq!(back, spec);
            value_paths(&v, "", &mut in_types);
        }
        let only_schema: Vec<_> = in_schema.difference(&in_types).collect();
        let only_types: Vec<_> = in_types.difference(&in_schema).collect();
        assert!(
            only_schema.is_empty() && only_types.is_empty(),
            "in the schema only: {only_schema:?}\nin the Rust types only: {only_types:?}"
        );
        assert!(in_schema.contains("/models/impeller/builtin/geometry/material/young"));
        assert!(in_schema.len() > 80, "{}", in_schema.len());
    }

    fn refined(refine: Value) -> Value {
        let mut v = base();
        v["grid"]["speed"] = serde_json::json!({"unit": "rad_s",
            "range": {"start": 3500, "stop": 5300, "count": 9}, "refine": refine});
        v
    }

    #[test]
    fn a_refinement_request_is_read_with_its_defaults() {
        let spec = spec_from_value(refined(serde_json::json!(
            {"tolerance_rad_s": 20.0, "max_jobs": 12.0, "peak_of": "max_blade_te_radial_m"}
        )))
        .unwrap();
        let r = spec.grid.speed.refine.unwrap();
        assert_eq!(
            (r.tolerance_rad_s, r.max_jobs, r.boundary),
            (20.0, 12, true)
        );
        assert_eq!(r.peak_of.as_deref(), Some("max_blade_te_radial_m"));
        // An rpm axis takes its tolerance in rad/s: 60 rpm apart is 2π rad/s.
        let mut v = refined(serde_json::json!({"tolerance_rad_s": 6.0, "max_jobs": 1}));
        v["grid"]["speed"]["unit"] = serde_json::json!("rpm");
        v["grid"]["speed"]["range"] = serde_json::json!({"start": 600, "stop": 660, "count": 2});
        assert!(spec_from_value(v.clone()).is_ok());
        v["grid"]["speed"]["refine"]["tolerance_rad_s"] = serde_json::json!(6.3);
        let i = issues_of(v);
        assert!(
            i.iter()
                .any(|s| s
                    .starts_with("/grid/speed/refine/tolerance_rad_s: 6.3 rad/s cannot shrink")),
            "{i:?}"
        );
    }

    #[test]
    fn a_refinement_request_that_cannot_work_is_refused_at_its_pointer() {
        let ok = serde_json::json!({"tolerance_rad_s": 20.0, "max_jobs": 12});
        let cases: Vec<(Value, &str, &str)> = vec![
            // Schema stage: bounds, types, unknown fields, unknown column.
            (
                serde_json::json!({"tolerance_rad_s": 0.0}),
                "/grid/speed/refine/tolerance_rad_s",
                "",
            ),
            (
                serde_json::json!({"tolerance_rad_s": -1.0}),
                "/grid/speed/refine/tolerance_rad_s",
                "",
            ),
            (
                serde_json::json!({"max_jobs": 0}),
                "/grid/speed/refine/max_jobs",
                "",
            ),
            (
                serde_json::json!({"max_jobs": 1.5}),
                "/grid/speed/refine/max_jobs",
                "",
            ),
            (
                serde_json::json!({"tolerence_rad_s": 20.0}),
                "/grid/speed/refine",
                "did you mean `tolerance_rad_s`?",
            ),
            (
                serde_json::json!({"peak_of": "max_blade_te_radial"}),
                "/grid/speed/refine/peak_of",
                "did you mean `max_blade_te_radial_m`?",
            ),
            // Semantic stage: what a schema cannot say.
            (
                serde_json::json!({"tolerance_rad_s": 1e-7}),
                "/grid/speed/refine/tolerance_rad_s",
                "float resolution",
            ),
            (
                serde_json::json!({"tolerance_rad_s": 225.0}),
                "/grid/speed/refine/tolerance_rad_s",
                "cannot shrink any bracket",
            ),
            (
                serde_json::json!({"boundary": false}),
                "/grid/speed/refine",
                "asks for nothing",
            ),
            (
                serde_json::json!({"max_jobs": 100000}),
                "/grid/speed/refine/max_jobs",
                "more than the 100000",
            ),
        ];
        for (edit, path, needle) in cases {
            let mut r = ok.clone();
            for (k, x) in edit.as_object().unwrap() {
                r[k] = x.clone();
            }
            let i = issues_of(refined(r));
            assert!(
                i.iter()
                    .any(|s| s.starts_with(&format!("{path}: ")) && s.contains(needle)),
                "{edit}: {path} … {needle} not in {i:?}"
            );
        }
        // One speed, a zipped speed axis.
        let mut v = refined(ok.clone());
        v["grid"]["speed"]["range"] = serde_json::json!({"start": 3500, "stop": 3500, "count": 1});
        let i = issues_of(v);
        assert!(
            i.iter()
                .any(|s| s.starts_with("/grid/speed/refine: refinement needs at least 2 speeds")),
            "{i:?}"
        );
        let mut v = refined(ok.clone());
        v["grid"]["speed"]["range"]["count"] = serde_json::json!(2);
        v["grid"]["zip"] = serde_json::json!(["speed", "friction"]);
        let i = issues_of(v);
        assert!(
            i.iter()
                .any(|s| s.starts_with("/grid/speed/refine: a speed axis zipped")),
            "{i:?}"
        );
        // A spec built in code meets the same rules, `peak_of` with its suggestion.
        let mut spec = spec_from_value(refined(ok)).unwrap();
        let r = spec.grid.speed.refine.as_mut().unwrap();
        r.tolerance_rad_s = f64::NAN;
        r.max_jobs = 0;
        r.peak_of = Some("max_blade_te_radial".into());
        let i: Vec<String> = spec
            .validate()
            .unwrap_err()
            .issues()
            .iter()
            .map(ToString::to_string)
            .collect();
        assert_eq!(i.len(), 3, "{i:?}");
        assert!(
            i[0].starts_with("/grid/speed/refine/tolerance_rad_s: NaN"),
            "{i:?}"
        );
        assert!(i[1].starts_with("/grid/speed/refine/max_jobs: 0"), "{i:?}");
        assert!(
            i[2].starts_with("/grid/speed/refine/peak_of: ")
                && i[2].contains("did you mean `max_blade_te_radial_m`?"),
            "{i:?}"
        );
        // A column that is not a result quantity is named as such.
        let r = spec.grid.speed.refine.as_mut().unwrap();
        r.tolerance_rad_s = 20.0;
        r.max_jobs = 1;
        r.peak_of = Some("wall_time_s".into());
        let i = spec.validate().unwrap_err().to_string();
        assert!(
            i.contains("`wall_time_s` is a column of the results table but not a result quantity"),
            "{i}"
        );
    }

    #[test]
    fn bad_json_reports_line() {
        let e = parse_spec("{\n \"name\": \"x\",\n}").unwrap_err();
        assert!(matches!(e, SpecError::Syntax { line: 3, .. }), "{e}");
    }

    /// A spec file that is not JSON is named with its line; a leading byte-order mark is
    /// not an error.
    #[test]
    fn a_spec_file_that_is_not_json_is_named_and_a_byte_order_mark_is_read() {
        let dir = std::env::temp_dir().join(format!("rubscan-bom-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let quickstart = concat!(env!("CARGO_MANIFEST_DIR"), "/sweeps/quickstart.json");
        let text = std::fs::read_to_string(quickstart).unwrap();
        let bom = dir.join("bom.json");
        std::fs::write(&bom, format!("\u{feff}{text}")).unwrap();
        assert_eq!(
            load_spec(&bom).unwrap().name,
            load_spec(Path::new(quickstart)).unwrap().name
        );
        let broken = dir.join("broken.json");
        std::fs::write(&broken, "{\n \"name\": \"x\",\n}").unwrap();
        let e = load_spec(&broken).unwrap_err().to_string();
        assert!(
            e.contains(&broken.display().to_string()) && e.contains("line 3"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The schema counts `2.0` as an integer, so the typed spec reads it as one; a number the
    /// schema admits but the type cannot hold is reported at its JSON pointer.
    #[test]
    fn integral_float_ids_read_as_integers_and_type_errors_name_their_pointer() {
        let mut v = base();
        v["scenario"]["probes"] =
            serde_json::json!([{"blade": 1.0, "row": 2.0, "quantity": "gap"}]);
        v["scenario"]["lobes"] = serde_json::json!(3.0);
        let spec = spec_from_value(v.clone()).unwrap();
        assert_eq!(spec.scenario.probes[0].blade, Some(1));
        assert_eq!(spec.scenario.probes[0].row, Some(2));
        assert_eq!(spec.scenario.lobes, Some(3));
        // A float field is untouched.
        assert_eq!(spec.scenario.duration_s, 0.1);

        v["scenario"]["probes"] = serde_json::json!([
            {"blade": 0, "row": 0, "quantity": "gap"},
            {"node": 1e20, "quantity": "displacement", "component": "y"}
        ]);
        let e = spec_from_value(v).unwrap_err();
        let issues = e.issues();
        assert_eq!(issues.len(), 1, "{e}");
        assert_eq!(issues[0].path, "/scenario/probes/1/node", "{e}");
        assert!(issues[0].reason.contains("expected usize"), "{e}");
    }
}
