//! Analysis stage: spectra of probe signals and the linear interaction criterion.

pub mod interaction;
pub mod spectra;
