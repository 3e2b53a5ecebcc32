//! The interface shared by the two central-difference kernels.
//!
//! Each step, for one structure (ROM `M ü + D u̇ + K(Ω) u = f`):
//! predictor `(M/h² + D/2h) u*_{n+1} = f_n − (K − 2M/h²) u_n − (M/h² − D/2h) u_{n−1}`,
//! then the forward-increment Lagrange correction `u_{n+1} = u* + A⁻¹ f_c`, `A = M/h² + D/2h`
//! (Carpenter, Taylor & Katona 1991), with `f_c` the contact forces on the boundary DOFs.
//!
//! Boundary vectors are *sector-major*: entry `s·3n_c + 3j + d` is DOF `d` (x, y, z of the
//! sector-local frame) of contact node `j` of sector `s`.

use crate::contact::CasingSpline;

/// Kinetic and strain energy of a structure (J), at the half step `n − ½` in the form that
/// central differences conserve exactly in undamped free flight:
/// `T = ½ v̄ᵀ M v̄`, `v̄ = (u_n − u_{n−1})/h`, and `V = ½ u_nᵀ K u_{n−1}`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energies {
    /// Kinetic energy `T = ½ v̄ᵀ M v̄` (J).
    pub kinetic: f64,
    /// Strain energy `V = ½ u_nᵀ K u_{n−1}` (J).
    pub strain: f64,
}

impl Energies {
    /// Vibration energy `T + V` (J).
    pub fn total(&self) -> f64 {
        self.kinetic + self.strain
    }
}

/// A central-difference kernel for one structure.
pub trait StructureKernel {
    /// Number of sectors N.
    fn n_sectors(&self) -> usize;
    /// Boundary DOFs per sector, 3 n_c.
    fn n_boundary(&self) -> usize;
    /// Sets the external boundary force pattern (sector-major, N); the applied force is
    /// `amplitude × pattern` (see [`StructureKernel::predict`]).
    fn set_load_pattern(&mut self, pattern: &[f64]);
    /// Sets the initial velocity (m/s, assembled physical DOF ordering) with `u_0 = 0`:
    /// `u_{−1} = −h v_0` (rest at t = 0 otherwise).
    fn set_initial_velocity(&mut self, velocity: &[f64]);
    /// Predictor `u*_{n+1}` with the external force `amplitude × pattern` at step n; refreshes
    /// [`StructureKernel::boundary`].
    fn predict(&mut self, amplitude: f64);
    /// Boundary displacements (m) of the current `u_{n+1}` (predicted, or corrected).
    fn boundary(&self) -> &[f64];
    /// Adds boundary forces `f` (N, sector-major) to the load of the next step's predictor,
    /// on the inertial modes only: the quasi-static modes of a massless boundary (module doc
    /// of [`crate::dynamics::structure`]) do not see it. Call it in step n, before the
    /// correction that forms the predictor of step n + 1 (or before that predictor when no
    /// correction follows); [`StructureKernel::predict`] of step n + 1 uses it up. It carries
    /// the coating force's history (`CoatingStage` in `simulate`).
    fn add_inertial_load(&mut self, forces: &[f64]);
    /// Correction `u_{n+1} += A⁻¹ f` for boundary forces `f` (N, sector-major); refreshes the boundary.
    fn correct(&mut self, forces: &[f64]);
    /// [`StructureKernel::correct`], after which [`StructureKernel::advance`] and then
    /// [`StructureKernel::predict`] with `next_amplitude` must follow; a kernel may form that
    /// predictor now, in the same pass over its matrices (the result is the same), and may
    /// keep it in place of `u_{n−1}`, which nothing reads before `advance`.
    fn correct_then_predict(&mut self, forces: &[f64], next_amplitude: f64) {
        let _ = next_amplitude;
        self.correct(forces);
    }
    /// [`StructureKernel::correct_then_predict`] for a caller that does not read the corrected
    /// channels: [`StructureKernel::boundary`] is stale until the next `predict`. The state,
    /// energies and node displacements are those of `correct_then_predict`; a kernel may skip
    /// the channels of the correction (the fast kernel saves a basis pass and the inverse
    /// sector DFTs).
    fn correct_state_then_predict(&mut self, forces: &[f64], next_amplitude: f64) {
        self.correct_then_predict(forces, next_amplitude);
    }
    /// Boundary displacements of `A⁻¹ f` (no change of state): the boundary flexibility.
    fn response(&mut self, forces: &[f64], out: &mut [f64]);
    /// Shifts time: `u_{n−1} ← u_n`, `u_n ← u_{n+1}`.
    fn advance(&mut self);
    /// Energies at the half step `n − ½` (after [`StructureKernel::advance`]).
    fn energies(&self) -> Energies;
    /// Strain energy `½ x_kᵀ K_k x_k` of each nodal diameter at step n (J), paper eqs. (20)–(22).
    fn nd_strain_energy(&self, out: &mut [f64]);
    /// Whether every state entry is finite.
    fn is_finite(&self) -> bool;
    /// Makes the per-step channels ([`StructureKernel::boundary`], `correct`, `response`) the
    /// control points of `spline` instead of the contact nodes, when the kernel can (see
    /// `ModalKernel::fold_spline`); `Ok(false)`: it keeps the nodes.
    fn map_to_surface(&mut self, spline: &CasingSpline) -> Result<bool, String> {
        let _ = spline;
        Ok(false)
    }
    /// The state `u_n` (after [`StructureKernel::advance`]) as the concatenated harmonic
    /// real-form vectors `[x_0; x_1; …]` of [`crate::dynamics::structure::Structure`]
    /// (offsets `NdBlock::offset`, `n_modal` entries): what recovery rows act on. Not per step.
    fn harmonic_state(&self, out: &mut [f64]);
    /// Contact-node displacements (m, sector-major) of `u_n` (after
    /// [`StructureKernel::advance`]), whatever the per-step channels are.
    fn node_displacements(&mut self, out: &mut [f64]) {
        out.copy_from_slice(self.boundary());
    }
    /// The linear functional `wᵀ u` of the contact-node displacements `u` (sector-major, as
    /// [`StructureKernel::node_displacements`]) with weights `w`, written on the kernel's own
    /// state so that [`StructureKernel::functional_value`] evaluates it on every step without
    /// forming `u`. By reciprocity the coefficients are the state's generalised force of the
    /// load `w`.
    fn boundary_functional(&mut self, weights: &[f64]) -> Vec<f64> {
        weights.to_vec()
    }
    /// The value at `u_n` (after [`StructureKernel::advance`]) of a functional of
    /// [`StructureKernel::boundary_functional`].
    fn functional_value(&self, functional: &[f64]) -> f64 {
        functional
            .iter()
            .zip(self.boundary())
            .map(|(g, u)| g * u)
            .sum()
    }
}
