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
//! - `fixtures` (hidden, for tests and benches): synthetic ROMs and a seeded
//!   generator;
//! - [`app`]: each `rubscan` subcommand as a library call (the binary only parses arguments).
//!
//! Units are SI everywhere inside (m, kg, s, N, Pa, rad/s).
//!
//! # Where to start
//! The items a notebook binding or a service calls first are re-exported here; the stage
//! modules stay public for everything else.
//!
//! **One simulation** (paper Figs. 4 and 11): a [`Case`] (speed Ω in rad/s, duration in s,
//! friction μ, casing load, clearances, probes, coating, [`Numerics`]) run for an impeller
//! [`CyclicRom`] inside a [`CasingModel`] (flexible ROM or rigid surface):
//! - [`simulate()`] keeps every sample in memory and returns a [`SimulationOutput`];
//! - [`Simulation`] is the same run built once ([`Simulation::new`] checks the case and the
//!   stability limit) and stepped one flowchart box per method, with a caller-chosen
//!   recorder ([`Simulation::run`]) for memory bounded in run length;
//! - both fail with a typed [`SimError`].
//!
//! **Reduced-order models** (paper §2, cyclic Craig–Bampton):
//! - [`ModelSpec`] = [`ImpellerSpec`] + [`CasingSpec`], the built-in parametric models;
//! - [`build_impeller`] / [`build_casing`] build a ROM (no file access; [`BuildError`]);
//!   [`impeller_rom`] / [`casing_rom`] do the same through the on-disk cache;
//! - [`load_rom`] / [`save_rom`] read and write a ROM file (safetensors; [`RomFileError`]).
//!
//! **A sweep** (DESIGN.md §6): [`load_spec`] (file) or [`parse_spec`] (text) give a
//! [`SweepSpec`]; [`resolve`] validates the whole of it with its models before any work;
//! [`plan`] lists its jobs; [`ModelSimulator`] runs one job on the resolved models and
//! [`run_sweep`] runs (or resumes) them all with [`RunOptions`], writing
//! `<out>/results.parquet`, which [`read_results`] reads back. Errors name the JSON path and
//! the reason ([`SpecError`]).
//!
//! ```no_run
//! # fn main() -> anyhow::Result<()> {
//! use std::path::Path;
//! let spec = rubscan::load_spec(Path::new("sweeps/quickstart.json"))?;
//! let sim = rubscan::ModelSimulator::new(&spec)?; // validates, then builds or loads the ROMs
//! let summary = rubscan::run_sweep(&spec, &rubscan::RunOptions::new("results/quickstart"), &sim)?;
//! let table = rubscan::read_results(&Path::new("results/quickstart").join("results.parquet"))?;
//! # let _ = (summary, table);
//! # Ok(())
//! # }
//! ```

#![warn(missing_docs)]

pub mod analysis;
pub mod app;
pub mod contact;
pub mod dynamics;
#[doc(hidden)]
pub mod fixtures;
pub mod io;
pub mod model;
pub mod simd;
pub mod sweep;

// The curated front ("Where to start" above).
pub use dynamics::{Case, CasingModel, Numerics, SimError, Simulation, SimulationOutput, simulate};
pub use io::model_cache::{casing_rom, impeller_rom};
pub use io::rom_file::{RomFileError, load as load_rom, save as save_rom};
pub use model::build::{
    BuildError, CasingSpec, ImpellerSpec, ModelSpec, build_casing, build_impeller,
};
pub use model::rom::CyclicRom;
pub use sweep::simulator::ModelSimulator;
pub use sweep::table::read_results;
pub use sweep::{
    JobSimulator, Plan, RunOptions, SpecError, SweepSpec, load_spec, parse_spec, plan, resolve,
    run_sweep,
};
