//! Finished results are never lost: `run` refuses an output directory holding another sweep's
//! or another shard's results, `merge` refuses shard sets that do not make up one plan (the same
//! shard twice, different splits, an unreadable manifest) and names the shards not given, and
//! `status` names the job records it cannot read. Library calls on the synthetic simulator, and
//! the binary on the small built-in models for the exit statuses.

use crate::common;
use common::stderr;

use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use rubscan::sweep::synthetic::SyntheticSimulator;
use rubscan::sweep::{
    Job, JobResult, JobSimulator, RunOptions, SweepSpec, merge, parse_spec, plan, run_sweep,
};

const SMALL: &str = "tests/data/small_sweep.json";

/// A six-job sweep (three speeds × two friction coefficients) named `name`.
fn spec(name: &str, speeds: &[f64]) -> SweepSpec {
    parse_spec(
        &serde_json::json!({
            "name": name,
            "models": {"impeller": {"builtin": {}}, "casing": {"rigid": {"lobes": 2, "amplitude_m": 1e-4}}},
            "scenario": {"duration_s": 0.01},
            "numerics": {"time_step_s": 1e-5},
            "grid": {"speed": {"unit": "rad_s", "values": speeds}, "friction": [0.0, 0.2]}
        })
        .to_string(),
    )
    .unwrap()
}

fn sweep_b() -> SweepSpec {
    spec("sweep_b", &[600.0, 1000.0, 1400.0])
}

/// Counts the jobs it runs.
#[derive(Default)]
struct Counting {
    calls: AtomicUsize,
}

impl JobSimulator for Counting {
    fn run(&self, job: &Job, cancel: &AtomicBool) -> Result<JobResult, String> {
        self.calls.fetch_add(1, Ordering::SeqCst);
        SyntheticSimulator::default().run(job, cancel)
    }
}

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rubscan-safety-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn opts(dir: &Path, shard: Option<(usize, usize)>) -> RunOptions {
    let mut o = RunOptions::new(dir);
    o.threads = 2;
    o.shard = shard;
    o
}

/// The bytes of a finished output's table and manifest: what a refused run must leave alone.
fn snapshot(dir: &Path) -> (Vec<u8>, Vec<u8>) {
    (
        std::fs::read(dir.join("results.parquet")).unwrap(),
        std::fs::read(dir.join("manifest.json")).unwrap(),
    )
}

/// Runs `spec` into `dir` expecting a refusal: no job runs, the error (with its causes) is
/// returned.
fn refused(spec: &SweepSpec, dir: &Path, shard: Option<(usize, usize)>) -> String {
    let sim = Counting::default();
    let err = run_sweep(spec, &opts(dir, shard), &sim).expect_err("run into the directory");
    assert_eq!(sim.calls.load(Ordering::SeqCst), 0, "a job ran: {err:#}");
    format!("{err:#}")
}

fn assert_names(text: &str, parts: &[&str]) {
    for p in parts {
        assert!(text.contains(p), "{p:?} not in: {text}");
    }
}

