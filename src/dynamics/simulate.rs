//! The time loop (paper Fig. 4): predict both structures, rebuild the casing spline from the
//! predicted casing contact nodes (the fast kernel gives its control points directly, see
//! `CasingFrames`), project every blade-tip node, and when some gap is negative solve the
//! contact problem and correct both structures.

use crate::contact::spline::{cubic_basis, real_row_weights};
use crate::contact::{
    CasingSpline, GapBounds, NodeProjectionError, Projection, SurfaceParam, friction_direction,
    project_nodes,
};
use crate::dynamics::abradable::{AbradableError, CoatingLayer, ElementUpdate};
use crate::dynamics::contact_solve::{ControlFlexTable, NodeFlexTable, active_set_solve, rot_z};
use crate::dynamics::dense::DenseKernel;
use crate::dynamics::kernel::StructureKernel;
use crate::dynamics::modal::ModalKernel;
use crate::dynamics::numerics::KernelChoice;
use crate::dynamics::probes::{CoatingOutput, SimulationOutput, Stage, StageClock};
use crate::dynamics::scenario::{Case, CasingModel, CoatingCase};
use crate::dynamics::structure::{Structure, StructureError};
use crate::model::rom::CyclicRom;
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, Ordering};
use thiserror::Error;

/// Why a simulation could not run or stopped.
#[derive(Debug, Error)]
pub enum SimError {
    #[error("invalid case: {0}")]
    InvalidCase(String),
    #[error(transparent)]
    Structure(#[from] StructureError),
    #[error(
        "time step h = {h:.4e} s is at or above the explicit stability limit 2/ω_max = {limit:.4e} s (ω_max = {omega_max:.4e} rad/s, {which}){rev}"
    )]
    Unstable {
        h: f64,
        limit: f64,
        omega_max: f64,
        which: String,
        rev: String,
    },
    #[error("casing spline: {0}")]
    Spline(String),
    #[error("closest-point projection failed at t = {time:.6e} s: {reason}")]
    Projection { time: f64, reason: String },
    #[error("simulation diverged at t = {time:.6e} s: {reason}")]
    Diverged { time: f64, reason: String },
    #[error("simulation cancelled at t = {time:.6e} s")]
    Cancelled { time: f64 },
    #[error("abradable coating: {0}")]
    Coating(#[from] AbradableError),
}

/// Radial unit vector of a reference position (m) in its own frame.
fn radial(p: &[f64; 3]) -> Vector3<f64> {
    let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
    if r > 0.0 {
        Vector3::new(p[0] / r, p[1] / r, 0.0)
    } else {
        Vector3::new(1.0, 0.0, 0.0)
    }
}

/// One contact candidate of the current step.
#[derive(Clone, Copy, Debug)]
struct Cand {
    node: usize,
    blade: usize,
    row: usize,
    n: Vector3<f64>,
    fdir: Vector3<f64>,
    slip: bool,
    g_loc: Vector3<f64>,
    f_loc: Vector3<f64>,
    param: SurfaceParam,
}

