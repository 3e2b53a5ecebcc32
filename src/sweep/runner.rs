//! Runner: executes the jobs of a plan on a rayon pool with checkpoint/resume,
//! sharding and cancellation, then writes `results.parquet` and `manifest.json`.
//!
//! Output directory layout:
//! ```text
//! <out>/jobs/<id>.json     one record per finished job (ok or failed), written atomically
//! <out>/results.parquet    one row per finished job, sorted by job index
//! <out>/manifest.json      resolved spec, version, counts, timings
//! ```

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, anyhow, bail};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::checkpoint::{JobRecord, Outcomes, read_record, write_json_atomic, write_record};
use super::planner::{JOB_IDENTITY, Job, Plan};
use super::rounds::refined_plan;
use super::slurm::shard_dirs;
use super::spec::SweepSpec;
use super::table::write_results;
use super::{JobSimulator, JobSteps, checkpoint};
use crate::io::content_hash::canonical_json;

/// Options of [`run_sweep`].
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Worker threads (0 = rayon's default, one per core).
    pub threads: usize,
    /// Run only jobs whose index ≡ i (mod n): `Some((i, n))`, 0 ≤ i < n.
    pub shard: Option<(usize, usize)>,
    /// Output directory (created if needed).
    pub output_dir: PathBuf,
    /// Draw an indicatif progress bar (true) or print plain log lines on stderr (false).
    pub progress: bool,
    /// Re-run jobs whose record says failed (default: failed jobs count as finished).
    pub retry_failed: bool,
    /// Set to stop cleanly: no new job starts, jobs in flight are not recorded unless they
    /// complete, results and manifest are written for what is finished.
    pub cancel: Arc<AtomicBool>,
    /// Jobs and steps done so far, readable while the run goes on.
    pub counters: Arc<RunCounters>,
}

/// What a run has done so far, updated while it runs, for a progress display outside the
/// runner (a notebook's bar reads it from another thread).
#[derive(Debug, Default)]
pub struct RunCounters {
    /// Time steps done by the jobs this run runs, counted while they run (capped at each job's
    /// planned steps, topped up when a job finishes ok or failed): after a run that was not
    /// cancelled it holds the planned steps of every job it ran. The progress bar shows it.
    pub steps_done: AtomicU64,
    /// Jobs queued to run so far (each refinement round adds its new jobs).
    pub jobs_queued: AtomicUsize,
    /// Jobs of those finished and recorded.
    pub jobs_finished: AtomicUsize,
}

impl RunOptions {
    /// Options with defaults: all cores, no shard, log lines, no retry, fresh cancel flag.
    pub fn new(output_dir: impl Into<PathBuf>) -> Self {
        RunOptions {
            threads: 0,
            shard: None,
            output_dir: output_dir.into(),
            progress: false,
            retry_failed: false,
            cancel: Arc::new(AtomicBool::new(false)),
            counters: Arc::default(),
        }
    }
}

/// What a run did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    /// Jobs in the whole plan.
    pub planned: usize,
    /// Jobs in this shard (= planned without sharding).
    pub in_shard: usize,
    /// Jobs skipped because a record already existed (resume).
    pub skipped: usize,
    /// Jobs run (and recorded) by this invocation.
    pub ran: usize,
    /// Finished jobs of the shard with status ok (including skipped ones).
    pub ok: usize,
    /// Finished jobs of the shard with status unstable: a runaway found, a success
    /// (including skipped ones).
    #[serde(default)]
    pub unstable: usize,
    /// Finished jobs of the shard with status failed (including skipped ones).
    pub failed: usize,
    /// Jobs of the shard left unfinished (cancellation).
    pub unfinished: usize,
    /// True when the cancel flag stopped the run.
    pub cancelled: bool,
    /// Wall-clock time of the run (s).
    pub wall_time_s: f64,
    /// Sum of the recorded wall times of the shard's finished jobs (s): the serial work.
    pub job_time_s_total: f64,
    /// Path of the results table.
    pub results_path: PathBuf,
}

/// What [`merge`] did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MergeSummary {
    /// Jobs in the plan.
    pub planned: usize,
    /// Jobs found in some shard directory.
    pub found: usize,
    /// Ids of planned jobs found nowhere.
    pub missing: Vec<String>,
    /// Finished jobs that failed.
    pub failed: usize,
    /// One line per shard directory that is not complete and ok: not started (no
    /// manifest), unfinished (jobs of its shard without a record) or with failed jobs.
    pub shard_problems: Vec<String>,
    /// Path of the merged results table.
    pub results_path: PathBuf,
}

