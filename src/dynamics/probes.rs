//! The recorded output of a simulation (decimated time series and summary numbers).

use serde::{Deserialize, Serialize};

/// Energies of one structure (J), see [`crate::dynamics::kernel::Energies`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EnergySeries {
    pub kinetic: Vec<f64>,
    pub strain: Vec<f64>,
}

/// Output of [`crate::dynamics::simulate::simulate`]. Every series has one entry per sample
/// (`time.len()`); per-blade series are indexed `[blade][sample]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SimulationOutput {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// Radial displacement (m, rotating frame, positive outward) of each blade's leading-edge
    /// tip node (contact row 0) and trailing-edge node (last row).
    pub blade_le_radial: Vec<Vec<f64>>,
    pub blade_te_radial: Vec<Vec<f64>>,
    /// Radial displacement (m, positive outward) of the requested casing contact nodes
    /// (`Case::casing_probes` order; empty for a rigid casing).
    pub casing_radial: Vec<Vec<f64>>,
    /// Per blade, sum over its tip nodes of the normal contact force λ (N) at the sample step.
    pub blade_normal_force: Vec<Vec<f64>>,
    /// Per blade, sum of the tangential (friction) force magnitudes μλ (N) at the sample step.
    pub blade_tangential_force: Vec<Vec<f64>>,
    /// Minimum predicted gap d* over all blade-tip nodes at the sample step (m).
    pub min_gap: Vec<f64>,
    /// Largest residual penetration after correction (m, ≥ 0) since the previous sample:
    /// re-projection of the corrected blade nodes on the corrected spline.
    pub residual_penetration: Vec<f64>,
    /// Impeller and casing energies (J, half-step form).
    pub impeller_energy: EnergySeries,
    pub casing_energy: EnergySeries,
    /// Impeller strain energy per nodal diameter (J), `[k][sample]`, paper eqs. (20)–(22).
    pub impeller_nd_strain_energy: Vec<Vec<f64>>,
    /// Time step h (s), stability limit 2/ω_max (s), steps per revolution at Ω.
    pub time_step: f64,
    pub stability_limit: f64,
    pub steps_per_revolution: f64,
    /// Number of steps, steps with at least one active contact, and the largest residual
    /// penetration (m) and largest vibration level (max |blade radial displacement|, m) of the run.
    pub n_steps: usize,
    pub contact_steps: usize,
    pub max_residual_penetration: f64,
    pub max_blade_radial: f64,
    /// Wall-clock time of the stepping loop alone (s), setup excluded.
    pub loop_seconds: f64,
}
