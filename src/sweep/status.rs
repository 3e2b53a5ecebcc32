//! `rubscan status`: how far a sweep's output directory is (per shard for Slurm arrays,
//! [`super::slurm::shard_dir`]), and an estimate of the time left.
//!
//! The counts come from the job records (`jobs/<id>.json`) against the plan of the spec in
//! the manifest, so a run still going, or killed, is read as it is on disk.

use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};

use super::checkpoint::read_record;
use super::checkpoint::{JobStatus, Outcomes};
use super::planner::Job;
use super::rounds::refined_plan;
use super::runner::{
    Manifest, check_job_identity, load_records, read_manifest, read_manifest_if_any,
};
use super::slurm::shard_dirs;

/// Progress of one output directory (a shard, or the whole sweep).
#[derive(Debug, Clone, PartialEq)]
pub struct ShardStatus {
    /// Shard `(i, n)`, `None` for an unsharded run.
    pub shard: Option<(usize, usize)>,
    /// Its output directory.
    pub dir: PathBuf,
    /// True when the directory has a manifest (its run started).
    pub started: bool,
    /// Jobs finished ok (bounded response).
    pub ok: usize,
    /// Jobs finished unstable (a runaway found: a success, stopped early).
    pub unstable: usize,
    /// Jobs finished failed.
    pub failed: usize,
    /// Jobs not finished.
    pub remaining: usize,
    /// Worker threads of its run (from its manifest; 0 = all cores).
    pub threads: usize,
    /// Estimated time left (s): the remaining jobs, `threads` at a time, each taking the
    /// mean wall time of the sweep's finished ok jobs (unstable ones stop early);
    /// `None` when no job finished ok.
    pub eta_s: Option<f64>,
}

/// Progress of a sweep's output directory.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepStatus {
    /// Sweep name.
    pub sweep: String,
    /// One entry per shard (shard order), or one for an unsharded run.
    pub shards: Vec<ShardStatus>,
    /// Mean wall time of the finished ok jobs (s).
    pub mean_job_s: Option<f64>,
}

impl SweepStatus {
    /// Time left (s) when the shards run at once (an array's tasks): the longest shard ETA.
    pub fn eta_s(&self) -> Option<f64> {
        self.shards
            .iter()
            .map(|s| s.eta_s)
            .try_fold(0.0_f64, |acc, e| e.map(|e| acc.max(e)))
    }

    /// Jobs (ok, unstable, failed, remaining) over all shards.
    pub fn totals(&self) -> (usize, usize, usize, usize) {
        self.shards.iter().fold((0, 0, 0, 0), |(o, u, f, r), s| {
            (o + s.ok, u + s.unstable, f + s.failed, r + s.remaining)
        })
    }
}

/// Threads a run with `threads` (0 = all cores) uses.
fn effective_threads(threads: usize) -> usize {
    match threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    }
}

/// A directory to count and its shard (`None`: unsharded).
type Unit = (Option<(usize, usize)>, PathBuf);

