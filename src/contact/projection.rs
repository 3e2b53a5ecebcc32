//! Closest point of a blade-tip node on the casing spline (paper §3.1, Fig. 6),
//! outward normal and gap (eq. 14), friction direction (eq. 15).
//!
//! The search runs in *global* spline parameters `U = i + u ∈ [0, N)`
//! (periodic) and `V = j + v ∈ [0, M−1]`: the spline is C² across patch seams,
//! so a Newton step that leaves `[0, 1]²` simply continues on the neighbouring
//! patch with unchanged derivatives — convergence is not affected. `U` wraps
//! around the closing line (patch `N−1` ↔ `0`); `V` is clamped at the free
//! edges, where the problem becomes a bound-constrained minimisation solved
//! by a projected Newton step (the closest point then lies on the boundary
//! curve `v = 0` of row 0 or `v = 1` of row `M−2`).

use super::spline::{CasingSpline, PatchEval, SplineError, SurfaceParam};
use crate::simd::{self, Isa};
use nalgebra::Vector3;
use thiserror::Error;

/// Default Newton–Raphson stop criterion ε_NR (paper §3.1).
pub const DEFAULT_EPS_NR: f64 = 1e-5;

/// Newton iterations allowed before [`ProjectionError::NotConverged`].
pub const MAX_NEWTON_ITERATIONS: usize = 50;

/// Relative threshold of [`friction_direction`]: below `NO_SLIP_REL_TOL · |Δ|`
/// the tangential increment is treated as zero.
pub(crate) const NO_SLIP_REL_TOL: f64 = 1e-9;

/// Result of [`closest_point`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// Patch and local coordinates of the closest point (the warm start of the next step).
    pub param: SurfaceParam,
    /// Closest point `S` on the spline, m.
    pub point: Vector3<f64>,
    /// Unit normal at `S` (eq. 14), pointing from the casing toward the rotation
    /// axis when [`CasingSpline::normal_sign`] is set for the model.
    pub normal: Vector3<f64>,
    /// Signed gap `d = n · (x − S)`, m; negative means penetration.
    pub gap: f64,
    /// Newton iterations used (for profiling counters).
    pub iterations: usize,
}

impl Default for Projection {
    fn default() -> Self {
        Projection {
            param: SurfaceParam {
                i: 0,
                j: 0,
                u: 0.5,
                v: 0.5,
            },
            point: Vector3::zeros(),
            normal: Vector3::zeros(),
            gap: f64::INFINITY,
            iterations: 0,
        }
    }
}

/// Why a projection failed. The batch [`project_nodes`] adds the node index.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ProjectionError {
    /// The point to project has a NaN or infinite coordinate.
    #[error("point {x:?} to project is not finite")]
    NonFinitePoint {
        /// The point (m).
        x: [f64; 3],
    },
    /// ε_NR must be positive and finite.
    #[error("eps_nr = {0}: the Newton stop criterion must be positive and finite")]
    BadTolerance(f64),
    /// The warm start is not a valid surface parameter.
    #[error("warm start {0:?} is not a valid patch parameter")]
    BadWarmStart(SurfaceParam),
    /// Control points of the wrong length (or another spline-level error).
    #[error("spline: {0}")]
    Spline(#[from] SplineError),
    /// `S_u` and `S_v` are parallel (or not finite): the surface is degenerate there.
    #[error("degenerate surface at {param:?}: S_u and S_v are parallel or not finite")]
    DegenerateSurface {
        /// Where on the surface.
        param: SurfaceParam,
    },
    /// Newton–Raphson did not reach ε_NR within [`MAX_NEWTON_ITERATIONS`].
    #[error(
        "Newton-Raphson did not converge in {iterations} iterations from point {x:?} (last update {last_step:e} patch lengths at {param:?})"
    )]
    NotConverged {
        /// The point being projected (m).
        x: [f64; 3],
        /// Newton iterations done.
        iterations: usize,
        /// Size of the last `(u, v)` update, in patch lengths.
        last_step: f64,
        /// The last iterate.
        param: SurfaceParam,
    },
}

/// A projection failure of casing-contact query node `node` (index into the slice given to [`project_nodes`]).
#[derive(Debug, Error, Clone, PartialEq)]
#[error("closest point of node {node}: {source}")]
pub struct NodeProjectionError {
    /// Index of the node in the slice given to [`project_nodes`].
    pub node: usize,
    /// Why its projection failed.
    #[source]
    pub source: ProjectionError,
}

/// Closest point on the casing spline of `x` (m), by Newton–Raphson on `(u, v)`
/// minimising `½|x − S(u, v)|²` (paper §3.1, Fig. 6).
///
/// - `q`: control points from [`CasingSpline::control_points`].
/// - `warm_start`: the previous step's parameter; `None` starts from the centre
///   of the patch, adjacent to the data point nearest to `x`, whose four corner
///   data points are nearest to `x` (sum of squared distances).
/// - `eps_nr`: stop when `max(|ΔU|, |ΔV|) ≤ eps_nr`, the update of the global
///   parameters actually taken (after clamping). A patch has unit extent in
///   `U` and `V`, so this is the update relative to the patch size (node spacing).
///
/// Each iteration uses the exact Hessian `[S_a·S_b − S_ab·(x − S)]`, or its
/// Gauss–Newton part `[S_a·S_b]` where the exact one is not positive definite
/// (far from the surface); steps are capped at one patch. The returned normal
/// is `normal_sign · (−S_u × S_v)/|S_u × S_v|` (eq. 14) and the gap
/// `d = n · (x − S)`; on a free edge the closest point lies on the boundary
/// curve and `d` is still measured along the surface normal there.
pub fn closest_point(
    spline: &CasingSpline,
    q: &[Vector3<f64>],
    x: Vector3<f64>,
    warm_start: Option<SurfaceParam>,
    eps_nr: f64,
) -> Result<Projection, ProjectionError> {
    closest_point_local(spline, q, x, warm_start, eps_nr).map(|(p, _)| p)
}

/// The casing surface about a closest point, at global parameters `(U, V)`: its point and
/// tangents as [`closest_point`] returns them (the second-order Taylor expansion of its last
/// Newton iteration's patch evaluation) and that evaluation's second derivatives.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocalSurface {
    e: PatchEval,
    gu: f64,
    gv: f64,
}

impl LocalSurface {
    /// The closest point of `x` (m) when one Newton iteration from here already meets ε_NR
    /// (`eps_nr`): the converging iteration of [`closest_point`] (the same step and the same
    /// second-order finish, with the same O(|Δ|³) error) on this Taylor model of the surface,
    /// without evaluating the spline. `None` when the step is longer, or the surface
    /// degenerate here: project `x` with [`closest_point`].
    pub fn reproject(
        &self,
        spline: &CasingSpline,
        x: Vector3<f64>,
        eps_nr: f64,
    ) -> Option<Projection> {
        let v_max = (spline.nodes_per_sector() - 1) as f64;
        let (du, dv, gv) = newton_step(&self.e, &x, self.gv, v_max).ok()?;
        if du.abs().max(dv.abs()) > eps_nr {
            return None;
        }
        let gu = wrap(self.gu + du, spline.n_sectors() as f64);
        converged(spline, &self.e, &x, (du, dv), (gu, gv), 1)
            .ok()
            .map(|(p, _)| p)
    }
}

