//! The time loop (paper Figs. 4 and 11) as a [`Simulation`]: built once from a case by
//! [`Simulation::new`] (the stability limit, both kernels, the casing surface, the load), then
//! advanced by [`Simulation::step`], one method per box of the flowchart: `predict` both
//! structures, rebuild the casing surface (`casing_surface`) from the predicted casing,
//! `project` every blade-tip node and take its gap, apply the abradable `coating` (Fig. 11),
//! and when some gap is negative solve the contact (`contact_solve`) and `correct` both
//! structures; then `advance` and `record` a sample for the caller's [`Recorder`]. With a
//! massless boundary the coating's forces are not applied in `coating` but solved with the
//! contact (`contact_solve`, see `CoatingStage`).
//!
//! Beside the loop, one file per concept: `blades` (the impeller side), `casing_side` (the
//! spline surface, the flexible casing and its frames), `contact_problem` (box 4's
//! candidates, Delassus operator and corrected gaps), `free_edge` (its rows where tips
//! overhang the casing's edges), `coating_stage` (Fig. 11), `record` (box 6),
//! `runaway_watch`, and `setup` ([`Simulation::new`]).

use crate::contact::spline::{cubic_basis, real_row_weights};
use crate::contact::{
    Along, CasingSpline, GapBounds, LocalSurface, NodeProjectionError, Projection, SurfaceParam,
    closest_point, closest_point_local, friction_direction, project_nodes,
};
use crate::dynamics::abradable::{AbradableError, CoatingLaw, CoatingLayer, ElementUpdate};
use crate::dynamics::contact_solve::{
    CoatedBuffers, ControlFlexTable, ControlWeights, NodeFlexTable, PatchFlexibility,
    active_set_solve, coated_solve,
};
use crate::dynamics::dense::DenseKernel;
use crate::dynamics::imposed_casing::ImposedCasing;
use crate::dynamics::kernel::StructureKernel;
use crate::dynamics::low_pass::{BLADE_BAND_HZ, BesselLowPass, LowPassPeak};
use crate::dynamics::modal::ModalKernel;
use crate::dynamics::numerics::{Boundary, KernelChoice, STEPS_PER_PERIOD, STEPS_PER_REVOLUTION};
use crate::dynamics::probes::{
    CoatingOutput, Probe, ProbeTarget, RecoveryEval, RunSummary, SimulationOutput, Stage,
    StageClock, resolve_probes,
};
use crate::dynamics::recorder::{RecordError, Recorder, SeriesRecorder};
use crate::dynamics::runaway::Runaway;
use crate::dynamics::scenario::{Case, CasingModel, CoatingCase};
use crate::dynamics::structure::{Structure, StructureError};
use crate::model::cyclic::rot_z;
use crate::model::rom::CyclicRom;
use crate::model::rom::Recovery;
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, Ordering};
use thiserror::Error;

