//! Runner: resume, thread-count and shard independence, Parquet read-back, failures.

use crate::common;
use common::table_without_timing;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::Duration;

use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, UInt64Type};
use arrow_array::{Array, RecordBatch};
use arrow_schema::DataType;
use rubscan::sweep::simulator::ModelSimulator;
use rubscan::sweep::synthetic::SyntheticSimulator;
use rubscan::sweep::table::{COLUMNS, read_results};
use rubscan::sweep::{
    Job, JobResult, JobSimulator, JobSteps, RunOptions, SweepSpec, merge, parse_spec, plan,
    run_sweep,
};

fn spec() -> SweepSpec {
    parse_spec(
        &serde_json::json!({
            "name": "runner_test",
            "models": {"impeller": {"builtin": {}}, "casing": {"rigid": {"lobes": 2, "amplitude_m": 1e-4}}},
            "scenario": {"duration_s": 0.01},
            "numerics": {"time_step_s": 1e-5},
            "grid": {
                "speed": {"unit": "rad_s", "range": {"start": 600.0, "stop": 1400.0, "count": 5}},
                "friction": [0.0, 0.2],
                "coating": {"young": {"scale": [0.1, 10.0]}, "thickness": {"values": [1.5e-4]}}
            }
        })
        .to_string(),
    )
    .unwrap()
}

/// Counts calls and optionally raises the cancel flag during the k-th call.
struct Counting {
    inner: SyntheticSimulator,
    calls: AtomicUsize,
    cancel_at: Option<(usize, Arc<AtomicBool>)>,
}

impl Counting {
    fn new(inner: SyntheticSimulator) -> Self {
        Counting {
            inner,
            calls: AtomicUsize::new(0),
            cancel_at: None,
        }
    }
}

impl JobSimulator for Counting {
    fn run(&self, job: &Job, cancel: &AtomicBool) -> Result<JobResult, String> {
        let n = self.calls.fetch_add(1, Ordering::SeqCst) + 1;
        if let Some((k, flag)) = &self.cancel_at
            && n == *k
        {
            flag.store(true, Ordering::SeqCst);
        }
        self.inner.run(job, cancel)
    }
}

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rubscan-runner-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn opts(dir: &Path, threads: usize) -> RunOptions {
    let mut o = RunOptions::new(dir);
    o.threads = threads;
    o
}

fn n_rows(t: &[RecordBatch]) -> usize {
    t.iter().map(RecordBatch::num_rows).sum()
}

