//! Cost of the coating stage per time step (DESIGN.md §5, issue #25 "Coating cost"): the
//! built-in impeller and casing at Ω = 3000 rad/s under the held two-lobe casing load of
//! `common::bench_default_models` (the quickstart's rub), without coating and with the nominal
//! 2 mm coating at η = 1500 and η = 6000 elements per row, the tips at the same clearance from
//! its unworn surface as a sweep job places them (the coating then takes the rub that the bare
//! casing's Lagrange contact takes without it). The three runs alternate in one process,
//! `BENCH_ROUNDS` times (default 3), and the best time of each is kept: coated / uncoated is
//! measured on the same machine state. Also prints each coated run's wear (sum and maximum, m) and peak force at full
//! precision, to compare the results of two builds. `BENCH_STEPS` (default 20000).
//!
//! `cargo bench --bench coating_cost`

mod common;

use common::default_models_case;
use rubscan::dynamics::KernelChoice;
use rubscan::dynamics::scenario::CasingModel;
use rubscan::dynamics::simulate;
use rubscan::model::build::{CasingSpec, ImpellerSpec};
use std::collections::BTreeMap;

fn main() {
    faer::set_global_parallelism(faer::Par::Seq);
    let env = |k: &str, d: usize| {
        std::env::var(k)
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let (steps, rounds) = (env("BENCH_STEPS", 20000), env("BENCH_ROUNDS", 3));
    let imp = rubscan::app::impeller_rom(&ImpellerSpec::default()).expect("impeller");
    let cas = rubscan::app::casing_rom(&CasingSpec::default()).expect("casing");
    let omega = 3000.0;
    let casing = CasingModel::Flexible(cas.clone());
    let mut best: BTreeMap<usize, f64> = BTreeMap::new();
    for round in 0..rounds {
        for eta in [0, 1500, 6000] {
            let eta_opt = (eta > 0).then_some(eta);
            let case =
                default_models_case(&imp, &cas, KernelChoice::Fast, true, omega, steps, eta_opt)
                    .expect("case");
            let out = simulate(&case, &imp, &casing, None).expect("run");
            let s = &out.summary;
            let us = s.loop_seconds / s.n_steps as f64 * 1e6;
            let b = best.entry(eta).or_insert(f64::INFINITY);
            *b = b.min(us);
            let contact = s.contact_steps as f64 / s.n_steps as f64;
            match &s.coating {
                Some(co) => {
                    let sum: f64 = co.final_wear.iter().flatten().sum();
                    println!(
                        "round {round} η = {eta}: {us:.2} µs/step, contact steps {contact:.3}, \
                         coating steps {}, wear sum {sum:e} m, max wear {:e} m, peak force {:e} N, \
                         max blade radial {:e} m",
                        co.coating_steps,
                        co.max_wear_final,
                        co.peak_force,
                        s.peaks.blade_radial()
                    );
                }
                None => println!(
                    "round {round} no coating: {us:.2} µs/step, contact steps {contact:.3}, \
                     max blade radial {:e} m",
                    s.peaks.blade_radial()
                ),
            }
        }
    }
    let base = best[&0];
    println!(
        "best of {rounds}, {steps} steps: no coating {base:.2} µs/step; η = 1500 {:.2} ({:.3}×); \
         η = 6000 {:.2} ({:.3}×)",
        best[&1500],
        best[&1500] / base,
        best[&6000],
        best[&6000] / base
    );
}
