//! The casing side of the time loop: its spline surface (eqs. 5–13) and, when flexible, its
//! kernel, sector frames and the casing's share of the contact forces (eq. 18); the surface
//! of the previous step that slip increments are measured on (eq. 15).

use super::*;

/// Simulated time (s) between two readings of the casing probes for their peak: each reading
/// takes a pass over the casing's whole modal state (3500 coordinates for the built-in casing,
/// 15 % of a massless step for two probes if read on every step), and the casing's response
/// has no content that 2 µs would misread by more than 0.8 % (20 kHz; its ND-3 mode at
/// 2.6 kHz by 0.01 %).
pub const CASING_PEAK_INTERVAL: f64 = 2e-6;

/// The flexible casing's kernel, frames and probe buffers.
#[derive(Clone)]
pub(super) struct FlexibleCasing {
    pub(super) kernel: Kernel<ControlFlexTable>,
    pub(super) frames: CasingFrames,
    /// Radial unit vector of each contact node of sector 0.
    pub(super) radial: Vec<Vector3<f64>>,
    /// Contact-node displacements (m, sector-major) of the casing probes, scratch.
    pub(super) nodes: Vec<f64>,
    /// The radial displacement of each casing probe as a functional of the kernel's state
    /// ([`StructureKernel::boundary_functional`]): read on every step for its peak.
    pub(super) probe_functionals: Vec<Vec<f64>>,
    /// Steps between two readings of the probe functionals: [`CASING_PEAK_INTERVAL`] of
    /// simulated time, at least one step.
    pub(super) probe_stride: usize,
    /// The contact nodes' quasi-static displacements (m, sector-major) under the full
    /// external load (empty without one): what the runaway watch takes out of `nodes`.
    pub(super) load_distortion: Vec<f64>,
}

/// The casing in the time loop: its spline surface (eqs. 5–13) and, when flexible, its kernel.
#[derive(Clone)]
pub(super) struct CasingSide {
    pub(super) spline: CasingSpline,
    pub(super) n_sectors: usize,
    pub(super) rows: usize,
    pub(super) flexible: Option<FlexibleCasing>,
    /// Control points (m, global) of this step, data points of the spline solve, and the
    /// control points of the corrected surface (residual check).
    pub(super) q: Vec<Vector3<f64>>,
    pub(super) pnodes: Vec<Vector3<f64>>,
    pub(super) q_corrected: Vec<Vector3<f64>>,
    /// With a massless boundary and the dense kernel (whose `q` is refreshed to the corrected
    /// surface), the predicted control points of this step, which the next step's slip
    /// increments start from (see `Blades::nodes_predicted`). Empty otherwise.
    pub(super) q_predicted: Vec<Vector3<f64>>,
    /// The surface at the end of the previous step (friction increments, eq. 15).
    pub(super) past: PastSurface,
    /// Largest radius (m) of the casing at rest (scale of the residual tolerance).
    pub(super) radius_scale: f64,
}

