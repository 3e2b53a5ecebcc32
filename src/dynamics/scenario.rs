//! The case definition: rotation speed, duration, friction, casing load (case study 1 of the
//! paper), clearance offsets, probes and numerics; and the casing model (flexible or rigid).

use crate::contact::ImposedGap;
use crate::dynamics::abradable::{CoatingLayer, CoatingMaterial};
use crate::dynamics::numerics::Numerics;
use crate::dynamics::probes::ProbeSpec;
use crate::model::rom::CyclicRom;
use serde::{Deserialize, Serialize};

/// Progressive n-lobe radial load on the casing trailing-edge contact nodes (row M−1):
/// the force on node `(i, M−1)` is `−F(t) cos(n θ_i) e_r` (inward at θ = 0), `F` ramping
/// linearly from 0 at t = 0 to its full value at `ramp_time`, held for `hold_time`, then
/// released (zero).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LobeLoad {
    /// Number of lobes n (2 = ovalization); must satisfy 1 ≤ n.
    pub lobes: usize,
    /// Full amplitude given as the *static* inward radial displacement δ (m) it produces at
    /// the peak of the lobe (converted through the casing's static stiffness of nodal diameter n).
    pub static_displacement: f64,
    /// End of the ramp t_f (s).
    pub ramp_time: f64,
    /// Time (s) the full load is held after the ramp before its release; 0 (the default)
    /// releases it at t_f, as in the paper's case study 1.
    #[serde(default)]
    pub hold_time: f64,
}

/// Shape of a rigid casing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum RigidShape {
    /// `r(θ, z) = r₀(z) − δ cos(n θ)`.
    Lobes {
        /// Number of lobes n; 0 gives a cylinder of revolution.
        lobes: usize,
        /// Distortion amplitude δ (m).
        amplitude: f64,
    },
    /// Radius offsets added on every row.
    Tabulated {
        /// Radius offset Δr(θ_i) (m) per circumferential station i = 0..N−1.
        offsets: Vec<f64>,
    },
}

/// The resolved surface of a rigid casing (stations, meridian, shape): the spline is built
/// once on it. The sweep spec's `RigidCasing` is resolved into one per job.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidSurface {
    /// Number of circumferential stations N (≥ 3).
    pub n_sectors: usize,
    /// Meridian `(r₀, z)` (m) of the M ≥ 2 rows, leading edge first.
    pub meridian: Vec<[f64; 2]>,
    /// Shape.
    pub shape: RigidShape,
}

impl RigidSurface {
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

/// The casing: a flexible cyclic ROM, a rigid prescribed surface, or rigid gaps imposed per
/// blade-tip node.
#[derive(Clone, Debug)]
pub enum CasingModel {
    /// A flexible cyclic casing (its ROM, fixed frame); its surface is the spline of eqs. 5–13.
    Flexible(CyclicRom),
    /// A rigid casing surface (the spline through its stations).
    Rigid(RigidSurface),
    /// A rigid casing given as a gap per blade-tip node along a fixed direction (the Rotor 37
    /// benchmark's form); no surface, no coating.
    ImposedGap(ImposedGap),
}

/// Initial velocities (m/s, assembled physical DOF ordering of each ROM); displacements start at 0.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitialVelocity {
    /// Impeller velocities (m/s), one per DOF of its assembled ROM.
    pub impeller: Option<Vec<f64>>,
    /// Casing velocities (m/s), one per DOF of its assembled ROM (flexible casing only).
    pub casing: Option<Vec<f64>>,
}

/// The sense in which the impeller turns about its model's +z axis. Everything that depends
/// on it follows from [`Case::angular_velocity`]: the rotating frame `R(ω_z t)`, the
/// fixed-frame angle `θ = φ + ω_z t` of a blade node, the slip and friction directions, the
/// drive's work and the forward/backward labels of waves. `K(Ω)` is even in Ω (centrifugal
/// stiffening and spin softening), so the models' matrices do not depend on it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Rotation {
    /// Counter-clockwise about +z (positive angular velocity), the default.
    #[default]
    Counterclockwise,
    /// Clockwise about +z (negative angular velocity).
    Clockwise,
}

