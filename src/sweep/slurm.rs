//! Slurm job arrays: which shard an array task runs, where shards write, and the sbatch
//! scripts of `rubscan slurm`.
//!
//! A task of `sbatch --array=MIN-MAX:STEP` sees `SLURM_ARRAY_TASK_ID`, `SLURM_ARRAY_TASK_MIN`,
//! `SLURM_ARRAY_TASK_STEP` and `SLURM_ARRAY_TASK_COUNT`; it runs shard
//! `(ID − MIN) / STEP` of `COUNT`, in `<output>/shards/<i>-of-<n>` ([`shard_dir`]), which
//! `rubscan merge` then combines into `<output>`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::io::atomic::write_atomic;

/// Environment variables read by [`shard_from_env`] and [`threads_from_env`].
pub const TASK_ID: &str = "SLURM_ARRAY_TASK_ID";
/// First task id of the array.
pub const TASK_MIN: &str = "SLURM_ARRAY_TASK_MIN";
/// Step between task ids (absent = 1).
pub const TASK_STEP: &str = "SLURM_ARRAY_TASK_STEP";
/// Number of tasks of the array.
pub const TASK_COUNT: &str = "SLURM_ARRAY_TASK_COUNT";
/// CPUs allocated to each task (`--cpus-per-task`).
pub const CPUS_PER_TASK: &str = "SLURM_CPUS_PER_TASK";

/// Reads the environment variable `name` as an unsigned integer; `Ok(None)` when unset.
fn env_number(env: &dyn Fn(&str) -> Option<String>, name: &str) -> Result<Option<usize>> {
    let Some(text) = env(name) else {
        return Ok(None);
    };
    match text.trim().parse::<usize>() {
        Ok(v) => Ok(Some(v)),
        Err(_) => bail!("{name}={text:?}: not a non-negative integer"),
    }
}

fn required(env: &dyn Fn(&str) -> Option<String>, name: &str) -> Result<usize> {
    env_number(env, name)?.ok_or_else(|| {
        anyhow::anyhow!("{name} is not set although {TASK_ID} is (not a Slurm array task?)")
    })
}

/// The shard `(i, n)` of array task `id` in an array of `count` tasks with ids
/// `min, min + step, …`. Errors name the variable at fault.
pub fn array_shard(id: usize, min: usize, step: usize, count: usize) -> Result<(usize, usize)> {
    if step == 0 {
        bail!("{TASK_STEP}=0: the step between task ids must be ≥ 1");
    }
    if count == 0 {
        bail!("{TASK_COUNT}=0: an array has at least one task");
    }
    if id < min || !(id - min).is_multiple_of(step) {
        bail!(
            "{TASK_ID}={id} is not a task of the array {min}, {min}+{step}, … ({TASK_MIN}, {TASK_STEP})"
        );
    }
    let i = (id - min) / step;
    if i >= count {
        bail!(
            "{TASK_ID}={id} is task {i} of the array, but {TASK_COUNT}={count} (ids {min}..={})",
            min + (count - 1) * step
        );
    }
    Ok((i, count))
}

/// The shard of the Slurm array task described by `env` (a variable lookup, e.g.
/// `|k| std::env::var(k).ok()`); `Ok(None)` outside an array task (no `SLURM_ARRAY_TASK_ID`).
pub fn shard_from_env(env: &dyn Fn(&str) -> Option<String>) -> Result<Option<(usize, usize)>> {
    let Some(id) = env_number(env, TASK_ID)? else {
        return Ok(None);
    };
    let min = required(env, TASK_MIN)?;
    let count = required(env, TASK_COUNT)?;
    let step = env_number(env, TASK_STEP)?.unwrap_or(1);
    array_shard(id, min, step, count).map(Some)
}

/// The CPUs Slurm allocated to the task (`SLURM_CPUS_PER_TASK`), `Ok(None)` when unset.
pub fn threads_from_env(env: &dyn Fn(&str) -> Option<String>) -> Result<Option<usize>> {
    match env_number(env, CPUS_PER_TASK)? {
        Some(0) => bail!("{CPUS_PER_TASK}=0: a task has at least one CPU"),
        n => Ok(n),
    }
}

