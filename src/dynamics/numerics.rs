//! Numerical parameters of a simulation (time step, Newton tolerance, kernel choice, decimation).
//! The same type is the `numerics` object of a sweep spec.
//!
//! There is no Newton iteration cap here: the closest-point projection stops after a fixed
//! [`MAX_NEWTON_ITERATIONS`](crate::contact::projection::MAX_NEWTON_ITERATIONS) and reports non-convergence as a failure.

use serde::{Deserialize, Deserializer, Serialize};

/// A count written as a JSON integer or an integral float (`2.0`), as JSON Schema's `integer` allows.
fn de_count<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    let v = f64::deserialize(d)?;
    if v.fract() == 0.0 && (0.0..=u32::MAX as f64).contains(&v) {
        Ok(v as usize)
    } else {
        Err(serde::de::Error::custom(format!(
            "{v} is not an integer in 0..=4294967295"
        )))
    }
}

/// Which linear-algebra kernel advances the structures (both give the same result to round-off).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KernelChoice {
    /// Per-nodal-diameter modal coordinates + real FFT over sectors + precomputed
    /// block-circulant flexibility tables: O(n) per step, no allocation. The product's kernel.
    #[default]
    Fast,
    /// The assembled physical ROM with a dense `A⁻¹` and dense contact rows
    /// (`W = G A⁻¹ Fᵀ` literally). Slow; the cross-check.
    DenseReference,
}

/// How the contact boundary of the Craig–Bampton ROMs carries inertia.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Boundary {
    /// The paper's formulation: the boundary DOFs carry mass; the stability limit is set by
    /// the boundary-dominated modes of the ROM.
    Mass,
    /// Massless boundary (Monjaraz-Tec, Gross & Krack 2022), the default: per nodal diameter
    /// the `n_m` lowest modes stay dynamic and the boundary follows statically through the
    /// residual flexibility, so the stability limit is set by the retained modes only (see
    /// [`crate::dynamics::structure`], "Massless boundary"). On case study 1's nominal job
    /// 2.6× cheaper than [`Boundary::Mass`] at the paper's h = 1e-7 s on the same 20-mode
    /// ROM, and converged with fewer modes per nodal diameter (`docs/validation.md`,
    /// "Converged ROMs").
    #[default]
    Massless,
}

impl Boundary {
    /// Whether this is the paper's formulation.
    pub fn is_mass(&self) -> bool {
        *self == Boundary::Mass
    }
}

/// Steps per period of the highest dynamic mode in the default time step: central
/// differences shorten a period by `(ωh)²/24` relative, 1.6 % at 10 steps for that mode and
/// under 0.2 % for the modes three times lower that carry the response.
pub const STEPS_PER_PERIOD: f64 = 10.0;

/// Fewest steps per revolution in the default time step: a blade then passes each of the
/// casing's n lobes in 1000/n steps (NLstep's Rotor 37 benchmark runs 1000 per revolution).
pub const STEPS_PER_REVOLUTION: f64 = 1000.0;

