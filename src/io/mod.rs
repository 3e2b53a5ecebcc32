//! Input and output: the only stage that touches the file system.

pub mod calculix;
pub mod matrix_market;
pub mod rom_file;
