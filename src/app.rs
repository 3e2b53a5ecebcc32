//! The subcommands of the `rubscan` binary as library calls, so tests, notebooks
//! or services can run them without the CLI. Errors carry the file or field at fault.

use std::fmt::Write as _;
use std::path::Path;

use std::f64::consts::PI;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, Result, anyhow, bail};

use crate::dynamics::simulate::default_time_step;
use crate::dynamics::{Boundary, SimError, Simulation};
use crate::io::calculix::{CalculixImportSpec, import_calculix};
use crate::io::calculix_sector::{CalculixSectorSpec, import_calculix_sector};
use crate::io::matrix_market::{MatrixMarketImportSpec, import_matrix_market};
use crate::io::timeseries::TimeSeriesWriter;
use crate::sweep::checkpoint::read_record;
use crate::sweep::planner::Job;
use crate::sweep::plots::{campbell_diagram, write_sweep_plots};
use crate::sweep::probe_report::ProbeReport;
use crate::sweep::report::{self, campbell_data, write_report};
use crate::sweep::rounds::{located_per_line, refined_plan};
use crate::sweep::simulator::ModelSimulator;
use crate::sweep::slurm;
use crate::sweep::status::status as sweep_status;
use crate::sweep::{
    CriticalSpeed, MergeSummary, Plan, RunCounters, RunOptions, RunSummary, SpecError, SweepSpec,
    default_output_dir, load_records, load_spec, merge, parse_shard, plan, resolve, run_sweep,
};

use crate::dynamics::structure::Structure;
use crate::io::{model_cache, rom_file};
use crate::model::build::{ModelSpec, build_casing, build_impeller};

pub use crate::io::model_cache::{casing_rom, impeller_rom};
use crate::model::rom::CyclicRom;
pub use crate::sweep::report::{DEFAULT_MAX_JOBS as DEFAULT_REPORT_JOBS, ReportOptions};

/// Exit status: every job ran and succeeded.
pub const EXIT_OK: u8 = 0;
/// Exit status: invalid input (spec, model file, arguments) or another error that stopped the
/// command before it finished; nothing was run.
pub const EXIT_INVALID: u8 = 1;
/// Exit status: the sweep (or simulation) ran but some jobs failed; the reasons are in
/// `jobs/<id>.json` and the manifest.
pub const EXIT_JOBS_FAILED: u8 = 2;
/// Exit status: interrupted (Ctrl-C); finished jobs are kept and a re-run resumes.
pub const EXIT_INTERRUPTED: u8 = 130;

/// Why a command did not succeed; [`AppError::exit_code`] is the process exit status.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// The sweep spec is invalid (every issue with its JSON pointer), or one of its models
    /// cannot be built or loaded.
    #[error(transparent)]
    Invalid(#[from] SpecError),
    /// Any other error that stopped the command (bad argument, unreadable file, I/O), with
    /// its causes, each said once.
    #[error("{}", crate::sweep::validate::causes(.0.as_ref()))]
    Failed(#[from] anyhow::Error),
    /// The sweep ran but jobs failed.
    #[error(
        "{failed} of {finished} finished jobs failed; the reasons are in {dir}/jobs/<id>.json and {dir}/manifest.json",
        dir = .output.display()
    )]
    JobsFailed {
        /// Failed jobs of the shard (including failed jobs skipped on resume).
        failed: usize,
        /// Finished jobs of the shard.
        finished: usize,
        /// Output directory.
        output: PathBuf,
    },
    /// The one simulation of `rubscan simulate` failed at run time.
    #[error("simulation failed: {0}")]
    SimulationFailed(SimError),
    /// Interrupted by Ctrl-C.
    #[error("interrupted")]
    Interrupted,
    /// `merge` found planned jobs in no shard, or failed jobs.
    #[error(
        "merge: {missing} planned jobs have no record and {failed} failed; shards to look at:\n  {shards}"
    )]
    MergeIncomplete {
        /// Planned jobs found in no shard.
        missing: usize,
        /// Failed jobs.
        failed: usize,
        /// One line per shard at fault.
        shards: String,
    },
}

impl AppError {
    /// Process exit status: [`EXIT_INVALID`], [`EXIT_JOBS_FAILED`] or [`EXIT_INTERRUPTED`].
    pub fn exit_code(&self) -> u8 {
        match self {
            AppError::Invalid(_) | AppError::Failed(_) => EXIT_INVALID,
            AppError::JobsFailed { .. }
            | AppError::SimulationFailed(_)
            | AppError::MergeIncomplete { .. } => EXIT_JOBS_FAILED,
            AppError::Interrupted => EXIT_INTERRUPTED,
        }
    }
}

/// `spec` checked as a whole, as `plan`, `run` and `slurm` check it before anything runs or
/// is written: validated with its models, planned, and every job's coating within the limits
/// of the explicit scheme ([`ModelSimulator::check_coating_limits`]).
fn checked_sweep(spec: &SweepSpec) -> Result<(ModelSimulator, Plan), AppError> {
    let plan = plan(spec)?;
    let sim = ModelSimulator::from_resolved(resolve(spec)?)?;
    sim.check_coating_limits(&plan.jobs)?;
    Ok((sim, plan))
}

/// `rubscan model info`: a human-readable summary of a ROM file (sizes, frequencies per
/// nodal diameter at the lowest and highest rotation speed of its modal data). With a
/// structural mistuning pattern (`δ_s` per blade), the mistuned wheel's modes at `omega`
/// (rad/s) follow ([`describe_mistuned_modes`]).
pub fn model_info(path: &Path, mistuning: Option<(&[f64], f64)>) -> Result<String> {
    let rom = rom_file::load(path)?;
    let mut text = describe_rom(&rom);
    if let Some((delta, omega)) = mistuning {
        text += &describe_mistuned_modes(&rom, delta, omega)
            .with_context(|| format!("{}: --mistuning", path.display()))?;
    }
    Ok(text)
}

