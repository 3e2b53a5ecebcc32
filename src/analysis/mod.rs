//! Analysis stage: spectra of probe signals, a probe's steady response over its last
//! revolutions, and the linear interaction criterion.

pub mod interaction;
pub mod revolutions;
pub mod spectra;
