//! Box 4 of the time step (the paper's Figs. 4 and 11): the contact problem of a step, its
//! candidates, the Delassus operator `W = G A⁻¹ Gᵀ` of both structures (eq. 18), and the gaps
//! of the corrected state with the casing surface moved by the correction.

use super::*;

/// One contact candidate of the current step.
#[derive(Clone, Copy, Debug)]
pub(super) struct Cand {
    pub(super) node: usize,
    pub(super) blade: usize,
    pub(super) row: usize,
    pub(super) n: Vector3<f64>,
    pub(super) fdir: Vector3<f64>,
    pub(super) slip: bool,
    pub(super) g_loc: Vector3<f64>,
    pub(super) f_loc: Vector3<f64>,
    pub(super) param: SurfaceParam,
}

impl Cand {
    /// Adds its force `λ · f_loc` (N, `lambda` its multiplier) to the impeller's boundary
    /// forces `fi` (sector-major, `nbi` DOFs per blade).
    pub(super) fn add_blade_force(&self, lambda: f64, nbi: usize, fi: &mut [f64]) {
        let at = &mut fi[self.blade * nbi + 3 * self.row..][..3];
        at.iter_mut()
            .zip(self.f_loc.iter())
            .for_each(|(x, f)| *x += lambda * f);
    }

    /// Adds the casing's share `−λ · fdir` (N, global) of its force to the casing load `fc`
    /// ([`CasingFrames::add_force`]; `scratch` of lengths N and M); returns that force.
    pub(super) fn add_casing_force(
        &self,
        lambda: f64,
        (frames, spline): (&CasingFrames, &CasingSpline),
        scratch: (&mut [f64], &mut [f64]),
        fc: &mut [f64],
    ) -> Result<Vector3<f64>, SimError> {
        let force = self.fdir * (-lambda);
        frames.add_force(spline, &self.param, &force, scratch, fc)?;
        Ok(force)
    }

    /// Blade-tip node `node` (blade-major, `n_contact` per blade) as a candidate at its
    /// projection `p`, before its friction direction is known.
    pub(super) fn at(node: usize, n_contact: usize, p: &Projection) -> Self {
        Cand {
            node,
            blade: node / n_contact,
            row: node % n_contact,
            n: p.normal,
            fdir: p.normal,
            slip: false,
            g_loc: Vector3::zeros(),
            f_loc: Vector3::zeros(),
            param: p.param,
        }
    }
}

/// Most Newton iterations on the gaps of a casing surface per step (see
/// `Simulation::refine_contact`). With `W` kept, each removes the second-order part of what
/// is left while the response is small, and two or three settle a step; under a runaway the
/// surface's rotation makes them converge linearly (a factor of about 0.15 per iteration in
/// case study 2 at 1.18 Ω*₅), and ten keep the contact exact until the watch confirms it.
pub(super) const GAP_NEWTON_ITERATIONS: usize = 10;

