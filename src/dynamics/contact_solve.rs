//! Contact solve of one time step: flexibility tables, the contact matrix `W` and the
//! active-set solution of `W λ = −d*` (paper §3.2, Fig. 4).
//!
//! # Which form of eq. (19)
//! We use the **non-symmetric** `W = G_i A_i⁻¹ F_iᵀ + G_c A_c⁻¹ F_cᵀ`: `G` holds the normal-gap
//! rows (normal `n`), `F` the force-direction rows (`n + μ t`). It is exact for any μ: the
//! corrected gap is `d = d* + W λ`, and `W λ = −d*` closes every active gap. The symmetric form
//! printed in eq. (19) (`F A⁻¹ Fᵀ`) is right only for μ = 0.
//!
//! # Rows
//! Impeller contact `k` (blade `s`, tip node `j`): `g = R(θ_s)ᵀ R(Ωt)ᵀ n`, `f = R(θ_s)ᵀ R(Ωt)ᵀ (n + μ t)`
//! at that node's DOFs (sector-local frame). Casing: the closest point is `S = Σ_a c_a Q_a` over
//! the 16 control points of its patch (`B̂ c`, eq. 18), `Q = B P`, `P_(i,j) = R(θ_i)(Y_j + u_(i,j))`;
//! the casing row is `−Σ w_(i,j) R(θ_i)ᵀ n` (gap) and the casing force `−λ (n + μ t)` at `S`.

use crate::contact::CasingSpline;
use crate::dynamics::abradable::CoatingLaw;
use crate::dynamics::kernel::StructureKernel;
use crate::model::cyclic::rot_z;
use crate::simd::{self, Isa};
use nalgebra::{Matrix3, Vector3};

/// Block-circulant boundary flexibility `H = [A⁻¹]_bb` of a cyclic structure:
/// `block(d, j1, j2)` is the 3×3 displacement of node `j1` of sector `s + d` (its local frame)
/// per unit force on node `j2` of sector `s` (local frame), for any `s`.
#[derive(Clone, Debug)]
pub struct NodeFlexTable {
    ns: usize,
    nc: usize,
    data: Vec<Matrix3<f64>>,
}

impl NodeFlexTable {
    /// Builds the table by probing `kernel` with `3 n_c` unit boundary forces on sector 0.
    pub fn build(kernel: &mut dyn StructureKernel) -> Self {
        let (ns, nb) = (kernel.n_sectors(), kernel.n_boundary());
        let nc = nb / 3;
        let mut data = vec![Matrix3::zeros(); ns * nc * nc];
        let mut f = vec![0.0; ns * nb];
        let mut out = vec![0.0; ns * nb];
        for j2 in 0..nc {
            for d2 in 0..3 {
                f.iter_mut().for_each(|x| *x = 0.0);
                f[3 * j2 + d2] = 1.0;
                kernel.response(&f, &mut out);
                for s in 0..ns {
                    for j1 in 0..nc {
                        for d1 in 0..3 {
                            data[(s * nc + j1) * nc + j2][(d1, d2)] = out[s * nb + 3 * j1 + d1];
                        }
                    }
                }
            }
        }
        Self { ns, nc, data }
    }

    /// The 3×3 block for sector offset `d = s1 − s2 (mod N)`, nodes `j1`, `j2`.
    #[inline]
    pub fn block(&self, s1: usize, s2: usize, j1: usize, j2: usize) -> &Matrix3<f64> {
        let d = (s1 + self.ns - s2) % self.ns;
        &self.data[(d * self.nc + j1) * self.nc + j2]
    }
}

/// Control-point flexibility of the flexible casing on the real control rows `Q[c][1..=M]`
/// (the ghost rows are combinations of them, eq. 10, see
/// [`crate::contact::spline::real_row_weights`]): the displacement (global frame) of
/// `Q[c1][k1]` per unit force (global) on `Q[c2][k2]`, both transmitted through `Q = B P`.
/// Rotationally covariant: with `cl = (c − 1) mod N` the class of a column (centred on angle
/// `cl·α`), `HQ = R(cl₂ α) T[(cl₁ − cl₂) mod N][k1−1][k2−1] R(cl₂ α)ᵀ`.
#[derive(Clone, Debug)]
pub struct ControlFlexTable {
    n: usize,
    m: usize,
    /// `T` entry by entry: entry `e = d1 + 3 d2` of the 3×3 block (column-major) at
    /// `((d·9 + e)·S + r1)·S + r2` with `S = max(M, 4)` (rows `≥ M` are zero, so that the hot
    /// loop of [`ControlFlexTable::pair_block`] always spans 4 × 4 rows): the four `r2` of a
    /// patch are contiguous, one vector.
    flat: Vec<f64>,
    /// cos, sin of cl·α per class.
    cs: Vec<(f64, f64)>,
    /// The SIMD path of [`ControlFlexTable::pair_block`], chosen when built.
    isa: Isa,
}

impl ControlFlexTable {
    /// Builds `T` by probing the casing kernel with `3M` unit control-point forces on column 1.
    /// Its SIMD path is [`Isa::selected`] at this call.
    pub fn build(kernel: &mut dyn StructureKernel, spline: &CasingSpline) -> Self {
        let (n, m) = (spline.n_sectors(), spline.nodes_per_sector());
        let nb = kernel.n_boundary();
        let alpha = 2.0 * std::f64::consts::PI / n as f64;
        let b = spline.b_matrix();
        let rots: Vec<Matrix3<f64>> = (0..n).map(|i| rot_z(i as f64 * alpha)).collect();
        let st = m.max(4);
        let mut flat = vec![0.0; n * 9 * st * st];
        let mut f = vec![0.0; n * nb];
        let mut out = vec![0.0; n * nb];
        let mut disp = vec![Vector3::zeros(); n * m];
        let mut dq = vec![Vector3::zeros(); spline.n_control()];
        for r2 in 0..m {
            let row = spline.control_index(1, r2 + 1);
            for d2 in 0..3 {
                let mut e = Vector3::zeros();
                e[d2] = 1.0;
                for i in 0..n {
                    let el = rots[i].transpose() * e;
                    for j in 0..m {
                        let bw = b[(row, i * m + j)];
                        for d in 0..3 {
                            f[i * nb + 3 * j + d] = bw * el[d];
                        }
                    }
                }
                kernel.response(&f, &mut out);
                for i in 0..n {
                    for j in 0..m {
                        let ul = Vector3::new(
                            out[i * nb + 3 * j],
                            out[i * nb + 3 * j + 1],
                            out[i * nb + 3 * j + 2],
                        );
                        disp[i * m + j] = rots[i] * ul;
                    }
                }
                spline
                    .control_points(&disp, &mut dq)
                    .expect("sizes fixed by the spline");
                for cl1 in 0..n {
                    for r1 in 0..m {
                        let v = dq[spline.control_index(cl1 + 1, r1 + 1)];
                        for d1 in 0..3 {
                            // Column-major: entry (d1, d2) at d1 + 3 d2.
                            flat[table_index(st, cl1, d1 + 3 * d2, (r1, r2))] = v[d1];
                        }
                    }
                }
            }
        }
        let cs = (0..n)
            .map(|c| (c as f64 * alpha).sin_cos())
            .map(|(s, c)| (c, s))
            .collect();
        Self {
            n,
            m,
            flat,
            cs,
            isa: Isa::selected(),
        }
    }

