//! Per-job checkpoint files and atomic writes.
//!
//! Every finished job is written to `<out>/jobs/<id>.json` through a temporary file
//! in the same directory followed by `rename`, which is atomic on POSIX file
//! systems: a reader (or a resumed run) sees either no file or a complete one, so an
//! interrupted sweep loses at most the jobs in flight.

use std::fs;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::JobResult;
use super::planner::{Job, JobParams};

/// Version of the job record format.
pub const JOB_RECORD_VERSION: u32 = 1;

/// Outcome of a job.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "state")]
pub enum JobStatus {
    /// Finished with a bounded response; the record holds a result.
    Ok,
    /// A runaway was confirmed and the job stopped early: a finding, not a failure. The
    /// record holds a result whose maxima run to the stop and whose `runaway` says when it
    /// started, how fast it grew and which wave grew.
    Unstable,
    /// The simulator reported a failure (or panicked, or produced non-finite numbers).
    Failed {
        /// Why.
        reason: String,
    },
}

/// Contents of `<out>/jobs/<id>.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobRecord {
    /// [`JOB_RECORD_VERSION`].
    pub format_version: u32,
    /// Job id (file name stem).
    pub id: String,
    /// Job parameters (for humans and for checks; the plan is authoritative).
    pub params: JobParams,
    /// Ok, unstable, or failed with reason.
    pub status: JobStatus,
    /// Aggregates when `status` is ok or unstable.
    pub result: Option<JobResult>,
    /// Wall-clock time of the job (s).
    pub wall_time_s: f64,
    /// Refinement round that added the job: 0 for the grid (not written then).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub refinement_round: u32,
}

fn is_zero(r: &u32) -> bool {
    *r == 0
}

impl JobRecord {
    /// Record of a finished job.
    pub fn new(job: &Job, outcome: Result<JobResult, String>, wall_time_s: f64) -> Self {
        let (status, result) = match outcome {
            Ok(r) if r.runaway.is_some() => (JobStatus::Unstable, Some(r)),
            Ok(r) => (JobStatus::Ok, Some(r)),
            Err(reason) => (JobStatus::Failed { reason }, None),
        };
        JobRecord {
            format_version: JOB_RECORD_VERSION,
            id: job.id.clone(),
            params: job.params,
            status,
            result,
            wall_time_s,
            refinement_round: 0,
        }
    }

    /// True when the job succeeded: it ran to its end (`ok`) or found a runaway
    /// (`unstable`); either way the record holds a result.
    pub fn succeeded(&self) -> bool {
        matches!(self.status, JobStatus::Ok | JobStatus::Unstable)
    }

    /// True when the job found a runaway.
    pub fn is_unstable(&self) -> bool {
        self.status == JobStatus::Unstable
    }
}

/// Numbers of finished jobs by outcome.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Outcomes {
    /// Bounded responses.
    pub ok: usize,
    /// Runaways found (a success).
    pub unstable: usize,
    /// Failures (numerics, I/O, limits).
    pub failed: usize,
}

impl Outcomes {
    /// Counts the outcomes of `records`.
    pub fn of<'a>(records: impl IntoIterator<Item = &'a JobRecord>) -> Self {
        records.into_iter().fold(Self::default(), |mut o, r| {
            match r.status {
                JobStatus::Ok => o.ok += 1,
                JobStatus::Unstable => o.unstable += 1,
                JobStatus::Failed { .. } => o.failed += 1,
            }
            o
        })
    }
}

/// Directory of the job records of an output directory.
pub(crate) fn jobs_dir(output_dir: &Path) -> PathBuf {
    output_dir.join("jobs")
}

/// Path of a job's record.
pub(crate) fn record_path(output_dir: &Path, id: &str) -> PathBuf {
    jobs_dir(output_dir).join(format!("{id}.json"))
}

/// Serializes `value` as pretty JSON and writes it atomically.
pub(crate) fn write_json_atomic<T: Serialize>(path: &Path, value: &T) -> std::io::Result<()> {
    let mut bytes = serde_json::to_vec_pretty(value).map_err(std::io::Error::other)?;
    bytes.push(b'\n');
    crate::io::atomic::write_atomic(path, &bytes)
}

/// Writes a job record atomically to `<out>/jobs/<id>.json`.
pub(crate) fn write_record(output_dir: &Path, record: &JobRecord) -> std::io::Result<()> {
    write_json_atomic(&record_path(output_dir, &record.id), record)
}

/// Reads the record of job `id`. `Ok(None)`: no record. `Err(reason)`: a file exists but
/// is unreadable, malformed, of another format version or for another id; the caller
/// treats the job as unfinished (running it again overwrites the file).
pub(crate) fn read_record(output_dir: &Path, id: &str) -> Result<Option<JobRecord>, String> {
    let path = record_path(output_dir, id);
    let text = match fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("{}: {e}", path.display())),
    };
    let rec: JobRecord = serde_json::from_str(&text)
        .map_err(|e| format!("{}: malformed job record: {e}", path.display()))?;
    if rec.format_version != JOB_RECORD_VERSION {
        return Err(format!(
            "{}: job record format {} (expected {JOB_RECORD_VERSION})",
            path.display(),
            rec.format_version
        ));
    }
    if rec.id != id {
        return Err(format!("{}: record is for job {}", path.display(), rec.id));
    }
    Ok(Some(rec))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::planner::{CoatingParams, JobContext};
    use crate::sweep::spec::{CasingSource, ModelSource, Numerics, Scenario};
    use std::sync::Arc;

    fn job() -> Job {
        Job {
            index: 0,
            id: "00000000deadbeef".into(),
            params: JobParams {
                speed_rad_s: 100.0,
                friction: 0.1,
                clearance_m: None,
                coating: CoatingParams::default(),
            },
            context: Arc::new(JobContext {
                impeller: ModelSource::Builtin(Default::default()),
                casing: CasingSource::Builtin(Default::default()),
                rotation: Default::default(),
                scenario: Scenario {
                    duration_s: 1.0,
                    lobes: None,
                    load_amplitude_m: None,
                    load_ramp_s: None,
                    casing_probes: vec![],
                    probes: vec![],
                    revolution_report: None,
                    steady_fraction: None,
                    rigid_stations: None,
                    coating: None,
                },
                numerics: Numerics::default(),
            }),
        }
    }

    #[test]
    fn record_round_trip_and_rejections() {
        let dir = std::env::temp_dir().join(format!("rubscan-ckpt-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(jobs_dir(&dir)).unwrap();
        let j = job();
        assert_eq!(read_record(&dir, &j.id), Ok(None));
        let rec = JobRecord::new(&j, Err("diverged at t = 0.1 s".into()), 0.25);
        write_record(&dir, &rec).unwrap();
        assert_eq!(read_record(&dir, &j.id).unwrap(), Some(rec.clone()));
        // No temporary file left behind.
        let names: Vec<_> = fs::read_dir(jobs_dir(&dir))
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1);
        // A truncated file is reported, not trusted.
        fs::write(record_path(&dir, &j.id), "{\"format_version\": 1,").unwrap();
        assert!(read_record(&dir, &j.id).is_err());
        // A record under the wrong name is reported.
        let mut other = rec;
        other.id = "ffffffffffffffff".into();
        fs::write(
            record_path(&dir, &j.id),
            serde_json::to_string(&other).unwrap(),
        )
        .unwrap();
        assert!(
            read_record(&dir, &j.id)
                .unwrap_err()
                .contains("ffffffffffffffff")
        );
        fs::remove_dir_all(&dir).unwrap();
    }
}