/// `manifest.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Manifest {
    /// rubscan version that wrote the output.
    pub rubscan_version: String,
    /// [`JOB_IDENTITY`] of the job ids in `jobs/` (1 when absent: written before it was
    /// recorded).
    #[serde(default = "first_job_identity")]
    pub job_identity: u32,
    /// Sweep name.
    pub sweep: String,
    /// The spec (ROM paths resolved).
    pub spec: SweepSpec,
    /// Shard (i, n) when sharded.
    pub shard: Option<(usize, usize)>,
    /// Directories merged into this one (merge only).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub merged_from: Vec<PathBuf>,
    /// Worker threads used (0 = default).
    pub threads: usize,
    /// Steps per job (duration / time step) when known.
    pub steps_per_job: Option<u64>,
    /// Work estimate of the whole plan: jobs × steps per job.
    pub total_steps: Option<u64>,
    /// Counts.
    pub summary: RunSummary,
    /// Start time (s since the Unix epoch).
    pub started_unix_s: f64,
    /// True when every job of the shard (or plan, for merges) is finished (ok, unstable or
    /// failed).
    pub complete: bool,
    /// Finished jobs that failed (= `summary.failed`); their reasons are in `jobs/<id>.json`
    /// and the `reason` column of the results table.
    #[serde(default)]
    pub failed: usize,
    /// True when the scan worked: complete and no job failed (`unstable` jobs are findings,
    /// not failures).
    #[serde(default)]
    pub all_ok: bool,
}

/// The progress line's word for an unstable job: when the runaway was confirmed, its growth
/// rate and its wave.
fn unstable_note(rec: &JobRecord) -> String {
    let Some(r) = rec.result.as_ref().and_then(|x| x.runaway) else {
        return "UNSTABLE".into();
    };
    let wave = match (r.nodal_diameter, r.frequency_hz) {
        (Some(k), Some(f)) => format!(", nodal diameter {k} at {f:.0} Hz"),
        (Some(k), None) => format!(", nodal diameter {k}"),
        _ => String::new(),
    };
    let breakdown = if r.at_solve_breakdown {
        " (where it outran the contact solve)"
    } else {
        ""
    };
    format!(
        "UNSTABLE: runaway from {:.2} ms, σ = {:.0} 1/s (R² {:.2}){wave}, stopped at {:.2} ms{breakdown}",
        r.onset_time_s * 1e3,
        r.growth_rate_per_s,
        r.growth_fit_r2,
        r.detected_time_s * 1e3
    )
}

fn now_unix_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".into()
    }
}

/// Runs one job, converting panics and non-finite results into failures; the job reports its
/// steps through `steps`, all of which count as done once it is recorded.
/// `None` = cancelled while running (not to be recorded).
fn execute(
    job: &Job,
    sim: &dyn JobSimulator,
    cancel: &AtomicBool,
    steps: &mut JobSteps<'_>,
) -> Option<JobRecord> {
    let t0 = Instant::now();
    let run = std::panic::AssertUnwindSafe(|| sim.run_reporting(job, cancel, &mut *steps));
    let outcome = std::panic::catch_unwind(run)
        .unwrap_or_else(|p| Err(format!("simulator panicked: {}", panic_message(p.as_ref()))));
    let wall = t0.elapsed().as_secs_f64();
    if !(outcome.is_err() && cancel.load(Ordering::SeqCst)) {
        steps.finish();
    }
    match outcome {
        Err(_) if cancel.load(Ordering::SeqCst) => None,
        Err(reason) => Some(JobRecord::new(job, Err(reason), wall)),
        Ok(r) => {
            let outcome = r.check_finite().map(|()| r);
            Some(JobRecord::new(job, outcome, wall))
        }
    }
}

/// Reporter: indicatif bar or plain stderr lines. The bar counts time steps when the plan
/// knows the steps per job (it then advances within a job, and its ETA comes from the steps
/// done), else jobs.
struct Reporter {
    bar: Option<indicatif::ProgressBar>,
    /// Steps per job when the bar counts steps.
    steps_per_job: Option<u64>,
    total: usize,
    done: AtomicUsize,
}

