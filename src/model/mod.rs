//! Model building: finite elements, built-in parametric geometry, cyclic symmetry,
//! Craig–Bampton reduction and the reduced-order model (ROM) type.

pub mod build;
pub mod cyclic;
pub mod fe;
pub mod mesh;
pub mod reduction;
pub mod rom;