/// The lowest 3 N_b modes of `rom`'s wheel with blade `s`'s Young's modulus scaled by
/// `1 + delta[s]`, at `omega` (rad/s): frequency (Hz), localization (inverse participation
/// ratio, 1 to N_b), the blade moving most, and every blade's tip amplitude relative to it.
pub(crate) fn describe_mistuned_modes(
    rom: &CyclicRom,
    delta: &[f64],
    omega: f64,
) -> Result<String> {
    let modes =
        crate::analysis::mistuned_modes::mistuned_modes(rom, delta, omega, 3 * rom.n_sectors)?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "mistuned wheel at Ω = {omega:.1} rad/s, blade Young's modulus × (1 + δ), δ = {delta:?} \
         ({} blade shapes):",
        rom.blade_modes.omega2.len()
    );
    let _ = writeln!(
        s,
        "{:>4}  {:>12}  {:>6}  {:>5}  blade tip amplitudes / largest (blade 0, 1, …)",
        "mode", "f [Hz]", "IPR", "blade"
    );
    for (p, f) in modes.frequencies_hz.iter().enumerate() {
        let amp = &modes.blade_amplitude[p];
        let top = amp.iter().position(|&a| a == 1.0).unwrap_or(0);
        let list: Vec<String> = amp.iter().map(|a| format!("{a:.2}")).collect();
        let _ = writeln!(
            s,
            "{p:>4}  {f:>12.2}  {:>6.2}  {top:>5}  {}",
            modes.localization[p],
            list.join(" ")
        );
    }
    Ok(s)
}

/// Summary text of a ROM: sizes, then per nodal diameter the first natural frequencies (Hz).
pub(crate) fn describe_rom(rom: &CyclicRom) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "name: {} ({:?})", rom.name, rom.component);
    let _ = writeln!(
        s,
        "sectors: {}, contact nodes per sector: {}, nodal diameters: 0..={}, assembled DOFs: {}",
        rom.n_sectors,
        rom.n_contact(),
        rom.max_nodal_diameter(),
        rom.n_dofs()
    );
    let _ = writeln!(s, "damping: {:?}", rom.damping);
    let speeds = rom
        .modal_data
        .first()
        .map_or(vec![0.0], |m| m.omega.clone());
    for omega in [
        speeds.first().copied().unwrap_or(0.0),
        speeds.last().copied().unwrap_or(0.0),
    ] {
        if let Ok(st) = Structure::new(rom, omega) {
            let _ = writeln!(
                s,
                "Ω = {omega:.1} rad/s: highest ROM frequency {:.4e} rad/s, explicit stability limit h < 2/ω_max = {:.4e} s, default step {:.4e} s",
                st.omega_max,
                st.stability_limit(),
                default_time_step(&st, None, omega)
            );
            let massless = st.with_boundary(Boundary::Massless);
            let _ = writeln!(
                s,
                "  massless boundary: highest retained frequency {:.4e} rad/s, explicit stability limit {:.4e} s, default step {:.4e} s",
                massless.omega_max,
                massless.stability_limit(),
                default_time_step(&massless, None, omega)
            );
        }
    }
    for md in &rom.modal_data {
        for (i, omega) in md.omega.iter().enumerate() {
            if i != 0 && i + 1 != md.omega.len() {
                continue;
            }
            let freqs: Vec<String> = md.frequencies[i]
                .iter()
                .take(6)
                .map(|f| format!("{f:.1}"))
                .collect();
            let _ = writeln!(
                s,
                "k = {:>3}  Ω = {:>8.1} rad/s  f [Hz]: {}",
                md.nodal_diameter,
                omega,
                freqs.join(", ")
            );
        }
    }
    s
}

/// Reads a model spec file (JSON, unknown fields rejected); `None` gives the built-in defaults.
pub(crate) fn read_model_spec(path: Option<&Path>) -> Result<ModelSpec> {
    let Some(path) = path else {
        return Ok(ModelSpec::default());
    };
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let value: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: malformed JSON", path.display()))?;
    ModelSpec::from_json(value).with_context(|| path.display().to_string())
}

/// `rubscan model build`: builds (or loads from the cache) the impeller and casing ROMs of a
/// spec and writes `impeller.rom` and `casing.rom` to `output`; prints timings and sizes.
pub fn model_build(spec: Option<&Path>, output: &Path) -> Result<()> {
    let spec = read_model_spec(spec)?;
    // Both models are built before either is written: a bad casing leaves no impeller file.
    let mut built = Vec::new();
    for kind in ["impeller", "casing"] {
        let start = std::time::Instant::now();
        let (rom, cached) = match kind {
            "impeller" => model_cache::cached_rom(kind, &spec.impeller, build_impeller)?,
            _ => model_cache::cached_rom(kind, &spec.casing, build_casing)?,
        };
        built.push((kind, rom, cached, start.elapsed()));
    }
    for (kind, rom, cached, elapsed) in built {
        let path = output.join(format!("{kind}.rom"));
        rom_file::save(&rom, &path)?;
        eprintln!(
            "{kind}: {} in {:.2} s ({}), {} sectors, {} contact nodes per sector, {} assembled DOFs -> {}",
            if cached { "loaded from cache" } else { "built" },
            elapsed.as_secs_f64(),
            model_cache::cache_dir().display(),
            rom.n_sectors,
            rom.n_contact(),
            rom.n_dofs(),
            path.display()
        );
    }
    Ok(())
}

/// Target format of `rubscan model export`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// CalculiX input decks (C3D20, cyclic symmetry), see [`crate::io::calculix_export`].
    Calculix,
}