#[test]
fn run_refuses_a_directory_holding_another_shard_and_keeps_its_results() {
    let spec = sweep_b();
    let sim = SyntheticSimulator::default();
    let full = tmp("full");
    run_sweep(&spec, &opts(&full, None), &sim).unwrap();
    let before = snapshot(&full);
    let err = refused(&spec, &full, Some((1, 2)));
    assert_names(
        &err,
        &[
            &full.display().to_string(),
            "the unsharded run",
            "shard 1/2",
        ],
    );
    assert_eq!(snapshot(&full), before, "the finished run was rewritten");

    let s0 = tmp("s0");
    run_sweep(&spec, &opts(&s0, Some((0, 2))), &sim).unwrap();
    let before = snapshot(&s0);
    for (shard, requested) in [
        (Some((1, 2)), "shard 1/2"),
        (Some((0, 3)), "shard 0/3"),
        (None, "the unsharded run"),
    ] {
        let err = refused(&spec, &s0, shard);
        assert_names(
            &err,
            &[&s0.display().to_string(), "holds shard 0/2", requested],
        );
        assert_eq!(snapshot(&s0), before, "{requested} rewrote shard 0/2");
    }

    // The same shard, and the same unsharded run, still resume.
    let sim = Counting::default();
    let again = run_sweep(&spec, &opts(&s0, Some((0, 2))), &sim).unwrap();
    assert_eq!((again.skipped, again.ran, again.ok), (3, 0, 3));
    let again = run_sweep(&spec, &opts(&full, None), &sim).unwrap();
    assert_eq!((again.skipped, again.ran, again.ok), (6, 0, 6));
    assert_eq!(sim.calls.load(Ordering::SeqCst), 0);
    for d in [full, s0] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn run_refuses_another_sweeps_directory_and_resumes_a_grown_grid_of_the_same_sweep() {
    let dir = tmp("other-sweep");
    run_sweep(
        &sweep_b(),
        &opts(&dir, None),
        &SyntheticSimulator::default(),
    )
    .unwrap();
    let before = snapshot(&dir);
    let err = refused(&spec("sweep_a", &[700.0, 900.0]), &dir, None);
    assert_names(
        &err,
        &[
            &dir.display().to_string(),
            "another sweep's results",
            "\"sweep_b\"",
            "another -o",
        ],
    );
    assert_eq!(snapshot(&dir), before, "sweep_b's output was rewritten");

    // Same name, one more speed: the six finished jobs are kept, the two new ones run.
    let grown = spec("sweep_b", &[600.0, 1000.0, 1400.0, 1800.0]);
    let sim = Counting::default();
    let s = run_sweep(&grown, &opts(&dir, None), &sim).unwrap();
    assert_eq!((s.skipped, s.ran, s.ok), (6, 2, 8));
    assert_eq!(sim.calls.load(Ordering::SeqCst), 2);
    std::fs::remove_dir_all(dir).unwrap();
}

/// A directory written before the formulation became part of a job's identity (its manifest
/// has no `job_identity`) is refused by `run`, `merge` and `status`, naming why and what to
/// do, and its results are kept byte for byte.
#[test]
fn run_merge_and_status_refuse_a_directory_of_an_older_job_identity() {
    let spec = sweep_b();
    let old = tmp("identity1");
    run_sweep(&spec, &opts(&old, None), &SyntheticSimulator::default()).unwrap();
    let path = old.join("manifest.json");
    let mut manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(manifest["job_identity"], 4);
    manifest["job_identity"] = 3.into();
    std::fs::write(&path, manifest.to_string()).unwrap();
    let err = refused(&spec, &old, None);
    assert_names(
        &err,
        &[
            "job identity 3",
            "coating force of the end of the step alone",
        ],
    );
    manifest["job_identity"] = 2.into();
    std::fs::write(&path, manifest.to_string()).unwrap();
    let err = refused(&spec, &old, None);
    assert_names(
        &err,
        &[
            "job identity 2",
            "maxima were taken on the sample steps only",
        ],
    );
    manifest.as_object_mut().unwrap().remove("job_identity");
    std::fs::write(&path, manifest.to_string()).unwrap();
    let before = snapshot(&old);
    let err = refused(&spec, &old, None);
    assert_names(
        &err,
        &[
            &old.display().to_string(),
            "job identity 1",
            "mass-carrying boundary was the default",
            "give another -o",
            "\"boundary\": \"mass\"",
        ],
    );
    let err = merge(std::slice::from_ref(&old), &tmp("identity1-merged")).unwrap_err();
    assert_names(&format!("{err:#}"), &["merge", "job identity 1"]);
    let err = rubscan::sweep::status::status(&old).unwrap_err();
    assert_names(&format!("{err:#}"), &["job identity 1", "give another -o"]);
    assert_eq!(snapshot(&old), before, "the old results were rewritten");
    std::fs::remove_dir_all(old).unwrap();
}

#[test]
fn run_refuses_an_unreadable_manifest_in_its_output_directory() {
    let dir = tmp("bad-manifest");
    let spec = sweep_b();
    run_sweep(&spec, &opts(&dir, None), &SyntheticSimulator::default()).unwrap();
    let path = dir.join("manifest.json");
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&path, &text[..text.len() / 2]).unwrap();
    let err = refused(&spec, &dir, None);
    assert_names(&err, &[&path.display().to_string(), "malformed", "EOF"]);
    assert_eq!(
        std::fs::read_to_string(&path).unwrap(),
        text[..text.len() / 2]
    );
    std::fs::remove_dir_all(dir).unwrap();
}

