//! Running on Slurm: the shard and threads of an array task taken from Slurm's environment,
//! the merge of its shard directories, and (with `RUBSCAN_SLURM_TEST=1`, on a machine where
//! `.ci/slurm/start.sh` has started a one-node cluster) a real array submitted and merged.

mod common;
use common::table_without_timing;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SMALL: &str = "tests/data/small_sweep.json";

fn rubscan() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rubscan"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    for k in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_MIN",
        "SLURM_ARRAY_TASK_STEP",
        "SLURM_ARRAY_TASK_COUNT",
        "SLURM_CPUS_PER_TASK",
    ] {
        c.env_remove(k);
    }
    c
}

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rubscan-slurm-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn manifest(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap()
}

/// `rubscan run SMALL -o out` as array task `id` of `--array=5-7:2` (two tasks), one CPU each.
fn run_as_task(out: &Path, id: &str) -> Output {
    rubscan()
        .args(["run", SMALL, "-o"])
        .arg(out)
        .env("SLURM_ARRAY_TASK_ID", id)
        .env("SLURM_ARRAY_TASK_MIN", "5")
        .env("SLURM_ARRAY_TASK_STEP", "2")
        .env("SLURM_ARRAY_TASK_COUNT", "2")
        .env("SLURM_CPUS_PER_TASK", "1")
        .output()
        .unwrap()
}

#[test]
fn array_tasks_run_their_shards_and_merge_into_the_full_table() {
    let (out, full) = (tmp("array"), tmp("array-full"));
    for (id, shard) in [("7", 1), ("5", 0)] {
        let o = run_as_task(&out, id);
        assert!(o.status.success(), "{}", stderr(&o));
        let dir = out.join(format!("shards/{shard}-of-2"));
        let m = manifest(&dir);
        assert_eq!(m["shard"], serde_json::json!([shard, 2]), "{m}");
        assert_eq!(m["threads"], 1);
        assert_eq!(m["summary"]["in_shard"], 3);
    }
    let o = rubscan()
        .args(["merge", "-o"])
        .arg(&out)
        .arg(out.join("shards/0-of-2"))
        .arg(out.join("shards/1-of-2"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = rubscan()
        .args(["run", SMALL, "--threads", "2", "-o"])
        .arg(&full)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(table_without_timing(&out), table_without_timing(&full));
    for d in [out, full] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn bad_slurm_environment_exits_1_naming_the_variable_and_writes_nothing() {
    let out = tmp("bad-env");
    for (id, var) in [
        ("9", "SLURM_ARRAY_TASK_COUNT=2"),
        ("6", "SLURM_ARRAY_TASK_ID=6"),
        ("x", "SLURM_ARRAY_TASK_ID=\"x\""),
    ] {
        let o = run_as_task(&out, id);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(stderr(&o).contains(var), "{}", stderr(&o));
        assert!(!out.exists());
    }
    let o = rubscan()
        .args(["run", SMALL, "-o"])
        .arg(&out)
        .env("SLURM_CPUS_PER_TASK", "many")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("SLURM_CPUS_PER_TASK"), "{}", stderr(&o));
    assert!(!out.exists());
}

/// Mean wall time of the ok job records in `dir/jobs`.
fn mean_job_time(dir: &Path) -> f64 {
    let times: Vec<f64> = std::fs::read_dir(dir.join("jobs"))
        .unwrap()
        .map(|e| {
            let v: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(e.unwrap().path()).unwrap()).unwrap();
            v["wall_time_s"].as_f64().unwrap()
        })
        .collect();
    times.iter().sum::<f64>() / times.len() as f64
}

#[test]
fn status_and_merge_name_the_shards_not_done() {
    let out = tmp("status");
    let o = run_as_task(&out, "5");
    assert!(o.status.success(), "{}", stderr(&o));
    let shard0 = out.join("shards/0-of-2");
    let st = rubscan::sweep::status::status(&out).unwrap();
    assert_eq!(st.totals(), (3, 0, 3));
    let counts: Vec<_> = st
        .shards
        .iter()
        .map(|s| (s.shard, s.started, s.ok, s.remaining))
        .collect();
    assert_eq!(
        counts,
        vec![(Some((0, 2)), true, 3, 0), (Some((1, 2)), false, 0, 3)]
    );
    // Shard 1 runs its 3 jobs on the 1 thread of shard 0's allocation: 3 mean job times.
    let mean = mean_job_time(&shard0);
    assert!((st.mean_job_s.unwrap() - mean).abs() < 1e-9 * mean);
    assert!((st.eta_s().unwrap() - 3.0 * mean).abs() < 1e-9 * mean);
    let o = rubscan().arg("status").arg(&out).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        text.lines()
            .any(|l| l.starts_with("1/2 ") && l.contains("not run")),
        "{text}"
    );
    assert!(
        text.lines()
            .any(|l| l.split_whitespace().take(4).eq(["total", "3", "0", "3"])),
        "{text}"
    );

    // The merge writes what there is, names the shard that never ran and exits 2.
    let merge = || {
        rubscan()
            .args(["merge", "-o"])
            .arg(&out)
            .arg(&shard0)
            .arg(out.join("shards/1-of-2"))
            .output()
            .unwrap()
    };
    let o = merge();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("shards/1-of-2: not started"),
        "{}",
        stderr(&o)
    );
    // Shard 1 with one job recorded, the others not: unfinished.
    let o = run_as_task(&out, "7");
    assert!(o.status.success(), "{}", stderr(&o));
    let shard1 = out.join("shards/1-of-2");
    let first = std::fs::read_dir(shard1.join("jobs"))
        .unwrap()
        .next()
        .unwrap();
    let rec = first.unwrap().path();
    std::fs::remove_file(&rec).unwrap();
    let o = merge();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("1-of-2 (shard 1/2): unfinished, 1 of 3 jobs have no record"),
        "{}",
        stderr(&o)
    );
    // A failed job in shard 0 is named too.
    let rec0 = std::fs::read_dir(shard0.join("jobs"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&rec0).unwrap()).unwrap();
    v["status"] = serde_json::json!({"state": "failed", "reason": "test"});
    v["result"] = serde_json::Value::Null;
    std::fs::write(&rec0, v.to_string()).unwrap();
    let o = merge();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("0-of-2 (shard 0/2): 1 of 3 jobs failed"),
        "{}",
        stderr(&o)
    );
    std::fs::remove_dir_all(&out).unwrap();
}