impl Reporter {
    fn new(total: usize, progress: bool, steps_per_job: Option<u64>) -> Self {
        let steps_per_job = steps_per_job.filter(|&n| n > 0);
        let bar = progress.then(|| {
            let (len, template) = match steps_per_job {
                Some(n) => (
                    n.saturating_mul(total as u64),
                    "{elapsed_precise} [{wide_bar}] {percent}% of {human_len} steps, ETA {eta} · \
                     {prefix} jobs {msg}",
                ),
                None => (
                    total as u64,
                    "{elapsed_precise} [{wide_bar}] {pos}/{len} jobs, ETA {eta} {msg}",
                ),
            };
            let pb = indicatif::ProgressBar::new(len);
            if let Ok(style) = indicatif::ProgressStyle::with_template(template) {
                pb.set_style(style);
            }
            pb.set_prefix(format!("0/{total}"));
            pb
        });
        Reporter {
            bar,
            steps_per_job,
            total,
            done: AtomicUsize::new(0),
        }
    }

    /// The step counter of one job (steps per job 0 when the plan does not know them).
    fn job_steps<'a>(&'a self, counter: &'a AtomicU64) -> JobSteps<'a> {
        let bar = self.bar.as_ref().filter(|_| self.steps_per_job.is_some());
        JobSteps::new(self.steps_per_job.unwrap_or(0), Some(counter), bar)
    }

    fn log(&self, line: &str) {
        match &self.bar {
            Some(b) => b.println(line),
            None => eprintln!("{line}"),
        }
    }

