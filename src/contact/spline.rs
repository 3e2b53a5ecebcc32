//! Closed bicubic B-spline through the casing contact nodes (paper §2.2, eqs. 1–13).
//!
//! # Indexing conventions (0-based; the paper is 1-based)
//! - **Casing contact nodes** (data points): node `n = i·M + j`, sector
//!   `i = 0..N−1`, row `j = 0..M−1` along the meridian from the leading edge
//!   (`j = 0`) to the trailing edge (`j = M−1`). Node `(i, j)` is the paper's
//!   `P(i+1, j+1)`; the paper's extra column `P(N+1, ·)` is the same node as
//!   `P(1, ·)` and never appears here. At rest node `(i, ·)` sits at angle
//!   `θ_i = i·α`, `α = 2π/N` (left face of sector `i`).
//! - **Control points**: `Q[c][k]`, column `c = 0..N+2` (circumferential, `u`),
//!   row `k = 0..M+1` (meridian, `v`), flat index `c·(M+2) + k` (the paper's
//!   "▼" ordering of eq. 2, row index fastest). `Q[c][k]` is the paper's
//!   `Q(c+1, k+1)`. Column `c` is centred on the data column `c − 1`, i.e. on the
//!   angle `(c − 1)·α`: column 0 on `−α`, column 1 on `0`, …, column `N+1` on
//!   `N·α ≡ 0` and column `N+2` on `(N+1)·α ≡ α`. Row `k` is centred on node row
//!   `k − 1`; rows 0 and `M+1` are the free-edge ghost rows.
//!   Because the data are periodic, the closing conditions make columns
//!   `0, N+1, N+2` exact copies of columns `N, 1, 2`.
//! - **Patches**: patch `(i, j)`, `i = 0..N−1`, `j = 0..M−2`, local
//!   `(u, v) ∈ [0, 1]²`, uses the 4×4 control points `Q[i+a][j+b]`,
//!   `a, b = 0..3` (local index `4a + b`). Its corners are the data points
//!   `S(0,0) = P(i, j)`, `S(1,0) = P(i+1 mod N, j)`, `S(0,1) = P(i, j+1)`,
//!   `S(1,1) = P(i+1 mod N, j+1)`. Global parameters `U = i + u ∈ [0, N)`
//!   (periodic, counter-clockwise for a casing whose nodes are numbered by
//!   increasing angle) and `V = j + v ∈ [0, M−1]`.
//!
//! # Boundary conditions (eqs. 10–11, derived rather than copied from eq. 12)
//! - Free edges (eq. 10, linear extrapolation of the ghost rows):
//!   `Q[c][0] = 2Q[c][1] − Q[c][2]` and `Q[c][M+1] = 2Q[c][M] − Q[c][M−1]` for
//!   every column `c` (the paper's range `i = 2..N` is a typo: the corner
//!   columns use the same rule). Geometrically `∂²S/∂v² = 0` on both free edges
//!   (natural end condition). With this rule the first and last node rows are
//!   interpolated by `Q[c][1]` and `Q[c][M]` directly, so `M = 2` works: the
//!   surface is then ruled (linear in `v`) between the two node rows.
//! - Closing line (eq. 11): `∂S/∂u` and `∂²S/∂u²` of patch `(0, j)` at `u = 0`
//!   equal those of patch `(N−1, j)` at `u = 1` for every `v`. Since the
//!   `v`-basis functions are independent this holds row by row; sum and
//!   difference of the two conditions give
//!   `Q[0][k] = Q[1][k] + Q[N][k] − Q[N+1][k]` and
//!   `Q[N+2][k] = Q[2][k] − Q[1][k] + Q[N+1][k]`, `k = 0..M+1`
//!   (the corner rows `k = 0, M+1` are first expressed through eq. 10).
//!
//! Everything is a tensor product: `A = A_u ⊗ A_v`, `C = C_u ⊗ C_v`, hence
//! `B = B_u ⊗ B_v`. The periodic data make `B_u` a periodic interpolation
//! (cyclic tridiagonal `(1, 4, 1)/6`) and `B_v` a natural-end interpolation
//! (tridiagonal), which [`CasingSpline::control_points`] solves in `O(N·M)`.

use faer::Mat;
use faer::prelude::*;
use nalgebra::{Vector3, Vector4};
use thiserror::Error;

/// Errors raised when building or using a [`CasingSpline`].
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SplineError {
    /// The number of sectors `N` is too small for a closed spline.
    #[error("n_sectors = {0}: a closed casing spline needs at least 3 sectors")]
    TooFewSectors(usize),
    /// The number of contact nodes per sector `M` is too small for a surface.
    #[error(
        "nodes_per_sector = {0}: the spline needs at least 2 nodes per sector along the meridian"
    )]
    TooFewRows(usize),
    /// A slice has the wrong length.
    #[error("{what}: expected length {expected}, got {got}")]
    LengthMismatch {
        /// Which slice.
        what: &'static str,
        /// Length required.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// A patch index lies outside `0..N` × `0..M−1`.
    #[error("patch ({i}, {j}) outside 0..{n} x 0..{m1}")]
    PatchOutOfRange {
        /// Circumferential patch index given.
        i: usize,
        /// Meridional patch index given.
        j: usize,
        /// Number of circumferential patches N.
        n: usize,
        /// Number of meridional patches M − 1.
        m1: usize,
    },
    /// The surface normal cannot be oriented toward the axis from these nodes.
    #[error("cannot orient the normal toward the axis: {0}")]
    Orientation(&'static str),
}

/// A point of the spline in patch coordinates: patch `(i, j)` and local `(u, v) ∈ [0, 1]²`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceParam {
    /// Circumferential patch index, `0..N`.
    pub i: usize,
    /// Meridional patch index, `0..M−1`.
    pub j: usize,
    /// Local circumferential coordinate in `[0, 1]`.
    pub u: f64,
    /// Local meridional coordinate in `[0, 1]`.
    pub v: f64,
}