/// Simulates `case` for `impeller` rotating inside `casing` (paper Fig. 4). Checks the stability
/// limit, builds both kernels, runs the explicit loop, and records the probes of
/// [`SimulationOutput`]. `cancel` is polled every 1024 steps.
pub fn simulate(
    case: &Case,
    impeller: &CyclicRom,
    casing: &CasingModel,
    cancel: Option<&AtomicBool>,
) -> Result<SimulationOutput, SimError> {
    let num = &case.numerics;
    num.validate().map_err(SimError::InvalidCase)?;
    let bad = |m: String| Err(SimError::InvalidCase(m));
    if !case.omega.is_finite() {
        return bad(format!("omega = {} rad/s must be finite", case.omega));
    }
    if !(case.duration.is_finite() && case.duration > 0.0) {
        return bad(format!("duration = {} s must be > 0", case.duration));
    }
    if !(case.friction.is_finite() && case.friction >= 0.0) {
        return bad(format!("friction = {} must be ≥ 0", case.friction));
    }
    let h = num.time_step;
    let mu = case.friction;

    // Structures and the stability limit.
    let st_i = Structure::new(impeller, case.omega)?;
    let st_c = match casing {
        CasingModel::Flexible(rom) => Some(Structure::new(rom, 0.0)?),
        CasingModel::Rigid(_) => None,
    };
    let (mut limit, mut omega_max, mut which) = (
        st_i.stability_limit(),
        st_i.omega_max,
        format!("impeller `{}`", st_i.name),
    );
    if let Some(c) = &st_c
        && c.stability_limit() < limit
    {
        (limit, omega_max, which) = (
            c.stability_limit(),
            c.omega_max,
            format!("casing `{}`", c.name),
        );
    }
    let steps_per_rev = if case.omega != 0.0 {
        2.0 * PI / (case.omega.abs() * h)
    } else {
        f64::INFINITY
    };
    if h >= limit {
        let rev = if case.omega != 0.0 {
            format!(
                "; at Ω = {} rad/s one revolution needs at least {:.0} steps (h gives {:.0})",
                case.omega,
                (2.0 * PI / (case.omega.abs() * limit)).ceil(),
                steps_per_rev
            )
        } else {
            String::new()
        };
        return Err(SimError::Unstable {
            h,
            limit,
            omega_max,
            which,
            rev,
        });
    }

    // Impeller geometry.
    let nbl = impeller.n_sectors;
    let nci = impeller.n_contact();
    let nbi = 3 * nci;
    let rows_i: Vec<usize> = impeller.contact_nodes.iter().map(|c| c.row).collect();
    let n_rows = rows_i.iter().max().map_or(0, |r| r + 1);
    if !case.clearance_offset.is_empty() && case.clearance_offset.len() != n_rows {
        return bad(format!(
            "clearance_offset has {} entries, the impeller has {} contact rows",
            case.clearance_offset.len(),
            n_rows
        ));
    }
    let er_i: Vec<Vector3<f64>> = impeller
        .contact_nodes
        .iter()
        .map(|c| radial(&c.position))
        .collect();
    let x_i: Vec<Vector3<f64>> = impeller
        .contact_nodes
        .iter()
        .enumerate()
        .map(|(j, c)| {
            let off = case.clearance_offset.get(c.row).copied().unwrap_or(0.0);
            Vector3::from(c.position) + er_i[j] * off
        })
        .collect();
    let le = (0..nci).min_by_key(|&j| rows_i[j]).unwrap_or(0);
    let te = (0..nci).max_by_key(|&j| rows_i[j]).unwrap_or(0);
    let alpha_i = 2.0 * PI / nbl as f64;
    let rot_i: Vec<Matrix3<f64>> = (0..nbl).map(|s| rot_z(s as f64 * alpha_i)).collect();

    // Casing geometry and spline.
    let (ncs, mc, y_c, rest_nodes) = match casing {
        CasingModel::Flexible(rom) => {
            let m = rom.n_contact();
            for (j, c) in rom.contact_nodes.iter().enumerate() {
                if c.row != j {
                    return bad(format!(
                        "casing contact node {j} has row {}: casing nodes must be ordered by row 0..M",
                        c.row
                    ));
                }
            }
            let a = 2.0 * PI / rom.n_sectors as f64;
            let y: Vec<Vector3<f64>> = rom
                .contact_nodes
                .iter()
                .map(|c| Vector3::from(c.position))
                .collect();
            let mut rest = Vec::with_capacity(rom.n_sectors * m);
            for i in 0..rom.n_sectors {
                for yj in &y {
                    rest.push(rot_z(i as f64 * a) * yj);
                }
            }
            (rom.n_sectors, m, y, rest)
        }
        CasingModel::Rigid(r) => {
            let pts = r.data_points().map_err(SimError::InvalidCase)?;
            (r.n_sectors, r.meridian.len(), vec![], pts)
        }
    };
    let mut spline = CasingSpline::new(ncs, mc).map_err(|e| SimError::Spline(e.to_string()))?;
    spline
        .orient_toward_axis(&rest_nodes)
        .map_err(|e| SimError::Spline(e.to_string()))?;
    let alpha_c = 2.0 * PI / ncs as f64;
    let rot_c: Vec<Matrix3<f64>> = (0..ncs).map(|i| rot_z(i as f64 * alpha_c)).collect();
    let er_c: Vec<Vector3<f64>> = match casing {
        CasingModel::Flexible(rom) => rom
            .contact_nodes
            .iter()
            .map(|c| radial(&c.position))
            .collect(),
        CasingModel::Rigid(_) => vec![],
    };
    for p in &case.casing_probes {
        if st_c.is_none() || p[0] >= ncs || p[1] >= mc {
            return bad(format!(
                "casing probe {p:?} is not a contact node of a flexible casing"
            ));
        }
    }

    // Kernels and flexibility.
    let nbc = 3 * mc;
    let fast = num.kernel == KernelChoice::Fast;
    let (mut tab_i, mut tab_c, mut hd_i, mut hd_c) = (None, None, None, None);
    let mut ki: Box<dyn StructureKernel>;
    let mut kc: Option<Box<dyn StructureKernel>> = None;
    if fast {
        ki = Box::new(ModalKernel::new(&st_i, h)?);
        tab_i = Some(NodeFlexTable::build(ki.as_mut()));
        if let Some(s) = &st_c {
            let mut k: Box<dyn StructureKernel> = Box::new(ModalKernel::new(s, h)?);
            tab_c = Some(ControlFlexTable::build(k.as_mut(), &spline));
            kc = Some(k);
        }
    } else {
        let k = DenseKernel::new(&st_i, h);
        hd_i = Some(k.boundary_flexibility().to_owned());
        ki = Box::new(k);
        if let Some(s) = &st_c {
            let k = DenseKernel::new(s, h);
            hd_c = Some(k.boundary_flexibility().to_owned());
            kc = Some(Box::new(k));
        }
    }

    // Casing load pattern, scaled to the requested static displacement.
    if let Some(load) = &case.load {
        let (Some(stc), Some(k)) = (&st_c, kc.as_mut()) else {
            return bad("a casing load needs a flexible casing".into());
        };
        if load.lobes == 0
            || !(load.static_displacement.is_finite())
            || load.ramp_time.is_nan()
            || load.ramp_time <= 0.0
            || load.hold_time.is_nan()
            || load.hold_time < 0.0
        {
            return bad(format!(
                "load {load:?}: lobes ≥ 1, finite δ, ramp_time > 0 and hold_time ≥ 0 required"
            ));
        }
        let te_c = mc - 1;
        let mut pat = vec![0.0; ncs * nbc];
        for i in 0..ncs {
            let f = -er_c[te_c] * (load.lobes as f64 * i as f64 * alpha_c).cos();
            for d in 0..3 {
                pat[i * nbc + 3 * te_c + d] = f[d];
            }
        }
        let mut stat = vec![0.0; ncs * nbc];
        let mut mk = ModalKernel::new(stc, h)?;
        mk.static_boundary(&pat, &mut stat)
            .map_err(SimError::InvalidCase)?;
        let peak = (0..ncs)
            .map(|i| {
                let u = Vector3::new(
                    stat[i * nbc + 3 * te_c],
                    stat[i * nbc + 3 * te_c + 1],
                    stat[i * nbc + 3 * te_c + 2],
                );
                -er_c[te_c].dot(&u)
            })
            .fold(0.0f64, f64::max);
        if peak.is_nan() || peak <= 0.0 {
            return bad("the casing load produces no inward static displacement".into());
        }
        let scale = load.static_displacement / peak;
        pat.iter_mut().for_each(|x| *x *= scale);
        k.set_load_pattern(&pat);
    }
    if let Some(v) = &case.initial_velocity.impeller {
        if v.len() != st_i.n_modal {
            return bad(format!(
                "initial impeller velocity has {} entries, expected {}",
                v.len(),
                st_i.n_modal
            ));
        }
        ki.set_initial_velocity(v);
    }
    if let Some(v) = &case.initial_velocity.casing {
        match (&st_c, kc.as_mut()) {
            (Some(s), Some(k)) if v.len() == s.n_modal => k.set_initial_velocity(v),
            _ => {
                return bad(
                    "initial casing velocity needs a flexible casing and one entry per DOF".into(),
                );
            }
        }
    }

    // Buffers (allocated once).
    let nn = nbl * nci;
    let mut gam = vec![Vector3::zeros(); nn];
    let mut gam_prev = vec![Vector3::zeros(); nn];
    for s in 0..nbl {
        for j in 0..nci {
            gam_prev[s * nci + j] = rot_i[s] * x_i[j];
        }
    }
    let mut pnodes = rest_nodes.clone();
    let mut q = vec![Vector3::zeros(); spline.n_control()];
    spline
        .control_points(&pnodes, &mut q)
        .map_err(|e| SimError::Spline(e.to_string()))?;
    // The fast kernel corrects the casing without refreshing its channels: the Lagrange loads
    // of a step then act on the surface through the control-point flexibility.
    let mut past = PastSurface {
        q: q.clone(),
        loads: vec![],
        flex: tab_c.as_ref(),
        touched: vec![None; nn],
    };
    let mut step_loads = Vec::with_capacity(nn);
    let mut touched = vec![None; nn];
    let mut vblk = vec![Matrix3::zeros(); if tab_c.is_some() { nn * nn } else { 0 }];
    let mut warm: Vec<Option<SurfaceParam>> = vec![None; nn];
    let mut proj = vec![Projection::default(); nn];
    // Nodes provably farther than this from the casing are not projected (a rub starts at gap
    // 0; a coating reacts from its thickness on).
    let mut gap_bounds = GapBounds::new(nn);
    let touch_margin = case.coating.as_ref().map_or(0.0, |c| c.material.thickness);
    let mut cands: Vec<Cand> = Vec::with_capacity(nn);
    let mut wmat = vec![0.0; nn * nn];
    let mut dvec = vec![0.0; nn];
    let mut lam = vec![0.0; nn];
    let (mut act, mut lu, mut rhs) = (
        Vec::with_capacity(nn),
        Vec::with_capacity(nn * nn),
        Vec::with_capacity(nn),
    );
    let mut fi = vec![0.0; nbl * nbi];
    let mut fc = vec![0.0; ncs * nbc];
    let (mut wu, mut wv) = (vec![0.0; ncs], vec![0.0; mc]);
    let mut res_proj = vec![Projection::default(); 1];
    let mut res_warm = vec![None; 1];
    let eps = num.newton_tolerance;
    let kmax_i = st_i.blocks.len();
    let mut nd_buf = vec![0.0; kmax_i];
    let mut force_n = vec![0.0; nbl];
    let mut force_t = vec![0.0; nbl];

    let n_steps = (case.duration / h).round() as usize;
    let n_samples = n_steps / num.decimation;
    let ser = |n: usize| vec![Vec::with_capacity(n_samples); n];
    let mut out = SimulationOutput {
        blade_le_radial: ser(nbl),
        blade_te_radial: ser(nbl),
        casing_radial: ser(case.casing_probes.len()),
        blade_normal_force: ser(nbl),
        blade_tangential_force: ser(nbl),
        impeller_nd_strain_energy: ser(kmax_i),
        time_step: h,
        stability_limit: limit,
        steps_per_revolution: steps_per_rev,
        n_steps,
        ..Default::default()
    };
    let mut coat = match &case.coating {
        Some(cc) => {
            let mut cs = CoatingStage::new(cc, impeller, &rows_i, n_rows, mu, ncs, mc, n_samples)?;
            cs.out.steps_per_element = steps_per_rev / cc.eta as f64;
            cs.check_stability(ki.as_mut(), kc.as_deref_mut(), &er_i, &er_c)?;
            Some(cs)
        }
        None => None,
    };
    // The fast casing kernel takes the spline into its modal basis (no spline solve per step).
    let surface = match kc.as_mut() {
        Some(k) if fast => k.map_to_surface(&spline).map_err(SimError::Spline)?,
        _ => false,
    };
    let casing_frames = CasingFrames {
        surface,
        rot: rot_c.clone(),
        rest_rows: y_c.clone(),
        q_rest: q.clone(),
    };
    let mut nodes_c = vec![0.0; ncs * nbc];
    let radius_scale = rest_nodes.iter().map(|p| p.xy().norm()).fold(0.0, f64::max);

    let clock = std::time::Instant::now();
    let mut stages = StageClock::new();
    for step in 0..n_steps {
        let t_n = step as f64 * h;
        // The same expression as the next step's t_n (the fused predictor checks its amplitude).
        let t1 = (step + 1) as f64 * h;
        if step % 1024 == 0
            && let Some(c) = cancel
            && c.load(Ordering::Relaxed)
        {
            return Err(SimError::Cancelled { time: t_n });
        }
        // 1. Predict both structures.
        ki.predict(0.0);
        if let Some(k) = kc.as_mut() {
            k.predict(case.load_factor(t_n));
        }
        stages.lap(Stage::Predict);
        // 2. Spline on the predicted casing nodes.
        if let Some(k) = kc.as_ref() {
            casing_frames.control_points(&spline, k.boundary(), &mut pnodes, &mut q)?;
        }
        stages.lap(Stage::Spline);
        // 3. Blade-tip nodes and closest points.
        let projection_failed = |e: NodeProjectionError| SimError::Projection {
            time: t1,
            reason: e.to_string(),
        };
        let r_om = rot_z(case.omega * t1);
        fill_blade_nodes(ki.boundary(), &r_om, &rot_i, &x_i, nci, &mut gam);
        // On sample steps also every node that may hold the smallest gap, so that the sampled
        // minimum gap is exact.
        let sample_step = (step + 1) % num.decimation == 0;
        gap_bounds
            .project_near(
                &spline,
                &q,
                &gam,
                &mut warm,
                eps,
                &mut proj,
                touch_margin,
                sample_step,
            )
            .map_err(projection_failed)?;
        // 3b. Abradable coating (paper Fig. 11): known coating forces first, then re-projection so
        // that the Lagrange problem below sees them in its predicted gaps.
        if let Some(cs) = coat.as_mut() {
            let fr = StepFrames {
                spline: &spline,
                q: &q,
                past: &past,
                casing: kc.is_some().then_some(&casing_frames),
                r_om: &r_om,
                rot_i: &rot_i,
                nci,
            };
            let any = cs.apply(&fr, &proj, &gam, &gam_prev)?;
            if any {
                ki.correct(&cs.fi);
                if let Some(k) = kc.as_mut() {
                    k.correct(&cs.fc);
                    casing_frames.control_points(&spline, k.boundary(), &mut pnodes, &mut q)?;
                }
                fill_blade_nodes(ki.boundary(), &r_om, &rot_i, &x_i, nci, &mut gam);
                gap_bounds
                    .project_near(&spline, &q, &gam, &mut warm, eps, &mut proj, 0.0, true)
                    .map_err(projection_failed)?;
                cs.flag_penetrations(nci, &proj)?;
            }
        }
        let mut min_gap = f64::INFINITY;
        cands.clear();
        for (node, p) in proj.iter().enumerate() {
            if !p.gap.is_finite() {
                return Err(SimError::Diverged {
                    time: t1,
                    reason: format!("non-finite gap at blade node {node}"),
                });
            }
            min_gap = min_gap.min(p.gap);
            if p.gap < 0.0 {
                cands.push(Cand {
                    node,
                    blade: 0,
                    row: 0,
                    n: p.normal,
                    fdir: p.normal,
                    slip: false,
                    g_loc: Vector3::zeros(),
                    f_loc: Vector3::zeros(),
                    param: p.param,
                });
            }
        }
        stages.lap(Stage::Projection);
        force_n.iter_mut().for_each(|x| *x = 0.0);
        force_t.iter_mut().for_each(|x| *x = 0.0);
        let in_contact = !cands.is_empty();
        // Largest residual penetration after correction, evaluated on sample steps (m).
        let mut residual = 0.0f64;
        // Off sample steps the fast kernel skips the corrected casing channels; the next step
        // sees its Lagrange loads through `past`.
        let lazy_correction = past.flex.is_some() && !sample_step;
        if in_contact {
            out.contact_steps += 1;
            let nk = cands.len();
            let rt = r_om.transpose();
            for cd in cands.iter_mut() {
                let (s, j) = (cd.node / nci, cd.node % nci);
                cd.blade = s;
                cd.row = j;
                // Relative increment of the blade node w.r.t. the casing material point (eq. 15).
                let mut inc = gam[cd.node] - gam_prev[cd.node];
                if kc.is_some() {
                    inc -= past.increment(&spline, &q, cd.node, &cd.param)?;
                }
                let t = if mu > 0.0 {
                    friction_direction(&cd.n, &inc)
                } else {
                    None
                };
                cd.slip = t.is_some();
                cd.fdir = cd.n + t.unwrap_or_else(Vector3::zeros) * mu;
                let to_loc = rot_i[s].transpose() * rt;
                cd.g_loc = to_loc * cd.n;
                cd.f_loc = to_loc * cd.fdir;
            }
            for (k, cd) in cands.iter().enumerate() {
                dvec[k] = proj[cd.node].gap;
            }
            // W = G_i A_i⁻¹ F_iᵀ + G_c A_c⁻¹ F_cᵀ (row-major nk × nk).
            let w = &mut wmat[..nk * nk];
            w.iter_mut().for_each(|x| *x = 0.0);
            if fast {
                let ti = tab_i.as_ref().expect("fast tables built");
                for (k, a) in cands.iter().enumerate() {
                    for (l, b) in cands.iter().enumerate() {
                        let blk = ti.block(a.blade, b.blade, a.row, b.row);
                        w[k * nk + l] = a.g_loc.dot(&(blk * b.f_loc));
                    }
                }
                if let Some(tc) = tab_c.as_ref() {
                    for (k, a) in cands.iter().enumerate() {
                        for (l, b) in cands.iter().enumerate().skip(k) {
                            let v = tc.pair_block(&a.param, &b.param);
                            w[k * nk + l] += a.n.dot(&(v * b.fdir));
                            vblk[k * nk + l] = v;
                            if l != k {
                                w[l * nk + k] += b.n.dot(&(v.transpose() * a.fdir));
                                vblk[l * nk + k] = v.transpose();
                            }
                        }
                    }
                }
            } else {
                dense_w(
                    hd_i.as_ref().expect("dense flexibility"),
                    &cands,
                    nk,
                    w,
                    |cd, row, is_f| {
                        let v = if is_f { cd.f_loc } else { cd.g_loc };
                        for d in 0..3 {
                            row[cd.blade * nbi + 3 * cd.row + d] = v[d];
                        }
                    },
                );
                if let Some(hc) = hd_c.as_ref() {
                    dense_w(hc, &cands, nk, w, |cd, row, is_f| {
                        let v = if is_f { cd.fdir } else { cd.n };
                        spline
                            .node_weight_factors(&cd.param, &mut wu, &mut wv)
                            .expect("valid param");
                        for i in 0..ncs {
                            let vl = rot_c[i].transpose() * v;
                            for j in 0..mc {
                                let wgt = -wu[i] * wv[j];
                                for d in 0..3 {
                                    row[i * nbc + 3 * j + d] = wgt * vl[d];
                                }
                            }
                        }
                    });
                }
            }
            if !active_set_solve(nk, w, &dvec[..nk], &mut lam, &mut act, &mut lu, &mut rhs) {
                return Err(SimError::Diverged {
                    time: t1,
                    reason: "singular contact matrix W".into(),
                });
            }
            stages.lap(Stage::ContactSolve);
            // Corrections, opposite signs on the two structures.
            fi.iter_mut().for_each(|x| *x = 0.0);
            for (k, cd) in cands.iter().enumerate() {
                let l = lam[k];
                if l == 0.0 {
                    continue;
                }
                for d in 0..3 {
                    fi[cd.blade * nbi + 3 * cd.row + d] += l * cd.f_loc[d];
                }
                force_n[cd.blade] += l;
                out.active_contacts += 1;
                if cd.slip {
                    force_t[cd.blade] += mu * l;
                }
            }
            // The impeller carries no load pattern: its next predictor has amplitude 0.
            ki.correct_then_predict(&fi, 0.0);
            if let Some(k) = kc.as_mut() {
                fc.iter_mut().for_each(|x| *x = 0.0);
                for (cd, l) in cands.iter().zip(&lam) {
                    if *l != 0.0 {
                        let f = cd.fdir * (-l);
                        casing_frames.add_force(
                            &spline,
                            &cd.param,
                            &f,
                            (&mut wu, &mut wv),
                            &mut fc,
                        )?;
                        if lazy_correction {
                            step_loads.push((cd.param, f));
                        }
                    }
                }
                casing_frames.finish_forces(&mut fc);
                if lazy_correction {
                    k.correct_state_then_predict(&fc, case.load_factor(t1));
                } else {
                    k.correct_then_predict(&fc, case.load_factor(t1));
                    casing_frames.control_points(&spline, k.boundary(), &mut pnodes, &mut q)?;
                }
                // The casing points the candidates touch, after the correction: moved by
                // ΔS_k = Σ_l V(k, l) F_l when the channels are not refreshed.
                for (k, cd) in cands.iter().enumerate() {
                    let mut x = surface_point(&spline, &q, &cd.param)?;
                    if lazy_correction {
                        for (l, (b, lb)) in cands.iter().zip(&lam).enumerate() {
                            x -= vblk[k * nk + l] * (b.fdir * *lb);
                        }
                    }
                    touched[cd.node] = Some((cd.param, x));
                }
            }
            fill_blade_nodes(ki.boundary(), &r_om, &rot_i, &x_i, nci, &mut gam);
            // Residual penetration: re-project the candidates on the corrected surface.
            if sample_step {
                for cd in cands.iter() {
                    res_warm[0] = Some(cd.param);
                    project_nodes(
                        &spline,
                        &q,
                        &gam[cd.node..cd.node + 1],
                        &mut res_warm,
                        eps,
                        &mut res_proj,
                    )
                    .map_err(projection_failed)?;
                    residual = residual.max(-res_proj[0].gap);
                }
                if residual > 1e-4 * radius_scale.max(1e-3) {
                    return Err(SimError::Diverged {
                        time: t1,
                        reason: format!("residual penetration {residual:.3e} m after correction"),
                    });
                }
            }
            stages.lap(Stage::Correction);
        }
        gam_prev.copy_from_slice(&gam);
        if kc.is_some() {
            // The next step's spline rewrites every control point of `q` before reading any.
            std::mem::swap(&mut past.q, &mut q);
            std::mem::swap(&mut past.loads, &mut step_loads);
            step_loads.clear();
            std::mem::swap(&mut past.touched, &mut touched);
            touched.iter_mut().for_each(|t| *t = None);
        }
        ki.advance();
        if let Some(k) = kc.as_mut() {
            k.advance();
        }
        if let Some(cs) = coat.as_mut() {
            cs.commit()?;
        }
        if step % 64 == 0 && !(ki.is_finite() && kc.as_ref().is_none_or(|k| k.is_finite())) {
            return Err(SimError::Diverged {
                time: t1,
                reason: "non-finite state".into(),
            });
        }
        // Probes.
        let ub = ki.boundary();
        for s in 0..nbl {
            let r_le = er_i[le].dot(&node_disp(ub, s, nbi, le));
            let r_te = er_i[te].dot(&node_disp(ub, s, nbi, te));
            out.max_blade_radial = out.max_blade_radial.max(r_le.abs()).max(r_te.abs());
        }
        if sample_step {
            out.time.push(t1);
            for s in 0..nbl {
                out.blade_le_radial[s].push(er_i[le].dot(&node_disp(ub, s, nbi, le)));
                out.blade_te_radial[s].push(er_i[te].dot(&node_disp(ub, s, nbi, te)));
                out.blade_normal_force[s].push(force_n[s]);
                out.blade_tangential_force[s].push(force_t[s]);
            }
            if let Some(k) = kc.as_mut() {
                if !case.casing_probes.is_empty() {
                    k.node_displacements(&mut nodes_c);
                }
                for (pi, p) in case.casing_probes.iter().enumerate() {
                    out.casing_radial[pi]
                        .push(er_c[p[1]].dot(&node_disp(&nodes_c, p[0], nbc, p[1])));
                }
                let e = k.energies();
                out.casing_energy.kinetic.push(e.kinetic);
                out.casing_energy.strain.push(e.strain);
            }
            out.min_gap.push(min_gap);
            out.residual_penetration.push(residual);
            out.max_residual_penetration = out.max_residual_penetration.max(residual);
            if let Some(cs) = coat.as_mut() {
                cs.sample();
            }
            let e = ki.energies();
            out.impeller_energy.kinetic.push(e.kinetic);
            out.impeller_energy.strain.push(e.strain);
            ki.nd_strain_energy(&mut nd_buf);
            for (k, v) in nd_buf.iter().enumerate() {
                out.impeller_nd_strain_energy[k].push(*v);
            }
        }
        stages.lap(Stage::Other);
    }
    out.loop_seconds = clock.elapsed().as_secs_f64();
    out.coating = coat.map(CoatingStage::finish).transpose()?;
    out.stage_seconds = stages.seconds;
    Ok(out)
}