/// Why a simulation could not run or stopped.
#[derive(Debug, Error)]
pub enum SimError {
    /// The case does not fit its models (the reason says which setting).
    #[error("invalid case: {0}")]
    InvalidCase(String),
    /// A ROM could not be frozen at the case's speed.
    #[error(transparent)]
    Structure(#[from] StructureError),
    /// The time step is at or above the explicit stability limit.
    #[error(
        "time step h = {h:.4e} s is at or above the explicit stability limit 2/ω_max = {limit:.4e} s (ω_max = {omega_max:.4e} rad/s, {which}){rev}"
    )]
    Unstable {
        /// Time step (s).
        h: f64,
        /// Stability limit 2/ω_max (s).
        limit: f64,
        /// Highest natural circular frequency (rad/s).
        omega_max: f64,
        /// Which structure sets the limit.
        which: String,
        /// The steps per revolution the limit allows, as text (empty at Ω = 0).
        rev: String,
    },
    /// The casing spline could not be built or evaluated.
    #[error("casing spline: {0}")]
    Spline(String),
    /// The closest-point projection of a blade-tip node failed.
    #[error("closest-point projection failed at t = {time:.6e} s: {reason}")]
    Projection {
        /// Time (s) of the step.
        time: f64,
        /// What failed.
        reason: String,
    },
    /// The state became non-finite, or the contact could not be solved.
    #[error("simulation diverged at t = {time:.6e} s: {reason}")]
    Diverged {
        /// Time (s) of the step.
        time: f64,
        /// What diverged.
        reason: String,
    },
    /// The caller's cancel flag was raised.
    #[error("simulation cancelled at t = {time:.6e} s")]
    Cancelled {
        /// Simulated time (s) reached.
        time: f64,
    },
    /// The abradable coating could not be built or updated.
    #[error("abradable coating: {0}")]
    Coating(#[from] AbradableError),
    /// The recorder could not keep a sample.
    #[error("recording the output: {0}")]
    Record(RecordError),
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

/// Residual penetration, as a share of the largest blade-tip displacement so far, above which
/// the contact is no longer exact: a runaway that takes the solve there is confirmed at once
/// (`Simulation::runaway_at_breakdown`), so that what a runaway job reports was computed with
/// exact contact.
pub const EXACT_CONTACT_SHARE: f64 = 1e-8;

/// The error of a failed closest-point projection at time `time` (s).
fn projection_failed(time: f64) -> impl Fn(NodeProjectionError) -> SimError {
    move |e| SimError::Projection {
        time,
        reason: e.to_string(),
    }
}

/// The linear-algebra kernel of one structure with the flexibility the contact solve reads:
/// the fast modal kernel with its precomputed table `T`, or the dense reference with its
/// boundary flexibility `A⁻¹` restricted to the boundary DOFs.
#[derive(Clone)]
enum Kernel<T> {
    Modal {
        kernel: ModalKernel,
        table: T,
    },
    Dense {
        kernel: DenseKernel,
        flexibility: Mat<f64>,
    },
}

impl<T> Kernel<T> {
    /// The kernel of `choice` for `st` at step `h`; `table` builds the fast kernel's table.
    fn new(
        st: &Structure,
        h: f64,
        choice: KernelChoice,
        table: impl FnOnce(&mut ModalKernel) -> T,
    ) -> Result<Self, SimError> {
        Ok(match choice {
            KernelChoice::Fast => {
                let mut kernel = ModalKernel::new(st, h)?;
                let table = table(&mut kernel);
                Kernel::Modal { kernel, table }
            }
            KernelChoice::DenseReference => {
                let kernel = DenseKernel::new(st, h);
                let flexibility = kernel.boundary_flexibility().to_owned();
                Kernel::Dense {
                    kernel,
                    flexibility,
                }
            }
        })
    }

    fn get(&self) -> &dyn StructureKernel {
        match self {
            Kernel::Modal { kernel, .. } => kernel,
            Kernel::Dense { kernel, .. } => kernel,
        }
    }

    fn get_mut(&mut self) -> &mut dyn StructureKernel {
        match self {
            Kernel::Modal { kernel, .. } => kernel,
            Kernel::Dense { kernel, .. } => kernel,
        }
    }
}

/// Gap tolerance of the contact correction, relative to the casing radius R: after the
/// correction no contact candidate penetrates the corrected casing by more than
/// `GAP_TOLERANCE · R` (m), active or not: the active set of the contact solve is iterated
/// to it, imposed gaps are linear so it holds exactly there, and on a casing surface the
/// Newton iterations of box 4b take the curved gaps to it. At R = 0.2 m that is 2e-13 m: about
/// 10³ times the round-off of a gap `n · (x − S)` between points at that radius, and 1e-8 of
/// a vibration level of 20 µm (the paper's residual check, §3.3.3).
pub const GAP_TOLERANCE: f64 = 1e-12;

/// One simulation of a case (paper Fig. 4), stepped by [`Simulation::step`].
pub struct Simulation<'a> {
    case: &'a Case,
    blades: Blades,
    casing: Casing,
    projector: Projector,
    contact: ContactProblem,
    coating: Option<CoatingStage>,
    summary: RunSummary,
    clock: StageClock,
    /// Steps done; this step's end time t_{n+1} (s), its rotation R(Ω t_{n+1}), whether it is
    /// a sample step, its minimum predicted gap (m) and residual penetration (m).
    steps_done: usize,
    t1: f64,
    r_om: Matrix3<f64>,
    sample_step: bool,
    min_gap: f64,
    residual: f64,
    drive_work: f64,
    /// The flexible casing's critical wave speed (rad/s) and its nodal diameter
    /// ([`Structure::critical_wave_speed`]).
    casing_wave: Option<(f64, usize)>,
    /// Whether some blade-tip node's predicted gap to the casing itself is negative.
    rubs: bool,
    /// The runaway watch (`None` when `numerics.stop_on_runaway` is off) and the runaway it
    /// confirmed, which ends the run.
    watch: Option<RunawayWatch>,
    runaway: Option<Runaway>,
    /// Vibration energy (J) of both structures at the last sample step (box 6 computes it).
    sample_energy: f64,
    /// The blade tips' leading- and trailing-edge radial displacements low-passed at
    /// [`BLADE_BAND_HZ`](crate::dynamics::low_pass::BLADE_BAND_HZ); `None` when the step is
    /// too long to resolve that band.
    blade_band_peaks: Option<[LowPassPeak; 2]>,
    /// Probe buffers (per blade, per casing probe, per nodal diameter): the blade tips' on
    /// every step, the others on sample steps.
    le: Vec<f64>,
    te: Vec<f64>,
    casing_radial: Vec<f64>,
    nd_energy: Vec<f64>,
    /// The case's probes and their values at the sample step.
    probes: Vec<Probe>,
    probe_values: Vec<f64>,
    /// The impeller's recovery rows, their evaluator and its harmonic-state buffer (only when
    /// a probe reads a recovery node).
    recovery: Option<(Recovery, RecoveryEval, Vec<f64>)>,
    /// The same for the flexible casing (only when a probe reads one of its recovery nodes).
    casing_recovery: Option<(Recovery, RecoveryEval, Vec<f64>)>,
}

