//! End-to-end behaviour of the `rubscan` binary on small built-in models: a simulation's
//! Parquet time series, clear errors on bad specs, and a sweep killed with SIGKILL then
//! resumed giving the table of an uninterrupted run.

use crate::common;
use common::{rubscan, stderr, table_without_timing};

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const SMALL: &str = "tests/data/small_sweep.json";

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rubscan-cli-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn simulate_writes_documented_time_series() {
    let out = tmp("sim");
    let st = rubscan()
        .args(["simulate", SMALL, "--job", "1", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let file = std::fs::File::open(out.join("timeseries.parquet")).unwrap();
    let reader =
        parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file).unwrap();
    let schema = reader.schema().clone();
    for name in [
        "time_s",
        "blade0_le_radial_m",
        "blade3_te_radial_m",
        "casing_probe0_radial_m",
        "blade0_normal_force_n",
        "min_gap_m",
        "drive_work_j",
    ] {
        let f = schema
            .field_with_name(name)
            .unwrap_or_else(|_| panic!("column {name} missing"));
        assert!(f.metadata().contains_key("unit"), "{name} has no unit");
    }
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["n_steps"], 10_000);
    // The two-lobe load pushes the casing 0.8 mm in against a 0.5 mm clearance: contact happens
    // and moves the blades (the residual-penetration criterion is checked in the dynamics tests).
    assert!(summary["contact_steps"].as_u64().unwrap() > 0);
    let level = summary["max_blade_radial_m"].as_f64().unwrap();
    assert!(level > 0.0 && level < 5e-4, "blade level {level} m");
    std::fs::remove_dir_all(&out).unwrap();
}