#[inline]
fn node_disp(ub: &[f64], s: usize, nb: usize, j: usize) -> Vector3<f64> {
    Vector3::new(
        ub[s * nb + 3 * j],
        ub[s * nb + 3 * j + 1],
        ub[s * nb + 3 * j + 2],
    )
}

/// Casing contact nodes in the global frame, `P(i, j) = R(θ_i)(Y_j + u_(i,j))`.
fn fill_casing_nodes(
    ub: &[f64],
    rot: &[Matrix3<f64>],
    y: &[Vector3<f64>],
    m: usize,
    out: &mut [Vector3<f64>],
) {
    let nb = 3 * m;
    for (i, r) in rot.iter().enumerate() {
        for j in 0..m {
            out[i * m + j] = r * (y[j] + node_disp(ub, i, nb, j));
        }
    }
}

/// Blade-tip nodes in the fixed frame, `Γ = R(Ωt) R(θ_s)(X_j + u_(s,j))`.
fn fill_blade_nodes(
    ub: &[f64],
    r_om: &Matrix3<f64>,
    rot: &[Matrix3<f64>],
    x: &[Vector3<f64>],
    nc: usize,
    out: &mut [Vector3<f64>],
) {
    let nb = 3 * nc;
    for (s, r) in rot.iter().enumerate() {
        let rr = r_om * r;
        for j in 0..nc {
            out[s * nc + j] = rr * (x[j] + node_disp(ub, s, nb, j));
        }
    }
}

