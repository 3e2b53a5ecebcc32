//! Contact at the casing's free edges (issue 39): where a blade tip overhangs an edge of the
//! casing surface, its closest point is pinned to the edge and its gap `d = n · (x − S)` is
//! measured along the edge's normal from a point `x − S` that is not along that normal. The
//! casing's correction then changes the gap at first order not only by moving the surface
//! (`−n · ΔS`, the translation that box 4b models) but by turning its normal,
//! `δn · (x − S)` with `δn = −(n · ΔS_u) a^u − (n · ΔS_v) a^v` (`a^u`, `a^v` the dual basis
//! of the tangents `S_u`, `S_v`), and by sliding the closest point along the edge (where the
//! distance, not the gap, is stationary). Away from the edges `x − S` lies along `n`, `δn · n`
//! is of second order and the gap is stationary along the surface, so the translation alone
//! is exact there to the Newton iterations' order. Here: the slopes `∂V/∂u`, `∂V/∂v` of the
//! casing's flexibility at a surface point, the edge rows of `W` with the normal's rotation,
//! and the corrected gap at an edge, at the corrected closest point along the corrected
//! surface's own normal.

use super::*;
use crate::contact::Along;

/// Whether `x − S` (m) of a projection on a free edge has a part off the normal: the tip
/// overhangs the edge. Below round-off of the point's coordinates (relative 1e-12 of `|x|`)
/// it does not: the projection is an interior one that lies on the edge.
fn overhang(x: &Vector3<f64>, at: &Projection) -> Option<Vector3<f64>> {
    let r = x - at.point;
    let off = r - at.normal * at.normal.dot(&r);
    (off.norm() > 1e-12 * x.norm()).then_some(r)
}

/// The lever arms `(a^u · r, a^v · r)` of the normal's rotation at a surface point of
/// tangents `su`, `sv` (per unit of patch coordinate), for `r = x − S` (m): the normal's
/// change under slopes `ΔS_u`, `ΔS_v` of the surface's correction moves the gap by
/// `−(n · ΔS_u) a^u · r − (n · ΔS_v) a^v · r` (`a^u`, `a^v` dual to the tangents).
fn levers(su: &Vector3<f64>, sv: &Vector3<f64>, r: &Vector3<f64>) -> (f64, f64) {
    let (guu, guv, gvv) = (su.dot(su), su.dot(sv), sv.dot(sv));
    let (ru, rv) = (su.dot(r), sv.dot(r));
    let det = guu * gvv - guv * guv;
    ((gvv * ru - guv * rv) / det, (guu * rv - guv * ru) / det)
}

/// Adds to the rows of `W` (box 4) of the candidates whose closest point `p_k` overhangs a
/// free edge the first-order change of their gap through the rotation of the casing's
/// normal under the loads of every candidate l: `∂d_k/∂λ_l += (n_k · V_u(p_k, p_l) f_l) a^u · r_k
/// + (n_k · V_v(p_k, p_l) f_l) a^v · r_k`, `r_k = x_k − S(p_k)` of the predicted tip node and
/// surface (`proj`: the projection of every tip node). With it the Newton iterations of box
/// 4b converge at the edges as fast as away from them. Leaves the slopes at `p_k` in
/// `c.vslope` (box 4b takes its own, at `p̂_k`).
pub(super) fn edge_rows_of_w(
    cs: &CasingSide,
    f: &FlexibleCasing,
    c: &mut ContactProblem,
    nodes: &[Vector3<f64>],
    proj: &[Projection],
) -> Result<(), SimError> {
    let nk = c.cands.len();
    for k in 0..nk {
        let cd = c.cands[k];
        let at = &proj[cd.node];
        if !cs.spline.on_free_edge(&at.param) {
            continue;
        }
        let Some(r) = overhang(&nodes[cd.node], at) else {
            continue;
        };
        let p = at.param;
        let e = cs.spline.eval_unchecked(&cs.q, p.i, p.j, p.u, p.v);
        let (lu, lv) = levers(&e.su, &e.sv, &r);
        c.vslope[k * nk..(k + 1) * nk].fill(None);
        slopes_at(f, &cs.spline, c, (k, &p), |_, _| true)?;
        for l in 0..nk {
            if let Some([bu, bv]) = &c.vslope[k * nk + l] {
                let fl = c.cands[l].fdir;
                c.w[k * nk + l] += lu * cd.n.dot(&(bu * fl)) + lv * cd.n.dot(&(bv * fl));
            }
        }
    }
    Ok(())
}

