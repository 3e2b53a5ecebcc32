//! Dynamics stage: explicit central-difference time integration of the impeller and the
//! casing with forward-increment Lagrange-multiplier contact and Coulomb friction
//! (Carpenter, Taylor & Katona 1991; Batailly & Legrand 2015 §3).
//!
//! - [`numerics`]: time step, Newton tolerance, kernel choice, decimation;
//! - [`structure`]: a cyclic ROM frozen at Ω (eigenpairs, damping, stability limit, assembly);
//! - [`kernel`]: the two interchangeable linear-algebra kernels ([`modal`] fast, [`dense`] reference);
//! - [`contact_solve`]: contact rows, `W = G A⁻¹ Fᵀ`, active-set solve;
//! - [`scenario`]: the case definition (speed, friction, casing load, clearances);
//! - [`simulate`](mod@simulate): the time loop ([`Simulation`], one method per box of Figs. 4 and 11);
//!   [`recorder`]: what a sample step hands out and who keeps it; [`probes`]: the run's output;
//! - [`abradable`]: the abradable coating's elastoplastic elements;
//! - [`low_pass`]: the blade-tip peaks below a band edge (fourth-order Bessel low-pass);

pub mod abradable;
pub mod contact_solve;
pub mod dense;
mod imposed_casing;
pub mod kernel;
#[cfg(test)]
mod kernel_agreement;
pub mod low_pass;
pub mod modal;
pub mod numerics;
pub mod probes;
pub mod recorder;
pub mod runaway;
pub mod scenario;
pub mod simulate;
pub mod structure;

pub use numerics::{Boundary, KernelChoice, Numerics};
pub use probes::{RunSummary, SimulationOutput};
pub use scenario::{
    Case, CasingModel, CoatingCase, InitialVelocity, LobeLoad, RigidShape, RigidSurface,
};
pub use simulate::{SimError, Simulation, simulate};