/// Dense `W += G H Fᵀ` with full boundary rows produced by `fill(cand, row, is_force_row)`.
fn dense_w(
    hmat: &Mat<f64>,
    cands: &[Cand],
    nk: usize,
    w: &mut [f64],
    mut fill: impl FnMut(&Cand, &mut [f64], bool),
) {
    let n = hmat.nrows();
    let mut g = Mat::<f64>::zeros(nk, n);
    let mut f = Mat::<f64>::zeros(n, nk);
    let mut row = vec![0.0; n];
    for (k, cd) in cands.iter().enumerate() {
        row.iter_mut().for_each(|x| *x = 0.0);
        fill(cd, &mut row, false);
        for (c, v) in row.iter().enumerate() {
            g[(k, c)] = *v;
        }
        row.iter_mut().for_each(|x| *x = 0.0);
        fill(cd, &mut row, true);
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

/// The casing at the end of the previous step, for the slip increment of a blade node
/// relative to the casing material point it rubs (eq. 15). That material point is the casing
/// point the node touched at the end of the previous step when it was a contact candidate
/// then (`touched`), else its current closest point. The surface is held as the control
/// points `q` of a state plus the Lagrange loads applied after it by
/// [`StructureKernel::correct_state_then_predict`] (fast kernel, `flex` present), whose
/// displacement of a surface point is `Σ_b V(p, p_b) F_b` through the control-point
/// flexibility (eq. 18). Without `flex`, `q` is the corrected state itself.
struct PastSurface<'a> {
    /// Control points (m, global).
    q: Vec<Vector3<f64>>,
    /// Surface points and forces (N, global) of the active contacts on the casing.
    loads: Vec<(SurfaceParam, Vector3<f64>)>,
    flex: Option<&'a ControlFlexTable>,
    /// Per blade-tip node: the surface point and position (m, global, corrected) of the
    /// casing point it touched, if it was a contact candidate.
    touched: Vec<Option<(SurfaceParam, Vector3<f64>)>>,
}

impl PastSurface<'_> {
    /// Displacement (m, global) over the step of the casing material point under blade node
    /// `node`, whose closest point on the casing of control points `q` is `param`.
    fn increment(
        &self,
        spline: &CasingSpline,
        q: &[Vector3<f64>],
        node: usize,
        param: &SurfaceParam,
    ) -> Result<Vector3<f64>, SimError> {
        if let Some((p0, x0)) = &self.touched[node] {
            return Ok(surface_point(spline, q, p0)? - x0);
        }
        let mut d = surface_point(spline, q, param)? - surface_point(spline, &self.q, param)?;
        if let Some(t) = self.flex {
            for (pb, f) in &self.loads {
                d -= t.pair_block(param, pb) * f;
            }
        }
        Ok(d)
    }
}

/// The casing surface point `S(p)` (m, global) of control points `q`.
fn surface_point(
    spline: &CasingSpline,
    q: &[Vector3<f64>],
    p: &SurfaceParam,
) -> Result<Vector3<f64>, SimError> {
    spline
        .evaluate(q, p)
        .map(|e| e.s)
        .map_err(|e| SimError::Spline(e.to_string()))
}

/// Frames and spline state of the current step, as seen by the coating stage.
struct StepFrames<'a> {
    spline: &'a CasingSpline,
    q: &'a [Vector3<f64>],
    past: &'a PastSurface<'a>,
    /// The flexible casing's frames (casing forces are then assembled); `None` if rigid.
    casing: Option<&'a CasingFrames>,
    r_om: &'a Matrix3<f64>,
    rot_i: &'a [Matrix3<f64>],
    nci: usize,
}

