//! The paper's formulation against the massless boundary, side by side in one run (#24):
//! core-seconds per simulated millisecond on the built-in paper-scale models rubbing under a
//! held two-lobe casing load (as `stage_breakdown`'s `BENCH_BUILTIN` case) at Ω = 3000 rad/s,
//! the paper's step 1e-7 s against the massless boundary at its default step, with every
//! retained mode and with a 50 kHz mode cutoff; the same with the nominal abradable coating
//! (tips at the built-in clearance from its unworn surface, the load then cuts it near the two
//! lobes): the paper's explicit coating force against the coating solved with the static
//! boundary;
//! then, when `results/rotor37/blade_benchmark.rom` exists (README), the Rotor 37 benchmark's
//! 50 revolutions in both formulations. Single thread; the two sides alternate, best of two.
//!
//! `cargo bench --bench massless`

mod common;

use common::{BENCH_LOBE_DEPTH, bench_run, coated_case, radial_clearance};
use rubscan::dynamics::abradable::CoatingMaterial;
use rubscan::dynamics::numerics::{Boundary, Numerics};
use rubscan::dynamics::scenario::CoatingCase;
use rubscan::dynamics::scenario::LobeLoad;
use rubscan::dynamics::simulate::default_time_step;
use rubscan::dynamics::structure::Structure;
use rubscan::model::build::{CasingSpec, ImpellerSpec};
use std::path::Path;

const OMEGA: f64 = 3000.0;
/// Simulated time of each built-in run (s).
const SIMULATED: f64 = 2e-3;

fn main() -> anyhow::Result<()> {
    faer::set_global_parallelism(faer::Par::Seq);
    let imp = rubscan::app::impeller_rom(&ImpellerSpec::default())?;
    let cas = rubscan::app::casing_rom(&CasingSpec::default())?;
    // (label, boundary, explicit step, mode cutoff Hz); each uncoated, then coated.
    let formulations = [
        ("mass", Boundary::Mass, Some(1e-7), None),
        ("massless", Boundary::Massless, None, None),
        (
            "massless, 50 kHz cutoff",
            Boundary::Massless,
            None,
            Some(5e4),
        ),
    ];
    let sides: Vec<_> = [false, true]
        .into_iter()
        .flat_map(|coated| formulations.map(|f| (coated, f)))
        .collect();
    let step = |b: Boundary, h: Option<f64>, cut: Option<f64>| -> anyhow::Result<f64> {
        let st = |rom, omega| -> anyhow::Result<Structure> {
            Ok(Structure::new(rom, omega)?
                .with_boundary(b)
                .with_mode_cutoff(cut))
        };
        Ok(h.unwrap_or(default_time_step(
            &st(&imp, OMEGA)?,
            Some(&st(&cas, 0.0)?),
            OMEGA,
        )))
    };
    let rows = imp.contact_nodes.iter().map(|c| c.row).max().unwrap_or(0) + 1;
    let depth = BENCH_LOBE_DEPTH * radial_clearance(&imp, &cas, rows / 2).max(0.0);
    let mut best = vec![f64::INFINITY; sides.len()];
    for _ in 0..2 {
        for (i, &(coated, (label, boundary, h, cut))) in sides.iter().enumerate() {
            let h = step(boundary, h, cut)?;
            let steps = (SIMULATED / h).round() as usize;
            let load = LobeLoad {
                lobes: 2,
                static_displacement: depth,
                ramp_time: 0.25 * SIMULATED,
                hold_time: f64::INFINITY,
            };
            let numerics = Numerics {
                time_step: Some(h),
                boundary,
                mode_cutoff_hz: cut,
                ..Default::default()
            };
            let coating = coated.then(|| CoatingCase::new(CoatingMaterial::nominal()));
            // A coated case keeps the built-in clearance to the unworn coating surface.
            let e = coating.as_ref().map_or(0.0, |c| c.material.thickness);
            let case = coated_case(OMEGA, numerics, vec![-e; rows], Some(load), coating, steps);
            let r = bench_run(&imp, &cas, &case)?;
            let per_ms = r.us_per_step * 1e-6 * steps as f64 / (SIMULATED * 1e3);
            best[i] = best[i].min(per_ms);
            let which = if coated { "coated" } else { "uncoated" };
            println!(
                "built-in {which}, {label}: h = {h:.3e} s, {:.0} steps/rev, {:.2} µs/step, \
                 {per_ms:.3} core-s per simulated ms, contact on {:.3} and coating on {:.3} of \
                 the steps",
                r.steps_per_revolution,
                r.us_per_step,
                r.contact_step_fraction,
                r.coating_step_fraction
            );
        }
    }
    let n = formulations.len();
    for (i, &(coated, (label, ..))) in sides.iter().enumerate() {
        let mass = best[i - i % n];
        if i % n != 0 {
            println!(
                "built-in {}: {label} / mass core-seconds per simulated ms = {:.3} ({:.1}× fewer)",
                if coated { "coated" } else { "uncoated" },
                best[i] / mass,
                mass / best[i]
            );
        }
    }
    rotor37()
}

/// The Rotor 37 benchmark in both formulations, if its ROM has been imported (README).
fn rotor37() -> anyhow::Result<()> {
    let rom = Path::new("results/rotor37/blade_benchmark.rom");
    if !rom.exists() {
        println!(
            "Rotor 37: {} not found (see README), skipped",
            rom.display()
        );
        return Ok(());
    }
    let text = std::fs::read_to_string("sweeps/rotor37_benchmark.json")?;
    let dir = std::env::temp_dir().join(format!("rubscan-massless-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    for massless in [false, true, false, true] {
        let mut spec: serde_json::Value = serde_json::from_str(&text)?;
        spec["models"]["impeller"]["rom"] = serde_json::json!(std::fs::canonicalize(rom)?);
        if massless {
            // The default step: 1000 per revolution binds (5.2e-6 s per the modes).
            spec["numerics"] = serde_json::json!({"decimation": 1, "boundary": "massless"});
        }
        let path = dir.join("spec.json");
        std::fs::write(&path, serde_json::to_string(&spec)?)?;
        let spec = rubscan::sweep::load_spec(&path)?;
        let out = rubscan::app::simulate(&spec, 0, Some(&dir.join("out")), &Default::default())?;
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json"))?)?;
        println!(
            "Rotor 37 benchmark, 50 revolutions, {}: {:.0} steps/rev, loop {:.2} s single thread",
            if massless { "massless" } else { "mass" },
            summary["steps_per_revolution"].as_f64().unwrap_or(f64::NAN),
            summary["loop_seconds"].as_f64().unwrap_or(f64::NAN)
        );
    }
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}