/// Output directory of shard `i` of `n` under a sweep's output directory `out`:
/// `<out>/shards/<i>-of-<n>`.
pub fn shard_dir(out: &Path, i: usize, n: usize) -> PathBuf {
    out.join("shards").join(format!("{i}-of-{n}"))
}

/// The shard directories `0..n` of `out`, in shard order ([`shard_dir`]).
pub fn shard_dirs(out: &Path, n: usize) -> Vec<PathBuf> {
    (0..n).map(|i| shard_dir(out, i, n)).collect()
}

/// Checks a Slurm time limit (`sbatch --time`): minutes, `MM:SS`, `HH:MM:SS`, `D-HH`,
/// `D-HH:MM` or `D-HH:MM:SS`, each field digits only. Minutes and seconds after the leading
/// field are < 60 and hours after a day count < 24: a field out of range (25:99:00) is a
/// typo, and the limit Slurm would make of it is not the one meant. The error says which
/// field is wrong; the caller names the option.
pub fn check_time(text: &str) -> Result<()> {
    let number = |field: &str, what: &str| -> Result<u32> {
        if field.is_empty() || !field.chars().all(|c| c.is_ascii_digit()) {
            bail!("the {what} {field:?} is not a number");
        }
        field
            .parse::<u32>()
            .with_context(|| format!("the {what} {field} is too large"))
    };
    let below = |field: &str, what: &str, limit: u32| -> Result<()> {
        let v = number(field, what)?;
        if v >= limit {
            bail!("the {what} {v} must be < {limit}");
        }
        Ok(())
    };
    let (days, clock) = match text.split_once('-') {
        Some((d, c)) => (Some(d), c),
        None => (None, text),
    };
    let fields: Vec<&str> = clock.split(':').collect();
    match (days, fields.as_slice()) {
        (None, [m]) => number(m, "minutes").map(drop),
        (None, [m, s]) => {
            number(m, "minutes")?;
            below(s, "seconds", 60)
        }
        (None, [h, m, s]) => {
            number(h, "hours")?;
            below(m, "minutes", 60)?;
            below(s, "seconds", 60)
        }
        (Some(d), [h, rest @ ..]) if rest.len() <= 2 => {
            number(d, "days")?;
            below(h, "hours", 24)?;
            for (f, what) in rest.iter().zip(["minutes", "seconds"]) {
                below(f, what, 60)?;
            }
            Ok(())
        }
        _ => bail!("too many fields"),
    }
}

/// A sweep as a Slurm job array (one task per shard) plus a merge job: what
/// `rubscan slurm` writes and submits.
#[derive(Debug, Clone, PartialEq)]
pub struct ArrayJob {
    /// Sweep name (job names `rubscan-<name>`, `rubscan-<name>-merge`).
    pub name: String,
    /// The `rubscan` executable the tasks run (absolute).
    pub rubscan: PathBuf,
    /// The sweep spec (absolute).
    pub spec: PathBuf,
    /// The sweep's output directory (absolute): shards in `shards/`, the merge in it.
    pub output: PathBuf,
    /// Array tasks = shards.
    pub tasks: usize,
    /// CPUs per task (the task's worker threads).
    pub cpus_per_task: usize,
    /// Time limit of each task and of the merge (`--time`), e.g. `02:00:00`.
    pub time: Option<String>,
    /// Partition (`--partition`).
    pub partition: Option<String>,
}

/// `text` quoted for a POSIX shell.
fn sh_quote(text: &str) -> String {
    format!("'{}'", text.replace('\'', r"'\''"))
}

fn path_arg(p: &Path) -> String {
    sh_quote(&p.to_string_lossy())
}

