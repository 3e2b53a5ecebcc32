//! The case definition: rotation speed, duration, friction, casing load (case study 1 of the
//! paper), clearance offsets, probes and numerics; and the casing model (flexible or rigid).

use crate::dynamics::numerics::Numerics;
use crate::model::rom::CyclicRom;
use serde::{Deserialize, Serialize};

/// Progressive n-lobe radial load on the casing trailing-edge contact nodes (row M−1):
/// the force on node `(i, M−1)` is `−F(t) cos(n θ_i) e_r` (inward at θ = 0), `F` ramping
/// linearly from 0 at t = 0 to its full value at `ramp_time`, then released (zero).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LobeLoad {
    /// Number of lobes n (2 = ovalization); must satisfy 1 ≤ n.
    pub lobes: usize,
    /// Full amplitude given as the *static* inward radial displacement δ (m) it produces at
    /// the peak of the lobe (converted through the casing's static stiffness of nodal diameter n).
    pub static_displacement: f64,
    /// End of the ramp t_f (s); the load is released after it.
    pub ramp_time: f64,
}

/// Shape of a rigid casing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum RigidShape {
    /// `r(θ, z) = r₀(z) − δ cos(n θ)`; `amplitude` δ in m, `lobes = 0` gives a cylinder of revolution.
    Lobes { lobes: usize, amplitude: f64 },
    /// Radius offset Δr(θ_i) (m) per circumferential station i = 0..N−1, added on every row.
    Tabulated { offsets: Vec<f64> },
}

/// A rigid casing: the spline is built once on the prescribed shape.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidCasing {
    /// Number of circumferential stations N (≥ 3).
    pub n_sectors: usize,
    /// Meridian `(r₀, z)` (m) of the M ≥ 2 rows, leading edge first.
    pub meridian: Vec<[f64; 2]>,
    /// Shape.
    pub shape: RigidShape,
}

impl RigidCasing {
    /// Data points `P(i, j)` (global frame, m), index `i·M + j`.
    pub fn data_points(&self) -> Result<Vec<nalgebra::Vector3<f64>>, String> {
        let (n, m) = (self.n_sectors, self.meridian.len());
        if n < 3 || m < 2 {
            return Err(format!(
                "rigid casing needs n_sectors ≥ 3 and ≥ 2 meridian rows (got {n}, {m})"
            ));
        }
        let alpha = 2.0 * std::f64::consts::PI / n as f64;
        let mut out = Vec::with_capacity(n * m);
        for i in 0..n {
            let th = i as f64 * alpha;
            let dr = match &self.shape {
                RigidShape::Lobes { lobes, amplitude } => -amplitude * (*lobes as f64 * th).cos(),
                RigidShape::Tabulated { offsets } => {
                    if offsets.len() != n {
                        return Err(format!(
                            "rigid casing: {} tabulated offsets for {n} stations",
                            offsets.len()
                        ));
                    }
                    offsets[i]
                }
            };
            for &[r, z] in &self.meridian {
                let rr = r + dr;
                if !(rr.is_finite() && rr > 0.0 && z.is_finite()) {
                    return Err(format!(
                        "rigid casing: radius {rr} at station {i} is not positive"
                    ));
                }
                out.push(nalgebra::Vector3::new(rr * th.cos(), rr * th.sin(), z));
            }
        }
        Ok(out)
    }
}

/// The casing: a flexible cyclic ROM or a rigid prescribed shape.
#[derive(Clone, Debug)]
pub enum CasingModel {
    Flexible(CyclicRom),
    Rigid(RigidCasing),
}

/// Initial velocities (m/s, assembled physical DOF ordering of each ROM); displacements start at 0.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitialVelocity {
    pub impeller: Option<Vec<f64>>,
    pub casing: Option<Vec<f64>>,
}

/// One simulation case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// Rotation speed Ω (rad/s), counter-clockwise about +z.
    pub omega: f64,
    /// Simulated duration (s).
    pub duration: f64,
    /// Coulomb friction coefficient μ (sliding only).
    #[serde(default)]
    pub friction: f64,
    /// Casing load (flexible casing only).
    #[serde(default)]
    pub load: Option<LobeLoad>,
    /// Radial offset (m) added to the blade tips' reference radius, per impeller contact row
    /// (empty = none); positive values reduce the clearance.
    #[serde(default)]
    pub clearance_offset: Vec<f64>,
    /// Casing contact nodes `[sector, node]` whose radial displacement is recorded.
    #[serde(default)]
    pub casing_probes: Vec<[usize; 2]>,
    /// Initial velocities (tests and special studies).
    #[serde(default)]
    pub initial_velocity: InitialVelocity,
    /// Numerical parameters.
    #[serde(default)]
    pub numerics: Numerics,
}

impl Case {
    /// Amplitude factor of the casing load at time t: `t/t_f` on [0, t_f], then 0.
    pub fn load_factor(&self, t: f64) -> f64 {
        match &self.load {
            Some(l) if t <= l.ramp_time && l.ramp_time > 0.0 => t / l.ramp_time,
            _ => 0.0,
        }
    }
}