impl<'a> Simulation<'a> {
    /// The time step h (s): the case's, or the default of [`default_time_step`].
    pub fn time_step(&self) -> f64 {
        self.summary.time_step
    }

    /// Runs every step, polling `cancel` every 1024 steps; hands each sample to `recorder`.
    /// A confirmed runaway ends the run early, with the finding in the summary; so does a
    /// growth that takes the contact solve past exactness or breaks it before the watch has
    /// confirmed it (`Simulation::runaway_at_breakdown`), at the step before.
    pub fn run(
        mut self,
        recorder: &mut dyn Recorder,
        cancel: Option<&AtomicBool>,
    ) -> Result<RunSummary, SimError> {
        let start = std::time::Instant::now();
        self.clock = StageClock::new();
        while self.steps_done < self.summary.n_steps {
            if self.steps_done.is_multiple_of(1024)
                && let Some(c) = cancel
                && c.load(Ordering::Relaxed)
            {
                return Err(SimError::Cancelled {
                    time: self.steps_done as f64 * self.summary.time_step,
                });
            }
            if let Err(e) = self.step(recorder)
                && self.runaway.is_none()
            {
                let broke = matches!(e, SimError::Diverged { .. } | SimError::Projection { .. });
                let runaway = broke.then(|| self.runaway_at_breakdown()).flatten();
                self.runaway = Some(runaway.ok_or(e)?);
            }
            if self.runaway.is_some() {
                break;
            }
        }
        self.summary.steps_run = self.steps_done;
        self.summary.runaway = self.runaway;
        self.summary.loop_seconds = start.elapsed().as_secs_f64();
        self.summary.stage_seconds = self.clock.seconds;
        self.summary.coating = self.coating.map(CoatingStage::finish).transpose()?;
        Ok(self.summary)
    }

    /// One time step t_n → t_{n+1} (paper Figs. 4 and 11).
    pub fn step(&mut self, recorder: &mut dyn Recorder) -> Result<(), SimError> {
        self.staged_step(recorder).map_err(|e| self.explain(e))
    }

    /// `e` with, when the response ran away above the flexible casing's critical wave speed,
    /// the energy the rotation fed in: a diverged or failed contact there is the moving-load
    /// instability of the casing's waves (forward in the fixed frame, slower than the blades),
    /// not a fault of the solve.
    fn explain(&self, e: SimError) -> SimError {
        let Some((omega_c, k)) = self.casing_wave.filter(|w| self.case.omega > w.0) else {
            return e;
        };
        let context = format!(
            " (Ω = {:.1} rad/s is above the flexible casing's critical wave speed {omega_c:.1} \
             rad/s, nodal diameter {k}, where the rotating contact can feed the casing's \
             waves, slower than the blades: the rotation had done {:.4e} J of work through the \
             contact forces)",
            self.case.omega, self.drive_work
        );
        match e {
            SimError::Diverged { time, reason } => SimError::Diverged {
                time,
                reason: reason + &context,
            },
            SimError::Projection { time, reason } => SimError::Projection {
                time,
                reason: reason + &context,
            },
            other => other,
        }
    }

    /// The boxes of one step, in the order of the paper's Figs. 4 and 11.
    fn staged_step(&mut self, recorder: &mut dyn Recorder) -> Result<(), SimError> {
        self.predict();
        self.casing_surface()?;
        self.project()?;
        self.coating()?;
        self.gaps()?;
        if !self.contact.cands.is_empty() {
            if self.rubs {
                self.summary.contact_steps += 1;
            }
            loop {
                self.friction_directions()?;
                self.contact_solve()?;
                if !self.admit_pushed_nodes() {
                    break;
                }
            }
            self.refine_contact()?;
            self.coating_history()?;
            self.correct()?;
            self.coating_forces()?;
        } else {
            self.coating_history()?;
        }
        self.advance()?;
        self.record(recorder)?;
        self.watch_runaway();
        Ok(())
    }

    /// Box 1: the predictors `u*_{n+1}` of both structures (the casing under its load).
    fn predict(&mut self) {
        let h = self.summary.time_step;
        let t_n = self.steps_done as f64 * h;
        // The same expression as the next step's t_n (the fused predictor checks its amplitude).
        self.t1 = (self.steps_done + 1) as f64 * h;
        self.r_om = rot_z(self.case.angular_velocity() * self.t1);
        self.sample_step = (self.steps_done + 1).is_multiple_of(self.case.numerics.decimation);
        self.blades.kernel.get_mut().predict(0.0);
        if let Some(f) = self.casing.flexible_mut() {
            f.kernel.get_mut().predict(self.case.load_factor(t_n));
        }
        self.clock.lap(Stage::Predict);
    }

