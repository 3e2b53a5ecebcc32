//! The impeller side of the time loop: the blades' kernel, their tip nodes in the rotating and
//! fixed frames, and the tip displacements the probes and peaks read.

use super::*;

/// The impeller in the time loop: its kernel and the blade-tip nodes (paper §2.2).
pub(super) struct Blades {
    pub(super) kernel: Kernel<NodeFlexTable>,
    /// Blades N_b, tip nodes per blade n_c, boundary DOFs per blade 3 n_c.
    pub(super) n_blades: usize,
    pub(super) n_contact: usize,
    pub(super) nb: usize,
    /// Contact row of each tip node, and the number of rows.
    pub(super) rows: Vec<usize>,
    pub(super) n_rows: usize,
    /// Radial unit vector and reference position (m, clearance offsets applied) of each tip
    /// node of blade 0; the leading- and trailing-edge nodes.
    pub(super) radial: Vec<Vector3<f64>>,
    pub(super) reference: Vec<Vector3<f64>>,
    pub(super) le: usize,
    pub(super) te: usize,
    /// `R(θ_s)` per blade.
    pub(super) rot: Vec<Matrix3<f64>>,
    /// Tip nodes Γ (m, fixed frame) of this step and of the previous one (the slip
    /// increments of eq. 15 are measured from it).
    pub(super) nodes: Vec<Vector3<f64>>,
    pub(super) nodes_prev: Vec<Vector3<f64>>,
    /// With a massless boundary, the predicted tip nodes of this step, which become
    /// `nodes_prev`: the boundary's static response to the contact forces is found again
    /// every step, so its appearance in the corrected nodes is not a motion of the
    /// material, and slip measured from them would follow the last friction force instead
    /// of the sliding. Empty with the paper's formulation.
    pub(super) nodes_predicted: Vec<Vector3<f64>>,
}

impl Blades {
    pub(super) fn new(
        case: &Case,
        h: f64,
        impeller: &CyclicRom,
        st: &Structure,
    ) -> Result<Self, SimError> {
        let n_blades = impeller.n_sectors;
        let n_contact = impeller.n_contact();
        let rows: Vec<usize> = impeller.contact_nodes.iter().map(|c| c.row).collect();
        let n_rows = rows.iter().max().map_or(0, |r| r + 1);
        if !case.clearance_offset.is_empty() && case.clearance_offset.len() != n_rows {
            return Err(SimError::InvalidCase(format!(
                "clearance_offset has {} entries, the impeller has {n_rows} contact rows",
                case.clearance_offset.len()
            )));
        }
        let radial: Vec<Vector3<f64>> = impeller
            .contact_nodes
            .iter()
            .map(|c| radial(&c.position))
            .collect();
        // The clearance offsets are applied once the casing is known (`shift_tips`).
        let reference: Vec<Vector3<f64>> = impeller
            .contact_nodes
            .iter()
            .map(|c| Vector3::from(c.position))
            .collect();
        let le = (0..n_contact).min_by_key(|&j| rows[j]).unwrap_or(0);
        let te = (0..n_contact).max_by_key(|&j| rows[j]).unwrap_or(0);
        let alpha = 2.0 * PI / n_blades as f64;
        let rot: Vec<Matrix3<f64>> = (0..n_blades).map(|s| rot_z(s as f64 * alpha)).collect();
        let kernel = Kernel::new(st, h, case.numerics.kernel, |k| NodeFlexTable::build(k))?;
        let nn = n_blades * n_contact;
        let mut nodes_prev = vec![Vector3::zeros(); nn];
        for s in 0..n_blades {
            for j in 0..n_contact {
                nodes_prev[s * n_contact + j] = rot[s] * reference[j];
            }
        }
        Ok(Self {
            kernel,
            n_blades,
            n_contact,
            nb: 3 * n_contact,
            rows,
            n_rows,
            radial,
            reference,
            le,
            te,
            rot,
            nodes: vec![Vector3::zeros(); nn],
            nodes_prev,
            nodes_predicted: match case.numerics.boundary {
                Boundary::Mass => Vec::new(),
                Boundary::Massless => vec![Vector3::zeros(); nn],
            },
        })
    }