/// Position and derivatives of a patch at one `(u, v)` (eq. 6), in m (derivatives per unit `u`, `v`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PatchEval {
    /// Surface point `S(u, v)` (m).
    pub s: Vector3<f64>,
    /// First derivative `∂S/∂u` (m).
    pub su: Vector3<f64>,
    /// First derivative `∂S/∂v` (m).
    pub sv: Vector3<f64>,
    /// Second derivative `∂²S/∂u²` (m).
    pub suu: Vector3<f64>,
    /// Mixed derivative `∂²S/∂u∂v` (m).
    pub suv: Vector3<f64>,
    /// Second derivative `∂²S/∂v²` (m).
    pub svv: Vector3<f64>,
}

/// Uniform cubic B-spline basis at `t ∈ [0, 1]`: values, first and second derivatives.
///
/// These are the columns of the 4×4 matrix of eq. (6) applied to `[t³, t², t, 1]`, divided by 6.
#[inline]
pub fn cubic_basis(t: f64) -> (Vector4<f64>, Vector4<f64>, Vector4<f64>) {
    let s = 1.0 - t;
    let t2 = t * t;
    let t3 = t2 * t;
    let b = Vector4::new(
        s * s * s / 6.0,
        (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
        (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
        t3 / 6.0,
    );
    let d = Vector4::new(
        -0.5 * s * s,
        0.5 * (3.0 * t2 - 4.0 * t),
        0.5 * (-3.0 * t2 + 2.0 * t + 1.0),
        0.5 * t2,
    );
    let dd = Vector4::new(s, 3.0 * t - 2.0, 1.0 - 3.0 * t, t);
    (b, d, dd)
}

/// What a surface point's basis weights give: the point `S` itself or its tangent along the
/// circumference (`S_u`) or the meridian (`S_v`), per unit of patch coordinate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Along {
    /// `S(u, v)`.
    Point,
    /// `∂S/∂u`.
    U,
    /// `∂S/∂v`.
    V,
}

impl Along {
    /// The four circumferential and four meridional basis weights of patch coordinates
    /// `(p.u, p.v)` for this quantity: values, or the derivative along the one direction.
    pub fn bases(self, p: &SurfaceParam) -> (Vector4<f64>, Vector4<f64>) {
        let (bu, du, _) = cubic_basis(p.u);
        let (bv, dv, _) = cubic_basis(p.v);
        match self {
            Along::Point => (bu, bv),
            Along::U => (du, bv),
            Along::V => (bu, dv),
        }
    }
}

/// Weights on the *real* control rows `1..=M` of a patch's four meridional basis values
/// `cv` (control rows `j..j+4`, paper eq. 13): the ghost rows are folded back by eq. (10),
/// `Q[c][0] = 2Q[c][1] − Q[c][2]`, `Q[c][M+1] = 2Q[c][M] − Q[c][M−1]`. Returns the first
/// real row (0-based: real row `r` is control row `r + 1`) of a window of `min(4, M)` rows and
/// the weights in it. `Σ w_r Q[c][r+1] = Σ_b cv_b Q[c][j+b]` for any control net.
pub fn real_row_weights(j: usize, cv: &Vector4<f64>, m: usize) -> (usize, [f64; 4]) {
    let len = m.min(4);
    let start = (j.max(1) - 1).min(m - len);
    let mut w = [0.0; 4];
    let mut put = |row: usize, x: f64| w[row - start] += x;
    for (b, &c) in cv.iter().enumerate() {
        match j + b {
            0 => {
                put(0, 2.0 * c);
                put(1, -c);
            }
            k if k == m + 1 => {
                put(m - 1, 2.0 * c);
                put(m - 2, -c);
            }
            k => put(k - 1, c),
        }
    }
    (start, w)
}

/// The closed casing spline operator for `N` sectors and `M` contact nodes per sector.
///
/// Holds only what depends on `(N, M)` (eq. 5 is independent of the node
/// positions): the factorizations of the periodic `u` and natural `v`
/// interpolations, and the dense 1-D maps `B_u E` and `B_v` used for the
/// per-node weights of a surface point. Control points live in caller-owned
/// buffers (see [`CasingSpline::control_points`]).
#[derive(Clone, Debug)]
pub struct CasingSpline {
    n: usize,
    m: usize,
    /// Thomas multipliers of the Sherman–Morrison-modified periodic matrix (size N).
    u_thomas: Vec<f64>,
    /// `T⁻¹ w` for the Sherman–Morrison rank-one correction (size N).
    u_z: Vec<f64>,
    /// `1 / (1 + vᵀ z)`.
    u_sm_factor: f64,
    /// Thomas multipliers of the `(1, 4, 1)` system of the interior meridian rows (size M−2).
    v_thomas: Vec<f64>,
    /// Effective `u` map: control column `c` = Σ_s `bu[c·N + s]` × data column `s` ((N+3) × N, row-major).
    bu: Vec<f64>,
    /// `v` map: control row `k` = Σ_r `bv[k·M + r]` × node row `r` ((M+2) × M, row-major).
    bv: Vec<f64>,
    /// +1: normal `−S_u × S_v` (eq. 14); −1: `+S_u × S_v` (see [`CasingSpline::normal_sign`]).
    normal_sign: f64,
}

/// Thomas multipliers for a tridiagonal matrix with unit off-diagonals and diagonal `diag`.
fn thomas_multipliers(diag: &[f64]) -> Vec<f64> {
    let mut mult = Vec::with_capacity(diag.len());
    let mut prev = 0.0;
    for &d in diag {
        let m = 1.0 / (d - prev);
        mult.push(m);
        prev = m;
    }
    mult
}

impl CasingSpline {
    /// Builds the spline operator for `n_sectors = N ≥ 3` and `nodes_per_sector = M ≥ 2`.
    pub fn new(n_sectors: usize, nodes_per_sector: usize) -> Result<Self, SplineError> {
        let (n, m) = (n_sectors, nodes_per_sector);
        if n < 3 {
            return Err(SplineError::TooFewSectors(n));
        }
        if m < 2 {
            return Err(SplineError::TooFewRows(m));
        }
        // Periodic (1,4,1) matrix A_p = T + w yᵀ with w = (γ,0..,0,1), y = (1,0..,0,1/γ), γ = −4:
        // T is tridiagonal with diagonal (8, 4, …, 4, 4.25), strictly diagonally dominant.
        let gamma = -4.0;
        let mut diag = vec![4.0; n];
        diag[0] = 4.0 - gamma;
        diag[n - 1] = 4.0 - 1.0 / gamma;
        let u_thomas = thomas_multipliers(&diag);
        let mut u_z = vec![0.0; n];
        u_z[0] = gamma;
        u_z[n - 1] = 1.0;
        thomas_solve_scalar(&u_thomas, &mut u_z);
        let u_sm_factor = 1.0 / (1.0 + u_z[0] + u_z[n - 1] / gamma);
        let v_thomas = thomas_multipliers(&vec![4.0; m.saturating_sub(2)]);
        let mut spline = CasingSpline {
            n,
            m,
            u_thomas,
            u_z,
            u_sm_factor,
            v_thomas,
            bu: Vec::new(),
            bv: Vec::new(),
            normal_sign: 1.0,
        };
        spline.bu = spline.unit_response_u();
        spline.bv = spline.unit_response_v();
        Ok(spline)
    }

    /// Number of sectors `N`.
    pub fn n_sectors(&self) -> usize {
        self.n
    }

    /// Number of contact nodes per sector `M`.
    pub fn nodes_per_sector(&self) -> usize {
        self.m
    }

    /// Number of casing contact nodes `N·M` (length of the node slice).
    pub fn n_nodes(&self) -> usize {
        self.n * self.m
    }

    /// Number of control points `(N+3)(M+2)` (length of the control-point slice).
    pub fn n_control(&self) -> usize {
        (self.n + 3) * (self.m + 2)
    }

    /// Flat index `c·(M+2) + k` of control point `Q[c][k]`.
    #[inline]
    pub fn control_index(&self, c: usize, k: usize) -> usize {
        c * (self.m + 2) + k
    }

    /// Sign applied to the paper's normal `−S_u × S_v` (eq. 14): +1 by default.
    ///
    /// With `u` counter-clockwise about +z, `−S_u × S_v` points toward the axis
    /// when the meridian (leading → trailing edge) runs toward +z where the
    /// casing is axial; a model whose meridian runs toward −z needs −1. Set it
    /// once from the rest geometry with [`CasingSpline::orient_toward_axis`].
    pub fn normal_sign(&self) -> f64 {
        self.normal_sign
    }

    /// Chooses [`CasingSpline::normal_sign`] so that the normal points from the
    /// casing toward the rotation axis (z), judged on the rest geometry `nodes`
    /// (length `N·M`): the sign of Σ over patch centres of `n · (−e_r)`.
    /// Fails when that sum is negligible (e.g. a purely radial, disk-like surface).
    pub fn orient_toward_axis(&mut self, nodes: &[Vector3<f64>]) -> Result<f64, SplineError> {
        let mut q = vec![Vector3::zeros(); self.n_control()];
        self.control_points(nodes, &mut q)?;
        self.normal_sign = 1.0;
        let (mut sum, mut total) = (0.0, 0.0);
        for i in 0..self.n {
            for j in 0..self.m - 1 {
                let e = self.eval_unchecked(&q, i, j, 0.5, 0.5);
                let nrm = -e.su.cross(&e.sv);
                let area = nrm.norm();
                let radial = Vector3::new(e.s.x, e.s.y, 0.0);
                let r = radial.norm();
                if area == 0.0 || r == 0.0 {
                    continue;
                }
                sum += nrm.dot(&(-radial / r));
                total += area;
            }
        }
        if total.is_nan() || total <= 0.0 || sum.abs() < 1e-3 * total {
            return Err(SplineError::Orientation(
                "the surface has no clear radial direction (degenerate or disk-like)",
            ));
        }
        self.normal_sign = sum.signum();
        Ok(self.normal_sign)
    }

    /// Sets [`CasingSpline::normal_sign`] explicitly (+1 or −1; any other value is mapped to its sign).
    pub fn set_normal_sign(&mut self, sign: f64) {
        self.normal_sign = if sign < 0.0 { -1.0 } else { 1.0 };
    }

    /// Control points `Q = B P` (eq. 5) of the spline through the casing contact
    /// nodes `nodes` (length `N·M`, index `i·M + j`, m) into `out` (length
    /// `(N+3)(M+2)`, index `c·(M+2) + k`). No allocation, `O(N·M)`: a natural
    /// tridiagonal solve per sector along `v`, then a periodic (Sherman–Morrison)
    /// tridiagonal solve per control row along `u`. Equal to [`CasingSpline::b_matrix`] × nodes.
    pub fn control_points(
        &self,
        nodes: &[Vector3<f64>],
        out: &mut [Vector3<f64>],
    ) -> Result<(), SplineError> {
        let (n, m) = (self.n, self.m);
        check_len("casing contact nodes", n * m, nodes.len())?;
        check_len("control points", self.n_control(), out.len())?;
        let w = m + 2;
        // v direction, sector by sector, into control column c = i + 1.
        for i in 0..n {
            let p = &nodes[i * m..(i + 1) * m];
            let col = &mut out[(i + 1) * w..(i + 2) * w];
            col[1] = p[0];
            col[m] = p[m - 1];
            if m > 2 {
                // Unknowns col[2..m], equations x_{k−1} + 4 x_k + x_{k+1} = 6 P[k−1].
                for k in 2..m {
                    col[k] = p[k - 1] * 6.0;
                }
                col[2] -= p[0];
                col[m - 1] -= p[m - 1];
                thomas_solve_strided(&self.v_thomas, col, 2, 1);
            }
            col[0] = col[1] * 2.0 - col[2];
            col[m + 1] = col[m] * 2.0 - col[m - 1];
        }
        // u direction, row by row: periodic R[s] stored in column s + 1.
        for k in 0..w {
            for s in 0..n {
                out[(s + 1) * w + k] *= 6.0;
            }
            thomas_solve_strided(&self.u_thomas, out, w + k, w);
            let corr = (out[w + k] + out[n * w + k] / -4.0) * self.u_sm_factor;
            for s in 0..n {
                out[(s + 1) * w + k] -= corr * self.u_z[s];
            }
            out[k] = out[n * w + k];
            out[(n + 1) * w + k] = out[w + k];
            out[(n + 2) * w + k] = out[2 * w + k];
        }
        Ok(())
    }

    /// Column `s` of the effective periodic `u` map (response to a unit data column).
    fn unit_response_u(&self) -> Vec<f64> {
        let n = self.n;
        let mut bu = vec![0.0; (n + 3) * n];
        let mut x = vec![0.0; n];
        for s in 0..n {
            x.iter_mut().for_each(|e| *e = 0.0);
            x[s] = 6.0;
            thomas_solve_scalar(&self.u_thomas, &mut x);
            let corr = (x[0] + x[n - 1] / -4.0) * self.u_sm_factor;
            for r in 0..n {
                bu[(r + 1) * n + s] = x[r] - corr * self.u_z[r];
            }
            bu[s] = bu[n * n + s];
            bu[(n + 1) * n + s] = bu[n + s];
            bu[(n + 2) * n + s] = bu[2 * n + s];
        }
        bu
    }

    /// Column `r` of the natural `v` map (response to a unit node row).
    fn unit_response_v(&self) -> Vec<f64> {
        let m = self.m;
        let mut bv = vec![0.0; (m + 2) * m];
        let mut col = vec![0.0; m + 2];
        for r in 0..m {
            col.iter_mut().for_each(|e| *e = 0.0);
            let p = |k: usize| if k == r { 1.0 } else { 0.0 };
            col[1] = p(0);
            col[m] = p(m - 1);
            if m > 2 {
                for (k, ck) in col.iter_mut().enumerate().take(m).skip(2) {
                    *ck = 6.0 * p(k - 1);
                }
                col[2] -= p(0);
                col[m - 1] -= p(m - 1);
                thomas_solve_scalar_strided(&self.v_thomas, &mut col, 2);
            }
            col[0] = 2.0 * col[1] - col[2];
            col[m + 1] = 2.0 * col[m] - col[m - 1];
            for k in 0..m + 2 {
                bv[k * m + r] = col[k];
            }
        }
        bv
    }

    /// The 16 flat control-point indices of patch `(i, j)`, local order `4a + b`
    /// (`a` along `u`, `b` along `v`), matching [`CasingSpline::basis_weights`].
    pub fn patch_control_indices(&self, i: usize, j: usize) -> Result<[usize; 16], SplineError> {
        self.check_patch(i, j)?;
        let mut idx = [0usize; 16];
        for a in 0..4 {
            for b in 0..4 {
                idx[4 * a + b] = self.control_index(i + a, j + b);
            }
        }
        Ok(idx)
    }

    /// Basis weights `c^{ij}(u, v)` of eq. (16)–(18): `S^{ij}(u, v) = Σ_l c_l Q[idx_l]`
    /// with `idx` from [`CasingSpline::patch_control_indices`], local order `4a + b`.
    pub fn basis_weights(u: f64, v: f64) -> [f64; 16] {
        let (bu, _, _) = cubic_basis(u);
        let (bv, _, _) = cubic_basis(v);
        let mut c = [0.0; 16];
        for a in 0..4 {
            for b in 0..4 {
                c[4 * a + b] = bu[a] * bv[b];
            }
        }
        c
    }

    /// Weights of the casing contact nodes in a surface point: `S(p) = Σ_n w_n P_n`
    /// (the product `B̂ c` of eq. 18, written per node: the same weight applies to
    /// x, y and z). `w_n = wu[i_n] · wv[j_n]` for node `n = i_n·M + j_n`; fills
    /// `wu` (length N) and `wv` (length M) in `O(N + M)`.
    pub fn node_weight_factors(
        &self,
        p: &SurfaceParam,
        wu: &mut [f64],
        wv: &mut [f64],
    ) -> Result<(), SplineError> {
        self.node_weight_factors_of(Along::Point, p, wu, wv)
    }

    /// [`CasingSpline::node_weight_factors`] of the point (`Along::Point`) or of its
    /// tangent `S_u` or `S_v` (per unit of patch coordinate): `∂S/∂u (p) = Σ_n w_n P_n`
    /// with the weights of the basis' derivative along u, and likewise along v.
    pub fn node_weight_factors_of(
        &self,
        along: Along,
        p: &SurfaceParam,
        wu: &mut [f64],
        wv: &mut [f64],
    ) -> Result<(), SplineError> {
        self.check_patch(p.i, p.j)?;
        check_len("wu", self.n, wu.len())?;
        check_len("wv", self.m, wv.len())?;
        let (bu, bv) = along.bases(p);
        let (n, m) = (self.n, self.m);
        wu.iter_mut().for_each(|e| *e = 0.0);
        wv.iter_mut().for_each(|e| *e = 0.0);
        for a in 0..4 {
            let row = &self.bu[(p.i + a) * n..(p.i + a + 1) * n];
            for (w, r) in wu.iter_mut().zip(row) {
                *w += bu[a] * r;
            }
            let row = &self.bv[(p.j + a) * m..(p.j + a + 1) * m];
            for (w, r) in wv.iter_mut().zip(row) {
                *w += bv[a] * r;
            }
        }
        Ok(())
    }

    /// Whether `p` lies on a free edge of the surface, `V = j + v` at 0 (leading edge) or at
    /// `M − 1` (trailing edge), where [`crate::contact::closest_point`] clamps the closest
    /// point.
    pub fn on_free_edge(&self, p: &SurfaceParam) -> bool {
        (p.j == 0 && p.v <= 0.0) || (p.j + 2 == self.m && p.v >= 1.0)
    }

    /// Dense per-node weights `w` (length `N·M`, node index `i·M + j`) with
    /// `S(p) = Σ_n w_n P_n`; see [`CasingSpline::node_weight_factors`], which is
    /// the allocation-free form for hot loops (this one allocates two small buffers).
    #[cfg(test)]
    pub(crate) fn node_weights(
        &self,
        p: &SurfaceParam,
        out: &mut [f64],
    ) -> Result<(), SplineError> {
        check_len("node weights", self.n_nodes(), out.len())?;
        let mut wu = vec![0.0; self.n];
        let mut wv = vec![0.0; self.m];
        self.node_weight_factors(p, &mut wu, &mut wv)?;
        for (i, a) in wu.iter().enumerate() {
            for (j, b) in wv.iter().enumerate() {
                out[i * self.m + j] = a * b;
            }
        }
        Ok(())
    }

    /// Position and first/second derivatives of patch `(p.i, p.j)` at `(p.u, p.v)` (eq. 6),
    /// from the control points `q` (length `(N+3)(M+2)`).
    pub fn evaluate(&self, q: &[Vector3<f64>], p: &SurfaceParam) -> Result<PatchEval, SplineError> {
        self.check_patch(p.i, p.j)?;
        check_len("control points", self.n_control(), q.len())?;
        Ok(self.eval_unchecked(q, p.i, p.j, p.u, p.v))
    }

    /// The surface point `S(p)` alone (m), bit for bit the `s` of [`CasingSpline::evaluate`]
    /// (the same sums in the same order) without its derivatives: a third of the work.
    pub fn point(&self, q: &[Vector3<f64>], p: &SurfaceParam) -> Result<Vector3<f64>, SplineError> {
        self.check_patch(p.i, p.j)?;
        check_len("control points", self.n_control(), q.len())?;
        let w = self.m + 2;
        let (bu, _, _) = cubic_basis(p.u);
        let (bv, _, _) = cubic_basis(p.v);
        let mut g = [[0.0f64; 3]; 4];
        for (a, ga) in g.iter_mut().enumerate() {
            let base = (p.i + a) * w + p.j;
            let row = &q[base..base + 4];
            for (c, gac) in ga.iter_mut().enumerate() {
                let (q0, q1, q2, q3) = (row[0][c], row[1][c], row[2][c], row[3][c]);
                *gac = bv[0] * q0 + bv[1] * q1 + bv[2] * q2 + bv[3] * q3;
            }
        }
        Ok(Vector3::from_fn(|c, _| {
            bu[0] * g[0][c] + bu[1] * g[1][c] + bu[2] * g[2][c] + bu[3] * g[3][c]
        }))
    }

    /// Patch evaluation without bounds checks on `(i, j)` beyond slice indexing;
    /// callers guarantee `i < N`, `j < M−1` and `q.len() == n_control()`.
    #[inline(always)]
    pub(crate) fn eval_unchecked(
        &self,
        q: &[Vector3<f64>],
        i: usize,
        j: usize,
        u: f64,
        v: f64,
    ) -> PatchEval {
        let w = self.m + 2;
        let (bu, du, ddu) = cubic_basis(u);
        let (bv, dv, ddv) = cubic_basis(v);
        // Contract along v first (per control column a), then along u: 3 × 16
        // multiply-adds per coordinate for S, S_v, S_vv of each column.
        let (mut g, mut gv, mut gvv) = ([[0.0f64; 3]; 4], [[0.0f64; 3]; 4], [[0.0f64; 3]; 4]);
        for a in 0..4 {
            let base = (i + a) * w + j;
            let row: &[Vector3<f64>; 4] = q[base..base + 4]
                .try_into()
                .expect("a slice of length 4 converts to an array of 4");
            for c in 0..3 {
                let (q0, q1, q2, q3) = (row[0][c], row[1][c], row[2][c], row[3][c]);
                g[a][c] = bv[0] * q0 + bv[1] * q1 + bv[2] * q2 + bv[3] * q3;
                gv[a][c] = dv[0] * q0 + dv[1] * q1 + dv[2] * q2 + dv[3] * q3;
                gvv[a][c] = ddv[0] * q0 + ddv[1] * q1 + ddv[2] * q2 + ddv[3] * q3;
            }
        }
        let contract = |wu: &Vector4<f64>, h: &[[f64; 3]; 4]| {
            Vector3::new(
                wu[0] * h[0][0] + wu[1] * h[1][0] + wu[2] * h[2][0] + wu[3] * h[3][0],
                wu[0] * h[0][1] + wu[1] * h[1][1] + wu[2] * h[2][1] + wu[3] * h[3][1],
                wu[0] * h[0][2] + wu[1] * h[1][2] + wu[2] * h[2][2] + wu[3] * h[3][2],
            )
        };
        PatchEval {
            s: contract(&bu, &g),
            su: contract(&du, &g),
            sv: contract(&bu, &gv),
            suu: contract(&ddu, &g),
            suv: contract(&du, &gv),
            svv: contract(&bu, &gvv),
        }
    }

    fn check_patch(&self, i: usize, j: usize) -> Result<(), SplineError> {
        if i >= self.n || j + 1 >= self.m {
            return Err(SplineError::PatchOutOfRange {
                i,
                j,
                n: self.n,
                m1: self.m - 1,
            });
        }
        Ok(())
    }

    /// Interpolation matrix `A` of eqs. (8)–(9): `(N+1)M × (N+3)(M+2)`, dense,
    /// `P(i, j) = Σ_{a,b=0..2} w_a w_b Q[i+a][j+b] / 36` with `w = (1, 4, 1)`;
    /// rows `i·M + j`, `i = 0..N` (row block `N` is the repeated first column).
    pub(crate) fn a_matrix(&self) -> Mat<f64> {
        let (n, m) = (self.n, self.m);
        let w = [1.0, 4.0, 1.0];
        Mat::from_fn((n + 1) * m, (n + 3) * (m + 2), |r, col| {
            let (i, j) = (r / m, r % m);
            let (c, k) = (col / (m + 2), col % (m + 2));
            if c >= i && c <= i + 2 && k >= j && k <= j + 2 {
                w[c - i] * w[k - j] / 36.0
            } else {
                0.0
            }
        })
    }

    /// Boundary-condition matrix `C` of eq. (4) derived from eqs. (10)–(11) (see
    /// the module doc): `(N+3)(M+2) × (N+1)M`, mapping the interior control
    /// points `Q[1..=N+1][1..=M]` (index `(c−1)·M + (k−1)`) to all control points.
    pub(crate) fn c_matrix(&self) -> Mat<f64> {
        let (n, m) = (self.n, self.m);
        let cu = Mat::from_fn(n + 3, n + 1, |c, a| match c {
            0 => f64::from(a == 0) + f64::from(a == n - 1) - f64::from(a == n),
            c if c == n + 2 => f64::from(a == 1) - f64::from(a == 0) + f64::from(a == n),
            c => f64::from(a == c - 1),
        });
        let cv = Mat::from_fn(m + 2, m, |k, b| match k {
            0 => 2.0 * f64::from(b == 0) - f64::from(b == 1),
            k if k == m + 1 => 2.0 * f64::from(b == m - 1) - f64::from(b == m - 2),
            k => f64::from(b == k - 1),
        });
        Mat::from_fn((n + 3) * (m + 2), (n + 1) * m, |r, col| {
            cu[(r / (m + 2), col / m)] * cv[(r % (m + 2), col % m)]
        })
    }

    /// Dense `B = C (A C)^{-1}` of eq. (5) times the map `E` from the `N·M` casing
    /// contact nodes to the `(N+1)M` data points (`P(N, ·) = P(0, ·)`):
    /// `(N+3)(M+2) × N·M`. For tests and small models; use
    /// [`CasingSpline::control_points`] in time stepping.
    pub fn b_matrix(&self) -> Mat<f64> {
        let (n, m) = (self.n, self.m);
        let c = self.c_matrix();
        let ac = self.a_matrix() * &c;
        let e = Mat::from_fn((n + 1) * m, n * m, |r, col| {
            f64::from((r / m) % n == col / m && r % m == col % m)
        });
        let x = ac.partial_piv_lu().solve(&e);
        c * x
    }
}

fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), SplineError> {
    if expected != got {
        return Err(SplineError::LengthMismatch {
            what,
            expected,
            got,
        });
    }
    Ok(())
}

