//! Where a held blade tip meets the casing: the contact normal, the force direction
//! `n + μ e_θ`, and the casing nodes whose displacement, interpolated along the meridian,
//! stands for the surface under the tip.
//!
//! The casing surface is reduced to its meridian polyline through the contact nodes of sector 0
//! (sorted by row). A tip is projected onto it in the `(r, z)` half-plane; the casing
//! displacement under it is the linear interpolation of the two nodes of that segment (the
//! B-spline's meridional curvature is neglected: on the built-in models the tips sit over the
//! casing rows, so the weights are ≈ 1). The normal is the polyline's, by central differences at
//! the nodes and interpolated, oriented from the tips towards the casing (the side the casing
//! pushes from); a single row uses the radial direction. All vectors are taken in cylindrical
//! components `(r, θ, z)` at the node they act on and rotated to that node's sector-local
//! Cartesian frame, the frame of the ROM's boundary DOFs.

use super::{StabilityError, StabilityOptions};
use crate::model::rom::CyclicRom;

/// One casing node under a held tip.
#[derive(Clone, Debug)]
pub(super) struct CasingTerm {
    /// Index of the casing contact node (its DOFs are `3 node..3 node + 3` of a block).
    pub node: usize,
    /// Meridional interpolation weight.
    pub weight: f64,
    /// Angle of the tip minus angle of the casing node in their sector frames, `φ_j − ψ_r`
    /// (rad): harmonic `k` reaches the tip with `e^{ik(φ_j − ψ_r)}`.
    pub angle_offset: f64,
    /// The normal in the node's local Cartesian frame (gap direction).
    pub normal: [f64; 3],
    /// The force direction `n + μ e_θ` in the node's local Cartesian frame.
    pub force: [f64; 3],
}

/// One held tip row.
#[derive(Clone, Debug)]
pub(super) struct HeldRow {
    /// Index of the impeller contact node.
    pub tip_node: usize,
    /// The normal in the tip's blade-local Cartesian frame.
    pub tip_normal: [f64; 3],
    /// The force direction `n + μ e_θ` in the tip's blade-local Cartesian frame.
    pub tip_force: [f64; 3],
    /// The casing nodes under the tip.
    pub casing: Vec<CasingTerm>,
}

/// The contact geometry of every held row.
#[derive(Clone, Debug)]
pub(super) struct Interface {
    pub rows: Vec<HeldRow>,
}

/// `(r, z)` and angle of a position.
fn cylindrical(p: &[f64; 3]) -> ([f64; 2], f64) {
    ([p[0].hypot(p[1]), p[2]], p[1].atan2(p[0]))
}

/// Cylindrical components `(v_r, v_θ, v_z)` at angle `a` → Cartesian.
fn to_cartesian(v: [f64; 3], a: f64) -> [f64; 3] {
    let (s, c) = a.sin_cos();
    [v[0] * c - v[1] * s, v[0] * s + v[1] * c, v[2]]
}

/// Meridian of the casing: node indices sorted by row, their `(r, z)` and unit normals
/// `(n_r, n_z)` (tangent rotated by −90°, sign fixed later).
fn casing_meridian(casing: &CyclicRom) -> (Vec<usize>, Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let mut order: Vec<usize> = (0..casing.n_contact()).collect();
    order.sort_by_key(|&i| casing.contact_nodes[i].row);
    let rz: Vec<[f64; 2]> = (order.iter())
        .map(|&i| cylindrical(&casing.contact_nodes[i].position).0)
        .collect();
    let m = rz.len();
    let normals = (0..m)
        .map(|i| {
            if m == 1 {
                return [1.0, 0.0];
            }
            let (a, b) = (rz[i.saturating_sub(1)], rz[(i + 1).min(m - 1)]);
            let (tr, tz) = (b[0] - a[0], b[1] - a[1]);
            let l = tr.hypot(tz);
            [tz / l, -tr / l]
        })
        .collect();
    (order, rz, normals)
}