/// `rubscan model export calculix [spec] -o dir`: writes the built-in impeller and casing
/// sectors of a model spec (the meshes `rubscan model build` reduces, same defaults) as
/// CalculiX decks: `<component>_sector.inp` (model definition) and
/// `<component>_frequencies.inp` (cyclic frequencies of every nodal diameter at rest; run
/// `ccx <component>_frequencies` in `dir`). Returns the written files, impeller first.
pub fn model_export(
    format: ExportFormat,
    spec: Option<&Path>,
    prestress_rad_s: &[f64],
    output: &Path,
) -> Result<Vec<PathBuf>> {
    use crate::io::calculix_export::{
        DEFAULT_CALCULIX_MODES, FrequencyDeck, frequency_deck, model_deck,
    };
    let ExportFormat::Calculix = format;
    let label = spec.map_or("built-in defaults".to_string(), |p| p.display().to_string());
    if let Some(w) = prestress_rad_s
        .iter()
        .find(|w| !(w.is_finite() && **w > 0.0))
    {
        bail!("--omega {w}: a prestress speed must be a finite number of rad/s above 0");
    }
    let spec = read_model_spec(spec)?;
    let meshes = [
        ("impeller", spec.impeller.geometry.build()),
        ("casing", spec.casing.geometry.build()),
    ];
    // Every deck is made before any is written: a bad casing leaves no impeller deck.
    let mut files = Vec::new();
    for (component, mesh) in meshes {
        let mesh = mesh.with_context(|| format!("{label}: {component} geometry"))?;
        let model_file = format!("{component}_sector.inp");
        let model = model_deck(&mesh, component)?;
        let opts = FrequencyDeck {
            model_file: model_file.clone(),
            modes_per_diameter: DEFAULT_CALCULIX_MODES,
            omega_rad_s: 0.0,
        };
        files.push((output.join(&model_file), model));
        let freq = output.join(format!("{component}_frequencies.inp"));
        files.push((freq, frequency_deck(&mesh, &opts)));
        if component == "impeller" {
            for &omega in prestress_rad_s {
                let deck = frequency_deck(
                    &mesh,
                    &FrequencyDeck {
                        omega_rad_s: omega,
                        ..opts.clone()
                    },
                );
                files.push((
                    output.join(format!("impeller_prestressed_{omega}.inp")),
                    deck,
                ));
            }
        }
    }
    for (path, text) in &files {
        crate::io::atomic::write_atomic(path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(files.into_iter().map(|(p, _)| p).collect())
}

/// A cancel flag that Ctrl-C sets, for the CLI: the sweep runner and the time loop poll it and
/// stop cleanly, writing nothing half-done. A library caller (a notebook binding) passes its
/// own flag instead and keeps the process's signal handling.
pub fn cancel_on_ctrl_c() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let set = flag.clone();
    let _ = ctrlc::set_handler(move || {
        eprintln!(
            "interrupt: finishing cleanly (jobs in flight are dropped and will re-run on resume)"
        );
        set.store(true, Ordering::SeqCst);
    });
    flag
}

/// `rubscan simulate`: runs one job of a spec (sweep format; job `index` of its plan, 0 by
/// default) and writes `timeseries.parquet` and `summary.json` to `output`
/// (default `results/<name>/simulate-<index>`). Returns the output directory. Setting
/// `cancel` stops the time loop ([`AppError::Interrupted`], nothing written).
pub fn simulate(
    spec: &SweepSpec,
    index: usize,
    output: Option<&Path>,
    cancel: &AtomicBool,
) -> Result<PathBuf, AppError> {
    // As in a sweep's jobs: faer's parallel products change the round-off of the set-up
    // with the thread count, and that reaches the contact dynamics (the Rotor 37 benchmark's
    // peak-to-peak moved by 0.27 % between 1 and 2 threads).
    faer::set_global_parallelism(faer::Par::Seq);
    let resolved = resolve(spec)?;
    let plan = plan(spec)?;
    let job = plan.jobs.get(index).ok_or_else(|| {
        anyhow!(
            "sweep {}: the plan has {} jobs, no job {index}",
            spec.name,
            plan.jobs.len()
        )
    })?;
    let sim = ModelSimulator::from_resolved(resolved)?;
    sim.check_coating_limits(std::slice::from_ref(job))?;
    let (case, casing, _) = sim.case_for_job(job)?;
    let failed = |e| match e {
        SimError::Cancelled { .. } => AppError::Interrupted,
        e => AppError::SimulationFailed(e),
    };
    // Every check of the case runs before the output directory is made.
    let simulation = Simulation::new(&case, sim.impeller(), &casing).map_err(failed)?;
    let dir = output.map_or_else(
        || {
            PathBuf::from("results")
                .join(&spec.name)
                .join(format!("simulate-{index}"))
        },
        Path::to_path_buf,
    );
    // The directories this call makes, removed again if the job fails (they hold nothing
    // then: the series is written under a temporary name until it is complete).
    let made: Vec<PathBuf> = dir
        .ancestors()
        .take_while(|d| !d.as_os_str().is_empty() && !d.exists())
        .map(Path::to_path_buf)
        .collect();
    let mut series = TimeSeriesWriter::create(&dir.join("timeseries.parquet"))?;
    let report = spec.scenario.revolution_report;
    let mut figures = report.map(|w| ProbeReport::new(case.omega, case.duration, w));
    let out = match figures.as_mut() {
        Some(f) => simulation.run(&mut (&mut series, f), Some(cancel)),
        None => simulation.run(&mut series, Some(cancel)),
    };
    let out = match out {
        Ok(out) => out,
        Err(e) => {
            drop(series);
            for d in &made {
                // Only empty directories go: nothing else is touched.
                let _ = std::fs::remove_dir(d);
            }
            return Err(failed(e));
        }
    };
    series.finish()?;
    let figures = figures
        .map(ProbeReport::finish)
        .transpose()
        .map_err(|e| anyhow!(e))?;
    let summary = serde_json::json!({
        "job_id": job.id,
        "case": case,
        "units": "SI: m, N, J, s, rad/s",
        "time_step_s": out.time_step,
        "stability_limit_s": out.stability_limit,
        "steps_per_revolution": out.steps_per_revolution,
        "n_steps": out.n_steps,
        "steps_run": out.steps_run,
        "outcome": if out.runaway.is_some() { "unstable" } else { "ok" },
        "runaway": out.runaway,
        "contact_steps": out.contact_steps,
        "closed_contact_steps": out.closed_contact_steps,
        "closed_contact_fraction": out.closed_contact_steps as f64 / out.n_steps.max(1) as f64,
        "max_blade_radial_m": out.peaks.blade_radial(),
        "max_residual_penetration_m": out.max_residual_penetration,
        "steps_over_gap_tolerance": out.steps_over_gap_tolerance,
        "loop_seconds": out.loop_seconds,
        "revolution_report": report,
        "probes": figures,
    });
    crate::io::atomic::write_atomic(
        &dir.join("summary.json"),
        serde_json::to_string_pretty(&summary)
            .map_err(anyhow::Error::from)?
            .as_bytes(),
    )
    .map_err(anyhow::Error::from)?;
    eprintln!(
        "{} steps ({} with contact) in {:.1} s, h = {:.3e} s (limit {:.3e} s, {:.0} steps/rev) -> {}",
        out.n_steps,
        out.contact_steps,
        out.loop_seconds,
        out.time_step,
        out.stability_limit,
        out.steps_per_revolution,
        dir.display()
    );
    eprintln!(
        "closed contact on {:.4} of the steps; largest residual penetration {:.3e} m, \
         {} steps above the gap tolerance",
        out.closed_contact_steps as f64 / out.n_steps.max(1) as f64,
        out.max_residual_penetration,
        out.steps_over_gap_tolerance
    );
    if let Some(r) = &out.runaway {
        eprintln!(
            "UNSTABLE: runaway from {:.3} ms (σ = {:.1} 1/s, R² {:.2}, nodal diameter {:?}, {:?} Hz), \
             stopped at {:.3} ms after {} of {} steps{}",
            r.onset_time_s * 1e3,
            r.growth_rate_per_s,
            r.growth_fit_r2,
            r.nodal_diameter,
            r.frequency_hz,
            r.detected_time_s * 1e3,
            out.steps_run,
            out.n_steps,
            if r.at_solve_breakdown {
                ", where it outran the contact solve"
            } else {
                ""
            }
        );
    }
    for f in figures.iter().flatten() {
        let s = &f.steady;
        eprintln!(
            "{}: min {:.6e} max {:.6e} {u}; last revolutions: peak-to-peak {:.6e} {u}, mean {:.6e} {u}, \
             dominant {:.3} Hz (engine order {:.3}, amplitude {:.4e} {u})",
            f.column,
            f.min,
            f.max,
            s.peak_to_peak,
            s.mean,
            s.dominant_frequency_hz,
            s.dominant_engine_order,
            s.dominant_amplitude,
            u = f.unit
        );
    }
    Ok(dir)
}

/// The jobs of a sweep, after validating the whole spec with its models as `run` does.
pub fn checked_plan(spec: &SweepSpec) -> Result<Plan, AppError> {
    Ok(checked_sweep(spec)?.1)
}

/// `rubscan plan`: the jobs of a sweep with their resolved parameters and the work estimate,
/// after validating the whole spec with its models.
pub fn plan_text(spec: &SweepSpec) -> Result<String, AppError> {
    let plan = checked_plan(spec)?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:>5}  {:<16}  {:>12}  {:>6}  {:>12}  coating",
        "index", "id", "Ω [rad/s]", "μ", "clearance [m]"
    );
    for j in &plan.jobs {
        let p = &j.params;
        let clearance = p.clearance_m.map_or("-".into(), |c| format!("{c:.3e}"));
        let _ = writeln!(
            s,
            "{:>5}  {:<16}  {:>12.2}  {:>6.3}  {:>12}  {}",
            j.index,
            j.id,
            p.speed_rad_s,
            p.friction,
            clearance,
            serde_json::to_string(&p.coating).map_err(anyhow::Error::from)?
        );
    }
    let _ = match (plan.steps_per_job, plan.total_steps) {
        (Some(per_job), Some(total)) => writeln!(
            s,
            "{} jobs; {per_job} steps per job, {total} steps in all",
            plan.jobs.len()
        ),
        _ => writeln!(
            s,
            "{} jobs; steps per job from the default time step at each speed (`rubscan model \
             info` prints it)",
            plan.jobs.len()
        ),
    };
    Ok(s)
}

