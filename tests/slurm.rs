//! Running on Slurm: the shard and threads of an array task taken from Slurm's environment,
//! the merge of its shard directories, and (with `RUBSCAN_SLURM_TEST=1`, on a machine where
//! `.ci/slurm/start.sh` has started a one-node cluster) a real array submitted and merged.

use crate::common;
use common::{rubscan, stderr, table_without_timing};

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SMALL: &str = "tests/data/small_sweep.json";

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rubscan-slurm-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
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
    assert_eq!(st.totals(), (3, 0, 0, 3));
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
        text.lines().any(|l| l
            .split_whitespace()
            .take(5)
            .eq(["total", "3", "0", "0", "3"])),
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

/// States of the jobs (array tasks) of Slurm job `id`, from `scontrol show job -o`.
fn job_states(id: &str) -> Vec<String> {
    let o = Command::new("scontrol")
        .args(["show", "job", "-o", id])
        .output()
        .unwrap();
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter_map(|l| {
            let state = l
                .split_whitespace()
                .find_map(|f| f.strip_prefix("JobState="))?;
            let code = l
                .split_whitespace()
                .find_map(|f| f.strip_prefix("ExitCode="))?;
            Some(format!("{state} {code}"))
        })
        .collect()
}

/// Waits (at most 5 min) until every task of job `id` has left the queue; returns their
/// states (`COMPLETED 0:0`, `FAILED 2:0`, …).
fn wait_for(id: &str) -> Vec<String> {
    let start = std::time::Instant::now();
    loop {
        let states = job_states(id);
        let active = |s: &String| {
            ["PENDING", "RUNNING", "CONFIGURING", "COMPLETING"]
                .iter()
                .any(|a| s.starts_with(a))
        };
        if !states.is_empty() && !states.iter().any(active) {
            return states;
        }
        assert!(
            start.elapsed().as_secs() < 300,
            "job {id} still queued after 5 min: {states:?}"
        );
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
}

fn records_in(dir: &Path) -> usize {
    std::fs::read_dir(dir.join("jobs")).map_or(0, |d| {
        d.filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.file_name().to_string_lossy().ends_with(".json"))
        })
        .count()
    })
}

/// `rubscan slurm --submit` of a 2-task array; returns (array id, merge id).
fn submit(spec: &Path, out: &Path) -> (String, String) {
    let o = rubscan()
        .args(["slurm", "--tasks", "2", "--cpus-per-task", "1", "--submit"])
        .arg(spec)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}{text}", stderr(&o));
    let id = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key))
            .unwrap_or_else(|| panic!("no {key:?} in {text}"))
            .trim()
            .to_string()
    };
    (id("array job "), id("merge job "))
}

/// The real scheduler (needs `RUBSCAN_SLURM_TEST=1` and a cluster started by
/// `.ci/slurm/start.sh`; CI runs `.ci/slurm/test.sh`): the small sweep as a 2-task array plus
/// its merge gives the table of a local run; then an array task killed with `scancel` makes
/// the merge fail naming its shard, and resubmitting only that task then the merge gives the
/// table of an uninterrupted run.
#[test]
fn real_slurm_array_merge_and_scancel_resume() {
    if std::env::var("RUBSCAN_SLURM_TEST").as_deref() != Ok("1") {
        eprintln!(
            "\n*** SKIPPED real_slurm_array_merge_and_scancel_resume: needs RUBSCAN_SLURM_TEST=1 and a \
             running Slurm (.ci/slurm/start.sh; CI runs .ci/slurm/test.sh) ***\n"
        );
        return;
    }
    let sinfo = Command::new("sinfo").args(["-h", "-o", "%t"]).output();
    match &sinfo {
        Ok(o) if o.status.success() && String::from_utf8_lossy(&o.stdout).contains("idle") => {}
        _ => panic!(
            "Slurm is not up (sinfo shows no idle node): {sinfo:?}; start it with .ci/slurm/start.sh"
        ),
    }
    let dir = tmp("real");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = std::fs::canonicalize(SMALL).unwrap();
    let local = |spec: &Path, out: &Path| {
        let o = rubscan()
            .arg("run")
            .arg(spec)
            .arg("-o")
            .arg(out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    };

    // 1. The array and its merge.
    let out = dir.join("array");
    let (array, merge) = submit(&spec, &out);
    local(&spec, &dir.join("local"));
    let merged = wait_for(&merge);
    assert_eq!(merged, ["COMPLETED 0:0"], "merge job {merge}");
    assert_eq!(
        wait_for(&array),
        ["COMPLETED 0:0", "COMPLETED 0:0"],
        "array {array}"
    );
    assert_eq!(
        table_without_timing(&out),
        table_without_timing(&dir.join("local"))
    );

    // 2. Task 1 killed with scancel after its first job; jobs of 0.01 s simulated (~5x the
    //    small ones) leave time to catch it between its first and last job.
    let long: serde_json::Value = {
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(SMALL).unwrap()).unwrap();
        v["scenario"]["duration_s"] = serde_json::json!(0.01);
        v
    };
    let long_spec = dir.join("long.json");
    std::fs::write(&long_spec, long.to_string()).unwrap();
    let out = dir.join("killed");
    let (array, merge) = submit(&long_spec, &out);
    let shard1 = out.join("shards/1-of-2");
    let start = std::time::Instant::now();
    while records_in(&shard1) < 1 {
        assert!(
            start.elapsed().as_secs() < 300,
            "task 1 made no record in 5 min"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let o = Command::new("scancel")
        .arg(format!("{array}_1"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    local(&long_spec, &dir.join("long-local"));
    assert_eq!(
        wait_for(&merge),
        ["FAILED 2:0"],
        "merge after a cancelled task"
    );
    let killed_after = records_in(&shard1);
    assert!(killed_after < 3, "scancel landed after task 1 finished");
    let logs = out.with_file_name("killed.slurm").join("logs");
    let merge_log =
        std::fs::read_to_string(logs.join(format!("rubscan-small-merge-{merge}.out"))).unwrap();
    assert!(
        merge_log.contains("1-of-2 (shard 1/2): unfinished"),
        "{merge_log}"
    );

    // 3. Only task 1 resubmitted, then the merge: the table of the uninterrupted run.
    let scripts = out.with_file_name("killed.slurm");
    let resumed =
        rubscan::sweep::slurm::sbatch(&["--array=1".into()], &scripts.join("array.sbatch"))
            .unwrap();
    let merge = rubscan::sweep::slurm::sbatch(
        &[format!("--dependency=afterany:{resumed}")],
        &scripts.join("merge.sbatch"),
    )
    .unwrap();
    assert_eq!(
        wait_for(&merge),
        ["COMPLETED 0:0"],
        "merge after the resume"
    );
    assert_eq!(wait_for(&resumed), ["COMPLETED 0:0"]);
    let task_log =
        std::fs::read_to_string(logs.join(format!("rubscan-small-{resumed}_1.out"))).unwrap();
    assert!(
        task_log.contains(&format!(
            "resuming: {killed_after} of 3 jobs already finished"
        )),
        "{task_log}"
    );
    assert_eq!(
        table_without_timing(&out),
        table_without_timing(&dir.join("long-local"))
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
