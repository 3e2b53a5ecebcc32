//! Input and output: the only stage that touches the file system.

pub mod rom_file;
pub mod timeseries;
