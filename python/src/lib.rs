//! `rubscan._native`: the rubscan library's commands for Python (the `rubscan` package wraps
//! them). Every long call releases the GIL and runs on a worker thread while the calling
//! thread polls Python's signals, so Ctrl-C in a notebook stops a sweep the way it stops the
//! CLI: no new job starts, finished jobs are kept, and `KeyboardInterrupt` is raised once the
//! sweep has written its table and manifest. Tables cross as Arrow record batches through the
//! Arrow C stream interface (`arrow-pyarrow`), without copying their buffers.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use arrow_array::builder::{BooleanBuilder, Float64Builder, StringBuilder, UInt32Builder};
use arrow_array::{ArrayRef, Float64Array, RecordBatch, UInt32Array};
use arrow_pyarrow::ToPyArrow;
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rubscan::app::{self, AppError, ReportOptions, RunArgs, StabilityRange};
use rubscan::sweep::table::plan_batch;
use rubscan::sweep::{RunCounters, SpecError as RustSpecError, SweepSpec, load_spec, parse_spec};

create_exception!(
    _native,
    RubscanError,
    PyRuntimeError,
    "A rubscan command failed: a model that cannot be built or read, an I/O error, a failed simulation."
);
create_exception!(
    _native,
    SpecError,
    PyValueError,
    "The sweep spec is invalid. `issues` lists (JSON pointer, reason) pairs; `pointer` and `reason` are the first's."
);

/// How often the calling thread looks at Python's signals and the progress callback while a
/// command runs (s): fast enough for Ctrl-C to feel immediate, slow enough to cost nothing.
const POLL: Duration = Duration::from_millis(100);

/// The Python exception of an [`AppError`]: [`SpecError`] with its issues for an invalid spec,
/// `KeyboardInterrupt` for a cancelled command, [`RubscanError`] otherwise.
fn to_py(py: Python<'_>, e: AppError) -> PyErr {
    match e {
        AppError::Invalid(spec) => spec_error(py, &spec),
        AppError::Interrupted => pyo3::exceptions::PyKeyboardInterrupt::new_err("interrupted"),
        e => RubscanError::new_err(e.to_string()),
    }
}

/// [`SpecError`] carrying every issue as `(pointer, reason)`; an unreadable or non-JSON spec
/// has the pointer `""` (the whole document).
fn spec_error(py: Python<'_>, e: &RustSpecError) -> PyErr {
    let issues: Vec<(String, String)> = if e.issues().is_empty() {
        vec![(String::new(), e.to_string())]
    } else {
        (e.issues().iter())
            .map(|i| (i.path.clone(), i.reason.clone()))
            .collect()
    };
    let err = SpecError::new_err(e.to_string());
    let value = err.value(py);
    let first = issues[0].clone();
    // Setting attributes on a fresh exception instance cannot fail.
    let _ = value.setattr("issues", issues);
    let _ = value.setattr("pointer", first.0);
    let _ = value.setattr("reason", first.1);
    err
}

/// A sweep spec, parsed and checked against the schema and the semantic rules; its relative
/// model paths are resolved against the spec file's folder (or `base_dir` for JSON text).
#[pyclass(module = "rubscan._native", frozen)]
struct Spec {
    spec: SweepSpec,
}

#[pymethods]
impl Spec {
    /// Reads and checks a spec file.
    #[staticmethod]
    fn from_path(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let spec = load_spec(&path).map_err(|e| spec_error(py, &e))?;
        Ok(Spec { spec })
    }

    /// Parses and checks a spec given as JSON text; relative paths in it are read from
    /// `base_dir`.
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str, base_dir: PathBuf) -> PyResult<Self> {
        let mut spec = parse_spec(text).map_err(|e| spec_error(py, &e))?;
        spec.resolve_paths(&base_dir);
        Ok(Spec { spec })
    }

    /// The sweep's name (its default output folder is `results/<name>`).
    #[getter]
    fn name(&self) -> &str {
        &self.spec.name
    }

    fn __repr__(&self) -> String {
        format!("Spec(name={:?})", self.spec.name)
    }
}

/// Runs `work` on a worker thread with the GIL released. Meanwhile, every [`POLL`], the
/// calling thread checks Python's signals (a `KeyboardInterrupt` sets `cancel`, then the
/// call waits for `work` to stop cleanly and raises it) and calls `tick`.
fn interruptible<T: Send>(
    py: Python<'_>,
    cancel: &AtomicBool,
    mut tick: impl FnMut(Python<'_>) -> PyResult<()>,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    std::thread::scope(|scope| {
        let handle = scope.spawn(work);
        let mut interrupt = None;
        let mut tick_error = None;
        while !handle.is_finished() {
            py.detach(|| std::thread::sleep(POLL));
            if interrupt.is_none()
                && let Err(e) = py.check_signals()
            {
                cancel.store(true, Ordering::SeqCst);
                interrupt = Some(e);
            }
            if tick_error.is_none()
                && let Err(e) = tick(py)
            {
                // A broken progress display must not stop the sweep; it is raised at the end.
                tick_error = Some(e);
            }
        }
        let out = py.detach(|| handle.join());
        let out = out.map_err(|_| RubscanError::new_err("the worker thread panicked"))?;
        match (interrupt, tick_error) {
            (Some(e), _) | (None, Some(e)) => Err(e),
            (None, None) => Ok(out),
        }
    })
}