    fn finished(&self, job: &Job, rec: &JobRecord) {
        let n = self.done.fetch_add(1, Ordering::SeqCst) + 1;
        let status = match &rec.status {
            checkpoint::JobStatus::Ok => "ok".to_string(),
            checkpoint::JobStatus::Unstable => unstable_note(rec),
            checkpoint::JobStatus::Failed { reason } => format!("FAILED: {reason}"),
        };
        let msg = format!(
            "job {} ({}) Ω = {:.4} rad/s μ = {} {status} in {:.2} s",
            job.index, job.id, job.params.speed_rad_s, job.params.friction, rec.wall_time_s
        );
        match &self.bar {
            Some(b) => {
                if rec.status != checkpoint::JobStatus::Ok {
                    b.println(format!("[sweep] {msg}"));
                }
                b.set_message(msg);
                if self.steps_per_job.is_some() {
                    b.set_prefix(format!("{n}/{}", self.total));
                } else {
                    b.inc(1);
                }
            }
            None => eprintln!("[sweep] {n}/{} {msg}", self.total),
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// Parses a `--shard i/n` argument (0 ≤ i < n).
pub fn parse_shard(text: &str) -> Result<(usize, usize)> {
    let (i, n) = text
        .split_once('/')
        .ok_or_else(|| anyhow!("shard {text:?}: expected i/n, e.g. 0/4"))?;
    let i: usize = i
        .trim()
        .parse()
        .with_context(|| format!("shard {text:?}: bad index"))?;
    let n: usize = n
        .trim()
        .parse()
        .with_context(|| format!("shard {text:?}: bad count"))?;
    validate_shard(Some((i, n)))?;
    Ok((i, n))
}

/// Default output directory of a sweep: `results/<name>` under `root`.
pub fn default_output_dir(root: &Path, spec: &SweepSpec) -> PathBuf {
    root.join("results").join(&spec.name)
}

fn validate_shard(shard: Option<(usize, usize)>) -> Result<()> {
    if let Some((i, n)) = shard
        && (n == 0 || i >= n)
    {
        bail!("invalid shard {i}/{n}: need 0 ≤ i < n");
    }
    Ok(())
}

/// Loads the records of `jobs` found in output directory `dir` as `(job index, record)`,
/// in job order; jobs without a (valid) record are left out. The parameters are taken
/// from the plan (bit-exact), not from the record's JSON.
///
/// A record file that exists but cannot be read (truncated, malformed, another format or
/// job) counts as not finished, like a missing one, and is named in a warning on stderr, so
/// that `rubscan status` and `merge` do not count it as remaining without saying why.
pub fn load_records<'a>(
    dir: &Path,
    jobs: impl Iterator<Item = &'a Job>,
) -> Vec<(usize, JobRecord)> {
    let (records, unreadable) = read_records(dir, jobs);
    for reason in unreadable {
        eprintln!("warning: {reason}; the job counts as not finished");
    }
    records
}

/// [`load_records`] without the warnings: the records, and the reasons of the record files
/// that exist but cannot be read (for callers that report them their own way).
fn read_records<'a>(
    dir: &Path,
    jobs: impl Iterator<Item = &'a Job>,
) -> (Vec<(usize, JobRecord)>, Vec<String>) {
    let mut records = Vec::new();
    let mut unreadable = Vec::new();
    for j in jobs {
        match read_record(dir, &j.id) {
            Ok(Some(mut r)) => {
                r.params = j.params;
                records.push((j.index, r));
            }
            Ok(None) => {}
            Err(reason) => unreadable.push(reason),
        }
    }
    (records, unreadable)
}

fn first_job_identity() -> u32 {
    1
}

/// Refuses a directory whose job ids stand for something else than today's
/// ([`JOB_IDENTITY`]): its records cannot be matched to a plan, and its spec was read with
/// today's defaults, not the ones it ran with.
pub(super) fn check_job_identity(dir: &Path, m: &Manifest) -> Result<()> {
    if m.job_identity == JOB_IDENTITY {
        return Ok(());
    }
    let why = match m.job_identity {
        1 => {
            "an older rubscan, when the paper's mass-carrying boundary was the default and the \
             formulation was not part of a job's identity"
        }
        2 => {
            "an older rubscan, whose maxima were taken on the sample steps only and so \
             depended on numerics.decimation, and whose impeller K(Ω) was the stress \
             stiffening alone (\"prestress\": \"stress_stiffening\" in the model spec)"
        }
        3 => {
            "an older rubscan, whose massless boundary gave the inertial modes the coating \
             force of the end of the step alone (an error of first order in the time step)"
        }
        _ => "a newer rubscan",
    };
    bail!(
        "{} holds results of sweep \"{}\" written by rubscan {} under job identity {} (by {why}); \
         this rubscan's is {JOB_IDENTITY}, so its jobs cannot be resumed or merged: keep it as \
         it is and give another -o, or move it away to run the sweep again (add \"boundary\": \
         \"mass\" to the spec's numerics for the paper's formulation)",
        dir.display(),
        m.sweep,
        m.rubscan_version,
        m.job_identity
    )
}

/// How a manifest names the part of the plan its directory holds.
fn shard_label(shard: Option<(usize, usize)>) -> String {
    shard.map_or("the unsharded run".into(), |(i, n)| {
        format!("shard {i}/{n}")
    })
}

/// Refuses to run `spec` (shard `shard`) into `out` when that would replace finished results
/// of another run: `out/manifest.json` names another sweep, or records another shard split or
/// shard index (results.parquet and manifest.json are rewritten for the requested shard only,
/// so the recorded shard's rows would vanish from them). Also refuses a manifest that exists
/// but cannot be read, since what it holds cannot be checked. Nothing is written.
///
/// "Another sweep" means another sweep name. A spec changed under the same name (grid
/// extended, scenario edited) is the same sweep evolving and still resumes into its directory,
/// as the planner intends: its jobs keep their ids when they did not change, so finished
/// ones are skipped, and the records of the jobs it no longer plans stay in `jobs/`.
/// Without a manifest (a new or a seeded directory) there is nothing to check.
pub fn check_output_dir(out: &Path, spec: &SweepSpec, shard: Option<(usize, usize)>) -> Result<()> {
    let recorded = read_manifest_if_any(out).with_context(|| {
        format!(
            "{} cannot be checked before running into it (move its manifest.json away to reuse \
             the directory)",
            out.display()
        )
    })?;
    let Some(m) = recorded else {
        return Ok(());
    };
    check_job_identity(out, &m)?;
    if m.sweep != spec.name {
        bail!(
            "{} holds another sweep's results, those of sweep \"{}\" (its manifest.json), not of \
             \"{}\": running there would replace its results.parquet and manifest.json; give \
             another -o",
            out.display(),
            m.sweep,
            spec.name
        );
    }
    if m.shard != shard {
        let (recorded, requested) = (shard_label(m.shard), shard_label(shard));
        bail!(
            "{} holds {recorded} of sweep \"{}\" (its manifest.json), not {requested} as \
             requested: running there would replace its results.parquet and manifest.json with \
             those of {requested} only; give {requested} its own -o",
            out.display(),
            m.sweep
        );
    }
    Ok(())
}

/// Runs (or resumes) a sweep. Validates the spec and the options before touching the
/// file system, so a bad spec writes nothing.
///
/// Jobs already recorded in `<out>/jobs/` are skipped (failed ones too, unless
/// `retry_failed`); a failing job is recorded with its reason and the sweep goes on.
/// The results table and manifest cover the jobs of this shard finished so far.
/// An output directory holding another sweep's or another shard's results is refused before
/// anything is written ([`check_output_dir`]).
pub fn run_sweep(
    spec: &SweepSpec,
    opts: &RunOptions,
    sim: &dyn JobSimulator,
) -> Result<RunSummary> {
    let started_unix_s = now_unix_s();
    let t0 = Instant::now();
    validate_shard(opts.shard)?;
    let out = &opts.output_dir;
    let dirs = record_dirs(out, opts.shard);
    let finished = |job: &Job| {
        dirs.iter()
            .find_map(|d| read_record(d, &job.id).ok().flatten())
    };
    let mut plan = refined_plan(spec, &finished).map_err(|e| anyhow!(e))?;
    check_output_dir(out, spec, opts.shard)?;
    std::fs::create_dir_all(checkpoint::jobs_dir(out))
        .with_context(|| format!("cannot create output directory {}", out.display()))?;

    let mut ran = 0;
    loop {
        ran += run_round(spec, &plan, opts, sim, started_unix_s, t0)?;
        if opts.cancel.load(Ordering::SeqCst) {
            break;
        }
        // The next refinement round, once every job of this one is finished (in this shard's
        // sibling directories too).
        let next = refined_plan(spec, &finished).map_err(|e| anyhow!(e))?;
        if next.jobs.len() == plan.jobs.len() {
            break;
        }
        let round = next.refinement_rounds.last().copied().unwrap_or(0);
        eprintln!(
            "[sweep] refinement round {round}: {} new speeds",
            next.jobs.len() - plan.jobs.len()
        );
        plan = next;
    }
    let shard_jobs = shard_jobs(&plan, opts.shard);
    let (records, _) = read_records(out, shard_jobs.iter().copied());
    let cancelled = opts.cancel.load(Ordering::SeqCst);
    let skipped = records.len().saturating_sub(ran);
    let summary = summarise(
        &plan,
        &shard_jobs,
        &records,
        skipped,
        ran,
        cancelled,
        t0,
        out,
    );
    write_results(&summary.results_path, &records)?;
    ManifestContext {
        spec,
        plan: &plan,
        opts,
        started_unix_s,
    }
    .write(out, &summary)?;
    Ok(summary)
}

/// The jobs of `plan` in `shard` (all of them without sharding).
fn shard_jobs(plan: &Plan, shard: Option<(usize, usize)>) -> Vec<&Job> {
    plan.jobs
        .iter()
        .filter(|j| shard.is_none_or(|(i, n)| j.index % n == i))
        .collect()
}

/// Where the records of a run's jobs may be: its own directory and, for a shard in the
/// layout of [`shard_dir`](super::slurm::shard_dir), its sibling shards' and the merged
/// sweep's (a refinement round needs every job of the round before it, whichever shard
/// ran it).
fn record_dirs(out: &Path, shard: Option<(usize, usize)>) -> Vec<PathBuf> {
    let mut dirs = vec![out.to_path_buf()];
    let sweep_dir = out
        .parent()
        .filter(|p| p.file_name().is_some_and(|n| n == "shards"))
        .and_then(Path::parent);
    if let (Some((_, n)), Some(sweep_dir)) = (shard, sweep_dir) {
        dirs.extend(shard_dirs(sweep_dir, n).into_iter().filter(|d| d != out));
        dirs.push(sweep_dir.to_path_buf());
    }
    dirs
}

/// Runs the unfinished jobs of `plan` in the run's shard (failed ones too with
/// `retry_failed`); returns how many ran. The manifest says incomplete while they run.
fn run_round(
    spec: &SweepSpec,
    plan: &Plan,
    opts: &RunOptions,
    sim: &dyn JobSimulator,
    started_unix_s: f64,
    t0: Instant,
) -> Result<usize> {
    let out = &opts.output_dir;
    let shard_jobs = shard_jobs(plan, opts.shard);
    let mut pending = Vec::new();
    let mut skipped = 0;
    for &job in &shard_jobs {
        match read_record(out, &job.id) {
            Ok(Some(rec)) if rec.succeeded() || !opts.retry_failed => skipped += 1,
            Ok(_) => pending.push(job),
            Err(reason) => {
                eprintln!(
                    "[sweep] warning: {reason}; job {} will run again",
                    job.index
                );
                pending.push(job);
            }
        }
    }
    if pending.is_empty() {
        return Ok(0);
    }

    // A manifest from the start, so that `rubscan status` and `merge` know the spec and
    // shard of a run still going (or killed); it says incomplete until the end.
    let ctx = ManifestContext {
        spec,
        plan,
        opts,
        started_unix_s,
    };
    // Unreadable records were named in the warnings above.
    let (records, _) = read_records(out, shard_jobs.iter().copied());
    let mut early = summarise(plan, &shard_jobs, &records, skipped, 0, false, t0, out);
    // Failed jobs about to be retried are not finished yet.
    early.unfinished = early.unfinished.max(pending.len());
    ctx.write(out, &early)?;

    let reporter = Reporter::new(pending.len(), opts.progress, plan.steps_per_job);
    (opts.counters.jobs_queued).fetch_add(pending.len(), Ordering::SeqCst);
    if skipped > 0 {
        reporter.log(&format!(
            "[sweep] resuming: {skipped} of {} jobs already finished",
            shard_jobs.len()
        ));
    }
    let ran = AtomicUsize::new(0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()
        .context("cannot build the worker thread pool")?;
    // faer parallelism inside a job would oversubscribe the job-level pool (crates.md pitfall 2).
    faer::set_global_parallelism(faer::Par::Seq);
    let write_error: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    let cancel = &*opts.cancel;
    pool.install(|| {
        // One job per work item: rayon's default leaves of several jobs would leave the last
        // leaf's jobs to one thread while the others idle (a tenth of the headline scan's wall).
        pending.par_iter().with_max_len(1).for_each(|&job| {
            if cancel.load(Ordering::SeqCst) {
                return;
            }
            let mut steps = reporter.job_steps(&opts.counters.steps_done);
            let Some(mut rec) = execute(job, sim, cancel, &mut steps) else {
                return;
            };
            rec.refinement_round = plan.refinement_round(job.index);
            if let Err(e) = write_record(out, &rec) {
                // A write failure (disk full…) stops the sweep like a cancellation.
                cancel.store(true, Ordering::SeqCst);
                let mut slot = write_error.lock().unwrap_or_else(|p| p.into_inner());
                slot.get_or_insert(
                    anyhow!(e).context(format!("cannot write record of job {}", job.id)),
                );
                return;
            }
            ran.fetch_add(1, Ordering::SeqCst);
            opts.counters.jobs_finished.fetch_add(1, Ordering::SeqCst);
            reporter.finished(job, &rec);
        });
    });
    reporter.finish();
    if let Some(e) = write_error.into_inner().unwrap_or_else(|p| p.into_inner()) {
        return Err(e);
    }

    Ok(ran.into_inner())
}

/// The summary of a shard's run from the records of its finished jobs.
#[allow(clippy::too_many_arguments)]
fn summarise(
    plan: &Plan,
    shard_jobs: &[&Job],
    records: &[(usize, JobRecord)],
    skipped: usize,
    ran: usize,
    cancelled: bool,
    t0: Instant,
    out: &Path,
) -> RunSummary {
    let outcomes = Outcomes::of(records.iter().map(|(_, r)| r));
    RunSummary {
        planned: plan.jobs.len(),
        in_shard: shard_jobs.len(),
        skipped,
        ran,
        ok: outcomes.ok,
        unstable: outcomes.unstable,
        failed: outcomes.failed,
        unfinished: shard_jobs.len() - records.len(),
        cancelled,
        wall_time_s: t0.elapsed().as_secs_f64(),
        job_time_s_total: records.iter().map(|(_, r)| r.wall_time_s).sum(),
        results_path: out.join("results.parquet"),
    }
}

/// What the manifest of a run says besides its summary.
struct ManifestContext<'a> {
    spec: &'a SweepSpec,
    plan: &'a Plan,
    opts: &'a RunOptions,
    started_unix_s: f64,
}

impl ManifestContext<'_> {
    /// Writes `<out>/manifest.json` for `summary` (atomically).
    fn write(&self, out: &Path, summary: &RunSummary) -> Result<()> {
        let complete = summary.unfinished == 0;
        let manifest = Manifest {
            rubscan_version: env!("CARGO_PKG_VERSION").into(),
            job_identity: JOB_IDENTITY,
            sweep: self.spec.name.clone(),
            spec: self.spec.clone(),
            shard: self.opts.shard,
            merged_from: Vec::new(),
            threads: self.opts.threads,
            steps_per_job: self.plan.steps_per_job,
            total_steps: self.plan.total_steps,
            complete,
            failed: summary.failed,
            all_ok: complete && summary.failed == 0,
            summary: summary.clone(),
            started_unix_s: self.started_unix_s,
        };
        write_json_atomic(&out.join("manifest.json"), &manifest)
            .context("cannot write manifest.json")
    }
}