/// In-place Thomas solve (unit off-diagonals, multipliers `mult`) on
/// `x[start + s·stride]`, `s = 0..mult.len()`.
fn thomas_solve_strided(mult: &[f64], x: &mut [Vector3<f64>], start: usize, stride: usize) {
    let len = mult.len();
    if len == 0 {
        return;
    }
    x[start] *= mult[0];
    for s in 1..len {
        let prev = x[start + (s - 1) * stride];
        x[start + s * stride] = (x[start + s * stride] - prev) * mult[s];
    }
    for s in (0..len - 1).rev() {
        let next = x[start + (s + 1) * stride];
        x[start + s * stride] -= next * mult[s];
    }
}

fn thomas_solve_scalar_strided(mult: &[f64], x: &mut [f64], start: usize) {
    thomas_solve_scalar(mult, &mut x[start..start + mult.len()]);
}

fn thomas_solve_scalar(mult: &[f64], x: &mut [f64]) {
    let len = mult.len();
    if len == 0 {
        return;
    }
    x[0] *= mult[0];
    for s in 1..len {
        x[s] = (x[s] - x[s - 1]) * mult[s];
    }
    for s in (0..len - 1).rev() {
        x[s] -= x[s + 1] * mult[s];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::Lcg;
    use nalgebra::Rotation3;
    use std::f64::consts::PI;

    /// Folded weights reproduce the meridional combination of every patch row window,
    /// ghost rows included, on control nets built by `control_points` (which applies eq. 10).
    #[test]
    fn real_row_weights_fold_the_ghost_rows() {
        for m in 2..=6 {
            let n = 5;
            let sp = CasingSpline::new(n, m).unwrap();
            let nodes: Vec<Vector3<f64>> = (0..n * m)
                .map(|k| Vector3::new((k as f64).sin(), (k as f64 * 0.7).cos(), k as f64 * 0.1))
                .collect();
            let mut q = vec![Vector3::zeros(); sp.n_control()];
            sp.control_points(&nodes, &mut q).unwrap();
            for j in 0..m - 1 {
                for v in [0.0, 0.3, 1.0] {
                    let (cv, _, _) = cubic_basis(v);
                    let (start, w) = real_row_weights(j, &cv, m);
                    for c in 0..n + 3 {
                        let direct: Vector3<f64> =
                            (0..4).map(|b| q[sp.control_index(c, j + b)] * cv[b]).sum();
                        let folded: Vector3<f64> = (0..m.min(4))
                            .map(|r| q[sp.control_index(c, start + r + 1)] * w[r])
                            .sum();
                        assert!(
                            (direct - folded).norm() < 1e-12,
                            "M = {m}, j = {j}, v = {v}"
                        );
                    }
                }
            }
        }
    }

    /// `point` is the `s` of `evaluate`, bit for bit, on every patch of a perturbed net.
    #[test]
    fn point_is_the_evaluated_surface_point_bit_for_bit() {
        let (n, m) = (7, 5);
        let nodes = revolution_nodes(n, m, |s| 0.3 - 0.05 * s, |s| 0.1 * s, 1e-3, 11);
        let (sp, q) = spline_and_q(n, m, &nodes);
        let mut rng = Lcg(5);
        for i in 0..n {
            for j in 0..m - 1 {
                let p = param(i, j, 0.5 + 0.5 * rng.next(), 0.5 + 0.5 * rng.next());
                let s = sp.evaluate(&q, &p).unwrap().s;
                assert_eq!(sp.point(&q, &p).unwrap(), s, "patch ({i}, {j})");
            }
        }
        assert!(sp.point(&q, &param(n, 0, 0.5, 0.5)).is_err());
    }

    /// Nodes on a surface of revolution `r(z)` plus an optional random perturbation.
    fn revolution_nodes(
        n: usize,
        m: usize,
        r_of: impl Fn(f64) -> f64,
        z_of: impl Fn(f64) -> f64,
        noise: f64,
        seed: u64,
    ) -> Vec<Vector3<f64>> {
        let mut rng = Lcg(seed);
        let mut nodes = Vec::with_capacity(n * m);
        for i in 0..n {
            let th = 2.0 * PI * i as f64 / n as f64;
            for j in 0..m {
                let s = j as f64 / (m - 1) as f64;
                let (r, z) = (r_of(s), z_of(s));
                nodes.push(
                    Vector3::new(r * th.cos(), r * th.sin(), z)
                        + noise * Vector3::new(rng.next(), rng.next(), rng.next()),
                );
            }
        }
        nodes
    }

    fn spline_and_q(
        n: usize,
        m: usize,
        nodes: &[Vector3<f64>],
    ) -> (CasingSpline, Vec<Vector3<f64>>) {
        let sp = CasingSpline::new(n, m).unwrap();
        let mut q = vec![Vector3::zeros(); sp.n_control()];
        sp.control_points(nodes, &mut q).unwrap();
        (sp, q)
    }

    fn param(i: usize, j: usize, u: f64, v: f64) -> SurfaceParam {
        SurfaceParam { i, j, u, v }
    }

    #[test]
    fn fast_control_points_equal_dense_b() {
        for &(n, m) in &[(3, 2), (5, 2), (7, 4), (12, 5), (4, 3)] {
            let nodes = revolution_nodes(n, m, |s| 0.3 + 0.05 * s, |s| 0.1 * s, 0.01, 7 + n as u64);
            let (sp, q) = spline_and_q(n, m, &nodes);
            let b = sp.b_matrix();
            assert_eq!((b.nrows(), b.ncols()), (sp.n_control(), n * m));
            for r in 0..sp.n_control() {
                let mut dense = Vector3::zeros();
                for (col, p) in nodes.iter().enumerate() {
                    dense += b[(r, col)] * p;
                }
                assert!(
                    (dense - q[r]).norm() < 1e-12,
                    "N={n} M={m} row {r}: {dense} vs {}",
                    q[r]
                );
            }
        }
    }

    #[test]
    fn dense_a_and_c_reproduce_data_and_conditions() {
        let (n, m) = (6, 4);
        let nodes = revolution_nodes(n, m, |s| 0.2 + 0.1 * s * s, |s| 0.05 * s, 0.02, 3);
        let (sp, q) = spline_and_q(n, m, &nodes);
        let a = sp.a_matrix();
        assert_eq!((a.nrows(), a.ncols()), ((n + 1) * m, (n + 3) * (m + 2)));
        for r in 0..(n + 1) * m {
            let mut p = Vector3::zeros();
            for (col, qc) in q.iter().enumerate() {
                p += a[(r, col)] * qc;
            }
            let node = nodes[((r / m) % n) * m + r % m];
            assert!((p - node).norm() < 1e-13, "A Q != P at row {r}");
        }
        // Q = C Q_int with Q_int = Q[1..=N+1][1..=M].
        let c = sp.c_matrix();
        for r in 0..sp.n_control() {
            let mut x = Vector3::zeros();
            for col in 0..(n + 1) * m {
                let qi = q[sp.control_index(col / m + 1, col % m + 1)];
                x += c[(r, col)] * qi;
            }
            assert!((x - q[r]).norm() < 1e-13, "C Q_int != Q at row {r}");
        }
    }

    #[test]
    fn interpolates_every_node_and_free_edges_hold() {
        for &(n, m) in &[(8, 5), (5, 2), (3, 3)] {
            let nodes = revolution_nodes(n, m, |s| 0.3 - 0.1 * s, |s| 0.08 * s, 0.01, 11);
            let (sp, q) = spline_and_q(n, m, &nodes);
            for i in 0..n {
                for j in 0..m - 1 {
                    let ip = (i + 1) % n;
                    let corners = [
                        (0.0, 0.0, nodes[i * m + j]),
                        (1.0, 0.0, nodes[ip * m + j]),
                        (0.0, 1.0, nodes[i * m + j + 1]),
                        (1.0, 1.0, nodes[ip * m + j + 1]),
                    ];
                    for (u, v, p) in corners {
                        let s = sp.evaluate(&q, &param(i, j, u, v)).unwrap().s;
                        assert!(
                            (s - p).norm() < 1e-14,
                            "N={n} M={m} patch ({i},{j}) corner ({u},{v})"
                        );
                    }
                }
                // Free edges (eq. 10): ghost rows are linear extrapolations, and S_vv = 0 on the edges.
                for c in 0..n + 3 {
                    let g0 = q[sp.control_index(c, 0)];
                    let e0 = 2.0 * q[sp.control_index(c, 1)] - q[sp.control_index(c, 2)];
                    let g1 = q[sp.control_index(c, m + 1)];
                    let e1 = 2.0 * q[sp.control_index(c, m)] - q[sp.control_index(c, m - 1)];
                    assert!((g0 - e0).norm() < 1e-14 && (g1 - e1).norm() < 1e-14);
                }
                for u in [0.0, 0.3, 1.0] {
                    let lo = sp.evaluate(&q, &param(i, 0, u, 0.0)).unwrap().svv;
                    let hi = sp.evaluate(&q, &param(i, m - 2, u, 1.0)).unwrap().svv;
                    assert!(lo.norm() < 1e-13 && hi.norm() < 1e-13, "S_vv on free edge");
                }
            }
        }
    }

    #[test]
    fn c1_c2_across_closing_line_and_patch_seams() {
        let (n, m) = (9, 5);
        let nodes = revolution_nodes(n, m, |s| 0.25 + 0.1 * s, |s| 0.1 * s, 0.03, 5);
        let (sp, q) = spline_and_q(n, m, &nodes);
        for j in 0..m - 1 {
            for v in [0.0, 0.17, 0.5, 0.93, 1.0] {
                // Closing line (eq. 11) and every interior seam along u.
                for i in 0..n {
                    let left = sp.evaluate(&q, &param(i, j, 1.0, v)).unwrap();
                    let right = sp.evaluate(&q, &param((i + 1) % n, j, 0.0, v)).unwrap();
                    for (a, b) in [
                        (left.s, right.s),
                        (left.su, right.su),
                        (left.suu, right.suu),
                        (left.sv, right.sv),
                        (left.suv, right.suv),
                        (left.svv, right.svv),
                    ] {
                        assert!(
                            (a - b).norm() < 1e-12,
                            "seam after patch {i}, row {j}, v={v}: {a} vs {b}"
                        );
                    }
                }
            }
        }
        // Seams along v.
        for i in 0..n {
            for j in 0..m - 2 {
                let lo = sp.evaluate(&q, &param(i, j, 0.4, 1.0)).unwrap();
                let hi = sp.evaluate(&q, &param(i, j + 1, 0.4, 0.0)).unwrap();
                for (a, b) in [(lo.s, hi.s), (lo.sv, hi.sv), (lo.svv, hi.svv)] {
                    assert!((a - b).norm() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let (n, m) = (6, 4);
        let nodes = revolution_nodes(n, m, |s| 0.25 + 0.1 * s, |s| 0.1 * s, 0.03, 9);
        let (sp, q) = spline_and_q(n, m, &nodes);
        let h = 1e-5;
        let e = |u: f64, v: f64| sp.evaluate(&q, &param(2, 1, u, v)).unwrap();
        let (u, v) = (0.37, 0.61);
        let c = e(u, v);
        let fd_u = (e(u + h, v).s - e(u - h, v).s) / (2.0 * h);
        let fd_v = (e(u, v + h).s - e(u, v - h).s) / (2.0 * h);
        let fd_uu = (e(u + h, v).su - e(u - h, v).su) / (2.0 * h);
        let fd_uv = (e(u, v + h).su - e(u, v - h).su) / (2.0 * h);
        let fd_vv = (e(u, v + h).sv - e(u, v - h).sv) / (2.0 * h);
        for (a, b) in [
            (c.su, fd_u),
            (c.sv, fd_v),
            (c.suu, fd_uu),
            (c.suv, fd_uv),
            (c.svv, fd_vv),
        ] {
            assert!((a - b).norm() < 1e-8 * (1.0 + a.norm()), "{a} vs {b}");
        }
    }

    #[test]
    fn rest_casing_has_exact_rotational_symmetry() {
        let (n, m) = (10, 5);
        // A curved meridian (axial inlet turning outward), no noise.
        let nodes = revolution_nodes(
            n,
            m,
            |s| 0.2 + 0.1 * s * s,
            |s| 0.1 * (1.0 - (1.0 - s).powi(2)),
            0.0,
            1,
        );
        let (sp, q) = spline_and_q(n, m, &nodes);
        let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), 2.0 * PI / n as f64);
        for i in 0..n {
            for j in 0..m - 1 {
                for (u, v) in [(0.0, 0.0), (0.3, 0.7), (0.9, 0.1), (1.0, 1.0)] {
                    let a = sp.evaluate(&q, &param(i, j, u, v)).unwrap();
                    let b = sp.evaluate(&q, &param((i + 1) % n, j, u, v)).unwrap();
                    assert!(
                        (rot * a.s - b.s).norm() < 1e-14,
                        "patch ({i},{j}) ({u},{v})"
                    );
                    assert!((rot * a.su - b.su).norm() < 1e-13);
                    assert!((rot * a.sv - b.sv).norm() < 1e-13);
                }
            }
        }
    }

    #[test]
    fn patch_weights_and_node_weights_reproduce_the_surface() {
        let (n, m) = (7, 4);
        let nodes = revolution_nodes(n, m, |s| 0.3 + 0.02 * s, |s| 0.1 * s, 0.02, 21);
        let (sp, q) = spline_and_q(n, m, &nodes);
        let mut w = vec![0.0; n * m];
        for &(i, j, u, v) in &[(0, 0, 0.2, 0.8), (6, 2, 0.9, 0.4), (3, 1, 0.0, 1.0)] {
            let p = param(i, j, u, v);
            let s = sp.evaluate(&q, &p).unwrap().s;
            let idx = sp.patch_control_indices(i, j).unwrap();
            let c = CasingSpline::basis_weights(u, v);
            let s16: Vector3<f64> = idx.iter().zip(c).map(|(&k, ck)| ck * q[k]).sum();
            assert!((s - s16).norm() < 1e-14);
            sp.node_weights(&p, &mut w).unwrap();
            let sn: Vector3<f64> = w.iter().zip(&nodes).map(|(wk, pk)| *wk * pk).sum();
            assert!((s - sn).norm() < 1e-13, "{s} vs {sn}");
            // Partition of unity: translating all nodes translates the surface.
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-13);
        }
    }

    /// The node weights of the tangents give the tangents of `evaluate` (its control-point
    /// sums with the basis' derivatives), on the free edges too, and `on_free_edge` finds
    /// exactly the points of the first and last meridian boundary curves.
    #[test]
    fn node_weights_of_the_tangents_reproduce_the_surface_tangents() {
        let (n, m) = (7, 4);
        let nodes = revolution_nodes(n, m, |s| 0.3 + 0.02 * s, |s| 0.1 * s, 0.02, 21);
        let (sp, q) = spline_and_q(n, m, &nodes);
        let (mut wu, mut wv) = (vec![0.0; n], vec![0.0; m]);
        let cases = [
            (0, 0, 0.2, 0.0),
            (6, 2, 0.9, 1.0),
            (3, 1, 0.0, 0.4),
            (5, 2, 0.5, 0.7),
        ];
        for &(i, j, u, v) in &cases {
            let p = param(i, j, u, v);
            let e = sp.evaluate(&q, &p).unwrap();
            for (along, want) in [(Along::Point, e.s), (Along::U, e.su), (Along::V, e.sv)] {
                sp.node_weight_factors_of(along, &p, &mut wu, &mut wv)
                    .unwrap();
                let got: Vector3<f64> =
                    (0..n * m).map(|k| nodes[k] * (wu[k / m] * wv[k % m])).sum();
                assert!(
                    (got - want).norm() < 1e-13 * want.norm().max(1.0),
                    "{along:?} at {p:?}: {got} vs {want}"
                );
            }
            let edge = (j == 0 && v == 0.0) || (j == m - 2 && v == 1.0);
            assert_eq!(sp.on_free_edge(&p), edge, "{p:?}");
        }
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert_eq!(
            CasingSpline::new(2, 5).unwrap_err(),
            SplineError::TooFewSectors(2)
        );
        assert_eq!(
            CasingSpline::new(10, 1).unwrap_err(),
            SplineError::TooFewRows(1)
        );
        let sp = CasingSpline::new(4, 3).unwrap();
        let mut q = vec![Vector3::zeros(); sp.n_control()];
        assert!(matches!(
            sp.control_points(&vec![Vector3::zeros(); 11], &mut q),
            Err(SplineError::LengthMismatch {
                expected: 12,
                got: 11,
                ..
            })
        ));
        assert!(matches!(
            sp.evaluate(&q, &param(4, 0, 0.5, 0.5)),
            Err(SplineError::PatchOutOfRange { .. })
        ));
        assert!(sp.patch_control_indices(0, 2).is_err());
    }

    #[test]
    fn orientation_points_toward_axis() {
        let (n, m) = (12, 4);
        let up = revolution_nodes(n, m, |s| 0.3 + 0.05 * s, |s| 0.1 * s, 0.0, 1);
        let down = revolution_nodes(n, m, |s| 0.3 + 0.05 * s, |s| -0.1 * s, 0.0, 1);
        let mut sp = CasingSpline::new(n, m).unwrap();
        assert_eq!(sp.orient_toward_axis(&up).unwrap(), 1.0);
        assert_eq!(sp.orient_toward_axis(&down).unwrap(), -1.0);
        let disk = revolution_nodes(n, m, |s| 0.2 + 0.1 * s, |_| 0.0, 0.0, 1);
        assert!(sp.orient_toward_axis(&disk).is_err());
    }
}