    /// Casing contribution to `W` of the pair (k, l): `n_kᵀ V(k, l) f_l`, see
    /// [`ControlFlexTable::pair_block`].
    pub fn pair(
        &self,
        pk: &crate::contact::SurfaceParam,
        nk: &Vector3<f64>,
        pl: &crate::contact::SurfaceParam,
        fl: &Vector3<f64>,
    ) -> f64 {
        nk.dot(&(self.pair_block(pk, pl) * fl))
    }

    /// The basis weights of the surface point `p` on the table's control net
    /// ([`ControlWeights`]), which [`ControlFlexTable::weighted_pair_block`] contracts.
    pub fn weights(&self, p: &crate::contact::SurfaceParam) -> ControlWeights {
        self.weights_of(crate::contact::Along::Point, p)
    }

    /// [`ControlFlexTable::weights`] of the point or of its tangent along u or v: with them,
    /// [`ControlFlexTable::weighted_pair_block`] gives `∂V(p, p_l)/∂u` or `∂V(p, p_l)/∂v`,
    /// how the displacement under a force at `p_l` changes along the surface at `p`.
    pub fn weights_of(
        &self,
        along: crate::contact::Along,
        p: &crate::contact::SurfaceParam,
    ) -> ControlWeights {
        use crate::contact::spline::real_row_weights;
        let (u, v) = along.bases(p);
        let (row, w) = real_row_weights(p.j, &v, self.m);
        ControlWeights {
            i: p.i,
            u: u.into(),
            row,
            w,
        }
    }

    /// Flexibility between two surface points (m/N, global frame): the displacement of
    /// `S(pk)` per unit force at `S(pl)`, `V(k, l) = Σ_a Σ_b c^k_a c^l_b HQ(a, b)` over their 16
    /// control points and basis weights `c` (eq. 18). `V(l, k) = V(k, l)ᵀ` (Maxwell–Betti), so
    /// a contact matrix needs it once per unordered pair. See
    /// [`ControlFlexTable::weighted_pair_block`].
    pub fn pair_block(
        &self,
        pk: &crate::contact::SurfaceParam,
        pl: &crate::contact::SurfaceParam,
    ) -> Matrix3<f64> {
        self.weighted_pair_block(&self.weights(pk), &self.weights(pl))
    }

    /// [`ControlFlexTable::pair_block`] of two points given by their weights
    /// ([`ControlFlexTable::weights`], taken once per point when it pairs with many). The
    /// tensor-product weights are contracted along the meridian first, for the 7 distinct
    /// circumferential offsets, by the products `w^k_a w^l_b` with the table's rows of four
    /// (~2.4k flops, [`simd::meridian_sums`]), compiled for the table's SIMD path (its
    /// multiply-adds fused where that path fuses them).
    pub fn weighted_pair_block(&self, k: &ControlWeights, l: &ControlWeights) -> Matrix3<f64> {
        simd::compiled_for(self.isa, |isa| self.pair_block_impl(isa, k, l))
    }

    /// Rows per side of a block of `flat`, `S = max(M, 4)`.
    fn side(&self) -> usize {
        self.m.max(4)
    }

    /// The flexibility from the load point of weights `l` to every point of the patch of
    /// `patch` (its column `i` and meridian rows `row..row+4`), contracted over all but the
    /// patch point's own weights ([`PatchFlexibility`]): the same sums as
    /// [`ControlFlexTable::weighted_pair_block`], with the patch point's weights taken last.
    pub fn patch_flexibility(
        &self,
        patch: &ControlWeights,
        l: &ControlWeights,
    ) -> PatchFlexibility {
        let (n, st) = (self.n, self.side());
        // Per α − β = δ − 3 and patch row a: Σ_b w^l_b T_d(row + a, row_l + b), d the class
        // offset i − i_l + δ − 3 (wrapped), entries as the table's (column-major 3×3).
        let mut meridian = [[[0.0f64; 12]; 4]; 7];
        for (delta, rows) in meridian.iter_mut().enumerate() {
            let d = (patch.i + n * 4 + delta - 3 - l.i) % n;
            for (a, sums) in rows.iter_mut().enumerate() {
                for (e, sum) in sums.iter_mut().take(9).enumerate() {
                    *sum = (0..4)
                        .map(|b| {
                            l.w[b] * self.flat[table_index(st, d, e, (patch.row + a, l.row + b))]
                        })
                        .sum();
                }
            }
        }
        let mut m = [[Matrix3::zeros(); 4]; 4];
        for beta in 0..4 {
            let clb = (l.i + beta + n - 1) % n;
            for (alpha, m) in m.iter_mut().enumerate() {
                for (a, m) in m.iter_mut().enumerate() {
                    *m += rotate_about_z(self.cs[clb], &meridian[alpha + 3 - beta][a]) * l.u[beta];
                }
            }
        }
        PatchFlexibility {
            i: patch.i,
            row: patch.row,
            load: *l,
            m,
        }
    }

