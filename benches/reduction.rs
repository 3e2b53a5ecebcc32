//! Wall time of the cyclic Craig–Bampton reduction of the built-in models (default specs,
//! DESIGN.md §2), built from scratch (no cache), with faer's default parallelism.
//!
//! `cargo bench --bench reduction`

use std::time::Instant;

use rubscan::model::build::{CasingSpec, ImpellerSpec, build_casing, build_impeller};

fn main() {
    let t = Instant::now();
    let casing = build_casing(&CasingSpec::default()).expect("casing reduction");
    println!(
        "casing: {} sectors, {} harmonics reduced in {:.2} s",
        casing.n_sectors,
        casing.harmonics.len(),
        t.elapsed().as_secs_f64()
    );
    let t = Instant::now();
    let impeller = build_impeller(&ImpellerSpec::default()).expect("impeller reduction");
    println!(
        "impeller: {} sectors, {} harmonics reduced in {:.2} s",
        impeller.n_sectors,
        impeller.harmonics.len(),
        t.elapsed().as_secs_f64()
    );
}
