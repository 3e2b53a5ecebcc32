//! Files: atomic writes, the content hash that names them, ROM files and their cache, the
//! CalculiX and Matrix Market readers, the CalculiX deck export, the time-series writer. The sweep's own output
//! directory (job records, results table, plots, manifest) is written by [`crate::sweep`],
//! on top of this stage; the numerics stages below it never touch the file system.

pub mod atomic;
pub mod calculix;
pub mod calculix_dat;
pub mod calculix_deck;
pub mod calculix_export;
pub mod calculix_sector;
pub mod content_hash;
pub mod matrix_market;
pub mod model_cache;
pub mod rom_file;
pub mod text_lines;
pub mod timeseries;
