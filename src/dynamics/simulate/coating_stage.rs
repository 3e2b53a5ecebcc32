//! The abradable coating's stage of the time loop (paper Fig. 11): its elements under the
//! blade tips, their law, the forces on both structures and the wear they leave.

use super::*;
use std::f64::consts::{PI, TAU};

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
///
/// With a massless boundary a tip node has no mass and steps 1–2 would not be stable (`k w`
/// is not small, [`CoatingStage::check_stability`]): [`CoatingStage::laws_of`] replaces them.
/// A node with `d* ≤ 0` is handled as in step 1; every node below the worn surface becomes a
/// candidate of the contact problem with its element's law, and box 4 solves its force and
/// plastic shortening with the Lagrange multipliers ([`coated_solve`]); a node the solve takes
/// to the casing is removed and solved again as a Lagrange contact
/// ([`CoatingStage::wear_through`]). [`CoatingStage::implicit_force`] then keeps the solved
/// states, and step 3 commits them.
///
/// Solved with the displacement, the force `F_{n+1}` at the end of the step is the
/// quasi-static modes' equilibrium, as it must be; but applied through `A⁻¹` to the inertial
/// modes too, it is a spring taken at the end of the step inside central differences: an
/// implicit-Euler term, which damps at the rate `h k / 2m` (first order in h;
/// docs/validation.md, "The mode cutoff on a coating"). So the inertial modes receive the
/// force's history as well: `F_n` and `F_{n−1}` of both boundaries are kept
/// ([`ForceHistory`]) and `F_{n−1} − F_n` goes to the next predictor of the inertial modes
/// ([`StructureKernel::add_inertial_load`]). Those modes are then loaded by
/// `F_{n+1} − F_n + F_{n−1} = F_n + O(h²)`, a symmetric three-point weighting: second order,
/// and for a linear spring its characteristic polynomial is palindromic (roots on the unit
/// circle: no numerical damping), stable whatever the stiffness
/// (`python/benches/implicit_spring.py`). The implicit solve and its `W` are unchanged. The
/// Lagrange multipliers keep the end of the step alone: a constraint's multiplier would
/// otherwise follow `λ_{n+1} − λ_n + λ_{n−1} = Λ`, whose roots `e^{±iπ/3}` ring undamped.
pub(super) struct CoatingStage {
    pub(super) layer: CoatingLayer,
    /// Impeller contact node index j → coating row.
    pub(super) row_of: Vec<usize>,
    pub(super) mu: f64,
    pub(super) nbi: usize,
    pub(super) pending: Vec<ElementUpdate>,
    pub(super) removals: Vec<(usize, usize)>,
    /// Coating force per blade of the current step (N), and their torque about the axis
    /// (N·m, fixed frame).
    pub(super) blade_force: Vec<f64>,
    pub(super) torque: f64,
    /// Boundary forces of the current step (sector-major), impeller and casing.
    pub(super) fi: Vec<f64>,
    pub(super) fc: Vec<f64>,
    pub(super) wu: Vec<f64>,
    pub(super) wv: Vec<f64>,
    pub(super) max_wear_row: Vec<f64>,
    pub(super) removed_row: Vec<usize>,
    pub(super) out: CoatingOutput,
    /// With a massless boundary, per blade-tip node the row, element and law of the element
    /// it presses this step ([`CoatingStage::laws_of`]); empty with the paper's formulation.
    pub(super) node_law: Vec<Option<(usize, usize, CoatingLaw)>>,
    /// With a massless boundary, per blade-tip node the fixed-frame angle (rad) of its closest
    /// point and its gap to the casing (m, at the end of the step once solved) in this step
    /// and in the previous one, the angle NaN when it was not within `e_abr` of the casing: a
    /// step may move a tip over more than an element (`CoatingStage::cut_swept`).
    pub(super) path_now: Vec<[f64; 2]>,
    pub(super) path_prev: Vec<[f64; 2]>,
    /// With a massless boundary, the coating forces of this step and the previous one on the
    /// impeller's boundary (local frames) and on the casing's channels (see the type doc).
    pub(super) history_i: ForceHistory,
    pub(super) history_c: ForceHistory,
}

/// One structure's coating force on its boundary (N, sector-major) in this step, `F_n`, and
/// in the previous one, and the load `F_{n−1} − F_n` that the next predictor gives its
/// inertial modes ([`CoatingStage`]).
pub(super) struct ForceHistory {
    now: Vec<f64>,
    prev: Vec<f64>,
    load: Vec<f64>,
    /// Whether `now` and `prev` hold a nonzero force: a step without one touches neither.
    now_loaded: bool,
    prev_loaded: bool,
}

