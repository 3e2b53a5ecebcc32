//! The real [`JobSimulator`]: resolves a sweep's models once, turns each job into a
//! [`Case`], runs its [`Simulation`] into a [`JobAggregator`] (maxima, Fourier peaks over
//! the steady window, strain energy per nodal diameter, in bounded memory) and adds the
//! nearest critical speed of the linear interaction criterion.

use std::borrow::Cow;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use rayon::prelude::*;

use crate::analysis::interaction::{self, CriterionOptions, InterfaceModes};
use crate::analysis::stability::{self, StabilityOptions};
use crate::dynamics::abradable::CoatingMaterial;
use crate::dynamics::numerics::Boundary;
use crate::dynamics::recorder::{RecordError, Recorder, Sample};
use crate::dynamics::scenario::{CoatingCase, Rotation};
use crate::dynamics::simulate::CasingCache;
use crate::dynamics::structure::Structure;
use crate::dynamics::{
    Case, CasingModel, LobeLoad, RigidShape, RigidSurface, SimError, Simulation,
};
use crate::io::timeseries::TimeSeriesWriter;
use crate::model::rom::CyclicRom;
use crate::sweep::aggregate::JobAggregator;
use crate::sweep::planner::{CoatingParams, CoatingValue, Job, slice_label};
use crate::sweep::schema::SpecError;
use crate::sweep::spec::{Scenario, SweepSpec};
use crate::sweep::validate::{self, ResolvedCasing, ResolvedSweep};
use crate::sweep::{CriticalSpeed, JobResult, JobSimulator, JobSteps, PredictedStability};

/// Applies one grid coating value to a nominal one.
fn resolve(nominal: f64, value: Option<CoatingValue>) -> f64 {
    match value {
        None => nominal,
        Some(CoatingValue::Absolute(v)) => v,
        Some(CoatingValue::Scale(f)) => f * nominal,
    }
}

/// The coating of one job: the scenario's nominal coating with the job's grid values applied;
/// `None` when neither the scenario nor the grid asks for a coating.
fn job_coating(extras: &Scenario, params: &CoatingParams) -> Option<CoatingCase> {
    let on_grid = params.young.is_some()
        || params.hardening.is_some()
        || params.yield_stress.is_some()
        || params.thickness.is_some();
    if extras.coating.is_none() && !on_grid {
        return None;
    }
    let n = extras.coating.clone().unwrap_or_default();
    let material = CoatingMaterial {
        young: resolve(n.young_pa, params.young),
        plastic_modulus: resolve(n.hardening_pa, params.hardening),
        yield_stress: resolve(n.yield_stress_pa, params.yield_stress),
        thickness: resolve(n.thickness_m, params.thickness),
    };
    Some(CoatingCase {
        eta: n.eta,
        ..CoatingCase::new(material)
    })
}

/// Default tip clearance (m) of a rigid casing when the grid gives none.
const DEFAULT_RIGID_CLEARANCE: f64 = 0.5e-3;

/// A [`JobSimulator`] running the flexible-casing contact simulation of [`crate::dynamics`].
#[derive(Debug)]
pub struct ModelSimulator {
    impeller: CyclicRom,
    casing: ResolvedCasing,
    /// Tip clearance (m) built into the impeller geometry, when known (built-in models).
    nominal_clearance: Option<f64>,
    /// Critical speeds of the linear interaction criterion, computed once.
    criticals: Vec<CriticalSpeed>,
    /// Where each job's time series goes (`<dir>/<job id>.parquet`), when asked.
    timeseries_dir: Option<PathBuf>,
    /// Wall-clock limit of each job (s), `SweepSpec::job_time_limit_s`.
    job_time_limit_s: Option<f64>,
    /// The sense of rotation of the sweep.
    rotation: Rotation,
    /// The flexible casing's structure and side, shared by the jobs (they do not depend on Ω).
    casing_cache: CasingCache,
}

/// Stops a simulation whose wall-clock time passes a limit: a recorder that fails the
/// first sample after the deadline, so the time loop needs no hook of its own. Reading
/// the clock (tens of ns) once per sample step is negligible next to a step.
#[derive(Debug)]
pub struct WallClockLimit {
    limit_s: f64,
    deadline: Option<Instant>,
}