    /// [`ControlFlexTable::weighted_pair_block`] on the path `isa`.
    #[inline(always)]
    fn pair_block_impl(&self, isa: Isa, k: &ControlWeights, l: &ControlWeights) -> Matrix3<f64> {
        let n = self.n;
        let st = self.side();
        let (uk, ul) = (&k.u, &l.u);
        let (sk, wk) = (k.row, &k.w);
        let (sl, wl) = (l.row, &l.w);
        // V_δ, δ = α − β ∈ −3..=3, class offset i_k − i_l + δ, the meridian rows contracted
        // with the weights w^k_a w^l_b.
        let wkl: [[f64; 4]; 4] = std::array::from_fn(|a| std::array::from_fn(|b| wk[a] * wl[b]));
        let first = sk * st + sl;
        // A plain loop, not `array::from_fn`: its closure would be compiled apart, without
        // the pass's target features, so the kernel could not inline into it (and `isa` would
        // not be a constant there). Uninitialised, not zeroed: no `memset` per call.
        let mut v = [std::mem::MaybeUninit::<[f64; 12]>::uninit(); 7];
        // Class offsets i_k − i_l + δ for δ = −3..=3, wrapped.
        let mut d = (k.i + n * 4 - 3 - l.i) % n;
        for vd in &mut v {
            let t = &self.flat[table_index(st, d, 0, (0, 0))..table_index(st, d + 1, 0, (0, 0))];
            vd.write(simd::meridian_sums(isa, t, st, first, &wkl));
            d = if d + 1 == n { 0 } else { d + 1 };
        }
        // SAFETY: the loop above wrote all seven entries (read in place: a `transmute` would
        // copy the array).
        let v = unsafe { &*v.as_ptr().cast::<[[f64; 12]; 7]>() };
        let mut out = Matrix3::zeros();
        for beta in 0..4 {
            let mut mb = [0.0f64; 12];
            for alpha in 0..4 {
                let m = &v[alpha + 3 - beta];
                for e in 0..12 {
                    mb[e] = simd::madd_for(isa, uk[alpha], m[e], mb[e]);
                }
            }
            // Column-major 3×3 (nalgebra layout), in the frame of class clb: R mb Rᵀ, with R
            // the rotation by the class angle about z.
            let clb = (l.i + beta + n - 1) % n;
            out += rotate_about_z(self.cs[clb], &mb) * ul[beta];
        }
        out
    }

    /// `nᵀ HQ(a, b) f` for flat control indices `a`, `b` (global vectors), ghost rows included
    /// (through eq. 10). A reference for tests: one control-point pair at a time.
    pub fn bilinear(&self, a: usize, b: usize, nvec: &Vector3<f64>, fvec: &Vector3<f64>) -> f64 {
        let w = self.m + 2;
        let (ca, ka) = (a / w, a % w);
        let (cb, kb) = (b / w, b % w);
        let cla = (ca + self.n - 1) % self.n;
        let clb = (cb + self.n - 1) % self.n;
        let (c, s) = self.cs[clb];
        // R(φ)ᵀ v
        let nl = Vector3::new(c * nvec.x + s * nvec.y, -s * nvec.x + c * nvec.y, nvec.z);
        let fl = Vector3::new(c * fvec.x + s * fvec.y, -s * fvec.x + c * fvec.y, fvec.z);
        let d = (cla + self.n - clb) % self.n;
        let mut acc = 0.0;
        for (r1, w1) in self.real_rows(ka) {
            for (r2, w2) in self.real_rows(kb) {
                let t = Matrix3::from_fn(|d1, d2| {
                    self.flat[table_index(self.side(), d, d1 + 3 * d2, (r1, r2))]
                });
                acc += w1 * w2 * nl.dot(&(t * fl));
            }
        }
        acc
    }

    /// Control row `k` as a combination of real rows (0-based), eq. (10).
    fn real_rows(&self, k: usize) -> Vec<(usize, f64)> {
        let m = self.m;
        match k {
            0 => vec![(0, 2.0), (1, -1.0)],
            k if k == m + 1 => vec![(m - 1, 2.0), (m - 2, -1.0)],
            k => vec![(k - 1, 1.0)],
        }
    }
}

/// The weights of a surface point on the casing's control net (eq. 18): its patch column
/// `i`, the four circumferential basis values of its control columns `i..i+4`, and its
/// meridian weights on the real control rows `row..row+4` (eq. 10 folded in,
/// [`crate::contact::spline::real_row_weights`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ControlWeights {
    i: usize,
    u: [f64; 4],
    row: usize,
    w: [f64; 4],
}

/// The casing's flexibility from one load point `p_l` to the points `p` of one surface patch
/// (m/N, global): `V(p, p_l) = Σ_α Σ_a u_α(p) w_a(p) M[α][a]` over the patch point's four
/// circumferential and four meridian weights ([`ControlWeights`]), eq. (18) with everything
/// but those weights contracted ([`ControlFlexTable::patch_flexibility`], ~5k flops). A
/// block then costs 16 multiply-adds of 3×3 blocks where
/// [`ControlFlexTable::weighted_pair_block`] takes ~2.4k flops, and so do its slopes along
/// the surface (the weights of [`ControlFlexTable::weights_of`]): box 4b takes a
/// candidate's blocks again whenever its closest point moves, many times per step against
/// the same load points, nearly always on the same patch.
#[derive(Clone, Debug)]
pub struct PatchFlexibility {
    i: usize,
    row: usize,
    load: ControlWeights,
    m: [[Matrix3<f64>; 4]; 4],
}

impl PatchFlexibility {
    /// Whether this is the flexibility from the load point of weights `load` to the patch of
    /// the point of weights `p`: what [`ControlFlexTable::patch_flexibility`] would build.
    pub fn is_for(&self, p: &ControlWeights, load: &ControlWeights) -> bool {
        self.covers(p) && self.load == *load
    }

    /// Whether the point of weights `p` lies on this patch.
    pub fn covers(&self, p: &ControlWeights) -> bool {
        p.i == self.i && p.row == self.row
    }

    /// `V(p, p_l)` (m/N) for the weights `p` of a point on this patch (or of its tangent,
    /// for a slope); `None` off the patch.
    pub fn block(&self, p: &ControlWeights) -> Option<Matrix3<f64>> {
        self.covers(p).then(|| {
            let mut out = Matrix3::zeros();
            for (m, u) in self.m.iter().zip(p.u) {
                let along: Matrix3<f64> = m.iter().zip(p.w).map(|(m, w)| m * w).sum();
                out += along * u;
            }
            out
        })
    }
}

/// Index in [`ControlFlexTable`]'s `flat` of entry `e` of the 3×3 block of class offset `d`
/// and meridian rows `(r1, r2)`, with `st` rows per block side.
#[inline(always)]
fn table_index(st: usize, d: usize, e: usize, (r1, r2): (usize, usize)) -> usize {
    ((d * 9 + e) * st + r1) * st + r2
}