impl ForceHistory {
    fn new(n: usize) -> Self {
        Self {
            now: vec![0.0; n],
            prev: vec![0.0; n],
            load: vec![0.0; n],
            now_loaded: false,
            prev_loaded: false,
        }
    }

    /// Starts a step: the last step's forces become the previous ones; returns this step's,
    /// zeroed, to be filled ([`ForceHistory::mark_loaded`] when a force goes in).
    pub(super) fn start(&mut self) -> &mut [f64] {
        std::mem::swap(&mut self.now, &mut self.prev);
        std::mem::swap(&mut self.now_loaded, &mut self.prev_loaded);
        if std::mem::take(&mut self.now_loaded) {
            self.now.fill(0.0);
        }
        &mut self.now
    }

    /// This step's forces hold a nonzero one.
    pub(super) fn mark_loaded(&mut self) {
        self.now_loaded = true;
    }

    /// This step's forces (N), being filled.
    pub(super) fn now_mut(&mut self) -> &mut [f64] {
        &mut self.now
    }

    /// `F_{n−1} − F_n` (N), or `None` when both steps' forces are zero.
    pub(super) fn load(&mut self) -> Option<&[f64]> {
        if !self.now_loaded && !self.prev_loaded {
            return None;
        }
        let forces = self.prev.iter().zip(&self.now);
        for (l, (p, n)) in self.load.iter_mut().zip(forces) {
            *l = p - n;
        }
        Some(&self.load[..])
    }
}