/// Numerical parameters of the explicit contact simulation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Numerics {
    /// Time step h (s). Must stay below the explicit stability limit `2/ω_max` of both ROMs
    /// at the simulated speed. Absent, the accuracy-driven default of
    /// [`default_time_step`](crate::dynamics::simulate::default_time_step):
    /// [`STEPS_PER_PERIOD`] steps per period of the highest dynamic mode and at least
    /// [`STEPS_PER_REVOLUTION`] per revolution (the paper's 1e-7 s is about 14 per period of
    /// the built-in casing's highest mode). Not written when absent (job ids unchanged).
    /// JSON name `time_step_s` (the unit in the name, as everywhere in the sweep spec).
    #[serde(rename = "time_step_s", skip_serializing_if = "Option::is_none")]
    pub time_step: Option<f64>,
    /// Massless boundary only: the retained modes above this frequency (Hz) also become
    /// quasi-static (their static flexibility is kept exactly, their inertia dropped), so
    /// that the highest dynamic mode, hence the stability limit and the default step, is
    /// set by the modes that matter. Absent: every retained mode stays dynamic.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mode_cutoff_hz: Option<f64>,
    /// Relative stop criterion ε_NR of the closest-point Newton–Raphson (paper §3.1, default 1e-5):
    /// iterations stop when the parameter update is below ε_NR (patch-local units).
    pub newton_tolerance: f64,
    /// Kernel choice (default `fast`).
    pub kernel: KernelChoice,
    /// Output decimation: one probe sample every `decimation` steps (default 10, ≥ 1).
    /// Integral floats (`10.0`) are accepted, like JSON Schema's `integer`.
    #[serde(deserialize_with = "de_count")]
    pub decimation: usize,
    /// Inertia of the contact boundary (default `massless`; `mass` is the paper's
    /// formulation). Always written, so that it is part of every job's identity and a resume
    /// never mixes formulations.
    pub boundary: Boundary,
    /// Whether a run stops as soon as a runaway is confirmed (default true): the structures'
    /// energy growing exponentially, fed by the rotation ([`crate::dynamics::runaway`]). The run then ends with its finding instead of growing
    /// until the contact solve gives up. Not written when true (job ids unchanged).
    #[serde(skip_serializing_if = "is_true")]
    pub stop_on_runaway: bool,
}

fn is_true(b: &bool) -> bool {
    *b
}

impl Default for Numerics {
    fn default() -> Self {
        Self {
            time_step: None,
            mode_cutoff_hz: None,
            newton_tolerance: 1e-5,
            kernel: KernelChoice::Fast,
            decimation: 10,
            boundary: Boundary::Massless,
            stop_on_runaway: true,
        }
    }
}

impl Numerics {
    /// Checks that every parameter is finite and in range; the message names the parameter.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(h) = self.time_step
            && !(h.is_finite() && h > 0.0)
        {
            return Err(format!(
                "numerics.time_step_s = {h} s must be finite and > 0"
            ));
        }
        if let Some(f) = self.mode_cutoff_hz {
            if !(f.is_finite() && f > 0.0) {
                return Err(format!(
                    "numerics.mode_cutoff_hz = {f} Hz must be finite and > 0"
                ));
            }
            if self.boundary.is_mass() {
                return Err("numerics.mode_cutoff_hz needs boundary = massless".into());
            }
        }
        if !(self.newton_tolerance.is_finite() && self.newton_tolerance > 0.0) {
            return Err(format!(
                "numerics.newton_tolerance = {} must be finite and > 0",
                self.newton_tolerance
            ));
        }
        if self.decimation == 0 {
            return Err("numerics.decimation must be ≥ 1".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serde_defaults_and_rejects_unknown() {
        let n: Numerics =
            serde_json::from_str(r#"{"kernel":"dense_reference","decimation":4.0}"#).unwrap();
        assert_eq!(n.kernel, KernelChoice::DenseReference);
        assert_eq!((n.time_step, n.decimation), (None, 4));
        assert!(!serde_json::to_string(&n).unwrap().contains("time_step_s"));
        let n: Numerics = serde_json::from_str(r#"{"time_step_s":2e-7}"#).unwrap();
        assert_eq!(n.time_step, Some(2e-7));
        let cut = r#"{"mode_cutoff_hz":5e4,"boundary":"mass"}"#;
        let n: Numerics = serde_json::from_str(cut).unwrap();
        assert!(n.validate().unwrap_err().contains("massless"));
        assert!(serde_json::from_str::<Numerics>(r#"{"time_step":1e-7}"#).is_err());
        assert!(serde_json::from_str::<Numerics>(r#"{"decimation":2.5}"#).is_err());
        assert!(serde_json::from_str::<Numerics>(r#"{"newton_max_iterations":5}"#).is_err());
        assert!(serde_json::from_str::<Numerics>(r#"{"dt":1}"#).is_err());
        assert!(
            Numerics {
                decimation: 0,
                ..Default::default()
            }
            .validate()
            .is_err()
        );
    }
}