/// `scenario.probes` reach `simulate`'s time series: one column per probe, named by node
/// and component, with its unit; the radial displacement of blade 0's row 0 equals the
/// built-in leading-edge column.
#[test]
fn simulate_writes_the_probe_columns_of_the_spec() {
    use arrow_array::Float64Array;
    let dir = tmp("simprobes");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = small_with(&dir, "probes", |v| {
        v["scenario"]["probes"] = serde_json::json!([
            {"blade": 0, "row": 0, "quantity": "displacement", "component": "radial"},
            {"blade": 1, "row": 0, "quantity": "gap"},
            {"blade": 1, "row": 0, "quantity": "normal_force"},
            {"sector": 3, "row": 0, "quantity": "displacement", "component": "axial"},
            {"point": "leading_edge_mid_span", "quantity": "displacement", "component": "tangential"},
            {"point": "trailing_edge_mid_span", "blade": 2, "quantity": "displacement", "component": "axial"},
            {"point": "outer_mid_meridian", "sector": 3, "quantity": "displacement", "component": "radial"}
        ])
    });
    let out = dir.join("out");
    let st = rubscan()
        .args(["simulate"])
        .arg(&spec)
        .args(["--job", "1", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let file = std::fs::File::open(out.join("timeseries.parquet")).unwrap();
    let reader =
        parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file).unwrap();
    let schema = reader.schema().clone();
    for (name, unit) in [
        ("blade0_row0_radial_m", "m"),
        ("blade1_row0_gap_m", "m"),
        ("blade1_row0_normal_force_n", "N"),
        ("casing3_row0_axial_m", "m"),
        ("leading_edge_mid_span_tangential_m", "m"),
        ("blade2_trailing_edge_mid_span_axial_m", "m"),
        ("casing3_outer_mid_meridian_radial_m", "m"),
    ] {
        let f = schema
            .field_with_name(name)
            .unwrap_or_else(|_| panic!("column {name} missing"));
        assert_eq!(f.metadata()["unit"], unit, "{name}");
    }
    let column = |name: &str| -> Vec<f64> {
        let i = schema.index_of(name).unwrap();
        let file = std::fs::File::open(out.join("timeseries.parquet")).unwrap();
        parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file)
            .unwrap()
            .build()
            .unwrap()
            .flat_map(|b| {
                let b = b.unwrap();
                let c = b.column(i).as_any().downcast_ref::<Float64Array>().unwrap();
                c.values().to_vec()
            })
            .collect()
    };
    let le = column("blade0_le_radial_m");
    assert!(le.iter().any(|x| *x != 0.0));
    assert_eq!(column("blade0_row0_radial_m"), le);
    // The built-in models' named nodes move (recovered from the ROM state).
    for name in [
        "leading_edge_mid_span_tangential_m",
        "blade2_trailing_edge_mid_span_axial_m",
        "casing3_outer_mid_meridian_radial_m",
    ] {
        let v = column(name);
        assert!(
            v.iter().all(|x| x.is_finite()) && v.iter().any(|x| *x != 0.0),
            "{name}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_specs_fail_with_the_json_path_and_write_nothing() {
    let dir = tmp("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let good: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(SMALL).unwrap()).unwrap();
    let mut negative = good.clone();
    negative["grid"]["friction"] = serde_json::json!([-0.1]);
    let mut unknown = good.clone();
    unknown["scenario"]["load_amplitud_m"] = serde_json::json!(1e-4);
    let mut too_big_step = good.clone();
    too_big_step["numerics"]["time_step_s"] = serde_json::json!(1e-4);
    let cases: [(&str, String, &str); 4] = [
        ("syntax", "{ \"name\": ".into(), "line"),
        ("negative", negative.to_string(), "/grid/friction/0"),
        ("unknown", unknown.to_string(), "load_amplitud_m"),
        ("unstable", too_big_step.to_string(), "stability limit"),
    ];
    for (tag, text, expect) in cases {
        let path = dir.join(format!("{tag}.json"));
        std::fs::write(&path, text).unwrap();
        let out = dir.join(format!("out-{tag}"));
        let st = rubscan()
            .arg("simulate")
            .arg(&path)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&st.stderr);
        assert!(!st.status.success(), "{tag} accepted");
        assert!(err.contains(expect), "{tag}: {err}");
        assert!(!out.exists(), "{tag}: output written");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

fn job_files(dir: &Path) -> usize {
    std::fs::read_dir(dir.join("jobs")).map_or(0, |d| {
        d.filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "json")
        })
        .count()
    })
}

/// "N ran, M skipped" from the runner's last line.
fn ran_and_skipped(stderr: &str) -> (usize, usize) {
    let line = stderr
        .lines()
        .rev()
        .find(|l| l.contains(" ran, "))
        .expect("summary line");
    let num = |key: &str| {
        let before = &line[..line.find(key).unwrap()];
        before.split_whitespace().last().unwrap().parse().unwrap()
    };
    (num(" ran"), num(" skipped"))
}

#[test]
fn sigkill_then_resume_equals_an_uninterrupted_run() {
    let (killed, full) = (tmp("killed"), tmp("full"));
    let st = rubscan()
        .args(["run", SMALL, "--threads", "1", "-o"])
        .arg(&full)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let planned = job_files(&full);
    assert_eq!(planned, 6);

    let mut child = rubscan()
        .args(["run", SMALL, "--threads", "1", "-o"])
        .arg(&killed)
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while job_files(&killed) < 2 && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
    let done_before = job_files(&killed);
    assert!(
        (2..planned).contains(&done_before),
        "kill landed after {done_before} jobs"
    );

    let st = rubscan()
        .args(["run", SMALL, "--threads", "2", "-o"])
        .arg(&killed)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&st.stderr);
    assert!(st.status.success(), "{err}");
    assert_eq!(
        ran_and_skipped(&err),
        (planned - done_before, done_before),
        "{err}"
    );
    assert_eq!(
        table_without_timing(&killed),
        table_without_timing(&full),
        "resumed table differs"
    );
    for d in [killed, full] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

/// The small spec as JSON, edited by `f`, written to `dir/<tag>.json`.
fn small_with(dir: &Path, tag: &str, f: impl FnOnce(&mut serde_json::Value)) -> PathBuf {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(SMALL).unwrap()).unwrap();
    f(&mut v);
    let path = dir.join(format!("{tag}.json"));
    std::fs::write(&path, v.to_string()).unwrap();
    path
}