    /// Box 2: the casing spline's control points on the predicted casing (eq. 13).
    fn casing_surface(&mut self) -> Result<(), SimError> {
        if let Some(cs) = self.casing.surface_mut() {
            cs.refresh()?;
        }
        self.clock.lap(Stage::Spline);
        Ok(())
    }

    /// Box 3: the blade-tip nodes and their closest points on the casing (eq. 14), for the
    /// nodes that may be closer than the projector's margin; or their imposed gaps.
    fn project(&mut self) -> Result<(), SimError> {
        self.blades.place(&self.r_om);
        if !self.blades.nodes_predicted.is_empty() {
            self.blades
                .nodes_predicted
                .copy_from_slice(&self.blades.nodes);
        }
        let p = &mut self.projector;
        let cs = match &self.casing {
            Casing::Surface(cs) => cs,
            Casing::Imposed(imposed) => {
                let b = &self.blades;
                let ub = b.kernel.get().boundary();
                imposed.gaps(self.t1, ub, &self.r_om, &b.rot, &b.nodes, &mut p.proj);
                return Ok(());
            }
        };
        p.bounds.next_step();
        let found = p.bounds.project_near(
            &cs.spline,
            &cs.q,
            &self.blades.nodes,
            &mut p.warm,
            p.eps,
            &mut p.proj,
            p.margin,
            false,
        );
        found.map(drop).map_err(projection_failed(self.t1))
    }

    /// The contact candidates: every blade-tip node of negative predicted gap d* (eq. 14).
    /// On sample steps the minimum gap is made exact: the skipped nodes that may hold it are
    /// projected aside, changing no state (the same states whatever the decimation).
    fn gaps(&mut self) -> Result<(), SimError> {
        let c = &mut self.contact;
        c.cands.clear();
        c.force_n.iter_mut().for_each(|x| *x = 0.0);
        c.force_t.iter_mut().for_each(|x| *x = 0.0);
        self.residual = 0.0;
        self.min_gap = f64::INFINITY;
        self.rubs = false;
        let laws = self.coating.as_ref().map_or(&[][..], |cs| &cs.node_law[..]);
        for (node, p) in self.projector.proj.iter().enumerate() {
            if !p.gap.is_finite() {
                return Err(SimError::Diverged {
                    time: self.t1,
                    reason: format!("non-finite gap at blade node {node}"),
                });
            }
            self.min_gap = self.min_gap.min(p.gap);
            self.rubs |= p.gap < 0.0;
            if p.gap < 0.0 || laws.get(node).is_some_and(Option::is_some) {
                c.cands.push(Cand::at(node, self.blades.n_contact, p));
            }
        }
        // Imposed gaps are all computed: their minimum is exact already.
        if self.sample_step
            && let Some(cs) = self.casing.surface()
        {
            let p = &mut self.projector;
            let exact = p.bounds.exact_min_gap(
                &cs.spline,
                &cs.q,
                &self.blades.nodes,
                &p.warm,
                p.eps,
                self.min_gap,
            );
            self.min_gap = exact.map_err(projection_failed(self.t1))?;
        }
        self.clock.lap(Stage::Projection);
        Ok(())
    }

    /// The friction direction of each candidate from its slip increment relative to the
    /// casing material point (eq. 15), and its rows in the blade's frame.
    fn friction_directions(&mut self) -> Result<(), SimError> {
        let mu = self.case.friction;
        let (b, flexible) = (
            &self.blades,
            self.casing.surface().filter(|cs| cs.flexible.is_some()),
        );
        let rt = self.r_om.transpose();
        for cd in self.contact.cands.iter_mut() {
            let mut inc = b.nodes[cd.node] - b.nodes_prev[cd.node];
            if let Some(cs) = flexible {
                inc -= cs
                    .past
                    .increment(&cs.spline, &cs.q, cd.node, &cd.param, cs.lazy_table())?;
            }
            let t = if mu > 0.0 {
                friction_direction(&cd.n, &inc)
            } else {
                None
            };
            cd.slip = t.is_some();
            cd.fdir = cd.n + t.unwrap_or_else(Vector3::zeros) * mu;
            let to_loc = b.rot[cd.blade].transpose() * rt;
            cd.g_loc = to_loc * cd.n;
            cd.f_loc = to_loc * cd.fdir;
        }
        Ok(())
    }