impl ArrayJob {
    /// Checks the options before anything is written: ≥ 1 task and CPU, a Slurm time
    /// ([`check_time`]), a partition name without blanks, and an output directory that is a
    /// directory or does not exist yet (likewise the script directory beside it), since the
    /// tasks write their shards under it. Errors name the option.
    pub fn validate(&self) -> Result<()> {
        if self.tasks == 0 {
            bail!("--tasks 0: an array needs at least one task");
        }
        if self.cpus_per_task == 0 {
            bail!("--cpus-per-task 0: a task needs at least one CPU");
        }
        if let Some(t) = &self.time {
            check_time(t).with_context(|| {
                format!(
                    "--time {t:?}: expected a Slurm time such as 02:00:00, 1-00:00:00 or 90 \
                     (minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS)"
                )
            })?;
        }
        if let Some(p) = &self.partition
            && (p.is_empty()
                || !p
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c)))
        {
            bail!("--partition {p:?}: expected a partition name ([A-Za-z0-9_.-]+)");
        }
        for (dir, what) in [
            (&self.output, "the sweep's output directory"),
            (&self.script_dir(), "the directory of the scripts"),
        ] {
            if dir.exists() && !dir.is_dir() {
                bail!(
                    "-o {}: {} exists and is not a directory; {what} must be a directory or \
                     not exist yet",
                    self.output.display(),
                    dir.display()
                );
            }
        }
        Ok(())
    }

    /// Checks `--tasks` against the `planned_jobs` of the sweep: each task runs one shard
    /// (jobs with index ≡ i mod n), so a task beyond the number of jobs would run nothing.
    /// Refused rather than clamped: the split `n` is the user's choice and names the shard
    /// directories (`<i>-of-<n>`), so it is not changed behind their back.
    pub fn check_tasks(&self, planned_jobs: usize) -> Result<()> {
        if self.tasks > planned_jobs {
            bail!(
                "--tasks {}: more array tasks than the {planned_jobs} planned jobs of the sweep \
                 (each task runs one shard of the jobs); use --tasks {} or fewer",
                self.tasks,
                planned_jobs
            );
        }
        Ok(())
    }

    /// Where the scripts and logs go: `<output>.slurm/` beside the output directory.
    pub fn script_dir(&self) -> PathBuf {
        let mut name = self.output.file_name().unwrap_or_default().to_os_string();
        name.push(".slurm");
        self.output.with_file_name(name)
    }

    /// Path of the array script.
    pub fn array_script_path(&self) -> PathBuf {
        self.script_dir().join("array.sbatch")
    }

    /// Path of the merge script.
    pub fn merge_script_path(&self) -> PathBuf {
        self.script_dir().join("merge.sbatch")
    }

    fn header(&self, job_name: &str, log: &str, cpus: usize) -> String {
        let mut s = String::from("#!/bin/bash\n");
        let _ = writeln!(s, "#SBATCH --job-name={job_name}");
        let _ = writeln!(s, "#SBATCH --cpus-per-task={cpus}");
        let _ = writeln!(s, "#SBATCH --ntasks=1");
        if let Some(t) = &self.time {
            let _ = writeln!(s, "#SBATCH --time={t}");
        }
        if let Some(p) = &self.partition {
            let _ = writeln!(s, "#SBATCH --partition={p}");
        }
        let log = self.script_dir().join("logs").join(log);
        let _ = writeln!(s, "#SBATCH --output={}", log.display());
        s
    }

    /// The array script: task i runs shard i of n into `<output>/shards/<i>-of-<n>`, with
    /// `SLURM_CPUS_PER_TASK` threads. The shard is pinned to the task id (not derived from
    /// the array's extent), so resubmitting a subset (`sbatch --array=1 …`) resumes
    /// exactly those shards.
    pub fn array_script(&self) -> String {
        let n = self.tasks;
        let mut s = self.header(
            &format!("rubscan-{}", self.name),
            "%x-%A_%a.out",
            self.cpus_per_task,
        );
        let _ = writeln!(s, "#SBATCH --array=0-{}", n - 1);
        let _ = writeln!(
            s,
            "# Written by `rubscan slurm`. Resume some shards: sbatch --array=1,3 {}",
            self.array_script_path().display()
        );
        s.push_str("set -euo pipefail\n");
        let shard_dir = self.output.join("shards");
        let _ = writeln!(
            s,
            "exec {} run {} --shard \"${{SLURM_ARRAY_TASK_ID}}/{n}\" -o {}/\"${{SLURM_ARRAY_TASK_ID}}-of-{n}\"",
            path_arg(&self.rubscan),
            path_arg(&self.spec),
            path_arg(&shard_dir),
        );
        s
    }

    /// The merge script: `rubscan merge` of every shard directory into the output directory;
    /// it fails (non-zero) naming the shards that are unfinished or have failed jobs.
    pub fn merge_script(&self) -> String {
        let mut s = self.header(&format!("rubscan-{}-merge", self.name), "%x-%j.out", 1);
        s.push_str(
            "# Written by `rubscan slurm`; runs after the array (afterany).\nset -euo pipefail\n",
        );
        let _ = write!(
            s,
            "exec {} merge -o {}",
            path_arg(&self.rubscan),
            path_arg(&self.output)
        );
        for d in shard_dirs(&self.output, self.tasks) {
            let _ = write!(s, " \\\n  {}", path_arg(&d));
        }
        s.push('\n');
        s
    }

    /// Writes both scripts (atomically) and creates the log directory; returns the script
    /// paths (array, merge).
    pub fn write(&self) -> Result<(PathBuf, PathBuf)> {
        let logs = self.script_dir().join("logs");
        std::fs::create_dir_all(&logs)
            .with_context(|| format!("cannot create {}", logs.display()))?;
        let (a, m) = (self.array_script_path(), self.merge_script_path());
        write_atomic(&a, self.array_script().as_bytes())
            .with_context(|| format!("cannot write {}", a.display()))?;
        write_atomic(&m, self.merge_script().as_bytes())
            .with_context(|| format!("cannot write {}", m.display()))?;
        Ok((a, m))
    }

    /// The shell commands that submit the array, then the merge after it.
    pub fn submit_commands(&self) -> String {
        format!(
            "jobid=$(sbatch --parsable {})\nsbatch --dependency=afterany:${{jobid%%;*}} {}\n",
            path_arg(&self.array_script_path()),
            path_arg(&self.merge_script_path())
        )
    }

    /// Submits the array, then the merge with `--dependency=afterany:<array id>`; returns
    /// the two job ids.
    pub fn submit(&self) -> Result<(String, String)> {
        let array = sbatch(&[], &self.array_script_path())?;
        let merge = sbatch(
            &[format!("--dependency=afterany:{array}")],
            &self.merge_script_path(),
        )?;
        Ok((array, merge))
    }
}

