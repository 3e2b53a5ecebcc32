//! Box 3 for the imposed-gap rigid casing ([`ImposedGap`]): the gap of every blade-tip node
//! along its fixed direction, `d = g(Ω t + φ) − e · (u + ΔX)`, in place of the closest-point
//! projection on a casing surface. The casing is fixed and rigid, so the contact normal is
//! `−e` (toward the axis) and the node's slip relative to the casing is its own increment in the
//! fixed frame: the blade's rotation `Ω r h` plus its vibration. The profile's rate `Ω dg/dθ` is
//! normal to the casing and has no share in the tangential slip of eq. (15).

use crate::contact::{GapDirection, ImposedGap, Projection};
use crate::model::rom::CyclicRom;
use nalgebra::{Matrix3, Vector3};

/// The imposed-gap casing resolved on an impeller: per-node directions, offsets and phases.
pub(crate) struct ImposedCasing {
    gap: ImposedGap,
    /// Rotation speed Ω (rad/s).
    omega: f64,
    /// Outward unit direction `e_j` of each tip node of the reference blade (blade frame).
    direction: Vec<Vector3<f64>>,
    /// `e_j · ΔX_j` (m): the node's clearance offset along its direction.
    offset: Vec<f64>,
    /// Fixed-frame angle φ (rad) of every tip node at t = 0, blade-major.
    phase: Vec<f64>,
    /// Largest radius (m) of the tip nodes: the scale of the gap tolerances.
    radius: f64,
}

impl ImposedCasing {
    /// Resolves `gap` for the tip nodes of `impeller`, whose reference positions are moved by
    /// `offsets[j]` (m, blade frame: the case's clearance offsets) and whose blades sit at
    /// `rot[s]`; the impeller turns at `omega` (rad/s).
    pub(crate) fn new(
        gap: &ImposedGap,
        impeller: &CyclicRom,
        offsets: &[Vector3<f64>],
        rot: &[Matrix3<f64>],
        omega: f64,
    ) -> Result<Self, String> {
        gap.profile
            .validate()
            .map_err(|e| format!("profile: {e}"))?;
        let nodes = &impeller.contact_nodes;
        let direction: Vec<Vector3<f64>> = match &gap.direction {
            GapDirection::Radial => nodes
                .iter()
                .enumerate()
                .map(|(j, c)| {
                    let r = Vector3::new(c.position[0], c.position[1], 0.0);
                    let n = r.norm();
                    (n > 0.0).then(|| r / n).ok_or_else(|| {
                        format!("contact node {j} lies on the axis: it has no radial direction")
                    })
                })
                .collect::<Result<_, _>>()?,
            GapDirection::PerNode(d) => {
                if d.len() != nodes.len() {
                    return Err(format!(
                        "direction: {} vectors for {} contact nodes",
                        d.len(),
                        nodes.len()
                    ));
                }
                d.iter()
                    .enumerate()
                    .map(|(j, v)| {
                        let v = Vector3::from(*v);
                        let n = v.norm();
                        (n.is_finite() && n > 0.0)
                            .then(|| v / n)
                            .ok_or_else(|| format!("direction {j} is not a non-zero vector"))
                    })
                    .collect::<Result<_, _>>()?
            }
        };
        let offset = direction
            .iter()
            .zip(offsets)
            .map(|(e, dx)| e.dot(dx))
            .collect();
        let phase = rot
            .iter()
            .flat_map(|r| {
                nodes.iter().map(move |c| {
                    let p = r * Vector3::from(c.position);
                    p.y.atan2(p.x)
                })
            })
            .collect();
        let radius = nodes
            .iter()
            .map(|c| c.position[0].hypot(c.position[1]))
            .fold(0.0, f64::max);
        Ok(Self {
            radius,
            gap: gap.clone(),
            omega,
            direction,
            offset,
            phase,
        })
    }

    /// The gap (m) of tip node `node` (blade-major) at time `t` (s) for the blade-frame
    /// boundary displacements `ub` (m, blade-major, 3 per node).
    pub(crate) fn gap(&self, node: usize, t: f64, ub: &[f64]) -> f64 {
        let j = node % self.direction.len();
        let u = Vector3::new(ub[3 * node], ub[3 * node + 1], ub[3 * node + 2]);
        let (g, _) = self.gap.profile.at(self.omega * t + self.phase[node]);
        g - self.offset[j] - self.direction[j].dot(&u)
    }

    /// The gap (m) of tip node `node` once its displacement is corrected by `du` (m, blade
    /// frame) from the boundary displacements `ub` (see [`Self::gap`]).
    pub(crate) fn gap_corrected(&self, node: usize, t: f64, ub: &[f64], du: &Vector3<f64>) -> f64 {
        self.gap(node, t, ub) - self.direction[node % self.direction.len()].dot(du)
    }

    /// Largest radius (m) of the tip nodes.
    pub(crate) fn radius_scale(&self) -> f64 {
        self.radius
    }

    /// The gaps and normals of every tip node at time `t` (s) for the boundary displacements
    /// `ub` (see [`Self::gap`]), the rotation `r_om = R(Ω t)` and the blade frames `rot`;
    /// `nodes` are the tip nodes in the fixed frame. Writes `out` in the form of a projection:
    /// gap, normal, and the casing point `S = x − d n`.
    pub(crate) fn gaps(
        &self,
        t: f64,
        ub: &[f64],
        r_om: &Matrix3<f64>,
        rot: &[Matrix3<f64>],
        nodes: &[Vector3<f64>],
        out: &mut [Projection],
    ) {
        let nc = self.direction.len();
        for (node, p) in out.iter_mut().enumerate() {
            p.gap = self.gap(node, t, ub);
            p.normal = -(r_om * rot[node / nc] * self.direction[node % nc]);
            p.point = nodes[node] - p.normal * p.gap;
        }
    }
}