/// Options of `rubscan run`.
#[derive(Clone, Debug, Default)]
pub struct RunArgs {
    /// Worker threads (0 = all cores); `None`: `SLURM_CPUS_PER_TASK` inside a Slurm job,
    /// else all cores.
    pub threads: Option<usize>,
    /// `i/n`: run only the jobs whose index ≡ i (mod n); `None`: the shard of the Slurm
    /// array task when `SLURM_ARRAY_TASK_ID` is set (written to `<output>/shards/<i>-of-<n>`).
    pub shard: Option<String>,
    /// Output directory (default `results/<name>`).
    pub output: Option<PathBuf>,
    /// Re-run failed jobs too.
    pub retry_failed: bool,
    /// Also write each job's time series to `<output>/timeseries/<job id>.parquet`.
    pub timeseries: bool,
    /// Draw the indicatif progress bar on stderr (the CLI, when stderr is a terminal); else
    /// plain log lines.
    pub progress_bar: bool,
    /// Set to stop the sweep cleanly (finished jobs kept; [`check_run`] then says
    /// [`AppError::Interrupted`]). The CLI's is [`cancel_on_ctrl_c`].
    pub cancel: Arc<AtomicBool>,
    /// Jobs and steps done so far, readable while the sweep runs (a notebook's progress bar).
    pub counters: Arc<RunCounters>,
}

