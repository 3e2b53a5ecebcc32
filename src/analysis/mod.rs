//! Analysis stage: spectra of probe signals, a probe's steady response over its last
//! revolutions, the linear interaction criterion, the free vibration of a mistuned wheel, and the linear stability of a persistent rub.

pub mod interaction;
pub mod mistuned_modes;
pub mod revolutions;
pub mod spectra;
pub mod stability;
