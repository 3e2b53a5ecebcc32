//! Model building: finite elements, built-in parametric geometry, cyclic symmetry,
//! Craig–Bampton reduction and the reduced-order model (ROM) type.

pub mod component;
pub mod rom;