/// `rubscan run`: validates the whole spec with its models, then runs (or resumes) the sweep
/// and writes `results.parquet`, the manifest and plots. Failed jobs do not make this an
/// error: see [`check_run`] for the exit status.
pub fn run(spec: &SweepSpec, args: &RunArgs) -> Result<RunSummary, AppError> {
    let env = |k: &str| std::env::var(k).ok();
    let explicit = args.shard.as_deref().map(parse_shard).transpose()?;
    let from_slurm = match explicit {
        Some(_) => None,
        None => slurm::shard_from_env(&env)?,
    };
    let threads = match args.threads {
        Some(n) => n,
        None => slurm::threads_from_env(&env)?.unwrap_or(0),
    };
    // The spec alone names the output directory, checked before the models are touched.
    let base = args
        .output
        .clone()
        .unwrap_or_else(|| default_output_dir(Path::new("."), spec));
    let mut opts = RunOptions::new(match from_slurm {
        Some((i, n)) => slurm::shard_dir(&base, i, n),
        None => base,
    });
    if let Some((i, n)) = from_slurm {
        eprintln!(
            "[sweep] Slurm array task: shard {i}/{n}, {} threads -> {}",
            threads,
            opts.output_dir.display()
        );
    }
    opts.threads = threads;
    opts.shard = explicit.or(from_slurm);
    opts.progress = args.progress_bar;
    opts.retry_failed = args.retry_failed;
    opts.cancel = args.cancel.clone();
    opts.counters = args.counters.clone();
    crate::sweep::runner::check_output_dir(&opts.output_dir, spec, opts.shard)?;
    let (mut sim, plan) = checked_sweep(spec)?;
    if let Some(note) = sim.supercritical_note(&plan.jobs)? {
        eprintln!("[sweep] note: {note}");
    }
    if args.timeseries {
        sim = sim.with_timeseries(opts.output_dir.join("timeseries"));
    }
    let summary = run_sweep(spec, &opts, &sim)?;
    // A refined sweep's jobs are those of its rounds so far.
    let out = &opts.output_dir;
    let finished = |job: &Job| read_record(out, &job.id).ok().flatten();
    let plan = refined_plan(spec, &finished)?;
    let records = load_records(out, plan.jobs.iter());
    for (line, found) in located_per_line(spec, &plan, &records).iter().enumerate() {
        for b in &found.boundaries {
            eprintln!(
                "[sweep] line {line}: {} from between {:.2} and {:.2} rad/s{}",
                if b.unstable_above { "unstable" } else { "ok" },
                b.lo_rad_s,
                b.hi_rad_s,
                if b.within_tolerance {
                    ""
                } else {
                    " (not yet within the tolerance)"
                }
            );
        }
        for p in found.peaks.iter().filter(|p| !p.at_end) {
            eprintln!(
                "[sweep] line {line}: peak {:.4e} at {:.2} rad/s, between {:.2} and {:.2} rad/s{}",
                p.value,
                p.best_rad_s,
                p.lo_rad_s,
                p.hi_rad_s,
                if p.within_tolerance {
                    ""
                } else {
                    " (not yet within the tolerance)"
                }
            );
        }
    }
    let lobes = report::lobes(spec);
    let orders: Vec<u32> = (1..=8).map(|i| i * lobes).collect();
    let plots =
        write_sweep_plots(&opts.output_dir, &records, &orders).map_err(anyhow::Error::from)?;
    eprintln!(
        "{} jobs: {} ran, {} skipped (already done), {} ok, {} unstable, {} failed{} in {:.1} s -> {} (+{} plots)",
        summary.in_shard,
        summary.ran,
        summary.skipped,
        summary.ok,
        summary.unstable,
        summary.failed,
        if summary.cancelled { ", cancelled" } else { "" },
        summary.wall_time_s,
        summary.results_path.display(),
        plots.len()
    );
    Ok(summary)
}

/// The exit status of a finished [`run`]: [`AppError::Interrupted`] when Ctrl-C stopped it,
/// [`AppError::JobsFailed`] when any finished job of the shard failed (including failed jobs
/// skipped on resume). An `unstable` job (a runaway found) is a success.
pub fn check_run(summary: &RunSummary) -> Result<(), AppError> {
    if summary.cancelled {
        return Err(AppError::Interrupted);
    }
    if summary.failed > 0 {
        return Err(AppError::JobsFailed {
            failed: summary.failed,
            finished: summary.ok + summary.unstable + summary.failed,
            output: summary
                .results_path
                .parent()
                .map_or_else(PathBuf::new, Path::to_path_buf),
        });
    }
    Ok(())
}

/// The critical speeds of a sweep's models ([`critical_speeds`]).
#[derive(Debug, Clone)]
pub struct CriticalSpeeds {
    /// The linear interaction criterion's coincidences, by increasing speed.
    pub speeds: Vec<CriticalSpeed>,
    /// The flexible casing's critical wave speed min_k ω_k/k (rad/s) and its nodal diameter;
    /// `None` for a rigid casing.
    pub critical_wave_speed: Option<(f64, usize)>,
}

/// The linear interaction criterion's critical speeds of a sweep's models, and the flexible
/// casing's critical wave speed when it has one.
pub fn critical_speeds(spec: &SweepSpec) -> Result<CriticalSpeeds, AppError> {
    let sim = ModelSimulator::from_resolved(resolve(spec)?)?;
    Ok(CriticalSpeeds {
        speeds: sim.critical_speeds().to_vec(),
        critical_wave_speed: sim.casing_wave_speed()?,
    })
}

/// `rubscan campbell`: critical speeds of the linear interaction criterion for a sweep's
/// models, as a table; draws the absolute-frame Campbell diagram to `output` (PNG or SVG).
pub fn campbell(spec: &SweepSpec, output: &Path) -> Result<String, AppError> {
    let sim = ModelSimulator::from_resolved(resolve(spec)?)?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:>12}  {:>8}  {:>13}  {:>8}",
        "Ω* [rad/s]", "Ω* [rpm]", "nodal diam. n", "compat."
    );
    for c in sim.critical_speeds() {
        let _ = writeln!(
            s,
            "{:>12.1}  {:>8.0}  {:>13}  {:>8.3}",
            c.speed_rad_s,
            c.speed_rad_s * 30.0 / PI,
            c.nodal_diameter,
            c.compatibility
        );
    }
    if let Some((omega_c, k)) = sim.casing_wave_speed()? {
        let _ = writeln!(
            s,
            "flexible casing's critical wave speed min_k ω_k/k = {omega_c:.1} rad/s ({:.0} rpm, \
             nodal diameter {k}): above it a rotating contact can feed the casing's backward \
             waves with the rotation's energy (moving-load instability, docs/validation.md)",
            omega_c * 30.0 / PI
        );
    }
    // A readable diagram: the nodal diameters of the first critical speeds, first casing mode
    // and first two impeller branches of each.
    let data = campbell_data(&sim, None);
    campbell_diagram(&data, output).map_err(anyhow::Error::from)?;
    let _ = writeln!(s, "Campbell diagram -> {}", output.display());
    Ok(s)
}