/// `R M Rᵀ` for the column-major 3×3 `M` in `m[..9]` and the rotation `R` about z by the
/// angle of `(cos, sin)`: the 2×2 block turns on both sides, the z column and row on one.
#[inline(always)]
fn rotate_about_z((c, s): (f64, f64), m: &[f64; 12]) -> Matrix3<f64> {
    // Q A with A = [[m0, m3], [m1, m4]], Q = [[c, −s], [s, c]].
    let (p00, p01) = (c * m[0] - s * m[1], c * m[3] - s * m[4]);
    let (p10, p11) = (s * m[0] + c * m[1], s * m[3] + c * m[4]);
    Matrix3::new(
        p00 * c - p01 * s,
        p00 * s + p01 * c,
        c * m[6] - s * m[7],
        p10 * c - p11 * s,
        p10 * s + p11 * c,
        s * m[6] + c * m[7],
        c * m[2] - s * m[5],
        s * m[2] + c * m[5],
        m[8],
    )
}

/// Why [`active_set_solve`] found no multipliers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ContactSolveError {
    /// `W_AA` of an active set is singular.
    #[error("singular contact matrix W on an active set of {active} contacts")]
    Singular {
        /// Size of the active set.
        active: usize,
    },
    /// The pivoting hit its cap: with friction `W` may not be a P-matrix (a large μ), and the
    /// complementarity problem then need not have one solution.
    #[error(
        "contact active set not settled after {pivots} pivots ({candidates} candidates): \
         W may not be a P-matrix (friction too large for this contact geometry)"
    )]
    NotSettled {
        /// Pivots made.
        pivots: usize,
        /// Contact candidates of the step.
        candidates: usize,
    },
}

/// The complementarity problem of a step (eq. 18): finds `λ ≥ 0` with the linearised gaps
/// `g = d + W λ` (m) closed on the active set `A = {λ > 0}` and `g ≥ −tol` off it, for `W`
/// non-symmetric (friction) or not. `w` is row-major `n × n` (m/N), `d` the predicted gaps
/// (m), `tol` (m, ≥ 0) the admitted penetration of an inactive contact. Returns the pivots
/// taken after the first phase.
///
/// 1. From every candidate, drop all negative multipliers at once until none is left (the
///    solution whenever no dropped contact is pushed back in, one or two solves).
/// 2. Then principal pivoting with Murty's least-index rule: the first index that breaks a
///    condition (`λ_k < 0` on `A`, `g_k < −tol` off `A`) changes sides. For a P-matrix `W`
///    (the frictionless `G A⁻¹ Gᵀ`, and small μ) this ends, at the unique solution, in
///    finitely many pivots (Murty 1974); the cap `8 n + 16` turns a cycle (a large μ) into
///    [`ContactSolveError::NotSettled`].
///
/// Works in the caller's buffers (`active`, `lu`, `rhs` with capacity ≥ n², n): no
/// allocation.
#[allow(clippy::too_many_arguments)]
pub fn active_set_solve(
    n: usize,
    w: &[f64],
    d: &[f64],
    tol: f64,
    lambda: &mut [f64],
    active: &mut Vec<usize>,
    lu: &mut Vec<f64>,
    rhs: &mut Vec<f64>,
) -> Result<usize, ContactSolveError> {
    active.clear();
    active.extend(0..n);
    loop {
        solve_on(n, w, d, active, lambda, lu, rhs)?;
        if rhs.iter().all(|&x| x >= 0.0) {
            break;
        }
        let mut i = 0;
        active.retain(|_| {
            let keep = rhs[i] >= 0.0;
            i += 1;
            keep
        });
    }
    let cap = 8 * n + 16;
    for pivots in 0..=cap {
        // The least index that breaks a condition (both lists are in index order).
        let mut flip = None;
        let mut a = 0;
        for k in 0..n {
            if active.get(a) == Some(&k) {
                a += 1;
                if lambda[k] < 0.0 {
                    flip = Some((k, a - 1, true));
                    break;
                }
            } else if gap(n, w, d, lambda, k) < -tol {
                flip = Some((k, a, false));
                break;
            }
        }
        let Some((k, at, was_active)) = flip else {
            return Ok(pivots);
        };
        if pivots == cap {
            break;
        }
        if was_active {
            active.remove(at);
        } else {
            active.insert(at, k);
        }
        solve_on(n, w, d, active, lambda, lu, rhs)?;
    }
    Err(ContactSolveError::NotSettled {
        pivots: cap,
        candidates: n,
    })
}

/// The buffers of [`coated_solve`]: its complementarity problem of `n + n_c` unknowns (`n_c`
/// coating rows), grown on first use and kept (no allocation once the largest step is seen).
#[derive(Clone, Debug, Default)]
pub(crate) struct CoatedBuffers {
    m: Vec<f64>,
    q: Vec<f64>,
    z: Vec<f64>,
    active: Vec<usize>,
    lu: Vec<f64>,
    rhs: Vec<f64>,
}

