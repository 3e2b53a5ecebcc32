//! Recovery rows of a cyclic Craig–Bampton ROM: the displacement of chosen sector nodes from
//! the harmonic ROM coordinates (DESIGN §2.1–2.2; built-in models' named nodes).
//!
//! For nodal diameter `k` the reduction basis `V` maps the ROM coordinates `x̃ = (q_B, η)` to
//! the independent DOFs of the harmonic sector problem: `ũ_I = Ψ q_B + Φ η` for an interior
//! DOF (the constraint-mode and fixed-interface-mode rows), `ũ_B = q_B` for a contact DOF.
//! A sector DOF is a combination of independent DOFs ([`CyclicDofMap::dof_terms`]: itself, a
//! right-face DOF `e^{ikα} R(α)` times its left partner, or nothing when clamped), so its row
//! of `R_k` is the same combination of rows of `V`. The node's displacement in sector `s` is
//! then `u_s = Re(R_k x̃ e^{ikθ_s})` summed over `k` with the sector DFT of the ROM state
//! (evaluated by the dynamics stage).

use faer::{MatRef, c64};
use nalgebra::DMatrix;

use crate::model::cyclic::{CyclicDofMap, is_real_harmonic};
use crate::model::mesh::NamedNode;
use crate::model::rom::{ComplexRows, Recovery, RecoveryNode};

/// Rows `R_k` (3 per node, x y z of the sector frame, node-major) of the basis `v` of nodal
/// diameter `k` over the independent DOFs of `map`, for sector nodes `nodes`; exactly real
/// for the real harmonics.
pub(crate) fn harmonic_recovery_rows(
    map: &CyclicDofMap,
    v: MatRef<'_, c64>,
    nodes: &[usize],
    k: usize,
) -> ComplexRows {
    let (nr, nc) = (3 * nodes.len(), v.ncols());
    let mut re = DMatrix::zeros(nr, nc);
    let mut im = DMatrix::zeros(nr, nc);
    let real = is_real_harmonic(k, map.n_sectors());
    for (i, &node) in nodes.iter().enumerate() {
        for d in 0..3 {
            for (j, c) in map.dof_terms(3 * node + d, k) {
                for col in 0..nc {
                    let x = c * v[(j, col)];
                    re[(3 * i + d, col)] += x.re;
                    if !real {
                        im[(3 * i + d, col)] += x.im;
                    }
                }
            }
        }
    }
    ComplexRows { re, im }
}

/// The ROM's recovery block: the points (id = sector node index, name, position) and their rows
/// per nodal diameter; empty when there are no points.
pub(crate) fn recovery_of(
    points: &[NamedNode],
    nodes: &[[f64; 3]],
    rows: Vec<ComplexRows>,
) -> Recovery {
    if points.is_empty() {
        return Recovery::default();
    }
    Recovery {
        nodes: points
            .iter()
            .map(|p| RecoveryNode {
                id: p.node,
                position: nodes[p.node],
                name: Some(p.name.clone()),
            })
            .collect(),
        rows,
    }
}