/// [`closest_point`], with the surface as its last Newton iteration saw it: enough to project
/// a point nearby again without evaluating the spline ([`LocalSurface::reproject`]). Inlined
/// everywhere, so that [`closest_point`] does not even form the surface it drops.
#[inline(always)]
pub fn closest_point_local(
    spline: &CasingSpline,
    q: &[Vector3<f64>],
    x: Vector3<f64>,
    warm_start: Option<SurfaceParam>,
    eps_nr: f64,
) -> Result<(Projection, LocalSurface), ProjectionError> {
    if !(x.x.is_finite() && x.y.is_finite() && x.z.is_finite()) {
        return Err(ProjectionError::NonFinitePoint { x: x.into() });
    }
    if !(eps_nr > 0.0 && eps_nr.is_finite()) {
        return Err(ProjectionError::BadTolerance(eps_nr));
    }
    if q.len() != spline.n_control() {
        return Err(SplineError::LengthMismatch {
            what: "control points",
            expected: spline.n_control(),
            got: q.len(),
        }
        .into());
    }
    let n = spline.n_sectors() as f64;
    let v_max = (spline.nodes_per_sector() - 1) as f64;
    let start = match warm_start {
        Some(p) => {
            let ok = p.i < spline.n_sectors()
                && p.j + 1 < spline.nodes_per_sector()
                && (0.0..=1.0).contains(&p.u)
                && (0.0..=1.0).contains(&p.v);
            if !ok {
                return Err(ProjectionError::BadWarmStart(p));
            }
            p
        }
        None => initial_guess(spline, q, &x),
    };
    let (mut gu, mut gv) = (start.i as f64 + start.u, start.j as f64 + start.v);
    let mut last_step = f64::INFINITY;
    for it in 1..=MAX_NEWTON_ITERATIONS {
        let p = to_param(spline, gu, gv);
        let e = spline.eval_unchecked(q, p.i, p.j, p.u, p.v);
        let (du, dv, new_gv) = newton_step(&e, &x, gv, v_max)
            .map_err(|()| ProjectionError::DegenerateSurface { param: p })?;
        last_step = du.abs().max(dv.abs());
        gu = wrap(gu + du, n);
        gv = new_gv;
        if last_step <= eps_nr {
            let (found, e) = converged(spline, &e, &x, (du, dv), (gu, gv), it)?;
            return Ok((found, LocalSurface { e, gu, gv }));
        }
    }
    Err(ProjectionError::NotConverged {
        x: x.into(),
        iterations: MAX_NEWTON_ITERATIONS,
        last_step,
        param: to_param(spline, gu, gv),
    })
}

/// One Newton iteration toward the closest point of `x` from the evaluation `e` at the global
/// meridian parameter `gv`: the update `(ΔU, ΔV)`, capped at one patch and kept within the
/// free edges `0 ≤ V ≤ v_max`, and the new `V`. `Err` where `S_u` and `S_v` are parallel or
/// not finite.
#[inline(always)]
fn newton_step(
    e: &PatchEval,
    x: &Vector3<f64>,
    gv: f64,
    v_max: f64,
) -> Result<(f64, f64, f64), ()> {
    let r = x - e.s;
    let (g_u, g_v) = (-e.su.dot(&r), -e.sv.dot(&r));
    let (a_uu, a_uv, a_vv) = (e.su.dot(&e.su), e.su.dot(&e.sv), e.sv.dot(&e.sv));
    let (mut h_uu, mut h_uv, mut h_vv) = (
        a_uu - e.suu.dot(&r),
        a_uv - e.suv.dot(&r),
        a_vv - e.svv.dot(&r),
    );
    let gauss_det = a_uu * a_vv - a_uv * a_uv;
    // Written positively so that NaN (non-finite control points) is rejected too.
    let regular = gauss_det > 1e-14 * a_uu * a_vv;
    if !regular {
        return Err(());
    }
    let newton_pd = h_uu > 0.0 && h_uu * h_vv - h_uv * h_uv > 1e-10 * a_uu * a_vv;
    if !newton_pd {
        (h_uu, h_uv, h_vv) = (a_uu, a_uv, a_vv);
    }
    // Projected Newton at the free edges: a bound stays active while the
    // gradient pushes outward, and the step is then taken along u only.
    let at_bound = (gv <= 0.0 && g_v > 0.0) || (gv >= v_max && g_v < 0.0);
    let (mut du, mut dv) = if at_bound {
        (-g_u / h_uu, 0.0)
    } else {
        let det = h_uu * h_vv - h_uv * h_uv;
        (
            (-h_vv * g_u + h_uv * g_v) / det,
            (h_uv * g_u - h_uu * g_v) / det,
        )
    };
    let len = du.abs().max(dv.abs());
    if len > 1.0 {
        du /= len;
        dv /= len;
    }
    let new_gv = (gv + dv).clamp(0.0, v_max);
    Ok((du, new_gv - gv, new_gv))
}

/// The projection of `x` when the Newton update `(du, dv)` from the evaluation `e` met ε_NR,
/// landing at global parameters `(gu, gv)` after `iterations`, and the surface there. The
/// final point and tangents come from the second-order Taylor expansion of `e` (error O(|Δ|³)
/// in S, O(|Δ|²) in the tangents, far below round-off for |Δ| ≤ ε_NR) instead of one more
/// patch evaluation; the second derivatives are `e`'s.
#[inline(always)]
fn converged(
    spline: &CasingSpline,
    e: &PatchEval,
    x: &Vector3<f64>,
    (du, dv): (f64, f64),
    (gu, gv): (f64, f64),
    iterations: usize,
) -> Result<(Projection, PatchEval), ProjectionError> {
    let s = e.s
        + e.su * du
        + e.sv * dv
        + (e.suu * (du * du) + e.suv * (2.0 * du * dv) + e.svv * (dv * dv)) * 0.5;
    let su = e.su + e.suu * du + e.suv * dv;
    let sv = e.sv + e.suv * du + e.svv * dv;
    let raw = -su.cross(&sv);
    let norm = raw.norm();
    let p = to_param(spline, gu, gv);
    let usable = norm > 0.0 && norm.is_finite();
    if !usable {
        return Err(ProjectionError::DegenerateSurface { param: p });
    }
    let normal = raw * (spline.normal_sign() / norm);
    let found = Projection {
        param: p,
        point: s,
        normal,
        gap: normal.dot(&(x - s)),
        iterations,
    };
    Ok((found, PatchEval { s, su, sv, ..*e }))
}

/// Projects every point of `xs` (e.g. all blade-tip nodes) with [`closest_point`],
/// warm-starting node `k` from `warm[k]` and storing its new parameter there;
/// results go to `out[k]`. Stops at the first failure, naming the node.
pub fn project_nodes(
    spline: &CasingSpline,
    q: &[Vector3<f64>],
    xs: &[Vector3<f64>],
    warm: &mut [Option<SurfaceParam>],
    eps_nr: f64,
    out: &mut [Projection],
) -> Result<(), NodeProjectionError> {
    check_lengths(xs.len(), warm.len(), out.len())?;
    for (node, ((x, w), o)) in xs
        .iter()
        .zip(warm.iter_mut())
        .zip(out.iter_mut())
        .enumerate()
    {
        project_node(spline, q, node, x, w, eps_nr, o)?;
    }
    Ok(())
}