/// Candidate k's gap (m) to the corrected casing where its closest point is pinned to a free
/// edge. `at` is the closest point of `y = x − ΔS(p̂_k)` (the corrected tip node `x` moved
/// back by the casing's correction at `p̂_k`) on the predicted surface `S`; the corrected
/// surface about `p̂_k` is `S + ΔS(p̂_k) + ΔS_u δu + ΔS_v δv`, with the slopes `ΔS_a = −Σ_l
/// ∂V(p̂_k, p_l)/∂a F_l` over the loaded candidates (kept in `c.vslope` while `p̂_k` stays
/// put). Two things differ from the translated surface at the edge, both at first order in
/// the correction because `x − S` is not along the normal there: the normal turns, `n' ∝
/// −(S_u + ΔS_u) × (S_v + ΔS_v)`, and the closest point slides along the edge, where
/// `(S_u + ΔS_u) · (x − S')` vanishes instead of `S_u · (y − S)` (a Newton step along the
/// edge, its Hessian the predicted surface's). The gap is `n' · (x − S')` there. Where the
/// slide is long enough that the blocks taken at `p̂_k` would miss more than a quarter of
/// `tol` (m) at the slid point (their change along it estimated by the slopes themselves, the
/// flexibility varying over a patch), `p̂_k` moves there, its blocks are taken again and
/// the step repeated (at most [`EDGE_SLIDES`] times). `None` where `at` is not on a free
/// edge or `y` does not overhang it: the translated surface's gap is exact there.
pub(super) fn edge_gap(
    cs: &CasingSide,
    f: &FlexibleCasing,
    c: &mut ContactProblem,
    k: usize,
    (at, x, tol): (&Projection, &Vector3<f64>, f64),
) -> Result<Option<f64>, SimError> {
    if !cs.spline.on_free_edge(&at.param) {
        return Ok(None);
    }
    let mut y = translated(*x, c, k);
    if overhang(&y, at).is_none() {
        return Ok(None);
    }
    let nk = c.cands.len();
    let mut p = at.param;
    for slide in 1..=EDGE_SLIDES {
        let phat = c.phat[k];
        slopes_at(f, &cs.spline, c, (k, &phat), |c, l| c.lambda[l] != 0.0)?;
        let (mut dsu, mut dsv) = (Vector3::zeros(), Vector3::zeros());
        for (l, (b, lb)) in c.cands.iter().zip(&c.lambda).enumerate() {
            if let (Some([vu, vv]), true) = (&c.vslope[k * nk + l], *lb != 0.0) {
                let force = b.fdir * *lb;
                dsu -= vu * force;
                dsv -= vv * force;
            }
        }
        let e = cs.spline.eval_unchecked(&cs.q, p.i, p.j, p.u, p.v);
        let r = y - e.s;
        let (su, sv) = (e.su + dsu, e.sv + dsv);
        // Along the edge to the corrected surface's closest point: `y − S` is `x` less the
        // corrected surface point at `p`.
        let du = su.dot(&r) / (su.dot(&su) - e.suu.dot(&r));
        let missed = (dsu.norm() + dsv.norm()) * du.abs() * (r.norm() / sv.norm() + du.abs());
        if missed <= 0.25 * tol || slide == EDGE_SLIDES {
            let r = r - su * du - e.suu * (0.5 * du * du);
            let (su, sv) = (su + e.suu * du, sv + e.suv * du);
            let raw = -su.cross(&sv);
            let normal = raw * (cs.spline.normal_sign() / raw.norm());
            return Ok(Some(normal.dot(&r)));
        }
        p = slid(&cs.spline, &p, du);
        c.phat[k] = p;
        c.vhat[k * nk..(k + 1) * nk].fill(None);
        c.vslope[k * nk..(k + 1) * nk].fill(None);
        casing_blocks_at(f, &cs.spline, c, k)?;
        y = translated(*x, c, k);
    }
    unreachable!("the last slide returns")
}

/// Most Newton steps along a free edge per gap ([`edge_gap`]).
const EDGE_SLIDES: usize = 3;

/// The surface point `du` patch lengths from `p` along the circumference (wrapped around the
/// closing line), on the same meridian patch and `v`.
fn slid(spline: &CasingSpline, p: &SurfaceParam, du: f64) -> SurfaceParam {
    let n = spline.n_sectors();
    let g = (p.i as f64 + p.u + du).rem_euclid(n as f64);
    let i = (g.floor() as usize).min(n - 1);
    SurfaceParam {
        i,
        u: (g - i as f64).clamp(0.0, 1.0),
        ..*p
    }
}

/// The slopes `∂V(p, p_l)/∂u` and `∂V(p, p_l)/∂v` (m/N per unit of patch coordinate, global)
/// of the casing's flexibility blocks from the candidates' load points `p_l` to the surface
/// point `p`, into `c.vslope[k · nk + l]` for the candidates l that `want(c, l)` and that lack
/// them: how the displacement under a unit force at `p_l` changes along the surface at `p`
/// (the fast kernel's table with the basis' derivative at `p`; the dense kernel's flexibility
/// through the spline weights' derivative, as in [`dense_pair_blocks`], every l at once).
fn slopes_at(
    f: &FlexibleCasing,
    spline: &CasingSpline,
    c: &mut ContactProblem,
    (k, p): (usize, &SurfaceParam),
    want: impl Fn(&ContactProblem, usize) -> bool,
) -> Result<(), SimError> {
    let nk = c.cands.len();
    let missing = |c: &ContactProblem, l: usize| want(c, l) && c.vslope[k * nk + l].is_none();
    match &f.kernel {
        Kernel::Modal { table, .. } => {
            let (at_u, at_v) = (table.weights_of(Along::U, p), table.weights_of(Along::V, p));
            for l in 0..nk {
                if missing(c, l) {
                    let pair = c.patch_blocks(table, (k, l), [&at_u, &at_v]);
                    c.vslope[k * nk + l] = Some(pair);
                }
            }
        }
        Kernel::Dense { .. } if !(0..nk).any(|l| missing(c, l)) => {}
        Kernel::Dense { flexibility, .. } => {
            let at = Cand {
                param: *p,
                ..c.cands[k]
            };
            let pair: Vec<Cand> = std::iter::once(at).chain(c.cands.iter().copied()).collect();
            let n = pair.len();
            let mut blocks = [vec![Matrix3::zeros(); n * n], vec![Matrix3::zeros(); n * n]];
            for (along, all) in [Along::U, Along::V].into_iter().zip(&mut blocks) {
                dense_pair_blocks(
                    f,
                    flexibility,
                    spline,
                    &pair,
                    all,
                    (&mut c.wu, &mut c.wv),
                    along,
                )?;
            }
            for l in 0..nk {
                c.vslope[k * nk + l] = Some([blocks[0][l + 1], blocks[1][l + 1]]);
            }
        }
    }
    Ok(())
}
