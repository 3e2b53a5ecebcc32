//! rubscan: critical-speed scans of a bladed impeller rubbing inside a flexible casing.
//!
//! The module tree follows the pipeline of Batailly & Legrand (2015):
//! - [`model`]: finite elements, built-in geometry, cyclic symmetry, Craig–Bampton reduction, ROMs;
//! - [`contact`]: the casing B-spline contact surface and closest-point projection;
//! - [`dynamics`]: explicit time integration with Lagrange-multiplier contact, friction, abradable coating;
//! - [`analysis`]: spectra, linear interaction criterion, strain energy per nodal diameter;
//! - [`sweep`]: sweep specification and its schema, validation, planner, runner with its output
//!   directory (job records, the Parquet results table, plots, manifest);
//! - [`simd`]: the explicit SIMD kernels (AVX2/FMA) with their portable twins, and the choice
//!   between them (made once; `RUBSCAN_SIMD=portable` forces the portable path);
//! - [`io`]: files: atomic writes, content hashes, ROM files and cache, FE model readers, the
//!   time-series writer (the numerics stages above never touch the file system);
//! - `fixtures` (tests and benches only, feature `fixtures`): synthetic ROMs and a seeded
//!   generator;
//! - [`app`]: each `rubscan` subcommand as a library call (the binary only parses arguments).
//!
//! Units are SI everywhere inside (m, kg, s, N, Pa, rad/s).

#![warn(missing_docs)]

pub mod analysis;
pub mod app;
pub mod contact;
pub mod dynamics;
#[cfg(any(test, feature = "fixtures"))]
pub mod fixtures;
pub mod io;
pub mod model;
pub mod simd;
pub mod sweep;