/// [`closest_point`] of node `node` at `x`, warm-started from `warm` and storing its new
/// parameter there; the result goes to `out`.
fn project_node(
    spline: &CasingSpline,
    q: &[Vector3<f64>],
    node: usize,
    x: &Vector3<f64>,
    warm: &mut Option<SurfaceParam>,
    eps_nr: f64,
    out: &mut Projection,
) -> Result<(), NodeProjectionError> {
    *out = closest_point(spline, q, *x, *warm, eps_nr)
        .map_err(|source| NodeProjectionError { node, source })?;
    *warm = Some(out.param);
    Ok(())
}

/// Fails, naming the buffer, unless the warm starts and results match the nodes in length.
fn check_lengths(nodes: usize, warm: usize, out: usize) -> Result<(), NodeProjectionError> {
    let len_err = |what, got| NodeProjectionError {
        node: 0,
        source: SplineError::LengthMismatch {
            what,
            expected: nodes,
            got,
        }
        .into(),
    };
    if warm != nodes {
        return Err(len_err("warm starts", warm));
    }
    if out != nodes {
        return Err(len_err("projections", out));
    }
    Ok(())
}

/// A node's change of global parameter `(U, V)` over its last step, and over the step before
/// when it was projected in both.
#[derive(Clone, Copy, Debug)]
struct Trend {
    last: (f64, f64),
    before: Option<(f64, f64)>,
}

/// Conservative lower bounds on the gaps of nodes between their projections, so that nodes
/// far from the casing need not be projected every step ([`GapBounds::project_near`]).
///
/// The signed distance to a surface is 1-Lipschitz in the point, and a point of a B-spline
/// surface moves by at most the largest displacement of its control points (the basis
/// functions are non-negative and sum to one: the convex-hull property). So a node projected
/// at `x₀` with gap `d₀` has now, at `x`, a gap `d ≥ d₀ − |x − x₀| − D`, where `D` sums the
/// largest control-point displacement of every surface update since.
///
/// Warm starts are extrapolated over a time step ([`GapBounds::next_step`]): a node projected
/// in each of the last three steps starts from its closest point moved on by the last step's
/// change plus that change's own change (a third difference away from the answer, so Newton
/// usually stops after one iteration: a blade tip's parameter speed varies by ~ε_NR per step);
/// after two steps, by the last change alone; any other node sweeping about the casing axis
/// (a blade tip) starts from its last closest point advanced by the angle swept since. A node
/// projected again within a step (after the coating's forces) keeps the change of its first
/// projection in the step.
#[derive(Clone, Debug)]
pub struct GapBounds {
    /// Gap (m), position and cumulative surface drift (m) at each node's last projection.
    gap: Vec<f64>,
    x: Vec<Vector3<f64>>,
    drift_then: Vec<f64>,
    /// Cumulative surface drift (m) and the control points it was last measured on.
    drift: f64,
    q_last: Vec<Vector3<f64>>,
    /// The surface never moves (a rigid casing): its drift stays 0 without a scan of its
    /// control points each step, which was a third of a rigid-casing step's time.
    fixed_surface: bool,
    /// Patch lengths along `u` per radian swept counterclockwise about z (±N/2π, the sign
    /// from the order of the sectors).
    u_per_radian: f64,
    /// Time steps begun so far (from 1, so that no node counts as projected in the previous
    /// step before the first), the step of each node's last projection, and the change of its
    /// global parameter `(U, V)` over its last two steps when it was projected in both.
    steps: u64,
    last_step: Vec<u64>,
    trend: Vec<Option<Trend>>,
    /// The nodes beyond the margin in a call, with their bounds (work buffer).
    far: Vec<(f64, usize)>,
}

impl GapBounds {
    /// No bound yet: every node is projected on the first call.
    pub fn new(n_nodes: usize) -> Self {
        Self {
            gap: vec![f64::NEG_INFINITY; n_nodes],
            x: vec![Vector3::zeros(); n_nodes],
            drift_then: vec![0.0; n_nodes],
            drift: 0.0,
            q_last: Vec::new(),
            fixed_surface: false,
            u_per_radian: 0.0,
            steps: 1,
            last_step: vec![0; n_nodes],
            trend: vec![None; n_nodes],
            far: Vec::with_capacity(n_nodes),
        }
    }

    /// The same bounds, told whether the surface is `fixed` (a rigid casing): its control
    /// points never change, so every call must then pass those of the first.
    pub fn with_fixed_surface(self, fixed: bool) -> Self {
        Self {
            fixed_surface: fixed,
            ..self
        }
    }

    /// Lower bound (m) of node `k`'s gap at position `x` on the surface of the last call.
    pub(crate) fn lower_bound(&self, k: usize, x: &Vector3<f64>) -> f64 {
        self.gap[k] - (x - self.x[k]).norm() - (self.drift - self.drift_then[k])
    }

    /// Guessed change of node `k`'s global parameter since its last projection, now at `x`:
    /// if it was last projected in the previous step, its last step's change, extrapolated to
    /// second order when the step before is known; else the angle it swept (within a step:
    /// next to none).
    fn step_guess(&self, k: usize, x: &Vector3<f64>, consecutive: bool) -> (f64, f64) {
        let trend = self.trend[k]
            .filter(|_| consecutive)
            .map(|t| match t.before {
                Some(b) => (2.0 * t.last.0 - b.0, 2.0 * t.last.1 - b.1),
                None => t.last,
            });
        trend.unwrap_or_else(|| {
            let x0 = self.x[k];
            let swept = (x0.x * x.y - x0.y * x.x).atan2(x0.x * x.x + x0.y * x.y);
            (swept * self.u_per_radian, 0.0)
        })
    }

    /// Begins a time step: the next projection of each node extrapolates its warm start over
    /// the step; those after it in the same step start where it ended.
    pub fn next_step(&mut self) {
        self.steps += 1;
    }

    /// [`project_nodes`] restricted to the nodes whose gap bound is not above `margin` (m).
    /// With `exact_min`, then also every node whose bound is below the smallest gap found so
    /// far, nearest first: the smallest gap of `out` is then the smallest gap of all nodes. The
    /// others keep their last `out` and warm start (their gap there is stale, but provably
    /// above `margin` and not below that minimum). Returns the number of nodes projected.
    #[allow(clippy::too_many_arguments)]
    pub fn project_near(
        &mut self,
        spline: &CasingSpline,
        q: &[Vector3<f64>],
        xs: &[Vector3<f64>],
        warm: &mut [Option<SurfaceParam>],
        eps_nr: f64,
        out: &mut [Projection],
        margin: f64,
        exact_min: bool,
    ) -> Result<usize, NodeProjectionError> {
        check_lengths(xs.len(), warm.len(), out.len())?;
        check_lengths(xs.len(), self.gap.len(), out.len())?;
        if self.q_last.len() != q.len() {
            // A new surface (first call): no earlier bound applies.
            self.q_last = q.to_vec();
            self.gap.iter_mut().for_each(|g| *g = f64::NEG_INFINITY);
            let (p0, p1) = (data_point(spline, q, 0, 0), data_point(spline, q, 1, 0));
            let ccw = p0.x * p1.y - p0.y * p1.x >= 0.0;
            let n = spline.n_sectors() as f64 / std::f64::consts::TAU;
            self.u_per_radian = if ccw { n } else { -n };
        } else if !self.fixed_surface {
            self.drift += largest_move(Isa::selected(), &mut self.q_last, q);
        }
        let mut projected = 0;
        let mut min_gap = f64::INFINITY;
        self.far.clear();
        for (node, x) in xs.iter().enumerate() {
            let bound = self.lower_bound(node, x);
            if bound > margin {
                self.far.push((bound, node));
                continue;
            }
            self.project_one(spline, q, node, x, warm, eps_nr, out)?;
            min_gap = min_gap.min(out[node].gap);
            projected += 1;
        }
        if exact_min {
            self.far.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
            for i in 0..self.far.len() {
                let (bound, node) = self.far[i];
                if bound >= min_gap {
                    break;
                }
                self.project_one(spline, q, node, &xs[node], warm, eps_nr, out)?;
                min_gap = min_gap.min(out[node].gap);
                projected += 1;
            }
        }
        Ok(projected)
    }