/// The abradable coating in the time loop (paper §4.1, Fig. 11).
///
/// Order within a step (after the prediction and the projection giving d*):
/// 1. [`CoatingStage::apply`]: a node with `d* ≤ 0` reached the casing: the element under it is
///    marked for full removal and the node is quarantined (no coating force this step; the
///    Lagrange multipliers act). For every other node the gap to the worn coating surface is
///    `d_abr = d* − e_abr (1 − ε_p(θ))` (θ = fixed-frame angle of its closest point, row = its
///    contact row); if `d_abr < 0` the element law gives the force `F ≥ 0` at the incursion
///    `δ = e_abr − d*`, applied like a Lagrange force: `F (n + μ t)` on the blade node
///    (t of eq. 15) and `−F (n + μ t)` on the casing at the closest point through `B̂ c`.
/// 2. The caller corrects both structures with these known forces (`u += A⁻¹ f_abr`),
///    re-projects the blade nodes and only then builds the Lagrange problem, so the multipliers
///    see the coating forces in their predicted gaps (corrected gap `d* + G A⁻¹ f_abr + W λ`).
///    A non-quarantined node pushed through the casing by that correction is flagged for
///    removal too ([`CoatingStage::flag_penetrations`]).
/// 3. [`CoatingStage::commit`] at the end of the step commits the trial element states and the
///    removals (plastic strain never decreases, so the order does not matter).
struct CoatingStage {
    layer: CoatingLayer,
    /// Impeller contact node index j → coating row.
    row_of: Vec<usize>,
    mu: f64,
    nbi: usize,
    pending: Vec<ElementUpdate>,
    removals: Vec<(usize, usize)>,
    /// Coating force per blade of the current step (N).
    blade_force: Vec<f64>,
    /// Boundary forces of the current step (sector-major), impeller and casing.
    fi: Vec<f64>,
    fc: Vec<f64>,
    wu: Vec<f64>,
    wv: Vec<f64>,
    max_wear_row: Vec<f64>,
    removed_row: Vec<usize>,
    out: CoatingOutput,
}

impl CoatingStage {
    #[allow(clippy::too_many_arguments)]
    fn new(
        cc: &CoatingCase,
        impeller: &CyclicRom,
        rows_i: &[usize],
        n_rows: usize,
        mu: f64,
        ncs: usize,
        mc: usize,
        n_samples: usize,
    ) -> Result<Self, SimError> {
        let bad = |m: String| SimError::InvalidCase(m);
        let mut row_pos = vec![None; n_rows];
        for (c, &r) in impeller.contact_nodes.iter().zip(rows_i) {
            row_pos[r].get_or_insert(c.position);
        }
        let row_pos: Vec<[f64; 3]> = row_pos
            .into_iter()
            .enumerate()
            .map(|(r, p)| p.ok_or_else(|| bad(format!("impeller contact row {r} has no node"))))
            .collect::<Result<_, _>>()?;
        let area = cc.resolve_tip_area(&row_pos).map_err(bad)?;
        let layer = CoatingLayer::new(cc.material, cc.eta, area)?;
        let nbl = impeller.n_sectors;
        let nbi = 3 * impeller.n_contact();
        let nn = nbl * impeller.n_contact();
        Ok(Self {
            layer,
            row_of: rows_i.to_vec(),
            mu,
            nbi,
            pending: Vec::with_capacity(nn),
            removals: Vec::with_capacity(2 * nn),
            blade_force: vec![0.0; nbl],
            fi: vec![0.0; nbl * nbi],
            fc: vec![0.0; ncs * 3 * mc],
            wu: vec![0.0; ncs],
            wv: vec![0.0; mc],
            max_wear_row: vec![0.0; n_rows],
            removed_row: vec![0; n_rows],
            out: CoatingOutput {
                eta: cc.eta,
                thickness: cc.material.thickness,
                max_wear: vec![Vec::with_capacity(n_samples); n_rows],
                blade_force: vec![Vec::with_capacity(n_samples); nbl],
                ..Default::default()
            },
        })
    }

    /// Elastic stiffness `E A_r / e_abr` (N/m) of the elements of row `r`.
    fn elastic_stiffness(&self, row: usize) -> f64 {
        let m = self.layer.material();
        m.young * self.layer.tip_area()[row] / m.thickness
    }

    /// Step 1 of the stage (see the type doc): trial forces of every node from the predicted
    /// projections; fills `fi`, `fc`, `blade_force`. Returns whether any force is non-zero.
    fn apply(
        &mut self,
        fr: &StepFrames,
        proj: &[Projection],
        gam: &[Vector3<f64>],
        gam_prev: &[Vector3<f64>],
    ) -> Result<bool, SimError> {
        self.pending.clear();
        self.removals.clear();
        self.blade_force.iter_mut().for_each(|x| *x = 0.0);
        let e_abr = self.layer.material().thickness;
        let mut any = false;
        for (node, p) in proj.iter().enumerate() {
            let (s, j) = (node / fr.nci, node % fr.nci);
            let row = self.row_of[j];
            let theta = p.point.y.atan2(p.point.x);
            if p.gap <= 0.0 {
                let el = self.layer.element_index(theta)?;
                self.removals.push((row, el));
                continue;
            }
            if p.gap >= self.layer.remaining_thickness(row, theta)? {
                continue;
            }
            let (f, up) = self.layer.trial(row, theta, e_abr - p.gap)?;
            self.pending.push(up);
            if f <= 0.0 {
                continue;
            }
            if !any {
                self.fi.iter_mut().for_each(|x| *x = 0.0);
                self.fc.iter_mut().for_each(|x| *x = 0.0);
                any = true;
            }
            // Relative increment of the node w.r.t. the casing material point (eq. 15).
            let mut inc = gam[node] - gam_prev[node];
            if fr.casing.is_some() {
                inc -= fr.past.increment(fr.spline, fr.q, node, &p.param)?;
            }
            let t = if self.mu > 0.0 {
                friction_direction(&p.normal, &inc)
            } else {
                None
            };
            let fdir = (p.normal + t.unwrap_or_else(Vector3::zeros) * self.mu) * f;
            let floc = fr.rot_i[s].transpose() * fr.r_om.transpose() * fdir;
            for d in 0..3 {
                self.fi[s * self.nbi + 3 * j + d] += floc[d];
            }
            if let Some(cf) = fr.casing {
                cf.add_force(
                    fr.spline,
                    &p.param,
                    &(-fdir),
                    (&mut self.wu, &mut self.wv),
                    &mut self.fc,
                )?;
            }
            self.blade_force[s] += f;
        }
        if any {
            if let Some(cf) = fr.casing {
                cf.finish_forces(&mut self.fc);
            }
            self.out.coating_steps += 1;
            let peak = self.blade_force.iter().fold(0.0f64, |m, &x| m.max(x));
            self.out.peak_force = self.out.peak_force.max(peak);
        }
        Ok(any)
    }

    /// Flags for removal the elements under nodes that penetrate the casing after the coating
    /// correction (projections of the corrected state).
    fn flag_penetrations(&mut self, nci: usize, proj: &[Projection]) -> Result<(), SimError> {
        for (node, p) in proj.iter().enumerate() {
            if p.gap < 0.0 {
                let row = self.row_of[node % nci];
                let el = self.layer.element_index(p.point.y.atan2(p.point.x))?;
                self.removals.push((row, el));
            }
        }
        Ok(())
    }

    /// Step 3: commits the trial states and the removals of the step; updates the running
    /// per-row maximum wear and removal counts (wear never decreases, so running values are exact).
    fn commit(&mut self) -> Result<(), SimError> {
        let e_abr = self.layer.material().thickness;
        for up in &self.pending {
            self.layer.commit(up)?;
            let w = self.layer.plastic_strain(up.row, up.element)? * e_abr;
            self.max_wear_row[up.row] = self.max_wear_row[up.row].max(w);
        }
        for &(row, el) in &self.removals {
            if self.layer.plastic_strain(row, el)? < 1.0 {
                self.layer.remove(row, el)?;
                self.removed_row[row] += 1;
                self.max_wear_row[row] = e_abr;
            }
        }
        self.pending.clear();
        self.removals.clear();
        Ok(())
    }

    /// Records one probe sample.
    fn sample(&mut self) {
        for (r, w) in self.max_wear_row.iter().enumerate() {
            self.out.max_wear[r].push(*w);
        }
        for (b, f) in self.blade_force.iter().enumerate() {
            self.out.blade_force[b].push(*f);
        }
    }