/// The speed range of a stability prediction.
#[derive(Debug, Clone, Copy)]
pub struct StabilityRange {
    /// Lowest speed (rad/s); default 0.8 × the grid's lowest.
    pub from: Option<f64>,
    /// Highest speed (rad/s); default 1.2 × the grid's highest, at most the highest speed of
    /// the impeller's modal grid.
    pub to: Option<f64>,
    /// Speeds of the scan, ≥ 2.
    pub count: usize,
}

/// Arguments of [`stability`].
#[derive(Debug, Clone)]
pub struct StabilityArgs {
    /// Diagram file (.png or .svg); one per friction coefficient when the grid has several
    /// (`<stem>-mu<μ>.<ext>`).
    pub output: PathBuf,
    /// The speeds scanned.
    pub range: StabilityRange,
}

/// The linear stability of a persistent rub over a speed range, for one friction coefficient.
#[derive(Debug, Clone)]
pub struct FrictionStability {
    /// Coulomb friction coefficient μ.
    pub friction: f64,
    /// Per speed of the range, ascending: every coupled wave and the verdict.
    pub speeds: Vec<crate::analysis::stability::StabilityAtSpeed>,
    /// Lowest speed (rad/s) at which a wave grows, located to 1e-4 of the range's top; `None`
    /// when none grows in the range.
    pub onset_rad_s: Option<f64>,
}

/// The stability prediction of a sweep's models ([`stability_prediction`]).
#[derive(Debug, Clone)]
pub struct StabilityPrediction {
    /// The flexible casing's critical wave speed min_k ω_k/k (rad/s) and its nodal diameter.
    pub critical_wave_speed: Option<(f64, usize)>,
    /// The interaction criterion's critical speeds Ω*_n (rad/s) in the range, with n.
    pub interaction: Vec<(f64, u32)>,
    /// One entry per friction coefficient of the grid, ascending.
    pub per_friction: Vec<FrictionStability>,
}

/// The linear stability of a persistent rub ([`crate::analysis::stability`]) of a sweep's
/// models over a speed range, for each friction coefficient of its grid.
pub fn stability_prediction(
    spec: &SweepSpec,
    range: StabilityRange,
) -> Result<StabilityPrediction, AppError> {
    use crate::analysis::stability::{Predictor, StabilityOptions};
    use rayon::prelude::*;
    let jobs = plan(spec)?.jobs;
    let sim = ModelSimulator::from_resolved(resolve(spec)?)?;
    let (impeller, casing) = (sim.counterclockwise_models())
        .ok_or_else(|| anyhow!("the stability prediction needs a flexible casing model"))?;
    let grid =
        |f: fn(f64, f64) -> f64, init| jobs.iter().map(|j| j.params.speed_rad_s).fold(init, f);
    let from = range.from.unwrap_or(0.8 * grid(f64::min, f64::INFINITY));
    // Not beyond the impeller's modal grid, the speeds its K(Ω) fit was made for.
    let fitted = (sim.impeller().modal_data.first())
        .and_then(|m| m.omega.last().copied())
        .filter(|&w| w > 0.0)
        .unwrap_or(f64::INFINITY);
    let to = (range.to).unwrap_or((1.2 * grid(f64::max, 0.0)).min(fitted));
    if !(from.is_finite() && to.is_finite() && from >= 0.0 && to > from && range.count >= 2) {
        return Err(anyhow!(
            "speed range --from {from} --to {to} --count {} is invalid (0 ≤ from < to, count ≥ 2)",
            range.count
        )
        .into());
    }
    let omegas: Vec<f64> = (0..range.count)
        .map(|i| from + (to - from) * i as f64 / (range.count - 1) as f64)
        .collect();
    let mut frictions: Vec<f64> = jobs.iter().map(|j| j.params.friction).collect();
    frictions.sort_by(f64::total_cmp);
    frictions.dedup();
    let interaction = (sim.critical_speeds().iter())
        .filter(|c| (from..=to).contains(&c.speed_rad_s))
        .map(|c| (c.speed_rad_s, c.nodal_diameter))
        .collect();
    let per_friction = (frictions.iter())
        .map(|&mu| {
            let p = Predictor::new(&impeller, &casing, &StabilityOptions::with_friction(mu))?;
            let speeds = omegas
                .par_iter()
                .map(|&w| p.at(w))
                .collect::<Result<_, _>>()?;
            let onset_rad_s = p.onset_speed(from, to, 1e-4 * to)?;
            Ok(FrictionStability {
                friction: mu,
                speeds,
                onset_rad_s,
            })
        })
        .collect::<Result<_, crate::analysis::stability::StabilityError>>()
        .map_err(anyhow::Error::from)?;
    Ok(StabilityPrediction {
        critical_wave_speed: sim.casing_wave_speed()?,
        interaction,
        per_friction,
    })
}

/// `rubscan stability`: [`stability_prediction`] as a table, per speed the most unstable wave
/// and the predicted onset beside the casing's critical wave speed and the interaction
/// criterion's Ω*, with a diagram of σ_max(Ω) per nodal diameter per friction coefficient.
pub fn stability(spec: &SweepSpec, args: &StabilityArgs) -> Result<String, AppError> {
    use crate::sweep::stability_plot::{StabilityPlotData, stability_diagram};
    let prediction = stability_prediction(spec, args.range)?;
    let mut s = String::new();
    if let Some((w, k)) = prediction.critical_wave_speed {
        let _ = writeln!(
            s,
            "casing critical wave speed {w:.1} rad/s (nodal diameter {k})"
        );
    }
    for (w, n) in &prediction.interaction {
        let _ = writeln!(s, "interaction criterion Ω*_{n} = {w:.1} rad/s");
    }
    let n_frictions = prediction.per_friction.len();
    for f in &prediction.per_friction {
        stability_table(&mut s, f.friction, &f.speeds, f.onset_rad_s);
        let path = diagram_path(&args.output, f.friction, n_frictions);
        let data = StabilityPlotData {
            friction: f.friction,
            speeds: &f.speeds,
            onset_rad_s: f.onset_rad_s,
            critical_wave_speed: prediction.critical_wave_speed,
            interaction_speeds: prediction.interaction.clone(),
        };
        stability_diagram(&data, &path).map_err(anyhow::Error::from)?;
        let _ = writeln!(s, "stability diagram -> {}", path.display());
    }
    Ok(s)
}