/// The jobs of a sweep after checking the whole spec with its models: the results table's
/// parameter columns (`job_index` … `refinement_round`, units as field metadata), a row per job.
#[pyfunction]
fn plan<'py>(py: Python<'py>, spec: &Spec) -> PyResult<Bound<'py, PyAny>> {
    let plan = py
        .detach(|| app::checked_plan(&spec.spec))
        .map_err(|e| to_py(py, e))?;
    let batch = plan_batch(&plan).map_err(|e| RubscanError::new_err(format!("{e:#}")))?;
    batch.to_pyarrow(py)
}

/// Runs (or resumes) a sweep into `output_dir` (default `results/<name>`) on `threads`
/// workers (None or 0: all cores). `progress(jobs_finished, jobs_queued, steps_done)` is
/// called from this thread about ten times a second. Returns the run's summary (counts,
/// wall time in s, the results table's path).
#[pyfunction]
#[pyo3(signature = (spec, threads=None, output_dir=None, retry_failed=false, timeseries=false, progress=None))]
fn run<'py>(
    py: Python<'py>,
    spec: &Spec,
    threads: Option<usize>,
    output_dir: Option<PathBuf>,
    retry_failed: bool,
    timeseries: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let counters = Arc::new(RunCounters::default());
    let args = RunArgs {
        threads: Some(threads.unwrap_or(0)),
        output: output_dir,
        retry_failed,
        timeseries,
        counters: counters.clone(),
        ..RunArgs::default()
    };
    let tick = |_: Python<'_>| -> PyResult<()> {
        if let Some(p) = &progress {
            p.call1((
                counters.jobs_finished.load(Ordering::SeqCst),
                counters.jobs_queued.load(Ordering::SeqCst),
                counters.steps_done.load(Ordering::SeqCst),
            ))?;
        }
        Ok(())
    };
    let summary = interruptible(py, &args.cancel, tick, || app::run(&spec.spec, &args))?
        .map_err(|e| to_py(py, e))?;
    tick(py)?;
    let out = PyDict::new(py);
    out.set_item("planned", summary.planned)?;
    out.set_item("ran", summary.ran)?;
    out.set_item("skipped", summary.skipped)?;
    out.set_item("ok", summary.ok)?;
    out.set_item("unstable", summary.unstable)?;
    out.set_item("failed", summary.failed)?;
    out.set_item("unfinished", summary.unfinished)?;
    out.set_item("cancelled", summary.cancelled)?;
    out.set_item("wall_time_s", summary.wall_time_s)?;
    out.set_item("results_path", summary.results_path)?;
    if summary.cancelled {
        return Err(pyo3::exceptions::PyKeyboardInterrupt::new_err(
            "interrupted: finished jobs are kept; run again to resume",
        ));
    }
    Ok(out)
}

/// Runs job `job` of a sweep's plan and writes `timeseries.parquet` and `summary.json` to
/// `output_dir` (default `results/<name>/simulate-<job>`), as `rubscan simulate` does.
/// Returns the output folder.
#[pyfunction]
#[pyo3(signature = (spec, job=0, output_dir=None))]
fn simulate(
    py: Python<'_>,
    spec: &Spec,
    job: usize,
    output_dir: Option<PathBuf>,
) -> PyResult<PathBuf> {
    let cancel = AtomicBool::new(false);
    let dir = interruptible(
        py,
        &cancel,
        |_| Ok(()),
        || app::simulate(&spec.spec, job, output_dir.as_deref(), &cancel),
    )?;
    dir.map_err(|e| to_py(py, e))
}

/// A flexible casing's critical wave speed (rad/s) and its nodal diameter.
type WaveSpeed = Option<(f64, usize)>;

/// The linear interaction criterion's critical speeds Ω*_n (rad/s) of a sweep's models, with
/// the nodal diameter n and the modes' spatial compatibility; and the flexible casing's
/// critical wave speed (rad/s, nodal diameter) or None.
#[pyfunction]
fn critical_speeds<'py>(py: Python<'py>, spec: &Spec) -> PyResult<(Bound<'py, PyAny>, WaveSpeed)> {
    let found = py
        .detach(|| app::critical_speeds(&spec.spec))
        .map_err(|e| to_py(py, e))?;
    let speeds = &found.speeds;
    let batch = RecordBatch::try_from_iter([
        (
            "speed_rad_s",
            Arc::new(
                speeds
                    .iter()
                    .map(|c| c.speed_rad_s)
                    .collect::<Float64Array>(),
            ) as ArrayRef,
        ),
        (
            "speed_rpm",
            Arc::new(
                (speeds.iter())
                    .map(|c| c.speed_rad_s * 30.0 / std::f64::consts::PI)
                    .collect::<Float64Array>(),
            ),
        ),
        (
            "nodal_diameter",
            Arc::new(
                speeds
                    .iter()
                    .map(|c| c.nodal_diameter)
                    .collect::<UInt32Array>(),
            ),
        ),
        (
            "compatibility",
            Arc::new(
                speeds
                    .iter()
                    .map(|c| c.compatibility)
                    .collect::<Float64Array>(),
            ),
        ),
    ])
    .map_err(|e| RubscanError::new_err(e.to_string()))?;
    Ok((batch.to_pyarrow(py)?, found.critical_wave_speed))
}

