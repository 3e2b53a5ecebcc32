//! Bad command-line arguments of `slurm`, `report` and `status` are refused up front with
//! exit status 1, an error naming the argument and the reason, and nothing written; a
//! corrupt shard manifest is named in a warning by `status` instead of being skipped.

use crate::common;
use common::{rubscan, stderr};

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

const SMALL: &str = "tests/data/small_sweep.json";

/// A fresh (absent) directory under the system's temporary directory.
fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rubscan-args-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// `<dir>.slurm`, where `rubscan slurm -o <dir>` writes its scripts.
fn script_dir(dir: &Path) -> PathBuf {
    dir.with_file_name(format!(
        "{}.slurm",
        dir.file_name().unwrap().to_string_lossy()
    ))
}

/// `rubscan slurm SMALL <args> -o <out>`, checked to fail with status 1 naming `expected`
/// (every string) and writing nothing.
fn slurm_refused(args: &[&str], out: &Path, expected: &[&str]) {
    let o = rubscan()
        .args(["slurm", SMALL])
        .args(args)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    for e in expected {
        assert!(err.contains(e), "{e:?} not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    assert!(!script_dir(out).exists(), "{err}");
}

/// The 1-job sweep (SMALL at one speed and friction), run once for all tests: its output
/// directory (`run`), and a sweep directory whose shard 0 of 2 ran (`shards/`).
struct OneJob {
    run: PathBuf,
    sharded: PathBuf,
}

fn one_job() -> &'static OneJob {
    static ONE: OnceLock<OneJob> = OnceLock::new();
    ONE.get_or_init(|| {
        // Under target/ (not the system's temporary directory): nothing removes it after
        // the last test, so the next run of this file replaces it.
        let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli_arguments-one-job");
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).unwrap();
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(SMALL).unwrap()).unwrap();
        v["grid"]["speed"]["values"] = serde_json::json!([2000]);
        v["grid"]["friction"] = serde_json::json!([0.1]);
        let spec = root.join("one.json");
        std::fs::write(&spec, v.to_string()).unwrap();
        let (run, sharded) = (root.join("run"), root.join("sharded"));
        for (dir, shard) in [
            (run.clone(), None),
            (sharded.join("shards/0-of-2"), Some("0/2")),
        ] {
            let mut c = rubscan();
            c.arg("run")
                .arg(&spec)
                .args(["--threads", "1", "-o"])
                .arg(&dir);
            if let Some(s) = shard {
                c.args(["--shard", s]);
            }
            let o = c.output().unwrap();
            assert!(o.status.success(), "{}", stderr(&o));
        }
        OneJob { run, sharded }
    })
}

/// Minutes and seconds ≥ 60 are refused, naming `--time` and the field.
#[test]
fn slurm_refuses_a_time_with_minutes_or_seconds_out_of_range() {
    let out = tmp("time");
    slurm_refused(
        &["--tasks", "2", "--time", "25:99:00"],
        &out,
        &["--time \"25:99:00\"", "minutes 99 must be < 60"],
    );
    slurm_refused(
        &["--tasks", "2", "--time", "10:60"],
        &out,
        &["--time \"10:60\"", "seconds 60 must be < 60"],
    );
    slurm_refused(
        &["--tasks", "2", "--time", "1-24:00:00"],
        &out,
        &["--time \"1-24:00:00\"", "hours 24 must be < 24"],
    );
}

/// An array task beyond the planned jobs would run nothing: refused, naming both counts.
#[test]
fn slurm_refuses_more_tasks_than_planned_jobs() {
    let out = tmp("tasks");
    // SMALL plans 3 speeds × 2 frictions = 6 jobs.
    slurm_refused(&["--tasks", "7"], &out, &["--tasks 7", "6 planned jobs"]);
    slurm_refused(
        &["--tasks", "1000000"],
        &out,
        &["--tasks 1000000", "6 planned jobs"],
    );
}

/// `-o` naming an existing regular file is refused; the file is left as it was.
#[test]
fn slurm_refuses_an_output_that_is_a_file() {
    let dir = tmp("outfile");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("results");
    std::fs::write(&file, "keep me").unwrap();
    slurm_refused(
        &["--tasks", "2"],
        &file,
        &["-o ", "results exists and is not a directory"],
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep me");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--max-jobs 0` is refused before anything is written (it used to mean 6, silently).
#[test]
fn report_refuses_max_jobs_zero() {
    let run = &one_job().run;
    let out = tmp("report-max0");
    let o = rubscan()
        .arg("report")
        .arg(run)
        .args(["--max-jobs", "0", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("--max-jobs 0: must be ≥ 1"), "{err}");
    assert!(!out.exists());
}

/// A file given as the results directory is said to be not a directory (it exists).
#[test]
fn report_on_a_file_says_it_is_not_a_directory() {
    let o = rubscan().args(["report", SMALL]).output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("small_sweep.json: not a directory"), "{err}");
    assert!(!err.contains("no such directory"), "{err}");
}

/// A `results.parquet` that is a directory is named as such, not as a missing table.
#[test]
fn report_names_a_results_table_that_is_a_directory() {
    let dir = tmp("report-tabledir");
    std::fs::create_dir_all(dir.join("results.parquet")).unwrap();
    std::fs::copy(
        one_job().run.join("manifest.json"),
        dir.join("manifest.json"),
    )
    .unwrap();
    let o = rubscan().arg("report").arg(&dir).output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("results.parquet: a directory, not the Parquet table"),
        "{err}"
    );
    assert!(!err.contains("has not finished"), "{err}");
    assert!(!dir.join("report").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A corrupt manifest in `shards/` is named in a warning; the status is still printed.
#[test]
fn status_warns_about_a_corrupt_shard_manifest() {
    let out = &one_job().sharded;
    let shard1 = out.join("shards/1-of-2");
    std::fs::create_dir_all(&shard1).unwrap();
    std::fs::write(shard1.join("manifest.json"), "{ truncated").unwrap();
    let o = rubscan().arg("status").arg(out).output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let corrupt = shard1.join("manifest.json");
    assert!(
        err.lines()
            .any(|l| l.starts_with("warning:") && l.contains(&*corrupt.to_string_lossy())),
        "{err}"
    );
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("0/2") && text.contains("1/2"), "{text}");
}