    /// Imposed gaps: the nodes that were not candidates (their predicted gap was open) but
    /// that the correction of the others pushes into the casing (the blade's flexibility
    /// couples its tip nodes) join the candidates, and the contact is solved again. Returns
    /// whether any joined. The gaps are exact and cheap here; on a casing surface a node's
    /// gap after the others' correction needs its own flexibility rows (not done yet).
    fn admit_pushed_nodes(&mut self) -> bool {
        let Casing::Imposed(imposed) = &self.casing else {
            return false;
        };
        let tol = self.casing.gap_tolerance();
        let (b, c) = (&self.blades, &mut self.contact);
        let ub = b.kernel.get().boundary();
        let n_before = c.cands.len();
        for (node, p) in self.projector.proj.iter().enumerate() {
            if c.cands[..n_before].iter().any(|cd| cd.node == node) {
                continue;
            }
            let cand = Cand::at(node, b.n_contact, p);
            let du = blade_correction(&b.kernel, b.nb, &c.cands[..n_before], &c.lambda, &cand);
            if imposed.gap_corrected(node, self.t1, ub, &du) < -tol {
                c.cands.push(cand);
            }
        }
        c.cands.len() > n_before
    }

    /// Box 4: `W = G_i A_i⁻¹ F_iᵀ + G_c A_c⁻¹ F_cᵀ` and the multipliers λ of eq. (18).
    fn contact_solve(&mut self) -> Result<(), SimError> {
        let c = &mut self.contact;
        let nk = c.cands.len();
        for (k, cd) in c.cands.iter().enumerate() {
            c.d[k] = self.projector.proj[cd.node].gap;
        }
        let w = &mut c.w[..nk * nk];
        w.iter_mut().for_each(|x| *x = 0.0);
        match &self.blades.kernel {
            Kernel::Modal { table, .. } => {
                for (k, a) in c.cands.iter().enumerate() {
                    for (l, b) in c.cands.iter().enumerate() {
                        let blk = table.block(a.blade, b.blade, a.row, b.row);
                        w[k * nk + l] = a.g_loc.dot(&(blk * b.f_loc));
                    }
                }
            }
            Kernel::Dense { flexibility, .. } => {
                let nbi = self.blades.nb;
                dense_w(flexibility, &c.cands, nk, w, |_, cd, row, is_f| {
                    let v = if is_f { cd.f_loc } else { cd.g_loc };
                    let at = cd.blade * nbi + 3 * cd.row;
                    row[at..at + 3].copy_from_slice(v.as_slice());
                });
            }
        }
        if let Some(cs) = self.casing.surface()
            && let Some(f) = &cs.flexible
        {
            casing_w(f, &cs.spline, c, nk)?;
            free_edge::edge_rows_of_w(cs, f, c, &self.blades.nodes, &self.projector.proj)?;
        }
        let tol = self.casing.gap_tolerance();
        c.laws.clear();
        if let Some(coating) = self.coating.as_mut().filter(|cs| cs.implicit()) {
            let laws = c
                .cands
                .iter()
                .map(|cd| coating.node_law[cd.node].map(|l| l.2));
            c.laws.extend(laws);
            // A tip that the solve takes through its element to the casing has worn it
            // through: the element is removed and the tip is a Lagrange contact (as a tip
            // predicted through it is, `CoatingStage::laws_of`), until none is left.
            loop {
                c.solve_multipliers(tol, self.t1)?;
                let through = (0..nk).filter(|&k| c.laws[k].is_some()).find(|&k| {
                    let wl: f64 = (0..nk).map(|l| c.w[k * nk + l] * c.lambda[l]).sum();
                    c.d[k] + wl < -tol
                });
                let Some(k) = through else { break };
                c.laws[k] = None;
                coating.wear_through(c.cands[k].node)?;
            }
        } else {
            c.solve_multipliers(tol, self.t1)?;
        }
        self.clock.lap(Stage::ContactSolve);
        Ok(())
    }