/// The linear stability of a persistent rub over `count` speeds from `from_rad_s` to
/// `to_rad_s` (defaults as `rubscan stability`), per friction coefficient of the grid. Returns
/// a table with one row per (friction, speed): the most unstable counted wave's growth rate
/// (1/s), fixed-frame frequency (Hz), nodal diameters and sense; and a dict with the
/// predicted onset per friction (rad/s, None when nothing grows), the casing's critical wave
/// speed and the interaction criterion's Ω*_n in the range.
#[pyfunction]
#[pyo3(signature = (spec, from_rad_s=None, to_rad_s=None, count=41))]
fn stability<'py>(
    py: Python<'py>,
    spec: &Spec,
    from_rad_s: Option<f64>,
    to_rad_s: Option<f64>,
    count: usize,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let range = StabilityRange {
        from: from_rad_s,
        to: to_rad_s,
        count,
    };
    let p = py
        .detach(|| app::stability_prediction(&spec.spec, range))
        .map_err(|e| to_py(py, e))?;
    let mut friction = Float64Builder::new();
    let mut speed = Float64Builder::new();
    let mut stable = BooleanBuilder::new();
    let mut growth = Float64Builder::new();
    let mut freq = Float64Builder::new();
    let mut nd = UInt32Builder::new();
    let mut nd_imp = UInt32Builder::new();
    let mut backward = BooleanBuilder::new();
    for f in &p.per_friction {
        for at in &f.speeds {
            friction.append_value(f.friction);
            speed.append_value(at.omega_rad_s);
            stable.append_value(at.is_stable());
            let w = at.most_unstable();
            growth.append_option(w.map(|w| w.growth_rate_per_s));
            freq.append_option(w.map(|w| w.frequency_hz));
            nd.append_option(w.map(|w| w.nodal_diameter as u32));
            nd_imp.append_option(w.map(|w| w.impeller_nodal_diameter as u32));
            backward.append_option(w.map(|w| w.backward));
        }
    }
    let mut sense = StringBuilder::new();
    for b in backward.finish().iter() {
        sense.append_option(b.map(|b| if b { "backward" } else { "forward" }));
    }
    let batch = RecordBatch::try_from_iter([
        ("friction", Arc::new(friction.finish()) as ArrayRef),
        ("speed_rad_s", Arc::new(speed.finish())),
        ("stable", Arc::new(stable.finish())),
        ("growth_rate_per_s", Arc::new(growth.finish())),
        ("frequency_hz", Arc::new(freq.finish())),
        ("nodal_diameter", Arc::new(nd.finish())),
        ("impeller_nodal_diameter", Arc::new(nd_imp.finish())),
        ("wave", Arc::new(sense.finish())),
    ])
    .map_err(|e| RubscanError::new_err(e.to_string()))?;
    let info = PyDict::new(py);
    let onsets = PyDict::new(py);
    for f in &p.per_friction {
        onsets.set_item(f.friction, f.onset_rad_s)?;
    }
    info.set_item("onset_rad_s", onsets)?;
    info.set_item("critical_wave_speed", p.critical_wave_speed)?;
    info.set_item("interaction_rad_s", p.interaction)?;
    Ok((batch.to_pyarrow(py)?, info))
}

/// Writes the report of a results folder (figures and `index.html`, in `output_dir`, default
/// `<results>/report`) and returns the path of `index.html`.
#[pyfunction]
#[pyo3(signature = (results, output_dir=None, jobs=None, max_jobs=app::DEFAULT_REPORT_JOBS))]
fn report(
    py: Python<'_>,
    results: PathBuf,
    output_dir: Option<PathBuf>,
    jobs: Option<Vec<usize>>,
    max_jobs: usize,
) -> PyResult<PathBuf> {
    let options = ReportOptions {
        output_dir,
        jobs: jobs.unwrap_or_default(),
        max_jobs,
    };
    let r = py
        .detach(|| rubscan::sweep::report::write_report(&results, &options))
        .map_err(|e| RubscanError::new_err(e.to_string()))?;
    Ok(r.index)
}

/// The version of the rubscan library this module was built from.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("RubscanError", py.get_type::<RubscanError>())?;
    m.add("SpecError", py.get_type::<SpecError>())?;
    m.add_class::<Spec>()?;
    m.add_function(wrap_pyfunction!(plan, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(critical_speeds, m)?)?;
    m.add_function(wrap_pyfunction!(stability, m)?)?;
    m.add_function(wrap_pyfunction!(report, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    m.add("DEFAULT_REPORT_JOBS", app::DEFAULT_REPORT_JOBS)?;
    Ok(())
}