    /// The smallest gap (m) of all nodes, given `min_gap`, the smallest gap of the nodes the
    /// last [`GapBounds::project_near`] projected: the nodes it skipped whose bound is below
    /// the running minimum are projected too, nearest first, from their extrapolated warm
    /// starts, into scratch. Nothing that a later call reads changes (warm starts, bounds,
    /// trends, `out`): a probe, so that sampling the minimum gap never changes the states.
    pub fn exact_min_gap(
        &mut self,
        spline: &CasingSpline,
        q: &[Vector3<f64>],
        xs: &[Vector3<f64>],
        warm: &[Option<SurfaceParam>],
        eps_nr: f64,
        mut min_gap: f64,
    ) -> Result<f64, NodeProjectionError> {
        self.far.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        for &(bound, node) in &self.far {
            if bound >= min_gap {
                break;
            }
            let x = &xs[node];
            let mut start = warm[node].map(|p| self.extrapolated(spline, node, x, p));
            let mut out = Projection::default();
            project_node(spline, q, node, x, &mut start, eps_nr, &mut out)?;
            min_gap = min_gap.min(out.gap);
        }
        Ok(min_gap)
    }

    /// The warm start of node `node`, now at `x`, extrapolated from its last closest point `p`
    /// by [`GapBounds::step_guess`].
    fn extrapolated(
        &self,
        spline: &CasingSpline,
        node: usize,
        x: &Vector3<f64>,
        p: SurfaceParam,
    ) -> SurfaceParam {
        let n = spline.n_sectors() as f64;
        let consecutive = self.last_step[node] + 1 == self.steps;
        let (du, dv) = self.step_guess(node, x, consecutive);
        to_param(
            spline,
            wrap(p.i as f64 + p.u + du, n),
            p.j as f64 + p.v + dv,
        )
    }

    /// Projects node `node` at `x` from its extrapolated warm start and records its bound.
    #[allow(clippy::too_many_arguments)]
    fn project_one(
        &mut self,
        spline: &CasingSpline,
        q: &[Vector3<f64>],
        node: usize,
        x: &Vector3<f64>,
        warm: &mut [Option<SurfaceParam>],
        eps_nr: f64,
        out: &mut [Projection],
    ) -> Result<(), NodeProjectionError> {
        let n = spline.n_sectors() as f64;
        let start = warm[node].map(|p| (p.i as f64 + p.u, p.j as f64 + p.v));
        let (same_step, consecutive) = (
            self.last_step[node] == self.steps,
            self.last_step[node] + 1 == self.steps,
        );
        if let Some(p) = warm[node] {
            warm[node] = Some(self.extrapolated(spline, node, x, p));
        }
        project_node(spline, q, node, x, &mut warm[node], eps_nr, &mut out[node])?;
        let p = out[node].param;
        if !same_step {
            let before = self.trend[node].map(|t| t.last);
            self.trend[node] = start.filter(|_| consecutive).map(|(gu, gv)| {
                // The shorter way round the closed direction.
                let du = wrap(p.i as f64 + p.u - gu, n);
                let du = if du > 0.5 * n { du - n } else { du };
                Trend {
                    last: (du, p.j as f64 + p.v - gv),
                    before,
                }
            });
        }
        self.last_step[node] = self.steps;
        self.gap[node] = out[node].gap;
        self.x[node] = *x;
        self.drift_then[node] = self.drift;
        Ok(())
    }
}

/// The largest distance (m) between the points of `last` and `now`, which then replace
/// `last`. A step scans every control point of the casing: [`simd::largest_move`] on the
/// process's SIMD path.
fn largest_move(isa: Isa, last: &mut [Vector3<f64>], now: &[Vector3<f64>]) -> f64 {
    simd::largest_move(
        isa,
        bytemuck::cast_slice_mut(last),
        bytemuck::cast_slice(now),
    )
}

/// Cold-start guess (paper §3.1): centre of the patch, among those touching the
/// data point nearest to `x`, whose four corner data points are nearest to `x`.
/// Costs `O(N·M)`; used only without a warm start.
pub(crate) fn initial_guess(
    spline: &CasingSpline,
    q: &[Vector3<f64>],
    x: &Vector3<f64>,
) -> SurfaceParam {
    let (n, m) = (spline.n_sectors(), spline.nodes_per_sector());
    let dist2 = |i: usize, j: usize| (data_point(spline, q, i % n, j) - x).norm_squared();
    let mut best = (f64::INFINITY, 0, 0);
    for i in 0..n {
        for j in 0..m {
            let d = dist2(i, j);
            if d < best.0 {
                best = (d, i, j);
            }
        }
    }
    let (_, bi, bj) = best;
    let mut choice = (f64::INFINITY, bi, bj.min(m - 2));
    for pi in [(bi + n - 1) % n, bi] {
        for pj in [bj.saturating_sub(1), bj.min(m - 2)] {
            let s = dist2(pi, pj) + dist2(pi + 1, pj) + dist2(pi, pj + 1) + dist2(pi + 1, pj + 1);
            if s < choice.0 {
                choice = (s, pi, pj);
            }
        }
    }
    SurfaceParam {
        i: choice.1,
        j: choice.2,
        u: 0.5,
        v: 0.5,
    }
}

/// Data point `P(i, j)` (eq. 8) recovered from the control points: the
/// `(1, 4, 1) ⊗ (1, 4, 1) / 36` stencil centred on `Q[i+1][j+1]`.
fn data_point(spline: &CasingSpline, q: &[Vector3<f64>], i: usize, j: usize) -> Vector3<f64> {
    const W: [f64; 3] = [1.0, 4.0, 1.0];
    let mut p = Vector3::zeros();
    for (a, wa) in W.iter().enumerate() {
        for (b, wb) in W.iter().enumerate() {
            p += q[spline.control_index(i + a, j + b)] * (wa * wb);
        }
    }
    p / 36.0
}

/// `x.rem_euclid(n)`, bit for bit, without its `fmod` call where `x ∈ (−n, 2n)` (a Newton
/// update or a step's sweep crosses the closing line at most once): there `x`, `x + n` and
/// `x − n` are exact.
#[inline]
fn wrap(x: f64, n: f64) -> f64 {
    if (0.0..n).contains(&x) {
        x
    } else if x > -n && x < 0.0 {
        x + n
    } else if (n..2.0 * n).contains(&x) {
        x - n
    } else {
        x.rem_euclid(n)
    }
}

/// Patch parameter of global coordinates `U ∈ [0, N]`, `V ∈ [0, M−1]`.
#[inline]
fn to_param(spline: &CasingSpline, gu: f64, gv: f64) -> SurfaceParam {
    // After `max(0)` a truncating cast is `floor` (and costs no `libm` call).
    let i = (gu.max(0.0) as usize).min(spline.n_sectors() - 1);
    let j = (gv.max(0.0) as usize).min(spline.nodes_per_sector() - 2);
    SurfaceParam {
        i,
        j,
        u: (gu - i as f64).clamp(0.0, 1.0),
        v: (gv - j as f64).clamp(0.0, 1.0),
    }
}