    /// The final coating probes.
    fn finish(mut self) -> Result<CoatingOutput, SimError> {
        self.out.final_wear = (0..self.layer.n_rows())
            .map(|r| self.layer.wear_profile(r))
            .collect::<Result<_, _>>()?;
        self.out.removed_elements = self.removed_row.clone();
        self.out.max_wear_final = self.layer.max_wear();
        Ok(self.out)
    }
}

/// Adds to `fc` the casing boundary forces of a global force `f` (N) applied at the spline
/// point `param`, distributed to the data points through `B̂ c` (eq. 18). The forces are left in
/// the *global* frame (one rotation per node at the end, [`rotate_to_sector_frames`], instead of
/// one per contact).
fn add_casing_force_global(
    spline: &CasingSpline,
    param: &SurfaceParam,
    f: &Vector3<f64>,
    wu: &mut [f64],
    wv: &mut [f64],
    fc: &mut [f64],
) -> Result<(), SimError> {
    spline
        .node_weight_factors(param, wu, wv)
        .map_err(|e| SimError::Spline(e.to_string()))?;
    let nbc = 3 * wv.len();
    for (i, &a) in wu.iter().enumerate() {
        if a == 0.0 {
            continue;
        }
        let fa = f * a;
        for (j, &b) in wv.iter().enumerate() {
            for d in 0..3 {
                fc[i * nbc + 3 * j + d] += b * fa[d];
            }
        }
    }
    Ok(())
}

/// Rotates global-frame casing boundary forces (sector-major) into each sector's local frame.
fn rotate_to_sector_frames(rot_c: &[Matrix3<f64>], mc: usize, fc: &mut [f64]) {
    let nbc = 3 * mc;
    for (i, r) in rot_c.iter().enumerate() {
        for j in 0..mc {
            let k = i * nbc + 3 * j;
            let v = r.transpose() * Vector3::new(fc[k], fc[k + 1], fc[k + 2]);
            fc[k..k + 3].copy_from_slice(v.as_slice());
        }
    }
}

/// The flexible casing's geometry in the time loop, and which channels its kernel uses.
struct CasingFrames {
    /// True when the spline is folded into the kernel ([`StructureKernel::map_to_surface`]):
    /// the kernel's channels are control-point rows 1..=M per column class, else contact nodes.
    surface: bool,
    /// `R(θ_i)` per sector (column class).
    rot: Vec<Matrix3<f64>>,
    /// Contact nodes of sector 0 at rest, by row (m).
    rest_rows: Vec<Vector3<f64>>,
    /// Control points of the casing at rest (m).
    q_rest: Vec<Vector3<f64>>,
}

impl CasingFrames {
    /// Control points `q` (m, global) of the casing state whose channels are `ub`: from the
    /// contact nodes through the spline solve (eq. 13), or directly from the folded kernel,
    /// `Q[cl+1][k] = Q_rest + R(cl α) ΔQ_loc`, then the ghost rows (eq. 10) and wrap columns (eq. 11).
    fn control_points(
        &self,
        spline: &CasingSpline,
        ub: &[f64],
        pnodes: &mut [Vector3<f64>],
        q: &mut [Vector3<f64>],
    ) -> Result<(), SimError> {
        let m = self.rest_rows.len();
        if !self.surface {
            fill_casing_nodes(ub, &self.rot, &self.rest_rows, m, pnodes);
            return spline
                .control_points(pnodes, q)
                .map_err(|e| SimError::Spline(e.to_string()));
        }
        let (n, nb) = (self.rot.len(), 3 * m);
        // Control-point columns are contiguous (`control_index`); column cl + 1 holds class cl.
        let columns = q.chunks_exact_mut(m + 2).skip(1);
        let rest = self.q_rest.chunks_exact(m + 2).skip(1);
        for (((col, rest), u), r) in columns.zip(rest).zip(ub.chunks_exact(nb)).zip(&self.rot) {
            // R(θ) is a rotation about z.
            let (c, s) = (r[(0, 0)], r[(1, 0)]);
            for ((x, x0), d) in col[1..=m]
                .iter_mut()
                .zip(&rest[1..=m])
                .zip(u.chunks_exact(3))
            {
                *x = x0 + Vector3::new(c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]);
            }
            col[0] = col[1] * 2.0 - col[2];
            col[m + 1] = col[m] * 2.0 - col[m - 1];
        }
        for (dst, src) in [(0, n), (n + 1, 1), (n + 2, 2)] {
            for k in 0..m + 2 {
                q[spline.control_index(dst, k)] = q[spline.control_index(src, k)];
            }
        }
        Ok(())
    }

    /// Adds the casing share of a global force `f` (N) applied at the spline point `param` to
    /// the casing load `fc` in the kernel's channels (eq. 18): on the 16 control points of the
    /// patch with weights `N_a(u) N_b(v)` (ghost rows folded back by the transpose of eq. 10,
    /// [`real_row_weights`]; sector-local frames), or on the contact nodes through `B̂ c` (global frame until
    /// [`CasingFrames::finish_forces`]). `wu`, `wv`: scratch of lengths N and M.
    fn add_force(
        &self,
        spline: &CasingSpline,
        param: &SurfaceParam,
        f: &Vector3<f64>,
        (wu, wv): (&mut [f64], &mut [f64]),
        fc: &mut [f64],
    ) -> Result<(), SimError> {
        if !self.surface {
            return add_casing_force_global(spline, param, f, wu, wv, fc);
        }
        let (n, m) = (self.rot.len(), self.rest_rows.len());
        let nb = 3 * m;
        let (cu, _, _) = cubic_basis(param.u);
        let (cv, _, _) = cubic_basis(param.v);
        let (start, wv) = real_row_weights(param.j, &cv, m);
        for (a, wa) in cu.iter().enumerate() {
            let cl = (param.i + a + n - 1) % n;
            let fl = self.rot[cl].transpose() * f * *wa;
            for (r, w) in wv.iter().enumerate().take(m.min(4)) {
                for d in 0..3 {
                    fc[cl * nb + 3 * (start + r) + d] += w * fl[d];
                }
            }
        }
        Ok(())
    }

    /// Puts node-channel loads from the global frame into the sector frames (control-point
    /// loads are assembled in them already).
    fn finish_forces(&self, fc: &mut [f64]) {
        if !self.surface {
            rotate_to_sector_frames(&self.rot, self.rest_rows.len(), fc);
        }
    }
}

