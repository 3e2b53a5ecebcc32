//! Sweep stage: specification, planner, runner with checkpoint/resume (DESIGN.md §6).
//!
//! Pipeline: [`spec::load_spec`] → [`validate::resolve`] (the whole spec, with its models) →
//! [`planner::plan`] → [`runner::run_sweep`] (one
//! [`JobSimulator::run`] per job on a rayon pool, each finished job persisted at once
//! under `<out>/jobs/<id>.json`) → `<out>/results.parquet` + `<out>/manifest.json`;
//! shard outputs combine with [`runner::merge`].
//!
//! The simulation itself is behind the [`JobSimulator`] trait; `synthetic::SyntheticSimulator`
//! (hidden, for tests) is a deterministic analytic stand-in used by the tests.

pub mod aggregate;
pub mod checkpoint;
pub mod figures;
pub mod labels;
pub mod planner;
pub mod plots;
pub mod probe_report;
pub mod refine;
pub mod report;
pub mod rounds;
pub mod runner;
pub mod scan_figure;
pub mod schema;
pub mod simulator;
pub mod slurm;
pub mod spec;
pub mod stability_plot;
pub mod status;
#[doc(hidden)]
pub mod synthetic;
pub mod table;
pub mod validate;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use serde::{Deserialize, Serialize};

use crate::dynamics::runaway::Runaway;

pub use checkpoint::{JobRecord, JobStatus};
pub use planner::{CoatingParams, CoatingValue, Job, JobContext, JobParams, Plan, plan};
pub use runner::{
    Manifest, MergeSummary, RunCounters, RunOptions, RunSummary, default_output_dir, load_records,
    merge, parse_shard, read_manifest, run_sweep,
};
pub use spec::{SpecError, SpecIssue, SweepSpec, load_spec, parse_spec};
pub use validate::{ResolvedSweep, resolve};

/// Runs one job of a sweep. Implementations must be deterministic for a given job
/// (the resume and sharding guarantees rely on it) and single-threaded inside
/// (the runner parallelises over jobs).
pub trait JobSimulator: Sync {
    /// Runs `job`. `Err(reason)` marks the job failed (diverged, invalid model…); the
    /// sweep goes on. Long simulations should poll `cancel` (set on Ctrl-C) and return
    /// early with any `Err`: a job that returns while `cancel` is set is not recorded
    /// and will run again on resume.
    fn run(&self, job: &Job, cancel: &AtomicBool) -> Result<JobResult, String>;

    /// [`JobSimulator::run`], reporting the time steps done as the job goes through `steps`
    /// (the runner's progress within a job). The default reports nothing: the runner counts
    /// the job's steps when it finishes. Reporting must not change the job's result.
    fn run_reporting(
        &self,
        job: &Job,
        cancel: &AtomicBool,
        steps: &mut JobSteps<'_>,
    ) -> Result<JobResult, String> {
        let _ = steps;
        self.run(job, cancel)
    }
}

/// The time steps one job has done, added as they are reported to the run's shared counter
/// (and its progress bar): the progress of a long job shows before it finishes, and the
/// bar's ETA comes from the steps done. Reports past the job's planned total are capped, so the
/// counter of a run reaches exactly the planned steps of its finished jobs.
#[derive(Debug)]
pub struct JobSteps<'a> {
    total: u64,
    reported: u64,
    counter: Option<&'a AtomicU64>,
    bar: Option<&'a indicatif::ProgressBar>,
}

impl<'a> JobSteps<'a> {
    /// A job of `total` planned steps reporting to `counter` and, when drawn, `bar`.
    pub fn new(
        total: u64,
        counter: Option<&'a AtomicU64>,
        bar: Option<&'a indicatif::ProgressBar>,
    ) -> Self {
        JobSteps {
            total,
            reported: 0,
            counter,
            bar,
        }
    }

    /// A job of `total` steps whose reports go nowhere (a job run outside a sweep).
    pub fn detached(total: u64) -> Self {
        Self::new(total, None, None)
    }