/// The manifest that names the spec, and the directories to count: the shard directories
/// of `<out>/shards/` when there are any, else `out` itself. A shard whose `manifest.json`
/// exists but cannot be read is named in a warning on stderr, not skipped silently.
fn units(out: &Path) -> Result<(Manifest, Vec<Unit>)> {
    let shards_root = out.join("shards");
    if !shards_root.is_dir() {
        let m = read_manifest(out)?;
        let shard = m.shard;
        return Ok((m, vec![(shard, out.to_path_buf())]));
    }
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(&shards_root)
        .with_context(|| format!("cannot read {}", shards_root.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|d| d.is_dir())
        .collect();
    dirs.sort();
    // The first readable manifest names the spec; an unreadable one makes its shard count
    // as not started, so that the others can still be reported.
    let mut first = None;
    for d in &dirs {
        match read_manifest_if_any(d) {
            Ok(Some(m)) => {
                first.get_or_insert(m);
            }
            Ok(None) => {}
            Err(e) => eprintln!("warning: {e:#}; that shard counts as not started"),
        }
    }
    let Some(m) = first else {
        bail!(
            "{}: no shard has started yet (no readable manifest.json in its directories)",
            shards_root.display()
        )
    };
    let n = m
        .shard
        .map(|s| s.1)
        .ok_or_else(|| anyhow!("{}: a manifest without a shard", shards_root.display()))?;
    let units = shard_dirs(out, n)
        .into_iter()
        .enumerate()
        .map(|(i, d)| (Some((i, n)), d))
        .collect();
    Ok((m, units))
}

/// Progress of the sweep output directory `out` (an unsharded run, or the parent of
/// `shards/<i>-of-<n>`).
pub fn status(out: &Path) -> Result<SweepStatus> {
    let (manifest, units) = units(out)?;
    check_job_identity(out, &manifest)?;
    // A refined sweep's plan grows round by round with the jobs finished in any shard.
    let dirs: Vec<&PathBuf> = units.iter().map(|(_, d)| d).collect();
    let finished = |job: &Job| {
        dirs.iter()
            .find_map(|d| read_record(d, &job.id).ok().flatten())
    };
    let plan = refined_plan(&manifest.spec, &finished).map_err(|e| anyhow!(e))?;
    let mut shards = Vec::new();
    let mut ok_times = Vec::new();
    for (shard, dir) in units {
        let jobs = plan
            .jobs
            .iter()
            .filter(|j| shard.is_none_or(|(i, n)| j.index % n == i));
        let n_jobs = jobs.clone().count();
        let records = load_records(&dir, jobs);
        let outcomes = Outcomes::of(records.iter().map(|(_, r)| r));
        ok_times.extend(
            records
                .iter()
                .filter(|(_, r)| r.status == JobStatus::Ok)
                .map(|(_, r)| r.wall_time_s),
        );
        let own = read_manifest(&dir).ok();
        shards.push(ShardStatus {
            shard,
            started: own.is_some(),
            threads: own.map_or(manifest.threads, |m| m.threads),
            dir,
            ok: outcomes.ok,
            unstable: outcomes.unstable,
            failed: outcomes.failed,
            remaining: n_jobs - records.len(),
            eta_s: None,
        });
    }
    let mean_job_s =
        (!ok_times.is_empty()).then(|| ok_times.iter().sum::<f64>() / ok_times.len() as f64);
    for s in &mut shards {
        let rounds = s.remaining.div_ceil(effective_threads(s.threads));
        s.eta_s = mean_job_s.map(|m| rounds as f64 * m);
    }
    Ok(SweepStatus {
        sweep: manifest.sweep,
        shards,
        mean_job_s,
    })
}

fn fmt_eta(eta: Option<f64>) -> String {
    match eta {
        None => "?".into(),
        Some(s) if s < 120.0 => format!("{s:.0} s"),
        Some(s) if s < 7200.0 => format!("{:.1} min", s / 60.0),
        Some(s) => format!("{:.1} h", s / 3600.0),
    }
}

impl fmt::Display for SweepStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "sweep {}", self.sweep)?;
        writeln!(
            f,
            "{:<8}  {:>6}  {:>8}  {:>6}  {:>9}  {:>7}  {:>10}  directory",
            "shard", "ok", "unstable", "failed", "remaining", "threads", "ETA"
        )?;
        for s in &self.shards {
            let label = s.shard.map_or("-".into(), |(i, n)| format!("{i}/{n}"));
            let threads = if s.started {
                s.threads.to_string()
            } else {
                "not run".into()
            };
            writeln!(
                f,
                "{label:<8}  {:>6}  {:>8}  {:>6}  {:>9}  {threads:>7}  {:>10}  {}",
                s.ok,
                s.unstable,
                s.failed,
                s.remaining,
                fmt_eta(s.eta_s),
                s.dir.display()
            )?;
        }
        let (ok, unstable, failed, remaining) = self.totals();
        writeln!(
            f,
            "{:<8}  {ok:>6}  {unstable:>8}  {failed:>6}  {remaining:>9}  {:>7}  {:>10}",
            "total",
            "",
            fmt_eta(self.eta_s())
        )?;
        match self.mean_job_s {
            Some(m) => writeln!(
                f,
                "mean job wall time {m:.2} s; ETA assumes the shards run at once"
            ),
            None => writeln!(f, "no job finished ok yet: no ETA"),
        }
    }
}