/// Reads `<dir>/manifest.json`.
pub fn read_manifest(dir: &Path) -> Result<Manifest> {
    let path = dir.join("manifest.json");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("malformed {}", path.display()))
}

/// Reads `<dir>/manifest.json` when there is one: `Ok(None)` when the file does not exist (a
/// run not started), an error naming the file when it exists but cannot be read or parsed.
pub fn read_manifest_if_any(dir: &Path) -> Result<Option<Manifest>> {
    match std::fs::metadata(dir.join("manifest.json")) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        _ => read_manifest(dir).map(Some),
    }
}

/// Merges the outputs of shard runs (each a [`run_sweep`] output directory of the same
/// spec) into `out_dir`: job records are copied, and `results.parquet` / `manifest.json`
/// are written for the whole plan, identical to what a single unsharded run writes.
/// Planned jobs found in no shard, failed jobs and the shard directories at fault (not
/// started, unfinished, with failed jobs) are listed in the summary and the manifest is
/// marked incomplete; they do not make this function fail (`rubscan merge` then exits 2).
///
/// Refused before anything is written: a shard directory whose manifest.json exists but
/// cannot be read, shards of different specs, the same directory or shard given twice,
/// shards of different splits, and an output directory holding another sweep's or a shard's
/// results ([`check_output_dir`]).
pub fn merge(shard_dirs: &[PathBuf], out_dir: &Path) -> Result<MergeSummary> {
    let started_unix_s = now_unix_s();
    let t0 = Instant::now();
    if shard_dirs.is_empty() {
        bail!("merge: no shard directory given")
    }
    // A shard that never started has no manifest: the others still name the spec. A manifest
    // that is there but unreadable could be another spec's: refused, not skipped.
    let manifests = shard_dirs
        .iter()
        .map(|d| read_manifest_if_any(d).with_context(|| format!("merge: {}", d.display())))
        .collect::<Result<Vec<Option<Manifest>>>>()?;
    let Some(manifest) = manifests.iter().flatten().next().cloned() else {
        bail!(
            "merge: none of the {} shard directories has a readable manifest.json (not started?), e.g. {}",
            shard_dirs.len(),
            shard_dirs[0].display()
        );
    };
    for (d, m) in shard_dirs.iter().zip(&manifests) {
        if let Some(m) = m {
            check_job_identity(d, m).context("merge")?;
        }
    }
    let spec_json = canonical_json(&serde_json::to_value(&manifest.spec)?);
    for (d, m) in shard_dirs.iter().zip(&manifests) {
        if let Some(m) = m
            && canonical_json(&serde_json::to_value(&m.spec)?) != spec_json
        {
            bail!(
                "merge: {} was produced by a different spec than the other shards",
                d.display()
            );
        }
    }
    check_shard_set(shard_dirs, &manifests)?;
    // The merged table is an unsharded run's: its own -o must not hold another's results.
    check_output_dir(out_dir, &manifest.spec, None)?;
    let finished =
        |job: &Job| (shard_dirs.iter()).find_map(|d| read_record(d, &job.id).ok().flatten());
    let plan = refined_plan(&manifest.spec, &finished).map_err(|e| anyhow!(e))?;
    std::fs::create_dir_all(checkpoint::jobs_dir(out_dir))
        .with_context(|| format!("cannot create output directory {}", out_dir.display()))?;
    let mut records = Vec::new();
    let mut missing = Vec::new();
    for job in &plan.jobs {
        let found = shard_dirs
            .iter()
            .find_map(|d| read_record(d, &job.id).ok().flatten());
        match found {
            Some(mut rec) => {
                write_record(out_dir, &rec)
                    .with_context(|| format!("cannot write record of job {}", job.id))?;
                rec.params = job.params;
                records.push((job.index, rec));
            }
            None => missing.push(job.id.clone()),
        }
    }
    let results_path = out_dir.join("results.parquet");
    write_results(&results_path, &records)?;
    let outcomes = Outcomes::of(records.iter().map(|(_, r)| r));
    let summary = RunSummary {
        planned: plan.jobs.len(),
        in_shard: plan.jobs.len(),
        skipped: records.len(),
        ran: 0,
        ok: outcomes.ok,
        unstable: outcomes.unstable,
        failed: outcomes.failed,
        unfinished: missing.len(),
        cancelled: false,
        wall_time_s: t0.elapsed().as_secs_f64(),
        job_time_s_total: records.iter().map(|(_, r)| r.wall_time_s).sum(),
        results_path: results_path.clone(),
    };
    let out_manifest = Manifest {
        rubscan_version: env!("CARGO_PKG_VERSION").into(),
        job_identity: JOB_IDENTITY,
        sweep: manifest.sweep.clone(),
        spec: manifest.spec.clone(),
        shard: None,
        merged_from: shard_dirs.to_vec(),
        threads: 0,
        steps_per_job: plan.steps_per_job,
        total_steps: plan.total_steps,
        complete: missing.is_empty(),
        failed: summary.failed,
        all_ok: missing.is_empty() && summary.failed == 0,
        summary,
        started_unix_s,
    };
    write_json_atomic(&out_dir.join("manifest.json"), &out_manifest)
        .context("cannot write manifest.json")?;
    let failed = out_manifest.failed;
    let mut problems = shard_problems(shard_dirs, &manifests, &plan);
    if problems.is_empty() && !missing.is_empty() {
        // Not expected (a shard's own count or an absent shard names them), but `merge`'s
        // error must never list nothing.
        problems.push(format!(
            "{} planned jobs are in none of the given directories",
            missing.len()
        ));
    }
    Ok(MergeSummary {
        planned: plan.jobs.len(),
        found: records.len(),
        missing,
        failed,
        shard_problems: problems,
        results_path,
    })
}

