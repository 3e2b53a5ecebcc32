//! Model building: finite elements, built-in parametric geometry, cyclic symmetry,
//! Craig–Bampton reduction (cyclic and single-component) and the reduced-order model (ROM) type.

pub mod build;
#[cfg(test)]
mod builtin_sectors;
pub mod component;
pub mod cyclic;
pub mod eigen;
pub mod fe;
pub(crate) mod hex20;
pub mod mesh;
mod mirror;
pub mod mistuning;
pub(crate) mod recovery;
#[cfg(test)]
mod recovery_check;
pub mod reduction;
pub mod rom;
pub mod sector_faces;
pub mod sector_modes;
pub mod sparse_eigen;