impl WallClockLimit {
    /// A limit of `limit_s` seconds from now; `None`: no limit.
    pub fn new(limit_s: Option<f64>) -> Self {
        let deadline =
            limit_s.and_then(|s| Instant::now().checked_add(Duration::try_from_secs_f64(s).ok()?));
        WallClockLimit {
            limit_s: limit_s.unwrap_or(f64::INFINITY),
            deadline,
        }
    }
}

/// The error of [`WallClockLimit`]: the job's failure reason.
#[derive(Debug, thiserror::Error)]
#[error("wall-time limit of {limit_s} s exceeded after {simulated_s:.6e} s simulated")]
pub struct WallTimeExceeded {
    /// The limit (s).
    pub limit_s: f64,
    /// Simulated time reached (s).
    pub simulated_s: f64,
}

impl Recorder for WallClockLimit {
    fn record(&mut self, sample: &Sample<'_>) -> Result<(), RecordError> {
        match self.deadline {
            Some(d) if Instant::now() >= d => Err(Box::new(WallTimeExceeded {
                limit_s: self.limit_s,
                simulated_s: sample.time,
            })),
            _ => Ok(()),
        }
    }
}

/// A simulation error as a job's failure reason; a passed wall-time limit is said as such.
fn failure_reason(e: SimError) -> String {
    match e {
        SimError::Record(r) if r.is::<WallTimeExceeded>() => r.to_string(),
        e => e.to_string(),
    }
}

/// Meridian of a rigid casing: the blade-tip contact rows `(r, z)` (leading → trailing edge)
/// moved by `clearance` (m) along the meridian normal on the shroud side, taken as the side
/// the normals point to on average radially outward (the tip of an axial blade faces +r; a
/// centrifugal tip turns from +r at the inlet to axial at the outlet).
pub fn rigid_meridian(tip_rz: &[[f64; 2]], clearance: f64) -> Vec<[f64; 2]> {
    let n = tip_rz.len();
    let normals: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            let (a, b) = (tip_rz[i.saturating_sub(1)], tip_rz[(i + 1).min(n - 1)]);
            let (dr, dz) = (b[0] - a[0], b[1] - a[1]);
            let len = dr.hypot(dz);
            if len > 0.0 {
                [dz / len, -dr / len]
            } else {
                [1.0, 0.0]
            }
        })
        .collect();
    let side = if normals.iter().map(|n| n[0]).sum::<f64>() < 0.0 {
        -1.0
    } else {
        1.0
    };
    tip_rz
        .iter()
        .zip(&normals)
        .map(|(p, nrm)| {
            [
                p[0] + side * clearance * nrm[0],
                p[1] + side * clearance * nrm[1],
            ]
        })
        .collect()
}

/// A rigid casing on `meridian`: n lobes of amplitude a (m), phased so that the blades start
/// where the clearance is widest (r = r₀ + a cos nθ: contact then builds up as they turn
/// instead of starting with an overlap that the first correction would kick out), plus an
/// optional tabulated gap offset Δr(θ_i) (m) whose length sets the number of stations.
pub fn rigid_casing(
    lobes: usize,
    amplitude: f64,
    offsets: Option<&[f64]>,
    stations: Option<usize>,
    meridian: Vec<[f64; 2]>,
) -> RigidSurface {
    match offsets {
        None => RigidSurface {
            n_sectors: stations.unwrap_or(120),
            meridian,
            shape: RigidShape::Lobes {
                lobes,
                amplitude: -amplitude,
            },
        },
        Some(o) => {
            let n = o.len() as f64;
            let offsets = o
                .iter()
                .enumerate()
                .map(|(i, d)| {
                    d + amplitude * (lobes as f64 * 2.0 * std::f64::consts::PI * i as f64 / n).cos()
                })
                .collect();
            RigidSurface {
                n_sectors: o.len(),
                meridian,
                shape: RigidShape::Tabulated { offsets },
            }
        }
    }
}

/// `(r, z)` (m) of the impeller's contact nodes, one per contact row, in row order: the
/// blade-tip meridian a rigid casing follows ([`rigid_meridian`]).
pub fn tip_rows(rom: &CyclicRom) -> Vec<[f64; 2]> {
    let mut rows: Vec<(usize, [f64; 2])> = rom
        .contact_nodes
        .iter()
        .map(|c| (c.row, [c.position[0].hypot(c.position[1]), c.position[2]]))
        .collect();
    rows.sort_by_key(|r| r.0);
    rows.dedup_by_key(|r| r.0);
    rows.into_iter().map(|r| r.1).collect()
}