impl Rotation {
    /// +1 counter-clockwise, −1 clockwise: the sign of the angular velocity about +z.
    pub fn sign(self) -> f64 {
        match self {
            Rotation::Counterclockwise => 1.0,
            Rotation::Clockwise => -1.0,
        }
    }

    /// Whether this is the default sense (not written to a spec, so job ids stay).
    pub fn is_default(&self) -> bool {
        *self == Rotation::Counterclockwise
    }
}

/// One simulation case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// Rotation speed Ω ≥ 0 (rad/s), in the sense of `rotation`.
    pub omega: f64,
    /// The sense of rotation about the models' +z axis.
    #[serde(default, skip_serializing_if = "Rotation::is_default")]
    pub rotation: Rotation,
    /// Simulated duration (s).
    pub duration: f64,
    /// Coulomb friction coefficient μ (sliding only).
    #[serde(default)]
    pub friction: f64,
    /// Casing load (flexible casing only).
    #[serde(default)]
    pub load: Option<LobeLoad>,
    /// Offset (m) of the blade tips toward the casing, per impeller contact row (empty =
    /// none); positive values reduce the clearance. Along the casing surface's normal at each
    /// tip's closest point at rest (the direction of the gap), radial for an imposed-gap casing.
    #[serde(default)]
    pub clearance_offset: Vec<f64>,
    /// Casing contact nodes `[sector, node]` whose radial displacement is recorded.
    #[serde(default)]
    pub casing_probes: Vec<[usize; 2]>,
    /// Probes of contact and recovery nodes (see [`ProbeSpec`]), recorded in this order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub probes: Vec<ProbeSpec>,
    /// Initial velocities (tests and special studies).
    #[serde(default)]
    pub initial_velocity: InitialVelocity,
    /// Numerical parameters.
    #[serde(default)]
    pub numerics: Numerics,
    /// Abradable coating on the casing contact surface (paper §4, Fig. 11); `None` = bare casing.
    #[serde(default)]
    pub coating: Option<CoatingCase>,
}

fn default_eta() -> usize {
    CoatingLayer::DEFAULT_ETA
}

fn default_blade_thickness() -> f64 {
    2.5e-3
}

/// The abradable coating of a case (paper §4).
///
/// Geometry: the coating of thickness `material.thickness` = e_abr lies on the casing contact
/// surface, so a blade-tip node touches the *unworn* coating when its gap to the casing is
/// e_abr. The casing models' clearances are to the casing itself: to keep a nominal clearance to
/// the coating surface, shift the tips away from the casing with `Case::clearance_offset = −e_abr` (per row).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoatingCase {
    /// Coating material in absolute values (E, K, σ_Y, e_abr); scale factors such as the
    /// paper's E/10 … 10E (§5.2) are resolved by the caller ([`CoatingMaterial::scaled`]).
    pub material: CoatingMaterial,
    /// Elements per circumferential row η (default 6000, paper §4.2.1).
    #[serde(default = "default_eta")]
    pub eta: usize,
    /// Blade-tip area attributed to each impeller contact row (m², one entry per row, leading
    /// edge first). Empty (default) = `blade_thickness` × the tip length attributed to the row's
    /// node: half the distance to each meridional neighbour (r, z) of the reference geometry.
    #[serde(default)]
    pub tip_area: Vec<f64>,
    /// Blade thickness at the tip (m) for the default `tip_area` (default 2.5 mm, the built-in
    /// impeller's blade thickness).
    #[serde(default = "default_blade_thickness")]
    pub blade_thickness: f64,
}

impl CoatingCase {
    /// A coating of `material` with the defaults (η = 6000, tip areas from a 2.5 mm blade).
    pub fn new(material: CoatingMaterial) -> Self {
        Self {
            material,
            eta: default_eta(),
            tip_area: vec![],
            blade_thickness: default_blade_thickness(),
        }
    }