/// The gaps `d_k` (m) of the contact candidates after the correction of multipliers λ,
/// without applying it: the corrected tip node `x_k + R(Ωt) R(θ_s) Δu_k(λ)` projected on the
/// predicted casing surface translated by the casing's correction where it projects,
/// `ΔS(p̂_k) = −Σ_l V(p̂_k, p_l) F_l` (see `Simulation::refine_contact`). The first call of a
/// step finds `p̂_k` with the candidates' own blocks `V(p_k, p_l)`; an inactive candidate
/// then open by more than twice that translation (plus `tol`, m) stays open whatever the
/// blocks at `p̂_k` and is not looked at again this step; the others take `V(p̂_k, p_l)` of
/// the loaded candidates, kept while `p̂_k` does not move. The later projections of a step
/// move the point by round-off to a few nm: one Newton iteration on the surface kept from
/// the last full projection ([`reproject`]).
pub(super) fn corrected_gaps(
    blades: &Blades,
    cs: &CasingSide,
    r_om: &Matrix3<f64>,
    c: &mut ContactProblem,
    p: &Projector,
    (time, tol): (f64, f64),
) -> Result<(), SimError> {
    let nk = c.cands.len();
    for k in 0..nk {
        let cd = &c.cands[k];
        let du = blade_correction(&blades.kernel, blades.nb, &c.cands, &c.lambda, cd);
        let x = blades.nodes[cd.node] + r_om * (blades.rot[cd.blade] * du);
        let Some(flexible) = &cs.flexible else {
            c.d[k] = project_one(cs, &x, cd.param, p, time)?.0.gap;
            continue;
        };
        let mut shift = None;
        if !c.blocks_taken[k] {
            let mut t0 = Vector3::zeros();
            for (l, (b, lb)) in c.cands.iter().zip(&c.lambda).enumerate() {
                t0 += c.vblk[k * nk + l] * (b.fdir * *lb);
            }
            let first;
            (first, c.local[k]) = project_one(cs, &(x + t0), cd.param, p, time)?;
            // At a free edge the normal's rotation moves the gap too (`free_edge`).
            let pinned = cs.spline.on_free_edge(&first.param);
            if c.lambda[k] == 0.0 && !pinned && first.gap > 2.0 * t0.norm() + tol {
                // Open whatever the blocks where it projects; looked at again after a new λ.
                c.d[k] = first.gap;
                continue;
            }
            (c.phat[k], c.blocks_taken[k], shift) = (first.param, true, Some(t0));
        }
        casing_blocks_at(flexible, &cs.spline, c, k)?;
        let mut y = translated(x, c, k);
        if let Some(t0) = shift {
            // How fast the casing's correction changes along the surface (m per unit of
            // patch coordinates): from p_k to p̂_k.
            let step = param_distance(&c.phat[k], &c.cands[k].param);
            c.translation_rate[k] = (y - x - t0).norm() / step.max(f64::EPSILON);
        }
        let mut at = reproject(cs, &y, (&mut c.local[k], c.phat[k]), p, time)?;
        // What blocks taken at p̂_k would miss in the gap, were the closest point now at.
        let stale = c.translation_rate[k] * param_distance(&at.param, &c.phat[k]);
        if stale > 0.25 * tol {
            c.phat[k] = at.param;
            c.vhat[k * nk..(k + 1) * nk].fill(None);
            c.vslope[k * nk..(k + 1) * nk].fill(None);
            casing_blocks_at(flexible, &cs.spline, c, k)?;
            y = translated(x, c, k);
            at = reproject(cs, &y, (&mut c.local[k], c.phat[k]), p, time)?;
        }
        c.phat[k] = at.param;
        c.d[k] = free_edge::edge_gap(cs, flexible, c, k, (&at, &x, tol))?.unwrap_or(at.gap);
    }
    Ok(())
}

/// `x + Σ_l V(p̂_k, p_l) F_l`: the point whose gap to the predicted surface is candidate k's
/// gap to the corrected one.
pub(super) fn translated(x: Vector3<f64>, c: &ContactProblem, k: usize) -> Vector3<f64> {
    let nk = c.cands.len();
    let mut y = x;
    for (l, (b, lb)) in c.cands.iter().zip(&c.lambda).enumerate() {
        if let Some(v) = &c.vhat[k * nk + l] {
            y += v * (b.fdir * *lb);
        }
    }
    y
}

/// Distance between two surface points in patch coordinates, `|Δ(i + u)| + |Δ(j + v)|`: what
/// [`corrected_gaps`] scales the casing correction's rate by (it ignores the circumference's
/// seam, where it reads large).
pub(super) fn param_distance(a: &SurfaceParam, b: &SurfaceParam) -> f64 {
    let along = |i: usize, u: f64| i as f64 + u;
    (along(a.i, a.u) - along(b.i, b.u)).abs() + (along(a.j, a.v) - along(b.j, b.v)).abs()
}

/// The closest point of `x` on the predicted casing surface, from `warm` (at time `time`, s),
/// and the surface about it.
pub(super) fn project_one(
    cs: &CasingSide,
    x: &Vector3<f64>,
    warm: SurfaceParam,
    p: &Projector,
    time: f64,
) -> Result<(Projection, LocalSurface), SimError> {
    closest_point_local(&cs.spline, &cs.q, *x, Some(warm), p.eps)
        .map_err(|source| projection_failed(time)(NodeProjectionError { node: 0, source }))
}

