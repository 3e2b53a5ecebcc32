//! Refinement rounds: the plan of a sweep that refines its speed axis, from the jobs
//! finished so far.
//!
//! Round 0 is the grid. Once every job of rounds ≤ r has a record, round r + 1 adds to each
//! speed line the speeds [`next_round`] asks for (bisecting the `ok`/`unstable` boundaries,
//! fitting and checking the peaks), until no line asks for more or its budget is spent. The
//! plan is a function of the spec and of the finished records alone, and those are
//! deterministic: a resumed, re-threaded or sharded run plans the same rounds, with the same
//! job ids and indices (refined jobs follow the grid's by round, line and Ω).

use std::collections::HashMap;

use super::checkpoint::{JobRecord, JobStatus};
use super::planner::{Job, Plan, RefinedSpeed, plan_with_speeds, speed_lines};
use super::refine::{
    Located, PointOutcome, RefineSpec, SpeedPoint, located, next_round, quantity_of,
};
use super::schema::SpecError;
use super::spec::SweepSpec;

/// The plan of `spec` as far as the finished jobs allow: every round whose predecessors are
/// all finished (`record` gives a job's record, `None` while it is unfinished). Without
/// `grid.speed.refine` this is the grid's plan.
pub fn refined_plan(
    spec: &SweepSpec,
    record: &dyn Fn(&Job) -> Option<JobRecord>,
) -> Result<Plan, SpecError> {
    let mut extra: Vec<RefinedSpeed> = Vec::new();
    loop {
        let plan = plan_with_speeds(spec, &extra)?;
        let Some(refine) = &spec.grid.speed.refine else {
            return Ok(plan);
        };
        let Some(records) = plan.jobs.iter().map(record).collect::<Option<Vec<_>>>() else {
            return Ok(plan);
        };
        let round = plan.refinement_rounds.iter().max().map_or(1, |r| r + 1);
        let mut added = false;
        for (line, jobs) in speed_lines(&plan).iter().enumerate() {
            let points = line_points(&plan, jobs, &|i| records.get(i), refine);
            let spent = jobs
                .iter()
                .filter(|&&i| plan.refinement_round(i) > 0)
                .count();
            for s in next_round(&points, refine, spent) {
                extra.push(RefinedSpeed {
                    line,
                    omega_rad_s: s.omega_rad_s,
                    round,
                });
                added = true;
            }
        }
        if !added {
            return Ok(plan);
        }
    }
}

/// What the finished rounds have located on each speed line (boundaries and peaks, with
/// their brackets), from the records `(index, record)` of `plan`'s finished jobs.
pub fn located_per_line(
    spec: &SweepSpec,
    plan: &Plan,
    records: &[(usize, JobRecord)],
) -> Vec<Located> {
    let Some(refine) = &spec.grid.speed.refine else {
        return Vec::new();
    };
    let by_index: HashMap<usize, &JobRecord> = records.iter().map(|(i, r)| (*i, r)).collect();
    let record = |i: usize| by_index.get(&i).copied();
    speed_lines(plan)
        .iter()
        .map(|jobs| located(&line_points(plan, jobs, &record, refine), refine))
        .collect()
}

/// The points of one speed line (`jobs`: indices into `plan`) whose jobs have a record.
fn line_points<'a>(
    plan: &Plan,
    jobs: &[usize],
    record: &dyn Fn(usize) -> Option<&'a JobRecord>,
    refine: &RefineSpec,
) -> Vec<SpeedPoint> {
    jobs.iter()
        .filter_map(|&i| {
            let rec = record(i)?;
            Some(SpeedPoint {
                omega_rad_s: plan.jobs[i].params.speed_rad_s,
                outcome: match rec.status {
                    JobStatus::Ok => PointOutcome::Ok,
                    JobStatus::Unstable => PointOutcome::Unstable,
                    JobStatus::Failed { .. } => PointOutcome::Failed,
                },
                value: (refine.peak_of.as_deref())
                    .zip(rec.result.as_ref())
                    .and_then(|(column, r)| quantity_of(column, r)),
            })
        })
        .collect()
}