    /// Tip area per row (m²): `tip_area` if given, else `blade_thickness` × tributary tip length
    /// of the row's node. `row_positions[r]` is the reference position (m) of the tip node of row
    /// `r` (sector-0 frame). Errors name the parameter.
    pub fn resolve_tip_area(&self, row_positions: &[[f64; 3]]) -> Result<Vec<f64>, String> {
        let rows = row_positions.len();
        if !self.tip_area.is_empty() {
            if self.tip_area.len() != rows {
                return Err(format!(
                    "coating.tip_area has {} entries, the impeller has {rows} contact rows",
                    self.tip_area.len()
                ));
            }
            return Ok(self.tip_area.clone());
        }
        if !(self.blade_thickness.is_finite() && self.blade_thickness > 0.0) {
            return Err(format!(
                "coating.blade_thickness = {} m must be finite and > 0",
                self.blade_thickness
            ));
        }
        if rows < 2 {
            return Err(
                "coating.tip_area must be given when the impeller has a single contact row".into(),
            );
        }
        let rz = |p: &[f64; 3]| [(p[0] * p[0] + p[1] * p[1]).sqrt(), p[2]];
        let seg: Vec<f64> = row_positions
            .windows(2)
            .map(|w| {
                let (a, b) = (rz(&w[0]), rz(&w[1]));
                ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
            })
            .collect();
        (0..rows)
            .map(|r| {
                let left = if r > 0 { seg[r - 1] } else { 0.0 };
                let right = seg.get(r).copied().unwrap_or(0.0);
                let a = 0.5 * (left + right) * self.blade_thickness;
                if a > 0.0 && a.is_finite() {
                    Ok(a)
                } else {
                    Err(format!(
                        "coating: default tip area of row {r} is {a} m² (coincident tip nodes); give coating.tip_area"
                    ))
                }
            })
            .collect()
    }
}

impl Case {
    /// The impeller's angular velocity ω_z = ±Ω (rad/s) about +z: the one place the sense of
    /// rotation enters the dynamics.
    pub fn angular_velocity(&self) -> f64 {
        self.rotation.sign() * self.omega
    }

    /// Amplitude factor of the casing load at time t: `t/t_f` on [0, t_f], 1 during the hold,
    /// then 0.
    pub fn load_factor(&self, t: f64) -> f64 {
        match &self.load {
            Some(l) if t <= l.ramp_time && l.ramp_time > 0.0 => t / l.ramp_time,
            Some(l) if t <= l.ramp_time + l.hold_time => 1.0,
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn load_ramps_holds_then_is_released() {
        let mut case: Case =
            serde_json::from_value(serde_json::json!({"omega": 1.0, "duration": 1.0})).unwrap();
        case.load = Some(LobeLoad {
            lobes: 2,
            static_displacement: 1e-4,
            ramp_time: 0.25,
            hold_time: 0.25,
        });
        let f = [0.0, 0.125, 0.25, 0.375, 0.5, 0.625].map(|t| case.load_factor(t));
        assert_eq!(f, [0.0, 0.5, 1.0, 1.0, 1.0, 0.0]);
        case.load.as_mut().unwrap().hold_time = 0.0;
        assert_eq!(case.load_factor(0.375), 0.0);
    }

    #[test]
    fn default_tip_area_is_thickness_times_tributary_length() {
        let cc = CoatingCase::new(CoatingMaterial::nominal());
        // Tip nodes on a cone, meridional segments 3-4-5 → lengths 5 and 10 (m, any frame angle:
        // only (r, z) matters).
        let p = [[0.0, 1.0, 0.0], [4.0, 0.0, 4.0], [10.0, 0.0, 12.0]];
        let a = cc.resolve_tip_area(&p).unwrap();
        let t = cc.blade_thickness;
        let expect = [2.5 * t, 7.5 * t, 5.0 * t];
        for (x, y) in a.iter().zip(expect) {
            assert!((x - y).abs() <= 1e-12 * y, "{a:?}");
        }
        // Explicit areas are used as given; wrong counts and single rows are errors.
        let given = CoatingCase {
            tip_area: vec![1e-6, 2e-6, 3e-6],
            ..cc.clone()
        };
        assert_eq!(given.resolve_tip_area(&p).unwrap(), vec![1e-6, 2e-6, 3e-6]);
        assert!(given.resolve_tip_area(&p[..2]).is_err());
        assert!(
            cc.resolve_tip_area(&p[..1])
                .unwrap_err()
                .contains("tip_area")
        );
        assert!(cc.resolve_tip_area(&[p[0], p[0]]).is_err());
    }
}
