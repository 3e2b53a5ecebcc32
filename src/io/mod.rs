//! Files: atomic writes, the content hash that names them, ROM files and their cache, the
//! CalculiX and Matrix Market readers, the time-series writer. The sweep's own output
//! directory (job records, results table, plots, manifest) is written by [`crate::sweep`],
//! on top of this stage; the numerics stages below it never touch the file system.

pub mod atomic;
#[allow(missing_docs)] // documented after #23 lands
pub mod calculix;
pub mod content_hash;
#[allow(missing_docs)] // documented after #23 lands
pub mod matrix_market;
pub mod model_cache;
#[allow(missing_docs)] // documented after #23 lands
pub mod rom_file;
#[allow(missing_docs)] // documented after #23 lands
pub mod timeseries;