impl ModelSimulator {
    /// Validates `spec` as a whole ([`validate::resolve`]), resolves (builds, loads or takes from the
    /// cache) its models and evaluates the linear interaction criterion once.
    pub fn new(spec: &SweepSpec) -> Result<Self> {
        Self::from_resolved(validate::resolve(spec)?)
    }

    /// The simulator of a validated sweep: evaluates the linear interaction criterion once.
    pub fn from_resolved(resolved: ResolvedSweep) -> Result<Self> {
        let ResolvedSweep {
            impeller,
            casing,
            nominal_clearance,
            spec,
        } = resolved;
        let opts = CriterionOptions::default();
        let criticals = match &casing {
            ResolvedCasing::Flexible(c) => interaction::critical_speeds(
                &InterfaceModes::from_rom(&impeller),
                &InterfaceModes::from_rom(c),
                &opts,
            )
            .context("linear interaction criterion")?
            .into_iter()
            .map(|c| CriticalSpeed {
                speed_rad_s: c.omega_rad_s,
                nodal_diameter: c.nodal_diameter as u32,
                compatibility: c.compatibility.unwrap_or(0.0),
            })
            .collect(),
            // A tabulated imposed-gap profile holds every harmonic: from the first on.
            ResolvedCasing::Rigid(r) => rigid_criticals(&impeller, r.lobes as usize, &opts)?,
            ResolvedCasing::ImposedGap(g) => {
                rigid_criticals(&impeller, g.profile.lobes().unwrap_or(1), &opts)?
            }
        };
        Ok(Self {
            impeller,
            casing,
            nominal_clearance,
            criticals,
            timeseries_dir: None,
            job_time_limit_s: spec.job_time_limit_s,
            rotation: spec.models.rotation,
            casing_cache: CasingCache::default(),
        })
    }

    /// Also streams each job's time series (the probes of every sample step, as
    /// `rubscan simulate` writes them) to `<dir>/<job id>.parquet`, written atomically when the
    /// job finishes; a failed or cancelled job leaves no file. Recording does not change the
    /// results.
    pub fn with_timeseries(mut self, dir: impl Into<PathBuf>) -> Self {
        self.timeseries_dir = Some(dir.into());
        self
    }

    /// Critical speeds found by the linear interaction criterion (rad/s, nodal diameter, compatibility).
    pub fn critical_speeds(&self) -> &[CriticalSpeed] {
        &self.criticals
    }

    /// The impeller and the flexible casing (`None` for a rigid casing) as a machine turning
    /// counter-clockwise, which the linear predictions assume: the models themselves, or
    /// their mirror images when the sweep turns clockwise (a machine turning clockwise is the
    /// mirror image of one turning counter-clockwise).
    pub fn counterclockwise_models(&self) -> Option<(Cow<'_, CyclicRom>, Cow<'_, CyclicRom>)> {
        let casing = self.casing_rom()?;
        Some(match self.rotation {
            Rotation::Counterclockwise => (Cow::Borrowed(&self.impeller), Cow::Borrowed(casing)),
            Rotation::Clockwise => (
                Cow::Owned(self.impeller.mirrored()),
                Cow::Owned(casing.mirrored()),
            ),
        })
    }

    /// The flexible casing ROM of the sweep (`None` for a rigid casing).
    pub fn casing_rom(&self) -> Option<&CyclicRom> {
        match &self.casing {
            ResolvedCasing::Flexible(rom) => Some(rom),
            ResolvedCasing::Rigid(_) | ResolvedCasing::ImposedGap(_) => None,
        }
    }

    /// The flexible casing's critical wave speed (rad/s) and its nodal diameter
    /// ([`Structure::critical_wave_speed`]); `None` for a rigid casing.
    pub fn casing_wave_speed(&self) -> Result<Option<(f64, usize)>> {
        let Some(rom) = self.casing_rom() else {
            return Ok(None);
        };
        Ok(Structure::new(rom, 0.0)?.critical_wave_speed())
    }

