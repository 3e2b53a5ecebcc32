//! Contact geometry: the casing B-spline contact surface (paper §2.2) and the
//! closest-point projection of blade-tip nodes onto it (paper §3.1); the imposed-gap rigid casing
//! of the public Rotor 37 benchmark.

pub mod imposed_gap;
pub mod projection;
pub mod spline;

pub use imposed_gap::{GapDirection, GapProfile, ImposedGap};
pub use projection::{
    DEFAULT_EPS_NR, GapBounds, LocalSurface, NodeProjectionError, Projection, ProjectionError,
    closest_point, closest_point_local, friction_direction, project_nodes,
};
pub use spline::{Along, CasingSpline, PatchEval, SplineError, SurfaceParam};
