//! io stage.

pub mod parquet;
pub mod plots;