    /// How many of `jobs` run above the flexible casing's critical wave speed, as a sentence
    /// for the user; `None` when none does (or the casing is rigid).
    pub fn supercritical_note(&self, jobs: &[Job]) -> Result<Option<String>> {
        let Some((omega_c, k)) = self.casing_wave_speed()? else {
            return Ok(None);
        };
        let above = (jobs.iter())
            .filter(|j| j.params.speed_rad_s > omega_c)
            .count();
        Ok((above > 0).then(|| {
            format!(
                "{above} of {} jobs run above the flexible casing's critical wave speed \
                 {omega_c:.1} rad/s (nodal diameter {k}), where a contact that stays closed can \
                 feed the casing's waves with the rotation's energy: such a job stops early as \
                 `unstable` once its runaway is confirmed (docs/validation.md)",
                jobs.len()
            )
        }))
    }

    /// The impeller ROM of the sweep.
    pub fn impeller(&self) -> &CyclicRom {
        &self.impeller
    }

    /// Sets up, without running them, the jobs of stiffest coating (largest `E / e_abr`) and of
    /// thickest coating at each speed of `jobs`: the explicit coating force's limit `k·w < 1`
    /// (`k = E A / e_abr`, the contact flexibility `w ∝ h²`) and a clearance offset that keeps
    /// the tips facing the casing, which a job would otherwise meet at its own start, are
    /// checked before any job runs. A job that cannot start is a spec issue at the property that
    /// made it extreme (Young's modulus or thickness, `/scenario/coating/…` or the grid's axis
    /// when the grid sets it for the job), naming the job. With a massless boundary the
    /// coating force is solved with the displacement (no step limit) and the clearance offset
    /// acts at rest, so the extremes are taken over all speeds, not at each one.
    pub fn check_coating_limits(&self, jobs: &[Job]) -> Result<(), SpecError> {
        // The stiffest sets the step's limit, the thickest the tips' clearance offset.
        let keys: [fn(&CoatingMaterial) -> f64; 2] = [|m| m.young / m.thickness, |m| m.thickness];
        let mut extreme: Vec<(&Job, f64, usize)> = Vec::new();
        for job in jobs {
            let Some(c) = job_coating(&job.context.scenario, &job.params.coating) else {
                continue;
            };
            let speed = job.params.speed_rad_s;
            let per_speed = job.context.numerics.boundary == Boundary::Mass;
            let same = |j: &Job| !per_speed || j.params.speed_rad_s == speed;
            for (which, key) in keys.iter().enumerate() {
                let k = key(&c.material);
                match (extreme.iter_mut()).find(|(j, _, w)| *w == which && same(j)) {
                    Some(entry) if entry.1 >= k => {}
                    Some(entry) => *entry = (job, k, which),
                    None => extreme.push((job, k, which)),
                }
            }
        }
        // The thickest first: when they pass, the stiffest (no thicker) can fail on its
        // stiffness only. A job both the stiffest and the thickest is set up once.
        extreme.sort_by_key(|&(_, _, which)| std::cmp::Reverse(which));
        let mut seen = std::collections::BTreeSet::new();
        extreme.retain(|(j, _, _)| seen.insert(j.index));
        // Set up on every core (one per speed on a scan), the first failure in plan order
        // reported, whatever the thread count. faer runs sequentially inside, as in the jobs
        // (crates.md pitfall 2): the casing built here is the jobs' (`CasingCache`), to the bit
        // whatever the core count.
        faer::set_global_parallelism(faer::Par::Seq);
        let failures: Vec<Result<Option<SimError>, SpecError>> =
            extreme
                .par_iter()
                .map(|(job, _, _)| {
                    let (case, casing, _) = self
                        .case_for_job(job)
                        .map_err(|e| SpecError::one("", format!("{e:#}")))?;
                    Ok(Simulation::with_cache(
                        &case,
                        &self.impeller,
                        &casing,
                        Some(&self.casing_cache),
                    )
                    .err())
                })
                .collect();
        for ((job, _, which), failure) in extreme.into_iter().zip(failures) {
            if let Some(e) = failure? {
                // The property that made this job extreme, where the spec sets it for the job.
                let c = &job.params.coating;
                let path = match (which, c.young.is_some(), c.thickness.is_some()) {
                    (0, true, _) => "/grid/coating/young",
                    (0, false, _) => "/scenario/coating/young_pa",
                    (_, _, true) => "/grid/coating/thickness",
                    _ => "/scenario/coating/thickness_m",
                };
                return Err(SpecError::one(
                    path,
                    format!(
                        "job {} (Ω = {} rad/s, {}) cannot start: {e}",
                        job.index,
                        job.params.speed_rad_s,
                        slice_label(&job.params)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Builds the simulation case and casing model of one job, and returns the job's scenario.
    /// The job comes from the plan of the validated spec this simulator was made from, so
    /// every option applies to the models; the errors left are internal inconsistencies.
    pub fn case_for_job(&self, job: &Job) -> Result<(Case, CasingModel, Scenario)> {
        let ctx = &job.context;
        let extras = ctx.scenario.clone();
        let numerics = ctx.numerics.clone();
        let duration = ctx.scenario.duration_s;
        let rows = tip_rows(&self.impeller).len();
        let p = &job.params;
        let coating = job_coating(&extras, &p.coating);
        // Clearances are to the coating surface: the tips move in by the coating thickness.
        let e_abr = coating.as_ref().map_or(0.0, |c| c.material.thickness);
        let (casing, clearance_offset, load) = match &self.casing {
            ResolvedCasing::Flexible(rom) => {
                let offset = match (p.clearance_m, self.nominal_clearance) {
                    (None, _) if e_abr == 0.0 => vec![],
                    (None, _) => vec![-e_abr; rows],
                    (Some(c), Some(c0)) => vec![c0 - c - e_abr; rows],
                    (Some(_), None) => bail!(
                        "/grid/clearance_m needs a built-in impeller (a ROM file does not state its clearance)"
                    ),
                };
                let load = match (extras.lobes, extras.load_amplitude_m) {
                    (Some(n), Some(delta)) => Some(LobeLoad {
                        lobes: n as usize,
                        static_displacement: delta,
                        ramp_time: extras.load_ramp_s.unwrap_or(0.25 * duration),
                        hold_time: 0.0,
                    }),
                    (None, None) => None,
                    _ => bail!(
                        "/scenario: `lobes` and `load_amplitude_m` go together (the n-lobe casing load)"
                    ),
                };
                (CasingModel::Flexible(rom.clone()), offset, load)
            }
            ResolvedCasing::Rigid(r) => {
                let clearance = p.clearance_m.unwrap_or(DEFAULT_RIGID_CLEARANCE);
                let meridian = rigid_meridian(&tip_rows(&self.impeller), clearance + e_abr);
                let rigid = rigid_casing(
                    r.lobes as usize,
                    r.amplitude_m,
                    r.gap_offsets_m.as_deref(),
                    extras.rigid_stations.map(|n| n as usize),
                    meridian,
                );
                (CasingModel::Rigid(rigid), vec![], None)
            }
            // The profile holds the clearance; the spec admits no coating with it.
            ResolvedCasing::ImposedGap(g) => (CasingModel::ImposedGap(g.clone()), vec![], None),
        };
        let case = Case {
            omega: p.speed_rad_s,
            rotation: ctx.rotation,
            duration,
            friction: p.friction,
            load,
            clearance_offset,
            casing_probes: extras.casing_probes.clone(),
            probes: extras.probes.clone(),
            initial_velocity: Default::default(),
            numerics,
            coating,
        };
        Ok((case, casing, extras))
    }
}

/// A rigid casing has no modes: its critical speeds are the engine-order crossings of the
/// harmonics of its `lobes`, whose shapes are compatible by construction (score 1).
fn rigid_criticals(
    impeller: &CyclicRom,
    lobes: usize,
    opts: &CriterionOptions,
) -> Result<Vec<CriticalSpeed>> {
    Ok(interaction::engine_order_crossings(
        &impeller.modal_data,
        impeller.n_sectors,
        lobes,
        12 * lobes,
        opts,
    )
    .context("engine-order crossings")?
    .into_iter()
    .map(|c| CriticalSpeed {
        speed_rad_s: c.omega_rad_s,
        nodal_diameter: c.nodal_diameter as u32,
        compatibility: 1.0,
    })
    .collect())
}

/// A recorder reporting the time steps done at each sample to a job's step counter: the
/// progress within a long job. It reads the sample's time only (one atomic add per sample).
struct StepReporter<'s, 'a> {
    steps: &'s mut JobSteps<'a>,
    time_step: f64,
}

impl Recorder for StepReporter<'_, '_> {
    fn record(&mut self, sample: &Sample<'_>) -> Result<(), RecordError> {
        self.steps
            .advance_to((sample.time / self.time_step).round() as u64);
        Ok(())
    }
}

impl JobSimulator for ModelSimulator {
    fn run(&self, job: &Job, cancel: &AtomicBool) -> Result<JobResult, String> {
        self.run_reporting(job, cancel, &mut JobSteps::detached(0))
    }

    fn run_reporting(
        &self,
        job: &Job,
        cancel: &AtomicBool,
        steps: &mut JobSteps<'_>,
    ) -> Result<JobResult, String> {
        let (case, casing, extras) = self.case_for_job(job).map_err(|e| format!("{e:#}"))?;
        let window_start = steady_window_start(&case, extras.steady_fraction.unwrap_or(0.5));
        let mut rows = JobAggregator::new(
            case.omega,
            window_start,
            JobAggregator::DEFAULT_WINDOW_SAMPLES,
        );
        let simulation =
            Simulation::with_cache(&case, &self.impeller, &casing, Some(&self.casing_cache))
                .map_err(|e| e.to_string())?;
        // The clock starts with the time loop: building the case is not the job's run.
        let reporter = StepReporter {
            steps,
            time_step: simulation.time_step(),
        };
        let mut limited = (
            (WallClockLimit::new(self.job_time_limit_s), reporter),
            &mut rows,
        );
        let summary = match &self.timeseries_dir {
            None => simulation.run(&mut limited, Some(cancel)),
            Some(dir) => {
                std::fs::create_dir_all(dir)
                    .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
                let path = dir.join(format!("{}.parquet", job.id));
                let mut series = TimeSeriesWriter::create(&path).map_err(|e| format!("{e:#}"))?;
                let summary = simulation.run(&mut (&mut limited, &mut series), Some(cancel));
                if summary.is_ok() {
                    series.finish().map_err(|e| format!("{e:#}"))?;
                }
                summary
            }
        }
        .map_err(failure_reason)?;
        let mut result = rows.finish(&summary)?;
        result.critical_speed = nearest(&self.criticals, case.omega);
        result.predicted = self.predicted_stability(case.omega, case.friction)?;
        Ok(result)
    }
}

impl ModelSimulator {
    /// The linear stability prediction of a persistent rub at `omega` (rad/s) with friction
    /// `mu` (flexible casings only): the most unstable counted wave.
    fn predicted_stability(
        &self,
        omega: f64,
        mu: f64,
    ) -> Result<Option<PredictedStability>, String> {
        let Some((impeller, casing)) = self.counterclockwise_models() else {
            return Ok(None);
        };
        let at = stability::predict(
            &impeller,
            &casing,
            omega,
            &StabilityOptions::with_friction(mu),
        )
        .map_err(|e| format!("stability prediction: {e}"))?;
        Ok(at.most_unstable().map(|w| PredictedStability {
            stable: at.is_stable(),
            growth_rate_per_s: w.growth_rate_per_s,
            nodal_diameter: w.nodal_diameter as u32,
            frequency_hz: w.frequency_hz,
        }))
    }
}

/// Start time (s) of the steady window: after the load is released and within the last
/// `fraction` of the run.
fn steady_window_start(case: &Case, fraction: f64) -> f64 {
    let tail = case.duration * (1.0 - fraction.clamp(0.0, 1.0));
    case.load
        .as_ref()
        .map_or(tail, |l| tail.max(l.ramp_time + l.hold_time))
}

fn nearest(table: &[CriticalSpeed], omega: f64) -> Option<CriticalSpeed> {
    table
        .iter()
        .min_by(|a, b| {
            (a.speed_rad_s - omega)
                .abs()
                .total_cmp(&(b.speed_rad_s - omega).abs())
        })
        .copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Jobs that take the casing's structure and side from the sweep's cache (built by the
    /// plan-time coating check on the rayon pool, then by the first job at a new step) run to
    /// the bit as jobs that build their own. The quickstart, coated, its load ramped over 2 ms,
    /// 3 ms, at two speeds.
    #[test]
    fn jobs_sharing_the_casing_run_as_jobs_building_their_own() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/sweeps/quickstart.json");
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        v["scenario"]["duration_s"] = 3e-3.into();
        v["scenario"]["load_ramp_s"] = 2e-3.into();
        v["scenario"]["coating"] = serde_json::json!({});
        v["grid"]["speed"]["values"] = serde_json::json!([2000, 3500]);
        let spec = crate::sweep::parse_spec(&v.to_string()).unwrap();
        let sim = ModelSimulator::new(&spec).unwrap();
        let jobs = crate::sweep::plan(&spec).unwrap().jobs;
        sim.check_coating_limits(&jobs).unwrap();
        let run = |s: Simulation<'_>| {
            let mut rec = crate::dynamics::recorder::SeriesRecorder::default();
            let mut summary = s.run(&mut rec, None).unwrap();
            (summary.loop_seconds, summary.stage_seconds) = Default::default();
            (summary, rec.out.time.len())
        };
        for job in &jobs {
            let (case, casing, _) = sim.case_for_job(job).unwrap();
            let shared =
                Simulation::with_cache(&case, &sim.impeller, &casing, Some(&sim.casing_cache))
                    .unwrap();
            let own = Simulation::new(&case, &sim.impeller, &casing).unwrap();
            let (a, b) = (run(shared), run(own));
            let coating = a.0.coating.as_ref().expect("a coated run");
            assert!(a.0.peaks.blade_radial() > 0.0 && coating.coating_steps > 0);
            assert_eq!(a, b, "Ω = {}", case.omega);
        }
        assert_eq!(sim.casing_cache.sides_kept(), 1);
    }

    #[test]
    fn rigid_meridian_offsets_along_the_shroud_side_normal() {
        // Axial tip (r constant, z increasing): the casing is radially outside.
        let m = rigid_meridian(&[[0.1, 0.0], [0.1, 0.01], [0.1, 0.02]], 1e-3);
        for p in &m {
            assert!((p[0] - 0.101).abs() < 1e-15);
        }
        // Radial tip at the outlet of a centrifugal wheel (r increasing at constant z): the
        // shroud is on the −z side.
        let m = rigid_meridian(&[[0.09, 0.0], [0.10, 0.05], [0.11, 0.05]], 1e-3);
        assert!((m[2][1] - 0.049).abs() < 1e-15 && (m[2][0] - 0.11).abs() < 1e-15);
        // The same axial tip described trailing edge first still gets its casing outside.
        let m = rigid_meridian(&[[0.1, 0.02], [0.1, 0.01], [0.1, 0.0]], 1e-3);
        assert!(m.iter().all(|p| (p[0] - 0.101).abs() < 1e-15));
    }

    #[test]
    fn tabulated_gap_reproduces_the_lobed_casing() {
        let meridian = vec![[0.1, 0.0], [0.1, 0.02]];
        let lobed = rigid_casing(2, 3e-4, None, Some(60), meridian.clone());
        // The same two lobes given as a tabulated gap function (amplitude 0) …
        let table: Vec<f64> = (0..60)
            .map(|i| 3e-4 * (2.0 * 2.0 * std::f64::consts::PI * i as f64 / 60.0).cos())
            .collect();
        let tabulated = rigid_casing(2, 0.0, Some(&table), None, meridian.clone());
        let (a, b) = (
            lobed.data_points().unwrap(),
            tabulated.data_points().unwrap(),
        );
        assert_eq!(a.len(), b.len());
        for (p, q) in a.iter().zip(&b) {
            assert!((p - q).norm() < 1e-15, "{p} vs {q}");
        }
        // … and the blades start in the widest clearance (θ = 0 is a valley of the casing).
        assert!((a[0].norm() - (0.1 + 3e-4)).abs() < 1e-15);
        // A constant offset widens the gap everywhere.
        let wider = rigid_casing(2, 0.0, Some(&[1e-4; 8]), None, meridian);
        assert!(
            wider
                .data_points()
                .unwrap()
                .iter()
                .step_by(2)
                .all(|p| (p.xy().norm() - 0.1001).abs() < 1e-15)
        );
    }

    #[test]
    fn steady_window_starts_after_the_load() {
        let mut case: Case =
            serde_json::from_value(serde_json::json!({"omega": 1.0, "duration": 1.0})).unwrap();
        assert_eq!(steady_window_start(&case, 0.5), 0.5);
        case.load = Some(LobeLoad {
            lobes: 2,
            static_displacement: 1e-4,
            ramp_time: 0.8,
            hold_time: 0.0,
        });
        assert_eq!(steady_window_start(&case, 0.5), 0.8);
    }
}