/// [`project_one`] for a point `x` near one projected before, about whose closest point
/// `local` holds the surface: when one Newton iteration from there meets ε_NR, the projection
/// is that iteration's ([`LocalSurface::reproject`], no spline evaluation); otherwise `x` is
/// projected from `warm` and `local` moves to its closest point.
pub(super) fn reproject(
    cs: &CasingSide,
    x: &Vector3<f64>,
    (local, warm): (&mut LocalSurface, SurfaceParam),
    p: &Projector,
    time: f64,
) -> Result<Projection, SimError> {
    if let Some(near) = local.reproject(&cs.spline, *x, p.eps) {
        return Ok(near);
    }
    let (at, surface) = project_one(cs, x, warm, p, time)?;
    *local = surface;
    Ok(at)
}

/// The blocks `V(p̂_k, p_l)` of candidate k against the loaded candidates l (λ_l ≠ 0) that
/// it lacks (the fast kernel's table; the dense kernel's flexibility through the spline
/// weights, as in [`casing_w`], all of them at once).
pub(super) fn casing_blocks_at(
    f: &FlexibleCasing,
    spline: &CasingSpline,
    c: &mut ContactProblem,
    k: usize,
) -> Result<(), SimError> {
    let nk = c.cands.len();
    match &f.kernel {
        Kernel::Modal { table, .. } => {
            let at = table.weights(&c.phat[k]);
            for l in 0..nk {
                if c.lambda[l] != 0.0 && c.vhat[k * nk + l].is_none() {
                    let [v] = c.patch_blocks(table, (k, l), [&at]);
                    c.vhat[k * nk + l] = Some(v);
                }
            }
        }
        Kernel::Dense { .. } if c.vhat[k * nk..(k + 1) * nk].iter().all(Option::is_some) => {}
        Kernel::Dense { flexibility, .. } => {
            let at = Cand {
                param: c.phat[k],
                ..c.cands[k]
            };
            let pair: Vec<Cand> = std::iter::once(at).chain(c.cands.iter().copied()).collect();
            let mut blocks = vec![Matrix3::zeros(); (nk + 1) * (nk + 1)];
            dense_pair_blocks(
                f,
                flexibility,
                spline,
                &pair,
                &mut blocks,
                (&mut c.wu, &mut c.wv),
                Along::Point,
            )?;
            for l in 0..nk {
                c.vhat[k * nk + l] = Some(blocks[l + 1]);
            }
        }
    }
    Ok(())
}

/// The closest points of the blade-tip nodes on the casing and their gaps (paper §3.1).
pub(super) struct Projector {
    pub(super) bounds: GapBounds,
    pub(super) warm: Vec<Option<SurfaceParam>>,
    pub(super) proj: Vec<Projection>,
    /// Newton–Raphson tolerance ε_NR.
    pub(super) eps: f64,
    /// Nodes provably farther than this from the casing are not projected (m): a rub starts
    /// at gap 0, a coating reacts from its thickness on.
    pub(super) margin: f64,
    /// Scratch of the residual re-projection.
    pub(super) res_proj: Vec<Projection>,
    pub(super) res_warm: Vec<Option<SurfaceParam>>,
}