    /// The job has done `steps` time steps (capped at its total; never goes back).
    pub fn advance_to(&mut self, steps: u64) {
        let steps = steps.min(self.total);
        if steps <= self.reported {
            return;
        }
        let delta = steps - self.reported;
        self.reported = steps;
        if let Some(c) = self.counter {
            c.fetch_add(delta, Ordering::Relaxed);
        }
        if let Some(b) = self.bar {
            b.inc(delta);
        }
    }

    /// The job is finished (ok or failed): all its planned steps count as done.
    pub fn finish(&mut self) {
        self.advance_to(self.total);
    }

    /// Steps reported so far.
    pub fn reported(&self) -> u64 {
        self.reported
    }
}

/// Maxima over the simulated time of one job.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Maxima {
    /// Largest |radial displacement| of any blade leading-edge node (m).
    pub blade_le_radial_m: f64,
    /// Largest |radial displacement| of any blade trailing-edge node (m).
    pub blade_te_radial_m: f64,
    /// Largest |radial displacement| of any blade leading-edge node low-passed at
    /// [`BLADE_BAND_HZ`](crate::dynamics::low_pass::BLADE_BAND_HZ) (m); `None` when the step
    /// cannot resolve that band, or in results written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blade_le_radial_lowpass_m: Option<f64>,
    /// The same at the trailing edge (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blade_te_radial_lowpass_m: Option<f64>,
    /// Largest |radial displacement| of the casing probe nodes (m).
    pub casing_radial_m: f64,
    /// Largest normal contact force, summed over a blade (N).
    pub contact_normal_force_n: f64,
    /// Largest abradable-coating force, summed over a blade (N).
    pub coating_force_n: f64,
}

/// One peak of the blade-tip radial displacement spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FourierPeak {
    /// Frequency (Hz).
    pub frequency_hz: f64,
    /// Engine order: frequency / (Ω / 2π).
    pub engine_order: f64,
    /// One-sided amplitude (m).
    pub amplitude_m: f64,
}

/// Nearest critical speed of the linear interaction criterion n Ω − ω_b(Ω) = ω_c (DESIGN.md §5).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CriticalSpeed {
    /// Critical speed Ω*_n (rad/s).
    pub speed_rad_s: f64,
    /// Nodal diameter n of the coincidence.
    pub nodal_diameter: u32,
    /// Spatial compatibility of the two mode shapes at the contact interface, in [0, 1].
    pub compatibility: f64,
}

/// The linear stability prediction at a job's speed and friction
/// ([`crate::analysis::stability`]): the most unstable coupled wave of a persistent rub.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PredictedStability {
    /// Whether no counted wave grows (the prediction says the rub settles).
    pub stable: bool,
    /// Growth rate Re λ (1/s) of the most unstable counted wave (≤ 0 when stable).
    pub growth_rate_per_s: f64,
    /// Its casing nodal diameter.
    pub nodal_diameter: u32,
    /// Its fixed-frame frequency (Hz).
    pub frequency_hz: f64,
}

/// Amplitude spectrum of the blade-tip radial displacement on a uniform frequency grid
/// f_k = k · df_hz, k = 0, 1, …
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    /// Frequency resolution (Hz).
    pub df_hz: f64,
    /// One-sided amplitudes (m).
    pub amplitude_m: Vec<f64>,
}