/// Shard directories `<tag>-<i>-of-<n>` of `sweep_b` for each `(i, n)`.
fn run_shards(tag: &str, shards: &[(usize, usize)]) -> Vec<PathBuf> {
    shards
        .iter()
        .map(|&(i, n)| {
            let d = tmp(&format!("{tag}-{i}-of-{n}"));
            run_sweep(
                &sweep_b(),
                &opts(&d, Some((i, n))),
                &SyntheticSimulator::default(),
            )
            .unwrap();
            d
        })
        .collect()
}

/// Merges `dirs` expecting a refusal before anything is written.
fn merge_refused(dirs: &[PathBuf], out: &Path) -> String {
    let err = merge(dirs, out).expect_err("merge refused");
    assert!(!out.exists(), "a refused merge wrote {}", out.display());
    format!("{err:#}")
}

#[test]
fn merge_refuses_a_shard_given_twice_and_shards_of_different_splits() {
    let dirs = run_shards("dup", &[(0, 2), (1, 2), (0, 3)]);
    let (s0, s1, t0) = (&dirs[0], &dirs[1], &dirs[2]);
    let out = tmp("dup-out");
    let name = |d: &Path| d.display().to_string();

    let err = merge_refused(&[s0.clone(), s0.clone()], &out);
    assert_names(&err, &[&name(s0), "twice"]);
    // The same shard from two directories.
    let copy = tmp("dup-copy");
    std::fs::create_dir_all(copy.join("jobs")).unwrap();
    for f in ["manifest.json", "results.parquet"] {
        std::fs::copy(s0.join(f), copy.join(f)).unwrap();
    }
    let err = merge_refused(&[s0.clone(), s1.clone(), copy.clone()], &out);
    assert_names(&err, &[&name(s0), &name(&copy), "both hold shard 0/2"]);
    let err = merge_refused(&[s0.clone(), t0.clone()], &out);
    assert_names(&err, &[&name(s0), &name(t0), "shard 0/2", "shard 0/3"]);
    let full = tmp("dup-full");
    run_sweep(
        &sweep_b(),
        &opts(&full, None),
        &SyntheticSimulator::default(),
    )
    .unwrap();
    let err = merge_refused(&[full.clone(), s1.clone()], &out);
    assert_names(&err, &[&name(&full), &name(s1), "the unsharded run"]);

    // A merge into a shard's directory (whose table it would replace) is refused.
    let before = snapshot(s1);
    let err = format!("{:#}", merge(&[s0.clone(), s1.clone()], s1).unwrap_err());
    assert_names(&err, &[&name(s1), "holds shard 1/2"]);
    assert_eq!(snapshot(s1), before);

    // The two shards of one split merge into the full plan, and again into the same output.
    for _ in 0..2 {
        let m = merge(&[s1.clone(), s0.clone()], &out).unwrap();
        assert_eq!((m.found, m.missing.len()), (6, 0));
        assert!(m.shard_problems.is_empty(), "{:?}", m.shard_problems);
    }
    for d in dirs.iter().chain([&out, &copy, &full]) {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn merge_names_the_shards_not_given() {
    let dirs = run_shards("absent", &[(1, 3)]);
    let out = tmp("absent-out");
    let m = merge(&dirs, &out).unwrap();
    assert_eq!((m.found, m.missing.len()), (2, 4));
    assert_eq!(
        m.shard_problems,
        [
            "shard 0/3 not given (no directory holds its manifest.json)",
            "shard 2/3 not given (no directory holds its manifest.json)",
        ]
    );
    for d in dirs.iter().chain([&out]) {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn merge_refuses_a_shard_whose_manifest_is_unreadable() {
    let dirs = run_shards("unreadable", &[(0, 2), (1, 2)]);
    let out = tmp("unreadable-out");
    let path = dirs[1].join("manifest.json");
    std::fs::write(&path, "{\"rubscan_version\": \"0.1.0\", \"sweep\": ").unwrap();
    let err = merge_refused(&dirs, &out);
    assert_names(&err, &[&path.display().to_string(), "malformed", "EOF"]);
    // Without a manifest at all the directory is a shard not started; the records it has are
    // still merged.
    std::fs::remove_file(&path).unwrap();
    let m = merge(&dirs, &out).unwrap();
    assert_eq!((m.found, m.missing.len()), (6, 0));
    assert_eq!(
        m.shard_problems,
        [
            format!("{}: not started (no manifest.json)", dirs[1].display()),
            "shard 1/2 not given or not started (no directory holds its manifest.json)".into(),
        ]
    );
    for d in dirs.iter().chain([&out]) {
        std::fs::remove_dir_all(d).unwrap();
    }
}

fn rubscan(args: &[&str], paths: &[&Path]) -> Output {
    common::rubscan().args(args).args(paths).output().unwrap()
}

#[test]
fn cli_refused_outputs_and_merges_exit_1_and_a_missing_shard_is_named() {
    let dir = tmp("cli");
    std::fs::create_dir_all(&dir).unwrap();
    let (full, s0, t0) = (dir.join("full"), dir.join("s0"), dir.join("t0"));
    for (out, shard) in [(&full, None), (&s0, Some("0/2")), (&t0, Some("0/3"))] {
        let mut args = vec!["run", SMALL, "--threads", "2"];
        args.extend(shard.iter().flat_map(|s| ["--shard", *s]));
        args.push("-o");
        let o = rubscan(&args, &[out]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let before = snapshot(&full);
    let o = rubscan(&["run", SMALL, "--shard", "1/2", "-o"], &[&full]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_names(
        &stderr(&o),
        &[
            &full.display().to_string(),
            "the unsharded run",
            "shard 1/2",
        ],
    );
    let mut other: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(SMALL).unwrap()).unwrap();
    other["name"] = "other".into();
    let other_spec = dir.join("other.json");
    std::fs::write(&other_spec, other.to_string()).unwrap();
    let o = rubscan(&["run"], &[&other_spec, Path::new("-o"), &full]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_names(&stderr(&o), &["another sweep's results", "\"small\""]);
    assert_eq!(snapshot(&full), before);

    let out = dir.join("merged");
    let o = rubscan(&["merge", "-o"], &[&out, &s0]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_names(&stderr(&o), &["shards to look at:\n  shard 1/2 not given"]);
    for (shards, parts) in [
        ([&s0, &s0], vec!["twice"]),
        ([&s0, &t0], vec!["shard 0/2", "shard 0/3"]),
    ] {
        let out = dir.join("refused");
        let o = rubscan(&["merge", "-o"], &[&out, shards[0], shards[1]]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert_names(&stderr(&o), &parts);
        assert_names(&stderr(&o), &[&s0.display().to_string()]);
        assert!(!out.exists());
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn status_names_an_unreadable_job_record_and_run_reruns_it() {
    let dir = tmp("status");
    let o = rubscan(&["run", SMALL, "--threads", "2", "-o"], &[&dir]);
    assert!(o.status.success(), "{}", stderr(&o));
    let job = &plan(&rubscan::sweep::load_spec(Path::new(SMALL)).unwrap())
        .unwrap()
        .jobs[4];
    let record = dir.join("jobs").join(format!("{}.json", job.id));
    let text = std::fs::read_to_string(&record).unwrap();
    std::fs::write(&record, &text[..text.len() / 3]).unwrap();

    let o = rubscan(&["status"], &[&dir]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert_names(
        &err,
        &[&record.display().to_string(), "malformed job record"],
    );
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.lines().any(|l| l
            .split_whitespace()
            .take(5)
            .eq(["total", "5", "0", "0", "1"])),
        "{text}"
    );
    let o = rubscan(&["run", SMALL, "--threads", "2", "-o"], &[&dir]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_names(
        &stderr(&o),
        &[&record.display().to_string(), "1 ran, 5 skipped"],
    );
    std::fs::remove_dir_all(dir).unwrap();
}