impl CoatingStage {
    /// Refuses a coating too stiff for the explicit treatment of its force. The coating force
    /// is evaluated on the predicted position and applied through `A⁻¹`: for a node of normal
    /// flexibility `w = nᵀ A⁻¹ n` (impeller + casing, m/N, ∝ h²) on an element of stiffness
    /// `k = E A / e_abr` the step map is `u ← (1 − k w) u*`, stable for `k w < 4/3` and
    /// non-oscillating for `k w < 1`, which is required here.
    fn check_stability(
        &self,
        ki: &mut dyn StructureKernel,
        kc: Option<&mut (dyn StructureKernel + '_)>,
        er_i: &[Vector3<f64>],
        er_c: &[Vector3<f64>],
    ) -> Result<(), SimError> {
        let unit_radial = |k: &mut dyn StructureKernel, e: &[Vector3<f64>]| {
            let nb = k.n_boundary();
            let mut f = vec![0.0; k.n_sectors() * nb];
            let mut u = vec![0.0; k.n_sectors() * nb];
            e.iter()
                .enumerate()
                .map(|(j, ej)| {
                    f.iter_mut().for_each(|x| *x = 0.0);
                    for d in 0..3 {
                        f[3 * j + d] = ej[d];
                    }
                    k.response(&f, &mut u);
                    (0..3).map(|d| ej[d] * u[3 * j + d]).sum::<f64>()
                })
                .collect::<Vec<f64>>()
        };
        let w_i = unit_radial(ki, er_i);
        let w_c = kc.map_or(0.0, |k| {
            unit_radial(k, er_c).into_iter().fold(0.0f64, f64::max)
        });
        for (j, wi) in w_i.iter().enumerate() {
            let k = self.elastic_stiffness(self.row_of[j]);
            let ratio = k * (wi + w_c);
            if ratio.is_nan() || ratio >= 1.0 {
                return Err(SimError::InvalidCase(format!(
                    "coating too stiff for the time step: row {} has E·A/e_abr = {k:.3e} N/m and \
                     contact flexibility {:.3e} m/N, k·w = {ratio:.3} ≥ 1; reduce numerics.time_step \
                     (k·w ∝ h²) or the tip area",
                    self.row_of[j],
                    wi + w_c
                )));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::numerics::Numerics;
    use crate::dynamics::scenario::{InitialVelocity, LobeLoad, RigidShape, RigidSurface};
    use crate::dynamics::synthetic::{SyntheticSpec, synthetic_rom};
    use crate::model::rom::{Component, ContactNode, Damping, HarmonicBlock, HermitianMatrix};
    use nalgebra::DMatrix;

    /// Virtual work: for any channel displacement δ, the load of a point force f satisfies
    /// Σ F·δ = f·δS(param), in both channel modes, patches touching the ghost rows and the
    /// closing line included. δS comes from CasingFrames::control_points (the forward map).
    #[test]
    fn casing_loads_are_the_transpose_of_the_surface_map() {
        let (n, m) = (7, 4);
        let sp = CasingSpline::new(n, m).unwrap();
        let rot: Vec<Matrix3<f64>> = (0..n)
            .map(|i| rot_z(i as f64 * 2.0 * PI / n as f64))
            .collect();
        let f = Vector3::new(0.7, -1.3, 2.1);
        let delta: Vec<f64> = (0..n * 3 * m)
            .map(|i| ((i * 7919 % 113) as f64 / 113.0 - 0.5) * 1e-3)
            .collect();
        for surface in [false, true] {
            let frames = CasingFrames {
                surface,
                rot: rot.clone(),
                rest_rows: vec![Vector3::zeros(); m],
                q_rest: vec![Vector3::zeros(); sp.n_control()],
            };
            let mut q = vec![Vector3::zeros(); sp.n_control()];
            let mut pnodes = vec![Vector3::zeros(); n * m];
            frames
                .control_points(&sp, &delta, &mut pnodes, &mut q)
                .unwrap();
            for (i, j, u, v) in [(0, 0, 0.2, 0.1), (n - 1, m - 2, 0.9, 0.8), (3, 1, 0.5, 0.4)] {
                let param = SurfaceParam { i, j, u, v };
                let (mut wu, mut wv) = (vec![0.0; n], vec![0.0; m]);
                let mut fc = vec![0.0; n * 3 * m];
                frames
                    .add_force(&sp, &param, &f, (&mut wu, &mut wv), &mut fc)
                    .unwrap();
                frames.finish_forces(&mut fc);
                let work: f64 = fc.iter().zip(&delta).map(|(a, b)| a * b).sum();
                let ds = sp.evaluate(&q, &param).unwrap().s;
                assert!(
                    (work - f.dot(&ds)).abs() <= 1e-13 * f.norm() * 1e-3,
                    "surface = {surface}, patch ({i}, {j}): {work:e} vs {:e}",
                    f.dot(&ds)
                );
            }
        }
    }

    /// The casing share of a contact force is a partition of `f` over the data points: rotated
    /// back to the global frame the node forces sum to `f` (the spline weights sum to 1).
    #[test]
    fn casing_force_distribution_sums_to_the_contact_force() {
        let (n, m) = (8, 3);
        let sp = CasingSpline::new(n, m).unwrap();
        let rot: Vec<Matrix3<f64>> = (0..n)
            .map(|i| rot_z(i as f64 * 2.0 * PI / n as f64))
            .collect();
        let (mut wu, mut wv) = (vec![0.0; n], vec![0.0; m]);
        let mut fc = vec![0.0; n * 3 * m];
        let f = Vector3::new(1.0, -2.0, 3.0);
        let param = SurfaceParam {
            i: 2,
            j: 1,
            u: 0.3,
            v: 0.6,
        };
        add_casing_force_global(&sp, &param, &f, &mut wu, &mut wv, &mut fc).unwrap();
        rotate_to_sector_frames(&rot, m, &mut fc);
        let mut total = Vector3::zeros();
        for (i, r) in rot.iter().enumerate() {
            for j in 0..m {
                let k = i * 3 * m + 3 * j;
                total += r * Vector3::new(fc[k], fc[k + 1], fc[k + 2]);
            }
        }
        assert!((total - f).norm() <= 1e-12 * f.norm(), "{total:?}");
    }

    fn small_pair(nb: usize) -> (CyclicRom, CyclicRom) {
        let imp = synthetic_rom(&SyntheticSpec::small(Component::Impeller, nb, 2, 2));
        let cas = synthetic_rom(&SyntheticSpec::small(Component::Casing, 8, 3, 2));
        (imp, cas)
    }

    fn stable_h(imp: &CyclicRom, cas: &CyclicRom, omega: f64) -> f64 {
        let a = Structure::new(imp, omega).unwrap().stability_limit();
        let b = Structure::new(cas, 0.0).unwrap().stability_limit();
        0.5 * a.min(b)
    }

    fn lobe_case(h: f64, mu: f64, kernel: KernelChoice, eps: f64) -> Case {
        Case {
            omega: 1500.0,
            duration: 6e-3,
            friction: mu,
            load: Some(LobeLoad {
                lobes: 2,
                static_displacement: 2.5e-4,
                ramp_time: 3e-3,
                hold_time: 0.0,
            }),
            clearance_offset: vec![],
            casing_probes: vec![[0, 2], [2, 2]],
            initial_velocity: InitialVelocity::default(),
            numerics: Numerics {
                time_step: h,
                newton_tolerance: eps,
                kernel,
                decimation: 5,
            },
            coating: None,
        }
    }

    fn max_abs(v: &[Vec<f64>]) -> f64 {
        v.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()))
    }

    fn max_diff(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
        a.iter()
            .zip(b)
            .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
            .fold(0.0, f64::max)
    }

    #[test]
    fn fast_and_dense_agree_on_a_contact_run_with_friction() {
        let (imp, cas) = small_pair(4);
        let h = stable_h(&imp, &cas, 1500.0);
        let casing = CasingModel::Flexible(cas);
        // Tight ε_NR so that both runs take the same Newton path (the kernels differ by round-off).
        let f = simulate(
            &lobe_case(h, 0.1, KernelChoice::Fast, 1e-12),
            &imp,
            &casing,
            None,
        )
        .unwrap();
        let d = simulate(
            &lobe_case(h, 0.1, KernelChoice::DenseReference, 1e-12),
            &imp,
            &casing,
            None,
        )
        .unwrap();
        assert!(
            f.contact_steps > 20,
            "the scenario must rub: {} contact steps",
            f.contact_steps
        );
        assert_eq!(f.contact_steps, d.contact_steps);
        for (a, b) in [
            (&f.blade_le_radial, &d.blade_le_radial),
            (&f.blade_te_radial, &d.blade_te_radial),
            (&f.casing_radial, &d.casing_radial),
            (&f.blade_normal_force, &d.blade_normal_force),
            (&f.blade_tangential_force, &d.blade_tangential_force),
        ] {
            let s = max_abs(b);
            assert!(s > 0.0);
            assert!(
                max_diff(a, b) <= 1e-9 * s,
                "fast vs dense: {:e} vs {:e}",
                max_diff(a, b),
                s
            );
        }
        // Residual penetrations (sample steps): the fast kernel re-projects on refreshed channels.
        let worst = f
            .residual_penetration
            .iter()
            .zip(&d.residual_penetration)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(d.max_residual_penetration > 0.0);
        assert!(
            worst <= 1e-9 * max_abs(&d.blade_le_radial),
            "residual: {worst:e}"
        );
    }

    /// One radial oscillator (1-sector ROM, one node, no modes) released outward with speed v0
    /// toward a rigid cylinder at clearance g0. Exact solution with the explicit Lagrange method
    /// (perfectly plastic impact): u = (v0/ω) sin ωt until u = g0 at t_c, then u = g0 cos ω(t − t_c).
    #[test]
    fn single_oscillator_impacting_a_rigid_cylinder_matches_the_analytic_solution() {
        let (m, k) = (0.1, 4e6);
        let r0 = 0.2;
        let g0 = 1e-4;
        let n = 3;
        let rom = CyclicRom {
            name: "oscillator".into(),
            component: Component::Impeller,
            n_sectors: 1,
            contact_nodes: vec![ContactNode {
                position: [r0, 0.0, 0.0],
                row: 0,
            }],
            harmonics: vec![HarmonicBlock {
                nodal_diameter: 0,
                n_modes: 0,
                mass: HermitianMatrix::real(DMatrix::identity(n, n) * m),
                stiffness: [
                    HermitianMatrix::real(DMatrix::identity(n, n) * k),
                    HermitianMatrix::real(DMatrix::zeros(n, n)),
                    HermitianMatrix::real(DMatrix::zeros(n, n)),
                ],
            }],
            modal_data: vec![],
            damping: Damping::Modal { ratio: 0.0 },
            provenance: serde_json::Value::Null,
        };
        let casing = CasingModel::Rigid(RigidSurface {
            n_sectors: 64,
            meridian: vec![[r0 + g0, -0.01], [r0 + g0, 0.01]],
            shape: RigidShape::Lobes {
                lobes: 0,
                amplitude: 0.0,
            },
        });
        let w = (k / m).sqrt();
        let h = 1e-3 / w;
        let v0 = 2.0 * g0 * w;
        let case = Case {
            omega: 0.0,
            duration: 3.0 * 2.0 * PI / w,
            friction: 0.0,
            load: None,
            clearance_offset: vec![],
            casing_probes: vec![],
            initial_velocity: InitialVelocity {
                impeller: Some(vec![v0, 0.0, 0.0]),
                casing: None,
            },
            numerics: Numerics {
                time_step: h,
                decimation: 1,
                newton_tolerance: 1e-12,
                ..Default::default()
            },
            coating: None,
        };
        let out = simulate(&case, &rom, &casing, None).unwrap();
        let tc = (g0 * w / v0).asin() / w;
        // The discrete impact spreads over ≤ 2 steps: a timing error ≤ 2h, i.e. ≤ 2 ωh g0 in u.
        let tol = 5.0 * w * h * g0;
        let mut worst = 0.0f64;
        for (t, u) in out.time.iter().zip(&out.blade_le_radial[0]) {
            let exact = if *t < tc {
                v0 / w * (w * t).sin()
            } else {
                g0 * (w * (t - tc)).cos()
            };
            worst = worst.max((u - exact).abs());
            assert!(*u <= g0 * (1.0 + 1e-9), "penetration at t = {t}: u = {u}");
        }
        assert!(worst <= tol, "max error {worst:e} > {tol:e}");
        assert!(
            out.contact_steps >= 1 && out.contact_steps <= 4,
            "{} contact steps",
            out.contact_steps
        );
        // Energy after the impact: only the strain energy at the wall remains, ½ k g0².
        let e_end = out.impeller_energy.kinetic.last().unwrap()
            + out.impeller_energy.strain.last().unwrap();
        assert!((e_end - 0.5 * k * g0 * g0).abs() < 1e-2 * 0.5 * k * g0 * g0);
    }

    #[test]
    fn time_step_above_the_stability_limit_is_refused() {
        let (imp, cas) = small_pair(4);
        let h = 2.0 * stable_h(&imp, &cas, 1500.0) * 1.001;
        let err = simulate(
            &lobe_case(h, 0.0, KernelChoice::Fast, 1e-5),
            &imp,
            &CasingModel::Flexible(cas),
            None,
        )
        .unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, SimError::Unstable { .. }));
        assert!(
            msg.contains("stability limit") && msg.contains("steps"),
            "{msg}"
        );
        assert!(msg.contains(&format!("{h:.4e}")), "{msg}");
    }

