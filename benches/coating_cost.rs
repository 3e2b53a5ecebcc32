//! Paper-scale cost of the coating stage per time step, by discretisation η of the coating
//! (DESIGN.md §5): prints µs per step without coating, with η = 600 and η = 12000.

use rubscan::app::{casing_rom, impeller_rom};
use rubscan::dynamics::abradable::CoatingMaterial;
use rubscan::dynamics::numerics::Numerics;
use rubscan::dynamics::scenario::{Case, CasingModel, CoatingCase, InitialVelocity};
use rubscan::dynamics::simulate;
use rubscan::dynamics::structure::Structure;
use rubscan::model::build::{CasingSpec, ImpellerSpec};

/// Paper-scale cost of the coating stage: the built-in impeller and casing ROMs
/// (`rubscan::app::{impeller_rom, casing_rom}`, default specs, cached), every tip node held
/// inside a 2 mm nominal coating (continuous rubbing, no direct contact), η = 600 vs 12000.
/// Run: `cargo bench --bench coating_cost`.
fn main() {
    faer::set_global_parallelism(faer::Par::Seq);
    let imp = impeller_rom(&ImpellerSpec::default()).unwrap();
    let cas = casing_rom(&CasingSpec::default()).unwrap();
    let omega = 1000.0;
    let h = (0.5 * Structure::new(&imp, omega).unwrap().stability_limit())
        .min(0.5 * Structure::new(&cas, 0.0).unwrap().stability_limit())
        .min(1e-7);
    let rows = imp.contact_nodes.iter().map(|c| c.row).max().unwrap() + 1;
    let casing = CasingModel::Flexible(cas);
    let steps = 20000;
    let mk = |eta: usize, offset: f64| Case {
        omega,
        duration: steps as f64 * h,
        friction: 0.1,
        load: None,
        clearance_offset: vec![offset; rows],
        casing_probes: vec![],
        probes: vec![],
        initial_velocity: InitialVelocity::default(),
        numerics: Numerics {
            time_step: h,
            decimation: 10,
            ..Default::default()
        },
        coating: (eta > 0).then(|| CoatingCase {
            eta,
            ..CoatingCase::new(CoatingMaterial::nominal())
        }),
    };
    // Rest clearance of the closest tip node to the casing itself.
    let mut probe = mk(0, 0.0);
    probe.duration = 10.0 * h;
    probe.numerics.decimation = 1;
    let g0 = simulate(&probe, &imp, &casing, None).unwrap().min_gap[0];
    let e = CoatingMaterial::nominal().thickness;
    // Closest tips 0.5 e_abr deep in the coating.
    let offset = g0 - 0.5 * e;
    println!("h = {h:e} s, rest clearance {g0:e} m, offset {offset:e} m, {steps} steps");
    let mut best = std::collections::BTreeMap::new();
    for _round in 0..2 {
        for eta in [0, 600, 12000] {
            let out = simulate(&mk(eta, offset), &imp, &casing, None).unwrap();
            let us = out.summary.loop_seconds / out.summary.n_steps as f64 * 1e6;
            let entry = best.entry(eta).or_insert(f64::INFINITY);
            *entry = entry.min(us);
            if let Some(co) = &out.summary.coating {
                println!(
                    "η = {eta}: {us:.2} µs/step, coating steps {}, contact steps {}, peak force {:.3e} N, max wear {:.3e} m, steps/element {:.1}",
                    co.coating_steps,
                    out.summary.contact_steps,
                    co.peak_force,
                    co.max_wear_final,
                    co.steps_per_element
                );
            } else {
                println!(
                    "no coating: {us:.2} µs/step, contact steps {}",
                    out.summary.contact_steps
                );
            }
        }
    }
    println!(
        "best of 2: no coating {:.2}, η=600 {:.2}, η=12000 {:.2} µs/step; 12000/600 = {:.3}",
        best[&0],
        best[&600],
        best[&12000],
        best[&12000] / best[&600]
    );
}