impl CasingSide {
    pub(super) fn new(
        case: &Case,
        h: f64,
        casing: &CasingModel,
        st: Option<&Structure>,
    ) -> Result<Self, SimError> {
        let (n_sectors, rows, rest_rows, rest_nodes) = match casing {
            CasingModel::Flexible(rom) => {
                let m = rom.n_contact();
                for (j, c) in rom.contact_nodes.iter().enumerate() {
                    if c.row != j {
                        return Err(SimError::InvalidCase(format!(
                            "casing contact node {j} has row {}: casing nodes must be ordered by row 0..M",
                            c.row
                        )));
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
            CasingModel::ImposedGap(_) => {
                return Err(SimError::InvalidCase(
                    "an imposed-gap casing has no surface".into(),
                ));
            }
        };
        let spline_err = |e: crate::contact::SplineError| SimError::Spline(e.to_string());
        let mut spline = CasingSpline::new(n_sectors, rows).map_err(spline_err)?;
        spline.orient_toward_axis(&rest_nodes).map_err(spline_err)?;
        let mut q = vec![Vector3::zeros(); spline.n_control()];
        spline
            .control_points(&rest_nodes, &mut q)
            .map_err(spline_err)?;
        let alpha = 2.0 * PI / n_sectors as f64;
        let mut flexible = match (casing, st) {
            (CasingModel::Flexible(rom), Some(st)) => {
                let kernel = Kernel::new(st, h, case.numerics.kernel, |k| {
                    ControlFlexTable::build(k, &spline)
                })?;
                Some(FlexibleCasing {
                    kernel,
                    frames: CasingFrames {
                        surface: false,
                        rot: (0..n_sectors).map(|i| rot_z(i as f64 * alpha)).collect(),
                        rest_rows,
                        q_rest: q.clone(),
                    },
                    radial: rom
                        .contact_nodes
                        .iter()
                        .map(|c| radial(&c.position))
                        .collect(),
                    nodes: vec![0.0; n_sectors * 3 * rows],
                    probe_functionals: Vec::new(),
                    probe_stride: ((CASING_PEAK_INTERVAL / h).floor() as usize).max(1),
                    load_distortion: Vec::new(),
                })
            }
            _ => None,
        };
        for p in &case.casing_probes {
            if flexible.is_none() || p[0] >= n_sectors || p[1] >= rows {
                return Err(SimError::InvalidCase(format!(
                    "casing probe {p:?} is not a contact node of a flexible casing"
                )));
            }
        }
        if let Some(f) = flexible.as_mut() {
            for &[sector, row] in &case.casing_probes {
                let mut weights = vec![0.0; f.nodes.len()];
                let at = sector * 3 * rows + 3 * row;
                weights[at..at + 3].copy_from_slice(f.radial[row].as_slice());
                let functional = f.kernel.get_mut().boundary_functional(&weights);
                f.probe_functionals.push(functional);
            }
        }
        let radius_scale = rest_nodes.iter().map(|p| p.xy().norm()).fold(0.0, f64::max);
        Ok(Self {
            past: PastSurface {
                q: q.clone(),
                loads: vec![],
                touched: vec![],
            },
            q_corrected: q.clone(),
            q_predicted: Vec::new(),
            spline,
            n_sectors,
            rows,
            flexible,
            q,
            pnodes: rest_nodes,
            radius_scale,
        })
    }

    /// The fast casing kernel takes the spline into its modal basis (no spline solve per
    /// step); done after everything that uses the contact-node channels.
    pub(super) fn fold_spline(&mut self) -> Result<(), SimError> {
        if let Some(FlexibleCasing {
            kernel: Kernel::Modal { kernel, .. },
            frames,
            ..
        }) = self.flexible.as_mut()
        {
            frames.surface = kernel
                .map_to_surface(&self.spline)
                .map_err(SimError::Spline)?;
        }
        Ok(())
    }

    /// The flexibility table of the fast casing kernel, through which the Lagrange loads of a
    /// step act on the surface without refreshing the kernel's channels.
    pub(super) fn lazy_table(&self) -> Option<&ControlFlexTable> {
        match self.flexible.as_ref()?.kernel {
            Kernel::Modal { ref table, .. } => Some(table),
            Kernel::Dense { .. } => None,
        }
    }

    /// Control points `q` of the current casing state (a rigid casing's never change).
    pub(super) fn refresh(&mut self) -> Result<(), SimError> {
        if let Some(f) = &self.flexible {
            f.frames.control_points(
                &self.spline,
                f.kernel.get().boundary(),
                &mut self.pnodes,
                &mut self.q,
            )?;
        }
        Ok(())
    }
}

/// The casing in the time loop: a surface (flexible or rigid spline) that the blade-tip
/// nodes are projected on, or gaps imposed per node along fixed directions.
#[allow(clippy::large_enum_variant)] // one per simulation, built once, never moved in the loop
pub(super) enum Casing {
    Surface(CasingSide),
    Imposed(ImposedCasing),
}

impl Casing {
    pub(super) fn surface(&self) -> Option<&CasingSide> {
        match self {
            Casing::Surface(cs) => Some(cs),
            Casing::Imposed(_) => None,
        }
    }

    pub(super) fn surface_mut(&mut self) -> Option<&mut CasingSide> {
        match self {
            Casing::Surface(cs) => Some(cs),
            Casing::Imposed(_) => None,
        }
    }

    pub(super) fn flexible(&self) -> Option<&FlexibleCasing> {
        self.surface()?.flexible.as_ref()
    }

    pub(super) fn flexible_mut(&mut self) -> Option<&mut FlexibleCasing> {
        self.surface_mut()?.flexible.as_mut()
    }

    /// Largest radius (m) of the casing at rest, or of the blade tips against imposed gaps.
    pub(super) fn radius_scale(&self) -> f64 {
        match self {
            Casing::Surface(cs) => cs.radius_scale,
            Casing::Imposed(imposed) => imposed.radius_scale(),
        }
    }

    /// [`GAP_TOLERANCE`] × [`Casing::radius_scale`] (m).
    pub(super) fn gap_tolerance(&self) -> f64 {
        GAP_TOLERANCE * self.radius_scale()
    }
}

/// Scales the n-lobe casing load (paper §5) to its static displacement and hands it to the
/// casing kernel: the force on node `(i, M−1)` is `−F cos(n θ_i) e_r`.
pub(super) fn set_casing_load(
    case: &Case,
    h: f64,
    st: Option<&Structure>,
    casing: &mut Casing,
) -> Result<(), SimError> {
    let Some(load) = &case.load else {
        return Ok(());
    };
    let bad = |m: String| Err(SimError::InvalidCase(m));
    let Some(casing) = casing.surface_mut() else {
        return bad("a casing load needs a flexible casing".into());
    };
    let (Some(stc), Some(fc)) = (st, casing.flexible.as_mut()) else {
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
    let (ncs, mc) = (casing.n_sectors, casing.rows);
    let (nbc, te_c, alpha) = (3 * mc, mc - 1, 2.0 * PI / ncs as f64);
    let er = fc.radial[te_c];
    let mut pat = vec![0.0; ncs * nbc];
    for i in 0..ncs {
        let f = -er * (load.lobes as f64 * i as f64 * alpha).cos();
        pat[i * nbc + 3 * te_c..i * nbc + 3 * te_c + 3].copy_from_slice(f.as_slice());
    }
    let mut stat = vec![0.0; ncs * nbc];
    // The fast casing kernel has the modes (its static response reads no state); the dense
    // reference has not.
    let mut own;
    let mk = match &mut fc.kernel {
        Kernel::Modal { kernel, .. } => kernel,
        Kernel::Dense { .. } => {
            own = ModalKernel::new(stc, h)?;
            &mut own
        }
    };
    mk.static_boundary(&pat, &mut stat)
        .map_err(SimError::InvalidCase)?;
    let peak = (0..ncs)
        .map(|i| -er.dot(&node_disp(&stat, i, nbc, te_c)))
        .fold(0.0f64, f64::max);
    if peak.is_nan() || peak <= 0.0 {
        return bad("the casing load produces no inward static displacement".into());
    }
    let scale = load.static_displacement / peak;
    pat.iter_mut().for_each(|x| *x *= scale);
    fc.kernel.get_mut().set_load_pattern(&pat);
    stat.iter_mut().for_each(|x| *x *= scale);
    fc.load_distortion = stat;
    Ok(())
}

/// The casing at the end of the previous step, for the slip increment of a blade node
/// relative to the casing material point it rubs (eq. 15). That material point is the casing
/// point the node touched at the end of the previous step when it was a contact candidate
/// then (`touched`), else its current closest point. The surface is held as the control
/// points `q` of a state plus the Lagrange loads applied after it by
/// [`StructureKernel::correct_state_then_predict`] (fast kernel), whose displacement of a
/// surface point is `Σ_b V(p, p_b) F_b` through the control-point flexibility `flex`
/// (eq. 18). Without `flex` (dense kernel), `q` is the corrected state itself.
#[derive(Clone)]
pub(super) struct PastSurface {
    /// Control points (m, global).
    pub(super) q: Vec<Vector3<f64>>,
    /// Surface points and forces (N, global) of the active contacts on the casing.
    pub(super) loads: Vec<(SurfaceParam, Vector3<f64>)>,
    /// Per blade-tip node: the surface point and position (m, global, corrected) of the
    /// casing point it touched, if it was a contact candidate.
    pub(super) touched: Vec<Option<(SurfaceParam, Vector3<f64>)>>,
}

impl PastSurface {
    /// Displacement (m, global) over the step of the casing material point under blade node
    /// `node`, whose closest point on the casing of control points `q` is `param`.
    pub(super) fn increment(
        &self,
        spline: &CasingSpline,
        q: &[Vector3<f64>],
        node: usize,
        param: &SurfaceParam,
        flex: Option<&ControlFlexTable>,
    ) -> Result<Vector3<f64>, SimError> {
        if let Some((p0, x0)) = &self.touched[node] {
            return Ok(surface_point(spline, q, p0)? - x0);
        }
        let mut d = surface_point(spline, q, param)? - surface_point(spline, &self.q, param)?;
        if let Some(t) = flex {
            for (pb, f) in &self.loads {
                d -= t.pair_block(param, pb) * f;
            }
        }
        Ok(d)
    }
}

/// The casing surface point `S(p)` (m, global) of control points `q`.
pub(super) fn surface_point(
    spline: &CasingSpline,
    q: &[Vector3<f64>],
    p: &SurfaceParam,
) -> Result<Vector3<f64>, SimError> {
    (spline.point(q, p)).map_err(|e| SimError::Spline(e.to_string()))
}

/// Adds to `fc` the casing boundary forces of a global force `f` (N) applied at the spline
/// point `param`, distributed to the data points through `B̂ c` (eq. 18). The forces are left in
/// the *global* frame (one rotation per node at the end, [`rotate_to_sector_frames`], instead of
/// one per contact).
pub(super) fn add_casing_force_global(
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
pub(super) fn rotate_to_sector_frames(rot_c: &[Matrix3<f64>], mc: usize, fc: &mut [f64]) {
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
#[derive(Clone)]
pub(super) struct CasingFrames {
    /// True when the spline is folded into the kernel ([`StructureKernel::map_to_surface`]):
    /// the kernel's channels are control-point rows 1..=M per column class, else contact nodes.
    pub(super) surface: bool,
    /// `R(θ_i)` per sector (column class).
    pub(super) rot: Vec<Matrix3<f64>>,
    /// Contact nodes of sector 0 at rest, by row (m).
    pub(super) rest_rows: Vec<Vector3<f64>>,
    /// Control points of the casing at rest (m).
    pub(super) q_rest: Vec<Vector3<f64>>,
}

impl CasingFrames {
    /// Control points `q` (m, global) of the casing state whose channels are `ub`: from the
    /// contact nodes through the spline solve (eq. 13), or directly from the folded kernel,
    /// `Q[cl+1][k] = Q_rest + R(cl α) ΔQ_loc`, then the ghost rows (eq. 10) and wrap columns (eq. 11).
    pub(super) fn control_points(
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
    pub(super) fn add_force(
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
    pub(super) fn finish_forces(&self, fc: &mut [f64]) {
        if !self.surface {
            rotate_to_sector_frames(&self.rot, self.rest_rows.len(), fc);
        }
    }
}
