//! µs per time step at paper scale (casing N = 100, M = 5, 10 modes/ND; impeller N_b = 10,
//! 5 tip nodes, 10 modes/ND), single thread, fast vs dense kernel, free flight and with
//! contact (synthetic ROMs: the trailing-edge row rubbing; built-in models: the held two-lobe
//! casing load of `bench_default_models`, about 10 % of the tip nodes rubbing), on the
//! synthetic ROMs and on the built-in models (`app::impeller_rom`/`app::casing_rom` defaults,
//! Ω = 3000 rad/s). Needs in Cargo.toml:
//! `[[bench]] name = "time_step" harness = false`.

mod common;

use common::{bench_default_models, bench_paper_scale};
use criterion::{Criterion, criterion_group, criterion_main};
use rubscan::dynamics::KernelChoice;

fn time_step(c: &mut Criterion) {
    faer::set_global_parallelism(faer::Par::Seq);
    let mut g = c.benchmark_group("time_step_paper_scale");
    g.sample_size(10);
    for (kernel, steps) in [
        (KernelChoice::Fast, 5000),
        (KernelChoice::DenseReference, 10),
    ] {
        for builtin in [false, true] {
            for contact in [false, true] {
                let name = format!(
                    "{}/{kernel:?}/{}",
                    if builtin { "builtin" } else { "synthetic" },
                    if contact { "contact" } else { "free" }
                );
                g.bench_function(&name, |b| {
                    b.iter_custom(|iters| {
                        let mut total = 0.0;
                        for _ in 0..iters {
                            let r = if builtin {
                                bench_default_models(kernel, contact, 3000.0, steps)
                                    .expect("bench run")
                            } else {
                                bench_paper_scale(kernel, contact, steps).expect("bench run")
                            };
                            total += r.us_per_step * 1e-6;
                        }
                        std::time::Duration::from_secs_f64(total)
                    })
                });
            }
        }
    }
    g.finish();
}

criterion_group!(benches, time_step);
criterion_main!(benches);