/// The table of [`stability`] for one friction coefficient.
fn stability_table(
    s: &mut String,
    mu: f64,
    at: &[crate::analysis::stability::StabilityAtSpeed],
    onset: Option<f64>,
) {
    let _ = writeln!(
        s,
        "μ = {mu}\n{:>10}  {:>8}  {:>8}  {:>4}  {:>4}  {:>11}  {:>10}  {:>8}",
        "Ω [rad/s]", "Ω [rpm]", "verdict", "ND", "ND_b", "σ [1/s]", "f [Hz]", "wave"
    );
    for a in at {
        let Some(w) = a.most_unstable() else { continue };
        let _ = writeln!(
            s,
            "{:>10.1}  {:>8.0}  {:>8}  {:>4}  {:>4}  {:>11.2}  {:>10.1}  {:>8}",
            a.omega_rad_s,
            a.omega_rad_s * 30.0 / PI,
            if a.is_stable() { "stable" } else { "GROWS" },
            w.nodal_diameter,
            w.impeller_nodal_diameter,
            w.growth_rate_per_s,
            w.frequency_hz,
            if w.backward { "backward" } else { "forward" },
        );
    }
    match onset {
        Some(w) if w <= at.first().map_or(0.0, |a| a.omega_rad_s) => {
            let _ = writeln!(
                s,
                "μ = {mu}: a wave grows from the lowest speed of the range, {w:.1} rad/s: the \
                 onset lies below it (lower --from)"
            );
        }
        Some(w) => {
            let _ = writeln!(
                s,
                "μ = {mu}: predicted onset {w:.1} rad/s ({:.0} rpm)",
                w * 30.0 / PI
            );
        }
        None => {
            let _ = writeln!(s, "μ = {mu}: no growing wave in the range");
        }
    }
}

/// `output`, or `<stem>-mu<μ>.<ext>` when the grid has several friction coefficients.
fn diagram_path(output: &Path, mu: f64, n_frictions: usize) -> PathBuf {
    if n_frictions <= 1 {
        return output.to_path_buf();
    }
    let stem = output
        .file_stem()
        .map_or("stability".into(), |s| s.to_string_lossy());
    let ext = output
        .extension()
        .map_or("png".into(), |e| e.to_string_lossy());
    output.with_file_name(format!("{stem}-mu{mu}.{ext}"))
}

/// `rubscan report`: the paper's figures and an `index.html` from a results directory (see
/// [`crate::sweep::report`]); returns a summary for the terminal. A missing or malformed
/// manifest or table is an error naming the file (exit status 1), before anything is written.
pub fn report(results: &Path, options: &ReportOptions) -> Result<String, AppError> {
    let r = write_report(results, options).map_err(anyhow::Error::from)?;
    let mut s = String::new();
    let _ = writeln!(s, "jobs shown: {:?}", r.selected);
    for n in &r.notes {
        let _ = writeln!(s, "note: {n}");
    }
    for f in &r.figures {
        let _ = writeln!(s, "figure -> {}", f.display());
    }
    let _ = writeln!(s, "report -> {}", r.index.display());
    Ok(s)
}

/// `rubscan merge`: combines shard outputs into the table a single run gives. The merged
/// table is written even when shards are unfinished or have failed jobs; then the error
/// names those shards ([`AppError::MergeIncomplete`], exit status 2).
pub fn merge_shards(shards: &[PathBuf], output: &Path) -> Result<MergeSummary, AppError> {
    let summary = merge(shards, output)?;
    eprintln!(
        "{} of {} jobs found ({} failed) -> {}",
        summary.found,
        summary.planned,
        summary.failed,
        summary.results_path.display()
    );
    if summary.missing.is_empty() && summary.failed == 0 {
        return Ok(summary);
    }
    Err(AppError::MergeIncomplete {
        missing: summary.missing.len(),
        failed: summary.failed,
        shards: summary.shard_problems.join("\n  "),
    })
}

/// `rubscan status`: done, failed and remaining jobs of a sweep output directory, per shard,
/// with an estimate of the time left.
pub fn status(output: &Path) -> Result<String> {
    Ok(sweep_status(output)?.to_string())
}

/// Options of `rubscan slurm`.
#[derive(Clone, Debug, Default)]
pub struct SlurmArgs {
    /// Array tasks (= shards).
    pub tasks: usize,
    /// CPUs (worker threads) per task.
    pub cpus_per_task: usize,
    /// `--time` of each task, e.g. `02:00:00`.
    pub time: Option<String>,
    /// `--partition`.
    pub partition: Option<String>,
    /// Output directory (default `results/<name>`).
    pub output: Option<PathBuf>,
    /// Submit with sbatch instead of printing the commands.
    pub submit: bool,
}

/// `rubscan slurm`: validates the spec with its models, writes the array and merge scripts
/// beside the output directory, and prints the sbatch commands, or submits them and prints
/// the job ids.
pub fn slurm(spec_path: &Path, args: &SlurmArgs) -> Result<String, AppError> {
    let spec = load_spec(spec_path)?;
    let (_, plan) = checked_sweep(&spec)?;
    let absolute = |p: &Path| {
        std::path::absolute(p).with_context(|| format!("cannot make {} absolute", p.display()))
    };
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output_dir(Path::new("."), &spec));
    let job = slurm::ArrayJob {
        name: spec.name.clone(),
        rubscan: std::env::current_exe().context("cannot locate the rubscan executable")?,
        spec: absolute(spec_path)?,
        output: absolute(&output)?,
        tasks: args.tasks,
        cpus_per_task: args.cpus_per_task,
        time: args.time.clone(),
        partition: args.partition.clone(),
    };
    job.validate()?;
    job.check_tasks(plan.jobs.len())?;
    let (array, merge) = job.write()?;
    let mut s = format!(
        "wrote {} ({} tasks) and {}\n",
        array.display(),
        job.tasks,
        merge.display()
    );
    if args.submit {
        let (a, m) = job.submit()?;
        let _ = writeln!(s, "array job {a}\nmerge job {m}");
    } else {
        s.push_str(&job.submit_commands());
    }
    Ok(s)
}