/// The contact problem of a step whose candidates may sit on abradable coating elements, for a
/// massless boundary (#24): the coating force is solved with the boundary's static response,
/// as the Lagrange multipliers are. Candidate `k` without a law is a Lagrange contact with the
/// casing (eq. 18: `g_k = d_k + Σ_l W_kl λ_l ≥ 0`, `λ_k ≥ 0`, complementary). Candidate `k` on
/// an element of law `laws[k]` carries the element's force `λ_k` with the plastic shortening
/// `Δp_k ≥ 0` (m) of the step, where its linearised depth below the worn surface is
/// `p_k = remaining − g_k`:
/// - `r_k = −p_k + Δp_k + λ_k / k ≥ 0`, `λ_k ≥ 0`, complementary: the element, of stiffness
///   `k`, is compressed by `p_k − Δp_k` when it pushes, and carries no tension;
/// - `s_k = (λ_Y + K' Δp_k − λ_k) / k ≥ 0`, `Δp_k ≥ 0`, complementary: it shortens plastically
///   only at its (hardening) yield force, the return mapping of
///   `CoatingMaterial::return_map` in forces and lengths.
///
/// With `μ_k = k Δp_k` (N) as the second unknown every row is a length (m) and the matrix is
/// `[[W + D, D], [−D, K' D²]]` (`D = diag(1/k)` on the coating rows), whose symmetric part is
/// that of `W` plus a positive diagonal: a P-matrix whenever `W`'s symmetric part is positive
/// semi-definite (no or mild friction), so [`active_set_solve`] finds its unique solution.
/// `w` is row-major `n × n`, `d` the predicted gaps to the casing (m); returns the pivots, the
/// forces in `lambda` and the plastic shortenings in `plastic` (m, 0 off the coating rows).
#[allow(clippy::too_many_arguments)]
pub(crate) fn coated_solve(
    n: usize,
    w: &[f64],
    d: &[f64],
    laws: &[Option<CoatingLaw>],
    tol: f64,
    lambda: &mut [f64],
    plastic: &mut [f64],
    buf: &mut CoatedBuffers,
) -> Result<usize, ContactSolveError> {
    let nc = laws[..n].iter().filter(|l| l.is_some()).count();
    let nt = n + nc;
    let (m, q) = (&mut buf.m, &mut buf.q);
    m.clear();
    m.resize(nt * nt, 0.0);
    q.clear();
    q.extend_from_slice(&d[..n]);
    q.resize(nt, 0.0);
    for k in 0..n {
        m[k * nt..k * nt + n].copy_from_slice(&w[k * n..(k + 1) * n]);
    }
    let mut c = n;
    for (k, law) in laws[..n].iter().enumerate() {
        let Some(law) = law else { continue };
        let compliance = 1.0 / law.stiffness;
        m[k * nt + k] += compliance;
        m[k * nt + c] = compliance;
        q[k] -= law.remaining;
        m[c * nt + k] = -compliance;
        m[c * nt + c] = law.hardening * compliance * compliance;
        q[c] = law.yield_force * compliance;
        c += 1;
    }
    buf.z.resize(nt, 0.0);
    let pivots = active_set_solve(
        nt,
        m,
        q,
        tol,
        &mut buf.z,
        &mut buf.active,
        &mut buf.lu,
        &mut buf.rhs,
    )?;
    lambda[..n].copy_from_slice(&buf.z[..n]);
    let mut c = n;
    for (k, law) in laws[..n].iter().enumerate() {
        plastic[k] = match law {
            Some(law) => {
                c += 1;
                buf.z[c - 1] / law.stiffness
            }
            None => 0.0,
        };
    }
    Ok(pivots)
}

/// The linearised gap `d_k + Σ_l W_kl λ_l` (m).
#[inline]
fn gap(n: usize, w: &[f64], d: &[f64], lambda: &[f64], k: usize) -> f64 {
    let row = &w[k * n..(k + 1) * n];
    d[k] + row
        .iter()
        .zip(&lambda[..n])
        .map(|(a, b)| a * b)
        .sum::<f64>()
}

/// Solves `W_AA λ_A = −d_A` (`A` = `active`, in `rhs` in that order) and scatters it into
/// `lambda`, zero off `A`.
fn solve_on(
    n: usize,
    w: &[f64],
    d: &[f64],
    active: &[usize],
    lambda: &mut [f64],
    lu: &mut Vec<f64>,
    rhs: &mut Vec<f64>,
) -> Result<(), ContactSolveError> {
    let na = active.len();
    lu.clear();
    rhs.clear();
    for &r in active {
        lu.extend(active.iter().map(|&c| w[r * n + c]));
        rhs.push(-d[r]);
    }
    if !gauss_solve(na, lu, rhs) {
        return Err(ContactSolveError::Singular { active: na });
    }
    lambda[..n].iter_mut().for_each(|x| *x = 0.0);
    for (&r, &x) in active.iter().zip(rhs.iter()) {
        lambda[r] = x;
    }
    Ok(())
}

