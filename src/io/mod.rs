//! Input and output: the only stage that touches the file system.

pub mod atomic;
pub mod calculix;
pub mod matrix_market;
pub mod model_cache;
pub mod parquet;
pub mod plots;
pub mod rom_file;
pub mod timeseries;