/// What one successful job produces (aggregates only; time series stay with the simulator).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JobResult {
    /// Maxima over time.
    pub maxima: Maxima,
    /// Final wear depth (m): outer index = station along the meridian (leading → trailing
    /// edge), inner index = angle θ_k = 2π k / n_angles, k = 0..n_angles.
    pub wear_profile_m: Vec<Vec<f64>>,
    /// Spectrum peaks, largest first.
    pub fourier_peaks: Vec<FourierPeak>,
    /// Strain energy per nodal diameter k = 0..=N/2 (J) (paper eqs. 20–22).
    pub strain_energy_per_nd_j: Vec<f64>,
    /// Largest penetration left after a contact correction, over every step (m, ≥ 0).
    pub residual_penetration_m: f64,
    /// Steps whose residual penetration exceeds the contact's gap tolerance (`None` in a
    /// record written before the count existed).
    #[serde(default)]
    pub steps_over_gap_tolerance: Option<u64>,
    /// Nearest critical speed, if the criterion was evaluated.
    pub critical_speed: Option<CriticalSpeed>,
    /// Full amplitude spectrum (for interaction maps), if kept.
    pub spectrum: Option<Spectrum>,
    /// Work (J) the rotation did through the contact forces from the start to the end (or
    /// the stop) of the run (`None` in a record written before it was kept).
    #[serde(default)]
    pub drive_work_j: Option<f64>,
    /// The linear stability prediction at the job's speed (flexible casings only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted: Option<PredictedStability>,
    /// The runaway that stopped the job early: its outcome is then `unstable`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub runaway: Option<Runaway>,
}

impl JobResult {
    /// Checks that every number is finite (JSON cannot store NaN/∞, and a non-finite
    /// aggregate means the simulation diverged). Returns the offending field.
    pub(crate) fn check_finite(&self) -> Result<(), String> {
        let m = &self.maxima;
        let scalars = [
            ("maxima.blade_le_radial_m", m.blade_le_radial_m),
            ("maxima.blade_te_radial_m", m.blade_te_radial_m),
            (
                "maxima.blade_le_radial_lowpass_m",
                m.blade_le_radial_lowpass_m.unwrap_or(0.0),
            ),
            (
                "maxima.blade_te_radial_lowpass_m",
                m.blade_te_radial_lowpass_m.unwrap_or(0.0),
            ),
            ("maxima.casing_radial_m", m.casing_radial_m),
            ("maxima.contact_normal_force_n", m.contact_normal_force_n),
            ("maxima.coating_force_n", m.coating_force_n),
            ("residual_penetration_m", self.residual_penetration_m),
        ];
        for (name, v) in scalars {
            if !v.is_finite() {
                return Err(format!("non-finite result: {name} = {v}"));
            }
        }
        let bad = |name: &str, it: &mut dyn Iterator<Item = f64>| -> Result<(), String> {
            for v in it {
                if !v.is_finite() {
                    return Err(format!("non-finite result: {name} contains {v}"));
                }
            }
            Ok(())
        };
        bad(
            "wear_profile_m",
            &mut self.wear_profile_m.iter().flatten().copied(),
        )?;
        bad(
            "fourier_peaks",
            &mut self
                .fourier_peaks
                .iter()
                .flat_map(|p| [p.frequency_hz, p.engine_order, p.amplitude_m]),
        )?;
        bad(
            "strain_energy_per_nd_j",
            &mut self.strain_energy_per_nd_j.iter().copied(),
        )?;
        if let Some(c) = &self.critical_speed {
            bad(
                "critical_speed",
                &mut [c.speed_rad_s, c.compatibility].into_iter(),
            )?;
        }
        if let Some(r) = &self.runaway {
            bad(
                "runaway",
                &mut [
                    r.onset_time_s,
                    r.detected_time_s,
                    r.growth_rate_per_s,
                    r.growth_fit_r2,
                    r.energy_growth,
                    r.drive_work_j,
                ]
                .into_iter()
                .chain(r.frequency_hz)
                .chain(r.rotating_frame_frequency_hz),
            )?;
        }
        bad("drive_work_j", &mut self.drive_work_j.into_iter())?;
        if let Some(p) = &self.predicted {
            bad(
                "predicted",
                &mut [p.growth_rate_per_s, p.frequency_hz].into_iter(),
            )?;
        }
        if let Some(s) = &self.spectrum {
            bad(
                "spectrum",
                &mut std::iter::once(s.df_hz).chain(s.amplitude_m.iter().copied()),
            )?;
        }
        Ok(())
    }
}