    /// Box 4b: Newton iterations on the gaps of a casing surface (the linearised correction of
    /// eq. 18 leaves second-order residuals: surface curvature, the tangential part of the
    /// correction). The correction is linear in λ, so before it is applied the corrected
    /// tip node `x_k + Δx_k(λ)` and the casing displacement under it `ΔS_k(λ) = −Σ_l V(k, l)
    /// F_l` are known: each candidate is projected again on the predicted surface translated
    /// by `ΔS_k`. While an active candidate's gap or an inactive one's penetration exceeds the
    /// tolerance, λ is solved again on the linear model about the current λ, same `W`
    /// (`d' = g(λ) − W λ`). At most [`GAP_NEWTON_ITERATIONS`]; the residual check of box 5
    /// measures what is left on the exact corrected surface.
    fn refine_contact(&mut self) -> Result<(), SimError> {
        let Casing::Surface(cs) = &self.casing else {
            return Ok(());
        };
        let tol = self.casing.gap_tolerance();
        let nk = self.contact.cands.len();
        let c = &mut self.contact;
        c.vhat[..nk * nk].fill(None);
        c.vslope[..nk * nk].fill(None);
        c.blocks_taken[..nk].fill(false);
        for iteration in 0..=GAP_NEWTON_ITERATIONS {
            let c = &mut self.contact;
            let at = (self.t1, tol);
            corrected_gaps(&self.blades, cs, &self.r_om, c, &self.projector, at)?;
            let settled = (0..nk).all(|k| {
                // On a coating element the condition is on its compression (`coated_solve`).
                let g = match c.laws.get(k).copied().flatten() {
                    Some(law) => {
                        c.d[k] - law.remaining
                            + (c.lambda[k] + c.plastic[k] * law.stiffness) / law.stiffness
                    }
                    None => c.d[k],
                };
                if c.lambda[k] > 0.0 {
                    g.abs() <= tol
                } else {
                    g >= -tol
                }
            });
            if settled || iteration == GAP_NEWTON_ITERATIONS {
                // What is left penetrating the casing after the last correction: this step's
                // residual.
                let left = (0..nk).map(|k| -c.d[k]).fold(0.0, f64::max);
                self.residual = self.residual.max(left);
                break;
            }
            for k in 0..nk {
                let wl: f64 = (0..nk).map(|l| c.w[k * nk + l] * c.lambda[l]).sum();
                c.d[k] -= wl;
            }
            c.solve_multipliers(tol, self.t1)?;
        }
        self.clock.lap(Stage::ContactSolve);
        Ok(())
    }

    /// Box 5: the corrections `u_{n+1} = u* + A⁻¹ f_c` of both structures, opposite signs,
    /// fused with the next predictors; on sample steps the residual penetration.
    fn correct(&mut self) -> Result<(), SimError> {
        let mu = self.case.friction;
        let next_load = self.case.load_factor(self.t1);
        let c = &mut self.contact;
        let nbi = self.blades.nb;
        let b_nodes = &self.blades.nodes;
        let mut torque = 0.0;
        c.fi.iter_mut().for_each(|x| *x = 0.0);
        let lagrange = |k: &usize| !c.on_coating(*k);
        if (0..c.cands.len())
            .filter(lagrange)
            .any(|k| c.lambda[k] != 0.0)
        {
            self.summary.closed_contact_steps += 1;
        }
        for (k, (cd, &l)) in c.cands.iter().zip(&c.lambda).enumerate() {
            if l == 0.0 {
                continue;
            }
            cd.add_blade_force(l, nbi, &mut c.fi);
            // The rotation works through coating forces too.
            torque += b_nodes[cd.node].cross(&(l * cd.fdir)).z;
            if c.on_coating(k) {
                // A coating force: `coating_forces` records it.
                continue;
            }
            c.force_n[cd.blade] += l;
            self.summary.active_contacts += 1;
            if cd.slip {
                c.force_t[cd.blade] += mu * l;
            }
        }
        self.drive_work -= self.case.angular_velocity() * torque * self.summary.time_step;
        // The impeller carries no load pattern: its next predictor has amplitude 0.
        self.blades
            .kernel
            .get_mut()
            .correct_then_predict(&c.fi, 0.0);
        if self.casing.flexible().is_some() {
            self.correct_casing(next_load)?;
        }
        self.blades.place(&self.r_om);
        // Imposed gaps are exact and cheap: their residual is measured on every step.
        if self.sample_step || matches!(self.casing, Casing::Imposed(_)) {
            self.residual_penetration()?;
        }
        self.check_residual()?;
        self.clock.lap(Stage::Correction);
        Ok(())
    }

    /// This step's residual penetration (m) into the run's summary: its maximum, and a count
    /// of the steps above the gap tolerance. A divergence when above 1e-4 of the casing
    /// radius; the end of the run, this step not kept, when above [`EXACT_CONTACT_SHARE`] of
    /// the blade-tip level while the watch sees a runaway.
    fn check_residual(&mut self) -> Result<(), SimError> {
        let level = self.summary.peaks.blade_radial();
        let diverged = self.residual > 1e-4 * self.casing.radius_scale().max(1e-3);
        let tolerance = self.casing.gap_tolerance();
        let inexact = self.residual > tolerance.max(EXACT_CONTACT_SHARE * level);
        // The watch confirms runaways after a step, so none is set yet unless confirmed here.
        if !diverged && inexact && self.runaway.is_none() {
            self.runaway = self.runaway_at_breakdown();
        }
        if diverged || self.runaway.is_some() {
            return Err(SimError::Diverged {
                time: self.t1,
                reason: format!(
                    "residual penetration {:.3e} m after correction ({:.2e} of the blade-tip \
                     level {level:.3e} m)",
                    self.residual,
                    self.residual / level
                ),
            });
        }
        let s = &mut self.summary;
        s.max_residual_penetration = s.max_residual_penetration.max(self.residual);
        if self.residual > tolerance {
            s.steps_over_gap_tolerance += 1;
        }
        Ok(())
    }