/// `rubscan slurm` without `--submit`: the scripts, run by bash as Slurm would run them (task
/// ids 0 and 1, then the merge), give the table of a single run.
#[test]
fn slurm_scripts_run_by_hand_give_the_table_of_a_single_run() {
    let (out, full) = (tmp("scripts"), tmp("scripts-full"));
    let o = rubscan()
        .args(["slurm", SMALL, "--tasks", "2", "--time", "00:10:00", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    let scripts = out.with_file_name(format!(
        "{}.slurm",
        out.file_name().unwrap().to_string_lossy()
    ));
    let (array, merge) = (scripts.join("array.sbatch"), scripts.join("merge.sbatch"));
    assert!(
        text.contains(&format!("jobid=$(sbatch --parsable '{}')", array.display())),
        "{text}"
    );
    assert!(text.contains("sbatch --dependency=afterany:"), "{text}");
    assert!(scripts.join("logs").is_dir());
    for id in ["1", "0"] {
        let o = Command::new("bash")
            .arg(&array)
            .env("SLURM_ARRAY_TASK_ID", id)
            .env("SLURM_CPUS_PER_TASK", "1")
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = Command::new("bash").arg(&merge).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = rubscan()
        .args(["run", SMALL, "-o"])
        .arg(&full)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(table_without_timing(&out), table_without_timing(&full));
    assert_eq!(manifest(&out)["all_ok"], true);
    // Bad options: exit 1, naming the option, nothing written.
    let bad = tmp("scripts-bad");
    let o = rubscan()
        .args(["slurm", SMALL, "--tasks", "2", "--time", "2h", "-o"])
        .arg(&bad)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("--time \"2h\""), "{}", stderr(&o));
    assert!(
        !bad.with_file_name(format!(
            "{}.slurm",
            bad.file_name().unwrap().to_string_lossy()
        ))
        .exists()
    );
    for d in [out, full, scripts] {
        std::fs::remove_dir_all(d).unwrap();
    }
}