/// Runs `sbatch --parsable [args] script`; returns the job id.
pub fn sbatch(args: &[String], script: &Path) -> Result<String> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .arg(script)
        .output()
        .context("cannot run sbatch (is Slurm installed and on PATH?)")?;
    if !out.status.success() {
        bail!(
            "sbatch {} failed ({}): {}",
            script.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    parse_job_id(&String::from_utf8_lossy(&out.stdout))
}

/// The job id in the output of `sbatch --parsable` (`<id>` or `<id>;<cluster>`).
pub fn parse_job_id(stdout: &str) -> Result<String> {
    let id = stdout.trim().split(';').next().unwrap_or_default();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        bail!("sbatch --parsable printed {stdout:?}, not a job id");
    }
    Ok(id.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let map: HashMap<String, String> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k| map.get(k).cloned()
    }

    #[test]
    fn array_ids_map_onto_consecutive_shards() {
        // --array=0-3: ids are the shard numbers.
        for id in 0..4 {
            assert_eq!(array_shard(id, 0, 1, 4).unwrap(), (id, 4));
        }
        // --array=5-17:4 → ids 5, 9, 13, 17 → shards 0..4 of 4.
        let shards: Vec<_> = [5, 9, 13, 17]
            .iter()
            .map(|&id| array_shard(id, 5, 4, 4).unwrap())
            .collect();
        assert_eq!(shards, vec![(0, 4), (1, 4), (2, 4), (3, 4)]);
    }

    #[test]
    fn ids_outside_the_array_are_rejected_naming_the_variable() {
        let msg = |r: Result<(usize, usize)>| format!("{:#}", r.unwrap_err());
        assert!(msg(array_shard(4, 5, 4, 4)).contains("SLURM_ARRAY_TASK_ID=4"));
        assert!(msg(array_shard(7, 5, 4, 4)).contains("SLURM_ARRAY_TASK_ID=7"));
        assert!(msg(array_shard(21, 5, 4, 4)).contains("SLURM_ARRAY_TASK_COUNT=4"));
        assert!(msg(array_shard(5, 5, 0, 4)).contains("SLURM_ARRAY_TASK_STEP=0"));
        assert!(msg(array_shard(5, 5, 1, 0)).contains("SLURM_ARRAY_TASK_COUNT=0"));
    }

    #[test]
    fn shard_from_the_environment() {
        assert_eq!(shard_from_env(&env(&[])).unwrap(), None);
        let e = env(&[
            (TASK_ID, "13"),
            (TASK_MIN, "5"),
            (TASK_STEP, "4"),
            (TASK_COUNT, "4"),
        ]);
        assert_eq!(shard_from_env(&e).unwrap(), Some((2, 4)));
        // The step defaults to 1.
        let e = env(&[(TASK_ID, "3"), (TASK_MIN, "2"), (TASK_COUNT, "2")]);
        assert_eq!(shard_from_env(&e).unwrap(), Some((1, 2)));
        let bad = env(&[(TASK_ID, "x1"), (TASK_MIN, "0"), (TASK_COUNT, "2")]);
        let err = format!("{:#}", shard_from_env(&bad).unwrap_err());
        assert!(err.contains("SLURM_ARRAY_TASK_ID=\"x1\""), "{err}");
        let bad = env(&[(TASK_ID, "1"), (TASK_MIN, "-1"), (TASK_COUNT, "2")]);
        let err = format!("{:#}", shard_from_env(&bad).unwrap_err());
        assert!(err.contains("SLURM_ARRAY_TASK_MIN=\"-1\""), "{err}");
        let bad = env(&[(TASK_ID, "1"), (TASK_MIN, "0")]);
        let err = format!("{:#}", shard_from_env(&bad).unwrap_err());
        assert!(err.contains("SLURM_ARRAY_TASK_COUNT is not set"), "{err}");
    }

    #[test]
    fn threads_from_the_allocation() {
        assert_eq!(threads_from_env(&env(&[])).unwrap(), None);
        let e = env(&[(CPUS_PER_TASK, "3")]);
        assert_eq!(threads_from_env(&e).unwrap(), Some(3));
        for bad in ["0", "two"] {
            let err = threads_from_env(&env(&[(CPUS_PER_TASK, bad)])).unwrap_err();
            assert!(
                format!("{err:#}").contains("SLURM_CPUS_PER_TASK"),
                "{err:#}"
            );
        }
    }

    #[test]
    fn shard_dirs_are_named_by_index_and_count() {
        assert_eq!(
            shard_dirs(Path::new("out"), 2),
            vec![
                PathBuf::from("out/shards/0-of-2"),
                PathBuf::from("out/shards/1-of-2")
            ]
        );
    }

    fn job() -> ArrayJob {
        ArrayJob {
            name: "small".into(),
            rubscan: "/opt/bin/rubscan".into(),
            spec: "/home/u/it's.json".into(),
            output: "/scratch/results/small".into(),
            tasks: 3,
            cpus_per_task: 4,
            time: Some("01:30:00".into()),
            partition: Some("short".into()),
        }
    }

    #[test]
    fn array_script_runs_task_i_as_shard_i_into_its_directory() {
        let j = job();
        assert_eq!(
            j.script_dir(),
            PathBuf::from("/scratch/results/small.slurm")
        );
        let s = j.array_script();
        for line in [
            "#SBATCH --array=0-2",
            "#SBATCH --cpus-per-task=4",
            "#SBATCH --time=01:30:00",
            "#SBATCH --partition=short",
            "#SBATCH --output=/scratch/results/small.slurm/logs/%x-%A_%a.out",
            "exec '/opt/bin/rubscan' run '/home/u/it'\\''s.json' --shard \"${SLURM_ARRAY_TASK_ID}/3\" \
             -o '/scratch/results/small/shards'/\"${SLURM_ARRAY_TASK_ID}-of-3\"",
        ] {
            assert!(s.lines().any(|l| l == line), "{line}\n{s}");
        }
        // Task i writes where the merge and `shard_dir` look.
        let task1 = s
            .replace("${SLURM_ARRAY_TASK_ID}", "1")
            .replace(['\'', '"'], "");
        let dir = shard_dir(&j.output, 1, 3);
        assert!(task1.contains(&format!("-o {}", dir.display())), "{task1}");
        assert!(
            !s.contains("--threads"),
            "threads come from SLURM_CPUS_PER_TASK"
        );
    }

    #[test]
    fn merge_script_merges_every_shard_into_the_output() {
        let s = job().merge_script();
        assert!(s.contains("#SBATCH --cpus-per-task=1\n"), "{s}");
        assert!(s.contains("exec '/opt/bin/rubscan' merge -o '/scratch/results/small'"));
        for i in 0..3 {
            assert!(
                s.contains(&format!("'/scratch/results/small/shards/{i}-of-3'")),
                "{s}"
            );
        }
        let c = job().submit_commands();
        assert!(c.contains("sbatch --dependency=afterany:${jobid%%;*} '/scratch/results/small.slurm/merge.sbatch'"), "{c}");
    }

    #[test]
    fn bad_options_are_rejected_naming_the_option() {
        let err = |f: fn(&mut ArrayJob)| {
            let mut j = job();
            f(&mut j);
            format!("{:#}", j.validate().unwrap_err())
        };
        assert!(err(|j| j.tasks = 0).contains("--tasks"));
        assert!(err(|j| j.cpus_per_task = 0).contains("--cpus-per-task"));
        assert!(err(|j| j.time = Some("1h".into())).contains("--time"));
        assert!(err(|j| j.time = Some("1::0".into())).contains("--time"));
        assert!(err(|j| j.partition = Some("a b".into())).contains("--partition"));
        let mut j = job();
        for t in [
            "90",
            "30:00",
            "90:59",
            "02:00:00",
            "48:00:00",
            "1-00:00:00",
            "1-12",
            "1-23:59",
            "0",
        ] {
            j.time = Some(t.into());
            j.validate().unwrap();
        }
    }

    #[test]
    fn times_out_of_range_are_rejected_naming_the_field() {
        for (t, why) in [
            ("25:99:00", "minutes 99 must be < 60"),
            ("00:10:60", "seconds 60 must be < 60"),
            ("10:75", "seconds 75 must be < 60"),
            ("1-24:00:00", "hours 24 must be < 24"),
            ("1-00:60", "minutes 60 must be < 60"),
            ("1:2-3", "not a number"),
            ("1-2:3:4:5", "too many fields"),
            ("", "not a number"),
            ("99999999999", "too large"),
        ] {
            let mut j = job();
            j.time = Some(t.into());
            let e = format!("{:#}", j.validate().unwrap_err());
            assert!(e.contains(&format!("--time {t:?}")), "{e}");
            assert!(e.contains(why), "{t}: {e}");
        }
    }

    #[test]
    fn more_tasks_than_planned_jobs_are_refused_naming_both_counts() {
        let j = job();
        j.check_tasks(3).unwrap();
        j.check_tasks(6).unwrap();
        let e = format!("{:#}", j.check_tasks(2).unwrap_err());
        assert!(
            e.contains("--tasks 3") && e.contains("2 planned jobs"),
            "{e}"
        );
    }

    #[test]
    fn an_output_that_is_a_file_is_refused() {
        let dir = std::env::temp_dir().join(format!("rubscan-slurm-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut j = job();
        j.output = dir.join("results");
        j.validate().unwrap();
        std::fs::write(&j.output, "x").unwrap();
        let e = format!("{:#}", j.validate().unwrap_err());
        assert!(e.contains("-o ") && e.contains("is not a directory"), "{e}");
        std::fs::remove_file(&j.output).unwrap();
        std::fs::write(j.script_dir(), "x").unwrap();
        let e = format!("{:#}", j.validate().unwrap_err());
        assert!(
            e.contains("results.slurm exists and is not a directory"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn job_ids_from_sbatch_parsable() {
        assert_eq!(parse_job_id("123\n").unwrap(), "123");
        assert_eq!(parse_job_id("77;cluster\n").unwrap(), "77");
        assert!(parse_job_id("Submitted batch job 5").is_err());
        assert!(parse_job_id("").is_err());
    }
}
