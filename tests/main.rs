//! rubscan's end-to-end tests, one module per behaviour (`cargo test --test integration
//! <module>::` runs one, e.g. `rotor37::`). One test binary rather than one per file: each
//! binary links the whole library and instantiates its own copy of the generic code it calls
//! (faer, serde, arrow), so 27 of them cost CI minutes of compiling and linking;
//! `.ci/rust-tests` still runs the modules as separate processes, two at a time.
//! `readers_never_panic.rs` is a binary of its own: its global allocator refuses large
//! allocations, which the Rotor 37 full solve makes.

mod common;

mod architecture;
mod calculix_export;
mod calculix_import;
mod cli;
mod cli_arguments;
mod coating;
mod free_edge;
mod massless;
mod numerics;
mod onset;
mod output_safety;
mod paper_conclusions;
mod probes;
mod quickstart_reference;
mod recording;
mod refinement;
mod report;
mod rotation;
mod rotor37;
mod slurm;
mod stability_builtin;
mod stability_cli;
mod supercritical;
mod sweep_plots;
mod sweep_runner;
mod sweep_spec;