/// `rubscan model import`: imports a CalculiX or Matrix Market model (spec JSON), reduces it
/// by Craig–Bampton and writes the ROM file.
pub fn model_import(format: ImportFormat, spec_path: &Path, output: &Path) -> Result<()> {
    let text = std::fs::read_to_string(spec_path)
        .with_context(|| format!("reading {}", spec_path.display()))?;
    let base = spec_path.parent().unwrap_or(Path::new("."));
    // faer's nested threads spin on shared cores; the sparse factorisation is faster sequential
    // here (Rotor 37: 26 s sequential against 49 s with 2 threads).
    faer::set_global_parallelism(faer::Par::Seq);
    let start = std::time::Instant::now();
    // The ROM must not replace one of the files it is made from.
    let refuse_output_among = |inputs: &[&Path]| -> Result<()> {
        let output = std::path::absolute(output)?;
        for input in inputs {
            if std::path::absolute(input)? == output {
                bail!(
                    "-o {}: that is an input of the import; write the ROM to another file",
                    output.display()
                );
            }
        }
        Ok(())
    };
    // Checked before the reduction (seconds), not on the ROM after it.
    let check_damping =
        |d: &crate::model::rom::Damping| d.check().with_context(|| spec_path.display().to_string());
    let rom = match format {
        ImportFormat::Calculix => {
            let mut spec: CalculixImportSpec =
                serde_json::from_str(&text).with_context(|| spec_path.display().to_string())?;
            for p in [
                &mut spec.stiffness,
                &mut spec.mass,
                &mut spec.dof_map,
                &mut spec.mesh,
            ] {
                *p = base.join(&*p);
            }
            refuse_output_among(&[
                spec_path,
                &spec.stiffness,
                &spec.mass,
                &spec.dof_map,
                &spec.mesh,
            ])?;
            check_damping(&spec.damping)?;
            import_calculix(&spec)?
        }
        ImportFormat::MatrixMarket => {
            let mut spec: MatrixMarketImportSpec =
                serde_json::from_str(&text).with_context(|| spec_path.display().to_string())?;
            for p in [
                &mut spec.stiffness,
                &mut spec.mass,
                &mut spec.dof_map,
                &mut spec.nodes,
            ] {
                *p = base.join(&*p);
            }
            refuse_output_among(&[
                spec_path,
                &spec.stiffness,
                &spec.mass,
                &spec.dof_map,
                &spec.nodes,
            ])?;
            check_damping(&spec.damping)?;
            import_matrix_market(&spec)?
        }
        ImportFormat::CalculixCyclic => {
            let mut spec: CalculixSectorSpec =
                serde_json::from_str(&text).with_context(|| spec_path.display().to_string())?;
            spec.deck = base.join(&spec.deck);
            refuse_output_among(&[spec_path, &spec.deck])?;
            check_damping(&spec.damping)?;
            import_calculix_sector(&spec)?
        }
    };
    rom_file::save(&rom, output)?;
    eprintln!(
        "imported and reduced in {:.1} s -> {}",
        start.elapsed().as_secs_f64(),
        output.display()
    );
    Ok(())
}

/// Source format of `rubscan model import`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImportFormat {
    /// CalculiX matrix storage (`.sti`, `.mas`, `.dof`) with nodes from `.inp`/`.msh`.
    Calculix,
    /// Matrix Market `.mtx` with a DOF map and a node table.
    MatrixMarket,
    /// A cyclic sector's CalculiX input deck (C3D20 mesh, cyclic faces), assembled and
    /// reduced by rubscan ([`crate::io::calculix_sector`]).
    CalculixCyclic,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn info_names_the_missing_file() {
        let err = model_info(Path::new("/nonexistent/x.rom"), None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("/nonexistent/x.rom"), "{err}");
    }

    /// The mistuned modes of a small wheel: one line per mode with N_b amplitudes, the blade
    /// moving most at 1.00. A ROM without blade shapes and a pattern of the wrong length are
    /// refused, naming what to change.
    #[test]
    fn info_prints_the_mistuned_modes_and_names_what_is_missing() {
        use crate::model::build::{ImpellerSpec, build_impeller};
        use crate::model::mesh::ImpellerGeometry;
        let spec = ImpellerSpec {
            geometry: ImpellerGeometry {
                n_blades: 4,
                ..ImpellerGeometry::default()
            },
            modes_per_diameter: 6,
            omega_grid_rad_s: vec![0.0],
            blade_modes: 4,
            ..ImpellerSpec::default()
        };
        let rom = build_impeller(&spec).unwrap();
        let text = describe_mistuned_modes(&rom, &[0.1, 0.0, 0.0, 0.0], 0.0).unwrap();
        let rows: Vec<&str> = text.lines().skip(2).collect();
        assert_eq!(rows.len(), 12, "{text}");
        for row in rows {
            let cols: Vec<&str> = row.split_whitespace().collect();
            assert_eq!(cols.len(), 4 + 4, "{row}");
            assert!(cols[4..].contains(&"1.00"), "{row}");
        }
        let err = describe_mistuned_modes(&rom, &[0.1, 0.0], 0.0)
            .unwrap_err()
            .to_string();
        assert!(err.contains("2 values for 4 blades"), "{err}");
        let mut plain = rom.clone();
        *plain.blade_modes = Default::default();
        let err = describe_mistuned_modes(&plain, &[0.0; 4], 0.0)
            .unwrap_err()
            .to_string();
        assert!(err.contains("impeller.blade_modes"), "{err}");
    }

    /// A cause that the message above it already quotes is not said again (it printed
    /// "Is a directory (os error 21): Is a directory (os error 21)"); a new one is.
    #[test]
    fn an_error_says_each_cause_once() {
        let io = || std::io::Error::from(std::io::ErrorKind::IsADirectory);
        let quoted = anyhow::Error::new(io()).context(format!("writing out.png: {}", io()));
        assert_eq!(
            AppError::Failed(quoted).to_string(),
            format!("writing out.png: {}", io())
        );
        let apart = anyhow::Error::new(io()).context("writing out.png");
        assert_eq!(
            AppError::Failed(apart).to_string(),
            format!("writing out.png: {}", io())
        );
    }
}