/// Unit friction direction of eq. (15): `t = n × (n × Δ)` normalised, i.e. minus
/// the unit tangential part of the increment `Δ` (the node's predicted slip);
/// `n` must be a unit vector. Returns `None` (no slip: no friction direction,
/// the caller applies no tangential force) when `|Δ_t| ≤ NO_SLIP_REL_TOL · |Δ|`,
/// when `Δ = 0`, or when the input is not finite.
pub fn friction_direction(n: &Vector3<f64>, increment: &Vector3<f64>) -> Option<Vector3<f64>> {
    let t = n.cross(&n.cross(increment));
    let tn = t.norm();
    let dn = increment.norm();
    if !(tn.is_finite() && dn.is_finite()) || tn <= NO_SLIP_REL_TOL * dn || tn == 0.0 {
        return None;
    }
    Some(t / tn)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// `wrap` is `rem_euclid` bit for bit: near the closing line, at its ends and zeros, and
    /// far from it.
    #[test]
    fn wrap_is_rem_euclid() {
        let n = 100.0;
        let tiny = f64::EPSILON;
        let xs = [
            0.0,
            -0.0,
            tiny,
            -tiny,
            1e-300,
            -1e-300,
            0.3,
            99.999_999,
            n,
            n - 1e-13,
            n + 1e-13,
            -n,
            -n + 1e-13,
            -n - 1e-13,
            2.0 * n,
            2.0 * n - 1e-12,
            -0.7,
            150.25,
            -250.5,
            1e9,
            f64::NAN,
            f64::INFINITY,
        ];
        for x in xs {
            let (got, want) = (wrap(x, n), x.rem_euclid(n));
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "{x}: {got} vs {want}"
            );
        }
    }

    /// The scan finds the one point that moved far, wherever it sits in the runs of four
    /// (each lane, and the partial run), and leaves `last` equal to `now`.
    #[test]
    fn largest_move_is_the_largest_point_distance() {
        let mut rng = crate::fixtures::Lcg(5);
        let mut random = || Vector3::new(rng.next(), rng.next(), rng.next());
        for n in [1, 4, 7, 14] {
            for far in 0..n {
                let mut last: Vec<Vector3<f64>> = (0..n).map(|_| random()).collect();
                let mut now: Vec<Vector3<f64>> = last.iter().map(|p| p + random() * 1e-6).collect();
                now[far] = last[far] + random();
                let want = (now[far] - last[far]).norm();
                let got = largest_move(Isa::selected(), &mut last, &now);
                // The vector sums may add the squares in another order.
                assert!(
                    (got - want).abs() <= 1e-15 * want,
                    "{n} points, far {far}: {got} vs {want}"
                );
                assert_eq!(last, now);
            }
        }
    }

    /// Nodes on a surface of revolution (`r(s)`, `z(s)`, `s ∈ [0, 1]` along the meridian).
    fn revolution_nodes(
        n: usize,
        m: usize,
        r_of: impl Fn(f64) -> f64,
        z_of: impl Fn(f64) -> f64,
    ) -> Vec<Vector3<f64>> {
        let mut nodes = Vec::with_capacity(n * m);
        for i in 0..n {
            let th = 2.0 * PI * i as f64 / n as f64;
            for j in 0..m {
                let s = j as f64 / (m - 1) as f64;
                nodes.push(Vector3::new(
                    r_of(s) * th.cos(),
                    r_of(s) * th.sin(),
                    z_of(s),
                ));
            }
        }
        nodes
    }

    struct Case {
        sp: CasingSpline,
        q: Vec<Vector3<f64>>,
        nodes: Vec<Vector3<f64>>,
    }

    fn case(n: usize, m: usize, r_of: impl Fn(f64) -> f64, z_of: impl Fn(f64) -> f64) -> Case {
        let nodes = revolution_nodes(n, m, r_of, z_of);
        let mut sp = CasingSpline::new(n, m).unwrap();
        sp.orient_toward_axis(&nodes).unwrap();
        let mut q = vec![Vector3::zeros(); sp.n_control()];
        sp.control_points(&nodes, &mut q).unwrap();
        Case { sp, q, nodes }
    }

    fn cylinder() -> Case {
        case(24, 5, |_| 0.3, |s| 0.1 * s)
    }

    fn cone() -> Case {
        case(16, 4, |s| 0.2 + 0.1 * s, |s| 0.1 * s)
    }

    fn p(i: usize, j: usize, u: f64, v: f64) -> SurfaceParam {
        SurfaceParam { i, j, u, v }
    }

    /// Point at signed distance `t` from `S(param)` along the oriented normal: its
    /// closest point on the spline is `S(param)` (for |t| below the curvature radius).
    fn offset_point(
        c: &Case,
        param: SurfaceParam,
        t: f64,
    ) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let e = c.sp.evaluate(&c.q, &param).unwrap();
        let nrm = -e.su.cross(&e.sv).normalize() * c.sp.normal_sign();
        (e.s + t * nrm, e.s, nrm)
    }

    fn global(sp: &CasingSpline, a: &SurfaceParam) -> (f64, f64) {
        let _ = sp;
        (a.i as f64 + a.u, a.j as f64 + a.v)
    }

    #[test]
    fn recovers_known_closest_points_on_cylinder_and_cone() {
        for c in [cylinder(), cone()] {
            let n = c.sp.n_sectors();
            let m = c.sp.nodes_per_sector();
            let targets = [
                p(0, 0, 0.3, 0.4),
                p(n - 1, m - 2, 0.77, 0.21),
                p(n / 2, 1, 0.05, 0.95),
                p(3, m - 2, 0.5, 0.5),
            ];
            for target in targets {
                for t in [-0.004, 0.0, 0.002, 0.02] {
                    let (x, s, nrm) = offset_point(&c, target, t);
                    for warm in [None, Some(p(target.i, target.j, 0.5, 0.5))] {
                        let pr = closest_point(&c.sp, &c.q, x, warm, DEFAULT_EPS_NR).unwrap();
                        assert!(
                            (pr.point - s).norm() < 1e-10,
                            "{:?} t={t}: {} vs {s}",
                            target,
                            pr.point
                        );
                        assert!((pr.gap - t).abs() < 1e-10, "gap {} vs {t}", pr.gap);
                        assert!((pr.normal - nrm).norm() < 1e-9);
                        let (a, b) = (global(&c.sp, &pr.param), global(&c.sp, &target));
                        assert!((a.0 - b.0).abs() < 1e-8 && (a.1 - b.1).abs() < 1e-8);
                    }
                }
            }
        }
    }

    /// A point moved by far less than ε_NR of a patch from a projected one projects again on
    /// the stored surface as the full projection does (to round-off, on a doubly curved
    /// surface, across the closing line too); a point moved farther is left to the full
    /// projection.
    #[test]
    fn local_reprojection_agrees_with_the_full_projection_nearby() {
        let c = case(16, 4, |s| 0.2 + 0.1 * s * s, |s| 0.1 * s);
        let n = c.sp.n_sectors();
        for target in [
            p(0, 0, 0.3, 0.4),
            p(n - 1, 1, 0.999_999_9, 0.7),
            p(5, 2, 0.5, 0.99),
        ] {
            let (x, _, nrm) = offset_point(&c, target, -1e-4);
            let (first, local) =
                closest_point_local(&c.sp, &c.q, x, Some(target), DEFAULT_EPS_NR).unwrap();
            assert_eq!(
                closest_point(&c.sp, &c.q, x, Some(target), DEFAULT_EPS_NR),
                Ok(first)
            );
            let tangent = nrm.cross(&Vector3::z()).normalize();
            // The largest: a patch-step of 5e-6, the surface curving away by 5e-13 m.
            for shift in [1e-10, 1e-8, -3e-8, 5e-7] {
                let y = x + shift * (tangent + 0.5 * nrm);
                let near = local.reproject(&c.sp, y, DEFAULT_EPS_NR).unwrap();
                let full =
                    closest_point(&c.sp, &c.q, y, Some(first.param), DEFAULT_EPS_NR).unwrap();
                // Round-off of coordinates at a radius of 0.3 m.
                let ulps = 4.0 * f64::EPSILON * 0.3;
                assert!(
                    (near.gap - full.gap).abs() <= ulps,
                    "{target:?} {shift}: {near:?} vs {full:?}"
                );
                assert!((near.point - full.point).norm() <= ulps);
                assert!((near.normal - full.normal).norm() <= 1e-13);
                let (a, b) = (global(&c.sp, &near.param), global(&c.sp, &full.param));
                let du = (a.0 - b.0 + 0.5 * n as f64).rem_euclid(n as f64) - 0.5 * n as f64;
                assert!(du.abs() <= 1e-12 && (a.1 - b.1).abs() <= 1e-12);
            }
            let far = x + 1e-3 * tangent;
            assert_eq!(local.reproject(&c.sp, far, DEFAULT_EPS_NR), None);
        }
    }

    /// Three nodes 0.29 m from the axis, inside [`cylinder`]: node `k` at the angle `theta(k)`
    /// (rad) and z = 0.02 + 0.03 k (m).
    fn three_nodes(theta: impl Fn(usize) -> f64) -> Vec<Vector3<f64>> {
        (0..3)
            .map(|k| {
                let th = theta(k);
                Vector3::new(0.29 * th.cos(), 0.29 * th.sin(), 0.02 + 0.03 * k as f64)
            })
            .collect()
    }

    #[test]
    fn warm_starts_follow_the_angle_swept_by_the_node() {
        // Nodes sweeping 0.02 rad per step (0.08 patch lengths) inside a cylinder whose sectors
        // run either way round. The second projection starts from the first advanced by the
        // swept angle, later ones from the extrapolated parameter (one Newton iteration); the
        // plain warm start of `project_nodes` must cover the sweep. Both find the same points.
        for mirrored in [false, true] {
            let mut c = cylinder();
            if mirrored {
                c.nodes.iter_mut().for_each(|x| x.y = -x.y);
                c.sp.orient_toward_axis(&c.nodes).unwrap();
                c.sp.control_points(&c.nodes, &mut c.q).unwrap();
            }
            let mut bounds = GapBounds::new(3);
            let (mut warm_swept, mut warm_plain) = (vec![None; 3], vec![None; 3]);
            let mut swept = vec![Projection::default(); 3];
            let mut plain = vec![Projection::default(); 3];
            // Iterations of [the second projection, later ones] × [GapBounds, plain].
            let mut iterations = [[0; 2]; 2];
            let at = |step: usize, twist: f64| {
                three_nodes(|k| 0.02 * step as f64 + 2.0 * k as f64 + twist)
            };
            for step in 0..50 {
                let xs = at(step, 0.0);
                project_nodes(
                    &c.sp,
                    &c.q,
                    &xs,
                    &mut warm_plain,
                    DEFAULT_EPS_NR,
                    &mut plain,
                )
                .unwrap();
                bounds.next_step();
                // The step's projection, then one within the step (as after the coating's
                // forces) of the points 1 µrad further round: it must not spoil the next
                // step's warm start.
                for twist in [0.0, 1e-6] {
                    bounds
                        .project_near(
                            &c.sp,
                            &c.q,
                            &at(step, twist),
                            &mut warm_swept,
                            DEFAULT_EPS_NR,
                            &mut swept,
                            0.0,
                            true,
                        )
                        .unwrap();
                    if twist != 0.0 {
                        continue;
                    }
                    for k in 0..3 {
                        assert!((swept[k].point - plain[k].point).norm() < 1e-9);
                        if step > 0 {
                            let later = usize::from(step > 1);
                            iterations[later][0] += swept[k].iterations;
                            iterations[later][1] += plain[k].iterations;
                        }
                    }
                }
            }
            let [second, later] = iterations;
            assert!(second[0] < second[1], "{second:?}");
            assert!(later[0] == 3 * 48 && later[1] > later[0], "{later:?}");
        }
    }

    #[test]
    fn warm_starts_follow_a_node_that_speeds_up() {
        // Nodes at 0.002 rad per step (0.008 patch lengths), speeding up by 2e-5 rad per step:
        // the last step's change alone misses by 8e-5 patch lengths (8 ε_NR), its change from
        // the step before as well leaves a third difference. From the fourth step on, one
        // Newton iteration each (all nodes are within the 1 m margin).
        let c = cylinder();
        let mut bounds = GapBounds::new(3);
        let mut warm = vec![None; 3];
        let mut out = vec![Projection::default(); 3];
        for step in 0..40 {
            let s = step as f64;
            let xs = three_nodes(|k| 0.002 * s + 1e-5 * s * s + 2.0 * k as f64);
            bounds.next_step();
            bounds
                .project_near(
                    &c.sp,
                    &c.q,
                    &xs,
                    &mut warm,
                    DEFAULT_EPS_NR,
                    &mut out,
                    1.0,
                    false,
                )
                .unwrap();
            if step >= 3 {
                let iterations: Vec<usize> = out.iter().map(|p| p.iterations).collect();
                assert_eq!(iterations, [1; 3], "step {step}");
            }
        }
    }

    #[test]
    fn bounds_on_a_fixed_surface_skip_the_same_nodes_with_the_same_gaps() {
        // Without its scan of the control points, the fixed-surface variant must still see the
        // nodes move: the same nodes projected, with the same gaps, as the general bounds.
        let c = cylinder();
        let mut general = GapBounds::new(3);
        let mut fixed = GapBounds::new(3).with_fixed_surface(true);
        let (mut warm_g, mut warm_f) = (vec![None; 3], vec![None; 3]);
        let (mut out_g, mut out_f) = (
            vec![Projection::default(); 3],
            vec![Projection::default(); 3],
        );
        let mut skipped = 0;
        for step in 0..200 {
            let s = step as f64;
            let xs = three_nodes(|k| 0.002 * s + 2.0 * k as f64);
            // Radial motion through the margin, so that nodes are skipped and taken up again.
            let xs: Vec<Vector3<f64>> = (xs.iter().enumerate())
                .map(|(k, x)| x * (1.0 + 0.033 * (0.05 * s + k as f64).sin().max(0.0)))
                .collect();
            let run =
                |b: &mut GapBounds, warm: &mut [Option<SurfaceParam>], out: &mut [Projection]| {
                    b.next_step();
                    b.project_near(&c.sp, &c.q, &xs, warm, DEFAULT_EPS_NR, out, 2e-3, false)
                        .unwrap()
                };
            let n_g = run(&mut general, &mut warm_g, &mut out_g);
            let n_f = run(&mut fixed, &mut warm_f, &mut out_f);
            assert_eq!(n_g, n_f, "step {step}: nodes projected");
            skipped += 3 - n_g;
            for (g, f) in out_g.iter().zip(&out_f) {
                assert_eq!(g.gap.to_bits(), f.gap.to_bits(), "step {step}");
            }
        }
        assert!(
            skipped > 0,
            "no node was ever skipped: the test saw no bound at work"
        );
    }

    #[test]
    fn gap_bounds_never_exceed_the_gap_and_skip_only_far_nodes() {
        // Nodes sweeping round inside a casing that then breathes in a two-lobe shape: each step,
        // projecting only the nodes near the surface must find every node within the margin,
        // with the gaps of a full projection, and the bound must stay below the true gap.
        let (n, m) = (24, 5);
        let mut c = cylinder();
        let mut bounds = GapBounds::new(8);
        let (mut warm_all, mut warm_near) = (vec![None; 8], vec![None; 8]);
        let (mut full, mut near) = (
            vec![Projection::default(); 8],
            vec![Projection::default(); 8],
        );
        let margin = 1e-3;
        let (mut skipped, mut in_margin) = (0, 0);
        // A second set of bounds asked for the smallest gap alone (no margin).
        let mut min_bounds = GapBounds::new(8);
        let (mut warm_min, mut min_only) = (vec![None; 8], vec![Projection::default(); 8]);
        let mut min_projected = 0;
        for step in 0..400 {
            // First the nodes alone move (also radially), then the casing too.
            let t = step as f64 * 1e-3;
            let breathe = if step < 200 { 0.0 } else { (50.0 * t).sin() };
            let mut nodes = c.nodes.clone();
            for (k, x) in nodes.iter_mut().enumerate() {
                let th = 2.0 * PI * (k / m) as f64 / n as f64;
                *x += Vector3::new(th.cos(), th.sin(), 0.0) * 4e-3 * (2.0 * th).cos() * breathe;
            }
            c.sp.control_points(&nodes, &mut c.q).unwrap();
            let xs: Vec<Vector3<f64>> = (0..8)
                .map(|k| {
                    let (th, r) = (
                        0.7 * k as f64 + 0.3 * t,
                        0.3 - 0.004 + 1e-3 * (k % 3) as f64 + 2e-3 * (20.0 * t + k as f64).sin(),
                    );
                    Vector3::new(r * th.cos(), r * th.sin(), 0.02 + 0.01 * k as f64)
                })
                .collect();
            project_nodes(&c.sp, &c.q, &xs, &mut warm_all, DEFAULT_EPS_NR, &mut full).unwrap();
            bounds.next_step();
            min_bounds.next_step();
            let done = bounds
                .project_near(
                    &c.sp,
                    &c.q,
                    &xs,
                    &mut warm_near,
                    DEFAULT_EPS_NR,
                    &mut near,
                    margin,
                    false,
                )
                .unwrap();
            // After the call the bound includes this step's surface motion.
            let bound: Vec<f64> = (0..8).map(|k| bounds.lower_bound(k, &xs[k])).collect();
            skipped += 8 - done;
            min_projected += min_bounds
                .project_near(
                    &c.sp,
                    &c.q,
                    &xs,
                    &mut warm_min,
                    DEFAULT_EPS_NR,
                    &mut min_only,
                    f64::NEG_INFINITY,
                    true,
                )
                .unwrap();
            let smallest = |p: &[Projection]| p.iter().map(|p| p.gap).fold(f64::INFINITY, f64::min);
            assert!(
                (smallest(&min_only) - smallest(&full)).abs() < 1e-9,
                "step {step}: smallest gap {} against {}",
                smallest(&min_only),
                smallest(&full)
            );
            for k in 0..8 {
                if step > 0 {
                    assert!(
                        bound[k] <= full[k].gap + 1e-12,
                        "step {step} node {k}: bound above gap"
                    );
                }
                if full[k].gap <= margin {
                    in_margin += 1;
                    assert!(
                        (near[k].gap - full[k].gap).abs() < 1e-9,
                        "step {step} node {k}"
                    );
                }
            }
        }
        // The test must exercise both branches, and the minimum alone must skip nodes.
        assert!(
            skipped > 400 && in_margin > 100 && min_projected < 4 * 400,
            "skipped {skipped}, in margin {in_margin}, projected for the minimum {min_projected}"
        );
    }

    #[test]
    fn point_on_a_data_point_projects_onto_it() {
        let c = cone();
        let m = c.sp.nodes_per_sector();
        for &k in &[0, 1, 5, m * 7 + 2, c.nodes.len() - 1] {
            let x = c.nodes[k];
            let pr = closest_point(&c.sp, &c.q, x, None, DEFAULT_EPS_NR).unwrap();
            assert!(
                (pr.point - x).norm() < 1e-10,
                "node {k}: {}",
                (pr.point - x).norm()
            );
            assert!(pr.gap.abs() < 1e-10);
        }
    }

    #[test]
    fn warm_start_crosses_patch_seams_and_the_closing_line() {
        let c = cylinder();
        let n = c.sp.n_sectors();
        let cases = [
            (p(5, 1, 0.5, 0.5), p(6, 2, 0.2, 0.3)), // diagonal neighbour
            (p(n - 1, 2, 0.9, 0.5), p(0, 2, 0.1, 0.5)), // closing line, forward
            (p(0, 1, 0.05, 0.5), p(n - 1, 1, 0.8, 0.6)), // closing line, backward
            (p(n - 1, 0, 0.5, 0.5), p(1, 1, 0.5, 0.5)), // two patches across the closing line
        ];
        for (warm, target) in cases {
            let (x, s, _) = offset_point(&c, target, 0.003);
            let pr = closest_point(&c.sp, &c.q, x, Some(warm), DEFAULT_EPS_NR).unwrap();
            assert!(
                (pr.point - s).norm() < 1e-10,
                "{warm:?} -> {target:?}: got {:?}",
                pr.param
            );
            assert!(pr.iterations <= 8, "{} iterations", pr.iterations);
        }
    }

    #[test]
    fn beyond_a_free_edge_the_closest_point_is_on_the_boundary_curve() {
        let c = cone();
        let m = c.sp.nodes_per_sector();
        // Past the trailing edge (z > 0.1) and before the leading edge (z < 0).
        for (target, beyond) in [
            (p(4, m - 2, 0.3, 1.0), Vector3::new(0.0, 0.0, 0.02)),
            (p(9, 0, 0.6, 0.0), Vector3::new(0.0, 0.0, -0.02)),
        ] {
            let (x0, _, _) = offset_point(&c, target, 0.005);
            let x = x0 + beyond;
            let pr = closest_point(&c.sp, &c.q, x, Some(p(target.i, target.j, 0.5, 0.5)), 1e-10)
                .unwrap();
            assert_eq!(pr.param.j, target.j);
            assert_eq!(pr.param.v, target.v, "must sit on the free edge");
            // KKT: stationary along the edge, the residual points out of the surface across it.
            let e = c.sp.evaluate(&c.q, &pr.param).unwrap();
            let r = x - e.s;
            assert!(r.dot(&e.su).abs() < 1e-12 * r.norm() * e.su.norm());
            let outward = if target.v == 1.0 { 1.0 } else { -1.0 };
            assert!(outward * r.dot(&e.sv) > 0.0);
            // Independent check: brute-force minimum along the boundary curve.
            let mut best = f64::INFINITY;
            for k in -2000..=2000 {
                let gu = target.i as f64 + target.u + k as f64 * 1e-3;
                let i = gu.floor() as usize;
                let s =
                    c.sp.evaluate(&c.q, &p(i, target.j, gu - i as f64, target.v))
                        .unwrap()
                        .s;
                best = best.min((x - s).norm());
            }
            assert!((x - pr.point).norm() <= best + 1e-12);
        }
    }

    #[test]
    fn normal_points_toward_axis_and_gap_sign() {
        for c in [cylinder(), cone()] {
            for &(i, j) in &[(0, 0), (3, 1), (c.sp.n_sectors() - 1, 2)] {
                let (x_in, _, _) = offset_point(&c, p(i, j, 0.4, 0.6), 0.01);
                let pr = closest_point(&c.sp, &c.q, x_in, None, DEFAULT_EPS_NR).unwrap();
                let radial = Vector3::new(pr.point.x, pr.point.y, 0.0).normalize();
                // Toward the axis: negative radial component (cone half-angle 45°: -1/√2).
                assert!(
                    pr.normal.dot(&radial) < -0.7,
                    "normal {} at {}",
                    pr.normal,
                    pr.point
                );
                assert!(pr.gap > 0.0);
                // Move the point radially outward, through the casing: penetration.
                let x_out = x_in + 0.03 * radial;
                let pr = closest_point(&c.sp, &c.q, x_out, Some(pr.param), DEFAULT_EPS_NR).unwrap();
                assert!(pr.gap < 0.0, "gap {}", pr.gap);
            }
        }
        // A meridian running toward −z flips the raw normal; orientation restores it.
        let c = case(12, 3, |_| 0.3, |s| -0.1 * s);
        assert_eq!(c.sp.normal_sign(), -1.0);
        let (x, _, _) = offset_point(&c, p(2, 1, 0.5, 0.5), 0.01);
        let pr = closest_point(&c.sp, &c.q, x, None, DEFAULT_EPS_NR).unwrap();
        assert!(Vector3::new(x.x, x.y, 0.0).norm() < 0.3 && pr.gap > 0.0);
    }

    #[test]
    fn ovalized_casing_projection_is_the_global_minimum() {
        // Two-lobe distorted cone: no symmetry to lean on; compare with a dense scan.
        let (n, m) = (20, 4);
        let mut nodes = revolution_nodes(n, m, |s| 0.2 + 0.1 * s, |s| 0.1 * s);
        for (k, x) in nodes.iter_mut().enumerate() {
            let th = 2.0 * PI * (k / m) as f64 / n as f64;
            let f = 1.0 + 0.03 * (2.0 * th).cos();
            x.x *= f;
            x.y *= f;
        }
        let mut sp = CasingSpline::new(n, m).unwrap();
        sp.orient_toward_axis(&nodes).unwrap();
        let mut q = vec![Vector3::zeros(); sp.n_control()];
        sp.control_points(&nodes, &mut q).unwrap();
        let mut grid = Vec::new();
        for i in 0..n {
            for j in 0..m - 1 {
                for a in 0..20 {
                    for b in 0..=20 {
                        let e = sp
                            .evaluate(&q, &p(i, j, a as f64 / 20.0, b as f64 / 20.0))
                            .unwrap();
                        grid.push(e.s);
                    }
                }
            }
        }
        let mut warm = None;
        for k in 0..40 {
            let th = 0.37 + 2.0 * PI * k as f64 / 40.0;
            let (r, z) = (0.2 + 0.0025 * k as f64, 0.005 + 0.0022 * k as f64);
            let x = Vector3::new(r * th.cos(), r * th.sin(), z);
            for start in [None, warm] {
                let pr = closest_point(&sp, &q, x, start, 1e-9).unwrap();
                let e = sp.evaluate(&q, &pr.param).unwrap();
                let res = x - e.s;
                // Stationarity (interior points) and global minimality against the scan.
                assert!(res.dot(&e.su).abs() < 1e-10 * e.su.norm());
                assert!(res.dot(&e.sv).abs() < 1e-10 * e.sv.norm());
                let best = grid
                    .iter()
                    .map(|g| (x - g).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    res.norm() <= best + 1e-12,
                    "node {k}: {} > scan {best}",
                    res.norm()
                );
                assert!((pr.gap.abs() - res.norm()).abs() < 1e-12);
                warm = Some(pr.param);
            }
        }
    }

    #[test]
    fn batch_projection_updates_warm_starts() {
        let c = cylinder();
        let xs: Vec<_> = (0..10)
            .map(|k| offset_point(&c, p(2 * k, k % 4, 0.3, 0.7), 0.001 * k as f64).0)
            .collect();
        let mut warm = vec![None; xs.len()];
        let mut out = vec![Projection::default(); xs.len()];
        project_nodes(&c.sp, &c.q, &xs, &mut warm, DEFAULT_EPS_NR, &mut out).unwrap();
        for (k, o) in out.iter().enumerate() {
            assert!((o.gap - 0.001 * k as f64).abs() < 1e-10);
            assert_eq!(warm[k], Some(o.param));
        }
        let mut bad = xs.clone();
        bad[3].x = f64::NAN;
        let err =
            project_nodes(&c.sp, &c.q, &bad, &mut warm, DEFAULT_EPS_NR, &mut out).unwrap_err();
        assert_eq!(err.node, 3);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let c = cylinder();
        let x = Vector3::new(0.2, 0.0, 0.05);
        assert!(matches!(
            closest_point(&c.sp, &c.q, x, None, 0.0),
            Err(ProjectionError::BadTolerance(_))
        ));
        assert!(matches!(
            closest_point(&c.sp, &c.q[1..], x, None, 1e-5),
            Err(ProjectionError::Spline(_))
        ));
        assert!(matches!(
            closest_point(&c.sp, &c.q, x, Some(p(24, 0, 0.5, 0.5)), 1e-5),
            Err(ProjectionError::BadWarmStart(_))
        ));
        assert!(matches!(
            closest_point(&c.sp, &c.q, x, Some(p(0, 0, 1.5, 0.5)), 1e-5),
            Err(ProjectionError::BadWarmStart(_))
        ));
        // A collapsed surface (all nodes at one point) is degenerate, not a panic.
        let sp = CasingSpline::new(4, 3).unwrap();
        let q = vec![Vector3::new(1.0, 0.0, 0.0); sp.n_control()];
        assert!(matches!(
            closest_point(&sp, &q, x, None, 1e-5),
            Err(ProjectionError::DegenerateSurface { .. })
        ));
    }

    #[test]
    fn friction_direction_is_minus_tangential_increment() {
        let n = Vector3::new(0.0, 0.0, 1.0);
        let t = friction_direction(&n, &Vector3::new(3.0, -4.0, 7.0)).unwrap();
        assert!((t - Vector3::new(-0.6, 0.8, 0.0)).norm() < 1e-15);
        assert_eq!(friction_direction(&n, &Vector3::new(0.0, 0.0, 2.0)), None);
        assert_eq!(friction_direction(&n, &Vector3::zeros()), None);
        assert_eq!(friction_direction(&n, &Vector3::new(1e-12, 0.0, 1.0)), None);
        assert!(friction_direction(&n, &Vector3::new(1e-6, 0.0, 1.0)).is_some());
        assert_eq!(
            friction_direction(&n, &Vector3::new(f64::NAN, 0.0, 1.0)),
            None
        );
    }
}