/// True when `a` and `b` name the same directory (through links or `..` when both exist).
fn same_dir(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// Refuses shard directories that do not make up one plan: the same directory given twice,
/// two directories holding the same shard, or shards of different splits (an unsharded run
/// counts as its own split). Shards that no directory holds are not an error here: the merge
/// writes what there is and [`shard_problems`] names them.
fn check_shard_set(dirs: &[PathBuf], manifests: &[Option<Manifest>]) -> Result<()> {
    for (k, d) in dirs.iter().enumerate() {
        if let Some(prev) = dirs[..k].iter().find(|p| same_dir(p, d)) {
            bail!(
                "merge: the same directory is given twice ({} and {}): give each shard once",
                prev.display(),
                d.display()
            );
        }
    }
    let given: Vec<(&PathBuf, Option<(usize, usize)>)> = dirs
        .iter()
        .zip(manifests)
        .filter_map(|(d, m)| m.as_ref().map(|m| (d, m.shard)))
        .collect();
    for (k, &(d, shard)) in given.iter().enumerate() {
        let split = |s: Option<(usize, usize)>| s.map(|(_, n)| n);
        if let Some(&(p, other)) = given[..k].iter().find(|(_, s)| split(*s) != split(shard)) {
            bail!(
                "merge: {} holds {} but {} holds {}: shards of different splits do not make one \
                 table; merge the shards of one split",
                p.display(),
                shard_label(other),
                d.display(),
                shard_label(shard)
            );
        }
        if let Some(&(p, _)) = given[..k].iter().find(|(_, s)| *s == shard) {
            bail!(
                "merge: {} and {} both hold {}: give each shard once",
                p.display(),
                d.display(),
                shard_label(shard)
            );
        }
    }
    Ok(())
}

/// What is wrong with each shard directory of a merge (see [`MergeSummary::shard_problems`]),
/// then the shards of the split that have planned jobs and that no directory holds.
fn shard_problems(dirs: &[PathBuf], manifests: &[Option<Manifest>], plan: &Plan) -> Vec<String> {
    let mut out = Vec::new();
    for (d, m) in dirs.iter().zip(manifests) {
        let Some(m) = m else {
            out.push(format!("{}: not started (no manifest.json)", d.display()));
            continue;
        };
        let label = m
            .shard
            .map_or("unsharded run".into(), |(i, n)| format!("shard {i}/{n}"));
        let jobs = plan
            .jobs
            .iter()
            .filter(|j| m.shard.is_none_or(|(i, n)| j.index % n == i));
        let n_jobs = jobs.clone().count();
        let records = load_records(d, jobs);
        let failed = records.iter().filter(|(_, r)| !r.succeeded()).count();
        let unfinished = n_jobs - records.len();
        if unfinished > 0 {
            out.push(format!(
                "{} ({label}): unfinished, {unfinished} of {n_jobs} jobs have no record",
                d.display()
            ));
        }
        if failed > 0 {
            out.push(format!(
                "{} ({label}): {failed} of {n_jobs} jobs failed (reasons in its jobs/<id>.json)",
                d.display()
            ));
        }
    }
    // A directory without a manifest may be one of the absent shards: then say so.
    let absent = if manifests.iter().any(Option::is_none) {
        "not given or not started"
    } else {
        "not given"
    };
    let given: Vec<(usize, usize)> = manifests.iter().flatten().filter_map(|m| m.shard).collect();
    if let Some(&(_, n)) = given.first() {
        for i in (0..n).filter(|i| !given.contains(&(*i, n))) {
            if plan.jobs.iter().any(|j| j.index % n == i) {
                out.push(format!(
                    "shard {i}/{n} {absent} (no directory holds its manifest.json)"
                ));
            }
        }
    }
    out
}