/// The contact problem of a step (eq. 18) and its buffers, allocated once.
pub(super) struct ContactProblem {
    pub(super) cands: Vec<Cand>,
    pub(super) w: Vec<f64>,
    pub(super) d: Vec<f64>,
    pub(super) lambda: Vec<f64>,
    pub(super) active: Vec<usize>,
    pub(super) lu: Vec<f64>,
    pub(super) rhs: Vec<f64>,
    /// Casing flexibility blocks `V(k, l)` (m/N, global) between the candidates' surface points,
    /// and the points' weights on the control net (fast kernel).
    pub(super) vblk: Vec<Matrix3<f64>>,
    pub(super) weights: Vec<ControlWeights>,
    /// Box 4b: `V(p̂_k, p_l)` between the point `p̂_k` where candidate k projects after the
    /// correction and the load points, computed once per step when first needed.
    pub(super) vhat: Vec<Option<Matrix3<f64>>>,
    /// Their slopes along the surface at `p̂_k`, `∂V(p̂_k, p_l)/∂u` and `/∂v`, where candidate
    /// k overhangs a free edge (see `free_edge`).
    pub(super) vslope: Vec<Option<[Matrix3<f64>; 2]>>,
    /// The flexibility from load point l to the patch where candidate k's blocks were last
    /// taken (fast kernel, [`PatchFlexibility`]): box 4b's blocks and slopes on that patch
    /// come from it while it is for that patch and load point (in practice, one step).
    pub(super) patch: Vec<Option<PatchFlexibility>>,
    /// `p̂_k` of each candidate, whether its blocks are taken there, and whether it was
    /// found open with a margin (box 4b).
    pub(super) phat: Vec<SurfaceParam>,
    pub(super) blocks_taken: Vec<bool>,
    /// The casing surface about the closest point of each candidate's last exact projection
    /// (box 4b): the later ones in the step move the point by far less than a patch.
    pub(super) local: Vec<LocalSurface>,
    /// Per candidate: how fast the casing's correction changes along the surface between
    /// `p_k` and `p̂_k` (m per unit of patch coordinates).
    pub(super) translation_rate: Vec<f64>,
    /// Boundary forces (N, sector-major) on the impeller and the casing.
    pub(super) fi: Vec<f64>,
    pub(super) fc: Vec<f64>,
    pub(super) wu: Vec<f64>,
    pub(super) wv: Vec<f64>,
    /// Lagrange loads on the casing surface, and the casing points the candidates touch after
    /// the correction (the next step's [`PastSurface`]).
    pub(super) loads: Vec<(SurfaceParam, Vector3<f64>)>,
    pub(super) touched: Vec<Option<(SurfaceParam, Vector3<f64>)>>,
    /// Normal and friction force per blade (N) of the step.
    pub(super) force_n: Vec<f64>,
    pub(super) force_t: Vec<f64>,
    /// With a coating on a massless boundary, the law of the element each candidate presses
    /// (`None`: Lagrange contact with the casing), the plastic shortening of the step (m) and
    /// the buffers of [`coated_solve`]. `laws` is empty otherwise.
    pub(super) laws: Vec<Option<CoatingLaw>>,
    pub(super) plastic: Vec<f64>,
    pub(super) coated: CoatedBuffers,
}

impl ContactProblem {
    /// Buffers for every blade-tip node as a candidate, sized once (no allocation per step).
    pub(super) fn new(blades: &Blades, casing: &Casing) -> Self {
        let nn = blades.n_blades * blades.n_contact;
        let (ncs, rows) = casing
            .surface()
            .map_or((0, 0), |cs| (cs.n_sectors, cs.rows));
        let nbc = 3 * rows;
        ContactProblem {
            cands: Vec::with_capacity(nn),
            w: vec![0.0; nn * nn],
            d: vec![0.0; nn],
            lambda: vec![0.0; nn],
            active: Vec::with_capacity(nn),
            lu: Vec::with_capacity(nn * nn),
            rhs: Vec::with_capacity(nn),
            vblk: vec![
                Matrix3::zeros();
                if casing.flexible().is_some() {
                    nn * nn
                } else {
                    0
                }
            ],
            weights: vec![ControlWeights::default(); nn],
            vhat: vec![None; nn * nn],
            vslope: vec![None; nn * nn],
            patch: vec![None; nn * nn],
            blocks_taken: vec![false; nn],
            local: vec![LocalSurface::default(); nn],
            translation_rate: vec![0.0; nn],
            phat: vec![
                SurfaceParam {
                    i: 0,
                    j: 0,
                    u: 0.0,
                    v: 0.0
                };
                nn
            ],
            fi: vec![0.0; blades.n_blades * blades.nb],
            fc: vec![0.0; ncs * nbc],
            wu: vec![0.0; ncs],
            wv: vec![0.0; rows],
            loads: Vec::with_capacity(nn),
            touched: vec![None; nn],
            force_n: vec![0.0; blades.n_blades],
            force_t: vec![0.0; blades.n_blades],
            laws: Vec::with_capacity(nn),
            plastic: vec![0.0; nn],
            coated: CoatedBuffers::default(),
        }
    }

    /// Whether candidate `k` presses a coating element (massless boundary).
    pub(super) fn on_coating(&self, k: usize) -> bool {
        self.laws.get(k).is_some_and(Option::is_some)
    }