#[test]
fn resume_after_cancel_runs_only_unfinished_jobs() {
    let spec = spec();
    let total = plan(&spec).unwrap().jobs.len();
    assert_eq!(total, 20);
    let full_dir = tmp("full");
    let full = run_sweep(&spec, &opts(&full_dir, 1), &SyntheticSimulator::default()).unwrap();
    assert_eq!((full.ran, full.ok, full.unfinished), (total, total, 0));

    // Interrupted run: the flag goes up during the 7th call, which still completes.
    let dir = tmp("resume");
    let k = 7;
    let o = opts(&dir, 1);
    let mut sim = Counting::new(SyntheticSimulator::default());
    sim.cancel_at = Some((k, Arc::clone(&o.cancel)));
    let first = run_sweep(&spec, &o, &sim).unwrap();
    assert!(first.cancelled);
    assert_eq!((first.ran, first.unfinished), (k, total - k));
    assert_eq!(sim.calls.load(Ordering::SeqCst), k);
    assert_eq!(n_rows(&table_without_timing(&dir)), k);

    // Resume: only the remaining jobs run, and the table equals the uninterrupted one.
    let sim = Counting::new(SyntheticSimulator::default());
    let second = run_sweep(&spec, &opts(&dir, 1), &sim).unwrap();
    assert_eq!(sim.calls.load(Ordering::SeqCst), total - k);
    assert_eq!(
        (second.skipped, second.ran, second.unfinished),
        (k, total - k, 0)
    );
    assert_eq!(table_without_timing(&dir), table_without_timing(&full_dir));

    // A third run has nothing to do.
    let sim = Counting::new(SyntheticSimulator::default());
    run_sweep(&spec, &opts(&dir, 1), &sim).unwrap();
    assert_eq!(sim.calls.load(Ordering::SeqCst), 0);

    // Pre-existing job files (copied from the full run) are skipped.
    let seeded = tmp("seeded");
    std::fs::create_dir_all(seeded.join("jobs")).unwrap();
    let p = plan(&spec).unwrap();
    for j in p.jobs.iter().filter(|j| j.index % 3 == 0) {
        let name = format!("{}.json", j.id);
        std::fs::copy(
            full_dir.join("jobs").join(&name),
            seeded.join("jobs").join(&name),
        )
        .unwrap();
    }
    let copied = p.jobs.iter().filter(|j| j.index % 3 == 0).count();
    let sim = Counting::new(SyntheticSimulator::default());
    run_sweep(&spec, &opts(&seeded, 2), &sim).unwrap();
    assert_eq!(sim.calls.load(Ordering::SeqCst), total - copied);
    assert_eq!(
        table_without_timing(&seeded),
        table_without_timing(&full_dir)
    );

    for d in [full_dir, dir, seeded] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn cancel_mid_job_leaves_no_partial_files() {
    let spec = spec();
    let dir = tmp("midjob");
    let o = opts(&dir, 2);
    let sim = SyntheticSimulator {
        sleep: Duration::from_millis(40),
        ..Default::default()
    };
    let flag = Arc::clone(&o.cancel);
    let stopper = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(150));
        flag.store(true, Ordering::SeqCst);
    });
    let s = run_sweep(&spec, &o, &sim).unwrap();
    stopper.join().unwrap();
    assert!(s.cancelled && s.unfinished > 0, "{s:?}");
    // Every file in jobs/ is a complete record of a finished job; no temporary files.
    let names: Vec<String> = std::fs::read_dir(dir.join("jobs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), s.ran);
    assert!(
        names
            .iter()
            .all(|n| n.ends_with(".json") && !n.starts_with('.')),
        "{names:?}"
    );
    let resumed = run_sweep(&spec, &opts(&dir, 2), &SyntheticSimulator::default()).unwrap();
    assert_eq!(resumed.ran, s.unfinished);
    assert_eq!(n_rows(&table_without_timing(&dir)), 20);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn thread_count_and_sharding_do_not_change_the_table() {
    let spec = spec();
    let d1 = tmp("t1");
    let d2 = tmp("t2");
    run_sweep(&spec, &opts(&d1, 1), &SyntheticSimulator::default()).unwrap();
    // The progress-bar path (hidden when stderr is not a terminal) must give the same table.
    let mut o2 = opts(&d2, 2);
    o2.progress = true;
    run_sweep(&spec, &o2, &SyntheticSimulator::default()).unwrap();
    assert_eq!(table_without_timing(&d1), table_without_timing(&d2));

    let s0 = tmp("shard0");
    let s1 = tmp("shard1");
    let mut o0 = opts(&s0, 1);
    o0.shard = Some((0, 2));
    let mut o1 = opts(&s1, 2);
    o1.shard = Some((1, 2));
    let r0 = run_sweep(&spec, &o0, &SyntheticSimulator::default()).unwrap();
    let r1 = run_sweep(&spec, &o1, &SyntheticSimulator::default()).unwrap();
    assert_eq!((r0.in_shard, r1.in_shard), (10, 10));
    // Shard i holds exactly the indices ≡ i mod 2.
    for (d, i) in [(&s0, 0u64), (&s1, 1u64)] {
        for b in table_without_timing(d) {
            let idx = b
                .column_by_name("job_index")
                .unwrap()
                .as_primitive::<UInt64Type>();
            assert!(idx.values().iter().all(|&x| x % 2 == i));
        }
    }
    let merged = tmp("merged");
    let m = merge(&[s0.clone(), s1.clone()], &merged).unwrap();
    assert_eq!((m.planned, m.found, m.missing.len()), (20, 20, 0));
    assert_eq!(table_without_timing(&merged), table_without_timing(&d1));
    // Merging only one shard reports the missing jobs.
    let partial = tmp("partial");
    let m = merge(std::slice::from_ref(&s0), &partial).unwrap();
    assert_eq!(m.missing.len(), 10);
    for d in [d1, d2, s0, s1, merged, partial] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn parquet_reads_back_with_documented_columns_and_failures() {
    let spec = spec();
    let dir = tmp("parquet");
    let sim = SyntheticSimulator {
        fail_above_speed_rad_s: Some(1250.0),
        ..Default::default()
    };
    let s = run_sweep(&spec, &opts(&dir, 2), &sim).unwrap();
    // Speeds 600, 800, 1000, 1200, 1400: one in five fails.
    assert_eq!((s.ok, s.failed), (16, 4));
    let batches = read_results(&dir.join("results.parquet")).unwrap();
    let b = &batches[0];
    assert_eq!(b.num_rows(), 20);
    let schema = b.schema();
    let names: Vec<&str> = schema.fields().iter().map(|f| f.name().as_str()).collect();
    let documented: Vec<&str> = COLUMNS.iter().map(|c| c.0).collect();
    assert_eq!(names, documented);
    let f64_list =
        |dt: &DataType| matches!(dt, DataType::List(f) if f.data_type() == &DataType::Float64);
    for f in schema.fields() {
        let dt = f.data_type();
        let ok = match f.name().as_str() {
            "job_index" | "steps_over_gap_tolerance" => dt == &DataType::UInt64,
            "job_id" | "status" | "reason" => dt == &DataType::Utf8,
            "critical_nodal_diameter"
            | "refinement_round"
            | "growing_nodal_diameter"
            | "predicted_nodal_diameter" => dt == &DataType::UInt32,
            "growing_wave_forward" | "runaway_at_solve_breakdown" | "predicted_stable" => {
                dt == &DataType::Boolean
            }
            "strain_energy_per_nd_j" | "spectrum_amplitude_m" => f64_list(dt),
            "wear_profile_m" => matches!(dt, DataType::List(f) if f64_list(f.data_type())),
            "fourier_peaks" => match dt {
                DataType::List(item) => match item.data_type() {
                    DataType::Struct(fs) => {
                        fs.iter().map(|f| f.name().as_str()).collect::<Vec<_>>()
                            == ["frequency_hz", "engine_order", "amplitude_m"]
                            && fs.iter().all(|f| f.data_type() == &DataType::Float64)
                    }
                    _ => false,
                },
                _ => false,
            },
            _ => dt == &DataType::Float64,
        };
        assert!(ok, "column {} has type {dt:?}", f.name());
        // Units travel in the field metadata too.
        let unit = COLUMNS.iter().find(|c| c.0 == f.name()).unwrap().1;
        if !unit.is_empty() {
            assert_eq!(
                f.metadata().get("unit").map(String::as_str),
                Some(unit),
                "{}",
                f.name()
            );
        }
    }
    let idx = b
        .column_by_name("job_index")
        .unwrap()
        .as_primitive::<UInt64Type>();
    assert!(
        idx.values().windows(2).all(|w| w[0] < w[1]),
        "rows sorted by job index"
    );
    let speed = b
        .column_by_name("speed_rad_s")
        .unwrap()
        .as_primitive::<Float64Type>();
    let status = b.column_by_name("status").unwrap().as_string::<i32>();
    let reason = b.column_by_name("reason").unwrap().as_string::<i32>();
    let le = b
        .column_by_name("max_blade_le_radial_m")
        .unwrap()
        .as_primitive::<Float64Type>();
    for r in 0..b.num_rows() {
        if speed.value(r) > 1250.0 {
            assert_eq!(status.value(r), "failed");
            assert!(
                reason.value(r).starts_with("diverged"),
                "{}",
                reason.value(r)
            );
            assert!(le.is_null(r));
        } else {
            assert_eq!(status.value(r), "ok");
            assert!(reason.is_null(r));
            // Independent check: the synthetic LE maximum is A(Ω)(1 + μ).
            let mu = b
                .column_by_name("friction")
                .unwrap()
                .as_primitive::<Float64Type>()
                .value(r);
            let want = sim.amplitude(speed.value(r)) * (1.0 + mu);
            assert!(
                (le.value(r) - want).abs() <= 1e-15 * want,
                "{} vs {want}",
                le.value(r)
            );
        }
    }
    // Wear profile shape: stations × angles.
    let wear = b.column_by_name("wear_profile_m").unwrap().as_list::<i32>();
    let first = wear.value(0);
    let stations = first.as_list::<i32>();
    assert_eq!(stations.len(), sim.n_stations);
    assert_eq!(stations.value(0).len(), sim.n_angles);
    // Manifest is complete.
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["complete"], serde_json::json!(true));
    assert_eq!(m["summary"]["failed"], serde_json::json!(4));
    // Failed jobs count as finished on resume (no retry), unless asked.
    let c = Counting::new(SyntheticSimulator::default());
    run_sweep(&spec, &opts(&dir, 2), &c).unwrap();
    assert_eq!(c.calls.load(Ordering::SeqCst), 0);
    let mut o = opts(&dir, 2);
    o.retry_failed = true;
    let r = run_sweep(&spec, &o, &c).unwrap();
    assert_eq!((c.calls.load(Ordering::SeqCst), r.failed), (4, 0));
    std::fs::remove_dir_all(dir).unwrap();
}

/// A simulator that panics or returns NaN must not stop the sweep.
struct Faulty;
impl JobSimulator for Faulty {
    fn run(&self, job: &Job, _cancel: &AtomicBool) -> Result<JobResult, String> {
        match job.index % 3 {
            0 => panic!("boom at job {}", job.index),
            1 => {
                let mut r = SyntheticSimulator::default().evaluate(job);
                r.maxima.casing_radial_m = f64::NAN;
                Ok(r)
            }
            _ => Ok(SyntheticSimulator::default().evaluate(job)),
        }
    }
}

#[test]
fn panics_and_non_finite_results_are_recorded_as_failures() {
    let spec = spec();
    let dir = tmp("faulty");
    let s = run_sweep(&spec, &opts(&dir, 2), &Faulty).unwrap();
    assert_eq!(s.ok + s.failed, 20);
    assert_eq!(s.ok, (0..20).filter(|i| i % 3 == 2).count());
    let b = &read_results(&dir.join("results.parquet")).unwrap()[0];
    let reason = b.column_by_name("reason").unwrap().as_string::<i32>();
    assert!(reason.value(0).contains("panicked") && reason.value(0).contains("boom at job 0"));
    assert!(reason.value(1).contains("non-finite") && reason.value(1).contains("casing_radial_m"));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn shard_argument_parsing() {
    use rubscan::sweep::parse_shard;
    assert_eq!(parse_shard("1/4").unwrap(), (1, 4));
    for bad in ["4/4", "1", "a/2", "0/0", "-1/2"] {
        assert!(parse_shard(bad).is_err(), "{bad}");
    }
}

/// Progress within a job (issue #25): the model simulator reports its time steps while a job
/// runs, through the sample recorder, so that its own reports already reach the job's planned
/// steps before the runner counts the finished job; the report does not change the job's
/// result; and the run's step counter ends at the planned steps of the sweep. Built-in impeller
/// in a rigid two-lobe casing, 1000 steps per job, two jobs on two threads.
#[test]
fn step_progress_reaches_the_planned_steps_of_a_small_sweep() {
    let spec = parse_spec(
        &serde_json::json!({
            "name": "step_progress",
            "models": {"impeller": {"builtin": {}}, "casing": {"rigid": {"lobes": 2, "amplitude_m": 1e-4}}},
            "scenario": {"duration_s": 2e-4},
            "numerics": {"time_step_s": 2e-7, "decimation": 10},
            "grid": {"speed": {"unit": "rad_s", "values": [2000.0, 3000.0]}, "friction": [0.1]}
        })
        .to_string(),
    )
    .unwrap();
    let p = plan(&spec).unwrap();
    let per_job = p.steps_per_job.unwrap();
    assert_eq!(per_job, 1000);
    let sim = ModelSimulator::new(&spec).unwrap();
    let cancel = AtomicBool::new(false);
    let counter = AtomicU64::new(0);
    let mut steps = JobSteps::new(per_job, Some(&counter), None);
    let reported = sim.run_reporting(&p.jobs[0], &cancel, &mut steps).unwrap();
    assert_eq!(steps.reported(), per_job, "reported by the job itself");
    assert_eq!(counter.load(Ordering::SeqCst), per_job);
    assert_eq!(reported, sim.run(&p.jobs[0], &cancel).unwrap());

    let dir = tmp("step-progress");
    let o = opts(&dir, 2);
    let summary = run_sweep(&spec, &o, &sim).unwrap();
    assert_eq!((summary.ran, summary.ok), (2, 2));
    assert_eq!(o.counters.steps_done.load(Ordering::SeqCst), 2 * per_job);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A simulator without step reports (the synthetic one) still brings the step counter to the
/// planned steps of the jobs it ran, failed jobs included, when each job is recorded.
#[test]
fn step_counter_counts_finished_jobs_without_reports() {
    let spec = spec();
    let p = plan(&spec).unwrap();
    let dir = tmp("step-counter");
    let o = opts(&dir, 2);
    let sim = SyntheticSimulator {
        fail_above_speed_rad_s: Some(1000.0),
        ..SyntheticSimulator::default()
    };
    let summary = run_sweep(&spec, &o, &sim).unwrap();
    assert!(summary.failed > 0 && summary.ok > 0);
    assert_eq!(
        o.counters.steps_done.load(Ordering::SeqCst),
        p.steps_per_job.unwrap() * p.jobs.len() as u64
    );
    let _ = std::fs::remove_dir_all(&dir);
}
