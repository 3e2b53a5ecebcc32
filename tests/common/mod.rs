//! Helpers shared by the integration tests (each test crate uses some of them).
#![allow(dead_code)]

use arrow_array::RecordBatch;
use rubscan::sweep::table::read_results;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

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

/// Skips `test` for want of a tool or file, or fails it when that is required: when
/// `RUBSCAN_REQUIRE_TOOLS` (set by the README's test command, `.ci/test`, which installs every
/// tool the tests use) or `CI` is set. A skip is written straight to the process's standard
/// error, which libtest does not capture (it captures `print!` and `eprint!` only), so that it
/// shows even when the test passes.
pub fn skip_or_fail(test: &str, why: &str) {
    for var in ["RUBSCAN_REQUIRE_TOOLS", "CI"] {
        if std::env::var_os(var).is_some() {
            panic!("{test}: {why} (required because {var} is set)");
        }
    }
    use std::io::Write;
    let _ = writeln!(
        std::io::stderr(),
        "SKIPPED {test} (not run, but reported as passed): {why}"
    );
}

/// The output folder of the README's main job, `rubscan run sweeps/quickstart.json --threads 2`,
/// run once per build of the binary under test and shared by every test process of a `cargo
/// test` run instead of once in each: kept under `CARGO_TARGET_TMPDIR`, keyed by the binary's
/// size and modification time and by the spec's text, and made whole by a rename. A lock file
/// beside it makes a process that needs it while another runs it wait for that run instead of
/// running it too. Read it; write nothing into it (a report goes elsewhere with `-o`).
pub fn quickstart_output() -> &'static Path {
    static OUT: OnceLock<PathBuf> = OnceLock::new();
    OUT.get_or_init(|| {
        use std::hash::{Hash, Hasher};
        let spec = Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps/quickstart.json");
        let bin = std::fs::metadata(env!("CARGO_BIN_EXE_rubscan")).unwrap();
        let mut key = std::collections::hash_map::DefaultHasher::new();
        (bin.len(), bin.modified().unwrap()).hash(&mut key);
        std::fs::read(&spec).unwrap().hash(&mut key);
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join(format!("quickstart-{:016x}", key.finish()));
        // Released when the file is closed, at the end of this block.
        let lock = std::fs::File::create(dir.with_extension("lock")).unwrap();
        lock.lock().unwrap();
        if !dir.join("results.parquet").is_file() {
            let part = dir.with_extension(format!("part{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&part);
            let run = rubscan()
                .args(["run", "sweeps/quickstart.json", "--threads", "2", "-o"])
                .arg(&part)
                .output()
                .unwrap();
            assert!(
                run.status.success(),
                "the quickstart failed: {}",
                stderr(&run)
            );
            std::fs::rename(&part, &dir).unwrap();
        }
        dir
    })
}

/// Removes a scratch folder when dropped, even if the test fails.
pub struct Scratch(pub PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
