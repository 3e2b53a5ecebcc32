//! Refinement of Ω end to end (`grid.speed.refine`): the runner's rounds locate a runaway's
//! onset and a response peak to the tolerance with far fewer jobs than a uniform grid of the
//! same resolution, and write the same table whatever the thread count, the sharding, or a
//! kill and resume in the middle of a round. The jobs are analytic (known onset and peak),
//! so that what is tested is the planning, not the physics.

use crate::common;
use common::table_without_timing;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use arrow_array::RecordBatch;
use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, UInt32Type};
use rubscan::dynamics::runaway::Runaway;
use rubscan::sweep::slurm::shard_dir;
use rubscan::sweep::table::read_results;
use rubscan::sweep::{Job, JobResult, JobSimulator, RunOptions, SweepSpec, merge, parse_spec};

/// Onset of the runaway (rad/s) and speed of the response peak (rad/s), neither on the grid.
const ONSET: f64 = 1013.7;
const PEAK: f64 = 913.3;

/// Analytic jobs: a Lorentzian response peaking at [`PEAK`], unstable above [`ONSET`];
/// optionally raises the cancel flag during its k-th call (a kill in the middle of a round).
struct Analytic {
    calls: AtomicUsize,
    cancel_at: Option<(usize, Arc<AtomicBool>)>,
}

impl Analytic {
    fn new() -> Self {
        Self {
            calls: AtomicUsize::new(0),
            cancel_at: None,
        }
    }
}

impl JobSimulator for Analytic {
    fn run(&self, job: &Job, _cancel: &AtomicBool) -> Result<JobResult, String> {
        let n = self.calls.fetch_add(1, Ordering::SeqCst) + 1;
        if let Some((k, flag)) = &self.cancel_at
            && n == *k
        {
            flag.store(true, Ordering::SeqCst);
        }
        let w = job.params.speed_rad_s;
        let mut r = JobResult::default();
        r.maxima.blade_te_radial_m = 1e-4 / (1.0 + ((w - PEAK) / 40.0).powi(2));
        r.runaway = (w > ONSET).then_some(Runaway {
            onset_time_s: 4e-3,
            detected_time_s: 6e-3,
            growth_rate_per_s: w - ONSET,
            growth_fit_r2: 0.95,
            energy_growth: 10.0,
            drive_work_j: 1e4,
            nodal_diameter: Some(5),
            frequency_hz: Some(3800.0),
            forward: Some(true),
            rotating_frame_frequency_hz: Some(-10.0),
            at_solve_breakdown: false,
        });
        Ok(r)
    }
}

/// A scan of 9 speeds over 0.8–1.2 × 1000 rad/s refined to `tolerance` rad/s.
fn spec(tolerance: f64, peak: bool) -> SweepSpec {
    let mut refine = serde_json::json!({"tolerance_rad_s": tolerance, "max_jobs": 12});
    if peak {
        refine["peak_of"] = "max_blade_te_radial_m".into();
    }
    parse_spec(
        &serde_json::json!({
            "name": "refinement_test",
            "models": {"impeller": {"builtin": {}}, "casing": {"rigid": {"lobes": 2, "amplitude_m": 1e-4}}},
            "scenario": {"duration_s": 0.01},
            "numerics": {"time_step_s": 1e-5},
            "grid": {
                "speed": {"unit": "rad_s", "range": {"start": 800.0, "stop": 1200.0, "count": 9},
                          "refine": refine},
                "friction": [0.15]
            }
        })
        .to_string(),
    )
    .unwrap()
}

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rubscan-refine-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn opts(dir: &Path, threads: usize) -> RunOptions {
    let mut o = RunOptions::new(dir);
    o.threads = threads;
    o
}