/// In-place Gaussian elimination with partial pivoting; solution left in `b`.
fn gauss_solve(n: usize, a: &mut [f64], b: &mut [f64]) -> bool {
    for col in 0..n {
        let (mut piv, mut best) = (col, a[col * n + col].abs());
        for r in col + 1..n {
            if a[r * n + col].abs() > best {
                best = a[r * n + col].abs();
                piv = r;
            }
        }
        if best.is_nan() || best <= 0.0 || !best.is_finite() {
            return false;
        }
        if piv != col {
            for c in 0..n {
                a.swap(col * n + c, piv * n + c);
            }
            b.swap(col, piv);
        }
        let p = a[col * n + col];
        for r in col + 1..n {
            let f = a[r * n + col] / p;
            if f != 0.0 {
                for c in col..n {
                    a[r * n + c] -= f * a[col * n + c];
                }
                b[r] -= f * b[col];
            }
        }
    }
    for col in (0..n).rev() {
        let mut s = b[col];
        for c in col + 1..n {
            s -= a[col * n + c] * b[c];
        }
        b[col] = s / a[col * n + col];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A layer of one row (nominal material, 2 mm; tip area 5e-6 m²) and the law of the element
    /// at angle 0.1 rad after a first plastic shortening `worn` (m).
    fn coating_law(worn: f64) -> (crate::dynamics::abradable::CoatingLayer, CoatingLaw) {
        use crate::dynamics::abradable::{CoatingLayer, CoatingMaterial};
        let mut layer = CoatingLayer::new(CoatingMaterial::nominal(), 600, vec![5e-6]).unwrap();
        let (el, _) = layer.law(0, 0.1).unwrap();
        let up = layer.plastic_update(0, el, worn).unwrap();
        layer.commit(&up).unwrap();
        let law = layer.law(0, 0.1).unwrap().1;
        (layer, law)
    }

    /// A tip on a spring of flexibility `w` (the static flexibility of a massless boundary)
    /// pressed into a coating element: the predicted gap `d` is where the static load alone
    /// puts it. Closed form of the 1D law in series with the spring, with `p₀ = e_r − d` the
    /// predicted depth below the worn surface: elastic `λ = k p₀ / (1 + k w)` while `λ ≤ λ_Y`,
    /// else `λ = (λ_Y + K' p₀) / (1 + K'/k + K' w)` and the wear `Δp = (λ − λ_Y) / K'`; the
    /// tip ends `w λ` above its prediction. Open, elastic and plastic, virgin and worn.
    #[test]
    fn a_tip_on_a_spring_pressed_into_a_coating_element_has_the_closed_form_force_and_wear() {
        let mut buf = CoatedBuffers::default();
        for worn in [0.0, 3e-4] {
            let (layer, law) = coating_law(worn);
            let (k, ly, kh) = (law.stiffness, law.yield_force, law.hardening);
            assert!((law.remaining - (2e-3 - worn)).abs() < 1e-15);
            // m/N: k w = 3.5, a stiff element on a soft boundary (the explicit force needs k w < 1).
            let w = 2e-7;
            let p_yield = ly * (1.0 + k * w) / k;
            // Every depth stays inside the layer (5 p_yield < e_r both times).
            assert!(5.0 * p_yield < law.remaining);
            for p0 in [
                -1e-5,
                0.5 * p_yield,
                0.999 * p_yield,
                1.5 * p_yield,
                5.0 * p_yield,
            ] {
                let d = law.remaining - p0;
                let (mut lambda, mut plastic) = ([0.0], [0.0]);
                coated_solve(
                    1,
                    &[w],
                    &[d],
                    &[Some(law)],
                    1e-14,
                    &mut lambda,
                    &mut plastic,
                    &mut buf,
                )
                .unwrap();
                let (l_exact, dp_exact) = if p0 <= 0.0 {
                    (0.0, 0.0)
                } else if p0 <= p_yield {
                    (k * p0 / (1.0 + k * w), 0.0)
                } else {
                    let l = (ly + kh * p0) / (1.0 + kh / k + kh * w);
                    (l, (l - ly) / kh)
                };
                let scale = ly.max(1.0);
                assert!(
                    (lambda[0] - l_exact).abs() <= 1e-10 * scale,
                    "p0 {p0:e}: λ {} vs {l_exact}",
                    lambda[0]
                );
                assert!(
                    (plastic[0] - dp_exact).abs() <= 1e-12 * 2e-3,
                    "p0 {p0:e}: Δp {} vs {dp_exact}",
                    plastic[0]
                );
                // The element's own return mapping at the corrected incursion gives the same force.
                let incursion = 2e-3 - (d + w * lambda[0]);
                let (f, up) = layer.trial(0, 0.1, incursion).unwrap();
                assert!(
                    (f - lambda[0]).abs() <= 1e-9 * scale,
                    "trial {f} vs λ {}",
                    lambda[0]
                );
                let eps_p0 = worn / 2e-3;
                assert!((up.plastic_strain - eps_p0 - plastic[0] / 2e-3).abs() <= 1e-12);
            }
        }
    }

    /// Two coupled tips (a symmetric flexibility with coupling), one on the coating, one against
    /// the bare casing: the solution meets each law — the element's return mapping at the
    /// corrected incursion, and the Lagrange complementarity — checked on the output alone.
    #[test]
    fn coated_and_lagrange_tips_together_meet_both_laws() {
        let (layer, law) = coating_law(1e-4);
        let w = [3e-7, 1e-7, 1e-7, 2e-7];
        let mut buf = CoatedBuffers::default();
        for (d0, d1) in [
            (1.5e-3, -1e-5),
            (1.0e-3, -2e-5),
            (1.9e-3, -1e-6),
            (1.0e-3, 5e-5),
        ] {
            let (mut lambda, mut plastic) = ([0.0; 2], [0.0; 2]);
            let laws = [Some(law), None];
            coated_solve(
                2,
                &w,
                &[d0, d1],
                &laws,
                1e-14,
                &mut lambda,
                &mut plastic,
                &mut buf,
            )
            .unwrap();
            let g0 = d0 + w[0] * lambda[0] + w[1] * lambda[1];
            let g1 = d1 + w[2] * lambda[0] + w[3] * lambda[1];
            let (f, up) = layer.trial(0, 0.1, 2e-3 - g0).unwrap();
            assert!(
                (f - lambda[0]).abs() <= 1e-9 * law.yield_force,
                "{f} vs {}",
                lambda[0]
            );
            assert!((up.plastic_strain - 0.05 - plastic[0] / 2e-3).abs() <= 1e-12);
            assert!(lambda[1] >= 0.0 && g1 >= -1e-14 && (lambda[1] == 0.0 || g1.abs() <= 1e-14));
            assert_eq!(plastic[1], 0.0);
        }
    }

    #[test]
    fn contracted_pair_equals_the_explicit_control_point_sum() {
        use crate::contact::SurfaceParam;
        use crate::dynamics::modal::ModalKernel;
        use crate::dynamics::structure::Structure;
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, 8, 3, 2));
        let st = Structure::new(&rom, 0.0).unwrap();
        let mut k = ModalKernel::new(&st, 0.2 * st.stability_limit()).unwrap();
        let spline = CasingSpline::new(8, 3).unwrap();
        let tab = ControlFlexTable::build(&mut k, &spline);
        let params = [
            SurfaceParam {
                i: 0,
                j: 0,
                u: 0.3,
                v: 0.9,
            },
            SurfaceParam {
                i: 7,
                j: 1,
                u: 0.8,
                v: 0.2,
            },
            SurfaceParam {
                i: 3,
                j: 1,
                u: 0.05,
                v: 0.6,
            },
        ];
        let nv = Vector3::new(-0.8, 0.1, 0.3);
        let fv = Vector3::new(0.2, -0.9, 0.4);
        for pk in &params {
            for pl in &params {
                let ia = spline.patch_control_indices(pk.i, pk.j).unwrap();
                let ib = spline.patch_control_indices(pl.i, pl.j).unwrap();
                let ca = CasingSpline::basis_weights(pk.u, pk.v);
                let cb = CasingSpline::basis_weights(pl.u, pl.v);
                let mut explicit = 0.0;
                for a in 0..16 {
                    for b in 0..16 {
                        explicit += ca[a] * cb[b] * tab.bilinear(ia[a], ib[b], &nv, &fv);
                    }
                }
                let fast = tab.pair(pk, &nv, pl, &fv);
                assert!(
                    (fast - explicit).abs() <= 1e-12 * explicit.abs().max(1e-30),
                    "{fast:e} vs {explicit:e}"
                );
                // Maxwell–Betti, which the contact matrix assembly relies on.
                let (v, vt) = (tab.pair_block(pk, pl), tab.pair_block(pl, pk).transpose());
                assert!((v - vt).norm() <= 1e-10 * v.norm(), "{v} vs {vt}");
            }
        }
    }

    /// The slopes `∂V(p, p_l)/∂u`, `∂V(p, p_l)/∂v` from the tangents' weights equal the
    /// central differences of `V(p, p_l)` along the surface at `p` (the last patch's trailing
    /// edge `v = 1` and the leading edge `v = 0` among the points, one-sided there).
    #[test]
    fn slope_blocks_are_the_derivatives_of_the_pair_blocks() {
        use crate::contact::{Along, SurfaceParam};
        use crate::dynamics::modal::ModalKernel;
        use crate::dynamics::structure::Structure;
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, 8, 4, 2));
        let st = Structure::new(&rom, 0.0).unwrap();
        let mut k = ModalKernel::new(&st, 0.2 * st.stability_limit()).unwrap();
        let spline = CasingSpline::new(8, 4).unwrap();
        let tab = ControlFlexTable::build(&mut k, &spline);
        let p = |i, j, u, v| SurfaceParam { i, j, u, v };
        let points = [p(2, 2, 0.4, 1.0), p(5, 0, 0.7, 0.0), p(0, 1, 0.5, 0.5)];
        let load = p(3, 2, 0.3, 0.8);
        let h = 1e-5;
        for at in &points {
            let wl = tab.weights(&load);
            let block = |q: &SurfaceParam| tab.pair_block(q, &load);
            let (up, um) = (
                SurfaceParam { u: at.u + h, ..*at },
                SurfaceParam { u: at.u - h, ..*at },
            );
            let du = (block(&up) - block(&um)) / (2.0 * h);
            // One-sided at the edges, second order: (−3 f₀ + 4 f₁ − f₂) / 2h inward.
            let s = if at.v >= 1.0 { -1.0 } else { 1.0 };
            let dv = if at.v <= 0.0 || at.v >= 1.0 {
                let at_v = |t: f64| {
                    block(&SurfaceParam {
                        v: at.v + s * t,
                        ..*at
                    })
                };
                (at_v(2.0 * h) * -1.0 + at_v(h) * 4.0 - at_v(0.0) * 3.0) * (s / (2.0 * h))
            } else {
                let at_v = |t: f64| block(&SurfaceParam { v: at.v + t, ..*at });
                (at_v(h) - at_v(-h)) / (2.0 * h)
            };
            let su = tab.weighted_pair_block(&tab.weights_of(Along::U, at), &wl);
            let sv = tab.weighted_pair_block(&tab.weights_of(Along::V, at), &wl);
            for (got, want) in [(su, du), (sv, dv)] {
                assert!(
                    (got - want).norm() <= 1e-7 * want.norm(),
                    "at {at:?}: {got} vs {want}"
                );
            }
        }
    }

    /// A patch's flexibility gives the pair blocks and their slopes of every point of the
    /// patch, to round-off, on the edges and the seam's patch too (the table's own
    /// contraction, [`ControlFlexTable::weighted_pair_block`], is the reference), and refuses
    /// the points of another patch.
    #[test]
    fn patch_flexibility_gives_the_pair_blocks_and_slopes_of_its_patch() {
        use crate::contact::{Along, SurfaceParam};
        use crate::dynamics::modal::ModalKernel;
        use crate::dynamics::structure::Structure;
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, 8, 5, 2));
        let st = Structure::new(&rom, 0.0).unwrap();
        let spline = CasingSpline::new(8, 5).unwrap();
        let mut k = ModalKernel::new(&st, 0.2 * st.stability_limit()).unwrap();
        let tab = ControlFlexTable::build(&mut k, &spline);
        let p = |i, j, u, v| SurfaceParam { i, j, u, v };
        let loads = [p(3, 2, 0.3, 0.8), p(7, 0, 0.9, 0.0), p(0, 3, 0.5, 1.0)];
        let patches = [p(2, 2, 0.4, 1.0), p(7, 0, 0.7, 0.0), p(0, 1, 0.5, 0.5)];
        for load in &loads {
            let wl = tab.weights(load);
            for patch in &patches {
                let flex = tab.patch_flexibility(&tab.weights(patch), &wl);
                for (u, v) in [(0.0, 0.0), (0.3, 0.7), (1.0, 1.0), (patch.u, patch.v)] {
                    let at = SurfaceParam { u, v, ..*patch };
                    for along in [Along::Point, Along::U, Along::V] {
                        let w = tab.weights_of(along, &at);
                        let want = tab.weighted_pair_block(&w, &wl);
                        let got = flex.block(&w).expect("a point of the patch");
                        assert!(
                            (got - want).norm() <= 1e-12 * want.norm(),
                            "{along:?} at {at:?} against {load:?}: {got} vs {want}"
                        );
                    }
                }
                let other = SurfaceParam {
                    i: (patch.i + 1) % 8,
                    ..*patch
                };
                assert_eq!(flex.block(&tab.weights(&other)), None);
            }
        }
    }

    /// One table's pair blocks on the portable path equal those on the best path (to
    /// round-off: the portable path may not fuse its multiply-adds).
    #[test]
    fn pair_blocks_agree_on_both_paths() {
        use crate::contact::SurfaceParam;
        use crate::dynamics::modal::ModalKernel;
        use crate::dynamics::structure::Structure;
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let best = Isa::best();
        if best.is_portable() {
            eprintln!("no explicit SIMD path on this CPU: pair blocks not compared");
            return;
        }
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, 8, 5, 2));
        let st = Structure::new(&rom, 0.0).unwrap();
        let spline = CasingSpline::new(8, 5).unwrap();
        let mut k = ModalKernel::new(&st, 0.2 * st.stability_limit()).unwrap();
        let mut explicit = ControlFlexTable::build(&mut k, &spline);
        explicit.isa = best;
        let portable = ControlFlexTable {
            isa: Isa::PORTABLE,
            ..explicit.clone()
        };
        let mut rng = crate::fixtures::Lcg(3);
        let mut param = || SurfaceParam {
            i: (4.0 * (rng.next() + 1.0)) as usize % 8,
            j: (2.0 * (rng.next() + 1.0)) as usize % 4,
            u: 0.5 * (rng.next() + 1.0),
            v: 0.5 * (rng.next() + 1.0),
        };
        for _ in 0..20 {
            let (pk, pl) = (param(), param());
            let (a, b) = (explicit.pair_block(&pk, &pl), portable.pair_block(&pk, &pl));
            assert!((a - b).norm() <= 1e-13 * a.norm(), "{a} vs {b}");
        }
    }

    /// Every solution of the complementarity problem `λ ≥ 0`, `g = d + W λ ≥ −tol`,
    /// `λ_k g_k = 0`, by enumerating the 2ⁿ active sets (an independent reference).
    fn brute_force(n: usize, w: &[f64], d: &[f64], tol: f64) -> Vec<Vec<f64>> {
        let mut found = vec![];
        for mask in 0u32..1 << n {
            let set: Vec<usize> = (0..n).filter(|k| mask >> k & 1 == 1).collect();
            let mut a: Vec<f64> = set
                .iter()
                .flat_map(|&r| set.iter().map(move |&c| w[r * n + c]))
                .collect();
            let mut b: Vec<f64> = set.iter().map(|&r| -d[r]).collect();
            if !gauss_solve(set.len(), &mut a, &mut b) || b.iter().any(|&x| x < 0.0) {
                continue;
            }
            let mut l = vec![0.0; n];
            set.iter().zip(&b).for_each(|(&r, &x)| l[r] = x);
            if (0..n).all(|k| set.contains(&k) || gap(n, w, d, &l, k) >= -tol) {
                found.push(l);
            }
        }
        found
    }

    fn solve(n: usize, w: &[f64], d: &[f64]) -> Result<Vec<f64>, ContactSolveError> {
        let (mut l, mut a, mut lu, mut r) = (vec![0.0; n], vec![], vec![], vec![]);
        active_set_solve(n, w, d, 0.0, &mut l, &mut a, &mut lu, &mut r).map(|_| l)
    }

    /// The drop-everything-at-once solve (the solve before the pivoting phase): its
    /// multipliers on this problem.
    fn drop_all(n: usize, w: &[f64], d: &[f64]) -> Vec<f64> {
        let mut active: Vec<usize> = (0..n).collect();
        let (mut l, mut lu, mut r) = (vec![0.0; n], vec![], vec![]);
        loop {
            solve_on(n, w, d, &active, &mut l, &mut lu, &mut r).unwrap();
            if r.iter().all(|&x| x >= 0.0) {
                return l;
            }
            let mut i = 0;
            active.retain(|_| {
                i += 1;
                r[i - 1] >= 0.0
            });
        }
    }

    #[test]
    fn active_set_drops_negative_multipliers() {
        // Two coupled contacts: the second would need a pulling force.
        let w = [2.0, 1.0, 1.0, 2.0];
        let d = [-1.0, 0.1];
        let l = solve(2, &w, &d).unwrap();
        assert_eq!(l[1], 0.0);
        assert!((l[0] - 0.5).abs() < 1e-15);
        // Corrected gaps: first closed exactly, second still open.
        assert!((d[0] + w[0] * l[0]).abs() < 1e-15 && d[1] + w[2] * l[0] > 0.0);
    }

    /// Three contacts (symmetric positive definite `W`): all three solved together need two
    /// pulling forces, and dropping both at once leaves contact 2 penetrating by 0.2; the
    /// exact solve re-adds it: `λ = (0, 0, 0.1)`, the only solution.
    #[test]
    fn a_contact_dropped_with_the_others_is_re_added() {
        let w = [2.0, 0.7, -0.8, 0.7, 2.0, -0.9, -0.8, -0.9, 2.0];
        let d = [0.1, 0.9, -0.2];
        let old = drop_all(3, &w, &d);
        assert!(gap(3, &w, &d, &old, 2) < -0.19, "{old:?}");
        let l = solve(3, &w, &d).unwrap();
        let reference = brute_force(3, &w, &d, 0.0);
        assert_eq!(reference.len(), 1);
        for (a, b) in l.iter().zip(&reference[0]) {
            assert!((a - b).abs() <= 1e-15, "{l:?} vs {reference:?}");
        }
        assert!((l[2] - 0.1).abs() <= 1e-15 && l[0] == 0.0 && l[1] == 0.0);
    }

    /// Friction: `W = G H Fᵀ` with the force rows `n + μ t` (non-symmetric), on one flexible
    /// body of four 3-DOF contact nodes; random predicted gaps. Every problem has exactly
    /// one solution (W is a P-matrix at this μ), which the solve finds.
    #[test]
    fn non_symmetric_problems_match_the_enumeration_of_active_sets() {
        let mut rng = crate::fixtures::Lcg(11);
        let (n, mu) = (4, 0.3);
        let (mut re_added, mut checked) = (0, 0);
        for _ in 0..200 {
            // H = B Bᵀ + I (12×12, positive definite).
            let b: Vec<f64> = (0..144).map(|_| rng.next()).collect();
            let h = |i: usize, j: usize| {
                (0..12).map(|k| b[i * 12 + k] * b[j * 12 + k]).sum::<f64>()
                    + if i == j { 1.0 } else { 0.0 }
            };
            let unit = |v: Vector3<f64>| v / v.norm();
            let nrm: Vec<Vector3<f64>> = (0..n)
                .map(|_| unit(Vector3::new(rng.next(), rng.next(), 2.0)))
                .collect();
            let frc: Vec<Vector3<f64>> = nrm
                .iter()
                .map(|nk| {
                    let t = unit(nk.cross(&Vector3::new(rng.next(), rng.next(), rng.next())));
                    nk + t * mu
                })
                .collect();
            let mut w = vec![0.0; n * n];
            for k in 0..n {
                for l in 0..n {
                    for (a, b) in (0..3).flat_map(|a| (0..3).map(move |b| (a, b))) {
                        w[k * n + l] += nrm[k][a] * h(3 * k + a, 3 * l + b) * frc[l][b];
                    }
                }
            }
            let d: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            let reference = brute_force(n, &w, &d, 0.0);
            if reference.len() != 1 {
                continue;
            }
            checked += 1;
            let l = solve(n, &w, &d).unwrap();
            let scale = reference[0].iter().fold(1e-300f64, |m, x| m.max(x.abs()));
            for (a, b) in l.iter().zip(&reference[0]) {
                assert!((a - b).abs() <= 1e-12 * scale, "{l:?} vs {reference:?}");
            }
            let old = drop_all(n, &w, &d);
            if (0..n).any(|k| gap(n, &w, &d, &old, k) < -1e-12) {
                re_added += 1;
            }
        }
        assert!(checked >= 150, "{checked} uniquely solvable problems");
        // The sample exercises the pivoting: the old solve leaves penetrations in some.
        assert!(re_added >= 5, "{re_added} problems needed a pivot");
    }

    #[test]
    fn a_singular_contact_matrix_is_an_error() {
        let w = [1.0, 1.0, 1.0, 1.0];
        assert_eq!(
            solve(2, &w, &[-1.0, -1.0]),
            Err(ContactSolveError::Singular { active: 2 })
        );
    }
}
