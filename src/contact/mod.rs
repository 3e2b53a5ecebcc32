//! Contact geometry: the casing B-spline contact surface (paper §2.2) and the
//! closest-point projection of blade-tip nodes onto it (paper §3.1).

pub mod spline;

pub use spline::{CasingSpline, PatchEval, SplineError, SurfaceParam};