/// The (Ω, status, round) rows of a table, in table order.
fn rows(t: &[RecordBatch]) -> Vec<(f64, String, u32)> {
    t.iter()
        .flat_map(|b| {
            let w = b
                .column_by_name("speed_rad_s")
                .unwrap()
                .as_primitive::<Float64Type>();
            let s = b.column_by_name("status").unwrap().as_string::<i32>();
            let r = b.column_by_name("refinement_round").unwrap();
            let r = r.as_primitive::<UInt32Type>();
            (0..b.num_rows())
                .map(|i| (w.value(i), s.value(i).to_string(), r.value(i)))
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The closest ok and unstable speeds around the onset.
fn bracket(rows: &[(f64, String, u32)]) -> (f64, f64) {
    let ok = rows
        .iter()
        .filter(|r| r.1 == "ok")
        .map(|r| r.0)
        .fold(f64::MIN, f64::max);
    let unstable = (rows.iter().filter(|r| r.1 == "unstable"))
        .map(|r| r.0)
        .fold(f64::MAX, f64::min);
    (ok, unstable)
}

#[test]
fn the_onset_is_bracketed_to_half_a_percent_with_a_quarter_of_the_uniform_jobs() {
    let tolerance = 0.005 * ONSET;
    let dir = tmp("onset");
    let summary =
        rubscan::sweep::run_sweep(&spec(tolerance, false), &opts(&dir, 2), &Analytic::new())
            .unwrap();
    let rows = rows(&read_results(&dir.join("results.parquet")).unwrap());
    let (ok, unstable) = bracket(&rows);
    println!(
        "{} jobs; onset bracketed in [{ok}, {unstable}] rad/s",
        rows.len()
    );
    assert!(
        ok < ONSET && ONSET < unstable && unstable - ok <= tolerance,
        "{ok} {unstable}"
    );
    // A uniform grid of that resolution over the band.
    let uniform = (400.0 / tolerance).ceil() as usize + 1;
    assert!(
        4 * rows.len() <= uniform,
        "{} jobs against {uniform}",
        rows.len()
    );
    assert_eq!(
        (summary.unstable + summary.ok, summary.failed),
        (rows.len(), 0)
    );
    assert!(rows.iter().any(|r| r.2 > 1), "refined in several rounds");
}

#[test]
fn a_response_peak_is_located_to_the_tolerance() {
    let tolerance = 2.0;
    let dir = tmp("peak");
    rubscan::sweep::run_sweep(&spec(tolerance, true), &opts(&dir, 2), &Analytic::new()).unwrap();
    let t = read_results(&dir.join("results.parquet")).unwrap();
    let te: Vec<f64> = t
        .iter()
        .flat_map(|b| {
            let c = b.column_by_name("max_blade_te_radial_m").unwrap();
            c.as_primitive::<Float64Type>().values().to_vec()
        })
        .collect();
    let rows = rows(&t);
    let best = (0..rows.len())
        .filter(|&i| rows[i].1 == "ok")
        .max_by(|&a, &b| te[a].total_cmp(&te[b]))
        .unwrap();
    println!("{} jobs; best speed {} rad/s", rows.len(), rows[best].0);
    assert!((rows[best].0 - PEAK).abs() <= tolerance, "{}", rows[best].0);
    // And the onset as well, in the same rounds.
    let (ok, unstable) = bracket(&rows);
    assert!(ok < ONSET && ONSET < unstable && unstable - ok <= tolerance);
}

#[test]
fn the_refined_table_is_the_same_whatever_threads_shards_or_a_kill_in_a_round() {
    let spec = spec(5.0, true);
    let one = tmp("one");
    rubscan::sweep::run_sweep(&spec, &opts(&one, 1), &Analytic::new()).unwrap();
    let reference = table_without_timing(&one);
    assert!(rows(&reference).iter().any(|r| r.2 >= 2));

    let two = tmp("two");
    rubscan::sweep::run_sweep(&spec, &opts(&two, 2), &Analytic::new()).unwrap();
    assert_eq!(table_without_timing(&two), reference, "two threads");

    // Killed in round 1 (during its first job, the 10th), then resumed.
    let killed = tmp("killed");
    let flag = Arc::new(AtomicBool::new(false));
    let mut o = opts(&killed, 1);
    o.cancel = flag.clone();
    let sim = Analytic {
        calls: AtomicUsize::new(0),
        cancel_at: Some((10, flag.clone())),
    };
    let first = rubscan::sweep::run_sweep(&spec, &o, &sim).unwrap();
    assert!(first.cancelled && first.unfinished > 0, "{first:?}");
    rubscan::sweep::run_sweep(&spec, &opts(&killed, 1), &Analytic::new()).unwrap();
    assert_eq!(
        table_without_timing(&killed),
        reference,
        "killed and resumed"
    );

    // Two shards, each run again until neither has anything left (successive arrays), merged.
    let base = tmp("shards");
    let dirs: Vec<PathBuf> = (0..2).map(|i| shard_dir(&base, i, 2)).collect();
    loop {
        let mut ran = 0;
        for (i, d) in dirs.iter().enumerate() {
            let mut o = opts(d, 1);
            o.shard = Some((i, 2));
            ran += rubscan::sweep::run_sweep(&spec, &o, &Analytic::new())
                .unwrap()
                .ran;
        }
        if ran == 0 {
            break;
        }
    }
    let merged = base.join("merged");
    let m = merge(&dirs, &merged).unwrap();
    assert!(m.missing.is_empty(), "{m:?}");
    assert_eq!(
        table_without_timing(&merged),
        reference,
        "two shards merged"
    );
}