    #[test]
    fn energy_never_grows_with_contacts_and_no_damping_or_friction() {
        let (imp, cas) = small_pair(4);
        // Per-step penetrations d* ∝ h: with h = limit/20 the O(κ d*²) error of linearizing the
        // curved constraint each step is below round-off (at h = limit/2 it reaches ~1e-7 of E).
        let h = stable_h(&imp, &cas, 0.0) / 10.0;
        let st = Structure::new(&imp, 0.0).unwrap();
        // Every tip node of every blade thrown outward.
        let mut v = vec![0.0; st.n_modal];
        for s in 0..4 {
            for j in 0..2 {
                v[s * 6 + 3 * j] = 30.0 + 10.0 * s as f64;
            }
        }
        let case = Case {
            omega: 0.0,
            duration: 3e-3,
            friction: 0.0,
            load: None,
            clearance_offset: vec![],
            casing_probes: vec![],
            initial_velocity: InitialVelocity {
                impeller: Some(v),
                casing: None,
            },
            numerics: Numerics {
                time_step: h,
                decimation: 1,
                ..Default::default()
            },
            coating: None,
        };
        let out = simulate(&case, &imp, &CasingModel::Flexible(cas), None).unwrap();
        assert!(out.contact_steps > 5);
        let e: Vec<f64> = (0..out.time.len())
            .map(|i| {
                out.impeller_energy.kinetic[i]
                    + out.impeller_energy.strain[i]
                    + out.casing_energy.kinetic[i]
                    + out.casing_energy.strain[i]
            })
            .collect();
        for w in e.windows(2) {
            assert!(
                w[1] <= w[0] * (1.0 + 1e-13),
                "energy grew: {} -> {}",
                w[0],
                w[1]
            );
        }
        assert!(
            e.last().unwrap() < &(0.999 * e[0]),
            "impacts must dissipate"
        );
    }

    #[test]
    fn two_lobe_scenario_stays_symmetric_under_rotation_by_pi() {
        let (imp, cas) = small_pair(4);
        let h = stable_h(&imp, &cas, 1500.0);
        let out = simulate(
            &lobe_case(h, 0.1, KernelChoice::Fast, 1e-5),
            &imp,
            &CasingModel::Flexible(cas),
            None,
        )
        .unwrap();
        assert!(out.contact_steps > 0);
        let s = max_abs(&out.blade_le_radial);
        for b in 0..2 {
            let d = max_diff(
                &out.blade_le_radial[b..b + 1],
                &out.blade_le_radial[b + 2..b + 3],
            );
            assert!(d <= 1e-9 * s, "blade {b} vs {}: {d:e} (scale {s:e})", b + 2);
            let f = max_diff(
                &out.blade_normal_force[b..b + 1],
                &out.blade_normal_force[b + 2..b + 3],
            );
            assert!(f <= 1e-9 * max_abs(&out.blade_normal_force));
        }
    }

    #[test]
    fn convergence_in_h_eps_nr_and_friction() {
        let (imp, cas) = small_pair(4);
        let h = stable_h(&imp, &cas, 1500.0) / 10.0;
        let casing = CasingModel::Flexible(cas);
        let run = |h: f64, mu: f64, eps: f64| {
            simulate(
                &lobe_case(h, mu, KernelChoice::Fast, eps),
                &imp,
                &casing,
                None,
            )
            .unwrap()
        };
        let base = run(h, 0.0, 1e-5);
        assert!(base.contact_steps > 0);
        // ε_NR = 1e-5 and 1e-10 superimposed.
        let tight = run(h, 0.0, 1e-10);
        let s = max_abs(&base.blade_le_radial);
        let d = max_diff(&base.blade_le_radial, &tight.blade_le_radial);
        assert!(d <= 1e-6 * s, "eps_NR: {d:e} vs {s:e}");
        // Halving h: peak blade amplitude within 1 %.
        let half = run(0.5 * h, 0.0, 1e-5);
        let (p1, p2) = (
            max_abs(&base.blade_le_radial),
            max_abs(&half.blade_le_radial),
        );
        assert!((p1 - p2).abs() <= 0.01 * p1, "peak {p1:e} vs {p2:e}");
        // μ = 0.01 nearly identical, no instability.
        let fr = run(h, 0.01, 1e-5);
        assert!(fr.max_blade_radial.is_finite());
        let d = max_diff(&base.blade_le_radial, &fr.blade_le_radial);
        assert!(d <= 0.05 * s, "mu: {d:e} vs {s:e}");
        assert!(max_abs(&fr.blade_tangential_force) > 0.0);
    }

    /// At the paper's resolution (h = 1e-7 s) the residual penetration after correction is
    /// ≤ 1e-8 of the vibration level (paper §3.3.3). It is the O(κ d*²) error of the linearized
    /// constraint, so it shrinks like h²; at coarse steps (a few hundred per revolution) it is larger.
    #[test]
    fn residual_penetration_is_negligible_at_paper_resolution() {
        let (imp, cas) = small_pair(4);
        let casing = CasingModel::Flexible(cas);
        for mu in [0.0, 0.01] {
            let mut case = lobe_case(1e-7, mu, KernelChoice::Fast, 1e-5);
            case.duration = 4e-3;
            case.numerics.decimation = 100;
            let out = simulate(&case, &imp, &casing, None).unwrap();
            assert!(out.contact_steps > 100);
            assert!(
                out.max_residual_penetration <= 1e-8 * out.max_blade_radial,
                "μ = {mu}: residual {:e} vs level {:e}",
                out.max_residual_penetration,
                out.max_blade_radial
            );
        }
    }
}
