//! `rubscan` command line: parses arguments and dispatches to [`rubscan::app`].

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use rubscan::app::{self, AppError, ExportFormat, ImportFormat, ReportOptions, RunArgs, SlurmArgs};
use rubscan::sweep::load_spec;

/// Exit statuses, shown by `rubscan --help`.
const EXIT_STATUS_HELP: &str = "\
Exit status:
  0    success (every job ran and succeeded)
  1    invalid input (spec, model file, arguments) or another error; nothing ran
  2    the sweep ran but some jobs failed (reasons in jobs/<id>.json and manifest.json);
       merge: some shards unfinished or with failed jobs (named)
  130  interrupted (Ctrl-C); finished jobs are kept, a re-run resumes";

/// Critical-speed scans of a bladed impeller rubbing inside a flexible casing.
#[derive(Parser)]
#[command(version, about, after_help = EXIT_STATUS_HELP)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build, import or inspect reduced-order models.
    Model {
        #[command(subcommand)]
        action: ModelAction,
    },
    /// Run one job of a spec and write its time series (Parquet) and summary (JSON).
    Simulate {
        /// Spec (sweep format, JSON).
        spec: PathBuf,
        /// Index of the job in the spec's plan.
        #[arg(long, default_value_t = 0)]
        job: usize,
        /// Output directory (default results/<name>/simulate-<job>).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Expand a sweep into jobs and print them with the work estimate.
    Plan {
        /// Sweep spec (JSON).
        spec: PathBuf,
    },
    /// Run or resume a sweep: one simulation per job on a thread pool, one Parquet table.
    Run {
        /// Sweep spec (JSON).
        spec: PathBuf,
        /// Worker threads, at most 1024 (0 = all cores; default: SLURM_CPUS_PER_TASK in a
        /// Slurm job, else all cores).
        #[arg(long, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(0..=1024))]
        threads: Option<usize>,
        /// Run only shard i of n (jobs with index ≡ i mod n), e.g. 0/4. Default in a Slurm
        /// array task: shard (SLURM_ARRAY_TASK_ID − SLURM_ARRAY_TASK_MIN) / SLURM_ARRAY_TASK_STEP
        /// of SLURM_ARRAY_TASK_COUNT, written to <output>/shards/<i>-of-<n>.
        #[arg(long)]
        shard: Option<String>,
        /// Output directory (default results/<name>).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Re-run jobs recorded as failed.
        #[arg(long)]
        retry_failed: bool,
        /// Also write each job's time series (probes at every sample step) to
        /// <output>/timeseries/<job id>.parquet.
        #[arg(long)]
        timeseries: bool,
    },
    /// Merge shard outputs into one table.
    Merge {
        /// Shard output directories.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Output directory.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Done, failed and remaining jobs of a sweep output directory (per shard), with an ETA.
    Status {
        /// Sweep output directory (of `run`, or the parent of Slurm shard directories).
        output: PathBuf,
    },
    /// Write (and optionally submit) a Slurm job array running the sweep's shards, plus a
    /// merge job after it.
    Slurm {
        /// Sweep spec (JSON).
        spec: PathBuf,
        /// Array tasks, one shard each.
        #[arg(long)]
        tasks: usize,
        /// CPUs (worker threads) per task.
        #[arg(long, default_value_t = 1)]
        cpus_per_task: usize,
        /// Time limit of each task, e.g. 02:00:00.
        #[arg(long)]
        time: Option<String>,
        /// Slurm partition.
        #[arg(long)]
        partition: Option<String>,
        /// Output directory (default results/<name>); the scripts go to <output>.slurm/.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Submit with sbatch and print the job ids (default: print the sbatch commands).
        #[arg(long)]
        submit: bool,
    },
    /// The paper's figures (time histories, wear, strain energy per nodal diameter, Campbell
    /// diagram, interaction map) and an index.html from a results directory.
    Report {
        /// Output directory of `rubscan run` or `rubscan merge`.
        results: PathBuf,
        /// Output directory (default <results>/report).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Job index to overlay in the per-job figures (repeatable; default: chosen from the
        /// grid, see the page).
        #[arg(long = "job")]
        jobs: Vec<usize>,
        /// At most this many jobs chosen when none is named.
        #[arg(long, default_value_t = app::DEFAULT_REPORT_JOBS)]
        max_jobs: usize,
    },
    /// Critical speeds of the linear interaction criterion and the Campbell diagram.
    Campbell {
        /// Sweep spec (JSON) naming the models.
        spec: PathBuf,
        /// Diagram file (.png or .svg).
        #[arg(short, long, default_value = "results/campbell.png")]
        output: PathBuf,
    },
    /// Linear stability of a persistent rub per speed (growth rate of every coupled wave, the
    /// predicted onset), beside the casing's critical wave speed and the criterion's Ω*.
    Stability {
        /// Sweep spec (JSON) naming the models; its friction grid gives μ.
        spec: PathBuf,
        /// Diagram file (.png or .svg).
        #[arg(short, long, default_value = "results/stability.png")]
        output: PathBuf,
        /// Lowest speed (rad/s); default 0.8 × the grid's lowest.
        #[arg(long)]
        from: Option<f64>,
        /// Highest speed (rad/s); default 1.2 × the grid's highest, at most the highest speed
        /// of the impeller's modal grid.
        #[arg(long)]
        to: Option<f64>,
        /// Speeds of the scan.
        #[arg(long, default_value_t = 200)]
        count: usize,
    },
}

#[derive(Subcommand)]
enum ModelAction {
    /// Build the impeller and casing ROMs of a model spec (JSON; omit for the built-in defaults).
    Build {
        /// Model spec (JSON). Without it, the built-in default models are built.
        spec: Option<PathBuf>,
        /// Output directory for `impeller.rom` and `casing.rom`.
        #[arg(short, long, default_value = "results/models")]
        output: PathBuf,
    },
    /// Import an FE model and reduce it: one component from CalculiX matrix storage or Matrix
    /// Market, or a cyclic sector from a CalculiX deck (`calculix-cyclic`).
    Import {
        /// Source format.
        format: Format,
        /// Import spec (JSON); relative paths are relative to it.
        spec: PathBuf,
        /// Output ROM file.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Write the built-in impeller and casing sectors of a model spec as solver input decks
    /// (CalculiX: C3D20 mesh, clamps, cyclic symmetry, a frequency step per nodal diameter).
    Export {
        /// Target format.
        format: ExportTarget,
        /// Model spec (JSON). Without it, the built-in default models are exported.
        spec: Option<PathBuf>,
        /// Also write the impeller's prestressed frequency deck at this speed (rad/s;
        /// repeatable): `impeller_prestressed_<speed>.inp`.
        #[arg(long = "omega", value_name = "RAD_S")]
        omegas: Vec<f64>,
        /// Output directory for the decks.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Print sizes, frequencies per nodal diameter and Ω dependence of a ROM file; with
    /// `--mistuning`, the mistuned wheel's modes.
    Info {
        /// ROM file.
        file: PathBuf,
        /// Structural mistuning: one δ per blade, comma-separated (blade s's Young's modulus
        /// is E (1 + δ_s)); needs a ROM built with `impeller.blade_modes` > 0.
        #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
        mistuning: Option<Vec<f64>>,
        /// Rotation speed (rad/s) of the mistuned modes.
        #[arg(long, default_value_t = 0.0, requires = "mistuning")]
        omega: f64,
    },
}

#[derive(Clone, Copy, ValueEnum)]
enum ExportTarget {
    Calculix,
}

#[derive(Clone, Copy, ValueEnum)]
enum Format {
    Calculix,
    MatrixMarket,
    CalculixCyclic,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // Help and version go to stdout with status 0; usage errors are invalid input.
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(app::EXIT_INVALID)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    match dispatch(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

fn dispatch(command: Command) -> Result<(), AppError> {
    match command {
        Command::Model {
            action: ModelAction::Build { spec, output },
        } => Ok(app::model_build(spec.as_deref(), &output)?),
        Command::Model {
            action:
                ModelAction::Import {
                    format,
                    spec,
                    output,
                },
        } => {
            let format = match format {
                Format::Calculix => ImportFormat::Calculix,
                Format::MatrixMarket => ImportFormat::MatrixMarket,
                Format::CalculixCyclic => ImportFormat::CalculixCyclic,
            };
            Ok(app::model_import(format, &spec, &output)?)
        }
        Command::Model {
            action:
                ModelAction::Export {
                    format: ExportTarget::Calculix,
                    spec,
                    omegas,
                    output,
                },
        } => {
            let files =
                app::model_export(ExportFormat::Calculix, spec.as_deref(), &omegas, &output)?;
            for f in files {
                eprintln!("wrote {}", f.display());
            }
            Ok(())
        }
        Command::Model {
            action:
                ModelAction::Info {
                    file,
                    mistuning,
                    omega,
                },
        } => Ok(
            app::model_info(&file, mistuning.as_deref().map(|d| (d, omega)))
                .map(|text| print!("{text}"))?,
        ),
        Command::Simulate { spec, job, output } => app::simulate(
            &load_spec(&spec)?,
            job,
            output.as_deref(),
            &app::cancel_on_ctrl_c(),
        )
        .map(drop),
        Command::Plan { spec } => app::plan_text(&load_spec(&spec)?).map(|text| print!("{text}")),
        Command::Run {
            spec,
            threads,
            shard,
            output,
            retry_failed,
            timeseries,
        } => app::run(
            &load_spec(&spec)?,
            &RunArgs {
                threads,
                shard,
                output,
                retry_failed,
                timeseries,
                progress_bar: std::io::stderr().is_terminal(),
                cancel: app::cancel_on_ctrl_c(),
                counters: Default::default(),
            },
        )
        .and_then(|summary| app::check_run(&summary)),
        Command::Merge { shards, output } => app::merge_shards(&shards, &output).map(drop),
        Command::Status { output } => Ok(app::status(&output).map(|text| print!("{text}"))?),
        Command::Slurm {
            spec,
            tasks,
            cpus_per_task,
            time,
            partition,
            output,
            submit,
        } => app::slurm(
            &spec,
            &SlurmArgs {
                tasks,
                cpus_per_task,
                time,
                partition,
                output,
                submit,
            },
        )
        .map(|text| print!("{text}")),
        Command::Report {
            results,
            output,
            jobs,
            max_jobs,
        } => app::report(
            &results,
            &ReportOptions {
                output_dir: output,
                jobs,
                max_jobs,
            },
        )
        .map(|text| print!("{text}")),
        Command::Campbell { spec, output } => {
            app::campbell(&load_spec(&spec)?, &output).map(|text| print!("{text}"))
        }
        Command::Stability {
            spec,
            output,
            from,
            to,
            count,
        } => app::stability(
            &load_spec(&spec)?,
            &app::StabilityArgs {
                output,
                range: app::StabilityRange { from, to, count },
            },
        )
        .map(|text| print!("{text}")),
    }
}