impl CoatingStage {
    pub(super) fn new(
        cc: &CoatingCase,
        impeller: &CyclicRom,
        blades: &Blades,
        mu: f64,
        casing: &CasingSide,
    ) -> Result<Self, SimError> {
        let bad = |m: String| SimError::InvalidCase(m);
        let (rows_i, n_rows) = (&blades.rows, blades.n_rows);
        let (ncs, mc) = (casing.n_sectors, casing.rows);
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
            row_of: rows_i.clone(),
            mu,
            nbi,
            pending: Vec::with_capacity(nn),
            removals: Vec::with_capacity(2 * nn),
            blade_force: vec![0.0; nbl],
            torque: 0.0,
            fi: vec![0.0; nbl * nbi],
            fc: vec![0.0; ncs * 3 * mc],
            wu: vec![0.0; ncs],
            wv: vec![0.0; mc],
            max_wear_row: vec![0.0; n_rows],
            removed_row: vec![0; n_rows],
            out: CoatingOutput {
                eta: cc.eta,
                thickness: cc.material.thickness,
                ..Default::default()
            },
            node_law: Vec::new(),
            path_now: Vec::new(),
            path_prev: Vec::new(),
            history_i: ForceHistory::new(nbl * nbi),
            history_c: ForceHistory::new(ncs * 3 * mc),
        })
    }

    /// Whether the coating force is solved with the displacement (massless boundary).
    pub(super) fn implicit(&self) -> bool {
        !self.node_law.is_empty()
    }

    /// Step 1 with a massless boundary: a node with `d* ≤ 0` reached the casing: its element is
    /// marked for removal and the node is a Lagrange contact (as in step 1 of the paper's
    /// formulation). Every other node below the worn surface (`d* < e_abr (1 − ε_p)`) gets
    /// the law of its element, which box 4 solves with the boundary's static response.
    pub(super) fn laws_of(&mut self, nci: usize, proj: &[Projection]) -> Result<(), SimError> {
        self.pending.clear();
        self.removals.clear();
        self.blade_force.iter_mut().for_each(|x| *x = 0.0);
        let e_abr = self.layer.material().thickness;
        std::mem::swap(&mut self.path_prev, &mut self.path_now);
        for (node, p) in proj.iter().enumerate() {
            self.node_law[node] = None;
            self.path_now[node] = [f64::NAN; 2];
            if p.gap >= e_abr {
                continue;
            }
            let row = self.row_of[node % nci];
            let theta = p.point.y.atan2(p.point.x);
            self.path_now[node] = [theta, p.gap];
            let (element, law) = self.layer.law(row, theta)?;
            if p.gap <= 0.0 {
                self.removals.push((row, element));
                self.cut_swept(node, row, p.gap)?;
            } else if p.gap < law.remaining {
                self.node_law[node] = Some((row, element, law));
            } else {
                // Above its element's worn surface, maybe not above the ones jumped over.
                self.cut_swept(node, row, p.gap)?;
            }
        }
        Ok(())
    }

    /// The elements that tip `node` (row `row`) jumped over in the step, between its element
    /// of the previous step and this one, are cut as the tip's own element is, at the tip's
    /// gap to the casing where it passed over their centres: the gap along the straight path
    /// from the previous step's end gap to this one's, `gap` (m), by angle. An element is
    /// removed where that gap is ≤ 0. (The paper's steps move a tip by less than an element;
    /// a massless boundary's may not.)
    pub(super) fn cut_swept(&mut self, node: usize, row: usize, gap: f64) -> Result<(), SimError> {
        self.path_now[node][1] = gap;
        let (from, to) = (self.path_prev[node], self.path_now[node]);
        if from[0].is_nan() || to[0].is_nan() {
            return Ok(());
        }
        let e_abr = self.layer.material().thickness;
        for theta in self.layer.centres_between(from[0], to[0])? {
            let gap = gap_along_path(from, to, theta);
            if gap <= 0.0 {
                let element = self.layer.element_index(theta)?;
                self.removals.push((row, element));
                continue;
            }
            let (f, up) = self.layer.trial(row, theta, e_abr - gap)?;
            if f > 0.0 {
                self.pending.push(up);
            }
        }
        Ok(())
    }

    /// The contact solve took `node` through its element to the casing: the element, and any
    /// jumped over, are removed.
    pub(super) fn wear_through(&mut self, node: usize) -> Result<(), SimError> {
        if let Some((row, element, _)) = self.node_law[node].take() {
            self.removals.push((row, element));
            self.cut_swept(node, row, 0.0)?;
        }
        Ok(())
    }

    /// The solved force `lambda` (N) of `node` (on blade `blade`) on its element, the
    /// element's plastic shortening `plastic` (m) in the step, and the tip's gap to the casing
    /// at the end of the step `gap` (m), at which the elements it jumped over are cut.
    pub(super) fn implicit_force(
        &mut self,
        node: usize,
        blade: usize,
        (lambda, plastic, gap): (f64, f64, f64),
    ) -> Result<(), SimError> {
        let Some((row, element, _)) = self.node_law[node] else {
            return Ok(());
        };
        if plastic > 0.0 {
            let up = self.layer.plastic_update(row, element, plastic)?;
            self.pending.push(up);
        }
        self.cut_swept(node, row, gap)?;
        self.blade_force[blade] += lambda;
        Ok(())
    }

    /// The step's coating statistics, once its forces are known.
    pub(super) fn finish_step(&mut self) {
        if self.blade_force.iter().any(|&f| f > 0.0) {
            self.out.coating_steps += 1;
            let peak = self.blade_force.iter().fold(0.0f64, |m, &x| m.max(x));
            self.out.peak_force = self.out.peak_force.max(peak);
        }
    }

    /// Elastic stiffness `E A_r / e_abr` (N/m) of the elements of row `r`.
    pub(super) fn elastic_stiffness(&self, row: usize) -> f64 {
        let m = self.layer.material();
        m.young * self.layer.tip_area()[row] / m.thickness
    }

    /// Step 1 of the stage (see the type doc): trial forces of every node from the predicted
    /// projections; fills `fi`, `fc`, `blade_force`. Returns whether any force is non-zero.
    pub(super) fn apply(
        &mut self,
        fr: &StepFrames,
        proj: &[Projection],
        gam: &[Vector3<f64>],
        gam_prev: &[Vector3<f64>],
    ) -> Result<bool, SimError> {
        self.pending.clear();
        self.removals.clear();
        self.blade_force.iter_mut().for_each(|x| *x = 0.0);
        self.torque = 0.0;
        let e_abr = self.layer.material().thickness;
        let mut any = false;
        for (node, p) in proj.iter().enumerate() {
            // Beyond the unworn surface (or a stale projection, provably beyond the projector's
            // margin e_abr): no element to look up.
            if p.gap >= e_abr {
                continue;
            }
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
            let t = if self.mu > 0.0 {
                // Relative increment of the node w.r.t. the casing material point (eq. 15):
                // only friction reads it.
                let mut inc = gam[node] - gam_prev[node];
                if fr.casing.is_some() {
                    inc -= fr
                        .past
                        .increment(fr.spline, fr.q, node, &p.param, fr.lazy)?;
                }
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
            self.torque += gam[node].cross(&fdir).z;
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
    pub(super) fn flag_penetrations(
        &mut self,
        nci: usize,
        proj: &[Projection],
    ) -> Result<(), SimError> {
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
    pub(super) fn commit(&mut self) -> Result<(), SimError> {
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

    /// The final coating probes.
    pub(super) fn finish(mut self) -> Result<CoatingOutput, SimError> {
        self.out.final_wear = (0..self.layer.n_rows())
            .map(|r| self.layer.wear_profile(r))
            .collect::<Result<_, _>>()?;
        self.out.removed_elements = self.removed_row.clone();
        self.out.max_wear_final = self.layer.max_wear();
        Ok(self.out)
    }
}

impl CoatingStage {
    /// Refuses a coating too stiff for the explicit treatment of its force. The coating force
    /// is evaluated on the predicted position and applied through `A⁻¹`: for a node of normal
    /// flexibility `w = nᵀ A⁻¹ n` (impeller + casing, m/N, ∝ h²) on an element of stiffness
    /// `k = E A / e_abr` the step map is `u ← (1 − k w) u*`, stable for `k w < 4/3` and
    /// non-oscillating for `k w < 1`, which is required here.
    pub(super) fn check_stability(
        &self,
        blades: &mut Blades,
        casing: Option<&mut FlexibleCasing>,
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
        let w_i = unit_radial(blades.kernel.get_mut(), &blades.radial);
        let w_c = casing.map_or(0.0, |f| {
            unit_radial(f.kernel.get_mut(), &f.radial)
                .into_iter()
                .fold(0.0f64, f64::max)
        });
        for (j, wi) in w_i.iter().enumerate() {
            let k = self.elastic_stiffness(self.row_of[j]);
            let ratio = k * (wi + w_c);
            if ratio.is_nan() || ratio >= 1.0 {
                return Err(SimError::InvalidCase(format!(
                    "coating too stiff for the time step: row {} has E·A/e_abr = {k:.3e} N/m and \
                     contact flexibility {:.3e} m/N, k·w = {ratio:.3} ≥ 1; reduce numerics.time_step_s \
                     (k·w ∝ h²) or the tip area, or set numerics.boundary \"massless\" (the coating \
                     force is then solved with the displacement)",
                    self.row_of[j],
                    wi + w_c
                )));
            }
        }
        Ok(())
    }
}

/// The coating's boxes of the time loop (Fig. 11).
impl Simulation<'_> {
    /// Box 3b (Fig. 11): the abradable coating's known forces, applied like corrections, then
    /// the re-projection so that the Lagrange problem sees them in its predicted gaps.
    pub(super) fn coating(&mut self) -> Result<(), SimError> {
        let (Some(cs), Casing::Surface(side)) = (self.coating.as_mut(), &mut self.casing) else {
            return Ok(());
        };
        if cs.implicit() {
            // A massless boundary: the elements' laws join the contact problem (box 4).
            return cs.laws_of(self.blades.n_contact, &self.projector.proj);
        }
        let fr = StepFrames {
            spline: &side.spline,
            q: &side.q,
            past: &side.past,
            lazy: side.lazy_table(),
            casing: side.flexible.as_ref().map(|f| &f.frames),
            r_om: &self.r_om,
            rot_i: &self.blades.rot,
            nci: self.blades.n_contact,
        };
        let any = cs.apply(
            &fr,
            &self.projector.proj,
            &self.blades.nodes,
            &self.blades.nodes_prev,
        )?;
        if !any {
            return Ok(());
        }
        self.drive_work -= self.case.angular_velocity() * cs.torque * self.summary.time_step;
        // Fused with the next predictors, as the Lagrange correction is (box 5): most coating
        // steps have no Lagrange contact, and their next `predict` then only swaps in the
        // predictor formed here. A Lagrange correction that follows forms it again from the
        // fully corrected state (`correct_then_predict` may be repeated before `advance`).
        let next_load = self.case.load_factor(self.t1);
        self.blades
            .kernel
            .get_mut()
            .correct_then_predict(&cs.fi, 0.0);
        if let Some(f) = side.flexible.as_mut() {
            f.kernel.get_mut().correct_then_predict(&cs.fc, next_load);
        }
        side.refresh()?;
        self.blades.place(&self.r_om);
        let p = &mut self.projector;
        let (eps, spline, q) = (p.eps, &side.spline, &side.q);
        // Only the nodes that may now touch the bare casing (the Lagrange candidates of box 3):
        // the others keep a gap provably above 0, and a sample step finds the exact minimum gap
        // in `gaps`.
        let found = p.bounds.project_near(
            spline,
            q,
            &self.blades.nodes,
            &mut p.warm,
            eps,
            &mut p.proj,
            0.0,
            false,
        );
        found.map_err(projection_failed(self.t1))?;
        cs.flag_penetrations(self.blades.n_contact, &self.projector.proj)?;
        Ok(())
    }

    /// With a coating on a massless boundary: this step's coating forces on both boundaries,
    /// and their history `F_{n−1} − F_n` to the next predictors' inertial modes (see
    /// [`CoatingStage`]), before the corrections that form those predictors.
    pub(super) fn coating_history(&mut self) -> Result<(), SimError> {
        let (Some(cs), Casing::Surface(side)) = (
            self.coating.as_mut().filter(|cs| cs.implicit()),
            &mut self.casing,
        ) else {
            return Ok(());
        };
        let c = &self.contact;
        let nbi = self.blades.nb;
        let fi = cs.history_i.start();
        let fc = cs.history_c.start();
        let mut loaded = false;
        for (k, (cd, &l)) in c.cands.iter().zip(&c.lambda).enumerate() {
            if l == 0.0 || !c.on_coating(k) {
                continue;
            }
            loaded = true;
            cd.add_blade_force(l, nbi, fi);
            if let Some(f) = &side.flexible {
                cd.add_casing_force(l, (&f.frames, &side.spline), (&mut cs.wu, &mut cs.wv), fc)?;
            }
        }
        if loaded {
            cs.history_i.mark_loaded();
            cs.history_c.mark_loaded();
        }
        if let Some(load) = cs.history_i.load() {
            self.blades.kernel.get_mut().add_inertial_load(load);
        }
        if let Some(f) = side.flexible.as_mut() {
            if loaded {
                f.frames.finish_forces(cs.history_c.now_mut());
            }
            if let Some(load) = cs.history_c.load() {
                f.kernel.get_mut().add_inertial_load(load);
            }
        }
        Ok(())
    }

    /// With a coating on a massless boundary: the coating forces and plastic shortenings the
    /// contact solve found (box 4), into the coating's forces per blade and its pending
    /// element states.
    pub(super) fn coating_forces(&mut self) -> Result<(), SimError> {
        let (Some(cs), c) = (self.coating.as_mut(), &self.contact) else {
            return Ok(());
        };
        for (k, cd) in c.cands.iter().enumerate() {
            if c.on_coating(k) {
                // `refine_contact` leaves the gaps after the correction in `d`.
                cs.implicit_force(cd.node, cd.blade, (c.lambda[k], c.plastic[k], c.d[k]))?;
            }
        }
        cs.finish_step();
        Ok(())
    }
}

/// The gap (m) at angle `theta` (rad) of a tip going the shorter way round from `[θ₀, d₀]`
/// to `[θ₁, d₁]` (angle in rad, gap in m) with its gap linear in the angle.
fn gap_along_path([t0, d0]: [f64; 2], [t1, d1]: [f64; 2], theta: f64) -> f64 {
    let turn = |a: f64| (a + PI).rem_euclid(TAU) - PI;
    d0 + (d1 - d0) * turn(theta - t0) / turn(t1 - t0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gap_along_a_path_is_linear_in_the_angle_across_the_closing_line() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-15;
        assert!(close(
            gap_along_path([0.1, 2e-4], [0.3, 1e-4], 0.15),
            1.75e-4
        ));
        // Backwards, and across θ = ±π: from 3.1 rad to −3.1 rad is 0.0832 rad forward.
        assert!(close(
            gap_along_path([0.3, 1e-4], [0.1, 2e-4], 0.25),
            1.25e-4
        ));
        let span = TAU - 6.2;
        let at = gap_along_path([3.1, 0.0], [-3.1, 1e-4], PI);
        assert!(close(at, 1e-4 * (PI - 3.1) / span), "{at}");
        let at = gap_along_path([3.1, 0.0], [-3.1, 1e-4], -3.12);
        assert!(close(at, 1e-4 * (TAU - 3.12 - 3.1) / span), "{at}");
    }
}
