//! One timed run of the time step with its stage breakdown, printed; also the target that
//! callgrind runs to count instructions per step (README, "Speed"). Knobs (environment):
//! `BENCH_CONTACT` (any value: rubbing; see `common::bench_default_models` and
//! `common::bench_paper_scale`), `BENCH_DENSE` (reference kernel), `BENCH_BUILTIN` (built-in
//! models at Ω = 3000 rad/s instead of the synthetic ones), `BENCH_COATING=η` (with
//! `BENCH_BUILTIN`: the nominal coating of η elements per row, see
//! `common::bench_default_models_coated`), `BENCH_STEPS` (default 30000).
//!
//! `cargo bench --bench stage_breakdown`

mod common;

use common::{bench_default_models_coated, bench_paper_scale};
use rubscan::dynamics::KernelChoice;

fn main() {
    faer::set_global_parallelism(faer::Par::Seq);
    let on = |k: &str| std::env::var_os(k).is_some();
    let steps = std::env::var("BENCH_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30000);
    let kernel = if on("BENCH_DENSE") {
        KernelChoice::DenseReference
    } else {
        KernelChoice::Fast
    };
    let contact = on("BENCH_CONTACT");
    let eta = std::env::var("BENCH_COATING")
        .ok()
        .map(|s| s.parse().expect("BENCH_COATING: elements per row"));
    let r = if on("BENCH_BUILTIN") {
        bench_default_models_coated(kernel, contact, 3000.0, steps, eta).expect("bench run")
    } else {
        bench_paper_scale(kernel, contact, steps).expect("bench run")
    };
    println!(
        "{kernel:?} contact={contact} coating η={eta:?}: {:.2} µs/step, contact fraction {:.3} of the tip nodes, \
         {:.3} of the steps, h = {:.3e} s, {:.0} steps/rev\n{:?}",
        r.us_per_step,
        r.contact_fraction,
        r.contact_step_fraction,
        r.time_step,
        r.steps_per_revolution,
        r.stage_us
    );
}