    /// The blocks `V(p, p_l)` (m/N, global) of the points (or tangents) of weights `at`, all
    /// on one patch, against load point l, from candidate k's [`PatchFlexibility`] for l,
    /// built first (or again) if it is of another patch.
    pub(super) fn patch_blocks<const N: usize>(
        &mut self,
        table: &ControlFlexTable,
        (k, l): (usize, usize),
        at: [&ControlWeights; N],
    ) -> [Matrix3<f64>; N] {
        let nk = self.cands.len();
        let (slot, load) = (&mut self.patch[k * nk + l], &self.weights[l]);
        if !slot.as_ref().is_some_and(|p| p.is_for(at[0], load)) {
            *slot = Some(table.patch_flexibility(at[0], load));
        }
        let patch = slot.as_ref();
        // A point's tangents share its patch; another patch's point takes the table's sums.
        at.map(|w| {
            patch
                .and_then(|p| p.block(w))
                .unwrap_or_else(|| table.weighted_pair_block(w, load))
        })
    }

    /// The multipliers of eq. (18) for the first `nk` candidates, gaps `d` and matrix `w`,
    /// the active set iterated to the gap tolerance `tol` (m); time `time` (s) for the error.
    pub(super) fn solve_multipliers(&mut self, tol: f64, time: f64) -> Result<(), SimError> {
        let nk = self.cands.len();
        let solved = if self.laws.is_empty() {
            active_set_solve(
                nk,
                &self.w[..nk * nk],
                &self.d[..nk],
                tol,
                &mut self.lambda,
                &mut self.active,
                &mut self.lu,
                &mut self.rhs,
            )
        } else {
            coated_solve(
                nk,
                &self.w[..nk * nk],
                &self.d[..nk],
                &self.laws,
                tol,
                &mut self.lambda,
                &mut self.plastic,
                &mut self.coated,
            )
        };
        solved.map(drop).map_err(|e| SimError::Diverged {
            time,
            reason: e.to_string(),
        })
    }
}

/// The correction (m, blade frame) of candidate `a`'s node by the forces `λ (n + μ t)` of the
/// `cands`, through the blade's boundary flexibility.
pub(super) fn blade_correction(
    kernel: &Kernel<NodeFlexTable>,
    nb: usize,
    cands: &[Cand],
    lambda: &[f64],
    a: &Cand,
) -> Vector3<f64> {
    let mut du = Vector3::zeros();
    for (b, l) in cands.iter().zip(lambda).filter(|(_, l)| **l != 0.0) {
        match kernel {
            Kernel::Modal { table, .. } => {
                du += table.block(a.blade, b.blade, a.row, b.row) * (b.f_loc * *l);
            }
            Kernel::Dense { flexibility, .. } => {
                let (ra, cb) = (a.blade * nb + 3 * a.row, b.blade * nb + 3 * b.row);
                for d in 0..3 {
                    for e in 0..3 {
                        du[d] += flexibility[(ra + d, cb + e)] * b.f_loc[e] * l;
                    }
                }
            }
        }
    }
    du
}

/// Adds the casing's `G_c A_c⁻¹ F_cᵀ` to `W`: control-point flexibility blocks of the
/// candidate pairs (fast kernel, kept in `vblk` for the lazy correction), or the dense
/// flexibility through `B̂ c` (eq. 18).
pub(super) fn casing_w(
    f: &FlexibleCasing,
    spline: &CasingSpline,
    c: &mut ContactProblem,
    nk: usize,
) -> Result<(), SimError> {
    let w = &mut c.w[..nk * nk];
    match &f.kernel {
        Kernel::Modal { table, .. } => {
            for (weights, cd) in c.weights.iter_mut().zip(&c.cands) {
                *weights = table.weights(&cd.param);
            }
            for (k, a) in c.cands.iter().enumerate() {
                for (l, b) in c.cands.iter().enumerate().skip(k) {
                    let v = table.weighted_pair_block(&c.weights[k], &c.weights[l]);
                    w[k * nk + l] += a.n.dot(&(v * b.fdir));
                    c.vblk[k * nk + l] = v;
                    if l != k {
                        w[l * nk + k] += b.n.dot(&(v.transpose() * a.fdir));
                        c.vblk[l * nk + k] = v.transpose();
                    }
                }
            }
        }
        Kernel::Dense { flexibility, .. } => {
            let (cands, blocks) = (&c.cands, &mut c.vblk[..nk * nk]);
            let weights = (&mut c.wu[..], &mut c.wv[..]);
            dense_pair_blocks(f, flexibility, spline, cands, blocks, weights, Along::Point)?;
            for (k, a) in c.cands.iter().enumerate() {
                for (l, b) in c.cands.iter().enumerate() {
                    w[k * nk + l] += a.n.dot(&(c.vblk[k * nk + l] * b.fdir));
                }
            }
        }
    }
    Ok(())
}