/// The closest point of `p` on the polyline `rz`: segment start index and parameter in [0, 1].
fn project(rz: &[[f64; 2]], p: [f64; 2]) -> (usize, f64) {
    if rz.len() == 1 {
        return (0, 0.0);
    }
    let mut best = (f64::INFINITY, 0, 0.0);
    for i in 0..rz.len() - 1 {
        let (a, b) = (rz[i], rz[i + 1]);
        let d = [b[0] - a[0], b[1] - a[1]];
        let l2 = d[0] * d[0] + d[1] * d[1];
        let t = if l2 > 0.0 {
            (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = [a[0] + t * d[0] - p[0], a[1] + t * d[1] - p[1]];
        let dist = q[0].hypot(q[1]);
        if dist < best.0 {
            best = (dist, i, t);
        }
    }
    (best.1, best.2)
}

impl Interface {
    /// The geometry of the held rows of `opts` (every tip row when `None`).
    pub fn new(
        impeller: &CyclicRom,
        casing: &CyclicRom,
        opts: &StabilityOptions,
    ) -> Result<Self, StabilityError> {
        let tips: Vec<usize> = match &opts.held_rows {
            None => (0..impeller.n_contact()).collect(),
            Some(rows) => {
                let mut tips = Vec::new();
                for &r in rows {
                    let found: Vec<usize> = (0..impeller.n_contact())
                        .filter(|&j| impeller.contact_nodes[j].row == r)
                        .collect();
                    if found.is_empty() {
                        return Err(StabilityError::UnknownRow(r));
                    }
                    for j in found {
                        if !tips.contains(&j) {
                            tips.push(j);
                        }
                    }
                }
                tips
            }
        };
        let (order, rz, normals) = casing_meridian(casing);
        // Per tip: (tip node, tip angle, casing terms (index into `order`, weight), normal, the
        // tip's offset to the surface along the unoriented normal).
        let mut raw = Vec::with_capacity(tips.len());
        let mut offset_sum = 0.0;
        for &j in &tips {
            let (p, phi) = cylindrical(&impeller.contact_nodes[j].position);
            let (i, t) = project(&rz, p);
            let pair: Vec<(usize, f64)> = if rz.len() == 1 {
                vec![(0, 1.0)]
            } else {
                vec![(i, 1.0 - t), (i + 1, t)]
            };
            let mut n = [0.0; 2];
            let mut surf = [0.0; 2];
            for &(c, w) in &pair {
                for a in 0..2 {
                    n[a] += w * normals[c][a];
                    surf[a] += w * rz[c][a];
                }
            }
            let l = n[0].hypot(n[1]);
            let n = [n[0] / l, n[1] / l];
            offset_sum += n[0] * (surf[0] - p[0]) + n[1] * (surf[1] - p[1]);
            raw.push((j, phi, pair, n));
        }
        // The casing lies outward of the tips along n: the force on the casing is +N n.
        let sign = if offset_sum < 0.0 { -1.0 } else { 1.0 };
        let mu = opts.friction;
        let rows = raw
            .into_iter()
            .map(|(j, phi, pair, n)| {
                let normal = [sign * n[0], 0.0, sign * n[1]];
                let force = [normal[0], mu, normal[2]];
                let casing = pair
                    .into_iter()
                    .filter(|&(_, w)| w != 0.0)
                    .map(|(c, weight)| {
                        let node = order[c];
                        let psi = cylindrical(&casing.contact_nodes[node].position).1;
                        CasingTerm {
                            node,
                            weight,
                            angle_offset: phi - psi,
                            normal: to_cartesian(normal, psi),
                            force: to_cartesian(force, psi),
                        }
                    })
                    .collect();
                HeldRow {
                    tip_node: j,
                    tip_normal: to_cartesian(normal, phi),
                    tip_force: to_cartesian(force, phi),
                    casing,
                }
            })
            .collect();
        Ok(Self { rows })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{SyntheticSpec, synthetic_rom};
    use crate::model::rom::Component;

    #[test]
    fn tips_over_an_axial_casing_get_the_radial_normal_and_their_own_row() {
        let imp = synthetic_rom(&SyntheticSpec::small(Component::Impeller, 3, 3, 1));
        let cas = synthetic_rom(&SyntheticSpec::small(Component::Casing, 5, 3, 1));
        let opts = StabilityOptions::with_friction(0.2);
        let f = Interface::new(&imp, &cas, &opts).unwrap();
        assert_eq!(f.rows.len(), 3);
        for (j, r) in f.rows.iter().enumerate() {
            // Tips at angle 0 along z over casing nodes at angle 0: e_r = x, e_θ = y.
            assert!((r.tip_normal[0] - 1.0).abs() < 1e-12 && r.tip_normal[2].abs() < 1e-12);
            assert_eq!(r.tip_force, [r.tip_normal[0], 0.2, r.tip_normal[2]]);
            let main = r.casing.iter().max_by(|a, b| a.weight.total_cmp(&b.weight));
            assert_eq!(main.unwrap().node, j);
            let w: f64 = r.casing.iter().map(|c| c.weight).sum();
            assert!((w - 1.0).abs() < 1e-12);
        }
        let only = StabilityOptions {
            held_rows: Some(vec![2]),
            ..opts.clone()
        };
        assert_eq!(Interface::new(&imp, &cas, &only).unwrap().rows.len(), 1);
        let unknown = StabilityOptions {
            held_rows: Some(vec![7]),
            ..opts
        };
        assert_eq!(
            Interface::new(&imp, &cas, &unknown).unwrap_err(),
            StabilityError::UnknownRow(7)
        );
    }
}
