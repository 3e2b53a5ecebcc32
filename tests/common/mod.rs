//! Helpers shared by the integration tests (each test crate uses some of them).
#![allow(dead_code)]

use arrow_array::RecordBatch;
use rubscan::sweep::table::read_results;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `rubscan` binary under test, run from the crate root and outside any Slurm job: the
/// variables of an array task are removed, so that a test run inside one (CI on a cluster)
/// does not take its shard or thread count from them.
pub fn rubscan() -> Command {
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

/// A finished command's standard error, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The results table of the sweep output folder `dir` without its timing column
/// (`wall_time_s`), the part that a rerun must reproduce.
pub fn table_without_timing(dir: &Path) -> Vec<RecordBatch> {
    read_results(&dir.join("results.parquet"))
        .unwrap()
        .into_iter()
        .map(|b| {
            let keep: Vec<usize> = (0..b.num_columns())
                .filter(|&i| b.schema().field(i).name() != "wall_time_s")
                .collect();
            b.project(&keep).unwrap()
        })
        .collect()
}

/// The first of `names` found as a file in a folder of the PATH (names tried in order).
pub fn find_on_path(names: &[&str]) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    names
        .iter()
        .flat_map(|name| std::env::split_paths(&path).map(move |d| d.join(name)))
        .find(|p| p.is_file())
}

/// Skips `test` (prints why) unless `CI` is set, in which case a missing prerequisite fails.
pub fn skip_or_fail(test: &str, why: &str) {
    if std::env::var_os("CI").is_some() {
        panic!("{why} (required because CI is set)");
    }
    eprintln!("SKIPPED {test}: {why}");
}

/// Removes a scratch folder when dropped, even if the test fails.
pub struct Scratch(pub PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
