//! The recorded output of a simulation (decimated time series and summary numbers).

use serde::{Deserialize, Serialize};

/// Energies of one structure (J), see [`crate::dynamics::kernel::Energies`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EnergySeries {
    pub kinetic: Vec<f64>,
    pub strain: Vec<f64>,
}

/// Output of [`crate::dynamics::simulate::simulate`]: the series of every sample step and the
/// run's [`RunSummary`]. Every series has one entry per sample (`time.len()`); per-blade
/// series are indexed `[blade][sample]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SimulationOutput {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// Radial displacement (m, rotating frame, positive outward) of each blade's leading-edge
    /// tip node (contact row 0) and trailing-edge node (last row).
    pub blade_le_radial: Vec<Vec<f64>>,
    pub blade_te_radial: Vec<Vec<f64>>,
    /// Radial displacement (m, positive outward) of the requested casing contact nodes
    /// (`Case::casing_probes` order; empty for a rigid casing).
    pub casing_radial: Vec<Vec<f64>>,
    /// Per blade, sum over its tip nodes of the normal contact force λ (N) at the sample step.
    pub blade_normal_force: Vec<Vec<f64>>,
    /// Per blade, sum of the tangential (friction) force magnitudes μλ (N) at the sample step.
    pub blade_tangential_force: Vec<Vec<f64>>,
    /// Minimum predicted gap d* over all blade-tip nodes at the sample step (m).
    pub min_gap: Vec<f64>,
    /// Largest residual penetration after correction (m, ≥ 0) at the sample step:
    /// re-projection of the corrected blade nodes on the corrected spline. Only sample steps
    /// synthesise the corrected casing surface (aside: the state never reads it), so only
    /// they are checked.
    pub residual_penetration: Vec<f64>,
    /// Impeller and casing energies (J, half-step form).
    pub impeller_energy: EnergySeries,
    pub casing_energy: EnergySeries,
    /// Impeller strain energy per nodal diameter (J), `[k][sample]`, paper eqs. (20)–(22).
    pub impeller_nd_strain_energy: Vec<Vec<f64>>,
    /// Largest wear of each coating row (m) at each sample, `[row][sample]` (empty without a
    /// coating).
    pub coating_max_wear: Vec<Vec<f64>>,
    /// Per blade, sum over its tip nodes of the coating force magnitude (N, along the casing
    /// normal) applied at the sample step, `[blade][sample]` (empty without a coating).
    pub coating_blade_force: Vec<Vec<f64>>,
    /// The run's scalar results.
    pub summary: RunSummary,
}

/// Final state of the abradable coating (paper §4, Figs. 12–13). Rows are the impeller contact
/// rows (leading edge first); element `i` of a row is centred at the fixed-frame angle
/// `2π (i + ½)/η`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CoatingOutput {
    /// Number of elements per row η.
    pub eta: usize,
    /// Initial coating thickness e_abr (m).
    pub thickness: f64,
    /// Final wear profile per row (m, removed depth `ε_p e_abr ∈ [0, e_abr]`), `[row][element]`.
    pub final_wear: Vec<Vec<f64>>,
    /// Number of fully removed elements (wear = e_abr) per row at the end of the run.
    pub removed_elements: Vec<usize>,
    /// Largest per-blade coating force (N) over every step of the run (not only samples).
    pub peak_force: f64,
    /// Largest wear over the whole coating at the end of the run (m).
    pub max_wear_final: f64,
    /// Number of steps in which at least one blade node loaded the coating.
    pub coating_steps: usize,
    /// Time steps a blade tip spends over one element, `2π / (η |Ω| h)`. Below about 1 the
    /// tips skip elements (they are loaded only at the sampled positions) and the wear profile
    /// becomes spiky: refine h or coarsen η.
    pub steps_per_element: f64,
}

/// Wall-clock time (s) of each stage of the time loop (paper Fig. 4), summed over the run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StageSeconds {
    /// Predictors of both structures (modal recurrence and boundary synthesis).
    pub predict: f64,
    /// Control points of the casing spline from the predicted casing nodes.
    pub spline: f64,
    /// Blade-tip nodes and their closest points on the spline.
    pub projection: f64,
    /// Friction directions, the contact matrix `W` and the active-set solve.
    pub contact_solve: f64,
    /// Corrections of both structures, refreshed spline and residual re-projection.
    pub correction: f64,
    /// Time shift, probes and everything else.
    pub other: f64,
}

impl StageSeconds {
    /// Sum of all stages (s).
    pub fn total(&self) -> f64 {
        self.predict
            + self.spline
            + self.projection
            + self.contact_solve
            + self.correction
            + self.other
    }
}

/// Which stage of [`StageSeconds`] a [`StageClock::lap`] closes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    Predict,
    Spline,
    Projection,
    ContactSolve,
    Correction,
    Other,
}

/// Lap timer of the time loop: each [`StageClock::lap`] charges the time since the previous
/// lap to one stage (one `Instant::now()` per lap, ~20 ns).
#[derive(Clone, Debug)]
pub struct StageClock {
    last: std::time::Instant,
    /// Accumulated seconds per stage.
    pub seconds: StageSeconds,
}

impl Default for StageClock {
    fn default() -> Self {
        Self::new()
    }
}

impl StageClock {
    /// Starts the clock now with every stage at zero.
    pub fn new() -> Self {
        Self {
            last: std::time::Instant::now(),
            seconds: StageSeconds::default(),
        }
    }

    /// Charges the time since the previous lap to `stage`.
    #[inline]
    pub fn lap(&mut self, stage: Stage) {
        let now = std::time::Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        let s = &mut self.seconds;
        *match stage {
            Stage::Predict => &mut s.predict,
            Stage::Spline => &mut s.spline,
            Stage::Projection => &mut s.projection,
            Stage::ContactSolve => &mut s.contact_solve,
            Stage::Correction => &mut s.correction,
            Stage::Other => &mut s.other,
        } += dt;
    }
}
/// Scalar results of a run (the series go to the [`Recorder`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunSummary {
    /// Time step h (s), stability limit 2/ω_max (s), steps per revolution at Ω.
    pub time_step: f64,
    pub stability_limit: f64,
    pub steps_per_revolution: f64,
    /// Steps, steps with at least one contact candidate, (step, node) pairs with a positive
    /// multiplier.
    pub n_steps: usize,
    pub contact_steps: usize,
    pub active_contacts: usize,
    /// Largest residual penetration (m, over the sample steps) and largest |blade-tip radial
    /// displacement| (m, over every step).
    pub max_residual_penetration: f64,
    pub max_blade_radial: f64,
    /// Wall-clock time of the stepping loop (s) and its split by stage.
    pub loop_seconds: f64,
    pub stage_seconds: StageSeconds,
    /// The coating's final state (`None` without a coating).
    pub coating: Option<CoatingOutput>,
}