    /// The casing's share of box 5. The fast kernel corrects its state without refreshing its
    /// channels: the next step sees the Lagrange loads through the control-point flexibility
    /// ([`PastSurface`]), on every step alike, so that what is recorded never changes the
    /// state. On sample steps the corrected channels are synthesised too, into a surface kept aside
    /// for the residual check.
    fn correct_casing(&mut self, next_load: f64) -> Result<(), SimError> {
        // A massless boundary's static response to these loads is found again next step:
        // the slip increments then start from the predicted surface (see `nodes_predicted`).
        let massless = self.case.numerics.boundary == Boundary::Massless;
        let c = &mut self.contact;
        let Some(cs) = self.casing.surface_mut() else {
            return Ok(());
        };
        let Some(f) = cs.flexible.as_mut() else {
            return Ok(());
        };
        let lazy = matches!(f.kernel, Kernel::Modal { .. });
        c.fc.iter_mut().for_each(|x| *x = 0.0);
        for (cd, l) in c.cands.iter().zip(&c.lambda) {
            if *l != 0.0 {
                let on = (&f.frames, &cs.spline);
                let force = cd.add_casing_force(*l, on, (&mut c.wu, &mut c.wv), &mut c.fc)?;
                if lazy && !massless {
                    c.loads.push((cd.param, force));
                }
            }
        }
        f.frames.finish_forces(&mut c.fc);
        if !lazy {
            if massless {
                cs.q_predicted.clone_from(&cs.q);
            }
            f.kernel.get_mut().correct_then_predict(&c.fc, next_load);
            cs.refresh()?;
        } else if self.sample_step {
            // The same state as `correct_state_then_predict`, and the corrected channels in
            // the same pass: the corrected surface, aside, for the residual check.
            let k = f.kernel.get_mut();
            k.correct_then_predict(&c.fc, next_load);
            f.frames.control_points(
                &cs.spline,
                k.boundary(),
                &mut cs.pnodes,
                &mut cs.q_corrected,
            )?;
        } else {
            f.kernel
                .get_mut()
                .correct_state_then_predict(&c.fc, next_load);
        }
        // The casing points the candidates touch, after the correction: moved by
        // ΔS_k = Σ_l V(k, l) F_l when the channels are not refreshed.
        let nk = c.cands.len();
        let q = if massless && !lazy {
            &cs.q_predicted
        } else {
            &cs.q
        };
        for (k, cd) in c.cands.iter().enumerate() {
            let mut x = surface_point(&cs.spline, q, &cd.param)?;
            if lazy && !massless {
                for (l, (b, lb)) in c.cands.iter().zip(&c.lambda).enumerate() {
                    x -= c.vblk[k * nk + l] * (b.fdir * *lb);
                }
            }
            c.touched[cd.node] = Some((cd.param, x));
        }
        Ok(())
    }

    /// The largest residual penetration after the correction (m), exactly: the corrected
    /// candidates re-projected on the corrected casing surface, or their imposed gaps.
    fn residual_penetration(&mut self) -> Result<(), SimError> {
        let cs = match &self.casing {
            Casing::Surface(cs) => cs,
            Casing::Imposed(imposed) => {
                let ub = self.blades.kernel.get().boundary();
                for cd in self.contact.cands.iter() {
                    let gap = imposed.gap(cd.node, self.t1, ub);
                    self.residual = self.residual.max(-gap);
                }
                return Ok(());
            }
        };
        let q = match cs.flexible.as_ref().map(|f| &f.kernel) {
            Some(Kernel::Modal { .. }) => &cs.q_corrected,
            _ => &cs.q,
        };
        let p = &mut self.projector;
        for cd in self.contact.cands.iter() {
            p.res_warm[0] = Some(cd.param);
            let found = project_nodes(
                &cs.spline,
                q,
                &self.blades.nodes[cd.node..cd.node + 1],
                &mut p.res_warm,
                p.eps,
                &mut p.res_proj,
            );
            found.map_err(projection_failed(self.t1))?;
            self.residual = self.residual.max(-p.res_proj[0].gap);
        }
        Ok(())
    }

