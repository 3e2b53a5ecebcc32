//! Helpers shared by the integration tests.

use arrow_array::RecordBatch;
use rubscan::sweep::table::read_results;
use std::path::Path;

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
