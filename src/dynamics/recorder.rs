//! What a simulation hands out on its sample steps, and who keeps it.
//!
//! The time loop computes the probes of a sample step (one step in `numerics.decimation`)
//! into its own buffers and lends them to a [`Recorder`] chosen by the caller as a
//! [`Sample`]. The recorder decides what is kept: [`SeriesRecorder`] keeps every series in
//! memory (tests, short runs), the sweep's aggregator keeps bounded online aggregates, a
//! Parquet recorder streams row groups to a file. Recording never feeds back into the state:
//! the same case gives the same states whatever the decimation or the recorder.

use crate::dynamics::kernel::Energies;
use crate::dynamics::probes::{EnergySeries, Probe, RunSummary, SimulationOutput};

/// The probes of one sample step, SI units, borrowed from the simulation. Per-blade slices
/// have one entry per blade.
#[derive(Clone, Copy, Debug)]
pub struct Sample<'a> {
    /// Time t_{n+1} (s) of the state sampled.
    pub time: f64,
    /// Radial displacement (m, rotating frame, positive outward) of each blade's leading-edge
    /// tip node (contact row 0).
    pub blade_le_radial: &'a [f64],
    /// Radial displacement (m) of each blade's trailing-edge tip node (last contact row).
    pub blade_te_radial: &'a [f64],
    /// Radial displacement (m, positive outward) of the casing probes (`Case::casing_probes`).
    pub casing_radial: &'a [f64],
    /// Per blade, sum over its tip nodes of the normal contact force λ (N) of the step.
    pub blade_normal_force: &'a [f64],
    /// Per blade, sum of the friction force magnitudes μλ (N) of the step.
    pub blade_tangential_force: &'a [f64],
    /// Minimum predicted gap d* over all blade-tip nodes (m).
    pub min_gap: f64,
    /// Largest residual penetration after the step's correction (m, ≥ 0): box 4b's, and the
    /// corrected blade nodes re-projected on the corrected casing surface (or their imposed
    /// gaps).
    pub residual_penetration: f64,
    /// Work (J) the imposed rotation has done on the two structures through the contact
    /// forces since t = 0: `−Ω ∫ M_z dt`, `M_z` the contact forces' torque about the axis.
    pub drive_work: f64,
    /// Impeller energies (J, half-step form).
    pub impeller_energy: Energies,
    /// Casing energies (J); `None` for a rigid casing.
    pub casing_energy: Option<Energies>,
    /// Impeller strain energy per nodal diameter (J), paper eqs. (20)–(22).
    pub impeller_nd_strain_energy: &'a [f64],
    /// The abradable coating's probes; `None` without a coating.
    pub coating: Option<CoatingSample<'a>>,
    /// The probes the case selects (`Case::probes`, in its order).
    pub probe_columns: &'a [Probe],
    /// The probes' values at this sample (m or N, see [`Probe::unit`]), one per probe of
    /// `probe_columns`.
    pub probes: &'a [f64],
}

/// The coating probes of one sample step.
#[derive(Clone, Copy, Debug)]
pub struct CoatingSample<'a> {
    /// Largest wear (m) of each impeller contact row so far.
    pub max_wear: &'a [f64],
    /// Per blade, the coating force magnitude (N) of the step.
    pub blade_force: &'a [f64],
}

/// Receives the samples of a simulation. An error stops the simulation.
pub trait Recorder {
    /// Records one sample.
    fn record(&mut self, sample: &Sample<'_>) -> Result<(), RecordError>;
}

/// Why a recorder could not keep a sample (e.g. a time-series file could not be written).
pub type RecordError = Box<dyn std::error::Error + Send + Sync>;

/// A recorder lent to a run (so the caller keeps it, e.g. to combine it with another).
impl<R: Recorder + ?Sized> Recorder for &mut R {
    fn record(&mut self, sample: &Sample<'_>) -> Result<(), RecordError> {
        (**self).record(sample)
    }
}

/// Both recorders receive every sample, the first one first (e.g. a job's aggregates and its
/// time-series file).
impl<A: Recorder, B: Recorder> Recorder for (A, B) {
    fn record(&mut self, sample: &Sample<'_>) -> Result<(), RecordError> {
        self.0.record(sample)?;
        self.1.record(sample)
    }
}

/// Keeps nothing: runs whose only output is the summary.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoRecorder;

impl Recorder for NoRecorder {
    fn record(&mut self, _: &Sample<'_>) -> Result<(), RecordError> {
        Ok(())
    }
}

/// Keeps every sample in memory, as the series of [`SimulationOutput`] (memory grows with the
/// run's length: for tests and short runs).
#[derive(Clone, Debug, Default)]
pub struct SeriesRecorder {
    /// The series recorded so far (the summary stays at its default until
    /// [`SeriesRecorder::into_output`]).
    pub out: SimulationOutput,
}

fn push_each(series: &mut Vec<Vec<f64>>, values: &[f64]) {
    if series.len() < values.len() {
        series.resize_with(values.len(), Vec::new);
    }
    for (s, v) in series.iter_mut().zip(values) {
        s.push(*v);
    }
}

fn push_energy(series: &mut EnergySeries, e: Energies) {
    series.kinetic.push(e.kinetic);
    series.strain.push(e.strain);
}

impl Recorder for SeriesRecorder {
    fn record(&mut self, s: &Sample<'_>) -> Result<(), RecordError> {
        let o = &mut self.out;
        o.time.push(s.time);
        push_each(&mut o.blade_le_radial, s.blade_le_radial);
        push_each(&mut o.blade_te_radial, s.blade_te_radial);
        push_each(&mut o.casing_radial, s.casing_radial);
        push_each(&mut o.blade_normal_force, s.blade_normal_force);
        push_each(&mut o.blade_tangential_force, s.blade_tangential_force);
        o.min_gap.push(s.min_gap);
        o.residual_penetration.push(s.residual_penetration);
        o.drive_work.push(s.drive_work);
        push_energy(&mut o.impeller_energy, s.impeller_energy);
        if let Some(e) = s.casing_energy {
            push_energy(&mut o.casing_energy, e);
        }
        push_each(
            &mut o.impeller_nd_strain_energy,
            s.impeller_nd_strain_energy,
        );
        if let Some(c) = &s.coating {
            push_each(&mut o.coating_max_wear, c.max_wear);
            push_each(&mut o.coating_blade_force, c.blade_force);
        }
        push_each(&mut o.probes, s.probes);
        Ok(())
    }
}

impl SeriesRecorder {
    /// The recorded series with the run's `summary`, as one [`SimulationOutput`].
    pub fn into_output(self, summary: RunSummary) -> SimulationOutput {
        SimulationOutput {
            summary,
            ..self.out
        }
    }
}