    /// Shifts time on both structures, keeps this step's surface for the next step's slip
    /// increments, commits the coating, and checks the state is finite.
    fn advance(&mut self) -> Result<(), SimError> {
        let b = &mut self.blades;
        if b.nodes_predicted.is_empty() {
            b.nodes_prev.copy_from_slice(&b.nodes);
        } else {
            std::mem::swap(&mut b.nodes_prev, &mut b.nodes_predicted);
        }
        if let Some(cs) = self.casing.surface_mut()
            && cs.flexible.is_some()
        {
            // The next step's spline rewrites every control point of `q` (and the next
            // correction of `q_predicted`) before reading any.
            if cs.q_predicted.is_empty() {
                std::mem::swap(&mut cs.past.q, &mut cs.q);
            } else {
                std::mem::swap(&mut cs.past.q, &mut cs.q_predicted);
            }
            std::mem::swap(&mut cs.past.loads, &mut self.contact.loads);
            self.contact.loads.clear();
            std::mem::swap(&mut cs.past.touched, &mut self.contact.touched);
            self.contact.touched.iter_mut().for_each(|t| *t = None);
        }
        b.kernel.get_mut().advance();
        if let Some(f) = self.casing.flexible_mut() {
            f.kernel.get_mut().advance();
        }
        if let Some(c) = self.coating.as_mut() {
            c.commit()?;
        }
        if self.steps_done.is_multiple_of(64)
            && !(b.kernel.get().is_finite()
                && (self.casing.flexible()).is_none_or(|f| f.kernel.get().is_finite()))
        {
            return Err(SimError::Diverged {
                time: self.t1,
                reason: "non-finite state".into(),
            });
        }
        self.track_peaks();
        self.steps_done += 1;
        Ok(())
    }

    /// The run's maxima ([`Peaks`](crate::dynamics::probes::Peaks)) updated with the state
    /// and forces of the step just taken: on every step, so that they do not depend on the
    /// output decimation.
    fn track_peaks(&mut self) {
        let peaks = &mut self.summary.peaks;
        let raise = |peak: &mut f64, x: f64| *peak = peak.max(x.abs());
        let b = &self.blades;
        for s in 0..b.n_blades {
            self.le[s] = b.radial_displacement(s, b.le);
            self.te[s] = b.radial_displacement(s, b.te);
            raise(&mut peaks.blade_le_radial, self.le[s]);
            raise(&mut peaks.blade_te_radial, self.te[s]);
        }
        if let Some([le, te]) = &mut self.blade_band_peaks {
            le.push(self.le.iter().copied());
            te.push(self.te.iter().copied());
            peaks.blade_le_radial_lowpass = Some(le.peak());
            peaks.blade_te_radial_lowpass = Some(te.peak());
        }
        if let Some(f) = self.casing.flexible()
            && self.steps_done.is_multiple_of(f.probe_stride)
        {
            let k = f.kernel.get();
            for g in &f.probe_functionals {
                raise(&mut peaks.casing_radial, k.functional_value(g));
            }
        }
        for &x in &self.contact.force_n {
            raise(&mut peaks.contact_normal_force, x);
        }
        if let Some(c) = &self.coating {
            for &x in &c.blade_force {
                raise(&mut peaks.coating_force, x);
            }
        }
    }
}

/// Simulates `case` for `impeller` rotating inside `casing` (paper Fig. 4) and keeps every
/// sample in memory ([`SeriesRecorder`]); `cancel` is polled every 1024 steps. For long runs
/// use [`Simulation::run`] with a recorder whose memory is bounded.
pub fn simulate(
    case: &Case,
    impeller: &CyclicRom,
    casing: &CasingModel,
    cancel: Option<&AtomicBool>,
) -> Result<SimulationOutput, SimError> {
    let mut rec = SeriesRecorder::default();
    let summary = Simulation::new(case, impeller, casing)?.run(&mut rec, cancel)?;
    Ok(rec.into_output(summary))
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

/// Frames and spline state of the current step, as seen by the coating stage.
struct StepFrames<'a> {
    spline: &'a CasingSpline,
    q: &'a [Vector3<f64>],
    past: &'a PastSurface,
    /// The fast casing kernel's control-point flexibility (see [`PastSurface`]).
    lazy: Option<&'a ControlFlexTable>,
    /// The flexible casing's frames (casing forces are then assembled); `None` if rigid.
    casing: Option<&'a CasingFrames>,
    r_om: &'a Matrix3<f64>,
    rot_i: &'a [Matrix3<f64>],
    nci: usize,
}

mod blades;
mod casing_side;
mod coating_stage;
mod contact_problem;
mod free_edge;
mod record;
mod runaway_watch;
mod setup;
#[cfg(test)]
mod tests;

use blades::Blades;
pub use casing_side::CASING_PEAK_INTERVAL;
use casing_side::{
    Casing, CasingFrames, CasingSide, FlexibleCasing, PastSurface, set_casing_load, surface_point,
};
use coating_stage::CoatingStage;
use contact_problem::{
    Cand, ContactProblem, GAP_NEWTON_ITERATIONS, Projector, blade_correction, casing_blocks_at,
    casing_w, corrected_gaps, dense_pair_blocks, dense_w, translated,
};
use runaway_watch::RunawayWatch;
pub(crate) use setup::CasingCache;
pub use setup::default_time_step;