/// `rubscan run <spec> -o <out>`: its exit status and stderr.
fn run_to(spec: &Path, out: &Path) -> (Option<i32>, String) {
    let st = rubscan()
        .arg("run")
        .arg(spec)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap();
    (
        st.status.code(),
        String::from_utf8_lossy(&st.stderr).into_owned(),
    )
}

/// An edit of the small sweep's JSON.
type Edit = fn(&mut serde_json::Value);

/// The invalid specs of [`invalid_specs_exit_1_fast_naming_path_and_reason_and_write_nothing`]:
/// a tag, the edit of the small sweep that breaks it, and what the error must say.
fn invalid_spec_cases() -> [(&'static str, Edit, &'static [&'static str]); 18] {
    [
        (
            "probe_typo",
            |v| v["scenario"]["probes"] = serde_json::json!([{"nod": 5, "quantity": "gap"}]),
            &[
                "/scenario/probes/0",
                "unknown field `nod`",
                "did you mean `node`",
            ],
        ),
        (
            "probe_row_missing",
            |v| {
                v["scenario"]["probes"] = serde_json::json!([
                    {"blade": 0, "row": 0, "quantity": "gap"},
                    {"blade": 0, "row": 99, "quantity": "normal_force"}
                ])
            },
            &["/scenario/probes/1/row", "99 does not exist"],
        ),
        (
            "probe_node_missing",
            |v| {
                v["scenario"]["probes"] = serde_json::json!([{"node": 1353, "quantity": "displacement", "component": "y"}])
            },
            &["/scenario/probes/0/node", "not a recovery node"],
        ),
        (
            "probe_point_unknown",
            |v| v["scenario"]["probes"] = serde_json::json!([{"point": "outer_mid_meridian", "quantity": "displacement", "component": "y"}]),
            &[
                "/scenario/probes/0/point",
                "not a named node of the impeller",
                "leading_edge_mid_span",
            ],
        ),
        (
            "scenario_typo",
            |v| v["scenario"]["load_amplitud_m"] = serde_json::json!(1e-4),
            &[
                "/scenario",
                "load_amplitud_m",
                "did you mean `load_amplitude_m`",
            ],
        ),
        (
            "numerics_typo",
            |v| v["numerics"]["decimaton"] = serde_json::json!(5),
            &["/numerics", "decimaton", "did you mean `decimation`"],
        ),
        (
            "decimation_0",
            |v| v["numerics"]["decimation"] = serde_json::json!(0),
            &["/numerics/decimation", "minimum of 1"],
        ),
        (
            "probe_outside",
            |v| v["scenario"]["casing_probes"] = serde_json::json!([[0, 4], [12, 0]]),
            &["/scenario/casing_probes/1", "does not exist", "12 sectors"],
        ),
        (
            "unstable_step",
            |v| v["numerics"]["time_step_s"] = serde_json::json!(1e-4),
            &["/numerics/time_step_s", "stability limit"],
        ),
        (
            "huge_friction",
            |v| v["grid"]["friction"] = serde_json::json!([0.1, 1e6]),
            &["/grid/friction/1", "maximum of 2"],
        ),
        (
            "speed_above_range",
            |v| v["grid"]["speed"]["values"] = serde_json::json!([1500, 20000]),
            &["/grid/speed/values/1", "valid speed range", "20000"],
        ),
        (
            "lobes_on_rigid",
            |v| {
                v["models"]["casing"] =
                    serde_json::json!({"rigid": {"lobes": 2, "amplitude_m": 1e-4}});
                let sc = v["scenario"].as_object_mut().unwrap();
                sc.remove("load_amplitude_m");
                sc.remove("load_ramp_s");
                sc.remove("casing_probes");
            },
            &["/scenario/lobes", "flexible casing only"],
        ),
        (
            // 10⁹ jobs: refused before any of them is allocated.
            "grid_too_large",
            |v| {
                let many: Vec<f64> = (0..1000).map(|i| 1e-4 * f64::from(i)).collect();
                v["grid"]["friction"] = serde_json::json!(many);
                v["grid"]["clearance_m"] = serde_json::json!(many[1..].to_vec());
                v["grid"]["coating"] = serde_json::json!({"young": {"scale": many[1..]}});
            },
            &["/grid", "jobs, more than the 100000"],
        ),
        (
            // 10 m: meant as mm; the job would diverge at its first contact.
            "load_far_too_large",
            |v| v["scenario"]["load_amplitude_m"] = serde_json::json!(10.0),
            &[
                "/scenario/load_amplitude_m",
                "blade-tip radius",
                "unit mistake",
            ],
        ),
        (
            // The small casing has 12 sectors: 7 lobes would load it on 5.
            "lobes_alias",
            |v| v["scenario"]["lobes"] = serde_json::json!(7),
            &["/scenario/lobes", "12 sectors", "at most 6"],
        ),
        (
            "coating_elements_too_many",
            |v| v["scenario"]["coating"] = serde_json::json!({"eta": 4_000_000_000u64}),
            &["/scenario/coating/eta", "maximum of 1000000"],
        ),
        (
            "step_far_too_small",
            |v| v["numerics"]["time_step_s"] = serde_json::json!(1e-300),
            &["/numerics/time_step_s", "steps per job", "1e9"],
        ),
        (
            "duration_far_too_long",
            |v| v["scenario"]["duration_s"] = serde_json::json!(1e300),
            &["/scenario/duration_s", "steps per job", "1e9"],
        ),
    ]
}

/// Each invalid spec is refused by `plan` and `run` with exit status 1 within 5 s, its
/// stderr names the JSON path or field and the reason, and no output directory appears.
#[test]
fn invalid_specs_exit_1_fast_naming_path_and_reason_and_write_nothing() {
    let dir = tmp("invalid");
    std::fs::create_dir_all(&dir).unwrap();
    // Warm the model cache (a fresh machine builds the small models once, in seconds).
    let warm = rubscan().args(["plan", SMALL]).output().unwrap();
    assert!(
        warm.status.success(),
        "{}",
        String::from_utf8_lossy(&warm.stderr)
    );
    for (tag, edit, expect) in invalid_spec_cases() {
        let spec = small_with(&dir, tag, edit);
        for cmd in ["plan", "run"] {
            let out = dir.join(format!("out-{tag}-{cmd}"));
            let start = Instant::now();
            let mut c = rubscan();
            c.arg(cmd).arg(&spec);
            if cmd == "run" {
                c.arg("-o").arg(&out);
            }
            let st = c.output().unwrap();
            let elapsed = start.elapsed();
            let err = String::from_utf8_lossy(&st.stderr);
            assert_eq!(st.status.code(), Some(1), "{tag} {cmd}: {err}");
            assert!(elapsed < Duration::from_secs(5), "{tag} {cmd}: {elapsed:?}");
            for e in expect {
                assert!(err.contains(e), "{tag} {cmd}: {e:?} not in {err}");
            }
            assert!(!out.exists(), "{tag} {cmd}: output written");
        }
    }
    // The default output directory (results/<name>) is not created either.
    assert!(
        !Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("results/small")
            .exists()
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The small sweep, 0.5 ms at one speed and friction, with `coating` as its grid's coating axes.
fn small_coated(dir: &Path, tag: &str, coating: serde_json::Value) -> PathBuf {
    small_with(dir, tag, |v| {
        v["scenario"]["duration_s"] = serde_json::json!(0.0005);
        v["scenario"]["load_ramp_s"] = serde_json::json!(0.0002);
        v["grid"]["speed"]["values"] = serde_json::json!([2000]);
        v["grid"]["friction"] = serde_json::json!([0.1]);
        v["grid"]["coating"] = coating;
    })
}

/// `rubscan run spec -o out` is refused before any job runs: exit status 1, every one of
/// `expect` in its message, and nothing written; `plan` and `slurm` refuse it the same way
/// (a plan or an array script that `run` would refuse is no plan).
fn assert_run_refused(spec: &Path, out: &Path, expect: &[&str]) {
    let (code, err) = run_to(spec, out);
    let plan = rubscan().arg("plan").arg(spec).output().unwrap();
    let slurm = rubscan()
        .args(["slurm", "--tasks", "2", "-o"])
        .arg(out)
        .arg(spec)
        .output()
        .unwrap();
    for (cmd, code, err) in [
        ("run", code, err),
        ("plan", plan.status.code(), stderr(&plan)),
        ("slurm", slurm.status.code(), stderr(&slurm)),
    ] {
        assert_eq!(code, Some(1), "{cmd}: {err}");
        for e in expect {
            assert!(err.contains(e), "{cmd}: {e:?} not in {err}");
        }
        assert!(!out.exists(), "{cmd}: output written: {err}");
    }
}

/// A coating so thick that the clearance to its unworn surface would take the tips off the
/// casing, at a grid point that is not the stiffest coating, is refused by `run` before any job
/// runs, naming the grid field, the job and the reason. (Its job would fail at its start, its
/// tips' projections lost.)
#[test]
fn a_coating_too_thick_for_the_casing_is_refused_before_any_job_runs() {
    let dir = tmp("thickcoating");
    std::fs::create_dir_all(&dir).unwrap();
    let axis = serde_json::json!({"thickness": {"values": [0.002, 0.5]}});
    let spec = small_coated(&dir, "spec", axis);
    let expect = ["/grid/coating/thickness", "job 1", "off the casing"];
    assert_run_refused(&spec, &dir.join("out"), &expect);
    // The scenario's thickness, with the grid varying another property: the scenario's field.
    let spec = small_with(&dir, "scenario", |v| {
        v["scenario"]["duration_s"] = serde_json::json!(0.0005);
        v["grid"]["speed"]["values"] = serde_json::json!([2000]);
        v["scenario"]["coating"] = serde_json::json!({"thickness_m": 0.5});
        v["grid"]["coating"] = serde_json::json!({"young": {"scale": [1.0, 2.0]}});
    });
    let expect = ["/scenario/coating/thickness_m", "job 0", "off the casing"];
    assert_run_refused(&spec, &dir.join("out"), &expect);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A coating too stiff for the explicit step at one grid point (the limit k·w < 1 that the
/// paper's formulation needs; the massless boundary solves the coating force with the
/// displacement) is refused by `run` before any job runs: exit status 1, the message names
/// the grid field, the job and the reason, and nothing is written.
#[test]
fn a_coating_too_stiff_for_the_step_is_refused_before_any_job_runs() {
    let dir = tmp("stiffcoating");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = small_coated(
        &dir,
        "spec",
        serde_json::json!({"young": {"scale": [1.0, 1e6]}}),
    );
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&spec).unwrap()).unwrap();
    v["numerics"]["boundary"] = "mass".into();
    std::fs::write(&spec, v.to_string()).unwrap();
    let out = dir.join("out");
    let expect = [
        "/grid/coating/young",
        "job 1",
        "coating too stiff",
        "time_step_s",
    ];
    assert_run_refused(&spec, &out, &expect);
    // `simulate` refuses that job the same way.
    let st = rubscan()
        .args(["simulate", "--job", "1"])
        .arg(&spec)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&st.stderr);
    assert_eq!(st.status.code(), Some(1), "{err}");
    assert!(err.contains("coating too stiff") && !out.exists(), "{err}");
    // The nominal coating alone runs.
    let spec = small_coated(
        &dir,
        "nominal",
        serde_json::json!({"young": {"scale": [1.0]}}),
    );
    let (code, err) = run_to(&spec, &out);
    assert_eq!(code, Some(0), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn help_documents_the_exit_status_and_bad_arguments_exit_1() {
    let st = rubscan().arg("--help").output().unwrap();
    assert_eq!(st.status.code(), Some(0));
    let text = String::from_utf8_lossy(&st.stdout);
    for line in ["Exit status", "130", "some jobs failed"] {
        assert!(text.contains(line), "{text}");
    }
    // Not a number, and more threads than any machine has (spawning 10⁵ threads hung).
    for threads in ["x", "100000"] {
        let st = rubscan()
            .args(["run", "--threads", threads, SMALL])
            .output()
            .unwrap();
        let err = stderr(&st);
        assert_eq!(st.status.code(), Some(1), "{err}");
        assert!(err.contains("--threads"), "{err}");
    }
}

/// Every record batch of a Parquet file.
fn read_all(path: &Path) -> Vec<arrow_array::RecordBatch> {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file)
        .unwrap()
        .build()
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

/// `run --timeseries` writes one time series per job, equal to the one `simulate` writes for
/// that job, and leaves the results table as it is without time series.
#[test]
fn run_timeseries_writes_each_jobs_series_and_leaves_the_table_unchanged() {
    let dir = tmp("series");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = small_with(&dir, "spec", |v| {
        v["scenario"]["duration_s"] = serde_json::json!(0.0008);
        v["scenario"]["load_ramp_s"] = serde_json::json!(0.0002);
        v["grid"]["speed"]["values"] = serde_json::json!([2000]);
    });
    let (with, without, single) = (dir.join("with"), dir.join("without"), dir.join("simulate"));
    for (out, extra) in [(&with, Some("--timeseries")), (&without, None)] {
        let mut c = rubscan();
        c.args(["run", "--threads", "2"])
            .arg(&spec)
            .arg("-o")
            .arg(out);
        c.args(extra);
        let st = c.output().unwrap();
        assert!(
            st.status.success(),
            "{}",
            String::from_utf8_lossy(&st.stderr)
        );
    }
    assert_eq!(table_without_timing(&with), table_without_timing(&without));
    assert!(!without.join("timeseries").exists());
    let plan =
        String::from_utf8(rubscan().arg("plan").arg(&spec).output().unwrap().stdout).unwrap();
    let ids: Vec<&str> = plan
        .lines()
        .skip(1)
        .filter_map(|l| l.split_whitespace().nth(1))
        .filter(|id| id.len() == 16)
        .collect();
    assert_eq!(ids.len(), 2, "{plan}");
    for (index, id) in ids.iter().enumerate() {
        let st = rubscan()
            .arg("simulate")
            .arg(&spec)
            .args(["--job", &index.to_string(), "-o"])
            .arg(&single)
            .output()
            .unwrap();
        assert!(
            st.status.success(),
            "{}",
            String::from_utf8_lossy(&st.stderr)
        );
        let series = read_all(&with.join("timeseries").join(format!("{id}.parquet")));
        let reference = read_all(&single.join("timeseries.parquet"));
        let rows: usize = series.iter().map(|b| b.num_rows()).sum();
        assert_eq!(rows, 4000 / 10, "job {index}: one row per sample step");
        assert_eq!(
            series, reference,
            "job {index}: run and simulate series differ"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// SIGINT (Ctrl-C) during a run stops it cleanly with exit status 130: the jobs in flight are
/// dropped and the manifest says the scan is incomplete (resuming is tested above).
#[test]
fn interrupted_run_exits_130_and_records_an_incomplete_scan() {
    let dir = tmp("sigint");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = small_with(&dir, "spec", |v| {
        v["scenario"]["duration_s"] = serde_json::json!(0.05);
    });
    let out = dir.join("out");
    let mut child = rubscan()
        .args(["run", "--threads", "1"])
        .arg(&spec)
        .arg("-o")
        .arg(&out)
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    // The jobs directory appears once the spec is validated and the handler installed.
    while !out.join("jobs").exists() && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(5));
    }
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["complete"], false, "{manifest}");
    assert_eq!(manifest["summary"]["cancelled"], true, "{manifest}");
    assert!(job_files(&out) < 6);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A job past the spec's `job_time_limit_s` is stopped and recorded as failed with the limit
/// and the simulated time it reached; the run exits 2. The jobs simulate 0.02 s (10⁵ steps),
/// which no machine does within the 1 ms limit.
#[test]
fn jobs_past_the_wall_time_limit_fail_with_the_reason() {
    let dir = tmp("timelimit");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = small_with(&dir, "spec", |v| {
        v["scenario"]["duration_s"] = serde_json::json!(0.02);
        v["grid"]["speed"]["values"] = serde_json::json!([2000]);
        v["grid"]["friction"] = serde_json::json!([0.1]);
        v["job_time_limit_s"] = serde_json::json!(0.001);
    });
    let out = dir.join("out");
    let st = rubscan()
        .args(["run", "--threads", "1"])
        .arg(&spec)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&st.stderr);
    assert_eq!(st.status.code(), Some(2), "{err}");
    let record = std::fs::read_dir(out.join("jobs"))
        .unwrap()
        .map(|e| std::fs::read_to_string(e.unwrap().path()).unwrap())
        .next()
        .unwrap();
    let record: serde_json::Value = serde_json::from_str(&record).unwrap();
    let reason = record["status"]["reason"].as_str().unwrap();
    let prefix = "wall-time limit of 0.001 s exceeded after ";
    assert!(reason.starts_with(prefix), "{reason}");
    let simulated: f64 = reason[prefix.len()..]
        .trim_end_matches(" s simulated")
        .parse()
        .unwrap();
    assert!(simulated > 0.0 && simulated < 0.02, "{reason}");
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["complete"], true);
    assert_eq!(manifest["all_ok"], false);
    assert_eq!(manifest["failed"], 1);
    // A resume runs nothing and still reports the failure.
    let (code, err) = run_to(&spec, &out);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("1 of 1 finished jobs failed"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `run` says how many jobs lie above the flexible casing's critical wave speed (5517.7 rad/s,
/// nodal diameter 4, for the small casing: `min_k ω_k / k`), and says nothing when none does.
#[test]
fn run_notes_the_jobs_above_the_casing_critical_wave_speed() {
    let dir = tmp("wavespeed");
    std::fs::create_dir_all(&dir).unwrap();
    for (speeds, note) in [(vec![1500.0, 7000.0], true), (vec![1500.0], false)] {
        let spec = small_with(&dir, "spec", |v| {
            v["scenario"]["duration_s"] = serde_json::json!(0.001);
            v["scenario"]["load_ramp_s"] = serde_json::json!(0.0005);
            v["grid"]["speed"]["values"] = serde_json::json!(speeds);
            v["grid"]["friction"] = serde_json::json!([0.0]);
        });
        let out = dir.join(format!("out{}", speeds.len()));
        let (code, err) = run_to(&spec, &out);
        assert_eq!(code, Some(0), "{err}");
        let said = err.contains("1 of 2 jobs run above the flexible casing's critical wave speed");
        assert_eq!(said, note, "{err}");
        assert_eq!(err.contains("critical wave speed"), note, "{err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `model build` builds both models before it writes either: a casing that cannot be built
/// leaves no impeller file behind (exit 1, the casing's field named).
#[test]
fn model_build_writes_nothing_when_one_model_is_invalid() {
    let dir = tmp("modelbuild");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = dir.join("models.json");
    let models = serde_json::json!({
        "impeller": {"geometry": {"n_blades": 4}, "modes_per_diameter": 3},
        "casing": {"geometry": {"n_sectors": 12, "material": {"young": -1.0, "poisson": 0.3, "density": 7800.0}}, "modes_per_diameter": 3}
    });
    std::fs::write(&spec, models.to_string()).unwrap();
    let out = dir.join("out");
    let st = rubscan()
        .args(["model", "build"])
        .arg(&spec)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let err = stderr(&st);
    assert_eq!(st.status.code(), Some(1), "{err}");
    assert!(err.contains("young"), "{err}");
    assert!(
        !out.join("impeller.rom").exists(),
        "impeller.rom written: {err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `model export calculix` refuses a bad spec naming the file and the field, and writes no
/// deck when one component cannot be meshed (the casing here, after a valid impeller).
#[test]
fn model_export_names_the_bad_field_and_writes_nothing() {
    let dir = tmp("modelexport");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = dir.join("models.json");
    let out = dir.join("out");
    for (models, field) in [
        (
            serde_json::json!({"casing": {"geometry": {"n_sectorz": 12}}}),
            "n_sectorz",
        ),
        (
            serde_json::json!({"casing": {"geometry": {"n_sectors": 12, "elements_meridian": 7}}}),
            "elements_meridian",
        ),
    ] {
        std::fs::write(&spec, models.to_string()).unwrap();
        let st = rubscan()
            .args(["model", "export", "calculix"])
            .arg(&spec)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let err = stderr(&st);
        assert_eq!(st.status.code(), Some(1), "{err}");
        assert!(err.contains("models.json") && err.contains(field), "{err}");
        assert!(!out.exists(), "a deck was written: {err}");
    }
    for omega in ["0", "-100", "nan"] {
        let st = rubscan()
            .args([
                "model",
                "export",
                "calculix",
                &format!("--omega={omega}"),
                "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        let err = stderr(&st);
        assert_eq!(st.status.code(), Some(1), "{err}");
        assert!(err.contains("--omega") && err.contains("above 0"), "{err}");
        assert!(!out.exists(), "a deck was written: {err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `model import` does not write its ROM over one of its inputs (it used to replace the
/// import spec itself), and checks its damping before reading the matrices: both refused
/// before the import, exit 1, the input unchanged.
#[test]
fn model_import_refuses_to_write_over_its_inputs() {
    let dir = tmp("importover");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = dir.join("spec.json");
    std::fs::copy("tests/data/rotor37_import.json", &spec).unwrap();
    let before = std::fs::read(&spec).unwrap();
    for target in [spec.clone(), dir.join("blade.sti")] {
        let st = rubscan()
            .args(["model", "import", "calculix"])
            .arg(&spec)
            .arg("-o")
            .arg(&target)
            .output()
            .unwrap();
        let err = stderr(&st);
        assert_eq!(st.status.code(), Some(1), "{err}");
        assert!(err.contains("an input of the import"), "{err}");
    }
    assert_eq!(std::fs::read(&spec).unwrap(), before);
    assert!(!dir.join("blade.sti").exists());
    // Damping is checked before the (absent) matrices are read, not after the reduction.
    let mut v: serde_json::Value = serde_json::from_slice(&before).unwrap();
    v["damping"] = serde_json::json!({"modal": {"ratio": 3.0}});
    std::fs::write(&spec, v.to_string()).unwrap();
    let st = rubscan()
        .args(["model", "import", "calculix"])
        .arg(&spec)
        .arg("-o")
        .arg(dir.join("out.rom"))
        .output()
        .unwrap();
    let err = stderr(&st);
    assert_eq!(st.status.code(), Some(1), "{err}");
    assert!(err.contains("spec.json: damping: modal ratio 3"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A `simulate` stopped before its job ends (Ctrl-C; a failed job takes the same path)
/// leaves no output directory behind: exit 130, and the directories it made are gone.
#[test]
fn an_interrupted_simulate_leaves_no_output_directory() {
    let dir = tmp("simint");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = small_with(&dir, "spec", |v| {
        v["scenario"]["duration_s"] = serde_json::json!(0.5);
    });
    let out = dir.join("made").join("out");
    let mut child = rubscan()
        .arg("simulate")
        .arg(&spec)
        .arg("-o")
        .arg(&out)
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    // The directory appears once the job is set up and its series opened.
    while !out.exists() && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(out.exists(), "simulate never started");
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    assert_eq!(child.wait().unwrap().code(), Some(130));
    assert!(!dir.join("made").exists(), "output directory left behind");
    std::fs::remove_dir_all(&dir).unwrap();
}