    /// Moves tip node `j` of every blade by `Case::clearance_offset[row of j]` along the unit
    /// direction `dir[j]` (blade frame), and restarts the previous-step nodes from there.
    pub(super) fn shift_tips(&mut self, offsets: &[f64], dir: &[Vector3<f64>]) {
        if offsets.is_empty() {
            return;
        }
        for (j, x) in self.reference.iter_mut().enumerate() {
            *x += dir[j] * offsets[self.rows[j]];
        }
        for s in 0..self.n_blades {
            for j in 0..self.n_contact {
                self.nodes_prev[s * self.n_contact + j] = self.rot[s] * self.reference[j];
            }
        }
    }

    /// The clearance offsets against a casing surface: along the surface normal at each tip
    /// node's closest point on the casing at rest, the direction in which the gap, the tip
    /// clearance of the built-in models and the coating thickness are measured. (A radial
    /// shift changes the gap only by its normal part: nothing at a radial outlet, where the
    /// normal is axial, so a coating's thickness would not be added to the clearance there.)
    ///
    /// Along the normal a tip keeps its closest point, so its gap grows by the offset exactly;
    /// an offset that breaks this (a coating thick against the casing, which takes a tip past
    /// a free edge of the casing or across its axis) leaves no clearance to measure and is
    /// refused, naming the row.
    pub(super) fn shift_tips_toward(
        &mut self,
        case: &Case,
        side: &CasingSide,
    ) -> Result<(), SimError> {
        if case.clearance_offset.is_empty() {
            return Ok(());
        }
        let eps = case.numerics.newton_tolerance;
        let at_rest = |x: Vector3<f64>| closest_point(&side.spline, &side.q, x, None, eps);
        // At t = 0 blade 0's frame is the fixed frame; the casing at rest is cyclic, so one
        // blade's projections hold for all.
        let before = (self.reference.iter())
            .enumerate()
            .map(|(j, x)| {
                at_rest(*x).map_err(|e| SimError::Projection {
                    time: 0.0,
                    reason: format!("tip node {j} on the casing at rest: {e}"),
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let dir: Vec<Vector3<f64>> = before.iter().map(|p| -p.normal).collect();
        self.shift_tips(&case.clearance_offset, &dir);
        for (j, p) in before.iter().enumerate() {
            let offset = case.clearance_offset[self.rows[j]];
            let expected = p.gap - offset;
            let kept = at_rest(self.reference[j])
                .is_ok_and(|q| (q.gap - expected).abs() <= 1e-9 + 1e-6 * offset.abs());
            if !kept {
                return Err(SimError::InvalidCase(format!(
                    "the clearance offset of tip row {} ({offset:e} m along the casing normal: \
                     the coating's thickness_m, and a clearance_m axis if any) takes tip node \
                     {j} off the casing at rest, so that it is no longer {expected:.4e} m from \
                     it; the coating must be thin against the casing",
                    self.rows[j]
                )));
            }
        }
        Ok(())
    }

    /// Tip nodes in the fixed frame, `Γ = R(Ωt) R(θ_s)(X_j + u_(s,j))`, of the current state.
    pub(super) fn place(&mut self, r_om: &Matrix3<f64>) {
        fill_blade_nodes(
            self.kernel.get().boundary(),
            r_om,
            &self.rot,
            &self.reference,
            self.n_contact,
            &mut self.nodes,
        );
    }

    /// Radial displacement (m) of tip node `j` of blade `s` in the current state.
    pub(super) fn radial_displacement(&self, s: usize, j: usize) -> f64 {
        self.radial[j].dot(&node_disp(self.kernel.get().boundary(), s, self.nb, j))
    }
}
