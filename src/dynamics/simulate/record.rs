//! Box 6 of the time step (the paper's Figs. 4 and 11): on sample steps, the probes of the new
//! state (blade and casing displacements, contact and coating forces, energies, the probes of
//! the spec) handed to the recorder.

use super::{Casing, Kernel, SimError, Simulation, node_disp, projection_failed};
use crate::contact::project_nodes;
use crate::dynamics::probes::{ProbeQuantity, ProbeTarget, RecoveryEval, Stage};
use crate::dynamics::recorder::{CoatingSample, Recorder, Sample};
use crate::model::rom::Recovery;

impl Simulation<'_> {
    /// Box 6: on sample steps, the probes of the new state, handed to `recorder`.
    pub(super) fn record(&mut self, recorder: &mut dyn Recorder) -> Result<(), SimError> {
        if !self.sample_step {
            self.clock.lap(Stage::Other);
            return Ok(());
        }
        // The blade tips' buffers hold this state: `track_peaks` fills them on every step.
        let mut casing_energy = None;
        if let Some(cs) = self.casing.surface_mut()
            && let Some(f) = cs.flexible.as_mut()
        {
            let k = f.kernel.get_mut();
            if !self.case.casing_probes.is_empty() {
                k.node_displacements(&mut f.nodes);
            }
            let nbc = 3 * cs.rows;
            for (x, p) in self.casing_radial.iter_mut().zip(&self.case.casing_probes) {
                *x = f.radial[p[1]].dot(&node_disp(&f.nodes, p[0], nbc, p[1]));
            }
            casing_energy = Some(k.energies());
        }
        self.probe_values()?;
        let b = &self.blades;
        let ki = b.kernel.get();
        ki.nd_strain_energy(&mut self.nd_energy);
        let impeller_energy = ki.energies();
        self.sample_energy = impeller_energy.total() + casing_energy.map_or(0.0, |e| e.total());
        let sample = Sample {
            time: self.t1,
            blade_le_radial: &self.le,
            blade_te_radial: &self.te,
            casing_radial: &self.casing_radial,
            blade_normal_force: &self.contact.force_n,
            blade_tangential_force: &self.contact.force_t,
            min_gap: self.min_gap,
            residual_penetration: self.residual,
            drive_work: self.drive_work,
            impeller_energy,
            casing_energy,
            impeller_nd_strain_energy: &self.nd_energy,
            coating: self.coating.as_ref().map(|c| CoatingSample {
                max_wear: &c.max_wear_row,
                blade_force: &c.blade_force,
            }),
            probe_columns: &self.probes,
            probes: &self.probe_values,
        };
        recorder.record(&sample).map_err(SimError::Record)?;
        self.clock.lap(Stage::Other);
        Ok(())
    }

    /// The values of the case's probes at the sample step (reads the state, never writes it).
    fn probe_values(&mut self) -> Result<(), SimError> {
        if self.probes.is_empty() {
            return Ok(());
        }
        let b = &self.blades;
        if let Some((_, _, x)) = self.recovery.as_mut() {
            b.kernel.get().harmonic_state(x);
        }
        if let (Some((_, _, x)), Some(f)) = (self.casing_recovery.as_mut(), self.casing.flexible())
        {
            f.kernel.get().harmonic_state(x);
        }
        if let Some(f) = self.casing.flexible_mut()
            && self
                .probes
                .iter()
                .any(|p| matches!(p.target, ProbeTarget::Casing { .. }))
        {
            f.kernel.get_mut().node_displacements(&mut f.nodes);
        }
        for i in 0..self.probes.len() {
            self.probe_values[i] = self.probe_value(i)?;
        }
        Ok(())
    }

    /// The value of probe `i` (m or N).
    fn probe_value(&mut self, i: usize) -> Result<f64, SimError> {
        let p = &self.probes[i];
        let b = &self.blades;
        Ok(match (p.target, p.quantity) {
            (ProbeTarget::Recovery { blade, index }, _) => {
                let rec = recovery_of(&self.recovery, "impeller", &p.column)?;
                p.direction
                    .dot(&rec.1.displacement(&rec.0, index, blade, &rec.2))
            }
            (ProbeTarget::CasingRecovery { sector, index }, _) => {
                let rec = recovery_of(&self.casing_recovery, "flexible casing", &p.column)?;
                p.direction
                    .dot(&rec.1.displacement(&rec.0, index, sector, &rec.2))
            }
            (ProbeTarget::Casing { sector, index }, _) => {
                let flexible = self
                    .casing
                    .surface()
                    .and_then(|cs| Some((cs.flexible.as_ref()?, cs.rows)));
                let Some((f, rows)) = flexible else {
                    return Err(SimError::InvalidCase(format!(
                        "probe `{}` needs a flexible casing",
                        p.column
                    )));
                };
                p.direction
                    .dot(&node_disp(&f.nodes, sector, 3 * rows, index))
            }
            (ProbeTarget::Blade { blade, index }, q) => {
                let node = blade * b.n_contact + index;
                let cand = self.contact.cands.iter().position(|c| c.node == node);
                let lambda = cand.map_or(0.0, |k| self.contact.lambda[k]);
                match q {
                    ProbeQuantity::Displacement => {
                        let ub = b.kernel.get().boundary();
                        p.direction.dot(&node_disp(ub, blade, b.nb, index))
                    }
                    ProbeQuantity::NormalForce => lambda,
                    ProbeQuantity::TangentialForce => {
                        let slip = cand.is_some_and(|k| self.contact.cands[k].slip);
                        if slip {
                            self.case.friction * lambda
                        } else {
                            0.0
                        }
                    }
                    ProbeQuantity::Gap => self.probe_gap(node)?,
                }
            }
        })
    }

    /// Gap (m) of blade-tip node `node` after the step: its corrected position projected on
    /// the casing surface after the correction (the one the residual check uses), from its
    /// warm start; exact, where the step's `d*` is predicted (and stale for nodes the
    /// projector skipped as far). Scratch buffers only: the state is not changed.
    fn probe_gap(&mut self, node: usize) -> Result<f64, SimError> {
        let cs = match &self.casing {
            Casing::Surface(cs) => cs,
            Casing::Imposed(imposed) => {
                return Ok(imposed.gap(node, self.t1, self.blades.kernel.get().boundary()));
            }
        };
        let fast = matches!(
            cs.flexible.as_ref().map(|f| &f.kernel),
            Some(Kernel::Modal { .. })
        );
        // `advance` has moved a flexible casing's surface of this step to `past.q`.
        let q = match (&cs.flexible, fast && !self.contact.cands.is_empty()) {
            (None, _) => &cs.q,
            (Some(_), true) => &cs.q_corrected,
            (Some(_), false) => &cs.past.q,
        };
        let p = &mut self.projector;
        p.res_warm[0] = p.warm[node];
        let found = project_nodes(
            &cs.spline,
            q,
            &self.blades.nodes[node..node + 1],
            &mut p.res_warm,
            p.eps,
            &mut p.res_proj,
        );
        found.map_err(projection_failed(self.t1))?;
        Ok(p.res_proj[0].gap)
    }
}

/// The recovery rows, their evaluator and the harmonic state of `structure` that probe
/// `column` reads; an error when the structure kept none.
fn recovery_of<'a>(
    recovery: &'a Option<(Recovery, RecoveryEval, Vec<f64>)>,
    structure: &str,
    column: &str,
) -> Result<&'a (Recovery, RecoveryEval, Vec<f64>), SimError> {
    recovery.as_ref().ok_or_else(|| {
        SimError::InvalidCase(format!(
            "probe `{column}` needs the {structure}'s recovery rows"
        ))
    })
}