/// The dense casing's flexibility blocks `V(k, l)` (m/N, global) between the surface points
/// of `cands` (row-major `nk × nk`): `e_aᵀ V(k, l) e_b = g_a(p_k) H g_b(p_l)ᵀ` with the spline
/// weights of each point spread over the contact nodes in their sector frames (eq. 18). With
/// `first` along u or v, the rows of the first point take the weights of the tangent there
/// (`∂V(p_0, p_l)/∂u` or `/∂v` in the first row of blocks, see `free_edge`).
pub(super) fn dense_pair_blocks(
    f: &FlexibleCasing,
    flexibility: &Mat<f64>,
    spline: &CasingSpline,
    cands: &[Cand],
    blocks: &mut [Matrix3<f64>],
    (wu, wv): (&mut [f64], &mut [f64]),
    first: Along,
) -> Result<(), SimError> {
    let nk = cands.len();
    let (ncs, mc) = (f.frames.rot.len(), f.frames.rest_rows.len());
    let nbc = 3 * mc;
    let mut failed = None;
    let unit: Vec<Cand> = (cands.iter())
        .flat_map(|cd| {
            (0..3).map(move |a| Cand {
                n: Vector3::ith(a, 1.0),
                ..*cd
            })
        })
        .collect();
    let mut v = vec![0.0; 9 * nk * nk];
    dense_w(
        flexibility,
        &unit,
        3 * nk,
        &mut v,
        |row_of, cd, row, is_f| {
            let along = if row_of < 3 && !is_f {
                first
            } else {
                Along::Point
            };
            if let Err(e) = spline.node_weight_factors_of(along, &cd.param, wu, wv) {
                failed = Some(e);
                return;
            }
            for i in 0..ncs {
                let vl = f.frames.rot[i].transpose() * cd.n;
                for j in 0..mc {
                    let wgt = -wu[i] * wv[j];
                    for d in 0..3 {
                        row[i * nbc + 3 * j + d] = wgt * vl[d];
                    }
                }
            }
        },
    );
    if let Some(e) = failed {
        return Err(SimError::Spline(e.to_string()));
    }
    for (kl, blk) in blocks.iter_mut().enumerate() {
        let (k, l) = (kl / nk, kl % nk);
        *blk = Matrix3::from_fn(|a, b| v[(3 * k + a) * 3 * nk + 3 * l + b]);
    }
    Ok(())
}

/// Dense `W += G H Fᵀ` with full boundary rows produced by `fill(k, cand, row,
/// is_force_row)` for the k-th of `cands`.
pub(super) fn dense_w(
    hmat: &Mat<f64>,
    cands: &[Cand],
    nk: usize,
    w: &mut [f64],
    mut fill: impl FnMut(usize, &Cand, &mut [f64], bool),
) {
    let n = hmat.nrows();
    let mut g = Mat::<f64>::zeros(nk, n);
    let mut f = Mat::<f64>::zeros(n, nk);
    let mut row = vec![0.0; n];
    for (k, cd) in cands.iter().enumerate() {
        row.iter_mut().for_each(|x| *x = 0.0);
        fill(k, cd, &mut row, false);
        for (c, v) in row.iter().enumerate() {
            g[(k, c)] = *v;
        }
        row.iter_mut().for_each(|x| *x = 0.0);
        fill(k, cd, &mut row, true);
        for (c, v) in row.iter().enumerate() {
            f[(c, k)] = *v;
        }
    }
    let mut hf = Mat::<f64>::zeros(n, nk);
    matmul(
        hf.as_mut(),
        Accum::Replace,
        hmat.as_ref(),
        f.as_ref(),
        1.0,
        Par::Seq,
    );
    let mut gw = Mat::<f64>::zeros(nk, nk);
    matmul(
        gw.as_mut(),
        Accum::Replace,
        g.as_ref(),
        hf.as_ref(),
        1.0,
        Par::Seq,
    );
    for k in 0..nk {
        for l in 0..nk {
            w[k * nk + l] += gw[(k, l)];
        }
    }
}
